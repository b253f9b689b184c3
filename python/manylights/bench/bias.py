"""``python -m manylights.bench bias``: is ``res.bias_estimate`` the bias a render really has?

``ml.render(scene, target_error=e)`` splits the probes' squared error into the variance its light counts and
MRCS leave (``variance_estimate``) and the rest, ``bias_estimate``: the relative L2 of ``E[I] - I*``, what no
count removes (the VPLs' clamp, a light model's missing paths). One render cannot know ``E[I]``; many seeds
can. Per cell this renders ``--seeds`` seeds with the light counts held fixed (``first_lights = max_lights``,
so every seed renders the same light model at the same counts, only the draws differ) and measures the true
bias of their mean against a stored, converged Mitsuba reference, with both noises taken out:

    b^2 = (||m - R||^2 - sum var(R) - sum s^2 / S) / ||R||^2                                      (1)

``m`` the mean of the S renders, ``s^2`` their per-pixel sample variance (so ``s^2 / S`` is the variance of
``m``), ``var(R)`` the stored variance of the reference. The squared standard error of (1) comes from the
seeds' spread of ``||I_s - R||^2`` (a jackknife over seeds). The same is done in relMSE (Rousselle et al.
2011: ``(I - R)^2 / (R^2 + 0.01)`` averaged over pixels), where a dark corner's bias shows that barely moves
relative L2.

Seeds that choose different light models (``budget['light_model']['chosen']``: the lights as generated or
with the clamp's compensation) render different expectations; each model's seeds are a group of their own,
and a group is judged when it has at least ``MIN_GROUP`` seeds. A group **covers its bias** when the median
``bias_estimate`` of its seeds is within a factor ``FACTOR`` (2) of the true bias, or within ``ABSOLUTE``
(0.5%) of it where the bias is that small, for a true bias within two standard errors of the measured one. Beside it, how many seeds' ``bias_upper`` (the probes' upper
bound on the bias, ``sqrt(error_estimate^2 - q variance_estimate^2)``, ``q`` the variance's lower-bound factor)
is at least the true bias.

    python -m manylights.bench bias                          # three indirect-lit cells, 16 seeds
    python -m manylights.bench bias --cells cbox-gi-64 --seeds 4

Writes ``<out>/bias.json`` after every render (Ctrl-C keeps what was measured) and ``<out>/bias.md``.

Symbols
-------
| here | meaning |
|---|---|
| ``I_s``, ``m`` | the render of seed s, (H, W, 3) float32, and the mean over S seeds |
| ``R`` | the converged Mitsuba reference |
| ``b`` | true bias: relative L2 of ``E[I] - R``, equation (1) |
| ``bias_estimate`` | ``res.bias_estimate``, one render's estimate of ``b`` from its probes |
"""
from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

import manylights as ml

from .._utils.files import atomic_write_text
from ..renderers.probe_error import variance_lower
from .common import REPO, display_path
from .targets import CELLS, load_reference

#: cell name (from ``bench.targets.CELLS``) -> fixed light count per kind: clamped-VPL interiors.
BIAS_CELLS = {"cbox-gi-64": 16384, "staircase-gi-64": 65536, "veach-ajar-gi-32": 65536}
#: the target each render is given (MRCS renders to sqrt(1 - g) of it; the counts are fixed).
TARGET = 0.05
#: a model's group is judged with at least this many seeds ...
MIN_GROUP = 4
#: ... its median estimate within this factor of the true bias ...
FACTOR = 2.0
#: ... or within this absolute relative L2 of it.
ABSOLUTE = 0.005


def add_parser(sub) -> None:
    p = sub.add_parser("bias", help="res.bias_estimate against the true bias of the mean over seeds "
                                    "(fixed light counts, converged Mitsuba references)")
    p.add_argument("--cells", nargs="+", default=list(BIAS_CELLS), choices=list(BIAS_CELLS))
    p.add_argument("--seeds", type=int, default=16)
    p.add_argument("--out", default="docs/bench")
    p.set_defaults(run=run)


def true_bias(images: np.ndarray, ref: np.ndarray, ref_var: np.ndarray) -> dict:
    """Equation (1) for ``images`` (S, H, W, 3) against ``ref`` (H, W, 3) with variance ``ref_var``:
    ``bias`` (relative L2, >= 0), its jackknife standard error ``bias_se``, and ``relmse`` the same in
    relMSE (``(m - R)^2 / (R^2 + 0.01)`` mean over pixels and channels, each noise term likewise removed).

    Raises:
        ValueError: fewer than 2 images (no spread to remove)."""
    x = np.asarray(images, np.float64)
    s = x.shape[0]
    if s < 2:
        raise ValueError(f"true_bias needs >= 2 renders, got {s}")
    r = np.asarray(ref, np.float64)
    rv = np.asarray(ref_var, np.float64)
    norm2 = float((r * r).sum())
    w = 1.0 / (r * r + 0.01)

    def b2(sub: np.ndarray) -> tuple[float, float]:
        m = sub.mean(axis=0)
        var_m = sub.var(axis=0, ddof=1) / sub.shape[0]
        d2 = (m - r) ** 2 - rv - var_m
        return float(d2.sum()) / norm2, float((d2 * w).mean())

    full, rel = b2(x)
    jack = np.array([b2(np.delete(x, i, axis=0))[0] for i in range(s)]) if s >= 3 else np.array([full])
    se2 = (s - 1) / s * float(((jack - jack.mean()) ** 2).sum())
    bias = float(np.sqrt(max(full, 0.0)))
    # The standard error of sqrt(b^2) by the delta method, floored where b^2 is near 0.
    se = float(np.sqrt(se2) / (2 * max(bias, np.sqrt(np.sqrt(se2)) if se2 > 0 else 1e-12)))
    return {"bias": bias, "bias_squared": full, "bias_se": se, "relmse": max(rel, 0.0)}


def judge(estimates: list[float], truth: float, truth_se: float = 0.0) -> bool:
    """A group covers its bias: the median estimate within ``FACTOR`` of the true bias or ``ABSOLUTE`` of it,
    for some true bias within 2 standard errors (``truth_se``) of the measured ``truth`` (the seeds measure
    the bias no better than that)."""
    med = float(np.median(estimates))
    lo, hi = max(truth - 2.0 * truth_se, 0.0), truth + 2.0 * truth_se
    nearest = min(max(med, lo), hi)  # the true bias in [lo, hi] closest to the estimate
    if abs(med - nearest) <= ABSOLUTE:
        return True
    # within FACTOR of some b in [lo, hi]: the intervals [b / FACTOR, FACTOR b] cover [lo / FACTOR, FACTOR hi]
    return hi > 0 and lo / FACTOR <= med <= FACTOR * hi


def upper_bound(r: dict) -> float:
    """A run's upper bound on its bias: ``bias_upper`` as the probes report it, else from its error estimate
    and variance part, ``sqrt(max(error_estimate^2 - q variance_estimate^2, 0))`` with ``q`` the variance's
    lower-bound factor at 90% (``probe_error.variance_lower``; the same number)."""
    if r.get("bias_upper") is not None:
        return float(r["bias_upper"])
    q = variance_lower(0.9)
    return float(np.sqrt(max(r["error_estimate"] ** 2 - q * (r["variance_estimate"] or 0.0) ** 2, 0.0)))


def run(args) -> dict:
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    summary = {"target": TARGET, "seeds": args.seeds, "cells": []}

    def save():
        atomic_write_text(out / "bias.json", json.dumps(summary, indent=1, default=float) + "\n")

    for name in args.cells:
        rel_xml, params, max_depth, ref_name, what = CELLS[name]
        lights = BIAS_CELLS[name]
        ref, ref_var, meta = load_reference(ref_name)
        cell = {"cell": name, "what": what, "lights_per_kind": lights, "reference": ref_name,
                "reference_noise": meta["relative_noise"], "runs": [], "groups": []}
        summary["cells"].append(cell)
        images = []
        for s in range(args.seeds):
            t = time.perf_counter()
            res = ml.render(REPO / rel_xml, target_error=TARGET, seed=s, params=params, max_depth=max_depth,
                            first_lights=lights, max_lights=lights, progress=False)
            images.append(res.image)
            model = (res.budget.get("light_model") or {}).get("chosen")
            cell["runs"].append({"seed": s, "model": model, "bias_estimate": res.bias_estimate,
                                 "bias_upper": (res.budget.get("probes") or {}).get("bias_upper"),
                                 "variance_estimate": res.variance_estimate, "error_estimate": res.error_estimate,
                                 "seconds": time.perf_counter() - t,
                                 "counts": {k: v["count"] for k, v in res.budget["light_counts"].items()
                                            if isinstance(v, dict) and "count" in v}})
            print(f"{name} seed {s}: model={model} bias_estimate={res.bias_estimate} "
                  f"variance={res.variance_estimate:.3g} ({time.perf_counter() - t:.1f} s)", flush=True)
            save()
        cell["groups"] = []
        for model in sorted({r["model"] for r in cell["runs"]}, key=str):
            idx = [i for i, r in enumerate(cell["runs"]) if r["model"] == model]
            est = [cell["runs"][i]["bias_estimate"] or 0.0 for i in idx]
            g = {"model": model, "seeds": len(idx), "median_bias_estimate": float(np.median(est)),
                 "bias_estimates": est}
            if len(idx) >= 2:
                g.update(true_bias(np.stack([images[i] for i in idx]), ref, ref_var))
            if len(idx) >= MIN_GROUP:
                g["covers"] = judge(est, g["bias"], g["bias_se"])
            if "bias" in g:
                up = [upper_bound(cell["runs"][i]) for i in idx]
                g["upper_at_least_true"] = int(sum(u >= g["bias"] for u in up))
                g["median_bias_upper"] = float(np.median(up))
            cell["groups"].append(g)
        save()
    md = table(summary)
    atomic_write_text(out / "bias.md", md)
    print(md)
    print(f"wrote {display_path(out / 'bias.json')}, bias.md")
    return summary


def table(summary: dict) -> str:
    """The groups as a Markdown table."""
    lines = ["| cell | lights per kind | light model | seeds | true bias (relative L2, +- 1 s.e.) "
             "| bias_estimate (median, range) | covered | bias_upper (median; seeds >= true bias) "
             "| true relMSE of the mean |",
             "|---|---|---|---|---|---|---|---|---|"]
    for c in summary["cells"]:
        for g in c["groups"]:
            tb = f"{g['bias']:.2%} +- {g['bias_se']:.2%}" if "bias" in g else "-"
            rng = f"{min(g['bias_estimates']):.2%}-{max(g['bias_estimates']):.2%}"
            cov = {True: "yes", False: "**no**"}.get(g.get("covers"), "too few seeds")
            rel = f"{g['relmse']:.2g}" if "relmse" in g else "-"
            up = (f"{g['median_bias_upper']:.2%}; {g['upper_at_least_true']}/{g['seeds']}"
                  if "median_bias_upper" in g else "-")
            lines.append(f"| {c['cell']} | {c['lights_per_kind']} | {g['model']} | {g['seeds']} | {tb} "
                         f"| {g['median_bias_estimate']:.2%} ({rng}) | {cov} | {up} | {rel} |")
    return "\n".join(lines) + "\n"
