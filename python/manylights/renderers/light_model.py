"""The light model of ``render("scene.xml", target_error=e)``: which model's image is kept, chosen by the probes'
error against the converged scene (``probe_error``), and the virtual spherical lights tried where clamped VPLs
miss the target. The light counts, the escalation and the claim are ``light_budget``'s.

Counts are not the whole choice: a light model can converge to the wrong image (``bias``), and no count removes
that. With probes (``render``'s ``error_probes``) the rendered image's light model is chosen by its error against
the converged scene (``choose_light_model``): the lights as generated, and where the VPLs are clamped, the same
image plus the clamp's energy by ``LightMatrix.bias_compensation`` (unbiased, cheap: short BSDF paths; its own
variance from two independent estimates). A selection probe set scores both, the smaller point estimate wins (the
compensated image scored with a third, independent compensation estimate, so the choice does not keep the draws that
happened to miss the compensation's rare bright paths), and fresh probes that took no part in the choice give the
reported error (``budget['light_model']``). The probes' per-path variance also prices the alternative: the paths per
pixel an unbiased path tracer needs for the target and their time on this machine (``probe_error``'s (3));
``budget['advice']`` says so when that is less than this render took.

Where clamped VPLs miss the target (their probes' point estimate above it, with or without the compensation),
virtual spherical lights are offered next (``ALTERNATIVE_MODELS``, ``other_light_models``): VSLs (Hašan et al. 2009:
no clamp; their bias, the blur of the sphere, shrinks as the lights grow), then, while VSLs at ``max_lights`` also
miss, VSLs importance-sampled by the camera (Georgiev and Slusallek 2010) at that count. Each model climbs a count
ladder: the first rung at ``max_lights`` / ``LADDER_START`` indirect lights (at least the clamped VPLs' count),
each next rung where the bias of the rung before, falling as 1 / sqrt(count), would bring its bound to
``LADDER_AIM`` x the target (``vsl_count``: at least twice the count, ``max_lights`` above half of it; measured on the staircase at 64^2: 4.7% at 4,096 VSLs, 1.18% at
65,536). Each rung is a whole attempt (lights, matrix, render, fresh probes); the first whose own probes claim the
target is kept (a rung that claims ends the ladder, so a claim is always the last attempt's); otherwise a
separate selection probe set scores all of them and the smallest point estimate is kept, with the bound of its own
probes, which took no part in the choice (``budget['light_model']['tried']``; the others' seconds in
``timings['other_light_models']``); where too few of its probes carry that bound, a fresh probe set with twice the
probes and paths decides (as in ``light_budget``'s "Escalation", ``budget['escalation']`` kind "probes"). Measured
(one seed each): the staircase at 64^2, full GI, 5%: VSLs at 4,096 claim (true 4.0%) in 8 s, or 4,096 (bound
5.9%) then 12,288 (true 2.6%) in 16 s, where a single attempt at 65,536 took 65-78 s; Veach Ajar 32 x 18 at 5%:
the clamped VPLs are at 65,536 already, so VSLs there (bound 12%), then importance-sampled VSLs (true 5.4%, bound
6.8%, not claimed), 43 s in all. Still the caller's
choice: importance-sampled VPLs (clamped, they keep the clamp's bias: 21% on Veach Ajar), the VSLs' radius and the
glossy threshold (``generate_lights`` / ``LightMatrix``).

Symbols
-------
| here | meaning |
|---|---|
| ``e`` | ``target_error``, relative L2 of the whole image |
| (2), (7), (9) | ``probe_error``'s point estimate of the squared error, its estimate of ``||I*||``, its retracing |
| VPL, VSL | virtual point light (clamped), virtual spherical light (Hašan et al. 2009) |
| rung | one attempt of a light model at one indirect-light count (``vsl_count``) |
"""
from __future__ import annotations

import copy
import time
from typing import Optional

import numpy as np

from .._utils.seeds import derived_seed
from .probe_error import attach_probe_error, probe_error, probe_estimate, probe_sample

#: Seed streams of ``render`` (``derived_seed(seed, STREAM[...])``), shared with ``light_budget``.
STREAM = {"area": 1, "environment": 2, "indirect": 3, "final": 4, "rows": 5, "compensation": 6, "model_probes": 7,
           "escalation": 8, "probe_escalation": 9, "models": 10}
#: The light models offered, in this order, while clamped VPLs (and then the previous model) miss the target
#: (module doc): (name, ``generate_lights`` keywords).
ALTERNATIVE_MODELS = (
    ("VSLs", {"indirect_kind": "vsl"}),
    ("VSLs, importance-sampled", {"indirect_kind": "vsl", "vpl_importance": True}),
)
#: The first rung of a model's count ladder: ``max_lights`` / LADDER_START indirect lights (at least the clamped
#: VPLs' count).
LADDER_START = 16
#: A next rung aims its bound at this fraction of the target (``vsl_count``).
LADDER_AIM = 0.7
#: Rungs are multiples of this many lights.
LADDER_STEP = 1024
#: Paths per pixel of each of the two bias-compensation estimates a clamped-VPL model is offered with.
COMPENSATION_SPP = 1
#: (``light_budget`` module doc, "Escalation") When the probes see no error beyond their own noise, or too few
#: carry their estimate, a fresh probe set with this many times the probes and the paths per probe.
PROBE_ESCALATION = 2
#: A light model with a known bias source must score this much better at the selection probes to be kept
#: over one without (within the probes' noise the unbiased model wins).
BIAS_MARGIN = 0.05


def selection_errors(images: list, sample: dict) -> list:
    """The selection score of each image in ``images`` (H x W x 3 float32 arrays of one scene) at the same
    selection probes ``sample`` (``probe_error.probe_sample``): the square root of the point estimate (2) of its
    squared error, relative to one estimate of ||I*||^2 (the first image's (7) at these probes), so the scores
    differ only by the residuals. Returns floats (0 where that norm is 0); ranks models, not a bound."""
    ests = [probe_estimate(image, sample) for image in images]
    norm2 = (ests[0]["reference_norm_ratio"] * float(np.linalg.norm(images[0].astype(np.float64)))) ** 2
    return [float(np.sqrt(max(float(np.mean(e["residuals"] / sample["p"])), 0.0) / norm2)) if norm2 > 0 else 0.0
            for e in ests]


def choose_light_model(res, A, scene, probes: int, seed: int, *, spp: int, max_depth: int, variance: float,
                       refine_paths: Optional[int] = None, target_error: Optional[float] = None) -> dict:
    """The light model of the rendered image ``res`` (from ``A``), chosen by probe residuals (module doc), and the
    chosen model's error from FRESH probes that took no part in the choice.

    Candidates: the lights as generated; with clamped VPLs (``bias`` source ``vpl_clamp``) also the same image
    plus the clamp's energy (``LightMatrix.bias_compensation``, two independent estimates of ``COMPENSATION_SPP``
    paths per pixel averaged: their half difference is the compensation's own variance, added to
    ``variance`` in quadrature). With one candidate no choice is made and one probe set estimates the error;
    with more, a selection probe set (its own stream) scores every candidate by the point estimate (2) of
    ``probe_error`` on the same probes, the smallest wins (a model with a known bias source must be
    ``BIAS_MARGIN`` better), and a second, fresh probe set estimates the winner's error (so the reported
    bound is not the minimum of noisy scores); where few probes carry that estimate they are retraced with
    more paths, at most ``refine_paths`` of them (``probe_error.refine_probes``), and likewise
    while ``target_error`` lies between its lower and upper confidence bounds. Both candidates' scores are
    ``selection_errors``. The compensated candidate is
    scored with a third, independent compensation estimate of 2 ``COMPENSATION_SPP`` paths (the noise of the
    pair's mean) computed at the selection probes alone, and the pair is computed only when it wins; never is
    it scored with the pair it adds: the compensation is heavy-tailed, and a choice made on its own
    draws keeps the draws that missed its rare bright paths, a mean too dark (measured on the staircase,
    4,096 VPLs, 64 seeds: the mean of the seeds that chose it was 2.7% +- 0.8% (relative L2) from the
    converged image and 1.4% too dark; all seeds' compensated images 0.0% +- 0.7%; scored independently,
    the seeds that chose it 0.0% +- 1.0%).

    Sets ``res.image``, ``res.bias_sources`` (the winner's), the error fields (``attach_probe_error``),
    ``budget['light_model']`` (``chosen``, ``candidates``: model, variance (the compensated one's only when
    chosen), selection error, ``reason``),
    ``timings['light_model']`` (the choice: the scoring compensation at the selection probes),
    ``timings['compensation']`` (the chosen compensation's image, when it wins) and adds the selection probes to
    ``timings['probes']``. Returns the fresh ``probe_estimate``. Raises: what ``probe_error`` raises."""
    generated = {"model": "lights as generated", "image": res.image, "variance": float(variance),
                 "bias_sources": list(res.bias_sources)}
    candidates = [generated]
    t_models = select_seconds = 0.0
    if any(b["source"] == "vpl_clamp" for b in res.bias_sources):
        compensated = {"model": "VPLs + bias compensation",
                       "bias_sources": [b for b in res.bias_sources if b["source"] != "vpl_clamp"]}
        candidates.append(compensated)
        sample = probe_sample(res.image, scene, probes, spp=spp, max_depth=max_depth,
                              seed=derived_seed(seed, STREAM["model_probes"]))
        select_seconds = sample["seconds"]
        t = time.perf_counter()
        # The score's own compensation estimate, at the selection probes only (their values are those of
        # the whole image: every view sample draws from its own stream).
        scored = res.image + A.bias_compensation(max_depth, spp=2 * COMPENSATION_SPP, light_samples=64,
                                                 seed=derived_seed(seed, 100 * STREAM["compensation"] + 2),
                                                 pixels=sample["index"])
        t_models += time.perf_counter() - t
        generated["selection"], compensated["selection"] = selection_errors([res.image, scored], sample)
        chosen = min(candidates, key=lambda c: c["selection"] * (1.0 + BIAS_MARGIN * bool(c["bias_sources"])))
        reason = (f"smallest error at {probes} selection probes: " + ", ".join(
            f"{c['model']} {c['selection']:.3g}" for c in candidates))
        if chosen is compensated:
            t = time.perf_counter()
            comp = [A.bias_compensation(max_depth, spp=COMPENSATION_SPP, light_samples=64,
                                        seed=derived_seed(seed, 100 * STREAM["compensation"] + h)) for h in (0, 1)]
            norm = float(np.linalg.norm(res.image.astype(np.float64)))
            spread = float(np.linalg.norm(comp[0].astype(np.float64) - comp[1])) / 2.0 / norm if norm > 0 else 0.0
            compensated["image"] = res.image + 0.5 * (comp[0] + comp[1])
            compensated["variance"] = float(np.hypot(variance, spread))
            res.timings["compensation"] = time.perf_counter() - t
    else:
        chosen, reason = generated, "one light model for this scene: no choice"
    est = probe_error(chosen["image"], scene, probes, spp=spp, max_depth=max_depth, seed=seed,
                      variance_estimate=chosen["variance"], refine_paths=refine_paths,
                      refine_target=target_error)
    res.image = chosen["image"]
    res.bias_sources = chosen["bias_sources"]
    attach_probe_error(res, scene, probes, seed, variance=chosen["variance"], estimate=est)
    res.timings["probes"] += select_seconds
    res.timings["light_model"] = t_models
    res.budget["light_model"] = {
        "chosen": chosen["model"], "reason": reason,
        "candidates": [{k: c[k] for k in ("model", "variance", "selection") if k in c} for c in candidates]}
    return est


def fresh_probes(res, est: dict, scene, target_error: float, probe_seed: int, seed: int, *, probes: int, spp: int,
                 max_depth: int, refine_paths: int):
    """(``light_budget`` module doc, "Escalation") A fresh probe set with ``PROBE_ESCALATION`` x the probes and the
    paths per probe for ``res`` (the image kept), whose first probes ``est`` saw no error beyond their own noise
    or were carried by too few probes; the claim then rests on the fresh set alone. Returns (the fresh estimate,
    the ``escalation`` record of kind "probes"), or (``est``, None) where the probes cannot run (recorded in
    ``budget['probes']``). ``refine_paths``: the retracing's budget in paths (``probe_error.refine_probes``)."""
    noise_only = est["error_mean"] == 0.0 and est["error_lower"] == 0.0
    first_bound = float(res.error_estimate)
    why = ("with no error beyond their own noise (point estimate and lower bound 0)" if noise_only else
           f"carried by {est['effective_probes']:.1f} of {est['probes']} probes, too few to bound the error")
    n2 = min(PROBE_ESCALATION * probes, scene.width * scene.height)
    try:
        fresh = probe_error(res.image, scene, n2, spp=PROBE_ESCALATION * spp, max_depth=max_depth, seed=probe_seed,
                            variance_estimate=res.variance_estimate, refine_paths=refine_paths,
                            refine_target=target_error)
    except ValueError as e:  # as in render_scene's attempt(): the result stands with the first probes
        res.budget["probes"]["escalation_error"] = str(e)
        return est, None
    attach_probe_error(res, scene, n2, seed, variance=res.variance_estimate, estimate=fresh)
    side = ">" if first_bound > target_error else "<="
    return fresh, {"kind": "probes", "error_estimate": first_bound, "probes": int(n2),
                   "spp": int(PROBE_ESCALATION * spp), "seconds": float(fresh["seconds"]), "reason": (
                       f"the probes' bound {first_bound:.3g} {side} target {target_error:g} {why}: a fresh set "
                       f"of {n2} probes at {PROBE_ESCALATION * spp} paths, the image kept")}


def vsl_count(count: int, est: dict, bound: float, target_error: float, max_lights: int) -> int:
    """The next rung of a model's count ladder (module doc): the indirect lights that bring the error of an
    attempt at ``count`` (its probes' point estimate (2) ``est['error_mean']`` and upper bound ``bound``) to
    ``LADDER_AIM`` x ``target_error``, with the VSLs' bias falling as 1 / sqrt(count) (measured on the
    staircase at 64^2: 4.7% at 4,096 VSLs, 1.18% at 65,536): ``count (e / (LADDER_AIM target))^2`` with e the
    bound where it is finite (the point estimate otherwise), at least 2 x ``count``, rounded up to a multiple
    of ``LADDER_STEP``; ``max_lights`` itself where that is above half of it (measured: a rung at 62,464 of
    65,536 VSLs that missed was followed by one at 65,536, 63 s each)."""
    e = bound if np.isfinite(bound) else float(est["error_mean"])
    want = count * (e / (LADDER_AIM * target_error)) ** 2 if np.isfinite(e) else float(max_lights)
    want = max(want, 2.0 * count)
    if want > max_lights / 2:
        # A rung just below max_lights would cost nearly as much as max_lights and leave one more rung there.
        return int(max_lights)
    return int(min(max_lights, LADDER_STEP * np.ceil(want / LADDER_STEP)))


def other_light_models(first: dict, attempt, scene, target_error: float, time_budget: Optional[float],
                       t_start: float, seed: int, *, max_lights: int, probes: int, spp: int, max_depth: int,
                       refine_paths) -> tuple:
    """Clamped VPLs whose probes' point estimate (2) is above ``target_error`` (not claimed): render
    ``ALTERNATIVE_MODELS`` in turn, each up its count ladder (``attempt`` with the model's ``generate_lights``
    keywords, fresh probes each): the first rung at ``max_lights`` / ``LADDER_START`` indirect lights (at
    least the clamped VPLs' count), each next rung at ``vsl_count``; a model at ``max_lights`` whose point
    estimate still misses hands over to the next model at that count. It stops at the first attempt whose
    own probes claim the target, at a point estimate within the target at ``max_lights``, or (with a
    ``time_budget``) once half of it is spent. The last attempt is kept if it claims, else the one with the
    smallest point estimate (2) at a separate selection probe set (``selection_errors``; so the kept one's
    reported bound took no part in the choice). ``first`` and the return value: res, A, est, t_lights, counts
    of an attempt. Records every attempt in ``budget['light_model']['tried']`` (model, indirect lights, bound,
    lower bound, seconds, selection estimate) and the seconds of those set aside in
    ``timings['other_light_models']``. ``refine_paths(res, A, counts)``: an attempt's retracing budget in paths."""
    def claims(t):
        # Whether attempt t's own probes claim the target.
        return t["est"]["reliable"] and t["res"].error_estimate <= target_error

    tried = [{**first, "model": first["res"].budget["light_model"]["chosen"]}]
    clamped = int(first["counts"]["indirect"]["count"])
    count = min(max_lights, max(clamped, max_lights // LADDER_START))
    models = list(ALTERNATIVE_MODELS)
    why = f"the first rung of its ladder, max_lights / {LADDER_START} (the clamped VPLs had {clamped})"
    while models:
        name, keywords = models[0]
        if time_budget is not None and time.perf_counter() - t_start > time_budget / 2:
            break
        counts = copy.deepcopy(first["counts"])
        counts["indirect"]["count"] = count
        counts["indirect"]["reason"] = f"{name}: {why}"
        res, A, est, t_lights, failed = attempt(counts, derived_seed(seed, 100 * STREAM["models"] + len(tried)),
                                                model=keywords)
        if failed or est is None:
            break
        tried.append({"res": res, "A": A, "est": est, "t_lights": t_lights, "counts": counts, "model": name})
        if claims(tried[-1]):
            break
        if count < max_lights:
            new = vsl_count(count, est, float(res.error_estimate), target_error, max_lights)
            why = (f"the ladder's next rung: {count} gave bound {res.error_estimate:.3g}; a VSL's bias falls as "
                   f"1 / sqrt(count)")
            count = new
        elif est["error_mean"] <= target_error:
            # Within the target at max_lights and not claimed: another model would not be claimed sooner.
            break
        else:
            models.pop(0)
            why = f"{name} missed the target at max_lights ({max_lights}): the next model at that count"
    for t in tried:
        t["seconds"] = float(sum(t["res"].timings.values())) + t["t_lights"]
    last = tried[-1]
    if len(tried) == 1:
        chosen, reason = last, None
    elif claims(last):
        chosen, reason = last, f"{last['model']}: its own probes' bound {last['res'].error_estimate:.3g} <= target"
    else:
        sample = probe_sample(first["res"].image, scene, probes, spp=spp, max_depth=max_depth,
                              seed=derived_seed(seed, 100 * STREAM["models"] + 99))
        for t, e in zip(tried, selection_errors([t["res"].image for t in tried], sample)):
            t["selection"] = e
        chosen = min(tried, key=lambda t: t["selection"])
        reason = f"{chosen['model']}: the smallest point estimate at {probes} selection probes"
        chosen["res"].timings["probes"] += sample["seconds"]
    res = chosen["res"]
    model = res.budget["light_model"]
    model["chosen"] = chosen["model"]
    for c in model["candidates"]:
        if chosen is not tried[0] and c["model"] == "lights as generated":
            c["model"] = chosen["model"]
    if reason:
        model["reason"] = (f"{reason} (of {', '.join(t['model'] + ' at ' + str(t['counts']['indirect']['count']) for t in tried)}: "
                           "each tried while the one before did not claim the target)")
    model["tried"] = [{"model": t["model"], "indirect": int(t["counts"]["indirect"]["count"]),
                       "error_estimate": float(t["res"].error_estimate), "error_lower": float(t["est"]["error_lower"]),
                       "seconds": t["seconds"], **({"selection": t["selection"]} if "selection" in t else {})}
                      for t in tried]
    res.timings["other_light_models"] = float(sum(t["seconds"] for t in tried if t is not chosen))
    est = chosen["est"]
    if chosen is not tried[0]:
        res.budget["escalation"] = None
        if not est["reliable"] and est["error_lower"] <= target_error:
            # Too few probes carry the kept model's estimate: a fresh, larger probe set decides, as for the
            # first attempt (``light_budget`` module doc, "Escalation").
            est, res.budget["escalation"] = fresh_probes(
                res, est, scene, target_error, derived_seed(seed, 100 * STREAM["models"] + 98), seed, probes=probes,
                spp=spp, max_depth=max_depth, refine_paths=refine_paths(res, chosen["A"], chosen["counts"]))
    return res, chosen["A"], est, chosen["t_lights"], chosen["counts"]
