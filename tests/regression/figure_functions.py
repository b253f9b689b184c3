"""The computations behind tests/regression/figures.py's cases: the shared setups (each built once per
process) and one function per case returning {figure name: number}. Only the public API
(``import manylights as ml``, ``ml.scenes``), the Mitsuba references and tests/data are used.
"""
from __future__ import annotations

import functools
import json
import sys
from pathlib import Path

import numpy as np

import manylights as ml
import manylights.scenes

HERE = Path(__file__).resolve().parent
TESTS = HERE.parent
REFERENCES = TESTS / "references"
DATA = TESTS / "data"


def _reference(name: str) -> np.ndarray:
    return ml.read_exr(REFERENCES / f"{name}.exr")[..., :3]


def _reference_size(name: str) -> tuple:
    return tuple(json.loads((REFERENCES / f"{name}.json").read_text())["size"])


def _bundled(name: str, **params):
    return ml.load_scene(ml.scenes.scene_path(name), **params)


def _brute(A) -> np.ndarray:
    return A.column_sum(progress=False) + A.emitted()


def _rel(image, reference) -> float:
    return float(ml.relative_l2(image, reference))


def _mean_ratio(image, reference) -> float:
    return float(np.mean(image, dtype=np.float64) / np.mean(reference, dtype=np.float64))


# --------------------------------------------------------------------------------------------------
# shared setups (each built once per process)
# --------------------------------------------------------------------------------------------------
@functools.lru_cache(maxsize=None)
def cbox_lights_32():
    """cbox-lights 32x32, 512 area + 512 environment + ~1024 VPLs (seed 3) and its 3 delta emitters: the
    small matrix of tests/renderers/test_mrcs.py and tests/renderers/test_error_estimate.py; truth = column sum + emitted."""
    scene = _bundled("cbox-lights", res=32)
    lights = ml.generate_lights(scene, area=512, environment=512, indirect=1024, seed=3)
    A = ml.LightMatrix(scene, lights, device="cpu")
    return scene, lights, A, _brute(A)


@functools.lru_cache(maxsize=None)
def cbox_gi_64():
    """cbox 64x64 full GI (the cbox-gi-64 reference), 1024 area + ~4000 clamped VPLs (max_depth -1, seed 0),
    as tests/lights/test_lights.py::test_gi_brute_force."""
    scene = _bundled("cbox", res=64)
    assert (scene.width, scene.height) == _reference_size("cbox-gi-64")
    lights = ml.generate_lights(scene, area=1024, indirect=4000, max_depth=-1, seed=0)
    A = ml.LightMatrix(scene, lights, device="cpu")
    return scene, lights, A, _brute(A), _reference("cbox-gi-64")


@functools.lru_cache(maxsize=None)
def veach_32():
    """veach-ajar 32x18 full GI (the veach-ajar-gi-32 reference), 1000 area + ~4000 unclamped VPLs
    (max_depth -1, seed 0), as tests/lights/test_vpl_importance.py."""
    w, h = _reference_size("veach-ajar-gi-32")
    scene = _bundled("veach-ajar", size=(w, h), resx=w, resy=h)
    lights = ml.generate_lights(scene, area=1000, indirect=4000, max_depth=-1, seed=0, clamp=float("inf"))
    A = ml.LightMatrix(scene, lights, device="cpu")
    return scene, lights, A, _brute(A), _reference("veach-ajar-gi-32")


@functools.lru_cache(maxsize=None)
def cbox_48():
    """cbox 48x48, 256 area + ~2048 VPLs (seed 1): tests/renderers/test_clustered_visibility.py's matrix."""
    scene = _bundled("cbox", res=48)
    lights = ml.generate_lights(scene, area=256, indirect=2048, seed=1)
    A = ml.LightMatrix(scene, lights, device="cpu")
    return scene, lights, A, _brute(A)


# --------------------------------------------------------------------------------------------------
# the figures of each case
# --------------------------------------------------------------------------------------------------
def _power_sums(lights, mask) -> dict:
    p = np.asarray(lights.power, np.float64)[mask].sum(axis=0)
    return {"power_r": float(p[0]), "power_g": float(p[1]), "power_b": float(p[2])}


def lights_cbox_area():
    scene = _bundled("cbox", res=64)
    L = ml.generate_lights(scene, area=4096)
    kind = np.asarray(L.kind)
    return {"area_lights": int((kind == 3).sum()), **_power_sums(L, kind == 3)}


def lights_cbox_lights_env():
    scene = _bundled("cbox-lights", res=32)
    L = ml.generate_lights(scene, area=512, environment=512)
    kind = np.asarray(L.kind)
    out = {"delta_lights": int(np.isin(kind, (0, 1, 2)).sum() - 512), "environment_lights": 512}
    env = np.zeros(len(kind), bool)
    env[-512:] = True  # environment lights come last (generate_lights' order: scene, area, environment)
    assert (kind[env] == 2).all()
    out.update({f"environment_{k}": v for k, v in _power_sums(L, env).items()})
    out.update({f"area_{k}": v for k, v in _power_sums(L, kind == 3).items()})
    return out


def lights_cbox_vpls():
    _, L, _, _, _ = cbox_gi_64()
    kind = np.asarray(L.kind)
    return {"vpls": int((kind == 4).sum()), **{f"vpl_{k}": v for k, v in _power_sums(L, kind == 4).items()}}


def brute_cbox_direct():
    w, h = _reference_size("cbox-direct")
    scene = _bundled("cbox", res=w)
    L = ml.generate_lights(scene, area=1024)
    img = _brute(ml.LightMatrix(scene, L, device="cpu", max_depth=2))
    ref = _reference("cbox-direct")
    return {"rel_l2_vs_mitsuba": _rel(img, ref), "mean_ratio_vs_mitsuba": _mean_ratio(img, ref)}


def brute_cbox_lights_direct():
    w, h = _reference_size("cbox-lights-direct")
    scene = _bundled("cbox-lights", res=w)
    L = ml.generate_lights(scene, area=1024, environment=1024)
    img = _brute(ml.LightMatrix(scene, L, device="cpu", max_depth=2))
    ref = _reference("cbox-lights-direct")
    return {"rel_l2_vs_mitsuba": _rel(img, ref), "mean_ratio_vs_mitsuba": _mean_ratio(img, ref)}


def brute_cbox_gi():
    _, _, _, img, ref = cbox_gi_64()
    return {"rel_l2_vs_mitsuba": _rel(img, ref), "mean_ratio_vs_mitsuba": _mean_ratio(img, ref)}


def brute_veach():
    scene, L, _, img, ref = veach_32()
    Li = ml.generate_lights(scene, area=1000, indirect=4000, max_depth=-1, seed=0, clamp=float("inf"),
                            vpl_importance=True)
    imp = _brute(ml.LightMatrix(scene, Li, device="cpu"))
    return {"lights_plain": len(L), "rel_l2_vs_mitsuba_plain": _rel(img, ref),
            "lights_importance": len(Li), "rel_l2_vs_mitsuba_importance": _rel(imp, ref)}


def mrcs_budget(rows, columns, seed=0):
    def compute():
        _, _, A, truth = cbox_lights_32()
        return {"rel_l2": _rel(ml.mrcs(A, rows=rows, columns=columns, seed=seed).image, truth)}
    return compute


def mrcs_halves():
    _, _, A, truth = cbox_lights_32()
    res = ml.mrcs(A, rows=32, columns=128, seed=0, halves=True)
    return {"rel_l2": _rel(res.image, truth), "error_estimate": float(res.error_estimate),
            "rendered_columns": int(res.budget["rendered_columns"]),
            "unseen_lights": int(res.budget["unseen_lights"])}


def mrcs_error_rows():
    _, _, A, truth = cbox_lights_32()
    res = ml.mrcs(A, rows=32, columns=128, seed=0, error_rows=64)
    return {"rel_l2": _rel(res.image, truth), "error_estimate": float(res.error_estimate)}


def mrcs_cbox_gi():
    _, _, A, truth, ref = cbox_gi_64()
    img = ml.mrcs(A, rows=64, columns=256, seed=0).image
    return {"rel_l2": _rel(img, truth), "rel_l2_vs_mitsuba": _rel(img, ref)}


def mrcs_veach():
    _, _, A, truth, _ = veach_32()
    return {"rel_l2": _rel(ml.mrcs(A, rows=64, columns=256, seed=0).image, truth)}


def power_sampling():
    _, _, A, truth = cbox_lights_32()
    return {"rel_l2": _rel(ml.power_sampling(A, columns=128, seed=0).image, truth)}


def instant_radiosity_small():
    scene, _, _, truth = cbox_lights_32()
    res = ml.instant_radiosity(scene, lights=256, seed=0, device="cpu")
    return {"lights": int(res.budget["lights"]), "rel_l2": _rel(res.image, truth)}


def instant_radiosity_cbox_gi():
    scene, _, _, _, ref = cbox_gi_64()
    res = ml.instant_radiosity(scene, lights=2000, seed=0, max_depth=-1, device="cpu")
    return {"lights": int(res.budget["lights"]), "rel_l2_vs_mitsuba": _rel(res.image, ref)}


def progressive():
    _, _, A, truth = cbox_lights_32()
    out = {}
    for res in ml.mrcs_progressive(A, rows=8, columns=16, rounds=4, seed=0, progress=False):
        t = res.budget["round"]
        out[f"round{t}_columns"] = int(res.budget["columns"])
        out[f"round{t}_rel_l2"] = _rel(res.image, truth)
        out[f"round{t}_error_estimate"] = float(res.error_estimate)
    return out


def render_target():
    _, _, A, truth = cbox_lights_32()
    res = ml.render(A, target_error=0.05, seed=0, rows_per_column=0.25, progress=False)
    ch = res.budget["chosen"]
    return {"rounds": int(ch["rounds"]), "rows": int(res.budget["rows"]), "columns": int(res.budget["columns"]),
            "rel_l2": _rel(res.image, truth), "error_estimate": float(res.error_estimate)}


def clustered_visibility():
    _, _, A, truth = cbox_48()
    out = {}
    for f in (1, 6):
        res = ml.clustered_visibility(A, light_clusters=200, view_clusters=50, fuzzy=f, seed=0)
        out[f"F{f}_rel_l2"] = _rel(res.image, truth)
        out[f"F{f}_light_clusters"] = int(res.budget["light_clusters"])
        out[f"F{f}_rays"] = int(res.budget["rays"])
    return out


def clustered_shading_singletons():
    scene = _bundled("cbox-lights", res=24)
    L = ml.generate_lights(scene, area=64, environment=32, indirect=256, seed=4)
    A = ml.LightMatrix(scene, L, device="cpu")
    vs = A.view_samples()
    m = len(vs["position"])
    res = ml.clustered_shading(A, np.arange(len(L)), np.nan_to_num(np.asarray(L.position, np.float32)),
                               vs["position"], vs["normal"], np.arange(m), np.ones(m, np.float32))
    return {"rays": int(res.budget["rays"]), "rel_l2": _rel(res.image, _brute(A))}


def kmeans_cbox():
    scene, L, A, _ = cbox_48()
    vs = A.view_samples()
    surf = np.asarray(vs["surface"])
    view = ml.kmeans(vs["position"][surf], vs["normal"][surf], 50, iterations=8, seed=0, device="cpu")
    light = ml.kmeans(np.asarray(L.position), None, 200, iterations=8, seed=0, device="cpu")
    return {"view_objective_initial": float(view.objective[0]), "view_objective_final": float(view.objective[-1]),
            "light_objective_initial": float(light.objective[0]),
            "light_objective_final": float(light.objective[-1])}


@functools.lru_cache(maxsize=None)
def bounce_tensor():
    """bounce, frames 0-7 of its 40-frame path at 32x32 (camera moving), 512 area + 512 environment + 500
    gather lights, 10,000 photons (seed 0): a smaller version of tests/animation/test_tensor_animation.py's tensor."""
    frames = ml.scenes.animation_frames("bounce", count=40)[:8]
    anim = ml.load_animation(ml.scenes.scene_path("bounce"), frames=frames, res=32, device="cpu")
    L = ml.generate_animation_lights(anim, area=512, environment=512, indirect=500, photons=10000, seed=0)
    T = ml.LightTensor(anim, L, device="cpu")
    return T, T.brute_force()


def tensor():
    T, B = bounce_tensor()
    m, n, f = T.shape
    out = {"lights": n}
    runs = [("tensor_r100_c200", ml.tensor_clustering(T, rows=100, columns=200, seed=0)),
            ("mrcs_per_frame_r100_c200", ml.mrcs_per_frame(T, rows=100, columns=200, seed=0)),
            ("mrcs_per_frame_r100_c500", ml.mrcs_per_frame(T, rows=100, columns=500, seed=0))]
    for name, res in runs:
        out[f"{name}_mean_rel_l2"] = float(ml.relative_l2_per_frame(res.frames, B).mean())
        out[f"{name}_flicker"] = float(ml.flicker(res.frames, B))
    out["tensor_r100_c200_shadow_maps"] = int(np.sum(runs[0][1].shadow_maps_per_frame))
    return out


def relight():
    box = ml.load_scene(DATA / "relight_box.xml")
    lights = ml.scene_lights(box)
    exact = ml.DirectToIndirect(box, gather=4**4, final_gather_coefficients=4**4, threshold=0.0,
                                near_field="point", device="cpu")
    img_exact = exact.relight(lights)
    # The dense product: every gather sample a VPL (flux E A, albedo k_d) through the light matrix.
    flux = exact.gather_irradiance(lights) * exact.gather_areas[:, None]
    vpl = ml.LightSet.from_arrays(box, kind=4, position=exact.gather_positions, normal=exact.gather_normals,
                                  geo_normal=exact.gather_geo_normals, incident=exact.gather_geo_normals,
                                  intensity=flux, albedo=exact.gather_k_d)
    dense = (ml.LightMatrix(box, vpl, device="cpu").column_sum(progress=False)
             + ml.LightMatrix(box, lights, device="cpu").column_sum(progress=False))
    out = {"exact_vs_dense_rel_l2": _rel(img_exact, dense)}
    for k in (10, 30):
        rel = ml.DirectToIndirect(box, gather=4**4, final_gather_coefficients=k, device="cpu")
        out[f"coefficients{k}_rel_l2"] = _rel(rel.relight(lights), img_exact)
        out[f"coefficients{k}_kept"] = int(rel.stats["coefficients_kept"])
    return out


def _test_scenes() -> Path:
    """The test-only scenes (matpreview, bunny: tests/data/scenes), as tests/conftest.py names them."""
    if str(TESTS) not in sys.path:
        sys.path.insert(0, str(TESTS))
    from conftest import TEST_SCENES

    return TEST_SCENES


def brute_matpreview():
    w, h = _reference_size("matpreview-full-direct")
    scene = ml.load_scene(_test_scenes() / "matpreview" / "scene.xml", size=(w, h), width=w, height=h)
    L = ml.generate_lights(scene, area=0, environment=1024)
    img = _brute(ml.LightMatrix(scene, L, device="cpu", max_depth=2))
    ref = _reference("matpreview-full-direct")
    return {"rel_l2_vs_mitsuba": _rel(img, ref), "mean_ratio_vs_mitsuba": _mean_ratio(img, ref)}


def brute_bunny():
    scene = ml.load_scene(_test_scenes() / "bunny" / "scene.xml", size=_reference_size("bunny-direct"))
    L = ml.generate_lights(scene, area=0, environment=512)
    img = _brute(ml.LightMatrix(scene, L, device="cpu", max_depth=2))
    ref = _reference("bunny-direct")
    return {"rel_l2_vs_mitsuba": _rel(img, ref), "mean_ratio_vs_mitsuba": _mean_ratio(img, ref)}


def _masked_rel(img, ref, mask) -> float:
    return float(np.sqrt(((img - ref)[mask] ** 2).sum() / (ref[mask] ** 2).sum()))


def glossy_plates():
    scene = ml.load_scene(DATA / "veach_plates.xml", size=_reference_size("veach-plates-direct"))
    ref = _reference("veach-plates-direct")
    L = ml.generate_lights(scene, area=1024)
    bare = ml.LightMatrix(scene, L, device="cpu", max_depth=2, glossy_roughness=0.0)
    plates = bare.emitted().sum(-1) == 0  # pixels that see no emitter (as tests/lights/test_glossy.py)
    mis = _brute(ml.LightMatrix(scene, L, device="cpu", max_depth=2, bsdf_samples=1024))
    return {"plates_rel_l2_vs_mitsuba_mis": _masked_rel(mis, ref, plates),
            "plates_rel_l2_vs_mitsuba_light_samples_only": _masked_rel(_brute(bare), ref, plates)}


def _without_patches(scene, lights):
    return ml.LightSet.from_arrays(scene, kind=lights.kind, position=lights.position, normal=lights.normal,
                                   intensity=lights.intensity)


def _near_field(xml, reference, area, **params):
    scene = ml.load_scene(DATA / xml, **params)
    ref = _reference(reference)
    L = ml.generate_lights(scene, area=area, seed=0)
    out = {}
    for name, ls in (("patch", L), ("point", _without_patches(scene, L))):
        A = ml.LightMatrix(scene, ls, device="cpu", max_depth=2)
        em = A.emitted()
        lit = (em.sum(-1) == 0) & (ref.sum(-1) > 0)  # lit pixels that see no emitter (tests/lights/test_nearfield.py)
        out[f"{name}_rel_l2_vs_mitsuba"] = _masked_rel(A.column_sum(progress=False) + em, ref, lit)
    return out


def near_field_panel():
    return _near_field("nearfield_panel.xml", "nearfield-panel-direct", 256, res=64)


def near_field_staircase():
    return _near_field("staircase_recessed.xml", "staircase-direct", 1024, res=64)


def vsl_veach():
    scene, _, _, _, ref = veach_32()
    L = ml.generate_lights(scene, area=1000, indirect=4000, max_depth=-1, seed=0, indirect_kind="vsl")
    return {"lights": len(L), "rel_l2_vs_mitsuba": _rel(_brute(ml.LightMatrix(scene, L, device="cpu")), ref)}


def bias_compensation():
    scene, _, _, _, ref = cbox_gi_64()
    lo, hi = np.asarray(scene.bounds[0], np.float64), np.asarray(scene.bounds[1], np.float64)
    d = 0.3 * float(np.linalg.norm(hi - lo))
    L = ml.generate_lights(scene, area=1024, indirect=4000, max_depth=-1, seed=1, clamp=1.0 / d**2)
    A = ml.LightMatrix(scene, L, device="cpu")
    img = _brute(A)
    comp = A.bias_compensation(spp=2, light_samples=32, seed=4)
    return {"clamped_rel_l2_vs_mitsuba": _rel(img, ref), "clamped_mean_ratio_vs_mitsuba": _mean_ratio(img, ref),
            "compensated_rel_l2_vs_mitsuba": _rel(img + comp, ref),
            "compensated_mean_ratio_vs_mitsuba": _mean_ratio(img + comp, ref)}


def gpu_available() -> bool:
    try:
        ml.device_info("gpu")
    except ml.GpuUnavailableError:
        return False
    return True


def gpu_adapter() -> str:
    return str(ml.device_info("gpu")["name"])


def gpu_cbox_lights():
    """A fresh scene whose view samples come from the CPU G-buffer (``scene.gbuffer(device="cpu")`` before
    any matrix: a Scene keeps the G-buffer of the first device that needs it, and GPU rasterisation breaks
    ties at pixel centres on edges differently), so the figures measure the GPU's columns and rows only."""
    scene = _bundled("cbox-lights", res=24)
    scene.gbuffer(device="cpu")
    L = ml.generate_lights(scene, area=128, environment=64, indirect=256, seed=4)
    A = ml.LightMatrix(scene, L, device="cpu")
    truth = _brute(A)
    G = ml.LightMatrix(scene, L, device="gpu", visibility="ray_traced")
    # Hybrid visibility (the GPU's default) on every 8th light only: its shadow maps cost ~12 ms a light here.
    H = ml.LightMatrix(scene, L, device="gpu", visibility="hybrid")
    some = np.arange(0, len(L), 8)
    w = np.ones((len(some), 3), np.float32)
    view = A.view_samples()
    surf = np.asarray(view["surface"])
    km = ml.kmeans(view["position"][surf], view["normal"][surf], 20, iterations=8, seed=0, device="gpu")
    return {"lights": len(L),
            "ray_traced_brute_force_vs_cpu_rel_l2": _rel(_brute(G), truth),
            "hybrid_every_8th_column_vs_cpu_rel_l2": _rel(H.weighted_sum(some, w), A.weighted_sum(some, w)),
            "mrcs_r32_c96_rel_l2": _rel(ml.mrcs(G, rows=32, columns=96, seed=0).image, truth),
            "clustered_visibility_100x40_F6_rel_l2":
                _rel(ml.clustered_visibility(G, light_clusters=100, view_clusters=40, fuzzy=6, seed=0).image, truth),
            "kmeans_view_objective_final": float(km.objective[-1])}
