"""``bench cuts``: MRCS's time to an error by log-log interpolation, and one small run end to end."""
import argparse
import json

import pytest

from manylights.bench.cuts import measure_scene, run, time_to_error


def test_time_to_an_error_is_interpolated_in_log_log():
    # Errors 10% at 1 s and 2.5% at 4 s: the error falls as 1 / t, so 5% is reached at 2 s.
    assert time_to_error([1.0, 4.0], [0.1, 0.025], 0.05) == (pytest.approx(2.0), "interpolated")
    assert time_to_error([4.0, 1.0], [0.025, 0.1], 0.05)[0] == pytest.approx(2.0)  # order does not matter
    assert time_to_error([1.0, 4.0], [0.1, 0.025], 0.2) == (1.0, "at most")
    assert time_to_error([1.0, 4.0], [0.1, 0.025], 0.01) == (None, "not reached")
    # A noisy budget whose error rose is held at the best error so far: 8 s reaches 2.5% as 4 s did.
    assert time_to_error([1.0, 4.0, 8.0], [0.1, 0.025, 0.03], 0.025) == (4.0, "interpolated")
    for bad in (([], [], 0.1), ([1.0], [0.1, 0.2], 0.1), ([0.0], [0.1], 0.1), ([1.0], [0.1], 0.0)):
        with pytest.raises(ValueError):
            time_to_error(*bad)


def test_one_small_run_measures_both_methods_against_the_same_brute_force(tmp_path):
    args = argparse.Namespace(scenes=["cbox", "many-emitters:200"], res=16, errors=[0.05, 0.01], columns=[20, 400],
                              seeds=1, block=4, out=str(tmp_path))
    summary = run(args)
    saved = json.loads((tmp_path / "cuts.json").read_text())
    assert [s["scene"] for s in saved["scenes"]] == ["cbox", "many-emitters:200"]
    for sc in summary["scenes"]:
        assert sc["lights"] >= 4096 and sc["brute_force_seconds"] > 0
        (loose, tight) = sc["cuts"]
        assert 0 < tight["error"] < loose["error"] < 0.1 and tight["mean_cut"] > loose["mean_cut"]
        mrcs = sc["mrcs"]
        assert mrcs[1]["error"] < mrcs[0]["error"]
        for c in sc["cuts"]:
            t, kind = time_to_error([m["seconds"] for m in mrcs], [m["error"] for m in mrcs], c["error"])
            assert (c["mrcs_seconds"], c["mrcs_kind"]) == (t, kind)
            assert c["ratio"] is None if t is None else c["ratio"] == pytest.approx(c["seconds"] / t)
    assert "| cbox (" in (tmp_path / "cuts.md").read_text()
    with pytest.raises(ValueError, match="none of"):
        measure_scene("bunny", args)
    # Names are checked before any work; budgets past the pixels' rows or the lights are cut or skipped.
    with pytest.raises(ValueError, match="none of"):
        run(argparse.Namespace(**{**vars(args), "scenes": ["cbox", "bogus"], "out": str(tmp_path / "x")}))
    assert not (tmp_path / "x" / "cuts.json").exists()
    big = measure_scene("cbox", argparse.Namespace(**{**vars(args), "columns": [900, 10**6], "errors": [0.05]}))
    assert [(r["columns"], r["rows"]) for r in big["mrcs"]] == [(900, 256)]
    with pytest.raises(ValueError, match="--errors"):
        run(argparse.Namespace(**{**vars(args), "errors": [0.0]}))
