"""``tensor_clustering``: an animation rendered by tensor clustering, in this process or with its chunks of
frames on a Dask cluster (``animation.tensor_dask``)."""
from __future__ import annotations

import time
from typing import Optional

import numpy as np

from .._utils import validate as _v
from .._utils.keywords import checked_keywords
from .._utils.seeds import derived_seed
from ..renderers.probe_error import probe_error, probe_summary
from .tensor import LightTensor
from .tensor_clusters import render_clustered
from .tensor_dask import distributed_tensor_clustering


@checked_keywords()
def tensor_clustering(T, rows: int = 100, columns: int = 300, seed: int = 0, *, chunk: int = 40,
                      representative: str = "centroid", init_clusters: int = 100, time_weight: float = 1.0,
                      row_indices=None, progress: Optional[bool] = None, client=None, connect_timeout: float = 10.0,
                      first_chunk: int = 0, error_probes: int = 0, probe_spp: int = 256,
                      probe_max_depth: Optional[int] = None):
    """Render an animation by tensor clustering (Hašan, Velázquez, Pellacini, Bala, EGSR 2008, Sec. 4).

    The same ``rows`` stratified view samples are computed in every frame (the r slices, ``T.slices``), the
    n x f light-frame pairs of the reduced tensor are clustered (``cluster_tensor``: ``columns`` per frame on
    average, ``columns * f`` in all, chunks of ``chunk`` frames), each cluster's representative column is
    rendered once in its own frame and carried into every frame of its cluster by the pixel mappings,
    scaled by Rec (Sec. 4.5), and each frame adds what its camera sees of emitters. On the GPU backend the
    representative columns never leave the GPU: they are scaled, mapped and accumulated there and each
    chunk's frames are read back once (Sec. 5; ``_native.tensor_reconstruct_gpu``); on the CPU backend
    ``_native.tensor_accumulate`` does the same with rayon. The two agree to float round-off.

    Args:
        T: a ``LightTensor``.
        rows: r, view samples sampled in every frame (ignored with ``row_indices``).
        columns: representative columns per frame on average (the paper's budget: 300-500 shadow maps per
            frame are rows + columns); the total c = columns * f is clipped to [f, n f].
        seed: seeds the rows and the clustering.
        chunk, init_clusters, time_weight: as ``cluster_tensor``.
        representative: "centroid" (default; not in the paper: the pair whose scaled reduced column best
            matches its cluster's sum), "max" (the paper's Sec. 4.5: the pair of largest weight) or
            "sampled" (MRCS's weight-proportional choice). Measured on the bundled animation (8 frames,
            48x48, 3,000 lights, 300 shadow maps per frame): mean per-frame error 1.6% with "centroid"
            against 3.0-3.2% with "max" (per-frame MRCS at 600: 1.9-2.2%); docs/validation/animations.md has the full figures.
            "centroid" considers only pairs of at least half the cluster's mean weight, so no pair the rows
            barely see is scaled up by hundreds (which made one seed in 8 an outlier at 6.4%).
        row_indices: your own view-sample rows instead of ``stratified_rows``.
        progress: progress over the slices (None: a bar in a terminal or notebook, nothing in logs; True:
            also a few lines in logs; False: nothing).
        client: a ``dask.distributed.Client`` or scheduler address: each chunk of ``chunk`` frames is one Dask
            task (a worker loads its frames from ``T.animation``'s paths and parameters; ``animation.tensor_dask``).
            Each chunk is clustered with its index (``first_chunk``), so the result equals the serial call's
            to float round-off. Timings are summed over chunks; ``budget`` adds chunks and wall_seconds.
        connect_timeout: seconds to wait for a scheduler given by address.
        first_chunk: as ``cluster_tensor``: T is chunk ``first_chunk`` onwards of a longer animation (its
            chunks are then clustered exactly as in the whole animation).
        error_probes: N > 0: in every frame, N probe pixels path-traced with ``probe_spp`` paths each estimate
            the frame's error against the converged frame, bias included (``renderers.probe_error``; the
            probes of frame k are seeded by (seed, k)). 0: no probes.
        probe_spp: paths per probe (>= 2).
        probe_max_depth: the converged frames' path depth; None = the tensor's ``max_depth`` (-1 or >= 2: the
            depth the lights model). A depth above what the lights model (direct-only lights and -1) counts
            the missing light as error, as it is.

    Returns:
        AnimationResult: frames (f, H, W, 3) float32; shadow_maps_per_frame = rows + representatives
        rendered in that frame (counted); the clustering; timings per stage in seconds: row_selection,
        slices, clustering, mappings, columns (rendering the representatives), reconstruction (scaling and
        mapping them into their frames), emitted (and probes). With probes: ``error_estimate`` (f,) the upper
        bounds, ``budget['probes']`` one dict per frame (``probe_error``'s, without its per-probe arrays).

    Raises:
        FloatingPointError: a frame that overflowed float32 (the first pixel named).
        TypeError: T is not a LightTensor. ValueError: rows or columns out of range, a bad chunk or
            representative, a negative seed; ``client`` with a T not made from an ``Animation``.
        OSError: a scheduler address not reachable within ``connect_timeout``.
    """
    if not isinstance(T, LightTensor):
        raise TypeError(f"T must be a LightTensor, got {type(T).__name__}")
    m, n, f = T.shape
    seed = _v.seed(seed)
    columns = _v.integer("columns", columns, 1, n)
    error_probes = _v.integer("error_probes", error_probes, 0, m)
    probe_spp = _v.integer("probe_spp", probe_spp, 2, 1 << 30)
    depth = T._options["max_depth"] if probe_max_depth is None else _v.integer("probe_max_depth", probe_max_depth, -1)
    if depth in (0, 1):
        raise ValueError(f"probe_max_depth must be -1 or >= 2, got {depth}")
    if client is not None:
        res = distributed_tensor_clustering(T, rows, columns, seed, chunk, client, row_indices,
                                            _v.real("connect_timeout", connect_timeout, 0.0),
                                            dict(representative=representative, init_clusters=init_clusters,
                                                 time_weight=time_weight))
    else:
        res = render_clustered(T, rows, columns, seed, chunk=chunk, representative=representative,
                               init_clusters=init_clusters, time_weight=time_weight, row_indices=row_indices,
                               progress=progress, first_chunk=first_chunk)
    _v.finite_result("tensor_clustering", res.frames)
    if error_probes:
        attach_frame_probes(res, T.scenes, error_probes, seed, spp=probe_spp, max_depth=depth)
    return res


def attach_frame_probes(res, scenes, probes: int, seed: int, *, spp: int, max_depth: int):
    """Probe every frame of an ``AnimationResult`` (``renderers.probe_error``; frame k seeded by (seed, k)):
    ``res.error_estimate`` (f,), ``res.budget['probes']`` (a list per frame), ``res.timings['probes']``."""
    t = time.perf_counter()
    per_frame = []
    for k, scene in enumerate(scenes):
        est = probe_error(res.frames[k], scene, probes, spp=spp, max_depth=max_depth, seed=derived_seed(seed, k))
        per_frame.append(probe_summary(est))
    res.error_estimate = np.array([e["error_estimate"] for e in per_frame], dtype=np.float64)
    res.budget["probes"] = per_frame
    res.timings["probes"] = time.perf_counter() - t
    return res
