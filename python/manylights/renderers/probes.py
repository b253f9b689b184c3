"""Probe pixels: an unbiased CPU path tracer at a few pixels, the project's own reference estimator of the
converged image (bias included), so that a render's error can be estimated without Mitsuba at run time."""
from __future__ import annotations

from typing import Optional, Tuple

import numpy as np

from .. import _native
from .._native import LightSet, Scene
from .._utils import validate as _v
from .._utils.keywords import checked_keywords
from .._utils.progress import progress_bar


@checked_keywords()
def probe_pixels(scene: Scene, pixels, spp: int = 256, max_depth: int = -1, seed: int = 0, *,
                 progress: Optional[bool] = None, lights: Optional[LightSet] = None,
                 guided_env: bool = True) -> Tuple[np.ndarray, np.ndarray]:
    """Mean radiance and the variance of that mean at probe pixels, by an unbiased path tracer.

    The estimator is Mitsuba 3's ``path`` integrator (``src/pathtrace/mod.rs`` has the details): each of
    the ``spp`` paths of a probe starts at the pixel's own camera hit, the same pixel-centre view sample
    the images of ``scene`` use (Mitsuba's camera ray through the pixel centre; the environment along it
    for a background pixel), then at every vertex samples the emitters (point, spot and directional lights
    exactly; area emitters by a point uniform on their shape; the environment by a table over 16,384
    equal-area cells, ``guided_env``) and the BSDF, combined by multiple importance sampling with the power heuristic (Veach 1997);
    delta BSDFs (mirrors, glass, smooth plastic's coating) are sampled as Mitsuba does; Russian roulette
    from depth 5 with probability ``min(max(throughput) * eta^2, 0.95)``. Its expectation is the
    converged pixel-centre value of Mitsuba's ``path`` integrator with the same ``max_depth`` (what a
    pixel-centre Mitsuba render with a box filter converges to), with none of the bounds or clamps of
    the light-matrix renderers. Runs on the CPU in parallel over probes and blocks of 64 paths.

    Args:
        scene: a loaded Scene (its film size defines the pixels).
        pixels: (k, 2) integers, the (row, column) of each probe, row 0 at the top (``image[row, col]``);
            repeated pixels are independent estimates.
        spp: paths per probe, >= 2. The standard error falls as 1 / sqrt(spp).
        max_depth: Mitsuba's path depth in segments: -1 unlimited (full global illumination), 1 only
            emitters seen directly, 2 direct light only, 3 one indirect bounce, ...
        seed: random seed (>= 0); the same seed gives bit-identical output on any machine thread count.
        progress: paths done, when the call is long (None: a bar in a terminal or notebook, nothing in logs;
            True: also a few lines in logs; False: nothing).
        lights: a ``LightSet`` lighting the scene INSTEAD of its emitters (point, spot, directional, oriented
            points with their near-field patches, VPLs with their clamp, as ``LightMatrix`` shades them),
            every light sampled at every vertex (one uniformly when there are more than 8); the scene's
            emitters neither emit nor are seen (what ``DirectToIndirect.relight`` renders). None: the
            scene's own emitters.
        guided_env: sample the environment by a defensive mixture (0.6 / 0.3 / 0.1) of its luminance times
            what a unit of radiance from each direction adds to a pilot view of about 1,024 pixel centres
            (256 coarse cells, exact shadow rays; a window's directions in a room lit through it), its
            luminance, and uniform; False: 0.9 luminance + 0.1 uniform. Either is unbiased (multiple
            importance sampling with the BSDF); the guide costs a pilot per call.

    Returns:
        (mean, variance_of_mean): two (k, 3) float32 arrays of RGB radiance (the scene's units, as
        Mitsuba's image) and of the variance of each mean (radiance^2): the per-path sample variance
        divided by ``spp``. A z-score against another estimate is ``(a - b) / sqrt(var_a + var_b)``.

    Raises:
        ValueError: ``pixels`` not of shape (k, 2) or with a pixel outside the film, non-integer pixels,
            ``spp`` < 2, ``max_depth`` 0 or < -1, a negative ``seed``, or a scene with a ``principled`` BSDF
            (not supported: the call refuses rather than return a wrong value).
        TypeError: ``scene`` not a Scene; ``pixels`` not numeric; ``lights`` not a LightSet.
        KeyboardInterrupt: Ctrl-C (checked between blocks of paths).
    """
    if not isinstance(scene, Scene):
        raise TypeError(f"scene must be a manylights Scene, got {type(scene).__name__}")
    arr = np.asarray(pixels)
    if arr.dtype.kind not in "iu" and not (arr.dtype.kind == "f" and arr.size == 0):
        if arr.dtype.kind in "fb":
            raise ValueError(f"pixels must be integers (row, column), got dtype {arr.dtype}")
        raise TypeError(f"pixels must be an integer array of (row, column), got dtype {arr.dtype}")
    if arr.size == 0:
        arr = arr.reshape(0, 2)
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise ValueError(f"pixels must have shape (k, 2) of (row, column), got shape {arr.shape}")
    px = np.ascontiguousarray(arr, dtype=np.int64)
    spp = _v.integer("spp", spp, 2, 2**32 - 1)
    max_depth = _v.integer("max_depth", max_depth, -1)
    if max_depth == 0:
        raise ValueError("max_depth must be -1 (unlimited) or >= 1, got 0")
    seed = _v.seed(seed)
    if lights is not None and not isinstance(lights, LightSet):
        raise TypeError(f"lights must be a manylights LightSet or None, got {type(lights).__name__}")
    total = int(px.shape[0]) * spp
    # A bar only for calls long enough to need one (~1e6 paths take seconds).
    with progress_bar(total, "probe paths", progress if total >= 1_000_000 else False, unit="path") as callback:
        return _native.probe_pixels(scene, px, spp, max_depth, seed, callback, lights, bool(guided_env))
