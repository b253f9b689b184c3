"""``python -m manylights.bench lights``: full global illumination of ``cbox`` (128x128) and ``veach-ajar``
(64x36) with area + indirect lights against the stored Mitsuba references (tests/references/*-gi.exr), the
VPL clamp on and off, and a sweep over the number of VPLs N_i. Prints a table, writes ``<out>/lights.json``
and ``<out>/lights.png`` (error vs N_i).

    python -m manylights.bench lights --scene cbox --lights 100000
    python -m manylights.bench lights --scene all --lights 100000 --engine oracle

Engines: see the package doc (``manylights.bench``).
"""
from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

import manylights as ml

from .._utils.files import atomic_write, atomic_write_text
from ..scenes import scene_path
from .common import references_dir

# scene -> (bundled scene name (scenes/<name>/scene.xml), loader params, reference name)
LIGHT_SCENES = {
    "cbox": ("cbox", {"res": 128}, "cbox-gi"),
    "veach-ajar": ("veach-ajar", {"resx": 64, "resy": 36}, "veach-ajar-gi"),
}


def render(scene, lights, engine: str, visibility: str) -> np.ndarray:
    """The brute-force image of ``lights`` (matrix + emitted) by the chosen engine."""
    if engine in ("gpu", "cpu"):
        return ml.render_brute_force(scene, lights, device=engine, visibility=visibility if engine == "gpu" else None,
                                     progress=True)
    # The GPU is not used by the oracle; the smallest shadow maps keep the matrix set-up cheap.
    A = ml.LightMatrix(scene, lights, visibility="shadow_map", shadow_map_size=16)
    m = A.shape[0]
    rows = np.empty((m, 3), np.float64)
    for i in range(m):
        rows[i] = A.row_exact(i).sum(0, dtype=np.float64)
    emitted = A.emitted()  # one call: with glossy view samples it traces the BSDF-sampled strategy's rays
    return (rows.reshape(emitted.shape) + emitted).astype(np.float32)


def lights_runs(args) -> list[dict]:
    names = list(LIGHT_SCENES) if args.scene == "all" else [args.scene]
    n_area = args.area if args.area is not None else max(1, int(round(args.lights * args.area_fraction)))
    n_indirect = args.lights - n_area
    sweep = sorted({n for n in args.sweep if n < n_indirect} | {n_indirect})
    runs = []
    for name in names:
        xml, params, ref_name = LIGHT_SCENES[name]
        meta = json.loads((references_dir() / f"{ref_name}.json").read_text())
        ref = ml.read_exr(references_dir() / f"{ref_name}.exr")
        scene = ml.load_scene(scene_path(xml), size=tuple(meta["size"]), **params)
        configs = [(n_i, None) for n_i in sweep] + [(n_indirect, float("inf"))]
        if not args.no_clamp_sweep:
            configs += [(n_i, float("inf")) for n_i in sweep if n_i != n_indirect]
        for n_i, clamp in configs:
            for seed in range(args.seeds):
                t0 = time.perf_counter()
                lights = ml.generate_lights(scene, area=n_area, indirect=n_i, max_depth=args.max_depth,
                                            clamp=clamp, seed=seed)
                t_gen = time.perf_counter() - t0
                t0 = time.perf_counter()
                img = render(scene, lights, args.engine, args.visibility)
                t_render = time.perf_counter() - t0
                err = ml.relative_l2(img, ref)
                run = {
                    "scene": name, "size": meta["size"], "reference": ref_name,
                    "reference_noise": meta["relative_noise"], "area": n_area, "indirect": n_i,
                    "lights": len(lights), "clamp": "default" if clamp is None else "off", "seed": seed,
                    "relative_l2": float(err), "mean_ratio": float(img.mean() / ref.mean()),
                    "seconds_generate": round(t_gen, 2), "seconds_render": round(t_render, 2),
                    "engine": args.engine, "visibility": args.visibility if args.engine == "gpu" else "exact",
                    "nan_pixels": int(np.isnan(img).any(-1).sum()),
                }
                runs.append(run)
                print(f"{name:10s} area {n_area:6d} N_i {n_i:6d} ({len(lights):6d} lights) clamp "
                      f"{run['clamp']:7s} seed {seed}: relative L2 {err:7.3%}, mean ours/ref "
                      f"{run['mean_ratio']:.4f}, {t_gen:.1f} s + {t_render:.1f} s", flush=True)
                if args.images:
                    out = Path(args.out)
                    out.mkdir(parents=True, exist_ok=True)
                    ml.write_exr(out / f"{name}-Ni{n_i}-clamp{run['clamp']}-seed{seed}.exr", img)
    return runs


def lights_report(runs: list[dict], out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / "lights.json", json.dumps(runs, indent=2) + "\n")
    # Table: mean over seeds per (scene, clamp, N_i).
    groups: dict[tuple, list[dict]] = {}
    for r in runs:
        groups.setdefault((r["scene"], r["clamp"], r["indirect"]), []).append(r)
    print(f"\n{'scene':10s} {'clamp':8s} {'N_i':>7s} {'lights':>7s} {'rel. L2':>8s} {'mean ratio':>10s} "
          f"{'ref noise':>9s} {'seconds':>8s}")
    for (scene, clamp, n_i), rs in sorted(groups.items()):
        print(f"{scene:10s} {clamp:8s} {n_i:7d} {rs[0]['lights']:7d} "
              f"{np.mean([r['relative_l2'] for r in rs]):8.3%} {np.mean([r['mean_ratio'] for r in rs]):10.4f} "
              f"{rs[0]['reference_noise']:9.3%} {np.mean([r['seconds_render'] for r in rs]):8.1f}")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    for scene in sorted({r["scene"] for r in runs}):
        for clamp, style in [("default", "-o"), ("off", "--s")]:
            pts = sorted((n_i, np.mean([r["relative_l2"] for r in rs]))
                         for (s, c, n_i), rs in groups.items() if s == scene and c == clamp)
            if pts:
                ax.plot(*zip(*pts), style, label=f"{scene}, clamp {clamp}")
        noise = [r["reference_noise"] for r in runs if r["scene"] == scene][0]
        ax.axhline(noise, color="gray", lw=0.8, ls=":")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("indirect lights N_i (VPLs)")
    ax.set_ylabel("relative L2 vs Mitsuba (full GI)")
    ax.set_title("Brute force over area + indirect lights (dotted: reference noise)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    atomic_write(out / "lights.png", lambda tmp: fig.savefig(tmp, dpi=120))
    print(f"wrote {out / 'lights.json'} and {out / 'lights.png'}")


def add_parser(sub) -> None:
    p = sub.add_parser("lights", help="full GI vs Mitsuba with area + indirect lights (the many-light figures)")
    p.add_argument("--scene", choices=[*LIGHT_SCENES, "all"], default="all")
    p.add_argument("--lights", type=int, default=100_000, help="total area + indirect lights")
    p.add_argument("--area", type=int, default=None, help="area lights (default: --area-fraction of --lights)")
    p.add_argument("--area-fraction", type=float, default=0.1)
    p.add_argument("--sweep", type=int, nargs="*", default=[1000, 4000, 16000, 64000],
                   help="smaller N_i values to run (the full N_i is always run)")
    p.add_argument("--no-clamp-sweep", action="store_true", help="clamp off only at the full N_i")
    p.add_argument("--seeds", type=int, default=1)
    p.add_argument("--max-depth", type=int, default=-1)
    p.add_argument("--engine", choices=["cpu", "gpu", "oracle"], default="cpu")
    p.add_argument("--visibility", choices=["ray_traced", "hybrid", "shadow_map"], default="ray_traced")
    p.add_argument("--images", action="store_true", help="also write every image as EXR")
    p.add_argument("-o", "--out", default="out/bench")
    p.set_defaults(run=run)


def run(a) -> None:
    """The ``lights`` benchmark, from parsed arguments."""
    if a.lights < 2:
        raise SystemExit("--lights must be >= 2")
    lights_report(lights_runs(a), Path(a.out))
