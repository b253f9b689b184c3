"""Bad-input cases: clustering (reduced columns, k-means, fuzzy membership, tensors, clustered shading)
and the animation metrics."""
from __future__ import annotations

import numpy as np

from .common import IMG, R, _nan_at, cases_for

# --------------------------------------------------------------------------------------------------
# Clustering.

cases_for("cluster_reduced_columns", [
    ("4 channels", lambda c: c.ml.cluster_reduced_columns(R(4, 10, 4), 3), ["shape"]),
    ("1-D", lambda c: c.ml.cluster_reduced_columns(R(10), 3), ["shape"]),
    ("no rows", lambda c: c.ml.cluster_reduced_columns(R(0, 10, 3), 3), ["r"]),
    ("no columns", lambda c: c.ml.cluster_reduced_columns(R(4, 0, 3), 1), ["n"]),
    ("NaN (names row and column)", lambda c: c.ml.cluster_reduced_columns(_nan_at(R(4, 10, 3), (2, 7, 1)), 3),
     ["row 2", "column 7"]),
    ("inf", lambda c: c.ml.cluster_reduced_columns(_nan_at(R(4, 10), (1, 3), np.inf), 3), ["row 1", "column 3"]),
    ("c = 0", lambda c: c.ml.cluster_reduced_columns(R(4, 10, 3), 0), ["c"]),
    ("c > n", lambda c: c.ml.cluster_reduced_columns(R(4, 10, 3), 11), ["c"]),
    ("negative c", lambda c: c.ml.cluster_reduced_columns(R(4, 10, 3), -2), ["c"]),
    ("huge c", lambda c: c.ml.cluster_reduced_columns(R(4, 10, 3), 2**70), ["c"]),
    ("fractional c", lambda c: c.ml.cluster_reduced_columns(R(4, 10, 3), 2.5), ["c"]),
    ("power wrong length", lambda c: c.ml.cluster_reduced_columns(R(4, 10, 3), 3, power=np.ones(9)), ["power"]),
    ("NaN power", lambda c: c.ml.cluster_reduced_columns(R(4, 10, 3), 3, power=_nan_at(np.ones(10), 4)),
     ["power"]),
    ("negative power", lambda c: c.ml.cluster_reduced_columns(R(4, 10, 3), 3, power=-np.ones(10)), ["power"]),
    ("projection_dim 0", lambda c: c.ml.cluster_reduced_columns(R(4, 10, 3), 3, projection_dim=0),
     ["projection_dim"]),
    ("NaN sampling_fraction", lambda c: c.ml.cluster_reduced_columns(R(4, 10, 3), 3, sampling_fraction=np.nan),
     ["sampling_fraction"]),
    ("sampling_fraction 2", lambda c: c.ml.cluster_reduced_columns(R(4, 10, 3), 3, sampling_fraction=2.0),
     ["sampling_fraction"]),
    ("negative seed", lambda c: c.ml.cluster_reduced_columns(R(4, 10, 3), 3, seed=-1), ["seed"]),
    ("complex dtype", lambda c: c.ml.cluster_reduced_columns(np.zeros((4, 10), complex), 3), ["complex"]),
    ("strings", lambda c: c.ml.cluster_reduced_columns(np.full((4, 10), "x"), 3), ["x"]),
], raises=("ValueError", "TypeError"))
cases_for("clustering_cost", [
    ("assignment wrong length", lambda c: c.ml.clustering_cost(R(4, 10, 3), np.zeros(9, np.int64)), ["assignment"]),
    ("negative label", lambda c: c.ml.clustering_cost(R(4, 10, 3), -np.ones(10, np.int64)), ["label"]),
    ("fractional labels", lambda c: c.ml.clustering_cost(R(4, 10, 3), np.full(10, 0.5)), ["integer"]),
    ("huge label", lambda c: c.ml.clustering_cost(R(4, 10, 3), np.full(10, 2**40, np.int64)), ["label"]),
    ("NaN in R", lambda c: c.ml.clustering_cost(_nan_at(R(4, 10), (0, 0)), np.zeros(10, np.int64)), ["row 0"]),
    ("bad R shape", lambda c: c.ml.clustering_cost(R(4, 10, 2), np.zeros(10, np.int64)), ["shape"]),
])

# K-means and fuzzy membership.
KP = lambda n=20: np.random.default_rng(2).random((n, 3), dtype=np.float32)  # noqa: E731
KN = lambda n=20: np.tile(np.array([[0, 0, 1]], np.float32), (n, 1))  # noqa: E731
cases_for("kmeans", [
    ("k = 0", lambda c: c.ml.kmeans(KP(), KN(), 0), ["k", "got 0"]),
    ("k > N", lambda c: c.ml.kmeans(KP(), KN(), 21), ["k", "got 21"]),
    ("negative k", lambda c: c.ml.kmeans(KP(), KN(), -3), ["k", "-3"]),
    ("fractional k", lambda c: c.ml.kmeans(KP(), KN(), 2.5), ["k", "2.5"]),
    ("huge k", lambda c: c.ml.kmeans(KP(), KN(), 2**70), ["k"]),
    ("NaN point", lambda c: c.ml.kmeans(_nan_at(KP(), (4, 1)), KN(), 3), ["points", "(4, 1)"]),
    ("inf normal", lambda c: c.ml.kmeans(KP(), _nan_at(KN(), (2, 0), np.inf), 3), ["normals", "(2, 0)"]),
    ("zero normal", lambda c: c.ml.kmeans(KP(), _nan_at(KN(), (5, 2), 0.0), 3), ["normal 5", "zero"]),
    ("points (N, 2)", lambda c: c.ml.kmeans(KP()[:, :2], None, 3), ["points", "(N, 3)", "(20, 2)"]),
    ("normals rows differ", lambda c: c.ml.kmeans(KP(), KN(19), 3), ["normals", "(19, 3)"]),
    ("no points", lambda c: c.ml.kmeans(np.zeros((0, 3), np.float32), None, 1), ["at least one"]),
    ("negative iterations", lambda c: c.ml.kmeans(KP(), KN(), 3, iterations=-1), ["iterations", "-1"]),
    ("NaN tolerance", lambda c: c.ml.kmeans(KP(), KN(), 3, tolerance=np.nan), ["tolerance", "nan"]),
    ("negative tolerance", lambda c: c.ml.kmeans(KP(), KN(), 3, tolerance=-0.5), ["tolerance", "-0.5"]),
    ("threshold > 1", lambda c: c.ml.kmeans(KP(), KN(), 3, cos_threshold=1.5), ["cos_threshold", "1.5"]),
    ("threshold < -1", lambda c: c.ml.kmeans(KP(), KN(), 3, cos_threshold=-2), ["cos_threshold", "-2"]),
    ("bad device", lambda c: c.ml.kmeans(KP(), KN(), 3, device="tpu"), ["device", "tpu"]),
    ("negative seed", lambda c: c.ml.kmeans(KP(), KN(), 3, seed=-1), ["seed", "-1"]),
    ("complex points", lambda c: c.ml.kmeans(np.zeros((4, 3), complex), None, 1), ["complex"]),
], raises=("ValueError", "TypeError"))
cases_for("fuzzy_membership", [
    ("f = 0", lambda c: c.ml.fuzzy_membership(KP(), KN(), KP(5), KN(5), 0), ["f", "got 0"]),
    ("f > k", lambda c: c.ml.fuzzy_membership(KP(), KN(), KP(5), KN(5), 6), ["f", "got 6"]),
    ("f > 16", lambda c: c.ml.fuzzy_membership(KP(), KN(), KP(20), KN(20), 17), ["f", "got 17"]),
    ("NaN centroid", lambda c: c.ml.fuzzy_membership(KP(), KN(), _nan_at(KP(5), (3, 0)), KN(5), 2),
     ["centroids", "(3, 0)"]),
    ("one side's normals", lambda c: c.ml.fuzzy_membership(KP(), KN(), KP(5), None, 2), ["normals"]),
    ("centroid normals rows", lambda c: c.ml.fuzzy_membership(KP(), KN(), KP(5), KN(4), 2),
     ["centroid_normals", "(4, 3)"]),
    ("no centroids", lambda c: c.ml.fuzzy_membership(KP(), None, np.zeros((0, 3), np.float32), None, 1),
     ["0 centroids"]),
    ("threshold NaN", lambda c: c.ml.fuzzy_membership(KP(), KN(), KP(5), KN(5), 2, cos_threshold=np.nan),
     ["cos_threshold", "nan"]),
    ("bad device", lambda c: c.ml.fuzzy_membership(KP(), KN(), KP(5), KN(5), 2, device=3), ["device", "3"]),
], raises=("ValueError", "TypeError"))
# The native functions behind them (checks that hold without the Python wrapper).
cases_for("native.kmeans", [
    ("k = 0", lambda c: c.native.kmeans(KP(), KN(), 0), ["k", "got 0"]),
    ("k > N", lambda c: c.native.kmeans(KP(), KN(), 21), ["k", "got 21"]),
    ("negative iterations", lambda c: c.native.kmeans(KP(), KN(), 3, -4), ["iterations", "-4"]),
    ("NaN point", lambda c: c.native.kmeans(_nan_at(KP(), (6, 2)), KN(), 3), ["point 6"]),
    ("shape", lambda c: c.native.kmeans(np.zeros((5, 4), np.float32), None, 1), ["(N, 3)", "[5, 4]"]),
    ("normals rows", lambda c: c.native.kmeans(KP(), KN(3), 2), ["normals", "3 rows"]),
    ("threshold", lambda c: c.native.kmeans(KP(), KN(), 2, 10, 0.0, 3.0), ["cos_threshold", "3"]),
    ("negative tolerance", lambda c: c.native.kmeans(KP(), KN(), 2, 10, -1.0), ["tolerance", "-1"]),
    ("device", lambda c: c.native.kmeans(KP(), KN(), 2, device="quantum"), ["device", "quantum"]),
])
cases_for("native.fuzzy_membership", [
    ("f = 0", lambda c: c.native.fuzzy_membership(KP(), KN(), KP(5), KN(5), 0), ["F", "got 0"]),
    ("f > k", lambda c: c.native.fuzzy_membership(KP(), KN(), KP(5), KN(5), 9), ["F", "got 9"]),
    ("negative f", lambda c: c.native.fuzzy_membership(KP(), KN(), KP(5), KN(5), -1), ["f", "-1"]),
    ("one side's normals", lambda c: c.native.fuzzy_membership(KP(), None, KP(5), KN(5), 2), ["normals"]),
    ("NaN normal", lambda c: c.native.fuzzy_membership(KP(), _nan_at(KN(), (1, 1)), KP(5), KN(5), 2), ["normal 1"]),
])

# Tensor clustering and the animation metrics.
T4 = lambda *shape: np.random.default_rng(1).random(shape, dtype=np.float32)  # noqa: E731
cases_for("cluster_tensor", [
    ("columns below f", lambda c: c.ml.cluster_tensor(T4(4, 5, 3, 3), 2), ["columns", "[3, 15]"]),
    ("columns above n f", lambda c: c.ml.cluster_tensor(T4(4, 5, 3, 3), 16), ["columns", "[3, 15]"]),
    ("huge columns", lambda c: c.ml.cluster_tensor(T4(4, 5, 3, 3), 2**70), ["columns"]),
    ("fractional columns", lambda c: c.ml.cluster_tensor(T4(4, 5, 3, 3), 4.5), ["columns"]),
    ("chunk 0", lambda c: c.ml.cluster_tensor(T4(4, 5, 3, 3), 5, chunk=0), ["chunk"]),
    ("init_clusters 0", lambda c: c.ml.cluster_tensor(T4(4, 5, 3, 3), 5, init_clusters=0), ["init_clusters"]),
    ("projection_dim 0", lambda c: c.ml.cluster_tensor(T4(4, 5, 3, 3), 5, projection_dim=0), ["projection_dim"]),
    ("2 channels", lambda c: c.ml.cluster_tensor(T4(4, 5, 3, 2), 5), ["shape"]),
    ("2-D", lambda c: c.ml.cluster_tensor(T4(4, 5), 5), ["shape"]),
    ("no frames", lambda c: c.ml.cluster_tensor(T4(4, 5, 0, 3), 5), ["frame"]),
    ("NaN (names row, light, frame)", lambda c: c.ml.cluster_tensor(_nan_at(T4(4, 5, 3, 3), (3, 2, 1, 0)), 5),
     ["row 3", "light 2", "frame 1"]),
    ("unknown representative", lambda c: c.ml.cluster_tensor(T4(4, 5, 3, 3), 5, representative="min"),
     ["representative"]),
    ("negative seed", lambda c: c.ml.cluster_tensor(T4(4, 5, 3, 3), 5, seed=-1), ["seed"]),
    ("complex dtype", lambda c: c.ml.cluster_tensor(np.zeros((4, 5, 3, 3), complex), 5), ["complex"]),
], raises=("ValueError", "TypeError"))
cases_for("native.cluster_tensor", [
    ("native: columns below f", lambda c: c.native.cluster_tensor(T4(4, 5, 3, 3), 2), ["columns"]),
    ("native: columns above n f", lambda c: c.native.cluster_tensor(T4(4, 5, 3, 3), 16), ["columns"]),
    ("native: chunk 0", lambda c: c.native.cluster_tensor(T4(4, 5, 3, 3), 5, 0, 0), ["chunk"]),
    ("native: bad shape", lambda c: c.native.cluster_tensor(T4(4, 5, 3, 2), 5), ["shape"]),
    ("native: NaN", lambda c: c.native.cluster_tensor(_nan_at(T4(4, 5, 3, 3), (0, 4, 2, 2)), 5),
     ["light 4", "frame 2"]),
    ("native: unknown representative", lambda c: c.native.cluster_tensor(T4(4, 5, 3, 3), 5, 0, 40, 100, 50, "x"),
     ["representative"]),
    ("native: negative columns", lambda c: c.native.cluster_tensor(T4(4, 5, 3, 3), -1), []),
], raises=("ValueError", "TypeError", "OverflowError"))
def _cs(c, **kw):
    """Valid clustered_shading arguments for the corpus matrix (one light label, two view clusters, F = 1)
    with ``kw`` replaced."""
    args = dict(light_labels=np.zeros(c.n, np.int64), light_centroids=np.zeros((1, 3), np.float32),
                view_centroids=np.zeros((2, 3), np.float32), view_normals=np.tile([0, 0, 1], (2, 1)).astype(np.float32),
                membership_clusters=np.zeros((c.m, 1), np.uint32), membership_weights=np.ones((c.m, 1), np.float32))
    return {**args, **kw}


def _cs_native(c, **kw):
    a = _cs(c, **kw)
    return c.native.clustered_shading(c.A._m, a["light_labels"].astype(np.uint32), a["light_centroids"],
                                      a["view_centroids"], a["view_normals"], a["membership_clusters"],
                                      a["membership_weights"])


cases_for("native.cluster_view_samples", [
    ("k = 0", lambda c: c.native.cluster_view_samples(KP(), KN(), 0), ["k", "got 0"]),
    ("gamma = 0", lambda c: c.native.cluster_view_samples(KP(), KN(), 3, 0), ["gamma", "got 0"]),
    ("f = 0", lambda c: c.native.cluster_view_samples(KP(), KN(), 3, 2, 0), ["f"]),
    ("NaN point", lambda c: c.native.cluster_view_samples(_nan_at(KP(), (6, 2)), KN(), 3), ["point 6"]),
    ("normals rows", lambda c: c.native.cluster_view_samples(KP(), KN(3), 2), ["normals", "3 rows"]),
])
cases_for("clustered_visibility", [
    ("not a matrix", lambda c: c.ml.clustered_visibility("A"), ["LightMatrix"]),
    ("zero light clusters", lambda c: c.ml.clustered_visibility(c.A, light_clusters=0), ["light_clusters"]),
    ("zero view clusters", lambda c: c.ml.clustered_visibility(c.A, view_clusters=0), ["view_clusters"]),
    ("fuzzy 17", lambda c: c.ml.clustered_visibility(c.A, fuzzy=17), ["fuzzy", "17"]),
    ("downsample 0", lambda c: c.ml.clustered_visibility(c.A, downsample=0), ["downsample"]),
    ("negative iterations", lambda c: c.ml.clustered_visibility(c.A, iterations=-1), ["iterations"]),
    ("threshold 2", lambda c: c.ml.clustered_visibility(c.A, cos_threshold=2.0), ["cos_threshold"]),
    ("negative seed", lambda c: c.ml.clustered_visibility(c.A, seed=-1), ["seed"]),
], raises=("ValueError", "TypeError"))
cases_for("clustered_shading", [
    ("label out of range", lambda c: c.ml.clustered_shading(c.A, **_cs(c, light_labels=np.full(c.n, 5))),
     ["light label 5", "1 light centroids"]),
    ("negative label", lambda c: c.ml.clustered_shading(c.A, **_cs(c, light_labels=-np.ones(c.n, np.int64))),
     ["light label -1"]),
    ("float labels", lambda c: c.ml.clustered_shading(c.A, **_cs(c, light_labels=np.zeros(c.n))), ["integers"]),
    ("labels not one per light", lambda c: c.ml.clustered_shading(c.A, **_cs(c, light_labels=[0])),
     ["one label per light"]),
    ("NaN light centroid", lambda c: c.ml.clustered_shading(c.A, **_cs(c, light_centroids=np.full((1, 3), np.nan))),
     ["light_centroids", "nan"]),
    ("centroids (k, 2)", lambda c: c.ml.clustered_shading(c.A, **_cs(c, view_centroids=np.zeros((2, 2)))),
     ["view_centroids", "(k, 3)"]),
    ("no view centroids", lambda c: c.ml.clustered_shading(c.A, **_cs(c, view_centroids=np.zeros((0, 3)))),
     ["view_centroids", "k >= 1"]),
    ("inf view normal", lambda c: c.ml.clustered_shading(c.A, **_cs(c, view_normals=np.full((2, 3), np.inf))),
     ["view_normals", "inf"]),
    ("normals of another count", lambda c: c.ml.clustered_shading(c.A, **_cs(c, view_normals=np.ones((3, 3)))),
     ["view_normals", "shape"]),
    ("weights not summing to 1", lambda c: c.ml.clustered_shading(
        c.A, **_cs(c, membership_weights=np.full((c.m, 1), 0.5, np.float32))), ["sum to 1", "0.5"]),
    ("NaN weight", lambda c: c.ml.clustered_shading(
        c.A, **_cs(c, membership_weights=_nan_at(np.ones((c.m, 1), np.float32), (3, 0)))), ["membership_weights", "nan"]),
    ("negative weight", lambda c: c.ml.clustered_shading(c.A, **_cs(
        c, membership_clusters=np.zeros((c.m, 2), np.uint32),
        membership_weights=np.tile(np.float32([1.5, -0.5]), (c.m, 1)))), ["-0.5", ">= 0"]),
    ("cluster id out of range", lambda c: c.ml.clustered_shading(
        c.A, **_cs(c, membership_clusters=np.full((c.m, 1), 7))), ["membership cluster 7", "2 view centroids"]),
    ("membership rows != view samples", lambda c: c.ml.clustered_shading(c.A, **_cs(
        c, membership_clusters=np.zeros((3, 1), np.uint32), membership_weights=np.ones((3, 1), np.float32))),
     ["shape", "view sample"]),
    ("clusters and weights of other shapes", lambda c: c.ml.clustered_shading(
        c.A, **_cs(c, membership_weights=np.ones((c.m, 2), np.float32))), ["membership", "shape"]),
    ("F > view clusters", lambda c: c.ml.clustered_shading(c.A, **_cs(
        c, membership_clusters=np.zeros((c.m, 3), np.uint32),
        membership_weights=np.full((c.m, 3), 1 / 3, np.float32))), ["fuzziness", "got 3"]),
    ("A not a LightMatrix", lambda c: c.ml.clustered_shading("A", **_cs(c)), ["LightMatrix"]),
    ("string weights", lambda c: c.ml.clustered_shading(c.A, **_cs(c, membership_weights=np.full((c.m, 1), "x"))),
     ["membership_weights"]),
], raises=("ValueError", "TypeError"))
cases_for("native.clustered_shading", [
    ("native: label out of range", lambda c: _cs_native(c, light_labels=np.full(c.n, 9)), ["light label 9"]),
    ("native: cluster id out of range", lambda c: _cs_native(c, membership_clusters=np.full((c.m, 1), 2, np.uint32)),
     ["membership cluster 2"]),
    ("native: NaN view centroid", lambda c: _cs_native(c, view_centroids=np.full((2, 3), np.nan, np.float32)),
     ["view centroid 0", "NaN"]),
    ("native: centroids (k, 4)", lambda c: _cs_native(c, light_centroids=np.zeros((1, 4), np.float32)),
     ["light_centroids", "(k, 3)"]),
    ("native: weights of another shape", lambda c: _cs_native(c, membership_weights=np.ones((c.m, 2), np.float32)),
     ["membership_weights", "shape"]),
    ("native: F = 0", lambda c: _cs_native(c, membership_clusters=np.zeros((c.m, 0), np.uint32),
                                           membership_weights=np.ones((c.m, 0), np.float32)), ["got 0"]),
    ("native: float64 weights", lambda c: _cs_native(c, membership_weights=np.ones((c.m, 1))), []),
], raises=("ValueError", "TypeError"))

cases_for("TensorClustering.estimate", [
    ("other n", lambda c: c.ml.cluster_tensor(T4(4, 5, 3, 3), 5).estimate(T4(4, 6, 3, 3)), ["shape"]),
    ("other f", lambda c: c.ml.cluster_tensor(T4(4, 5, 3, 3), 5).estimate(T4(4, 5, 2, 3)), ["shape"]),
    ("NaN", lambda c: c.ml.cluster_tensor(T4(4, 5, 3, 3), 15).estimate(_nan_at(T4(4, 5, 3, 3), (1, 1, 1, 1))),
     ["non-finite"]),
    ("strings", lambda c: c.ml.cluster_tensor(T4(4, 5, 3, 3), 5).estimate(np.full((4, 5, 3, 3), "s")), ["'s'"]),
], raises=("ValueError", "TypeError"))
cases_for("TensorClustering.lights", [
    ("t out of range", lambda c: c.ml.cluster_tensor(T4(4, 5, 3, 3), 5).lights(5), ["t"]),
    ("negative t", lambda c: c.ml.cluster_tensor(T4(4, 5, 3, 3), 5).lights(-1), ["t"]),
])
cases_for("flicker", [
    ("one frame", lambda c: c.ml.flicker(IMG(1, 2, 2, 3) + 1, IMG(1, 2, 2, 3) + 1), ["2 frames"]),
    ("shapes differ", lambda c: c.ml.flicker(IMG(3, 2, 2, 3), IMG(3, 2, 3, 3) + 1), ["shape"]),
    ("not (f, H, W, 3)", lambda c: c.ml.flicker(IMG(2, 2, 3) + 1, IMG(2, 2, 3) + 1), ["(f, H, W, 3)"]),
    ("zero reference", lambda c: c.ml.flicker(IMG(3, 2, 2, 3), IMG(3, 2, 2, 3)), ["zero"]),
    ("NaN", lambda c: c.ml.flicker(np.full((3, 2, 2, 3), np.nan, np.float32), IMG(3, 2, 2, 3) + 1), ["non-finite"]),
    ("strings", lambda c: c.ml.flicker(np.full((2,), "a"), np.full((2,), "b")), ["'a'"]),
], raises=("ValueError", "TypeError"))
cases_for("relative_l2_per_frame", [
    ("zero reference frame", lambda c: c.ml.relative_l2_per_frame(IMG(2, 2, 2, 3) + 1,
                                                                   np.stack([IMG(2, 2, 3) + 1, IMG(2, 2, 3)])),
     ["frame 1"]),
    ("shapes differ", lambda c: c.ml.relative_l2_per_frame(IMG(3, 2, 2, 3), IMG(2, 2, 2, 3) + 1), ["shape"]),
    ("not (f, H, W, 3)", lambda c: c.ml.relative_l2_per_frame(IMG(2, 2, 3) + 1, IMG(2, 2, 3) + 1), ["(f, H, W, 3)"]),
    ("inf", lambda c: c.ml.relative_l2_per_frame(IMG(2, 2, 2, 3), np.full((2, 2, 2, 3), np.inf)), ["non-finite"]),
], raises=("ValueError", "TypeError"))
