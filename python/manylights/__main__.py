"""Command line: ``python -m manylights {render,demo,animate,relight,info}``."""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from .scenes import SCENES_DIR, resolve

DEMO_SCENE = SCENES_DIR / "demo" / "scene.xml"


def _params(pairs):
    out = {}
    for p in pairs or []:
        if "=" not in p:
            raise SystemExit(f"-D expects name=value, got {p!r}")
        k, v = p.split("=", 1)
        out[k] = v
    return out


class Stopwatch:
    def __init__(self):
        self.stages = []

    def __call__(self, name, fn, *a, **kw):
        t = time.perf_counter()
        r = fn(*a, **kw)
        self.stages.append((name, time.perf_counter() - t))
        return r

    def report(self):
        for name, s in self.stages:
            print(f"  {name:<28s} {s * 1000:9.1f} ms")


def render(scene_path, out, size=None, params=None, shadow_map_size=None, area=0, environment=0, indirect=0,
           seed=0, visibility=None, png=True, quiet=False, device="auto"):
    """Brute force: every column of the light matrix (the scene's delta lights, plus generated area /
    environment / indirect lights when asked) plus what the camera sees of emitters."""
    import manylights as ml

    sw = Stopwatch()
    sw("device", ml.device_info, device)
    scene = sw("load scene", ml.load_scene, resolve(scene_path), size=size, **(params or {}))
    if area or environment or indirect:
        lights = sw("generate lights", ml.generate_lights, scene, area=area, environment=environment,
                    indirect=indirect, seed=seed)
    else:
        lights = sw("lights", ml.scene_lights, scene)
    A = sw("g-buffer + light matrix setup", ml.LightMatrix, scene, lights, shadow_map_size=shadow_map_size,
           visibility=visibility, device=device)
    dev = A.device
    img = sw("columns (brute force)", A.column_sum, progress=not quiet)
    img = img + sw("emitted", A.emitted)
    written = _write(sw, Path(out), img, png)
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


def _write(sw, out: Path, img, png: bool):
    import manylights as ml

    out.parent.mkdir(parents=True, exist_ok=True)
    sw("write exr", ml.write_exr, out, img)
    written = [out]
    if png:
        p = out.with_suffix(".png")
        sw("write png", ml.write_png, p, img)
        written.append(p)
    return written


def demo(out_dir="out/demo", res=128, area=1024, indirect=3000, rows=300, columns=900, seed=0, device="auto"):
    """The project's main job on the bundled scene: many lights (area + indirect + delta), Matrix Row-Column
    Sampling at a default budget next to brute force, with the error and the time of every stage."""
    import manylights as ml
    from manylights.metrics import error_map

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    sw = Stopwatch()
    sw("device", ml.device_info, device)
    scene = sw("load scene", ml.load_scene, DEMO_SCENE, res=res)
    lights = sw("generate lights", ml.generate_lights, scene, area=area, indirect=indirect, seed=seed)
    A = sw("g-buffer + light matrix setup", ml.LightMatrix, scene, lights, shadow_map_size=512, device=device)
    dev = A.device
    print(f"manylights demo: {DEMO_SCENE}")
    print(f"device: {dev['kind']}, {dev['name']} ({dev['backend']}"
          + (f", {'software' if dev['is_software'] else 'hardware'})" if dev["kind"] == "gpu" else f", {dev['threads']} threads)"))
    print(f"{scene!r}; {len(lights)} lights (area {area}, indirect ~{indirect}, + delta); matrix {A.shape[0]} x {A.shape[1]}")
    t = time.perf_counter()
    brute = A.column_sum(progress=True) + A.emitted()
    t_brute = time.perf_counter() - t
    res_mrcs = ml.mrcs(A, rows=rows, columns=columns, seed=seed, progress=True)
    err = ml.relative_l2(res_mrcs.image, brute)
    written = _write(sw, out / "brute_force.exr", brute, True)
    written += _write(sw, out / "mrcs.exr", res_mrcs.image, True)
    emap = error_map(res_mrcs.image, brute)
    written += _write(sw, out / "error_map.exr", np.repeat(emap[..., None], 3, axis=-1) * 10.0, True)
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


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m manylights", description=__doc__)
    sub = ap.add_subparsers(dest="cmd", required=True)
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
    d = sub.add_parser("demo", help="MRCS vs brute force on the bundled demo scene")
    d.add_argument("-o", "--output", default="out/demo", help="output folder")
    d.add_argument("--res", type=int, default=128)
    d.add_argument("--rows", type=int, default=300)
    d.add_argument("--columns", type=int, default=900)
    d.add_argument("--device", default="auto", choices=["auto", "cpu", "gpu"])
    sub.add_parser("info", help="print the device that runs (and the GPU adapter wgpu would use)")
    from . import animate

    animate.add_parser(sub)
    from . import relight_cli

    relight_cli.add_parser(sub)
    a = ap.parse_args(argv)
    try:
        if a.cmd in ("animate", "relight"):
            a.run(a)
        elif a.cmd == "render":
            render(a.scene, a.output, size=tuple(a.size) if a.size else None, params=_params(a.params),
                   shadow_map_size=a.shadow_map_size, area=a.area, environment=a.environment, indirect=a.indirect,
                   seed=a.seed, visibility=a.visibility, png=not a.no_png, device=a.device)
        elif a.cmd == "demo":
            demo(a.output, res=a.res, rows=a.rows, columns=a.columns, device=a.device)
        elif a.cmd == "info":
            import manylights as ml

            for k, v in ml.device_info().items():
                print(f"{k}: {v}")
    except Exception as e:  # a clean message on the command line, not a traceback
        import manylights as ml

        if isinstance(e, (ml.ManyLightsError, ValueError, FileNotFoundError, OSError)):
            print(f"error: {e}", file=sys.stderr)
            return 1
        raise
    return 0


if __name__ == "__main__":
    sys.exit(main())
