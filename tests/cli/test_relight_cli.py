"""``python -m manylights relight``: one EXR (+ PNG) per light placement, equal to
``DirectToIndirect.relight`` of the same lights; ``--save`` / ``--load``; light specs and their errors."""
from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import manylights as ml
from manylights.cli import main
from manylights.cli import relight as relight_cli

BOX = Path(__file__).parents[1] / "data" / "relight_box.xml"
SPOT = "spot:pos=-0.4,0.9,0.3;target=0.1,-1,-0.2;intensity=3,3,2;cutoff=30;beam=20"
POINT = "point:pos=0.3,0.6,0.2;intensity=0.5"
OPTS = ["--res", "16", "--gather", "64", "--coefficients", "16"]


@pytest.fixture(scope="module")
def box():
    return ml.load_scene(BOX, res=16)


def _spot(scene):
    d = np.array([0.5, -1.9, -0.5])
    return ml.LightSet.from_arrays(scene, kind=1, position=[[-0.4, 0.9, 0.3]], direction=[d / np.linalg.norm(d)],
                                   intensity=[[3, 3, 2]], cutoff_angle=math.radians(30), beam_width=math.radians(20))


def test_cli_images_equal_relight_of_the_same_lights(box, tmp_path, capsys):
    out = tmp_path / "out"
    saved = tmp_path / "box.npz"
    assert main(["relight", str(BOX), *OPTS, "--light", SPOT, "--light", f"{SPOT} + {POINT}",
                 "--out", str(out), "--save", str(saved)]) == 0
    text = capsys.readouterr().out
    assert "relit 2 light placements" in text and "per second" in text
    files = sorted(p.name for p in out.iterdir())
    assert files == ["light_000.exr", "light_000.png", "light_001.exr", "light_001.png"]
    rel = ml.DirectToIndirect(box, gather=64, final_gather_coefficients=16)
    spot = _spot(box)
    point = ml.LightSet.from_arrays(box, kind=0, position=[[0.3, 0.6, 0.2]], intensity=[[0.5, 0.5, 0.5]])
    want0 = rel.relight(spot)
    want1 = rel.relight(ml.LightSet.concat([spot, point]))
    got0, got1 = ml.read_exr(out / "light_000.exr"), ml.read_exr(out / "light_001.exr")
    assert got0.shape == (16, 16, 3) and want0.max() > 0.05
    # Same precomputation (deterministic), same lights: the same image to float rounding of the direction
    # (the CLI normalises target - pos in float64, the test in float64 too).
    assert ml.relative_l2(got0, want0) < 1e-6 and ml.relative_l2(got1, want1) < 1e-6
    assert np.linalg.norm(got1 - got0) > 0.01 * np.linalg.norm(got0)  # the point light is there
    # --load reuses the saved precomputation: bit-identical images.
    out2 = tmp_path / "out2"
    assert main(["relight", str(BOX), "--res", "16", "--load", str(saved), "--light", SPOT, "--out", str(out2),
                 "--no-png"]) == 0
    assert sorted(p.name for p in out2.iterdir()) == ["light_000.exr"]
    assert np.array_equal(ml.read_exr(out2 / "light_000.exr"), got0)


def test_lights_file_and_scene_lights(box, tmp_path):
    f = tmp_path / "lights.json"
    f.write_text(json.dumps([SPOT, [{"type": "spot", "pos": [-0.4, 0.9, 0.3], "target": [0.1, -1, -0.2],
                                     "intensity": [3, 3, 2], "cutoff": 30, "beam": 20}],
                             {"type": "directional", "dir": [0.2, -1, -0.1], "irradiance": 0.5}]))
    out = tmp_path / "out"
    assert main(["relight", str(BOX), *OPTS, "--lights", str(f), "--out", str(out), "--no-png"]) == 0
    a, b, c = (ml.read_exr(out / f"light_{k:03d}.exr") for k in range(3))
    assert np.array_equal(a, b) and a.max() > 0.05 and c.max() > 0.05 and not np.array_equal(a, c)
    # No --light: the scene's own spot light.
    out = tmp_path / "own"
    assert main(["relight", str(BOX), *OPTS, "--out", str(out), "--no-png"]) == 0
    rel = ml.DirectToIndirect(box, gather=64, final_gather_coefficients=16)
    assert np.array_equal(ml.read_exr(out / "light_000.exr"), rel.relight(ml.scene_lights(box)))


def test_light_specs():
    s = relight_cli.parse_light("spot:pos=0,1,0;dir=0,-2,0;intensity=2;cutoff=40")
    assert s["kind"] == 1 and s["position"] == [0, 1, 0] and np.allclose(s["direction"], [0, -1, 0])
    assert s["intensity"] == [2, 2, 2] and math.isclose(s["cutoff_angle"], math.radians(40))
    assert math.isclose(s["beam_width"], math.radians(30))  # Mitsuba's default: 3/4 of the cutoff
    s = relight_cli.parse_light("point: pos=1,2,3 ; intensity=0.1,0.2,0.3")
    assert s["kind"] == 0 and s["position"] == [1, 2, 3] and s["intensity"] == [0.1, 0.2, 0.3]
    s = relight_cli.parse_light({"type": "directional", "dir": [0, 0, -3], "intensity": 2})
    assert s["kind"] == 2 and s["direction"] == [0, 0, -1] and s["intensity"] == [2, 2, 2]


@pytest.mark.parametrize("spec,msg", [
    ("spot:pos=0,1,0", "exactly one of target"),
    ("spot:pos=0,1,0;target=0,1,0", "zero length"),
    ("spot:pos=0,1;target=0,0,0", "pos needs 3"),
    ("spot:pos=0,1,0;target=0,0,0;intensity=nan", "finite"),
    ("spot:pos=0,1,0;target=0,0,0;cutoff=200", "cutoff"),
    ("spot:pos=0,1,0;target=0,0,0;cutoff=20;beam=30", "beam"),
    ("point:pos=0,1,0;intensity=-1", ">= 0"),
    ("point:intensity=1", "pos=x,y,z is required"),
    ("point:pos=a,b,c", "not a number"),
    ("point:pos=0,0,0;colour=1", "unknown key(s) colour"),
    ("area:pos=0,0,0", "unknown kind 'area'"),
    ("pos=0,0,0", "KIND:key=value"),
    ("point:pos=0,0,0;pos=1,1,1", "given twice"),
    ("point:pos", "not key=value"),
])
def test_bad_light_specs_name_the_problem(spec, msg, tmp_path, capsys):
    with pytest.raises(ValueError, match=__import__("re").escape(msg)):
        relight_cli.parse_light(spec)
    # On the command line: exit status 1 and the message, before any precomputation; nothing written.
    out = tmp_path / "out"
    assert main(["relight", str(BOX), *OPTS, "--light", spec, "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert "error:" in err and msg in err and spec in err
    assert not out.exists()


def test_bad_command_lines(tmp_path, capsys):
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    empty = tmp_path / "empty.json"
    empty.write_text("[]")
    for argv, msg in [(["--lights", str(bad)], "not JSON"), (["--lights", str(empty)], "non-empty JSON list"),
                      (["--lights", str(tmp_path / "missing.json")], "missing.json"),
                      (["--save", "a.npz", "--load", "b.npz"], "not both"),
                      (["--load", str(tmp_path / "absent.npz")], "absent.npz"),
                      (["--gather", "32"], "power of 4")]:
        assert main(["relight", str(BOX), "--res", "16", "--out", str(tmp_path / "o"), *argv]) == 1, argv
        err = capsys.readouterr().err
        assert msg in err, (argv, err)
    assert not (tmp_path / "o").exists()


def test_module_entry_point_runs(tmp_path):
    """``python -m manylights relight`` as a user types it (a child process; progress as log lines)."""
    r = subprocess.run([sys.executable, "-m", "manylights", "relight", str(BOX), *OPTS, "--light", POINT,
                        "--out", str(tmp_path)], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "relight" in r.stderr and (tmp_path / "light_000.exr").is_file() and (tmp_path / "light_000.png").is_file()
