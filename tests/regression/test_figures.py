"""Regression guard for every figure that does not depend on timing (tests/regression/README.md).

``figures.py`` recomputes ~110 figures -- relative L2 errors against brute force or the stored Mitsuba
references, the error estimates renderers report, exact counts -- for fixed cases (scene, size, light
counts, method, budget, seed) and this test compares them with ``figures.json``. A change that moves a
figure fails here with every moved figure listed (case, figure, stored, now, tolerance); if the move is
intended, regenerate the file in the same commit::

    python tests/regression/figures.py --write        # or: make figures

Tolerances (``figures.TOLERANCES``; a figure passes when |now - stored| <= rel * |stored| + abs):

- ``cpu``: rel 1e-4 (abs 1e-9), every CPU-backend figure. Measured: generating the file in three separate
  processes, at RAYON_NUM_THREADS=1 and at 2 threads, gave the same 8 stored digits for every figure (no
  scatter at all: the CPU backend is deterministic in the seed and independent of the thread count). The
  margin allows for other CPUs (SIMD width, libm) and the 8 significant digits stored; any change of
  method, sampling or seed use moves these figures by far more (a different draw moves an MRCS error by
  percent).
- ``count``: exact (0), integers such as lights generated, rays traced, coefficients kept, rounds.
- ``roundoff``: abs 1e-5, figures that are 0 in exact arithmetic (clustered shading with one cluster per
  light and view sample against brute force, the exact relighting transfer against the dense VPL product):
  only float summation order, bounded as the tests bound the same comparisons.
- ``gpu``: rel 1e-3 (abs 1e-6), the GPU backend's figures (wgpu; Mesa lavapipe here). Measured: bit-identical
  in three processes and with LP_NUM_THREADS=1 (lavapipe's own threading); 10x looser than the CPU because
  shader arithmetic (FMA contraction, driver versions) is less pinned down than Rust's. They are compared
  only on the adapter they were stored on (the case records it): another adapter makes other shadow-map
  decisions and rounding, so there they are reported as not compared. Without any GPU adapter the GPU
  case is skipped.
- ``gpu_roundoff``: abs 1e-5, a GPU figure that is 0 in exact arithmetic (hybrid columns against the CPU's;
  tests/matrix/test_backends.py bounds GPU = CPU at 1e-5 per value).

Cases needing the shared scenes (matpreview, bunny) run wherever the rest of the suite does (conftest).
"""
from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent


def _load_figures():
    spec = importlib.util.spec_from_file_location("manylights_regression_figures", HERE / "figures.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # dataclasses look their module up
    spec.loader.exec_module(mod)
    return mod


figures = _load_figures()


def test_file_lists_every_case_and_is_in_canonical_form(tmp_path):
    """Cheap: figures.json holds exactly the cases of figures.CASES, each with its description, and is
    byte for byte what ``--write`` writes (sorted keys, 8 significant digits)."""
    stored = figures.load()
    keys = {c.key for c in figures.CASES}
    assert set(stored) == keys, (f"figures.json and figures.CASES differ: only in the file "
                                 f"{sorted(set(stored) - keys)}, only in the code {sorted(keys - set(stored))}; "
                                 f"regenerate: {figures.COMMAND}")
    for c in figures.CASES:
        assert {k: v for k, v in stored[c.key]["case"].items() if k != "adapter"} == json.loads(json.dumps(c.case)), (
            f"{c.key}: the stored case description differs from the code's; regenerate: {figures.COMMAND}")
        for name in stored[c.key]["figures"]:
            c.tolerance(name)  # every figure has a known tolerance class
    out = tmp_path / "figures.json"
    figures.write(stored, out)
    assert out.read_text() == figures.FIGURES_JSON.read_text(), f"not in canonical form; regenerate: {figures.COMMAND}"


@pytest.mark.slow
def test_figures_match_the_stored_file():
    """Recompute every figure (about a minute on 2 cores) and compare with figures.json."""
    now, skipped = figures.compute()
    stored = figures.load()
    skipped = {**skipped, **figures.other_adapter(stored, now)}
    for key, why in skipped.items():
        print(f"not compared: {key}: {why}")
    rows = figures.compare(stored, now, skipped=skipped)
    print(figures.format_table(rows))
    assert all(r[5] for r in rows), "\n" + figures.moved_message(rows)
