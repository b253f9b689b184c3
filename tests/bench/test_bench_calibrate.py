"""``python -m manylights.bench calibrate`` end to end on a tiny configuration at two light
counts: every run is recorded with its light count, and the within-2x shares of the JSON follow from its runs."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from manylights.bench import calibrate as bench_calibrate


def test_calibrate_bench_keeps_light_counts_apart(tmp_path):
    cmd = [sys.executable, "-m", "manylights.bench", "calibrate", "--scenes", "cbox-lights", "--res", "12",
           "--lights", "64", "256", "--budgets", "4:8", "8:16", "--seeds", "3", "--out", str(tmp_path)]
    subprocess.run(cmd, check=True, capture_output=True, text=True)
    s = json.loads((tmp_path / "calibrate.json").read_text())
    assert (tmp_path / "calibrate.png").stat().st_size > 1000
    assert s["config"]["lights"] == [64, 256] and s["config"]["seeds"] == 3
    runs = s["runs"]
    # 2 light counts x 2 budgets x 2 estimators x 3 seeds, each once.
    assert len(runs) == 24
    assert {(r["lights"], r["rows"], r["columns"], r["estimator"], r["seed"]) for r in runs} == {
        (n, r, c, e, k) for n in (64, 256) for r, c in ((4, 8), (8, 16)) for e in ("halves", "rows") for k in range(3)}
    for r in runs:
        assert r["scene"] == "scenes/cbox-lights/scene.xml" and r["true"] > 0 and r["estimate"] >= 0
    for est in ("halves", "rows"):
        assert s["within_2x"][est] == pytest.approx(bench_calibrate.within([r for r in runs if r["estimator"] == est]))
        for n in (64, 256):
            sel = [r for r in runs if r["estimator"] == est and r["lights"] == n]
            q = np.array([r["estimate"] / r["true"] for r in sel])
            assert s["within_2x_by_lights"][str(n)][est] == pytest.approx(np.mean((q >= 0.5) & (q <= 2.0)))


def test_calibrate_bench_refuses_a_light_count_below_one(tmp_path):
    cmd = [sys.executable, "-m", "manylights.bench", "calibrate", "--scenes", "cbox-lights", "--lights", "0",
           "--out", str(tmp_path)]
    p = subprocess.run(cmd, capture_output=True, text=True)
    assert p.returncode != 0 and "--lights must be counts >= 1, got [0]" in p.stderr
    assert not (tmp_path / "calibrate.json").exists()
