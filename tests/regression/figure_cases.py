"""The cases of tests/regression/figures.py: the tolerance classes (``TOLERANCES``), ``Case`` and ``CASES``
(each case's stored description and the function of figure_functions.py that computes its figures).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

from figure_functions import (
    bias_compensation,
    brute_bunny,
    brute_cbox_direct,
    brute_cbox_gi,
    brute_cbox_lights_direct,
    brute_matpreview,
    brute_veach,
    clustered_shading_singletons,
    clustered_visibility,
    glossy_plates,
    gpu_cbox_lights,
    instant_radiosity_cbox_gi,
    instant_radiosity_small,
    kmeans_cbox,
    lights_cbox_area,
    lights_cbox_lights_env,
    lights_cbox_vpls,
    mrcs_budget,
    mrcs_cbox_gi,
    mrcs_error_rows,
    mrcs_halves,
    mrcs_veach,
    near_field_panel,
    near_field_staircase,
    power_sampling,
    progressive,
    relight,
    render_target,
    tensor,
    vsl_veach,
)

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
