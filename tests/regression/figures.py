"""The figures the project reports that do not depend on timing, at fixed scenes, sizes, light counts,
budgets and seeds: relative L2 errors against brute force (the exact column sum) or against the stored
Mitsuba references in tests/references, the error estimates renderers report, and a few exact counts.

    python tests/regression/figures.py --write     # recompute and rewrite figures.json (make figures)
    python tests/regression/figures.py --check     # recompute and compare: a table, exit 1 on a mismatch
    python tests/regression/figures.py --print     # recompute and print, compare nothing

Only the public API (``import manylights as ml``, ``ml.scenes``) is used, so the file survives moves inside
the package; besides it, the Mitsuba references (tests/references), tests/data and the shared scenes (found
as tests/conftest.py finds them). Everything runs on the CPU backend (``device="cpu"``, exact rays) unless a case says "gpu".
Tolerances (``TOLERANCES``, per figure class) are stated and justified in test_figures.py and README.md.
"""
from __future__ import annotations

import argparse
import functools
import json
import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

import manylights as ml
import manylights.scenes

HERE = Path(__file__).resolve().parent
TESTS = HERE.parent
REFERENCES = TESTS / "references"
DATA = TESTS / "data"
FIGURES_JSON = HERE / "figures.json"
COMMAND = "python tests/regression/figures.py --write"

# Tolerance classes: a figure passes when |now - stored| <= rel * |stored| + abs.
TOLERANCES = {
    # Deterministic CPU figures (same bits run to run and at 1 or 2 threads, measured); the margin covers
    # float summation order on other CPUs / SIMD widths and the 8 significant digits stored.
    "cpu": {"rel": 1e-4, "abs": 1e-9},
    # Integer counts (lights generated, rays traced, coefficients kept, rounds): exact.
    "count": {"rel": 0.0, "abs": 0.0},
    # Figures that are 0 in exact arithmetic (a method that must equal brute force): only round-off,
    # compared in absolute terms (the bound the tests use for the same comparison).
    "roundoff": {"rel": 0.0, "abs": 1e-5},
    # The GPU backend (wgpu; the software adapter lavapipe here): see test_figures.py.
    "gpu": {"rel": 1e-3, "abs": 1e-6},
    # A GPU figure that is 0 in exact arithmetic (GPU columns equal the CPU's to 1e-5 per value:
    # tests/matrix/test_backends.py).
    "gpu_roundoff": {"rel": 0.0, "abs": 1e-5},
}


@dataclass
class Case:
    """One configuration: ``key`` (stable name), ``case`` (what is computed, stored with the figures),
    ``compute`` (returns {figure name: float}), per-figure tolerance classes (default ``tol``)."""

    key: str
    case: dict
    compute: Callable[[], dict]
    tol: str = "cpu"
    tols: dict = field(default_factory=dict)
    #: "gpu": needs a GPU adapter (skipped without one).
    requires: str = ""

    def tolerance(self, name: str) -> dict:
        return TOLERANCES[self.tols.get(name, self.tol)]


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


CBOX_LIGHTS_32 = dict(scene="cbox-lights", size="32x32", lights="512 area + 512 environment + ~1024 VPLs, seed 3",
                      truth="brute force (column sum + emitted), CPU")

CASES = [
    # light generation: counts and total powers
    Case("lights/cbox/area-4096", dict(scene="cbox", size="64x64", lights="4096 area, seed 0",
                                       figures="area light count and total power (exact: pi * area * radiance)"),
         lights_cbox_area, tols={"area_lights": "count"}),
    Case("lights/cbox-lights/area-512-env-512", dict(scene="cbox-lights", size="32x32",
                                                     lights="512 area + 512 environment, seed 0",
                                                     figures="light counts, total power of environment and area "
                                                             "lights"),
         lights_cbox_lights_env, tols={"delta_lights": "count", "environment_lights": "count"}),
    Case("lights/cbox/vpl-4000-seed0", dict(scene="cbox", size="64x64", lights="1024 area + 4000 indirect (VPL, "
                                            "default clamp), max_depth -1, seed 0",
                                            figures="VPL count and their total power"),
         lights_cbox_vpls, tols={"vpls": "count"}),
    # brute force against Mitsuba
    Case("brute_force/cbox-direct", dict(scene="cbox", size="128x128", lights="1024 area, seed 0",
                                         method="brute force, max_depth 2", reference="cbox-direct"),
         brute_cbox_direct),
    Case("brute_force/cbox-lights-direct", dict(scene="cbox-lights", size="128x128",
                                                lights="1024 area + 1024 environment, seed 0",
                                                method="brute force, max_depth 2", reference="cbox-lights-direct"),
         brute_cbox_lights_direct),
    Case("brute_force/cbox-gi-64", dict(scene="cbox", size="64x64", lights="1024 area + 4000 VPLs (default clamp), "
                                        "max_depth -1, seed 0", method="brute force", reference="cbox-gi-64"),
         brute_cbox_gi),
    Case("brute_force/veach-ajar-gi-32", dict(scene="veach-ajar", size="32x18",
                                              lights="1000 area + 4000 unclamped VPLs, max_depth -1, seed 0; plain "
                                                     "and vpl_importance=True",
                                              method="brute force", reference="veach-ajar-gi-32"),
         brute_veach, tols={"lights_plain": "count", "lights_importance": "count"}),
    Case("brute_force/matpreview-full-direct", dict(scene="tests/data/scenes/matpreview", size="64x48",
                                                    lights="1024 environment, seed 0",
                                                    method="brute force, max_depth 2 (delta chains through the "
                                                           "smooth plastic)", reference="matpreview-full-direct"),
         brute_matpreview),
    Case("brute_force/bunny-direct", dict(scene="tests/data/scenes/bunny", size="128x96", lights="512 environment, seed 0",
                                          method="brute force, max_depth 2", reference="bunny-direct"),
         brute_bunny),
    Case("brute_force/veach-plates-glossy", dict(scene="tests/data/veach_plates.xml", size="64x48",
                                                 lights="1024 area, seed 0",
                                                 method="brute force, max_depth 2: glossy MIS (bsdf_samples 1024) "
                                                        "and light samples only (glossy_roughness 0)",
                                                 reference="veach-plates-direct",
                                                 figures="relative L2 on the pixels that see no emitter"),
         glossy_plates),
    Case("brute_force/nearfield-panel", dict(scene="tests/data/nearfield_panel.xml", size="64x64",
                                             lights="256 area, seed 0; with patches and as plain points",
                                             method="brute force, max_depth 2", reference="nearfield-panel-direct",
                                             figures="relative L2 on lit pixels that see no emitter"),
         near_field_panel),
    Case("brute_force/staircase", dict(scene="tests/data/staircase_recessed.xml", size="64x64",
                                       lights="1024 area, seed 0; with patches and as plain points",
                                       method="brute force, max_depth 2", reference="staircase-direct",
                                       figures="relative L2 on lit pixels that see no emitter"),
         near_field_staircase),
    Case("brute_force/veach-ajar-gi-32-vsl", dict(scene="veach-ajar", size="32x18",
                                                  lights="1000 area + 4000 VSLs, max_depth -1, seed 0",
                                                  method="brute force", reference="veach-ajar-gi-32"),
         vsl_veach, tols={"lights": "count"}),
    Case("brute_force/cbox-gi-64-bias-compensation", dict(scene="cbox", size="64x64",
                                                          lights="1024 area + 4000 VPLs clamped at 1/(0.3 diagonal)^2, "
                                                                 "max_depth -1, seed 1",
                                                          method="brute force, + bias_compensation(spp 2, "
                                                                 "light_samples 32, seed 4)",
                                                          reference="cbox-gi-64"),
         bias_compensation),
    # MRCS and its baselines against brute force
    *[Case(f"mrcs/cbox-lights-32/r{r}-c{c}", dict(CBOX_LIGHTS_32, method="mrcs", rows=r, columns=c, seed=0),
           mrcs_budget(r, c)) for r, c in [(16, 32), (32, 128), (64, 256)]],
    Case("mrcs/cbox-lights-32/r32-c128-halves", dict(CBOX_LIGHTS_32, method="mrcs, halves=True", rows=32,
                                                     columns=128, seed=0,
                                                     figures="true error, the halves estimate, columns rendered, "
                                                             "lights no row sees"),
         mrcs_halves, tols={"rendered_columns": "count", "unseen_lights": "count"}),
    Case("mrcs/cbox-lights-32/r32-c128-error-rows-64", dict(CBOX_LIGHTS_32, method="mrcs, error_rows=64", rows=32,
                                                            columns=128, seed=0,
                                                            figures="true error, the held-out-rows estimate"),
         mrcs_error_rows),
    Case("mrcs/cbox-gi-64/r64-c256", dict(scene="cbox", size="64x64", lights="1024 area + 4000 VPLs, max_depth -1, "
                                          "seed 0", method="mrcs", rows=64, columns=256, seed=0,
                                          truth="brute force of the same lights", reference="cbox-gi-64"),
         mrcs_cbox_gi),
    Case("mrcs/veach-ajar-32/r64-c256", dict(scene="veach-ajar", size="32x18", lights="1000 area + 4000 unclamped "
                                             "VPLs, max_depth -1, seed 0", method="mrcs", rows=64, columns=256,
                                             seed=0, truth="brute force of the same lights"),
         mrcs_veach),
    Case("power_sampling/cbox-lights-32/c128", dict(CBOX_LIGHTS_32, method="power_sampling", columns=128, seed=0),
         power_sampling),
    Case("instant_radiosity/cbox-lights-32/256", dict(CBOX_LIGHTS_32, method="instant_radiosity", lights=256,
                                                      seed=0, note="its own 256 lights against the 2048-light truth"),
         instant_radiosity_small, tols={"lights": "count"}),
    Case("instant_radiosity/cbox-gi-64/2000", dict(scene="cbox", size="64x64", method="instant_radiosity",
                                                   lights="2000 (half area, half VPLs), max_depth -1", seed=0,
                                                   reference="cbox-gi-64"),
         instant_radiosity_cbox_gi, tols={"lights": "count"}),
    Case("mrcs_progressive/cbox-lights-32/r8-c16-x4", dict(CBOX_LIGHTS_32, method="mrcs_progressive", rows=8,
                                                           columns=16, rounds=4, seed=0,
                                                           figures="per round: columns so far, true error, estimate"),
         progressive, tols={f"round{t}_columns": "count" for t in range(4)}),
    Case("render/cbox-lights-32/target-5pct", dict(CBOX_LIGHTS_32, method="render", target_error=0.05,
                                                   rows_per_column=0.25, seed=0,
                                                   note="rows_per_column given: no timing decides anything"),
         render_target, tols={"rounds": "count", "rows": "count", "columns": "count"}),
    # clustered visibility, K-means
    Case("clustered_visibility/cbox-48/200x50", dict(scene="cbox", size="48x48", lights="256 area + 2048 VPLs, seed 1",
                                                     method="clustered_visibility", light_clusters=200,
                                                     view_clusters=50, fuzzy=[1, 6], seed=0,
                                                     truth="brute force of the same lights"),
         clustered_visibility, tols={"F1_light_clusters": "count", "F6_light_clusters": "count", "F1_rays": "count",
                                     "F6_rays": "count"}),
    Case("clustered_shading/cbox-lights-24/singletons", dict(scene="cbox-lights", size="24x24",
                                                             lights="64 area + 32 environment + 256 VPLs, seed 4",
                                                             method="clustered_shading, every light and view sample "
                                                                    "its own cluster",
                                                             truth="brute force (equal in exact arithmetic)"),
         clustered_shading_singletons, tols={"rays": "count", "rel_l2": "roundoff"}),
    Case("kmeans/cbox-48", dict(scene="cbox", size="48x48", method="kmeans, device cpu", iterations=8, seed=0,
                                data="surface view samples (k=50, Eq. 7 threshold) and light positions (k=200, "
                                     "no normals) of the clustered_visibility case",
                                figures="objective (sum of squared distances) before and after the iterations"),
         kmeans_cbox),
    # animation: tensor clustering
    Case("tensor_clustering/bounce-32-f8", dict(scene="bounce", size="32x32", frames="0-7 of 40 (camera moving)",
                                               lights="512 area + 512 environment + 500 gather, 10,000 photons, "
                                                      "seed 0",
                                               method="tensor_clustering rows 100 columns 200 (300 shadow maps per "
                                                      "frame); mrcs_per_frame rows 100 columns 200 and 500",
                                               seed=0, truth="LightTensor.brute_force",
                                               figures="mean per-frame relative L2, flicker"),
         tensor, tols={"lights": "count", "tensor_r100_c200_shadow_maps": "count"}),
    # relighting
    Case("relight/relight_box/gather-256", dict(scene="tests/data/relight_box.xml", size="32x32",
                                                lights="the scene's spot", method="DirectToIndirect, gather 4^4",
                                                figures="exact transfer (all coefficients, threshold 0, point near "
                                                        "field) vs the dense VPL product; 10 and 30 coefficients "
                                                        "(defaults otherwise) vs the exact transfer"),
         relight, tols={"exact_vs_dense_rel_l2": "roundoff", "coefficients10_kept": "count",
                        "coefficients30_kept": "count"}),
    # the GPU backend (wgpu; lavapipe where there is no hardware GPU)
    Case("gpu/cbox-lights-24", dict(scene="cbox-lights", size="24x24", lights="128 area + 64 environment + 256 VPLs, "
                                    "seed 4", device="gpu (view samples from the CPU G-buffer)",
                                    method="brute force (ray_traced; hybrid on every 8th column), mrcs rows 32 "
                                           "columns 96 seed 0, clustered_visibility 100 x 40 F 6 seed 0, kmeans "
                                           "of the view samples (k 20, 8 iterations, seed 0)",
                                    truth="CPU brute force of the same lights"),
         gpu_cbox_lights, tol="gpu", requires="gpu",
         tols={"lights": "count", "hybrid_every_8th_column_vs_cpu_rel_l2": "gpu_roundoff"}),
]


def skip_reason(case: Case):
    """Why ``case`` cannot run on this machine (None: it can)."""
    if case.requires == "gpu" and not gpu_available():
        return "no GPU adapter (ml.device_info('gpu') raised GpuUnavailableError)"
    return None


def compute(cases=None, log=print) -> tuple:
    """({case key: {"case": description, "figures": {name: number}}}, {case key: why skipped}) for
    ``cases`` (default all)."""
    cases = CASES if cases is None else cases
    out, skipped = {}, {}
    t_all = time.perf_counter()
    for i, c in enumerate(cases, 1):
        why = skip_reason(c)
        if why:
            skipped[c.key] = why
            log(f"[{i:2d}/{len(cases)}] {c.key}: SKIPPED ({why})")
            continue
        t = time.perf_counter()
        figs = c.compute()
        case = dict(c.case, adapter=gpu_adapter()) if c.requires == "gpu" else c.case
        out[c.key] = {"case": case, "figures": {k: _round(v) for k, v in sorted(figs.items())}}
        log(f"[{i:2d}/{len(cases)}] {c.key}: {len(figs)} figures, {time.perf_counter() - t:.1f} s")
    log(f"computed {sum(len(v['figures']) for v in out.values())} figures of {len(out)} cases in "
        f"{time.perf_counter() - t_all:.1f} s" + (f"; {len(skipped)} skipped" if skipped else ""))
    return out, skipped


def _round(v):
    """Integers stay integers; floats keep 8 significant digits."""
    if isinstance(v, (bool, np.bool_)):
        raise TypeError("figures are numbers, not bools")
    if isinstance(v, (int, np.integer)):
        return int(v)
    v = float(v)
    if not math.isfinite(v):
        raise ValueError(f"figure is not finite: {v}")
    return float(f"{v:.8g}")


def write(figures: dict, path: Path = FIGURES_JSON) -> None:
    doc = {"about": "Timing-independent figures of manylights (tests/regression/README.md). Regenerate with: "
                    + COMMAND,
           "cases": figures}
    path.write_text(json.dumps(doc, indent=1, sort_keys=True) + "\n")


def load(path: Path = FIGURES_JSON) -> dict:
    return json.loads(path.read_text())["cases"]


def other_adapter(stored: dict, now: dict) -> dict:
    """{case key: why} for the GPU cases computed here on another adapter than the stored figures' (their
    figures are those of that adapter's arithmetic and shadow-map decisions: not compared)."""
    out = {}
    for key, v in now.items():
        a, b = stored.get(key, {}).get("case", {}).get("adapter"), v["case"].get("adapter")
        if a is not None and b is not None and a != b:
            out[key] = f"stored on GPU adapter {a!r}, this machine has {b!r}: not compared"
    return out


def compare(stored: dict, now: dict, cases=None, skipped=()) -> list:
    """Rows (key, figure, stored, now, tolerance, ok) for every figure of either side, except the cases in
    ``skipped`` (not run here); a figure on one side only does not pass."""
    cases = {c.key: c for c in (CASES if cases is None else cases)}
    rows = []
    for key in sorted((set(stored) | set(now)) - set(skipped)):
        s = stored.get(key, {}).get("figures", {})
        n = now.get(key, {}).get("figures", {})
        for name in sorted(set(s) | set(n)):
            a, b = s.get(name), n.get(name)
            tol = cases[key].tolerance(name) if key in cases else {"rel": 0.0, "abs": 0.0}
            ok = a is not None and b is not None and abs(b - a) <= tol["rel"] * abs(a) + tol["abs"]
            rows.append((key, name, a, b, tol, ok))
    return rows


def moved_message(rows) -> str:
    """The figures that moved beyond their tolerance and what to do about it."""
    moved = [r for r in rows if not r[5]]
    lines = [f"{len(moved)} of {len(rows)} figures moved beyond their tolerance (|now - stored| > rel * |stored| "
             f"+ abs):"]
    for key, name, a, b, tol, _ in moved:
        lines.append(f"  {key} / {name}: stored {_fmt(a)}, now {_fmt(b)}, tolerance rel {tol['rel']:g} abs "
                     f"{tol['abs']:g}")
    lines.append(f"If the change is intended, regenerate the file in the same commit: {COMMAND} "
                 f"(or make figures) and commit tests/regression/figures.json.")
    return "\n".join(lines)


def _fmt(v) -> str:
    return "-" if v is None else (str(v) if isinstance(v, int) else f"{v:.8g}")


def format_table(rows, only_failures: bool = False) -> str:
    lines = [f"{'case / figure':70s} {'stored':>14s} {'now':>14s} {'rel diff':>9s} {'tolerance':>17s}"]
    for key, name, a, b, tol, ok in rows:
        if only_failures and ok:
            continue
        if a is None or b is None:
            diff = "missing"
        else:
            diff = f"{abs(b - a) / abs(a):.1e}" if a else f"{abs(b - a):.1e}a"
        t = f"rel {tol['rel']:.0e} abs {tol['abs']:.0e}"
        lines.append(f"{key + ' / ' + name:70s} {_fmt(a):>14s} {_fmt(b):>14s} {diff:>9s} {t:>17s}"
                     f"{'' if ok else '  MOVED'}")
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    g = p.add_mutually_exclusive_group(required=True)
    g.add_argument("--write", action="store_true", help=f"recompute and rewrite {FIGURES_JSON.name}")
    g.add_argument("--check", action="store_true", help="recompute and compare with the file (exit 1 on a mismatch)")
    g.add_argument("--print", action="store_true", help="recompute and print the figures only")
    p.add_argument("--only", metavar="SUBSTRING", help="only the cases whose key contains this (not with --write)")
    args = p.parse_args(argv)
    if args.only and args.write:
        p.error("--only cannot be combined with --write (the file holds every case)")
    cases = CASES if not args.only else [c for c in CASES if args.only in c.key]
    if not cases:
        p.error(f"no case key contains {args.only!r}")
    now, skipped = compute(cases, log=lambda s: print(s, flush=True))
    if args.write:
        if skipped and FIGURES_JSON.exists():
            # A machine without a GPU (or the shared scenes) keeps the stored figures of those cases.
            old = load()
            for key in skipped:
                if key in old:
                    now[key] = old[key]
                    print(f"kept the stored figures of {key} (skipped here)")
        write(now)
        print(f"wrote {FIGURES_JSON}")
        return 0
    if args.print:
        for key, v in now.items():
            for name, x in v["figures"].items():
                print(f"{key} / {name}: {_fmt(x)}")
        return 0
    stored = load()
    if args.only:
        stored = {k: v for k, v in stored.items() if k in now or k in skipped}
    other = other_adapter(stored, now)
    for key, why in other.items():
        print(f"{key}: {why}")
    skipped = {**skipped, **other}
    rows = compare(stored, now, cases, skipped)
    print(format_table(rows))
    if not all(r[5] for r in rows):
        print("\n" + moved_message(rows))
        return 1
    print(f"\nall {len(rows)} figures within tolerance" + (f" ({len(skipped)} cases skipped)" if skipped else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
