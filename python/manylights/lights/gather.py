"""Gather clouds: the gather samples of direct-to-indirect relighting (Hašan, Pellacini, Bala 2006,
Sec. 4.1) and the indirect lights of tensor clustering, tied to surfaces so they follow an animation."""
from __future__ import annotations

from .. import _native
from .._native import GatherCloud, Scene
from .._utils import validate as _v
from .._utils.keywords import checked_keywords

__all__ = ["GatherCloud", "gather_cloud"]


@checked_keywords()
def gather_cloud(scene: Scene, n: int = 4**7, seed: int = 0, *, include_emitters: bool = True) -> GatherCloud:
    """n = 4^k gather samples spread uniformly by area over the scene's surfaces (Sec. 4.1).

    The paper's divide-and-conquer stratification: the triangles (and analytic spheres) are split by
    axis-aligned planes into halves of equal area, the budget split in proportion (randomly rounded), down
    to single triangles, which are bisected further into equal-area halves, so every point has the same
    sample density n / total area and each shape gets its area share of samples within a few samples.
    Every surface is sampled, emitters' own surfaces too unless ``include_emitters=False``.

    Args:
        scene: a loaded Scene.
        n: number of samples, a power of 4 (the cloud flattens into a 2^k x 2^k gather image), 1 ..= 4^12.
        seed: same scene and seed -> bit-identical cloud.
        include_emitters: also sample the surfaces of area emitters.

    Returns:
        GatherCloud with numpy arrays ``positions`` (n, 3) float32 (m), ``normals`` (shading) and
        ``geo_normals`` (n, 3) float32, ``uv`` (n, 2), ``areas`` (n,) float32 (m^2 each sample stands
        for: total area / n), ``shape`` (n,) int64, ``triangle`` (n,) int64 (-1 on an analytic sphere),
        ``barycentrics`` (n, 2) float32 ((b1, b2); on a sphere its (u, v) = (phi / 2 pi, theta / pi)),
        ``k_d`` (n, 3) float32 diffuse coefficient (textures evaluated; diffuse reflectance of diffuse,
        plastic, roughplastic; base_color (1 - metallic)(1 - spec_trans) of principled; blends mixed),
        ``k_g`` (n, 3) glossy coefficient (specular_reflectance of roughplastic / roughconductor;
        lerp(1, base_color, metallic) of principled; 0 otherwise), ``roughness`` (n,) (alpha of the glossy
        lobe), ``bsdf`` (opaque records), ``total_area``, ``diagonal``, ``side``; ``cloud.on(scene2)``
        re-evaluates the samples on a scene of the same topology (next animation frame), and
        ``cloud.hierarchy(K=30)`` builds the quad-tree and gather-image layout (Sec. 4.2).

    Raises:
        ValueError: n not a power of 4 (0, 2, 8, ...) or too large, a non-integer n or seed, or a scene
            without any surface of positive area.
        SceneError: a mesh with out-of-range indices or non-finite vertices.
    """
    if not isinstance(scene, Scene):
        raise TypeError(f"scene must be a manylights Scene, got {type(scene).__name__}")
    n = _v.integer("n", n, 0, 2**63 - 1)
    return _native.gather_cloud(scene, n, _v.seed(seed), bool(include_emitters))
