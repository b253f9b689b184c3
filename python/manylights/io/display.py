"""Looking at images: ``show`` (inline in a Jupyter notebook, else a PNG file) and ``png_bytes`` (the PNG that
``write_png`` writes, as bytes: what the results' ``_repr_png_`` returns)."""
from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import Optional, Union

import numpy as np

from .._utils.keywords import checked_keywords
from .images import write_png

#: At most this many frames of an animation side by side.
MAX_FRAMES = 8


def displayable(image) -> np.ndarray:
    """``image`` as one (H, W, 3) float32 linear image: a result's ``image`` (``RenderResult``) or its frames
    side by side (``AnimationResult``, (f, H, W, 3): up to ``MAX_FRAMES`` evenly spaced); (H, W) and
    (H, W, 1) as grey; (H, W, 4) without its alpha.

    Raises:
        ValueError: any other shape, or an empty image. TypeError: a non-numeric array."""
    if hasattr(image, "image") and not isinstance(image, np.ndarray):
        image = image.image
    elif hasattr(image, "frames") and not isinstance(image, np.ndarray):
        image = image.frames
    a = np.asarray(image)
    if a.dtype.kind not in "fiub":
        raise TypeError(f"image must be a real numeric array, got dtype {a.dtype}")
    a = a.astype(np.float32, copy=False)
    if a.ndim == 4 and a.shape[-1] == 3 and a.shape[0] > 0:
        picks = np.unique(np.linspace(0, a.shape[0] - 1, min(a.shape[0], MAX_FRAMES)).round().astype(int))
        a = np.concatenate(list(a[picks]), axis=1)
    if a.ndim == 2:
        a = a[..., None]
    if a.ndim == 3 and a.shape[-1] == 1:
        a = np.repeat(a, 3, axis=-1)
    if a.ndim == 3 and a.shape[-1] == 4:
        a = a[..., :3]
    if a.ndim != 3 or a.shape[-1] != 3 or a.size == 0:
        raise ValueError(f"image must have shape (H, W), (H, W, 1), (H, W, 3), (H, W, 4) or (f, H, W, 3) and not "
                         f"be empty, got {np.shape(image)}")
    return np.ascontiguousarray(a)


def png_bytes(image, exposure: float = 0.0) -> bytes:
    """The 8-bit sRGB PNG of ``image`` (any shape ``displayable`` takes), scaled by 2**exposure and clamped,
    exactly as ``write_png`` writes it.

    Raises:
        ValueError, TypeError: as ``displayable`` and ``write_png``."""
    with tempfile.TemporaryDirectory(prefix="manylights-png-") as d:
        path = Path(d) / "image.png"
        write_png(path, displayable(image), exposure)
        return path.read_bytes()


def in_notebook() -> bool:
    """Whether this runs in a Jupyter kernel (IPython importable and its shell has a kernel app)."""
    try:
        from IPython import get_ipython
    except ImportError:
        return False
    shell = get_ipython()
    return shell is not None and "IPKernelApp" in getattr(shell, "config", {})


@checked_keywords()
def show(image, exposure: float = 0.0, *, path: Optional[Union[str, os.PathLike]] = None) -> Optional[Path]:
    """Look at an image: inline in a Jupyter notebook, else as a PNG file.

    Args:
        image: (H, W, 3) linear RGB (also (H, W) or (H, W, 1) grey, (H, W, 4) whose alpha is dropped), a
            ``RenderResult`` (its ``image``) or an ``AnimationResult`` / (f, H, W, 3) frames (up to 8 side by
            side); any real dtype.
        exposure: scale by 2**exposure before the sRGB encoding (clamped to [0, 1], as ``write_png``).
        path: write the PNG here instead of displaying it.

    Returns:
        None when shown inline (in a Jupyter kernel, ``path`` not given); otherwise the ``Path`` of the PNG
        written: ``path``, or a new ``manylights-*.png`` in the system's temporary folder (its name is
        printed, for a terminal user to open).

    Raises:
        ValueError: an unsupported shape, an empty image, a non-finite exposure. TypeError: a non-numeric
            array. OSError: ``path`` cannot be written.
    """
    if path is None and in_notebook():
        from IPython.display import Image, display

        display(Image(data=png_bytes(image, exposure), format="png"))
        return None
    if path is None:
        fd, name = tempfile.mkstemp(prefix="manylights-", suffix=".png")
        os.close(fd)
        out = Path(name)
        write_png(out, displayable(image), exposure)
        print(f"manylights.show: wrote {out}")
        return out
    out = Path(path)
    write_png(out, displayable(image), exposure)
    return out
