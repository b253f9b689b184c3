"""``python -m manylights.bench tensor``: tensor clustering against per-frame MRCS on an animation.

The claim of Hašan, Velázquez, Pellacini, Bala, "Tensor Clustering for Rendering Many-Light Animations"
(EGSR 2008): 300-500 shadow maps per frame give an animation whose per-frame error and temporal flicker are
lower than per-frame MRCS at 1000+, because light-frame clusters reuse representatives across frames. One
run measures it side by side:

1. The animation (default: the bundled ``bounce``, ``--frames`` frames at ``--res``^2) and its lights
   (``generate_animation_lights``: area + environment + gather-sample indirect lights with a photon pre-pass).
2. Brute force of every frame (all columns), once, cached under ``--cache`` keyed by the scene's content,
   the frame parameters, the size, the light options and the device; its time is the Table 2 baseline.
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
import hashlib
import json
import os
import time
from pathlib import Path

import numpy as np


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
    p.add_argument("--cache", default="out/bench/cache")
    p.add_argument("--out", default="out/bench")
    p.set_defaults(run=run)


def _check(args) -> None:
    for name in ("frames", "res", "rows", "seeds", "chunk"):
        if getattr(args, name) < 1:
            raise ValueError(f"--{name} must be >= 1, got {getattr(args, name)}")
    for name in ("tensor", "mrcs"):
        if any(c < 1 for c in getattr(args, name)):
            raise ValueError(f"--{name} budgets must be >= 1, got {getattr(args, name)}")


def _key(path: Path, frames: list, args, device: dict) -> str:
    from .bench_vs_mitsuba import scene_hash

    h = hashlib.sha256()
    h.update(scene_hash(path).encode())
    h.update(json.dumps({"frames": frames, "res": args.res, "area": args.area, "environment": args.environment,
                         "indirect": args.indirect, "photons": args.photons, "device": device.get("kind")},
                        sort_keys=True).encode())
    return h.hexdigest()[:16]


def brute_force(T, cache: Path, key: str) -> tuple[np.ndarray, float, bool]:
    """(frames, seconds, cached): every frame's column sum + emitted, cached as an .npy (written under a
    temporary name, then renamed)."""
    cache.mkdir(parents=True, exist_ok=True)
    npy = cache / f"tensor-brute-{key}.npy"
    meta = npy.with_suffix(".json")
    if npy.is_file() and meta.is_file():
        return np.load(npy), float(json.loads(meta.read_text())["seconds"]), True
    t = time.perf_counter()
    B = T.brute_force(progress=True)
    seconds = time.perf_counter() - t
    tmp = npy.with_name(f".{npy.stem}.tmp{os.getpid()}.npy")
    np.save(tmp, B)
    os.replace(tmp, npy)
    meta.write_text(json.dumps({"seconds": seconds, "shape": list(B.shape)}) + "\n")
    return B, seconds, False


def run(args) -> dict:
    import manylights as ml
    import manylights.scenes as sc

    from .metrics import flicker, relative_l2_per_frame

    _check(args)
    path = sc.resolve(args.scene)
    name = path.parent.name
    if name not in sc.animated():
        raise ValueError(f"--scene {args.scene}: not a bundled animated scene ({', '.join(sc.animated())})")
    frames = sc.animation_frames(name, count=args.frames)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    json_path, png_path = out / f"tensor-{name}.json", out / f"tensor-{name}.png"
    t = time.perf_counter()
    anim = ml.load_animation(path, frames=frames, res=args.res)
    lights = ml.generate_animation_lights(anim, area=args.area, environment=args.environment, indirect=args.indirect,
                                          photons=args.photons, seed=0)
    t_lights = time.perf_counter() - t
    T = ml.LightTensor(anim, lights, device=args.device)
    m, n, f = T.shape
    print(f"{name}: {f} frames at {args.res}x{args.res}, {n} lights per frame {lights.counts} "
          f"({t_lights:.1f} s), device {T.device['kind']} ({T.device['name']})", flush=True)
    B, t_brute, cached = brute_force(T, Path(args.cache), _key(path, frames, args, T.device))
    print(f"brute force: {t_brute:.1f} s ({t_brute / f:.2f} s per frame){' (cached)' if cached else ''}", flush=True)
    summary = {"scene": f"scenes/{name}/scene.xml", "frames": f, "size": [args.res, args.res], "lights": n,
               "light_counts": lights.counts, "lights_seconds": t_lights, "device": T.device,
               "brute_force_seconds": t_brute, "brute_force_cached": cached, "rows": args.rows,
               "seeds": args.seeds, "records": [], "interrupted": False}

    def save() -> None:
        tmp = json_path.with_suffix(f".tmp{os.getpid()}")
        tmp.write_text(json.dumps(summary, indent=2) + "\n")
        os.replace(tmp, json_path)

    runs = [("tensor_clustering", c) for c in args.tensor] + [("mrcs_per_frame", c) for c in args.mrcs]
    try:
        for seed in range(args.seeds):
            for method, cols in runs:
                if method == "tensor_clustering":
                    res = ml.tensor_clustering(T, rows=args.rows, columns=cols, seed=seed, chunk=args.chunk)
                else:
                    res = ml.mrcs_per_frame(T, rows=args.rows, columns=min(cols, n), seed=seed)
                e = relative_l2_per_frame(res.frames, B)
                rec = {"method": method, "columns": cols, "seed": seed,
                       "shadow_maps_per_frame": float(np.mean(res.shadow_maps_per_frame)),
                       "mean_relative_l2": float(np.mean(e)), "max_relative_l2": float(np.max(e)),
                       "flicker": float(flicker(res.frames, B)), "seconds": res.seconds, "timings": res.timings}
                summary["records"].append(rec)
                print(f"  seed {seed} {method:<18s} {rec['shadow_maps_per_frame']:7.1f} maps/frame  "
                      f"rel L2 {rec['mean_relative_l2']:.3%}  flicker {rec['flicker']:.3f}  {rec['seconds']:.1f} s",
                      flush=True)
                save()
    except KeyboardInterrupt:
        summary["interrupted"] = True
        print("\ninterrupted: reporting what was measured")
    summary["table"] = table(summary["records"], t_brute)
    save()
    print_table(summary)
    if summary["records"]:
        chart(summary, png_path)
        print(f"wrote {json_path} and {png_path}")
    if summary["interrupted"]:
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
    fig.savefig(png, dpi=120)
    plt.close(fig)
