"""``python -m manylights.bench compare`` (issue 12 item 6) on a tiny configuration: every renderer on one
chart with its error against the cached brute force, the light x view cluster study, JSON and PNGs."""
from __future__ import annotations

import json
import subprocess
import sys

import pytest

from manylights import bench_compare


def test_compare_puts_every_renderer_on_one_chart(tmp_path):
    cmd = [sys.executable, "-m", "manylights.bench", "compare", "--scene", "cbox", "--lights", "600", "--res", "16",
           "--seeds", "2", "--columns", "30", "90", "--clusters", "30x20", "120x80", "--grid-light", "30", "120",
           "--grid-view", "20", "80", "--device", "cpu", "--out", str(tmp_path)]
    subprocess.run(cmd, check=True, capture_output=True, text=True)
    summary = json.loads((tmp_path / "compare-cbox.json").read_text())
    methods = {r["method"] for r in summary["records"]}
    assert methods == {"power_sampling", "instant_radiosity", "mrcs", "clustered_visibility"}
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
