"""Clustered visibility with given clusterings (the 2022 paper on GPU fuzzy K-means clustering of VPLs and
shading points, Sec. 3.1 steps 5-6, Eqs. 6, 9, 10).

``clustered_shading(A, ...)`` takes a hard clustering of the lights and a fuzzy clustering of the view
samples (from ``manylights.kmeans`` or your own code), traces one exact shadow ray per pair of
representatives into a visibility matrix and shades every view sample with every light cluster, the
visibility interpolated over the sample's F nearest view clusters. It runs on the device of ``A``.
Design and choices (representatives, cluster intensities, light kinds): ``src/cluster/visibility/mod.rs``.
"""
from __future__ import annotations

import time

import numpy as np

from .. import _native
from .._utils import validate as _v
from .._utils.keywords import checked_keywords
from ..matrix.light_matrix import LightMatrix
from .bias import bias_sources
from .kmeans import COS_30_DEG
from .probe_error import attach_probe_error
from .result import RenderResult, matrix_shape, with_emitted


def _points(name: str, a) -> np.ndarray:
    arr = _v.numeric_array(name, a)
    if arr.ndim != 2 or arr.shape[1] != 3 or arr.shape[0] == 0:
        raise ValueError(f"{name} must have shape (k, 3) with k >= 1, got {np.shape(a)}")
    return _v.finite(name, arr)


@checked_keywords()
def clustered_shading(A, light_labels, light_centroids, view_centroids, view_normals, membership_clusters,
                      membership_weights, *, add_emitted: bool = True) -> RenderResult:
    """Render light matrix ``A`` by clustered visibility with the given clusterings.

    Light clusters: each label's representative is its member nearest the label's centroid, with the sum
    of the members' intensities (a label holding several light kinds is split by kind, so the number of
    light clusters K can exceed the labels used; directional lights cluster by direction). View clusters:
    the representative is the surface view sample nearest the centroid among the cluster's hard members
    (membership column 0). One exact shadow ray per (view cluster, light cluster) pair gives the
    visibility V (in a scene with masked surfaces the ray's expected transmittance through them, as the
    light matrix's element); every view sample i is shaded by every light cluster c with its own BSDF and
    geometry term and the visibility ``sum_f weights[i, f] * V(clusters[i, f], c)`` (Eq. 6 with Eq. 9). With
    every light its own label and every view sample its own cluster (F = 1) this is the brute-force image.

    Args:
        A: a ``LightMatrix`` (its device, GPU or CPU, runs both stages).
        light_labels: (n,) integers in [0, k_light): the label of each light of ``A.lights``.
        light_centroids: (k_light, 3) float, world units: each label's centroid.
        view_centroids: (k_view, 3) float, world units: each view cluster's centroid.
        view_normals: (k_view, 3) float: each view cluster's mean normal (reported, not used for shading).
        membership_clusters: (m, F) or (m,) integers in [0, k_view): each view sample's F nearest view
            clusters, nearest first. m = view samples = ``A.shape[0]`` pixels (plus the delta-chain samples
            of scenes with mirrors or glass, which follow the pixels).
        membership_weights: (m, F) or (m,) float >= 0, each row summing to 1 (Eq. 10: normalised inverse
            distances; all 1 for F = 1).
        add_emitted: add what the camera sees of emitters (``A.emitted()``), as every renderer does.

    Returns:
        RenderResult (method "clustered_visibility", seed 0: nothing is random) with image (H, W, 3) float32
        linear radiance; timings in seconds: visibility (rays into the visibility matrix), shading, emitted;
        clusters = light_labels; representatives (K,) light index of each light cluster's representative;
        budget: light_clusters K, view_clusters k_view, fuzziness F, rays (shadow rays traced), gave_up
        (GPU rays that ran out of traversal steps; 0), lights n, view_samples m.

    Raises:
        TypeError: A is not a LightMatrix, or an argument is not a real numeric array.
        ValueError: a label or cluster id out of range, non-integer labels, wrong shapes, NaN or inf in
            centroids, normals or weights, negative weights or rows not summing to 1 (within 1e-3),
            F = 0 or F > min(64, k_view), an empty light set (each message names the value and where).
    """
    m, n = matrix_shape(A)
    if n == 0:
        raise ValueError("the light matrix has no lights (n = 0): nothing to cluster")
    light_centroids = _points("light_centroids", light_centroids)
    view_centroids = _points("view_centroids", view_centroids)
    view_normals = _points("view_normals", view_normals)
    if view_normals.shape != view_centroids.shape:
        raise ValueError(f"view_normals must have the shape of view_centroids {view_centroids.shape}, "
                         f"got {view_normals.shape}")
    labels = _v.indices("light label", light_labels, len(light_centroids), f"{len(light_centroids)} light centroids")
    if len(labels) != n:
        raise ValueError(f"light_labels must have one label per light (n = {n}), got {len(labels)}")
    clusters = np.asarray(membership_clusters)
    weights = _v.numeric_array("membership_weights", membership_weights)
    if clusters.ndim == 1:
        clusters = clusters[:, None]
    if weights.ndim == 1:
        weights = weights[:, None]
    if clusters.ndim != 2 or weights.shape != clusters.shape:
        raise ValueError(f"membership_clusters and membership_weights must have one shape (m, F), got "
                         f"{np.shape(membership_clusters)} and {np.shape(membership_weights)}")
    k_view = len(view_centroids)
    flat = _v.indices("membership cluster", clusters.reshape(-1), k_view, f"{k_view} view centroids")
    _v.finite("membership_weights", weights)
    t = time.perf_counter()
    out = _native.clustered_shading(A._m, labels.astype(np.uint32), light_centroids, view_centroids, view_normals,
                                    np.ascontiguousarray(flat.reshape(clusters.shape), dtype=np.uint32),
                                    np.ascontiguousarray(weights, dtype=np.float32))
    wall = time.perf_counter() - t
    timings = {"visibility": out["visibility_seconds"], "shading": out["shading_seconds"]}
    # Validation, representatives, uploads and readback (the rest of the native call).
    timings["setup"] = max(wall - timings["visibility"] - timings["shading"], 0.0)
    image = out["image"]
    image = with_emitted(A, image, timings, add_emitted)
    budget = {"light_clusters": int(out["light_clusters"]), "view_clusters": int(out["view_clusters"]),
              "fuzziness": int(clusters.shape[1]), "rays": int(out["rays"]), "gave_up": int(out["gave_up"]),
              "lights": int(n), "view_samples": int(clusters.shape[0])}
    return RenderResult(image=image, method="clustered_visibility", seed=0, timings=timings, clusters=labels,
                        representatives=out["light_representatives"], budget=budget, device=A.device,
                        bias_sources=bias_sources(A))


def _split_budget(k: int, counts: list) -> list:
    """k clusters over groups of ``counts`` items in proportion (largest remainders), each non-empty group
    at least 1 and at most its count."""
    total = sum(counts)
    share = [k * c / total for c in counts]
    out = [min(c, max(1 if c else 0, int(s))) for c, s in zip(counts, share)]
    for i in sorted(range(len(counts)), key=lambda i: share[i] - int(share[i]), reverse=True):
        if sum(out) >= k:
            break
        if out[i] < counts[i]:
            out[i] += 1
    return out


@checked_keywords()
def clustered_visibility(A, light_clusters: int = 1000, view_clusters: int = 8000, fuzzy: int = 6, seed: int = 0, *,
                         iterations: int = 10, cos_threshold=None, downsample: int = 4, add_emitted: bool = True,
                         error_probes: int = 0):
    """Render light matrix ``A`` by clustered visibility, the whole method of Colom, Marques and Santos,
    "Interactive VPL-based global illumination on the GPU using fuzzy clustering" (Computers & Graphics 2022,
    Sec. 3, Alg. 1-2, Eqs. 6-10).

    1. The lights are clustered by K-means (``kmeans``): oriented lights (area-light samples, VPLs) by
       position with Eq. 7's orientation threshold on their normals; point and spot lights by position;
       directional lights by their direction (a point on the unit sphere), each kind with a share of
       ``light_clusters`` proportional to its count (kinds never share a cluster: their units differ).
    2. The view samples (``A.view_samples()``, background excluded) are downsampled by ``downsample``
       (one per block of that many, seeded) and clustered by K-means with the threshold; every view sample
       then gets its ``fuzzy`` nearest clusters with Eq. 10's inverse-distance weights (F = 1: hard).
    3. One exact shadow ray per (view cluster, light cluster) pair of representatives fills the
       visibility matrix; every view sample is shaded by every light cluster with its own BSDF and geometry
       term and the visibility interpolated over its F clusters (Eq. 6 with Eq. 9; ``clustered_shading``).

    Everything runs on ``A``'s device (K-means, membership, rays and shading on the GPU for a GPU matrix).

    Args:
        A: a ``LightMatrix``.
        light_clusters: K_vpl, light clusters (clipped to the number of lights).
        view_clusters: K_sp, view-sample clusters (clipped to the surface view samples).
        fuzzy: F, clusters per view sample, 1 <= F <= 16.
        seed: seeds both K-means initialisations and the downsampling.
        iterations: K-means iterations (the paper's fixed count).
        cos_threshold: Eq. 7's n_t; None = cos 30 deg, the paper's.
        downsample: the paper's downsampling factor gamma of the view samples (>= 1; lowered when fewer
            than ``view_clusters`` samples would remain).
        add_emitted: add what the camera sees of emitters, as every renderer does.

    Returns:
        RenderResult (method "clustered_visibility") with image (H, W, 3) float32; timings in seconds:
        light_clustering, view_clustering, visibility, shading, setup, emitted; budget: light_clusters,
        view_clusters, fuzziness, rays, gave_up, lights, view_samples, downsample; clusters (n,) the light
        labels; representatives of the light clusters.

    Args (besides the method's):
        error_probes: N > 0: N path-traced probe pixels estimate the error against the converged scene, bias
            included (``probe_error``: ``error_estimate`` the upper bound, ``bias_estimate``); 0: none.

    Raises:
        TypeError: A is not a LightMatrix. ValueError: light_clusters or view_clusters < 1, fuzzy outside
            [1, 16], iterations < 0, downsample < 1, a threshold outside [-1, 1], an empty light set, a
            scene with no surface in view.
    """
    if not isinstance(A, LightMatrix):
        raise TypeError(f"A must be a LightMatrix, got {type(A).__name__}")
    m, n = matrix_shape(A)
    error_probes = _v.integer("error_probes", error_probes, 0, 2**31 - 1)
    if n == 0:
        raise ValueError("the light matrix has no lights (n = 0): nothing to cluster")
    light_clusters = _v.integer("light_clusters", light_clusters, 1, 2**31)
    view_clusters = _v.integer("view_clusters", view_clusters, 1, 2**31)
    fuzzy = _v.integer("fuzzy", fuzzy, 1, 16)
    iterations = _v.integer("iterations", iterations, 0, 2**31)
    downsample = _v.integer("downsample", downsample, 1, 2**31)
    seed = _v.seed(seed)
    threshold = COS_30_DEG if cos_threshold is None else _v.real("cos_threshold", cos_threshold, -1.0, 1.0)
    device = A.device.get("kind", "cpu")
    timings = {}

    t = time.perf_counter()
    L = A.lights
    kind = np.asarray(L.kind)
    groups = [(np.flatnonzero((kind == 3) | (kind == 4)), "oriented"), (np.flatnonzero((kind == 0) | (kind == 1)), "point"),
              (np.flatnonzero(kind == 2), "directional")]
    ks = _split_budget(min(light_clusters, n), [len(g) for g, _ in groups])
    labels = np.zeros(n, np.int64)
    centroids = []
    for (idx, what), k in zip(groups, ks):
        if len(idx) == 0:
            continue
        if what == "directional":
            pts, nrm = np.asarray(L.direction)[idx], None
        else:
            pts = np.asarray(L.position)[idx]
            nrm = np.asarray(L.normal)[idx] if what == "oriented" else None
        res = _native.kmeans(np.ascontiguousarray(pts, np.float32),
                             None if nrm is None else np.ascontiguousarray(nrm, np.float32), k, iterations,
                             0.0, threshold if nrm is not None else None, True, device, seed)
        labels[idx] = np.asarray(res["labels"]) + sum(len(c) for c in centroids)
        centroids.append(np.asarray(res["centroids"], np.float32))
    centroids = np.concatenate(centroids)
    timings["light_clustering"] = time.perf_counter() - t

    t = time.perf_counter()
    vs = A.view_samples()
    surface = np.flatnonzero(vs["surface"])
    if len(surface) == 0:
        raise ValueError("no view sample sees a surface (an empty image): nothing to shade")
    kv = min(view_clusters, len(surface))
    vc = _native.cluster_view_samples(np.ascontiguousarray(vs["position"][surface]),
                                      np.ascontiguousarray(vs["normal"][surface]), kv, downsample,
                                      min(fuzzy, kv), iterations, threshold, True, device, seed)
    f = vc["clusters"].shape[1]
    members = np.zeros((len(vs["surface"]), f), np.int64)
    weights = np.zeros((len(vs["surface"]), f), np.float32)
    weights[:, 0] = 1.0  # background samples: any cluster, weight 1 (never shaded)
    members[surface] = vc["clusters"]
    weights[surface] = vc["weights"]
    timings["view_clustering"] = time.perf_counter() - t

    res = clustered_shading(A, labels, centroids, vc["centroids"], vc["centroid_normals"], members, weights,
                            add_emitted=add_emitted)
    res.timings = {**timings, **res.timings}
    res.seed = seed
    res.budget = {**res.budget, "downsample": int(vc["gamma"]), "kmeans_iterations": iterations}
    return attach_probe_error(res, A.scene, error_probes, seed) if error_probes else res
