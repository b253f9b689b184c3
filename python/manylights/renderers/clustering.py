"""Clustering of reduced columns, the second step of Matrix Row-Column Sampling (Hašan, Pellacini, Bala 2007,
Sec. 3-4).

| symbol | name |
|---|---|
| R | reduced matrix (r x n): the rows of A at the sampled view samples |
| rho_j | reduced column j of R |
| c | number of clusters (columns rendered) |
"""
from __future__ import annotations

import numpy as np

from .. import _native
from .._utils import validate as _v
from .._utils.keywords import checked_keywords


@checked_keywords()
def cluster_reduced_columns(R, c: int, *, seed: int = 0, power=None, projection_dim: int = 50,
                            sampling_fraction: float = 2.0 / 3.0, color_averaging: bool = False) -> dict:
    """Cluster the reduced columns of a reduced matrix as Matrix Row-Column Sampling does (Hašan et al. 2007).

    Args:
        R: (r, n, 3) RGB or (r, n) scalar reduced matrix (any float dtype; converted to float32).
        c: number of clusters (1 <= c <= n).
        seed: seeds the random projection, the sampling, the splitting lines and the representatives.
        power: optional (n,) light powers, used to pick representatives of zero-norm reduced columns.
        projection_dim: r' of the random Gaussian projection applied when r > r'.
        sampling_fraction: share of the clusters made by sampling before top-down splitting (paper: 2/3).
        color_averaging: the paper's per-channel representative scaling (biased; off = unbiased grey weights).

    Returns:
        dict with assignment (n,), representatives (c,), weights (c, 3), cost, cluster_costs (c,),
        probability (n,) float64 (chance of each light being its cluster's representative).

    Raises:
        ValueError: bad shapes, NaN/inf (row and column named), c not an integer in [1, n], a negative or
            non-integer seed, power of the wrong length / negative / NaN, sampling_fraction outside [0, 1].
        TypeError: a non-numeric (complex, string) R or power.
    """
    R = _v.numeric_array("R", R)
    if power is not None:
        power = _v.numeric_array("power", power).reshape(-1)
    return _native.cluster_reduced_columns(R, _v.integer("c", c, 1, 2**63 - 1), _v.seed(seed), power,
                                           _v.integer("projection_dim", projection_dim, 1, 2**63 - 1),
                                           _v.real("sampling_fraction", sampling_fraction, 0.0, 1.0),
                                           bool(color_averaging))


@checked_keywords()
def clustering_cost(R, assignment) -> float:
    """Sum of the paper's cluster costs of a partition (assignment (n,)) on the scalar reduced matrix.

    Raises:
        ValueError: labels that are not integers in [0, 2^31), an assignment not of length n, NaN/inf in R."""
    R = _v.numeric_array("R", R)
    labels = np.asarray(assignment)
    if labels.dtype.kind not in "iu":
        raise ValueError(f"assignment labels must be integers, got dtype {labels.dtype}")
    if labels.size and (labels.min() < 0 or labels.max() > np.iinfo(np.int32).max):
        raise ValueError(f"assignment labels must be in [0, 2^31), got {labels.min()} .. {labels.max()}")
    return _native.clustering_cost(R, np.ascontiguousarray(labels, dtype=np.int32))
