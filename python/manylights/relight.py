"""Direct-to-indirect transfer relighting on the CPU or the GPU (Hašan, Pellacini, Bala, "Direct-to-Indirect
Transfer for Cinematic Relighting", SIGGRAPH 2006): precompute the diffuse final-gather transfer F_d from
the camera's view samples to a gather cloud, compressed in 2D Haar wavelets on the gather image, then
relight any LightSet (direct light plus one diffuse bounce)."""
from __future__ import annotations

import math

import numpy as np

from . import _native
from . import _validate as _v
from ._native import LightSet, Scene
from .progress import progress_bar as _progress_bar

__all__ = ["DirectToIndirect"]


class DirectToIndirect:
    """The precomputed final-gather transfer of one scene and its camera (Sec. 3.2-3.5, 4.1-4.3).

    Precomputation (in the constructor, CPU, rayon): a gather cloud of ``gather`` = 4^k samples spread
    uniformly by area (4.1), its quad-tree hierarchy and gather image (4.2), and for the camera hit of every
    pixel (pixel centres; delta-chain samples get no indirect light) the row
    F_d(i, g) = A_g min(cos_g cos_i / d^2, clamp) V(i, g) by the paper's hierarchical gather: a cluster with
    s^2 / d^2 <= ``threshold`` gets one link to a random member with an exact shadow ray and spreads it
    over its members by area; clusters behind the view sample are culled (4.3). ``threshold=0`` is the
    exact per-sample gather (one ray per view-gather pair); the default 0.03 casts ~3.5x fewer rays on a
    box scene for a 0.04% change of the image. Each row is projected into Haar wavelets
    on the gather image and its ``final_gather_coefficients`` most important coefficients kept
    (area-weighted, 4.3). With ``bounces`` b > 1 the same gather also runs from every gather sample (the
    gather-to-gather transfer, rows kept to ``multibounce_coefficients``), and relighting bounces the
    gather samples' radiance b - 1 times through it before the final gather: the paper's multi-bounce
    matrix M (Eq. 2, 7) as K + K^2 + ... of the one-bounce transfer K, with exact visibility instead of
    photon mapping. The glossy F_g is not computed (glossy view samples get their diffuse part only).

    Relighting (``relight``): E_g = direct irradiance at the gather samples (exact shadow rays), B_g =
    k_d(g) / pi E_g, wavelet-projected and culled on the fly with ``epsilon`` (3.5), indirect radiance
    k_d(i) / pi sum_g F_d(i, g) B_g at each pixel (Eq. 5), plus the direct light of the same lights
    (``LightMatrix(...).column_sum()`` on the CPU backend).

    On the GPU (``device``; Sec. 5) the transfer rows are uploaded once; each relight renders the lights'
    shadow maps once and runs the light matrix's column pass over the gather samples (a diffuse BSDF of
    reflectance 1 with throughput k_d(g), so the column sum is B_g) and over the view samples (direct
    light), then the Haar transform level by level, the culling, one thread per pixel summing its sparse
    row (no atomics; the CPU's summation order), times k_d / pi, plus direct, and reads the image back
    once. With ``visibility="ray_traced"`` it equals the CPU result to float precision (relative L2 ~1e-7).

    Args:
        scene: a loaded Scene (its film fixes the image size).
        gather: n_g, a power of 4 (4, 16, ..., 4^12).
        final_gather_coefficients: wavelet coefficients kept per pixel row, 1 ..= gather.
        seed: seeds the gather cloud and the clusters' representatives.
        bounces: diffuse bounces of indirect light, 1 ..= 64 (1: F_d only, Mitsuba's max_depth 3; b:
            max_depth b + 2).
        multibounce_coefficients: wavelet coefficients kept per gather-to-gather row, 1 ..= gather
            (used when bounces > 1).
        threshold: solid-angle threshold s^2 / d^2 of the hierarchical gather (>= 0; 0 = exact per-sample).
        clamp: bound on the geometry term cos cos / d^2 (1/m^2 in scene units; None = no clamp), the
            paper's clamp of F_d against corner singularities. It trades spikes near corners for
            darkening: on the 2 m test box at 128x128 with 4^7 gather samples, clamp=100 lowers the error
            against Mitsuba from 10.0% to 5.3%; at 32x32 with 4^6 samples clamp=10 raises it from 2.8% to
            5.4%.
        K: Eq. 9's position weight of the hierarchy (> 0).
        progress: show a progress bar (or log lines) over the pixels' rows (``manylights.progress``).
        device: where ``relight`` runs: "auto" (``MANYLIGHTS_DEVICE`` if set, else a hardware GPU, else the
            CPU, as ``LightMatrix``: on a 2-core machine with only lavapipe the CPU relights a 320x240 box
            at ~20/s against ~5/s on the software GPU), "gpu" (any adapter, software included) or "cpu".
            The precomputation always runs on the CPU.
        visibility: the GPU's shadow tests: None or "hybrid" (shadow maps where certain, exact rays
            elsewhere), "ray_traced" (exact rays only), "shadow_map" (biased shadow maps only); the CPU
            always casts exact rays (a shadow-map visibility with device "auto" picks the GPU).
        shadow_map_size: texels per side of the GPU's shadow maps (16..=8192).

    Attributes:
        timings: dict of seconds: gather_cloud, hierarchy, final_gather, multibounce; after a relight
            also relight_shadow_maps (GPU), relight_gather_direct, relight_bounces, relight_wavelet (Haar
            transform and culling), relight_transfer (sparse products, times k_d / pi, plus direct),
            relight_view_direct, relight_readback (GPU). On the GPU each stage is timed with a wait after it.
        device: dict: kind ("cpu" / "gpu"), name, backend, is_software, threads of the relighting device.
        stats: dict: gather, pixels, coefficients_per_row, coefficients_kept, bounces,
            multibounce_coefficients_per_row, multibounce_coefficients_kept, bytes, shadow_rays, links,
            threshold; after a relight wavelet_lights (non-zero coefficients of the projected lighting)
            and wavelet_lights_culled (those skipped by epsilon, including any whose image is 0 after
            the rows' culling).
        gather_positions, gather_normals, gather_geo_normals: (n_g, 3) float32 where and how each gather
            sample emits (its VPL); gather_areas (n_g,) float32 m^2; gather_k_d (n_g, 3) float32.

    Raises:
        ValueError: gather not a power of 4, final_gather_coefficients (or multibounce_coefficients with
            bounces > 1) outside 1 ..= gather, bounces outside 1 ..= 64, a negative
            or non-finite threshold, clamp <= 0, K <= 0, non-integer arguments, an unknown device (or
            MANYLIGHTS_DEVICE) or visibility, a shadow-map visibility with device="cpu", shadow_map_size
            outside 16..=8192.
        TypeError: scene not a Scene, device or visibility not a string.
        GpuUnavailableError: device="gpu" without any GPU adapter.
    """

    def __init__(self, scene: Scene, gather: int = 4**7, final_gather_coefficients: int = 100, seed: int = 0,
                 *, bounces: int = 1, multibounce_coefficients: int = 40, threshold: float = 0.03, clamp=None,
                 K: float = 30.0, progress: bool = False, device: str = "auto", visibility=None,
                 shadow_map_size: int = 1024):
        if not isinstance(scene, Scene):
            raise TypeError(f"scene must be a manylights Scene, got {type(scene).__name__}")
        gather = _v.integer("gather", gather, 1)
        if gather & (gather - 1) or (gather.bit_length() - 1) % 2:
            raise ValueError(f"gather must be a power of 4 (4^k: a 2^k x 2^k gather image), got {gather}")
        coefficients = _v.integer("final_gather_coefficients", final_gather_coefficients, 1)
        if coefficients > gather:
            raise ValueError(f"final_gather_coefficients must be at most gather ({gather}), got {coefficients}")
        bounces = _v.integer("bounces", bounces, 1, 64)
        mb = _v.integer("multibounce_coefficients", multibounce_coefficients, 1)
        if bounces > 1 and mb > gather:
            raise ValueError(f"multibounce_coefficients must be at most gather ({gather}), got {mb}")
        threshold = _v.real("threshold", threshold, 0.0)
        clamp = math.inf if clamp is None else _v.real("clamp", clamp)
        if not clamp > 0:
            raise ValueError(f"clamp must be > 0 (or None for no clamp), got {clamp}")
        K = _v.real("K", K)
        if not K > 0:
            raise ValueError(f"K must be > 0, got {K}")
        self.scene = scene
        seed = _v.seed(seed)
        if not isinstance(device, str):
            raise TypeError(f"device must be 'auto', 'gpu' or 'cpu', got {type(device).__name__}")
        if visibility is not None and not isinstance(visibility, str):
            raise TypeError(f"visibility must be None, 'hybrid', 'ray_traced' or 'shadow_map', got {visibility!r}")
        shadow_map_size = _v.integer("shadow_map_size", shadow_map_size, 16, 8192)
        rows = scene.width * scene.height + (gather if bounces > 1 else 0)
        with _progress_bar(rows, "final gather", progress, unit="pixel") as callback:
            self._t = _native.DirectToIndirect(scene, gather, coefficients, seed, threshold, clamp, K, bounces, mb,
                                               callback, device, visibility, shadow_map_size)

    def relight(self, lights: LightSet, epsilon: float = 0.0) -> np.ndarray:
        """The image lit by ``lights``: direct light plus ``bounces`` diffuse bounces through the transfer.

        Args:
            lights: a non-empty LightSet of this scene (point, spot, directional, oriented points, VPLs).
            epsilon: on-the-fly wavelet-light culling threshold (Sec. 3.5; >= 0, 0 keeps every light):
                a wavelet light is skipped when |intensity| * |image| < epsilon.

        Returns:
            (H, W, 3) float32 radiance. Emitters seen directly are not included (``LightMatrix.emitted``).

        Raises:
            ValueError: an empty LightSet, non-finite light values (the light named), a negative or
                non-finite epsilon.
            TypeError: lights not a LightSet.
        """
        if not isinstance(lights, LightSet):
            raise TypeError(f"lights must be a manylights LightSet, got {type(lights).__name__}")
        return self._t.relight(lights, _v.real("epsilon", epsilon, 0.0))

    def gather_irradiance(self, lights: LightSet) -> np.ndarray:
        """(n_g, 3) float32 direct irradiance (W/m^2) of ``lights`` at the gather samples (exact shadow rays).
        Raises ValueError as ``relight``."""
        if not isinstance(lights, LightSet):
            raise TypeError(f"lights must be a manylights LightSet, got {type(lights).__name__}")
        return self._t.gather_irradiance(lights)

    def __getattr__(self, name):
        if name in ("timings", "stats", "device", "gather_positions", "gather_normals", "gather_geo_normals",
                    "gather_areas", "gather_k_d"):
            return getattr(self._t, name)
        raise AttributeError(name)

    def __repr__(self) -> str:
        s = self.stats
        return (f"DirectToIndirect(gather={s['gather']}, pixels={s['pixels']}, "
                f"coefficients={s['coefficients_per_row']}, threshold={s['threshold']})")
