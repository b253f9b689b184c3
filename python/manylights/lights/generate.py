"""Lights of a scene: its delta emitters, and area, environment and indirect light turned into many point-like
lights (the columns of the light matrix)."""
from __future__ import annotations

import math
from typing import Optional

import numpy as np

from .. import _native
from .._native import LightSet, Scene
from .._utils import validate as _v
from .._utils.keywords import checked_keywords


@checked_keywords()
def scene_lights(scene: Scene) -> LightSet:
    """The scene's point, spot and directional emitters as a LightSet (area and environment emitters are
    turned into lights by the many-light generation, not here)."""
    return _native.scene_lights(scene)


@checked_keywords()
def generate_lights(
    scene: Scene,
    area: int = 4096,
    environment: int = 0,
    indirect: int = 0,
    max_depth: int = 5,
    clamp: Optional[float] = None,
    env_importance: bool = False,
    seed: int = 0,
    indirect_kind: str = "vpl",
    vsl_radius_scale: float = 1.0,
    vsl_neighbours: int = 16,
    vpl_importance: bool = False,
    vpl_view_samples: int = 256,
    vpl_accept_min: float = 0.01,
    env_visibility: bool = False,
) -> LightSet:
    """Turn a scene's emitters and its indirect light into point-like lights (many-light columns).

    The scene's point, spot and directional emitters come first, then ``area`` oriented point lights
    (stratified by area over all area emitters, split by power; their powers sum exactly to
    sum pi * area * radiance), ``environment`` directional lights (equal-area strata of the sphere, each
    carrying the environment radiance integrated over its stratum; powers sum to pi r^2 * int L dw with r
    the scene's bounding-sphere radius) and about ``indirect`` VPLs from particle tracing (paths with
    1 ..= max_depth - 2 bounces before the receiver, so the direct lights plus the VPLs estimate Mitsuba's
    ``path`` integrator with the same ``max_depth``).

    Args:
        scene: a loaded Scene.
        area: number of oriented point lights over all area emitters (0 for none).
        environment: number of directional lights over envmap / constant emitters.
        indirect: expected number of VPLs (the actual count is random around it).
        max_depth: Mitsuba's max_depth of the represented paths (>= 3 with indirect; -1 = unlimited).
        clamp: bound on the VPL geometry term cos cos / d^2 in 1/m^2; None = 1 / (0.1 * diagonal)^2,
            ``float("inf")`` = no clamp.
        env_importance: allocate environment strata by luminance (equal power per light).
        seed: same seed -> identical LightSet.
        indirect_kind: ``"vpl"`` (point VPLs, bounded by ``clamp``) or ``"vsl"``: virtual spherical
            lights (Hasan, Krivanek, Walter, Bala, SIGGRAPH Asia 2009, Sec. 4-5): each VPL spread over a
            sphere of radius ``vsl_radius_scale`` times the distance to its ``vsl_neighbours``-th
            nearest VPL (the ``vsl_radius`` property, m), its cap integrated against both cosines
            (``src/lights/vsl.rs``); not clamped. Still one column per light.
        vsl_radius_scale: > 0, finite (``"vsl"`` only).
        vsl_neighbours: k >= 1 of the k-th nearest VPL (``"vsl"`` only).
        vpl_importance: importance-sample the VPLs (and VSLs) by their estimated contribution to the
            camera's image (Georgiev and Slusallek, "Simple and Robust Iterative Importance Sampling of
            Virtual Point Lights", EG 2010 short paper): each particle-tracing candidate j is accepted
            with probability p_j = min(1, Phi_j / Phi_v + vpl_accept_min), its flux divided by p_j
            (unbiased: the same expected image), where Phi_j is its clamped contribution to about
            ``vpl_view_samples`` pilot pixel centres (exact shadow rays) and Phi_v the image's indirect
            contribution over ``indirect``; particles are traced until about ``indirect`` VPLs are
            accepted (at most indirect / vpl_accept_min candidates). CPU generation (the lights are
            ordinary columns for every backend and renderer); ``src/lights/generate/vpl_importance.rs``.
            Default False (measured accuracy and cost: docs/validation/accuracy.md).
        vpl_view_samples: integer in 1 ..= 65536, pilot view samples (``vpl_importance`` only).
        vpl_accept_min: eps in (0, 1], the floor of the acceptance probability (1 = plain VPLs).
        env_visibility: allocate the ``environment`` strata by what the camera sees of them: a coarse
            equal-area partition (``environment / 16`` cells, 8 to 4,096) is weighed by its cells'
            contributions to about 1,024 pilot pixel centres (exact shadow rays, the receivers' BSDFs),
            and each cell is cut into equal-area strata, a quarter of the lights spread evenly and the rest
            in proportion to contribution^(2/3). A room lit through a window gets its strata in the
            window. Still one directional light per stratum carrying its integral (the sum is the
            environment's, whatever the pilot saw); the seed jitters the pilot. Exclusive with
            ``env_importance``; with fewer than 128 environment lights, or a camera that sees no
            surface, the uniform strata. ``src/lights/generate/env_visibility.rs``; measured in
            docs/validation/accuracy.md.

    Returns:
        LightSet with numpy views ``kind`` (0 point, 1 spot, 2 directional, 3 oriented point, 4 VPL),
        ``position``, ``direction``, ``normal``, ``geo_normal``, ``incident``, ``intensity``, ``power``.

    Raises:
        ValueError: a negative, non-integer or too large count, a NaN or non-positive clamp,
            max_depth < 3 with indirect > 0, an indirect_kind other than "vpl"/"vsl", a
            vsl_radius_scale that is 0, negative, NaN or infinite, vsl_neighbours < 1, a non-bool
            vpl_importance, vpl_view_samples outside 1 ..= 65536, a vpl_accept_min that is NaN or
            outside (0, 1], vpl_importance on a camera that sees no surface (or that no pilot VPL
            reaches), env_importance and env_visibility both True, or a scene without emitters. Zero-area or zero-radiance
            emitters contribute nothing (no lights, no NaN).
    """
    counts = {"area": area, "environment": environment, "indirect": indirect, "max_depth": max_depth}
    for name, v in counts.items():
        counts[name] = _v.integer(name, v, None if name == "max_depth" else 0, 2**63 - 1)
    area, environment, indirect = counts["area"], counts["environment"], counts["indirect"]
    max_depth = counts["max_depth"]
    seed = _v.seed(seed)
    if clamp is not None:
        clamp = float(clamp)
        if not clamp > 0.0:
            raise ValueError(f"clamp must be > 0 (or inf for no clamp), got {clamp}")
    if indirect_kind not in ("vpl", "vsl"):
        raise ValueError(f"indirect_kind must be 'vpl' or 'vsl', got {indirect_kind!r}")
    vsl_radius_scale = float(vsl_radius_scale)
    if not (vsl_radius_scale > 0.0 and math.isfinite(vsl_radius_scale)):
        raise ValueError(f"vsl_radius_scale must be finite and > 0, got {vsl_radius_scale}")
    vsl_neighbours = _v.integer("vsl_neighbours", vsl_neighbours, 1, 1 << 20)
    for name, flag in (("vpl_importance", vpl_importance), ("env_importance", env_importance),
                       ("env_visibility", env_visibility)):
        if not isinstance(flag, (bool, np.bool_)):
            raise ValueError(f"{name} must be True or False, got {flag!r}")
    vpl_view_samples = _v.integer("vpl_view_samples", vpl_view_samples, 1, 1 << 16)
    vpl_accept_min = _v.real("vpl_accept_min", vpl_accept_min, 0.0, 1.0)
    if not vpl_accept_min > 0.0:
        raise ValueError(f"vpl_accept_min must be in (0, 1], got {vpl_accept_min}")
    return _native.generate_lights(
        scene, int(area), int(environment), int(indirect), int(max_depth), clamp, bool(env_importance), int(seed),
        indirect_kind, vsl_radius_scale, int(vsl_neighbours), bool(vpl_importance), int(vpl_view_samples),
        vpl_accept_min, bool(env_visibility),
    )
