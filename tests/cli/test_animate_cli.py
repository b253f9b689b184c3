"""``python -m manylights animate`` and ``python -m manylights.bench tensor`` at a
tiny size: the files they say they write are complete and hold the frames, the printed errors are those of
the written frames, and bad arguments are refused before anything is written."""
from __future__ import annotations

import json

import numpy as np
import pytest

import manylights as ml
import manylights.cli as cli
from manylights.bench import __main__ as bench

iio = pytest.importorskip("imageio.v3")

TINY = ["--frames", "3", "--res", "16", "--area", "32", "--environment", "32", "--indirect", "64", "--photons", "0",
        "--rows", "16", "--columns", "20"]


def test_animate_compare(tmp_path, capsys):
    out = tmp_path / "anim"
    assert cli.main(["animate", "bounce", *TINY, "--compare", "--gif", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    for name in ("tensor", "mrcs", "brute_force"):
        exrs = sorted((out / name).glob("frame_*.exr"))
        assert [p.name for p in exrs] == [f"frame_{k:04d}.exr" for k in range(3)]
        assert iio.imread(out / f"{name}.gif").shape[:3] == (3, 16, 16)
    strip = iio.imread(out / "strip.gif")
    assert strip.shape[0] == 3 and strip.shape[2] == 4 * 16 + 3 * 2
    # The printed error of tensor clustering is that of the written frames against the written brute force.
    t = np.stack([ml.read_exr(p) for p in sorted((out / "tensor").glob("*.exr"))])
    b = np.stack([ml.read_exr(p) for p in sorted((out / "brute_force").glob("*.exr"))])
    err = ml.relative_l2_per_frame(t, b).mean()
    assert f"tensor: mean relative L2 {err:.3%}" in text
    assert not list(out.rglob(".*tmp*"))


@pytest.mark.parametrize("argv, match", [
    (["animate", "cbox", "--frames", "2"], "not a bundled animated scene"),
    (["animate", "bounce", "--frames", "0"], "--frames"),
    (["animate", "bounce", "--columns", "0"], "--columns"),
    (["animate", "bounce", "--fps", "0"], "--fps"),
    (["animate", "bounce", "--frames", "2", "--frames-json", "x.json"], "not both"),
])
def test_animate_bad_input(tmp_path, argv, match, capsys):
    assert cli.main([*argv, "--out", str(tmp_path / "o")]) == 1
    assert match in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_bench_tensor_tiny(tmp_path):
    argv = ["tensor", "--frames", "3", "--res", "16", "--area", "32", "--environment", "32", "--indirect", "64",
            "--photons", "0", "--rows", "16", "--tensor", "20", "--mrcs", "20", "40", "--seeds", "2",
            "--cache", str(tmp_path / "cache"), "--out", str(tmp_path / "out")]
    assert bench.main(argv) == 0
    summary = json.loads((tmp_path / "out" / "tensor-bounce.json").read_text())
    assert (tmp_path / "out" / "tensor-bounce.png").is_file()
    recs = summary["records"]
    assert len(recs) == 2 * 3 and {r["method"] for r in recs} == {"tensor_clustering", "mrcs_per_frame"}
    assert all(r["shadow_maps_per_frame"] == 16 + r["columns"] for r in recs if r["method"] == "mrcs_per_frame")
    # The table is the mean over seeds of the records.
    for row in summary["table"]:
        rs = [r for r in recs if (r["method"], r["columns"]) == (row["method"], row["columns"])]
        assert row["runs"] == 2 and row["mean_relative_l2"] == pytest.approx(np.mean([r["mean_relative_l2"] for r in rs]))
        assert row["speedup_over_brute_force"] == pytest.approx(summary["brute_force_seconds"] / row["seconds"])
    # The brute force is cached: a second run reuses it.
    assert summary["brute_force_cached"] is False
    assert bench.main(argv[:-2] + ["--out", str(tmp_path / "out2"), "--seeds", "1"]) == 0
    assert json.loads((tmp_path / "out2" / "tensor-bounce.json").read_text())["brute_force_cached"] is True
