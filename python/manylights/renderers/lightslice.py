"""LightSlice (Ou and Pellacini, "LightSlice: Matrix Slice Sampling for the Many-Lights Problem", SIGGRAPH
Asia 2011), the successor of Matrix Row-Column Sampling.

1. slices: the pixels that see a surface are split top-down (kd-tree over normalised position and
   ``normal_weight`` x normal, median of the widest dimension of the largest slice) into ``slices`` slices;
2. rows: one random pixel per slice, its row of A rendered on the matrix's device (reduced matrix R);
3. global clustering: MRCS's clustering of R (``cluster_reduced_columns``) into ``global_columns``;
4. local refinement: per slice, the rows of its ``neighbours`` nearest slices (itself included) form R_s,
   and the global cluster of largest MRCS cost on R_s is split (MRCS's random-line split) until the slice
   has ``columns`` clusters;
5. reconstruction: per slice one representative per cluster, drawn by its norm on R_s and weighted
   1 / probability, shades the slice's pixels (CPU, exact shadow rays).

Deviations from the paper: the slicing features and their weight, and the distance between slices, are this
library's choices; columns that are zero on every row of R_s keep a small draw probability (``ZERO_SHARE``
= 0.25 x their share of the cluster, proportional to their norm on R, else power), so the image is unbiased
given the clustering, where the paper drops them; grey weights (no colour averaging); the reconstruction
runs on the CPU whatever the matrix's device. Details: ``src/baselines/lightslice.rs``.

Symbols: S slices, c = ``columns`` clusters per slice, c_g = ``global_columns``, k = ``neighbours``.
"""
from __future__ import annotations

from typing import Optional

import numpy as np

from .. import _native
from .._utils import validate as _v
from .._utils.keywords import checked_keywords
from .bias import bias_sources
from .probe_error import attach_probe_error
from .result import RenderResult, matrix_shape, with_emitted


@checked_keywords()
def lightslice(A, slices: int = 256, columns: int = 300, seed: int = 0, *, global_columns: Optional[int] = None,
               neighbours: int = 16, normal_weight: float = 0.25, add_emitted: bool = True,
               error_probes: int = 0) -> RenderResult:
    """Render the column sum of light matrix ``A`` by LightSlice (module doc).

    Args:
        A: a ``LightMatrix``.
        slices: S >= 1 slices = sampled rows (at most the pixels that see a surface; fewer are made then).
        columns: c >= 1 clusters (representative lights, shadow rays) per slice (at most n).
        seed: seeds the row choice, the clusterings and the representatives.
        global_columns: c_g in [1, c] clusters of the global clustering (default c // 2, at least 1).
        neighbours: k >= 1 slices whose rows refine each slice's clustering (itself included).
        normal_weight: >= 0, weight of the unit normal against the position (scaled to the visible
            points' bounding-box diagonal) in the slicing features.
        add_emitted: add what the camera sees of emitters (``A.emitted()``).
        error_probes: N > 0: N path-traced probe pixels estimate the error against the converged scene, the
            light set's bias included (``probe_error``: ``error_estimate`` becomes their upper bound,
            ``bias_estimate`` and ``budget["probes"]`` their details, ``timings["probes"]`` their cost).

    Returns:
        RenderResult with image (H, W, 3) float32, rows (S,) int64 (each slice's row), clusters (n,) int64
        (the global clustering's labels), the attribute ``slices`` (H, W) int32 (slice of each pixel, -1
        without a surface), timings per stage in seconds (slicing, rows, clustering, refinement,
        columns, emitted), budget rows, columns, global_columns, neighbours, shadow_rays, lights.

    Raises:
        TypeError: A is not a LightMatrix. ValueError: slices, columns, global_columns or neighbours not
            an integer >= 1, global_columns > columns, normal_weight negative or not finite, a negative
            seed, no lights, no pixel that sees a surface, error_probes < 0."""
    m, n = matrix_shape(A)
    if n == 0:
        raise ValueError("lightslice needs lights (the light matrix has n = 0)")
    slices = _v.integer("slices", slices, 1, 2**31 - 1)
    columns = _v.integer("columns", columns, 1, 2**31 - 1)
    global_columns = max(1, columns // 2) if global_columns is None else _v.integer("global_columns",
                                                                                     global_columns, 1, 2**31 - 1)
    if global_columns > columns:
        raise ValueError(f"global_columns ({global_columns}) must not exceed columns ({columns}): each slice "
                         f"refines the global clustering")
    neighbours = _v.integer("neighbours", neighbours, 1, 2**31 - 1)
    normal_weight = _v.real("normal_weight", normal_weight, 0.0, float("inf"))
    seed = _v.seed(seed)
    error_probes = _v.integer("error_probes", error_probes, 0, 2**31 - 1)
    out = _native.lightslice(A._m, slices, min(columns, n), min(global_columns, n), neighbours, normal_weight,
                             seed)
    timings = {k: float(v) for k, v in out["timings"].items()}
    image = np.asarray(out["image"], dtype=np.float32)
    image = with_emitted(A, image, timings, add_emitted)
    rows = np.asarray(out["rows"], dtype=np.int64)
    budget = {"rows": int(len(rows)), "columns": int(min(columns, n)), "global_columns": int(min(global_columns, n)),
              "neighbours": neighbours, "shadow_rays": int(out["shadow_rays"]), "lights": int(n)}
    res = RenderResult(image=image, method="lightslice", seed=seed, timings=timings, rows=rows,
                       clusters=np.asarray(out["global_assignment"], dtype=np.int64), budget=budget,
                       device=A.device, bias_sources=bias_sources(A))
    res.slices = np.asarray(out["slices"], dtype=np.int32)
    return attach_probe_error(res, A.scene, error_probes, seed) if error_probes else res
