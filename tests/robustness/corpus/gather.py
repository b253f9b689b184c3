"""Bad-input cases: gather cloud, cluster hierarchy, Haar wavelets, DirectToIndirect and its files."""
from __future__ import annotations

import numpy as np

from .common import REPO, _nan_at, cases_for

# --------------------------------------------------------------------------------------------------
# Gather cloud, cluster hierarchy, Haar wavelets.

_gather = lambda c: c._get("gather", lambda: c.ml.gather_cloud(c.scene, n=16))  # noqa: E731
F = lambda *shape: np.zeros(shape, np.float32)  # noqa: E731

cases_for("gather_cloud", [
    ("n = 0", lambda c: c.ml.gather_cloud(c.scene, n=0), ["power of 4", "got 0"]),
    ("n not a power of 4", lambda c: c.ml.gather_cloud(c.scene, n=8), ["power of 4", "got 8"]),
    ("n too large", lambda c: c.ml.gather_cloud(c.scene, n=4**13), ["power of 4"]),
    ("negative n", lambda c: c.ml.gather_cloud(c.scene, n=-4), ["n"]),
    ("fractional n", lambda c: c.ml.gather_cloud(c.scene, n=4.5), ["n"]),
    ("NaN n", lambda c: c.ml.gather_cloud(c.scene, n=float("nan")), ["n"]),
    ("negative seed", lambda c: c.ml.gather_cloud(c.scene, n=16, seed=-1), ["seed"]),
    ("not a scene", lambda c: c.ml.gather_cloud("scene.xml", n=16), ["Scene"]),
], raises=("ValueError", "TypeError"))
cases_for("native.gather_cloud", [
    ("n not a power of 4", lambda c: c.native.gather_cloud(c.scene, 32), ["power of 4", "got 32"]),
    ("negative n", lambda c: c.native.gather_cloud(c.scene, -16), ["power of 4", "-16"]),
])
cases_for("GatherCloud", [
    ("no constructor (made by gather_cloud)", lambda c: c.ml.GatherCloud(), ["cannot create"]),
], raises=("TypeError",))
cases_for("GatherCloud.on", [
    ("another topology", lambda c: _gather(c).on(c.ml.load_scene(REPO / "scenes" / "cbox" / "scene.xml", res=8)),
     ["shape", "topology"]),
], raises=("ValueError",))
cases_for("GatherCloud.on", [
    ("not a scene", lambda c: _gather(c).on(None), ["scene"]),
], raises=("TypeError",))
cases_for("GatherCloud.hierarchy", [
    ("K = 0", lambda c: _gather(c).hierarchy(K=0.0), ["K", "got 0"]),
    ("NaN K", lambda c: _gather(c).hierarchy(K=float("nan")), ["K", "NaN"]),
    ("inf K", lambda c: _gather(c).hierarchy(K=float("inf")), ["K", "inf"]),
])
cases_for("native.haar2d", [
    ("not square", lambda c: c.native.haar2d(F(4, 2)), ["shape"]),
    ("side 3", lambda c: c.native.haar2d(F(3, 3)), ["2^k"]),
    ("empty", lambda c: c.native.haar2d(F(0, 0)), ["2^k"]),
    ("4-D", lambda c: c.native.haar2d(F(2, 2, 3, 1)), ["shape"]),
    ("NaN (names the pixel)", lambda c: c.native.haar2d(_nan_at(F(4, 4, 3), (1, 2, 0))), ["image[1, 2, 0]"]),
])
cases_for("native.haar2d", [
    ("float64", lambda c: c.native.haar2d(np.zeros((4, 4))), ["float"]),
], raises=("TypeError",))
cases_for("native.ihaar2d", [
    ("side 6", lambda c: c.native.ihaar2d(F(6, 6)), ["2^k"]),
    ("inf", lambda c: c.native.ihaar2d(_nan_at(F(2, 2), (1, 1), np.inf)), ["coeffs[1, 1]"]),
])
cases_for("native.haar_support_area", [
    ("side 0", lambda c: c.native.haar_support_area(0), ["power of 2", "got 0"]),
    ("side 12", lambda c: c.native.haar_support_area(12), ["power of 2", "got 12"]),
    ("huge side", lambda c: c.native.haar_support_area(2**40), ["power of 2"]),
])
cases_for("native.haar_cull_area_weighted", [
    ("negative keep", lambda c: c.native.haar_cull_area_weighted(F(4, 4), -1), ["keep"]),
    ("not square", lambda c: c.native.haar_cull_area_weighted(F(4, 8), 3), ["shape"]),
    ("NaN", lambda c: c.native.haar_cull_area_weighted(_nan_at(F(2, 2), (0, 1)), 1), ["coeffs[0, 1]"]),
])
cases_for("native.cull_wavelet_lights", [
    ("negative epsilon", lambda c: c.native.cull_wavelet_lights(F(4, 3), F(4), -1.0), ["epsilon"]),
    ("NaN epsilon", lambda c: c.native.cull_wavelet_lights(F(4, 3), F(4), float("nan")), ["epsilon"]),
    ("length mismatch", lambda c: c.native.cull_wavelet_lights(F(4, 3), F(5), 0.0), ["image norms"]),
    ("2-D norms", lambda c: c.native.cull_wavelet_lights(F(4, 3), F(4, 1), 0.0), ["image_norms"]),
    ("3-D light", lambda c: c.native.cull_wavelet_lights(F(4, 3, 1), F(4), 0.0), ["light"]),
    ("negative norm", lambda c: c.native.cull_wavelet_lights(F(4, 3), -np.ones(4, np.float32), 0.0), ["norm 0"]),
    ("inf light", lambda c: c.native.cull_wavelet_lights(_nan_at(F(4, 3), (2, 1), np.inf), F(4), 0.0), ["light 2"]),
])
_d2i = lambda c: c._get("d2i", lambda: c.ml.DirectToIndirect(c.scene, gather=16, final_gather_coefficients=4))  # noqa: E731
cases_for("DirectToIndirect", [
    ("gather not a power of 4", lambda c: c.ml.DirectToIndirect(c.scene, gather=32, final_gather_coefficients=4), ["power of 4", "32"]),
    ("gather = 0", lambda c: c.ml.DirectToIndirect(c.scene, gather=0, final_gather_coefficients=4), ["gather"]),
    ("fractional gather", lambda c: c.ml.DirectToIndirect(c.scene, gather=16.5, final_gather_coefficients=4), ["gather"]),
    ("coefficients > gather", lambda c: c.ml.DirectToIndirect(c.scene, gather=16, final_gather_coefficients=17), ["at most", "17"]),
    ("coefficients = 0", lambda c: c.ml.DirectToIndirect(c.scene, gather=16, final_gather_coefficients=0), ["final_gather_coefficients"]),
    ("negative threshold", lambda c: c.ml.DirectToIndirect(c.scene, gather=16, final_gather_coefficients=4, threshold=-1), ["threshold"]),
    ("NaN threshold", lambda c: c.ml.DirectToIndirect(c.scene, gather=16, final_gather_coefficients=4, threshold=float("nan")), ["threshold"]),
    ("clamp 0", lambda c: c.ml.DirectToIndirect(c.scene, gather=16, final_gather_coefficients=4, clamp=0), ["clamp"]),
    ("K 0", lambda c: c.ml.DirectToIndirect(c.scene, gather=16, final_gather_coefficients=4, K=0), ["K"]),
    ("unknown near_field", lambda c: c.ml.DirectToIndirect(c.scene, gather=16, final_gather_coefficients=4, near_field="sphere"), ["near_field", "sphere"]),
    ("bounces 0", lambda c: c.ml.DirectToIndirect(c.scene, gather=16, final_gather_coefficients=4, bounces=0), ["bounces"]),
    ("multibounce_coefficients > gather", lambda c: c.ml.DirectToIndirect(c.scene, gather=16, final_gather_coefficients=4, bounces=2, multibounce_coefficients=17), ["multibounce_coefficients", "17"]),
    ("negative seed", lambda c: c.ml.DirectToIndirect(c.scene, gather=16, final_gather_coefficients=4, seed=-1), ["seed"]),
    ("not a scene", lambda c: c.ml.DirectToIndirect("scene.xml", gather=16, final_gather_coefficients=4), ["Scene"]),
], raises=("ValueError", "TypeError"))
cases_for("native.DirectToIndirect", [
    ("gather not a power of 4", lambda c: c.native.DirectToIndirect(c.scene, 32, 4, 0, 0.0, float("inf"), 30.0), ["power of 4", "32"]),
    ("coefficients > gather", lambda c: c.native.DirectToIndirect(c.scene, 16, 17, 0, 0.0, float("inf"), 30.0), ["17"]),
    ("negative threshold", lambda c: c.native.DirectToIndirect(c.scene, 16, 4, 0, -1.0, float("inf"), 30.0), ["threshold"]),
    ("clamp 0", lambda c: c.native.DirectToIndirect(c.scene, 16, 4, 0, 0.0, 0.0, 30.0), ["clamp"]),
    ("K NaN", lambda c: c.native.DirectToIndirect(c.scene, 16, 4, 0, 0.0, float("inf"), float("nan")), ["K"]),
    ("bounces 0", lambda c: c.native.DirectToIndirect(c.scene, 16, 4, 0, 0.0, float("inf"), 30.0, 0), ["bounces"]),
    ("unknown near_field", lambda c: c.native.DirectToIndirect(c.scene, 16, 4, 0, 0.0, float("inf"), 30.0, 1, 40, None, near_field="sphere"), ["near_field", "sphere"]),
    ("multibounce_coefficients 0", lambda c: c.native.DirectToIndirect(c.scene, 16, 4, 0, 0.0, float("inf"), 30.0, 2, 0), ["multibounce_coefficients"]),
])
cases_for("DirectToIndirect.relight", [
    ("empty LightSet", lambda c: _d2i(c).relight(c.lights[0:0]), ["empty"]),
    ("negative epsilon", lambda c: _d2i(c).relight(c.lights, epsilon=-1.0), ["epsilon"]),
    ("NaN epsilon", lambda c: _d2i(c).relight(c.lights, epsilon=float("nan")), ["epsilon"]),
    ("not a LightSet", lambda c: _d2i(c).relight(np.zeros((3, 3))), ["LightSet"]),
], raises=("ValueError", "TypeError"))
cases_for("DirectToIndirect.gather_irradiance", [
    ("empty LightSet", lambda c: _d2i(c).gather_irradiance(c.lights[0:0]), ["empty"]),
    ("not a LightSet", lambda c: _d2i(c).gather_irradiance(None), ["LightSet"]),
], raises=("ValueError", "TypeError"))

# Saving and loading a precomputation (tests/relight/test_relight_store.py has the scene-change cases).
_d2i_file = lambda c: c._get("d2i_file", lambda: _d2i(c).save(c.tmp / "d2i.npz"))  # noqa: E731


def _d2i_rewritten(c, name, **changes):
    with np.load(_d2i_file(c), allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    arrays.update(changes)
    np.savez(c.tmp / name, **arrays)
    return c.tmp / name


cases_for("DirectToIndirect.save", [
    ("missing folder", lambda c: _d2i(c).save(c.tmp / "no-such-folder" / "x.npz"), ["no-such-folder"]),
    ("folder is a file", lambda c: _d2i(c).save(c.file("plain.txt", b"x") / "x.npz"), ["plain.txt"]),
], raises=("OSError",))
cases_for("DirectToIndirect.save", [
    ("path not a path", lambda c: _d2i(c).save(3.5), ["path"]),
], raises=("TypeError",))
cases_for("DirectToIndirect.load", [
    ("truncated", lambda c: c.ml.DirectToIndirect.load(c.file("d2i-half.npz", _d2i_file(c).read_bytes()[:2000]), c.scene), ["truncated"]),
    ("png renamed", lambda c: c.ml.DirectToIndirect.load(c.file("d2i-png.npz", c.png_bytes), c.scene), ["not a manylights relighting file"]),
    ("random bytes", lambda c: c.ml.DirectToIndirect.load(c.file("d2i-rand.npz", bytes(range(256)) * 8), c.scene), ["not a manylights relighting file"]),
    ("empty file", lambda c: c.ml.DirectToIndirect.load(c.file("d2i-empty.npz", b""), c.scene), ["d2i-empty.npz"]),
    ("wrong version", lambda c: c.ml.DirectToIndirect.load(_d2i_rewritten(c, "d2i-v9.npz", version=np.array(9, np.uint32)), c.scene), ["version 9"]),
    ("film changed", lambda c: c.ml.DirectToIndirect.load(_d2i_file(c), c.ml.load_scene(REPO / "scenes" / "demo" / "scene.xml", res=12)), ["film changed"]),
    ("gather not a power of 4", lambda c: c.ml.DirectToIndirect.load(_d2i_rewritten(c, "d2i-g.npz", **{"options.gather": np.array(32, np.uint64)}), c.scene), ["power of 4", "32"]),
], raises=("ValueError",))
cases_for("DirectToIndirect.load", [
    ("missing file", lambda c: c.ml.DirectToIndirect.load(c.tmp / "absent.npz", c.scene), ["absent.npz"]),
], raises=("OSError",))
cases_for("DirectToIndirect.load", [
    ("not a scene", lambda c: c.ml.DirectToIndirect.load(_d2i_file(c), "scene.xml"), ["Scene"]),
], raises=("TypeError",))
cases_for("native.transfer_arrays", [
    ("not a DirectToIndirect", lambda c: c.native.transfer_arrays(c.scene), ["DirectToIndirect"]),
], raises=("TypeError",))
cases_for("native.transfer_from_arrays", [
    ("no arrays", lambda c: c.native.transfer_from_arrays(c.scene, []), ["options.gather"]),
    ("wrong shape", lambda c: c.native.transfer_from_arrays(c.scene, [(n, a.reshape(1, -1) if n == "size" else a) for n, a in c.native.transfer_arrays(_d2i(c))]), ["size", "[1, 2]"]),
], raises=("ValueError",))
cases_for("native.transfer_from_arrays", [
    ("int8 array", lambda c: c.native.transfer_from_arrays(c.scene, [("options.gather", np.zeros(1, np.int8))]), ["options.gather", "int8"]),
    ("not a list", lambda c: c.native.transfer_from_arrays(c.scene, 3), ["int"]),
], raises=("TypeError",))
cases_for("native.transfer_scene_hash", [
    ("not a scene", lambda c: c.native.transfer_scene_hash("scene.xml"), ["Scene"]),
], raises=("TypeError",))
