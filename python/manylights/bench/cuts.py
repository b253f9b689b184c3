"""``python -m manylights.bench cuts``: MRCS against reconstruction cuts at equal error, the comparison the MRCS
paper makes (Hasan, Pellacini, Bala 2007, Sec. 6: "speed improvements in the range between 20x and 30x" over
the reconstruction-cut algorithm of Lightcuts, Walter et al. 2005, Sec. 5, at high quality).

Per scene, one light set and its brute force ``T = A.column_sum()`` (the same lights for both methods, so the
error measured is each method's own, not the light model's), then on the same CPU backend with the same exact
shadow rays:

- reconstruction cuts (``ml.reconstruction_cuts``, blocks of 4 pixels, the paper's per-cluster criterion,
  ``max_cut`` 1000) at each ``--errors`` bound: seconds ``t_rc`` (cut tree included) and relative L2 ``e_rc``
  against ``T``;
- MRCS (``ml.mrcs``, rows = columns / 3, at most the pixels) at each ``--columns`` budget up to the number of
  lights, mean seconds and mean relative L2 over ``--seeds`` seeds;
- the ratio at equal error: MRCS's time to ``e_rc``, ``t_mrcs(e_rc)``, by log-log interpolation of its mean
  (seconds, error) curve, and ``t_rc / t_mrcs(e_rc)`` (> 1: MRCS is faster). Where ``e_rc`` is below every
  MRCS error the ratio is not measured ("MRCS does not reach it"); where it is above every one, MRCS's
  cheapest budget already reaches it and the ratio is a lower bound (``>=``).

The paper's 20-30x compared GPU shadow maps with a CPU ray tracer running reconstruction cuts; here both run
on one backend, so the ratio measures the two algorithms alone.

    python -m manylights.bench cuts                               # cbox, veach-ajar, many-emitters:5000
    python -m manylights.bench cuts --scenes cbox --errors 0.02 --columns 100 300

Writes ``<out>/cuts.json`` and ``<out>/cuts.md``.

| here | meaning |
|---|---|
| ``T`` | the brute force of the light set, (H, W, 3) float32 |
| ``t_rc``, ``e_rc`` | reconstruction cuts' seconds and relative L2 against ``T`` at one error bound |
| ``t_mrcs(e)`` | MRCS's seconds to relative L2 ``e``, interpolated |
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Optional

import numpy as np

import manylights as ml

from .._utils.files import atomic_write_text
from . import many_emitters
from .common import display_path, resolve_scene

#: Scene -> (load_scene keywords builder from the width, max_depth, area lights, indirect lights).
SCENES = {
    "cbox": (lambda w: {"res": w}, -1, 1024, 3072),
    "veach-ajar": (lambda w: {"resx": w, "resy": w * 9 // 16}, -1, 1024, 3072),
    "many-emitters": (lambda w: {"size": (w, w * 3 // 4)}, 2, 16384, 0),
}
DEFAULT_SCENES = ("cbox", "veach-ajar", "many-emitters:5000")


def add_parser(sub) -> None:
    p = sub.add_parser("cuts", help="MRCS against reconstruction cuts at equal error (the MRCS paper's comparison)",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scenes", nargs="+", default=list(DEFAULT_SCENES),
                   help="cbox, veach-ajar, many-emitters:N (the generated hall, written under --out)")
    p.add_argument("--res", type=int, default=64, help="image width")
    p.add_argument("--errors", type=float, nargs="+", default=[0.05, 0.02, 0.01, 0.005],
                   help="reconstruction cuts' relative error bounds per cluster")
    p.add_argument("--columns", type=int, nargs="+", default=[50, 100, 200, 400, 800, 1600],
                   help="MRCS columns (rows = columns / 3)")
    p.add_argument("--seeds", type=int, default=4, help="MRCS seeds per budget")
    p.add_argument("--block", type=int, default=4, help="reconstruction cuts' grid spacing (pixels)")
    p.add_argument("--out", default="out/bench")
    p.set_defaults(run=run)


def time_to_error(seconds, errors, target: float) -> tuple[Optional[float], str]:
    """A method's seconds to reach relative L2 ``target`` from its (seconds, error) points: log-log
    interpolation between the two budgets that bracket it on the lower convex path (errors taken as falling
    with time: each point's error is the smallest error at that time or less). Returns ``(seconds, kind)``:
    ``"interpolated"``; ``"at most"`` (the cheapest budget is already below: its seconds); ``(None,
    "not reached")`` (every error is above).

    Raises:
        ValueError: no points, lengths that differ, a non-positive time, error or target."""
    t = np.asarray(seconds, dtype=np.float64)
    e = np.asarray(errors, dtype=np.float64)
    if t.size == 0 or t.shape != e.shape:
        raise ValueError(f"need as many seconds as errors (>= 1), got {t.size} and {e.size}")
    if not (np.all(t > 0) and np.all(e > 0) and target > 0):
        raise ValueError("seconds, errors and the target must be > 0")
    order = np.argsort(t, kind="stable")
    t, e = t[order], np.minimum.accumulate(e[order])
    if e[0] <= target:
        return float(t[0]), "at most"
    if e[-1] > target:
        return None, "not reached"
    k = int(np.argmax(e <= target))  # first budget at or below the target; k >= 1
    if e[k - 1] == e[k]:
        return float(t[k]), "interpolated"
    f = (np.log(target) - np.log(e[k - 1])) / (np.log(e[k]) - np.log(e[k - 1]))
    return float(np.exp(np.log(t[k - 1]) + f * (np.log(t[k]) - np.log(t[k - 1])))), "interpolated"


def check_scene_name(name: str) -> Optional[int]:
    """The emitter count of ``many-emitters:N`` (None for a bundled scene).

    Raises:
        ValueError: a name that is none of the scenes (or a bad N)."""
    emitters = many_emitters.parse_name(name)
    if emitters is None and name not in SCENES:
        raise ValueError(f"--scenes: {name!r} is none of {', '.join(list(SCENES)[:2])}, many-emitters:N")
    return emitters


def _scene(name: str, width: int, out: Path):
    emitters = check_scene_name(name)
    if emitters is not None:
        path = many_emitters.write_scene(out / "scenes" / f"{many_emitters.PREFIX}-{emitters}", emitters)
        key = "many-emitters"
    else:
        path, key = resolve_scene(name), name
    kw, max_depth, area, indirect = SCENES[key]
    scene = ml.load_scene(path, **kw(width))
    return path, scene, max_depth, area, indirect


def measure_scene(name: str, args) -> dict:
    """One scene's row of the comparison (module doc)."""
    path, scene, max_depth, area, indirect = _scene(name, args.res, Path(args.out))
    lights = ml.generate_lights(scene, area=area, indirect=indirect, max_depth=max_depth if indirect else 5,
                                seed=0)
    A = ml.LightMatrix(scene, lights, device="cpu", max_depth=max_depth)
    t = time.perf_counter()
    truth = A.column_sum(progress=False)
    brute = time.perf_counter() - t
    out = {"scene": name, "path": display_path(path), "size": [scene.width, scene.height], "lights": A.shape[1],
           "brute_force_seconds": brute, "cuts": [], "mrcs": []}
    print(f"{name}: {scene.width}x{scene.height}, {A.shape[1]} lights, brute force {brute:.2f} s", flush=True)
    m, n = A.shape
    for c in args.columns:
        if c > n:
            print(f"  MRCS {c}: skipped, more columns than the {n} lights", flush=True)
            continue
        rows = min(max(1, c // 3), m)
        ts, es = [], []
        for s in range(args.seeds):
            t = time.perf_counter()
            res = ml.mrcs(A, rows=rows, columns=c, seed=s, add_emitted=False)
            ts.append(time.perf_counter() - t)
            es.append(ml.relative_l2(res.image, truth))
        out["mrcs"].append({"columns": c, "rows": rows, "seconds": float(np.mean(ts)),
                            "error": float(np.mean(es)), "error_std": float(np.std(es))})
        print(f"  MRCS {c}: {out['mrcs'][-1]['error']:.3%} in {out['mrcs'][-1]['seconds']:.3f} s", flush=True)
    mt = [r["seconds"] for r in out["mrcs"]]
    me = [r["error"] for r in out["mrcs"]]
    for err in args.errors:
        t = time.perf_counter()
        res = ml.reconstruction_cuts(A, error=err, seed=0, block=args.block, add_emitted=False)
        t_rc = time.perf_counter() - t
        e_rc = ml.relative_l2(res.image, truth)
        t_m, kind = time_to_error(mt, me, e_rc) if e_rc > 0 and mt else (None, "not reached")
        row = {"error_bound": err, "seconds": t_rc, "error": e_rc, "mean_cut": res.budget["mean_cut"],
               "shadow_rays": res.budget["shadow_rays"], "full_cuts": res.budget["full_cuts"],
               "capped_cuts": res.budget["capped_cuts"], "mrcs_seconds": t_m, "mrcs_kind": kind,
               "ratio": (t_rc / t_m) if t_m else None}
        out["cuts"].append(row)
        print(f"  reconstruction cuts {err:g}: {e_rc:.3%} in {t_rc:.3f} s; MRCS {kind} "
              f"{'' if t_m is None else f'{t_m:.3f} s, ratio {t_rc / t_m:.2f}'}", flush=True)
    return out


def table(summary: dict) -> str:
    """The comparison as a Markdown table."""
    lines = ["| scene (lights) | brute force | bound | reconstruction cuts: error, s, mean cut | MRCS s to that error "
             "| ratio (cuts s / MRCS s) |", "|---|---|---|---|---|---|"]
    for sc in summary["scenes"]:
        for c in sc["cuts"]:
            if c["mrcs_seconds"] is None:
                m, r = "not reached", "-"
            else:
                m = f"{'<= ' if c['mrcs_kind'] == 'at most' else ''}{c['mrcs_seconds']:.3f}"
                r = f"{'>= ' if c['mrcs_kind'] == 'at most' else ''}{c['ratio']:.2f}x"
            lines.append(f"| {sc['scene']} ({sc['lights']}) | {sc['brute_force_seconds']:.2f} s | {c['error_bound']:g} "
                         f"| {c['error']:.2%}, {c['seconds']:.3f}, {c['mean_cut']:.0f} | {m} | {r} |")
    return "\n".join(lines) + "\n"


def run(args) -> dict:
    if args.res < 4 or args.seeds < 1 or args.block < 1:
        raise ValueError(f"--res must be >= 4, --seeds and --block >= 1, got {args.res}, {args.seeds}, {args.block}")
    if not args.errors or any(not e > 0 for e in args.errors) or not args.columns or min(args.columns) < 1:
        raise ValueError(f"--errors must be > 0 and --columns >= 1, got {args.errors} and {args.columns}")
    for name in args.scenes:  # every name checked before any work
        check_scene_name(name)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    summary = {"res": args.res, "seeds": args.seeds, "block": args.block, "scenes": []}
    for name in args.scenes:
        summary["scenes"].append(measure_scene(name, args))
        atomic_write_text(out / "cuts.json", json.dumps(summary, indent=1, default=float) + "\n")
    md = table(summary)
    atomic_write_text(out / "cuts.md", md)
    print(md)
    print(f"wrote {display_path(out / 'cuts.json')}, cuts.md")
    return summary
