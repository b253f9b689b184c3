"""2D Haar wavelets of the gather image and the paper's coefficient culling:
`_native.haar2d` / `ihaar2d` / `haar_support_area` / `haar_cull_area_weighted` / `cull_wavelet_lights`,
checked against an independent numpy construction of the same orthonormal non-standard transform."""
from __future__ import annotations

import numpy as np
import pytest

from manylights import _native


def _haar_matrix_1d_step(s: int) -> np.ndarray:
    """(s, s) orthonormal one-level 1D Haar step: rows 0..s/2 pair sums / sqrt 2, rows s/2.. differences."""
    h = np.zeros((s, s))
    for i in range(s // 2):
        h[i, 2 * i] = h[i, 2 * i + 1] = 1 / np.sqrt(2)
        h[s // 2 + i, 2 * i], h[s // 2 + i, 2 * i + 1] = 1 / np.sqrt(2), -1 / np.sqrt(2)
    return h


def _reference_haar2d(img: np.ndarray) -> np.ndarray:
    """Non-standard decomposition in float64: one 1D step on the rows and on the columns of the current
    top-left s x s block, then s /= 2 (Stollnitz, DeRose, Salesin, "Wavelets for computer graphics")."""
    out = img.astype(np.float64).copy()
    s = out.shape[0]
    while s > 1:
        h = _haar_matrix_1d_step(s)
        out[:s, :s] = np.einsum("ij,jk...->ik...", h, out[:s, :s])
        out[:s, :s] = np.einsum("ij,kj...->ki...", h, out[:s, :s])
        s //= 2
    return out


@pytest.mark.parametrize("side,channels", [(1, None), (2, None), (8, 3), (32, None), (64, 3)])
def test_forward_matches_reference_and_inverse_is_exact(side, channels):
    rng = np.random.default_rng(side)
    shape = (side, side) if channels is None else (side, side, channels)
    img = rng.standard_normal(shape).astype(np.float32)
    w = _native.haar2d(img)
    assert w.shape == img.shape and w.dtype == np.float32
    np.testing.assert_allclose(w, _reference_haar2d(img), atol=1e-5)
    back = _native.ihaar2d(w)
    assert np.abs(back - img).max() <= 4 * max(1, np.log2(side)) * np.finfo(np.float32).eps * np.abs(img).max()
    # Orthonormal: energy is kept.
    assert float((w.astype(np.float64) ** 2).sum()) == pytest.approx(float((img.astype(np.float64) ** 2).sum()), rel=1e-5)


def test_known_values():
    np.testing.assert_array_equal(_native.haar2d(np.array([[1, 2], [3, 5]], np.float32)), [[5.5, -1.5], [-2.5, 0.5]])
    c = _native.haar2d(np.full((16, 16), 0.5, np.float32))
    assert c[0, 0] == 8.0 and np.count_nonzero(c) == 1


def test_support_area_counts_basis_nonzeros():
    side = 16
    area = _native.haar_support_area(side)
    assert area.shape == (side, side) and area.dtype == np.int64
    for r in range(side):
        for c in range(side):
            e = np.zeros((side, side), np.float32)
            e[r, c] = 1.0
            assert np.count_nonzero(_native.ihaar2d(e)) == area[r, c]
    assert area[0, 0] == area[0, 1] == area[1, 1] == 256 and area[15, 15] == 4


def test_culling_nothing_reproduces_the_dense_product():
    """T g (dense, float64) equals the sparse wavelet product sum_j T^w[i, j] g^w[j] when every coefficient is
    kept (Eq. 3, W orthonormal), to float precision; keeping fewer area-weighted coefficients gives an error
    that falls as more are kept."""
    rng = np.random.default_rng(1)
    side, rows = 16, 20
    n = side * side
    t = rng.random((rows, n)).astype(np.float32)
    t *= np.exp(-np.arange(n) / 60.0).astype(np.float32)  # some structure for culling to exploit
    g = rng.random((side, side, 3)).astype(np.float32)
    dense = t.astype(np.float64) @ g.reshape(n, 3).astype(np.float64)
    gw = _native.haar2d(g).reshape(n, 3).astype(np.float64)

    def product(keep):
        out = np.zeros((rows, 3))
        for i in range(rows):
            idx, val = _native.haar_cull_area_weighted(_native.haar2d(t[i].reshape(side, side)), keep)
            out[i] = val.astype(np.float64) @ gw[idx]
        return out

    rel = lambda p: np.linalg.norm(p - dense) / np.linalg.norm(dense)  # noqa: E731
    assert rel(product(n)) < 1e-6
    errors = [rel(product(k)) for k in (4, 16, 64)]
    assert errors[0] > errors[1] > errors[2], errors


def test_area_weighted_culling_prefers_large_support():
    c = np.zeros((4, 4), np.float32)
    c[0, 1], c[0, 2], c[3, 3] = 0.5, 1.5, 1.9  # importance 0.5*16 = 8, 1.5*4 = 6, 1.9*4 = 7.6
    idx, val = _native.haar_cull_area_weighted(c, 2)
    assert idx.tolist() == [1, 15] and val.tolist() == [0.5, pytest.approx(1.9)]
    idx, val = _native.haar_cull_area_weighted(np.repeat(c[..., None], 3, axis=2), 1)
    assert idx.tolist() == [1] and val.shape == (1, 3)
    assert len(_native.haar_cull_area_weighted(c, 100)[0]) == 3  # zeros are never kept


def test_wavelet_light_culling():
    light = np.array([[0.1, 0, 0], [9, 9, 9], [0, 0.6, 0.8], [2, 0, 0]], np.float32)
    norms = np.array([5.0, 0.0, 1.0, 0.5], np.float32)  # products 0.5, 0, 1.0, 1.0
    assert _native.cull_wavelet_lights(light, norms, 0.0).tolist() == [0, 1, 2, 3]
    assert _native.cull_wavelet_lights(light, norms, 0.6).tolist() == [2, 3]
    assert _native.cull_wavelet_lights(light[:, 0].copy(), norms, 0.4).tolist() == [0, 3]
    assert _native.cull_wavelet_lights(light, norms, 1.01).tolist() == []


@pytest.mark.parametrize("shape", [(3, 3), (4, 2), (0, 0), (4, 4, 3, 1), (6, 6, 3)])
def test_bad_shapes(shape):
    a = np.zeros(shape, np.float32)
    with pytest.raises(ValueError):
        _native.haar2d(a)
    with pytest.raises(ValueError):
        _native.ihaar2d(a)


def test_bad_values():
    a = np.zeros((4, 4, 3), np.float32)
    a[2, 1, 1] = np.nan
    with pytest.raises(ValueError, match=r"image\[2, 1, 1\] is not finite"):
        _native.haar2d(a)
    with pytest.raises(TypeError):
        _native.haar2d(np.zeros((4, 4)))  # float64
    with pytest.raises(ValueError, match="keep"):
        _native.haar_cull_area_weighted(np.zeros((4, 4), np.float32), -1)
    for side in (0, 3, 1 << 16):
        with pytest.raises(ValueError, match="power of 2"):
            _native.haar_support_area(side)
    ok_light, ok_norms = np.ones((4, 3), np.float32), np.ones(4, np.float32)
    with pytest.raises(ValueError, match="epsilon"):
        _native.cull_wavelet_lights(ok_light, ok_norms, -1.0)
    with pytest.raises(ValueError, match="epsilon"):
        _native.cull_wavelet_lights(ok_light, ok_norms, float("nan"))
    with pytest.raises(ValueError):
        _native.cull_wavelet_lights(ok_light, np.ones(3, np.float32), 0.0)
    with pytest.raises(ValueError, match="image norm 1"):
        _native.cull_wavelet_lights(ok_light, np.array([1, -1, 1, 1], np.float32), 0.0)
    with pytest.raises(ValueError, match="wavelet light 2"):
        _native.cull_wavelet_lights(np.where(np.arange(12).reshape(4, 3) == 7, np.inf, 1).astype(np.float32), ok_norms, 0.0)
