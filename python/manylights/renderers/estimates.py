"""An error estimate for MRCS without the reference (progressive MRCS: ``progressive``; budgets: ``budget``;
the light counts of a scene: ``light_budget``).

Error estimate (``RenderResult.error_estimate``, ``RenderResult.error_image``)
------------------------------------------------------------------------------
Matrix row-column sampling (Hašan et al. 2007, Sec. 3.3) estimates the column sum ``ΣA`` by
``X = sum_k A[:, J_k] / p_{J_k}``, one representative ``J_k`` per cluster ``C_k`` drawn independently with
probability ``p_j`` (``|rho_j| / s_k``; power or uniform for zero-norm clusters; ``probability`` in the
clustering dict). For a FIXED clustering X is unbiased and its variance at pixel i, per channel, is

    Var[X_i] = sum_k ( sum_{j in C_k} A_ij^2 / p_j  -  (sum_{j in C_k} A_ij)^2 )          (1)

(expand ``E[X_i^2]`` over the independent draws: the per-row form of the paper's Appendix A). (1) is
exact at every pixel whose whole row of A is known (``row_variance``, Rust: src/cluster/variance.rs).
Summed over a stratified set of rows and divided by the squared exact pixel values there,

    sqrt( sum_{rows} sum_ch Var[X_ich] / sum_{rows} sum_ch T_ich^2 )                        (2)

estimates the expected relative L2. Evaluated at the clustering's OWN rows (free) it reads low -- the
clustering minimises the reduced form of (1) on exactly those rows -- by 0.4x (median, measured on
cbox-lights 32x32, 8 seeds x 4 budgets), so MRCS does not report it. Two estimators ship instead:

(3) ``mrcs(..., halves=True)``, the default of ``mrcs_progressive`` and ``render``: ``c // 2`` clusters,
    TWO representatives drawn independently in each (``draw_representatives``), rendered as two half
    images ``X1``, ``X2``, each an unbiased estimate of ΣA; the image is their mean. Then
    ``E||X1 - X2||^2 = 2 E||X1 - ΣA||^2 = 4 E||(X1 + X2)/2 - ΣA||^2``, so

        error_estimate = ||X1 - X2|| / 2 / ||image||,    error_image = RMS_ch |X1 - X2| / 2,

    per pixel at full resolution (one degree of freedom per pixel: noisy; a map of where the error is).
    A light that both draws of its cluster pick (always in a cluster of one light) adds the same
    weighted column to both halves and is rendered once (``shared_halves``): the c representatives
    cost ``c/2 + (clusters whose draws differ)`` columns (``budget['rendered_columns']``; veach-ajar
    64x36, 16k lights, 128 rows: 2,675 of 4,096, column time 0.57 s against 1.0 s).
    Cost: no extra column and no extra row; the price is a clustering of c/2 clusters instead of c
    (measured, mean true relative L2 over 8 seeds at 32x32, 2k lights, 32 rows x 128 columns, plain /
    halves: cbox-lights 0.062 / 0.059, matpreview 0.031 / 0.068, veach-ajar 0.016 / 0.067: where c
    clusters pay off, halves costs up to 2-4x in error).
(4) ``mrcs(..., error_rows=h)``: the plain MRCS image, plus h extra stratified rows (seeded apart from
    the clustering's) that the clustering never saw; the estimate is the REALISED relative error at
    those pixels, ``sqrt(sum ||X_i - T_i||^2 / sum ||T_i||^2)`` (exact T_i from the full rows), and
    ``error_image`` spreads (1) at those rows to their nearest pixels. Cost: h rows, no column.

Calibration (``python -m manylights.bench calibrate``, 32 px wide, budgets rows:columns 16:32, 32:64,
32:128, 64:256, 8 seeds, 6 scenes, CPU backend): estimate within a factor 2 of the true relative L2
against brute force, for (3) / (4) with h = rows:

- at 16,384 lights: 97.9% / 77.6% of 192 runs ((3): veach-ajar 91%, cbox-lights 97%, bounce, demo,
  matpreview, bunny 100%);
- at 2,048 lights: 88.0% / 74.0% ((3): cbox-lights 97%, bounce 97%, demo 97%, matpreview 94%, bunny 97%,
  veach-ajar 47%; 96.2% without veach-ajar), short of the 90% target because of veach-ajar, where the
  light count is so low that one VPL carries half of the image. Two causes there, measured on its whole
  576 x 2041 matrix (32x18 px):

(i) zero-norm lights: at 64 rows 93% of its lights have a zero reduced column. They shared ONE
    power-drawn cluster: nearly every draw landed on a light adding nothing, both halves agreed and the
    image missed that light (3.8% of the image). They now get ``ceil(c z / 8n)`` strata
    (``zero_cluster_count``, src/cluster/mod.rs). A/B on the same non-zero clusters, 64 seeds: at 64:256
    within 2x 36% -> 73%, median true error 0.038 -> 0.008; no change at the smaller budgets (16:32 38 /
    36%, 32:64 55 / 48%, 32:128 55 / 58%: seed noise).
(ii) VPL splotches: one VPL near the floor puts 52% of the image's L2 norm on 3 pixels (another 22% on
    3 others). Rows that miss those pixels give it a small reduced norm, it shares a cluster of 3-8
    lights at weight ~1-2, both halves usually skip it: the image misses it (true error ~0.52) and the
    halves agree (estimate 0.1-0.3). No estimate from the run can see a light it never drew; this is
    the row sampling's blind spot and dominates the failures at 16-32 rows (rms true error 2.3 at
    16:32). Rows placed by an unshadowed bound on each light's contribution did not remove it
    (docs/guide/render-to-target.md, "Calibration").
Results of (3) carry ``budget['unseen_lights']``, the number of lights no sampled row sees: when it is a
large share of n, treat the estimate as a lower bound.

Symbols
-------
| here | meaning |
|---|---|
| ``A``, ``m``, ``n`` | the light matrix, its rows (pixels) and columns (lights) |
| ``C_k``, ``J_k``, ``p_j`` | cluster k, its representative, light j's selection probability (``probability``) |
| ``X``, ``X1``, ``X2`` | the MRCS estimate and the two half estimates of (3) |
| ``T_i`` | exact pixel value at row i (row sum + emitted) |
"""
from __future__ import annotations

import time
from typing import Optional

import numpy as np

from .. import _native
from .._utils import validate as _v
from .._utils.seeds import derived_seed
from ..matrix.rows import stratified_rows
from .clustering import cluster_reduced_columns
from .result import RenderResult


def row_variance(R, clustering: dict) -> np.ndarray:
    """Exact variance of the MRCS estimate at complete rows of A, equation (1) of the module doc.

    Args:
        R: (h, n, 3) rows of the light matrix (``LightMatrix.rows``), any real dtype (float32 used).
        clustering: a dict from ``cluster_reduced_columns`` (needs ``assignment`` (n,) and
            ``probability`` (n,)).

    Returns:
        (h, 3) float64 variance per row and channel, radiance^2.

    Raises:
        ValueError: shapes that do not match, a clustering without ``assignment`` / ``probability``,
            NaN/inf in R, probabilities outside [0, 1].
    """
    R = np.ascontiguousarray(_v.numeric_array("R", R), dtype=np.float32)
    if not hasattr(clustering, "__getitem__") or any(k not in clustering for k in ("assignment", "probability")):
        raise ValueError("clustering must be a dict from cluster_reduced_columns with 'assignment' and 'probability'")
    assignment = np.ascontiguousarray(clustering["assignment"], dtype=np.int32).reshape(-1)
    probability = np.ascontiguousarray(clustering["probability"], dtype=np.float64).reshape(-1)
    c = int(assignment.max()) + 1 if assignment.size else 0
    return _native.mrcs_row_variance(R, assignment, probability, c)


def _totals(R: np.ndarray, rows: np.ndarray, emitted: np.ndarray) -> np.ndarray:
    """(h, 3) float64 exact pixel values at the rows: row sums of A plus what the camera sees directly."""
    return R.sum(axis=1, dtype=np.float64) + emitted.reshape(-1, 3)[rows].astype(np.float64)


def relative_error_from_rows(variance: np.ndarray, totals: np.ndarray) -> float:
    """Equation (2): sqrt(sum variance / sum totals^2) over rows and channels; inf for an all-zero image."""
    den = float(np.sum(np.square(totals)))
    num = float(np.sum(variance))
    if den <= 0.0:
        return 0.0 if num == 0.0 else float("inf")
    return float(np.sqrt(num / den))


def error_image(shape: tuple[int, int], rows: np.ndarray, variance: np.ndarray) -> np.ndarray:
    """(H, W) float32 map of the estimated per-pixel RMS error over channels: ``sqrt(mean_ch variance)`` at
    each sampled pixel (``rows``: (h,) indices ``y * W + x``), every other pixel takes its nearest
    sampled pixel's value (ties: the first row)."""
    h, w = shape
    rms = np.sqrt(np.maximum(np.asarray(variance, np.float64), 0.0).mean(axis=1))
    rows = np.asarray(rows, np.int64)
    ry, rx = (rows // w).astype(np.float64), (rows % w).astype(np.float64)
    out = np.empty(h * w, np.float32)
    ys, xs = np.divmod(np.arange(h * w, dtype=np.int64), w)
    step = max(1, 2_000_000 // max(len(rows), 1))
    for a in range(0, h * w, step):
        d = (ys[a:a + step, None] - ry[None, :]) ** 2 + (xs[a:a + step, None] - rx[None, :]) ** 2
        out[a:a + step] = rms[np.argmin(d, axis=1)]
    return out.reshape(h, w)


def draw_representatives(clustering: dict, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """One more representative per cluster, drawn independently of the clustering's own with the same
    probabilities (``clustering['probability']``), and its unbiased grey weights ``1/p``.

    Returns:
        (representatives (c,) int64, weights (c, 3) float32). Vectorised numpy, O(n)."""
    a = np.asarray(clustering["assignment"], np.int64)
    p = np.asarray(clustering["probability"], np.float64)
    c = int(a.max()) + 1
    order = np.argsort(a, kind="stable")
    counts = np.bincount(a, minlength=c)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    cum = np.cumsum(p[order])
    base = np.concatenate([[0.0], cum])[starts]
    last = starts + counts - 1
    u = np.random.default_rng(seed).random(c)
    idx = np.searchsorted(cum, base + u * (cum[last] - base), side="right")
    idx = np.clip(idx, starts, last)
    # Round-off may land on a light of probability 0: step back to the cluster's last drawable light.
    reps = order[idx]
    bad = p[reps] <= 0
    for k in np.flatnonzero(bad):
        members = order[starts[k]:last[k] + 1]
        reps[k] = members[np.flatnonzero(p[members] > 0)[-1]]
    w = (1.0 / p[reps]).astype(np.float32)
    return reps.astype(np.int64), np.repeat(w[:, None], 3, axis=1)


def halves_estimate(X1: np.ndarray, X2: np.ndarray, image: np.ndarray) -> tuple[float, np.ndarray]:
    """Equation (3) of the module doc: (relative L2 estimate, (H, W) float32 per-pixel RMS error) of the
    mean of two independent unbiased estimates ``X1``, ``X2`` (H, W, 3) of the same image ``image``."""
    d = 0.5 * (np.asarray(X1, np.float64) - np.asarray(X2, np.float64))
    den = float(np.linalg.norm(np.asarray(image, np.float64)))
    num = float(np.linalg.norm(d))
    est = (0.0 if num == 0.0 else float("inf")) if den == 0.0 else num / den
    return est, np.sqrt(np.mean(d * d, axis=2)).astype(np.float32)


def mrcs_halves(A, R: np.ndarray, columns: int, seed: int, power: np.ndarray, timings: dict,
                progress: Optional[bool] = None, seen: Optional[np.ndarray] = None, **cluster_options) -> tuple[dict, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The paired-representative MRCS of ``mrcs(..., halves=True)``: ``columns // 2`` clusters of the
    reduced matrix ``R``, two independent representatives each. Returns (clustering, representatives
    (2k,), weights (2k, 3) (each half's weights / 2: the image is the mean), X1, X2 (H, W, 3) float32:
    the two half images, no emitted). ``clustering['unseen_lights']``: lights whose reduced column is 0
    (``seen``: (n,) bool, the lights with a non-zero element in R when the caller keeps it, else computed)."""
    k = columns // 2
    if k < 1:
        raise ValueError(f"columns must be at least 2 for the paired (halves) error estimate, got {columns}")
    t = time.perf_counter()
    cl = cluster_reduced_columns(R, k, seed=seed, power=power, **cluster_options)
    reps2, w2 = draw_representatives(cl, derived_seed(seed, 1 << 21))
    # Lights no sampled row sees: the estimate's blind spot (module doc, the veach-ajar case).
    if seen is None:
        seen = lights_seen(R)
    cl["unseen_lights"] = int(np.count_nonzero(~seen))
    timings["clustering"] = timings.get("clustering", 0.0) + time.perf_counter() - t
    t = time.perf_counter()
    reps1 = np.asarray(cl["representatives"], np.int64)
    w1 = np.asarray(cl["weights"], np.float32)
    X1, X2, rendered = shared_halves(A, reps1, w1, reps2, w2, progress)
    cl["rendered_columns"] = rendered
    timings["columns"] = timings.get("columns", 0.0) + time.perf_counter() - t
    reps = np.concatenate([reps1, reps2])
    weights = (0.5 * np.concatenate([w1, w2])).astype(np.float32)
    return cl, reps, weights, X1, X2


def lights_seen(R) -> np.ndarray:
    """(n,) bool: the lights with a non-zero element in the rows ``R`` ((r, n, 3) or (r, n)). Reduced over
    the rows first (contiguous), then the channels: ``np.any(R != 0, axis=(0, 2))`` took 2.5 ms a row at
    100k lights, a quarter of rendering the row."""
    nz = np.asarray(R) != 0
    seen = nz.any(axis=0)
    return seen.any(axis=1) if seen.ndim == 2 else seen


def shared_halves(A, reps1: np.ndarray, w1: np.ndarray, reps2: np.ndarray, w2: np.ndarray,
                  progress: Optional[bool] = None) -> tuple[np.ndarray, np.ndarray, int]:
    """The half images ``X_h = sum_k w_h[k] A[:, reps_h[k]]`` (h = 1, 2) of (3), rendering a column
    drawn by BOTH halves of its cluster once: where ``reps1[k] == reps2[k]`` the light is the same, so is
    its weight ``1 / p_j``, and its weighted column ``S`` is common to both halves,
    ``X_h = S + D_h``. A cluster of one light (p = 1) always draws it twice, and so does a cluster whose
    probability sits on one light: on veach-ajar (64x36, 16k lights) 752 of 1,024 clusters at 128 rows
    are single lights and ``sum_k sum_{j in C_k} p_j^2`` (the expected number of shared draws) is 834 of
    1,024, so the 2,048 representatives need about 1,214 columns. The images are those of rendering
    every representative (up to float summation order): unbiased, independent halves, (3) unchanged.

    Args:
        reps1, reps2: (k,) int64 the two representatives of each of the k clusters (aligned by cluster).
        w1, w2: (k, 3) float32 their weights (``w1`` is used for a shared column: the same 1/p).

    Returns:
        (X1, X2) (H, W, 3) float32 without emitted light, and the number of columns rendered
        (k + the clusters whose draws differ)."""
    same = reps1 == reps2

    def part(reps, w, sel):
        return A.weighted_sum(reps[sel], w[sel], progress=progress) if np.any(sel) else None

    S, D1, D2 = part(reps1, w1, same), part(reps1, w1, ~same), part(reps2, w2, ~same)
    rendered = int(len(reps1) + np.count_nonzero(~same))
    if S is None:
        return D1, D2, rendered
    if D1 is None:
        return S, S.copy(), rendered
    return S + D1, S + D2, rendered


def attach_error_estimate(A, res: RenderResult, clustering: dict, error_rows: int,
                          progress: Optional[bool] = None) -> RenderResult:
    """Fill ``res.error_estimate`` / ``res.error_image`` of a plain MRCS run from ``error_rows`` extra
    stratified rows the clustering never saw (module doc, estimator (4)); ``res.budget['error_rows']``
    and ``timings['error_estimate']`` say what it cost."""
    t = time.perf_counter()
    emitted = A.emitted()
    extra = stratified_rows(A.scene, error_rows, seed=derived_seed(res.seed, 1 << 20))
    Rh = A.rows(extra, progress=progress)
    tot = _totals(Rh, extra, emitted)
    x = res.image.reshape(-1, 3)[extra].astype(np.float64)
    den = float(np.sum(tot * tot))
    num = float(np.sum((x - tot) ** 2))
    res.error_estimate = (0.0 if num == 0.0 else float("inf")) if den == 0.0 else float(np.sqrt(num / den))
    h, w = emitted.shape[:2]
    res.error_image = error_image((h, w), extra, row_variance(Rh, clustering))
    res.budget["error_rows"] = int(error_rows)
    res.timings["error_estimate"] = time.perf_counter() - t
    return res

