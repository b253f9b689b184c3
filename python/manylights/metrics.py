"""Image error metrics (numpy)."""
from __future__ import annotations

import numpy as np

from ._utils.keywords import checked_keywords
from ._utils.validate import finite, numeric_array, real


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


@checked_keywords()
def relative_l2(image, reference) -> float:
    """||image - reference|| / ||reference|| over all pixels and channels (float64).

    Raises:
        ValueError: different shapes, empty images, NaN/inf values, or an all-zero reference."""
    a, b = _pair(image, reference)
    nb = np.linalg.norm(b)
    if nb == 0:
        raise ValueError("reference image is all zero: relative error undefined")
    return float(np.linalg.norm(a - b) / nb)


@checked_keywords()
def fraction_within(image, reference, rel: float = 0.02, abs_: float = 1e-3) -> float:
    """Fraction of pixels whose every channel is within ``rel`` relative or ``abs_`` absolute of the reference.

    Raises:
        ValueError: different shapes, empty images, NaN/inf values, or a negative / NaN tolerance."""
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


def _animation_pair(frames, reference) -> tuple[np.ndarray, np.ndarray]:
    """Both animations as float64 (f, H, W, C) arrays of one shape, every value finite."""
    a, b = _pair(frames, reference)
    if a.ndim != 4:
        raise ValueError(f"animations must have shape (f, H, W, 3), got {a.shape}")
    return a, b


@checked_keywords()
def relative_l2_per_frame(frames, reference) -> np.ndarray:
    """Relative L2 error of every frame: ``||X_k - R_k|| / ||R_k||`` over pixels and channels.

    Args:
        frames, reference: (f, H, W, 3) animations (any real dtype; computed in float64).

    Returns:
        (f,) float64.

    Raises:
        ValueError: shapes that differ or are not (f, H, W, C), empty arrays, NaN/inf values (index named),
            a reference frame that is all zero (frame named)."""
    a, b = _animation_pair(frames, reference)
    den = np.sqrt((b * b).reshape(len(b), -1).sum(axis=1))
    zero = np.flatnonzero(den == 0)
    if zero.size:
        raise ValueError(f"reference frame {int(zero[0])} is all zero: relative error undefined")
    return np.sqrt(((a - b) ** 2).reshape(len(a), -1).sum(axis=1)) / den


@checked_keywords()
def flicker(frames, reference) -> float:
    """Temporal flicker of an animation against its reference: the relative L2 norm of the frame-to-frame
    change of the error,

        flicker = sqrt( mean_k ||E_{k+1} - E_k||^2 / (2 mean_k ||R_k||^2) ),   E_k = X_k - R_k,

    sums over pixels and channels, k = 0 .. f-2 in the numerator and 0 .. f-1 in the denominator.

    Why this form: an error that stays the same from frame to frame (a fixed bias, a clustering reused
    over frames) does not flicker and scores 0; an error that changes does. Normalising by the
    reference's energy, not by its own frame differences, keeps it finite for a static reference (a
    camera that does not move). The factor 2 makes it equal the per-frame relative L2 for errors that are
    independent between frames with equal energy (E[||E_{k+1} - E_k||^2] = 2 E||E||^2): per-frame MRCS with
    new random choices every frame then has flicker ~ its relative L2, and a method reusing its choices
    over time has less. It is 0 for the reference and grows linearly with the amplitude of added
    temporal noise.

    Args:
        frames, reference: (f, H, W, 3) animations with f >= 2 (any real dtype; computed in float64).

    Returns:
        float.

    Raises:
        ValueError: shapes that differ or are not (f, H, W, C), fewer than 2 frames, NaN/inf values, an
            all-zero reference."""
    a, b = _animation_pair(frames, reference)
    if len(a) < 2:
        raise ValueError(f"flicker needs at least 2 frames, got {len(a)}")
    den = 2.0 * float((b * b).sum()) / len(b)
    if den == 0:
        raise ValueError("reference animation is all zero: flicker undefined")
    num = float((np.diff(a - b, axis=0) ** 2).sum()) / (len(a) - 1)
    return float(np.sqrt(num / den))


def _pair_eps(image, reference, eps):
    """``_pair`` of the two images (float64) and ``eps`` checked > 0, for relMSE and SMAPE."""
    eps = real("eps", eps, 0.0)
    if eps <= 0:
        raise ValueError(f"eps must be > 0, got {eps}")
    a, b = _pair(image, reference)
    return a, b, eps


@checked_keywords()
def relmse(image, reference, eps: float = 1e-2) -> float:
    """Relative mean squared error (Rousselle, Knaus, Zwicker, "Adaptive Sampling and Reconstruction using
    Greedy Error Minimization", SIGGRAPH Asia 2011, Sec. 3; the error of Bitterli et al. 2020's ReSTIR
    comparisons):

        relMSE = mean over pixels and channels of (image - reference)^2 / (reference^2 + eps)

    ``eps`` (default 1e-2, in squared radiance units) keeps dark pixels from dominating.

    Args:
        image, reference: arrays of one shape, e.g. (H, W, 3) (any real dtype; computed in float64).
        eps: > 0.

    Returns:
        float.

    Raises:
        ValueError: different shapes, empty images, NaN/inf values, eps <= 0 or NaN."""
    a, b, eps = _pair_eps(image, reference, eps)
    return float(np.mean((a - b) ** 2 / (b * b + eps)))


@checked_keywords()
def smape(image, reference, eps: float = 1e-2) -> float:
    """Symmetric mean absolute percentage error (Vogels et al., "Denoising with Kernel Prediction and
    Asymmetric Loss Functions", SIGGRAPH 2018, Sec. 6; Müller et al. 2021 report it for neural radiance
    caching):

        SMAPE = mean over pixels and channels of |image - reference| / (|image| + |reference| + eps)

    in [0, 1); ``eps`` (default 1e-2, radiance units) keeps pixels where both are ~0 at 0.

    Args:
        image, reference: arrays of one shape, e.g. (H, W, 3) (any real dtype; computed in float64).
        eps: > 0.

    Returns:
        float.

    Raises:
        ValueError: different shapes, empty images, NaN/inf values, eps <= 0 or NaN."""
    a, b, eps = _pair_eps(image, reference, eps)
    return float(np.mean(np.abs(a - b) / (np.abs(a) + np.abs(b) + eps)))


@checked_keywords()
def flip(image, reference, *, return_map: bool = False):
    """HDR-FLIP (Andersson et al., "FLIP: A Difference Evaluator for Alternating Images", HPG 2020; HDR
    version: "Visualizing Errors in Rendered High Dynamic Range Images", Eurographics 2021 short papers)
    by NVIDIA's ``flip-evaluator`` package (pinned in requirements-dev.txt), with its defaults: the
    images are linear sRGB radiance (as every image here), tone-mapped by ACES at the exposures from
    ``c_start`` to ``c_stop`` that the package derives from the reference (Sec. 3 of the HDR paper), 67
    pixels per degree; the mean over pixels of the per-pixel maximum over exposures.

    Args:
        image, reference: (H, W, 3) non-negative linear RGB (any real dtype; passed as float32).
        return_map: also return the (H, W) float32 FLIP error map.

    Returns:
        float mean FLIP in [0, 1] (0 = identical), or (mean, map) with ``return_map``.

    Raises:
        ImportError: ``flip-evaluator`` is not installed (``pip install flip-evaluator==1.7``).
        ValueError: shapes that differ or are not (H, W, 3), NaN/inf or negative values."""
    a, b = _pair(image, reference)
    if a.ndim != 3 or a.shape[-1] != 3:
        raise ValueError(f"images must have shape (H, W, 3), got {a.shape}")
    for name, v in (("image", a), ("reference", b)):
        if (v < 0).any():
            k = np.unravel_index(int(np.argmin(v)), v.shape)
            raise ValueError(f"{name} has a negative value {float(v[k])} at {tuple(int(x) for x in k)}: "
                             "HDR-FLIP needs non-negative radiance")
    try:
        import flip_evaluator
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("manylights.metrics.flip needs the flip-evaluator package: "
                          "pip install flip-evaluator==1.7") from e
    fmap, mean, _ = flip_evaluator.evaluate(np.ascontiguousarray(b, dtype=np.float32),
                                            np.ascontiguousarray(a, dtype=np.float32), "HDR", applyMagma=False)
    mean = float(mean)
    return (mean, np.asarray(fmap, dtype=np.float32).reshape(a.shape[:2])) if return_map else mean
