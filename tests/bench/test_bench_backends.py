"""``python -m manylights.bench backends`` at a tiny size: both backends timed side by side, the JSON holds
every figure and the GPU / CPU ratios are the quotients of the measured times."""
from __future__ import annotations

import json

import pytest

from manylights.bench import __main__ as bench


def test_backends_benchmark_writes_both_devices(tmp_path):
    bench.main(["backends", "--scene", "cbox", "--res", "24", "--lights", "80", "--row-lights", "300",
                "--columns", "4", "--rows", "3", "--repeats", "1", "--gpu-visibility", "ray_traced",
                "--out", str(tmp_path)])
    report = json.loads((tmp_path / "backends.json").read_text())
    res = report["scenes"]["cbox"]["results"]
    assert set(res) == {"cpu", "gpu ray_traced"}
    assert res["cpu"]["device"]["kind"] == "cpu" and res["gpu ray_traced"]["device"]["kind"] == "gpu"
    assert report["scenes"]["cbox"]["size"] == [24, 24]
    keys = ("column_ms", "column_batch_ms", "weighted_column_ms", "row_ms")
    for k in keys:
        assert res["cpu"][k] > 0 and res["gpu ray_traced"][k] > 0
        assert res["gpu ray_traced"]["ratio_to_cpu"][k] == pytest.approx(res["gpu ray_traced"][k] / res["cpu"][k])


def test_backends_benchmark_refuses_bad_sizes(tmp_path):
    with pytest.raises(ValueError, match="--res"):
        bench.main(["backends", "--scene", "cbox", "--res", "0", "--out", str(tmp_path)])


def test_the_peer_traces_the_same_rays_as_mitsuba_and_agrees(tmp_path):
    from conftest import REPO
    from manylights.bench.ray_peer import measure

    out = measure("cbox", REPO / "scenes" / "cbox" / "scene.xml", {}, (24, 24), lights=24, row_lights=64, rows=16,
                  repeats=1)
    for batch in ("columns", "rows"):
        b = out["batches"][batch]
        assert 0 < b["rays"] <= b["elements"]
        assert 0.05 < b["blocked_share"] < 0.95          # both answers occur
        assert b["agreement"] >= 0.999, b                 # the same queries, the same answers
        assert b["visibility_ratio"] == pytest.approx(b["seconds"]["mitsuba"] / b["seconds"]["ours"])
        assert b["split"]["traversal"] > 0 and b["seconds"]["ray_arrays"] > 0
        assert b["split"]["setup_shading_rest"] == pytest.approx(max(1 - b["split"]["traversal"], 0.0))
        # every element's ray: a superset of the cast ones, one per element of a surface view sample
        e = b["every_element"]
        assert b["rays"] < e["rays"] <= b["elements"]
        assert e["agreement"] >= 0.999, e
        assert e["element_ratio"] == pytest.approx(e["seconds"]["mitsuba"] / b["seconds"]["element"])
