"""``python -m manylights.bench mrcs``: error against time for MRCS and its baselines (the paper's Figure 6).

One ``ml.sweep`` renders instant radiosity, power sampling and MRCS at row:column ratios 1:1, 1:2, 1:3 and 1:5
over increasing budgets, each at several seeds, against the brute-force image of the scene's light matrix
(rendered once and cached by content hash under ``--reference-dir``). ``--workers N`` runs the renders on a
Dask LocalCluster of N processes, ``--scheduler ADDRESS`` on a running cluster, ``--workers 0`` (default) in
this process. Writes ``<out>/mrcs-<scene>-<settings hash>.parquet`` (one row per render, as it completes:
the same command run again resumes a stopped run), ``<out>/mrcs-<scene>.json`` (method, budget, seconds per stage, relative L2 mean and std, the
sweep's wall time) and ``<out>/mrcs-<scene>.png`` (relative L2 vs seconds, log-log, error bars = std over
seeds), and prints the speed-up over brute force and the share of MRCS time spent outside shadow maps +
shading (clustering and readback).
"""
from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

import manylights as ml

from .._utils.files import atomic_write, atomic_write_text
from .common import display_path, ok_rows, resolve_scene, settings_tag
from .dask_options import add_dask_arguments, check_dask_arguments

RATIOS = {"1:1": 1, "1:2": 2, "1:3": 3, "1:5": 5}
# MRCS stages outside shadow maps + shading (the paper's "overhead"), and the GPU stages.
OVERHEAD_STAGES = ("row_selection", "row_setup", "row_readback", "clustering")
GPU_STAGES = ("row_shadow_maps", "row_evaluation", "columns", "emitted")


def add_parser(sub) -> None:
    p = sub.add_parser("mrcs", help="MRCS vs baselines: relative L2 against time (JSON + PNG chart)")
    p.add_argument("--scene", required=True, help="scene XML, or a bundled scene's name (a folder of scenes/: cbox, veach-ajar, ...)")
    p.add_argument("--lights", type=int, default=100_000, help="total generated lights (area + indirect)")
    p.add_argument("--res", type=int, default=128, help="image width (height follows the film's aspect)")
    p.add_argument("--columns", type=int, nargs="+", default=[100, 300, 900],
                   help="MRCS column budgets (rows = columns / ratio)")
    p.add_argument("--ratios", nargs="+", default=list(RATIOS), choices=list(RATIOS))
    p.add_argument("--seeds", type=int, default=8)
    p.add_argument("--device", default="auto", choices=["auto", "cpu", "gpu"],
                   help="the light matrix's backend (auto: a hardware GPU, else the CPU)")
    p.add_argument("--visibility", default=None, choices=["hybrid", "shadow_map", "ray_traced"],
                   help="GPU visibility (default: the device's own: ray_traced on the CPU, hybrid on a GPU)")
    p.add_argument("--shadow-map-size", type=int, default=512)
    p.add_argument("--out", default="out/bench")
    add_dask_arguments(p)
    p.set_defaults(run=run)


def run(args) -> dict:
    check_dask_arguments(args)
    path = resolve_scene(args.scene)
    film = ml.load_scene(path)
    size = (args.res, max(1, round(args.res * film.height / film.width)))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    stem = f"mrcs-{path.parent.name}"

    # Every render is one row of ml.sweep: power sampling and instant radiosity at each column count, MRCS at
    # each ratio's (rows, columns); a (rows, columns) pair two ratios share is run once, under the first.
    labels: dict[tuple[int, int], str] = {}
    for c in args.columns:
        for name in args.ratios:
            labels.setdefault((max(1, c // RATIOS[name]), c), "mrcs " + name)
    budgets = list(labels) or [(1, c) for c in args.columns]
    methods = ["power_sampling", "instant_radiosity"] + (["mrcs"] if args.ratios else [])
    where = (f"scheduler {args.scheduler}" if args.scheduler else
             "this process" if args.workers == 0 else f"a LocalCluster of {args.workers or 'default'} workers")
    print(f"{path}: {size[0]}x{size[1]}, {args.lights} lights, {len(args.columns)} budgets x {args.seeds} seeds "
          f"on {where}", flush=True)
    t = time.perf_counter()
    df = ml.sweep([(str(path), {"size": size})], methods=methods, budgets=budgets, seeds=list(range(args.seeds)),
                  lights=args.lights, client=args.scheduler, workers=args.workers,
                  out=out / f"{stem}-{settings_tag(args)}.parquet",
                  reference_dir=args.reference_dir or out / "references", device=args.device,
                  visibility=args.visibility, shadow_map_size=args.shadow_map_size)
    wall = time.perf_counter() - t
    ok = ok_rows(df)
    first = ok.iloc[0]
    t_brute = float(first["reference_seconds"])
    print(f"{int(first['lights'])} lights, {first['device']} backend ({first['adapter']}); brute force "
          f"{t_brute:.1f} s{' (cached)' if first['reference_cached'] else ''}; sweep of {len(df)} renders: "
          f"{wall:.1f} s wall", flush=True)
    summary = {"scene": display_path(path), "size": list(size), "lights": int(first["lights"]),
               "visibility": args.visibility, "shadow_map_size": args.shadow_map_size,
               "device": {"kind": first["device"], "name": first["adapter"]}, "brute_force_seconds": t_brute,
               "seeds": args.seeds, "workers": args.workers, "scheduler": args.scheduler,
               "sweep_wall_seconds": wall, "hosts": sorted(ok["host"].unique().tolist()), "records": [],
               "adapter": ml.device_info(args.device)}
    records = summary["records"]
    stage_cols = [c for c in df.columns if c.startswith("seconds_")]

    def record(method, budget, rows):
        if rows.empty:
            return
        stages = {c[len("seconds_"):]: float(rows[c].mean()) for c in stage_cols if rows[c].notna().all()}
        errs = rows["rel_l2"].to_numpy()
        rec = {"method": method, "budget": budget, "seconds": float(rows["seconds"].mean()), "stages": stages,
               "rel_l2_mean": float(np.mean(errs)), "rel_l2_std": float(np.std(errs)), "seeds": len(rows)}
        if method.startswith("mrcs"):
            rec["overhead_share"] = sum(stages.get(k, 0.0) for k in OVERHEAD_STAGES) / max(rec["seconds"], 1e-9)
        records.append(rec)
        extra = f"   overhead {rec['overhead_share']:.1%}" if "overhead_share" in rec else ""
        print(f"  {method:<18s} {json.dumps(budget):<34s} {rec['seconds']:8.3f} s   "
              f"rel L2 {rec['rel_l2_mean']:.4f} +- {rec['rel_l2_std']:.4f}{extra}", flush=True)

    for c in args.columns:
        record("power_sampling", {"columns": c}, ok[(ok["method"] == "power_sampling") & (ok["columns"] == c)])
        record("instant_radiosity", {"lights": c}, ok[(ok["method"] == "instant_radiosity") & (ok["columns"] == c)])
        for name in args.ratios:
            r = max(1, c // RATIOS[name])
            if labels.get((r, c)) == "mrcs " + name:
                record("mrcs " + name, {"rows": r, "columns": c},
                       ok[(ok["method"] == "mrcs") & (ok["rows"] == r) & (ok["columns"] == c)])

    _summarize(summary, t_brute)
    atomic_write_text(out / f"{stem}.json", json.dumps(summary, indent=2) + "\n")
    _chart(records, out / f"{stem}.png", f"{path.parent.name}: {summary['lights']} lights, {size[0]}x{size[1]}, "
           f"{args.seeds} seeds")
    print(f"wrote {out / (stem + '.json')}, {out / (stem + '.png')} and the rows in "
          f"{out / (stem + '-' + settings_tag(args) + '.parquet')}")
    return summary


def _summarize(summary: dict, t_brute: float) -> None:
    """Speed-up over brute force at <= 2% error, and where MRCS spends its time."""
    records = summary["records"]
    mrcs_recs = [r for r in records if r["method"].startswith("mrcs")]
    good = [r for r in mrcs_recs if r["rel_l2_mean"] <= 0.02]
    if good:
        best = min(good, key=lambda r: r["seconds"])
        summary["speedup_at_2pct"] = t_brute / best["seconds"]
        summary["speedup_config"] = {"method": best["method"], **best["budget"], "rel_l2": best["rel_l2_mean"],
                                     "overhead_share": best["overhead_share"]}
        print(f"speed-up over brute force at <= 2% error: {summary['speedup_at_2pct']:.1f}x "
              f"({best['method']} {best['budget']}, rel L2 {best['rel_l2_mean']:.4f}, "
              f"overhead {best['overhead_share']:.1%})")
    else:
        print("no MRCS configuration reached 2% relative L2")
    if mrcs_recs:
        share = float(np.mean([r["overhead_share"] for r in mrcs_recs]))
        summary["overhead_share_mean"] = share
        gpu = float(np.mean([sum(r["stages"].get(k, 0.0) for k in GPU_STAGES) / r["seconds"] for r in mrcs_recs]))
        summary["gpu_share_mean"] = gpu
        print(f"MRCS time (mean over configurations): shadow maps + shading {gpu:.1%}, "
              f"clustering + row readback + row setup/selection {share:.1%}")
    # Equal-time comparison: at each MRCS time, the error of each baseline interpolated in log-log.
    summary["equal_time"] = _equal_time(records)
    for row in summary["equal_time"]:
        print(f"  at {row['seconds']:.2f} s: mrcs {row['mrcs']:.4f}, power sampling {row['power_sampling']}, "
              f"instant radiosity {row['instant_radiosity']}")


def _equal_time(records) -> list:
    """For each MRCS record, each baseline's error at the same time (log-log interpolation between its
    measured budgets; None outside the measured range)."""
    rows = []
    for r in (r for r in records if r["method"].startswith("mrcs")):
        row = {"method": r["method"], "seconds": r["seconds"], "mrcs": r["rel_l2_mean"]}
        for base in ("power_sampling", "instant_radiosity"):
            pts = sorted((b["seconds"], b["rel_l2_mean"]) for b in records if b["method"] == base)
            ts = np.log([p[0] for p in pts]) if pts else np.array([])
            if len(pts) >= 2 and ts[0] <= np.log(r["seconds"]) <= ts[-1]:
                row[base] = float(np.exp(np.interp(np.log(r["seconds"]), ts, np.log([p[1] for p in pts]))))
            else:
                row[base] = None
        rows.append(row)
    return rows


def _chart(records, png: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 5))
    for method in dict.fromkeys(r["method"] for r in records):
        rs = sorted((r for r in records if r["method"] == method), key=lambda r: r["seconds"])
        ax.errorbar([r["seconds"] for r in rs], [r["rel_l2_mean"] for r in rs], yerr=[r["rel_l2_std"] for r in rs],
                    marker="o", capsize=3, label=method)
    ax.axhline(0.02, color="grey", linestyle="--", linewidth=1, label="2%")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("relative L2 error vs brute force")
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    atomic_write(png, lambda tmp: fig.savefig(tmp, dpi=120))
    plt.close(fig)
