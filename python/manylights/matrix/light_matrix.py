"""The light matrix A of a scene (m view samples x n lights) on the CPU or GPU backend."""
from __future__ import annotations

from typing import Optional, Sequence

import numpy as np

from .. import _native
from .._native import LightSet, Scene
from .._utils import validate as _v
from .._utils.keywords import checked_keywords
from .._utils.progress import progress_bar


class LightMatrix:
    """The m x n light matrix of a scene: A[i, j] = light j's contribution to view sample i (pixel centre).

    Computed by one of two backends with the same shading (``device``):

    - ``"cpu"``: Rust on every core (rayon), an exact shadow ray per light-sample pair through the scene's
      BVH (Mitsuba's ray offsets). On machines without a hardware GPU it is 5-20x faster than the
      software GPU adapter (docs/validation/backends.md: measured figures).
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
            mode of the CPU backend, and the default on the CPU and on a hardware GPU, where it is the
            fastest: on an H200, 3-16x faster column sums than ``"hybrid"``), ``"hybrid"`` (the default on a
            software adapter such as lavapipe: shadow maps where they are certain, an exact GPU ray
            elsewhere) or ``"shadow_map"`` (biased shadow maps only; small errors at contact edges). ``"hybrid"`` and ``"shadow_map"`` need the GPU: with
            ``device="auto"`` they choose it.
        max_depth: Mitsuba's ``path`` ``max_depth`` for what pixels see through mirrors and glass: a camera
            ray hitting a smooth conductor, dielectric or plastic's specular layer follows every delta
            lobe (Fresnel-weighted reflection and refraction) to the first rough surface, which becomes an
            extra view sample of the pixel with its RGB throughput (a row of the matrix is a pixel: the sum
            of its samples). -1 (default) = unlimited (at most 8 delta bounces, branches below 1e-3
            throughput dropped); 2 = direct light only (mirrors show the emitters they reflect).
        glossy_roughness: glossy highlights by BSDF sampling with multiple importance sampling
            (Veach and Guibas 1995; rule and formulas in ``src/matrix/glossy.rs``): view samples on a
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
            ``glossy_roughness`` outside [0, 1] or a ``bsdf_samples`` outside 1..65536; ``device="gpu"`` for a
            scene the GPU backend does not support (``device="auto"`` takes the CPU for one, and
            ``device_info(scene=scene)`` says why; every scene the XML loader accepts runs on both backends,
            masked surfaces included).
        GpuUnavailableError: ``device="gpu"`` on a machine without any GPU adapter (the message says what
            to install).
    """

    @checked_keywords()
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
        #: Lobes with alpha below this get BSDF samples (glossy MIS; ``glossy_work`` counts them).
        self.glossy_roughness = _v.real("glossy_roughness", glossy_roughness, 0.0, 1.0)
        self._m = _native.LightMatrix(scene, lights, self.shadow_map_size, visibility=visibility,
                                      max_depth=_v.integer("max_depth", max_depth, -1, 1 << 20), device=device,
                                      glossy_roughness=self.glossy_roughness,
                                      bsdf_samples=_v.integer("bsdf_samples", bsdf_samples, 1, 65536),
                                      glossy_seed=_v.integer("glossy_seed", glossy_seed, 0, (1 << 64) - 1))

    @property
    def device(self) -> dict:
        """The device computing this matrix: ``kind`` ("cpu" or "gpu"), ``name`` (CPU model or GPU
        adapter), ``backend`` ("rayon", "vulkan", ...), ``is_software``, ``threads`` (CPU workers),
        ``shadow_rays``: "embree" (the CPU backend's shadow rays in 16-ray packets through Embree 3), "own"
        (the library's traversal, a ray at a time: a build without Embree, or a scene with analytic
        spheres) or "gpu"."""
        return dict(self._m.device)

    @property
    def visibility(self) -> str:
        """How shadow tests are decided: "ray_traced" (always on the CPU), "hybrid" or "shadow_map"."""
        return self._m.visibility

    @property
    def glossy_work(self) -> tuple[int, int]:
        """Glossy MIS work: (view samples that get BSDF samples, BSDF samples in all),
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
        idx = [int(i) for i in idx]
        out = self._m.columns(idx)
        if not np.isfinite(out).all():
            k, y, x, _ = np.argwhere(~np.isfinite(out))[0]
            raise FloatingPointError(f"column of light {idx[k]} is not finite at pixel (x {x}, y {y}) = view sample "
                                     f"{y * out.shape[2] + x}: {out[k, y, x].tolist()} (float32 overflow)")
        return out

    def column_sum(self, weights: Optional[Sequence[float]] = None, *, progress: Optional[bool] = None) -> np.ndarray:
        """Sum of all columns, each times its weight (default 1), (H, W, 3) float32: the matrix part of
        the brute-force image (add ``emitted()`` for the image itself; ``render_brute_force`` does).

        Args:
            weights: optional (n,) weights.
            progress: progress over light batches (None: a bar in a terminal or notebook, nothing in logs;
                True: also a few lines in logs; False: nothing).

        Raises:
            ValueError: weights not of shape (n,), or NaN/inf. TypeError: non-numeric weights.
        """
        w = None
        if weights is not None:
            w = _v.numeric_array("weights", weights)
            if w.ndim != 1 or w.shape[0] != self.shape[1]:
                raise ValueError(f"weights must have shape (n,) = ({self.shape[1]},) (length n), got {w.shape}")
        with progress_bar(self.shape[1], "columns", progress) as callback:
            return self._finite(self._m.column_sum(w, callback), "column_sum", None, w)

    def weighted_sum(self, indices: Sequence[int], weights, *, progress: Optional[bool] = None) -> np.ndarray:
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
        with progress_bar(len(idx), "columns", progress) as callback:
            return self._finite(self._m.weighted_sum(idx, w, callback), "weighted_sum", idx, None)

    def _finite(self, img: np.ndarray, what: str, lights, weights) -> np.ndarray:
        """``img`` when every element is finite; else FloatingPointError naming the first non-finite pixel
        (view sample) and the light whose contribution there is not finite (found from that row), or
        saying that the sum overflowed although each contribution is finite."""
        bad = ~np.isfinite(img)
        if not bad.any():
            return img
        y, x, _ = np.argwhere(bad)[0]
        sample = int(y * img.shape[1] + x)
        where = f"{what}: pixel (x {x}, y {y}) = view sample {sample} is {img[y, x].tolist()} (float32 overflow)"
        row = np.asarray(self._m.rows([sample], None, 256)[0])[0] if sample < self.shape[0] else None
        if row is not None:
            cand = range(row.shape[0]) if lights is None else lights
            j = next((j for j in cand if not np.isfinite(row[j]).all()), None)
            if j is not None:
                raise FloatingPointError(f"{where}: light {j}'s contribution there is {row[j].tolist()}")
        raise FloatingPointError(f"{where}: every light's contribution is finite but their weighted sum is not; "
                                 "scale the lights or the weights down")

    def rows(self, indices: Sequence[int], *, progress: Optional[bool] = None, shadow_map_size: int = 256,
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
        with progress_bar(int(idx.size), "rows", progress, unit="row") as callback:
            R, timings = self._m.rows([int(i) for i in idx], callback, int(shadow_map_size))
        if not np.isfinite(R).all():
            k, j, _ = np.argwhere(~np.isfinite(R))[0]
            raise FloatingPointError(f"rows: element (view sample {int(idx[k])}, light {j}) is {R[k, j].tolist()} "
                                     "(float32 overflow)")
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

    def bias_compensation(self, max_depth: int = -1, spp: int = 1, light_samples: int = 64, seed: int = 0,
                          pixels=None) -> np.ndarray:
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
            pixels: None (every pixel) or flat pixel indices ``y * W + x`` (1-D integers): only those are
                estimated, each with the value it has in the whole image (every view sample draws from its
                own stream), the others are 0 (e.g. the compensation at probe pixels alone).

        Raises:
            ValueError: spp < 1, a negative light_samples, a light set holding virtual spherical
                lights (not clamped), a pixel index outside [0, H W) or pixels not 1-D integers. Zero for
                an infinite clamp or a set without VPLs.
        """
        spp = _v.integer("spp", spp, 1, 1 << 24)
        light_samples = _v.integer("light_samples", light_samples, 0, 1 << 24)
        max_depth = _v.integer("max_depth", max_depth, -1, 1 << 30)
        if pixels is not None:
            px = np.asarray(pixels)
            if px.ndim != 1 or (px.size and not np.issubdtype(px.dtype, np.integer)):
                raise ValueError(f"pixels must be a 1-D array of integer pixel indices, got shape {px.shape} "
                                 f"dtype {px.dtype}")
            n = self.shape[0]
            bad = np.flatnonzero((px < 0) | (px >= n))
            if bad.size:
                raise ValueError(f"pixels[{int(bad[0])}] = {int(px[bad[0]])} is out of range for {n} pixels")
            pixels = [int(p) for p in px]
        return self._m.bias_compensation(int(max_depth), int(spp), int(light_samples), _v.seed(seed), pixels)

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

    def shadow_rays(self, view_indices: Sequence[int], light_indices: Sequence[int], *,
                    order: str = "columns", every_element: bool = False) -> dict:
        """The exact shadow rays of the elements ``view_indices`` x ``light_indices`` as the CPU backend casts
        them (Mitsuba's ``spawn_ray_to`` offsets: the rays to hand a peer ray tracer, e.g. Mitsuba's
        ``ray_test``; ``bench backends --peer mitsuba``). A pixel's elements are those of each of its view
        samples: its camera hit, then its delta-chain samples (mirrors, glass), as its row sums them.
        Elements whose unshadowed value is 0 cast no ray and are left out, unless ``every_element``.

        Args:
            view_indices: pixels i in [0, m) (``y * width + x``). light_indices: lights j in [0, n).
            order: ``"columns"`` (light by light, in the order given) or ``"rows"`` (view sample by view
                sample; each sample's lights in the order the CPU backend's ``rows`` traces them: neighbours
                in space next to each other, so consecutive rays leave in similar directions; the
                ``light`` array names each ray's light).
            every_element: bool; one ray for every element whose view sample lies on a surface, lit or not,
                toward the same point of the light (the rays of a renderer that tested visibility before
                shading; the ones the backend casts are among them, unchanged).

        Returns:
            dict: ``origin``, ``direction`` (r, 3) float32 (world units; unit directions), ``t_max`` (r,)
            float32 (inf toward directional lights), ``view`` (r,) int64 (the view sample of each ray: a
            pixel's own sample has the pixel's index, delta-chain samples come after the m pixels),
            ``pixel``, ``light`` (r,) int64 (the element of each ray), ``elements`` (int: the batch's view
            samples x lights), ``seconds`` (float: the set-up, unshadowed shading included).

        Raises:
            ValueError: indices that are not integers or out of range, an unknown order, more than 2^31
                elements. TypeError: ``every_element`` not a bool."""
        m, n = self.shape
        if not isinstance(every_element, (bool, np.bool_)):
            raise TypeError(f"every_element must be True or False, got {every_element!r}")
        views = [int(i) for i in _v.indices("view index", view_indices, m, f"m = {m} pixels")]
        lights = [int(j) for j in _v.indices("light index", light_indices, n, f"n = {n} lights")]
        return dict(self._m.shadow_rays(views, lights, order, bool(every_element)))

    def trace_shadow_rays(self, origin, direction, t_max) -> tuple[np.ndarray, float]:
        """Whether each ray ``o + t d``, ``t_0 < t < t_max``, is blocked, by this matrix's CPU ray tracer alone
        (BVH traversal and triangle tests, in parallel; no shading). ``t_0`` is a distance of
        ``(1 + max_i |o_i|) 2^-20`` world units along ``d`` (the GPU traversal's floor: 1e-6 near the origin,
        1 mm at 1,000 units), far below the offsets with which shading points spawn their rays.

        Args:
            origin, direction: (r, 3) float32-convertible, finite (a zero direction is never blocked).
            t_max: (r,), not NaN (inf: an unbounded ray).

        Returns:
            (blocked (r,) bool, seconds of the tracing: float).

        Raises:
            ValueError: arrays of other shapes or lengths, a NaN or infinite origin or direction, a NaN
                t_max (naming the first such ray)."""
        o = np.ascontiguousarray(origin, dtype=np.float32)
        d = np.ascontiguousarray(direction, dtype=np.float32)
        t = np.ascontiguousarray(t_max, dtype=np.float32)
        for name, a in (("origin", o), ("direction", d)):
            if a.ndim != 2 or a.shape[1] != 3:
                raise ValueError(f"trace_shadow_rays: {name} must have shape (r, 3), got {a.shape}")
        if t.ndim != 1:
            raise ValueError(f"t_max must have shape (r,), got {t.shape}")
        for name, a in (("origin", o), ("direction", d)):
            bad = ~np.isfinite(a).all(axis=1)
            if bad.any():
                k = int(np.flatnonzero(bad)[0])
                raise ValueError(f"trace_shadow_rays: {name} of ray {k} is not finite: {a[k].tolist()}")
        if np.isnan(t).any():
            k = int(np.flatnonzero(np.isnan(t))[0])
            raise ValueError(f"trace_shadow_rays: t_max of ray {k} is NaN")
        blocked, seconds = self._m.trace_shadow_rays(o, d, t)
        return np.asarray(blocked), float(seconds)

    def __repr__(self) -> str:
        m, n = self.shape
        return f"LightMatrix({m} view samples x {n} lights, {self.device['kind']}: {self.device['name']})"
