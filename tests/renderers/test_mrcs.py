"""Matrix Row-Column Sampling end to end: unbiasedness, clustering objective, baselines, bad input."""
import numpy as np
import pytest

import manylights as ml
from conftest import SCENE_CONFIGS, SCENES

# Unbiasedness test configuration: cbox-lights at 32x32 with ~2k lights, 64 seeds, 32 rows and
# 128 columns.
SEEDS = 64
ROWS, COLUMNS = 32, 128
# The mean over seeds of each quadrant-block x channel sum must lie within this many standard errors of
# the truth. The standard error is the EXACT one of the representative draws given each seed's
# clustering (Sec. 3.3: Var = sum_j f_j^2 / p_j - F^2 per cluster), not the sample spread over seeds:
# the per-seed estimates are heavy-tailed (a zero-norm light drawn by power can stand for many), so a
# sample standard error over 64 seeds is too small in most runs and the z-scores lean negative.
# Simulated with these clusterings, |z| of the exact form exceeds 4 in none of 2,000 trials.
MAX_Z = 4.0
# Error of the mean over 4 -> 64 seeds should fall like 1/sqrt(seeds) (x 0.25); allow noise up to 0.5.
MAX_RATIO_64_OVER_4 = 0.5


@pytest.fixture(scope="module")
def small_matrix():
    xml, _, _ = SCENE_CONFIGS["cbox-lights"]
    scene = ml.load_scene(xml, res=32)
    lights = ml.generate_lights(scene, area=512, environment=512, indirect=1024, seed=3)
    A = ml.LightMatrix(scene, lights, shadow_map_size=256)
    truth = A.column_sum(progress=False)
    return scene, lights, A, truth


@pytest.fixture(scope="module")
def mrcs_runs(small_matrix):
    _, _, A, _ = small_matrix
    return np.stack([ml.mrcs(A, rows=ROWS, columns=COLUMNS, seed=s, add_emitted=False).image for s in range(SEEDS)])


def _quadrant_sums(images):
    """(..., H, W, 3) -> (..., 12) float64 sums over the 2 x 2 quadrant blocks, per channel."""
    x = np.asarray(images, dtype=np.float64)
    h, w = x.shape[-3:-1]
    return x.reshape(*x.shape[:-3], 2, h // 2, 2, w // 2, 3).sum(axis=(-4, -2)).reshape(*x.shape[:-3], 12)


def _paper_probabilities(R, assignment, power):
    """Sec. 3.3's chance of each light being its cluster's representative, derived here from R alone:
    |rho_j| / s in a cluster with non-zero reduced norm, the light's share of power in a zero-norm one."""
    norm = np.linalg.norm(np.asarray(R, dtype=np.float64), axis=(0, 2))
    p = np.zeros(len(norm))
    for k in np.unique(assignment):
        cols = np.flatnonzero(assignment == k)
        w = norm[cols] if norm[cols].sum() > 0 else power[cols]
        p[cols] = w / w.sum() if w.sum() > 0 else 1.0 / len(cols)
    return p


def _mrcs_unbiasedness(A, scene, lights, seeds=SEEDS):
    """Runs MRCS for `seeds` seeds and checks its estimator against every column of A.

    Per seed, exactly: the image is sum_k w_k * column(rep_k); each weight is 1 / p of its
    representative; every light that lights any pixel can be drawn (p > 0), so E[image | clustering]
    is the full column sum. Over seeds: returns the z-scores of the quadrant sums with the exact
    standard error of the draws."""
    n = A.shape[1]
    power = np.maximum(np.asarray(lights.power, dtype=np.float64) @ [0.2126, 0.7152, 0.0722], 0.0)
    F = _quadrant_sums(A.columns(range(n)))  # (n, 12) every light's quadrant sums
    truth = F.sum(axis=0)
    deviation, variance = np.zeros(12), np.zeros(12)
    for s in range(seeds):
        R = A.rows(ml.stratified_rows(scene, ROWS, seed=s), progress=False)
        res = ml.mrcs(A, rows=ROWS, columns=COLUMNS, seed=s, add_emitted=False)
        a = np.asarray(res.clusters)
        p = _paper_probabilities(R, a, power)
        reps, w = np.asarray(res.representatives), np.asarray(res.weights, dtype=np.float64)
        np.testing.assert_allclose(w, np.repeat(1.0 / p[reps][:, None], 3, axis=1), rtol=1e-5,
                                   err_msg=f"seed {s}: weights are not 1 / P(representative)")
        image = _quadrant_sums(res.image)
        np.testing.assert_allclose(image, (F[reps].reshape(-1, 4, 3) * w[:, None, :]).sum(0).reshape(12),
                                   rtol=1e-4, err_msg=f"seed {s}: image is not sum_k w_k column(rep_k)")
        undrawable = np.flatnonzero(p == 0)
        assert np.abs(F[undrawable]).sum() == 0, f"seed {s}: lights {undrawable[:5]} light pixels but cannot be drawn"
        assert len(np.unique(a[reps])) == COLUMNS, f"seed {s}: a cluster has two representatives"
        deviation += image - truth
        ok = p > 0
        for k in np.unique(a):
            cols = np.flatnonzero(a == k)
            cols = cols[ok[cols]]
            variance += (F[cols] ** 2 / p[cols][:, None]).sum(0) - F[cols].sum(0) ** 2
    return deviation / np.sqrt(np.maximum(variance, 1e-30))


def test_mrcs_is_unbiased(small_matrix):
    scene, lights, A, _ = small_matrix
    z = _mrcs_unbiasedness(A, scene, lights)
    assert np.abs(z).max() <= MAX_Z, f"block z-scores {np.round(z, 2)}"


def test_mrcs_is_unbiased_with_virtual_spherical_lights(small_matrix):
    """VSLs are one column each like VPLs, so MRCS stays unbiased for their matrix."""
    scene, _, _, _ = small_matrix
    lights = ml.generate_lights(scene, area=512, environment=512, indirect=1024, seed=3, indirect_kind="vsl")
    assert (lights.vsl_radius[lights.kind == 4] > 0).all() and (lights.vsl_radius[lights.kind != 4] == 0).all()
    A = ml.LightMatrix(scene, lights, shadow_map_size=256)
    z = _mrcs_unbiasedness(A, scene, lights, seeds=16)
    assert np.abs(z).max() <= MAX_Z, f"block z-scores {np.round(z, 2)}"


def test_mrcs_error_of_mean_shrinks_like_inverse_sqrt(small_matrix, mrcs_runs):
    _, _, _, truth = small_matrix
    err = {k: ml.relative_l2(mrcs_runs[:k].mean(axis=0), truth) for k in (4, 16, 64)}
    assert err[64] <= MAX_RATIO_64_OVER_4 * err[4], err
    assert err[16] < err[4], err


def test_clustering_beats_random_partition_and_sampling_alone(small_matrix):
    _, _, A, _ = small_matrix
    rows = ml.stratified_rows(A.scene, 32, seed=1)
    R = A.rows(rows)
    c = 64
    full = ml.cluster_reduced_columns(R, c, seed=1)
    sampled = ml.cluster_reduced_columns(R, c, seed=1, sampling_fraction=1.0)
    rng = np.random.default_rng(1)
    random_assignment = rng.permutation(np.arange(R.shape[1]) % c)
    cost_random = ml.clustering_cost(R, random_assignment)
    assert full["cost"] < sampled["cost"], (full["cost"], sampled["cost"])
    assert full["cost"] < 0.5 * cost_random, (full["cost"], cost_random)


def test_mrcs_beats_baselines_at_equal_columns(small_matrix):
    scene, _, A, truth = small_matrix
    emitted = A.emitted()
    ref = truth + emitted
    e_mrcs = np.mean([ml.relative_l2(ml.mrcs(A, rows=32, columns=96, seed=s).image, ref) for s in range(4)])
    e_power = np.mean([ml.relative_l2(ml.power_sampling(A, columns=96, seed=s).image, ref) for s in range(4)])
    e_ir = np.mean([ml.relative_l2(ml.instant_radiosity(scene, lights=96, seed=s, shadow_map_size=256).image, ref)
                    for s in range(4)])
    assert e_mrcs < e_power, (e_mrcs, e_power)
    assert e_mrcs < e_ir, (e_mrcs, e_ir)


def test_result_records_what_was_done(small_matrix):
    _, lights, A, _ = small_matrix
    res = ml.mrcs(A, rows=16, columns=32, seed=5)
    assert res.image.shape == (32, 32, 3) and np.isfinite(res.image).all()
    assert len(res.rows) == 16 and len(res.representatives) == 32 and res.weights.shape == (32, 3)
    assert res.clusters.shape == (len(lights),) and set(np.unique(res.clusters)) <= set(range(32))
    assert set(res.timings) >= {"row_selection", "row_shadow_maps", "row_evaluation", "row_readback", "clustering", "columns"}
    assert res.seconds > 0 and res.timings["row_evaluation"] > 0
    again = ml.mrcs(A, rows=16, columns=32, seed=5)
    np.testing.assert_array_equal(again.image, res.image)


def test_custom_rows_and_clustering_from_python(small_matrix):
    _, _, A, truth = small_matrix
    rows = np.arange(0, 32 * 32, 37)
    R = A.rows(rows)
    cl = ml.cluster_reduced_columns(R, 40, seed=2)
    res = ml.mrcs(A, row_indices=rows, clustering=cl, add_emitted=False)
    np.testing.assert_array_equal(res.representatives, cl["representatives"])
    assert ml.relative_l2(res.image, truth) < 1.0


def test_bad_input(small_matrix):
    scene, lights, A, _ = small_matrix
    m, n = A.shape
    with pytest.raises(ValueError):
        ml.stratified_rows(scene, m + 1)
    with pytest.raises(ValueError):
        ml.stratified_rows(scene, 0)
    with pytest.raises(ValueError):
        ml.mrcs(A, rows=8, columns=n + 1)
    with pytest.raises(ValueError):
        ml.mrcs(A, rows=8, columns=0)
    with pytest.raises(ValueError):
        ml.cluster_reduced_columns(np.full((4, 10, 3), np.nan, np.float32), 2)
    # An all-zero reduced matrix is exact behaviour, not an error: power sampling among all lights.
    zero = ml.cluster_reduced_columns(np.zeros((4, n, 3), np.float32), 8, power=np.ones(n, np.float32))
    assert len(zero["representatives"]) == 8 and np.isfinite(zero["weights"]).all()


def test_zero_light_matrix_is_an_error():
    # cbox has one area emitter and no delta lights: asking for no area lights leaves none at all.
    scene = ml.load_scene(SCENES / "cbox" / "scene.xml", res=16)
    lights = ml.generate_lights(scene, area=0, environment=0, indirect=0)
    assert len(lights) == 0
    A = ml.LightMatrix(scene, lights)
    assert A.shape == (256, 0)
    with pytest.raises(ValueError, match="no lights"):
        ml.mrcs(A, rows=4, columns=4)
    with pytest.raises(ValueError):
        ml.power_sampling(A, columns=4)


def test_benchmark_writes_json_and_chart(tmp_path):
    """`python -m manylights.bench mrcs` on a tiny configuration: every method and ratio is recorded with
    stage timings, the reference is cached for a second run, and the chart is written."""
    import json

    from manylights.bench import __main__ as bench

    argv = ["mrcs", "--scene", str(SCENE_CONFIGS["cbox"][0]), "--lights", "400", "--res", "16",
            "--columns", "8", "24", "--ratios", "1:1", "1:3", "--seeds", "2", "--out", str(tmp_path)]
    assert bench.main(argv) == 0
    summary = json.loads((tmp_path / "mrcs-cbox.json").read_text())
    methods = [(r["method"], r["budget"].get("columns", r["budget"].get("lights"))) for r in summary["records"]]
    assert methods == [(m, c) for c in (8, 24) for m in ("power_sampling", "instant_radiosity", "mrcs 1:1", "mrcs 1:3")]
    mrcs_1_3 = [r for r in summary["records"] if r["method"] == "mrcs 1:3"]
    assert [r["budget"]["rows"] for r in mrcs_1_3] == [2, 8]
    for r in summary["records"]:
        assert r["seeds"] == 2 and 0 < r["rel_l2_mean"] < 1 and r["rel_l2_std"] >= 0
        assert abs(sum(r["stages"].values()) - r["seconds"]) < 1e-6 * max(1.0, r["seconds"])
        if r["method"].startswith("mrcs"):
            assert set(r["stages"]) >= {"row_setup", "row_shadow_maps", "row_evaluation", "row_readback", "clustering", "columns"}
            assert 0 < r["overhead_share"] < 1
    assert summary["brute_force_seconds"] > 0 and 0 < summary["gpu_share_mean"] < 1
    assert len(summary["equal_time"]) == 4
    assert (tmp_path / "mrcs-cbox.png").stat().st_size > 10_000
    # A second run reads the brute-force reference from the cache: same reference seconds, same errors.
    assert bench.main(argv) == 0
    again = json.loads((tmp_path / "mrcs-cbox.json").read_text())
    assert again["brute_force_seconds"] == summary["brute_force_seconds"]
    assert [r["rel_l2_mean"] for r in again["records"]] == pytest.approx([r["rel_l2_mean"] for r in summary["records"]])
