"""``python -m manylights.bench mrcs``: error against time for MRCS and its baselines (the paper's Figure 6).

Renders the brute-force image of a scene's light matrix once, then instant radiosity, power sampling and
MRCS at row:column ratios 1:1, 1:2, 1:3 and 1:5 over increasing budgets, each at several seeds, all in
one run so the timings compare side by side. Writes ``<out>/mrcs-<scene>.json`` (method, budget, seconds
per stage, relative L2 mean and std) and ``<out>/mrcs-<scene>.png`` (relative L2 vs seconds, log-log,
error bars = std over seeds), and prints the speed-up over brute force and the share of MRCS time spent
outside shadow maps + shading (clustering and readback).
"""
from __future__ import annotations

import hashlib
import json
import time
from pathlib import Path

import numpy as np

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
    p.set_defaults(run=run)


def _resolve_scene(name: str) -> Path:
    """An XML path as given, else the bundled scene of that name (``scenes/<name>/scene.xml``)."""
    from .scenes import resolve

    return resolve(name)


def _display_path(path: Path) -> str:
    """The scene path as written into results: relative to the repository for bundled scenes (results are
    committed and must not carry a machine's paths), else as given."""
    repo = Path(__file__).resolve().parents[2]
    try:
        return str(Path(path).resolve().relative_to(repo))
    except ValueError:
        return str(path)


def _load(path: Path, res: int):
    """The scene at width ``res``, height from the film's own aspect ratio."""
    import manylights as ml

    film = ml.load_scene(path)
    return ml.load_scene(path, size=(res, max(1, round(res * film.height / film.width))))


def run(args) -> dict:
    import manylights as ml

    path = _resolve_scene(args.scene)
    scene = _load(path, args.res)
    has_area = any(e["type"] == "area" for e in scene.emitters)
    has_env = any(e["type"] in ("envmap", "constant") for e in scene.emitters)
    n_area = args.lights // 4 if has_area else 0
    n_env = args.lights // 4 if has_env else 0
    t = time.perf_counter()
    lights = ml.generate_lights(scene, area=n_area, environment=n_env, indirect=args.lights - n_area - n_env, seed=0)
    t_gen = time.perf_counter() - t
    A = ml.LightMatrix(scene, lights, device=args.device, visibility=args.visibility,
                       shadow_map_size=args.shadow_map_size)
    print(f"{path}: {scene.width}x{scene.height}, {len(lights)} lights (generated in {t_gen:.2f} s), "
          f"{A.device['kind']} backend ({A.device['name']}), visibility {A.visibility}"
          + (f", shadow maps {args.shadow_map_size}^2" if A.device["kind"] == "gpu" else ""))

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    stem = f"mrcs-{path.parent.name}"
    # The cache key names everything the reference depends on, the scene file's content included.
    xml_hash = hashlib.sha256(path.read_bytes()).hexdigest()[:12]
    reference, t_brute = _brute_force(A, out / f"{stem}-reference-{xml_hash}-{len(lights)}-{scene.width}x"
                                      f"{scene.height}-{A.visibility}-{args.shadow_map_size}.npz")
    print(f"brute force ({len(lights)} columns): {t_brute:.1f} s")

    summary = {"scene": _display_path(path), "size": [scene.width, scene.height], "lights": len(lights),
               "visibility": A.visibility, "shadow_map_size": args.shadow_map_size, "device": A.device,
               "brute_force_seconds": t_brute, "seeds": args.seeds, "records": [], "adapter": ml.device_info()}
    records = summary["records"]

    def record(method, budget, results):
        errs = [ml.relative_l2(r.image, reference) for r in results]
        stages = {k: float(np.mean([r.timings.get(k, 0.0) for r in results])) for k in results[0].timings}
        rec = {"method": method, "budget": budget, "seconds": float(np.mean([r.seconds for r in results])),
               "stages": stages, "rel_l2_mean": float(np.mean(errs)), "rel_l2_std": float(np.std(errs)),
               "seeds": len(results)}
        if method.startswith("mrcs"):
            rec["overhead_share"] = sum(stages.get(k, 0.0) for k in OVERHEAD_STAGES) / max(rec["seconds"], 1e-9)
        records.append(rec)
        extra = f"   overhead {rec['overhead_share']:.1%}" if "overhead_share" in rec else ""
        print(f"  {method:<18s} {json.dumps(budget):<34s} {rec['seconds']:8.3f} s   "
              f"rel L2 {rec['rel_l2_mean']:.4f} +- {rec['rel_l2_std']:.4f}{extra}", flush=True)
        # Written after every record, so that a long run that is stopped keeps what it measured.
        (out / f"{stem}.json").write_text(json.dumps(summary, indent=2) + "\n")
        return rec

    seeds = range(args.seeds)
    for c in args.columns:
        record("power_sampling", {"columns": c}, [ml.power_sampling(A, columns=c, seed=s) for s in seeds])
        record("instant_radiosity", {"lights": c},
               [ml.instant_radiosity(scene, lights=c, seed=s, device=args.device, visibility=args.visibility,
                                     shadow_map_size=args.shadow_map_size) for s in seeds])
        for name in args.ratios:
            r = max(1, c // RATIOS[name])
            record("mrcs " + name, {"rows": r, "columns": c}, [ml.mrcs(A, rows=r, columns=c, seed=s) for s in seeds])

    _summarize(summary, t_brute)
    (out / f"{stem}.json").write_text(json.dumps(summary, indent=2) + "\n")
    _chart(records, out / f"{stem}.png", f"{path.parent.name}: {len(lights)} lights, {scene.width}x{scene.height}, "
           f"{args.seeds} seeds")
    print(f"wrote {out / (stem + '.json')} and {out / (stem + '.png')}")
    return summary


def _brute_force(A, cache: Path):
    """The full column sum (+ emitted) and its seconds; reused from ``cache`` when an earlier run with the
    same scene file, light count, size and visibility stored it (the seconds are those of that run)."""
    if cache.exists():
        with np.load(cache) as z:
            print(f"brute force read from {cache}")
            return z["image"], float(z["seconds"])
    t = time.perf_counter()
    image = A.column_sum(progress=True) + A.emitted()
    seconds = time.perf_counter() - t
    np.savez(cache, image=image, seconds=seconds)
    return image, seconds


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
    fig.savefig(png, dpi=120)
    plt.close(fig)
