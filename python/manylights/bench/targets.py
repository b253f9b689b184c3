"""``python -m manylights.bench targets``: does ``ml.render(scene, target_error=e)`` keep its word?

The calibration of the whole answer, light model and all: every cell is a (scene, target) pair, rendered from
the scene XML with ``ml.render(xml, target_error=e, seed=s)`` for ``--seeds`` seeds, and compared with a
stored, converged Mitsuba 3 reference of the same scene (``tests/references``, pixel-centre ``path``
renders with the same ``max_depth``). The true error of a render is the relative L2 against the reference
with the reference's own noise taken out,

    true = sqrt(max(||I - R||^2 - sum var(R), 0)) / ||R||

(``var(R)``: the stored variance of the reference's mean per pixel); ``true_without_edges`` leaves out the
pixels whose centre lies on a shape's edge, where the two renderers' camera rays may hit different shapes
(cbox-lights: ~2%). Per seed it records what ``render``
claims (``budget['target_reached']``, ``budget['target_reason']``), its error estimate
(``budget['estimated_total_error']``: the probes' upper bound, bias included), the variance and bias parts,
the light model it chose, the light counts, wall seconds and the probes' share of them.

A cell **keeps its word** (judged by the true error without the edge pixels where Mitsuba found them: wherever
Mitsuba is installed, also with ``--no-mitsuba``, which skips only its timing) when

- the seeds that claim the target have a true error <= ``CLAIM_TOLERANCE`` (1.25) x e in all but at most
  one of them (">= 7 of 8"), and none above ``CLAIM_LIMIT`` (2) x e;
- the seeds that do not claim it have an estimate within a factor ``ESTIMATE_FACTOR`` (2) of their true error.

Beside each cell, Mitsuba's own path tracer (``--mitsuba``, the default; ``llvm_ad_rgb`` where it works,
pixel-centre rays, spp 1, 2, 4, ... up to ``--max-spp``, each level warmed up once, then timed) gives the
seconds it needs to reach the median true error of the cell's renders (interpolated log-log between the
bracketing spp levels, ``time_to_error.time_to_error``), measured in the same run.

Writes ``<out>/targets.json`` after every render (Ctrl-C keeps what was measured), ``<out>/targets.md``
(the table, for the docs' validation page) and ``<out>/targets.png`` (estimate and true error against
the target per cell).

    python -m manylights.bench targets                       # every cell, 5% and 2%, 8 seeds
    python -m manylights.bench targets --cells cbox-gi-64 --targets 0.05 --seeds 2 --no-mitsuba

Symbols
-------
| here | meaning |
|---|---|
| ``e`` | the target relative L2 (``--targets``) |
| ``I``, ``R`` | the render and the converged Mitsuba reference, (H, W, 3) float32 |
| ``true`` | relative L2 of ``I`` against ``R`` with ``R``'s noise removed |
| ``claimed`` | ``budget['target_reached']`` |
| ``estimate`` | ``budget['estimated_total_error']``: the upper confidence bound the render reports |
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

import manylights as ml

from .._utils.files import atomic_write, atomic_write_text
from .common import REPO, display_path, references_dir
from .time_to_error import time_to_error

#: A claimed target must hold within this factor in all but one seed ...
CLAIM_TOLERANCE = 1.25
#: ... and within this factor in every seed.
CLAIM_LIMIT = 2.0
#: A target not claimed must come with an estimate within this factor of the truth.
ESTIMATE_FACTOR = 2.0

#: cell name -> (scene XML relative to the clone, loader params, max_depth, stored reference, what it is).
CELLS = {
    "cbox-gi-64": ("scenes/cbox/scene.xml", {"res": 64}, -1, "cbox-gi-64",
                   "Cornell box, full GI (area light + VPLs), 64^2"),
    "cbox-gi-256": ("scenes/cbox/scene.xml", {"res": 256}, -1, "cbox-gi-256",
                    "Cornell box, full GI, 256^2"),
    "cbox-lights-direct": ("scenes/cbox-lights/scene.xml", {"res": 128}, 2, "cbox-lights-direct",
                           "point, spot, sun, area and environment lights, direct, 128^2"),
    "veach-ajar-gi-32": ("scenes/veach-ajar/scene.xml", {"resx": 32, "resy": 18}, -1, "veach-ajar-gi-32",
                         "Bitterli's Veach Ajar (public interior lit through a door), full GI, 32x18"),
    "staircase-direct": ("tests/data/staircase_recessed.xml", {"res": 64}, 2, "staircase-direct",
                         "twosided walls, 13 small recessed lights, direct, 64^2"),
    "staircase-gi-64": ("tests/data/staircase_recessed.xml", {"res": 64}, -1, "staircase-gi-64",
                        "the same staircase, mostly indirect light, full GI, 64^2"),
    "window-room-direct": ("scenes/window-room/scene.xml", {"resx": 256, "resy": 144}, 2, "window-room-direct",
                           "a room lit through a window by an environment map, direct, 256x144"),
    "plates-env-direct": ("tests/data/veach_plates_env.xml", {"width": 64, "height": 48}, 2,
                          "veach-plates-env-direct", "glossy plates under an environment map, direct, 64x48"),
}
DEFAULT_TARGETS = [0.05, 0.02]


def add_parser(sub) -> None:
    p = sub.add_parser("targets", help="render(scene, target_error=e) against converged Mitsuba references: "
                                       "claims, estimates and true errors per (scene, target) cell")
    p.add_argument("--cells", nargs="+", default=list(CELLS), choices=list(CELLS))
    p.add_argument("--targets", type=float, nargs="+", default=DEFAULT_TARGETS)
    p.add_argument("--seeds", type=int, default=8)
    p.add_argument("--mitsuba", action=argparse.BooleanOptionalAction, default=True,
                   help="time Mitsuba's path tracer to each cell's median true error (default: on)")
    p.add_argument("--max-spp", type=int, default=4096, help="the last spp level of Mitsuba's ladder")
    p.add_argument("--out", default="docs/bench")
    p.set_defaults(run=run)


def load_reference(name: str) -> tuple[np.ndarray, np.ndarray, dict]:
    """The stored reference ``name``: (mean (H, W, 3) float32, variance of the mean (H, W, 3), its JSON)."""
    folder = references_dir()
    meta = json.loads((folder / f"{name}.json").read_text())
    return ml.read_exr(folder / f"{name}.exr"), ml.read_exr(folder / f"{name}.var.exr"), meta


def true_error(image: np.ndarray, ref: np.ndarray, ref_var: np.ndarray) -> float:
    """Relative L2 of ``image`` against ``ref`` with the reference's own noise removed (module doc)."""
    d = image.astype(np.float64) - ref
    sq = float((d * d).sum()) - float(ref_var.astype(np.float64).sum())
    return float(np.sqrt(max(sq, 0.0)) / np.linalg.norm(ref.astype(np.float64)))


def render_once(xml: Path, params: dict, max_depth: int, target: float, seed: int, ref, ref_var,
                edges=None) -> dict:
    """One ``render`` of a cell: its claim, estimates, chosen model, time and true error."""
    t = time.perf_counter()
    res = ml.render(xml, target_error=target, seed=seed, params=params, max_depth=max_depth, progress=False)
    seconds = time.perf_counter() - t
    b = res.budget
    model = b.get("light_model") or {}
    return {
        "seed": seed,
        "claimed": bool(b.get("target_reached")),
        "reason": b.get("target_reason"),
        "stopped": b.get("stopped"),
        "estimate": float(res.error_estimate),
        "estimated_total_error": float(b.get("estimated_total_error", float("nan"))),
        "variance_estimate": float(res.variance_estimate) if res.variance_estimate is not None else None,
        "bias_estimate": float(res.bias_estimate) if res.bias_estimate is not None else None,
        "bias_sources": list(res.bias_sources or []),
        "light_model": model.get("chosen"),
        "lights": b.get("lights"),
        "true": true_error(res.image, ref, ref_var),
        "true_without_edges": (None if edges is None or not edges.any() else
                               true_error(res.image[~edges], ref[~edges], ref_var[~edges])),
        "seconds": seconds,
        "probe_seconds": float(res.timings.get("probes", 0.0)),
        "timings": {k: float(v) for k, v in res.timings.items()},
        "advice": b.get("advice"),
    }


def edge_pixels(xml: Path, size, params: dict):
    """(H, W) bool: pixels whose centre lies on a shape's edge to within 1e-3 pixel, where Mitsuba's and
    this library's camera rays may hit different shapes (``testing.mitsuba.mitsuba_edge_pixels``); None
    where Mitsuba (a vectorised variant) is not installed: the cells are then judged on all pixels."""
    from ..testing import mitsuba as reference

    try:
        return reference.mitsuba_edge_pixels(xml, tuple(size), **params)
    except (ImportError, RuntimeError):
        return None


def truth(r: dict) -> float:
    """The true error a run is judged by: without the edge pixels where they were found, else all pixels."""
    return r["true"] if r.get("true_without_edges") is None else r["true_without_edges"]


def judge(runs: list[dict], target: float) -> dict:
    """Whether a cell keeps its word (module doc), with the counts behind the verdict (``truth`` of each run)."""
    runs = [{**r, "true": truth(r)} for r in runs]
    claimed = [r for r in runs if r["claimed"]]
    open_ = [r for r in runs if not r["claimed"]]
    over = sum(r["true"] > CLAIM_TOLERANCE * target for r in claimed)
    far = sum(r["true"] > CLAIM_LIMIT * target for r in claimed)
    ratios = [r["estimate"] / r["true"] for r in open_ if r["true"] > 0]
    low = sum(q < 1 / ESTIMATE_FACTOR for q in ratios)
    high = sum(q > ESTIMATE_FACTOR for q in ratios)
    off = low + high
    ok = over <= (1 if len(claimed) >= 2 else 0) and far == 0 and off == 0
    return {"claimed": len(claimed), "seeds": len(runs), "claimed_over_1_25x": over, "claimed_over_2x": far,
            "unclaimed_estimate_off_2x": off, "unclaimed_estimate_below_half": low,
            "unclaimed_estimate_above_2x": high, "keeps_its_word": ok,
            "bound_covers": sum(r["estimate"] >= r["true"] for r in runs),
            "median_true": float(np.median([r["true"] for r in runs])),
            "median_estimate": float(np.median([r["estimate"] for r in runs])),
            "mean_seconds": float(np.mean([r["seconds"] for r in runs])),
            "probe_share": float(np.sum([r["probe_seconds"] for r in runs]) / np.sum([r["seconds"] for r in runs]))}


def mitsuba_ladder(xml: Path, params: dict, size, max_depth: int, max_spp: int, ref, ref_var,
                   edges=None) -> list[tuple]:
    """(seconds, true error, spp) of Mitsuba's path tracer at spp 1, 2, 4, ... ``max_spp`` (each warmed up
    once); the true error without the ``edges`` pixels where given, as the cells are judged."""
    from ..testing import mitsuba as reference

    scene = reference.load(xml, **params)
    points, spp = [], 1
    while spp <= max_spp:
        reference.render_loaded(scene, size, max_depth=max_depth, spp=spp, seed=1)  # compile the kernel
        t = time.perf_counter()
        mean, _ = reference.render_loaded(scene, size, max_depth=max_depth, spp=spp, seed=2 + spp)
        seconds = time.perf_counter() - t
        keep = np.ones(mean.shape[:2], bool) if edges is None or not edges.any() else ~edges
        points.append((seconds, true_error(mean[keep], ref[keep], ref_var[keep]), spp))
        spp *= 2
    return points


def table(summary: dict) -> str:
    """The cells as a Markdown table."""
    lines = ["| cell | target | claimed | true error (median, max of claimed) | estimate (median) "
             "| estimate >= true error | not claimed: estimate < truth/2, > 2 truth | keeps its word "
             "| render s (mean) | probes | Mitsuba s to the same error |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for c in summary["cells"]:
        j = c["verdict"]
        claimed_true = [truth(r) for r in c["runs"] if r["claimed"]]
        mx = f"{max(claimed_true):.2%}" if claimed_true else "-"
        mit, lad = c.get("mitsuba_seconds"), c.get("mitsuba_ladder") or []
        if mit is not None:
            mit_s = f"{mit:.2f} ({c['mitsuba_how']})" if c["mitsuba_how"] != "interpolated" else f"{mit:.2f}"
        elif lad:
            last = lad[-1]
            mit_s = f"> {last['seconds']:.2f} ({last['true']:.2%} at {last['spp']} spp)"
        else:
            mit_s = "-"
        lines.append(f"| {c['cell']} | {c['target']:.0%} | {j['claimed']}/{j['seeds']} | {j['median_true']:.2%}, {mx} "
                     f"| {j['median_estimate']:.2%} | {j.get('bound_covers', '-')}/{j['seeds']} "
                     f"| {j.get('unclaimed_estimate_below_half', '-')}, "
                     f"{j.get('unclaimed_estimate_above_2x', '-')} | {'yes' if j['keeps_its_word'] else '**no**'} "
                     f"| {j['mean_seconds']:.1f} | {j['probe_share']:.0%} | {mit_s} |")
    return "\n".join(lines) + "\n"


def chart(summary: dict, png: Path) -> None:
    """Per cell and target: true error (dots, filled where claimed) and the estimate (crosses)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cells = summary["cells"]
    fig, ax = plt.subplots(figsize=(max(6, 0.55 * len(cells) + 2), 4.2))
    for i, c in enumerate(cells):
        for r in c["runs"]:
            x = i + np.random.default_rng(r["seed"]).uniform(-0.18, 0.18)
            ax.scatter(x, truth(r), s=18, color="C0" if r["claimed"] else "white", edgecolor="C0", zorder=3)
            ax.scatter(x, r["estimate"], s=18, marker="x", color="C3", zorder=3)
        ax.hlines([c["target"], CLAIM_TOLERANCE * c["target"]], i - 0.35, i + 0.35, colors=["k", "0.6"],
                  linestyles=["-", ":"])
    ax.set_yscale("log")
    ax.set_xticks(range(len(cells)), [f"{c['cell']}\n{c['target']:.0%}" for c in cells], rotation=60, ha="right",
                  fontsize=7)
    ax.set_ylabel("relative L2 against Mitsuba")
    ax.set_title("render(target_error=e): true error (o, filled: claimed) and estimate (x); lines: e, 1.25e",
                 fontsize=9)
    fig.tight_layout()
    atomic_write(png, lambda tmp: fig.savefig(tmp, format="png", dpi=110))
    plt.close(fig)


def run(args) -> dict:
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    note = ("Mitsuba timed in the same run" if args.mitsuba
            else "Mitsuba not timed (--no-mitsuba): no times beside the cells")
    summary = {"machine_note": f"wall seconds on this machine, {note}",
               "cells": [], "targets": args.targets, "seeds": args.seeds}

    def save():
        atomic_write_text(out / "targets.json", json.dumps(summary, indent=1, default=float) + "\n")

    for name in args.cells:
        rel_xml, params, max_depth, ref_name, what = CELLS[name]
        xml = REPO / rel_xml
        ref, ref_var, meta = load_reference(ref_name)
        size = tuple(meta["size"])
        ladder = None
        edges = edge_pixels(xml, size, params)  # Mitsuba's intersection alone, also with --no-mitsuba
        for target in args.targets:
            cell = {"cell": name, "what": what, "scene": display_path(xml), "params": params,
                    "max_depth": max_depth, "target": target, "reference": ref_name,
                    "reference_noise": meta["relative_noise"], "runs": []}
            summary["cells"].append(cell)
            for s in range(args.seeds):
                r = render_once(xml, params, max_depth, target, s, ref, ref_var, edges)
                cell["runs"].append(r)
                print(f"{name} e={target:.0%} seed {s}: claimed={r['claimed']} true={r['true']:.2%} "
                      f"estimate={r['estimate']:.2%} {r['seconds']:.1f} s (probes {r['probe_seconds']:.1f} s) "
                      f"model={r['light_model']}", flush=True)
                cell["verdict"] = judge(cell["runs"], target)
                save()
            if args.mitsuba:
                if ladder is None:
                    ladder = mitsuba_ladder(xml, params, size, max_depth, args.max_spp, ref, ref_var, edges)
                secs, how = time_to_error([(t, e) for t, e, _ in ladder], cell["verdict"]["median_true"])
                cell["mitsuba_ladder"] = [{"seconds": t, "true": e, "spp": n} for t, e, n in ladder]
                cell["mitsuba_seconds"], cell["mitsuba_how"] = secs, how
                save()
    md = table(summary)
    atomic_write_text(out / "targets.md", md)
    chart(summary, out / "targets.png")
    print(md)
    print(f"wrote {display_path(out / 'targets.json')}, targets.md, targets.png")
    return summary
