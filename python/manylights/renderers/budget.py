"""Budgets chosen automatically: ``ml.render(A, target_error=e)`` / ``time_budget=s`` on
top of progressive MRCS (``manylights.renderers.estimates``: rounds, the paired-representative estimate (3), the
inverse-variance combination).

Schedule
--------
Round 0 is a pilot of ``r_0 = 8`` rows and ``c_0 = 32`` columns. Its OWN rows, columns and clustering are
timed (``t_r`` rendering seconds per row, ``t_c`` per column; a time budget also counts a row's share of
the clustering, which reads every row so far; every later round re-times them from its own work):
nothing is rendered only to time it.
After each round t with combined estimate ``eps_t`` (3) at ``R_t`` rows in total and ``Δc_t`` new columns:

1. **Stop** when ``eps_t <= SAFETY e`` (0.8 e), or when the next round would not fit the time budget.
2. **Row:column ratio.** Locally ``V ~ R^-e_r Δc^-e_c`` (``e_r``, ``e_c``: how fast more rows and more
   columns cut the variance); minimising the round's cost ``ΔR t_r + Δc t_c`` at a fixed V (Lagrange:
   ``t_r = λ e_r / R``, ``t_c = λ e_c / Δc``) gives

       R t_r / (Δc t_c) = e_r / e_c,   i.e.   R = (e_r / e_c) (t_c / t_r) Δc                  (8)

   the rendering time on the rows (all R, rendered so far or new) against the round's new columns is
   the ratio of what each buys. The ratio uses no measured exponents: ``e_r / e_c = 1``, equal
   rendering time on the rows and on the round's columns, with ``t_r``, ``t_c`` the last round's
   rendering seconds per row and per column. That is an empirical choice, not (8) at the prediction's
   exponents of step 3 (which would give rows half the columns' time): it is what the cheapest fixed
   budgets spend (below), and the blind spot of rows (adaptive's doc) makes rows worth more than a
   power law says. Rows already rendered are paid for:
   ``R = max(R_t + 8, (8))``. The exponents are not measured per render: estimated from held-out
   variances they scatter too much between seeds to steer by (docs/validation/budgets.md).
   The cheapest fixed budgets of ``bench budgets`` spend about equal time on both: cbox 16:128 and
   32:256 (a row costs ~11 columns: rows 1.4x the columns' time), veach-ajar 256:2048 (~7 columns:
   0.9x).
3. **The increment from the estimate** instead of blind doubling: the rounds' variances (1) ``v_s`` share
   one scale with the estimate (nearly: the newest round's v is at its own rows, the others' at held-out
   rows, so V_t reads low where own rows miss a splotch), ``V_s = eps_t^2 v_s sum_s' 1/v_s'`` (the
   combination (inverse variance) gives ``1 / eps_t^2 = sum_s 1 / V_s``); the next round must bring the
   combination to
   ``(AIM SAFETY e)^2``, so alone it needs ``1 / V_new = 1 / (AIM SAFETY e)^2 - 1 / eps_t^2``, predicted by
   ``V_new = V_t (R / R_t)^-e_r (Δc / Δc_t)^-e_c`` with R from (8) and Monte Carlo's ``e_c = 1``,
   ``e_r = 1/2`` (``E_COLUMNS``, ``E_ROWS``). Where the variance collapses faster (veach-ajar, once the
   clusters catch the VPL splotches) this asks for too much: after the round of 4,000 columns 1% renders
   took the 4x cap and ended at 0.06% (true, mean) with 18,222 columns where the cheapest fixed budget
   has 8,192 (exponents fitted to the last two rounds did worse: docs/validation/budgets.md). Δc solves it (bisection), at least
   ``max(c_0, C_t / 2)`` (every round re-clusters all rows: small rounds do not pay) and at most
   ``GROWTH`` (4) x the columns so far (predictions from small rounds run far: larger caps overshoot). AIM = 0.85 is the margin: a seed that lands
   just above the stop adds a round of what the estimate says is missing (at least half the columns so
   far), not a blind doubling.
   A round also costs its overhead ``t_0`` (clustering, combination: up to a second at 100k lights
   whatever its size), so it gets at least ``t_0 / t_c`` columns: that at most doubles the round, and a
   further round (another ``t_0``) gets unlikely (on cbox 128^2 a round's clustering of 100k lights costs
   0.4-1 s, its 16-200 columns 0.1-1.5 s). Without a target (time budget only) each round doubles the columns,
   cut to what the time left allows.
4. **All lights**: when the next round would pass ``BRUTE_FORCE_SHARE`` (1/2) of the n columns (with a
   target; n without), brute force (exact; said in ``stopped``; the seconds of the rounds it replaces in
   ``timings['mrcs_rounds']``): it costs at most about twice that round's columns and has no rows or
   clustering (the staircase's 65,536 VSLs at 64^2: a round to 58,510 columns, then brute force all the same,
   49 s of rounds before a 41 s brute force). Sooner (after the second round, without
   ``rows_per_column``) when the prediction of step 3 without the ``GROWTH`` cap needs all n columns and the
   rounds' seconds with the next one would pass ``BRUTE_FORCE_SHARE`` (1/2) of brute force's (n t_c, where
   that is at least ``BRUTE_FORCE_MIN_SECONDS``, 2 s): the
   prediction is trusted only once it would cost that much (on veach-ajar the variance collapses later than
   predicted: there early rounds predict more than n columns and still end at 4,000-20,000).

Every round stays the unbiased round of ``mrcs_progressive`` (weights from rows only), so the estimate is
(3) unchanged, and the schedule is reported: ``budget['chosen']['rows']`` / ``['columns']`` (cumulative
per round) replayed by ``mrcs_progressive(A, rows=..., columns=..., seed=seed)`` give the image bit for bit.
With ``rows_per_column=`` given, (8) is replaced by ``ΔR = max(8, rows_per_column Δc)``, the overhead
floor of step 3 is not applied, and nothing depends on a timing: the same seed gives the same image
(with a time budget, where it stops still does).

Measured (``python -m manylights.bench budgets``, CPU, 100k lights, 8 seeds, paired time ratio against the
cheapest fixed MRCS budget reaching e): cbox 128^2 reaches 5/2/1% in every seed at 1.0-1.9x that budget's
time; veach-ajar 128x72 in 88-100% of seeds at 2.1-2.6x. Where it falls short on veach-ajar: the variance
collapses once rows and clusters catch the VPL splotches, which no local power law (step 3) foresees, so
rounds hit the 4x cap and the last one overshoots; each round re-clusters all rows of all lights (~1 s at
100k); and the halves use c/2 clusters, while veach-ajar's MRCS error collapses once each splotch VPL has a
cluster of its own. The tables, and what was tried and not kept: docs/validation/budgets.md.

Symbols
-------
| here | meaning |
|---|---|
| ``e``, ``eps_t`` | target relative L2, the combined estimate (3) after round t |
| ``R_t``, ``C_t``, ``Δc_t``, ``ΔR`` | rows so far, columns so far, round t's new columns, next round's new rows |
| ``t_r``, ``t_c`` | measured rendering seconds per row and per column, last round (see Schedule) |
| ``e_r``, ``e_c`` | exponents of the variance in rows and columns (``V ~ R^-e_r Δc^-e_c``) |
| ``V_s``, ``v_s`` | round s's variance alone (relative^2), its mean variance (1) per row (``round_variance``) |
| ``SAFETY``, ``AIM``, ``GROWTH`` | stop at 0.8 e; aim rounds at 0.85 x that; at most 4x the columns so far per round |
"""
from __future__ import annotations

import math
import time
from typing import Optional

import numpy as np

from .._utils import validate as _v
from .bias import bias_sources
from .progressive import progressive_rounds
from .result import RenderResult, matrix_shape

#: ``render`` stops when the estimate is <= SAFETY * target_error: the estimate scatters around the truth
#: (calibration), and stopping at the target itself left the true error above it in 25% (5%) / 6% (2%)
#: of 16 seeds on cbox-lights 32x32 (2k lights); at 0.8 x the target, in none of them.
SAFETY = 0.8
#: A predicted round aims at AIM x SAFETY x target (margin for the prediction's error).
AIM = 0.85
#: At most this many times the columns so far in one round (a pilot of 8 rows predicts poorly: 20-60% at
#: 8:32 on cbox-lights 32x32 and 1.2-2.6% after 16x columns; later rounds on veach-ajar overshoot too).
GROWTH = 4
#: Rows of the pilot round (round 0) and the fewest new rows of any later round.
FIRST_ROWS = 8
#: (Step 4) Brute force before the columns reach n: when a round would pass this share of the n columns, or
#: when the uncapped prediction needs all the lights and MRCS's seconds with its next round would pass this
#: share of brute force's (the staircase's 65,536 VSLs at 64^2: rounds of 32-20,000 columns whose estimate
#: stayed at 13-83% spent 20-27 s before the 41 s brute force).
BRUTE_FORCE_SHARE = 0.5
#: ... the timed form only where brute force costs at least this many seconds (n t_c): below, a round's fixed
#: overhead dominates the comparison, and the saving is small.
BRUTE_FORCE_MIN_SECONDS = 2.0
#: Exponents of the prediction (step 3): Monte Carlo's 1 for the columns, 1/2 for the rows.
E_COLUMNS = 1.0
E_ROWS = 0.5


def check_targets(target_error, time_budget) -> tuple[Optional[float], Optional[float]]:
    """(target_error, time_budget) as floats (or None), checked: at least one given, each finite and > 0.

    Raises:
        ValueError: neither given, NaN/inf, <= 0 or not a number (the message names the parameter)."""
    if target_error is None and time_budget is None:
        raise ValueError("give target_error (relative L2, e.g. 0.02) or time_budget (seconds) or both")
    if target_error is not None:
        target_error = _v.real("target_error", target_error)
        if not target_error > 0:
            raise ValueError(f"target_error must be a relative L2 > 0, got {target_error}")
    if time_budget is not None:
        time_budget = _v.real("time_budget", time_budget)
        if not time_budget > 0:
            raise ValueError(f"time_budget must be seconds > 0, got {time_budget}")
    return target_error, time_budget


def _round_costs(rd: dict) -> tuple[float, float, float, float]:
    """(rendering seconds per row, seconds per row with its share of the clustering, seconds per column,
    seconds of overhead) of one finished round from its own timings. The clustering reads every row so
    far (~n R projections), so a row also costs its share of it; the overhead is what the round spent
    beside rendering (clustering, combination)."""
    sec = rd["seconds"]
    t_row = sec.get("rows", 0.0) / max(rd["new_rows"], 1)
    t_r = t_row + sec.get("clustering", 0.0) / max(rd["total_rows"], 1)
    t_c = sec.get("columns", 0.0) / max(rd["new_columns"], 1)
    return max(t_row, 1e-9), max(t_r, 1e-9), max(t_c, 1e-9), sec.get("clustering", 0.0) + sec.get("combination", 0.0)


def _solve_columns(V_t: float, V_req: float, R_t: int, dc_t: int, e_r: float, e_c: float, rows_of, lo: int,
                   hi: int) -> int:
    """The least Δc in [lo, hi] with ``V_t (rows_of(Δc) / R_t)^-e_r (Δc / dc_t)^-e_c <= V_req`` (bisection in
    log Δc; hi when none is)."""
    def pred(dc):
        return V_t * (rows_of(dc) / R_t) ** (-e_r) * (dc / dc_t) ** (-e_c)

    if pred(hi) > V_req:
        return hi
    if pred(lo) <= V_req:
        return lo
    a, b = lo, hi
    while b - a > max(1, a // 64):
        mid = int(math.sqrt(a * b))
        mid = min(max(mid, a + 1), b - 1)
        a, b = (a, mid) if pred(mid) <= V_req else (mid, b)
    return b


def fit_columns(round_seconds, lo: int, hi: int, left: float) -> Optional[int]:
    """The largest Δc in [lo, hi] whose round fits the time left, ``round_seconds(Δc) <= left``
    (``round_seconds``: the new rows that Δc brings, at t_r each, plus Δc t_c; non-decreasing in Δc), by
    bisection, rounded down to even (the halves: two columns per cluster); None when not even ``lo`` fits.
    The new rows count: Δc columns bring ``rows_of(Δc)`` rows, so a cut round also has fewer rows."""
    if round_seconds(lo) > left:
        return None
    a, b = lo, hi  # round_seconds(a) fits; the answer is in [a, b]
    while a < b:
        mid = (a + b + 1) // 2
        a, b = (mid, b) if round_seconds(mid) <= left else (a, mid - 1)
    return a - a % 2
def render_matrix(A, target_error: Optional[float] = None, time_budget: Optional[float] = None, seed: int = 0, *,
                  first_columns: Optional[int] = None, max_rounds: int = 16, rows_per_column: Optional[float] = None,
                  add_emitted: bool = True, progress: Optional[bool] = None,
                  first_rows: Optional[int] = None) -> RenderResult:
    """``render`` of a ``LightMatrix`` (its doc: arguments, result, errors): progressive MRCS rounds with the
    budget chosen from the estimates and the measured costs (this module's doc). ``first_rows``: rows of
    round 0 (1 <= r <= m; default ``FIRST_ROWS``, or ``rows_per_column`` x ``first_columns``): a floor a caller
    sets when it knows the pilot's own estimate cannot see the error (``light_budget``'s escalation)."""
    m, n = matrix_shape(A)
    if n == 0:
        raise ValueError("the light matrix has no lights (n = 0): nothing to render")
    target_error, time_budget = check_targets(target_error, time_budget)
    seed = _v.seed(seed)
    max_rounds = _v.integer("max_rounds", max_rounds, 1, 64)
    if first_columns is None:
        first_columns = min(32, n // 2)
        if first_columns < 2:
            first_columns = n + 1  # no round fits: brute force below
    else:
        first_columns = _v.integer("first_columns", first_columns, 2, max(n, 2))
    if rows_per_column is not None:
        rows_per_column = _v.real("rows_per_column", rows_per_column)
        if not 0.0 < rows_per_column <= 1.0:
            raise ValueError(f"rows_per_column must be in (0, 1], got {rows_per_column}")
    start = time.perf_counter()
    chosen = {"target_error": target_error, "time_budget": time_budget, "rows": [], "columns": [], "estimates": [],
              "seconds_per_row": [], "seconds_per_column": [], "overhead_seconds": [],
              "rows_per_column": [],
              "why": [], "given_rows_per_column": rows_per_column}
    decision_seconds = 0.0
    pending: list = []
    if first_columns <= n:
        r0 = FIRST_ROWS if rows_per_column is None else max(FIRST_ROWS, round(rows_per_column * first_columns))
        if first_rows is not None:
            r0 = _v.integer("first_rows", first_rows, 1, max(m, 1))
        pending.append((min(r0, m), first_columns))
    state: dict = {}
    last = None
    stopped = "all lights"

    def plan(_state):
        return pending.pop() if pending else None

    gen = progressive_rounds(A, plan, max_rounds, seed, add_emitted, progress, {}, state) if pending else iter(())
    for res in gen:
        last = res
        t_dec = time.perf_counter()
        rd = state["rounds"][-1]
        eps = float(res.error_estimate)
        chosen["estimates"].append(eps)
        chosen["rows"].append(int(res.budget["rows"]))
        chosen["columns"].append(int(res.budget["columns"]))
        if target_error is not None and eps <= SAFETY * target_error:
            stopped = "target error reached"
            break
        if len(state["rounds"]) >= max_rounds:
            stopped = "max_rounds"
            break
        R_t, C_t, dc_t = int(res.budget["rows"]), int(res.budget["columns"]), int(len(rd["reps"]))
        t_row, t_r, t_c, t_0 = _round_costs(rd)
        if rows_per_column is None:
            ratio = t_c / t_row  # (8) with e_r / e_c = 1: total rows per new column

            def rows_of(dc, R_t=R_t, ratio=ratio):
                return min(m, max(R_t + FIRST_ROWS, ratio * dc))
        else:
            def rows_of(dc, R_t=R_t):
                return min(m, R_t + max(FIRST_ROWS, round(rows_per_column * dc)))

        def round_seconds(c, R_t=R_t, t_r=t_r, t_c=t_c, rows_of=rows_of):
            # A round of c new columns: the new rows it brings at t_r each plus c t_c (without its overhead t_0).
            return max(rows_of(c) - R_t, 0) * t_r + c * t_c

        lo, hi = max(first_columns, C_t // 2), max(first_columns, GROWTH * C_t)
        if target_error is not None and 0.0 < eps < math.inf:
            v = np.array([r["v"] for r in state["rounds"]], np.float64)
            V_t = eps * eps * float(v[-1] * np.sum(1.0 / v)) if np.all(v > 0) else eps * eps
            goal = AIM * SAFETY * target_error
            V_req = 1.0 / (1.0 / goal ** 2 - 1.0 / eps ** 2)
            dc = _solve_columns(V_t, V_req, R_t, dc_t, E_ROWS, E_COLUMNS, rows_of, lo, hi)
            why = f"estimate {eps:.3%} > {SAFETY:g} x target: {dc} columns predicted to bring it to {goal:.3%}"
            if rows_per_column is None and len(chosen["estimates"]) >= 2:
                # (Step 4) Brute force sooner: the prediction, uncapped, needs all the lights, and MRCS's seconds
                # with the next round would pass BRUTE_FORCE_SHARE of brute force's (n columns at t_c each).
                need = _solve_columns(V_t, V_req, R_t, dc_t, E_ROWS, E_COLUMNS, rows_of, lo, max(hi, n))
                spent = time.perf_counter() - start
                next_round = round_seconds(dc) + t_0
                if (C_t + need >= n and n * t_c >= BRUTE_FORCE_MIN_SECONDS
                        and spent + next_round > BRUTE_FORCE_SHARE * n * t_c):
                    chosen["why"].append(
                        f"estimate {eps:.3%}: the target needs more than the {n} lights, and {spent:.3g} s spent + "
                        f"{next_round:.3g} s for the next round > {BRUTE_FORCE_SHARE:g} x brute force "
                        f"({n * t_c:.3g} s): brute force now")
                    stopped = "all lights"
                    break
            # A round costs its overhead t_0 whatever its size: buy at least as many columns as t_0 pays
            # for (the round costs at most 2x, and another round, t_0 again, becomes unlikely). A timing:
            # not with rows_per_column given (then nothing depends on one).
            floor_dc = min(hi, int(t_0 / t_c)) if rows_per_column is None else 0
            if floor_dc > dc:
                dc = floor_dc
                why += f"; raised to {dc} columns, the round's overhead {t_0:.2f} s in columns"
        else:
            dc = max(lo, C_t)
            why = f"doubling the columns to {C_t + dc} (no target to predict from)"
        dc += dc % 2
        if time_budget is not None:
            now = time.perf_counter()
            left = time_budget - (now - start) - (now - t_dec)
            if round_seconds(dc) > left:
                fit = fit_columns(round_seconds, lo, dc, left)
                if fit is None:
                    stopped = "time budget"
                    break
                dc = fit
                why += f"; cut to {dc} columns by the time budget"
        if (target_error is not None and C_t + dc > BRUTE_FORCE_SHARE * n
                and (time_budget is None or time.perf_counter() - start + n * t_c <= time_budget)):
            # (Step 4) A round past half the lights' columns: brute force costs at most about twice its columns,
            # with no rows to render or clusters to build, and is exact (where the time budget allows it).
            chosen["why"].append(f"{why}: {C_t + dc} columns, more than {BRUTE_FORCE_SHARE:g} x the {n} lights: "
                                 "brute force now")
            stopped = "all lights"
            break
        dr = int(max(0, round(rows_of(dc) - R_t)))
        chosen["seconds_per_row"].append(t_row)
        chosen["seconds_per_column"].append(t_c)
        chosen["overhead_seconds"].append(t_0)
        chosen["rows_per_column"].append(dr / dc)
        chosen["why"].append(why)
        decision_seconds += time.perf_counter() - t_dec
        if C_t + dc > n:
            stopped = "all lights"
            break
        pending.append((dr, dc))
    getattr(gen, "close", lambda: None)()
    if stopped == "all lights":
        elapsed = time.perf_counter() - start
        t_col = chosen["seconds_per_column"][-1] if chosen["seconds_per_column"] else 0.0
        # Brute force costs about n columns.
        if time_budget is None or elapsed + n * t_col <= time_budget or last is None:
            t = time.perf_counter()
            image = A.column_sum(progress=progress)
            timings = {"columns": time.perf_counter() - t}
            if last is not None:
                # The MRCS rounds whose image brute force replaces: their seconds were spent too.
                timings["mrcs_rounds"] = elapsed
            if add_emitted:
                image = image + A.emitted()
            last = RenderResult(image=image, method="brute_force", seed=seed, timings=timings,
                                budget={"columns": int(n), "lights": int(n)}, device=A.device,
                                bias_sources=bias_sources(A))
            last.error_estimate = 0.0
            last.error_image = np.zeros(image.shape[:2], np.float32)
            stopped = "all lights: brute force"
        else:
            stopped = "all lights: time budget too small for brute force"
    chosen["rounds"] = len(chosen["estimates"])
    last.budget["stopped"] = stopped
    last.budget["chosen"] = chosen
    last.timings["budget_choice"] = decision_seconds
    return last
