"""K-means of surface data points (position, normal) on the GPU, and distance-based fuzzy membership.

The clustering of Colom, Marques and Santos, "Interactive VPL-based global illumination on the GPU using
fuzzy clustering" (Computers & Graphics, 2022; Sec. 3.2-3.3, Eq. 7-10, Alg. 1-2), used by clustered visibility for both the VPLs and the view
samples. The Rust core is ``src/cluster/kmeans/`` (GPU passes in ``src/gpu/kmeans.rs`` and
``shaders/kmeans.wgsl``; a CPU twin for ``device="cpu"`` and tests).

- Distance (Eq. 7): ``|p1 - p2|`` when ``n1 . n2 > cos_threshold``, infinite otherwise (default
  ``cos_threshold`` = cos 30 deg = sqrt(3)/2, the paper's value; ``None`` or ``normals=None``: Euclidean).
  Equal distances go to the lower centroid index.
- Initial centroids: ``k`` distinct data points drawn uniformly with ``seed`` (the paper's "subset of K
  points of D").
- Each iteration: the assignment step (nearest centroid; on the GPU through a regular grid over the
  centroids rebuilt every iteration, searched in expanding shells so that it equals the exhaustive search),
  then the reduction step (centroid = mean position, normalised mean normal, summed with integer atomics in
  64-bit fixed point: steps of 2^-24 of the data's bounding box, CPU and GPU agree to ~1e-7 of the box).
- A point whose normal is within the threshold of no centroid goes to the nearest centroid by position
  (the paper does not say); an empty cluster keeps its centroid.
- ``objective[t]``: sum of squared distances of the points to their nearest centroid after t updates
  (t = 0 ..= iterations), as scikit-learn's ``inertia_``. It never rises with the threshold off.

Symbols (paper -> here):

=====================================  ==============================================
D, M, d_m = (p, n)                     ``points``, ``len(points)``, ``points[m]``, ``normals[m]``
K, C = {c_k}                           ``k``, ``centroids`` / ``centroid_normals``
A (assignment vector, Alg. 1)          ``labels``
n_t (orientation threshold, Eq. 7)     ``cos_threshold``
G (regular grid, Alg. 1 line 5)        ``grid=True``
F, I_m, w_f (Alg. 2, Eq. 10)           ``f``, ``clusters`` row, ``weights`` row
=====================================  ==============================================
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from .. import _native
from .._utils import validate as _v
from .._utils.keywords import checked_keywords

#: The paper's orientation threshold: cos(pi / 6) = sqrt(3) / 2.
COS_30_DEG = math.sqrt(3.0) / 2.0


@dataclass
class KMeansResult:
    """What ``kmeans`` returns."""

    #: (k, 3) float32 centroid positions (the units of ``points``).
    centroids: np.ndarray
    #: (k, 3) float32 unit centroid normals (zeros when ``normals`` was None).
    centroid_normals: np.ndarray
    #: (N,) int64: each point's nearest centroid (Eq. 7 order) for the final centroids.
    labels: np.ndarray
    #: iterations + 1 floats: sum of squared distances to the nearest centroid after t updates.
    objective: list = field(default_factory=list)
    #: update steps run (fewer than asked when ``tolerance`` stopped early).
    iterations: int = 0
    #: (k,) int64: indices of the points chosen as initial centroids.
    initial: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    #: seconds per stage: setup, iterations, readback, total.
    timings: dict = field(default_factory=dict)
    #: "gpu" or "cpu".
    device: str = ""
    seed: int = 0

    @property
    def k(self) -> int:
        return int(len(self.centroids))


def _triples(name: str, a, n: Optional[int] = None) -> np.ndarray:
    arr = _v.numeric_array(name, a)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"{name} must have shape (N, 3), got {arr.shape}")
    if n is not None and arr.shape[0] != n:
        raise ValueError(f"{name} must have shape ({n}, 3) (one row per point), got {arr.shape}")
    return _v.finite(name, arr)


def _threshold(cos_threshold) -> Optional[float]:
    return None if cos_threshold is None else _v.real("cos_threshold", cos_threshold, -1.0, 1.0)


def _device(device) -> str:
    if not isinstance(device, str):
        raise ValueError(f"device must be 'auto', 'gpu' or 'cpu', got {device!r}")
    return device


@checked_keywords()
def kmeans(points, normals, k: int, *, iterations: int = 10, tolerance: float = 0.0,
           cos_threshold: Optional[float] = COS_30_DEG, grid: bool = True, device: str = "auto",
           seed: int = 0) -> KMeansResult:
    """K-means of N surface points with the paper's orientation-thresholded distance (Sec. 3.2.1, Eq. 7;
    Alg. 1, without downsampling: pass the subset you want clustered).

    Args:
        points: (N, 3) float32 positions (any real dtype is converted), scene units.
        normals: (N, 3) normals (normalised here; zero rows are refused while the threshold is on), or
            None: no orientation term.
        k: number of clusters, 1 <= k <= N.
        iterations: most update steps, >= 0 (0 returns the initial centroids and their assignment).
        tolerance: stop when the objective falls by no more than ``tolerance`` times its previous value;
            0 (default) runs exactly ``iterations`` updates.
        cos_threshold: Eq. 7's n_t, a cosine in [-1, 1]; None switches it off (ignored when normals is None).
        grid: on the GPU, search the nearest centroid through the regular grid over the centroids (the
            result equals the exhaustive search; False is for comparisons).
        device: "gpu" (wgpu, software adapters included), "cpu" (the Rust reference) or "auto"
            (``MANYLIGHTS_DEVICE``, else a hardware GPU, else the CPU).
        seed: seed of the initial centroids (the same seed gives the same result on the same device).

    Returns:
        KMeansResult: centroids (k, 3), centroid_normals (k, 3), labels (N,) int64, objective per
        iteration, iterations, initial centroid indices, timings (seconds), device.

    Raises:
        ValueError: k outside [1, N], negative iterations or tolerance, shapes other than (N, 3), NaN/inf
            values (index named), zero normals with the threshold on, cos_threshold outside [-1, 1], an
            unknown device.
        TypeError: non-numeric arrays.
        GpuUnavailableError: device="gpu" without any adapter.
    """
    p = _triples("points", points)
    nrm = None if normals is None else _triples("normals", normals, len(p))
    if len(p) == 0:
        raise ValueError("points must hold at least one point, got shape (0, 3)")
    k = _v.integer("k", k, 1, len(p))
    iterations = _v.integer("iterations", iterations, 0, 2**31 - 1)
    tolerance = _v.real("tolerance", tolerance, 0.0)
    seed = _v.seed(seed)
    d = _native.kmeans(p, nrm, k, iterations, tolerance, _threshold(cos_threshold), bool(grid), _device(device), seed)
    return KMeansResult(centroids=d["centroids"], centroid_normals=d["centroid_normals"], labels=d["labels"],
                        objective=list(d["objective"]), iterations=int(d["iterations"]), initial=d["initial"],
                        timings=dict(d["timings"]), device=d["device"], seed=seed)


@checked_keywords()
def fuzzy_membership(points, normals, centroids, centroid_normals, f: int = 6, *,
                     cos_threshold: Optional[float] = COS_30_DEG, grid: bool = True,
                     device: str = "auto") -> dict:
    """The F nearest clusters of each point and the paper's inverse-distance weights (Sec. 3.2.2, Alg. 2,
    Eq. 10: ``w_f = (1 / dist_f) / sum_g (1 / dist_g)``). F = 1 is the hard assignment.

    Where Eq. 10 is undefined: an inadmissible cluster (Eq. 7 distance infinite) weighs 0; a point with no
    admissible cluster among its F uses the Euclidean distances; a cluster at distance 0 takes all the
    weight (shared equally among several).

    Args:
        points: (N, 3) float32 positions; normals: (N, 3) or None (threshold off).
        centroids: (k, 3) float32; centroid_normals: (k, 3) or None (must be None exactly when normals is).
        f: clusters per point, 1 <= f <= min(k, 16); the paper uses 6.
        cos_threshold: Eq. 7's n_t in [-1, 1], or None.
        grid: use the regular grid on the GPU (same result).
        device: "auto", "gpu" or "cpu".

    Returns:
        dict: clusters (N, f) int64 (nearest first), weights (N, f) float32 (each row sums to 1),
        distances (N, f) float32 Euclidean, admissible (N, f) bool, device.

    Raises:
        ValueError: f out of range, bad shapes, NaN/inf, zero normals with the threshold on, normals given
            for only one side, cos_threshold outside [-1, 1], an unknown device.
    """
    p = _triples("points", points)
    c = _triples("centroids", centroids)
    if (normals is None) != (centroid_normals is None):
        raise ValueError("give both normals and centroid_normals, or neither (got one of them as None)")
    nrm = None if normals is None else _triples("normals", normals, len(p))
    cnm = None if centroid_normals is None else _triples("centroid_normals", centroid_normals, len(c))
    if len(p) == 0 or len(c) == 0:
        raise ValueError(f"need at least one point and one centroid, got {len(p)} points and {len(c)} centroids")
    f = _v.integer("f", f, 1, min(len(c), 16))
    return _native.fuzzy_membership(p, nrm, c, cnm, f, _threshold(cos_threshold), bool(grid), _device(device))
