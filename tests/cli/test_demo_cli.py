"""``python -m manylights demo`` (``make demo``), small: MRCS, brute force and Mitsuba's path tracer at equal
time on the demo scene, the errors against brute force printed and the side-by-side strip written."""
from __future__ import annotations

import numpy as np

import manylights as ml
from manylights.cli import main


def test_demo_small(tmp_path, capsys):
    out = tmp_path / "demo"
    assert main(["demo", "--res", "16", "--lights", "3000", "--rows", "64", "--columns", "200", "--device", "cpu",
                 "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "3,003 lights (3,000 on the area light + 3 point, spot and sun)" in text, text
    assert "speed-up of MRCS over brute force: " in text
    line = next(s for s in text.splitlines() if s.strip().startswith("Mitsuba path ") and " error " in s)
    mi_err = float(line.split("error ")[1].split("%")[0]) / 100
    mrcs_line = next(s for s in text.splitlines() if s.strip().startswith("MRCS ") and "error" in s)
    mrcs_err = float(mrcs_line.split("error ")[1].split("%")[0]) / 100
    # MRCS of 3,003 lights at 64 rows is within a few percent of brute force; Mitsuba at equal time (a
    # fraction of a second here: a few samples per pixel) is a noisy estimate of the same image
    assert 0 <= mrcs_err < 0.05 and np.isfinite(mi_err) and mi_err > 0, (mrcs_err, mi_err)
    # equal time: Mitsuba's level took no longer than MRCS, unless even 1 spp did
    t_mrcs = float(mrcs_line.split()[1])
    spp_line = next(s for s in text.splitlines() if s.startswith("Mitsuba path tracer at equal time: "))
    spp, t_mi = int(spp_line.split(": ")[1].split(" spp")[0]), float(spp_line.split(" in ")[1].split(" s")[0])
    assert spp >= 1 and (t_mi <= t_mrcs + 0.01 or spp == 1), (spp, t_mi, t_mrcs)
    brute = ml.read_exr(out / "brute_force.exr")
    assert brute.shape == (16, 16, 3) and brute.mean() > 0.05
    mitsuba = ml.read_exr(out / "mitsuba_equal_time.exr")
    np.testing.assert_allclose(ml.relative_l2(mitsuba, brute), mi_err, rtol=1e-3)
    assert (out / "side_by_side.png").is_file()
