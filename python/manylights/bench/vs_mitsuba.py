"""``python -m manylights.bench vs-mitsuba --scene S``: time to equal error, MRCS against Mitsuba's path tracer.

The question a user asks: to get an image within x% relative L2 of the converged result, is MRCS or
Mitsuba 3's ``path`` integrator faster, on this machine? One run answers it side by side:

1. A converged Mitsuba pixel-centre reference (``reference.mitsuba_render``: camera rays through pixel
   centres, the rest random, ``--ref-spp`` samples, ``--ref-seed``) is rendered once and cached under
   ``--cache`` (EXR of the mean, EXR of the variance of the mean, JSON of the parameters), keyed by the
   scene's content (the XML and every file in its folder), its path, loader parameters, image size,
   max_depth, spp, seed and the Mitsuba version and variant. Its own noise, sqrt(sum var) / ||mean||, is
   estimated from the per-pixel variance and printed.
2. Mitsuba's path tracer (``llvm_ad_rgb`` where it works, the reference's max_depth, pixel-centre rays, seeds
   other than the reference's) at spp 1, 2, 4, ... up to ``--max-spp``. Each level is rendered once untimed
   first (warm-up: Dr.Jit compiles one kernel per wavefront shape and caches it; that one-time compile is
   not what a user pays per render), then timed wall-clock from the loaded scene to the image in numpy.
   Sub-second renders are repeated (up to 5 runs or 1 s) and the median time is reported.
3. MRCS on each backend of ``--devices`` at increasing budgets (lights, rows, columns): the time includes
   ``ml.generate_lights`` (area + environment lights, + indirect VPLs for full GI), ``ml.LightMatrix`` and
   ``ml.mrcs``. One untimed warm-up render per backend first (GPU adapter and pipeline creation). Scene
   loading is left out of both methods' times.

4. With ``--samplers``: light-BVH sampling, RIS and / or Stochastic Lightcuts (CPU backend, exact rays) at
   each ``--samples`` count (shadow rays per view sample; the cut size for Stochastic Lightcuts) over
   ``--sampler-lights`` lights, timed like MRCS (light generation, matrix, render).

``--scene many-emitters:N`` writes the generated hall with N emitters (``bench.many_emitters``) under
``--cache`` and measures it: the scene those samplers were designed for.

Every budget and every spp level is rendered with ``--seeds`` seeds (default 3): its error is the root mean
square of the per-seed errors, its time the median (a single seed's MRCS error scatters by ~10% around it,
enough to move a threshold crossing by a ladder step).

MRCS runs first; its ladder stops once an error at or below the smallest threshold is measured, and
Mitsuba's once it is below both the smallest threshold and the lowest MRCS error (``--no-early-stop``: run
them all). For each threshold (default 5%, 2%, 1%; cbox-lights also 2.5%) the time each method needs is
interpolated log-log between the two measured points that bracket it (the first crossing in time order;
"not reached" if none does; "<=" if the cheapest point is already below it), with the ratio Mitsuba time /
MRCS time (> 1: MRCS is faster). For each MRCS backend it also prints the lowest error MRCS reached and
Mitsuba's time to that error. Relative L2 is ``manylights.metrics.relative_l2`` against the reference;
where pixel centres lie exactly on shape edges (``reference.mitsuba_edge_pixels``: cbox-lights has a ~2%
floor from them) the table is printed a second time with those pixels left out.

Writes ``<out>/vs-mitsuba-<scene>.json`` (after every measurement, so Ctrl-C keeps what was measured) and
``<out>/vs-mitsuba-<scene>.png`` (relative L2 against seconds, log-log, one curve per method/backend, the
thresholds as horizontal lines).

    python -m manylights.bench vs-mitsuba --scene cbox
    python -m manylights.bench vs-mitsuba --scene cbox-lights --devices cpu --res 64 --budgets 1000:30:100
    python -m manylights.bench vs-mitsuba --scene many-emitters:5000 --devices cpu \
        --samplers light_bvh_sampling ris_sampling stochastic_lightcuts
"""
from __future__ import annotations

import argparse
import hashlib
import json
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import manylights as ml

from .._utils.files import atomic_write_text
from .._utils.files import folder_hash as scene_hash
from .._utils.progress import progress_bar
from ..scenes import resolve
from ..testing import mitsuba as reference
from . import many_emitters
from .common import display_path
from .time_to_error import best_error_rows, chart, print_tables, threshold_table

#: Lanes per Mitsuba wavefront (W * H * spp per batch): ~1M keeps memory at a few hundred MB and is as
#: fast per sample as larger wavefronts on this machine.
LANES = 1 << 20
#: Timing: a render is repeated (same seed, same image) until REPEAT_SECONDS of timed renders or
#: MAX_REPEATS runs, and the median is reported (sub-second renders vary by tens of percent run to run).
REPEAT_SECONDS = 1.0
MAX_REPEATS = 5

GI_BUDGETS = [(1000, 30, 100), (4000, 100, 300), (16000, 200, 600), (50000, 300, 900), (100000, 600, 1800)]
DIRECT_BUDGETS = [(1000, 30, 100), (4000, 100, 300), (16000, 200, 600), (64000, 300, 900)]
#: cbox crosses 1% between 1,000 and 4,000 lights, so its ladder is dense there, and its rows are many: on the
#: CPU backend a row of 2,000 lights costs ~1/8 of a 128x128 column, and rows buy accuracy cheaply. Measured
#: (4 seeds, RMS error against the reference, CPU seconds): 2,000 lights with 150 rows and 110 columns 0.97% in
#: 0.26 CPU-s; with 50 rows it needs ~160 columns (1.1%, 0.35 CPU-s).
CBOX_BUDGETS = [(1000, 100, 80), (1500, 150, 110), (2000, 150, 150), (3000, 200, 200), (4000, 300, 300),
                (16000, 300, 600), (50000, 300, 900)]


@dataclass
class SceneDefaults:
    """Per-scene defaults: image width (height from the film's aspect), the loader parameters naming the
    size, Mitsuba max_depth (-1 = full GI), reference spp, Mitsuba's largest spp, MRCS budgets
    (lights, rows, columns), thresholds, and whether to report errors without shape-edge pixels."""

    width: int
    size_params: tuple = ("res",)
    max_depth: int = -1
    ref_spp: int = 4096
    max_spp: int = 1024
    budgets: list = field(default_factory=lambda: list(GI_BUDGETS))
    thresholds: tuple = (0.05, 0.02, 0.01)
    report_edges: bool = False


# Reference spp: its relative L2 noise is resolution-independent (sum of variances over pixels against
# the image norm) and falls as 1/sqrt(spp). Measured: cbox GI 0.19% at 960 spp, cbox-lights direct 0.74% at
# 14k spp (the environment map is noisy), veach-ajar GI 8.2% at 4096 spp (lit through a door gap: no
# affordable spp gets it below 1%; MRCS's own floor there is ~19%, see docs/validation/vs-mitsuba.md), demo direct 1.16% at
# 4096 spp (four emitters, one picked per sample). Reference cost on 2 cores: ~2.4-5 M samples/s (llvm).
DEFAULTS = {
    "cbox": SceneDefaults(width=128, max_depth=-1, ref_spp=2048, max_spp=1024,
                          budgets=list(CBOX_BUDGETS)),  # noise ~0.13%
    "cbox-lights": SceneDefaults(width=128, max_depth=2, ref_spp=131072, max_spp=8192, budgets=list(DIRECT_BUDGETS),
                                 thresholds=(0.05, 0.025, 0.02, 0.01), report_edges=True),  # noise ~0.25%
    "veach-ajar": SceneDefaults(width=64, size_params=("resx", "resy"), max_depth=-1, ref_spp=65536,
                                max_spp=4096, thresholds=(0.5, 0.2, 0.05, 0.02, 0.01)),  # noise ~2%
    "demo": SceneDefaults(width=128, max_depth=2, ref_spp=65536, max_spp=8192,
                          budgets=list(DIRECT_BUDGETS)),  # noise ~0.29%
}
GENERIC = SceneDefaults(width=128, size_params=())
#: The generated many-emitter hall (``bench.many_emitters``): direct light; Mitsuba picks one of thousands of
#: emitters per sample, so its reference needs many samples. Its emitters are smaller than a pixel's footprint,
#: so some pixel centres lie on an emitter's edge, where the hit is decided by rounding: at 64 x 48 with 5,000
#: emitters 5 such pixels carried 99.96% of every method's squared error (a 19.5% floor), so the table is also
#: printed without the shape-edge pixels.
MANY_EMITTERS = SceneDefaults(width=128, size_params=(), max_depth=2, ref_spp=16384, max_spp=4096,
                              budgets=[(4000, 100, 300), (16000, 200, 600), (64000, 300, 900)],
                              thresholds=(0.2, 0.1, 0.05, 0.02, 0.01), report_edges=True)
#: The light-tree samplers ``--samplers`` can add: name -> f(A, samples, seed) -> RenderResult.
SAMPLERS = {
    "light_bvh_sampling": lambda A, k, seed: ml.light_bvh_sampling(A, samples=k, seed=seed),
    "ris_sampling": lambda A, k, seed: ml.ris_sampling(A, samples=k, seed=seed),
    "stochastic_lightcuts": lambda A, k, seed: ml.stochastic_lightcuts(A, cut_size=k, seed=seed),
}


def add_parser(sub) -> None:
    p = sub.add_parser("vs-mitsuba", help="time to 5/2/1%% relative L2: MRCS (CPU/GPU) against Mitsuba's path tracer",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scene", required=True,
                   help=f"bundled scene ({', '.join(DEFAULTS)}), {many_emitters.PREFIX}:N (the generated hall with N "
                        "emitters, written under --cache) or a scene XML path")
    p.add_argument("--res", type=int, default=None, help="image width (height from the film's aspect); "
                   "default per scene (128; veach-ajar 64)")
    p.add_argument("--max-depth", type=int, default=None,
                   help="Mitsuba path max_depth for reference, Mitsuba and MRCS (-1 full GI, 2 direct); default "
                        "per scene (cbox, veach-ajar -1; cbox-lights, demo 2)")
    p.add_argument("--ref-spp", type=int, default=None, help="reference spp (default per scene: noise well below 1%%)")
    p.add_argument("--ref-seed", type=int, default=0)
    p.add_argument("--cache", default="out/bench/cache", help="reference cache folder")
    p.add_argument("--spp", type=int, nargs="+", default=None, help="Mitsuba spp levels (default 1, 2, 4, ... --max-spp)")
    p.add_argument("--max-spp", type=int, default=None, help="largest Mitsuba spp of the default ladder")
    p.add_argument("--budgets", nargs="+", default=None, metavar="LIGHTS:ROWS:COLUMNS",
                   help="MRCS budgets, e.g. 1000:30:100 16000:200:600 (default per scene)")
    p.add_argument("--devices", nargs="+", default=["cpu", "gpu"], choices=["cpu", "gpu", "auto"],
                   help="MRCS backends (ml.LightMatrix device=)")
    p.add_argument("--gpu-visibility", default="hybrid", choices=["hybrid", "shadow_map", "ray_traced"],
                   help="visibility of the GPU backend (the CPU backend always casts exact rays)")
    p.add_argument("--thresholds", type=float, nargs="+", default=None,
                   help="relative L2 thresholds as fractions (default 0.05 0.02 0.01; cbox-lights adds 0.025)")
    p.add_argument("--seed", type=int, default=1, help="first seed of MRCS (lights and sampling) and of Mitsuba's renders")
    p.add_argument("--seeds", type=int, default=3,
                   help="seeds per budget and per spp level: errors are the RMS over them, times the median")
    p.add_argument("--samplers", nargs="*", default=[], choices=list(SAMPLERS),
                   help="also chart these light-tree samplers (CPU backend, exact rays) at each --samples count")
    p.add_argument("--samples", type=int, nargs="+", default=[1, 4, 16, 64],
                   help="shadow rays per view sample of the samplers (Stochastic Lightcuts: the cut size)")
    p.add_argument("--sampler-lights", type=int, default=None,
                   help="lights the samplers draw from (default: the largest MRCS budget's)")
    p.add_argument("--no-early-stop", action="store_true",
                   help="run every level even after the smallest threshold is reached")
    p.add_argument("--out", default="out/bench")
    p.set_defaults(run=run)


# ----------------------------------------------------------------------------------------------- set-up
def parse_budget(text: str) -> tuple[int, int, int]:
    """``"LIGHTS:ROWS:COLUMNS"`` -> (lights, rows, columns), each a positive integer.

    Raises:
        ValueError: not three ':'-separated positive integers (the text is named)."""
    parts = str(text).split(":")
    try:
        vals = tuple(int(p) for p in parts)
    except ValueError:
        vals = ()
    if len(vals) != 3 or min(vals) < 1:
        raise ValueError(f"budget {text!r}: expected LIGHTS:ROWS:COLUMNS, three positive integers (e.g. 4000:100:300)")
    return vals


def _settings(args) -> dict:
    """Resolve the per-scene defaults and check every argument (ValueError naming the bad value)."""
    emitters = many_emitters.parse_name(args.scene)
    if emitters is not None:
        name = f"{many_emitters.PREFIX}-{emitters}"
        path = many_emitters.write_scene(Path(args.cache) / "scenes" / name, emitters)
        d = MANY_EMITTERS
    else:
        path = resolve(args.scene)
        name = path.parent.name if path.name == "scene.xml" else path.stem
        d = DEFAULTS.get(name) if path.parent.parent.name == "scenes" else None
        d = d or GENERIC
    width = d.width if args.res is None else args.res
    max_depth = d.max_depth if args.max_depth is None else args.max_depth
    ref_spp = d.ref_spp if args.ref_spp is None else args.ref_spp
    max_spp = d.max_spp if args.max_spp is None else args.max_spp
    if not 1 <= width <= 8192:
        raise ValueError(f"--res must be in [1, 8192], got {width}")
    if max_depth != -1 and max_depth < 2:
        raise ValueError(f"--max-depth must be -1 (unlimited) or >= 2, got {max_depth}")
    if ref_spp < 2:
        raise ValueError(f"--ref-spp must be >= 2 (its variance estimates the reference noise), got {ref_spp}")
    if max_spp < 1:
        raise ValueError(f"--max-spp must be >= 1, got {max_spp}")
    spp = args.spp if args.spp is not None else [1 << k for k in range(max_spp.bit_length()) if (1 << k) <= max_spp]
    if not spp or min(spp) < 1:
        raise ValueError(f"--spp levels must be positive integers, got {spp}")
    budgets = [parse_budget(b) for b in args.budgets] if args.budgets is not None else list(d.budgets)
    if not budgets:
        raise ValueError("--budgets: give at least one LIGHTS:ROWS:COLUMNS")
    thresholds = tuple(args.thresholds) if args.thresholds is not None else d.thresholds
    for t in thresholds:
        if not 0.0 < t < 1e3 or t != t:
            raise ValueError(f"--thresholds must be positive fractions (0.01 = 1%), got {t}")
    if args.seeds < 1:
        raise ValueError(f"--seeds must be >= 1, got {args.seeds}")
    samplers = list(dict.fromkeys(getattr(args, "samplers", None) or []))
    samples = sorted(set(getattr(args, "samples", None) or [1]))
    if min(samples) < 1:
        raise ValueError(f"--samples must be positive integers, got {samples}")
    sampler_lights = getattr(args, "sampler_lights", None)
    sampler_lights = max(b[0] for b in budgets) if sampler_lights is None else sampler_lights
    if sampler_lights < 1:
        raise ValueError(f"--sampler-lights must be >= 1, got {sampler_lights}")
    if args.ref_seed < 0 or args.seed < 0:
        raise ValueError(f"seeds must be >= 0, got --ref-seed {args.ref_seed}, --seed {args.seed}")
    film = ml.load_scene(path)
    height = max(1, round(width * film.height / film.width))
    if d.size_params == ("res",):
        params = {"res": width}
    elif d.size_params == ("resx", "resy"):
        params = {"resx": width, "resy": height}
    else:
        params = {}
    return {"path": path, "name": name, "size": (width, height), "params": params, "max_depth": max_depth,
            "ref_spp": ref_spp, "spp": sorted(set(spp)), "budgets": sorted(set(budgets)),
            "thresholds": tuple(sorted(set(thresholds), reverse=True)), "report_edges": d.report_edges,
            "samplers": samplers, "samples": samples, "sampler_lights": sampler_lights}


def relative_noise(mean: np.ndarray, var: np.ndarray) -> float:
    """Expected relative L2 of a Monte Carlo image against its own expectation: sqrt(sum var) / ||mean||."""
    return float(np.sqrt(np.sum(var, dtype=np.float64)) / np.linalg.norm(mean.astype(np.float64)))


def cached_reference(s: dict, cache: Path, seed: int) -> tuple[np.ndarray, np.ndarray, dict, bool]:
    """The pixel-centre reference of settings ``s``, from ``cache`` when a run with the same key stored it,
    else rendered (with a progress bar) and stored. Returns (mean, variance of the mean, metadata, cached).

    The EXRs are written under temporary names and renamed, the JSON last: a run stopped while writing
    leaves no entry that a later run would take for complete."""
    mi = reference.mitsuba()
    W, H = s["size"]
    # The path as results show it (repository-relative for bundled scenes): the content hash tells scenes apart.
    key_fields = {"scene": display_path(s["path"]), "scene_sha256": scene_hash(s["path"]), "params": s["params"],
                  "size": [W, H], "max_depth": s["max_depth"], "spp": s["ref_spp"], "seed": seed,
                  "footprint": "pixel centre", "mitsuba": mi.__version__, "variant": mi.variant()}
    key = hashlib.sha256(json.dumps(key_fields, sort_keys=True).encode()).hexdigest()[:16]
    stem = cache / f"ref-{s['name']}-{W}x{H}-depth{s['max_depth']}-{s['ref_spp']}spp-seed{seed}-{key}"
    meta_path = Path(f"{stem}.json")
    if meta_path.is_file():
        meta = json.loads(meta_path.read_text())
        if meta.get("key") == key:
            return ml.read_exr(f"{stem}.exr"), ml.read_exr(f"{stem}.var.exr"), meta, True
    cache.mkdir(parents=True, exist_ok=True)
    t = time.perf_counter()
    with progress_bar(s["ref_spp"], "reference", True, unit="sample") as cb:
        mean, var = reference.mitsuba_render(s["path"], (W, H), max_depth=s["max_depth"], spp=s["ref_spp"], seed=seed,
                                             batch=max(1, LANES // (W * H)), progress=cb, **s["params"])
    seconds = time.perf_counter() - t
    for suffix, img in ((".exr", mean), (".var.exr", var)):
        ml.write_exr(f"{stem}{suffix}", img)
    meta = {**key_fields, "key": key, "relative_noise": relative_noise(mean, var), "seconds": round(seconds, 2),
            "exr": Path(f"{stem}.exr").name}
    atomic_write_text(meta_path, json.dumps(meta, indent=2) + "\n")
    return mean, var, meta, False


# --------------------------------------------------------------------------------------------- analysis
def _light_counts(scene, lights: int, max_depth: int) -> dict:
    """Split a light budget: a quarter each to area and environment emitters (where the scene has them) and
    the rest to indirect VPLs for full GI; for direct light (max_depth 2) area and environment share it."""
    has_area = any(e["type"] == "area" for e in scene.emitters)
    has_env = any(e["type"] in ("envmap", "constant") for e in scene.emitters)
    if max_depth == 2:
        k = int(has_area) + int(has_env)
        if k == 0:
            return {"area": 0, "environment": 0, "indirect": 0}
        area = lights // k if has_area else 0
        return {"area": area, "environment": lights - area if has_env else 0, "indirect": 0}
    area = lights // 4 if has_area else 0
    env = lights // 4 if has_env else 0
    return {"area": area, "environment": env, "indirect": lights - area - env}


def timed(fn):
    """(first result of ``fn()``, median wall-clock seconds, runs): ``fn`` is run until REPEAT_SECONDS
    of runs or MAX_REPEATS runs."""
    times, first = [], None
    while not times or (sum(times) < REPEAT_SECONDS and len(times) < MAX_REPEATS):
        t = time.perf_counter()
        r = fn()
        times.append(time.perf_counter() - t)
        first = r if first is None else first
    return first, float(np.median(times)), len(times)


def run_mrcs(scene, budget, max_depth: int, device: str, gpu_visibility: str, seed: int):
    """One MRCS image, all of it timed: (image, stages in seconds, ``A.device``, number of lights).
    ``gpu_visibility`` applies to ``device="gpu"``; the CPU backend (and "auto") take their own default."""
    lights_n, rows, columns = budget
    t0 = time.perf_counter()
    lights = ml.generate_lights(scene, **_light_counts(scene, lights_n, max_depth), max_depth=max_depth, seed=seed)
    t1 = time.perf_counter()
    A = ml.LightMatrix(scene, lights, device=device, visibility=gpu_visibility if device == "gpu" else None,
                       max_depth=max_depth)
    t2 = time.perf_counter()
    n = len(lights)
    res = ml.mrcs(A, rows=min(rows, A.shape[0]), columns=min(columns, n), seed=seed)
    stages = {"generate_lights": t1 - t0, "light_matrix": t2 - t1, **res.timings}
    return res.image, stages, A.device, n


def run_sampler(scene, method: str, lights_n: int, samples: int, max_depth: int, seed: int):
    """One image of light-tree sampler ``method`` (``SAMPLERS``) on the CPU backend, all of it timed: (image,
    stages in seconds, number of lights). The lights are split as MRCS's budgets split them."""
    t0 = time.perf_counter()
    lights = ml.generate_lights(scene, **_light_counts(scene, lights_n, max_depth), max_depth=max_depth, seed=seed)
    t1 = time.perf_counter()
    A = ml.LightMatrix(scene, lights, device="cpu", max_depth=max_depth)
    t2 = time.perf_counter()
    res = SAMPLERS[method](A, samples, seed)
    return res.image, {"generate_lights": t1 - t0, "light_matrix": t2 - t1, **res.timings}, len(lights)


def run(args) -> dict:
    """The whole benchmark (see the module docs); returns the summary written to the JSON."""
    s = _settings(args)
    W, H = s["size"]
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    stem = f"vs-mitsuba-{s['name']}"
    json_path, png_path = out / f"{stem}.json", out / f"{stem}.png"

    ref, _var, meta, cached = cached_reference(s, Path(args.cache), args.ref_seed)
    noise = meta["relative_noise"]
    print(f"{s['path']}: {W}x{H}, max_depth {s['max_depth']}; reference {s['ref_spp']} spp "
          f"({'cached' if cached else 'rendered in %.1f s' % meta['seconds']}), estimated noise {noise:.3%} "
          f"relative L2")
    if noise > min(s["thresholds"]) / 4:
        print(f"warning: the reference's own noise ({noise:.3%}) is not 4x below the smallest threshold "
              f"({min(s['thresholds']):.2%}): raise --ref-spp")
    mi = reference.mitsuba()
    edges = None
    if not mi.variant().startswith("scalar"):
        edges = reference.mitsuba_edge_pixels(s["path"], (W, H), **s["params"])
    summary = {"scene": display_path(s["path"]), "scene_name": s["name"], "size": [W, H], "params": s["params"],
               "max_depth": s["max_depth"], "thresholds": list(s["thresholds"]), "report_edges": s["report_edges"],
               "reference": {**meta, "cached": cached}, "reference_cached": cached,
               "edge_pixels": None if edges is None else int(edges.sum()),
               "mitsuba": {"variant": mi.variant(), "version": mi.__version__, "integrator": "path",
                           "footprint": "pixel centre", "warm_up": "each spp level rendered once untimed first"},
               "mrcs_warm_up": "one untimed render at the smallest budget per backend first",
               "devices": {}, "records": [], "interrupted": False}
    records = summary["records"]

    def save() -> None:
        atomic_write_text(json_path, json.dumps(summary, indent=2) + "\n")

    def errors(img) -> dict:
        e = {"relative_l2": ml.relative_l2(img, ref)}
        if edges is not None:
            keep = ~edges
            e["relative_l2_no_edges"] = ml.relative_l2(img[keep], ref[keep]) if keep.any() else None
        return e

    def over_seeds(per_seed: list, image_of) -> dict:
        """One budget's measurement over ``--seeds`` seeds: each error is the root mean square of the
        per-seed errors (the expected squared error, which a single seed's error scatters around by
        ~10% for MRCS), the time the median of the per-seed medians; per-seed values are kept too."""
        errs = [errors(image_of(r)) for r, _, _ in per_seed]
        out = {"seconds": float(np.median([t for _, t, _ in per_seed])), "timed_runs": sum(n for _, _, n in per_seed),
               "seeds": len(per_seed), "seconds_per_seed": [t for _, t, _ in per_seed]}
        for key in errs[0]:
            vals = [e[key] for e in errs]
            out[key] = None if None in vals else float(np.sqrt(np.mean(np.square(vals))))
            out[key + "_per_seed"] = vals
        return out

    def record(rec: dict) -> dict:
        records.append(rec)
        extra = (f", {rec['relative_l2_no_edges']:.3%} without edge pixels"
                 if s["report_edges"] and rec.get("relative_l2_no_edges") is not None else "")
        if rec["method"] == "mitsuba":
            what = f"{rec['spp']} spp"
        elif "samples" in rec:
            what = f"{rec['lights']} lights, {rec['samples']} samples"
        else:
            what = f"{rec['lights']} lights, {rec['rows']} rows, {rec['columns']} columns"
        print(f"  {rec['curve']:<20s} {what:<42s} {rec['seconds']:9.3f} s   rel L2 {rec['relative_l2']:.3%}{extra}",
              flush=True)
        save()
        return rec

    min_thr = min(s["thresholds"])
    total = len(s["spp"]) + len(s["budgets"]) * len(args.devices) + len(s["samplers"]) * len(s["samples"])
    scene = ml.load_scene(s["path"], size=(W, H), **s["params"])
    mscene = reference.load(s["path"], **s["params"])
    batch = max(1, LANES // (W * H))
    try:
        with progress_bar(total, "vs-mitsuba", True, unit="image") as cb:
            done = 0

            def step() -> None:
                nonlocal done
                done += 1
                if cb:
                    cb(done, total)

            for device in args.devices:
                try:
                    run_mrcs(scene, s["budgets"][0], s["max_depth"], device, args.gpu_visibility, args.seed + 1)
                except Exception as e:  # a missing backend (GpuUnavailableError): say so, measure the others
                    print(f"  mrcs {device}: not measured: {type(e).__name__}: {e}")
                    summary["devices"][device] = {"error": f"{type(e).__name__}: {e}"}
                    for _ in s["budgets"]:
                        step()
                    continue
                for j, budget in enumerate(s["budgets"]):
                    per_seed = [timed(lambda: run_mrcs(scene, budget, s["max_depth"], device, args.gpu_visibility,
                                                       args.seed + k)) for k in range(args.seeds)]
                    (img, stages, info, n), _, _ = per_seed[0]
                    summary["devices"][device] = info
                    curve = f"mrcs {device}" if device != "auto" else f"mrcs auto={info.get('kind')}"
                    rec = record({"method": "mrcs", "curve": curve, "device": info.get("kind", device),
                                  "device_name": info.get("name"), "lights_budget": budget[0], "lights": n,
                                  "rows": budget[1], "columns": budget[2], **over_seeds(per_seed, lambda r: r[0]),
                                  "stages": stages})
                    step()
                    if rec["relative_l2"] <= min_thr and not args.no_early_stop:
                        for _ in s["budgets"][j + 1:]:
                            step()
                        break
            for method in s["samplers"]:
                for j, k in enumerate(s["samples"]):
                    per_seed = [timed(lambda: run_sampler(scene, method, s["sampler_lights"], k, s["max_depth"],
                                                          args.seed + q)) for q in range(args.seeds)]
                    (img, stages, n), _, _ = per_seed[0]
                    rec = record({"method": method, "curve": method, "device": "cpu", "lights_budget":
                                  s["sampler_lights"], "lights": n, "samples": k,
                                  **over_seeds(per_seed, lambda r: r[0]), "stages": stages})
                    step()
                    if rec["relative_l2"] <= min_thr and not args.no_early_stop:
                        for _ in s["samples"][j + 1:]:
                            step()
                        break
            # Mitsuba runs until it is below the smallest threshold and below the lowest MRCS error (so that
            # its time to MRCS's best error is measured too), or out of levels.
            target = min([min_thr] + [r["relative_l2"] for r in records])
            for k, spp in enumerate(s["spp"]):
                # Warm-up: the same wavefront shapes with another seed compile (or load) the kernels.
                reference.render_loaded(mscene, (W, H), max_depth=s["max_depth"], spp=spp,
                                        seed=args.seed * 7919 + 1000 + k, batch=batch)
                per_seed = [timed(lambda: reference.render_loaded(
                    mscene, (W, H), max_depth=s["max_depth"], spp=spp, seed=(args.seed + q) * 7919 + k, batch=batch))
                    for q in range(args.seeds)]
                rec = record({"method": "mitsuba", "curve": "mitsuba", "device": "cpu", "spp": spp,
                              **over_seeds(per_seed, lambda r: r[0])})
                step()
                if rec["relative_l2"] <= target and not args.no_early_stop:
                    break
    except KeyboardInterrupt:
        summary["interrupted"] = True
        print("\ninterrupted: reporting what was measured")
    for key in ("relative_l2", "relative_l2_no_edges"):
        summary["thresholds_" + key] = threshold_table(records, s["thresholds"], key)
        summary["best_" + key] = best_error_rows(records, key)
    save()
    if records:
        print_tables(summary)
        chart(summary, png_path)
        print(f"wrote {json_path} and {png_path}")
    if summary["interrupted"]:
        raise SystemExit(130)
    return summary
