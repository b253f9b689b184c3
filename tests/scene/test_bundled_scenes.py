"""A clone runs alone: every scene the README, the notebooks, the CLI and the benchmarks name is bundled
in scenes/ with its source and licence, found relative to the package; the scenes only the tests read are
in tests/data/scenes with theirs; nothing looks beside the checkout or at an absolute machine path.

The subprocess runs here start from a temporary working directory.
"""
from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import nbformat
import pytest

from conftest import REPO, TEST_SCENES
from manylights.bench import lights as bench_lights
from manylights.scenes import SCENES_DIR, animated, available, resolve, scene_path

PRODUCT_FILES = sorted(
    [*(REPO / "python" / "manylights").rglob("*.py"), *(REPO / "notebooks").glob("*.ipynb"), REPO / "Makefile",
     *(REPO / "scripts").glob("*"), REPO / "README.md", REPO / "pyproject.toml"]
)
NOTEBOOKS = sorted((REPO / "notebooks").glob("*.ipynb"))


def named_scenes() -> dict[str, set[str]]:
    """Bundled scene names, each with where it is named (README, notebooks, CLI, benchmarks)."""
    names: dict[str, set[str]] = {}

    def add(name, where):
        names.setdefault(name, set()).add(where)

    readme = (REPO / "README.md").read_text()
    for m in re.finditer(r"scenes/([\w.-]+)/", readme):
        add(m.group(1), "README")
    for m in re.finditer(r"--scene ([\w.-]+)", readme):
        add(m.group(1), "README")
    for m in re.finditer(r"manylights render ([\w.-]+) ", readme):
        if not m.group(1).startswith("scenes"):
            add(m.group(1), "README")
    for nb in NOTEBOOKS:
        for m in re.finditer(r'scene_path\(\\?"([\w.-]+)\\?"\)', nb.read_text()):
            add(m.group(1), nb.name)
    for name, (bundled, _, _) in bench_lights.LIGHT_SCENES.items():
        add(bundled, "bench lights")
    add("demo", "CLI demo")
    for name in animated():
        add(name, "animation_frames")
    return names


def test_named_scenes_are_bundled_with_source_and_licence():
    names = named_scenes()
    assert {"demo", "cbox", "cbox-lights", "veach-ajar"} <= set(names), names
    for name, where in names.items():
        folder = SCENES_DIR / name
        assert (folder / "scene.xml").is_file(), f"scene {name!r} named by {sorted(where)} is not bundled"
        source = (folder / "SOURCE.txt").read_text()
        assert "Source:" in source and ("licen" in source.lower()), f"{name}/SOURCE.txt names no source or licence"
    # the licences that SOURCE.txt files point to are there
    assert "Redistribution and use" in (SCENES_DIR / "LICENSE-mitsuba3-BSD3.txt").read_text()
    assert "CC0" in (SCENES_DIR / "veach-ajar" / "LICENSE.txt").read_text()
    # only what is named is bundled (the repository stays small)
    assert set(available()) == set(names)
    size = sum(p.stat().st_size for p in SCENES_DIR.rglob("*") if p.is_file())
    assert size < 4 * 2**20, f"scenes/ holds {size / 2**20:.1f} MiB"


def test_test_scenes_ship_with_source_and_licence():
    """The scenes only the tests read (tests/data/scenes) are in the repository, each with its source and
    licence, and every file their XML names is there (a clone tests itself with nothing beside it)."""
    names = sorted(p.name for p in TEST_SCENES.iterdir() if p.is_dir())
    assert names == ["bunny", "living-room", "matpreview"], names
    for name in names:
        folder = TEST_SCENES / name
        source = (folder / "SOURCE.txt").read_text()
        assert "Source:" in source and "licen" in source.lower(), f"{name}/SOURCE.txt names no source or licence"
        xml = (folder / "scene.xml").read_text()
        files = re.findall(r'name="filename" value="([^"]+)"', xml)
        assert len(files) >= 3, (name, files)
        for f in files:
            assert (folder / f).is_file(), f"{name}/scene.xml names {f}, which is not in the repository"
    assert "Stanford" in (TEST_SCENES / "bunny" / "LICENSE.txt").read_text()
    assert "CC-BY" in (TEST_SCENES / "living-room" / "LICENSE.txt").read_text()
    # The public interior (5.2 MiB, 65 meshes) is most of it.
    size = sum(p.stat().st_size for p in TEST_SCENES.rglob("*") if p.is_file())
    assert size < 10 * 2**20, f"tests/data/scenes holds {size / 2**20:.1f} MiB"


def test_nothing_looks_beside_the_checkout():
    """No test, test helper, build file or module comment reads or names a folder beside the checkout
    (the old ../shared) or an environment variable pointing to one."""
    files = [*(REPO / "src").rglob("*.rs"), *(REPO / "tests").rglob("*.py"), *(REPO / "python").rglob("*.py"),
             *(REPO / "fuzz").glob("*.py"), REPO / "Makefile", *(REPO / ".ci").glob("*"), REPO / "Cargo.toml",
             REPO / "pyproject.toml"]
    me = Path(__file__).resolve()
    bad = []
    for f in files:
        if f.resolve() == me or not f.is_file():
            continue
        for k, line in enumerate(f.read_text(errors="replace").splitlines(), 1):
            if re.search(r"\.\./shared|MANYLIGHTS_SHARED|parent / \"shared\"|shared/(docs|seeds|scenes)", line):
                bad.append(f"{f.relative_to(REPO)}:{k}: {line.strip()}")
    assert not bad, bad


def test_scene_path_and_resolve():
    p = scene_path("cbox")
    assert p == SCENES_DIR / "cbox" / "scene.xml" and p.is_file()
    assert resolve("cbox") == p and resolve(str(p)) == p
    for bad in ["nope", "", "..", "../scenes/cbox", "cbox/scene.xml"]:
        with pytest.raises(FileNotFoundError, match="bundled scene"):
            scene_path(bad)
    with pytest.raises(FileNotFoundError, match="neither a file nor a bundled scene"):
        resolve("nope.xml")
    with pytest.raises(TypeError, match="string"):
        scene_path(3)


def test_no_shared_lookup_in_product():
    """No absolute machine path and no ../shared lookup anywhere in the product (tests may use them)."""
    bad = []
    for f in PRODUCT_FILES:
        if not f.is_file():
            continue
        text = f.read_text(errors="replace")
        for pat in [r"/work\b", r"/home/", r"/root/", r"/tmp/", r"MANYLIGHTS_SHARED", r"[\"'/]shared[\"'/]"]:
            for m in re.finditer(pat, text):
                line = text[: m.start()].count("\n") + 1
                if f.name == "Makefile" and pat == r"/tmp/":
                    continue  # XDG_RUNTIME_DIR default, not a data path
                if f.name == "mitsuba.py" and "shared/docs" in text.splitlines()[line - 1]:
                    continue  # a docstring citing the conventions document
                bad.append(f"{f.relative_to(REPO)}:{line}: {m.group(0)}")
    assert not bad, bad


def _hidden_env(tmp_path: Path) -> dict:
    env = os.environ.copy()
    env.update(MPLBACKEND="Agg", MANYLIGHTS_NB_RES="16", MANYLIGHTS_NB_LIGHTS="64")
    return env


def test_named_scenes_load_from_elsewhere(tmp_path):
    """From another working directory, every named scene loads by name."""
    names = sorted(named_scenes())
    code = ("import json, manylights as ml\nfrom manylights.scenes import scene_path\nout = {}\n"
            f"for n in {names!r}:\n"
            "    s = ml.load_scene(scene_path(n), size=(8, 8))\n"
            "    out[n] = [len(s.shapes), len(s.emitters)]\n"
            "print(json.dumps(out))\n")
    r = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=_hidden_env(tmp_path), capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-3000:]
    counts = json.loads(r.stdout.strip().splitlines()[-1])
    # shapes / emitters as the files declare them
    assert counts["cbox"][1] == 1 and counts["veach-ajar"][1] == 1
    assert counts["cbox-lights"][1] == 5 and counts["demo"][1] == 4
    assert all(c[0] > 0 for c in counts.values())


def test_notebooks_scene_lookup_from_elsewhere(tmp_path):
    """Each notebook's code up to and including its first scene load runs from a temporary folder
    (small sizes via the notebooks' own environment knobs)."""
    for nb_path in NOTEBOOKS:
        nb = nbformat.read(nb_path, as_version=4)
        cells = [c.source for c in nb.cells if c.cell_type == "code"]
        upto = next(k for k, src in enumerate(cells) if "scene_path(" in src)
        code = "\n".join(cells[: upto + 1]) + "\nprint('SCENE', scene.width, scene.height)\n"
        r = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=_hidden_env(tmp_path),
                           capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, f"{nb_path.name}: {r.stderr[-3000:]}"
        assert "SCENE 16 16" in r.stdout, r.stdout[-1000:]


def test_tiny_lights_benchmark_from_elsewhere(tmp_path):
    """``python -m manylights.bench lights`` at a tiny size, from elsewhere: it finds the
    bundled cbox, compares with the stored reference and writes its JSON. (The tiny MRCS benchmark runs in
    test_readme.py, the same way.)"""
    out = tmp_path / "bench"
    r = subprocess.run([sys.executable, "-m", "manylights.bench", "lights", "--scene", "cbox", "--lights", "20",
                        "--area", "10", "--sweep", "--seeds", "1", "--engine", "oracle", "--no-clamp-sweep",
                        "-o", str(out)], cwd=tmp_path, env=_hidden_env(tmp_path), capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, r.stderr[-3000:]
    runs = json.loads((out / "lights.json").read_text())
    assert [(x["area"], x["indirect"], x["clamp"]) for x in runs] == [(10, 10, "default"), (10, 10, "off")]
    for x in runs:
        # 21 lights against full GI: a coarse but finite estimate of the right image
        assert x["nan_pixels"] == 0 and 0.0 < x["relative_l2"] < 0.25 and 0.8 < x["mean_ratio"] < 1.2
