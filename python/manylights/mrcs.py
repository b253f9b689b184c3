"""Matrix Row-Column Sampling (Hašan, Pellacini, Bala, SIGGRAPH 2007) and its baselines.

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

Baselines: ``power_sampling`` (c lights drawn by power, unbiased weights, no rows) and
``instant_radiosity`` (fewer lights, all rendered).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from . import _native
from . import _validate as _v

# Rec. 709 luminance, for turning RGB powers into sampling weights.
LUMINANCE = np.array([0.2126, 0.7152, 0.0722], dtype=np.float64)


@dataclass
class RenderResult:
    """What a renderer did: the image (column estimate + what the camera sees of emitters) and how."""

    image: np.ndarray
    method: str
    seed: int
    timings: dict = field(default_factory=dict)
    rows: Optional[np.ndarray] = None
    clusters: Optional[np.ndarray] = None
    representatives: Optional[np.ndarray] = None
    weights: Optional[np.ndarray] = None
    budget: dict = field(default_factory=dict)
    #: The device that computed the image (``LightMatrix.device``: kind "cpu"/"gpu", name, backend, ...).
    device: dict = field(default_factory=dict)
    #: Estimated relative L2 of ``image`` against brute force, without the reference (MRCS: see
    #: ``manylights.adaptive``); None for renderers without one.
    error_estimate: Optional[float] = None
    #: (H, W) float32 estimated RMS error per pixel (radiance), where the renderer has one.
    error_image: Optional[np.ndarray] = None

    @property
    def seconds(self) -> float:
        """Total time of all stages."""
        return float(sum(self.timings.values()))


def _light_luminance_power(lights) -> np.ndarray:
    return np.maximum(np.asarray(lights.power, dtype=np.float64) @ LUMINANCE, 0.0)


def _reconstruct(A, reps, weights, timings: dict, add_emitted: bool, progress: bool) -> np.ndarray:
    """Render the weighted representative columns on the GPU (+ the emitted image), timing each stage."""
    t = time.perf_counter()
    image = A.weighted_sum(reps, weights, progress=progress)
    timings["columns"] = time.perf_counter() - t
    if add_emitted:
        t = time.perf_counter()
        image = image + A.emitted()
        timings["emitted"] = time.perf_counter() - t
    return image


def mrcs(A, rows: int = 300, columns: int = 900, seed: int = 0, *, row_indices=None, clustering=None,
         add_emitted: bool = True, progress: bool = False, error_rows: int = 0, halves: bool = False,
         **cluster_options) -> RenderResult:
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
            (``error_estimate``, ``error_image``; ``manylights.adaptive``). 0: no estimate (None).
        halves: the error estimate from two independent half images instead: ``columns // 2`` clusters
            with two representatives each (same column count, one clustering of half the size), the
            image is their mean (``manylights.adaptive``; calibrated in ``bench calibrate``). A light both
            draws of its cluster pick is rendered once: ``budget['rendered_columns']`` (<= columns).
        **cluster_options: passed to ``cluster_reduced_columns`` (projection_dim, sampling_fraction, ...).

    Returns:
        RenderResult with image (H, W, 3), rows, clusters (assignment per light), representatives, weights,
        and timings per stage in seconds: row_selection, row_setup (GPU allocations and the light upload
        of a matrix's first rows call), row_shadow_maps (GPU cube maps at the rows),
        row_evaluation (GPU: all lights against each row), row_readback (GPU -> numpy), clustering,
        columns (GPU shadow maps + shading of the representatives, accumulated on the GPU), emitted,
        error_estimate; ``error_estimate`` (float, estimated relative L2 against brute force) and
        ``error_image`` ((H, W) float32 RMS error per pixel) with ``halves`` or ``error_rows``
        (``manylights.adaptive``), else None.

    Raises:
        TypeError: A is not a LightMatrix. ValueError: rows / columns out of range, row_indices outside
            [0, m), a clustering without representatives in [0, n) and finite (c, 3) or (c,) weights,
            a negative seed, error_rows not an integer in [0, m], halves with columns < 2 or with a
            given clustering.
    """
    from . import cluster_reduced_columns, stratified_rows
    from . import adaptive

    m, n = _matrix_shape(A)
    if n == 0:
        raise ValueError("the light matrix has no lights (n = 0): nothing to sample")
    seed = _v.seed(seed)
    error_rows = _v.integer("error_rows", error_rows, 0, m)
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
        cl, reps, weights, X1, X2 = adaptive.mrcs_halves(A, R, _v.integer("columns", columns, 2, n), seed,
                                                        _light_luminance_power(A.lights), timings, progress,
                                                        **cluster_options)
        image = 0.5 * (X1 + X2)
        if add_emitted:
            t = time.perf_counter()
            image = image + A.emitted()
            timings["emitted"] = time.perf_counter() - t
        res = RenderResult(image=image, method="mrcs", seed=seed, timings=timings, rows=row_indices,
                           clusters=cl["assignment"], representatives=reps, weights=weights,
                           budget={"rows": int(len(row_indices)), "columns": int(len(reps)), "lights": int(n),
                                   "clusters": int(len(reps) // 2), "rendered_columns": cl["rendered_columns"],
                                   "unseen_lights": cl["unseen_lights"]},
                           device=A.device)
        res.error_estimate, res.error_image = adaptive.halves_estimate(X1, X2, res.image)
        return res
    t = time.perf_counter()
    if clustering is None:
        clustering = cluster_reduced_columns(R, _v.integer("columns", columns, 1, n), seed=seed,
                                             power=_light_luminance_power(A.lights), **cluster_options)
    reps, weights = _clustering(clustering, n)
    timings["clustering"] = time.perf_counter() - t

    image = _reconstruct(A, reps, weights, timings, add_emitted, progress)
    res = RenderResult(image=image, method="mrcs", seed=seed, timings=timings, rows=row_indices,
                       clusters=clustering.get("assignment"), representatives=reps, weights=weights,
                       budget={"rows": 0 if row_indices is None else int(len(row_indices)),
                               "columns": int(len(reps)), "lights": int(n)}, device=A.device)
    if error_rows and R is not None:
        adaptive.attach_error_estimate(A, res, clustering, error_rows, progress=progress)
    return res


def _matrix_shape(A) -> tuple[int, int]:
    from . import LightMatrix

    if not isinstance(A, LightMatrix):
        raise TypeError(f"A must be a manylights LightMatrix, got {type(A).__name__}")
    return A.shape


def _clustering(clustering, n: int) -> tuple[np.ndarray, np.ndarray]:
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


def power_sampling(A, columns: int = 900, seed: int = 0, *, add_emitted: bool = True,
                   progress: bool = False) -> RenderResult:
    """Baseline: draw ``columns`` lights with probability proportional to their power (with replacement)
    and weight each by 1 / (columns * p_j): an unbiased estimate of the column sum that ignores visibility
    and geometry (no rows). Lights of zero power are never drawn (they emit nothing).

    Raises:
        TypeError: A is not a LightMatrix. ValueError: columns not an integer in [1, 2^31), a negative
            seed, lights without finite power."""
    m, n = _matrix_shape(A)
    columns = _v.integer("columns", columns, 1, 2**31 - 1)
    seed = _v.seed(seed)
    if n == 0:
        raise ValueError(f"power_sampling needs lights (n = {n})")
    t = time.perf_counter()
    p = _light_luminance_power(A.lights)
    if not np.isfinite(p).all() or p.sum() <= 0:
        raise ValueError("power_sampling: the lights carry no (finite) power")
    p = p / p.sum()
    rng = np.random.default_rng(seed)
    reps = rng.choice(n, size=int(columns), p=p)
    w = (1.0 / (columns * p[reps])).astype(np.float32)
    weights = np.repeat(w[:, None], 3, axis=1)
    timings = {"sampling": time.perf_counter() - t}
    image = _reconstruct(A, reps, weights, timings, add_emitted, progress)
    return RenderResult(image=image, method="power_sampling", seed=seed, timings=timings, representatives=reps,
                        weights=weights, budget={"columns": int(columns), "lights": int(n)}, device=A.device)


def instant_radiosity(scene, lights: int = 2500, seed: int = 0, *, area_fraction: float = 0.5,
                      environment_fraction: float = 0.0, max_depth: int = 5, clamp=None,
                      progress: bool = False, **matrix_options) -> RenderResult:
    """Baseline: generate only ``lights`` lights (area / environment / indirect shares as given) and render
    all of them (Keller's instant radiosity with the same light generation as the large matrix).

    Raises:
        TypeError: scene is not a Scene. ValueError: lights not an integer >= 1, fractions outside [0, 1]
            or summing past 1, and whatever ``generate_lights`` / ``LightMatrix`` refuse."""
    from . import LightMatrix, generate_lights

    from . import Scene

    if not isinstance(scene, Scene):
        raise TypeError(f"scene must be a manylights Scene, got {type(scene).__name__}")
    lights = _v.integer("lights", lights, 1, 2**63 - 1)
    area_fraction = _v.real("area_fraction", area_fraction, 0.0, 1.0)
    environment_fraction = _v.real("environment_fraction", environment_fraction, 0.0, 1.0)
    if area_fraction + environment_fraction > 1.0:
        raise ValueError(f"area_fraction + environment_fraction must be <= 1, got {area_fraction} + "
                         f"{environment_fraction}")
    t = time.perf_counter()
    has_env = any(e["type"] in ("envmap", "constant") for e in scene.emitters)
    has_area = any(e["type"] == "area" for e in scene.emitters)
    n_env = int(round(lights * environment_fraction)) if has_env else 0
    n_area = int(round(lights * area_fraction)) if has_area else 0
    n_ind = max(lights - n_env - n_area, 0)
    L = generate_lights(scene, area=n_area, environment=n_env, indirect=n_ind, max_depth=max_depth, clamp=clamp,
                        seed=seed)
    timings = {"lights": time.perf_counter() - t}
    t = time.perf_counter()
    A = LightMatrix(scene, L, **matrix_options)
    image = A.column_sum(progress=progress)
    timings["columns"] = time.perf_counter() - t
    t = time.perf_counter()
    image = image + A.emitted()
    timings["emitted"] = time.perf_counter() - t
    return RenderResult(image=image, method="instant_radiosity", seed=seed, timings=timings,
                        budget={"lights": int(len(L)), "area": n_area, "environment": n_env, "indirect": n_ind},
                        device=A.device)
