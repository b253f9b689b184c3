"""``python -m manylights.bench compare`` on a tiny configuration: every renderer on one
chart with its error against the cached brute force, the light x view cluster study, JSON and PNGs; and the
light models side by side (``--light-models``)."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from manylights.bench import compare as bench_compare


def test_compare_puts_every_renderer_on_one_chart(tmp_path):
    cmd = [sys.executable, "-m", "manylights.bench", "compare", "--scene", "cbox", "--lights", "600", "--res", "16",
           "--seeds", "2", "--columns", "30", "90", "--clusters", "30x20", "120x80", "--grid-light", "30", "120",
           "--grid-view", "20", "80", "--samples", "16", "64", "--cuts", "60", "--device", "cpu", "--out", str(tmp_path)]
    subprocess.run(cmd, check=True, capture_output=True, text=True)
    summary = json.loads((tmp_path / "compare-cbox.json").read_text())
    methods = {r["method"] for r in summary["records"]}
    assert methods == {"power_sampling", "instant_radiosity", "mrcs", "clustered_visibility", "light_bvh_sampling",
                       "ris_sampling", "lightcuts", "reconstruction_cuts", "stochastic_lightcuts", "lightslice"}
    assert {r["budget"]["samples"] for r in summary["records"] if r["method"] == "ris_sampling"} == {16, 64}
    assert {r["budget"]["cut_size"] for r in summary["records"] if r["method"] == "stochastic_lightcuts"} == {16, 64}
    assert {r["budget"]["slices"] for r in summary["records"] if r["method"] == "lightslice"} == {10, 30}
    for r in summary["records"]:
        assert r["seeds"] == 2 and 0 < r["rel_l2_mean"] < 0.5 and r["seconds"] > 0, r
    cv = [r for r in summary["records"] if r["method"] == "clustered_visibility"]
    assert [(r["budget"]["light_clusters"], r["budget"]["view_clusters"]) for r in cv] == [(30, 20), (120, 80)]
    # More clusters, less error (the study's grid, seed means).
    study = {(r["budget"]["light_clusters"], r["budget"]["view_clusters"]): r["rel_l2_mean"]
             for r in summary["cluster_study"]}
    assert set(study) == {(30, 20), (30, 80), (120, 20), (120, 80)}
    assert study[(120, 80)] < study[(30, 20)]
    assert summary["lights"] > 500 and summary["brute_force_seconds"] > 0
    assert (tmp_path / "compare-cbox.png").stat().st_size > 1000
    assert (tmp_path / "compare-cbox-clusters.png").stat().st_size > 1000
    # The same command again renders nothing new: every row comes back from the Parquet files, timings
    # included.
    subprocess.run(cmd, check=True, capture_output=True, text=True)
    again = json.loads((tmp_path / "compare-cbox.json").read_text())
    assert [r["seconds"] for r in again["records"]] == [r["seconds"] for r in summary["records"]]


def test_cluster_pairs_are_checked():
    with pytest.raises(ValueError, match="LIGHTxVIEW"):
        bench_compare._pair("300-2400")
    with pytest.raises(ValueError, match=">= 1"):
        bench_compare._pair("0x10")


def test_light_models_side_by_side_record_their_model(tmp_path):
    """``--light-models``: every model's renders are rows naming it; the bias compensation's seconds
    are in each image's time; with the clamped VPLs' brute force as the truth the errors are exact: 0 for VPLs
    and for glossy MIS off (cbox has no glossy surface), > 0 for VSLs and the compensated VPLs."""
    import numpy as np
    import pandas as pd

    import manylights as ml
    from manylights.distributed.worker import light_counts
    from manylights.scenes import scene_path

    scene = ml.load_scene(scene_path("cbox"), size=(16, 16))
    lights = ml.generate_lights(scene, **light_counts(scene, {"total": 400, "seed": 0}))
    A = ml.LightMatrix(scene, lights, device="cpu", max_depth=5)
    np.save(tmp_path / "vpl.npy", A.column_sum(progress=False) + A.emitted())
    cmd = [sys.executable, "-m", "manylights.bench", "compare", "--scene", "cbox", "--lights", "400", "--res", "16",
           "--seeds", "2", "--columns", "30", "90", "--device", "cpu", "--max-depth", "5", "--truth",
           str(tmp_path / "vpl.npy"), "--light-models", "vpl", "vpl+bc", "vsl", "no-mis", "--out", str(tmp_path)]
    subprocess.run(cmd, check=True, capture_output=True, text=True)
    summary = json.loads((tmp_path / "compare-cbox-lightmodels.json").read_text())
    assert (tmp_path / "compare-cbox-lightmodels.png").stat().st_size > 1000
    assert summary["truth"].endswith("vpl.npy")
    models = ["vpl", "vpl+bc", "vsl", "no-mis"]
    assert [b["light_model"] for b in summary["brute_force"]] == models
    brute = {b["light_model"]: b["rel_l2"] for b in summary["brute_force"]}
    assert brute["vpl"] == 0.0 and brute["no-mis"] == 0.0
    assert 0.001 < brute["vpl+bc"] < 0.5 and 0.001 < brute["vsl"] < 0.5
    got = {(r["light_model"], r["method"], r["budget"]["columns"]) for r in summary["records"]}
    assert got == {(m, k, c) for m in models for k in ("mrcs", "power_sampling") for c in (30, 90)}
    df = pd.concat([pd.read_parquet(p) for p in tmp_path.glob("compare-cbox-lightmodels-*.parquet")])
    assert len(df) == 4 * 2 * 2 * 2 and (df["status"] == "ok").all() and df["task"].is_unique
    assert sorted(df["light_model"].unique()) == sorted(models)
    assert (df["truth"] == "image:vpl.npy").all()
    vpl = df[df.light_model == "vpl"]
    assert np.array_equal(vpl["rel_l2"].to_numpy(), vpl["rel_l2_brute_force"].to_numpy())
    bc = df[df.light_model == "vpl+bc"]
    assert (bc["seconds_bias_compensation"] > 0).all()
    assert (bc["seconds"] >= bc["seconds_bias_compensation"] + bc["seconds_columns"]).all()
    assert df.loc[df.light_model != "vpl+bc", "seconds_bias_compensation"].isna().all()
    # The same seed gives the same image in both VPL models but for the compensation: its rows differ.
    assert (bc["rel_l2"].to_numpy() != vpl["rel_l2"].to_numpy()).all()


def test_light_model_settings_are_checked(tmp_path):
    import manylights as ml
    from manylights.bench import light_models as blm

    with pytest.raises(ValueError, match="bias compensation applies to clamped VPLs"):
        ml.sweep("cbox", light_models={"x": {"lights": {"indirect_kind": "vsl"}, "bias_compensation": {"spp": 1}}},
                 workers=0, progress=False)
    with pytest.raises(ValueError, match=r"light_models\['x'\]\['matrix'\]"):
        ml.sweep("cbox", light_models={"x": {"matrix": {"visibility": "hybrid"}}}, workers=0, progress=False)
    with pytest.raises(ValueError, match="one image path"):
        ml.sweep("cbox", truth=[None, None], workers=0, progress=False)
    with pytest.raises(FileNotFoundError, match="truth"):
        ml.sweep("cbox", truth=tmp_path / "missing.exr", workers=0, progress=False)
    # The stored Mitsuba references are found by scene file and size.
    assert blm.find_reference(Path("scenes/veach-ajar/scene.xml"), (32, 18)).name == "veach-ajar-gi-32.exr"
    assert blm.find_reference(Path("tests/data/veach_plates.xml"), (64, 48)).name == "veach-plates-direct.exr"
    assert blm.find_reference(Path("scenes/veach-ajar/scene.xml"), (30, 18)) is None
    assert blm.scene_stem(Path("tests/data/veach_plates.xml")) == "veach-plates"


def test_equal_time_takes_the_best_budget_within_each_time():
    recs = [{"method": "a", "budget": {"c": 1}, "seconds": 0.05, "rel_l2_mean": 0.10, "rel_l2_std": 0.01},
            {"method": "a", "budget": {"c": 2}, "seconds": 0.2, "rel_l2_mean": 0.04, "rel_l2_std": 0.01},
            {"method": "a", "budget": {"c": 3}, "seconds": 0.9, "rel_l2_mean": 0.05, "rel_l2_std": 0.02},
            {"method": "b", "budget": {"c": 1}, "seconds": 0.5, "rel_l2_mean": 0.02, "rel_l2_std": 0.001}]
    t = bench_compare.equal_time(recs, times=(0.1, 0.3, 1.0))
    assert [t["a"][x]["budget"]["c"] for x in (0.1, 0.3, 1.0)] == [1, 2, 2]  # the slower budget erred more
    assert t["b"][0.1] is None and t["b"][1.0]["rel_l2_mean"] == 0.02
    md = bench_compare.equal_time_table([{"scene": "scenes/x/scene.xml", "records": recs, "seeds": 4,
                                          "brute_force_seconds": 2.0}], times=(0.1, 0.3, 1.0))
    assert "| a | 10% +- 1.0% | 4.0% +- 1.0% | 4.0% +- 1.0% |" in md and "| b | - | - | 2.0% +- 0.10% |" in md, md
