"""Bad-input cases: LightMatrix."""
from __future__ import annotations

import numpy as np

from .common import cases_for

# --------------------------------------------------------------------------------------------------
# LightMatrix.

cases_for("LightMatrix", [
    ("not a scene", lambda c: c.ml.LightMatrix(None, c.lights), ["Scene"]),
    ("not lights", lambda c: c.ml.LightMatrix(c.scene, [1, 2, 3]), ["LightSet"]),
], raises=("TypeError",))
cases_for("LightMatrix", [
    ("unknown visibility", lambda c: c.ml.LightMatrix(c.scene, c.lights, visibility="magic"), ["magic"]),
    ("shadow map 0", lambda c: c.ml.LightMatrix(c.scene, c.lights, shadow_map_size=0), ["shadow_map_size"]),
    ("negative shadow map", lambda c: c.ml.LightMatrix(c.scene, c.lights, shadow_map_size=-512),
     ["shadow_map_size"]),
    ("huge shadow map", lambda c: c.ml.LightMatrix(c.scene, c.lights, shadow_map_size=2**40),
     ["shadow_map_size"]),
    ("fractional shadow map", lambda c: c.ml.LightMatrix(c.scene, c.lights, shadow_map_size=100.5),
     ["shadow_map_size"]),
    ("NaN shadow map", lambda c: c.ml.LightMatrix(c.scene, c.lights, shadow_map_size=float("nan")),
     ["shadow_map_size"]),
    ("native: NaN bias", lambda c: c.native.LightMatrix(c.scene, c.lights, 16, depth_bias=float("nan")),
     ["depth_bias"]),
    ("native: negative offset", lambda c: c.native.LightMatrix(c.scene, c.lights, 16, normal_offset=-1.0),
     ["normal_offset"]),
    ("unknown device", lambda c: c.ml.LightMatrix(c.scene, c.lights, device="tpu"), ["tpu", "'cpu'"]),
    ("device not a string", lambda c: c.ml.LightMatrix(c.scene, c.lights, device=0), ["device"]),
    ("shadow maps on the CPU", lambda c: c.ml.LightMatrix(c.scene, c.lights, device="cpu", visibility="hybrid"),
     ["only the GPU backend", "ray_traced"]),
])
cases_for("LightMatrix", [
    ("bad MANYLIGHTS_DEVICE", lambda c: c.ml.LightMatrix(c.scene, c.lights), ["MANYLIGHTS_DEVICE", "quantum"]),
], subprocess=True)
cases_for("device_info", [
    ("unknown device", lambda c: c.ml.device_info("npu"), ["npu", "'gpu'"]),
])
# No GPU adapter at all (Vulkan pointed at no driver, the only backend allowed): "gpu" says what to install.
cases_for("LightMatrix", [
    ("gpu without any adapter", lambda c: c.ml.LightMatrix(c.scene, c.lights, device="gpu"),
     ["mesa-vulkan-drivers"]),
], raises=("GpuUnavailableError",), subprocess=True)

_IDX_CASES = lambda call, size: [  # noqa: E731
    ("index = size", lambda c: call(c, size(c)), ["range"]),
    ("negative index", lambda c: call(c, -1), ["-1"]),
    ("huge index", lambda c: call(c, 2**70), ["range"]),
    ("fractional index", lambda c: call(c, 1.5), ["integer"]),
    ("NaN index", lambda c: call(c, float("nan")), ["integer"]),
    ("bool index", lambda c: call(c, True), ["integer"]),
]
cases_for("LightMatrix.columns", _IDX_CASES(lambda c, i: c.A.columns([0, i]), lambda c: c.n) + [
    ("2-D indices", lambda c: c.A.columns(np.zeros((2, 2), np.int64)), ["one-dimensional", "(2, 2)"]),
    ("strings", lambda c: c.A.columns(["a"]), ["a"]),
])
cases_for("LightMatrix.element", _IDX_CASES(lambda c, i: c.A.element(i, 0), lambda c: c.m)
          + [("column out of range", lambda c: c.A.element(0, c.n), ["range"])])
cases_for("LightMatrix.bias_compensation", [
    ("zero spp", lambda c: c.A.bias_compensation(spp=0), ["spp"]),
    ("fractional spp", lambda c: c.A.bias_compensation(spp=1.5), ["spp"]),
    ("negative light_samples", lambda c: c.A.bias_compensation(light_samples=-1), ["light_samples"]),
    ("max_depth below -1", lambda c: c.A.bias_compensation(max_depth=-2), ["max_depth"]),
    ("negative seed", lambda c: c.A.bias_compensation(seed=-1), ["seed"]),
])
cases_for("LightMatrix.row_exact", _IDX_CASES(lambda c, i: c.A.row_exact(i), lambda c: c.m))
cases_for("LightMatrix.column_exact", _IDX_CASES(lambda c, i: c.A.column_exact(i), lambda c: c.n))
cases_for("LightMatrix.shadow_rays", [
    ("view sample out of range", lambda c: c.A.shadow_rays([c.m], [0]), ["range"]),
    ("light out of range", lambda c: c.A.shadow_rays([0], [c.n]), ["range"]),
    ("negative light", lambda c: c.A.shadow_rays([0], [-1]), ["range"]),
    # uint64 above int64's range: the value as given, not wrapped to a negative one.
    ("view sample 2**63 as uint64", lambda c: c.A.shadow_rays(np.array([2**63], np.uint64), [0]),
     ["9223372036854775808", "range"]),
    ("unknown order", lambda c: c.A.shadow_rays([0], [0], order="diagonal"), ["order"]),
    ("float indices", lambda c: c.A.shadow_rays([0.5], [0]), ["integer"]),
])
cases_for("LightMatrix.shadow_rays", [
    ("every_element a string", lambda c: c.A.shadow_rays([0], [0], every_element="False"), ["every_element"]),
    ("every_element None", lambda c: c.A.shadow_rays([0], [0], every_element=None), ["every_element"]),
], raises=("TypeError",))
cases_for("LightMatrix.trace_shadow_rays", [
    ("two columns", lambda c: c.A.trace_shadow_rays(np.zeros((2, 2)), np.zeros((2, 3)), np.ones(2)), ["shape"]),
    ("lengths differ", lambda c: c.A.trace_shadow_rays(np.zeros((2, 3)), np.zeros((3, 3)), np.ones(2)),
     ["one entry per ray"]),
    ("t_max 2-D", lambda c: c.A.trace_shadow_rays(np.zeros((2, 3)), np.zeros((2, 3)), np.ones((2, 1))), ["t_max"]),
    ("1-D origin", lambda c: c.A.trace_shadow_rays(np.zeros(3), np.zeros((1, 3)), np.ones(1)), ["origin", "shape"]),
    ("no rays, wrong shape", lambda c: c.A.trace_shadow_rays([], [], []), ["origin", "shape"]),
    ("NaN origin", lambda c: c.A.trace_shadow_rays(np.array([[0, 0, 0], [0, np.nan, 0]]), np.ones((2, 3)),
                                                   np.ones(2)), ["origin of ray 1"]),
    ("inf direction", lambda c: c.A.trace_shadow_rays(np.zeros((1, 3)), np.array([[np.inf, 0, 0]]), np.ones(1)),
     ["direction of ray 0"]),
    ("NaN t_max", lambda c: c.A.trace_shadow_rays(np.zeros((2, 3)), np.ones((2, 3)), np.array([1.0, np.nan])),
     ["t_max of ray 1"]),
])
cases_for("LightMatrix.rows", _IDX_CASES(lambda c, i: c.A.rows([0, i], progress=False), lambda c: c.m) + [
    ("no rows", lambda c: c.A.rows([], progress=False), ["at least one"]),
    ("bool mask", lambda c: c.A.rows(np.ones(4, bool), progress=False), ["integer"]),
    ("shadow map 8", lambda c: c.A.rows([0], progress=False, shadow_map_size=8), ["shadow_map_size"]),
    ("more rows than samples", lambda c: c.A.rows(np.zeros(c.m + 1, np.int64), progress=False), ["rows"]),
])
cases_for("LightMatrix.column_sum", [
    ("wrong length", lambda c: c.A.column_sum(np.ones(c.n + 1), progress=False), ["length"]),
    ("2-D weights", lambda c: c.A.column_sum(np.ones((c.n, 3)), progress=False), ["(n,)", "(7, 3)"]),
    ("NaN weight", lambda c: c.A.column_sum(np.r_[np.nan, np.ones(c.n - 1)], progress=False), ["nan"]),
    ("inf weight", lambda c: c.A.column_sum(np.r_[np.inf, np.ones(c.n - 1)], progress=False), ["inf"]),
    ("empty weights", lambda c: c.A.column_sum(np.ones(0), progress=False), ["length"]),
    ("native: wrong length", lambda c: c.A._m.column_sum(np.ones(c.n + 1, np.float32)), ["length"]),
])
def _overflowing_matrix(c):
    """Light 1 of 1e30 W/sr a millionth of a unit above a visible surface: its contribution overflows."""
    def make():
        vs = c.A.view_samples()
        p, n = vs["position"][vs["surface"]][10], vs["normal"][vs["surface"]][10]
        lights = c.ml.LightSet.from_arrays(c.scene, kind=[0, 0], position=[[0, 1, 0], (p + n * 1e-6).tolist()],
                                           intensity=[[1, 1, 1], [1e30] * 3])
        return c.ml.LightMatrix(c.scene, lights, device="cpu")
    return c._get("overflow", make)


cases_for("LightMatrix.column_sum", [
    ("a contribution overflowing float32", lambda c: _overflowing_matrix(c).column_sum(progress=False),
     ["view sample", "light 1", "inf"]),
    ("weights overflowing the sum", lambda c: c.ml.LightMatrix(c.scene, c.ml.LightSet.from_arrays(
        c.scene, kind=[0, 0], position=[[0, 1, 0], [0, 1.1, 0]], intensity=[[1e30] * 3] * 2), device="cpu").column_sum(
        [1e10, 1e10], progress=False),
     ["view sample", "weighted sum", "inf"]),
], raises=("FloatingPointError",))
cases_for("LightMatrix.columns", [
    ("a column overflowing float32", lambda c: _overflowing_matrix(c).columns([1]), ["light 1", "view sample", "inf"]),
], raises=("FloatingPointError",))
cases_for("LightMatrix.column_sum", [("strings", lambda c: c.A.column_sum(["a"] * c.n, progress=False), ["'a'"])],
          raises=("TypeError",))
cases_for("LightMatrix.weighted_sum", [
    ("length mismatch", lambda c: c.A.weighted_sum([0, 1], np.ones((3, 3))), ["shape"]),
    ("2 channels", lambda c: c.A.weighted_sum([0, 1], np.ones((2, 2))), ["shape"]),
    ("3-D weights", lambda c: c.A.weighted_sum([0, 1], np.ones((2, 3, 1))), ["shape"]),
    ("NaN weight", lambda c: c.A.weighted_sum([0, 1], np.array([[1, 1, 1], [np.nan, 1, 1]])), ["nan"]),
    ("inf weight", lambda c: c.A.weighted_sum([0], np.array([np.inf])), ["inf"]),
    ("index out of range", lambda c: c.A.weighted_sum([c.n], np.ones(1)), ["range"]),
    ("negative index", lambda c: c.A.weighted_sum([-1], np.ones(1)), ["-1"]),
    ("fractional index", lambda c: c.A.weighted_sum([0.5], np.ones(1)), ["integer"]),
    ("native: 2 channels", lambda c: c.A._m.weighted_sum([0, 1], np.ones((2, 2), np.float32)), ["shape"]),
])
cases_for("LightMatrix.emitted", [("arguments", lambda c: c.A.emitted(1), ["argument"])], raises=("TypeError",))
cases_for("LightMatrix.visibility_stats", [("arguments", lambda c: c.A.visibility_stats(1), ["argument"])],
          raises=("TypeError",))
cases_for("native.LightMatrix.reset_visibility_stats", [
    ("arguments", lambda c: c.A._m.reset_visibility_stats(1), ["argument"])], raises=("TypeError",))
