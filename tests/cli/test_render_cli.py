"""``python -m manylights render``: the library's default lights (every kind the scene has), ``--method``,
one flag vocabulary with the other commands (``-o/--output``, ``--res``, ``--size``, ``-D``)."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import manylights as ml
from conftest import REPO, SCENES
from manylights.cli import main
from manylights.cli import render as render_cli


def test_render_cbox_equals_brute_force_with_default_lights(tmp_path):
    """``python -m manylights render cbox`` (small: --res 32, the CPU): the lit image equals
    ``ml.render_brute_force`` with ``generate_lights``' defaults, bit for bit."""
    out = tmp_path / "cbox.exr"
    r = subprocess.run([sys.executable, "-m", "manylights", "render", "cbox", "--res", "32", "--device", "cpu",
                        "-o", str(out)], capture_output=True, text=True, cwd=tmp_path, timeout=900)
    assert r.returncode == 0, r.stderr[-3000:]
    img = ml.read_exr(out)
    scene = ml.load_scene(SCENES / "cbox" / "scene.xml", res=32)
    lights = ml.generate_lights(scene)
    assert len(lights) == 4096  # cbox: one area emitter, nothing else
    ref = ml.render_brute_force(scene, lights, device="cpu", progress=False)
    np.testing.assert_array_equal(img, ref)
    assert img.mean() > 0.05  # lit (the old default, --area 0, gave a black box: cbox has no delta light)
    assert "lights: 4096 (area 4096, environment 0, indirect 0" in r.stdout, r.stdout
    assert (tmp_path / "cbox.png").is_file()


def test_light_counts_cover_every_kind():
    box = ml.load_scene(SCENES / "cbox" / "scene.xml", res=8)
    both = ml.load_scene(SCENES / "cbox-lights" / "scene.xml", res=8)  # area + envmap + delta emitters
    assert render_cli.light_counts(box) == {"area": 4096, "environment": 0, "indirect": 0}
    assert render_cli.light_counts(both) == {"area": 4096, "environment": 4096, "indirect": 0}
    assert render_cli.light_counts(both, area=10, environment=0, indirect=5) == {"area": 10, "environment": 0,
                                                                                 "indirect": 5}


@pytest.mark.parametrize("method", ["mrcs", "render"])
def test_render_methods(tmp_path, method, capsys):
    out = tmp_path / f"{method}.exr"
    argv = ["render", "cbox", "--res", "16", "--device", "cpu", "--method", method, "--output", str(out), "--no-png"]
    argv += ["--rows", "16", "--columns", "64"] if method == "mrcs" else ["--target-error", "0.2"]
    assert main(argv) == 0
    text = capsys.readouterr().out
    img = ml.read_exr(out)
    assert img.shape == (16, 16, 3) and np.isfinite(img).all() and img.mean() > 0.05
    assert "RenderResult: " in text and "time: " in text  # the result's summary
    if method == "mrcs":
        assert "budget: rows 16, columns 64, lights 4,096" in text, text


def test_one_flag_vocabulary(tmp_path):
    """-o/--output everywhere (the older --out still parses, hidden), --res / --size / -D for scenes."""
    import argparse

    ap = argparse.ArgumentParser()
    sub = ap.add_subparsers(dest="cmd")
    from manylights.cli import COMMANDS

    for command in COMMANDS:
        command.add_parser(sub)
    for cmd in ["render cbox", "demo", "animate bounce", "relight cbox-lights"]:
        a = ap.parse_args(cmd.split() + ["-o", "x"])
        assert a.output == "x", cmd
        a = ap.parse_args(cmd.split() + ["--out", "y"])
        assert a.output == "y", cmd
    for cmd in ["render cbox", "relight cbox-lights"]:
        a = ap.parse_args(cmd.split() + ["--res", "8", "--size", "4", "3", "-D", "spp=2"])
        assert (a.res, a.size, a.params) == (8, [4, 3], ["spp=2"])
    help_text = sub.choices["animate"].format_help()
    assert "--output" in help_text and "--out " not in help_text


def test_unknown_method_is_refused():
    r = subprocess.run([sys.executable, "-m", "manylights", "render", "cbox", "--method", "fast"],
                       capture_output=True, text=True, cwd=REPO, timeout=300)
    assert r.returncode == 2 and "invalid choice: 'fast'" in r.stderr
