"""``python -m manylights animate SCENE``: render an animation by tensor clustering and write what people watch.

Frames come from a bundled animated scene (``--frames N``: ``scenes.animation_frames``), from a JSON file of
per-frame parameter dicts (``--frames-json``), or from several XML files (one per frame). The lights are
``generate_animation_lights`` (``--area``, ``--environment``, ``--indirect`` gather samples, ``--photons``),
the renderer ``tensor_clustering`` (``--rows``, ``--columns`` per frame, ``--chunk``). With ``--compare``
the same lights are also rendered by per-frame MRCS at the same shadow maps per frame and by brute force,
and per-frame relative L2 and flicker (``metrics.flicker``) are printed for both.

Writes into ``--out``: ``tensor/frame_0000.exr ...`` (float32), ``tensor.mp4`` (or ``.gif`` with
``--gif``), and with ``--compare`` the same for ``mrcs`` and ``brute_force`` plus ``strip.mp4``: tensor |
per-frame MRCS | brute force | 4x error of tensor clustering. Every file appears complete or not at all.

    python -m manylights animate bounce --frames 24 --res 96 --compare
"""
from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from ..animation.frames import load_animation
from ..animation.lights import generate_animation_lights
from ..animation.tensor import LightTensor, mrcs_per_frame
from ..animation.tensor_clustering import tensor_clustering
from ..io.video import error_panel, side_by_side, write_exr_sequence, write_video
from ..metrics import flicker, relative_l2_per_frame
from ..scenes import animated, animation_frames, resolve
from .common import add_output


def add_parser(sub) -> None:
    p = sub.add_parser("animate", help="render an animation by tensor clustering (EXR sequence + MP4/GIF)",
                       description=__doc__, formatter_class=__import__("argparse").RawDescriptionHelpFormatter)
    p.add_argument("scene", nargs="+", help="a bundled animated scene's name (bounce), one XML with --frames-json, "
                                            "or one XML file per frame")
    p.add_argument("--frames", type=int, default=None, help="frames of a bundled animated scene (default 24)")
    p.add_argument("--frames-json", default=None, help="JSON list of per-frame parameter dicts for one XML")
    p.add_argument("--res", type=int, default=None, help="image width and height (the scene's 'res' parameter)")
    p.add_argument("--area", type=int, default=2048)
    p.add_argument("--environment", type=int, default=2048)
    p.add_argument("--indirect", type=int, default=4000, help="gather samples as indirect lights (0 = direct only)")
    p.add_argument("--photons", type=int, default=50000, help="multiple-bounce photons per frame (0 = one bounce)")
    p.add_argument("--rows", type=int, default=100)
    p.add_argument("--columns", type=int, default=300, help="representative columns per frame on average")
    p.add_argument("--chunk", type=int, default=40, help="frames per independently clustered chunk")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--device", default="auto", choices=["auto", "cpu", "gpu"])
    p.add_argument("--fps", type=float, default=12.0)
    p.add_argument("--exposure", type=float, default=0.0)
    p.add_argument("--gif", action="store_true", help="write GIF instead of MP4")
    p.add_argument("--compare", action="store_true", help="also per-frame MRCS and brute force, with errors")
    add_output(p, "out/animate", "output folder")
    p.set_defaults(run=run)


def _load(args):
    size = {} if args.res is None else {"res": args.res}
    if len(args.scene) > 1:
        if args.frames is not None or args.frames_json is not None:
            raise ValueError("give either several XML files (one per frame) or one scene with --frames/--frames-json")
        return load_animation([resolve(s) for s in args.scene], **size)
    path = resolve(args.scene[0])
    if args.frames_json is not None:
        if args.frames is not None:
            raise ValueError("give --frames or --frames-json, not both")
        frames = json.loads(Path(args.frames_json).read_text())
        if not isinstance(frames, list) or not all(isinstance(f, dict) for f in frames):
            raise ValueError(f"{args.frames_json}: expected a JSON list of parameter dicts")
        return load_animation(path, frames=frames, **size)
    name = path.parent.name
    if name not in animated():
        raise ValueError(f"{args.scene[0]}: not a bundled animated scene ({', '.join(animated())}); give "
                         "--frames-json or one XML per frame")
    count = 24 if args.frames is None else args.frames
    if count < 1:
        raise ValueError(f"--frames must be >= 1, got {count}")
    return load_animation(path, frames=animation_frames(name, count=count), **size)


def _write(folder: Path, name: str, frames, args) -> list[Path]:
    paths = write_exr_sequence(frames, folder / name)
    paths.append(write_video(frames, folder / f"{name}.{'gif' if args.gif else 'mp4'}", fps=args.fps,
                                exposure=args.exposure))
    return paths


def run(args) -> dict:
    """The command (module docs); returns a summary dict (also printed)."""
    for name in ("rows", "columns", "chunk"):
        if getattr(args, name) < 1:
            raise ValueError(f"--{name} must be >= 1, got {getattr(args, name)}")
    if not args.fps > 0:
        raise ValueError(f"--fps must be > 0, got {args.fps}")
    out = Path(args.output)
    t = time.perf_counter()
    anim = _load(args)
    lights = generate_animation_lights(anim, area=args.area, environment=args.environment, indirect=args.indirect,
                                          photons=args.photons, seed=args.seed)
    t_lights = time.perf_counter() - t
    T = LightTensor(anim, lights, device=args.device)
    m, n, f = T.shape
    print(f"{anim!r}: {n} lights per frame {lights.counts}, device {T.device['kind']} ({T.device['name']}); "
          f"lights {t_lights:.2f} s")
    res = tensor_clustering(T, rows=args.rows, columns=args.columns, seed=args.seed, chunk=args.chunk)
    summary = {"frames": f, "lights": n, "tensor": {"seconds": res.seconds, "timings": res.timings,
                                                    "shadow_maps_per_frame": float(np.mean(res.shadow_maps_per_frame))}}
    unit = "shadow maps" if T.device["kind"] == "gpu" else "rows + columns (exact rays)"
    print(f"tensor clustering: {res.seconds:.2f} s, {np.mean(res.shadow_maps_per_frame):.0f} {unit} per frame")
    out.mkdir(parents=True, exist_ok=True)
    written = _write(out, "tensor", res.frames, args)
    if args.compare:
        spf = int(round(float(np.mean(res.shadow_maps_per_frame))))
        cols = max(1, min(n, spf - args.rows))
        per = mrcs_per_frame(T, rows=args.rows, columns=cols, seed=args.seed)
        t = time.perf_counter()
        brute = T.brute_force()
        t_brute = time.perf_counter() - t
        for name, r in (("tensor", res), ("mrcs", per)):
            e = relative_l2_per_frame(r.frames, brute)
            summary.setdefault(name, {}).update({"mean_relative_l2": float(np.mean(e)),
                                                 "flicker": float(flicker(r.frames, brute)),
                                                 "seconds": r.seconds})
            print(f"{name:>7s}: mean relative L2 {np.mean(e):.3%}, flicker {summary[name]['flicker']:.3f}, "
                  f"{r.seconds:.2f} s, {np.mean(r.shadow_maps_per_frame):.0f} {unit} per frame")
        summary["brute_force_seconds"] = t_brute
        print(f"brute force: {t_brute:.2f} s ({n} columns per frame)")
        written += _write(out, "mrcs", per.frames, args) + _write(out, "brute_force", brute, args)
        strip = side_by_side([res.frames, per.frames, brute, error_panel(res.frames, brute)],
                                labels=["tensor", "per-frame MRCS", "brute force", "4x error"])
        written.append(write_video(strip, out / f"strip.{'gif' if args.gif else 'mp4'}", fps=args.fps,
                                      exposure=args.exposure))
    print(f"wrote {len(written)} files under {out}")
    return summary
