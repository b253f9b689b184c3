"""The error a rendered image really has -- variance AND bias -- from unbiased probe pixels.

Every other estimate of this package (the halves of MRCS, held-out rows, the halving of light counts) measures
the spread of a renderer around ITS expectation, the column sum of a light model. The light model itself can
be biased (clamped VPLs, glossy lobes, near-field patches: ``bias``), and then the image converges to the
wrong answer. Probes measure against the right one: at ``N`` probe pixels the unbiased path tracer
(``probes.probe_pixels``, Mitsuba's ``path`` integrator with the scene's own ``max_depth``) estimates the
converged value ``P_k`` with the variance of its mean ``v_k``, and for the image ``I`` (fixed)

    E[ sum_ch (I_k - P_k)^2 - sum_ch v_k ] = sum_ch (I_k - I*_k)^2                                (1)

so with probes drawn independently from a defensive mixture
``p_i = (1 - a - b) / M + a |I_i|^2 / ||I||^2 + b r_i / sum r`` (``a`` = ``RISK_SHARE`` = 1/4: the pixels
that can carry relative error mass; ``b`` = ``PILOT_SHARE`` = 1/4, ``r_i = sum_ch (I_i - Q_i)^2`` against a
pilot ``Q`` of two fresh paths per pixel: the pixels where the image is off, such as one near-field pixel
that MRCS's representatives left dark (6); the Hansen-Hurwitz weights ``w_k = 1 / (N p_k)``; the mixture is
fixed before the probes' own paths are traced, from paths independent of them)

    SE = sum_k w_k d_k,   d_k = sum_ch (I_k - P_k)^2 - sum_ch v_k                                   (2)

is an unbiased estimate of the total squared error ``||I - I*||^2`` of this image. Reported as a relative
L2, ``sqrt(SE) / ||I*||`` as ``relative_l2(image, reference)`` measures it, with ``||I*||^2`` estimated by the
difference estimator

    ||I*||^2 ~= ||I||^2 - sum_k w_k (sum_ch I_k^2 - sum_ch (P_k^2 - v_k))                             (7)

(exact where the image is right; ``||I||^2`` alone would understate the error of an image whose error is a
few far too bright pixels: measured 0.66-0.91x of the truth), at an upper confidence bound: ``max(SE, 0) + z_q s``, ``s = std(d_k / p_k) / sqrt(N)``
the standard error of (2) (a negative SE says the error is within the probes' noise, and the bound is that
noise), ``z_q`` the one-sided normal
quantile of ``confidence``. Fireflies: a probe whose paths rarely find a bright, small light underestimates
its own ``v_k`` and its ``d_k`` can dominate (2); ``effective_probes`` = (sum |d_k|)^2 / sum d_k^2 says
how many probes carry the estimate (of the terms d_k / p_k), and below min(N / 4, 16), or with fewer than 16
probes, the estimate is marked unreliable. Then the probes that carry it are traced again with more, fresh paths (``refine_probes``)    (5)

Retracing (5) chooses probes by their own residuals, so what a probe reports must come from paths that
no choice of probes has seen: every batch of a probe's paths is traced as two independent parts, the choice
reads the ``screen`` part (a quarter) and the probes report their ``keep`` part (9). Without it the probes
left alone are those that missed the rare bright paths, and the estimate falls short of (1) where paths are
heavy-tailed. Whether to go on retracing reads the reported estimate itself (a stopping rule, not a choice
among probes).

The probes' path tracer itself: a probe's per-path variance is ``spp v_k``, so an image of ``S`` paths per
pixel from the same tracer has the expected squared relative L2

    sum_i sum_ch spp v_i / S / ||I||^2 ~= mean_k (sum_ch spp v_k / p_k) / (S ||I||^2)                (3)

which prices "would a path tracer get there sooner" (``path_tracer_projection``). Where the error sits: the
positive terms of (2) summed by the shape each probe pixel sees (``error_by_shape``)                  (4)

The variance part: a renderer that also estimates its own variance (MRCS halves: relative ``sigma``) gives
``bias^2 ~= SE / ||I||^2 - sigma^2``, the squared relative L2 of ``E[I] - I*`` (``bias_estimate``; noisy:
both terms are estimates), and ``bias_upper^2 = SE_upper / ||I*||^2 - q sigma^2`` with ``SE_upper`` the upper
confidence bound of (2) and ``q sigma^2`` the variance's lower bound at the same confidence (8): sigma comes
from two halves, as uncertain as one degree of freedom (``variance_lower``; subtracting sigma^2 itself left
the bound below the true bias in 17-50% of a model's seeds). Where sigma dominates, a bias well below it hardly moves SE
and the point estimate reads 0 (``bench bias``: seeds of the compensated staircase, under 15-30% of variance);
``bias_upper`` is the bound, and there it is close to the total's.

| symbol | meaning |
|---|---|
| ``I``, ``I*`` | the rendered image, the converged image of the scene (Mitsuba's ``path``) |
| ``M``, ``N`` | pixels, probes |
| ``P_k``, ``v_k`` | probe k's path-traced mean and the variance of that mean |
| ``p_i``, ``a``, ``b`` | probability of pixel i in the probes' mixture, its shares by squared value and by pilot residual |
| ``Q_i``, ``r_i`` | the pilot's mean at pixel i (``PILOT_SPP`` paths), the pilot residual |
| ``d_k``, ``w_k``, ``SE`` | probe k's residual (1), its weight, the estimated total squared error (2) |
| ``z_q`` | normal quantile of the confidence (one-sided) |
| screen, keep | the two independent parts of a probe's latest batch of paths (9) |
| ``sigma``, ``q`` | the renderer's own relative error from variance, its lower-bound factor (8) |
"""
from __future__ import annotations

import statistics
import time
from typing import Optional

import numpy as np

from .._native import Scene
from .._utils import validate as _v
from .._utils.seeds import derived_seed
from .probes import probe_pixels

#: Random stream of the probes' pixels and paths (apart from every renderer's own streams).
PROBE_STREAM = 1 << 26
#: Fewer effective probes than this (or N / 4) mark the estimate unreliable, and so do fewer probes than this
#: (with 1 or 2 probes a single one carries the estimate: cbox-gi-64 claimed a 0.4% target at 0.56% true).
MIN_EFFECTIVE = 16
#: (5) Rounds of retracing, the factor on the paths of a retraced probe, the share of sum |d_k / p_k| retraced,
#: and at most N / REFINE_CAP probes a round (``refine_probes``).
REFINE_ROUNDS = 12
REFINE_FACTOR = 8
REFINE_MASS = 0.8
REFINE_CAP = 8
#: (5') The factor on the paths of every probe when the point estimate is within the probes' own noise.
NOISE_FACTOR = 4
#: ``probe_error``'s default limit on retracing: this many times the first pass's paths (its pilot included),
#: at least REFINE_MIN_PATHS -- counted in paths, so a seed retraces the same probes on any machine.
REFINE_TIMES = 4.0
REFINE_MIN_PATHS = 1 << 20
REFINE_MIN_SECONDS = 0.5
#: A target's "missed" (the lower bound above it) is retraced like an undecided one before a first round of
#: retracing and while fewer than this share of the probes carry the estimate (``refine_probes``).
DECIDE_SHARE = 0.25
#: (9) 1 / SCREEN_PART of every batch of a probe's paths (at least 2) is the part that retracing's choice of
#: probes reads; the rest is what the probe reports once a choice was made.
SCREEN_PART = 4
#: Share of the probes' distribution proportional to the image's squared value (the rest uniform).
RISK_SHARE = 0.25
#: (6) Share of the mixture proportional to the pilot residual sum_ch (I_i - Q_i)^2, Q_i the mean of PILOT_SPP
#: fresh paths at pixel i (at most PILOT_MAX_PIXELS pixels, the rest keep the other shares).
PILOT_SHARE = 0.25
PILOT_SPP = 2
PILOT_MAX_PIXELS = 1 << 18


def integrator_depth(scene) -> tuple[str, int]:
    """The scene's top-level ``<integrator>`` as (type, max_depth), from the loader (``Scene.integrator``,
    which resolved ``$name`` values, ``<include>`` and version upgrades): a path tracer's ``max_depth``
    (Mitsuba's default -1), 2 for ``direct``; no integrator: Mitsuba's default ``path``, -1.

    Raises:
        ValueError: an integrator without a path depth (e.g. ``aov``): give ``max_depth=`` (names the file
            and line)."""
    integ = scene.integrator
    if integ is None:
        return "path", -1
    if integ["max_depth"] is None:
        raise ValueError(f"{integ['file']}:{integ['line']}: integrator type {integ['type']!r} has no path depth "
                         "(not path, volpath or direct): give max_depth=")
    return integ["type"], int(integ["max_depth"])


def probe_error(image, scene: Scene, probes: int = 64, *, spp: int = 1024, max_depth: Optional[int] = None,
                seed: int = 0, confidence: float = 0.9, variance_estimate: Optional[float] = None,
                lights=None, refine: bool = True, refine_seconds: Optional[float] = None,
                refine_target: Optional[float] = None, refine_paths: Optional[int] = None) -> dict:
    """Estimate the relative L2 of ``image`` against the converged scene from unbiased probe pixels
    (module doc: (1), (2)): ``probe_estimate(image, probe_sample(image, scene, ...))``.

    Args:
        image: (H, W, 3) the rendered image of ``scene`` (float; what the camera sees included).
        scene: the Scene it renders.
        probes: N, probe pixels (the defensive mixture of the module doc, with replacement), 1 <= N <= M.
        spp: paths per probe (>= 4: two independent parts of >= 2, (9)).
        max_depth: the path depth of the converged image; None = the scene's integrator (``integrator_depth``).
        seed: seeds the probes' pixels and paths (a stream apart from the renderers').
        confidence: one-sided confidence of the upper bound, in (0, 1).
        variance_estimate: the renderer's own estimate of its relative L2 from variance (e.g. MRCS halves), to
            split the error into variance and bias; None: no split.
        lights: a ``LightSet`` that lights the scene instead of its emitters (``probe_pixels``), for images
            of the scene under those lights (``DirectToIndirect.relight``); None: the scene's emitters.
        refine: retrace the probes that carry an unreliable estimate with more, fresh paths
            (``refine_probes``, (5)); False: one pass of ``spp`` paths per probe.
        refine_seconds: at most this many seconds of retracing instead of a number of paths (then the result
            depends on the machine's speed; at least ``REFINE_MIN_SECONDS``).
        refine_paths: at most this many paths of retracing (None, and no ``refine_seconds``: ``REFINE_TIMES``
            x the first pass's paths, at least ``REFINE_MIN_PATHS``): the result depends on the seed alone.
        refine_target: a target relative L2: retrace also while it lies between the lower and the upper
            bound (``refine_probes``' target); None: only while the estimate is unreliable.

    Returns:
        dict: ``error_estimate`` (relative L2 against the converged image, ||I - I*|| / ||I*||, at the
        upper confidence bound), ``error_mean`` (the point
        estimate (2), relative), ``error_lower`` (the lower confidence bound, relative), ``bias_estimate``
        (relative L2 of E[I] - I*, from ``variance_estimate``, or None) and ``bias_upper`` (its upper
        confidence bound; only with ``variance_estimate``), ``probes`` N, ``spp``, ``max_depth``, ``confidence``, ``effective_probes``, ``reliable``
        (N >= ``MIN_EFFECTIVE`` and effective_probes >= min(N / 4, ``MIN_EFFECTIVE``)), ``pixels`` (N, 2) int64 (row, column),
        ``probe_mean`` / ``probe_variance`` (N, 3) float32, ``residuals`` (N,) float64 d_k, ``seconds``,
        ``paths_per_second``, ``path_tracer_variance`` (equation (3): the squared relative L2 of a one-path
        per pixel image of the probes' path tracer), ``error_by_shape`` (equation (4)) and
        ``reference_norm_ratio`` (the estimate (7) of ||I*|| / ||I||, relative errors are divided by ||I*||).

    Raises:
        ValueError: an image whose shape is not the scene's (H, W, 3) or with NaN / inf values, probes outside [1, M], spp < 2, a
            confidence outside (0, 1), a negative seed, an integrator whose depth is unknown (give max_depth),
            what ``probe_pixels`` refuses (e.g. a BSDF it does not support).
        TypeError: scene not a Scene; a non-numeric image.
    """
    sample = probe_sample(image, scene, probes, spp=spp, max_depth=max_depth, seed=seed, lights=lights)
    if refine and refine_seconds is not None and refine_paths is None:
        sample = refine_probes(image, sample, seed=seed, lights=lights, max_seconds=max(REFINE_MIN_SECONDS, refine_seconds),
                               target=refine_target)
    elif refine:
        limit = refine_paths if refine_paths is not None else max(REFINE_MIN_PATHS, int(REFINE_TIMES * sample["traced"]))
        sample = refine_probes(image, sample, seed=seed, lights=lights, max_paths=limit, target=refine_target)
    return probe_estimate(image, sample, confidence=confidence, variance_estimate=variance_estimate)


def refine_probes(image, sample: dict, *, seed: int = 0, lights=None, rounds: Optional[int] = None,
                  factor: Optional[int] = None, max_seconds: Optional[float] = None,
                  target: Optional[float] = None, max_paths: Optional[int] = None) -> dict:
    """Retrace the probes that carry an unreliable or undecided estimate (5): while fewer than
    min(N / 4, ``MIN_EFFECTIVE``) probes carry (2) (or N itself is below it), or while a ``target`` lies between the lower and the upper
    confidence bound (more paths can decide it) or below the lower bound before a first round of retracing
    the heaviest probes or while fewer than ``DECIDE_SHARE`` x N probes carry it (a "missed" that a few heavy residuals decide),
    the fewest probes whose terms |d_k / p_k| make up
    ``REFINE_MASS`` of the sum (at most N / ``REFINE_CAP``) are traced again with ``factor`` x the paths of their latest batch, all FRESH, which
    replace their mean and variance -- or, with a ``target`` and a lower confidence bound at 0 (the error
    not told from the probes' own noise, which all of them carry), every probe with ``NOISE_FACTOR`` x the
    most paths behind any (5'); at most ``rounds`` times, and no round that would take the retracing
    past ``max_seconds`` (predicted from the paths per second of the sample) or past ``max_paths`` paths
    (deterministic: the same seed retraces the same probes on any machine).

    Every batch of paths comes in two independent parts (9). The choice of probes reads the ``screen`` parts
    alone, and once a round retraced anything every probe reports the ``keep`` part of its latest batch,
    which no choice of probes has seen: so each probe's mean and variance stay unbiased given those choices,
    retraced or not, and (1) holds for all of them (whether to go on reads the reported estimate: a stopping
    rule). A firefly that made a probe's residual large (or a bright path it missed, which made its own
    variance small) is averaged out instead of deciding the estimate. Reporting the probes' earlier paths
    where they were not retraced is what a choice by their own residuals biases: the probes left alone are
    those whose paths missed the rare bright ones, and on Veach Ajar (full GI, heavy-tailed paths) the
    estimate of the squared error fell to 0.45-0.52x its expectation.

    Args:
        image: (H, W, 3) the image the residuals are taken against (the one whose error is estimated).
        sample: a ``probe_sample`` of its scene (not modified).
        seed: seeds the fresh paths (a stream apart from the sample's).
        lights: as ``probe_sample``.
        target: a relative L2 the caller compares the bound with (None: retrace only while unreliable).
        rounds: at most this many rounds (>= 0; None: ``REFINE_ROUNDS``).
        factor: paths of a retraced probe, as a multiple of the paths behind its mean (>= 2; None:
            ``REFINE_FACTOR``).
        max_seconds: seconds the retracing may take in all (None: no limit).
        max_paths: paths the retracing may trace in all (None: no limit).

    Returns:
        a copy of ``sample``: where a round retraced anything, every probe's ``mean`` / ``variance`` are the
        ``keep`` part of its latest batch (else ``sample``'s own), ``parts`` each probe's latest batch,
        ``seconds`` including the retracing, ``refined`` (N,) int64: how many times each probe was retraced,
        ``paths`` (N,) int64: the paths behind each probe's mean now, ``traced``: all paths traced.

    Raises:
        ValueError: rounds < 0, factor < 2, max_seconds <= 0, what ``probe_pixels`` refuses.
    """
    rounds = _v.integer("rounds", REFINE_ROUNDS if rounds is None else rounds, 0, 16)
    factor = _v.integer("factor", REFINE_FACTOR if factor is None else factor, 2, 1 << 16)
    if max_seconds is not None and not (float(max_seconds) > 0.0):
        raise ValueError(f"max_seconds must be > 0 (or None), got {max_seconds}")
    if max_paths is not None:
        max_paths = _v.integer("max_paths", max_paths, 1, 1 << 62)
    traced = 0
    n = len(sample["index"])
    out = dict(sample)
    out["mean"], out["variance"] = sample["mean"].copy(), sample["variance"].copy()
    out["refined"] = np.zeros(n, np.int64)
    out["paths"] = sample["paths"].copy()
    # (9) Each probe's latest batch of paths in two independent parts: the choice of probes reads the
    # ``screen`` parts, and once a round has retraced anything the probes report their ``keep`` parts.
    parts = {k: tuple(np.array(a, copy=True) for a in v) for k, v in sample["parts"].items()}
    screen = dict(out)
    screen["mean"], screen["variance"], screen["paths"] = parts["screen"]
    batch = sample["paths"].copy()  # the paths of each probe's latest batch, both parts
    rate = out["traced"] / max(sample["seconds"], 1e-9)
    t = time.perf_counter()
    checked = False  # a round of the heaviest probes has run (a "missed" before it is retraced)

    def within(count: int, spp: int) -> bool:
        """Whether retracing ``count`` more probes at ``spp`` paths stays within both limits."""
        return ((max_seconds is None or time.perf_counter() - t + count * spp / rate <= max_seconds)
                and (max_paths is None or traced + count * spp <= max_paths))

    for r in range(rounds):
        est = probe_estimate(image, out)
        # Undecided: the target between the bounds, or a "missed" (lower bound above it) that no retracing of
        # the heaviest probes has checked yet (a round of all probes at 4x leaves a few of them several sigma
        # off where paths rarely find the sky through a window) or that rests on fewer than ``DECIDE_SHARE`` of the probes -- heavy residuals of noisy
        # probes can lift the lower bound of a converged image to 5x its error (glossy plates) and the upper
        # bound of a 1.7% image to 13% with 66 probes carrying it (a room lit through a window), and a render
        # would then deny a target it reached.
        undecided = target is not None and (est["error_lower"] <= target < est["error_estimate"] or (
            target < est["error_lower"] and (not checked or est["effective_probes"] < DECIDE_SHARE * n)))
        if (est["reliable"] and not undecided) or n < 2:
            break
        # Which probes: read from the screen parts alone (9).
        mag = np.abs(probe_estimate(image, screen)["residuals"] / out["p"])
        if not np.any(mag):
            break
        # (5') A lower bound at 0 says the error cannot be told from the probes' own noise, which every
        # probe carries alike: all of them are traced again with NOISE_FACTOR x the paths, if that fits
        # (the noise of (2) falls as 1 / paths there: measured on the window room's 1.2% image, bounds of
        # 1.3-1.4% where the heaviest probes alone reached 1.9-2.8%); else the heaviest probes only.
        which = np.arange(n)
        spp = int(min(batch.max() * NOISE_FACTOR, 1 << 30))
        if not (target is not None and est["error_lower"] == 0.0 and within(n, spp)):
            order = np.argsort(-mag, kind="stable")
            take = int(np.searchsorted(np.cumsum(mag[order]) / mag.sum(), REFINE_MASS) + 1)
            which = np.sort(order[:max(1, min(take, n // REFINE_CAP))])
            spp = int(min(batch[which].max() * factor, 1 << 30))
            if not within(len(which), spp):
                break
            checked = True
        fresh = _trace_parts(out["scene"], out["pixels"][which], spp, out["max_depth"],
                              (derived_seed(seed, PROBE_STREAM + 2 + r), derived_seed(seed, PROBE_STREAM + 32 + r)),
                              lights, out.get("guided_env", True))
        for k in ("screen", "keep"):
            for a, b in zip(parts[k], fresh[k]):
                a[which] = b
        screen["mean"], screen["variance"], screen["paths"] = parts["screen"]
        out["mean"], out["variance"], out["paths"] = parts["keep"]
        out["refined"][which] += 1
        batch[which] = spp
        out["traced"] += len(which) * spp
        traced += len(which) * spp
    out["seconds"] = sample["seconds"] + time.perf_counter() - t
    out["parts"] = parts
    return out


def _check_image(image, scene: Scene) -> np.ndarray:
    if not isinstance(scene, Scene):
        raise TypeError(f"scene must be a manylights Scene, got {type(scene).__name__}")
    img = _v.numeric_array("image", image)
    H, W = scene.height, scene.width
    if img.shape != (H, W, 3):
        raise ValueError(f"image must have the scene's shape ({H}, {W}, 3), got {img.shape}")
    bad = ~np.isfinite(img)
    if bad.any():
        y, x, c = (int(v[0]) for v in np.nonzero(bad))
        raise ValueError(f"image has {int(bad.sum())} non-finite values (NaN or inf), the first at pixel "
                         f"(row {y}, column {x}), channel {c}: no error can be estimated for it")
    return img


def probe_sample(image, scene: Scene, probes: int, *, spp: int = 1024, max_depth: Optional[int] = None,
                 seed: int = 0, lights=None, pilot: bool = True, guided_env: bool = True) -> dict:
    """Draw N probe pixels from the defensive mixture of ``image`` (module doc) and path-trace them: the part of
    ``probe_error`` that costs, reusable for several images of the same scene (``probe_estimate`` on each:
    the probabilities stay those of ``image``, so every estimate is unbiased; only its spread depends on how
    close the other images are to ``image``).

    Args: as ``probe_error``; ``pilot``: trace ``PILOT_SPP`` paths at every pixel (at most
    ``PILOT_MAX_PIXELS``, uniformly chosen) first and give the pixels where the image differs from them a share
    of the mixture (6); False: uniform and squared-value shares only; ``guided_env``: ``probe_pixels``' (the
    environment sampled by what the camera sees of it), kept for ``refine_probes``. Returns: dict ``pixels`` (N, 2) int64,
    ``index`` (N,) flat pixel indices, ``p`` (N,) float64 their probabilities, ``mean`` / ``variance`` (N, 3)
    float32, ``spp``, ``paths`` (N,) int64 (the paths behind each mean: ``spp``), ``max_depth``, ``seconds``
    (pilot included), ``shape_index`` (N,) int64 (-1: background), ``scene`` (the Scene), ``traced`` (all
    paths, the pilot's included), ``guided_env``, ``parts`` (the ``spp`` paths as two independent parts, whose
    combination ``mean`` / ``variance`` are: ``screen`` / ``keep``, each (mean, variance, paths), (9)). Raises: as
    ``probe_error``; ValueError for spp < 4.
    """
    img = _check_image(image, scene)
    H, W = scene.height, scene.width
    M = H * W
    probes = _v.integer("probes", probes, 1, M)
    spp = _v.integer("spp", spp, 4, 2**32 - 1)
    seed = _v.seed(seed)
    if max_depth is None:
        _, max_depth = integrator_depth(scene)
    t = time.perf_counter()
    # Defensive mixture (6): half uniform, a quarter proportional to the image's squared value (where relative
    # L2 error mass can be), a quarter to the pilot's residual (where the image is off); drawn with
    # replacement, each probe weighted by 1 / (N p_k) (Hansen-Hurwitz).
    flat = img.reshape(-1, 3).astype(np.float64)
    sq = np.sum(flat ** 2, axis=1)
    risk, pilot_paths = np.zeros(M), 0
    if pilot:
        rng = np.random.default_rng(derived_seed(seed, PROBE_STREAM + 8))
        at = np.arange(M) if M <= PILOT_MAX_PIXELS else np.sort(rng.choice(M, PILOT_MAX_PIXELS, replace=False))
        pm, _ = probe_pixels(scene, np.stack([at // W, at % W], axis=1).astype(np.int64), spp=PILOT_SPP,
                             max_depth=max_depth, seed=derived_seed(seed, PROBE_STREAM + 9), progress=False,
                             lights=lights, guided_env=guided_env)
        risk[at] = np.sum((flat[at] - pm.astype(np.float64)) ** 2, axis=1)
        pilot_paths = len(at) * PILOT_SPP
    prob = (1.0 - RISK_SHARE - PILOT_SHARE) / M + _share(sq, RISK_SHARE) + _share(risk, PILOT_SHARE)
    rng = np.random.default_rng(derived_seed(seed, PROBE_STREAM))
    idx = np.sort(rng.choice(M, size=probes, p=prob / prob.sum()))
    pk = prob[idx] / prob.sum()
    pixels = np.stack([idx // W, idx % W], axis=1).astype(np.int64)
    parts = _trace_parts(scene, pixels, spp, max_depth, (derived_seed(seed, PROBE_STREAM + 1),
                                                          derived_seed(seed, PROBE_STREAM + 10)), lights, guided_env)
    mean, var = _combine(parts)
    shape = np.asarray(scene.gbuffer(device="cpu")["shape_index"]).reshape(-1).astype(np.int64)[idx]
    return {"pixels": pixels, "index": idx, "p": pk, "mean": mean, "variance": var, "spp": int(spp),
            "max_depth": int(max_depth), "seconds": time.perf_counter() - t, "shape_index": shape, "scene": scene,
            "paths": np.full(probes, int(spp), np.int64), "traced": probes * int(spp) + pilot_paths,
            "guided_env": bool(guided_env), "parts": parts}


def _trace_parts(scene: Scene, pixels: np.ndarray, spp: int, max_depth: int, seeds: tuple, lights,
                  guided_env: bool) -> dict:
    """Two independent batches of paths at ``pixels``, ``max(spp // 4, 2)`` and the rest (9): ``screen``
    decides which probes ``refine_probes`` retraces, ``keep`` is what a probe reports once such a choice was
    made. Returns dict ``screen`` / ``keep``: (mean, variance of the mean, paths)."""
    out = {}
    n_screen = max(spp // SCREEN_PART, 2)
    for name, n, s in (("screen", n_screen, seeds[0]), ("keep", spp - n_screen, seeds[1])):
        m, v = probe_pixels(scene, pixels, spp=n, max_depth=max_depth, seed=s, progress=False, lights=lights,
                            guided_env=guided_env)
        out[name] = (m, v, np.full(len(pixels), n, np.int64))
    return out


def _combine(parts: dict) -> tuple:
    """The mean and variance of the mean of both parts' paths together."""
    (ma, va, na), (mb, vb, nb) = parts["screen"], parts["keep"]
    wa, wb = (na / (na + nb))[:, None], (nb / (na + nb))[:, None]
    return ((wa * ma + wb * mb).astype(np.float32), (wa * wa * va + wb * wb * vb).astype(np.float32))


def _share(weights: np.ndarray, share: float) -> np.ndarray:
    """``share`` of a mixture spread over the pixels in proportion to ``weights`` (evenly where all are 0)."""
    total = weights.sum()
    return share * weights / total if total > 0 else np.full(len(weights), share / len(weights))


def probe_estimate(image, sample: dict, *, confidence: float = 0.9, variance_estimate: Optional[float] = None) -> dict:
    """The error estimate (2) of ``image`` from a ``probe_sample`` of the same scene; returns and raises as
    ``probe_error`` (``seconds`` is the sample's)."""
    scene = sample["scene"]
    img = _check_image(image, scene)
    confidence = _v.real("confidence", confidence)
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence}")
    idx, pk, mean, var = sample["index"], sample["p"], sample["mean"], sample["variance"]
    probes, spp = len(idx), sample["spp"]
    x = img.reshape(-1, 3)[idx].astype(np.float64)
    p, v = mean.astype(np.float64), var.astype(np.float64)
    d = np.sum((x - p) ** 2, axis=1) - np.sum(v, axis=1)
    terms = d / pk
    se = float(terms.mean())
    sd = float(terms.std(ddof=1)) / np.sqrt(probes) if probes > 1 else abs(se)
    z = statistics.NormalDist().inv_cdf(confidence)
    # The denominator: ||I*||^2, the converged image's (as ``relative_l2(image, reference)`` measures), by the
    # difference estimator ||I||^2 - sum_k w_k (|I_k|^2 - (|P_k|^2 - v_k)) (7); ||I||^2 itself where that is
    # not positive (probes too few to say).
    image_norm2 = float(np.sum(img.astype(np.float64) ** 2))
    correction = float(np.mean((np.sum(x * x, axis=1) - (np.sum(p * p, axis=1) - np.sum(v, axis=1))) / pk))
    norm2 = image_norm2 - correction if image_norm2 - correction > 0.0 else image_norm2
    eff = float(np.abs(terms).sum() ** 2 / np.sum(terms * terms)) if np.any(terms) else float(probes)

    def rel(sq: float) -> float:
        if norm2 == 0.0:
            return 0.0 if sq <= 0.0 else float("inf")
        return float(np.sqrt(max(sq, 0.0) / norm2))

    # (3): one path per pixel of the probes' tracer has per-pixel variance spp * v_k; its total over the image
    # is estimated like (2), relative to ||I||^2.
    paths = sample["paths"].astype(np.float64)
    pt = float(np.mean(np.sum(v, axis=1) * paths / pk)) / norm2 if norm2 > 0 else float("inf")
    # A point estimate below zero says the error is within the probes' noise: the bound is then that noise
    # (z s), never less -- on glossy probes, whose variances are heavy-tailed, (2) falls below zero often.
    out = {"error_estimate": rel(max(se, 0.0) + z * sd), "error_mean": rel(se), "error_lower": rel(se - z * sd),
           "bias_estimate": None, "probes": probes,
           "spp": spp, "max_depth": sample["max_depth"], "confidence": confidence, "effective_probes": eff,
           "reliable": bool(probes >= MIN_EFFECTIVE and eff >= min(probes / 4, MIN_EFFECTIVE)),
           "pixels": sample["pixels"],
           "probe_mean": mean, "probe_variance": var, "residuals": d, "seconds": sample["seconds"],
           "paths_per_second": float(sample["traced"]) / max(sample["seconds"], 1e-9),
           "refined": int(np.count_nonzero(sample.get("refined", 0))), "path_tracer_variance": pt,
           "error_by_shape": error_by_shape(scene, sample["shape_index"], terms),
           "reference_norm_ratio": float(np.sqrt(norm2 / image_norm2)) if image_norm2 > 0 else 1.0}
    if variance_estimate is not None and norm2 > 0.0:
        out["bias_estimate"] = float(np.sqrt(max(se / norm2 - float(variance_estimate) ** 2, 0.0)))
        # What the split can promise: where the variance dominates, a bias well below it hardly moves the
        # total (a 6% bias under 15% of variance adds 1%) and the point estimate reads 0; the upper bound
        # (the total's upper bound less the variance) still covers it.
        out["bias_upper"] = rel((max(se, 0.0) + z * sd) - variance_lower(confidence) * float(variance_estimate) ** 2
                                * norm2)
    return out


def variance_lower(confidence: float) -> float:
    """The factor q with ``q sigma^2`` a lower confidence bound of a variance estimated as ``sigma^2``, taken as
    one degree of freedom (8): the variance parts here come from two halves (MRCS, the light counts' halving,
    the compensation pair), whose difference can be one image-wide mode, so ``sigma^2 / sigma_true^2`` may be
    as spread as chi^2_1. ``q = chi^2_1`` quantile at ``1 - confidence`` = ``Phi^-1(1 - confidence / 2)^2``
    (0.0158 at 90%)."""
    return statistics.NormalDist().inv_cdf(1.0 - confidence / 2.0) ** 2


def error_by_shape(scene: Scene, shape_index: np.ndarray, terms: np.ndarray, top: int = 3) -> list:
    """Where the error sits, (4): the probes' positive terms d_k / p_k of (2) summed per shape the probe pixel
    sees, as shares of their total, largest first: a list of up to ``top`` dicts ``{"shape", "share"}``
    (``shape``: the shape's ``id`` or ``"shape <i>"``, ``"background"`` for pixels that see no shape). Empty
    when no term is positive (no error the probes can see)."""
    pos = np.maximum(np.asarray(terms, dtype=np.float64), 0.0)
    total = float(pos.sum())
    if total <= 0.0:
        return []
    keys, inv = np.unique(np.asarray(shape_index), return_inverse=True)
    mass = np.bincount(inv, weights=pos)
    order = np.argsort(-mass)[:top]
    shapes = scene.shapes  # one read: the property builds every shape's dict
    out = []
    for k in order:
        i = int(keys[k])
        if 0 <= i < len(shapes):
            name = shapes[i].get("id") or f"shape {i}"
        else:
            name = "background"
        out.append({"shape": str(name), "share": float(mass[k] / total)})
    return out


def describe_location(by_shape: list) -> str:
    """``error_by_shape``'s list as words: ``"62% on 'floor', 21% on 'back'"``, or ``""``."""
    return ", ".join(f"{e['share']:.0%} on {e['shape']!r}" for e in by_shape if e["share"] >= 0.05)


def path_tracer_projection(est: dict, target_error: float, pixels: int) -> dict:
    """What the probes' own path tracer would need for ``target_error`` over the whole image, from (3):
    ``spp = path_tracer_variance / e^2`` paths per pixel (it has no bias), at the probes' measured
    ``paths_per_second`` (the same CPU, the same tracer as ``probe_pixels``): ``{"spp", "seconds"}``."""
    spp = max(1.0, float(np.ceil(est["path_tracer_variance"] / target_error ** 2)))
    return {"spp": spp, "seconds": spp * pixels / est["paths_per_second"]}


def probe_summary(est: dict) -> dict:
    """A ``probe_error`` result without its per-probe arrays (pixels, means, variances, residuals): what a
    result's ``budget['probes']`` keeps."""
    return {k: v for k, v in est.items() if k not in ("pixels", "probe_mean", "probe_variance", "residuals")}


def attach_probe_error(res, scene: Scene, probes: int, seed: int, variance: Optional[float] = None, *,
                       estimate: Optional[dict] = None, **options):
    """Fill a ``RenderResult``'s error fields from probes (``probe_error``): ``variance_estimate`` keeps what
    the renderer estimated itself (its ``error_estimate``, variance only), ``error_estimate`` becomes the
    probes' upper bound (variance and bias), ``bias_estimate`` their split, ``budget['probes']`` the
    details (without the per-probe arrays) and ``timings['probes']`` their cost. ``variance``: the relative
    error from variance when it is not ``res.error_estimate`` alone (e.g. light counts and MRCS together).
    ``estimate``: a ``probe_estimate`` of ``res.image`` already made (then nothing is traced). Returns ``res``."""
    variance = res.error_estimate if variance is None else variance
    est = estimate if estimate is not None else probe_error(res.image, scene, probes, seed=seed,
                                                             variance_estimate=variance, **options)
    res.variance_estimate = variance
    res.error_estimate = est["error_estimate"]
    res.bias_estimate = est["bias_estimate"]
    res.budget["probes"] = probe_summary(est)
    res.timings["probes"] = res.timings.get("probes", 0.0) + est["seconds"]
    return res
