"""Tensor clustering (Hašan et al. 2008, Sec. 4.3-4.5) on reduced tensors built with the library: the
cbox-lights scene at 32x32, its 3 emitters + 400 area lights, 48 stratified rows, 8 frames in which every
light drifts by its own small velocity (LightSet.from_arrays), and synthetic ones; plus the flicker and
per-frame error metrics."""
import numpy as np
import pytest

import manylights as ml
from conftest import SCENE_CONFIGS

FRAMES = 8
SEEDS = 200  # unbiasedness: estimates per configuration
MAX_Z = 4.0  # |mean - truth| / standard error allowed per (frame, channel) row-sum block


@pytest.fixture(scope="module")
def moving_full():
    """A small animation (static camera, every light drifting): the reduced tensor R (48, n, f, 3) of 48
    stratified rows and the full tensor A (1024, n, f, 3) of every pixel (float32)."""
    xml, _, _ = SCENE_CONFIGS["cbox-lights"]
    scene = ml.load_scene(xml, res=32)
    L = ml.generate_lights(scene, area=400, seed=1)
    rows = ml.stratified_rows(scene, 48, seed=0)
    velocity = np.random.default_rng(0).normal(size=(len(L), 3)).astype(np.float32) * np.float32([0.02, 0, 0.02])
    R, A = [], []
    for k in range(FRAMES):
        Lk = ml.LightSet.from_arrays(scene, kind=L.kind, position=L.position + k * velocity, direction=L.direction,
                                     normal=L.normal, intensity=L.intensity, cutoff_angle=L.cutoff_angle,
                                     beam_width=L.beam_width)
        matrix = ml.LightMatrix(scene, Lk, device="cpu")
        R.append(matrix.rows(rows))
        A.append(matrix.rows(np.arange(32 * 32)))
    R, A = np.stack(R, axis=2), np.stack(A, axis=2)
    assert R.shape == (48, 403, FRAMES, 3) and R.dtype == np.float32 and A.shape == (1024, 403, FRAMES, 3)
    assert not np.allclose(R[:, :, 0], R[:, :, -1])  # the lights really move
    np.testing.assert_array_equal(R, A[rows])
    return R, A


@pytest.fixture(scope="module")
def moving(moving_full):
    return moving_full[0]


def rel(est, exact) -> float:
    return float(np.linalg.norm(est - exact) / np.linalg.norm(exact))


def mrcs_row_sums(R2, c, seed):
    """Estimate of the row sums of a reduced matrix (r, n, 3) by the existing MRCS clustering."""
    m = ml.cluster_reduced_columns(R2, c, seed=seed)
    return (m["weights"][None] * R2[:, m["representatives"]]).sum(axis=1)


def test_outputs_are_a_rectangular_partition_with_counted_shadow_maps(moving):
    R = moving
    r, n, f, _ = R.shape
    T = ml.cluster_tensor(R, 20 * f, seed=3, init_clusters=20)
    c = T.num_clusters
    assert c == 20 * f
    assert T.representatives.shape == (c, 2) and T.assignment.shape == (n, f) and T.assignment.dtype == np.int32
    assert T.rec.shape == (c, f, 3) and T.rec.dtype == np.float32 and T.frames.shape == (c, 2)
    counts = np.bincount(T.assignment.ravel(), minlength=c)
    assert (counts == T.sizes).all()
    for t in range(c):
        k0, k1 = T.frames[t]
        J = T.lights(t)
        assert (T.assignment[np.ix_(J, np.arange(k0, k1))] == t).all() and len(J) * (k1 - k0) == T.sizes[t]
        j, k = T.representatives[t]
        assert j in J and k0 <= k < k1
        assert (T.rec[t, :k0] == 0).all() and (T.rec[t, k1:] == 0).all()
        # The paper's representative: the pair of largest weight |R(:, j, k)|.
        w = np.linalg.norm(R[:, J, k0:k1].astype(np.float64), axis=(0, 3))
        assert np.isclose(np.linalg.norm(R[:, j, k].astype(np.float64)), w.max(), rtol=1e-5)
    expected = np.bincount(T.representatives[T.rendered, 1], minlength=f)
    assert (T.shadow_maps_per_frame == expected).all() and T.shadow_maps_per_frame.sum() <= c
    assert (T.clusters_per_frame >= T.shadow_maps_per_frame).all()
    # Deterministic in the seed; another seed, another clustering.
    T2 = ml.cluster_tensor(R, 20 * f, seed=3, init_clusters=20)
    assert (T2.assignment == T.assignment).all() and (T2.rec == T.rec).all()
    assert (ml.cluster_tensor(R, 20 * f, seed=4, init_clusters=20).assignment != T.assignment).any()
    # More columns, less error.
    exact = R.sum(axis=1)
    errs = [rel(ml.cluster_tensor(R, cpf * f, seed=0, init_clusters=20).estimate(R), exact) for cpf in (5, 20, 80)]
    assert errs[0] > errs[1] > errs[2], errs


def test_full_budget_estimate_is_exact(moving):
    R = np.ascontiguousarray(moving[:, :60, :5])
    r, n, f, _ = R.shape
    for chunk in (40, 2):
        T = ml.cluster_tensor(R, n * f, chunk=chunk, init_clusters=7)
        assert (T.sizes == 1).all()
        np.testing.assert_allclose(T.estimate(R), R.sum(axis=1), rtol=1e-5, atol=1e-7)
        # Singletons: Rec = 1 in the representative's own frame (0 for pairs dark at every row).
        own = T.rec[np.arange(n * f), T.representatives[:, 1]]
        assert np.isin(own, [0.0, 1.0]).all()
    # Scalar (r, n, f) input: the same, one channel.
    S = np.linalg.norm(R, axis=3)
    T = ml.cluster_tensor(S, n * f)
    np.testing.assert_allclose(T.estimate(S), S.sum(axis=1), rtol=1e-5, atol=1e-7)


def test_one_frame_tensor_has_mrcs_quality(moving):
    """With f = 1 only light splits exist; with MRCS's representative rule (drawn by weight, grey weights)
    the estimate's relative L2 must be within the seed spread of the existing MRCS clustering."""
    R1 = np.ascontiguousarray(moving[:, :, :1])
    exact = R1.sum(axis=1)
    for c in (20, 40):
        t = [rel(ml.cluster_tensor(R1, c, seed=s, representative="sampled", color_averaging=False).estimate(R1),
                 exact) for s in range(8)]
        m = [rel(mrcs_row_sums(R1[:, :, 0], c, s), exact[:, 0]) for s in range(8)]
        print(f"c={c}: tensor {np.mean(t):.5f} +- {np.std(t):.5f}, MRCS {np.mean(m):.5f} +- {np.std(m):.5f}")
        assert np.mean(t) <= np.mean(m) + 2 * (np.std(m) + np.std(t)), (t, m)
        assert np.mean(t) < 0.02


def test_static_tensor_clusters_span_all_frames_and_beat_per_frame_mrcs(moving):
    R = np.repeat(moving[:, :, :1], FRAMES, axis=2)
    exact = R.sum(axis=1)
    for per_frame in (10, 20):
        T = ml.cluster_tensor(R, per_frame * FRAMES, seed=1, init_clusters=20)
        ch = T.chunks[0]
        span = T.frames[:, 1] - T.frames[:, 0]
        print(per_frame, ch, "full-span clusters:", (span == FRAMES).mean())
        assert ch["time_splits"] <= 0.1 * (ch["time_splits"] + ch["light_splits"]), ch
        assert (span == FRAMES).mean() >= 0.9
        # Every frame is served by (nearly) all clusters, not by its own 1/f share.
        assert T.clusters_per_frame.min() >= 0.9 * T.num_clusters
        tensor_err = rel(T.estimate(R), exact)
        mrcs = np.stack([mrcs_row_sums(R[:, :, k], per_frame, seed=100 + k) for k in range(FRAMES)], axis=1)
        mrcs_err = rel(mrcs, exact)
        print(f"{per_frame}/frame: tensor {tensor_err:.5f}, per-frame MRCS {mrcs_err:.5f}")
        assert tensor_err <= mrcs_err


def test_tensor_clustering_flickers_less_than_per_frame_mrcs(moving):
    """The paper's claim on the reduced tensor: at the same total budget, reusing clusters over frames
    gives a temporally stabler estimate than independent MRCS per frame (measured: 0.29x and 0.35x)."""
    R = moving
    f = R.shape[2]
    exact = R.sum(axis=1)
    def anim(e):  # (r, f, 3) -> (f, r, 1, 3)
        return np.transpose(e, (1, 0, 2))[:, :, None, :]

    for per_frame in (10, 20):
        tensor = np.mean([ml.flicker(anim(ml.cluster_tensor(R, per_frame * f, seed=s, init_clusters=20).estimate(R)),
                                     anim(exact)) for s in range(3)])
        mrcs = np.mean([ml.flicker(anim(np.stack([mrcs_row_sums(R[:, :, k], per_frame, 100 * s + k)
                                                  for k in range(f)], axis=1)), anim(exact)) for s in range(3)])
        print(f"{per_frame}/frame: flicker tensor {tensor:.5f}, per-frame MRCS {mrcs:.5f}")
        assert tensor < 0.5 * mrcs


def test_full_images_tensor_at_half_the_budget_of_per_frame_mrcs(moving_full):
    """The issue's acceptance in miniature, on every pixel (rows never seen by the clustering; static
    camera, so the pixel mappings are the identity and the estimate is what the renderer computes):
    tensor clustering at 20 columns per frame against per-frame MRCS at 40. Measured (3 seeds): mean
    per-frame error 0.00096 vs 0.00150, flicker 0.00073 vs 0.00149 with representative="centroid"; the
    paper's "max" has about 10x centroid's error here (0.0103) at a low flicker too (0.00097)."""
    R, A = moving_full
    f = R.shape[2]
    exact = A.sum(axis=1)
    def anim(e):  # (m, f, 3) -> (f, H, W, 3)
        return np.transpose(e, (1, 0, 2)).reshape(f, 32, 32, 3)

    def score(est):
        return ml.relative_l2_per_frame(anim(est), anim(exact)).mean(), ml.flicker(anim(est), anim(exact))

    tensor, paper, mrcs = [], [], []
    for s in range(3):
        tensor.append(score(ml.cluster_tensor(R, 20 * f, seed=s, init_clusters=20, representative="centroid")
                            .estimate(A)))
        paper.append(score(ml.cluster_tensor(R, 20 * f, seed=s, init_clusters=20).estimate(A)))
        est = np.zeros_like(exact)
        for k in range(f):
            m = ml.cluster_reduced_columns(R[:, :, k], 40, seed=100 * s + k)
            est[:, k] = (m["weights"][None] * A[:, m["representatives"], k]).sum(axis=1)
        mrcs.append(score(est))
    (t_err, t_fl), (p_err, p_fl), (m_err, m_fl) = (np.mean(x, axis=0) for x in (tensor, paper, mrcs))
    print(f"error / flicker: tensor centroid {t_err:.5f} / {t_fl:.5f}, tensor max {p_err:.5f} / {p_fl:.5f}, "
          f"per-frame MRCS at 2x {m_err:.5f} / {m_fl:.5f}")
    assert t_err < m_err and t_fl < 0.6 * m_fl
    assert p_fl < 0.75 * m_fl  # the paper's choice is temporally stable too...
    assert t_err < 0.3 * p_err  # ...but biased (module doc of src/cluster/tensor)


def _max_block_z(R, columns, **kw) -> float:
    """Largest |mean - truth| / standard error over seeds of the row sums summed over rows, per frame and
    channel."""
    truth = R.astype(np.float64).sum(axis=(0, 1))
    est = np.stack([ml.cluster_tensor(R, columns, seed=s, init_clusters=10, **kw).estimate(R).sum(axis=0)
                    for s in range(SEEDS)]).astype(np.float64)
    se = est.std(axis=0, ddof=1) / np.sqrt(SEEDS)
    assert (se > 0).all()
    return float(np.abs((est.mean(axis=0) - truth) / se).max())


def test_sampled_representatives_are_unbiased_where_the_paper_says(moving):
    """Weight-sampled representatives with grey Rec: the mean estimate over seeds converges to the exact
    row sums for one frame and for a static tensor (each cluster's lights do not change over its frames);
    for a moving tensor the sum over frames is unbiased. The paper's max-weight choice is biased (Sec. 4.5),
    which the same test detects."""
    sampled = dict(representative="sampled", color_averaging=False)
    R1 = np.ascontiguousarray(moving[:, :, :1])
    static = np.repeat(R1, 4, axis=2)
    assert _max_block_z(R1, 16, **sampled) < MAX_Z
    assert _max_block_z(static, 64, **sampled) < MAX_Z
    assert _max_block_z(static, 64) > 5 * MAX_Z  # the paper's deterministic representative: biased
    R4 = np.ascontiguousarray(moving[:, :, :4])
    truth = R4.astype(np.float64).sum(axis=(0, 1, 2))
    est = np.stack([ml.cluster_tensor(R4, 64, seed=s, init_clusters=10, **sampled).estimate(R4).sum(axis=(0, 1))
                    for s in range(SEEDS)]).astype(np.float64)
    z = np.abs(est.mean(axis=0) - truth) / (est.std(axis=0, ddof=1) / np.sqrt(SEEDS))
    assert (z < MAX_Z).all(), z


def test_chunks_get_their_share_of_the_budget(moving):
    R = np.ascontiguousarray(moving[:, :50])
    f = R.shape[2]
    T = ml.cluster_tensor(R, 4 * f + 3, chunk=3, init_clusters=4)  # 35 columns over chunks of 3, 3, 2 frames
    assert [c["frames"] for c in T.chunks] == [(0, 3), (3, 6), (6, 8)]
    # 35 * (3, 3, 2) / 8 = 13.125, 13.125, 8.75 -> 13, 13, 9 (the leftover to the largest fraction).
    assert [c["budget"] for c in T.chunks] == [13, 13, 9]
    for c in T.chunks:
        a, b = c["frames"]
        inside = (T.frames[:, 0] >= a) & (T.frames[:, 1] <= b)
        assert inside.sum() == c["budget"] == c["init_clusters"] + c["time_splits"] + c["light_splits"]
        assert ((T.representatives[inside, 1] >= a) & (T.representatives[inside, 1] < b)).all()
    assert len(T.representatives) == 35


def test_bad_input(moving):
    R = np.ascontiguousarray(moving[:4, :5, :3])
    with pytest.raises(ValueError, match=r"columns must be in \[f, n \* f\] = \[3, 15\].*got 2"):
        ml.cluster_tensor(R, 2)
    with pytest.raises(ValueError, match=r"\[3, 15\].*got 16"):
        ml.cluster_tensor(R, 16)
    with pytest.raises(ValueError, match="chunk must be in 1..=.*got 0"):
        ml.cluster_tensor(R, 5, chunk=0)
    with pytest.raises(ValueError, match=r"shape \(r, n, f, 3\).*\(4, 5, 3, 2\)"):
        ml.cluster_tensor(R[..., :2], 5)
    with pytest.raises(ValueError, match=r"shape \(r, n, f, 3\)"):
        ml.cluster_tensor(R[:, :, 0, 0], 5)
    with pytest.raises(ValueError, match="at least one row"):
        ml.cluster_tensor(R[:0], 5)
    with pytest.raises(TypeError, match="real numeric"):
        ml.cluster_tensor(R.astype(np.complex64), 5)
    bad = R.copy()
    bad[2, 4, 1, 0] = np.nan
    with pytest.raises(ValueError, match="row 2, light 4, frame 1, channel 0"):
        ml.cluster_tensor(bad, 5)
    with pytest.raises(ValueError, match="representative must be 'max', 'sampled' or 'centroid'"):
        ml.cluster_tensor(R, 5, representative="random")
    with pytest.raises(ValueError, match="seed"):
        ml.cluster_tensor(R, 5, seed=-1)
    with pytest.raises(ValueError, match="columns must be an integer"):
        ml.cluster_tensor(R, 5.5)
    T = ml.cluster_tensor(R, 5)
    with pytest.raises(ValueError, match=r"\(r, 5, 3, 3\)"):
        T.estimate(R[:, :4])
    with pytest.raises(ValueError, match="t must be"):
        T.lights(5)


# ---- metrics -------------------------------------------------------------------------------------------

def _animation(f=6, seed=0):
    rng = np.random.default_rng(seed)
    base = rng.uniform(0.2, 1.0, size=(1, 8, 10, 3))
    drift = np.linspace(0, 1, f)[:, None, None, None] * rng.uniform(0, 0.3, size=(1, 8, 10, 3))
    return (base + drift).astype(np.float32)


def test_flicker_is_zero_for_the_reference_and_grows_with_temporal_noise():
    ref = _animation()
    assert ml.flicker(ref, ref) == 0.0
    # A constant (temporally stable) error does not flicker.
    bias = ref + 0.05
    assert ml.flicker(bias, ref) == pytest.approx(0.0, abs=1e-7)
    noise = np.random.default_rng(1).normal(size=ref.shape)
    values = [ml.flicker(ref + a * noise, ref) for a in (0.001, 0.01, 0.03, 0.1)]
    assert all(x < y for x, y in zip(values, values[1:])), values
    # Linear in the noise amplitude.
    assert values[3] / values[1] == pytest.approx(10.0, rel=1e-6)
    # Independent noise per frame: flicker ~ per-frame relative L2 (the normalisation's purpose).
    per_frame = ml.relative_l2(ref + 0.1 * noise, ref)
    assert values[3] == pytest.approx(per_frame, rel=0.15)


def test_flicker_exact_value_and_static_reference():
    ref = np.ones((4, 2, 3, 3))  # static reference
    d = 0.02
    frames = ref + d * np.array([1, -1, 1, -1])[:, None, None, None]
    # E alternates +-d: ||E_{k+1} - E_k||^2 = 4 d^2 M, ||R_k||^2 = M -> sqrt(4 d^2 / 2) = sqrt(2) d.
    assert ml.flicker(frames, ref) == pytest.approx(np.sqrt(2) * d, rel=1e-12)
    assert np.isfinite(ml.flicker(frames, ref))
    with pytest.raises(ValueError, match="at least 2 frames"):
        ml.flicker(frames[:1], ref[:1])
    with pytest.raises(ValueError, match="shapes differ"):
        ml.flicker(frames, ref[:3])
    with pytest.raises(ValueError, match=r"\(f, H, W, 3\)"):
        ml.flicker(frames[0], ref[0])
    with pytest.raises(ValueError, match="all zero"):
        ml.flicker(frames, 0 * ref)
    bad = frames.copy()
    bad[1, 0, 0, 0] = np.inf
    with pytest.raises(ValueError, match="non-finite"):
        ml.flicker(bad, ref)


def test_relative_l2_per_frame():
    ref = _animation(f=3)
    frames = ref.copy()
    frames[1] *= 1.5
    frames[2] += 0.01
    got = ml.relative_l2_per_frame(frames, ref)
    assert got.shape == (3,)
    assert got[0] == 0.0 and got[1] == pytest.approx(0.5, rel=1e-6)
    assert got[2] == pytest.approx(ml.relative_l2(frames[2], ref[2]), rel=1e-9)
    z = ref.copy()
    z[2] = 0
    with pytest.raises(ValueError, match="reference frame 2 is all zero"):
        ml.relative_l2_per_frame(frames, z)
    with pytest.raises(ValueError, match=r"\(f, H, W, 3\)"):
        ml.relative_l2_per_frame(frames[0], ref[0])
