"""``python -m manylights.bench backends --peer mitsuba``: the CPU backend's shadow rays against Mitsuba 3's
``Scene::ray_test`` on exactly the same rays, side by side in one run.

Per scene two batches of light-matrix elements (Hašan et al. 2007, Sec. 3: ``A(i, j)`` is light j's
unshadowed contribution to view sample i times its visibility):

- **columns**: every view sample of the image to each of ``--peer-lights`` lights (default 256), light by
  light (the column batches of MRCS and of the clustered renderers);
- **rows**: ``--peer-rows`` stratified view samples (default 256) to each of ``--peer-row-lights`` lights (default 16,384)
  (``A.rows``: MRCS's row sampling), view sample by view sample.

``LightMatrix.shadow_rays`` returns the batch's exact shadow rays (``src/cpu/shadow_rays.rs``: the origin
offsets and ``t_max`` shortening of Mitsuba's ``spawn_ray_to``; elements whose unshadowed value is 0 cast
none). Then, best of ``--repeats`` after a warm-up:

- **visibility alone**: ``LightMatrix.trace_shadow_rays`` (the backend's BVH traversal and triangle tests,
  rayon) against ``scene.ray_test`` of Mitsuba's fastest CPU variant (``llvm_ad_rgb``; ``scalar_rgb`` if
  LLVM is missing) on the same rays, in Mrays/s, with the share of rays on which the two agree;
- **the whole element**: ``A.weighted_sum`` of the batch's lights (columns) or ``A.rows`` (rows): ray set-up,
  unshadowed shading, visibility and accumulation, in Mrays/s of the rays it casts, with the share of its
  seconds that traversal alone takes (the visibility-alone seconds; the rest is ray set-up, shading and
  accumulation). ``seconds["ray_arrays"]`` is ``shadow_rays``' own time to write the batch's rays into
  arrays (unshadowed shading included), which the element does not do;
- **every element's ray**: the same two measurements on one ray per element of the batch (every view sample
  on a surface to every light, lit or not: ``shadow_rays(..., every_element=True)``), the rays a renderer
  that traced before shading would cast, and the whole element's seconds against ``ray_test``'s on them
  (the element's throughput in elements per second beside ``ray_test``'s in rays per second).

Scenes: ``cbox`` (128^2), ``veach-ajar`` (128x72), ``bunny`` (the Stanford bunny, 128^2) and ``room-2m`` (the
generated room of ``bench scale`` with a 2,097,152-triangle floor, 128x96). Mitsuba is needed only here
(``pip install mitsuba==3.9.1``). Results go into ``backends.json`` under ``peer``.

Symbols
-------
| here | meaning |
|---|---|
| ``r`` | rays cast by the batch (elements with a non-zero unshadowed value) |
| ``e`` | the batch's elements; ``r_e``: their rays (elements of surface view samples) |
| ``Mrays/s`` | r / seconds / 1e6 |
"""
from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np

import manylights as ml

from .common import REPO, mixed_lights

#: scene -> (XML relative to the clone, or "generated", loader params, size)
PEER_SCENES = {
    "cbox": ("scenes/cbox/scene.xml", {}, (128, 128)),
    "veach-ajar": ("scenes/veach-ajar/scene.xml", {}, (128, 72)),
    "bunny": ("tests/data/scenes/bunny/scene.xml", {}, (128, 128)),
    "room-2m": ("generated", {}, (128, 96)),
}


def _best(f, repeats: int):
    """(best seconds as f reports them, last value) over ``repeats`` calls after a warm-up; ``f`` returns
    (seconds, value)."""
    f()
    best, value = float("inf"), None
    for _ in range(repeats):
        s, value = f()
        best = min(best, s)
    return best, value


def _timed(f):
    def g():
        t = time.perf_counter()
        v = f()
        return time.perf_counter() - t, v
    return g


def mitsuba_ray_test(scene, rays: dict, repeats: int) -> tuple[float, np.ndarray, str]:
    """Mitsuba's ``scene.ray_test`` on ``rays`` (``LightMatrix.shadow_rays``' dict): (best seconds, blocked
    (r,) bool, variant). The rays are built as Dr.Jit arrays before the clock starts; the clock covers the
    call and its evaluation (``dr.eval`` + ``dr.sync_thread``)."""
    from ..testing import mitsuba as reference

    mi = reference.mitsuba()
    import drjit as dr

    o, d, t = rays["origin"], rays["direction"], rays["t_max"]
    ray = mi.Ray3f(mi.Point3f(*(np.ascontiguousarray(o[:, k]) for k in range(3))),
                   mi.Vector3f(*(np.ascontiguousarray(d[:, k]) for k in range(3))),
                   mi.Float(np.ascontiguousarray(t)), 0.0, [])
    dr.eval(ray)
    dr.sync_thread()

    def once():
        t0 = time.perf_counter()
        hit = scene.ray_test(ray)
        dr.eval(hit)
        dr.sync_thread()
        return time.perf_counter() - t0, hit

    seconds, hit = _best(once, repeats)
    return seconds, np.asarray(hit, dtype=bool), mi.variant()


def measure(name: str, xml: Path, params: dict, size, lights: int, row_lights: int, rows: int,
            repeats: int) -> dict:
    """Both batches of one scene (module doc): per batch rays, elements, Mrays/s of the backend's
    visibility, of Mitsuba's ray_test and of the whole element, the agreement and the time split."""
    from ..testing import mitsuba as reference
    scene = ml.load_scene(xml, size=size, **params)
    peer = reference.load(xml, **params)
    out = {"size": list(size), "batches": {}}
    col_lights = mixed_lights(scene, lights)
    A = ml.LightMatrix(scene, col_lights, device="cpu")
    B = ml.LightMatrix(scene, mixed_lights(scene, row_lights, seed=1), device="cpu")
    m, n = A.shape
    js = list(range(n))
    view_rows = [int(i) for i in ml.stratified_rows(scene, rows, seed=0)]
    w = np.ones((n, 3), np.float32)
    batches = {
        "columns": (A, list(range(m)), js, _timed(lambda: A.weighted_sum(js, w))),
        "rows": (B, view_rows, list(range(B.shape[1])), _timed(lambda: B.rows(view_rows, progress=False))),
    }
    for batch, (M, views, ls, element) in batches.items():
        setup, rays = _best(lambda M=M, views=views, ls=ls, batch=batch: (
            lambda d: (d["seconds"], d))(M.shadow_rays(views, ls, order=batch)), repeats)
        r = len(rays["t_max"])
        ours, blocked = _best(lambda M=M, rays=rays: M.trace_shadow_rays(rays["origin"], rays["direction"],
                                                                         rays["t_max"])[::-1], repeats)
        theirs, their_blocked, variant = mitsuba_ray_test(peer, rays, repeats)
        whole, _ = _best(element, repeats)
        res = {"elements": int(rays["elements"]), "rays": r, "blocked_share": float(blocked.mean()) if r else 0.0,
               "agreement": float((blocked == their_blocked).mean()) if r else 1.0,
               "ours_mrays_s": r / ours / 1e6, "mitsuba_mrays_s": r / theirs / 1e6, "mitsuba_variant": variant,
               "element_mrays_s": r / whole / 1e6, "visibility_ratio": theirs / ours, "element_ratio": theirs / whole,
               "split": {"traversal": ours / whole, "setup_shading_rest": max(whole - ours, 0.0) / whole},
               "seconds": {"ours": ours, "mitsuba": theirs, "element": whole, "ray_arrays": setup}}
        every = M.shadow_rays(views, ls, order=batch, every_element=True)
        r_e = len(every["t_max"])
        ours_e, blocked_e = _best(lambda M=M, rays=every: M.trace_shadow_rays(rays["origin"], rays["direction"],
                                                                              rays["t_max"])[::-1], repeats)
        theirs_e, their_blocked_e, _ = mitsuba_ray_test(peer, every, repeats)
        res["every_element"] = {
            "rays": r_e, "blocked_share": float(blocked_e.mean()) if r_e else 0.0,
            "agreement": float((blocked_e == their_blocked_e).mean()) if r_e else 1.0,
            "ours_mrays_s": r_e / ours_e / 1e6, "mitsuba_mrays_s": r_e / theirs_e / 1e6,
            "visibility_ratio": theirs_e / ours_e, "element_melements_s": res["elements"] / whole / 1e6,
            "element_ratio": theirs_e / whole, "seconds": {"ours": ours_e, "mitsuba": theirs_e}}
        out["batches"][batch] = res
        print(f"{name} {batch:>7}: {r:>9,} rays ({res['blocked_share']:.0%} blocked, agreement "
              f"{res['agreement']:.5f}): ours {res['ours_mrays_s']:6.1f} Mrays/s, Mitsuba ray_test "
              f"{res['mitsuba_mrays_s']:6.1f} ({variant}), ratio {res['visibility_ratio']:.2f}x; whole element "
              f"{res['element_mrays_s']:6.1f} Mrays/s ({res['element_ratio']:.2f}x of ray_test; traversal "
              f"{res['split']['traversal']:.0%}, set-up, shading and the rest "
              f"{res['split']['setup_shading_rest']:.0%})", flush=True)
        e = res["every_element"]
        print(f"{name} {batch:>7}, every element's ray: {r_e:>9,} rays ({e['blocked_share']:.0%} blocked, agreement "
              f"{e['agreement']:.5f}): ours {e['ours_mrays_s']:6.1f} Mrays/s, Mitsuba ray_test "
              f"{e['mitsuba_mrays_s']:6.1f}, ratio {e['visibility_ratio']:.2f}x; whole element "
              f"{e['element_melements_s']:6.1f} Melements/s ({e['element_ratio']:.2f}x of ray_test)", flush=True)
    return out


def run_peer(scenes, lights: int, row_lights: int, rows: int, repeats: int) -> dict:
    """``measure`` for every scene named in ``scenes`` (keys of ``PEER_SCENES``)."""
    out = {}
    for name in scenes:
        rel, params, size = PEER_SCENES[name]
        if rel == "generated":
            from .scale import write_scene

            with tempfile.TemporaryDirectory(prefix="manylights-peer-") as tmp:
                out[name] = measure(name, write_scene(Path(tmp), 2_097_152), params, size, lights, row_lights,
                                    rows, repeats)
        else:
            out[name] = measure(name, REPO / rel, params, size, lights, row_lights, rows, repeats)
    return out
