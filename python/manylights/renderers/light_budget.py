"""Light counts chosen automatically: ``ml.render("scene.xml", target_error=0.02)`` end to end
("model no more than the scene needs").

A scene XML becomes an image in two stages whose errors add in quadrature (they are independent: the
light generation draws the lights, MRCS then samples the matrix of those lights):

    E_total^2 ~= E_gen^2 + E_mrcs^2,   E_gen^2 = sum_k E_k^2                                   (5)

``E_k`` is the relative L2 (against the converged image of the scene's light transport) that light kind k
leaves because it has only ``n_k`` lights; ``E_mrcs`` that of MRCS against the brute force of the
generated lights (``manylights.renderers.estimates``). The target is split: ``E_gen <= sqrt(g) e`` with
``g = generation_share`` (0.5), each of the K grown kinds ``E_k <= sqrt(g / K) e`` (its share), and MRCS
gets ``sqrt(1 - g) e`` (``auto_budget.render``'s target).

Estimating E_k by halving
-------------------------
Kind k at count n is generated twice, independently (seeds from (seed, kind, count, half)), with n/2
lights each: two unbiased estimates ``S_k^a``, ``S_k^b`` of that kind's light. On h stratified rows (exact
pixel values of those lights: ``LightMatrix.rows``, the whole row is known) as in (3) of
``manylights.renderers.estimates``:

    E_k(n) = || S_k^a - S_k^b ||_rows / 2 / || T ||_rows,   T = sum of all kinds at the rows + emitted  (6)

the error of the mean of two n/2 sets; the image is then rendered with ONE fresh set of n lights (its own
seed), which is at least as good (area points and environment directions are stratified: n strata beat
two independent sets of n/2; VPLs are equal in distribution), so (6) is a conservative estimate of what
the picked count leaves -- of its VARIANCE: the VPLs' geometry-term clamp (``generate_lights``' clamp)
removes energy deterministically, which no comparison of two draws can see (veach-ajar 64x36: estimate
11-13% at 65,536 VPLs, 20-25% against Mitsuba; docs/guide/render-to-target.md). Such known bias sources (``bias``) are listed in
``RenderResult.bias_sources``, and while any is active ``budget['target_reached']`` is False with the reason. 

Environment lights are strata allocated by what the camera sees of them (``generate_lights``'
``env_visibility``: a room lit through a window gets its strata in the window; at 16,384 lights its direct
light was 0.6% off where the uniform strata left 3.0%, the glossy plates 0.7% where they left 4.4%). The
strata hardly depend on the seed (only the pilot's jitter does: ``DETERMINISTIC``), so two draws of n/2
would be nearly the same set and (6) would read about 0. Such a kind is estimated from the set's
interleaved halves instead: ``S_k^e`` and ``S_k^o``, the even- and the odd-numbered lights of the n strata
(ordered cell by cell along the equal-area grid, so each half covers the whole sphere) with their weights
doubled, each a quadrature of n/2 strata twice the size,

    E_k(n) = || S_k^e - S_k^o ||_rows / 2 / || T ||_rows = || S_k^e - S_k(n) ||_rows / || T ||_rows   (6')

the error of the coarser half, an upper bound for the whole set's as the quadrature converges; the set of n
is the one rendered (the same strata), and its rows cost one set of n lights (comparing with a separate set
of n/2 cost 1.5 n).

Growth: every kind starts at ``first_lights`` and each kind whose estimate is above ``SAFETY`` x its share
grows to the count its estimate asks for if the error falls as 1 / sqrt(n),

    n' = n 2^j,  the smallest j >= 1 with 2^j >= (E_k / (SAFETY share))^2, 2^j <= MAX_GROWTH (8)      (7)

(recomputed at the new count) until it is below, or ``max_lights`` is reached, or the count phase has used
its part of ``time_budget`` (a quarter; the next step is predicted at the last step's time times its
growth); a kind whose lights add nothing at any row stops at once. With only a time budget the kind of the
largest estimate doubles first.

Light models
------------
Counts are not the whole choice: a light model can converge to the wrong image (``bias``), and no count
removes that. With probes the rendered image's light model is chosen by its error against the converged
scene, and where clamped VPLs miss the target virtual spherical lights are tried (``light_model``).

Escalation
----------
The halving of the counts sees the spread between two light sets, not an error both share: 16,384 strata
of an environment map with a small bright sun both place the sun's highlight on a near-specular plate badly
(measured on the glossy plates, seed 6: 32% true error, the halving satisfied, the probes' bound 38%; at
65,536 strata 2.0%). MRCS's own estimate has the same blind spot: its rows can all miss a highlight (seed 7
of the same plates: a pilot of 8 rows and 32 columns satisfied, the image 38% off). When the probes find the
target missed (reliably, or with a lower bound above it, which the retracing of ``refine_probes`` confirms
where few probes carry it), with no known bias source and their bound within ``ESCALATION_REACH`` = 16 x the
target -- or at any bound when MRCS stopped at its first round (seed 6 of the plates at 2%: the pilot's 8
rows missed the sun's highlight, the probes' bound 47%, the image 57% off; a larger pilot is what removes
that) -- every kind gets 2x its lights (a bound within sqrt(2) x the target: an error falling like
1 / sqrt(count) then reaches it) or ``ESCALATION_FACTOR`` = 4 x (at most ``max_lights``) once, MRCS's first
round gets the same factor times the first attempt's rows and columns (at most half the lights) when the first
attempt's MRCS stopped at its pilot (after more rounds its estimate rests on many rows; a floor of 4x their
thousands of rows and columns made the window room's second attempts 4x slower), and the
scene is rendered and probed again with fresh probes; the first attempt is set aside
(``budget['escalation']``, ``kind`` "lights": its counts, MRCS rows and columns, bound, seconds and why;
``timings['escalation']``). Where the probes' point estimate and lower bound are both 0 -- no error beyond
their own noise, so more lights could not be shown to help (the window room at 64 x 36: 16,384 -> 32,768
strata, 19 s, a second bound as high, the image 0.5% off) -- or where too few probes carry the estimate to
bound anything (heavy-tailed glossy probes whose retracing ran out of paths: the plates, seed 4, 10.4 of 256
probes carrying a bound of 3.7% on an image 0.3% off) -- the image is kept instead and a fresh probe set
with ``light_model.PROBE_ESCALATION`` = 2 x the probes and 2 x the paths per probe decides (``kind`` "probes": the first
bound, the probes, paths, seconds and why). The
claim rests on the second attempt's probes alone. Deciding to go on from one probe set and then claiming
from another keeps each claim's 90% bound; the time grows about 3-5x where it happens.

Which kinds exist (``budget['light_counts'][kind]['reason']``):

- ``delta``: the scene's point, spot and directional emitters, one light each, exact (never grown);
- ``area``: oriented points on area emitters, only if the scene has ``area`` emitters;
- ``environment``: directions of ``envmap`` / ``constant`` emitters (visibility-allocated strata), only if
  it has them;
- ``indirect``: VPLs, only if the integrator asks for indirect light (``max_depth`` -1 or > 2; the
  loader's ``Scene.integrator``, the XML's first top-level ``<integrator>``: ``path``/``volpath`` with their ``max_depth`` (default -1),
  ``direct`` = 2; ``max_depth=`` overrides). A scene with only delta lights still gets VPLs when the
  integrator asks for indirect light (its delta lights' light bounces); "no VPLs" needs both only delta
  lights (or any lights) AND ``max_depth`` 2.
- glossy work: the ``LightMatrix``'s glossy MIS (src/matrix/glossy.rs) gives BSDF samples only to view
  samples whose lobe is narrower than ``glossy_roughness``; a diffuse-only scene gets none. Reported, not
  chosen, in ``budget['glossy']`` (``LightMatrix.glossy_work``).
- shadow-map resolution (``budget['shadow_map_size']``): the CPU backend has no shadow maps (exact rays);
  the GPU backend's default ``hybrid`` visibility redoes every uncertain shadow-map test with an exact
  ray, so the resolution changes the cost, not the image (measured: 512^2 and 1024^2 give the same
  image to 1e-4): the default 512 is kept and the reason says so. (A ``shadow_map``-only resolution search is
  not built.)

Symbols
-------
| here | meaning |
|---|---|
| ``e`` | ``target_error``, relative L2 of the whole image |
| ``g`` | ``generation_share`` (0.5): share of e^2 for the light counts |
| ``n_k``, ``E_k`` | lights of kind k, its estimated error (6) (``estimates``: (count, E_k) per step) |
| ``S_k^a``, ``S_k^b`` | the kind's two half sets' values at the count rows |
| ``h`` | ``count_rows``: stratified rows of the count phase |
"""
from __future__ import annotations

import copy
import os
import time
from pathlib import Path
from typing import Optional

import numpy as np

from .._utils import validate as _v
from .._utils.seeds import derived_seed
from ..lights.generate import generate_lights
from ..matrix.light_matrix import LightMatrix
from ..matrix.rows import stratified_rows
from ..scene import load_scene
from .bias import bias_sources, describe, probes_blind
from .budget import check_targets, render_matrix
from .light_model import STREAM as _STREAM
from .light_model import choose_light_model, fresh_probes, other_light_models
from .probe_error import describe_location, integrator_depth, path_tracer_projection

#: A kind stops growing when its estimate (6) is <= SAFETY x its share (as ``auto_budget.SAFETY``).
SAFETY = 0.8
#: Part of ``time_budget`` the count phase may use; the rest renders (MRCS).
COUNT_TIME_SHARE = 0.25
KINDS = ("area", "environment", "indirect")
#: Kinds whose lights hardly depend on the seed (environment strata: only their pilot's jitter does):
#: estimated by refinement, (6').
DETERMINISTIC = ("environment",)
#: A kind grows by at most this factor per step of the count phase, (7).
MAX_GROWTH = 8
#: Retracing the probes that carry an unreliable estimate may take this share of the render so far, and at
#: least REFINE_MIN_PATHS (on short renders the estimate's accuracy comes first). Counted in work, not
#: seconds, so that a seed gives the same result on any machine: the render's matrix elements (MRCS's rows
#: and columns, the count phase's rows) at ELEMENTS_PER_PATH elements per probe path (measured on the 2-core
#: development machine: about 18M elements and 2.6M direct-light paths per second on the window room).
REFINE_SHARE = 0.15
ELEMENTS_PER_PATH = 7.0
REFINE_MIN_PATHS = 1 << 21
#: (Module doc, "Escalation") Lights per kind are multiplied by 2 (a bound within sqrt(2) x the target) or by
#: ESCALATION_FACTOR once when the probes find the target missed with no known bias source and their bound
#: within ESCALATION_REACH x the target.
ESCALATION_FACTOR = 4
ESCALATION_REACH = 16.0


def _refine_paths(res, A, counts: dict) -> int:
    """The probes' retracing budget in paths (``REFINE_SHARE``): deterministic for a seed."""
    m, n = A.shape
    b = res.budget
    if res.method == "brute_force":
        elements = m * n
    else:
        elements = int(b.get("rows", 0)) * n + int(b.get("columns", 0)) * m
    h = int(counts.get("rows", 0))
    elements += sum(h * c for k in KINDS for c, _ in counts.get(k, {}).get("estimates", []))
    return max(REFINE_MIN_PATHS, int(REFINE_SHARE * elements / ELEMENTS_PER_PATH))


def _mrcs_stopped_at_pilot(res) -> bool:
    """Whether MRCS stopped at its first round (its pilot's rows satisfied its own estimate): then a miss the
    probes find may be the pilot's blind spot, which a larger first round removes whatever its size (module
    doc, "Escalation")."""
    chosen = res.budget.get("chosen") or {}
    return res.method != "brute_force" and chosen.get("rounds") == 1


def _kind_lights(scene, kind: str, count: int, max_depth: int, seed: int, delta: int):
    """``count`` lights of one kind (without the scene's ``delta`` delta lights, which every call adds)."""
    args = {"area": 0, "environment": 0, "indirect": 0, kind: int(count)}
    L = generate_lights(scene, **args, max_depth=max_depth if kind == "indirect" else 5, seed=seed,
                        env_visibility=kind == "environment")
    return L[delta:]


def _row_sums(scene, lights, rows, matrix_options) -> np.ndarray:
    """(h, 3) float64 exact values of the lights' column sum at the rows."""
    if len(lights) == 0:
        return np.zeros((len(rows), 3))
    return LightMatrix(scene, lights, **matrix_options).rows(rows, progress=False).sum(axis=1, dtype=np.float64)


def choose_light_counts(scene, target_error: Optional[float], time_budget: Optional[float], seed: int, *,
                        max_depth: int, first_lights: int = 256, max_lights: int = 1 << 16,
                        count_rows: int = 256, generation_share: float = 0.5, matrix_options=None) -> dict:
    """The light counts of a loaded scene by halving, equation (6) of the module doc.

    Args:
        scene: a loaded Scene. target_error: relative L2 of the whole image (> 0) or None (then the
            counts grow, largest estimate first, while the count phase's time lasts). time_budget: seconds
            (> 0) or None; the count phase may use ``COUNT_TIME_SHARE`` of it. seed: seeds every light set
            and the rows. max_depth: the integrator's (2 = direct light only: no VPLs).
        first_lights: the first count of each kind (even, >= 2). max_lights: no kind grows past it.
        count_rows: stratified rows h for (6) (capped at the pixel count). generation_share: g of (5).
        matrix_options: ``LightMatrix`` keyword arguments (device, max_depth, ...).

    Returns:
        dict kind -> {"count", "reason", "estimates": [(count, E_k), ...], "share"} for "delta", "area",
        "environment", "indirect", plus "estimated_generation_error" (sqrt sum E_k^2 at the picked counts),
        "rows", "seconds".
    """
    t0 = time.perf_counter()
    matrix_options = dict(matrix_options or {})
    delta_lights = generate_lights(scene, area=0, environment=0, indirect=0, seed=seed)
    d = len(delta_lights)
    types = {e["type"] for e in scene.emitters}
    present = {"area": "area" in types, "environment": bool(types & {"envmap", "constant"}),
               "indirect": max_depth != 2}
    h = min(count_rows, scene.width * scene.height)
    rows = stratified_rows(scene, h, seed=derived_seed(seed, _STREAM["rows"]))
    out: dict = {"delta": {"count": d, "reason": "the scene's point/spot/directional emitters: one exact light each"}}
    active = [k for k in KINDS if present[k]]
    for k in KINDS:
        if not present[k]:
            out[k] = {"count": 0, "estimates": [], "reason": {
                "area": "no area emitters in the scene",
                "environment": "no envmap or constant emitter in the scene",
                "indirect": f"the integrator asks for direct light only (max_depth {max_depth})"}[k]}
    share = float(np.sqrt(generation_share / max(len(active), 1))) * target_error if target_error else None
    base = _row_sums(scene, delta_lights, rows, matrix_options)
    emitted_rows = LightMatrix(scene, delta_lights, **matrix_options).emitted().reshape(-1, 3)[rows]
    halves: dict = {}  # kind -> (count, value at the rows, error vector at the rows)

    def sums(k: str, n: int, s: int) -> np.ndarray:
        return _row_sums(scene, _kind_lights(scene, k, n, max_depth, s, d), rows, matrix_options)

    def measure(k: str, n: int) -> None:
        if k in DETERMINISTIC:
            # (6'): the strata do not depend on the seed, so two draws agree; the set's interleaved halves
            # instead, each the quadrature of n/2 strata twice the size (their lights' weights doubled):
            # the rows of n lights, split, cost no more than the rows of the set itself.
            lights = _kind_lights(scene, k, n, max_depth, seed, d)
            even, odd = (2.0 * _row_sums(scene, lights[h::2], rows, matrix_options) for h in (0, 1))
            halves[k] = (n, 0.5 * (even + odd), 0.5 * (even - odd))
            return
        # Two independent sets of n/2 lights, seeds from (seed, kind, count, half).
        sa, sb = (sums(k, n // 2, derived_seed(seed, 1000 * _STREAM[k] + 2 * n + half)) for half in (0, 1))
        halves[k] = (n, 0.5 * (sa + sb), 0.5 * (sa - sb))

    def estimates() -> dict:
        total = base + emitted_rows + sum(v for _, v, _ in halves.values())
        den = float(np.linalg.norm(total))
        return {k: (0.0 if den == 0 else float(np.linalg.norm(e)) / den) for k, (_, _, e) in halves.items()}

    for k in active:
        out[k] = {"count": first_lights, "estimates": [], "share": share}
        measure(k, first_lights)
    growing = set(active)
    count_time = None if time_budget is None else COUNT_TIME_SHARE * time_budget
    factor = {k: 2 for k in active}
    step_seconds = time.perf_counter() - t0
    while growing:
        est = estimates()
        for k in sorted(growing):
            out[k]["estimates"].append((halves[k][0], est[k]))
        done = []
        for k in sorted(growing):
            n, value, err = halves[k]
            if not np.any(value) and not np.any(err):
                out[k]["reason"] = f"its {n} lights add nothing at any of the {h} rows"
                done.append(k)
            elif share is not None and est[k] <= SAFETY * share:
                out[k]["reason"] = f"estimated error {est[k]:.2%} <= {SAFETY} x its share {share:.2%}"
                done.append(k)
            elif 2 * n > max_lights:
                out[k]["reason"] = f"max_lights {max_lights} reached (estimate {est[k]:.2%})"
                done.append(k)
            elif share is not None:
                # (7): the count the estimate asks for, if it falls as 1 / sqrt(n), in powers of two, at most
                # MAX_GROWTH x a step and never past max_lights.
                want = (est[k] / (SAFETY * share)) ** 2
                f = 2
                while f < MAX_GROWTH and f < want and 2 * f * n <= max_lights:
                    f *= 2
                factor[k] = f
        growing -= set(done)
        if not growing:
            break
        spent = time.perf_counter() - t0
        # The next step costs about the last one times its growth (the rows are linear in the lights).
        if count_time is not None and spent + step_seconds * max(factor[k] for k in growing) > count_time:
            for k in growing:
                out[k]["reason"] = f"the count phase's share of time_budget ({count_time:.3g} s) is spent " \
                                   f"(estimate {est[k]:.2%})"
            break
        # With a target, grow every kind above its share by (7); with only a time budget, double the largest.
        grow = sorted(growing) if share is not None else [max(sorted(growing), key=lambda k: est[k])]
        t_step = time.perf_counter()
        for k in grow:
            measure(k, factor[k] * halves[k][0] if share is not None else 2 * halves[k][0])
        step_seconds = time.perf_counter() - t_step
    est = estimates()
    for k in active:
        out[k]["count"] = halves[k][0]
    out["estimated_generation_error"] = float(np.sqrt(sum(v * v for v in est.values())))
    out["rows"] = int(h)
    out["seconds"] = time.perf_counter() - t0
    return out


def render_scene(path, target_error: Optional[float] = None, time_budget: Optional[float] = None, seed: int = 0, *,
                 params: Optional[dict] = None, size=None, device: str = "auto", max_depth: Optional[int] = None,
                 first_lights: int = 256, max_lights: int = 1 << 16, count_rows: int = 256,
                 generation_share: float = 0.5, error_probes: int = 256, probe_spp: int = 256,
                 **render_options):
    """``render("scene.xml", target_error=, time_budget=)``: load the scene, choose the light counts
    (``choose_light_counts``, module doc), generate the lights at those counts (a fresh seed), then
    ``auto_budget.render`` the matrix to ``sqrt(1 - generation_share) x target_error`` within what is left of
    ``time_budget``.

    Args:
        path: the scene's XML file (str or path).
        target_error, time_budget, seed: as ``render`` (at least one of the first two).
        params: the XML's ``<default>`` parameters (``{"res": 32}``), as ``load_scene``'s keywords.
        size: (width, height) overriding the film. device: ``LightMatrix`` device.
        max_depth: the integrator's max_depth (-1 or >= 2); None = read from the XML (module doc).
        first_lights: first count per kind (even integer >= 2). max_lights: cap per kind (>= first_lights;
            default 65,536: the count phase renders count_rows rows of 2 x that many lights).
        count_rows: rows of the count phase (>= 1). generation_share: g in (0, 1).
        error_probes: N probe pixels path-traced with ``probe_spp`` paths each at the scene's depth
            (``probe_error``): the error against the converged scene, bias included, at a 90% upper
            confidence bound; ``target_reached`` is claimed only when that bound is <= target_error and the
            probes are reliable. 0: no probes (then the estimates cover variance only, and any known bias
            source makes ``target_reached`` False). More than the image's pixels: the pixel count (the default
            of 256 on a smaller image; ``budget['probes']['probes']`` says how many ran), where the renderers
            that take ``error_probes`` directly refuse it.
        **render_options: passed to ``auto_budget.render`` (first_columns, max_rounds, rows_per_column,
            add_emitted, progress).

    Returns:
        ``auto_budget.render``'s RenderResult; ``budget`` adds ``light_counts`` (per kind: count, reason,
        estimates, share; estimated_generation_error, rows, seconds), ``integrator`` (type, max_depth),
        ``shadow_map_size`` (value, reason), ``glossy`` (view_samples, bsdf_samples, reason), ``estimated_total_error`` (equation (5):
        sqrt(E_gen^2 + error_estimate^2)), ``target_reached`` (that total <= target_error and no known bias
        source active (``RenderResult.bias_sources``): the estimates cover variance only; None without a
        target) and ``target_reason`` (a sentence: why it is or is not claimed), ``escalation`` (None; or, kind
        "lights", the first attempt that the probes sent back for 2x or 4x the lights: its counts, mrcs (its MRCS
        rows and columns), error_estimate, seconds, reason; or, kind "probes", the fresh probe set that replaced
        a bound with no error beyond the probes' noise: the first bound as error_estimate, probes, spp, seconds,
        reason; module doc); ``timings['light_counts']``, ``timings['lights']`` and ``timings['escalation']`` (the
        first attempt's seconds, where there was one).
        With probes ``error_estimate`` is their upper bound on the error against the converged scene,
        ``variance_estimate`` the variance part (equation (5)), ``bias_estimate`` the rest, ``budget['probes']``
        the details and ``timings['probes']`` their cost, ``budget['light_model']`` the light model chosen
        (``choose_light_model``: ``timings['light_model']`` the choice, ``timings['compensation']`` the
        compensation image where it is chosen; ``tried``: the models rendered when clamped VPLs missed by more
        than their probes' noise, module doc; ``timings['other_light_models']``); without, ``error_estimate``
        stays the MRCS
        estimate against the brute force of the generated lights.

    Raises:
        FileNotFoundError: the scene file does not exist. ValueError: neither target_error nor time_budget,
            a target_error or time_budget that is not a finite number > 0 (checked before loading), bad
            first_lights / max_lights / count_rows / generation_share / max_depth, an integrator type
            other than path/volpath/direct without max_depth=, and what ``load_scene`` and
            ``generate_lights`` refuse (e.g. a scene without emitters).
    """
    target_error, time_budget = check_targets(target_error, time_budget)
    seed = _v.seed(seed)
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a scene XML path (str or os.PathLike), got {type(path).__name__}")
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"scene file not found: {p}")
    first_lights = _v.integer("first_lights", first_lights, 2, 1 << 30)
    if first_lights % 2:
        raise ValueError(f"first_lights must be even (two halves), got {first_lights}")
    max_lights = _v.integer("max_lights", max_lights, 2, 1 << 30)
    if max_lights < first_lights:
        raise ValueError(f"max_lights ({max_lights}) must be >= first_lights ({first_lights})")
    count_rows = _v.integer("count_rows", count_rows, 1, 1 << 30)
    generation_share = _v.real("generation_share", generation_share)
    error_probes = _v.integer("error_probes", error_probes, 0, 1 << 30)  # capped at the pixel count below
    probe_spp = _v.integer("probe_spp", probe_spp, 2, 1 << 30)
    if not 0.0 < generation_share < 1.0:
        raise ValueError(f"generation_share must be in (0, 1), got {generation_share}")
    t_start = time.perf_counter()
    params = dict(params or {})
    if max_depth is not None:
        max_depth = _v.integer("max_depth", max_depth, -1, 1 << 20)
        if max_depth in (0, 1):
            raise ValueError(f"max_depth must be -1 or >= 2 (Mitsuba's path depth), got {max_depth}")
    scene = load_scene(p, size=size, **params)  # malformed XML: SceneError naming file and line
    error_probes = min(error_probes, scene.width * scene.height)
    if max_depth is None:
        integ, max_depth = integrator_depth(scene)
    else:
        integ = "given"
    matrix_options = {"device": device, "max_depth": max_depth}
    counts = choose_light_counts(scene, target_error, time_budget, seed, max_depth=max_depth,
                                 first_lights=first_lights, max_lights=max_lights, count_rows=count_rows,
                                 generation_share=generation_share, matrix_options=matrix_options)
    def attempt(counts: dict, probe_seed: int, mrcs_floor: Optional[dict] = None, model: Optional[dict] = None):
        """Lights at ``counts`` (``model``: more ``generate_lights`` keywords), the matrix, its render (MRCS's
        first round at least ``mrcs_floor``'s rows and columns when given) and its probes: (res, A, est,
        t_lights, probes_failed)."""
        t = time.perf_counter()
        n = {k: counts[k]["count"] for k in KINDS}
        lights = generate_lights(scene, area=n["area"], environment=n["environment"], indirect=n["indirect"],
                                 max_depth=max_depth if n["indirect"] else 5, seed=derived_seed(seed, _STREAM["final"]),
                                 env_visibility=True, **(model or {}))
        A = LightMatrix(scene, lights, **matrix_options)
        t_lights = time.perf_counter() - t
        left = None if time_budget is None else max(time_budget - (time.perf_counter() - t_start), 1e-3)
        options = dict(render_options)
        if mrcs_floor is not None:
            m, n_lights = A.shape
            options["first_columns"] = max(options.get("first_columns") or 0,
                                           min(mrcs_floor["columns"], max(2, n_lights // 2)))
            options["first_rows"] = min(m, mrcs_floor["rows"])
        res = render_matrix(A, None if target_error is None else float(np.sqrt(1.0 - generation_share)) * target_error,
                            left, seed, **options)
        res.budget["light_counts"] = counts
        total = float(np.hypot(counts["estimated_generation_error"], res.error_estimate))
        res.budget["estimated_total_error"] = total
        # Halving sees the light generation's variance, not the VPL clamp's bias (module doc): only probes
        # against the converged scene see bias; without them a known bias source means no claim.
        est, failed = None, None
        if error_probes:
            try:
                est = choose_light_model(res, A, scene, error_probes, probe_seed, spp=probe_spp, max_depth=max_depth,
                                         variance=total, refine_paths=_refine_paths(res, A, counts),
                                         target_error=target_error)
            except ValueError as e:  # a scene the probes do not support: the result stands, without them
                failed = str(e)
                res.budget["probes"] = {"error": failed}
        return res, A, est, t_lights, failed

    res, A, est, t_lights, probes_failed = attempt(counts, seed)
    if probes_failed:
        error_probes = 0
    # (Module doc, "Escalation") The counts' halving can be satisfied while the probes find the target missed,
    # with no known bias source: an error that more lights remove (a small bright feature of an environment
    # map that 16,384 strata place badly). Then every kind gets 2x or ESCALATION_FACTOR x its lights (at most
    # max_lights), once, with fresh probes, when the probes' bound is within ESCALATION_REACH x the target.
    escalation = None
    noise_only = est is not None and est["error_mean"] == 0.0 and est["error_lower"] == 0.0
    # Too few probes carry the estimate (retracing's paths ran out on heavy-tailed probes): no bound to go by.
    unreliable = (est is not None and target_error is not None and not est["reliable"]
                  and est["error_lower"] <= target_error)
    pilot = _mrcs_stopped_at_pilot(res)
    if (error_probes and target_error is not None and (noise_only or unreliable) and res.error_estimate > target_error
            and not res.bias_sources and not pilot
            and res.error_estimate <= ESCALATION_REACH * target_error):
        # (Module doc, "Escalation") The probes see no error beyond their own noise, or too few of them carry
        # their estimate: more lights could not be shown to help (the window room at 64 x 36: 16,384 -> 32,768
        # strata, 19 s, a second bound as high and the image 0.5% off). A fresh probe set with PROBE_ESCALATION
        # x the probes and the paths decides it; the image is kept and the claim rests on the fresh set alone.
        est, escalation = fresh_probes(res, est, scene, target_error, derived_seed(seed, _STREAM["probe_escalation"]),
                                       seed, probes=error_probes, spp=probe_spp, max_depth=max_depth,
                                       refine_paths=_refine_paths(res, A, counts))
    elif (error_probes and target_error is not None and est is not None
            and (est["reliable"] or est["error_lower"] > target_error)
            and res.error_estimate > target_error and not res.bias_sources
            and (res.error_estimate <= ESCALATION_REACH * target_error or pilot)
            and (any(0 < counts[k]["count"] < max_lights for k in KINDS) or pilot)
            and (time_budget is None or time.perf_counter() - t_start < time_budget / (1 + ESCALATION_FACTOR))):
        # The first attempt's own seconds: the count phase stays in timings['light_counts'].
        first = {"counts": {k: counts[k]["count"] for k in KINDS}, "error_estimate": float(res.error_estimate),
                 "seconds": float(sum(res.timings.values())) + t_lights}
        grown = copy.deepcopy(counts)
        # An error that falls like 1 / sqrt(count): 2x the lights for a bound within sqrt(2) x the target.
        factor = 2 if res.error_estimate <= np.sqrt(2.0) * target_error else ESCALATION_FACTOR
        grown["estimated_generation_error"] = counts["estimated_generation_error"] / float(np.sqrt(factor))
        for k in KINDS:
            c = grown[k]["count"]
            if c > 0:
                grown[k]["count"] = min(factor * c, max_lights)
                grown[k]["reason"] = (f"escalated from {c}: the probes' bound {res.error_estimate:.3g} > target "
                                      f"{target_error:g} with no known bias source")
        # The error may also be MRCS's: its own estimate (from its rows) was satisfied, which is how it stopped.
        # When that was at its pilot, the second attempt's first round gets factor x the first attempt's rows
        # and columns (not past half the lights), so MRCS cannot stop at a pilot as blind as the first one.
        floor = None
        if res.method != "brute_force":
            first["mrcs"] = {"rows": int(res.budget["rows"]), "columns": int(res.budget["columns"])}
            # Only a pilot can be that blind: after more rounds MRCS's estimate rests on many rows, and a floor of
            # factor x thousands of rows and columns made the window room's second attempts 4x slower.
            if pilot:
                floor = {k: factor * v for k, v in first["mrcs"].items()}
        res, A, est, t_lights, failed = attempt(grown, derived_seed(seed, _STREAM["escalation"]), floor)
        counts = grown
        escalation = {**first, "kind": "lights", "reason": (
            f"the probes' bound {first['error_estimate']:.3g} > target {target_error:g} at "
            f"{sum(first['counts'].values())} lights, no known bias source: {factor}x the lights of "
            f"every kind (at most max_lights {max_lights})"
            + (f" and MRCS's first round at {factor}x its {first['mrcs']['rows']} rows and "
               f"{first['mrcs']['columns']} columns" if floor else "") + ", fresh probes")}
        if failed:
            probes_failed, error_probes = failed, 0
        res.timings["escalation"] = first["seconds"]  # the first attempt, whose image was set aside
    res.budget["escalation"] = escalation
    if (error_probes and target_error is not None and est is not None and est["error_mean"] > target_error
            and counts["indirect"]["count"] > 0 and any(b["source"] == "vpl_clamp" for b in bias_sources(A))):
        res, A, est, t_lights, counts = other_light_models(
            {"res": res, "A": A, "est": est, "t_lights": t_lights, "counts": counts}, attempt, scene, target_error,
            time_budget, t_start, seed, max_lights=max_lights, probes=error_probes, spp=probe_spp,
            max_depth=max_depth, refine_paths=_refine_paths)
    total = res.budget["estimated_total_error"]
    probe = res.budget.get("probes")
    res.budget["integrator"] = {"type": integ, "max_depth": max_depth}
    if A.device.get("kind") == "gpu":
        res.budget["shadow_map_size"] = {"value": A.shadow_map_size, "reason": (
            "exact GPU rays: no shadow maps" if A.visibility == "ray_traced" else
            "hybrid visibility: every uncertain shadow-map test is an exact ray, so the size "
            "changes the cost, not the image; the default is kept")}
    else:
        res.budget["shadow_map_size"] = {"value": None,
                                         "reason": "the CPU backend casts exact shadow rays: no shadow maps"}
    views, samples = A.glossy_work
    res.budget["glossy"] = {"view_samples": views, "bsdf_samples": samples, "reason": (
        f"glossy MIS: {views} view samples below glossy_roughness get {samples} BSDF samples in all"
        if views else "no view sample's lobe is below glossy_roughness: pure many-light columns, no glossy work")}
    if error_probes and target_error is not None:
        pt = path_tracer_projection(est, target_error, scene.width * scene.height)
        spent = float(sum(res.timings.values())) + counts["seconds"] + t_lights
        res.budget["path_tracer"] = {**pt, "render_seconds": spent}
        res.budget["advice"] = (
            f"a path tracer would get there sooner: the probes' unbiased tracer needs about {pt['spp']:.0f} paths "
            f"per pixel for {target_error:g} (equation (3) of probe_error), about {pt['seconds']:.3g} s here, "
            f"against {spent:.3g} s for this render" if pt["seconds"] < spent else None)
    else:
        res.budget["advice"] = None
    if target_error is None:
        res.budget["target_reached"] = None
        res.budget["target_reason"] = "no target given"
    elif error_probes and probes_blind(res.bias_sources):
        res.budget["target_reached"] = False
        res.budget["target_reason"] = (
            f"not claimed: the probes' bound {res.error_estimate:.3g} cannot cover bias that their path tracer "
            f"shares: {describe(probes_blind(res.bias_sources))}")
    elif error_probes and not probe["reliable"]:
        res.budget["target_reached"] = False
        res.budget["target_reason"] = (
            f"not claimed: {probe['effective_probes']:.1f} of {error_probes} probes carry the probe estimate "
            f"({res.error_estimate:.3g}): too few to bound the error (more probes or probe_spp)")
    elif error_probes:
        ok = res.error_estimate <= target_error
        res.budget["target_reached"] = bool(ok)
        why = (f"probe upper bound {res.error_estimate:.3g} ({probe['confidence']:.0%}, variance and bias) "
               f"{'<=' if ok else '>'} target {target_error:g}")
        if not ok:
            if res.bias_sources:
                why += f"; bias {res.bias_estimate:.3g} from: {describe(res.bias_sources)}"
            where = describe_location(probe["error_by_shape"])
            if where:
                why += f"; the error sits {where}"
        res.budget["target_reason"] = why
    elif res.bias_sources:
        res.budget["target_reached"] = False
        res.budget["target_reason"] = (
            f"not claimed: the estimated total error {total:.3g} covers variance only, and the light model has "
            f"bias that no estimate covers: {describe(res.bias_sources)}")
    elif probes_failed:
        res.budget["target_reached"] = False
        res.budget["target_reason"] = (f"not claimed: no probe could check the error against the converged scene "
                                       f"({probes_failed}); the estimated total error {total:.3g} covers variance only")
    elif total <= target_error:
        res.budget["target_reached"] = True
        res.budget["target_reason"] = (f"estimated total error {total:.3g} <= target {target_error:g}, and no known "
                                       "bias source is active (without probes the estimate covers variance only)")
    else:
        res.budget["target_reached"] = False
        res.budget["target_reason"] = (f"estimated total error {total:.3g} > target {target_error:g} "
                                       f"(stopped: {res.budget.get('stopped')})")
    res.timings["light_counts"] = counts["seconds"]
    res.timings["lights"] = t_lights
    return res
