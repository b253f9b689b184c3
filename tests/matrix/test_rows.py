"""Rows of the light matrix (the reduced matrix R of matrix row-column sampling) from Python: shapes,
errors, stratified row selection, and agreement with columns."""
import numpy as np
import pytest

import manylights as ml
from conftest import SCENE_CONFIGS

# Rows and columns share emission and BSDF code; only ambiguous visibility may differ (hybrid maps).
PIXEL_REL, PIXEL_ABS = 0.02, 1e-3
MIN_AGREE = 0.99
SIZE = (32, 32)


@pytest.fixture(scope="module", params=["cpu", "gpu"])
def cbox(request):
    """The same matrix on each backend (the GPU's rows from cube maps with hybrid visibility)."""
    xml, params, _ = SCENE_CONFIGS["cbox"]
    scene = ml.load_scene(xml, size=SIZE, **params)
    lights = ml.generate_lights(scene, area=256, indirect=512, seed=2)
    return scene, lights, ml.LightMatrix(scene, lights, shadow_map_size=256, device=request.param)


def test_rows_shape_dtype_and_timings(cbox):
    scene, lights, A = cbox
    m, n = A.shape
    idx = ml.stratified_rows(scene, 6, seed=1)
    R, timings = A.rows(idx, progress=False, return_timings=True)
    assert R.shape == (6, n, 3) and R.dtype == np.float32
    assert np.isfinite(R).all() and (R >= 0).all() and R.max() > 0
    assert set(timings) == {"setup", "shadow_maps", "evaluation", "readback", "batches"}
    assert timings["batches"] >= 1 and all(timings[k] >= 0 for k in ("setup", "shadow_maps", "evaluation", "readback"))
    # Repeats and order are honoured.
    R2 = A.rows([int(idx[3]), int(idx[0]), int(idx[3])], progress=False)
    np.testing.assert_array_equal(R2[0], R[3])
    np.testing.assert_array_equal(R2[1], R[0])
    np.testing.assert_array_equal(R2[2], R[3])


def test_rows_agree_with_columns(cbox):
    scene, lights, A = cbox
    m, n = A.shape
    gb = scene.gbuffer()
    surface = np.flatnonzero(gb["shape_index"].reshape(-1) >= 0)
    I = surface[:: max(1, surface.size // 10)][:10]
    J = np.arange(0, n, 7)
    R = A.rows(I, progress=False)[:, J]                     # (r, k, 3)
    C = A.columns(J).reshape(len(J), m, 3)[:, I].transpose(1, 0, 2)
    scale = float(np.abs(C).max())
    ok = np.abs(R - C) <= np.maximum(PIXEL_REL * np.abs(C), PIXEL_ABS * scale)
    frac = ok.mean()
    assert C.max() > 0 and frac >= MIN_AGREE, f"only {frac:.4%} of entries agree"


def test_background_rows_are_zero(cbox):
    scene, lights, A = cbox
    sidx = scene.gbuffer()["shape_index"].reshape(-1)
    bg = np.flatnonzero(sidx < 0)
    if bg.size == 0:
        pytest.skip("no background pixel in this view")
    assert not A.rows(bg[:2], progress=False).any()


def test_row_errors_name_the_numbers(cbox):
    scene, lights, A = cbox
    m, n = A.shape
    with pytest.raises(ValueError, match="at least one row index, got 0"):
        A.rows([], progress=False)
    with pytest.raises(ValueError, match=f"row index {m} \\(at position 1\\) is out of range for m = {m}"):
        A.rows([0, m], progress=False)
    with pytest.raises(ValueError, match="row index -1"):
        A.rows([-1], progress=False)
    with pytest.raises(ValueError, match=f"{m + 1} rows requested but the matrix has only m = {m}"):
        A.rows(np.zeros(m + 1, dtype=np.int64), progress=False)
    with pytest.raises(ValueError, match="shadow_map_size must be in 16..=8192, got 8"):
        A.rows([0], progress=False, shadow_map_size=8)
    with pytest.raises(ValueError, match="must be integers"):
        A.rows([0.5], progress=False)


def test_stratified_rows(cbox):
    scene = cbox[0]
    W, H = scene.width, scene.height
    rows = ml.stratified_rows(scene, 16, seed=3)
    assert rows.shape == (16,) and rows.dtype == np.int64
    np.testing.assert_array_equal(rows, ml.stratified_rows(scene, 16, seed=3))
    assert not np.array_equal(rows, ml.stratified_rows(scene, 16, seed=4))
    # 16 rows on a square image: a 4 x 4 grid of 8 x 8 blocks, one row in each, in band-major order.
    blocks = (rows // W) // (H // 4) * 4 + (rows % W) // (W // 4)
    np.testing.assert_array_equal(blocks, np.arange(16))
    # Any r, factorable or not: r distinct pixels.
    for r in (1, 7, 300, W * H):
        got = ml.stratified_rows(scene, r)
        assert got.shape == (r,) and len(np.unique(got)) == r and got.min() >= 0 and got.max() < W * H
    for r in (0, W * H + 1):
        with pytest.raises(ValueError, match=f"r must be in \\[1, {W * H}\\].*got {r}"):
            ml.stratified_rows(scene, r)
    with pytest.raises(ValueError, match="integer"):
        ml.stratified_rows(scene, 2.5)
