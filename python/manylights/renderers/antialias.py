"""Anti-aliasing from a deep framebuffer at 3x the resolution (Hašan et al., "Tensor Clustering for
Rendering Many-Light Animations", EGSR 2008, Sec. 5; Hašan et al. 2006, Sec. 3.6).

Works on the image of any renderer: shading is computed once per pixel centre; the deep framebuffer
(position, normal, albedo) is rendered at ``factor`` x the resolution; every high-resolution sample takes
the colour of its nearest neighbour, in the 9-D metric of the pixel mappings, among the 3x3 pixels around
the one containing it; each pixel is then the mean (box filter) of its ``factor^2`` samples. Pixel
interiors keep their colour; edge pixels become area-weighted mixes of their neighbours, as a box-filtered
many-sample render (Mitsuba's ``rfilter box``) is.
"""
from __future__ import annotations

import numpy as np

from .. import _native
from .._native import Scene
from .._utils import validate as _v
from .._utils.keywords import checked_keywords

__all__ = ["antialias"]


@checked_keywords()
def antialias(image, scene: Scene, factor: int = 3, *, device: str = "auto") -> np.ndarray:
    """Anti-alias an image rendered from ``scene`` at pixel centres (paper Sec. 5, "Anti-aliasing").

    Args:
        image: (H, W, C) image of ``scene`` (its film size), any real dtype, e.g. (H, W, 3) radiance from
            any renderer (brute force, MRCS, tensor clustering) including what the camera sees directly.
        scene: the Scene the image was rendered from.
        factor: the deep framebuffer's resolution multiplier (the paper: 3); 1 returns the image.
        device: where the deep framebuffers are computed ("auto", "cpu": BVH ray casting, "gpu": raster).
            The high-resolution one is cached per (scene, factor) while the scene lives.

    Returns:
        (H, W, C) float32: the box filter of the upsampled image.

    Raises:
        ValueError: an image whose (H, W) is not the scene's film, an empty channel axis, a factor outside
            [1, 16] or not an integer, an unknown device.
        TypeError: a non-numeric image or ``scene`` not a Scene.
    """
    if not isinstance(scene, Scene):
        raise TypeError(f"scene must be a manylights Scene, got {type(scene).__name__}")
    factor = _v.integer("factor", factor, 1, 16)
    img = _v.numeric_array("image", image)
    if img.ndim != 3 or img.shape[:2] != (scene.height, scene.width) or img.shape[2] == 0:
        raise ValueError(f"image must have shape ({scene.height}, {scene.width}, C) to match the scene's "
                         f"{scene.width}x{scene.height} film, got {np.shape(image)}")
    if not isinstance(device, str):
        raise ValueError(f"device must be 'auto', 'gpu' or 'cpu', got {device!r}")
    return _native.antialias(img, scene, int(factor), device)
