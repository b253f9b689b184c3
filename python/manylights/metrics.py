"""Image error metrics (numpy)."""
from __future__ import annotations

import numpy as np


def relative_l2(image, reference) -> float:
    """||image - reference|| / ||reference|| over all pixels and channels (float64)."""
    a = np.asarray(image, dtype=np.float64)
    b = np.asarray(reference, dtype=np.float64)
    if a.shape != b.shape:
        raise ValueError(f"shapes differ: {a.shape} vs {b.shape}")
    nb = np.linalg.norm(b)
    if nb == 0:
        raise ValueError("reference image is all zero: relative error undefined")
    return float(np.linalg.norm(a - b) / nb)


def fraction_within(image, reference, rel: float = 0.02, abs_: float = 1e-3) -> float:
    """Fraction of pixels whose every channel is within ``rel`` relative or ``abs_`` absolute of the reference."""
    a = np.asarray(image, dtype=np.float64)
    b = np.asarray(reference, dtype=np.float64)
    if a.shape != b.shape:
        raise ValueError(f"shapes differ: {a.shape} vs {b.shape}")
    d = np.abs(a - b)
    ok = (d <= rel * np.abs(b)) | (d <= abs_)
    ok = ok.reshape(ok.shape[0], ok.shape[1], -1).all(axis=-1) if ok.ndim == 3 else ok
    return float(ok.mean())


def error_map(image, reference) -> np.ndarray:
    """Per-pixel relative error |a - b| / (|b| + 1e-3), averaged over channels, (H, W) float32."""
    a = np.asarray(image, dtype=np.float64)
    b = np.asarray(reference, dtype=np.float64)
    return (np.abs(a - b) / (np.abs(b) + 1e-3)).mean(axis=-1).astype(np.float32)
