"""Bad-input cases: the renderers."""
from __future__ import annotations

import numpy as np

from .common import IMG, REPO, cases_for

# --------------------------------------------------------------------------------------------------
# Renderers.

cases_for("mrcs", [
    ("not a matrix", lambda c: c.ml.mrcs("A"), ["LightMatrix"]),
], raises=("TypeError",))
cases_for("mrcs", [
    ("zero rows", lambda c: c.ml.mrcs(c.A, rows=0, columns=2), ["r"]),
    ("zero columns", lambda c: c.ml.mrcs(c.A, rows=4, columns=0), ["c"]),
    ("more columns than lights", lambda c: c.ml.mrcs(c.A, rows=4, columns=c.n + 1), ["c"]),
    ("row index out of range", lambda c: c.ml.mrcs(c.A, columns=2, row_indices=[c.m]), ["range"]),
    ("clustering without weights", lambda c: c.ml.mrcs(c.A, clustering={"representatives": [0]}), ["weights"]),
    ("clustering weights wrong shape", lambda c: c.ml.mrcs(
        c.A, clustering={"representatives": [0, 1], "weights": np.ones((3, 3))}), ["weights"]),
    ("clustering NaN weights", lambda c: c.ml.mrcs(
        c.A, clustering={"representatives": [0], "weights": np.full((1, 3), np.nan)}), ["nan"]),
    ("clustering representative out of range", lambda c: c.ml.mrcs(
        c.A, clustering={"representatives": [c.n], "weights": np.ones((1, 3))}), ["range"]),
])
cases_for("mrcs", [
    ("negative error_rows", lambda c: c.ml.mrcs(c.A, rows=4, columns=2, error_rows=-1), ["error_rows"]),
    ("error_rows past the pixels", lambda c: c.ml.mrcs(c.A, rows=4, columns=2, error_rows=c.m + 1), ["error_rows"]),
    ("halves with one column", lambda c: c.ml.mrcs(c.A, rows=4, columns=1, halves=True), ["columns"]),
    ("halves with one light", lambda c: c.ml.mrcs(c.ml.LightMatrix(c.scene, c.ml.LightSet.from_arrays(
        c.scene, kind=0, position=[[0, 1, 0]], intensity=[[1, 1, 1]]), device="cpu"), rows=4, columns=2, halves=True),
     ["halves=True needs >= 2 lights", "has 1"]),
    ("halves with a given clustering", lambda c: c.ml.mrcs(
        c.A, halves=True, clustering={"representatives": [0], "weights": np.ones((1, 3))}), ["halves"]),
])
cases_for("mrcs_progressive", [
    ("not a matrix", lambda c: c.ml.mrcs_progressive("A", rounds=2), ["LightMatrix"]),
], raises=("TypeError",))
cases_for("mrcs_progressive", [
    ("ints without rounds", lambda c: c.ml.mrcs_progressive(c.A, rows=4, columns=2), ["rounds"]),
    ("zero rounds", lambda c: c.ml.mrcs_progressive(c.A, rows=4, columns=2, rounds=0), ["rounds"]),
    ("NaN rounds", lambda c: c.ml.mrcs_progressive(c.A, rows=4, columns=2, rounds=float("nan")), ["rounds"]),
    ("one column per round", lambda c: c.ml.mrcs_progressive(c.A, rows=4, columns=1, rounds=2), ["2 new columns"]),
    ("decreasing columns", lambda c: c.ml.mrcs_progressive(c.A, rows=[4, 8], columns=[4, 2]), ["increasing"]),
    ("repeated columns", lambda c: c.ml.mrcs_progressive(c.A, rows=[4, 8], columns=[4, 4]), ["strictly increasing"]),
    ("decreasing rows", lambda c: c.ml.mrcs_progressive(c.A, rows=[8, 4], columns=[2, 4]), ["rows", "non-decreasing"]),
    ("empty columns", lambda c: c.ml.mrcs_progressive(c.A, rows=[], columns=[]), ["at least one"]),
    ("rounds do not match the list", lambda c: c.ml.mrcs_progressive(c.A, rows=[4, 8], columns=[2, 4], rounds=3),
     ["rounds"]),
    ("rows and columns rounds differ", lambda c: c.ml.mrcs_progressive(c.A, rows=[4, 8, 12], columns=[2, 4]),
     ["rounds"]),
    ("more columns than lights", lambda c: c.ml.mrcs_progressive(c.A, rows=4, columns=c.n, rounds=2), ["lights"]),
    ("more rows than pixels", lambda c: c.ml.mrcs_progressive(c.A, rows=c.m, columns=2, rounds=2), ["rows"]),
    ("negative seed", lambda c: c.ml.mrcs_progressive(c.A, rows=4, columns=2, rounds=2, seed=-1), ["seed"]),
])
cases_for("render", [
    ("not a matrix", lambda c: c.ml.render(None, target_error=0.1), ["LightMatrix"]),
], raises=("TypeError",))
cases_for("render", [
    ("no target and no budget", lambda c: c.ml.render(c.A), ["target_error"]),
    ("zero target", lambda c: c.ml.render(c.A, target_error=0.0), ["target_error"]),
    ("negative target", lambda c: c.ml.render(c.A, target_error=-0.02), ["target_error"]),
    ("NaN target", lambda c: c.ml.render(c.A, target_error=float("nan")), ["target_error"]),
    ("zero time budget", lambda c: c.ml.render(c.A, time_budget=0), ["time_budget"]),
    ("negative time budget", lambda c: c.ml.render(c.A, time_budget=-1.0), ["time_budget"]),
    ("inf time budget", lambda c: c.ml.render(c.A, time_budget=float("inf")), ["time_budget"]),
    ("one first column", lambda c: c.ml.render(c.A, target_error=0.1, first_columns=1), ["first_columns"]),
    ("zero max_rounds", lambda c: c.ml.render(c.A, target_error=0.1, max_rounds=0), ["max_rounds"]),
    ("negative seed", lambda c: c.ml.render(c.A, target_error=0.1, seed=-1), ["seed"]),
    ("zero rows_per_column", lambda c: c.ml.render(c.A, target_error=0.1, rows_per_column=0), ["rows_per_column"]),
    ("rows_per_column above 1", lambda c: c.ml.render(c.A, target_error=0.1, rows_per_column=2), ["rows_per_column"]),
])
DEMO_XML = REPO / "scenes" / "demo" / "scene.xml"
cases_for("render[scene path]", [
    ("zero target", lambda c: c.ml.render(DEMO_XML, target_error=0.0), ["target_error"]),
    ("NaN target", lambda c: c.ml.render(DEMO_XML, target_error=float("nan")), ["target_error"]),
    ("negative time budget", lambda c: c.ml.render(DEMO_XML, time_budget=-1.0), ["time_budget"]),
    ("no target and no budget", lambda c: c.ml.render(DEMO_XML), ["target_error"]),
    ("odd first_lights", lambda c: c.ml.render(DEMO_XML, target_error=0.1, first_lights=5), ["first_lights"]),
    ("max_lights below first_lights", lambda c: c.ml.render(DEMO_XML, target_error=0.1, max_lights=4),
     ["max_lights"]),
    ("generation_share 0", lambda c: c.ml.render(DEMO_XML, target_error=0.1, generation_share=0), ["generation_share"]),
    ("max_depth 1", lambda c: c.ml.render(DEMO_XML, target_error=0.1, max_depth=1), ["max_depth"]),
])
cases_for("render[scene path]", [
    ("missing scene file", lambda c: c.ml.render(c.tmp / "missing.xml", target_error=0.1), ["missing.xml"]),
], raises=("FileNotFoundError",))
cases_for("render[scene path]", [
    ("scene options with a matrix", lambda c: c.ml.render(c.A, target_error=0.1, first_lights=64), ["first_lights"]),
], raises=("TypeError",))
cases_for("native.mrcs_row_variance", [
    ("label out of range", lambda c: c.ml._native.mrcs_row_variance(
        np.ones((2, 3, 3), np.float32), np.array([0, 1, 5], np.int32), np.full(3, 0.5), 2), ["assignment[2]"]),
    ("negative label", lambda c: c.ml._native.mrcs_row_variance(
        np.ones((2, 3, 3), np.float32), np.array([0, -1, 0], np.int32), np.full(3, 0.5), 2), ["-1"]),
    ("probability above 1", lambda c: c.ml._native.mrcs_row_variance(
        np.ones((2, 3, 3), np.float32), np.zeros(3, np.int32), np.array([0.5, 2.0, 0.5]), 1), ["probability[1]"]),
    ("NaN probability", lambda c: c.ml._native.mrcs_row_variance(
        np.ones((2, 3, 3), np.float32), np.zeros(3, np.int32), np.array([0.5, np.nan, 0.5]), 1), ["probability[1]"]),
    ("wrong length", lambda c: c.ml._native.mrcs_row_variance(
        np.ones((2, 3, 3), np.float32), np.zeros(2, np.int32), np.full(3, 0.5), 1), ["n = 3"]),
    ("NaN row", lambda c: c.ml._native.mrcs_row_variance(
        np.full((2, 3, 3), np.nan, np.float32), np.zeros(3, np.int32), np.full(3, 0.5), 1), ["non-finite"]),
    ("bad shape", lambda c: c.ml._native.mrcs_row_variance(
        np.ones((2, 3, 2), np.float32), np.zeros(3, np.int32), np.full(3, 0.5), 1), ["shape"]),
])
cases_for("power_sampling", [
    ("zero columns", lambda c: c.ml.power_sampling(c.A, columns=0), ["columns"]),
    ("fractional columns", lambda c: c.ml.power_sampling(c.A, columns=2.5), ["columns"]),
    ("NaN columns", lambda c: c.ml.power_sampling(c.A, columns=float("nan")), ["columns"]),
    ("huge columns", lambda c: c.ml.power_sampling(c.A, columns=10**12), ["columns"]),
    ("negative seed", lambda c: c.ml.power_sampling(c.A, columns=2, seed=-1), ["seed"]),
    ("not a matrix", lambda c: c.ml.power_sampling(None, columns=2), ["LightMatrix"]),
], raises=("ValueError", "TypeError"))
cases_for("LightTree", [
    ("empty LightSet", lambda c: c.ml.LightTree(c.lights[np.zeros(len(c.lights), dtype=bool)]), ["empty"]),
    ("not a LightSet", lambda c: c.ml.LightTree(None), ["LightSet"]),
], raises=("ValueError", "TypeError"))
cases_for("LightTree.pdf", [
    ("sample out of range", lambda c: c.ml.LightTree(c.lights).pdf(c.A._m, 10**6), ["out of range"]),
    ("other LightSet", lambda c: c.ml.LightTree(c.lights[:1]).pdf(c.A._m, 0), ["another LightSet"]),
])
cases_for("light_bvh_sampling", [
    ("zero samples", lambda c: c.ml.light_bvh_sampling(c.A, samples=0), ["samples"]),
    ("fractional samples", lambda c: c.ml.light_bvh_sampling(c.A, samples=2.5), ["samples"]),
    ("negative seed", lambda c: c.ml.light_bvh_sampling(c.A, seed=-1), ["seed"]),
    ("not a matrix", lambda c: c.ml.light_bvh_sampling(None), ["LightMatrix"]),
    ("tree not a LightTree", lambda c: c.ml.light_bvh_sampling(c.A, tree=3), ["LightTree"]),
    ("tree over other lights", lambda c: c.ml.light_bvh_sampling(c.A, tree=c.ml.LightTree(c.lights[:1])),
     ["another LightSet"]),
], raises=("ValueError", "TypeError"))
cases_for("ris_sampling", [
    ("zero candidates", lambda c: c.ml.ris_sampling(c.A, candidates=0), ["candidates"]),
    ("zero samples", lambda c: c.ml.ris_sampling(c.A, samples=0), ["samples"]),
    ("negative neighbours", lambda c: c.ml.ris_sampling(c.A, neighbours=-1), ["neighbours"]),
    ("zero radius", lambda c: c.ml.ris_sampling(c.A, neighbours=2, radius=0), ["radius"]),
    ("not a matrix", lambda c: c.ml.ris_sampling(None), ["LightMatrix"]),
], raises=("ValueError", "TypeError"))
cases_for("lightcuts", [
    ("zero error", lambda c: c.ml.lightcuts(c.A, error=0), ["error"]),
    ("NaN error", lambda c: c.ml.lightcuts(c.A, error=float("nan")), ["error"]),
    ("zero max_cut", lambda c: c.ml.lightcuts(c.A, max_cut=0), ["max_cut"]),
    ("unknown criterion", lambda c: c.ml.lightcuts(c.A, criterion="sum"), ["criterion"]),
    ("not a matrix", lambda c: c.ml.lightcuts(None), ["LightMatrix"]),
    ("negative probes", lambda c: c.ml.lightcuts(c.A, error_probes=-1), ["error_probes"]),
], raises=("ValueError", "TypeError"))
cases_for("reconstruction_cuts", [
    ("zero block", lambda c: c.ml.reconstruction_cuts(c.A, block=0), ["block"]),
    ("negative error", lambda c: c.ml.reconstruction_cuts(c.A, error=-0.02), ["error"]),
    ("zero max_cut", lambda c: c.ml.reconstruction_cuts(c.A, max_cut=0), ["max_cut"]),
    ("negative probes", lambda c: c.ml.reconstruction_cuts(c.A, error_probes=-3), ["error_probes"]),
], raises=("ValueError", "TypeError"))
cases_for("native.lightcuts", [
    ("zero error", lambda c: c.native.lightcuts(c.A._m, 0.0, 10, 0), ["error"]),
    ("zero max_cut", lambda c: c.native.lightcuts(c.A._m, 0.02, 0, 0), ["max_cut"]),
    ("unknown criterion", lambda c: c.native.lightcuts(c.A._m, 0.02, 10, 0, 0, "sum"), ["criterion"]),
])
cases_for("stochastic_lightcuts", [
    ("zero cut size", lambda c: c.ml.stochastic_lightcuts(c.A, cut_size=0), ["cut_size"]),
    ("fractional cut size", lambda c: c.ml.stochastic_lightcuts(c.A, cut_size=2.5), ["cut_size"]),
    ("zero samples", lambda c: c.ml.stochastic_lightcuts(c.A, samples=0), ["samples"]),
    ("negative seed", lambda c: c.ml.stochastic_lightcuts(c.A, seed=-1), ["seed"]),
    ("not a matrix", lambda c: c.ml.stochastic_lightcuts(None), ["LightMatrix"]),
    ("tree over other lights", lambda c: c.ml.stochastic_lightcuts(c.A, tree=c.ml.LightTree(c.lights[:1])),
     ["another LightSet"]),
], raises=("ValueError", "TypeError"))
cases_for("lightslice", [
    ("zero slices", lambda c: c.ml.lightslice(c.A, slices=0), ["slices"]),
    ("zero columns", lambda c: c.ml.lightslice(c.A, columns=0), ["columns"]),
    ("global above columns", lambda c: c.ml.lightslice(c.A, columns=4, global_columns=5), ["global_columns"]),
    ("zero neighbours", lambda c: c.ml.lightslice(c.A, neighbours=0), ["neighbours"]),
    ("NaN normal weight", lambda c: c.ml.lightslice(c.A, normal_weight=np.nan), ["normal_weight"]),
    ("negative seed", lambda c: c.ml.lightslice(c.A, seed=-1), ["seed"]),
    ("not a matrix", lambda c: c.ml.lightslice(None), ["LightMatrix"]),
    ("probes not an integer", lambda c: c.ml.lightslice(c.A, error_probes=2.5), ["error_probes"]),
], raises=("ValueError", "TypeError"))
cases_for("native.stochastic_lightcuts", [
    ("zero cut size", lambda c: c.native.stochastic_lightcuts(c.A._m, 0, 1, 0), ["cut_size"]),
])
cases_for("native.lightslice", [
    ("global above columns", lambda c: c.native.lightslice(c.A._m, 4, 4, 5, 2, 0.25, 0), ["global_columns"]),
    ("NaN normal weight", lambda c: c.native.lightslice(c.A._m, 4, 4, 2, 2, float("nan"), 0), ["normal_weight"]),
])
cases_for("native.light_bvh_sampling", [
    ("zero samples", lambda c: c.native.light_bvh_sampling(c.A._m, 0, 0), ["samples"]),
])
cases_for("native.ris", [
    ("zero candidates", lambda c: c.native.ris(c.A._m, 1, 0, 0), ["candidates"]),
    ("zero radius", lambda c: c.native.ris(c.A._m, 1, 2, 0, None, 2, 0), ["radius"]),
])
for _metric in ("relmse", "smape"):
    cases_for(_metric, [
        ("zero eps", lambda c, f=_metric: getattr(c.ml, f)(IMG(2, 2, 3), IMG(2, 2, 3), eps=0.0), ["eps"]),
        ("NaN eps", lambda c, f=_metric: getattr(c.ml, f)(IMG(2, 2, 3), IMG(2, 2, 3), eps=np.nan), ["eps"]),
        ("shapes differ", lambda c, f=_metric: getattr(c.ml, f)(IMG(2, 2, 3), IMG(2, 3, 3)), ["shape"]),
        ("NaN image", lambda c, f=_metric: getattr(c.ml, f)(np.full((2, 2, 3), np.nan), IMG(2, 2, 3)),
         ["non-finite"]),
    ])
cases_for("metrics.flip", [
    ("negative radiance", lambda c: c.ml.metrics.flip(IMG(4, 4, 3) - 1, IMG(4, 4, 3)), ["negative"]),
    ("not (H, W, 3)", lambda c: c.ml.metrics.flip(IMG(4, 4), IMG(4, 4)), ["(H, W, 3)"]),
])
cases_for("instant_radiosity", [
    ("zero lights", lambda c: c.ml.instant_radiosity(c.scene, lights=0), ["lights"]),
    ("fractional lights", lambda c: c.ml.instant_radiosity(c.scene, lights=2.5), ["lights"]),
    ("area_fraction 2", lambda c: c.ml.instant_radiosity(c.scene, lights=8, area_fraction=2.0), ["area_fraction"]),
    ("NaN environment_fraction", lambda c: c.ml.instant_radiosity(c.scene, lights=8, environment_fraction=np.nan),
     ["environment_fraction"]),
    ("not a scene", lambda c: c.ml.instant_radiosity(None, lights=8), ["Scene"]),
], raises=("ValueError", "TypeError"))
cases_for("render_brute_force", [
    ("weights wrong length", lambda c: c.ml.render_brute_force(c.scene, c.lights, weights=[1.0], progress=False),
     ["length"]),
    ("unknown visibility", lambda c: c.ml.render_brute_force(c.scene, c.lights, visibility="x", progress=False),
     ["visibility"]),
    ("shadow map 1", lambda c: c.ml.render_brute_force(c.scene, c.lights, shadow_map_size=1, progress=False),
     ["shadow_map_size"]),
])
