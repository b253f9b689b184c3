"""What the benchmarks share: where the clone keeps its scenes and Mitsuba references, scene names, result
paths, settings tags, and the tables and charts of sweep results."""
from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np

from .._utils.files import atomic_write
from ..scenes import resolve

#: The repository the package was installed from (benchmarks write paths relative to it).
REPO = Path(__file__).resolve().parents[3]
#: The stored Mitsuba references of the clone (``tests/references``).
REFERENCES = REPO / "tests" / "references"


def references_dir() -> Path:
    """``tests/references`` of the clone the package runs from.

    Raises:
        FileNotFoundError: the package does not run from a clone (the references ship with the repository's
            tests, not with the wheel)."""
    if not REFERENCES.is_dir():
        raise FileNotFoundError(f"the stored Mitsuba references are not at {REFERENCES}: this benchmark needs the "
                                "repository's tests/references (run it from a clone)")
    return REFERENCES


def resolve_scene(name: str) -> Path:
    """An XML path as given, else the bundled scene of that name (``scenes/<name>/scene.xml``)."""
    return resolve(name)


def display_path(path: Path) -> str:
    """The scene path as written into results: relative to the repository for bundled scenes (results are
    committed and must not carry a machine's paths), else as given."""
    repo = REPO
    try:
        return str(Path(path).resolve().relative_to(repo))
    except ValueError:
        return str(path)


def settings_tag(args) -> str:
    """8 hex digits naming a benchmark's settings (every argument but where and how it runs), so that its
    Parquet file is resumed by the same command and a changed command writes another file."""
    skip = {"out", "workers", "scheduler", "reference_dir", "cache", "run", "cmd"}
    settings = {k: v for k, v in sorted(vars(args).items()) if k not in skip}
    return hashlib.sha256(json.dumps(settings, sort_keys=True, default=str).encode()).hexdigest()[:8]


def ok_rows(df):
    """The rendered rows of a sweep's DataFrame; prints every failed row.

    Raises:
        RuntimeError: every render failed (the first error quoted)."""
    failed = df[df["status"] != "ok"]
    for r in failed.itertuples():
        print(f"  failed: {r.method} rows {r.rows} columns {r.columns} seed {r.seed}: {r.error}", flush=True)
    ok = df[df["status"] == "ok"]
    if ok.empty:
        raise RuntimeError(f"every render of the sweep failed (first error: {failed['error'].iloc[0]})")
    return ok


def method_records(ok, method: str, keys: list) -> list:
    """One record per budget of ``method``: seconds (mean) and per-stage seconds, relative L2 mean and std."""
    rows = ok[ok["method"] == method]
    stage_cols = [c for c in rows.columns if c.startswith("seconds_")]
    out = []
    for budget, g in rows.groupby(keys, sort=True):
        budget = dict(zip(keys, (int(b) for b in np.atleast_1d(budget))))
        errs = g["rel_l2"].to_numpy()
        out.append({"method": method, "budget": budget, "seconds": float(g["seconds"].mean()),
                    "stages": {c[len("seconds_"):]: float(g[c].mean()) for c in stage_cols if g[c].notna().all()},
                    "rel_l2_mean": float(errs.mean()), "rel_l2_std": float(errs.std()), "seeds": int(len(g))})
    return out


def finish_loglog(fig, ax, png: Path, xlabel: str, ylabel: str, title: str, legend_size: int) -> None:
    """Log-log axes with labels, title, grid and legend; save ``png`` (120 dpi) and close ``fig``."""
    import matplotlib.pyplot as plt

    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=legend_size)
    fig.tight_layout()
    atomic_write(png, lambda tmp: fig.savefig(tmp, dpi=120))
    plt.close(fig)


def parse_budgets(specs) -> list[tuple[int, int]]:
    """``rows:columns`` strings as (rows, columns) pairs.

    Raises:
        ValueError: a string not of that form."""
    out = []
    for s in specs:
        r, _, c = str(s).partition(":")
        if not r.isdigit() or not c.isdigit():
            raise ValueError(f"a budget is rows:columns, e.g. 32:128; got {s!r}")
        out.append((int(r), int(c)))
    return out


def mixed_lights(scene, n: int, seed: int = 0):
    """About ``n`` lights of every kind the scene has: half area points (if it has area emitters), a quarter
    environment strata (if it has an environment), the rest VPLs (``generate_lights``, with its delta lights)."""
    from ..lights.generate import generate_lights

    has_area = any(e["type"] == "area" for e in scene.emitters)
    has_env = any(e["type"] in ("envmap", "constant") for e in scene.emitters)
    n_area = n // 2 if has_area else 0
    n_env = n // 4 if has_env else 0
    return generate_lights(scene, area=n_area, environment=n_env, indirect=n - n_area - n_env, seed=seed)
