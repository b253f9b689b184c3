"""Lightcuts and reconstruction cuts (Walter et al., "Lightcuts: a scalable approach to illumination",
SIGGRAPH 2005) on the light matrix's exact shading and shadow rays (CPU, rayon).

- ``lightcuts``: per view sample, a cut of a binary cluster tree over the lights is refined from its
  roots. A cluster is estimated by one representative light (drawn inside it with probability
  proportional to its intensity, once, at build time) shaded exactly with one shadow ray, times the
  cluster's intensity over the representative's; each cluster also carries an upper bound of its lights'
  unshadowed contribution (material term x geometric term x intensity, visibility bounded by 1). The
  cluster with the largest bound is split until every bound is at most ``error`` times the pixel's
  current estimate (``criterion="cluster"``, the paper's relative criterion, luminance) or the cut holds
  ``max_cut`` nodes. The per-cluster rule does not bound a pixel's error: the clusters' errors add up
  (on cbox at 2%, 60-80% of the pixels end within 2% of brute force). ``criterion="pixel"``
  refines until the SUM of the cut's bounds is at most ``error`` times the estimate, which bounds every
  pixel's relative error by ``error`` (unless ``max_cut`` stops it first), at larger cuts.
  ``criterion="hoeffding"`` refines until ``k sqrt(sum_C U_C^2)`` is at most ``error`` times the estimate,
  ``k = sqrt(ln(2 / delta) / 2)`` = 1.63 for ``delta`` = 1%: each cluster's estimate lies in ``[0, U_C]`` and is
  unbiased over its representative, drawn independently of the other clusters', so by Hoeffding's inequality
  a pixel's error exceeds ``error`` with probability at most ``delta`` -- a bound for 99% of the pixels at
  cuts far smaller than the sum's.
- ``reconstruction_cuts`` (the paper's Sec. 5, the algorithm the MRCS paper timed): full lightcuts only on
  a grid every ``block`` pixels; the pixels in between rebuild a cut from their block's corners' cuts and
  cast shadow rays only where the corners disagree about a cluster's visibility (clusters all corners saw
  lit are shaded without a ray, clusters all saw blocked are dropped). The per-pixel guarantees of the
  ``"pixel"`` and ``"hoeffding"`` criteria hold for the full cuts only, not for the rebuilt pixels.

Neither is unbiased: their error is bounded per cluster, not random. Trees, bounds and fallbacks (which
lights and BSDFs have no bound and are evaluated exactly): ``src/baselines/cut_tree.rs``; refinement:
``src/baselines/lightcuts.rs``, ``src/baselines/reconstruction_cuts.rs``.
"""
from __future__ import annotations

import numpy as np

from .. import _native
from .._utils import validate as _v
from .._utils.keywords import checked_keywords
from .bias import bias_sources
from .probe_error import attach_probe_error
from .result import RenderResult, matrix_shape, with_emitted

CRITERIA = ("cluster", "pixel", "hoeffding")
#: ``criterion="hoeffding"``: the probability that a view sample's error exceeds ``error`` (``delta``).
HOEFFDING_DELTA = 0.01


def _checked(A, error, max_cut, seed, criterion, what):
    _, n = matrix_shape(A)
    if criterion not in CRITERIA:
        raise ValueError(f"criterion must be one of {CRITERIA}, got {criterion!r}")
    error = _v.real("error", error)
    if not error > 0:
        raise ValueError(f"error must be a relative bound > 0 (e.g. 0.02), got {error}")
    max_cut = _v.integer("max_cut", max_cut, 1, 2**31 - 1)
    seed = _v.seed(seed)
    if n == 0:
        raise ValueError(f"{what} needs lights (n = {n})")
    return error, max_cut, seed


def _result(A, out: dict, method: str, seed: int, budget: dict, add_emitted: bool) -> RenderResult:
    timings = {"cut_tree": float(out["tree_seconds"]), **{k: float(v) for k, v in out["seconds"].items()}}
    image = np.asarray(out["image"], dtype=np.float32)
    image = with_emitted(A, image, timings, add_emitted)
    sizes = np.asarray(out["cut_sizes"], dtype=np.float32)
    lit = sizes > 0
    capped = int(out["capped_cuts"])
    budget = dict(budget, shadow_rays=int(out["shadow_rays"]), lights=int(A.shape[1]),
                  mean_cut=float(sizes[lit].mean()) if lit.any() else 0.0, exact_lights=int(out["exact_lights"]),
                  full_cuts=int(out["full_cuts"]), capped_cuts=capped)
    sources = list(bias_sources(A))
    if capped:
        rule = {"cluster": "every cluster's bound", "pixel": "the sum of the cut's bounds",
                "hoeffding": "the root-sum-square of the cut's bounds"}[budget["criterion"]]
        sources.append({"source": "max_cut", "view_samples": capped, "full_cuts": int(out["full_cuts"]),
                        "reason": f"{capped} of {out['full_cuts']} cuts stopped at max_cut={budget['max_cut']} "
                                  f"before {rule} was within error={budget['error']:g} of the estimate: their "
                                  "error is not bounded (raise max_cut)"})
    return RenderResult(image=image, method=method, seed=seed, timings=timings, budget=budget, device=A.device,
                        bias_sources=sources, cut_sizes=sizes.astype(np.int32))


@checked_keywords()
def lightcuts(A, error: float = 0.02, max_cut: int = 1000, seed: int = 0, *, criterion: str = "cluster",
              add_emitted: bool = True, error_probes: int = 0) -> RenderResult:
    """Lightcuts (module doc): a cut of the light cluster tree per view sample, refined until every
    cluster's error bound (``criterion="cluster"``), their sum (``"pixel"``) or 1.63 x their root-sum-square
    (``"hoeffding"``) is at most ``error`` x the pixel's estimate; approximates ``A.column_sum()`` (+ ``A.emitted()``).

    Args:
        A: a ``LightMatrix`` (any device; the cuts run on the CPU with the matrix's ray tracer).
        error: relative error bound per cluster (> 0; the paper's 2% by default).
        max_cut: the largest cut (tree nodes; lights without a bound come on top, evaluated exactly) per
            view sample, >= 1.
        seed: seed of the representatives' draw (same seed, same image).
        criterion: ``"cluster"`` (the paper's: every cluster's bound) or ``"pixel"`` (the sum of the cut's
            bounds: every pixel's relative error is then within ``error``, or its cut reached ``max_cut``)
            or ``"hoeffding"`` (k x the root-sum-square of the bounds, module doc: each pixel's relative error
            is within ``error`` with probability >= 1 - ``HOEFFDING_DELTA`` over the representatives, or its
            cut reached ``max_cut``; ``budget["error_probability"]`` says so).
        add_emitted: add what the camera sees of the emitters (``A.emitted()``).
        error_probes: N > 0: N path-traced probe pixels estimate the error against the converged scene (the
            cuts' error and the light set's bias: ``probe_error``; ``error_estimate`` becomes their upper
            bound, ``bias_estimate`` and ``budget["probes"]`` their details, ``timings["probes"]`` their cost).

    Returns:
        RenderResult: ``image`` (H, W, 3) float32; ``cut_sizes`` (H, W) int32, clusters and single lights
        shaded per pixel (0 for background); ``budget`` error, max_cut, shadow_rays, lights, mean_cut
        (over surface pixels), exact_lights (lights without a bound, shaded everywhere), full_cuts,
        capped_cuts (cuts that reached ``max_cut`` before the criterion held; when > 0, ``bias_sources``
        lists them as ``"max_cut"``: there the error is not bounded by ``error``); ``timings`` cut_tree, cuts,
        emitted (s).

    Raises:
        TypeError: A is not a LightMatrix. ValueError: error not a finite number > 0, max_cut not an integer
            >= 1, a negative seed, an unknown criterion, no lights, error_probes < 0."""
    error, max_cut, seed = _checked(A, error, max_cut, seed, criterion, "lightcuts")
    error_probes = _v.integer("error_probes", error_probes, 0, 2**31 - 1)
    out = _native.lightcuts(A._m, error, max_cut, seed, 0, criterion)
    budget = {"error": error, "max_cut": max_cut, "criterion": criterion}
    if criterion == "hoeffding":
        budget["error_probability"] = HOEFFDING_DELTA
    res = _result(A, out, "lightcuts", seed, budget, add_emitted)
    return attach_probe_error(res, A.scene, error_probes, seed) if error_probes else res


@checked_keywords()
def reconstruction_cuts(A, error: float = 0.02, max_cut: int = 1000, seed: int = 0, *, block: int = 4,
                        criterion: str = "cluster", add_emitted: bool = True, error_probes: int = 0) -> RenderResult:
    """Reconstruction cuts (module doc): lightcuts on a grid every ``block`` pixels, cuts rebuilt from
    the block's corners elsewhere (shadow rays only where they disagree about visibility).

    A pixel whose corners differ from it (BSDF kind, normal beyond 25 degrees, off their tangent plane)
    or lack a bound gets a full lightcut.

    Args:
        A, error, max_cut, seed, criterion, add_emitted, error_probes: as ``lightcuts`` (the criterion of the
            grid's cuts). The per-pixel guarantees of ``"pixel"`` and ``"hoeffding"`` hold for the full cuts
            only: a rebuilt pixel shades the clusters all its corners saw lit without a ray, and can be far off
            (measured on Veach Ajar 64 x 36 at 2%, ``"hoeffding"``: 5.3% of the pixels above the bound, one 26x
            off; ``lightcuts`` on the same matrix: none). ``budget["error_probability"]`` is not reported.
        block: grid spacing in pixels (>= 1; 1 = a full lightcut everywhere).

    Returns:
        RenderResult as ``lightcuts``'s, ``budget`` with block and full_cuts (view samples with a full
        lightcut), ``timings`` cut_tree, sparse_cuts, reconstruction, emitted.

    Raises:
        TypeError: A is not a LightMatrix. ValueError: as ``lightcuts``, and block not an integer >= 1."""
    error, max_cut, seed = _checked(A, error, max_cut, seed, criterion, "reconstruction_cuts")
    block = _v.integer("block", block, 1, 2**31 - 1)
    error_probes = _v.integer("error_probes", error_probes, 0, 2**31 - 1)
    out = _native.lightcuts(A._m, error, max_cut, seed, block, criterion)
    budget = {"error": error, "max_cut": max_cut, "criterion": criterion, "block": block}
    res = _result(A, out, "reconstruction_cuts", seed, budget, add_emitted)
    return attach_probe_error(res, A.scene, error_probes, seed) if error_probes else res
