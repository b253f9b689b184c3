"""Bad-input cases: animations, pixel mappings, anti-aliasing."""
from __future__ import annotations

import numpy as np

from .common import DEMO, _anim, cases_for


# Animations, pixel mappings, anti-aliasing.
def _tiny(c, name, shapes, size=8):
    return c.file(name, f"""<scene version="3.0.0"><sensor type="perspective">
        <film type="hdrfilm"><integer name="width" value="{size}"/><integer name="height" value="{size}"/></film>
        </sensor>{shapes}</scene>""".encode())


cases_for("load_animation", [
    ("empty frame list", lambda c: c.ml.load_animation(DEMO, frames=[]), ["empty"]),
    ("no frames for one file", lambda c: c.ml.load_animation(DEMO), ["frames is required"]),
    ("undeclared parameter", lambda c: c.ml.load_animation(DEMO, frames=[{}, {"wobble": 1}], res=8),
     ["frame 1", "wobble"]),
    ("different topology", lambda c: c.ml.load_animation(
        [_tiny(c, "t1.xml", '<shape type="cube" id="a"/>'), _tiny(c, "t2.xml", '<shape type="rectangle" id="a"/>')]),
     ["frame 1", "shape 0 'a'", "triangles"]),
    ("different film sizes", lambda c: c.ml.load_animation(
        [_tiny(c, "t1.xml", '<shape type="cube" id="a"/>'), _tiny(c, "t3.xml", '<shape type="cube" id="a"/>', 4)]),
     ["frame 1", "4x4"]),
    ("missing file", lambda c: c.ml.load_animation([DEMO, c.tmp / "nope.xml"], res=8), ["frame 1", "nope.xml"]),
    ("frame not a dict", lambda c: c.ml.load_animation(DEMO, frames=[{}, [1]]), ["frame 1", "dict"]),
    ("bad size", lambda c: c.ml.load_animation(DEMO, frames=[{}], size=(-1, 2)), ["size"]),
    ("paths and frames of different lengths", lambda c: c.ml.load_animation([DEMO], frames=[{}, {}]), ["1 scene files"]),
], raises=("ValueError", "TypeError", "SceneError", "FileNotFoundError"))
cases_for("Animation", [
    ("no frames", lambda c: c.ml.Animation([], [], []), ["at least one frame"]),
    ("not scenes", lambda c: c.ml.Animation(["a.xml"], ["a.xml"], [{}]), ["Scene"]),
    ("unknown device", lambda c: c.ml.Animation([c.scene], [DEMO], [{}], device="fpga"), ["fpga"]),
], raises=("ValueError", "TypeError"))
cases_for("Animation.mapping", [
    ("frame out of range", lambda c: _anim(c).mapping(0, 2), ["frame 2", "2 frames"]),
    ("negative out of range", lambda c: _anim(c).mapping(-3, 0), ["frame -3"]),
    ("fractional frame", lambda c: _anim(c).mapping(0.5, 1), ["integer"]),
], raises=("IndexError", "TypeError"))
cases_for("apply_mapping", [
    ("entry out of range", lambda c: c.ml.apply_mapping(np.zeros((8, 8, 3)), np.full((8, 8), 64)), ["64", "[0, 64)"]),
    ("float mapping", lambda c: c.ml.apply_mapping(np.zeros((8, 8, 3)), np.zeros((8, 8))), ["integer"]),
    ("image of another size", lambda c: c.ml.apply_mapping(np.zeros((4, 8, 3)), _anim(c).mapping(0, 1)), ["(K, 8, 8, 3)"]),
    ("empty chain", lambda c: c.ml.apply_mapping(np.zeros((8, 8, 3)), []), ["empty"]),
    ("unknown device", lambda c: c.ml.apply_mapping(np.zeros((8, 8, 3)), np.zeros((8, 8), int), device="fpga"), ["fpga"]),
], raises=("ValueError", "TypeError"))
cases_for("antialias", [
    ("image of another size", lambda c: c.ml.antialias(np.zeros((4, 8, 3)), c.scene), ["(8, 8, C)"]),
    ("zero factor", lambda c: c.ml.antialias(np.zeros((8, 8, 3)), c.scene, factor=0), ["factor"]),
    ("huge factor", lambda c: c.ml.antialias(np.zeros((8, 8, 3)), c.scene, factor=10**9), ["factor"]),
    ("not a scene", lambda c: c.ml.antialias(np.zeros((8, 8, 3)), "scene.xml"), ["Scene"]),
    ("unknown device", lambda c: c.ml.antialias(np.zeros((8, 8, 3)), c.scene, device="fpga"), ["fpga"]),
], raises=("ValueError", "TypeError"))
cases_for("probe_pixels", [
    ("pixel outside the film", lambda c: c.ml.probe_pixels(c.scene, [[10**6, 0]], spp=4, progress=False), ["outside"]),
    ("negative pixel", lambda c: c.ml.probe_pixels(c.scene, [[0, -1]], spp=4, progress=False), ["outside"]),
    ("wrong shape", lambda c: c.ml.probe_pixels(c.scene, [1, 2, 3], spp=4, progress=False), ["(k, 2)"]),
    ("float pixels", lambda c: c.ml.probe_pixels(c.scene, [[0.5, 1.0]], spp=4, progress=False), ["integers"]),
    ("string pixels", lambda c: c.ml.probe_pixels(c.scene, [["a", "b"]], spp=4, progress=False), ["integer"]),
    ("one spp", lambda c: c.ml.probe_pixels(c.scene, [[0, 0]], spp=1, progress=False), ["spp"]),
    ("NaN spp", lambda c: c.ml.probe_pixels(c.scene, [[0, 0]], spp=float("nan"), progress=False), ["spp"]),
    ("max_depth 0", lambda c: c.ml.probe_pixels(c.scene, [[0, 0]], spp=4, max_depth=0, progress=False),
     ["max_depth"]),
    ("max_depth -2", lambda c: c.ml.probe_pixels(c.scene, [[0, 0]], spp=4, max_depth=-2, progress=False),
     ["max_depth"]),
    ("negative seed", lambda c: c.ml.probe_pixels(c.scene, [[0, 0]], spp=4, seed=-1, progress=False), ["seed"]),
    ("not a scene", lambda c: c.ml.probe_pixels("scene.xml", [[0, 0]]), ["Scene"]),
], raises=("ValueError", "TypeError"))
cases_for("native.probe_pixels", [
    ("pixel outside the film", lambda c: c.native.probe_pixels(c.scene, np.array([[10**6, 0]]), 4, -1, 0),
     ["outside"]),
    ("wrong shape", lambda c: c.native.probe_pixels(c.scene, np.zeros((1, 3), np.int64), 4, -1, 0), ["(k, 2)"]),
    ("one spp", lambda c: c.native.probe_pixels(c.scene, np.zeros((1, 2), np.int64), 1, -1, 0), ["spp"]),
    ("max_depth 0", lambda c: c.native.probe_pixels(c.scene, np.zeros((1, 2), np.int64), 4, 0, 0), ["max_depth"]),
    ("float pixels", lambda c: c.native.probe_pixels(c.scene, np.zeros((1, 2)), 4, -1, 0), ["int64"]),
], raises=("ValueError", "TypeError"))
cases_for("native.check_animation_topology", [
    ("no frames", lambda c: c.native.check_animation_topology([]), ["at least one frame"]),
    ("not scenes", lambda c: c.native.check_animation_topology(["a"]), ["Scene"]),
], raises=("ValueError", "TypeError"))
cases_for("native.pixel_mapping", [
    ("frames of different sizes", lambda c: c.native.pixel_mapping(c.scene, c.ml.load_scene(DEMO, res=4), c.scene),
     ["differ in size"]),
    ("unknown device", lambda c: c.native.pixel_mapping(c.scene, c.scene, c.scene, "fpga"), ["fpga"]),
])
cases_for("native.compose_mappings", [
    ("no mappings", lambda c: c.native.compose_mappings([]), ["at least one"]),
    ("different sizes", lambda c: c.native.compose_mappings([np.zeros((2, 2), np.int64), np.zeros((2, 3), np.int64)]),
     ["2x3"]),
    ("negative entry", lambda c: c.native.compose_mappings([np.full((2, 2), -5, np.int64)]), ["-5"]),
])
cases_for("native.apply_mapping", [
    ("float64 images", lambda c: c.native.apply_mapping(np.zeros((1, 2, 2, 3)), [np.zeros((2, 2), np.int64)]),
     ["float32"]),
    ("int32 mapping", lambda c: c.native.apply_mapping(np.zeros((1, 2, 2, 3), np.float32), [np.zeros((2, 2), np.int32)]),
     ["int64"]),
], raises=("TypeError", "ValueError"))
cases_for("native.antialias", [
    ("float64 image", lambda c: c.native.antialias(np.zeros((8, 8, 3)), c.scene), ["float32"]),
    ("factor 17", lambda c: c.native.antialias(np.zeros((8, 8, 3), np.float32), c.scene, 17), ["factor"]),
], raises=("TypeError", "ValueError"))
cases_for("scenes.animation_frames", [
    ("unknown scene", lambda c: __import__("manylights.scenes").scenes.animation_frames("nope"), ["nope", "bounce"]),
    ("zero frames", lambda c: __import__("manylights.scenes").scenes.animation_frames("bounce", 0), ["count"]),
    ("fractional count", lambda c: __import__("manylights.scenes").scenes.animation_frames("bounce", 2.5), ["count"]),
])
