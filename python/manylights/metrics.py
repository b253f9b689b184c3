"""Image error metrics (numpy)."""
from __future__ import annotations

import numpy as np

from ._validate import finite, numeric_array


def _pair(image, reference) -> tuple[np.ndarray, np.ndarray]:
    """Both images as float64 arrays of one non-empty shape, every value finite (a NaN would turn the
    metric into NaN, or count as an error, without saying where it came from).

    Raises:
        TypeError: a non-numeric array. ValueError: different shapes, empty images, NaN/inf (named)."""
    a = numeric_array("image", image, np.float64)
    b = numeric_array("reference", reference, np.float64)
    if a.shape != b.shape:
        raise ValueError(f"shapes differ: image {a.shape} vs reference {b.shape}")
    if a.size == 0:
        raise ValueError(f"images are empty: shape {a.shape}")
    return finite("image", a), finite("reference", b)


def relative_l2(image, reference) -> float:
    """||image - reference|| / ||reference|| over all pixels and channels (float64).

    Raises:
        ValueError: different shapes, empty images, NaN/inf values, or an all-zero reference."""
    a, b = _pair(image, reference)
    nb = np.linalg.norm(b)
    if nb == 0:
        raise ValueError("reference image is all zero: relative error undefined")
    return float(np.linalg.norm(a - b) / nb)


def fraction_within(image, reference, rel: float = 0.02, abs_: float = 1e-3) -> float:
    """Fraction of pixels whose every channel is within ``rel`` relative or ``abs_`` absolute of the reference.

    Raises:
        ValueError: different shapes, empty images, NaN/inf values, or a negative / NaN tolerance."""
    from ._validate import real

    rel, abs_ = real("rel", rel, 0.0), real("abs_", abs_, 0.0)
    a, b = _pair(image, reference)
    d = np.abs(a - b)
    ok = (d <= rel * np.abs(b)) | (d <= abs_)
    ok = ok.reshape(ok.shape[0], ok.shape[1], -1).all(axis=-1) if ok.ndim == 3 else ok
    return float(ok.mean())


def error_map(image, reference) -> np.ndarray:
    """Per-pixel relative error |a - b| / (|b| + 1e-3), averaged over channels, (H, W) float32.

    Raises:
        ValueError: images not of one (H, W, C) shape, empty, or with NaN/inf values."""
    a, b = _pair(image, reference)
    if a.ndim != 3:
        raise ValueError(f"images must have shape (H, W, C), got {a.shape}")
    return (np.abs(a - b) / (np.abs(b) + 1e-3)).mean(axis=-1).astype(np.float32)
