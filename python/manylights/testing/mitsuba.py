"""Mitsuba 3 references for the same scene XML: pixel-centre G-buffers and deterministic renders.

Everything here follows the Mitsuba conventions (``docs/development/mitsuba-conventions.md``): camera rays go through pixel centres
(film position ``((i + 0.5) / W, (j + 0.5) / H)``), so a rasteriser that shades pixel centres can be compared
pixel by pixel. Mitsuba (``mitsuba==3.9.1``, ``drjit==1.5.0``) is imported lazily: it is a test/benchmark
dependency, not a runtime one.

Functions:
    mitsuba_gbuffer(path, (W, H), **params)    -> dict of (H, W, ...) arrays (position, normal, ...)
    mitsuba_render(path, (W, H), max_depth=2, spp=1, seed=0, **params) -> (mean, variance), (H, W, 3) float32
    render_loaded(load(path, **params), (W, H), ...)  -> the same for a scene loaded once (benchmarks)

``size`` is separate from ``**params`` because scenes name their own parameters ``width``/``height``.
    scene_variant(path, out_dir, keep_emitters=..., add_emitters=...) -> path of an edited copy of the XML
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

_VARIANT = None


def _llvm_works() -> bool:
    """Probe llvm_ad_rgb in a subprocess (LLVM 15/16 abort the whole process on first use)."""
    code = (
        "import mitsuba as mi; mi.set_variant('llvm_ad_rgb'); "
        "s = mi.load_dict({'type': 'scene', 's': {'type': 'sphere'}}); "
        "import drjit as dr; r = mi.Ray3f(mi.Point3f(0, 0, -5), mi.Vector3f(0, 0, 1)); "
        "print(dr.all(s.ray_intersect(r).is_valid()))"
    )
    try:
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    except (OSError, subprocess.TimeoutExpired):
        return False
    return out.returncode == 0 and "True" in out.stdout


def mitsuba():
    """Import mitsuba with the fastest working RGB variant (llvm_ad_rgb, else scalar_rgb)."""
    global _VARIANT
    import mitsuba as mi

    if _VARIANT is None:
        forced = os.environ.get("MANYLIGHTS_MITSUBA_VARIANT")
        _VARIANT = forced or ("llvm_ad_rgb" if _llvm_works() else "scalar_rgb")
    if mi.variant() != _VARIANT:
        mi.set_variant(_VARIANT)
    return mi


def _params_str(params: dict) -> dict:
    return {k: str(v) for k, v in params.items()}


def _pixel_centre_rays(mi, sensor, width: int, height: int, offset=(0.0, 0.0)):
    """Mitsuba camera rays through the centres of a width x height film (any film size of the same aspect),
    moved by ``offset`` pixels."""
    import drjit as dr

    idx = dr.arange(mi.UInt32, width * height)
    x = mi.Float(idx % width)
    y = mi.Float(idx // width)
    pos = mi.Point2f((x + 0.5 + offset[0]) / width, (y + 0.5 + offset[1]) / height)
    ray, _ = sensor.sample_ray(0.0, 0.5, pos, mi.Point2f(0.5, 0.5))
    return ray


def _pixel_centre_rays_scalar(mi, sensor, width, height):
    for j in range(height):
        for i in range(width):
            ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f((i + 0.5) / width, (j + 0.5) / height), mi.Point2f(0.5, 0.5))
            yield ray


def load(path, **params):
    mi = mitsuba()
    return mi.load_file(str(path), optimize=False, **_params_str(params))


def mitsuba_gbuffer(path, size: tuple[int, int], **params) -> dict:
    """Pixel-centre G-buffer by Mitsuba's own ray intersection (what its ``aov`` integrator reports).

    Returns float32/int32 arrays of shape (H, W, 3) / (H, W): ``position``, ``normal`` (shading),
    ``geo_normal``, ``uv`` (H, W, 2), ``shape_index`` (index into ``scene.shapes()``, -1 = miss) and the
    shapes' bounding boxes ``shape_bbox`` (S, 2, 3) so callers can match shapes to their own.
    """
    mi = mitsuba()
    width, height = size
    scene = load(path, **params)
    sensor = scene.sensors()[0]
    shapes = scene.shapes()
    bbox = np.array([[np.array(s.bbox().min), np.array(s.bbox().max)] for s in shapes], dtype=np.float32)
    n = width * height
    if mi.variant().startswith("scalar"):
        out = {k: np.zeros((n, 3), np.float32) for k in ("position", "normal", "geo_normal")}
        out["uv"] = np.zeros((n, 2), np.float32)
        sid = np.full(n, -1, np.int32)
        for k, ray in enumerate(_pixel_centre_rays_scalar(mi, sensor, width, height)):
            si = scene.ray_intersect(ray)
            if si.is_valid():
                out["position"][k] = np.array(si.p)
                out["normal"][k] = np.array(si.sh_frame.n)
                out["geo_normal"][k] = np.array(si.n)
                out["uv"][k] = np.array(si.uv)
                sid[k] = next(i for i, s in enumerate(shapes) if s == si.shape)
    else:
        ray = _pixel_centre_rays(mi, sensor, width, height)
        si = scene.ray_intersect(ray)
        valid = np.array(si.is_valid())

        def arr(v, c):
            a = np.array(v, dtype=np.float32)
            return a.T.copy() if a.shape == (c, n) else a.reshape(n, c)

        out = {"position": arr(si.p, 3), "normal": arr(si.sh_frame.n, 3), "geo_normal": arr(si.n, 3),
               "uv": arr(si.uv, 2)}
        sid = np.full(n, -1, np.int32)
        for k, s in enumerate(shapes):
            sid[np.array(si.shape == mi.ShapePtr(s)) & valid] = k
        for key in out:
            out[key][~valid] = 0.0
    out["shape_index"] = sid
    res = {k: v.reshape(height, width, -1) for k, v in out.items() if k != "shape_index"}
    res["shape_index"] = sid.reshape(height, width)
    res["shape_bbox"] = bbox
    return res


def mitsuba_edge_pixels(path, size: tuple[int, int], eps_px: float = 1e-3, **params) -> np.ndarray:
    """(H, W) bool: pixels whose centre lies on an edge between shapes, by Mitsuba's own intersection:
    the shape hit changes when the centre moves by ``eps_px`` pixels in x or y.

    At such centres (e.g. the image diagonals of a box seen head-on, where two walls meet exactly under
    the pixel centre) the hit surface is decided by rounding: Mitsuba's scalar and llvm variants disagree
    there too, so light-transport comparisons leave them out (the G-buffer test covers them).
    """
    mi = mitsuba()
    if mi.variant().startswith("scalar"):
        raise RuntimeError("mitsuba_edge_pixels needs a vectorised (llvm) variant")
    width, height = size
    scene = load(path, **params)
    sensor = scene.sensors()[0]
    shapes = scene.shapes()
    ids = []
    for off in [(0.0, 0.0), (eps_px, 0.0), (-eps_px, 0.0), (0.0, eps_px), (0.0, -eps_px)]:
        si = scene.ray_intersect(_pixel_centre_rays(mi, sensor, width, height, off))
        sid = np.full(width * height, -1, np.int32)
        valid = np.array(si.is_valid())
        for k, sh in enumerate(shapes):
            sid[np.array(si.shape == mi.ShapePtr(sh)) & valid] = k
        ids.append(sid)
    ids = np.stack(ids)
    return (ids != ids[0]).any(axis=0).reshape(height, width)


def mitsuba_render(path, size: tuple[int, int], *, max_depth: int = 2, spp: int = 1, seed: int = 0,
                   batch: int = 16, progress=None, integrator: str = "path", **params) -> tuple[np.ndarray, np.ndarray]:
    """Pixel-centre render with Mitsuba's ``path`` integrator (or ``integrator``, e.g. ``"volpath"``): every
    camera ray through the pixel centre, everything after it random. Returns (mean, variance of the mean),
    both (H, W, 3) float32.

    With a single delta light and ``max_depth=2`` the result is deterministic (spp=1 suffices).
    """
    return render_loaded(load(path, **params), size, max_depth=max_depth, spp=spp, seed=seed, batch=batch,
                         progress=progress, integrator=integrator)


def render_loaded(scene, size: tuple[int, int], *, max_depth: int = 2, spp: int = 1, seed: int = 0,
                  batch: int = 16, progress=None, integrator: str = "path") -> tuple[np.ndarray, np.ndarray]:
    """``mitsuba_render`` of a scene already loaded by ``load`` (so that timing a render leaves the XML
    parsing out): ``batch`` spp per wavefront of W*H*batch lanes, ``progress(done, spp)`` after each.
    ``integrator``: Mitsuba's integrator plugin (``path``, ``volpath``, ...), with ``max_depth``.
    Returns (mean, variance of the mean), both (H, W, 3) float32."""
    mi = mitsuba()
    import drjit as dr

    width, height = size
    sensor = scene.sensors()[0]
    integrator = mi.load_dict({"type": integrator, "max_depth": int(max_depth)})
    n = width * height
    total = np.zeros((n, 3), np.float64)
    total2 = np.zeros((n, 3), np.float64)
    done = 0
    if mi.variant().startswith("scalar"):
        sampler = mi.load_dict({"type": "independent"})
        sampler.seed(seed)
        rays = list(_pixel_centre_rays_scalar(mi, sensor, width, height))
        for s in range(spp):
            for k, ray in enumerate(rays):
                L, _, _ = integrator.sample(scene, sampler, mi.RayDifferential3f(ray))
                v = np.array(L, dtype=np.float64)
                total[k] += v
                total2[k] += v * v
                sampler.advance()
            done += 1
    else:
        while done < spp:
            b = min(batch, spp - done)
            sampler = mi.load_dict({"type": "independent"})
            sampler.seed((seed * 1000003 + done) % 2**32, n * b)
            idx = dr.arange(mi.UInt32, n * b) % n
            x = mi.Float(idx % width)
            y = mi.Float(idx // width)
            pos = mi.Point2f((x + 0.5) / width, (y + 0.5) / height)
            ray, _ = sensor.sample_ray(0.0, 0.5, pos, mi.Point2f(0.5, 0.5))
            L, _, _ = integrator.sample(scene, sampler, mi.RayDifferential3f(ray))
            v = np.array(L, dtype=np.float64)
            v = v.T if v.shape == (3, n * b) else v.reshape(n * b, 3)
            v = v.reshape(b, n, 3)
            total += v.sum(axis=0)
            total2 += (v * v).sum(axis=0)
            done += b
            if progress is not None:
                progress(done, spp)
    mean = total / spp
    var = np.maximum(total2 / spp - mean * mean, 0.0) / max(spp - 1, 1)
    return mean.reshape(height, width, 3).astype(np.float32), var.reshape(height, width, 3).astype(np.float32)


def scene_variant(path, out_dir=None, *, keep_emitters=None, add_emitters: list[str] = (),
                  remove_area_emitters: bool = True) -> Path:
    """Write an edited copy of a scene (with its folder, so relative paths resolve) and return its XML path.

    keep_emitters: indices (document order) of the top-level ``<emitter>`` elements to keep (None = all);
    add_emitters: XML snippets appended to the scene (e.g. an extra point light);
    remove_area_emitters: drop ``<emitter>`` children of shapes (their shapes stay, black or diffuse).
    """
    path = Path(path)
    out_dir = Path(out_dir) if out_dir else Path(tempfile.mkdtemp(prefix="manylights-scene-"))
    dst = out_dir / path.parent.name
    if not dst.exists():
        shutil.copytree(path.parent, dst)
    tree = ET.parse(path)
    root = tree.getroot()
    top = [e for e in root if e.tag == "emitter"]
    for k, e in enumerate(top):
        if keep_emitters is not None and k not in keep_emitters:
            root.remove(e)
    if remove_area_emitters:
        for shape in root.iter("shape"):
            for e in [c for c in shape if c.tag == "emitter"]:
                shape.remove(e)
    for snippet in add_emitters:
        root.append(ET.fromstring(snippet))
    out = dst / ("variant-" + path.name)
    k = 0
    while out.exists():
        k += 1
        out = dst / f"variant{k}-{path.name}"
    tree.write(out)
    return out
