"""Stochastic Lightcuts (Yuksel, "Stochastic Lightcuts", HPG 2019) on the light matrix's exact shading.

Per view sample: a cut of the light tree (``LightTree``) chosen by Lightcuts-style refinement (the node with
the largest error bound, intensity x receiver cosine bound x orientation bound / clamped squared distance,
is replaced by its children until the cut has ``cut_size`` nodes), then one light drawn below each cut node
by descending its subtree with the paper's importance (the mean of the children's normalised weights at the
nearest and at the farthest point of their boxes; a receiver inside a child's box gives that child the
nearest-distance share). Each drawn light is shaded exactly with one shadow ray and weighted by 1 / pdf, so
the image is unbiased for ``A.column_sum()``.

Deviations from the paper (details in ``src/baselines/stochastic_lightcuts.rs``): the bound's distance is
clamped at 0.3 of the node's box diagonal (the authors' real-time code: 0.1, which left a point light among
VPLs unrefined on cbox-lights, 3x the squared error); the tree is pbrt-v4's
SAOH light tree (not the paper's Morton build); the material bound is omitted (constant on diffuse
receivers); directional lights and environment strata form a second tree over their directions joined
at the root; where both children's weights vanish a child is picked by power (so pdfs always sum to 1).

Symbols: k = ``cut_size`` (shadow rays per estimate), s = ``samples`` (estimates per view sample).
"""
from __future__ import annotations

from typing import Optional

from .. import _native
from .._native import LightTree
from .._utils import validate as _v
from .._utils.keywords import checked_keywords
from .light_tree import _checked, _result, _tree


@checked_keywords()
def stochastic_lightcuts(A, cut_size: int = 16, samples: int = 1, seed: int = 0, *,
                         tree: Optional[LightTree] = None, add_emitted: bool = True):
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

    Returns:
        RenderResult: ``image`` (H, W, 3) float32; ``timings`` light_tree, sampling, emitted (s);
        ``budget`` cut_size, samples, shadow_rays, lights; for s >= 2 ``error_estimate`` (relative L2 from
        the per-pixel sample variance of the mean) and ``error_image`` (H, W) float32.

    Raises:
        TypeError: A is not a LightMatrix, tree not a LightTree. ValueError: cut_size or samples not an
            integer >= 1, a negative seed, no lights, a tree over another LightSet."""
    samples, seed = _checked(A, samples, seed, "stochastic_lightcuts")
    cut_size = _v.integer("cut_size", cut_size, 1, 2**31 - 1)
    out = _native.stochastic_lightcuts(A._m, cut_size, samples, seed, _tree(A, tree))
    return _result(A, out, "stochastic_lightcuts", seed, {"cut_size": cut_size, "samples": samples}, add_emitted)
