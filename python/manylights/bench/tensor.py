"""``python -m manylights.bench tensor``: tensor clustering against per-frame MRCS on an animation.

The claim of Hašan, Velázquez, Pellacini, Bala, "Tensor Clustering for Rendering Many-Light Animations"
(EGSR 2008): 300-500 shadow maps per frame give an animation whose per-frame error and temporal flicker are
lower than per-frame MRCS at 1000+, because light-frame clusters reuse representatives across frames. One
run measures it side by side:

1. The animation (default: the bundled ``bounce``, ``--frames`` frames at ``--res``^2) and its lights
   (``generate_animation_lights``: area + environment + gather-sample indirect lights with a photon pre-pass).
2. Brute force of every frame (all columns), once, cached under ``--cache`` keyed by the scene's content,
   the frame parameters, the size, the light options and the device; its time is the Table 2 baseline.
   Every run below is one row of an ``ml.sweep`` (``--workers N``: a Dask LocalCluster of N processes,
   ``--scheduler ADDRESS``: a running cluster; default: this process); the rows are kept in
   ``<out>/tensor-<scene>-<method>-<settings hash>.parquet``, so a stopped run resumes.
3. For every seed of ``--seeds`` and every budget: ``tensor_clustering`` with ``--rows`` rows and
   ``columns`` per frame (the budgets ``--tensor``, shadow maps per frame = rows + columns) and
   ``mrcs_per_frame`` at the budgets ``--mrcs`` (rows + columns per frame). Per run: mean per-frame
   relative L2 against brute force, flicker (``metrics.flicker``), seconds per stage, counted shadow maps
   per frame.

Prints a table (mean and spread over seeds), the speed-up of each method over brute force, and writes
``<out>/tensor-<scene>.json`` (after every run) and ``<out>/tensor-<scene>.png`` (error and flicker
against shadow maps per frame).

    python -m manylights.bench tensor
    python -m manylights.bench tensor --frames 24 --res 64 --seeds 2
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

import manylights as ml
import manylights.scenes as sc

from .._utils.dask import connect, release
from .._utils.files import atomic_write, atomic_write_text
from .common import settings_tag
from .dask_options import add_dask_arguments, check_dask_arguments


def add_parser(sub) -> None:
    p = sub.add_parser("tensor", help="tensor clustering vs per-frame MRCS on an animation (error, flicker)",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scene", default="bounce", help="a bundled animated scene")
    p.add_argument("--frames", type=int, default=40)
    p.add_argument("--res", type=int, default=128)
    p.add_argument("--area", type=int, default=4096)
    p.add_argument("--environment", type=int, default=4096)
    p.add_argument("--indirect", type=int, default=16000, help="gather samples (indirect lights)")
    p.add_argument("--photons", type=int, default=100000)
    p.add_argument("--rows", type=int, default=100)
    p.add_argument("--tensor", type=int, nargs="+", default=[200, 400], metavar="COLUMNS",
                   help="tensor clustering: representative columns per frame (shadow maps = rows + columns)")
    p.add_argument("--mrcs", type=int, nargs="+", default=[200, 500, 900], metavar="COLUMNS",
                   help="per-frame MRCS: columns per frame (shadow maps = rows + columns)")
    p.add_argument("--seeds", type=int, default=4)
    p.add_argument("--chunk", type=int, default=40)
    p.add_argument("--device", default="auto", choices=["auto", "cpu", "gpu"])
    p.add_argument("--cache", default="out/bench/cache", help="brute-force references (shared by the workers)")
    p.add_argument("--out", default="out/bench")
    add_dask_arguments(p, reference_dir=False)
    p.set_defaults(run=run)


def _check(args) -> None:
    for name in ("frames", "res", "rows", "seeds", "chunk"):
        if getattr(args, name) < 1:
            raise ValueError(f"--{name} must be >= 1, got {getattr(args, name)}")
    for name in ("tensor", "mrcs"):
        if any(c < 1 for c in getattr(args, name)):
            raise ValueError(f"--{name} budgets must be >= 1, got {getattr(args, name)}")


def _records(df) -> list:
    """One record per run (row) of the sweeps' DataFrame, in the order seed, method, columns."""
    recs = []
    stages = [c for c in df.columns if c.startswith("seconds_")]
    for r in df[df["status"] == "ok"].sort_values(["seed"], kind="stable").to_dict("records"):
        recs.append({"method": r["method"], "columns": int(r["columns"]), "seed": int(r["seed"]),
                     "shadow_maps_per_frame": float(r["shadow_maps_per_frame"]),
                     "mean_relative_l2": float(r["rel_l2"]), "max_relative_l2": float(r["max_rel_l2"]),
                     "flicker": float(r["flicker"]), "seconds": float(r["seconds"]),
                     "timings": {c[len("seconds_"):]: float(r[c]) for c in stages if r[c] == r[c]},
                     "host": r["host"]})
    return recs


def run(args) -> dict:
    import pandas as pd

    _check(args)
    check_dask_arguments(args)
    path = sc.resolve(args.scene)
    name = path.parent.name
    if name not in sc.animated():
        raise ValueError(f"--scene {args.scene}: not a bundled animated scene ({', '.join(sc.animated())})")
    frames = sc.animation_frames(name, count=args.frames)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    json_path, png_path = out / f"tensor-{name}.json", out / f"tensor-{name}.png"
    scene = (str(path), {"frames": frames, "res": args.res})
    lights = {"area": args.area, "environment": args.environment, "indirect": args.indirect, "photons": args.photons,
              "seed": 0}
    seeds = list(range(args.seeds))
    # Two sweeps (tensor clustering at --tensor, per-frame MRCS at --mrcs) on one cluster, one brute force.
    runs = [("tensor_clustering", args.tensor, {"chunk": args.chunk}), ("mrcs_per_frame", args.mrcs, {})]
    tag = settings_tag(args)
    parquets = {m: out / f"tensor-{name}-{m}-{tag}.parquet" for m, _, _ in runs}
    client, owned = (None, False) if (args.workers == 0 and not args.scheduler) else \
        connect(args.scheduler, args.workers, 10.0, args.device)
    where = (f"scheduler {args.scheduler}" if args.scheduler else "this process" if client is None else
             f"a LocalCluster of {len(client.scheduler_info()['workers'])} workers")
    print(f"{name}: {len(frames)} frames at {args.res}x{args.res} on {where}", flush=True)
    interrupted = False
    t = time.perf_counter()
    try:
        for method, budgets, opts in runs:
            ml.sweep([scene], methods=[method], budgets=[(args.rows, c) for c in budgets], seeds=seeds, lights=lights,
                     client=client, workers=0 if client is None else None, out=parquets[method],
                     reference_dir=args.cache, device=args.device, options={method: opts} if opts else None)
    except KeyboardInterrupt:
        interrupted = True
        print("\ninterrupted: reporting what was measured")
    finally:
        release(client, owned)
    wall = time.perf_counter() - t
    parts = [pd.read_parquet(p) for p in parquets.values() if p.is_file()]
    df = pd.concat(parts, ignore_index=True) if parts else None
    ok = None if df is None else df[df["status"] == "ok"]
    if ok is None or ok.empty:
        if interrupted:
            raise SystemExit(130)
        errors = "; ".join(df["error"].dropna().unique()[:3]) if df is not None else "no rows"
        raise RuntimeError(f"every run failed: {errors}")
    for r in df[df["status"] != "ok"].itertuples():
        print(f"  failed: {r.method} columns {r.columns} seed {r.seed}: {r.error}", flush=True)
    first = ok.iloc[0]
    t_brute, f, n = float(first["reference_seconds"]), int(first["frames"]), int(first["lights"])
    cached = bool(df.loc[df["method"] == runs[0][0], "reference_cached"].iloc[0]) if \
        (df["method"] == runs[0][0]).any() else bool(first["reference_cached"])
    print(f"{n} lights per frame, device {first['device']} ({first['adapter']}); brute force: {t_brute:.1f} s "
          f"({t_brute / f:.2f} s per frame){' (cached)' if cached else ''}; sweeps: {wall:.1f} s wall", flush=True)
    summary = {"scene": f"scenes/{name}/scene.xml", "frames": f, "size": [args.res, args.res], "lights": n,
               "light_spec": lights, "device": {"kind": first["device"], "name": first["adapter"]},
               "brute_force_seconds": t_brute, "brute_force_cached": cached, "rows": args.rows,
               "seeds": args.seeds, "workers": args.workers, "scheduler": args.scheduler, "sweep_wall_seconds": wall,
               "records": _records(ok), "interrupted": interrupted}
    for rec in summary["records"]:
        print(f"  seed {rec['seed']} {rec['method']:<18s} {rec['shadow_maps_per_frame']:7.1f} maps/frame  "
              f"rel L2 {rec['mean_relative_l2']:.3%}  flicker {rec['flicker']:.3f}  {rec['seconds']:.1f} s", flush=True)
    summary["table"] = table(summary["records"], t_brute)
    atomic_write_text(json_path, json.dumps(summary, indent=2) + "\n")
    print_table(summary)
    chart(summary, png_path)
    print(f"wrote {json_path}, {png_path} and the rows in {', '.join(str(p) for p in parquets.values())}")
    if interrupted:
        raise SystemExit(130)
    return summary


def table(records: list, t_brute: float) -> list:
    """Mean and spread over seeds per (method, columns), with the speed-up over brute force."""
    rows = []
    for key in sorted({(r["method"], r["columns"]) for r in records}):
        rs = [r for r in records if (r["method"], r["columns"]) == key]
        sec = float(np.mean([r["seconds"] for r in rs]))
        rows.append({"method": key[0], "columns": key[1], "runs": len(rs),
                     "shadow_maps_per_frame": float(np.mean([r["shadow_maps_per_frame"] for r in rs])),
                     "mean_relative_l2": float(np.mean([r["mean_relative_l2"] for r in rs])),
                     "relative_l2_std": float(np.std([r["mean_relative_l2"] for r in rs])),
                     "flicker": float(np.mean([r["flicker"] for r in rs])),
                     "flicker_std": float(np.std([r["flicker"] for r in rs])),
                     "seconds": sec, "speedup_over_brute_force": t_brute / sec if sec > 0 else None})
    return rows


def print_table(summary: dict) -> None:
    print(f"\n{'method':<18s} {'maps/frame':>10s} {'rel L2 (mean +- sd)':>22s} {'flicker':>16s} {'seconds':>9s} "
          f"{'speed-up':>9s}")
    for r in summary["table"]:
        print(f"{r['method']:<18s} {r['shadow_maps_per_frame']:10.1f} {r['mean_relative_l2']:>12.3%} +- "
              f"{r['relative_l2_std']:.3%} {r['flicker']:>8.3f} +- {r['flicker_std']:.3f} {r['seconds']:9.1f} "
              f"{r['speedup_over_brute_force']:8.1f}x")
    print(f"brute force: {summary['brute_force_seconds']:.1f} s for {summary['frames']} frames of {summary['lights']} lights")


def chart(summary: dict, png: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    for k, method in enumerate(("tensor_clustering", "mrcs_per_frame")):
        rows = [r for r in summary["table"] if r["method"] == method]
        x = [r["shadow_maps_per_frame"] for r in rows]
        for ax, key in zip(axes, ("mean_relative_l2", "flicker")):
            sd = "relative_l2_std" if key == "mean_relative_l2" else "flicker_std"
            ax.errorbar(x, [r[key] for r in rows], yerr=[r[sd] for r in rows], fmt="-o", color=f"C{k}",
                        label=method.replace("_", " "), capsize=3)
    for ax, label in zip(axes, ("mean per-frame relative L2 vs brute force", "flicker vs brute force")):
        ax.set_xlabel("shadow maps per frame (rows + columns)")
        ax.set_ylabel(label)
        ax.set_yscale("log")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    W, H = summary["size"]
    fig.suptitle(f"{summary['scene']} {summary['frames']} frames {W}x{H}, {summary['lights']} lights, "
                 f"{summary['seeds']} seeds")
    fig.tight_layout()
    atomic_write(png, lambda tmp: fig.savefig(tmp, dpi=120))
    plt.close(fig)
