"""``python -m manylights demo`` (``make demo``): the project's main job on the bundled demo scene, in a few
minutes: ``--lights`` (default 100,000) lights (oriented points on its area light plus its point, spot and
sun lights; direct light, so every method computes the same image), rendered by

- Matrix Row-Column Sampling (``--rows`` x ``--columns``),
- brute force (every column: the reference of the errors below),
- Mitsuba 3's path tracer (``max_depth`` 2: the same direct light) at the time MRCS took, when Mitsuba is
  installed (a test dependency; ``--no-mitsuba`` skips it): samples per pixel doubled until the next level
  would take longer than MRCS, each level timed after an untimed warm-up.

It prints the time of each, MRCS's speed-up over brute force and each method's relative L2 against brute
force, and writes the images (EXR + PNG) and ``side_by_side.png``: MRCS, brute force, Mitsuba at equal
time and MRCS's error map x10. ``--res`` defaults to 128 on a GPU, 64 on the CPU backend (brute force casts
one exact shadow ray per pixel and light there: about 100 s on 2 cores).
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from .._native import device_info
from ..io.images import write_png
from ..io.video import side_by_side
from ..lights.generate import generate_lights
from ..matrix.light_matrix import LightMatrix
from ..metrics import error_map, relative_l2
from ..renderers.mrcs import mrcs
from ..scene import load_scene
from ..scenes import SCENES_DIR
from ..testing import mitsuba as reference
from .common import Stopwatch, add_output, write_image

DEMO_SCENE = SCENES_DIR / "demo" / "scene.xml"
#: Direct light only (camera -> surface -> light): brute force, MRCS and Mitsuba's ``path`` agree in expectation.
MAX_DEPTH = 2


def add_parser(sub) -> None:
    d = sub.add_parser("demo", help="MRCS vs brute force vs Mitsuba's path tracer (equal time) on the demo scene")
    add_output(d, "out/demo", "output folder")
    d.add_argument("--res", type=int, default=None, help="image width and height (default 128 on a GPU, 64 on the CPU)")
    d.add_argument("--lights", type=int, default=100_000, help="oriented point lights on the area light")
    d.add_argument("--rows", type=int, default=300)
    d.add_argument("--columns", type=int, default=900)
    d.add_argument("--device", default="auto", choices=["auto", "cpu", "gpu"])
    d.add_argument("--no-mitsuba", action="store_true", help="skip Mitsuba's path tracer")
    d.set_defaults(run=run)


def run(a) -> None:
    """The command, from parsed arguments."""
    demo(a.output, res=a.res, lights=a.lights, rows=a.rows, columns=a.columns, device=a.device,
         mitsuba=not a.no_mitsuba)


def mitsuba_equal_time(res: int, seconds: float, seed: int = 1):
    """Mitsuba's ``path`` (pixel-centre rays, ``MAX_DEPTH``) on the demo scene at the largest power-of-two spp
    whose render fits in ``seconds`` (at least 1 spp): (image, spp, seconds taken), or None without Mitsuba."""
    try:
        reference.mitsuba()
    except Exception as e:  # not installed, or no usable variant
        print(f"Mitsuba: skipped ({type(e).__name__}: {str(e)[:120]})")
        return None
    scene = reference.load(DEMO_SCENE, res=res)
    reference.render_loaded(scene, (res, res), max_depth=MAX_DEPTH, spp=1, seed=seed)  # warm-up (kernel compile)
    best = None
    spp = 1
    while True:
        t = time.perf_counter()
        img, _ = reference.render_loaded(scene, (res, res), max_depth=MAX_DEPTH, spp=spp, seed=seed)
        took = time.perf_counter() - t
        if best is None or took <= seconds:
            best = (img, spp, took)
        # the next level takes about twice as long: stop when it would not fit
        if 2 * took > seconds or spp >= 1 << 16:
            return best
        spp *= 2


def demo(out_dir="out/demo", res=None, lights=100_000, rows=300, columns=900, seed=0, device="auto",
         mitsuba=True):
    """The demo (module doc); returns {"mrcs": relative L2 vs brute force, "mitsuba": the same or None,
    "speedup": brute-force time / MRCS time}."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    sw = Stopwatch()
    info = sw("device", device_info, device)
    if res is None:
        res = 128 if info.get("kind") == "gpu" else 64
    scene = sw("load scene", load_scene, DEMO_SCENE, res=res)
    L = sw("generate lights", generate_lights, scene, area=lights, seed=seed)
    A = sw("g-buffer + light matrix setup", LightMatrix, scene, L, device=device, max_depth=MAX_DEPTH)
    dev = A.device
    print(f"manylights demo: {DEMO_SCENE.name} at {res}x{res}, {len(L):,} lights ({lights:,} on the area light + "
          f"{len(L) - lights} point, spot and sun), direct light")
    print(f"device: {dev['kind']}, {dev['name']} ({dev['backend']}"
          + (f", {'software' if dev['is_software'] else 'hardware'})" if dev["kind"] == "gpu" else f", {dev['threads']} threads)"))

    res_mrcs = mrcs(A, rows=rows, columns=columns, seed=seed, progress=True)
    t_mrcs = res_mrcs.seconds
    print(f"MRCS ({rows} rows, {columns} columns): {t_mrcs:.2f} s")
    t = time.perf_counter()
    brute = A.column_sum(progress=True) + A.emitted()
    t_brute = time.perf_counter() - t
    print(f"brute force ({A.shape[1]:,} columns): {t_brute:.2f} s")
    err = relative_l2(res_mrcs.image, brute)
    mi = mitsuba_equal_time(res, t_mrcs) if mitsuba else None
    err_mi = None
    if mi is not None:
        img_mi, spp, t_mi = mi
        err_mi = relative_l2(img_mi, brute)
        print(f"Mitsuba path tracer at equal time: {spp} spp in {t_mi:.2f} s")

    written = write_image(sw, out / "mrcs.exr", res_mrcs.image, True)
    written += write_image(sw, out / "brute_force.exr", brute, True)
    emap = np.repeat(error_map(res_mrcs.image, brute)[..., None], 3, axis=-1) * 10.0
    panels, labels = [res_mrcs.image, brute], ["MRCS", "brute force"]
    if mi is not None:
        written += write_image(sw, out / "mitsuba_equal_time.exr", mi[0], True)
        panels.append(mi[0])
        labels.append("Mitsuba")
    panels.append(emap)
    labels.append("error x10")
    strip = out / "side_by_side.png"
    write_png(strip, side_by_side(panels, labels))
    written.append(strip)

    print("\nsummary (relative L2 against brute force):")
    print(f"  MRCS          {t_mrcs:8.2f} s   error {err:.4%}")
    print(f"  brute force   {t_brute:8.2f} s   (reference)")
    if mi is not None:
        print(f"  Mitsuba path  {mi[2]:8.2f} s   error {err_mi:.4%} ({mi[1]} spp, equal time)")
    print(f"  speed-up of MRCS over brute force: {t_brute / t_mrcs:.1f}x"
          + (f"; at equal time MRCS's error is {err_mi / err:.1f}x lower than Mitsuba's" if mi is not None and err > 0
             else ""))
    print("setup:")
    sw.report()
    for w in written:
        print(f"wrote {w}")
    return {"mrcs": err, "mitsuba": err_mi, "speedup": t_brute / t_mrcs}
