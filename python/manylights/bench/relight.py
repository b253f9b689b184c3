"""``python -m manylights.bench relight``: direct-to-indirect relighting (Hašan, Pellacini, Bala, SIGGRAPH
2006) measured as the paper reports it, side by side in one run.

1. **Accuracy against Mitsuba** (the paper's Figure 3: a spot light on the floor of a box, error against
   the number of kept wavelet coefficients). The bundled ``cbox`` with its ceiling light swapped for a spot
   light aimed at the floor, ``--res``^2 pixels, Mitsuba's path tracer with ``--max-depth`` (default -1, full
   global illumination) at pixel centres as the reference (cached under ``--cache``). For every count of
   ``--coefficients`` the whole precomputation runs (``DirectToIndirect(scene, gather, coefficients,
   bounces=..., multibounce_coefficients=...)``) and the spot relights the scene; the relative L2 is given
   over all pixels and without edge pixels (those whose first hit differs within the pixel, as the paper
   excludes them). A second spot placement (``--unseen``), never used by anything precomputed, is relit
   with the default coefficients and checked against its own reference.
2. **On-the-fly culling** (3.5): at the default coefficients, relights with epsilon = ``--cull`` x the L2 norm
   of the unculled image (a culled wavelet light changes the image's L2 norm by at most epsilon), reporting
   the wavelet lights culled, the error and the relight time.
3. **Frame rate** at each ``--sizes`` (default 320x240 and 640x480): precompute once (time, transfer bytes,
   peak resident memory of the process), then ``--relights`` relights of a spot moving along a path; the
   median seconds per relight, relights per second, and the median seconds per stage (``rel.timings``).

Prints the tables and writes ``<out>/relight-<scene>.json`` (after every measurement) and
``<out>/relight-<scene>.png`` (error against coefficients with and without culling; frame rate per size)
plus ``<out>/relight-<scene>-strip.png`` (relit images at three coefficient counts next to the reference).

    python -m manylights.bench relight
    python -m manylights.bench relight --res 64 --coefficients 10 100 1000 --sizes 160x120
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import manylights as ml

from .._utils.files import atomic_write, atomic_write_text
from ..io.video import to_srgb8
from ..scenes import scene_path
from ..testing import mitsuba as reference
from .vs_mitsuba import cached_reference

# The cbox spot placements (scene units: mm). The first is the precomputation's scene light, aimed at the
# floor as in the paper's Figure 3; the second is unseen by the precomputation.
SPOT_SEEN = {"origin": (278.0, 500.0, 279.6), "target": (240.0, 0.0, 240.0)}
SPOT_UNSEEN = {"origin": (120.0, 420.0, 120.0), "target": (400.0, 0.0, 380.0)}
SPOT_INTENSITY = 4.0e5  # W/sr: about the ceiling light's power


def add_parser(sub) -> None:
    p = sub.add_parser("relight", help="direct-to-indirect relighting: error vs coefficients, culling, frame rate",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scene", default="cbox", help="bundled scene whose emitters are replaced by a spot (cbox)")
    p.add_argument("--res", type=int, default=128, help="image side of the accuracy runs")
    p.add_argument("--gather", type=int, default=4**7, help="gather samples n_g (a power of 4)")
    p.add_argument("--coefficients", type=int, nargs="+", default=[10, 30, 100, 300, 1000],
                   help="final-gather coefficients kept per pixel (the chart's x axis)")
    p.add_argument("--default-coefficients", type=int, default=100,
                   help="coefficients of the culling, unseen-light and frame-rate runs (the paper's 100)")
    p.add_argument("--bounces", type=int, default=6, help="diffuse bounces (6 ~ Mitsuba's max_depth -1 in a box)")
    p.add_argument("--multibounce-coefficients", type=int, default=40)
    p.add_argument("--multibounce", default="photons", choices=["photons", "gather"], help="how M is computed")
    p.add_argument("--near-field", default="disc", choices=["disc", "point"], help="gather samples as discs or points")
    p.add_argument("--clamp", type=float, default=None, help="geometry-term clamp (1/scene unit^2; none by default)")
    p.add_argument("--max-depth", type=int, default=-1, help="Mitsuba's path depth of the references")
    p.add_argument("--ref-spp", type=int, default=16384, help="reference spp (16384: noise ~1%% at 128x128)")
    p.add_argument("--cull", type=float, nargs="+", default=[1e-4, 1e-3, 1e-2],
                   help="on-the-fly culling: epsilon as fractions of the unculled image's L2 norm")
    p.add_argument("--sizes", nargs="+", default=["320x240", "640x480"], help="frame-rate image sizes WxH")
    p.add_argument("--relights", type=int, default=20, help="relights timed per size")
    p.add_argument("--device", default="auto", choices=["auto", "cpu", "gpu"],
                   help="where relighting runs (DirectToIndirect device=; the precomputation is on the CPU)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--cache", default="out/bench/cache")
    p.add_argument("--out", default="out/bench")
    p.set_defaults(run=run)


def parse_size(text: str) -> tuple[int, int]:
    """``"WxH"`` -> (W, H), positive integers. Raises ValueError naming the text."""
    try:
        w, h = (int(v) for v in str(text).lower().split("x"))
    except ValueError:
        w = h = 0
    if not (1 <= w <= 8192 and 1 <= h <= 8192):
        raise ValueError(f"size {text!r}: expected WxH with 1 <= W, H <= 8192 (e.g. 320x240)")
    return w, h


def _check(args) -> None:
    for name in ("res", "relights", "bounces", "multibounce_coefficients", "default_coefficients", "ref_spp"):
        if getattr(args, name) < 1:
            raise ValueError(f"--{name.replace('_', '-')} must be >= 1, got {getattr(args, name)}")
    if args.gather < 4 or args.gather & (args.gather - 1) or (args.gather.bit_length() - 1) % 2:
        raise ValueError(f"--gather must be a power of 4, got {args.gather}")
    for c in list(args.coefficients) + [args.default_coefficients]:
        if not 1 <= c <= args.gather:
            raise ValueError(f"coefficient counts must be in 1..={args.gather} (--gather), got {c}")
    if any(not (c > 0 and np.isfinite(c)) for c in args.cull):
        raise ValueError(f"--cull fractions must be positive, got {args.cull}")
    if args.max_depth != -1 and args.max_depth < 2:
        raise ValueError(f"--max-depth must be -1 or >= 2, got {args.max_depth}")
    [parse_size(s) for s in args.sizes]


def spot_xml(origin, target, intensity: float = SPOT_INTENSITY) -> str:
    """A Mitsuba spot emitter (cutoff 40 deg, beam 30 deg) at ``origin`` aimed at ``target``."""
    o = ", ".join(f"{v:g}" for v in origin)
    t = ", ".join(f"{v:g}" for v in target)
    return (f'<emitter type="spot"><transform name="to_world"><lookat origin="{o}" target="{t}" up="0, 0, 1"/>'
            f'</transform><rgb name="intensity" value="{intensity:g}"/><float name="cutoff_angle" value="40"/>'
            f'<float name="beam_width" value="30"/></emitter>')


def spot_scene(scene_name: str, spot: dict, folder: Path, tag: str) -> Path:
    """The bundled scene with every emitter removed and the spot added, written as ``<folder>/<tag>/``
    (the scene's folder copied, so meshes resolve). Same input, same bytes: the reference cache keys on it."""
    dst = folder / tag
    if dst.exists():
        import shutil

        shutil.rmtree(dst)
    dst.mkdir(parents=True)
    return reference.scene_variant(scene_path(scene_name), dst, keep_emitters=[],
                                   add_emitters=[spot_xml(**spot)], remove_area_emitters=True)


def spot_light(scene, origin, target, intensity: float = SPOT_INTENSITY):
    """The same spot as ``spot_xml`` as a LightSet of ``scene`` (for relights without an XML)."""
    d = np.asarray(target, np.float64) - np.asarray(origin, np.float64)
    d /= np.linalg.norm(d)
    return ml.LightSet.from_arrays(scene, kind=1, position=[origin], direction=[d], intensity=[[intensity] * 3],
                                   cutoff_angle=np.radians(40.0), beam_width=np.radians(30.0))


def _peak_rss_mb() -> float:
    kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return kb / 1024.0 if sys.platform != "darwin" else kb / 2**20


def _rel_errors(img, ref, edges) -> dict:
    inner = ~edges
    return {"relative_l2": ml.relative_l2(img, ref),
            "relative_l2_no_edges": ml.relative_l2(img[inner], ref[inner])}


def run(args) -> int:
    _check(args)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    json_path = out / f"relight-{args.scene}.json"
    W = H = args.res
    tmp = Path(tempfile.mkdtemp(prefix="manylights-relight-"))
    paths = {"seen": spot_scene(args.scene, SPOT_SEEN, tmp, f"{args.scene}-spot"),
             "unseen": spot_scene(args.scene, SPOT_UNSEEN, tmp, f"{args.scene}-spot-unseen")}
    size_params = {"res": W} if "res" in _defaults(paths["seen"]) else {}
    scene = ml.load_scene(paths["seen"], size=(W, H), **size_params)
    refs, edges = {}, {}
    for key, path in paths.items():
        s = {"path": path, "name": f"{args.scene}-spot-{key}", "size": (W, H), "params": size_params,
             "max_depth": args.max_depth, "ref_spp": args.ref_spp}
        mean, var, meta, cached = cached_reference(s, Path(args.cache), seed=0)
        refs[key] = (mean, meta)
        # Pixels a boundary between shapes crosses (their centre moved by half a pixel hits another shape):
        # the paper's "edge pixels", where renderers with different pixel filters disagree most.
        edges[key] = reference.mitsuba_edge_pixels(path, (W, H), eps_px=0.5, **size_params)
        print(f"reference {key}: {W}x{H}, max_depth {args.max_depth}, {args.ref_spp} spp, noise "
              f"{100 * meta['relative_noise']:.2f}%{' (cached)' if cached else ''}; edge pixels "
              f"{100 * edges[key].mean():.1f}%", flush=True)

    result = {"scene": args.scene, "size": [W, H], "gather": args.gather, "bounces": args.bounces,
              "multibounce": args.multibounce, "near_field": args.near_field, "device": None,
              "multibounce_coefficients": args.multibounce_coefficients, "clamp": args.clamp,
              "max_depth": args.max_depth, "ref_spp": args.ref_spp, "seed": args.seed,
              "default_coefficients": args.default_coefficients,
              "reference_noise": {k: v[1]["relative_noise"] for k, v in refs.items()},
              "edge_fraction": {k: float(v.mean()) for k, v in edges.items()},
              "spots": {"seen": SPOT_SEEN, "unseen": SPOT_UNSEEN, "intensity": SPOT_INTENSITY},
              "coefficients": [], "culling": [], "frame_rate": [], "cpu_count": os.cpu_count()}

    def save():
        atomic_write_text(json_path, json.dumps(result, indent=2) + "\n")

    def precompute(sc, coefficients):
        t = time.perf_counter()
        rel = ml.DirectToIndirect(sc, gather=args.gather, final_gather_coefficients=coefficients, seed=args.seed,
                                  bounces=args.bounces, multibounce_coefficients=min(args.multibounce_coefficients,
                                                                                     args.gather),
                                  multibounce=args.multibounce, near_field=args.near_field, clamp=args.clamp,
                                  device=args.device, progress=True)
        return rel, time.perf_counter() - t

    # 1. error against coefficients
    spot = ml.scene_lights(scene)
    images = {}
    print(f"\n{'coefficients':>12} {'precompute s':>12} {'MB':>7} {'relight ms':>10} {'rel. L2':>8} {'no edges':>8}")
    for c in sorted(set(args.coefficients) | {args.default_coefficients}):
        rel, seconds = precompute(scene, c)
        t = time.perf_counter()
        img = rel.relight(spot)
        relight_s = time.perf_counter() - t
        images[c] = img
        errs = _rel_errors(img, refs["seen"][0], edges["seen"])
        result["device"] = dict(rel.device)
        row = {"coefficients": c, "precompute_seconds": seconds, "timings": dict(rel.timings),
               "bytes": int(rel.stats["bytes"]), "relight_seconds": relight_s, **errs}
        if c == args.default_coefficients:
            # 2. the unseen placement and on-the-fly culling, on the default precomputation
            unseen_scene = ml.load_scene(paths["unseen"], size=(W, H), **size_params)
            unseen = spot_light(scene, **SPOT_UNSEEN)
            assert np.allclose(ml.scene_lights(unseen_scene).intensity, unseen.intensity)
            result["unseen"] = _rel_errors(rel.relight(unseen), refs["unseen"][0], edges["unseen"])
            norm = float(np.linalg.norm(img.astype(np.float64)))
            base = {"epsilon_fraction": 0.0, "epsilon": 0.0, "wavelet_lights": rel.stats["wavelet_lights"],
                    "wavelet_lights_culled": 0, "relight_seconds": relight_s,
                    "transfer_seconds": rel.timings["relight_transfer"], **errs}
            result["culling"] = [base]
            for f in args.cull:
                t = time.perf_counter()
                culled = rel.relight(spot, epsilon=f * norm)
                result["culling"].append({"epsilon_fraction": f, "epsilon": f * norm,
                                          "wavelet_lights": rel.stats["wavelet_lights"],
                                          "wavelet_lights_culled": rel.stats["wavelet_lights_culled"],
                                          "relight_seconds": time.perf_counter() - t,
                                          "transfer_seconds": rel.timings["relight_transfer"],
                                          "change": ml.relative_l2(culled, img),
                                          **_rel_errors(culled, refs["seen"][0], edges["seen"])})
        result["coefficients"].append(row)
        save()
        print(f"{c:>12} {seconds:>12.2f} {row['bytes'] / 1e6:>7.1f} {1e3 * relight_s:>10.1f} "
              f"{100 * errs['relative_l2']:>7.2f}% {100 * errs['relative_l2_no_edges']:>7.2f}%", flush=True)
        del rel
    u = result["unseen"]
    print(f"unseen spot at {args.default_coefficients} coefficients: {100 * u['relative_l2']:.2f}% "
          f"({100 * u['relative_l2_no_edges']:.2f}% without edges)")
    print(f"\n{'cull eps/|img|':>14} {'culled':>14} {'change':>8} {'rel. L2':>8} {'transfer ms':>11}")
    for r in result["culling"]:
        print(f"{r['epsilon_fraction']:>14g} {r['wavelet_lights_culled']:>6}/{r['wavelet_lights']:<7} "
              f"{100 * r.get('change', 0.0):>7.3f}% {100 * r['relative_l2']:>7.2f}% {1e3 * r['transfer_seconds']:>11.2f}")

    # 3. frame rate
    print(f"\n{'size':>9} {'precompute s':>12} {'MB':>7} {'peak RSS MB':>11} {'relight ms':>10} {'relights/s':>10}  stages (ms)")
    for text in args.sizes:
        w, h = parse_size(text)
        sc = ml.load_scene(paths["seen"], size=(w, h), **({"res": w} if size_params else {}))
        rel, seconds = precompute(sc, args.default_coefficients)
        times, stages = [], {}
        for k in range(args.relights):
            a = 2 * np.pi * k / args.relights
            origin = (278.0 + 150 * np.cos(a), 500.0, 279.6 + 150 * np.sin(a))
            target = (278.0 - 120 * np.cos(a), 0.0, 279.6 - 120 * np.sin(a))
            lights = spot_light(sc, origin, target)
            t = time.perf_counter()
            rel.relight(lights)
            times.append(time.perf_counter() - t)
            for name, v in rel.timings.items():
                if name.startswith("relight_"):
                    stages.setdefault(name[len("relight_"):], []).append(v)
        med = float(np.median(times))
        row = {"size": [w, h], "precompute_seconds": seconds, "bytes": int(rel.stats["bytes"]),
               "peak_rss_mb": _peak_rss_mb(), "relight_seconds_median": med, "relights_per_second": 1.0 / med,
               "stages_median_seconds": {k: float(np.median(v)) for k, v in stages.items()},
               "timings": dict(rel.timings)}
        result["frame_rate"].append(row)
        save()
        st = " ".join(f"{k} {1e3 * v:.1f}" for k, v in row["stages_median_seconds"].items())
        print(f"{w:>4}x{h:<4} {seconds:>12.1f} {row['bytes'] / 1e6:>7.1f} {row['peak_rss_mb']:>11.0f} "
              f"{1e3 * med:>10.1f} {1.0 / med:>10.1f}  {st}", flush=True)
        del rel
    chart(result, images, refs["seen"][0], out / f"relight-{args.scene}.png", out / f"relight-{args.scene}-strip.png")
    print(f"\nwrote {json_path}, {out / f'relight-{args.scene}.png'}, {out / f'relight-{args.scene}-strip.png'}")
    return 0


def _defaults(path: Path) -> set:
    import xml.etree.ElementTree as ET

    return {e.get("name") for e in ET.parse(path).getroot() if e.tag == "default"}


def chart(result: dict, images: dict, ref: np.ndarray, png: Path, strip_png: Path) -> None:
    """Error against kept coefficients (all pixels, without edges; culled runs as points) and relights
    per second per size; and the strip of relit images next to the reference."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4))
    rows = result["coefficients"]
    c = [r["coefficients"] for r in rows]
    a.plot(c, [100 * r["relative_l2"] for r in rows], "o-", label="all pixels")
    a.plot(c, [100 * r["relative_l2_no_edges"] for r in rows], "s--", label="without edge pixels")
    culled = result["culling"][1:]
    if culled:
        a.scatter([result["default_coefficients"]] * len(culled), [100 * r["relative_l2"] for r in culled],
                  marker="x", color="k", zorder=3, label="culled on the fly (eps/|img| "
                  + ", ".join(f"{r['epsilon_fraction']:g}" for r in culled) + ")")
    noise = 100 * result["reference_noise"]["seen"]
    a.axhline(noise, color="grey", lw=0.8, ls=":", label=f"reference noise {noise:.2f}%")
    a.set_xscale("log")
    a.set_xlabel("wavelet coefficients kept per pixel (final gather)")
    a.set_ylabel("relative L2 vs Mitsuba (%)")
    a.set_title(f"{result['scene']} + spot, {result['size'][0]}x{result['size'][1]}, 4^{int(np.log(result['gather']) / np.log(4) + 0.5)} gather samples")
    a.legend(fontsize=8)
    fr = result["frame_rate"]
    b.bar([f"{r['size'][0]}x{r['size'][1]}" for r in fr], [r["relights_per_second"] for r in fr])
    b.axhline(10, color="grey", ls=":", lw=0.8, label="target 10/s")
    b.set_ylabel("relights per second")
    b.set_title("frame rate (median)")
    b.legend(fontsize=8)
    fig.tight_layout()
    atomic_write(png, lambda tmp: fig.savefig(tmp, dpi=120))
    plt.close(fig)
    keys = sorted(images)
    pick = sorted({keys[0], keys[len(keys) // 2], keys[-1]})
    tiles = [to_srgb8(images[k]) for k in pick] + [to_srgb8(ref)]
    fig, axes = plt.subplots(1, len(tiles), figsize=(3 * len(tiles), 3.3))
    for ax, t, title in zip(axes, tiles, [f"{k} coefficients" for k in pick] + ["Mitsuba"]):
        ax.imshow(t)
        ax.set_title(title, fontsize=9)
        ax.axis("off")
    fig.tight_layout()
    atomic_write(strip_png, lambda tmp: fig.savefig(tmp, dpi=120))
    plt.close(fig)
