"""The lighting tensor of an animation and the per-frame MRCS baseline:
slices equal the frames' rows, brute force equals each frame's column sum, per-frame MRCS is exactly
``mrcs`` on each frame with seed + k, and bad input is named."""
from __future__ import annotations

import numpy as np
import pytest

import manylights as ml
from manylights import scenes

F = 4


@pytest.fixture(scope="module")
def tensor():
    scene = ml.load_scene(scenes.scene_path("cbox"), res=32)
    rng = np.random.default_rng(3)
    n = 300
    pos = rng.uniform([150.0, 150.0, 150.0], [400.0, 400.0, 400.0], (n, 3)).astype(np.float32)  # inside the box
    inten = rng.uniform(1e3, 5e3, (n, 3)).astype(np.float32)
    # Light j of frame k is light j of frame 0 translated: the same lights, moving together.
    lights = [ml.LightSet.from_arrays(scene, kind=0, position=pos + np.float32([10.0 * k, 0.0, 0.0]),
                                      intensity=inten) for k in range(F)]
    return ml.LightTensor([scene] * F, lights, device="cpu"), scene, lights


def test_shape_and_frames(tensor):
    T, scene, lights = tensor
    assert T.shape == (32 * 32, 300, F) and len(T) == F
    assert T.frame(1) is T.frame(1) and T.frame(-1) is T.frame(F - 1)
    assert T.device["kind"] == "cpu"
    with pytest.raises(IndexError, match="frame 4 out of range for 4 frames"):
        T.frame(F)


def test_slices_are_the_frames_rows(tensor):
    T, scene, lights = tensor
    rows = ml.stratified_rows(scene, 20, seed=1)
    R = T.slices(rows)
    assert R.shape == (20, 300, F, 3) and R.dtype == np.float32
    for k in range(F):
        assert np.array_equal(R[:, :, k], T.frame(k).rows(rows, progress=False))
    # The lights move between frames, so the slices differ from frame to frame.
    assert np.abs(R[:, :, 0] - R[:, :, -1]).sum() > 0.01 * np.abs(R[:, :, 0]).sum()


def test_brute_force_is_each_frames_column_sum(tensor):
    T, scene, lights = tensor
    B = T.brute_force()
    assert B.shape == (F, 32, 32, 3)
    for k in (0, F - 1):
        A = ml.LightMatrix(scene, lights[k], device="cpu")
        assert np.array_equal(B[k], A.column_sum(progress=False) + A.emitted())


def test_mrcs_per_frame(tensor):
    T, scene, lights = tensor
    res = ml.mrcs_per_frame(T, rows=100, columns=150, seed=5)
    assert res.frames.shape == (F, 32, 32, 3) and res.method == "mrcs_per_frame"
    assert list(res.shadow_maps_per_frame) == [250] * F
    assert res.budget == {"rows": 100, "columns": 150 * F, "lights": 300, "frames": F}
    for k in (0, 2):
        want = ml.mrcs(T.frame(k), rows=100, columns=150, seed=5 + k, row_indices=res.rows)
        assert np.array_equal(res.frames[k], want.image)
    B = T.brute_force()
    err = [ml.relative_l2(res.frames[k], B[k]) for k in range(F)]
    # 150 of 300 point lights in the middle of the box (every pixel near some of them): measured 1-10%
    # relative L2 per frame over seeds; all 300 columns give 0.
    assert max(err) < 0.25, err
    assert np.mean(err) > 1e-4
    assert {"row_evaluation", "clustering", "columns"} <= set(res.timings)


def test_static_lights(tensor):
    T, scene, lights = tensor
    T1 = ml.LightTensor([scene, scene], lights[0], device="cpu")
    rows = [0, 100, 500]
    R = T1.slices(rows)
    assert np.array_equal(R[:, :, 0], R[:, :, 1])


def test_bad_input(tensor):
    T, scene, lights = tensor
    small = ml.load_scene(scenes.scene_path("cbox"), res=16)
    with pytest.raises(ValueError, match="no frames"):
        ml.LightTensor([], lights[0])
    with pytest.raises(ValueError, match="frame 1 is 16x16 but frame 0 is 32x32"):
        ml.LightTensor([scene, small], lights[0], device="cpu")
    with pytest.raises(ValueError, match="3 light sets for 2 frames"):
        ml.LightTensor([scene, scene], lights[:3], device="cpu")
    with pytest.raises(ValueError, match="frame 1 has 10 lights but frame 0 has 300"):
        ml.LightTensor([scene, scene], [lights[0], lights[1][:10]], device="cpu")
    with pytest.raises(ValueError, match="frame 1 is str"):
        ml.LightTensor([scene, "x"], lights[0], device="cpu")
    with pytest.raises(ValueError, match="row index"):
        T.slices([32 * 32])
    with pytest.raises(ValueError, match="at least one"):
        T.slices([])
    with pytest.raises(ValueError, match="columns"):
        ml.mrcs_per_frame(T, rows=10, columns=301)
    with pytest.raises(TypeError, match="LightTensor"):
        ml.mrcs_per_frame(T.frame(0), rows=10, columns=10)
    with pytest.raises(MemoryError, match="reduced tensor"):
        import os
        old = os.environ.get("MANYLIGHTS_MEMORY_LIMIT")
        os.environ["MANYLIGHTS_MEMORY_LIMIT"] = "1K"
        try:
            T.slices(list(range(100)))
        finally:
            if old is None:
                del os.environ["MANYLIGHTS_MEMORY_LIMIT"]
            else:
                os.environ["MANYLIGHTS_MEMORY_LIMIT"] = old


def test_tensor_accumulate_binding():
    # Frame k+1 is frame k shifted one pixel to the right: the representative of frame 1 lands shifted in
    # frame 2, unshifted (scaled) in frame 1 and shifted left in frame 0; pixels without a source get 0.
    from manylights import _native

    f, H, W = 3, 2, 4
    m = H * W
    x = np.arange(m, dtype=np.uint32)
    col = x % W
    NO = np.uint32(2**32 - 1)
    fw = np.where(col == 0, NO, x - 1).astype(np.uint32)
    bw = np.where(col == W - 1, NO, x + 1).astype(np.uint32)
    columns = (np.arange(m, dtype=np.float32) + 1).reshape(1, H, W, 1).repeat(3, -1)
    rec = np.array([[[1, 1, 1], [2, 2, 2], [0.5, 0.5, 0.5]]], np.float32)
    acc = np.zeros((f, H, W, 3), np.float32)
    _native.tensor_accumulate(acc, columns, np.array([1], np.uint32), rec, np.stack([fw, fw]), np.stack([bw, bw]))
    img = columns[0, :, :, 0]
    assert np.array_equal(acc[1, :, :, 0], 2 * img)
    assert np.array_equal(acc[2, :, 1:, 0], 0.5 * img[:, :-1]) and np.all(acc[2, :, 0] == 0)
    assert np.array_equal(acc[0, :, :-1, 0], img[:, 1:]) and np.all(acc[0, :, -1] == 0)
    with pytest.raises(ValueError, match="representative 0 is in frame 3"):
        _native.tensor_accumulate(acc, columns, np.array([3], np.uint32), rec, np.stack([fw, fw]), np.stack([bw, bw]))


def test_mapping_of_static_frames_is_identity(tensor):
    T, scene, lights = tensor
    M = T.mapping(0, 2)
    g = scene.gbuffer("cpu")
    surface = g["shape_index"] >= 0
    assert M.shape == (32, 32)
    assert np.array_equal(M[surface], np.flatnonzero(surface.reshape(-1)))
    assert np.all(M[~surface] == -1)
