"""The figures the project reports that do not depend on timing, at fixed scenes, sizes, light counts,
budgets and seeds: relative L2 errors against brute force (the exact column sum) or against the stored
Mitsuba references in tests/references, the error estimates renderers report, and a few exact counts.

    python tests/regression/figures.py --write     # recompute and rewrite figures.json (make figures)
    python tests/regression/figures.py --check     # recompute and compare: a table, exit 1 on a mismatch
    python tests/regression/figures.py --print     # recompute and print, compare nothing

Only the public API (``import manylights as ml``, ``ml.scenes``) is used, so the files survive moves inside
the package; besides it, the Mitsuba references (tests/references), tests/data and the shared scenes (found
as tests/conftest.py finds them). Everything runs on the CPU backend (``device="cpu"``, exact rays) unless a case says "gpu".
Tolerances (``TOLERANCES``, per figure class) are stated and justified in test_figures.py and README.md.
The cases (``CASES``, ``TOLERANCES``) are in figure_cases.py, the computations behind them in
figure_functions.py; this file runs them, stores and compares their figures.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
if str(HERE) not in sys.path:  # figure_cases.py and figure_functions.py sit beside this file
    sys.path.insert(0, str(HERE))

from figure_cases import CASES, TOLERANCES, Case  # noqa: E402
from figure_functions import gpu_adapter, gpu_available  # noqa: E402

FIGURES_JSON = HERE / "figures.json"
COMMAND = "python tests/regression/figures.py --write"

__all__ = ["CASES", "COMMAND", "FIGURES_JSON", "TOLERANCES", "Case", "compare", "compute",
           "format_table", "load", "main", "moved_message", "other_adapter", "write"]


def skip_reason(case: Case):
    """Why ``case`` cannot run on this machine (None: it can)."""
    if case.requires == "gpu" and not gpu_available():
        return "no GPU adapter (ml.device_info('gpu') raised GpuUnavailableError)"
    return None


def compute(cases=None, log=print) -> tuple:
    """({case key: {"case": description, "figures": {name: number}}}, {case key: why skipped}) for
    ``cases`` (default all)."""
    cases = CASES if cases is None else cases
    out, skipped = {}, {}
    t_all = time.perf_counter()
    for i, c in enumerate(cases, 1):
        why = skip_reason(c)
        if why:
            skipped[c.key] = why
            log(f"[{i:2d}/{len(cases)}] {c.key}: SKIPPED ({why})")
            continue
        t = time.perf_counter()
        figs = c.compute()
        case = dict(c.case, adapter=gpu_adapter()) if c.requires == "gpu" else c.case
        out[c.key] = {"case": case, "figures": {k: _round(v) for k, v in sorted(figs.items())}}
        log(f"[{i:2d}/{len(cases)}] {c.key}: {len(figs)} figures, {time.perf_counter() - t:.1f} s")
    log(f"computed {sum(len(v['figures']) for v in out.values())} figures of {len(out)} cases in "
        f"{time.perf_counter() - t_all:.1f} s" + (f"; {len(skipped)} skipped" if skipped else ""))
    return out, skipped


def _round(v):
    """Integers stay integers; floats keep 8 significant digits."""
    if isinstance(v, (bool, np.bool_)):
        raise TypeError("figures are numbers, not bools")
    if isinstance(v, (int, np.integer)):
        return int(v)
    v = float(v)
    if not math.isfinite(v):
        raise ValueError(f"figure is not finite: {v}")
    return float(f"{v:.8g}")


def write(figures: dict, path: Path = FIGURES_JSON) -> None:
    doc = {"about": "Timing-independent figures of manylights (tests/regression/README.md). Regenerate with: "
                    + COMMAND,
           "cases": figures}
    path.write_text(json.dumps(doc, indent=1, sort_keys=True) + "\n")


def load(path: Path = FIGURES_JSON) -> dict:
    return json.loads(path.read_text())["cases"]


def other_adapter(stored: dict, now: dict) -> dict:
    """{case key: why} for the GPU cases computed here on another adapter than the stored figures' (their
    figures are those of that adapter's arithmetic and shadow-map decisions: not compared)."""
    out = {}
    for key, v in now.items():
        a, b = stored.get(key, {}).get("case", {}).get("adapter"), v["case"].get("adapter")
        if a is not None and b is not None and a != b:
            out[key] = f"stored on GPU adapter {a!r}, this machine has {b!r}: not compared"
    return out


def compare(stored: dict, now: dict, cases=None, skipped=()) -> list:
    """Rows (key, figure, stored, now, tolerance, ok) for every figure of either side, except the cases in
    ``skipped`` (not run here); a figure on one side only does not pass."""
    cases = {c.key: c for c in (CASES if cases is None else cases)}
    rows = []
    for key in sorted((set(stored) | set(now)) - set(skipped)):
        s = stored.get(key, {}).get("figures", {})
        n = now.get(key, {}).get("figures", {})
        for name in sorted(set(s) | set(n)):
            a, b = s.get(name), n.get(name)
            tol = cases[key].tolerance(name) if key in cases else {"rel": 0.0, "abs": 0.0}
            ok = a is not None and b is not None and abs(b - a) <= tol["rel"] * abs(a) + tol["abs"]
            rows.append((key, name, a, b, tol, ok))
    return rows


def moved_message(rows) -> str:
    """The figures that moved beyond their tolerance and what to do about it."""
    moved = [r for r in rows if not r[5]]
    lines = [f"{len(moved)} of {len(rows)} figures moved beyond their tolerance (|now - stored| > rel * |stored| "
             f"+ abs):"]
    for key, name, a, b, tol, _ in moved:
        lines.append(f"  {key} / {name}: stored {_fmt(a)}, now {_fmt(b)}, tolerance rel {tol['rel']:g} abs "
                     f"{tol['abs']:g}")
    lines.append(f"If the change is intended, regenerate the file in the same commit: {COMMAND} "
                 f"(or make figures) and commit tests/regression/figures.json.")
    return "\n".join(lines)


def _fmt(v) -> str:
    return "-" if v is None else (str(v) if isinstance(v, int) else f"{v:.8g}")


def format_table(rows, only_failures: bool = False) -> str:
    lines = [f"{'case / figure':70s} {'stored':>14s} {'now':>14s} {'rel diff':>9s} {'tolerance':>17s}"]
    for key, name, a, b, tol, ok in rows:
        if only_failures and ok:
            continue
        if a is None or b is None:
            diff = "missing"
        else:
            diff = f"{abs(b - a) / abs(a):.1e}" if a else f"{abs(b - a):.1e}a"
        t = f"rel {tol['rel']:.0e} abs {tol['abs']:.0e}"
        lines.append(f"{key + ' / ' + name:70s} {_fmt(a):>14s} {_fmt(b):>14s} {diff:>9s} {t:>17s}"
                     f"{'' if ok else '  MOVED'}")
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    g = p.add_mutually_exclusive_group(required=True)
    g.add_argument("--write", action="store_true", help=f"recompute and rewrite {FIGURES_JSON.name}")
    g.add_argument("--check", action="store_true", help="recompute and compare with the file (exit 1 on a mismatch)")
    g.add_argument("--print", action="store_true", help="recompute and print the figures only")
    p.add_argument("--only", metavar="SUBSTRING", help="only the cases whose key contains this (not with --write)")
    args = p.parse_args(argv)
    if args.only and args.write:
        p.error("--only cannot be combined with --write (the file holds every case)")
    cases = CASES if not args.only else [c for c in CASES if args.only in c.key]
    if not cases:
        p.error(f"no case key contains {args.only!r}")
    now, skipped = compute(cases, log=lambda s: print(s, flush=True))
    if args.write:
        if skipped and FIGURES_JSON.exists():
            # A machine without a GPU (or the shared scenes) keeps the stored figures of those cases.
            old = load()
            for key in skipped:
                if key in old:
                    now[key] = old[key]
                    print(f"kept the stored figures of {key} (skipped here)")
        write(now)
        print(f"wrote {FIGURES_JSON}")
        return 0
    if args.print:
        for key, v in now.items():
            for name, x in v["figures"].items():
                print(f"{key} / {name}: {_fmt(x)}")
        return 0
    stored = load()
    if args.only:
        stored = {k: v for k, v in stored.items() if k in now or k in skipped}
    other = other_adapter(stored, now)
    for key, why in other.items():
        print(f"{key}: {why}")
    skipped = {**skipped, **other}
    rows = compare(stored, now, cases, skipped)
    print(format_table(rows))
    if not all(r[5] for r in rows):
        print("\n" + moved_message(rows))
        return 1
    print(f"\nall {len(rows)} figures within tolerance" + (f" ({len(skipped)} cases skipped)" if skipped else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
