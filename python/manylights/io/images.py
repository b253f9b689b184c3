"""Image files: float32 OpenEXR and 8-bit sRGB PNG.

Both writers encode in memory and write through ``_utils.files.atomic_write``: a temporary file beside the
target, synced and renamed over it, so the target is always the old file or the complete new one (an error,
a full disk, Ctrl-C or a killed process in the middle included), with the umask's mode (or the replaced
file's)."""
from __future__ import annotations

import os

import numpy as np

from .. import _native
from .._native import read_exr
from .._utils import validate as _v
from .._utils.files import atomic_write
from .._utils.keywords import checked_keywords

__all__ = ["read_exr", "write_exr", "write_png", "as_image"]


@checked_keywords()
def write_exr(path: str | os.PathLike, image: np.ndarray) -> None:
    """Write an (H, W, 3) image as float32 RGB OpenEXR.

    Raises:
        ValueError: a shape other than (H, W, 3) or an empty image. TypeError: a non-numeric array.
        OSError: the file cannot be written (named; the old file, if any, is kept)."""
    atomic_write(_path(path), data=_native.encode_exr(as_image(image)))


@checked_keywords()
def write_png(path: str | os.PathLike, image: np.ndarray, exposure: float = 0.0) -> None:
    """Write an (H, W, 3) linear image as 8-bit sRGB PNG, scaled by 2**exposure and clamped.

    Raises:
        ValueError: a bad shape, an empty image or a non-finite exposure. TypeError: a non-numeric array.
        OSError: the file cannot be written (named; the old file, if any, is kept)."""
    atomic_write(_path(path), data=_native.encode_png(as_image(image), _v.real("exposure", exposure)))


def _path(path) -> str | os.PathLike:
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a str or os.PathLike, got {type(path).__name__}")
    return path


def as_image(image) -> np.ndarray:
    a = _v.numeric_array("image", image)
    if a.ndim != 3 or a.shape[2] != 3:
        raise ValueError(f"image must have shape (H, W, 3), got {a.shape}")
    if a.size == 0:
        raise ValueError(f"image is empty: shape {a.shape}")
    return a
