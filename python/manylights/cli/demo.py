"""``python -m manylights demo``: the project's main job on the bundled scene: many lights (area + indirect +
delta), Matrix Row-Column Sampling at a default budget next to brute force, with the error and the time of
every stage."""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from .._native import device_info
from ..lights.generate import generate_lights
from ..matrix.light_matrix import LightMatrix
from ..metrics import error_map, relative_l2
from ..renderers.mrcs import mrcs
from ..scene import load_scene
from ..scenes import SCENES_DIR
from .common import Stopwatch, add_output, write_image

DEMO_SCENE = SCENES_DIR / "demo" / "scene.xml"


def add_parser(sub) -> None:
    d = sub.add_parser("demo", help="MRCS vs brute force on the bundled demo scene")
    add_output(d, "out/demo", "output folder")
    d.add_argument("--res", type=int, default=128)
    d.add_argument("--rows", type=int, default=300)
    d.add_argument("--columns", type=int, default=900)
    d.add_argument("--device", default="auto", choices=["auto", "cpu", "gpu"])
    d.set_defaults(run=run)


def run(a) -> None:
    """The command, from parsed arguments."""
    demo(a.output, res=a.res, rows=a.rows, columns=a.columns, device=a.device)


def demo(out_dir="out/demo", res=128, area=1024, indirect=3000, rows=300, columns=900, seed=0, device="auto"):
    """The project's main job on the bundled scene: many lights (area + indirect + delta), Matrix Row-Column
    Sampling at a default budget next to brute force, with the error and the time of every stage."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    sw = Stopwatch()
    sw("device", device_info, device)
    scene = sw("load scene", load_scene, DEMO_SCENE, res=res)
    lights = sw("generate lights", generate_lights, scene, area=area, indirect=indirect, seed=seed)
    A = sw("g-buffer + light matrix setup", LightMatrix, scene, lights, shadow_map_size=512, device=device)
    dev = A.device
    print(f"manylights demo: {DEMO_SCENE}")
    print(f"device: {dev['kind']}, {dev['name']} ({dev['backend']}"
          + (f", {'software' if dev['is_software'] else 'hardware'})" if dev["kind"] == "gpu" else f", {dev['threads']} threads)"))
    print(f"{scene!r}; {len(lights)} lights (area {area}, indirect ~{indirect}, + delta); matrix {A.shape[0]} x {A.shape[1]}")
    t = time.perf_counter()
    brute = A.column_sum(progress=True) + A.emitted()
    t_brute = time.perf_counter() - t
    res_mrcs = mrcs(A, rows=rows, columns=columns, seed=seed, progress=True)
    err = relative_l2(res_mrcs.image, brute)
    written = write_image(sw, out / "brute_force.exr", brute, True)
    written += write_image(sw, out / "mrcs.exr", res_mrcs.image, True)
    emap = error_map(res_mrcs.image, brute)
    written += write_image(sw, out / "error_map.exr", np.repeat(emap[..., None], 3, axis=-1) * 10.0, True)
    print("setup:")
    sw.report()
    print(f"brute force ({A.shape[1]} columns): {t_brute:.2f} s")
    print(f"MRCS ({rows} rows, {columns} columns): {res_mrcs.seconds:.2f} s")
    for k, v in res_mrcs.timings.items():
        print(f"  {k:<28s} {v * 1000:9.1f} ms")
    print(f"relative L2 error of MRCS vs brute force: {err:.4f}")
    print(f"speed-up over brute force: {t_brute / res_mrcs.seconds:.1f}x")
    for w in written:
        print(f"wrote {w}")
    return err
