"""``bench scale``: the generated room has exactly the triangles asked for, one point runs end to end, slopes."""
import numpy as np
import pytest

import manylights as ml
from manylights.bench.scale import PAPER, plan, point, slope, write_scene


def test_the_generated_room_has_the_triangles_asked_for(tmp_path):
    scene = ml.load_scene(write_scene(tmp_path, 2 * 16 * 16), size=(32, 24))
    tris = {s["type"]: 0 for s in scene.shapes}
    for s in scene.shapes:
        tris[s["type"]] += s["triangles"]
    assert tris == {"ply": 512, "rectangle": 10}      # the floor's grid and five rectangles of two
    assert sum(e["type"] == "area" for e in scene.emitters) == 1
    with pytest.raises(ValueError, match="2 k\\^2"):
        write_scene(tmp_path, 1000)


def test_one_point_runs_mrcs_and_reports_its_stages():
    r = point(32, 24, 1024, 2 * 8 * 8)
    assert (r["view_samples"], r["triangles"]) == (768, 128) and r["lights"] >= 1024
    assert set(r["seconds"]) == {"write_scene", "load", "lights", "matrix", "mrcs"}
    assert r["mrcs_stages"]["columns"] > 0 and r["peak_rss_mb"] > 0


def test_slopes_and_the_plan():
    assert slope([1, 2, 4, 8], [3, 6, 12, 24]) == pytest.approx(1.0)
    assert slope([1, 10, 100], np.sqrt([1, 10, 100])) == pytest.approx(0.5)
    points = plan(["pixels", "paper"])
    assert points[-1] == ("paper", PAPER) and PAPER[0] * PAPER[1] == 1024 * 768 and PAPER[3] >= 2_000_000
    assert [a for a, _ in points].count("pixels") == 5
