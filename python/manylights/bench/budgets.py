"""``python -m manylights.bench budgets``: ``ml.render(A, target_error=e)`` against the cheapest fixed MRCS
budget that reaches e ("the true error is <= e in >= 90% of seeds, and the time
is within 2x of the cheapest fixed budget that reaches e").

One light matrix of the scene on the CPU backend (``--lights`` lights, default 100k: the MRCS benchmark's
split -- a quarter area points, the rest VPLs -- or ``--area`` area points and the rest VPLs; veach-ajar
defaults to 10% area points, as the published full-GI figures (docs/validation/accuracy.md)). Its brute-force image (column sum + emitted)
is rendered once and cached by content hash under ``<cache>/references`` (the sweep's ``<key>.npz``;
``--cache``, default ``out/bench``).

1. **Fixed budgets**: one ``ml.sweep`` of plain MRCS at every ``rows:columns`` of ``--budgets`` x the seeds
   (the existing sweep, resumable from ``<cache>/budgets-<scene>-<settings>.parquet``). A budget *reaches* e
   when its true relative L2 is <= e in >= 90% of the seeds (``REACH``), the same criterion as ``render``'s,
   so the comparison is like for like; the cheapest one is the reaching budget of least mean seconds.
2. **Target**: ``ml.render(A, target_error=e, seed=s)`` per target and seed: true relative L2 against the
   brute force, its own estimate, wall seconds (everything: the cost measurement of a row and a column, every
   round), the budget it chose and why it stopped; right after each render, the cheapest fixed budget of its
   target is rendered again with the same seed and timed (``fixed_seconds``; same bits as in the sweep, so
   ``fixed_rel_l2`` equals the sweep's error): on a machine shared with other work the load drifts between
   the sweep and the renders, and a time measured minutes apart is not like for like.
3. Per target: the share of seeds with true error <= e, the mean render seconds, the cheapest fixed budget and
   ``ratio = mean render seconds / mean paired fixed seconds`` (``ratio_sweep``: against the sweep's own mean
   seconds of that budget; both None when no fixed budget reaches e).

Writes ``<out>/budgets-<scene>.json`` and ``<out>/budgets-<scene>.png`` (left: true and estimated error
against the target, per seed; right: render time and cheapest fixed time against the target).

Symbols
-------
| here | meaning |
|---|---|
| ``e`` | the target relative L2 (``--targets``) |
| ``hit_rate`` | share of seeds whose true relative L2 is <= e |
| ``ratio`` | mean wall seconds of ``render`` / mean seconds of the cheapest fixed budget reaching e, timed next to it |
| ``REACH`` | share of seeds a fixed budget must bring to <= e (0.9) |
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

import manylights as ml

from .._utils.files import atomic_write, atomic_write_text
from .._utils.progress import mode
from ..distributed import worker as sweep_worker
from ..distributed.specs import parse_lights, scene_specs
from .common import display_path, ok_rows, parse_budgets, resolve_scene, settings_tag

#: A fixed budget reaches e when this share of its seeds is at or below e (the acceptance's 90%).
REACH = 0.9
DEFAULT_TARGETS = [0.05, 0.02, 0.01]
DEFAULT_BUDGETS = ["8:32", "8:64", "16:64", "8:128", "16:128", "32:128", "16:256", "32:256", "64:256",
                   "32:512", "64:512", "128:512", "64:1024", "128:1024", "128:2048", "256:2048"]
#: Share of area points in the generated lights where the published figures use another split than a quarter.
AREA_FRACTION = {"veach-ajar": 0.1}


def add_parser(sub) -> None:
    p = sub.add_parser("budgets", help="ml.render(A, target_error=e) against the cheapest fixed MRCS budget (JSON + PNG)")
    p.add_argument("--scene", default="cbox", help="scene XML, or a bundled scene's name (cbox, veach-ajar, ...)")
    p.add_argument("--res", type=int, default=128, help="image width (height follows the film's aspect)")
    p.add_argument("--lights", type=int, default=100_000, help="total generated lights (area points + VPLs)")
    p.add_argument("--area", type=int, default=None,
                   help="area points (default: a quarter of --lights, 10%% on veach-ajar); the rest are VPLs")
    p.add_argument("--seeds", type=int, default=8)
    p.add_argument("--targets", type=float, nargs="+", default=DEFAULT_TARGETS, help="target relative L2 values")
    p.add_argument("--budgets", nargs="+", default=DEFAULT_BUDGETS, help="fixed MRCS rows:columns budgets")
    p.add_argument("--max-rounds", type=int, default=16, help="render's max_rounds")
    p.add_argument("--out", default="docs/bench")
    p.add_argument("--cache", default="out/bench",
                   help="the sweep's Parquet file and <cache>/references (brute force, content-hashed .npz)")
    p.set_defaults(run=run)


def lights_spec(name: str, total: int, area) -> dict:
    """The sweep's lights spec: ``{"total": N}`` (a quarter area points) or explicit area / indirect counts.

    Raises:
        ValueError: total < 1, or area outside [0, total]."""
    if total < 1:
        raise ValueError(f"--lights must be >= 1, got {total}")
    if area is None and name in AREA_FRACTION:
        area = int(round(total * AREA_FRACTION[name]))
    if area is None:
        return {"total": int(total)}
    if not 0 <= area <= total:
        raise ValueError(f"--area must be in [0, --lights = {total}], got {area}")
    return {"area": int(area), "indirect": int(total - area)}


def fixed_records(ok) -> list[dict]:
    """Per (rows, columns) budget of the sweep's rendered rows: seeds, mean seconds, errors per seed."""
    out = []
    for (r, c), g in ok.groupby(["rows", "columns"], sort=True):
        g = g.sort_values("seed")
        out.append({"rows": int(r), "columns": int(c), "seeds": int(len(g)), "seconds": float(g["seconds"].mean()),
                    "rel_l2": [float(x) for x in g["rel_l2"]], "rel_l2_mean": float(g["rel_l2"].mean())})
    return out


def cheapest_reaching(fixed: list[dict], e: float):
    """The fixed budget of least mean seconds whose error is <= e in >= REACH of its seeds, or None."""
    good = [f for f in fixed if np.mean(np.asarray(f["rel_l2"]) <= e) >= REACH]
    return min(good, key=lambda f: f["seconds"]) if good else None


def summarize(targets, runs: list[dict], fixed: list[dict]) -> list[dict]:
    """Per target: hit rate, render seconds (mean / max), the cheapest fixed budget and the time ratios,
    all computed from ``runs`` (render records, each with the paired timing of the cheapest fixed budget,
    ``fixed_seconds``) and ``fixed`` (``fixed_records``): ``ratio`` = mean render seconds / mean paired
    fixed seconds (timed next to each render: the same load on a shared machine), ``ratio_sweep`` = mean
    render seconds / the sweep's mean seconds of that budget."""
    table = []
    for e in targets:
        sel = [x for x in runs if x["target"] == e]
        true = np.array([x["true"] for x in sel])
        secs = np.array([x["seconds"] for x in sel])
        best = cheapest_reaching(fixed, e)
        row = {"target": e, "seeds": len(sel), "hit_rate": float(np.mean(true <= e)),
               "true_mean": float(true.mean()), "true_max": float(true.max()),
               "estimate_mean": float(np.mean([x["estimate"] for x in sel])),
               "render_seconds": float(secs.mean()), "render_seconds_max": float(secs.max()),
               "columns_mean": float(np.mean([x["columns"] for x in sel])),
               "rendered_columns_mean": float(np.mean([x["rendered_columns"] for x in sel])),
               "rows_mean": float(np.mean([x["rows"] for x in sel])), "cheapest_fixed": None, "ratio": None,
               "ratio_sweep": None}
        if best is not None:
            paired = float(np.mean([x["fixed_seconds"] for x in sel]))
            row["cheapest_fixed"] = {"rows": best["rows"], "columns": best["columns"], "seconds": best["seconds"],
                                     "seconds_paired": paired, "rel_l2_max": max(best["rel_l2"])}
            row["ratio"] = float(secs.mean() / paired)
            row["ratio_sweep"] = float(secs.mean() / best["seconds"])
        row["met"] = bool(row["hit_rate"] >= REACH and row["ratio"] is not None and row["ratio"] <= 2.0)
        table.append(row)
    return table


def run(args) -> dict:
    if args.seeds < 1:
        raise ValueError(f"--seeds must be >= 1, got {args.seeds}")
    if any(not (e > 0 and np.isfinite(e)) for e in args.targets):
        raise ValueError(f"--targets must be finite numbers > 0, got {args.targets}")
    budgets = parse_budgets(args.budgets)
    path = resolve_scene(args.scene)
    name = path.parent.name
    film = ml.load_scene(path)
    size = (args.res, max(1, round(args.res * film.height / film.width)))
    spec_lights = lights_spec(name, args.lights, args.area)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    cache = Path(args.cache)
    cache.mkdir(parents=True, exist_ok=True)
    refdir = cache / "references"
    seeds = list(range(args.seeds))

    # 1. The fixed budgets: the existing sweep (serial, this process: it keeps the matrix for step 2). Its
    # file is named by the settings the sweep depends on (not the targets), so other targets reuse it.
    tag = settings_tag(argparse.Namespace(**{k: v for k, v in vars(args).items() if k not in ("targets", "max_rounds")}))
    t = time.perf_counter()
    df = ml.sweep([(str(path), {"size": size})], methods=["mrcs"], budgets=budgets, seeds=seeds, lights=spec_lights,
                  workers=0, out=cache / f"budgets-{name}-{tag}.parquet", reference_dir=refdir,
                  device="cpu")
    sweep_wall = time.perf_counter() - t
    fixed = fixed_records(ok_rows(df))

    # 2. The same matrix and brute force (both cached by the sweep's worker code), then render to each target.
    scene_spec = scene_specs([(str(path), {"size": size})], local=True)[0]
    lspec, mspec = parse_lights(spec_lights), {"device": "cpu"}
    ref = sweep_worker.reference(scene_spec, lspec, mspec, str(refdir))
    A = sweep_worker._matrix(scene_spec, lspec, mspec)[2]
    truth = ref["image"]
    print(f"{name} {size[0]}x{size[1]}, {ref['lights']} lights ({json.dumps(spec_lights)}), CPU backend; brute "
          f"force {ref['seconds']:.1f} s{' (cached)' if ref['cached'] else ''}; {len(budgets)} fixed budgets x "
          f"{len(seeds)} seeds in {sweep_wall:.1f} s", flush=True)
    shown = display_path(path)
    if Path(shown).is_absolute():
        shown = f"{path.parent.name}/{path.name}"
    runs: list[dict] = []
    jobs = [(e, s) for e in args.targets for s in seeds]
    cheapest = {e: cheapest_reaching(fixed, e) for e in args.targets}

    def write(done: list) -> dict:
        """JSON + chart of the targets whose seeds are all rendered (after each one: a long run stopped
        early keeps what it measured; ``complete`` says whether every target is in)."""
        table = summarize(done, runs, fixed)
        summary = {"scene": shown, "size": list(size), "lights": int(ref["lights"]), "light_spec": spec_lights,
                   "device": {"kind": A.device.get("kind"), "name": A.device.get("name")},
                   "brute_force_seconds": float(ref["seconds"]), "seeds": args.seeds, "targets": list(done),
                   "complete": len(done) == len(args.targets), "reach": REACH, "sweep_wall_seconds": sweep_wall,
                   "table": table, "fixed": fixed, "runs": [x for x in runs if x["target"] in done]}
        atomic_write_text(out / f"budgets-{name}.json", json.dumps(summary, indent=1) + "\n")
        _chart(summary, out / f"budgets-{name}.png")
        row = table[-1]
        cf = row["cheapest_fixed"]
        cheap = ("none reaches it" if cf is None else
                 f"cheapest fixed {cf['rows']}:{cf['columns']} {cf['seconds_paired']:.2f} s next to the renders "
                 f"({cf['seconds']:.2f} s in the sweep), ratio {row['ratio']:.2f}x ({row['ratio_sweep']:.2f}x)")
        print(f"  target {row['target']:.0%}: true <= e in {row['hit_rate']:.0%} of {row['seeds']} seeds (mean "
              f"{row['true_mean']:.2%}, max {row['true_max']:.2%}), render {row['render_seconds']:.2f} s "
              f"({row['rows_mean']:.0f} rows, {row['columns_mean']:.0f} columns); {cheap}", flush=True)
        return summary

    bar = None
    if mode() == "bar":
        from tqdm.auto import tqdm

        bar = tqdm(total=len(jobs), desc="render to target", unit="render", leave=False)
    summary: dict = {}
    try:
        for i, (e, s) in enumerate(jobs):
            t = time.perf_counter()
            res = ml.render(A, target_error=e, seed=s, max_rounds=args.max_rounds, progress=False)
            wall = time.perf_counter() - t
            ch = res.budget.get("chosen", {})
            best = cheapest[e]
            f_sec = f_err = None
            if best is not None:  # the cheapest fixed budget of this target, timed now (same load) and seed
                t = time.perf_counter()
                f = ml.mrcs(A, rows=best["rows"], columns=best["columns"], seed=s)
                f_sec, f_err = time.perf_counter() - t, float(ml.relative_l2(f.image, truth))
            runs.append({"target": e, "seed": s, "true": float(ml.relative_l2(res.image, truth)),
                         "estimate": float(res.error_estimate), "seconds": wall,
                         "rows": int(res.budget.get("rows", 0)), "columns": int(res.budget["columns"]),
                         "rendered_columns": int(res.budget.get("rendered_columns", res.budget["columns"])),
                         "rounds": int(ch.get("rounds", 0)), "stopped": res.budget.get("stopped"),
                         "schedule_rows": ch.get("rows"), "schedule_columns": ch.get("columns"),
                         "estimates": ch.get("estimates"), "rows_per_column": ch.get("rows_per_column"),
                         "seconds_per_row": ch.get("seconds_per_row"),
                         "seconds_per_column": ch.get("seconds_per_column"),
                         "budget_choice_seconds": float(res.timings.get("budget_choice", 0.0)),
                         "fixed_seconds": f_sec, "fixed_rel_l2": f_err})
            msg = (f"target {e:.0%} seed {s}: true {runs[-1]['true']:.2%}, estimate {runs[-1]['estimate']:.2%}, "
                   f"{wall:.2f} s, {runs[-1]['columns']} columns")
            if bar is not None:
                bar.update(1)
                bar.set_postfix_str(msg)
            elif mode() == "log":  # one line per render
                print(f"manylights: budgets: {msg}", file=sys.stderr, flush=True)
            if i + 1 == len(jobs) or jobs[i + 1][0] != e:
                summary = write(list(dict.fromkeys(x["target"] for x in runs)))
    finally:
        if bar is not None:
            bar.close()
    print(f"wrote {out / f'budgets-{name}.json'} and {out / f'budgets-{name}.png'}")
    return summary


def _chart(summary: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    runs, table = summary["runs"], summary["table"]
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(10, 4.2))
    ax.scatter([x["target"] for x in runs], [x["true"] for x in runs], s=14, alpha=0.6, label="true (vs brute force)")
    ax.scatter([x["target"] * 1.04 for x in runs], [x["estimate"] for x in runs], s=14, marker="x", alpha=0.6,
               label="estimate")
    g = np.array(sorted(summary["targets"]))
    ax.plot(g, g, "k-", lw=0.8, label="= target")
    ax.set(xscale="log", yscale="log", xlabel="target relative L2", ylabel="relative L2",
           title="error of render(A, target_error)")
    ax.legend(fontsize=8)
    ts = [r["target"] for r in table]
    bx.plot(ts, [r["render_seconds"] for r in table], "o-", label="render (mean over seeds)")
    pts = [(r["target"], r["cheapest_fixed"]["seconds"]) for r in table if r["cheapest_fixed"]]
    if pts:
        bx.plot(*zip(*pts), "s--", label="cheapest fixed MRCS budget reaching e (sweep)")
    pts = [(r["target"], r["cheapest_fixed"]["seconds_paired"]) for r in table if r["cheapest_fixed"]]
    if pts:
        bx.plot(*zip(*pts), "^:", label="the same, timed next to the renders")
    bx.set(xscale="log", yscale="log", xlabel="target relative L2", ylabel="seconds", title="time")
    bx.legend(fontsize=8)
    w, h = summary["size"]
    fig.suptitle(f"{Path(summary['scene']).parent.name} {w}x{h}, {summary['lights']} lights, {summary['seeds']} seeds",
                 fontsize=10)
    fig.tight_layout()
    atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=110))
    plt.close(fig)
