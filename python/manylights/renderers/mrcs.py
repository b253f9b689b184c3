"""Matrix Row-Column Sampling (Hašan, Pellacini, Bala, SIGGRAPH 2007).

``mrcs(A, rows, columns)`` follows the paper's four steps, each replaceable from Python:

1. rows: ``stratified_rows`` picks one view sample per image block (section 4); ``A.rows`` renders them on
   the matrix's device (CPU: exact rays; GPU: a cube shadow map at each sample, all lights evaluated
   against it) -> the reduced matrix R (r x n);
2. clustering: ``cluster_reduced_columns(R, columns)`` (sampling by cluster cost, then splitting);
3. representatives: one light per cluster, chosen by reduced-column norm, weighted so that the estimate of
   the full column sum is unbiased (``weights``);
4. reconstruction: ``A.weighted_sum(representatives, weights)`` renders only the c representative columns
   and accumulates them (on the GPU without readback; on the CPU in registers per pixel).

Every step runs on either backend of the matrix (``LightMatrix(..., device=)``); ``RenderResult.device``
says which ran.

A researcher substitutes a step by passing ``row_indices=`` or ``clustering=`` (any dict with
``representatives`` and ``weights``), or by calling the pieces directly.

Its baselines, power sampling and instant radiosity, are in ``baselines``.

| symbol | name |
|---|---|
| A | light matrix (m view samples x n lights) |
| r, R | number of sampled rows; the reduced matrix (r x n) |
| c | number of clusters = representative columns |
| w_k | weight of cluster k's representative (RGB) |
"""
from __future__ import annotations

import time
from typing import Optional

import numpy as np

from .._utils import validate as _v
from .._utils.keywords import checked_keywords
from ..matrix.rows import stratified_rows
from . import estimates
from .bias import bias_sources
from .clustering import cluster_reduced_columns
from .probe_error import attach_probe_error
from .result import RenderResult, light_luminance_power, matrix_shape, with_emitted


def reconstruct(A, reps, weights, timings: dict, add_emitted: bool, progress: bool) -> np.ndarray:
    """Render the weighted representative columns on the GPU (+ the emitted image), timing each stage."""
    t = time.perf_counter()
    image = A.weighted_sum(reps, weights, progress=progress)
    timings["columns"] = time.perf_counter() - t
    image = with_emitted(A, image, timings, add_emitted)
    return image


@checked_keywords(cluster_reduced_columns, exclude=("seed", "power"))
def mrcs(A, rows: int = 300, columns: int = 900, seed: int = 0, *, row_indices=None, clustering=None,
         add_emitted: bool = True, progress: Optional[bool] = None, error_rows: int = 0, halves: bool = False,
         error_probes: int = 0, **cluster_options) -> RenderResult:
    """Render the column sum of light matrix ``A`` by Matrix Row-Column Sampling.

    Args:
        A: a ``LightMatrix``.
        rows: r, the number of sampled rows (ignored when ``row_indices`` is given).
        columns: c, the number of clusters = representative columns rendered.
        seed: seeds row selection, projection, sampling, splitting and representatives.
        row_indices: your own rows (view-sample indices) instead of ``stratified_rows``.
        clustering: your own clustering result (a dict with ``representatives`` (c,) and ``weights`` (c, 3)).
        add_emitted: add what the camera sees of emitters (``A.emitted()``), as every renderer does.
        error_rows: h > 0 renders h extra stratified rows only to estimate the error of this image
            (``error_estimate``, ``error_image``; ``manylights.renderers.estimates``). 0: no estimate (None).
        halves: the error estimate from two independent half images instead: ``columns // 2`` clusters
            with two representatives each (same column count, one clustering of half the size), the
            image is their mean (``manylights.renderers.estimates``; calibrated in ``bench calibrate``). A light both
            draws of its cluster pick is rendered once: ``budget['rendered_columns']`` (<= columns).
        error_probes: N > 0 path-traces N stratified probe pixels (1,024 paths each, the scene's integrator
            depth) and reports the error against the converged scene, bias included (``probe_error``):
            ``error_estimate`` becomes the probes' upper bound, ``variance_estimate`` keeps the halves' or
            rows' estimate, ``bias_estimate`` the split; 0 (default): no probes, the estimate covers variance
            only (``bias_sources`` lists what it misses).
        **cluster_options: passed to ``cluster_reduced_columns`` (projection_dim, sampling_fraction, ...).

    Returns:
        RenderResult with image (H, W, 3), rows, clusters (assignment per light), representatives, weights,
        and timings per stage in seconds: row_selection, row_setup (GPU allocations and the light upload
        of a matrix's first rows call), row_shadow_maps (GPU cube maps at the rows),
        row_evaluation (GPU: all lights against each row), row_readback (GPU -> numpy), clustering,
        columns (GPU shadow maps + shading of the representatives, accumulated on the GPU), emitted,
        error_estimate; ``error_estimate`` (float, estimated relative L2 against brute force) and
        ``error_image`` ((H, W) float32 RMS error per pixel) with ``halves`` or ``error_rows``
        (``manylights.renderers.estimates``), else None.

    Raises:
        TypeError: A is not a LightMatrix. ValueError: rows / columns out of range, row_indices outside
            [0, m), a clustering without representatives in [0, n) and finite (c, 3) or (c,) weights,
            a negative seed, error_rows not an integer in [0, m], halves with columns < 2 or with a
            given clustering.
    """
    m, n = matrix_shape(A)
    if n == 0:
        raise ValueError("the light matrix has no lights (n = 0): nothing to sample")
    if halves and n < 2:
        raise ValueError(f"halves=True needs >= 2 lights (two half images of columns // 2 clusters each); "
                         f"the matrix has {n}")
    seed = _v.seed(seed)
    error_rows = _v.integer("error_rows", error_rows, 0, m)
    error_probes = _v.integer("error_probes", error_probes, 0, m)
    timings = {}
    t = time.perf_counter()
    if clustering is not None:
        row_indices = None  # a given clustering needs no rows
    elif row_indices is None:
        row_indices = stratified_rows(A.scene, rows, seed=seed)
    else:
        row_indices = _v.indices("row index", row_indices, m, f"m = {m} view samples")
    timings["row_selection"] = time.perf_counter() - t
    R = None
    if clustering is None:
        t = time.perf_counter()
        R, stages = A.rows(row_indices, progress=progress, return_timings=True)
        wall = time.perf_counter() - t
        timings["row_setup"] = stages["setup"]
        timings["row_shadow_maps"] = stages["shadow_maps"]
        timings["row_evaluation"] = stages["evaluation"]
        # GPU -> host copy and the numpy array (the rest of the call).
        timings["row_readback"] = max(wall - stages["setup"] - stages["shadow_maps"] - stages["evaluation"], 0.0)

    if halves:
        if R is None:
            raise ValueError("halves=True needs the rows: it cannot be combined with a given clustering")
        cl, reps, weights, X1, X2 = estimates.mrcs_halves(A, R, _v.integer("columns", columns, 2, n), seed,
                                                        light_luminance_power(A.lights), timings, progress,
                                                        **cluster_options)
        image = with_emitted(A, 0.5 * (X1 + X2), timings, add_emitted)
        res = RenderResult(image=image, method="mrcs", seed=seed, timings=timings, rows=row_indices,
                           clusters=cl["assignment"], representatives=reps, weights=weights,
                           budget={"rows": int(len(row_indices)), "columns": int(len(reps)), "lights": int(n),
                                   "clusters": int(len(reps) // 2), "rendered_columns": cl["rendered_columns"],
                                   "unseen_lights": cl["unseen_lights"]},
                           device=A.device, bias_sources=bias_sources(A))
        res.error_estimate, res.error_image = estimates.halves_estimate(X1, X2, res.image)
        return attach_probe_error(res, A.scene, error_probes, seed) if error_probes else res
    t = time.perf_counter()
    if clustering is None:
        clustering = cluster_reduced_columns(R, _v.integer("columns", columns, 1, n), seed=seed,
                                             power=light_luminance_power(A.lights), **cluster_options)
    reps, weights = checked_clustering(clustering, n)
    timings["clustering"] = time.perf_counter() - t

    image = reconstruct(A, reps, weights, timings, add_emitted, progress)
    res = RenderResult(image=image, method="mrcs", seed=seed, timings=timings, rows=row_indices,
                       clusters=clustering.get("assignment"), representatives=reps, weights=weights,
                       budget={"rows": 0 if row_indices is None else int(len(row_indices)),
                               "columns": int(len(reps)), "lights": int(n)}, device=A.device,
                       bias_sources=bias_sources(A))
    if error_rows and R is not None:
        estimates.attach_error_estimate(A, res, clustering, error_rows, progress=progress)
    return attach_probe_error(res, A.scene, error_probes, seed) if error_probes else res


def checked_clustering(clustering, n: int) -> tuple[np.ndarray, np.ndarray]:
    """(representatives (c,) int64, weights (c, 3) float32) of a clustering dict, checked."""
    if not hasattr(clustering, "__getitem__") or any(k not in clustering for k in ("representatives", "weights")):
        raise ValueError("clustering must be a dict with 'representatives' (c,) and 'weights' (c, 3) or (c,)")
    reps = _v.indices("representative", clustering["representatives"], n, f"n = {n} lights")
    weights = _v.numeric_array("clustering['weights']", clustering["weights"])
    if weights.ndim == 1:
        weights = np.repeat(weights[:, None], 3, axis=1)
    if weights.shape != (len(reps), 3):
        raise ValueError(f"clustering['weights'] must have shape ({len(reps)}, 3) or ({len(reps)},) for "
                         f"{len(reps)} representatives, got {np.shape(clustering['weights'])}")
    return reps, _v.finite("clustering['weights']", weights)

