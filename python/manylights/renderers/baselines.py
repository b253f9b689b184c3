"""Baselines of Matrix Row-Column Sampling (Hašan, Pellacini, Bala 2007, Sec. 6): power sampling (c lights
drawn by power, unbiased weights, no rows) and instant radiosity (fewer lights, all rendered).
"""
from __future__ import annotations

import time
from typing import Optional

import numpy as np

from .._native import Scene
from .._utils import validate as _v
from .._utils.keywords import checked_keywords
from ..lights.generate import generate_lights
from ..matrix.light_matrix import LightMatrix
from .bias import bias_sources
from .mrcs import reconstruct
from .probe_error import attach_probe_error
from .result import RenderResult, light_luminance_power, matrix_shape


@checked_keywords()
def power_sampling(A, columns: int = 900, seed: int = 0, *, add_emitted: bool = True,
                   progress: Optional[bool] = None, error_probes: int = 0) -> RenderResult:
    """Baseline: draw ``columns`` lights with probability proportional to their power (with replacement)
    and weight each by 1 / (columns * p_j): an unbiased estimate of the column sum that ignores visibility
    and geometry (no rows). Lights of zero power are never drawn (they emit nothing).

    Args:
        error_probes: N > 0: N path-traced probe pixels estimate the error against the converged scene, bias
            included (``probe_error``: ``error_estimate`` the upper bound, ``bias_estimate``); 0: none.

    Raises:
        TypeError: A is not a LightMatrix. ValueError: columns not an integer in [1, 2^31), a negative
            seed, lights without finite power."""
    m, n = matrix_shape(A)
    columns = _v.integer("columns", columns, 1, 2**31 - 1)
    error_probes = _v.integer("error_probes", error_probes, 0, 2**31 - 1)
    seed = _v.seed(seed)
    if n == 0:
        raise ValueError(f"power_sampling needs lights (n = {n})")
    t = time.perf_counter()
    p = light_luminance_power(A.lights)
    if not np.isfinite(p).all() or p.sum() <= 0:
        raise ValueError("power_sampling: the lights carry no (finite) power")
    p = p / p.sum()
    rng = np.random.default_rng(seed)
    reps = rng.choice(n, size=int(columns), p=p)
    w = (1.0 / (columns * p[reps])).astype(np.float32)
    weights = np.repeat(w[:, None], 3, axis=1)
    timings = {"sampling": time.perf_counter() - t}
    image = reconstruct(A, reps, weights, timings, add_emitted, progress)
    res = RenderResult(image=image, method="power_sampling", seed=seed, timings=timings, representatives=reps,
                        weights=weights, budget={"columns": int(columns), "lights": int(n)}, device=A.device,
                        bias_sources=bias_sources(A))
    return attach_probe_error(res, A.scene, error_probes, seed) if error_probes else res


@checked_keywords(LightMatrix)
def instant_radiosity(scene, lights: int = 2500, seed: int = 0, *, area_fraction: float = 0.5,
                      environment_fraction: float = 0.0, max_depth: int = 5, clamp=None,
                      progress: Optional[bool] = None, error_probes: int = 0, **matrix_options) -> RenderResult:
    """Baseline: generate only ``lights`` lights (area / environment / indirect shares as given) and render
    all of them (Keller's instant radiosity with the same light generation as the large matrix).

    Args:
        error_probes: N > 0: N path-traced probe pixels estimate the error against the converged scene, bias
            included (``probe_error``: ``error_estimate`` the upper bound, ``bias_estimate``); 0: none.

    Raises:
        TypeError: scene is not a Scene. ValueError: lights not an integer >= 1, fractions outside [0, 1]
            or summing past 1, and whatever ``generate_lights`` / ``LightMatrix`` refuse."""
    if not isinstance(scene, Scene):
        raise TypeError(f"scene must be a manylights Scene, got {type(scene).__name__}")
    lights = _v.integer("lights", lights, 1, 2**63 - 1)
    error_probes = _v.integer("error_probes", error_probes, 0, 2**31 - 1)
    area_fraction = _v.real("area_fraction", area_fraction, 0.0, 1.0)
    environment_fraction = _v.real("environment_fraction", environment_fraction, 0.0, 1.0)
    if area_fraction + environment_fraction > 1.0:
        raise ValueError(f"area_fraction + environment_fraction must be <= 1, got {area_fraction} + "
                         f"{environment_fraction}")
    t = time.perf_counter()
    has_env = any(e["type"] in ("envmap", "constant") for e in scene.emitters)
    has_area = any(e["type"] == "area" for e in scene.emitters)
    n_env = int(round(lights * environment_fraction)) if has_env else 0
    n_area = int(round(lights * area_fraction)) if has_area else 0
    n_ind = max(lights - n_env - n_area, 0)
    L = generate_lights(scene, area=n_area, environment=n_env, indirect=n_ind, max_depth=max_depth, clamp=clamp,
                        seed=seed)
    timings = {"lights": time.perf_counter() - t}
    t = time.perf_counter()
    A = LightMatrix(scene, L, **matrix_options)
    image = A.column_sum(progress=progress)
    timings["columns"] = time.perf_counter() - t
    t = time.perf_counter()
    image = image + A.emitted()
    timings["emitted"] = time.perf_counter() - t
    res = RenderResult(image=image, method="instant_radiosity", seed=seed, timings=timings,
                       budget={"lights": int(len(L)), "area": n_area, "environment": n_env, "indirect": n_ind},
                       device=A.device, bias_sources=bias_sources(A))
    return attach_probe_error(res, scene, error_probes, seed) if error_probes else res
