"""The wheel works on its own: installed into a fresh virtual environment, outside the repository, it
imports, finds its bundled scenes (``scene_path("cbox")``) and renders the quick start; it carries the
licences and not the test-only scenes.

``make test`` builds the wheel once (``make wheel``: ``maturin build --release`` into ``target/wheel-test``,
reusing the release build of the cargo target) and passes it as ``MANYLIGHTS_WHEEL``; without that variable
this test builds it the same way (seconds when the cargo target is warm).
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from conftest import REPO

QUICK_START = r"""
import json, sys
import numpy as np
import manylights as ml
from manylights.scenes import available, scene_path

p = scene_path("cbox")
scene = ml.load_scene(p, res=16)
lights = ml.generate_lights(scene, area=64)
img = ml.render_brute_force(scene, lights, device="cpu", progress=False)
print(json.dumps({"module": ml.__file__, "scene": str(p), "available": available(), "shape": list(img.shape),
                  "mean": float(np.mean(img)), "finite": bool(np.isfinite(img).all()), "lights": len(lights)}))
"""


def _wheel(tmp_path_factory) -> Path:
    given = os.environ.get("MANYLIGHTS_WHEEL")
    if given:
        return Path(given)
    maturin = shutil.which("maturin") or str(Path(sys.executable).parent / "maturin")
    out = tmp_path_factory.mktemp("wheel")
    r = subprocess.run([maturin, "build", "--release", "-q", "-o", str(out), "-i", sys.executable], cwd=REPO,
                       capture_output=True, text=True, timeout=3600)
    assert r.returncode == 0, r.stderr[-3000:]
    return next(out.glob("manylights-*.whl"))


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    w = _wheel(tmp_path_factory)
    assert w.is_file(), w
    return w


def test_wheel_contents(wheel):
    names = zipfile.ZipFile(wheel).namelist()
    scenes = {n.split("/")[2] for n in names if n.startswith("manylights/scenes_data/") and n.count("/") >= 3}
    assert scenes == {"bounce", "cbox", "cbox-lights", "demo", "veach-ajar", "window-room"}, scenes
    for name in scenes:
        assert f"manylights/scenes_data/{name}/SOURCE.txt" in names
        assert f"manylights/scenes_data/{name}/scene.xml" in names
    licences = sorted(n.split("/licenses/", 1)[1] for n in names if "/licenses/" in n)
    assert licences == ["LICENSE", "licenses/THIRD-PARTY-embree-tbb.txt", "scenes/LICENSE-mitsuba3-BSD3.txt",
                        "scenes/veach-ajar/LICENSE.txt"], licences
    # only the package: no test data, no top-level folders other than the package, its metadata and (a build
    # with the embree feature) the shared libraries maturin copied in, Embree's and TBB's
    assert not [n for n in names if "bunny" in n or "matpreview" in n or "tests/" in n]
    libs = sorted(n.split("/", 1)[1].split("-")[0] for n in names if n.startswith("manylights.libs/"))
    assert libs in ([], ["libembree3", "libtbb"]), libs
    assert {n.split("/")[0] for n in names} - {"manylights.libs"} == {
        "manylights", next(n.split("/")[0] for n in names if n.split("/")[0].endswith(".dist-info"))}
    meta = next(n for n in names if n.endswith(".dist-info/METADATA"))
    text = zipfile.ZipFile(wheel).read(meta).decode()
    assert "License-Expression: MIT" in text, text[:800]


def test_wheel_quick_start_in_fresh_venv(wheel, tmp_path):
    """pip installs the wheel (without its dependencies) into a new venv; numpy and tqdm come from this
    interpreter's site-packages through a .pth file, which Python reads after the venv's own packages, so
    ``import manylights`` is the installed wheel's (checked), run from a folder outside the repository."""
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True, timeout=120)
    py = venv / "bin" / "python"
    r = subprocess.run([sys.executable, "-m", "pip", "--python", str(py), "install", "-q", "--no-deps", "--no-index",
                        str(wheel)], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    site = subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                          capture_output=True, text=True, check=True).stdout.strip()
    import numpy
    import tqdm
    deps = sorted({str(Path(m.__file__).resolve().parents[1]) for m in (numpy, tqdm)})
    (Path(site) / "zz_deps.pth").write_text("\n".join(deps) + "\n")
    work = tmp_path / "elsewhere"
    work.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    r = subprocess.run([str(py), "-c", QUICK_START], cwd=work, env=env, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    out = json.loads(r.stdout.strip().splitlines()[-1])
    assert Path(out["module"]).resolve().is_relative_to(venv.resolve()), out["module"]
    assert Path(out["scene"]).resolve().is_relative_to(venv.resolve()), out["scene"]
    assert out["available"] == ["bounce", "cbox", "cbox-lights", "demo", "veach-ajar", "window-room"]
    assert out["shape"] == [16, 16, 3] and out["finite"] and out["lights"] >= 64
    # the lit Cornell box: a mean well above zero (the full-size brute force has mean ~0.3)
    assert 0.05 < out["mean"] < 2.0, out["mean"]
