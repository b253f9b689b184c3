"""Lights for animations: one ``LightSet`` per frame, light j the same light in every frame.

Tensor clustering (Hašan, Velázquez, Pellacini, Bala, EGSR 2008) clusters light-frame pairs (j, k), so
light j of frame k must be light j of frame 0 moved with its surface. ``generate_animation_lights`` makes
such sets (the Rust module ``lights::animated`` has the derivation):

- delta emitters (point, spot, directional) from each frame's scene;
- ``area`` oriented points sampled on frame 0's area emitters and tied to (shape, triangle,
  barycentrics), re-evaluated on every frame (intensity L_e A_e(k) / n_e with the frame's emitter area);
- ``environment`` directional lights whose directions (equal-area strata) are the same in every frame;
- ``indirect`` gather samples (Sec. 5 of the paper) tied to all surfaces, shaded in each
  frame by that frame's direct light with exact shadow rays (plus, with ``photons`` > 0, multiple-bounce
  irradiance by density estimation of a photon pre-pass without the first hit), each a cosine-emitting
  light: a VPL with its Lambertian k_d and flux E A.

Symbols: f frames, n lights per frame, E irradiance (W/m^2), A a gather sample's area (m^2).
"""
from __future__ import annotations

from typing import Optional

from .. import _native
from .._utils import validate as _v
from .._utils.keywords import checked_keywords


class AnimationLights:
    """One ``LightSet`` per frame (``len``, ``[k]``, iteration), each with ``n`` lights in the order delta,
    area, environment, indirect; ``counts`` gives how many of each kind."""

    def __init__(self, frames: list, counts: dict):
        self.frames = list(frames)
        self.counts = dict(counts)

    def __len__(self) -> int:
        return len(self.frames)

    def __getitem__(self, k):
        return self.frames[k]

    def __iter__(self):
        return iter(self.frames)

    @property
    def n(self) -> int:
        """Lights per frame."""
        return len(self.frames[0]) if self.frames else 0

    def __repr__(self) -> str:
        return f"AnimationLights({len(self)} frames x {self.n} lights, {self.counts})"


@checked_keywords()
def generate_animation_lights(animation, *, area: int = 1024, environment: int = 0, indirect: int = 0,
                              photons: int = 0, max_depth: int = -1, clamp: Optional[float] = None,
                              seed: int = 0) -> AnimationLights:
    """Lights for every frame of an animation (module docs; the paper's Sec. 5).

    Args:
        animation: an ``Animation`` (``load_animation``) or a sequence of ``Scene`` with the same shapes.
        area: oriented points over the area emitters (split by power, stratified by area on frame 0).
        environment: directional lights over the environment map (same directions in every frame).
        indirect: gather samples turned into indirect lights (0 for none); those on surfaces without
            diffuse reflectance are left out, so ``counts["indirect"]`` may be smaller.
        photons: photons of the multiple-bounce pre-pass per frame (0: one bounce of indirect light).
        max_depth: Mitsuba's max_depth bounding the photons' bounces (-1 unlimited).
        clamp: VPL geometry-term clamp (1/m^2), None for ``generate_lights``' default of frame 0.
        seed: seeds every random choice (the same lights for the same frames and seed).

    Returns:
        AnimationLights: f LightSets of n lights each.

    Raises:
        ValueError: no frames, negative counts, frames whose shapes differ
            in topology or whose numbers of emitters differ (the frame is named), a frame without emitters.
    """
    scenes = [animation[k] for k in range(len(animation))]
    if not scenes:
        raise ValueError("the animation has no frames")
    sets, counts = _native.generate_animation_lights(
        scenes, _v.integer("area", area, 0, 1 << 26), _v.integer("environment", environment, 0, 1 << 26),
        _v.integer("indirect", indirect, 0, 1 << 26), _v.integer("photons", photons, 0, 1 << 26),
        _v.integer("max_depth", max_depth, -1, 1 << 20), clamp, _v.seed(seed))
    return AnimationLights(sets, counts)
