"""``ml.render``: an image to a target error or within a time budget, from a light matrix or a scene file
(budgets: ``budget``; light counts: ``light_budget``)."""
from __future__ import annotations

import os
from typing import Optional

from .._utils.keywords import checked_keywords
from .budget import render_matrix
from .light_budget import render_scene
from .result import RenderResult


@checked_keywords(render_scene)
def render(A, target_error: Optional[float] = None, time_budget: Optional[float] = None, seed: int = 0, *,
           first_columns: Optional[int] = None, max_rounds: int = 16, rows_per_column: Optional[float] = None,
           add_emitted: bool = True, progress: Optional[bool] = None, **scene_options) -> RenderResult:
    """Render ``A``'s column sum to a target relative L2 and/or within a time budget, choosing the budget
    (the schedule and the ratio (8): this module's doc): progressive MRCS rounds,
    the row:column ratio from the measured cost of a row against a column (equal rendering time), each
    round's columns predicted from the estimate, stopped when the estimated relative L2
    (``error_estimate``, paired representatives) is <= ``SAFETY`` (0.8) x ``target_error``, or when the
    next round would not fit ``time_budget``, or when it would need more columns than there are lights --
    then the brute-force image (all n columns, exact: error 0) is returned if the time budget allows.

    ``A`` may also be a scene XML path: then the light counts are chosen too
    (``light_budget.render_scene``; ``scene_options``: params, size, device, max_depth,
    first_lights, max_lights, count_rows, generation_share), and ``target_error`` is the error of the
    whole image against the converged scene.

    Args:
        A: a ``LightMatrix``, or a scene XML path (str / os.PathLike).
        target_error: relative L2 to reach (a float > 0), or None (then time_budget is needed).
        time_budget: seconds of rendering (> 0), or None (then target_error is needed). A schedule, not a
            hard limit: each round is planned to fit what is left, and on a scene path the count phase, the
            lights' generation, the probes and a light-model escalation are planned from shares of it, so the
            whole call can run past it (measured on small full-GI scenes: 4.1 s for 2 s, 14 s for 10 s); the
            seconds spent are in ``timings``.
        seed: as ``mrcs_progressive``.
        first_columns: columns of round 0 (>= 2; default min(32, n // 2), and a matrix of fewer than 4
            lights is rendered by brute force).
        max_rounds: at most this many rounds (>= 1).
        rows_per_column: new rows per new column in every round (in (0, 1], at least 8 a round) instead of
            the ratio (8): then no choice depends on a timing, and the same seed gives the same image.
        add_emitted, progress: as ``mrcs_progressive``.

    Returns:
        RenderResult of the last round (or method "brute_force"), with ``budget['stopped']`` ("target
        error reached", "time budget", "max_rounds", "all lights: brute force", "all lights: time budget
        too small for brute force") and ``budget['chosen']``: ``rows`` and ``columns`` (cumulative per
        round: ``mrcs_progressive(A, rows=, columns=, seed=seed)`` reproduces the image), per round
        ``estimates``, ``seconds_per_row`` (rendering only; older results included the clustering's
        share) / ``seconds_per_column`` / ``overhead_seconds`` (measured) and ``rows_per_column`` (new
        rows per new column) behind each next round, ``why`` (a sentence per round); target_error,
        time_budget, rounds.

    Raises:
        TypeError: A is not a LightMatrix or a path; scene_options with a LightMatrix.
        FileNotFoundError: a scene path that does not exist.
        ValueError: neither target_error nor time_budget given, a
            target_error or time_budget that is not a finite number > 0, an empty light matrix (n = 0),
            first_columns < 2 or > n, max_rounds < 1, rows_per_column outside (0, 1], a negative seed.
    """
    if isinstance(A, (str, os.PathLike)):
        return render_scene(A, target_error, time_budget, seed, first_columns=first_columns, max_rounds=max_rounds,
                            rows_per_column=rows_per_column, add_emitted=add_emitted, progress=progress,
                            **scene_options)
    if scene_options:
        raise TypeError(f"render: {', '.join(sorted(scene_options))} only apply to a scene path, not a LightMatrix")
    return render_matrix(A, target_error, time_budget, seed, first_columns=first_columns, max_rounds=max_rounds,
                         rows_per_column=rows_per_column, add_emitted=add_emitted, progress=progress)
