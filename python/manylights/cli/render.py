"""``python -m manylights render SCENE``: a Mitsuba XML scene rendered with the library's defaults.

Lights: every kind the scene has, as ``generate_lights`` makes them by default: its point, spot and
directional emitters, ``area`` (default ``generate_lights``' 4096) oriented points when it has area
emitters, as many directional lights when it has an environment map (``envmap`` / ``constant``), and
``--indirect`` VPLs when asked (default 0: direct light). ``--method``: ``brute-force`` (default: every
column, ``render_brute_force``), ``mrcs`` (``--rows`` x ``--columns``) or ``render`` (``ml.render`` to
``--target-error``, light counts chosen for the scene).
"""
from __future__ import annotations

import argparse
import inspect
from pathlib import Path

from .._native import device_info
from ..lights.generate import generate_lights
from ..matrix.light_matrix import LightMatrix
from ..renderers.mrcs import mrcs
from ..renderers.render import render as render_auto
from ..scene import load_scene
from ..scenes import resolve
from .common import Stopwatch, add_output, add_scene_options, scene_options, write_image

METHODS = ("brute-force", "mrcs", "render")
#: ``generate_lights``' default number of area lights (also used for an environment map).
DEFAULT_LIGHTS = inspect.signature(generate_lights).parameters["area"].default
ENV_TYPES = ("envmap", "constant")


def add_parser(sub) -> None:
    r = sub.add_parser("render", help="render a Mitsuba XML scene (brute force, MRCS, or to a target error)",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    r.add_argument("scene", help="a Mitsuba 3 XML file, or a bundled scene's name (demo, cbox, cbox-lights, veach-ajar)")
    add_output(r, "out.exr", "the EXR to write (a PNG beside it unless --no-png)")
    add_scene_options(r)
    r.add_argument("--method", default="brute-force", choices=METHODS,
                   help="brute-force (default: every column), mrcs (--rows x --columns) or render (to --target-error)")
    r.add_argument("--target-error", type=float, default=0.05,
                   help="relative L2 target of --method render (default 0.05)")
    r.add_argument("--rows", type=int, default=300, help="MRCS rows (--method mrcs)")
    r.add_argument("--columns", type=int, default=900, help="MRCS columns (--method mrcs)")
    r.add_argument("--shadow-map-size", type=int, default=None, help="default: 512 (hybrid), 1024 (shadow_map)")
    r.add_argument("--area", type=int, default=None,
                   help=f"oriented point lights over area emitters (default {DEFAULT_LIGHTS} when the scene has any)")
    r.add_argument("--environment", type=int, default=None,
                   help=f"directional lights for an environment map (default {DEFAULT_LIGHTS} when the scene has one)")
    r.add_argument("--indirect", type=int, default=0, help="this many VPLs for indirect light (default 0)")
    r.add_argument("--seed", type=int, default=0)
    r.add_argument("--device", default="auto", choices=["auto", "cpu", "gpu"],
                   help="auto (default): MANYLIGHTS_DEVICE, else a hardware GPU, else the CPU backend")
    r.add_argument("--visibility", default=None, choices=["hybrid", "shadow_map", "ray_traced"],
                   help="GPU shadow tests (default: the device's own; the CPU always casts exact rays)")
    r.add_argument("--no-png", action="store_true")
    r.set_defaults(run=run)


def run(a) -> None:
    """The command, from parsed arguments."""
    size, params = scene_options(a)
    render(a.scene, a.output, size=size, params=params, shadow_map_size=a.shadow_map_size, area=a.area,
           environment=a.environment, indirect=a.indirect, seed=a.seed, visibility=a.visibility,
           png=not a.no_png, device=a.device, method=a.method, rows=a.rows, columns=a.columns,
           target_error=a.target_error)


def light_counts(scene, area=None, environment=None, indirect=0) -> dict:
    """The ``generate_lights`` counts of the command: every kind the scene has (``None`` = the default count
    when the scene has that kind of emitter, else 0)."""
    types = {e.get("type") for e in scene.emitters}
    if area is None:
        area = DEFAULT_LIGHTS if "area" in types else 0
    if environment is None:
        environment = DEFAULT_LIGHTS if types & set(ENV_TYPES) else 0
    return {"area": int(area), "environment": int(environment), "indirect": int(indirect)}


def render(scene_path, out, size=None, params=None, shadow_map_size=None, area=None, environment=None, indirect=0,
           seed=0, visibility=None, png=True, quiet=False, device="auto", method="brute-force", rows=300,
           columns=900, target_error=0.05):
    """Render ``scene_path`` with ``method`` (module doc) and write the EXR (and PNG); returns (image, paths)."""
    if method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    sw = Stopwatch()
    sw("device", device_info, device)
    scene = sw("load scene", load_scene, resolve(scene_path), size=size, **(params or {}))
    progress = None if not quiet else False
    summary = None
    if method == "render":
        res = sw("render (to the target error)", render_auto, str(resolve(scene_path)), target_error=target_error,
                 seed=seed, params=params or None, size=size, device=device, progress=progress)
        img, summary = res.image, res
        counts = res.budget.get("light_counts", {})
        lights_line = "lights: chosen for the target: " + ", ".join(
            f"{k} {v.get('count', v) if isinstance(v, dict) else v}" for k, v in counts.items())
        A = None
    else:
        counts = light_counts(scene, area, environment, indirect)
        lights = sw("generate lights", generate_lights, scene, **counts, seed=seed)
        A = sw("g-buffer + light matrix setup", LightMatrix, scene, lights, shadow_map_size=shadow_map_size,
               visibility=visibility, device=device)
        lights_line = (f"lights: {len(lights)} (area {counts['area']}, environment {counts['environment']}, "
                       f"indirect {counts['indirect']}, plus the scene's point, spot and directional emitters); "
                       f"matrix {A.shape[0]} x {A.shape[1]}")
        if method == "brute-force":
            img = sw("columns (brute force)", A.column_sum, progress=progress)
            img = img + sw("emitted", A.emitted)
        else:
            summary = sw("mrcs", mrcs, A, rows=rows, columns=columns, seed=seed, progress=progress)
            img = summary.image
    written = write_image(sw, Path(out), img, png)
    if not quiet:
        print(f"scene: {scene!r}")
        dev = A.device if A is not None else summary.device
        if dev:
            print(f"device: {dev.get('kind')}, {dev.get('name')} ({dev.get('backend')}"
                  + (f", {'software' if dev.get('is_software') else 'hardware'})" if dev.get("kind") == "gpu"
                     else f", {dev.get('threads')} threads)"))
        print(lights_line + (f"; visibility {A.visibility}" if A is not None else "")
              + (f", shadow maps {A.shadow_map_size}^2" if A is not None and A.device["kind"] == "gpu" else ""))
        if summary is not None:
            print(summary)
        sw.report()
        for w in written:
            print(f"wrote {w}")
    return img, written
