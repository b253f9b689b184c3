"""Command line: ``python -m manylights {render,demo,info}``."""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

DEMO_SCENE = Path(__file__).resolve().parents[2] / "scenes" / "demo" / "scene.xml"


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


def render(scene_path, out, size=None, params=None, shadow_map_size=1024, png=True, quiet=False,
           area=4096, environment=4096, indirect=0, seed=0):
    import manylights as ml

    sw = Stopwatch()
    dev = sw("gpu device", ml.device_info)
    scene = sw("load scene", ml.load_scene, scene_path, size=size, **(params or {}))
    sw("g-buffer (view samples)", scene.gbuffer)
    lights = sw("lights", ml.generate_lights, scene, area=area, environment=environment, indirect=indirect,
                seed=seed)
    img = sw("brute force (+ emitted)", ml.render_brute_force, scene, lights, shadow_map_size=shadow_map_size,
             progress=not quiet)
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    sw("write exr", ml.write_exr, out, img)
    written = [out]
    if png:
        p = out.with_suffix(".png")
        sw("write png", ml.write_png, p, img)
        written.append(p)
    if not quiet:
        print(f"scene: {scene!r}")
        print(f"adapter: {dev['name']} ({dev['backend']}, {'software' if dev['is_software'] else 'hardware'})")
        print(f"lights: {len(lights)}; matrix {img.shape[0] * img.shape[1]} x {len(lights)}; "
              f"shadow maps {shadow_map_size}^2")
        sw.report()
        print(f"  {'total':<28s} {sum(s for _, s in sw.stages) * 1000:9.1f} ms")
        for w in written:
            print(f"wrote {w}")
    return img, written


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m manylights", description=__doc__)
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("render", help="render a Mitsuba XML scene by brute force over generated lights")
    r.add_argument("scene")
    r.add_argument("-o", "--output", default="out.exr")
    r.add_argument("--size", type=int, nargs=2, metavar=("W", "H"))
    r.add_argument("-D", dest="params", action="append", metavar="NAME=VALUE", help="scene parameter")
    r.add_argument("--shadow-map-size", type=int, default=1024)
    r.add_argument("--no-png", action="store_true")
    r.add_argument("--area", type=int, default=4096, help="oriented point lights over area emitters")
    r.add_argument("--environment", type=int, default=4096, help="directional lights over the environment")
    r.add_argument("--indirect", type=int, default=0, help="VPLs (indirect light)")
    r.add_argument("--seed", type=int, default=0)
    d = sub.add_parser("demo", help="render the bundled demo scene")
    d.add_argument("-o", "--output", default="out/demo.exr")
    sub.add_parser("info", help="print the GPU adapter")
    a = ap.parse_args(argv)
    try:
        if a.cmd == "render":
            render(a.scene, a.output, size=tuple(a.size) if a.size else None, params=_params(a.params),
                   shadow_map_size=a.shadow_map_size, png=not a.no_png, area=a.area,
                   environment=a.environment, indirect=a.indirect, seed=a.seed)
        elif a.cmd == "demo":
            print(f"manylights demo: {DEMO_SCENE}")
            render(DEMO_SCENE, a.output)
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
