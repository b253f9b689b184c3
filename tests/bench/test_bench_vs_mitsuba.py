"""``python -m manylights.bench vs-mitsuba`` on a tiny configuration: cbox-lights 32x32,
a 512-spp pixel-centre reference in a temporary cache, Mitsuba at 1/4/16 spp, MRCS at two budgets on each
backend this build has. No timing is compared with a constant: the checks are on the cache, on the
time-to-error table against the measured (seconds, error) points, on errors falling with budget, and on
the files written."""
from __future__ import annotations

import argparse
import json
import math

import numpy as np
import pytest

import manylights as ml
from manylights.bench import __main__ as bench
from manylights.bench import time_to_error as tte
from manylights.bench import vs_mitsuba as bvm

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")

# Both backends of ml.LightMatrix: the CPU one and the GPU one (a software adapter in CI).
DEVICES = ["cpu", "gpu"]
THRESHOLDS = [0.6, 0.3, 0.1, 0.03]


def _args(*argv):
    ap = argparse.ArgumentParser()
    bvm.add_parser(ap.add_subparsers(dest="cmd"))
    return ap.parse_args(["vs-mitsuba", *map(str, argv)])


def _base(tmp, out):
    return ["--scene", "cbox-lights", "--res", 32, "--ref-spp", 512, "--cache", tmp / "cache", "--out", tmp / out]


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("vs-mitsuba")
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(bvm, "MAX_REPEATS", 1)  # one timed run per render: no timing is checked here
        first = bvm.run(_args(*_base(tmp, "a"), "--spp", 1, 4, 16, "--budgets", "100:8:20", "4000:100:400",
                              "--devices", *DEVICES, "--thresholds", *THRESHOLDS, "--no-early-stop",
                              "--seeds", 2))
        cache = sorted((tmp / "cache").iterdir())
        mtimes = {p.name: p.stat().st_mtime_ns for p in cache}
        second = bvm.run(_args(*_base(tmp, "b"), "--spp", 1, "--budgets", "100:8:20", "--devices", DEVICES[0],
                               "--samplers", "light_bvh_sampling", "stochastic_lightcuts", "--samples", 1, 16,
                               "--sampler-lights", 2000, "--no-early-stop"))
    return tmp, first, second, mtimes


def test_reference_is_cached(runs):
    tmp, first, second, mtimes = runs
    assert first["reference_cached"] is False and second["reference_cached"] is True
    files = sorted((tmp / "cache").iterdir())
    # One entry: mean EXR, variance EXR, JSON; the second run rewrote none of them.
    assert len(files) == 3 and {p.suffix for p in files} == {".exr", ".json"}
    assert {p.name: p.stat().st_mtime_ns for p in files} == mtimes
    meta = json.loads(next(p for p in files if p.suffix == ".json").read_text())
    assert meta["spp"] == 512 and meta["size"] == [32, 32] and meta["max_depth"] == 2
    assert second["reference"]["key"] == first["reference"]["key"] == meta["key"]
    # The printed noise is sqrt(sum var) / ||mean|| of the stored images.
    mean = ml.read_exr(files[0].with_name(meta["exr"]))
    var = ml.read_exr(files[0].with_name(meta["exr"].replace(".exr", ".var.exr")))
    assert mean.shape == (32, 32, 3)
    assert meta["relative_noise"] == pytest.approx(math.sqrt(var.astype(np.float64).sum()) /
                                                   np.linalg.norm(mean.astype(np.float64)), rel=1e-5)
    assert 0.0 < meta["relative_noise"] < 0.1


def test_errors_fall_with_budget(runs):
    _, first, _, _ = runs
    recs = first["records"]
    mit = [r for r in recs if r["method"] == "mitsuba"]
    assert [r["spp"] for r in mit] == [1, 4, 16]
    assert mit[0]["relative_l2"] > mit[1]["relative_l2"] > mit[2]["relative_l2"]
    for dev in DEVICES:
        mr = [r for r in recs if r["curve"] == f"mrcs {dev}"]
        assert [(r["lights_budget"], r["rows"], r["columns"]) for r in mr] == [(100, 8, 20), (4000, 100, 400)]
        assert all(r["device"] == dev for r in mr), mr
        assert mr[0]["relative_l2"] > mr[1]["relative_l2"]
        # Light generation and the matrix set-up are part of the timed work.
        assert {"generate_lights", "light_matrix", "columns"} <= set(mr[0]["stages"])
    # cbox-lights: errors with the shape-edge pixel centres left out are reported too.
    assert first["edge_pixels"] > 0
    assert all(r["relative_l2_no_edges"] is not None for r in recs)


def test_errors_are_rms_over_seeds(runs):
    _, first, second, _ = runs
    for r in first["records"]:
        for key in ("relative_l2", "relative_l2_no_edges"):
            per_seed = r[key + "_per_seed"]
            # Two seeds, two different images (different light sets / samples), and the RMS of their errors.
            assert r["seeds"] == 2 and len(per_seed) == 2 and per_seed[0] != per_seed[1]
            assert r[key] == pytest.approx(math.sqrt((per_seed[0] ** 2 + per_seed[1] ** 2) / 2), rel=1e-12)
        assert r["seconds"] == pytest.approx(float(np.median(r["seconds_per_seed"])))
    # The default is 3 seeds; the second run left it.
    assert all(r["seeds"] == 3 for r in second["records"])


def _check_table(records, table, key):
    curves = {}
    for r in records:
        curves.setdefault(r["curve"], []).append((r["seconds"], r[key]))
    assert [row["threshold"] for row in table] == THRESHOLDS
    for row in table:
        thr = row["threshold"]
        assert set(row["curves"]) == set(curves)
        for name, c in row["curves"].items():
            pts = sorted(curves[name])
            if c["how"] == "at most":
                assert c["seconds"] == pts[0][0] and pts[0][1] <= thr
            elif c["how"] == "not reached":
                assert c["seconds"] is None and all(e > thr for _, e in pts)
            else:
                # The first pair in time order that brackets the threshold, and the time lies between them.
                k = next(k for k in range(len(pts) - 1) if pts[k][1] > thr >= pts[k + 1][1])
                (t0, e0), (t1, e1) = pts[k], pts[k + 1]
                assert t0 <= c["seconds"] <= t1
                # log-log interpolation: the point (t, thr) lies on the segment in log space.
                f = (math.log(thr) - math.log(e0)) / (math.log(e1) - math.log(e0))
                assert math.log(c["seconds"]) == pytest.approx(math.log(t0) + f * (math.log(t1) - math.log(t0)))
        mit = row["curves"]["mitsuba"]["seconds"]
        for name, ratio in row["ratio_mitsuba_over"].items():
            t = row["curves"][name]["seconds"]
            assert ratio == (pytest.approx(mit / t) if mit is not None and t is not None else None)


def test_threshold_table_matches_measured_curves(runs):
    _, first, _, _ = runs
    for key in ("relative_l2", "relative_l2_no_edges"):
        _check_table(first["records"], first["thresholds_" + key], key)
    # The thresholds are chosen so that Mitsuba's 1..16 spp (errors ~100% .. ~20%) crosses some of them.
    assert any(row["curves"]["mitsuba"]["how"] == "interpolated" for row in first["thresholds_relative_l2"])
    for b in first["best_relative_l2"]:
        errs = [r["relative_l2"] for r in first["records"] if r["curve"] == b["curve"]]
        assert b["relative_l2"] == min(errs)


def test_outputs_written(runs):
    tmp, first, _, _ = runs
    js = tmp / "a" / "vs-mitsuba-cbox-lights.json"
    png = tmp / "a" / "vs-mitsuba-cbox-lights.png"
    saved = json.loads(js.read_text())
    assert saved["records"] == json.loads(json.dumps(first["records"]))
    assert saved["interrupted"] is False and saved["size"] == [32, 32]
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    import matplotlib.image

    assert matplotlib.image.imread(png).shape[0] > 100


def test_samplers_are_charted_beside_mrcs(runs):
    _, _, second, _ = runs
    for method in ("light_bvh_sampling", "stochastic_lightcuts"):
        recs = [r for r in second["records"] if r["method"] == method]
        assert [(r["samples"], r["lights_budget"], r["device"]) for r in recs] == [(1, 2000, "cpu"), (16, 2000, "cpu")]
        # Unbiased samplers over the same 2,000 lights: 16 samples per view sample beat 1 (3 seeds, RMS).
        assert recs[1]["relative_l2"] < 0.6 * recs[0]["relative_l2"]
        assert {"generate_lights", "light_matrix", "sampling"} <= set(recs[0]["stages"])
        assert method in second["thresholds_relative_l2"][0]["curves"]


def test_many_emitter_hall_is_generated_exactly(tmp_path):
    from manylights.bench import many_emitters as me

    assert me.parse_name("many-emitters:5000") == 5000 and me.parse_name("cbox") is None
    for bad in ("many-emitters:", "many-emitters:five", "many-emitters:3", "many-emitters:1000000"):
        with pytest.raises(ValueError, match="many-emitters:N"):
            me.parse_name(bad)
    path = me.write_scene(tmp_path / "hall", 120, seed=3)
    text = path.read_text()
    assert text == me.scene_xml(120, seed=3) != me.scene_xml(120, seed=4)
    mtime = path.stat().st_mtime_ns
    assert me.write_scene(tmp_path / "hall", 120, seed=3) == path and path.stat().st_mtime_ns == mtime
    scene = ml.load_scene(path, size=(16, 12))
    assert len(scene.emitters) == 120 and all(e["type"] == "area" for e in scene.emitters)
    # Mitsuba reads the same file with the same emitters (12 boxes, 5 room rectangles, 120 emitters).
    from manylights.testing import mitsuba as reference

    mscene = reference.load(path)
    assert len(mscene.emitters()) == 120 and len(mscene.shapes()) == 137
    with pytest.raises(ValueError, match="emitters"):
        me.scene_xml(5)


def test_scene_defaults_name_bundled_scenes():
    from manylights.scenes import available

    assert set(bvm.DEFAULTS) == {"cbox", "cbox-lights", "veach-ajar", "demo"} and set(bvm.DEFAULTS) <= set(available())
    # full GI where the issue asks for it, direct light for cbox-lights (and the demo's own integrator)
    assert {k: d.max_depth for k, d in bvm.DEFAULTS.items()} == {"cbox": -1, "cbox-lights": 2, "veach-ajar": -1,
                                                                "demo": 2}


def test_time_to_error_exact():
    # log t is linear in log e between (1 s, 10%) and (4 s, 2.5%): 5% is reached at 2 s.
    assert tte.time_to_error([(4.0, 0.025), (1.0, 0.1)], 0.05) == (pytest.approx(2.0, rel=1e-12), "interpolated")
    assert tte.time_to_error([(1.0, 0.1), (4.0, 0.025)], 0.2) == (1.0, "at most")
    assert tte.time_to_error([(1.0, 0.1), (4.0, 0.025)], 0.01) == (None, "not reached")
    assert tte.time_to_error([], 0.01) == (None, "not reached")
    # Not monotone: the first crossing in time order counts.
    t, how = tte.time_to_error([(8.0, 0.01), (1.0, 0.1), (2.0, 0.04), (4.0, 0.06)], 0.05)
    assert how == "interpolated" and t == pytest.approx(2.0 ** (math.log(2.0) / math.log(2.5)), rel=1e-12)


def test_interrupt_keeps_measurements(runs, monkeypatch):
    tmp = runs[0]
    real = bvm.run_mrcs

    def stop_at_second_budget(scene, budget, *a, **k):  # warm-up and first budget run, then Ctrl-C
        if budget == (200, 8, 20):
            raise KeyboardInterrupt
        return real(scene, budget, *a, **k)

    monkeypatch.setattr(bvm, "run_mrcs", stop_at_second_budget)
    with pytest.raises(SystemExit) as e:
        bvm.run(_args(*_base(tmp, "c"), "--spp", 1, 2, "--budgets", "100:8:20", "200:8:20", "--devices", "cpu",
                      "--no-early-stop"))
    assert e.value.code == 130
    saved = json.loads((tmp / "c" / "vs-mitsuba-cbox-lights.json").read_text())
    assert saved["interrupted"] is True and saved["reference_cached"] is True
    assert [(r["method"], r["lights_budget"]) for r in saved["records"]] == [("mrcs", 100)]
    assert (tmp / "c" / "vs-mitsuba-cbox-lights.png").is_file()


@pytest.mark.parametrize("argv, exc, match", [
    (["--scene", "no-such-scene"], FileNotFoundError, "no-such-scene"),
    (["--scene", "cbox", "--budgets", "1000:30"], ValueError, "'1000:30'"),
    (["--scene", "cbox", "--budgets", "1000:0:100"], ValueError, "1000:0:100"),
    (["--scene", "cbox", "--max-depth", "1"], ValueError, "max-depth"),
    (["--scene", "cbox", "--ref-spp", "1"], ValueError, "ref-spp"),
    (["--scene", "cbox", "--spp", "0"], ValueError, "spp"),
    (["--scene", "cbox", "--thresholds", "0"], ValueError, "thresholds"),
    (["--scene", "cbox", "--res", "0"], ValueError, "res"),
    (["--scene", "cbox", "--seeds", "0"], ValueError, "seeds"),
])
def test_bad_input(tmp_path, argv, exc, match):
    # Through the registered subcommand; everything is checked before anything renders.
    with pytest.raises(exc, match=match):
        bench.main(["vs-mitsuba", *argv, "--cache", str(tmp_path / "c"), "--out", str(tmp_path / "o")])
    assert not (tmp_path / "c").exists()


def test_unknown_device_rejected(tmp_path, capsys):
    with pytest.raises(SystemExit) as e:
        bench.main(["vs-mitsuba", "--scene", "cbox", "--devices", "tpu"])
    assert e.value.code == 2 and "tpu" in capsys.readouterr().err


def test_the_many_emitter_hall_has_no_overlapping_emitters():
    """Coplanar overlapping emitters make the camera's hit a matter of rounding: every pair of emitter squares
    on the same plane must be disjoint (5,000 emitters, the benchmark's size)."""
    import re

    from manylights.bench import many_emitters as me

    xml = me.scene_xml(5000, seed=0)
    rects = re.findall(r'<scale value="([0-9.]+)"/><rotate (x|y)="1" angle="(-?[0-9]+)"/>'
                       r'<translate x="(-?[0-9.]+)" y="(-?[0-9.]+)" z="(-?[0-9.]+)"/></transform>\s*<ref id="black"/>', xml)
    assert len(rects) == 5000
    planes: dict = {}
    for half, axis, angle, x, y, z in rects:
        h, x, y, z = float(half), float(x), float(y), float(z)
        key = ("ceiling",) if axis == "x" else ("wall", angle)
        u, v = (x, z) if axis == "x" else (y, z)
        planes.setdefault(key, []).append((u - h, u + h, v - h, v + h))
    assert set(planes) == {("ceiling",), ("wall", "90"), ("wall", "-90")}
    for key, boxes in planes.items():
        b = np.array(boxes)
        order = np.argsort(b[:, 0])
        b = b[order]
        for i in range(len(b)):
            # Candidates whose u-interval starts before this one ends.
            j = i + 1
            while j < len(b) and b[j, 0] < b[i, 1]:
                assert not (b[j, 2] < b[i, 3] and b[i, 2] < b[j, 3]), f"{key}: emitters {b[i]} and {b[j]} overlap"
                j += 1
