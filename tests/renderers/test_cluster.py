"""MRCS clustering of reduced columns (Hašan, Pellacini, Bala 2007, Sec. 3.4-4) through the Python API.

The test matrix is a synthetic many-light matrix: point lights above a floor split by a wall with a
doorway, a box that only high lights see, narrow lights that mostly miss the sampled rows (zero-norm
reduced columns whose full columns are not zero) and lights under the floor (zero columns).
"""
from __future__ import annotations

import numpy as np
import pytest

from manylights import _native as native

SEEDS = 256
# 3 standard errors per block, as asked; the blocks are few (8 row blocks x 3 channels).
MAX_Z = 3.0
# Objective margins measured on this matrix (about 0.3 and 0.7, see the Rust test of the same name).
MAX_RATIO_TO_RANDOM = 0.4
MAX_RATIO_TO_SAMPLING = 0.8


def synthetic(num_lights: int, grid: tuple[int, int], num_rows: int, seed: int):
    """Full matrix (m, n, 3) float32, stratified row indices (num_rows,), power (n,) float32."""
    rng = np.random.default_rng(seed)
    kind = np.arange(num_lights) % 20  # 18 wide, 1 narrow, 1 under the floor
    lx, ly = rng.random(num_lights) * 2.0, rng.random(num_lights)
    lz = np.where(kind == 19, -0.1, 0.05 + 0.45 * rng.random(num_lights))
    color = 0.2 + 0.8 * rng.random((num_lights, 3))
    intensity = 0.01 * (0.5 + rng.random(num_lights))
    reach = np.where(kind == 18, 0.025, np.inf)
    gx, gy = grid
    p = np.arange(gx * gy)
    px = ((p % gx) + 0.5) * 2.0 / gx
    py = ((p // gx) + 0.5) / gy
    dx, dy = px[:, None] - lx[None], py[:, None] - ly[None]
    with np.errstate(divide="ignore", invalid="ignore"):
        y_wall = ly[None] + (1.0 - lx[None]) / (px[:, None] - lx[None]) * (py[:, None] - ly[None])
    crosses = (lx[None] - 1.0) * (px[:, None] - 1.0) < 0.0
    blocked = crosses & ~((y_wall >= 0.4) & (y_wall < 0.6))
    in_box = ((px >= 1.5) & (px < 1.7) & (py >= 0.6) & (py < 0.9))[:, None] & (lz[None] < 0.3)
    visible = (lz[None] > 0.0) & (np.hypot(dx, dy) <= reach[None]) & ~blocked & ~in_box
    d2 = dx * dx + dy * dy + lz[None] ** 2
    value = np.where(visible, intensity[None] * lz[None] / (d2 * np.sqrt(d2)), 0.0)
    full = (value[:, :, None] * color[None]).astype(np.float32)
    m = gx * gy
    rows = np.array([a + rng.integers(0, b - a) for a, b in
                     ((k * m // num_rows, (k + 1) * m // num_rows) for k in range(num_rows))])
    power = (intensity * color.sum(axis=1)).astype(np.float32)
    return full, rows, power


@pytest.fixture(scope="module")
def matrix():
    return synthetic(2000, (40, 30), 300, 1)


def check_partition(res, n, c):
    a, reps, w = res["assignment"], res["representatives"], res["weights"]
    assert a.shape == (n,) and a.dtype == np.int32
    assert reps.shape == (c,) and reps.dtype == np.int64
    assert w.shape == (c, 3) and w.dtype == np.float32
    assert res["cluster_costs"].shape == (c,) and res["cluster_costs"].dtype == np.float64
    # Every column in exactly one cluster, every cluster non-empty and containing its representative.
    assert a.min() == 0 and a.max() == c - 1
    assert np.all(np.bincount(a, minlength=c) >= 1)
    np.testing.assert_array_equal(a[reps], np.arange(c))
    assert res["cost"] == pytest.approx(res["cluster_costs"].sum(), rel=1e-12)


def block_sums(image, num_blocks=8):
    """(m, 3) -> (num_blocks, 3) sums over contiguous row blocks."""
    m = image.shape[0]
    idx = np.arange(m) * num_blocks // m
    return np.stack([np.bincount(idx, weights=image[:, k], minlength=num_blocks) for k in range(3)], axis=1)


def unbiasedness(full, reduced, c, power):
    truth = block_sums(full.astype(np.float64).sum(axis=1))
    samples = []
    for seed in range(SEEDS):
        res = native.cluster_reduced_columns(reduced, c, seed=seed, power=power)
        check_partition(res, full.shape[1], c)
        est = np.einsum("mkc,kc->mc", full[:, res["representatives"]].astype(np.float64), res["weights"].astype(np.float64))
        samples.append(block_sums(est))
    samples = np.array(samples)  # (SEEDS, blocks, 3)
    sd = samples.std(axis=0, ddof=1)
    z = (samples.mean(axis=0) - truth) / (sd / np.sqrt(SEEDS))
    assert np.all(np.abs(z) < MAX_Z), z
    # RMS of (mean of g seeds - truth) / sd over disjoint groups: ~ 1/sqrt(g).
    for g in (4, 16, 64, 256):
        means = samples.reshape(SEEDS // g, g, *samples.shape[1:]).mean(axis=1)
        scaled = np.sqrt(np.mean(((means - truth) / sd) ** 2)) * np.sqrt(g)
        assert 0.4 < scaled < 2.0, (g, scaled)


def test_unbiased_on_full_columns(matrix):
    full, rows, power = matrix
    reduced = np.ascontiguousarray(full[rows])
    zero = np.linalg.norm(reduced.reshape(len(rows), -1, 3), axis=(0, 2)) == 0
    assert np.count_nonzero(zero & (full.sum(axis=(0, 2)) > 0)) >= 20, "needs contributing zero-norm columns"
    unbiasedness(full, reduced, 60, power)


def test_all_zero_reduced_matrix_unbiased():
    full, rows, power = synthetic(600, (20, 15), 40, 2)
    reduced = np.zeros((40, 600, 3), np.float32)
    # 100 strata of 6 lights keep the mean of 256 draws close to normal (narrow lights are heavy-tailed).
    unbiasedness(full, reduced, 100, power)
    unbiasedness(full, reduced, 100, None)


def test_objective_beats_random_partition_and_sampling_alone(matrix):
    full, rows, _ = matrix
    reduced = np.ascontiguousarray(full[rows])
    n, c = reduced.shape[1], 100
    combined = np.mean([native.cluster_reduced_columns(reduced, c, seed=s)["cost"] for s in range(4)])
    sampling = np.mean([native.cluster_reduced_columns(reduced, c, seed=s, sampling_fraction=1.0)["cost"] for s in range(4)])
    rng = np.random.default_rng(0)
    random = np.mean([native.clustering_cost(reduced, rng.permutation(np.arange(n) % c)) for _ in range(4)])
    assert combined < MAX_RATIO_TO_RANDOM * random, (combined, random)
    assert combined < MAX_RATIO_TO_SAMPLING * sampling, (combined, sampling)
    res = native.cluster_reduced_columns(reduced, c, seed=3)
    assert native.clustering_cost(reduced, res["assignment"]) == pytest.approx(res["cost"], rel=1e-12)


def test_determinism_and_scalar_input(matrix):
    full, rows, _ = matrix
    reduced = np.ascontiguousarray(full[rows])
    a = native.cluster_reduced_columns(reduced, 50, seed=7)
    b = native.cluster_reduced_columns(reduced, 50, seed=7)
    for key in ("assignment", "representatives", "weights", "cluster_costs"):
        np.testing.assert_array_equal(a[key], b[key])
    other = native.cluster_reduced_columns(reduced, 50, seed=8)
    assert not np.array_equal(a["assignment"], other["assignment"])
    # Scalar input = the 2-norm of the RGB triples: a green-only matrix (norm exact) and its scalar
    # version give the same clustering and weights; a non-contiguous view gives the same as a copy.
    green = np.zeros_like(reduced)
    green[..., 1] = reduced[..., 1]
    g = native.cluster_reduced_columns(green, 50, seed=7)
    s = native.cluster_reduced_columns(np.ascontiguousarray(reduced[..., 1]), 50, seed=7)
    for key in ("assignment", "representatives", "weights", "cluster_costs"):
        np.testing.assert_array_equal(s[key], g[key])
    t = native.cluster_reduced_columns(np.asfortranarray(reduced), 50, seed=7)
    np.testing.assert_array_equal(t["assignment"], a["assignment"])


def test_bad_inputs():
    r = np.ones((4, 5, 3), np.float32)
    with pytest.raises(ValueError, match="at least 1"):
        native.cluster_reduced_columns(r, 0)
    with pytest.raises(ValueError, match="must not exceed"):
        native.cluster_reduced_columns(r, 6)
    with pytest.raises(ValueError, match=r"shape \(r, n, 3\) or \(r, n\)"):
        native.cluster_reduced_columns(np.ones((4, 5, 2), np.float32), 2)
    with pytest.raises(ValueError, match="at least one row"):
        native.cluster_reduced_columns(np.ones((0, 5, 3), np.float32), 2)
    bad = r.copy()
    bad[2, 3, 1] = np.inf
    with pytest.raises(ValueError, match="row 2, column 3, channel 1"):
        native.cluster_reduced_columns(bad, 2)
    with pytest.raises(ValueError, match="power must have 5"):
        native.cluster_reduced_columns(r, 2, power=np.ones(4, np.float32))
    with pytest.raises(ValueError, match="column 1"):
        native.cluster_reduced_columns(r, 2, power=np.array([1, -1, 1, 1, 1], np.float32))
    with pytest.raises(ValueError, match="assignment must have 5"):
        native.clustering_cost(r, np.zeros(3, np.int32))
    with pytest.raises(TypeError):
        native.cluster_reduced_columns(r.astype(np.float64), 2)
