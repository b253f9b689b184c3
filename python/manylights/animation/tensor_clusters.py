"""Tensor clustering of light-frame pairs (Hašan, Velázquez-Armendáriz, Pellacini, Bala, "Tensor Clustering
for Rendering Many-Light Animations", EGSR 2008, Sec. 4.3-4.5).

``cluster_tensor(R, columns)`` clusters the n x f light-frame pairs of a reduced tensor R (r sampled view
samples, the same in every frame, x n lights x f frames) into ``columns`` rectangular clusters (a set of
lights x a range of frames), each with one representative pair (light j, frame k) to render and a row of
the reconstruction matrix Rec: frame k' is estimated as ``sum_t Rec[t, k'] * A(:, rep_t)`` (the
representative's column mapped from its frame to k' by the renderer's pixel mappings). The algorithm (the
Rust core in ``src/cluster/tensor/``) follows the paper: MRCS sampling of the light slabs for the
initial light clusters, then the costliest cluster is split in time or in lights until the budget is
reached; frames are clustered in chunks of ``chunk`` frames, each with its share of the budget.

``tensor_clustering(T, rows, columns)`` is the whole renderer on a ``LightTensor``: slices, clustering,
pixel mappings, representative columns rendered once and carried into every frame of their cluster.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from .. import _native
from .._utils import validate as _v
from .._utils.keywords import checked_keywords
from ..matrix.rows import stratified_rows
from ..renderers.bias import bias_sources
from .tensor import AnimationResult, LightTensor


@dataclass
class TensorClustering:
    """A clustering of the (n, f) light-frame pairs of a reduced tensor (see ``cluster_tensor``)."""

    #: (c, 2) int64: (light, frame) of each cluster's representative.
    representatives: np.ndarray
    #: (n, f) int32: cluster of each light-frame pair.
    assignment: np.ndarray
    #: (c, f, 3) float32: the reconstruction matrix, RGB scale of representative t in frame k (0 outside
    #: the cluster's frames).
    rec: np.ndarray
    #: (c, 2) int64: each cluster's frames [start, end).
    frames: np.ndarray
    #: (c,) int64: light-frame pairs per cluster.
    sizes: np.ndarray
    #: (c,) float64: each cluster's cost (sum w)^2 - |sum R(:, p)|^2 (half the paper's Sec. 4.3.1 value).
    cost: np.ndarray
    #: (c,) bool: whether the representative must be rendered (some Rec entry non-zero).
    rendered: np.ndarray
    #: (f,) int64: representatives rendered in each frame (counted, not estimated).
    shadow_maps_per_frame: np.ndarray
    #: (f,) int64: clusters contributing to each frame (the paper's "effective number of clusters").
    clusters_per_frame: np.ndarray
    #: one dict per chunk: frames (start, end), budget, init_clusters, time_splits, light_splits.
    chunks: list = field(default_factory=list)
    seed: int = 0

    @property
    def num_clusters(self) -> int:
        return int(len(self.representatives))

    def lights(self, t: int) -> np.ndarray:
        """(|J|,) int64 lights of cluster t (ascending).

        Raises:
            ValueError: t not an integer in [0, c)."""
        t = _v.integer("t", t, 0, self.num_clusters - 1)
        return np.flatnonzero(self.assignment[:, int(self.frames[t, 0])] == t)

    def estimate(self, slices) -> np.ndarray:
        """The clustering's reconstruction of the row sums of the reduced tensor from the representatives
        only: ``out[i, k] = sum_t rec[t, k] * slices[i, rep_light_t, rep_frame_t]`` (what the renderer does
        with full columns, without pixel mappings since the rows are the same view samples in every frame).

        Args:
            slices: (r, n, f, 3) (or (r, n, f)) reduced tensor, n and f as clustered.

        Returns:
            (r, f, 3) (or (r, f)) float32.

        Raises:
            ValueError: a shape whose n or f differ from the clustering's. TypeError: a non-numeric array."""
        S = np.asarray(slices)
        if S.dtype.kind not in "fiub":
            S = _v.numeric_array("slices", S)  # raises the TypeError naming the dtype
        n, f = self.assignment.shape
        if S.ndim not in (3, 4) or S.shape[1:3] != (n, f) or (S.ndim == 4 and S.shape[3] != 3):
            raise ValueError(f"slices must have shape (r, {n}, {f}, 3) or (r, {n}, {f}) like the clustered tensor, "
                             f"got {S.shape}")
        scalar = S.ndim == 3
        if scalar:
            S = S[..., None]
        cols = S[:, self.representatives[:, 0], self.representatives[:, 1], :].astype(np.float64)  # (r, c, ch)
        _v.finite("slices (representative columns)", cols)
        rec = self.rec.astype(np.float64)
        out = np.stack([cols[:, :, ch] @ rec[:, :, ch] for ch in range(S.shape[3])], axis=-1)  # (r, f, ch)
        return (out[..., 0] if scalar else out).astype(np.float32)


def time_weight_of(v) -> float:
    v = _v.real("time_weight", v)
    if not (v > 0 and np.isfinite(v)):
        raise ValueError(f"time_weight must be a finite number > 0, got {v}")
    return float(v)


@checked_keywords()
def cluster_tensor(slices, columns: int, *, seed: int = 0, chunk: int = 40, init_clusters: int = 100,
                   projection_dim: int = 50, representative: str = "max",
                   color_averaging: bool = True, time_weight: float = 1.0, first_chunk: int = 0) -> TensorClustering:
    """Cluster the light-frame pairs of a reduced tensor (Hašan et al. 2008, Sec. 4.3-4.5).

    Args:
        slices: (r, n, f, 3) RGB (or (r, n, f) scalar) reduced tensor R: rows = view samples shared by all
            frames, n lights, f frames (float32; other real dtypes are converted). RGB elements become
            scalars by the 2-norm of the triple for the clustering; per-channel norms drive ``rec``.
        columns: c, the total number of clusters = representative columns rendered (shadow maps) over all
            frames, f <= c <= n f. The paper's "columns per frame" is c / f.
        seed: seeds the projection, the sampling, the light-split lines (and sampled representatives).
        chunk: frames per independently clustered chunk (paper: 40); each chunk gets a share of ``columns``
            proportional to its frame count.
        init_clusters: light clusters made by the initial MRCS sampling per chunk (paper: "e.g. 100"),
            capped by the chunk's budget; the rest of the budget is made by splitting.
        projection_dim: dimension of the random projection of the initialisation (applied when r * f is
            larger).
        representative: "max" (the paper: the pair of largest weight) or "sampled" (drawn with probability
            proportional to the weight, as MRCS does; with ``color_averaging=False`` the estimate of every
            frame's row sums is then unbiased when lights do not change over a cluster's frames, and the
            sum over frames is unbiased in general; the paper's "max" is biased, Sec. 4.5) or "centroid"
            (not in the paper, deterministic: the pair whose scaled reduced column is closest to the sum
            of the cluster's reduced columns; about 10x lower error than "max" on the test animation).
        color_averaging: Rec per channel from the per-channel column norms (the paper, Sec. 5); False: the
            scalar weight ratio in every channel.
        time_weight: a cluster is split in time only if that split's cost times ``time_weight`` is below
            the light split's (1: the paper; > 1 keeps clusters spanning more frames, the weighting of
            light against time splits that the paper's Sec. 4.3.2 suggests).
        first_chunk: index of the first chunk within a longer animation. Random streams are per (seed,
            chunk index), so the frames of chunk b clustered alone with ``first_chunk=b`` give exactly that
            chunk of the whole animation clustered at once (how chunks run as separate Dask tasks).

    Returns:
        TensorClustering with representatives (c, 2), assignment (n, f), rec (c, f, 3), frames (c, 2),
        sizes, cost, rendered, shadow_maps_per_frame (f,), clusters_per_frame (f,), chunks and
        ``estimate(slices)``.

    Raises:
        ValueError: slices not of shape (r, n, f, 3) / (r, n, f) or empty, NaN/inf (row, light, frame and
            channel named), columns not an integer in [f, n f], chunk / init_clusters / projection_dim < 1,
            a representative other than "max" / "sampled" / "centroid", a negative seed or first_chunk.
        TypeError: a non-numeric (complex, string) slices array.
    """
    S = np.asarray(slices)
    # A float32 (r, n, f, 3) view of frame-major data (``LightTensor.slices`` returns one) is handed to Rust as
    # it is stored; anything else becomes a C-contiguous float32 array.
    frame_major = (S.dtype == np.float32 and S.ndim in (3, 4) and not S.flags.c_contiguous
                   and np.moveaxis(S, 2, 0).flags.c_contiguous)
    if not frame_major:
        S = _v.numeric_array("slices", S)
    if S.ndim not in (3, 4) or (S.ndim == 4 and S.shape[3] != 3):
        raise ValueError(f"slices must have shape (r, n, f, 3) or (r, n, f), got {S.shape}")
    r, n, f = S.shape[:3]
    if r == 0 or n == 0 or f == 0:
        raise ValueError(f"slices must have at least one row, light and frame, got shape {S.shape}")
    columns = _v.integer("columns", columns)
    if not f <= columns <= n * f:
        raise ValueError(f"columns must be in [f, n * f] = [{f}, {n * f}] (at least one representative per frame "
                         f"on average, at most one per light-frame pair), got {columns}")
    seed = _v.seed(seed)
    if representative not in ("max", "sampled", "centroid"):
        raise ValueError(f"representative must be 'max', 'sampled' or 'centroid', got {representative!r}")
    d = _native.cluster_tensor(np.moveaxis(S, 2, 0) if frame_major else S, columns, seed, _v.integer("chunk", chunk, 1, 2**63 - 1),
                               _v.integer("init_clusters", init_clusters, 1, 2**63 - 1),
                               _v.integer("projection_dim", projection_dim, 1, 2**63 - 1), representative,
                               bool(color_averaging), time_weight_of(time_weight), frame_major,
                               _v.integer("first_chunk", first_chunk, 0, 2**62))
    return TensorClustering(representatives=d["representatives"], assignment=d["assignment"], rec=d["rec"],
                            frames=d["frames"], sizes=d["sizes"], cost=d["cost"], rendered=d["rendered"],
                            shadow_maps_per_frame=d["shadow_maps_per_frame"],
                            clusters_per_frame=d["clusters_per_frame"], chunks=list(d["chunks"]), seed=seed)


# ----------------------------------------------------------------------------------------------- renderer
#: Representative columns rendered and accumulated per batch (bounds the memory of a batch to
#: RENDER_BATCH * H * W * 12 bytes).
RENDER_BATCH = 128
NO_SOURCE = np.uint32(2**32 - 1)


def _mapping_arrays(T, m: int) -> tuple[np.ndarray, np.ndarray]:
    """Forward and backward adjacent pixel mappings as (f - 1, m) uint32 (NO_SOURCE for -1)."""
    f = len(T)

    def u32(a):
        a = np.asarray(a, dtype=np.int64).reshape(-1)
        return np.where(a < 0, np.int64(NO_SOURCE), a).astype(np.uint32)

    fw = np.empty((max(f - 1, 0), m), np.uint32)
    bw = np.empty((max(f - 1, 0), m), np.uint32)
    for k in range(f - 1):
        fw[k] = u32(T.mapping(k, k + 1))
        bw[k] = u32(T.mapping(k + 1, k))
    return fw, bw


def _reconstruct_cpu(T, cl, reps, todo, fw, bw, timings, shape) -> np.ndarray:
    """Representative columns rendered per source frame in batches, read back, then scaled, mapped and
    accumulated on the CPU (``_native.tensor_accumulate``)."""
    acc = np.zeros((*shape, 3), np.float32)
    for k0 in range(shape[0]):
        mine = todo[reps[todo, 1] == k0]
        for start in range(0, len(mine), RENDER_BATCH):
            batch = mine[start:start + RENDER_BATCH]
            t = time.perf_counter()
            cols = np.ascontiguousarray(T.frame(k0).columns(reps[batch, 0]), dtype=np.float32)
            timings["columns"] += time.perf_counter() - t
            t = time.perf_counter()
            _native.tensor_accumulate(acc, cols, np.full(len(batch), k0, np.uint32),
                                      np.ascontiguousarray(cl.rec[batch], dtype=np.float32), fw, bw)
            timings["reconstruction"] += time.perf_counter() - t
    return acc


def _reconstruct_gpu(T, cl, reps, todo, fw, bw, timings) -> np.ndarray:
    """The paper's Sec. 5 on the GPU, chunk by chunk: representative columns stay on the GPU, are scaled,
    carried through the pixel mappings and accumulated into every frame they serve there, and each
    chunk's frames are read back once (``_native.tensor_reconstruct_gpu``)."""
    parts = []
    rec = np.asarray(cl.rec, dtype=np.float32)
    for ch in cl.chunks:
        a, b = (int(v) for v in ch["frames"])
        mine = todo[(reps[todo, 1] >= a) & (reps[todo, 1] < b)]
        local = np.ascontiguousarray(np.stack([reps[mine, 0], reps[mine, 1] - a], axis=1), dtype=np.uint32).reshape(-1, 2)
        frames, t_cols, t_rec = _native.tensor_reconstruct_gpu(
            [T.frame(k)._m for k in range(a, b)], local, np.ascontiguousarray(rec[mine, a:b]),
            np.ascontiguousarray(fw[a:b - 1]), np.ascontiguousarray(bw[a:b - 1]))
        timings["columns"] += t_cols
        timings["reconstruction"] += t_rec
        parts.append(frames)
    return np.concatenate(parts, axis=0)


def render_clustered(T, rows: int = 100, columns: int = 300, seed: int = 0, *, chunk: int = 40,
                     representative: str = "centroid", init_clusters: int = 100, time_weight: float = 1.0,
                     row_indices=None, progress: Optional[bool] = None, first_chunk: int = 0):
    """Tensor clustering of ``T`` in this process (``tensor_clustering`` without ``client``; its doc: arguments,
    result, errors)."""
    if not isinstance(T, LightTensor):
        raise TypeError(f"T must be a LightTensor, got {type(T).__name__}")
    m, n, f = T.shape
    seed = _v.seed(seed)
    columns = _v.integer("columns", columns, 1, n)
    timings = {}
    t = time.perf_counter()
    if row_indices is None:
        row_indices = stratified_rows(T.scenes[0], _v.integer("rows", rows, 1, m), seed=seed)
    else:
        row_indices = _v.indices("row index", row_indices, m, f"m = {m} view samples")
    timings["row_selection"] = time.perf_counter() - t
    t = time.perf_counter()
    R = T.slices(row_indices, progress=progress)
    timings["slices"] = time.perf_counter() - t
    t = time.perf_counter()
    cl = cluster_tensor(R, min(max(columns * f, f), n * f), seed=seed, chunk=chunk, init_clusters=init_clusters,
                        representative=representative, time_weight=time_weight, first_chunk=first_chunk)
    del R
    timings["clustering"] = time.perf_counter() - t
    t = time.perf_counter()
    fw, bw = _mapping_arrays(T, m)
    timings["mappings"] = time.perf_counter() - t
    H, W = T.scenes[0].height, T.scenes[0].width
    reps = np.asarray(cl.representatives)
    todo = np.flatnonzero(np.asarray(cl.rendered))
    timings["columns"] = timings["reconstruction"] = 0.0
    if T.device.get("kind") == "gpu":
        acc = _reconstruct_gpu(T, cl, reps, todo, fw, bw, timings)
    else:
        acc = _reconstruct_cpu(T, cl, reps, todo, fw, bw, timings, (f, H, W))
    t = time.perf_counter()
    for k in range(f):
        acc[k] += T.frame(k).emitted()
    timings["emitted"] = time.perf_counter() - t
    spf = len(row_indices) + np.asarray(cl.shadow_maps_per_frame, dtype=np.int64)
    return AnimationResult(frames=acc, method="tensor_clustering", seed=seed, shadow_maps_per_frame=spf,
                           timings=timings, budget={"rows": int(len(row_indices)), "columns": int(len(todo)),
                                                    "lights": n, "frames": f},
                           device=T.device, rows=row_indices, clustering=cl, bias_sources=bias_sources(T.frame(0)))
