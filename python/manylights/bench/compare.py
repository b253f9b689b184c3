"""``python -m manylights.bench compare``: every many-light renderer of the project on one error-against-time
chart per scene, and the clustered-visibility paper's cluster-count study (its Figures 7, 9 and 11).

Two ``ml.sweep`` runs against the brute-force image of the scene's light matrix (rendered once, cached by
content hash under ``--reference-dir``):

1. power sampling and instant radiosity at each column count, MRCS and LightSlice at rows (slices) =
   columns / 3, clustered visibility (GPU fuzzy K-means, F = ``--fuzzy``) at each ``LIGHTxVIEW`` pair of
   ``--clusters``, light-BVH sampling, RIS (M = ``--candidates``) and Stochastic Lightcuts (cut size) at
   each ``--samples`` count per view sample, Lightcuts and reconstruction cuts (error ``--cut-error``) at
   each ``--cuts`` largest cut; every one at ``--seeds`` seeds. Chart ``compare-<scene>.png``: relative L2
   (mean, error bars = std over seeds)
   against seconds, log-log, brute force's time as a vertical line.
2. clustered visibility over the grid ``--grid-light`` x ``--grid-view`` (light clusters x view clusters):
   chart ``compare-<scene>-clusters.png``, error and time against both counts (the paper's study of K_vpl
   and K_sp).

Each run also prints the **equal-time table**: per method, the lowest mean error among its budgets that took
at most T seconds (``EQUAL_TIMES``), with its spread over seeds; ``--table compare-a.json compare-b.json ...``
prints that table for several scenes from their JSON files, rendering nothing.

``compare-<scene>.json`` holds every record (method, budget, seconds per stage, error mean and std); the
rows stay in Parquet files beside it (a stopped run resumes). ``--workers`` / ``--scheduler`` run the
renders on Dask as ``bench mrcs`` does. ``--light-models vpl vpl+bc vsl no-mis`` charts the light models and
estimator options instead (``bench.light_models``), against the scene's Mitsuba reference.
"""
from __future__ import annotations

import json
import time
from pathlib import Path

import manylights as ml

from .._utils.files import atomic_write, atomic_write_text
from . import light_models
from .common import display_path, finish_loglog, method_records, ok_rows, resolve_scene, settings_tag
from .dask_options import add_dask_arguments, check_dask_arguments

COLORS = {"power_sampling": "C0", "instant_radiosity": "C1", "mrcs": "C2", "clustered_visibility": "C3",
          "light_bvh_sampling": "C4", "ris_sampling": "C5", "lightcuts": "C6", "reconstruction_cuts": "C7",
          "stochastic_lightcuts": "C8", "lightslice": "C9"}


#: The times (s) of the equal-time table.
EQUAL_TIMES = (0.1, 0.3, 1.0)


def equal_time(records: list[dict], times=EQUAL_TIMES) -> dict[str, dict[float, dict | None]]:
    """Per method and time T: the record of least mean relative L2 among those of ``seconds <= T`` (None when
    every budget of the method took longer). ``records``: ``compare``'s records (method, budget, seconds,
    rel_l2_mean, rel_l2_std). Methods in the order they first appear."""
    out: dict[str, dict[float, dict | None]] = {}
    for r in records:
        out.setdefault(r["method"], {})
    for method, cells in out.items():
        own = [r for r in records if r["method"] == method]
        for t in times:
            fit = [r for r in own if r["seconds"] <= t]
            cells[t] = min(fit, key=lambda r: r["rel_l2_mean"]) if fit else None
    return out


def _pct(x: float) -> str:
    """A fraction as a percentage with 2-3 significant digits, no exponent."""
    p = 100.0 * x
    return f"{p:.0f}%" if p >= 10 else f"{p:.1f}%" if p >= 1 else f"{p:.2f}%"


def equal_time_table(summaries: list[dict], times=EQUAL_TIMES) -> str:
    """The equal-time table of ``compare`` summaries (one per scene) as Markdown: a row per method, a column
    per scene and time, cells "mean% +- std%" ("-" when no budget fits in the time)."""
    names = [Path(s["scene"]).parent.name for s in summaries]
    head = "| method | " + " | ".join(f"{n} <= {t:g} s" for n in names for t in times) + " |"
    lines = [head, "|---" * (1 + len(names) * len(times)) + "|"]
    tables = [equal_time(s["records"], times) for s in summaries]
    methods = list(dict.fromkeys(m for t in tables for m in t))
    for m in methods:
        cells = []
        for tab in tables:
            for t in times:
                r = tab.get(m, {}).get(t)
                cells.append("-" if r is None else f"{_pct(r['rel_l2_mean'])} +- {_pct(r['rel_l2_std'])}")
        lines.append(f"| {m} | " + " | ".join(cells) + " |")
    seeds = sorted({s["seeds"] for s in summaries})
    brute = ", ".join(f"{n} {s['brute_force_seconds']:.1f} s" for n, s in zip(names, summaries))
    return "\n".join(lines) + f"\n\nSeeds: {', '.join(map(str, seeds))}; brute force: {brute}.\n"


def _pair(text: str) -> tuple[int, int]:
    """``"300x2400"`` -> (300, 2400): light clusters x view clusters."""
    try:
        a, b = text.lower().split("x")
        pair = (int(a), int(b))
    except ValueError:
        raise ValueError(f"--clusters takes LIGHTxVIEW pairs such as 300x2400, got {text!r}") from None
    if min(pair) < 1:
        raise ValueError(f"--clusters counts must be >= 1, got {text!r}")
    return pair


def add_parser(sub) -> None:
    p = sub.add_parser("compare", help="all renderers on one error-against-time chart + the cluster-count study")
    p.add_argument("--scene", help="scene XML, or a bundled scene's name (cbox, veach-ajar, demo); required "
                                   "unless --table")
    p.add_argument("--table", nargs="+", metavar="JSON", default=None,
                   help="only print the equal-time table of these compare-<scene>.json files")
    p.add_argument("--lights", type=int, default=20_000, help="total generated lights (area + indirect)")
    p.add_argument("--res", type=int, default=64, help="image width (height follows the film's aspect)")
    p.add_argument("--columns", type=int, nargs="+", default=[100, 300, 900],
                   help="column budgets of power sampling, instant radiosity and MRCS (rows = columns / 3)")
    p.add_argument("--clusters", nargs="+", default=["100x100", "300x400", "1000x1600"],
                   help="clustered visibility: LIGHTxVIEW cluster pairs")
    p.add_argument("--samples", type=int, nargs="*", default=[4, 16, 64],
                   help="light samples (shadow rays) per view sample of light-BVH sampling and RIS, cut size of "
                        "Stochastic Lightcuts (none: skip them)")
    p.add_argument("--candidates", type=int, default=16, help="RIS candidates per sample (M)")
    p.add_argument("--cuts", type=int, nargs="*", default=[100, 1000],
                   help="largest cut per view sample of Lightcuts and reconstruction cuts (none: skip them)")
    p.add_argument("--cut-error", type=float, default=0.02, help="Lightcuts' relative error bound per cluster")
    p.add_argument("--fuzzy", type=int, default=6, help="clustered visibility's F (view clusters per sample)")
    p.add_argument("--grid-light", type=int, nargs="*", default=[100, 300, 1000], help="light clusters of the study")
    p.add_argument("--grid-view", type=int, nargs="*", default=[50, 200, 800], help="view clusters of the study")
    p.add_argument("--seeds", type=int, default=8)
    p.add_argument("--device", default="auto", choices=["auto", "cpu", "gpu"])
    p.add_argument("--light-models", nargs="+", default=None, metavar="MODEL",
                   help="instead of the renderers: the light models / options side by side (bench.light_models: "
                        "vpl, vpl+bc, vsl, no-mis), power sampling and MRCS per model, compare-<scene>-lightmodels.*")
    p.add_argument("--truth", default="auto",
                   help="with --light-models: the image errors are measured against: auto (the scene's Mitsuba "
                        "reference in tests/references when one matches scene and size, else brute force), none "
                        "(each model's brute force) or an EXR / .npy path")
    p.add_argument("--max-depth", type=int, default=None,
                   help="with --light-models: Mitsuba max_depth of lights and matrix (default: the reference's, else 5)")
    p.add_argument("--out", default="out/bench")
    add_dask_arguments(p)
    p.set_defaults(run=run)


def run(args) -> dict:
    if args.table:
        summaries = [json.loads(Path(f).read_text()) for f in args.table]
        print(equal_time_table(summaries))
        return {"table": summaries}
    if not args.scene:
        raise ValueError("--scene is required (or --table with compare JSON files)")
    check_dask_arguments(args)
    if args.fuzzy < 1:
        raise ValueError(f"--fuzzy must be >= 1, got {args.fuzzy}")
    if any(k < 1 for k in args.samples) or args.candidates < 1:
        raise ValueError(f"--samples and --candidates must be >= 1, got {args.samples} and {args.candidates}")
    if any(k < 1 for k in args.cuts) or not args.cut_error > 0:
        raise ValueError(f"--cuts must be >= 1 and --cut-error > 0, got {args.cuts} and {args.cut_error}")
    pairs = [_pair(c) for c in args.clusters]
    path = resolve_scene(args.scene)
    film = ml.load_scene(path)
    if args.light_models is not None:
        return light_models.run(args, path, film)
    size = (args.res, max(1, round(args.res * film.height / film.width)))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    stem = f"compare-{path.parent.name}"
    tag = settings_tag(args)
    common = dict(seeds=list(range(args.seeds)), lights=args.lights, client=args.scheduler, workers=args.workers,
                  reference_dir=args.reference_dir or out / "references", device=args.device)
    scene = [(str(path), {"size": size})]
    print(f"{path}: {size[0]}x{size[1]}, {args.lights} lights, {args.seeds} seeds", flush=True)
    t = time.perf_counter()
    base = ml.sweep(scene, methods=["power_sampling", "instant_radiosity"], budgets=[(1, c) for c in args.columns],
                    out=out / f"{stem}-baselines-{tag}.parquet", **common)
    mrcs = ml.sweep(scene, methods=["mrcs", "lightslice"], budgets=[(max(1, c // 3), c) for c in args.columns],
                    out=out / f"{stem}-mrcs-{tag}.parquet", **common)
    # clustered_visibility reads a budget as (view clusters, light clusters).
    grid = [(v, l) for l in args.grid_light for v in args.grid_view]
    cv_budgets = list(dict.fromkeys([(v, l) for l, v in pairs] + grid))
    cv = ml.sweep(scene, methods=["clustered_visibility"], budgets=cv_budgets,
                  options={"clustered_visibility": {"fuzzy": args.fuzzy}},
                  out=out / f"{stem}-clustered-{tag}.parquet", **common)
    frames = [base, mrcs, cv]
    if args.samples:
        frames.append(ml.sweep(scene, methods=["light_bvh_sampling", "ris_sampling", "stochastic_lightcuts"],
                               budgets=[(1, k) for k in args.samples],
                               options={"ris_sampling": {"candidates": args.candidates}},
                               out=out / f"{stem}-lighttree-{tag}.parquet", **common))
    if args.cuts:
        err = {"error": args.cut_error}
        frames.append(ml.sweep(scene, methods=["lightcuts", "reconstruction_cuts"], budgets=[(1, k) for k in args.cuts],
                               options={"lightcuts": err, "reconstruction_cuts": err},
                               out=out / f"{stem}-lightcuts-{tag}.parquet", **common))
    wall = time.perf_counter() - t
    import pandas as pd

    df = pd.concat(frames, ignore_index=True)
    ok = ok_rows(df)
    first = ok.iloc[0]
    t_brute = float(first["reference_seconds"])
    records = (method_records(ok, "power_sampling", ["columns"]) + method_records(ok, "instant_radiosity", ["columns"])
               + method_records(ok, "mrcs", ["rows", "columns"]))
    for r in method_records(ok, "lightslice", ["rows", "columns"]):
        r["budget"] = {"slices": r["budget"]["rows"], "columns": r["budget"]["columns"]}
        records.append(r)
    for method in ("light_bvh_sampling", "ris_sampling", "stochastic_lightcuts"):
        for r in method_records(ok, method, ["columns"]):
            key = "cut_size" if method == "stochastic_lightcuts" else "samples"
            r["budget"] = {key: r["budget"]["columns"]}
            if method == "ris_sampling":
                r["budget"]["candidates"] = args.candidates
            records.append(r)
    for method in ("lightcuts", "reconstruction_cuts"):
        for r in method_records(ok, method, ["columns"]):
            r["budget"] = {"max_cut": r["budget"]["columns"], "error": args.cut_error}
            records.append(r)
    cv_records = method_records(ok, "clustered_visibility", ["columns", "rows"])
    for r in cv_records:
        r["budget"] = {"light_clusters": r["budget"]["columns"], "view_clusters": r["budget"]["rows"],
                       "fuzzy": args.fuzzy}
    on_chart = {(l, v) for l, v in pairs}
    records += [r for r in cv_records if (r["budget"]["light_clusters"], r["budget"]["view_clusters"]) in on_chart]
    for r in records:
        print(f"  {r['method']:<21s} {json.dumps(r['budget']):<58s} {r['seconds']:8.3f} s   "
              f"rel L2 {r['rel_l2_mean']:.4f} +- {r['rel_l2_std']:.4f}", flush=True)
    study = [r for r in cv_records if r["budget"]["light_clusters"] in args.grid_light
             and r["budget"]["view_clusters"] in args.grid_view]
    summary = {"scene": display_path(path), "size": list(size), "lights": int(first["lights"]),
               "device": {"kind": first["device"], "name": first["adapter"]}, "brute_force_seconds": t_brute,
               "seeds": args.seeds, "fuzzy": args.fuzzy, "workers": args.workers, "scheduler": args.scheduler,
               "sweep_wall_seconds": wall, "records": records, "cluster_study": study}
    summary["speedup_at_2pct"] = {}
    for method in COLORS:
        good = [r for r in records if r["method"] == method and r["rel_l2_mean"] <= 0.02]
        if good:
            best = min(good, key=lambda r: r["seconds"])
            summary["speedup_at_2pct"][method] = {"speedup": t_brute / best["seconds"], **best["budget"],
                                                  "rel_l2": best["rel_l2_mean"], "seconds": best["seconds"]}
    print(f"brute force {t_brute:.2f} s; speed-up at <= 2% error: "
          + ", ".join(f"{m} {v['speedup']:.1f}x" for m, v in summary["speedup_at_2pct"].items()), flush=True)
    summary["equal_time"] = {m: {str(t): (None if r is None else {"budget": r["budget"], "seconds": r["seconds"],
                                                                  "rel_l2_mean": r["rel_l2_mean"],
                                                                  "rel_l2_std": r["rel_l2_std"]})
                                 for t, r in cells.items()} for m, cells in equal_time(records).items()}
    print(equal_time_table([summary]), flush=True)
    atomic_write_text(out / f"{stem}.json", json.dumps(summary, indent=2) + "\n")
    title = f"{path.parent.name}: {summary['lights']} lights, {size[0]}x{size[1]}, {args.seeds} seeds"
    _chart(records, t_brute, out / f"{stem}.png", title)
    if study:
        _study_chart(study, args.grid_light, args.grid_view, out / f"{stem}-clusters.png", title)
    print(f"wrote {out / (stem + '.json')}, {out / (stem + '.png')}"
          + (f", {out / (stem + '-clusters.png')}" if study else ""))
    return summary


def _chart(records, t_brute: float, png: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 5))
    for method, color in COLORS.items():
        rs = sorted((r for r in records if r["method"] == method), key=lambda r: r["seconds"])
        if rs:
            ax.errorbar([r["seconds"] for r in rs], [r["rel_l2_mean"] for r in rs],
                        yerr=[r["rel_l2_std"] for r in rs], marker="o", capsize=3, color=color,
                        label=method.replace("_", " ") + (" (1:3)" if method in ("mrcs", "lightslice") else ""))
    ax.axvline(t_brute, color="k", linestyle=":", linewidth=1, label=f"brute force ({t_brute:.1f} s)")
    ax.axhline(0.02, color="grey", linestyle="--", linewidth=1, label="2%")
    finish_loglog(fig, ax, png, "time (s)", "relative L2 error vs brute force", title, 8)


def _study_chart(study, lights: list, views: list, png: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for ax, key, label in [(axes[0], "rel_l2_mean", "relative L2"), (axes[1], "seconds", "seconds")]:
        for l in lights:
            rs = sorted((r for r in study if r["budget"]["light_clusters"] == l), key=lambda r: r["budget"]["view_clusters"])
            ax.plot([r["budget"]["view_clusters"] for r in rs], [r[key] for r in rs], marker="o",
                    label=f"{l} light clusters")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("view clusters")
        ax.set_ylabel(label)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(f"clustered visibility: {title}")
    fig.tight_layout()
    atomic_write(png, lambda tmp: fig.savefig(tmp, dpi=120))
    plt.close(fig)
