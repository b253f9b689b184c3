"""An error estimate for MRCS without the reference and progressive MRCS (issue 14, items 1-2; item 3, the
budgets, in ``manylights.auto_budget``; item 4, the light counts of a scene, in ``manylights.light_budget``).

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
  veach-ajar 47%; 96.2% without veach-ajar), short of the issue's 90% because of veach-ajar, where the
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
    16:32). An unshadowed bound ``|I_j| min(clamp, cos cos / d^2)`` over the view samples ranks that
    VPL 20th of 2041 and points at the pixel next to its peak, but rows at the bound's top pixels did
    not help (a quarter / half of the rows: within 2x 34% / 47% against 53% with stratified rows only,
    8 seeds x 4 budgets): not kept.
Results of (3) carry ``budget['unseen_lights']``, the number of lights no sampled row sees: when it is a
large share of n, treat the estimate as a lower bound.

Progressive MRCS (``mrcs_progressive``)
---------------------------------------
Round t renders ``Δr_t`` new stratified rows (seed of round t), clusters ALL rows rendered so far into
``Δc_t / 2`` new clusters (refined rows, more clusters) with two representatives each as in (3): two
independent unbiased half estimates ``X_t1``, ``X_t2`` of ΣA given the rows. Round T returns

    H_h = sum_{t<=T} a_t X_th  (h = 1, 2),   image = (H_1 + H_2) / 2,
    a_t = (1 / v_t) / sum_{t'<=T} (1 / v_t'),   v_t = mean over rows of (1) for round t

where the rows are those round t's clustering did not see -- the new rows of the later rounds, at most
``WEIGHT_ROWS`` = 48 of each round's batch (drawn with that round's seed) -- once there are any, and
before that (or while their variance is 0) at most 48 of its own rows. Each (round, batch) pair is
evaluated once. Rows of different rounds are stratified with different seeds, so a held-out row is
almost always a pixel the clustering did not see (it repeats one with probability ~R/m). (1) at a
clustering's own rows is low where those rows missed a VPL splotch: with all weights at 48 own rows, on
veach-ajar (5%, seed 1) a round estimated at 70% kept enough weight to hold the combination at 12% after
a round of 2,048 columns, and the schedule added one of 8,192; weighted at all rows, the same schedule
stopped there at 2.3%. With the held-out rows, 8 seeds of a fixed ratio (``rows_per_column=0.12``)
reached 5% in 11.0 s on the mean against 17.6 s, all 8 in both. Evaluating every round at every row
cost 24 s of a 141 s render at 100k lights; this costs at most ``48 (t + 1)`` row evaluations in round
t (1.1 ms each at 100k lights).

The weights depend only on rows and clusterings -- never on the representative draws -- so H_1 and H_2
stay independent and unbiased, the image is unbiased and (3) applies to it unchanged. Nothing rendered
is thrown away: every round's columns stay in the image (``representatives``/``weights`` of the result
reproduce it). With doubling increments (``Δc_t = c_0 2^t``) the error falls at least like
1/sqrt(columns) (inverse-variance weighting of independent estimates); it can stay above a single MRCS
run of the same total where clustering converges faster than that (each round starts a new clustering).

Seeding: round 0 uses ``seed`` itself, so round 0 IS ``mrcs(A, rows=r_0, columns=c_0, seed=seed,
halves=True)``; round t >= 1 uses a seed derived from (seed, t) only. A run stopped after round k
therefore returns exactly the image of a fresh run whose schedule ends at round k (``rounds=k+1``, or
the lists truncated), bit for bit on the same backend (tests/test_error_estimate.py).

Budgets (``render``)
--------------------
``render(A, target_error=, time_budget=)`` (``manylights.auto_budget``, its module doc: the
row:column ratio (8), increments predicted from the estimate) drives these rounds through the
same generator, choosing each round's rows and columns from what the earlier rounds rendered.
``render("scene.xml", ...)`` (item 4) also chooses the light counts before that:
``manylights.light_budget`` (its module doc: the error split (5), the halving estimate (6)).

Symbols
-------
| here | meaning |
|---|---|
| ``A``, ``m``, ``n`` | the light matrix, its rows (pixels) and columns (lights) |
| ``C_k``, ``J_k``, ``p_j`` | cluster k, its representative, light j's selection probability (``probability``) |
| ``X``, ``X1``, ``X2`` | the MRCS estimate and the two half estimates of (3) |
| ``T_i`` | exact pixel value at row i (row sum + emitted) |
| ``Δr_t``, ``Δc_t``, ``a_t``, ``v_t`` | round t's new rows, new columns, combination weight, variance (1) summed |
"""
from __future__ import annotations

import time
from typing import Iterator, Optional

import numpy as np

from . import _native
from . import _validate as _v
from .mrcs import RenderResult, _light_luminance_power, _matrix_shape


# --------------------------------------------------------------------------------------------------
# error estimate
# --------------------------------------------------------------------------------------------------
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
                progress: bool = False, seen: Optional[np.ndarray] = None, **cluster_options) -> tuple[dict, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The paired-representative MRCS of ``mrcs(..., halves=True)``: ``columns // 2`` clusters of the
    reduced matrix ``R``, two independent representatives each. Returns (clustering, representatives
    (2k,), weights (2k, 3) (each half's weights / 2: the image is the mean), X1, X2 (H, W, 3) float32:
    the two half images, no emitted). ``clustering['unseen_lights']``: lights whose reduced column is 0
    (``seen``: (n,) bool, the lights with a non-zero element in R when the caller keeps it, else computed)."""
    from . import cluster_reduced_columns

    k = columns // 2
    if k < 1:
        raise ValueError(f"columns must be at least 2 for the paired (halves) error estimate, got {columns}")
    t = time.perf_counter()
    cl = cluster_reduced_columns(R, k, seed=seed, power=power, **cluster_options)
    reps2, w2 = draw_representatives(cl, _derived_seed(seed, 1 << 21))
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
                  progress: bool = False) -> tuple[np.ndarray, np.ndarray, int]:
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
                          progress: bool = False) -> RenderResult:
    """Fill ``res.error_estimate`` / ``res.error_image`` of a plain MRCS run from ``error_rows`` extra
    stratified rows the clustering never saw (module doc, estimator (4)); ``res.budget['error_rows']``
    and ``timings['error_estimate']`` say what it cost."""
    from . import stratified_rows

    t = time.perf_counter()
    emitted = A.emitted()
    extra = stratified_rows(A.scene, error_rows, seed=_derived_seed(res.seed, 1 << 20))
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


def _derived_seed(seed: int, stream: int) -> int:
    """A seed in [0, 2^63) from (seed, stream), independent across streams (numpy SeedSequence)."""
    state = np.random.SeedSequence([int(seed), int(stream)]).generate_state(2, np.uint32)
    return int((int(state[0]) << 31) ^ int(state[1])) & ((1 << 63) - 1)


# --------------------------------------------------------------------------------------------------
# progressive MRCS
# --------------------------------------------------------------------------------------------------
def _schedule(name: str, value, rounds: Optional[int], limit: int, what: str, strict: bool = True) -> list[int]:
    """Per-round increments from an int (first round, doubling) or a list of cumulative totals (strictly
    increasing, or non-decreasing with ``strict=False``)."""
    if isinstance(value, (list, tuple, np.ndarray)):
        totals = [_v.integer(f"{name}[{k}]", v, 1, limit) for k, v in enumerate(value)]
        if not totals:
            raise ValueError(f"{name} must list at least one cumulative total, got []")
        if any(b < a or (strict and b == a) for a, b in zip(totals, totals[1:])):
            order = "strictly increasing" if strict else "non-decreasing"
            raise ValueError(f"{name} must be {order} cumulative totals per round, got {list(totals)}")
        if rounds is not None and rounds != len(totals):
            raise ValueError(f"rounds = {rounds} does not match the {len(totals)} totals given in {name}")
        return [b - a for a, b in zip([0] + totals[:-1], totals)]
    first = _v.integer(name, value, 1, limit)
    if rounds is None:
        raise ValueError(f"give rounds= when {name} is an int (the first round's {name}; later rounds double it)")
    steps = [first * 2 ** t for t in range(rounds)]
    if sum(steps) > limit:
        raise ValueError(f"{rounds} rounds doubling {name} from {first} need {sum(steps)} {name}, more than "
                         f"the {limit} {what}")
    return steps


def mrcs_progressive(A, rows=64, columns=128, rounds: Optional[int] = None, seed: int = 0, *,
                     add_emitted: bool = True, progress: bool = True,
                     **cluster_options) -> Iterator[RenderResult]:
    """Progressive matrix row-column sampling: an iterator of ``RenderResult``, one per round, each an
    unbiased image of all columns rendered so far with its error estimate (module doc).

    Args:
        A: a ``LightMatrix`` (either backend).
        rows: the first round's new rows (int; round t adds ``rows * 2**t``) or the cumulative row totals
            per round (non-decreasing list, one per round, the first >= 1: a round may add no rows, as
            ``render`` does once every pixel is a row).
        columns: the first round's clusters = representative columns (int; round t adds
            ``columns * 2**t``) or the cumulative column totals per round (list).
        rounds: number of rounds (needed when both are ints; must match the lists' length otherwise).
        seed: round 0 uses it as is (round 0 equals ``mrcs(A, rows, columns, seed)``), round t a seed
            derived from (seed, t).
        add_emitted: add ``A.emitted()`` to every image.
        progress: a progress bar over rounds showing the columns and the current error estimate
            (``manylights.progress``: a bar on a terminal or notebook, a few log lines elsewhere).
        **cluster_options: passed to ``cluster_reduced_columns`` (projection_dim, sampling_fraction).

    Yields:
        RenderResult per round: image (H, W, 3) float32, method "mrcs_progressive", budget (rows,
        columns, lights, round, rounds), error_estimate (float, relative L2), error_image (H, W) float32,
        representatives / weights of ALL rounds (weights scaled by the round's combination weight:
        ``A.weighted_sum(representatives, weights)`` reproduces the image), clusters (the last round's
        assignment), budget['unseen_lights'] (lights no row so far sees), budget['rendered_columns']
        (columns rendered over all rounds: a light drawn by both halves of a cluster counts once),
        timings summed over rounds so far. Stopping the loop (break, Ctrl-C between rounds) keeps every
        result already yielded.

    Raises:
        TypeError: A is not a LightMatrix. ValueError: an empty light matrix, rows / columns / rounds
            not positive integers or lists that do not increase, more columns than lights or rows than
            pixels in total, a negative seed, bad cluster options.
    """
    m, n = _matrix_shape(A)
    if n == 0:
        raise ValueError("the light matrix has no lights (n = 0): nothing to sample")
    seed = _v.seed(seed)
    if rounds is not None:
        rounds = _v.integer("rounds", rounds, 1, 64)
    dc = _schedule("columns", columns, rounds, n, "lights")
    dr = _schedule("rows", rows, len(dc) if rounds is None else rounds, m, "pixels (view samples)", strict=False)
    if len(dr) != len(dc):
        raise ValueError(f"rows give {len(dr)} rounds and columns {len(dc)}: give the same number")
    if sum(dc) > n:
        raise ValueError(f"columns: {sum(dc)} in total is more than the n = {n} lights; render brute force instead")
    if min(dc) < 2:
        raise ValueError(f"every round needs at least 2 new columns (two representatives per cluster), got {dc}")
    plan = iter(list(zip(dr, dc)))
    return _progressive(A, lambda state: next(plan, None), len(dc), seed, add_emitted, progress, cluster_options)


#: The combination weights evaluate (1) at this many rows of each round's batch of new rows (held out for the
#: earlier rounds) and at this many of all rows so far (the new round's own); at all of them when fewer.
WEIGHT_ROWS = 48


def _progressive(A, plan, planned_rounds: int, seed: int, add_emitted: bool, progress: bool, cluster_options: dict,
                 state: Optional[dict] = None) -> Iterator[RenderResult]:
    """The rounds of ``mrcs_progressive``. ``plan(state)`` gives round t's (new rows, new columns), or None to
    stop, before each round; ``state`` (filled here, read by ``plan``: ``R`` (rows so far, n, 3), ``rows``,
    ``rounds`` (per round: clustering, rows/columns, ``v`` the mean (1) per row behind its combination
    weight, from ``held_out_variance`` / ``held_out_rows`` (later rounds' new rows) or, before any,
    ``own_variance`` (its own rows), the round's own timings
    ``seconds``), ``round`` (the next round's index)) lets ``render`` choose increments from what was
    rendered. Round t's seed depends only on (seed, t), so a schedule replayed as lists gives the same bits."""
    from . import stratified_rows
    from .progress import progress_bar

    power = _light_luminance_power(A.lights)
    emitted = A.emitted()
    state = {} if state is None else state
    state.update({"R": None, "rows": np.zeros(0, np.int64), "rounds": [], "round": 0, "seen": False,
                  "R_buffer": None})
    rounds = state["rounds"]  # per round: clustering, half images X1, X2, v (round_variance) and its parts
    timings: dict = {}
    bar = progress_bar(planned_rounds, "mrcs_progressive", progress, unit="round")
    with bar as cb:
        t = 0
        while True:
            step = plan(state)
            if step is None:
                break
            r_t, c_t = int(step[0]), int(step[1])
            s_t = seed if t == 0 else _derived_seed(seed, t)
            before = dict(timings)
            t0 = time.perf_counter()
            if r_t > 0:
                new_rows = stratified_rows(A.scene, r_t, seed=s_t)
                R_t = A.rows(new_rows, progress=False)
            else:  # a round that only adds columns (render, when every pixel is a row already)
                new_rows, R_t = np.zeros(0, np.int64), np.zeros((0,) + state["R"].shape[1:], np.float32)
            timings["rows"] = timings.get("rows", 0.0) + time.perf_counter() - t0
            R_all = _grow_rows(state, R_t)
            row_all = np.concatenate([state["rows"], new_rows])
            state["rows"] = row_all
            state["seen"] = lights_seen(R_t) | state["seen"]
            cl, reps, weights, X1, X2 = mrcs_halves(A, R_all, c_t, s_t, power, timings, seen=state["seen"],
                                                    **cluster_options)
            t0 = time.perf_counter()
            rounds.append({"clustering": cl, "reps": reps, "weights": weights, "X1": X1, "X2": X2,
                           "new_rows": r_t, "new_columns": c_t, "total_rows": int(len(row_all))})
            # Combination weights from the rows only (never from the draws): v_t is the mean (1) per row
            # at rows round t's clustering did not see (WEIGHT_ROWS of each later batch) once there are any
            # (and their variance is > 0), before that at WEIGHT_ROWS of all rows so far (its own rows;
            # module doc: own rows miss the splotches).
            n_prev = len(row_all) - len(new_rows)
            if len(new_rows) and len(rounds) > 1:
                held = _weight_rows(len(new_rows), _derived_seed(s_t, 1 << 25)) + n_prev
                R_h = np.ascontiguousarray(R_all[held])
                for rd in rounds[:-1]:
                    rd["held_out_variance"] += float(row_variance(R_h, rd["clustering"]).sum())
                    rd["held_out_rows"] += len(held)
            own = _weight_rows(len(row_all), _derived_seed(s_t, (1 << 25) + 1))
            rounds[-1].update(own_variance=row_variance(np.ascontiguousarray(R_all[own]), rounds[-1]["clustering"]),
                              held_out_variance=0.0, held_out_rows=0)
            for rd in rounds:
                rd["v"] = round_variance(rd)
            v = np.array([rd["v"] for rd in rounds])
            a = (v <= 0).astype(np.float64) if np.any(v <= 0) else 1.0 / v  # exact rounds win outright
            a /= a.sum()
            H1 = sum(a_t * rd["X1"].astype(np.float64) for a_t, rd in zip(a, rounds))
            H2 = sum(a_t * rd["X2"].astype(np.float64) for a_t, rd in zip(a, rounds))
            image = 0.5 * (H1 + H2) + (emitted if add_emitted else 0.0)
            timings["combination"] = timings.get("combination", 0.0) + time.perf_counter() - t0
            rounds[-1]["seconds"] = {k: timings[k] - before.get(k, 0.0) for k in timings}
            rounds[-1]["combination_weights"] = a
            planned_rounds = max(planned_rounds, t + 1)
            res = RenderResult(
                image=image.astype(np.float32), method="mrcs_progressive", seed=seed, timings=dict(timings),
                rows=row_all.copy(), clusters=cl["assignment"],
                representatives=np.concatenate([rd["reps"] for rd in rounds]),
                weights=np.concatenate([a_t * rd["weights"] for a_t, rd in zip(a, rounds)]).astype(np.float32),
                budget={"rows": int(len(row_all)), "columns": int(sum(len(rd["reps"]) for rd in rounds)),
                        "rendered_columns": int(sum(rd["clustering"]["rendered_columns"] for rd in rounds)),
                        "lights": int(A.shape[1]), "round": t, "rounds": planned_rounds,
                        "unseen_lights": cl["unseen_lights"]}, device=A.device)
            res.error_estimate, res.error_image = halves_estimate(H1, H2, image)
            t += 1
            state["round"] = t
            if cb is not None:
                cb(t, planned_rounds)
                _show_estimate(bar, res)
            yield res


def round_variance(rd: dict) -> float:
    """v_t of the combination weights (module doc): the mean variance (1) per row (channels summed) at the
    held-out rows ``rd['held_out_variance'] / rd['held_out_rows']`` when that is > 0, else at the round's
    own rows (``rd['own_variance']``, (rows, 3)). A held-out variance of 0 (e.g. a few background rows)
    does not make a round exact; only 0 at both does (then it wins the combination outright)."""
    if rd["held_out_rows"] > 0 and rd["held_out_variance"] > 0.0:
        return rd["held_out_variance"] / rd["held_out_rows"]
    own = rd["own_variance"]
    return float(own.sum()) / max(len(own), 1)


def _weight_rows(count: int, seed: int) -> np.ndarray:
    """Sorted indices of the rows (1) is evaluated at for the combination weights: all ``count`` rows, or
    ``WEIGHT_ROWS`` of them drawn without replacement (seeded)."""
    if count <= WEIGHT_ROWS:
        return np.arange(count)
    return np.sort(np.random.default_rng(seed).choice(count, WEIGHT_ROWS, replace=False))


def _grow_rows(state: dict, R_t: np.ndarray) -> np.ndarray:
    """Append the round's rows ``R_t`` (r_t, n, 3) to the rows so far and return them all, a C-contiguous
    (R, n, 3) view (``state['R']``) of a buffer that grows by half when full: appending by concatenation
    copied every row rendered so far in every round (500 MB a round at 415 rows x 100k lights)."""
    buf, have = state["R_buffer"], 0 if state["R"] is None else len(state["R"])
    need = have + len(R_t)
    if buf is None or need > len(buf):
        capacity = need if buf is None else (3 * need) // 2
        grown = np.empty((capacity,) + R_t.shape[1:], np.float32)
        if have:
            grown[:have] = state["R"]
        buf = state["R_buffer"] = grown
    buf[have:need] = R_t
    state["R"] = buf[:need]
    return state["R"]


def _show_estimate(bar, res: RenderResult) -> None:
    """The current estimate on the bar (tqdm postfix) or as a log line."""
    import sys

    msg = (f"round {res.budget['round'] + 1}/{res.budget['rounds']}: {res.budget['columns']} columns, "
           f"estimated relative L2 {res.error_estimate:.2%}")
    if bar.bar is not None:
        bar.bar.set_postfix_str(msg)
    elif bar.mode == "log":
        try:
            print(f"manylights: mrcs_progressive: {msg}", file=sys.stderr, flush=True)
        except (OSError, ValueError):
            pass
