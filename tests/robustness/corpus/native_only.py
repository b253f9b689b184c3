"""Bad-input cases: native-only functions (documented in _native.pyi)."""
from __future__ import annotations

import numpy as np

from .common import REPO, R, cases_for

# --------------------------------------------------------------------------------------------------
# Native-only functions (documented in _native.pyi).

_D = lambda *v: np.array([v], np.float32)  # noqa: E731
UP = _D(0, 0, 1)
cases_for("native.bsdf_eval", [
    ("spec not a dict", lambda c: c.native.bsdf_eval("diffuse", UP, UP, "cpu"), ["dict"]),
    ("unknown type", lambda c: c.native.bsdf_eval({"type": "velvet"}, UP, UP, "cpu"), ["velvet"]),
    ("no type", lambda c: c.native.bsdf_eval({"alpha": 0.1}, UP, UP, "cpu"), ["type"]),
    ("wi (N, 2)", lambda c: c.native.bsdf_eval({"type": "diffuse"}, np.zeros((1, 2), np.float32), UP, "cpu"),
     ["shape"]),
    ("wi/wo lengths differ", lambda c: c.native.bsdf_eval({"type": "diffuse"}, np.repeat(UP, 2, 0), UP, "cpu"),
     ["wi", "wo"]),
    ("NaN direction", lambda c: c.native.bsdf_eval({"type": "diffuse"}, _D(np.nan, 0, 1), UP, "cpu"), ["nan"]),
    ("unknown device", lambda c: c.native.bsdf_eval({"type": "diffuse"}, UP, UP, "tpu"), ["tpu"]),
    ("NaN alpha", lambda c: c.native.bsdf_eval({"type": "roughplastic", "alpha": float("nan")}, UP, UP, "cpu"),
     ["alpha"]),
    ("reflectance of 2 values", lambda c: c.native.bsdf_eval(
        {"type": "diffuse", "reflectance": [0.5, 0.5]}, UP, UP, "cpu"), ["reflectance"]),
    ("string parameter", lambda c: c.native.bsdf_eval({"type": "roughplastic", "alpha": "x"}, UP, UP, "cpu"),
     ["alpha"]),
], raises=("ValueError", "TypeError"))
cases_for("native.load_scene", [
    ("params not pairs", lambda c: c.native.load_scene(str(REPO / "scenes" / "demo" / "scene.xml"), [("res",)]),
     ["tuple of length 2"]),
    ("size zero", lambda c: c.native.load_scene(str(REPO / "scenes" / "demo" / "scene.xml"), [], (0, 8)),
     ["0x8"]),
], raises=("ValueError", "TypeError", "SceneError"))
cases_for("native.scene_lights", [("not a scene", lambda c: c.native.scene_lights(3), ["Scene"])],
          raises=("TypeError",))
cases_for("native.encode_exr", [
    ("float64 image", lambda c: c.native.encode_exr(np.zeros((2, 2, 3))), ["float32"]),
    ("2-D image", lambda c: c.native.encode_exr(np.zeros((2, 2), np.float32)), ["(H, W, 3)"]),
], raises=("TypeError", "ValueError"))
cases_for("native.encode_png", [
    ("float64 image", lambda c: c.native.encode_png(np.zeros((2, 2, 3))), ["float32"]),
    ("NaN exposure", lambda c: c.native.encode_png(np.zeros((2, 2, 3), np.float32), float("nan")),
     ["exposure"]),
], raises=("TypeError", "ValueError"))
cases_for("scenes.scene_path", [
    ("unknown scene", lambda c: __import__("manylights.scenes").scenes.scene_path("nope"), ["nope", "cbox"]),
    ("path escape", lambda c: __import__("manylights.scenes").scenes.scene_path("../scenes/cbox"), ["bundled"]),
    ("not a string", lambda c: __import__("manylights.scenes").scenes.scene_path(3), ["string"]),
], raises=("FileNotFoundError", "TypeError"))
cases_for("scenes.resolve", [
    ("neither file nor scene", lambda c: __import__("manylights.scenes").scenes.resolve("x.xml"), ["x.xml"]),
], raises=("FileNotFoundError",))
cases_for("native.stratified_rows", [
    ("zero width", lambda c: c.native.stratified_rows(0, 8, 1), ["0x8"]),
    ("r > pixels", lambda c: c.native.stratified_rows(2, 2, 5), ["r"]),
    ("huge image", lambda c: c.native.stratified_rows(2**31, 2**31, 10**12), ["r"]),
], raises=("ValueError", "OverflowError"))
cases_for("native.generate_lights", [
    ("huge area count", lambda c: c.native.generate_lights(c.scene, 10**15, 0, 0, 5, None, False, 0), ["area"]),
])
cases_for("native.cluster_reduced_columns", [
    ("float64 R", lambda c: c.native.cluster_reduced_columns(np.zeros((2, 4)), 2), ["float64", "float32"]),
], raises=("TypeError", "ValueError"))
cases_for("native.clustering_cost", [
    ("float labels", lambda c: c.native.clustering_cost(R(2, 4), [0.5] * 4), ["integer"]),
], raises=("TypeError",))
