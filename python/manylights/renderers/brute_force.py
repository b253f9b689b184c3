"""Brute force (every column, plus what the camera sees directly)."""
from __future__ import annotations

from typing import Optional, Sequence

import numpy as np

from .._native import LightSet, Scene
from .._utils.keywords import checked_keywords
from ..matrix.light_matrix import LightMatrix


@checked_keywords()
def render_brute_force(scene: Scene, lights: LightSet, *, weights: Optional[Sequence[float]] = None,
                       shadow_map_size: int = 1024, visibility: Optional[str] = None,
                       progress: Optional[bool] = None, max_depth: int = -1, device: str = "auto") -> np.ndarray:
    """The brute-force image of ``lights``: ``A.column_sum(weights) + A.emitted()``, (H, W, 3) float32.

    ``column_sum`` is the light matrix only; ``emitted`` adds what the camera sees directly (area emitters
    seen from their front side, the environment behind background pixels), as Mitsuba's ``path`` does, so
    the result compares with a Mitsuba render of the same scene.

    Args:
        scene: a loaded Scene.
        lights: e.g. ``generate_lights(scene, area=4096, environment=4096, indirect=16384)``.
        weights: optional (n,) per-light weights.
        device, shadow_map_size, visibility, max_depth: as ``LightMatrix`` (``max_depth``: Mitsuba's path depth for
            what mirrors and glass show; use the reference's, e.g. 2 for direct light only).
        progress: progress over light batches (None: a bar in a terminal or notebook, nothing in logs;
            True: also a few lines in logs; False: nothing).

    Raises:
        ValueError: bad weights, ``device``, ``visibility``, ``shadow_map_size`` or ``max_depth``.
        GpuUnavailableError: ``device="gpu"`` without a GPU adapter.
    """
    A = LightMatrix(scene, lights, shadow_map_size=shadow_map_size, visibility=visibility, max_depth=max_depth,
                    device=device)
    return A.column_sum(weights, progress=progress) + A.emitted()
