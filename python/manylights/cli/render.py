"""``python -m manylights render SCENE``: a Mitsuba XML scene rendered by brute force (every column of the light
matrix plus what the camera sees of emitters)."""
from __future__ import annotations

from pathlib import Path

from .._native import device_info
from ..lights.generate import generate_lights, scene_lights
from ..matrix.light_matrix import LightMatrix
from ..scene import load_scene
from ..scenes import resolve
from .common import Stopwatch, scene_params, write_image


def add_parser(sub) -> None:
    r = sub.add_parser("render", help="render a Mitsuba XML scene's delta lights by brute force")
    r.add_argument("scene", help="a Mitsuba 3 XML file, or a bundled scene's name (demo, cbox, cbox-lights, veach-ajar)")
    r.add_argument("-o", "--output", default="out.exr")
    r.add_argument("--size", type=int, nargs=2, metavar=("W", "H"))
    r.add_argument("-D", dest="params", action="append", metavar="NAME=VALUE", help="scene parameter")
    r.add_argument("--shadow-map-size", type=int, default=None, help="default: 512 (hybrid), 1024 (shadow_map)")
    r.add_argument("--area", type=int, default=0, help="area emitters -> this many oriented point lights")
    r.add_argument("--environment", type=int, default=0, help="env map -> this many directional lights")
    r.add_argument("--indirect", type=int, default=0, help="this many VPLs for indirect light")
    r.add_argument("--seed", type=int, default=0)
    r.add_argument("--device", default="auto", choices=["auto", "cpu", "gpu"],
                   help="auto (default): MANYLIGHTS_DEVICE, else a hardware GPU, else the CPU backend")
    r.add_argument("--visibility", default=None, choices=["hybrid", "shadow_map", "ray_traced"],
                   help="GPU shadow tests (default: the device's own; the CPU always casts exact rays)")
    r.add_argument("--no-png", action="store_true")
    r.set_defaults(run=run)


def run(a) -> None:
    """The command, from parsed arguments."""
    render(a.scene, a.output, size=tuple(a.size) if a.size else None, params=scene_params(a.params),
           shadow_map_size=a.shadow_map_size, area=a.area, environment=a.environment, indirect=a.indirect,
           seed=a.seed, visibility=a.visibility, png=not a.no_png, device=a.device)


def render(scene_path, out, size=None, params=None, shadow_map_size=None, area=0, environment=0, indirect=0,
           seed=0, visibility=None, png=True, quiet=False, device="auto"):
    """Brute force: every column of the light matrix (the scene's delta lights, plus generated area /
    environment / indirect lights when asked) plus what the camera sees of emitters."""
    sw = Stopwatch()
    sw("device", device_info, device)
    scene = sw("load scene", load_scene, resolve(scene_path), size=size, **(params or {}))
    if area or environment or indirect:
        lights = sw("generate lights", generate_lights, scene, area=area, environment=environment,
                    indirect=indirect, seed=seed)
    else:
        lights = sw("lights", scene_lights, scene)
    A = sw("g-buffer + light matrix setup", LightMatrix, scene, lights, shadow_map_size=shadow_map_size,
           visibility=visibility, device=device)
    dev = A.device
    img = sw("columns (brute force)", A.column_sum, progress=not quiet)
    img = img + sw("emitted", A.emitted)
    written = write_image(sw, Path(out), img, png)
    if not quiet:
        print(f"scene: {scene!r}")
        print(f"device: {dev['kind']}, {dev['name']} ({dev['backend']}"
              + (f", {'software' if dev['is_software'] else 'hardware'})" if dev["kind"] == "gpu" else f", {dev['threads']} threads)"))
        print(f"lights: {len(lights)}; matrix {A.shape[0]} x {A.shape[1]}; visibility {A.visibility}"
              + (f", shadow maps {A.shadow_map_size}^2" if dev["kind"] == "gpu" else ""))
        sw.report()
        for w in written:
            print(f"wrote {w}")
    return img, written
