"""Time to equal error from measured (seconds, error) ladders: the crossing of each error threshold,
interpolated log-log between the two measured points that bracket it, the tables ``bench vs-mitsuba``
prints and its chart (relative L2 against seconds, one curve per method and backend). Used by
``bench vs_mitsuba`` and ``bench targets``.

| here | meaning |
|---|---|
| ``points`` | (seconds, error) of one method's ladder, in the order measured |
| ``threshold`` | the relative L2 a method must reach |
"""
from __future__ import annotations

from pathlib import Path
from typing import Optional

import numpy as np

from .._utils.files import atomic_write


def time_to_error(points, threshold: float) -> tuple[Optional[float], str]:
    """Seconds a method needs to reach relative L2 ``threshold``, from measured (seconds, error) points.

    The points are taken in time order; the first consecutive pair (t0, e0), (t1, e1) with
    e0 > threshold >= e1 brackets it and the time is interpolated linearly in log t against log e
    (t0 <= result <= t1). Returns (seconds, "interpolated"); (t_first, "at most") when the cheapest
    point is already at or below the threshold; (None, "not reached") when no point is.
    """
    pts = sorted((float(t), float(e)) for t, e in points)
    if not pts:
        return None, "not reached"
    if pts[0][1] <= threshold:
        return pts[0][0], "at most"
    for (t0, e0), (t1, e1) in zip(pts, pts[1:]):
        if e0 > threshold >= e1:
            if e1 <= 0.0 or e0 == e1:
                return t1, "interpolated"
            f = (np.log(threshold) - np.log(e0)) / (np.log(e1) - np.log(e0))
            return float(np.exp(np.log(t0) + f * (np.log(t1) - np.log(t0)))), "interpolated"
    return None, "not reached"


def _curves(records: list[dict], key: str) -> dict[str, list[tuple[float, float]]]:
    curves: dict[str, list] = {}
    for r in records:
        if r.get(key) is not None:
            curves.setdefault(r["curve"], []).append((r["seconds"], r[key]))
    return curves


def threshold_table(records: list[dict], thresholds, key: str = "relative_l2") -> list[dict]:
    """Per threshold: each curve's (seconds, how) from ``time_to_error`` and Mitsuba / MRCS ratios."""
    curves = _curves(records, key)
    rows = []
    for thr in thresholds:
        row = {"threshold": thr, "metric": key, "curves": {}}
        for name, pts in curves.items():
            t, how = time_to_error(pts, thr)
            row["curves"][name] = {"seconds": t, "how": how}
        mit = row["curves"].get("mitsuba", {}).get("seconds")
        row["ratio_mitsuba_over"] = {
            name: (mit / c["seconds"] if mit is not None and c["seconds"] else None)
            for name, c in row["curves"].items() if name != "mitsuba"}
        rows.append(row)
    return rows


def best_error_rows(records: list[dict], key: str = "relative_l2") -> list[dict]:
    """For each MRCS curve: its lowest error, the time it took, and Mitsuba's time to the same error."""
    curves = _curves(records, key)
    rows = []
    for name, pts in curves.items():
        if name == "mitsuba":
            continue
        t, e = min(pts, key=lambda p: p[1])
        mt, how = time_to_error(curves.get("mitsuba", []), e)
        rows.append({"curve": name, "metric": key, "relative_l2": e, "seconds": t, "mitsuba_seconds": mt,
                     "mitsuba_how": how, "ratio": (mt / t if mt is not None else None)})
    return rows


def _fmt_t(c: dict) -> str:
    if c["seconds"] is None:
        return "not reached"
    return ("<=" if c["how"] == "at most" else "") + f"{c['seconds']:.3g} s"


def print_tables(summary: dict) -> None:
    keys = [("relative_l2", "all pixels")]
    if summary.get("report_edges") and summary.get("edge_pixels"):
        keys.append(("relative_l2_no_edges", f"without the {summary['edge_pixels']} shape-edge pixels"))
    for key, what in keys:
        table = summary["thresholds_" + key]
        names = list(table[0]["curves"]) if table else []
        others = [n for n in names if n != "mitsuba"]
        head = f"{'rel. L2':>8s} | {'mitsuba':>12s}" + "".join(f" | {n:>12s} | {'ratio':>7s}" for n in others)
        print(f"\ntime to relative L2 ({what}; ratio = Mitsuba time / the method's time, > 1: the method is faster)")
        print(head)
        print("-" * len(head))
        for row in table:
            line = f"{row['threshold']:8.2%} | {_fmt_t(row['curves'].get('mitsuba', {'seconds': None})):>12s}"
            for n in others:
                ratio = row["ratio_mitsuba_over"][n]
                line += f" | {_fmt_t(row['curves'][n]):>12s} | {(f'{ratio:.2f}x' if ratio else '-'):>7s}"
            print(line)
        for b in summary["best_" + key]:
            mt = "not reached" if b["mitsuba_seconds"] is None else f"{b['mitsuba_seconds']:.3g} s"
            print(f"lowest {b['curve']} error {b['relative_l2']:.2%} in {b['seconds']:.3g} s; Mitsuba to that error: "
                  f"{mt}" + (f" (ratio {b['ratio']:.2f}x)" if b["ratio"] else ""))


def chart(summary: dict, png: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 5))
    keys = [("relative_l2", "-o", "")]
    if summary.get("report_edges") and summary.get("edge_pixels"):
        keys.append(("relative_l2_no_edges", "--x", " (no edge pixels)"))
    for key, style, suffix in keys:
        for k, (name, pts) in enumerate(_curves(summary["records"], key).items()):
            ax.plot([p[0] for p in pts], [p[1] for p in pts], style, color=f"C{k}", label=name + suffix)
    for thr in summary["thresholds"]:
        ax.axhline(thr, color="grey", linestyle=":", linewidth=1)
        ax.annotate(f"{thr:.3g}", (1.0, thr), xycoords=("axes fraction", "data"), fontsize=7, ha="right", va="bottom")
    ax.axhline(summary["reference"]["relative_noise"], color="black", linestyle="-.", linewidth=0.8,
               label="reference noise")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("seconds per image (wall clock)")
    ax.set_ylabel("relative L2 vs converged Mitsuba reference")
    W, H = summary["size"]
    ax.set_title(f"{summary['scene_name']} {W}x{H}, max_depth {summary['max_depth']}: many-light methods vs Mitsuba path",
                 fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    atomic_write(png, lambda tmp: fig.savefig(tmp, dpi=120))
    plt.close(fig)


# ------------------------------------------------------------------------------------------- measuring
