"""``python -m manylights.bench scale``: MRCS at the paper's sizes, and how its cost grows.

Matrix Row-Column Sampling (Hašan, Pellacini, Bala 2007, Sec. 6) renders 1.9M view samples from 100k lights.
This benchmark sweeps one axis at a time around a base point (``BASE``: 256x192 pixels, 16,384 lights,
131,072 triangles):

- pixels: 64x48 to 1024x768;
- lights: 1k to 1M (a quarter area points on the ceiling emitter, the rest VPLs);
- triangles: 8k to 2M (the room's floor is a generated height field, ``write_scene``: a generator, no data);

and renders one paper-size point, 1024x768 pixels, 100k lights, 2,097,152 floor triangles (``PAPER``).
Every point runs MRCS with 300 rows and 900 columns on the CPU backend (``ml.mrcs``) in a fresh process, so
that its peak resident memory (``ru_maxrss``) is its own; it reports the seconds of each stage (scene load,
light generation, the matrix's view samples, rows, clustering, columns) and the peak memory. Per axis the
log-log slope of time and of memory against that axis is fitted (1: linear).

Writes ``<out>/scale.json`` after every point (Ctrl-C keeps what was measured) and ``<out>/scale.md``.
Run it on an idle machine, alone.

    python -m manylights.bench scale                    # the three sweeps and the paper-size point
    python -m manylights.bench scale --axes paper       # only the paper-size point

Symbols
-------
| here | meaning |
|---|---|
| ``m`` | pixels (view samples, one per pixel) |
| ``n`` | lights (columns of the matrix) |
| ``r``, ``c`` | MRCS rows (300) and columns (900: clusters) |
| ``T`` | triangles of the scene |
"""
from __future__ import annotations

import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from .._utils.files import atomic_write_text
from .common import display_path

#: (width, height, lights, floor triangles) of the point every sweep starts from.
BASE = (256, 192, 16384, 131072)
#: the MRCS paper's size: 1024x768 view samples, 100k lights, >= 1M triangles.
PAPER = (1024, 768, 100_000, 2_097_152)
SWEEPS = {
    "pixels": [(64, 48), (128, 96), (256, 192), (512, 384), (1024, 768)],
    "lights": [1024, 4096, 16384, 65536, 262144, 1048576],
    "triangles": [8192, 32768, 131072, 524288, 2097152],
}
#: ``--small``: a quick sweep (seconds per point) for checking a backend, e.g. on a GPU machine.
BASE_SMALL = (128, 96, 4096, 32768)
SWEEPS_SMALL = {
    "pixels": [(64, 48), (128, 96), (256, 192)],
    "lights": [1024, 4096, 16384],
    "triangles": [8192, 32768, 131072],
}
ROWS, COLUMNS = 300, 900


def add_parser(sub) -> None:
    p = sub.add_parser("scale", help="MRCS 300/900 time and peak memory against pixels, lights and triangles, "
                                     "and the paper-size point (1024x768, 100k lights, 2M triangles)")
    p.add_argument("--axes", nargs="+", default=["pixels", "lights", "triangles", "paper"],
                   choices=["pixels", "lights", "triangles", "paper"])
    p.add_argument("--device", default="cpu", choices=["cpu", "gpu", "auto"],
                   help="the LightMatrix backend (default cpu)")
    p.add_argument("--visibility", default=None, choices=["ray_traced", "hybrid", "shadow_map"],
                   help="the LightMatrix's shadow tests (default: the backend's own)")
    p.add_argument("--small", action="store_true",
                   help="a quick sweep around 128x96 pixels, 4,096 lights, 32,768 triangles (the paper point stays "
                        "the paper's size)")
    p.add_argument("--point", help="internal: run one point (JSON [width, height, lights, triangles]) in this "
                                   "process and print its result as JSON")
    p.add_argument("--out", default="docs/bench")
    p.set_defaults(run=run)


def write_scene(folder: Path, triangles: int) -> Path:
    """Write the benchmark's room into ``folder``: a 5 m box open towards the camera, a ceiling area emitter
    and a floor that is a height field of ``triangles`` triangles (a k x k grid, ``triangles = 2 k^2``; binary
    PLY), path tracer ``max_depth`` -1. Returns the XML's path.

    Raises:
        ValueError: ``triangles`` not twice a square >= 2."""
    k = int(round(np.sqrt(triangles / 2)))
    if k < 1 or 2 * k * k != triangles:
        raise ValueError(f"triangles must be 2 k^2 for an integer k >= 1 (a k x k grid), got {triangles}")
    folder.mkdir(parents=True, exist_ok=True)
    g = np.linspace(-2.5, 2.5, k + 1, dtype=np.float64)
    x, z = np.meshgrid(g, g, indexing="ij")
    y = 0.04 * (np.sin(7.0 * x) + np.sin(5.0 * z + 1.0)) + 0.08
    verts = np.stack([x, y, z], axis=-1).reshape(-1, 3).astype("<f4")
    i, j = np.meshgrid(np.arange(k), np.arange(k), indexing="ij")
    v00 = (i * (k + 1) + j).ravel()
    v10, v01 = v00 + (k + 1), v00 + 1
    v11 = v10 + 1
    tris = np.concatenate([np.stack([v00, v01, v10], 1), np.stack([v10, v01, v11], 1)]).astype("<i4")
    faces = np.zeros(len(tris), dtype=[("n", "u1"), ("i", "<i4", (3,))])
    faces["n"], faces["i"] = 3, tris
    header = ("ply\nformat binary_little_endian 1.0\n"
              f"element vertex {len(verts)}\nproperty float x\nproperty float y\nproperty float z\n"
              f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n")
    (folder / "floor.ply").write_bytes(header.encode() + verts.tobytes() + faces.tobytes())

    def rect(transform: str, bsdf: str, emitter: str = "") -> str:
        return (f'    <shape type="rectangle">\n        <transform name="to_world">{transform}</transform>\n'
                f'        <ref id="{bsdf}"/>{emitter}\n    </shape>\n')

    ceiling = '<scale value="2.5"/><rotate x="1" angle="90"/><translate y="2.5"/>'
    xml = ('<scene version="3.0.0">\n'
           '    <integrator type="path"><integer name="max_depth" value="-1"/></integrator>\n'
           '    <sensor type="perspective"><float name="fov" value="70"/>\n'
           '        <transform name="to_world"><lookat origin="0, 1.4, 4.2" target="0, 0.9, 0" up="0, 1, 0"/>'
           '</transform>\n'
           '        <film type="hdrfilm"><integer name="width" value="256"/><integer name="height" value="192"/>'
           '<rfilter type="box"/></film>\n    </sensor>\n'
           '    <bsdf type="diffuse" id="white"><rgb name="reflectance" value="0.7, 0.7, 0.7"/></bsdf>\n'
           '    <bsdf type="diffuse" id="red"><rgb name="reflectance" value="0.6, 0.1, 0.1"/></bsdf>\n'
           '    <bsdf type="diffuse" id="green"><rgb name="reflectance" value="0.1, 0.5, 0.1"/></bsdf>\n'
           '    <shape type="ply"><string name="filename" value="floor.ply"/><ref id="white"/></shape>\n'
           + rect(ceiling, "white")
           + rect('<scale x="2.5" y="1.25"/><translate y="1.25" z="-2.5"/>', "white")
           + rect('<scale x="2.5" y="1.25"/><rotate y="1" angle="90"/><translate x="-2.5" y="1.25"/>', "red")
           + rect('<scale x="2.5" y="1.25"/><rotate y="1" angle="-90"/><translate x="2.5" y="1.25"/>', "green")
           + rect('<scale value="0.6"/><rotate x="1" angle="90"/><translate y="2.49"/>', "white",
                  '\n        <emitter type="area"><rgb name="radiance" value="12, 11, 10"/></emitter>')
           + "</scene>\n")
    path = folder / "scene.xml"
    path.write_text(xml)
    return path


def point(width: int, height: int, lights: int, triangles: int, device: str = "cpu",
          visibility: str | None = None) -> dict:
    """One point in this process: write and load the scene at ``width`` x ``height``, generate ``lights``
    lights (a quarter area points, the rest VPLs; seed 0), build the ``LightMatrix`` on ``device``
    (``"cpu"``, ``"gpu"`` or ``"auto"``; ``visibility`` as ``LightMatrix`` takes it) and render MRCS 300/900. Returns seconds per stage, the matrix shape,
    the device that ran and the process's peak resident memory (MB; host memory only)."""
    import manylights as ml

    sec = {}
    with tempfile.TemporaryDirectory(prefix="manylights-scale-") as tmp:
        t = time.perf_counter()
        xml = write_scene(Path(tmp), triangles)
        sec["write_scene"] = time.perf_counter() - t
        t = time.perf_counter()
        scene = ml.load_scene(xml, size=(width, height))
        sec["load"] = time.perf_counter() - t
    t = time.perf_counter()
    area = lights // 4
    ls = ml.generate_lights(scene, area=area, indirect=lights - area, seed=0)
    sec["lights"] = time.perf_counter() - t
    t = time.perf_counter()
    A = ml.LightMatrix(scene, ls, device=device, visibility=visibility)
    sec["matrix"] = time.perf_counter() - t
    t = time.perf_counter()
    res = ml.mrcs(A, rows=ROWS, columns=COLUMNS, seed=0, progress=False)
    sec["mrcs"] = time.perf_counter() - t
    return {"width": width, "height": height, "pixels": width * height, "lights": int(A.shape[1]),
            "view_samples": int(A.shape[0]), "triangles": triangles, "device": A.device,
            "visibility": A.visibility, "seconds": sec,
            "mrcs_stages": {k: float(v) for k, v in res.timings.items()},
            "total_seconds": float(sum(sec.values())),
            "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0}


def run_point(width: int, height: int, lights: int, triangles: int, device: str = "cpu",
              visibility: str | None = None) -> dict:
    """``point`` in a fresh Python process (its own peak memory). Raises RuntimeError when it fails."""
    arg = json.dumps([width, height, lights, triangles])
    p = subprocess.run([sys.executable, "-m", "manylights.bench", "scale", "--point", arg, "--device", device]
                       + (["--visibility", visibility] if visibility else []), capture_output=True, text=True)
    if p.returncode != 0:
        raise RuntimeError(f"bench scale point {arg} failed ({p.returncode}):\n{p.stderr[-2000:]}")
    return json.loads(p.stdout.strip().splitlines()[-1])


def slope(xs, ys) -> float:
    """The least-squares slope of log(ys) against log(xs)."""
    return float(np.polyfit(np.log(np.asarray(xs, float)), np.log(np.asarray(ys, float)), 1)[0])


def plan(axes, small: bool = False) -> list[tuple[str, tuple]]:
    """(axis, (width, height, lights, triangles)) of every point the ``axes`` ask for, in order (``small``:
    the quick sweep around ``BASE_SMALL``)."""
    w, h, n, tri = BASE_SMALL if small else BASE
    sweeps = SWEEPS_SMALL if small else SWEEPS
    out = []
    if "pixels" in axes:
        out += [("pixels", (pw, ph, n, tri)) for pw, ph in sweeps["pixels"]]
    if "lights" in axes:
        out += [("lights", (w, h, pn, tri)) for pn in sweeps["lights"]]
    if "triangles" in axes:
        out += [("triangles", (w, h, n, pt)) for pt in sweeps["triangles"]]
    if "paper" in axes:
        out.append(("paper", PAPER))
    return out


def run(args) -> dict:
    if args.point:
        w, h, n, tri = json.loads(args.point)
        print(json.dumps(point(int(w), int(h), int(n), int(tri), args.device, args.visibility)), flush=True)
        return {}
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    summary = {"rows": ROWS, "columns": COLUMNS, "base": BASE_SMALL if args.small else BASE, "paper": PAPER,
               "device": args.device, "visibility": args.visibility, "points": [], "slopes": {}}

    def save():
        atomic_write_text(out / "scale.json", json.dumps(summary, indent=1) + "\n")

    key = {"pixels": "pixels", "lights": "lights", "triangles": "triangles"}
    for axis, p in plan(args.axes, args.small):
        r = run_point(*p, device=args.device, visibility=args.visibility)
        r["axis"] = axis
        summary["points"].append(r)
        print(f"{axis:>9}: {r['width']}x{r['height']} {r['lights']:>8} lights {r['triangles']:>8} triangles: "
              f"{r['total_seconds']:.1f} s (mrcs {r['seconds']['mrcs']:.1f}), peak {r['peak_rss_mb']:.0f} MB",
              flush=True)
        pts = [q for q in summary["points"] if q["axis"] == axis]
        if axis in key and len(pts) >= 2:
            xs = [q[key[axis]] for q in pts]
            summary["slopes"][axis] = {"time": slope(xs, [q["total_seconds"] for q in pts]),
                                       "mrcs_time": slope(xs, [q["seconds"]["mrcs"] for q in pts]),
                                       "memory": slope(xs, [q["peak_rss_mb"] for q in pts])}
        save()
    md = table(summary)
    atomic_write_text(out / "scale.md", md)
    print(md)
    print(f"wrote {display_path(out / 'scale.json')}, scale.md")
    return summary


def table(summary: dict) -> str:
    """The points and the slopes as Markdown."""
    lines = ["| axis | pixels | lights | triangles | load s | lights s | matrix s | MRCS s (rows, clustering, "
             "columns) | total s | peak MB |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in summary["points"]:
        s, st = r["seconds"], r["mrcs_stages"]
        lines.append(f"| {r['axis']} | {r['width']}x{r['height']} | {r['lights']:,} | {r['triangles']:,} "
                     f"| {s['load']:.2f} | {s['lights']:.2f} | {s['matrix']:.2f} | {s['mrcs']:.1f} "
                     f"({st.get('row_evaluation', 0):.1f}, {st.get('clustering', 0):.1f}, {st.get('columns', 0):.1f}) "
                     f"| {r['total_seconds']:.1f} | {r['peak_rss_mb']:.0f} |")
    lines += ["", "| axis | slope of total time | slope of MRCS time | slope of peak memory |", "|---|---|---|---|"]
    for axis, sl in summary["slopes"].items():
        lines.append(f"| {axis} | {sl['time']:.2f} | {sl['mrcs_time']:.2f} | {sl['memory']:.2f} |")
    return "\n".join(lines) + "\n"
