"""manylights: many-light rendering research on the CPU (rayon, exact rays) or the GPU (wgpu), checked against Mitsuba 3.

Quick start::

    import manylights as ml
    scene = ml.load_scene("scene.xml", res=128)       # like mitsuba.load_file(path, **params)
    lights = ml.scene_lights(scene)                    # point / spot / directional emitters
    A = ml.LightMatrix(scene, lights)                  # m x n: m = H*W view samples, n = len(lights)
    img = A.column_sum() + A.emitted()                 # (H, W, 3) float32: all lights + visible emitters
    img = ml.render_brute_force(scene, ml.generate_lights(scene, area=4096))  # the same in one call
    ml.write_exr("out.exr", img); ml.write_png("out.png", img)
"""
from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Optional, Sequence

import numpy as np

from . import _native
from . import _validate as _v
from ._native import (
    GpuError,
    GpuUnavailableError,
    LightSet,
    ManyLightsError,
    Scene,
    SceneError,
    device_info,
    read_exr,
)
from .metrics import flicker, fraction_within, relative_l2, relative_l2_per_frame
from .progress import progress_bar as _progress_bar
from .mrcs import RenderResult, instant_radiosity, mrcs, power_sampling
from .adaptive import mrcs_progressive
from .tensor import TensorClustering, cluster_tensor, tensor_clustering
from .gather import GatherCloud, gather_cloud
from .relight import DirectToIndirect
from .clustered import clustered_shading, clustered_visibility
from .kmeans import KMeansResult, fuzzy_membership, kmeans

__version__ = _native.__version__

__all__ = [
    "Animation",
    "DirectToIndirect",
    "GatherCloud",
    "GpuError",
    "GpuUnavailableError",
    "LightMatrix",
    "LightSet",
    "LightTensor",
    "AnimationResult",
    "ManyLightsError",
    "RenderResult",
    "Scene",
    "SceneError",
    "antialias",
    "apply_mapping",
    "TensorClustering",
    "cluster_reduced_columns",
    "cluster_tensor",
    "clustered_shading",
    "clustered_visibility",
    "tensor_clustering",
    "clustering_cost",
    "device_info",
    "flicker",
    "fraction_within",
    "generate_animation_lights",
    "gather_cloud",
    "generate_lights",
    "instant_radiosity",
    "load_animation",
    "load_scene",
    "mrcs",
    "mrcs_progressive",
    "render",
    "mrcs_per_frame",
    "power_sampling",
    "read_exr",
    "relative_l2",
    "relative_l2_per_frame",
    "render_brute_force",
    "scene_lights",
    "stratified_rows",
    "sweep",
    "write_exr",
    "write_exr_sequence",
    "write_png",
    "write_video",
    "side_by_side",
    "KMeansResult",
    "kmeans",
    "fuzzy_membership",
]


def load_scene(path: str | os.PathLike, *, size: Optional[tuple[int, int]] = None, **params) -> Scene:
    """Load a Mitsuba 3 XML scene.

    Args:
        path: the scene's XML file.
        size: optional (width, height) overriding the film (for scenes whose film size is no parameter).
        **params: values for the file's ``<default name=...>`` parameters, as ``mitsuba.load_file`` takes
            them (``res=128``); converted with ``str``.

    Raises:
        FileNotFoundError: the scene or a file it names is missing.
        SceneError: malformed XML or an unsupported plugin (the message names file, line and value); an
            image (texture, environment map) declaring more than 16384^2 pixels.
        MemoryError: an image whose decoding needs more host memory than is available or allowed by
            ``MANYLIGHTS_MEMORY_LIMIT`` (the message names the file, its size and the limit).

    Warns:
        UserWarning: for input Mitsuba accepts with a warning (e.g. a mesh whose triangles all have zero
            area: it stays as an empty shape, so shape indices match Mitsuba's).
    """
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"scene file not found: {p}")
    conv = []
    for k, v in params.items():
        if isinstance(v, bool):
            v = "true" if v else "false"
        conv.append((k, str(v)))
    if size is not None:
        if np.ndim(size) != 1 or len(size) != 2:
            raise ValueError(f"size must be (width, height) positive integers, got {size!r}")
        size = (_v.integer("size[0] (width)", size[0], 1, 2**32 - 1),
                _v.integer("size[1] (height)", size[1], 1, 2**32 - 1))
    return _native.load_scene(str(p), conv, size)


def scene_lights(scene: Scene) -> LightSet:
    """The scene's point, spot and directional emitters as a LightSet (area and environment emitters are
    turned into lights by the many-light generation, not here)."""
    return _native.scene_lights(scene)


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
            Default False (README, issue 13: measured accuracy and cost).
        vpl_view_samples: integer in 1 ..= 65536, pilot view samples (``vpl_importance`` only).
        vpl_accept_min: eps in (0, 1], the floor of the acceptance probability (1 = plain VPLs).

    Returns:
        LightSet with numpy views ``kind`` (0 point, 1 spot, 2 directional, 3 oriented point, 4 VPL),
        ``position``, ``direction``, ``normal``, ``geo_normal``, ``incident``, ``intensity``, ``power``.

    Raises:
        ValueError: a negative, non-integer or too large count, a NaN or non-positive clamp,
            max_depth < 3 with indirect > 0, an indirect_kind other than "vpl"/"vsl", a
            vsl_radius_scale that is 0, negative, NaN or infinite, vsl_neighbours < 1, a non-bool
            vpl_importance, vpl_view_samples outside 1 ..= 65536, a vpl_accept_min that is NaN or
            outside (0, 1], vpl_importance on a camera that sees no surface (or that no pilot VPL
            reaches), or a scene without emitters. Zero-area or zero-radiance
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
    if not isinstance(vpl_importance, (bool, np.bool_)):
        raise ValueError(f"vpl_importance must be True or False, got {vpl_importance!r}")
    vpl_view_samples = _v.integer("vpl_view_samples", vpl_view_samples, 1, 1 << 16)
    vpl_accept_min = _v.real("vpl_accept_min", vpl_accept_min, 0.0, 1.0)
    if not vpl_accept_min > 0.0:
        raise ValueError(f"vpl_accept_min must be in (0, 1], got {vpl_accept_min}")
    return _native.generate_lights(
        scene, int(area), int(environment), int(indirect), int(max_depth), clamp, bool(env_importance), int(seed),
        indirect_kind, vsl_radius_scale, int(vsl_neighbours), bool(vpl_importance), int(vpl_view_samples),
        vpl_accept_min,
    )


class LightMatrix:
    """The m x n light matrix of a scene: A[i, j] = light j's contribution to view sample i (pixel centre).

    Computed by one of two backends with the same shading (``device``):

    - ``"cpu"``: Rust on every core (rayon), an exact shadow ray per light-sample pair through the scene's
      BVH (Mitsuba's ray offsets). On machines without a hardware GPU it is 5-20x faster than the
      software GPU adapter (README: measured figures).
    - ``"gpu"``: wgpu compute passes; shadow maps (cube maps for point lights, perspective maps for spots,
      orthographic maps for directional lights) decide where they are certain and exact GPU rays elsewhere
      (``visibility``); columns are accumulated on the GPU, nothing is read back per column.
    - ``"auto"`` (default): the ``MANYLIGHTS_DEVICE`` environment variable when it is set, else a hardware
      GPU if there is one, else the CPU (a software adapter such as lavapipe only when asked for, by
      ``device="gpu"``, ``MANYLIGHTS_ADAPTER`` or a shadow-map ``visibility``). ``A.device`` says which ran.

    Both backends give the same exact matrix (columns and rows equal to 1e-5 relative with
    ``visibility="ray_traced"``, tested), so every renderer runs on either unchanged.

    Args:
        scene: a loaded Scene.
        lights: a LightSet (e.g. ``scene_lights(scene)``).
        device: ``"auto"``, ``"cpu"`` or ``"gpu"`` (above).
        shadow_map_size: GPU only: texels per side of each shadow map (cube face). Default: 512 for
            ``"hybrid"`` (the exact ray decides wherever a map is unsure, so the size only trades shadow-map
            texels for rays: on cbox 128^2 columns at 512^2 cost 8.4 ms against 16.4 ms at 1024^2 with the
            same image to 1e-4), 1024 for ``"shadow_map"`` (where the size sets the accuracy).
        visibility: how shadow tests are decided: ``"ray_traced"`` (an exact ray for every test; the only
            mode of the CPU backend and its default), ``"hybrid"`` (the GPU's default: shadow maps where they
            are certain, an exact GPU ray elsewhere) or ``"shadow_map"`` (biased shadow maps only; fastest on
            a GPU, small errors at contact edges). ``"hybrid"`` and ``"shadow_map"`` need the GPU: with
            ``device="auto"`` they choose it.
        max_depth: Mitsuba's ``path`` ``max_depth`` for what pixels see through mirrors and glass: a camera
            ray hitting a smooth conductor, dielectric or plastic's specular layer follows every delta
            lobe (Fresnel-weighted reflection and refraction) to the first rough surface, which becomes an
            extra view sample of the pixel with its RGB throughput (a row of the matrix is a pixel: the sum
            of its samples). -1 (default) = unlimited (at most 8 delta bounces, branches below 1e-3
            throughput dropped); 2 = direct light only (mirrors show the emitters they reflect).
        glossy_roughness: glossy highlights by BSDF sampling with multiple importance sampling (issue 13
            item 3, Veach and Guibas 1995; rule and formulas in ``src/matrix/glossy.rs``): view samples on a
            ``roughplastic`` / ``roughconductor`` whose GGX/Beckmann alpha is below this threshold (in
            [0, 1]; 0 = off; default 0.2) weight the columns of area and uniform-environment light samples by
            the power-heuristic light weight w_L = q_L^2 / (q_L^2 + (n_B p_B)^2) (q_L the density of the light
            samples in that direction, p_B the BSDF pdf), and ``emitted()`` adds the BSDF-sampled rest
            (n_B = ``bsdf_samples`` rays per glossy sample, exact visibility, weight w_B = 1 - w_L), so
            every renderer's image includes it. Diffuse receivers keep pure many-light columns. Delta
            lights and VPLs are never weighted.
        bsdf_samples: n_B, BSDF samples per glossy view sample (1..65536; default 256).
        glossy_seed: seed of those BSDF samples (same seed, same image).

    Raises:
        ValueError: an unknown ``device`` or ``visibility`` (or an invalid ``MANYLIGHTS_DEVICE``), shadow-map
            visibility with ``device="cpu"``, a bad ``shadow_map_size`` or ``max_depth`` (0, 1 or < -1), a
            ``glossy_roughness`` outside [0, 1] or a ``bsdf_samples`` outside 1..65536.
        GpuUnavailableError: ``device="gpu"`` on a machine without any GPU adapter (the message says what
            to install).
    """

    def __init__(self, scene: Scene, lights: LightSet, *, device: str = "auto", shadow_map_size: Optional[int] = None,
                 visibility: Optional[str] = None, max_depth: int = -1, glossy_roughness: float = 0.2,
                 bsdf_samples: int = 256, glossy_seed: int = 0):
        self.scene = scene
        self.lights = lights
        if not isinstance(device, str):
            raise ValueError(f"device must be 'auto', 'gpu' or 'cpu', got {device!r}")
        if visibility is not None and not isinstance(visibility, str):
            raise ValueError(f"visibility must be 'hybrid', 'ray_traced' or 'shadow_map', got {visibility!r}")
        if shadow_map_size is None:
            shadow_map_size = 1024 if visibility == "shadow_map" else 512
        #: Texels per side of each shadow map (the default resolved; GPU only).
        self.shadow_map_size = _v.integer("shadow_map_size", shadow_map_size, 16, 8192)
        self._m = _native.LightMatrix(scene, lights, self.shadow_map_size, visibility=visibility,
                                      max_depth=_v.integer("max_depth", max_depth, -1, 1 << 20), device=device,
                                      glossy_roughness=_v.real("glossy_roughness", glossy_roughness, 0.0, 1.0),
                                      bsdf_samples=_v.integer("bsdf_samples", bsdf_samples, 1, 65536),
                                      glossy_seed=_v.integer("glossy_seed", glossy_seed, 0, (1 << 64) - 1))

    @property
    def device(self) -> dict:
        """The device computing this matrix: ``kind`` ("cpu" or "gpu"), ``name`` (CPU model or GPU
        adapter), ``backend`` ("rayon", "vulkan", ...), ``is_software``, ``threads`` (CPU workers)."""
        return dict(self._m.device)

    @property
    def visibility(self) -> str:
        """How shadow tests are decided: "ray_traced" (always on the CPU), "hybrid" or "shadow_map"."""
        return self._m.visibility

    @property
    def glossy_work(self) -> tuple[int, int]:
        """Glossy MIS work (issue 13, item 3): (view samples that get BSDF samples, BSDF samples in all),
        both ints; (0, 0) when no view sample's lobe alpha is below ``glossy_roughness`` (e.g. a
        diffuse-only scene: pure many-light columns)."""
        return tuple(self._m.glossy_work)

    def visibility_stats(self) -> dict[str, int]:
        """Counters since creation: ``shadow_tests``, ``ray_casts`` (tests resolved by exact rays) and
        ``gave_up`` (rays that ran out of traversal steps; should be 0)."""
        return dict(self._m.visibility_stats())

    @property
    def shape(self) -> tuple[int, int]:
        """(m, n): view samples (H * W) by lights."""
        return tuple(self._m.shape)

    def view_samples(self) -> dict:
        """The matrix's view samples (the shading points; the paper's deep framebuffer): pixels first, row
        by row, then the surfaces seen through delta chains (mirrors, glass), m_s >= H * W of them.

        Returns:
            dict: ``position`` (m_s, 3) float32 world units, ``normal`` (m_s, 3) float32 unit shading normal,
            ``pixel`` (m_s,) int64 the pixel (y * W + x) each sample belongs to, ``surface`` (m_s,) bool
            (False for background pixels, whose position and normal are 0)."""
        return dict(self._m.view_samples())

    def columns(self, indices: Sequence[int]) -> np.ndarray:
        """Columns ``indices`` as images, (k, H, W, 3) float32.

        Raises:
            ValueError: indices that are not integers (bools, floats) or outside [0, n), or not 1-D."""
        idx = _v.indices("column index", indices, self.shape[1], f"n = {self.shape[1]} lights")
        return self._m.columns([int(i) for i in idx])

    def column_sum(self, weights: Optional[Sequence[float]] = None, *, progress: bool = True) -> np.ndarray:
        """Sum of all columns, each times its weight (default 1), (H, W, 3) float32: the matrix part of
        the brute-force image (add ``emitted()`` for the image itself; ``render_brute_force`` does).

        Args:
            weights: optional (n,) weights.
            progress: show progress over light batches (a bar in terminals and notebooks, a few log
                lines elsewhere: ``manylights.progress``).

        Raises:
            ValueError: weights not of shape (n,), or NaN/inf. TypeError: non-numeric weights.
        """
        w = None
        if weights is not None:
            w = _v.numeric_array("weights", weights)
            if w.ndim != 1 or w.shape[0] != self.shape[1]:
                raise ValueError(f"weights must have shape (n,) = ({self.shape[1]},) (length n), got {w.shape}")
        with _progress_bar(self.shape[1], "columns", progress) as callback:
            return self._m.column_sum(w, callback)

    def weighted_sum(self, indices: Sequence[int], weights, *, progress: bool = False) -> np.ndarray:
        """``sum_k weights[k] * column[indices[k]]`` with (k, 3) RGB weights, rendering only those columns
        (repeated indices add up): how clustered renderers reconstruct an image. (H, W, 3) float32.

        Raises:
            ValueError: indices not integers in [0, n); weights not (k,) or (k, 3), or NaN/inf."""
        idx = [int(i) for i in _v.indices("column index", indices, self.shape[1], f"n = {self.shape[1]} lights")]
        w = _v.numeric_array("weights", weights)
        if w.ndim not in (1, 2):
            raise ValueError(f"weights must have shape (k,) or (k, 3), got {w.shape}")
        if w.ndim == 1:
            w = np.repeat(w[:, None], 3, axis=1)
        with _progress_bar(len(idx), "columns", progress) as callback:
            return self._m.weighted_sum(idx, w, callback)

    def rows(self, indices: Sequence[int], *, progress: bool = True, shadow_map_size: int = 256,
             return_timings: bool = False):
        """Rows ``indices`` of the matrix (the reduced matrix R of matrix row-column sampling), (r, n, 3)
        float32: R[k, j] = light j's contribution to view sample ``indices[k]`` (pixel ``y * W + x``).

        On the CPU every element casts its exact shadow ray (parallel over lights). On the GPU each row is
        shaded from a cube depth map centred at its view sample (``shadow_map_size`` texels per face), with
        the same emission, BSDF and visibility mode as ``columns``. Either way
        ``A.rows(I)[:, J]`` equals ``A.columns(J).reshape(len(J), -1, 3)[:, I].transpose(1, 0, 2)`` up to
        ambiguous visibility. Background samples give zero rows.

        Args:
            indices: (r,) view sample indices in [0, m), repeats allowed, 1 <= r <= m.
            progress: show progress over row batches (as ``column_sum``).
            shadow_map_size: GPU only: texels per cube face (16..=8192).
            return_timings: also return a dict of seconds per stage (setup, shadow_maps, evaluation, readback;
                the CPU backend spends everything in evaluation).

        Raises:
            ValueError: no indices, more indices than view samples, an index outside [0, m), or a bad
                ``shadow_map_size``.
        """
        m, n = self.shape
        if isinstance(indices, np.ndarray) and indices.dtype == bool:
            raise ValueError("row indices must be integers, got a bool array (use np.flatnonzero(mask))")
        idx = _v.indices("row index", indices, m, f"m = {m} view samples")
        if idx.size == 0:
            raise ValueError("rows needs at least one row index, got 0")
        if idx.size > m:
            raise ValueError(f"{idx.size} rows requested but the matrix has only m = {m} view samples")
        shadow_map_size = _v.integer("shadow_map_size", shadow_map_size, 16, 8192)
        with _progress_bar(int(idx.size), "rows", progress, unit="row") as callback:
            R, timings = self._m.rows([int(i) for i in idx], callback, int(shadow_map_size))
        if return_timings:
            return R, dict(timings)
        return R

    def emitted(self) -> np.ndarray:
        """What the camera sees directly, (H, W, 3) float32, as Mitsuba's ``path`` integrator at depth 0:
        view samples on an area emitter's shape show its radiance when seen from its +normal side
        (shading normal), background pixels the environment (envmap / constant emitters) along the
        pixel-centre camera ray. Not part of any column: every renderer adds it
        (``render_brute_force`` = ``column_sum() + emitted()``). NaN/inf emitter values count as 0.
        With glossy view samples (``glossy_roughness``) it also holds the BSDF-sampled strategy of
        glossy MIS (each glossy sample's ``bsdf_samples`` rays to area emitters and the environment,
        weighted by w_B = 1 - w_L; seeded by ``glossy_seed``), so every renderer's image includes it."""
        return self._m.emitted()

    def bias_compensation(self, max_depth: int = -1, spp: int = 1, light_samples: int = 64, seed: int = 0) -> np.ndarray:
        """The energy the VPL geometry-term clamp removes, estimated without bias by short BSDF-sampled
        paths (Kollig and Keller 2004; ``src/matrix/bias_compensation.rs``), (H, W, 3) float32, to add
        to an image like ``emitted()``: ``column_sum() + emitted() + bias_compensation()`` estimates the
        unclamped VPL image. Computed on the CPU (rayon) whatever ``device``.

        Args:
            max_depth: Mitsuba's max_depth the lights were generated with (-1 = unlimited); a path
                vertex at level l uses the direct lights when l + 2 <= max_depth and the VPLs when
                l + 3 <= max_depth (exact for 3 and unlimited); 0 <= max_depth < 3 gives zeros (no VPLs).
            spp: BSDF samples per view sample (>= 1).
            light_samples: lights drawn per path vertex proportionally to their unshadowed
                contribution (0 = all lights traced, exact).
            seed: same seed -> identical image.

        Raises:
            ValueError: spp < 1, a negative light_samples, or a light set holding virtual spherical
                lights (not clamped). Zero for an infinite clamp or a set without VPLs.
        """
        spp = _v.integer("spp", spp, 1, 1 << 24)
        light_samples = _v.integer("light_samples", light_samples, 0, 1 << 24)
        max_depth = _v.integer("max_depth", max_depth, -1, 1 << 30)
        return self._m.bias_compensation(int(max_depth), int(spp), int(light_samples), _v.seed(seed))

    def _index(self, name: str, v, size: int, what: str) -> int:
        if isinstance(v, (bool, np.bool_)) or int(v) != v:
            raise ValueError(f"{name} must be an integer, got {v!r}")
        if not 0 <= int(v) < size:
            raise ValueError(f"{name} = {v} is out of range for {size} {what}")
        return int(v)

    def element(self, i: int, j: int) -> np.ndarray:
        """A(i, j), (3,) float32, by exact CPU ray casting (the same shading as the GPU columns, exact
        visibility with Mitsuba's ray offsets). ``i = y * W + x``.

        Raises:
            ValueError: i not in [0, m) or j not in [0, n).
        """
        m, n = self.shape
        return self._m.element(self._index("i", i, m, "view samples"), self._index("j", j, n, "lights"))

    def row_exact(self, i: int) -> np.ndarray:
        """Row i (view sample ``i = y * W + x``) of A by exact CPU ray casting, (n, 3) float32.

        Raises:
            ValueError: i not in [0, m).
        """
        return self._m.row_exact(self._index("i", i, self.shape[0], "view samples"))

    def column_exact(self, j: int) -> np.ndarray:
        """Column j of A by exact CPU ray casting, as an image (H, W, 3) float32.

        Raises:
            ValueError: j not in [0, n).
        """
        return self._m.column_exact(self._index("j", j, self.shape[1], "lights"))

    def __repr__(self) -> str:
        m, n = self.shape
        return f"LightMatrix({m} view samples x {n} lights, {self.device['kind']}: {self.device['name']})"


def cluster_reduced_columns(R, c: int, *, seed: int = 0, power=None, projection_dim: int = 50,
                            sampling_fraction: float = 2.0 / 3.0, color_averaging: bool = False) -> dict:
    """Cluster the reduced columns of a reduced matrix as Matrix Row-Column Sampling does (Hašan et al. 2007).

    Args:
        R: (r, n, 3) RGB or (r, n) scalar reduced matrix (any float dtype; converted to float32).
        c: number of clusters (1 <= c <= n).
        seed: seeds the random projection, the sampling, the splitting lines and the representatives.
        power: optional (n,) light powers, used to pick representatives of zero-norm reduced columns.
        projection_dim: r' of the random Gaussian projection applied when r > r'.
        sampling_fraction: share of the clusters made by sampling before top-down splitting (paper: 2/3).
        color_averaging: the paper's per-channel representative scaling (biased; off = unbiased grey weights).

    Returns:
        dict with assignment (n,), representatives (c,), weights (c, 3), cost, cluster_costs (c,),
        probability (n,) float64 (chance of each light being its cluster's representative).

    Raises:
        ValueError: bad shapes, NaN/inf (row and column named), c not an integer in [1, n], a negative or
            non-integer seed, power of the wrong length / negative / NaN, sampling_fraction outside [0, 1].
        TypeError: a non-numeric (complex, string) R or power.
    """
    R = _v.numeric_array("R", R)
    if power is not None:
        power = _v.numeric_array("power", power).reshape(-1)
    return _native.cluster_reduced_columns(R, _v.integer("c", c, 1, 2**63 - 1), _v.seed(seed), power,
                                           _v.integer("projection_dim", projection_dim, 1, 2**63 - 1),
                                           _v.real("sampling_fraction", sampling_fraction, 0.0, 1.0),
                                           bool(color_averaging))


def clustering_cost(R, assignment) -> float:
    """Sum of the paper's cluster costs of a partition (assignment (n,)) on the scalar reduced matrix.

    Raises:
        ValueError: labels that are not integers in [0, 2^31), an assignment not of length n, NaN/inf in R."""
    R = _v.numeric_array("R", R)
    labels = np.asarray(assignment)
    if labels.dtype.kind not in "iu":
        raise ValueError(f"assignment labels must be integers, got dtype {labels.dtype}")
    if labels.size and (labels.min() < 0 or labels.max() > np.iinfo(np.int32).max):
        raise ValueError(f"assignment labels must be in [0, 2^31), got {labels.min()} .. {labels.max()}")
    return _native.clustering_cost(R, np.ascontiguousarray(labels, dtype=np.int32))
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


def write_exr(path: str | os.PathLike, image: np.ndarray) -> None:
    """Write an (H, W, 3) image as float32 RGB OpenEXR.

    Raises:
        ValueError: a shape other than (H, W, 3) or an empty image. TypeError: a non-numeric array.
        OSError: the file cannot be written (named)."""
    _native.write_exr(str(path), _as_image(image))


def write_png(path: str | os.PathLike, image: np.ndarray, exposure: float = 0.0) -> None:
    """Write an (H, W, 3) linear image as 8-bit sRGB PNG, scaled by 2**exposure and clamped.

    Raises:
        ValueError: a bad shape, an empty image or a non-finite exposure. TypeError: a non-numeric array.
        OSError: the file cannot be written (named)."""
    _native.write_png(str(path), _as_image(image), _v.real("exposure", exposure))


def _as_image(image) -> np.ndarray:
    a = _v.numeric_array("image", image)
    if a.ndim != 3 or a.shape[2] != 3:
        raise ValueError(f"image must have shape (H, W, 3), got {a.shape}")
    if a.size == 0:
        raise ValueError(f"image is empty: shape {a.shape}")
    return a


from .render import render_brute_force  # noqa: E402  (needs LightMatrix above)
from .auto_budget import render  # noqa: E402  (after .render: the function ml.render replaces the submodule attribute)
from .animation import Animation, apply_mapping, load_animation  # noqa: E402  (needs load_scene above)
from .antialias import antialias  # noqa: E402
from .animated import AnimationLights, generate_animation_lights  # noqa: E402
from .light_tensor import AnimationResult, LightTensor, mrcs_per_frame  # noqa: E402
from .video import side_by_side, write_exr_sequence, write_video  # noqa: E402  (needs write_exr above)
from .sweep import sweep  # noqa: E402  (dask and pandas are imported when a sweep runs)
