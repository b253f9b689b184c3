"""The tensor-clustering renderer on an animation: with every light-frame
pair its own cluster it is brute force; a one-frame tensor has MRCS quality; on the bundled animation
``bounce`` (8 consecutive frames of its 40-frame path at 48x48, ~3,000 lights) tensor clustering at 300
shadow maps per frame has lower mean per-frame error than per-frame MRCS at 600 and less flicker, shown
with the camera still (the pixel mappings are the identity) and moving (they carry columns between frames).

Measured (8 seeds, docs/validation/animations.md): still camera, tensor (centroid) 1.59% / flicker 0.0118 against MRCS 1.93% /
0.0207 (0.82x error, 0.57x flicker); moving camera 1.57% / 0.0126 against 1.80% / 0.0180 (0.87x, 0.70x).
The issue's "at most half" held with the camera still (0.45x) against MRCS before its zero-norm strata
 made per-frame MRCS flicker less; with the camera moving, representative columns carried to
other frames miss the moving box's shadow, which no pixel mapping moves
(scripts/tensor_flicker_decomposition.py). The paper's max-weight
representative gives 2.9-3.2% (above MRCS at 600) at 0.7-0.9x its flicker."""
from __future__ import annotations

import numpy as np
import pytest

import manylights as ml
import manylights.scenes

BOUNCE = ml.scenes.scene_path("bounce")


def _tensor(still: bool, frames=8, res=48, **light_counts):
    fr = ml.scenes.animation_frames("bounce", count=40)[:frames]
    if still:
        fr = [{**f, **{k: fr[0][k] for k in ("cam_x", "cam_y", "cam_z")}} for f in fr]
    anim = ml.load_animation(BOUNCE, frames=fr, res=res)
    counts = dict(area=1024, environment=1024, indirect=1000, photons=20000) | light_counts
    L = ml.generate_animation_lights(anim, seed=0, **counts)
    return ml.LightTensor(anim, L, device="cpu")


def test_every_pair_its_own_cluster_is_brute_force():
    T = _tensor(False, frames=3, res=24, area=40, environment=40, indirect=40, photons=0)
    m, n, f = T.shape
    res = ml.tensor_clustering(T, rows=30, columns=n, seed=1)
    B = T.brute_force()
    for k in range(f):
        assert ml.relative_l2(res.frames[k], B[k]) < 1e-5
    # Every non-zero pair rendered once, in its own frame: shadow maps per frame = rows + its pairs.
    cl = res.clustering
    assert np.array_equal(res.shadow_maps_per_frame, 30 + np.bincount(cl.representatives[cl.rendered, 1], minlength=f))
    assert {"slices", "clustering", "mappings", "columns", "reconstruction", "emitted"} <= set(res.timings)


def test_one_frame_has_mrcs_quality():
    T = _tensor(True, frames=1, res=32, area=512, environment=512, indirect=500, photons=0)
    B = T.brute_force()[0]
    tensor = [ml.relative_l2(ml.tensor_clustering(T, rows=64, columns=100, seed=s).frames[0], B) for s in range(4)]
    mrcs = [ml.relative_l2(ml.mrcs(T.frame(0), rows=64, columns=100, seed=s).image, B) for s in range(4)]
    # Within the seed spread of MRCS (or better).
    assert np.mean(tensor) < np.mean(mrcs) + 2 * np.std(mrcs) + 1e-3, (tensor, mrcs)


@pytest.mark.parametrize("still", [True, False], ids=["still camera", "moving camera"])
def test_tensor_at_300_beats_per_frame_mrcs_at_600(still):
    T = _tensor(still)
    B = T.brute_force()

    def score(fn):
        runs = [fn(s) for s in range(3)]
        return (np.mean([ml.relative_l2_per_frame(r.frames, B).mean() for r in runs]),
                np.mean([ml.flicker(r.frames, B) for r in runs]), runs[0])

    t_err, t_fl, t = score(lambda s: ml.tensor_clustering(T, rows=100, columns=200, seed=s))
    m_err, m_fl, m = score(lambda s: ml.mrcs_per_frame(T, rows=100, columns=500, seed=s))
    assert np.mean(t.shadow_maps_per_frame) == 300 and list(m.shadow_maps_per_frame) == [600] * 8
    print(f"{'still' if still else 'moving'}: tensor {t_err:.4f} / {t_fl:.4f}, per-frame MRCS {m_err:.4f} / {m_fl:.4f}")
    assert t_err < m_err
    # Less flicker: 0.58x with the camera still on these seeds, 0.66x with it moving (8 seeds: 0.57x, 0.70x).
    assert t_fl < (0.7 if still else 0.85) * m_fl


def test_gpu_reconstruction_stays_on_the_gpu_and_equals_the_cpu_accumulation():
    """On the GPU backend the representatives are rendered, scaled, carried through the mappings and
    accumulated on the GPU, chunk by chunk, read back once per chunk (Sec. 5); the result equals the CPU
    accumulation of the same GPU columns (measured 1e-7) across chunk boundaries and a moving camera."""
    from manylights.animation import tensor_clusters as tz
    fr = ml.scenes.animation_frames("bounce", count=40)[:5]
    anim = ml.load_animation(BOUNCE, frames=fr, res=16)
    L = ml.generate_animation_lights(anim, seed=0, area=32, environment=32, indirect=32, photons=0)
    T = ml.LightTensor(anim, L, device="gpu")
    res = ml.tensor_clustering(T, rows=12, columns=20, seed=1, chunk=3)
    cl = res.clustering
    assert [c["frames"] for c in cl.chunks] == [(0, 3), (3, 5)]
    reps, todo = np.asarray(cl.representatives), np.flatnonzero(np.asarray(cl.rendered))
    fw, bw = tz._mapping_arrays(T, T.shape[0])
    cpu = tz._reconstruct_cpu(T, cl, reps, todo, fw, bw, {"columns": 0.0, "reconstruction": 0.0}, (5, 16, 16))
    cpu += np.stack([T.frame(k).emitted() for k in range(5)])
    assert ml.relative_l2(res.frames, cpu) < 1e-5
    assert res.timings["columns"] > 0 and res.timings["reconstruction"] > 0


def test_bad_input():
    T = _tensor(True, frames=2, res=16, area=16, environment=16, indirect=0, photons=0)
    with pytest.raises(TypeError, match="LightTensor"):
        ml.tensor_clustering(T.frame(0))
    with pytest.raises(ValueError, match="columns"):
        ml.tensor_clustering(T, rows=4, columns=0)
    with pytest.raises(ValueError, match="columns"):
        ml.tensor_clustering(T, rows=4, columns=T.shape[1] + 1)
    with pytest.raises(ValueError, match="rows"):
        ml.tensor_clustering(T, rows=0, columns=4)
    with pytest.raises(ValueError, match="chunk"):
        ml.tensor_clustering(T, rows=4, columns=4, chunk=0)
    with pytest.raises(ValueError, match="representative"):
        ml.tensor_clustering(T, rows=4, columns=4, representative="best")


def test_time_weight_trades_time_splits_for_light_splits():
    """``time_weight`` > 1 (the paper's Sec. 4.3.2 suggestion of weighting light and time splits
    differently) makes fewer time splits; on bounce it raised the error 2.5-2.9x (docs/validation/animations.md), so the default
    stays the paper's 1."""
    T = _tensor(False, frames=4, res=24, area=128, environment=128, indirect=128, photons=0)
    R = T.slices(ml.stratified_rows(T.scenes[0], 32, seed=0))
    splits = [ml.cluster_tensor(R, 200, seed=0, time_weight=w).chunks[0]["time_splits"] for w in (1.0, 4.0)]
    assert splits[1] < splits[0], splits
    with pytest.raises(ValueError, match="time_weight"):
        ml.cluster_tensor(R, 200, time_weight=0.0)
    with pytest.raises(ValueError, match="time_weight"):
        ml.tensor_clustering(T, rows=8, columns=8, time_weight=float("nan"))


def test_error_probes_estimate_every_frames_error_against_the_converged_frame():
    """Per frame, the probes' upper bound against a path-traced reference of the whole frame (the probes'
    own unbiased tracer, 1,024 paths per pixel; its noise taken out in quadrature). Measured (seed 5): bounds
    9.1% and 8.0% against true 7.9% and 7.2%, 27 and 32 effective probes; over seeds 1-6 the bounds are
    0.99-1.34x the truth, and one frame of seed 1 rests on 14.7 effective probes (unreliable, says so)."""
    T = _tensor(False, frames=2, res=24, area=512, environment=512, indirect=500, photons=0)
    res = ml.tensor_clustering(T, rows=48, columns=100, seed=5, error_probes=128)
    assert res.error_estimate.shape == (2,) and len(res.budget["probes"]) == 2 and res.timings["probes"] > 0
    H, W = T.scenes[0].height, T.scenes[0].width
    pixels = np.stack(np.meshgrid(np.arange(H), np.arange(W), indexing="ij"), axis=-1).reshape(-1, 2)
    for k in range(2):
        mean, var = ml.probe_pixels(T.scenes[k], pixels, spp=1024, max_depth=-1, seed=9, progress=False)
        ref = mean.reshape(H, W, 3)
        noise = float(np.sqrt(var.sum()) / np.linalg.norm(ref))
        true = float(np.sqrt(max(ml.relative_l2(res.frames[k], ref) ** 2 - noise ** 2, 0.0)))
        assert res.budget["probes"][k]["reliable"]
        assert 0.7 * true <= res.error_estimate[k] <= 2.0 * true, (k, res.error_estimate[k], true, noise)
    plain = ml.tensor_clustering(T, rows=48, columns=100, seed=5)
    np.testing.assert_array_equal(plain.frames, res.frames)
    assert plain.error_estimate is None and "probes" not in plain.budget
    with pytest.raises(ValueError, match="error_probes"):
        ml.tensor_clustering(T, rows=8, columns=8, error_probes=-1)
