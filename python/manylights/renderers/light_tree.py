"""Light-tree samplers on the light matrix's exact shading: light-BVH importance sampling, RIS and Stochastic
Lightcuts.

All draw lights per view sample from a ``LightTree`` (Conty Estevez and Kulla, "Importance Sampling of
Many Lights with Adaptive Tree Splitting", HPG 2018, Sec. 4-5; pbrt-v4's ``BVHLightSampler``, Pharr et
al., "Physically Based Rendering" 4th ed., Sec. 12.6.3), shade each exactly as the ``LightMatrix``'s
elements (same BSDF, emission and one exact shadow ray; CPU, rayon) and are unbiased estimates of
``A.column_sum()``:

- ``light_bvh_sampling``: k lights per view sample, estimate (1/k) sum_s A(i, j_s) / pdf_i(j_s).
- ``ris_sampling``: resampled importance sampling (Talbot et al. 2005; ReSTIR DI's per-pixel core,
  Bitterli et al. 2020, Sec. 3, Eq. 6, Alg. 2): M tree candidates per output, one kept with probability
  proportional to w = p_hat / pdf (p_hat the luminance of the unshadowed element), one shadow ray,
  weight W = w_sum / (M p_hat(y)). With ``neighbours`` > 0, ReSTIR DI's spatial reuse (Sec. 4): each
  pixel's reservoirs are combined with those of K random neighbour pixels within ``radius`` pixels
  (normals within 25 degrees) with balance-heuristic MIS weights (Sec. 4.3), keeping it unbiased. No
  temporal reuse.
- ``stochastic_lightcuts``: Stochastic Lightcuts (Yuksel, HPG 2019): per view sample a cut of the tree chosen
  by Lightcuts-style refinement of the node with the largest error bound (intensity x receiver cosine bound
  x orientation bound / clamped squared distance) until ``cut_size`` nodes, then one light drawn below each
  cut node by the paper's importance (the mean of the children's normalised weights at the nearest and the
  farthest point of their boxes; a receiver inside a child's box gives that child the nearest-distance
  share), one shadow ray each, weight 1 / pdf. Deviations: the bound's distance is clamped at 0.3 of the
  node's box diagonal (the authors' real-time code: 0.1, which left a point light among VPLs unrefined on
  cbox-lights, 3x the squared error); pbrt-v4's SAOH tree, not the paper's Morton build; no material
  bound (constant on diffuse receivers); directional lights form a second tree over their directions
  joined at the root; where both children's weights vanish a child is picked by power
  (``src/baselines/stochastic_lightcuts.rs``).

Symbols: i view sample, j light, k = ``samples`` (Stochastic Lightcuts: ``cut_size``), M = ``candidates``, pdf_i(j) = ``LightTree.pdf``,
p_hat target function, w resampling weight, W unbiased contribution weight, A(i, j) the exact element.
Rules and deviations from pbrt (directional lights by power, children picked by power where both
importances vanish): ``src/lights/light_tree.rs``; estimators: ``src/baselines/``.
"""
from __future__ import annotations

from typing import Optional

import numpy as np

from .. import _native
from .._native import LightTree
from .._utils import validate as _v
from .._utils.keywords import checked_keywords
from .bias import bias_sources
from .probe_error import attach_probe_error
from .result import RenderResult, matrix_shape, with_emitted


def _tree(A, tree) -> Optional[LightTree]:
    if tree is not None and not isinstance(tree, LightTree):
        raise TypeError(f"tree must be a manylights LightTree or None, got {type(tree).__name__}")
    return tree


def _result(A, out: dict, method: str, seed: int, budget: dict, add_emitted: bool) -> RenderResult:
    timings = {"light_tree": float(out["tree_seconds"]), "sampling": float(out["seconds"])}
    image = np.asarray(out["image"], dtype=np.float32)
    error_estimate = error_image = None
    var = out["variance"]
    if var is not None:
        var = np.asarray(var, dtype=np.float64)
        error_image = np.sqrt(var.mean(axis=-1)).astype(np.float32)
        norm = float(np.linalg.norm(image.astype(np.float64)))
        error_estimate = float(np.sqrt(var.sum()) / norm) if norm > 0 else None
    image = with_emitted(A, image, timings, add_emitted)
    budget = dict(budget, shadow_rays=int(out["shadow_rays"]), lights=int(A.shape[1]))
    return RenderResult(image=image, method=method, seed=seed, timings=timings, budget=budget, device=A.device,
                        error_estimate=error_estimate, error_image=error_image, bias_sources=bias_sources(A))


def _checked(A, samples, seed, what):
    m, n = matrix_shape(A)
    samples = _v.integer("samples", samples, 1, 2**31 - 1)
    seed = _v.seed(seed)
    if n == 0:
        raise ValueError(f"{what} needs lights (n = {n})")
    return samples, seed


@checked_keywords()
def light_bvh_sampling(A, samples: int = 16, seed: int = 0, *, tree: Optional[LightTree] = None,
                       add_emitted: bool = True, error_probes: int = 0) -> RenderResult:
    """Light-BVH importance sampling (module doc): ``samples`` lights per view sample drawn from the light
    tree, each shaded exactly with one shadow ray; unbiased for ``A.column_sum()`` (+ ``A.emitted()``).

    Args:
        A: a ``LightMatrix`` (any device; the sampling runs on the CPU with the matrix's ray tracer).
        samples: k >= 1 lights per view sample.
        seed: random seed (same seed, same image, any thread count).
        tree: a ``LightTree`` over ``A.lights`` to reuse (built here, and timed as ``light_tree``, if None).
        add_emitted: add what the camera sees of the emitters (``A.emitted()``).
        error_probes: N > 0: N path-traced probe pixels estimate the error against the converged scene, the
            light set's bias included (``probe_error``: ``error_estimate`` becomes their upper bound,
            ``variance_estimate`` keeps the sample variance's, ``bias_estimate`` the split); 0: none.

    Returns:
        RenderResult: ``image`` (H, W, 3) float32; ``timings`` light_tree, sampling, emitted (s);
        ``budget`` samples, shadow_rays, lights; for k >= 2 ``error_estimate`` (relative L2 from the
        per-pixel sample variance of the mean, against ``A.column_sum()``: the light set's own error is not
        in it without probes) and ``error_image`` (H, W) float32 (RMS over channels).

    Raises:
        TypeError: A is not a LightMatrix, tree not a LightTree. ValueError: samples not an integer >= 1,
            a negative seed, no lights, a tree over another LightSet, error_probes < 0."""
    samples, seed = _checked(A, samples, seed, "light_bvh_sampling")
    error_probes = _v.integer("error_probes", error_probes, 0, 2**31 - 1)
    out = _native.light_bvh_sampling(A._m, samples, seed, _tree(A, tree))
    res = _result(A, out, "light_bvh_sampling", seed, {"samples": samples}, add_emitted)
    return attach_probe_error(res, A.scene, error_probes, seed) if error_probes else res


@checked_keywords()
def ris_sampling(A, samples: int = 4, candidates: int = 16, seed: int = 0, *, neighbours: int = 0, radius: int = 3,
                 tree: Optional[LightTree] = None, add_emitted: bool = True, error_probes: int = 0) -> RenderResult:
    """Resampled importance sampling over the light tree (module doc): per view sample ``samples``
    independent outputs, each resampled from M = ``candidates`` light-tree candidates by the unshadowed
    contribution, with one shadow ray; unbiased for ``A.column_sum()`` (+ ``A.emitted()``).

    Args:
        A: a ``LightMatrix``.
        samples: k >= 1 outputs (shadow rays) per view sample.
        candidates: M >= 1 candidates per output (M tree samples and unshadowed shadings each).
        neighbours: K >= 0 neighbour pixels of spatial reuse (0: none); costs up to (K + 1)^2 unshadowed
            shadings per output. Pixels then share reservoirs: ``error_estimate`` (summed per-pixel
            variances) ignores their correlation.
        radius: R >= 1, half-width in pixels of the square the neighbours are drawn from.
        seed, tree, add_emitted, error_probes: as ``light_bvh_sampling``.

    Returns:
        RenderResult as ``light_bvh_sampling``'s, ``budget`` with samples, candidates, neighbours, radius,
        shadow_rays, lights.

    Raises:
        TypeError: A is not a LightMatrix, tree not a LightTree. ValueError: samples, candidates or radius
            not an integer >= 1, neighbours < 0, a negative seed, no lights, a tree over another LightSet,
            error_probes < 0."""
    samples, seed = _checked(A, samples, seed, "ris_sampling")
    candidates = _v.integer("candidates", candidates, 1, 2**31 - 1)
    neighbours = _v.integer("neighbours", neighbours, 0, 1024)
    radius = _v.integer("radius", radius, 1, 2**31 - 1)
    error_probes = _v.integer("error_probes", error_probes, 0, 2**31 - 1)
    out = _native.ris(A._m, samples, candidates, seed, _tree(A, tree), neighbours, radius)
    budget = {"samples": samples, "candidates": candidates, "neighbours": neighbours, "radius": radius}
    res = _result(A, out, "ris_sampling", seed, budget, add_emitted)
    return attach_probe_error(res, A.scene, error_probes, seed) if error_probes else res


@checked_keywords()
def stochastic_lightcuts(A, cut_size: int = 16, samples: int = 1, seed: int = 0, *,
                         tree: Optional[LightTree] = None, add_emitted: bool = True,
                         error_probes: int = 0) -> RenderResult:
    """Stochastic Lightcuts (module doc): per view sample a cut of ``cut_size`` light-tree nodes and one
    light sampled below each, shaded exactly with one shadow ray; unbiased for ``A.column_sum()``
    (+ ``A.emitted()``).

    Args:
        A: a ``LightMatrix`` (any device; the sampling runs on the CPU with the matrix's ray tracer).
        cut_size: k >= 1 cut nodes (shadow rays) per estimate.
        samples: s >= 1 independent estimates per view sample, averaged (the cut is chosen once).
        seed: random seed (same seed, same image, any thread count).
        tree: a ``LightTree`` over ``A.lights`` to reuse (built here, and timed as ``light_tree``, if None).
        add_emitted: add what the camera sees of the emitters (``A.emitted()``).
        error_probes: as ``light_bvh_sampling``.

    Returns:
        RenderResult: ``image`` (H, W, 3) float32; ``timings`` light_tree, sampling, emitted (s);
        ``budget`` cut_size, samples, shadow_rays, lights; for s >= 2 ``error_estimate`` (relative L2 from
        the per-pixel sample variance of the mean) and ``error_image`` (H, W) float32.

    Raises:
        TypeError: A is not a LightMatrix, tree not a LightTree. ValueError: cut_size or samples not an
            integer >= 1, a negative seed, no lights, a tree over another LightSet, error_probes < 0."""
    samples, seed = _checked(A, samples, seed, "stochastic_lightcuts")
    cut_size = _v.integer("cut_size", cut_size, 1, 2**31 - 1)
    error_probes = _v.integer("error_probes", error_probes, 0, 2**31 - 1)
    out = _native.stochastic_lightcuts(A._m, cut_size, samples, seed, _tree(A, tree))
    res = _result(A, out, "stochastic_lightcuts", seed, {"cut_size": cut_size, "samples": samples}, add_emitted)
    return attach_probe_error(res, A.scene, error_probes, seed) if error_probes else res
