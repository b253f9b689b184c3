"""``python -m manylights.bench budgets`` end to end on a 16x16 configuration:
its JSON has every field, and each target's hit rate, cheapest fixed budget and time ratio follow from the
bench's own runs."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from manylights.bench import budgets as bench_budgets


def test_budgets_bench_runs_and_its_ratios_come_from_its_numbers(tmp_path):
    cmd = [sys.executable, "-m", "manylights.bench", "budgets", "--scene", "cbox", "--res", "16", "--lights", "600",
           "--seeds", "2", "--targets", "0.2", "0.05", "--budgets", "4:16", "8:32", "8:64", "--out", str(tmp_path),
           "--cache", str(tmp_path / "cache")]
    subprocess.run(cmd, check=True, capture_output=True, text=True)
    s = json.loads((tmp_path / "budgets-cbox.json").read_text())
    assert (tmp_path / "budgets-cbox.png").stat().st_size > 1000
    assert s["size"] == [16, 16] and s["lights"] > 500 and s["seeds"] == 2 and s["targets"] == [0.2, 0.05]
    assert s["complete"] and s["light_spec"] == {"total": 600} and s["device"]["kind"] == "cpu" and s["brute_force_seconds"] > 0
    assert [(f["rows"], f["columns"]) for f in s["fixed"]] == [(4, 16), (8, 32), (8, 64)]
    assert len(s["runs"]) == 4 and {(r["target"], r["seed"]) for r in s["runs"]} == {(e, k) for e in (0.2, 0.05)
                                                                                     for k in (0, 1)}
    for r in s["runs"]:
        assert r["seconds"] > 0 and r["columns"] >= 2 and 0 <= r["true"] < 1 and r["stopped"], r
        if r["stopped"] == "target error reached":  # render's rule: the estimate at <= 0.8 x the target
            assert r["estimate"] <= 0.8 * r["target"]
    for f in s["fixed"]:
        assert len(f["rel_l2"]) == 2 and f["seconds"] > 0
        assert f["rel_l2_mean"] == pytest.approx(np.mean(f["rel_l2"]))
    for row in s["table"]:
        e = row["target"]
        mine = [r for r in s["runs"] if r["target"] == e]
        assert row["hit_rate"] == pytest.approx(np.mean([r["true"] <= e for r in mine]))
        assert row["render_seconds"] == pytest.approx(np.mean([r["seconds"] for r in mine]))
        reaching = [f for f in s["fixed"] if np.mean(np.array(f["rel_l2"]) <= e) >= 0.9]
        if reaching:
            best = min(reaching, key=lambda f: f["seconds"])
            assert (row["cheapest_fixed"]["rows"], row["cheapest_fixed"]["columns"]) == (best["rows"], best["columns"])
            paired = np.mean([r["fixed_seconds"] for r in mine])
            assert row["cheapest_fixed"]["seconds_paired"] == pytest.approx(paired)
            assert row["ratio"] == pytest.approx(row["render_seconds"] / paired)
            assert row["ratio_sweep"] == pytest.approx(row["render_seconds"] / best["seconds"])
            # The paired re-render is the sweep's render again: same seed, same bits, same error.
            for r in mine:
                assert r["fixed_rel_l2"] == pytest.approx(best["rel_l2"][r["seed"]], rel=1e-6)
            assert row["met"] == (row["hit_rate"] >= 0.9 and row["ratio"] <= 2.0)
        else:
            assert row["cheapest_fixed"] is None and row["ratio"] is None and row["met"] is False
            assert all(r["fixed_seconds"] is None for r in mine)
    # 20% is within reach of the largest fixed budget at this size.
    assert s["table"][0]["cheapest_fixed"] is not None


def test_cheapest_reaching_needs_90_percent_of_seeds():
    fixed = [{"rows": 4, "columns": 16, "seconds": 0.1, "rel_l2": [0.01] * 9 + [0.5]},   # 90%: reaches
             {"rows": 2, "columns": 8, "seconds": 0.05, "rel_l2": [0.01] * 8 + [0.5] * 2},  # 80%: does not
             {"rows": 8, "columns": 64, "seconds": 0.4, "rel_l2": [0.001] * 10}]
    assert bench_budgets.cheapest_reaching(fixed, 0.02)["columns"] == 16
    assert bench_budgets.cheapest_reaching(fixed, 0.005)["columns"] == 64
    assert bench_budgets.cheapest_reaching(fixed, 1e-4) is None


def test_lights_spec():
    assert bench_budgets.lights_spec("cbox", 100_000, None) == {"total": 100_000}
    assert bench_budgets.lights_spec("veach-ajar", 100_000, None) == {"area": 10_000, "indirect": 90_000}
    assert bench_budgets.lights_spec("cbox", 1000, 100) == {"area": 100, "indirect": 900}
    with pytest.raises(ValueError, match="--area"):
        bench_budgets.lights_spec("cbox", 1000, 2000)
    with pytest.raises(ValueError, match="--lights"):
        bench_budgets.lights_spec("cbox", 0, None)
