"""Row selection of the light matrix: stratified view samples (Hašan et al. 2007, Sec. 4)."""
from __future__ import annotations

import numpy as np

from .. import _native
from .._native import Scene
from .._utils import validate as _v
from .._utils.keywords import checked_keywords


@checked_keywords()
def stratified_rows(scene: Scene, r: int, seed: int = 0) -> np.ndarray:
    """Stratified row selection (Hašan et al. 2007, Sec. 4): the image is cut into ``r`` blocks of nearly
    equal area (bands of about sqrt(r * H / W) rows of blocks, heights proportional to their block counts)
    and one pixel is drawn uniformly in each block (``seed``: same seed, same rows).

    Background pixels may be drawn; their rows are zero.

    Returns:
        (r,) int64 view sample indices ``y * W + x``, one per block, top band first.

    Raises:
        ValueError: r not an integer, r < 1 or r > W * H.
    """
    if not isinstance(scene, Scene):
        raise TypeError(f"scene must be a manylights Scene, got {type(scene).__name__}")
    r = _v.integer("r", r)
    m = scene.width * scene.height
    if not 1 <= r <= m:
        raise ValueError(f"r must be in [1, {m}] (view samples of a {scene.width}x{scene.height} image), got {r}")
    return _native.stratified_rows(scene.width, scene.height, r, _v.seed(seed))
