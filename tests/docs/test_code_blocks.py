"""Every code block of README.md and docs/**/*.md runs as written.

Each ```python block is executed on its own (a fresh namespace) in a temporary directory that holds the
repository's ``scenes/`` (as a clone has it); a block that raises fails its test.
Where a block makes a claim in its comments (a shape, an error, "the same in one call"), a check in
``CHECKS``, keyed by (file, the heading above the block), verifies it on the names the block leaves behind.

A block that cannot run here says so on its first line, visibly for readers too::

    # docs-test: skip: <why>

(docs/development/index.md documents the convention; keep such blocks to a minimum). Every command of README.md's
```sh blocks is either run the same way (cheap ones) or listed in ``NOT_RUN`` with the reason: a new command
that is neither fails the test. The ```sh blocks of docs/ are not run (benchmarks at their published sizes).
"""
from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import REPO

README = REPO / "README.md"
DOCS = REPO / "docs"
DOC_FILES = [README, *sorted(DOCS.rglob("*.md"))]
SKIP_MARKER = "# docs-test: skip:"

# Commands of README.md's ```sh blocks that the test does not run, and why. Everything else is run.
NOT_RUN = {
    "make demo": "sets up the machine and renders for minutes (make demo is run by hand and in CI)",
    "make test": "the whole test suite",
    "pip install .": "installs and builds (the test runs on that build)",
    'pip install ".[video]"': "installs (the test environment has the extra's packages)",
    'pip install ".[sweep]"': "installs (the test environment has the extra's packages)",
}


def rel(path: Path) -> str:
    return path.relative_to(REPO).as_posix()


def blocks(path: Path, lang: str) -> list[tuple[int, str]]:
    """(line number, code) of every fenced block of ``lang`` in ``path`` (indented fences included)."""
    text = path.read_text()
    out = []
    for m in re.finditer(r"^( *)```" + lang + r"\n(.*?)^\1```", text, flags=re.S | re.M):
        indent = len(m.group(1))
        code = "\n".join(line[indent:] for line in m.group(2).splitlines()) + "\n"
        out.append((text[: m.start()].count("\n") + 1, code))
    return out


def python_blocks() -> list[tuple[str, int, str]]:
    return [(rel(f), line, code) for f in DOC_FILES for line, code in blocks(f, "python")]


def sh_commands() -> list[tuple[int, str]]:
    """(line, command) of every command in README.md's ```sh blocks, comments stripped."""
    cmds = []
    for line0, code in blocks(README, "sh"):
        for k, line in enumerate(code.splitlines()):
            cmd = line.split("  #", 1)[0].split(" # ", 1)[0].strip()
            if cmd and not cmd.startswith("#"):
                cmds.append((line0 + 1 + k, cmd))
    return cmds


def heading_before(path: str, line: int) -> str:
    lines = (REPO / path).read_text().splitlines()[:line]
    return next(h.lstrip("# ").strip() for h in reversed(lines) if re.match(r"^#{1,6} ", h))


@pytest.fixture()
def clone_dir(tmp_path, monkeypatch):
    """A working directory like a fresh clone's root: scenes/ only."""
    work = tmp_path / "clone"
    work.mkdir()
    (work / "scenes").symlink_to(REPO / "scenes", target_is_directory=True)
    monkeypatch.setenv("MANYLIGHTS_PROGRESS", "off")
    monkeypatch.chdir(work)
    return work


# --- checks of what the blocks' comments claim --------------------------------------------------------------


def _check_readme_methods(ns):
    """README: every method's image is close to brute force at these tiny budgets (measured 0.8-2.1%)."""
    import manylights as ml

    ref = ns["ref"]
    assert ref.shape == (32, 32, 3) and ref.dtype == np.float32 and ref.max() > 0
    for name in ["ps", "ir", "mr", "cv", "to"]:
        err = ml.relative_l2(ns[name].image, ref)
        assert 0 < err < 0.06, (name, err)
    assert ns["to"].budget["stopped"] == "target error reached" and ns["to"].error_estimate <= 0.05


def _check_readme_tensor(ns):
    import manylights as ml

    res, T = ns["res"], ns["T"]
    assert res.frames.shape == (4, 24, 24, 3) and T.shape[2] == 4
    err = ml.relative_l2_per_frame(res.frames, T.brute_force())
    assert err.shape == (4,) and 0 < err.max() < 0.1  # measured 2.1-2.7%


def _check_readme_relight(ns):
    import manylights as ml

    img, spot = ns["img"], ns["spot"]
    assert img.shape == (32, 32, 3) and img.dtype == np.float32
    direct = ml.LightMatrix(ns["scene"], spot, device="cpu").column_sum(progress=False)
    assert img.sum() > 1.1 * direct.sum()  # the bounces add light


def _check_mrcs_block(ns):
    """The MRCS steps: shapes as its comments say, and ml.mrcs is 'the same in one call'."""
    A, R, rows, cl = ns["A"], ns["R"], ns["rows"], ns["cl"]
    m, n = A.shape
    assert R.shape == (len(rows), n, 3) and R.dtype == np.float32
    assert np.isfinite(R).all() and R.max() > 0
    assert len(cl["representatives"]) == len(cl["weights"]) <= n
    assert ns["img"].shape == (ns["scene"].height, ns["scene"].width, 3)
    # the same rows, clustering seed and reconstruction: the same image
    np.testing.assert_array_equal(ns["res"].image, ns["img"])
    assert set(ns["res"].timings) >= {"row_selection", "clustering", "columns", "emitted"}


def _check_python_block(ns):
    """The light matrix from Python: G-buffer keys, column shapes, and the error it prints (0 on the CPU)."""
    h, w = ns["scene"].height, ns["scene"].width
    assert {"position", "normal", "geo_normal", "albedo", "uv", "shape_index"} <= set(ns["gb"])
    assert ns["A"].shape == (h * w, len(ns["lights"]))
    assert ns["cols"].shape == (2, h, w, 3) and ns["cols"].dtype == np.float32
    assert Path("out.exr").is_file() and Path("out.png").is_file()
    import manylights as ml

    err = ml.relative_l2(ml.read_exr("out.exr"), ns["ref"])
    assert ns["img"].max() > 0
    if ns["A"].device["kind"] == "cpu":  # the oracle is the CPU backend's own arithmetic
        assert err == 0.0, f"the page says 0 on the CPU backend, got {err:.2e}"
    assert err < 1e-6, f"the page says ~1e-8 on a GPU, got {err:.2e}"


def _check_own_lights_block(ns):
    """Own light sets: two point lights from arrays, the VPLs by a boolean mask, concatenated; the image
    equals the sum of the two sets' images (columns add up)."""
    import manylights as ml

    pts, vpls, lights = ns["pts"], ns["vpls"], ns["lights"]
    assert len(pts) == 2 and list(pts.kind) == [0, 0]
    assert len(vpls) == int((lights.kind == 4).sum()) > 0 and set(vpls.kind) == {4}
    assert ns["img"].shape == (32, 32, 3) and ns["img"].max() > 0
    parts = sum(ml.LightMatrix(ns["scene"], s).column_sum(progress=False) for s in (pts, vpls))
    assert ml.relative_l2(ns["img"], parts) < 1e-5


def _check_backends_block(ns):
    """Two backends: the same MRCS image on the CPU and the GPU to float noise, each reporting itself."""
    import manylights as ml

    a, b = ns["a"], ns["b"]
    assert ns["A"].device["kind"] == a.device["kind"] == "cpu" and b.device["kind"] == "gpu"
    np.testing.assert_array_equal(a.representatives, b.representatives)
    err = ml.relative_l2(a.image, b.image)
    assert a.image.max() > 0 and err < 1e-6, f"the page says ~3e-8, got {err:.2e}"


def _check_animation_block(ns):
    """Tensor clustering: shapes, the frames' lights are the same lights, files written, and the printed
    error and flicker are those of the result against brute force."""
    import manylights as ml

    T, res, ref, per = ns["T"], ns["res"], ns["ref"], ns["per"]
    m, n, f = T.shape
    assert (m, f) == (32 * 32, 4) and len(ns["lights"]) == f and ns["lights"].n == n
    assert res.frames.shape == ref.shape == per.frames.shape == (4, 32, 32, 3)
    assert len(list(Path("out/anim").glob("frame_*.exr"))) == 4 and Path("out/anim.gif").is_file()
    err = ml.relative_l2_per_frame(res.frames, ref).mean()
    assert 0 < err < 0.2 and np.mean(res.shadow_maps_per_frame) == 64 + 100
    assert set(res.timings) >= {"slices", "clustering", "mappings", "columns", "reconstruction"}


def _check_relight_block(ns):
    """Relighting: the image shape, the bounces add light to the direct image, culling changes little, and
    the loaded precomputation relights bit-identically."""
    import manylights as ml

    rel, back, spot, scene = ns["rel"], ns["back"], ns["spot"], ns["scene"]
    img = rel.relight(spot)
    assert img.shape == (64, 64, 3) and img.dtype == np.float32
    direct = ml.LightMatrix(scene, spot, device="cpu").column_sum(progress=False)
    assert img.sum() > 1.1 * direct.sum()  # indirect light is there
    assert 0 < ml.relative_l2(ns["img"], img) < 0.05  # measured 5e-4
    rel.relight(spot, epsilon=1e-3)
    assert rel.stats["wavelet_lights_culled"] > 0
    np.testing.assert_array_equal(back.relight(spot), img)
    assert rel.stats["bounces"] == 3 and Path("cbox-lights.npz").is_file()


def _check_clustered_block(ns):
    """Clustered visibility: the error printed is that of the result against brute force, the rays are one
    per pair of representatives, K-means ran on the view samples."""
    import manylights as ml

    res, ref, km = ns["res"], ns["ref"], ns["km"]
    err = ml.relative_l2(res.image, ref)
    assert 1e-3 < err < 0.01, f"the page says 0.5%, got {err:.4f}"
    assert res.budget["rays"] == res.budget["light_clusters"] * 500 == 109_500
    assert km.centroids.shape == (50, 3) and {"light_clustering", "view_clustering", "visibility"} <= set(res.timings)


def _check_sweep_block(ns):
    """Sweeps: every (scene, method, budget, seed) once, all rendered, errors against the references."""
    df = ns["df"]
    assert len(df) == 2 * 2 * 2 * 2 and (df["status"] == "ok").all()
    assert df[["scene", "method", "rows", "columns", "seed"]].drop_duplicates().shape[0] == 16
    assert (df["rel_l2"] > 0).all() and (df["rel_l2"] < 0.2).all()
    assert Path("sweep.parquet").is_file()


def _check_adaptive_block(ns):
    """Error estimates, progressive MRCS and budgets: the estimate within 2x of the true error, the
    progressive rounds' budgets as commented, the target reached by the estimate and the truth."""
    import manylights as ml

    A, res, best = ns["A"], ns["res"], ns["best"]
    truth = A.column_sum(progress=False) + A.emitted()
    true = ml.relative_l2(res.image, truth)
    assert 0.5 * true <= res.error_estimate <= 2 * true, (res.error_estimate, true)
    assert res.error_image.shape == (32, 32) and ns["r"].budget["columns"] == 496
    assert best.budget["stopped"] == "target error reached" and best.error_estimate <= 0.05
    assert ml.relative_l2(best.image, truth) <= 0.1
    # The scene path: cbox has an area light and no environment, its path integrator asks for VPLs.
    counts = ns["auto"].budget["light_counts"]
    assert counts["area"]["count"] >= 256 and counts["indirect"]["count"] >= 256
    assert counts["environment"]["count"] == 0
    # Clamped VPLs, a known bias, listed unless the compensated model was chosen: the claim rests on the
    # probes' upper bound (variance and bias).
    auto = ns["auto"]
    compensated = auto.budget["light_model"]["chosen"] == "VPLs + bias compensation"
    assert [s["source"] for s in auto.bias_sources] == ([] if compensated else ["vpl_clamp"])
    assert auto.budget["probes"]["probes"] == 256
    assert auto.budget["target_reached"] is (auto.budget["probes"]["reliable"] and auto.error_estimate <= 0.05)


CHECKS = {
    ("README.md", "The methods in a few lines"): _check_readme_methods,
    ("README.md", "The methods in a few lines#2"): _check_readme_tensor,
    ("README.md", "The methods in a few lines#3"): _check_readme_relight,
    ("docs/guide/mrcs.md", "The steps one by one"): _check_mrcs_block,
    ("docs/guide/light-matrix.md", "The light matrix from Python"): _check_python_block,
    ("docs/guide/light-matrix.md", "Your own lights"): _check_own_lights_block,
    ("docs/guide/backends.md", "Two backends: CPU and GPU"): _check_backends_block,
    ("docs/guide/tensor-clustering.md", "Animations: tensor clustering"): _check_animation_block,
    ("docs/guide/relighting.md", "Relighting: direct-to-indirect transfer"): _check_relight_block,
    ("docs/guide/clustered-visibility.md", "Clustered visibility: GPU fuzzy K-means"): _check_clustered_block,
    ("docs/guide/sweeps.md", "Sweeps on Dask"): _check_sweep_block,
    ("docs/guide/render-to-target.md", "Rendering to a target error"): _check_adaptive_block,
}


def _block_key(path: str, line: int) -> tuple[str, str]:
    """(file, heading) of the block, with '#k' for the k-th block (k >= 2) under the same heading."""
    heading = heading_before(path, line)
    same = [ln for f, ln, _ in python_blocks() if f == path and ln <= line and heading_before(f, ln) == heading]
    return (path, heading if len(same) == 1 else f"{heading}#{len(same)}")


def test_docs_have_blocks():
    files = {f for f, _, _ in python_blocks()}
    assert "README.md" in files and len(files) >= 8, files
    assert len(sh_commands()) >= 5


def test_checks_match_blocks():
    """Every check names a block that exists (a renamed heading would silently drop its check)."""
    keys = {_block_key(f, ln) for f, ln, _ in python_blocks()}
    assert set(CHECKS) <= keys, set(CHECKS) - keys


def test_skips_are_few():
    skipped = [f"{f}:{ln}" for f, ln, code in python_blocks() if code.lstrip().startswith(SKIP_MARKER)]
    assert len(skipped) <= 2, f"blocks marked to skip: {skipped}"


@pytest.mark.parametrize("path,line,code", python_blocks(), ids=lambda v: v if isinstance(v, str) and len(v) < 60
                         else (f"line{v}" if isinstance(v, int) else ""))
def test_python_block(path, line, code, clone_dir):
    if code.lstrip().startswith(SKIP_MARKER):
        pytest.skip(code.lstrip().splitlines()[0])
    ns = {"__name__": "__main__"}  # blocks written as scripts run their main guard
    exec(compile(code, f"{path}:{line}", "exec"), ns)
    check = CHECKS.get(_block_key(path, line))
    if check is not None:
        check(ns)


def _run_cmd(cmd: str, cwd: Path) -> subprocess.CompletedProcess:
    argv = shlex.split(cmd)
    assert argv[0] == "python", f"a cheap README command should start with python: {cmd!r}"
    argv[0] = sys.executable
    return subprocess.run(argv, cwd=cwd, capture_output=True, text=True, timeout=300, env=os.environ.copy())


@pytest.mark.parametrize("line,cmd", sh_commands(), ids=lambda v: f"line{v}" if isinstance(v, int) else "")
def test_readme_sh_command(line, cmd, clone_dir):
    if cmd in NOT_RUN:
        pytest.skip(f"README.md:{line} `{cmd}` not run: {NOT_RUN[cmd]}")
    r = _run_cmd(cmd, clone_dir)
    assert r.returncode == 0, f"README.md:{line} `{cmd}` failed:\n{r.stdout[-2000:]}\n{r.stderr[-4000:]}"
    argv = shlex.split(cmd)
    # What each command says it writes is there and holds an image of the asked size.
    if "-o" in argv:
        import manylights as ml

        out = clone_dir / argv[argv.index("-o") + 1]
        img = ml.read_exr(out)
        assert out.with_suffix(".png").is_file()
        size = ([int(argv[argv.index("--size") + 1])] * 2 if "--size" in argv else [64, 64])
        assert img.shape == (size[1], size[0], 3) and np.isfinite(img).all() and img.max() > 0
    if argv[1:] == ["-m", "manylights", "info"]:
        assert "backend:" in r.stdout


def test_not_run_commands_are_in_readme():
    """NOT_RUN lists only commands the README has (a stale entry would hide nothing)."""
    cmds = {c for _, c in sh_commands()}
    assert set(NOT_RUN) <= cmds, set(NOT_RUN) - cmds


def test_readme_is_short():
    assert len(README.read_text().splitlines()) <= 250


def test_every_chart_is_on_a_page():
    """Every chart under docs/bench/ is shown on a docs page, and every image a page shows exists."""
    pages = {f: f.read_text() for f in DOC_FILES}
    shown = set()
    for f, text in pages.items():
        for m in re.finditer(r"!\[[^\]]*\]\(([^)]+\.png)\)", text):
            target = (f.parent / m.group(1)).resolve()
            assert target.is_file(), f"{rel(f)} shows {m.group(1)}, which does not exist"
            shown.add(target)
    charts = {p.resolve() for p in (DOCS / "bench").glob("*.png")}
    assert charts <= shown, sorted(rel(p) for p in charts - shown)


def test_no_issue_numbers():
    """Issue numbers belong to the tracker, not to the product: none in the docs, the code, the tests or the
    test scenes."""
    pattern = re.compile(r"\bissues? ?#?\d+|\(#\d+\)", re.I)
    files = [*DOC_FILES, *(REPO / "python").rglob("*.py"), *(REPO / "python").rglob("*.pyi"),
             *(REPO / "src").rglob("*.rs"), *(REPO / "shaders").rglob("*.wgsl"), *(REPO / "tests").rglob("*.py"),
             *(REPO / "tests" / "data").glob("*.xml"),
             *(REPO / "notebooks").glob("*.ipynb"), *(REPO / "scripts").glob("*.py")]
    bad = []
    for f in files:
        for k, line in enumerate(f.read_text(errors="replace").splitlines(), 1):
            if pattern.search(line):
                bad.append(f"{rel(f)}:{k}: {line.strip()[:100]}")
    assert not bad, bad
