"""Progressive MRCS: rounds of new rows and columns, each an unbiased image of everything rendered so far with
its error estimate (the estimators (1)-(4) are those of ``estimates``).

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
the lists truncated), bit for bit on the same backend (tests/renderers/test_error_estimate.py).

Budgets (``render``)
--------------------
``render(A, target_error=, time_budget=)`` (``budget``, its module doc: the
row:column ratio (8), increments predicted from the estimate) drives these rounds through the
same generator, choosing each round's rows and columns from what the earlier rounds rendered.
``render("scene.xml", ...)`` also chooses the light counts before that:
``light_budget`` (its module doc: the error split (5), the halving estimate (6)).

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

from .._utils import validate as _v
from .._utils.keywords import checked_keywords
from .._utils.progress import progress_bar
from .._utils.seeds import derived_seed
from ..matrix.rows import stratified_rows
from .bias import bias_sources
from .estimates import halves_estimate, lights_seen, mrcs_halves, row_variance
from .result import RenderResult, light_luminance_power, matrix_shape


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


@checked_keywords("manylights.renderers.clustering:cluster_reduced_columns", exclude=("seed", "power"))
def mrcs_progressive(A, rows=64, columns=128, rounds: Optional[int] = None, seed: int = 0, *,
                     add_emitted: bool = True, progress: Optional[bool] = None,
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
            (None: a bar in a terminal or notebook, nothing in logs; True: also a few lines in logs).
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
    m, n = matrix_shape(A)
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
    return progressive_rounds(A, lambda state: next(plan, None), len(dc), seed, add_emitted, progress, cluster_options)


#: The combination weights evaluate (1) at this many rows of each round's batch of new rows (held out for the
#: earlier rounds) and at this many of all rows so far (the new round's own); at all of them when fewer.
WEIGHT_ROWS = 48


def progressive_rounds(A, plan, planned_rounds: int, seed: int, add_emitted: bool, progress: bool, cluster_options: dict,
                 state: Optional[dict] = None) -> Iterator[RenderResult]:
    """The rounds of ``mrcs_progressive``. ``plan(state)`` gives round t's (new rows, new columns), or None to
    stop, before each round; ``state`` (filled here, read by ``plan``: ``R`` (rows so far, n, 3), ``rows``,
    ``rounds`` (per round: clustering, rows/columns, ``v`` the mean (1) per row behind its combination
    weight, from ``held_out_variance`` / ``held_out_rows`` (later rounds' new rows) or, before any,
    ``own_variance`` (its own rows), the round's own timings
    ``seconds``), ``round`` (the next round's index)) lets ``render`` choose increments from what was
    rendered. Round t's seed depends only on (seed, t), so a schedule replayed as lists gives the same bits."""
    power = light_luminance_power(A.lights)
    emitted = A.emitted()
    known_bias = bias_sources(A)
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
            s_t = seed if t == 0 else derived_seed(seed, t)
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
                held = _weight_rows(len(new_rows), derived_seed(s_t, 1 << 25)) + n_prev
                R_h = np.ascontiguousarray(R_all[held])
                for rd in rounds[:-1]:
                    rd["held_out_variance"] += float(row_variance(R_h, rd["clustering"]).sum())
                    rd["held_out_rows"] += len(held)
            own = _weight_rows(len(row_all), derived_seed(s_t, (1 << 25) + 1))
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
                        "unseen_lights": cl["unseen_lights"]}, device=A.device,
                bias_sources=list(known_bias))
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
