"""``python -m manylights.bench backends``: the light matrix's CPU backend against the GPU backend, side by side.

For each scene, in one run on this machine: milliseconds per column (``A.columns``, one at a time and in a
batch), per weighted column in a reconstruction (``A.weighted_sum`` of 300 representatives, as MRCS ends),
and per row (``A.rows``) on the CPU backend (exact rays, rayon) and on the GPU backend with each
visibility mode asked for (default: ``hybrid``, the default on a software adapter, and ``ray_traced``, the
default on a hardware GPU), with the ratio
GPU / CPU. Columns use the scene's lights at the column budget (``--lights``, default ~1,000 as the
issue's measurement); rows use ``--row-lights`` (default 100,000: a row's cost is n lights). Every timing
is the best of ``--repeats`` after a warm-up call, so one-off setup (shader compilation, the BVH, the
row pass's light upload) is not counted. Writes ``<out>/backends.json``.

``--peer mitsuba`` adds Mitsuba 3's ``ray_test`` on exactly the shadow rays of a column batch and a row
batch, beside the backend's visibility alone and the whole element (``bench.ray_peer``); ``--peer-only``
runs only that.
"""
from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

import manylights as ml

from .._utils.files import atomic_write_text
from ..scenes import resolve
from .common import mixed_lights

# scene -> loader params (bundled scenes/<name>/scene.xml)
SCENES = {
    "cbox": {"res": 128},
    "veach-ajar": {"resx": 128, "resy": 72},
    "cbox-lights": {"res": 128},
    "demo": {"res": 128},
}


def add_parser(sub) -> None:
    p = sub.add_parser("backends", help="CPU vs GPU backend: ms per column, weighted column and row")
    p.add_argument("--scene", nargs="+", default=["cbox", "veach-ajar"], choices=list(SCENES))
    p.add_argument("--res", type=int, default=None, help="image width (default per scene: 128; height keeps the aspect)")
    p.add_argument("--lights", type=int, default=1000, help="lights for the column timings (area + indirect)")
    p.add_argument("--row-lights", type=int, default=100_000, help="lights for the row timings")
    p.add_argument("--columns", type=int, default=60, help="columns timed")
    p.add_argument("--rows", type=int, default=20, help="rows timed")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--gpu-visibility", nargs="+", default=["hybrid", "ray_traced"],
                   choices=["hybrid", "ray_traced", "shadow_map"])
    p.add_argument("--peer", choices=["mitsuba"], default=None,
                   help="also time Mitsuba's ray_test on the same shadow rays (bench.ray_peer)")
    p.add_argument("--peer-only", action="store_true", help="only the peer comparison")
    p.add_argument("--peer-scenes", nargs="+", default=["cbox", "veach-ajar", "bunny", "room-2m"],
                   choices=["cbox", "veach-ajar", "bunny", "room-2m"])
    p.add_argument("--peer-lights", type=int, default=256, help="lights of the column batch")
    p.add_argument("--peer-rows", type=int, default=256, help="view samples of the row batch")
    p.add_argument("--peer-row-lights", type=int, default=16384, help="lights of the row batch")
    p.add_argument("--out", default="out/bench")
    p.set_defaults(run=run)


def _best(f, repeats: int) -> float:
    f()  # warm-up
    best = float("inf")
    for _ in range(repeats):
        t = time.perf_counter()
        f()
        best = min(best, time.perf_counter() - t)
    return best


def run(args) -> dict:
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    report = {"device": ml.device_info(), "scenes": {}}
    print(f"CPU: {report['device']['name']} ({report['device']['threads']} threads); GPU: "
          f"{(report['device'].get('gpu') or {}).get('name', 'none')}")
    if args.peer_only and args.peer is None:
        raise ValueError("--peer-only needs --peer mitsuba")
    for name in [] if args.peer_only else args.scene:
        scene = ml.load_scene(resolve(name), **SCENES[name])
        if args.res is not None:
            if args.res < 1:
                raise ValueError(f"--res must be >= 1, got {args.res}")
            scene = ml.load_scene(resolve(name), size=(args.res, max(1, round(args.res * scene.height / scene.width))),
                                  **SCENES[name])
        lights = mixed_lights(scene, args.lights)
        row_lights = mixed_lights(scene, args.row_lights, seed=1)
        m = scene.width * scene.height
        rng = np.random.default_rng(0)
        js = [int(j) for j in rng.choice(len(lights), size=min(args.columns, len(lights)), replace=False)]
        reps = [int(j) for j in rng.choice(len(lights), size=300, replace=True)]
        w = np.full((300, 3), 1.0 / 300, np.float32)
        if args.rows < 1 or args.columns < 1 or args.repeats < 1:
            raise ValueError(f"--rows, --columns and --repeats must be >= 1, got {args.rows}, {args.columns}, {args.repeats}")
        rows = [int(i) for i in ml.stratified_rows(scene, args.rows, seed=0)]
        configs = [("cpu", None)] + [("gpu", v) for v in args.gpu_visibility]
        res = {}
        for device, vis in configs:
            key = device if vis is None else f"gpu {vis}"
            A = ml.LightMatrix(scene, lights, device=device, visibility=vis)
            B = ml.LightMatrix(scene, row_lights, device=device, visibility=vis)
            one = _best(lambda: [A.columns([j]) for j in js[:10]], args.repeats) / 10
            batch = _best(lambda: A.columns(js), args.repeats) / len(js)
            wsum = _best(lambda: A.weighted_sum(reps, w), args.repeats) / len(reps)
            row = _best(lambda: B.rows(rows, progress=False), args.repeats) / len(rows)
            res[key] = {"column_ms": one * 1e3, "column_batch_ms": batch * 1e3, "weighted_column_ms": wsum * 1e3,
                        "row_ms": row * 1e3, "device": A.device}
            print(f"{name} {scene.width}x{scene.height} ({m} pixels) {key:<15s} column {one * 1e3:7.2f} ms   "
                  f"batched {batch * 1e3:7.2f} ms   weighted {wsum * 1e3:7.2f} ms   "
                  f"row ({len(row_lights)} lights) {row * 1e3:8.2f} ms", flush=True)
        for key in res:
            if key == "cpu":
                continue
            ratios = {k: res[key][k] / res["cpu"][k] for k in ("column_ms", "column_batch_ms", "weighted_column_ms", "row_ms")}
            res[key]["ratio_to_cpu"] = ratios
            print(f"  {key} / cpu: column {ratios['column_ms']:.1f}x, batched {ratios['column_batch_ms']:.1f}x, "
                  f"weighted {ratios['weighted_column_ms']:.1f}x, row {ratios['row_ms']:.1f}x")
        report["scenes"][name] = {"size": [scene.width, scene.height], "lights": len(lights),
                                  "row_lights": len(row_lights), "results": res}
        atomic_write_text(out / "backends.json", json.dumps(report, indent=2) + "\n")
    if args.peer:
        from .ray_peer import run_peer

        report["peer"] = run_peer(args.peer_scenes, args.peer_lights, args.peer_row_lights, args.peer_rows,
                                  args.repeats)
        atomic_write_text(out / "backends.json", json.dumps(report, indent=2) + "\n")
    print(f"wrote {out / 'backends.json'}")
    return report
