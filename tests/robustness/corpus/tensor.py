"""Bad-input cases: animation lights, the lighting tensor, tensor clustering, animation output."""
from __future__ import annotations

import numpy as np

from .common import REPO, _anim, cases_for


# Animation lights, the lighting tensor, tensor clustering, animation output.
def _tensor(c):
    return c._get("tensor", lambda: c.ml.LightTensor(
        _anim(c), c.ml.generate_animation_lights(_anim(c), area=8, indirect=8, seed=0), device="cpu"))


cases_for("generate_animation_lights", [
    ("no frames", lambda c: c.ml.generate_animation_lights([], area=4), ["no frames"]),
    ("negative area", lambda c: c.ml.generate_animation_lights(_anim(c), area=-1), ["area"]),
    ("fractional indirect", lambda c: c.ml.generate_animation_lights(_anim(c), indirect=2.5), ["indirect"]),
    ("huge photons", lambda c: c.ml.generate_animation_lights(_anim(c), photons=2**40), ["photons"]),
    ("NaN clamp", lambda c: c.ml.generate_animation_lights(_anim(c), area=4, clamp=float("nan")), ["clamp"]),
    ("negative seed", lambda c: c.ml.generate_animation_lights(_anim(c), area=4, seed=-1), ["seed"]),
    ("frames of other scenes", lambda c: c.ml.generate_animation_lights(
        [c.scene, c.ml.load_scene(REPO / "scenes" / "cbox" / "scene.xml", res=8)], area=4, indirect=4), ["frame 1"]),
])
cases_for("native.generate_animation_lights", [
    ("not scenes", lambda c: c.native.generate_animation_lights(["a"]), ["Scene"]),
    ("negative count", lambda c: c.native.generate_animation_lights([c.scene], -3), ["area"]),
], raises=("ValueError", "TypeError", "OverflowError"))
cases_for("LightTensor", [
    ("no frames", lambda c: c.ml.LightTensor([], c.lights), ["no frames"]),
    ("light sets of different sizes", lambda c: c.ml.LightTensor([c.scene, c.scene], [c.lights, c.lights[:1]]),
     ["frame 1 has 1 lights"]),
    ("too few light sets", lambda c: c.ml.LightTensor([c.scene, c.scene], [c.lights]), ["1 light sets for 2 frames"]),
    ("not a light set", lambda c: c.ml.LightTensor([c.scene], ["lights"]), ["LightSet"]),
    ("not a scene", lambda c: c.ml.LightTensor(["scene.xml"], c.lights), ["Scene"]),
    ("unknown device", lambda c: c.ml.LightTensor([c.scene], c.lights, device="fpga"), ["fpga"]),
])
cases_for("LightTensor.frame", [
    ("out of range", lambda c: _tensor(c).frame(2), ["frame 2 out of range"]),
    ("fractional", lambda c: _tensor(c).frame(0.5), ["integer"]),
], raises=("IndexError", "ValueError"))
cases_for("LightTensor.slices", [
    ("no rows", lambda c: _tensor(c).slices([]), ["at least one"]),
    ("row out of range", lambda c: _tensor(c).slices([64]), ["row index"]),
    ("fractional rows", lambda c: _tensor(c).slices([0.5]), ["row index"]),
])
cases_for("LightTensor.mapping", [
    ("frame out of range", lambda c: _tensor(c).mapping(0, 5), ["frame 5"]),
], raises=("IndexError", "TypeError"))
cases_for("mrcs_per_frame", [
    ("not a tensor", lambda c: c.ml.mrcs_per_frame(c.A), ["LightTensor"]),
    ("zero rows", lambda c: c.ml.mrcs_per_frame(_tensor(c), rows=0, columns=2), ["rows"]),
    ("too many columns", lambda c: c.ml.mrcs_per_frame(_tensor(c), rows=4, columns=10**6), ["columns"]),
    ("negative seed", lambda c: c.ml.mrcs_per_frame(_tensor(c), rows=4, columns=2, seed=-1), ["seed"]),
], raises=("ValueError", "TypeError"))
cases_for("tensor_clustering", [
    ("not a tensor", lambda c: c.ml.tensor_clustering(c.A), ["LightTensor"]),
    ("zero columns", lambda c: c.ml.tensor_clustering(_tensor(c), rows=4, columns=0), ["columns"]),
    ("zero rows", lambda c: c.ml.tensor_clustering(_tensor(c), rows=0, columns=2), ["rows"]),
    ("chunk 0", lambda c: c.ml.tensor_clustering(_tensor(c), rows=4, columns=2, chunk=0), ["chunk"]),
    ("unknown representative", lambda c: c.ml.tensor_clustering(_tensor(c), rows=4, columns=2, representative="x"),
     ["representative"]),
    ("negative time_weight", lambda c: c.ml.tensor_clustering(_tensor(c), rows=4, columns=2, time_weight=-1),
     ["time_weight"]),
    ("row index out of range", lambda c: c.ml.tensor_clustering(_tensor(c), columns=2, row_indices=[64]),
     ["row index"]),
], raises=("ValueError", "TypeError"))
cases_for("tensor_clustering", [
    ("client with frames not from an Animation", lambda c: c.ml.tensor_clustering(
        c.ml.LightTensor([c.scene], [c.lights], device="cpu"), rows=4, columns=2, client="tcp://127.0.0.1:9"),
     ["Animation", "load_animation"]),
    ("client with an unknown representative", lambda c: c.ml.tensor_clustering(
        _tensor(c), rows=4, columns=2, representative="x", client="tcp://127.0.0.1:9"), ["representative"]),
])
cases_for("tensor_clustering", [
    ("unreachable scheduler", lambda c: c.ml.tensor_clustering(_tensor(c), rows=4, columns=2,
                                                                client="tcp://127.0.0.1:9", connect_timeout=1),
     ["scheduler", "127.0.0.1:9"]),
], raises=("OSError",))
cases_for("cluster_tensor", [
    ("negative first_chunk", lambda c: c.ml.cluster_tensor(np.ones((2, 3, 2, 3), np.float32), 4, first_chunk=-1),
     ["first_chunk"]),
])
cases_for("native.tensor_accumulate", [
    ("acc not 4-D", lambda c: c.native.tensor_accumulate(np.zeros((2, 3), np.float32), np.zeros((1, 1, 1, 3), np.float32),
                                                          np.zeros(1, np.uint32), np.zeros((1, 2, 3), np.float32),
                                                          np.zeros((1, 1), np.uint32), np.zeros((1, 1), np.uint32)),
     ["(f, H, W, 3)"]),
    ("source frame out of range", lambda c: c.native.tensor_accumulate(
        np.zeros((2, 1, 1, 3), np.float32), np.zeros((1, 1, 1, 3), np.float32), np.full(1, 7, np.uint32),
        np.zeros((1, 2, 3), np.float32), np.zeros((1, 1), np.uint32), np.zeros((1, 1), np.uint32)), ["frame 7"]),
    ("mapping entry out of range", lambda c: c.native.tensor_accumulate(
        np.zeros((2, 1, 1, 3), np.float32), np.zeros((1, 1, 1, 3), np.float32), np.zeros(1, np.uint32),
        np.zeros((1, 2, 3), np.float32), np.full((1, 1), 5, np.uint32), np.zeros((1, 1), np.uint32)), ["maps to 5"]),
    ("float64 columns", lambda c: c.native.tensor_accumulate(
        np.zeros((2, 1, 1, 3), np.float32), np.zeros((1, 1, 1, 3)), np.zeros(1, np.uint32),
        np.zeros((1, 2, 3), np.float32), np.zeros((1, 1), np.uint32), np.zeros((1, 1), np.uint32)), ["float32"]),
], raises=("ValueError", "TypeError"))
cases_for("native.tensor_reconstruct_gpu", [
    ("no frames", lambda c: c.native.tensor_reconstruct_gpu([], np.zeros((0, 2), np.uint32), np.zeros((0, 0, 3), np.float32),
                                                            np.zeros((0, 1), np.uint32), np.zeros((0, 1), np.uint32)),
     ["no frames"]),
    ("representatives not (c, 2)", lambda c: c.native.tensor_reconstruct_gpu(
        [c.A._m], np.zeros((1, 3), np.uint32), np.zeros((1, 1, 3), np.float32), np.zeros((0, 1), np.uint32),
        np.zeros((0, 1), np.uint32)), ["(c, 2)"]),
    ("matrix on the CPU", lambda c: c.native.tensor_reconstruct_gpu(
        [c.ml.LightMatrix(c.scene, c.lights, device="cpu")._m], np.zeros((1, 2), np.uint32),
        np.zeros((1, 1, 3), np.float32), np.zeros((0, 1), np.uint32), np.zeros((0, 1), np.uint32)), ["not on the GPU"]),
], raises=("ValueError", "TypeError"))
