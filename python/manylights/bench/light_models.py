"""``python -m manylights.bench compare --light-models ...``: the light models and estimator options
next to each other on one error-against-time chart per scene.

| name | light model / option | settings |
|---|---|---|
| ``vpl`` | clamped VPLs (today's default), glossy MIS on | ``generate_lights(indirect_kind="vpl")`` |
| ``vpl+bc`` | clamped VPLs + bias compensation (Kollig and Keller 2004) | ``LightMatrix.bias_compensation(spp, light_samples)`` added to every image |
| ``vsl`` | virtual spherical lights (Hasan et al. 2009, Sec. 4-5), glossy MIS on | ``generate_lights(indirect_kind="vsl")`` |
| ``no-mis`` | clamped VPLs, glossy MIS off | ``LightMatrix(glossy_roughness=0)`` |
| ``vpl+is`` | clamped VPLs importance-sampled by the camera (Georgiev and Slusallek 2010) | ``generate_lights(vpl_importance=True)`` |
| ``vsl+is`` | VSLs from importance-sampled VPLs | ``generate_lights(indirect_kind="vsl", vpl_importance=True)`` |

One ``ml.sweep`` with a ``light_models`` axis: power sampling at each ``--columns`` count and MRCS at rows =
min(columns / 3, pixels), at ``--seeds`` render seeds, per model; plus each model's brute force (all its
columns; one point, the sweep's cached reference). The error is against the converged Mitsuba reference of the
scene when ``--truth`` names one or ``auto`` finds one in ``tests/references`` (same scene file, same size; its
``max_depth`` then sets the lights' and the matrix's), else against each model's own brute force; the chart's
axis label says which. Seconds count everything the option costs per image: the bias compensation image, the
BSDF samples of glossy MIS in ``emitted()``, the VSLs' cap integration in every column and row. The light set
is one (light seed 0) for every render, as in every sweep: the seeds vary the renderers' sampling and the
compensation's paths.

Writes ``compare-<scene>-lightmodels.json`` (every record: model, method, budget, seconds, error mean / std)
and ``.png``; rows stay in a Parquet file beside them (a stopped run resumes).
"""
from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Optional

import manylights as ml

from .._utils.files import atomic_write_text
from .common import REFERENCES, display_path, finish_loglog, method_records, ok_rows, settings_tag

#: name -> (sweep light-model settings, chart label with indirect lights, label for a direct-only scene).
MODELS = {
    "vpl": ({}, "VPL, clamped (glossy MIS on)", "glossy MIS on (default)"),
    "vpl+bc": ({"bias_compensation": {"spp": 2, "light_samples": 64}}, "VPL, clamped + bias compensation",
               "bias compensation (no VPLs: adds 0)"),
    "vsl": ({"lights": {"indirect_kind": "vsl"}}, "VSL (glossy MIS on)", "VSL (no indirect lights: = default)"),
    "no-mis": ({"matrix": {"glossy_roughness": 0.0}}, "VPL, clamped, glossy MIS off", "glossy MIS off"),
    "vpl+is": ({"lights": {"vpl_importance": True}}, "VPL, clamped, importance-sampled",
               "VPL importance sampling (no VPLs: = default)"),
    "vsl+is": ({"lights": {"indirect_kind": "vsl", "vpl_importance": True}}, "VSL, importance-sampled",
               "VSL importance sampling (no VPLs: = default)"),
}
METHOD_STYLE = {"mrcs": ("o", "-"), "power_sampling": ("s", "--")}
MODEL_COLOR = {"vpl": "C0", "vpl+bc": "C1", "vsl": "C2", "no-mis": "C3", "vpl+is": "C4", "vsl+is": "C5"}


def find_reference(path: Path, size: tuple[int, int], references: Path = REFERENCES) -> Optional[Path]:
    """The Mitsuba reference EXR in ``references`` rendered from the same scene file (its last two path parts)
    at ``size`` (W, H), or None."""
    tail = Path(path).resolve().parts[-2:]
    for meta in sorted(Path(references).glob("*.json")):
        try:
            m = json.loads(meta.read_text())
        except (OSError, ValueError):
            continue
        exr = meta.with_suffix(".exr")
        if (tuple(Path(m.get("scene", "")).parts[-2:]) == tail and tuple(m.get("size", ())) == tuple(size)
                and exr.is_file()):
            return exr
    return None


def light_spec(scene, total: int, max_depth: int) -> dict:
    """The sweep's lights for ``total`` lights: the usual split (``sweep_worker.light_counts``) with indirect
    light, every light on the emitters when ``max_depth`` = 2 (direct light only)."""
    if max_depth != 2:
        return {"total": total, "max_depth": max_depth}
    has_area = any(e["type"] == "area" for e in scene.emitters)
    has_env = any(e["type"] in ("envmap", "constant") for e in scene.emitters)
    env = total // 2 if has_area and has_env else (total if has_env else 0)
    return {"area": total - env if has_area else 0, "environment": env, "indirect": 0, "max_depth": 2}


def run(args, path: Path, film) -> dict:
    bad = [m for m in args.light_models if m not in MODELS]
    if bad or not args.light_models or len(set(args.light_models)) != len(args.light_models):
        raise ValueError(f"--light-models takes distinct names of {', '.join(MODELS)}, got {args.light_models}")
    size = (args.res, max(1, round(args.res * film.height / film.width)))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    truth, max_depth = None, args.max_depth
    if args.truth == "auto":
        truth = find_reference(path, size)
    elif args.truth != "none":
        truth = Path(args.truth)
        if not truth.is_file():
            raise FileNotFoundError(f"--truth: image file not found: {truth}")
    if truth is not None and truth.with_suffix(".json").is_file():
        ref_depth = json.loads(truth.with_suffix(".json").read_text())["integrator"]["max_depth"]
        max_depth = ref_depth if max_depth is None else max_depth
    max_depth = 5 if max_depth is None else max_depth
    scene = ml.load_scene(path, size=size)
    lights = light_spec(scene, args.lights, max_depth)
    direct_only = lights.get("indirect", 1) == 0
    models = {}
    for name in args.light_models:
        spec = json.loads(json.dumps(MODELS[name][0]))
        spec.setdefault("matrix", {})["max_depth"] = max_depth
        models[name] = spec
    stem = f"compare-{scene_stem(path)}-lightmodels"
    pixels = size[0] * size[1]
    budgets = [(max(1, min(c // 3, pixels)), c) for c in args.columns]
    print(f"{path}: {size[0]}x{size[1]}, {args.lights} lights, max_depth {max_depth}, {args.seeds} seeds, models "
          f"{', '.join(models)}; error against {truth if truth is not None else 'each model’s brute force'}",
          flush=True)
    t = time.perf_counter()
    df = ml.sweep([(str(path), {"size": size})], methods=["mrcs", "power_sampling"], budgets=budgets,
                  seeds=list(range(args.seeds)), lights=lights, light_models=models, truth=truth,
                  client=args.scheduler, workers=args.workers, device=args.device,
                  reference_dir=args.reference_dir or out / "references",
                  out=out / f"{stem}-{settings_tag(args)}.parquet")
    wall = time.perf_counter() - t
    ok = ok_rows(df)
    records, brute = [], []
    for name in models:
        rows = ok[ok["light_model"] == name]
        if rows.empty:
            continue
        for method, keys in (("mrcs", ["rows", "columns"]), ("power_sampling", ["columns"])):
            for r in method_records(rows, method, keys):
                sub = rows[rows["method"] == method]
                r["light_model"] = name
                r["rel_l2_brute_force_mean"] = float(sub[sub["columns"] == r["budget"]["columns"]]
                                                     ["rel_l2_brute_force"].mean())
                records.append(r)
        first = rows.iloc[0]
        brute.append({"light_model": name, "method": "brute_force", "seconds": float(first["reference_seconds"]),
                      "rel_l2": float(first["reference_rel_l2"]) if truth is not None else 0.0,
                      "lights": int(first["lights"]), "setup_seconds": float(rows["setup_seconds"].max())})
    for r in records + brute:
        err = r.get("rel_l2_mean", r.get("rel_l2"))
        print(f"  {r['light_model']:<7s} {r['method']:<15s} {json.dumps(r.get('budget', 'all')):<30s} "
              f"{r['seconds']:8.3f} s   rel L2 {err:.4f}" + (f" +- {r['rel_l2_std']:.4f}" if "rel_l2_std" in r else ""),
              flush=True)
    against = (f"Mitsuba reference {display_path(truth)}" if truth is not None else "each model's brute force")
    summary = {"scene": display_path(path), "size": list(size), "lights": lights, "max_depth": max_depth,
               "truth": against, "truth_noise": None if truth is None else reference_noise(truth), "device": {"kind": ok.iloc[0]["device"], "name": ok.iloc[0]["adapter"]},
               "seeds": args.seeds, "light_seed": 0, "sweep_wall_seconds": wall,
               "light_models": {n: {"settings": models[n], "label": label(n, direct_only)} for n in models},
               "records": records, "brute_force": brute}
    atomic_write_text(out / f"{stem}.json", json.dumps(summary, indent=2) + "\n")
    title = (f"{scene_stem(path)}: {int(ok.iloc[0]['lights'])} lights, {size[0]}x{size[1]}, {args.seeds} seeds, "
             f"max_depth {max_depth}")
    chart(records, brute, out / f"{stem}.png", title, against, direct_only)
    print(f"wrote {out / (stem + '.json')}, {out / (stem + '.png')}")
    return summary


def scene_stem(path: Path) -> str:
    """``scenes/<name>/scene.xml`` -> name; any other XML -> its file stem with ``-`` for ``_``."""
    path = Path(path)
    return path.parent.name if path.name == "scene.xml" else path.stem.replace("_", "-")


def label(name: str, direct_only: bool) -> str:
    return MODELS[name][2 if direct_only else 1]


def chart(records, brute, png: Path, title: str, against: str, direct_only: bool) -> None:
    """Error against seconds, log-log: one colour per light model, MRCS solid, power sampling dashed, each
    model's brute force a star."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 5.5))
    for name, color in MODEL_COLOR.items():
        for method, (marker, line) in METHOD_STYLE.items():
            rs = sorted((r for r in records if r["light_model"] == name and r["method"] == method),
                        key=lambda r: r["seconds"])
            if rs:
                ax.errorbar([r["seconds"] for r in rs], [r["rel_l2_mean"] for r in rs],
                            yerr=[r["rel_l2_std"] for r in rs], marker=marker, linestyle=line, capsize=3,
                            color=color, label=f"{label(name, direct_only)}: {method.replace('_', ' ')}"
                            + (" (1:3)" if method == "mrcs" else ""))
        for b in brute:
            if b["light_model"] == name and b["rel_l2"] > 0:
                ax.plot([b["seconds"]], [b["rel_l2"]], marker="*", markersize=13, color=color, linestyle="none",
                        label=f"{label(name, direct_only)}: brute force")
    finish_loglog(fig, ax, png, "time per image (s), every stage of the option included",
                  f"relative L2 vs {against}" if len(against) < 48 else f"relative L2 vs\n{against}", title, 7)


def reference_noise(truth: Path) -> Optional[float]:
    """The reference's relative noise from its JSON (None without one)."""
    meta = Path(truth).with_suffix(".json")
    return float(json.loads(meta.read_text())["relative_noise"]) if meta.is_file() else None
