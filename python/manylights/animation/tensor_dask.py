"""Tensor clustering with its chunks of frames rendered on a Dask cluster (``tensor_clustering(T, ...,
client=...)``).

Tensor clustering cuts the frames into chunks of ``chunk`` frames that are clustered and rendered
independently (no cluster spans two chunks, Hašan et al. 2008 Sec. 6), so each chunk is one Dask task: a
worker loads the chunk's frames from the animation's paths and per-frame parameters, rebuilds each frame's
lights from their arrays (``LightSet.from_arrays``: bit-identical lights, no GPU state pickled), makes the
chunk's ``LightTensor`` and runs the clustering (``tensor_clusters.render_clustered``) on it with the rows chosen once on the client. The
frames, the counts of shadow maps and the clusterings of the chunks are joined in frame order.

Chunk b is clustered with its index (``first_chunk=b``; the random streams are per (seed, chunk index)), so
a distributed run equals the serial call to float round-off.
"""
from __future__ import annotations

import time

import numpy as np

from .._native import LightSet
from .._utils import validate as _v
from .._utils.dask import connect, release
from ..matrix.rows import stratified_rows
from .frames import Animation, load_animation
from .tensor import AnimationResult, LightTensor
from .tensor_clusters import TensorClustering, render_clustered, time_weight_of

#: LightSet arrays that ``LightSet.from_arrays`` takes back (power follows from the intensity).
LIGHT_FIELDS = ("kind", "position", "direction", "normal", "geo_normal", "incident", "intensity", "cutoff_angle",
                "beam_width", "bsdf", "patch", "vsl_radius")


def _light_arrays(ls) -> dict:
    return {**{k: np.asarray(getattr(ls, k)) for k in LIGHT_FIELDS}, "vpl_clamp": float(ls.vpl_clamp)}


def render_chunk(paths: list, params: list, size: tuple, anim_device: str, light_arrays: list, options: dict,
                 row_indices: np.ndarray, columns: int, seed: int, kwargs: dict, index: int = 0) -> dict:
    """A worker's task: tensor clustering of one chunk of frames, loaded from paths + parameters.

    Returns:
        dict: frames (k, H, W, 3) float32, shadow_maps_per_frame (k,), timings, budget, device, clustering
        (the chunk's TensorClustering), host."""
    import socket

    t = time.perf_counter()
    anim = load_animation([str(p) for p in paths], frames=params, size=size, device=anim_device)
    lights = [LightSet.from_arrays(anim[k], **arrays) for k, arrays in enumerate(light_arrays)]
    T = LightTensor(anim, lights, **options)
    load = time.perf_counter() - t
    res = render_clustered(T, columns=columns, seed=seed, row_indices=row_indices, chunk=len(paths),
                            first_chunk=index, **kwargs)
    return {"frames": res.frames, "shadow_maps_per_frame": res.shadow_maps_per_frame,
            "timings": {"load": load, **res.timings}, "budget": res.budget, "device": res.device,
            "clustering": res.clustering, "host": socket.gethostname(), "bias_sources": res.bias_sources}


def _join_clusterings(parts: list, starts: list, f: int, seed: int):
    """One TensorClustering of all frames from the chunks' (cluster ids and frames offset)."""
    offs = np.cumsum([0] + [p.num_clusters for p in parts])
    rec = np.zeros((int(offs[-1]), f, 3), np.float32)
    reps, frames, chunks = [], [], []
    for p, k0, o in zip(parts, starts, offs):
        kf = p.assignment.shape[1]
        rec[o:o + p.num_clusters, k0:k0 + kf] = p.rec
        reps.append(np.asarray(p.representatives) + np.array([0, k0]))
        frames.append(np.asarray(p.frames) + k0)
        for ch in p.chunks:
            ch = dict(ch)
            if "frames" in ch:
                ch["frames"] = tuple(int(x) + k0 for x in ch["frames"])
            chunks.append(ch)
    return TensorClustering(
        representatives=np.concatenate(reps).astype(np.int64),
        assignment=np.concatenate([np.asarray(p.assignment) + o for p, o in zip(parts, offs)], axis=1).astype(np.int32),
        rec=rec, frames=np.concatenate(frames).astype(np.int64),
        sizes=np.concatenate([p.sizes for p in parts]), cost=np.concatenate([p.cost for p in parts]),
        rendered=np.concatenate([p.rendered for p in parts]),
        shadow_maps_per_frame=np.concatenate([p.shadow_maps_per_frame for p in parts]),
        clusters_per_frame=np.concatenate([p.clusters_per_frame for p in parts]), chunks=chunks, seed=seed)


def distributed_tensor_clustering(T, rows: int, columns: int, seed: int, chunk: int, client, row_indices,
                                  connect_timeout: float, kwargs: dict):
    """``tensor_clustering`` with one Dask task per chunk of frames (module docs); the arguments are
    ``tensor_clustering``'s, checked by it.

    Raises:
        ValueError: T not made from an ``Animation`` (``load_animation``: the workers need its paths and
            per-frame parameters). OSError: an unreachable scheduler. Whatever a chunk's task raises (the
            first error, re-raised here)."""
    anim = T.animation
    if not isinstance(anim, Animation):
        raise ValueError("tensor_clustering(client=...) needs a LightTensor made from an Animation (load_animation), "
                         f"whose frames workers can load from paths and parameters; got frames of type "
                         f"{type(anim).__name__}")
    m, n, f = T.shape
    seed = _v.seed(seed)
    columns = _v.integer("columns", columns, 1, n)
    chunk = _v.integer("chunk", chunk, 1, 2**63 - 1)
    # The workers check these too; checked here so that bad input fails before a cluster is reached.
    if kwargs["representative"] not in ("max", "sampled", "centroid"):
        raise ValueError(f"representative must be 'max', 'sampled' or 'centroid', got {kwargs['representative']!r}")
    _v.integer("init_clusters", kwargs["init_clusters"], 1, 2**63 - 1)
    time_weight_of(kwargs["time_weight"])
    if row_indices is None:
        row_indices = stratified_rows(T.scenes[0], _v.integer("rows", rows, 1, m), seed=seed)
    else:
        row_indices = _v.indices("row index", row_indices, m, f"m = {m} view samples")
    size = (anim.width, anim.height)
    cl, owned = connect(client, None, connect_timeout, "auto")
    t = time.perf_counter()
    try:
        starts = list(range(0, f, chunk))
        futures = []
        for index, k0 in enumerate(starts):
            ks = range(k0, min(k0 + chunk, f))
            futures.append(cl.submit(render_chunk, [anim.paths[k] for k in ks], [anim.params[k] for k in ks], size,
                                     anim.device, [_light_arrays(T.lights[k]) for k in ks], dict(T._options),
                                     row_indices, columns, seed, kwargs, index, pure=False))
        parts = cl.gather(futures)
    finally:
        release(cl, owned)
    wall = time.perf_counter() - t
    timings: dict = {}
    for p in parts:
        for k, v in p["timings"].items():
            timings[k] = timings.get(k, 0.0) + float(v)
    clustering = _join_clusterings([p["clustering"] for p in parts], starts, f, seed)
    budget = {"rows": int(len(row_indices)), "columns": int(sum(p["budget"]["columns"] for p in parts)), "lights": n,
              "frames": f, "chunks": len(parts), "wall_seconds": wall}
    device = {**parts[0]["device"], "hosts": sorted({p["host"] for p in parts})}
    return AnimationResult(frames=np.concatenate([p["frames"] for p in parts]), method="tensor_clustering", seed=seed,
                           shadow_maps_per_frame=np.concatenate([p["shadow_maps_per_frame"] for p in parts]),
                           timings=timings, budget=budget, device=device, rows=row_indices, clustering=clustering,
                           bias_sources=parts[0]["bias_sources"])
