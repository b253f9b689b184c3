"""Direct-to-indirect transfer relighting on the CPU (Hašan, Pellacini, Bala, "Direct-to-Indirect
Transfer for Cinematic Relighting", SIGGRAPH 2006): precompute the diffuse and glossy final-gather
transfers F_d, F_g from the camera's view samples to a gather cloud and the multi-bounce matrix M among
the gather samples, compressed in 2D Haar wavelets on the gather image, then relight any LightSet
(direct light plus indirect light, Eq. 4-8)."""
from __future__ import annotations

import math
import time
from typing import Optional

import numpy as np

from .. import _native
from .._native import LightSet, Scene
from .._utils import validate as _v
from .._utils.keywords import checked_keywords
from .._utils.progress import progress_bar
from ..renderers.probe_error import attach_probe_error
from ..renderers.result import RenderResult
from . import store

__all__ = ["DirectToIndirect"]


class DirectToIndirect:
    """The precomputed final-gather transfer of one scene and its camera (Sec. 3.2-3.5, 4.1-4.3).

    Precomputation (in the constructor, CPU, rayon): a gather cloud of ``gather`` = 4^k samples spread
    uniformly by area (4.1), its quad-tree hierarchy and gather image (4.2), and for the camera hit of every
    pixel (pixel centres; delta-chain samples get no indirect light) the row
    F_d(i, g) = A_g min(G, clamp) V(i, g) by the paper's hierarchical gather (G the geometry term of
    ``near_field``): a cluster with
    s^2 / d^2 <= ``threshold`` gets one link to a random member with an exact shadow ray and spreads it
    over its members by area; clusters behind the view sample are culled (4.3). ``threshold=0`` is the
    exact per-sample gather (one ray per view-gather pair); the default 0.03 casts ~3.5x fewer rays on a
    box scene for a 0.04% change of the image. Each row is projected into Haar wavelets
    on the gather image and its ``final_gather_coefficients`` most important coefficients kept
    (area-weighted, 4.3).

    Multiple bounces (Eq. 2, 7; ``bounces`` b > 1, rows of M kept to ``multibounce_coefficients``):
    ``multibounce="photons"`` (default) is the paper's 4.3: ``photons_per_sample`` photons leave every
    gather sample with k_d > 0 as a Lambertian emitter of unit radiance (flux pi A_g / P each), are traced
    through the scene's BSDFs (Russian roulette) and deposited at bounces 1 ..= b - 1 with their source's
    id; the ``photon_neighbours`` nearest photons (a kiddo kd-tree) of each gather sample h give the RGB
    row M_E(h, .) = sum Phi_q / (pi r^2) (irradiance per unit source radiance), and relighting adds
    k_d / pi (M_E B_1) once. ``multibounce="gather"`` runs the hierarchical gather from every gather sample
    instead (the exact one-bounce gather-to-gather transfer K, iterated b - 1 times: M = K + ... + K^(b-1)).
    Measured against Mitsuba (max_depth -1) on the 2 m test box at 32x32 with 6 bounces: 4^6 gather
    samples: photons 3.8%, gather 4.1%; 4^7: photons 3.4% (10.7 s), gather 20% (10.1 s: spikes from its
    point-sampled, unclamped 1/d^2 between neighbouring gather samples, iterated; with clamp=100 the
    gather reaches 3.9% and photons 3.6%), hence the default.

    Glossy view samples (Eq. 6, 8; ``glossy=True``): pixels whose BSDF has a glossy lobe (roughplastic's
    specular lobe, roughconductor, a blendbsdf containing either; not principled, smooth plastic,
    conductor or dielectric) also get a row of F_g(i, g) = A_g min(G, clamp) V mean_rgb(f_g(wi, wo)), the
    glossy lobe toward the fixed viewer baked in (the project's Mitsuba-exact BSDF evaluation), by the same
    hierarchical gather subdividing more around the lobe's peak, kept to ``final_gather_coefficients``;
    relighting adds k_g(i) F_g B, k_g the lobe's colour at its peak (unit mean). Light reflected by glossy
    surfaces onto others is not gathered (the paper's limitation, 4.3).

    Masked surfaces (Mitsuba's ``mask``): the camera rays are followed through them to Mitsuba's depth
    (max_depth = ``bounces`` + 2) and every view sample, the surface behind a mask included, gets its own rows,
    summed into its pixel with its throughput; the rows' and the gather samples' shadow rays cross masks with
    (1 - opacity) each within that depth (a gather sample is a bounce of its own), point, spot and directional
    lights stop at them (Mitsuba reaches those only by emitter sampling), and a gather sample on a mask reflects
    its opacity times the nested BSDF. Measured on the relighting box with a checkerboard-masked panel: 8.0% /
    9.0% relative L2 against Mitsuba at one / two bounces, as close as the same box with the panel opaque gets
    to its own reference (8.4% / 9.2%). The GPU relights masked scenes too (with exact rays within 4e-7 of
    the CPU).

    Relighting (``relight``): E_g = direct irradiance at the gather samples (exact shadow rays), B_g =
    k_d(g) / pi E_g, wavelet-projected and culled on the fly with ``epsilon`` (3.5), indirect radiance
    k_d(i) / pi sum_g F_d(i, g) B_g at each pixel (Eq. 5; a plastic's diffuse lobe is not Lambertian: its
    dependence on the direction to g is baked into F_d and k_d(i) is its colour, exact, so a plastic floor
    relit with every coefficient equals its gather samples as VPLs to 1e-7), plus the direct light of the
    same lights (``LightMatrix(...).column_sum()`` on the CPU backend).

    On the GPU (``device``; Sec. 5) the transfer rows are uploaded once; each relight renders the lights'
    shadow maps once and runs the light matrix's column pass over the gather samples (a diffuse BSDF of
    reflectance 1 with throughput k_d(g), so the column sum is B_g) and over the view samples (direct
    light), the multiple bounces (the gather-to-gather passes, or the photon-mapped M once: RGB rows),
    then the Haar transform level by level, the culling (against F_d's and, with glossy pixels, F_g's
    image norms), one thread per pixel summing its sparse rows (no atomics; the CPU's summation order),
    k_d / pi times the F_d sum plus k_g times the F_g sum, plus direct, and reads the image back once.
    With ``visibility="ray_traced"`` it equals the CPU result to float precision (relative L2 ~1e-7,
    photons, gather and glossy alike).

    Args:
        scene: a loaded Scene (its film fixes the image size).
        gather: n_g, a power of 4 (4, 16, ..., 4^12).
        final_gather_coefficients: wavelet coefficients kept per pixel row, 1 ..= gather.
        seed: seeds the gather cloud and the clusters' representatives.
        bounces: bounces of indirect light, 1 ..= 64 (1: the final gather only, Mitsuba's max_depth 3; b:
            max_depth b + 2; 6 or more approach max_depth -1 in a box of albedo ~0.7).
        multibounce_coefficients: wavelet coefficients kept per row of M, 1 ..= gather (used when
            bounces > 1; the paper's 40).
        multibounce: "photons" (default) or "gather": how M is computed (above).
        photons_per_sample: photons shot from each gather sample, 1 ..= 2^20 (default 64; "photons").
        photon_neighbours: K of the K-nearest photon queries, 1 ..= 2^20 (default 400; "photons").
        glossy: compute the glossy final gather F_g for glossy pixels (default True).
        threshold: solid-angle threshold s^2 / d^2 of the hierarchical gather (>= 0; 0 = exact per-sample).
        clamp: bound on the geometry term cos cos / d^2 (1/m^2 in scene units; None = no clamp), the
            paper's clamp of F_d against corner singularities. It trades spikes near corners for
            darkening: on the 2 m test box at 128x128 with 4^7 gather samples, clamp=100 lowers the error
            against Mitsuba from 10.0% to 5.3%; at 32x32 with 4^6 samples clamp=10 raises it from 2.8% to
            5.4%.
        K: Eq. 9's position weight of the hierarchy (> 0).
        near_field: the geometry term G of a gather sample seen from a receiver. "disc" (default): the
            sample is a disc of its area A_g facing the receiver, G = cos_g cos_i / (d^2 + A_g / pi), the
            point-to-disc form factor (Wallace et al. 1989): bounded near corners and contacts, the same as
            a point beyond a few sample spacings. "point": G = cos_g cos_i / d^2, exactly the gather cloud's
            VPLs in the light matrix (the dense-product identity), with the 1/d^2 spikes of point lights.
            Measured on the bundled cbox lit by a spot at 128x128 against Mitsuba (max_depth -1, 6
            bounces): 24% relative L2 with "point" (78% of the squared error in 0.1% of the pixels, the
            corners) against 10.6% with "disc". The paper clamps instead (``clamp``).
        progress: progress over the pixels' rows (None: a bar in a terminal or notebook, nothing in logs;
            True: also a few lines in logs; False: nothing).
        device: where ``relight`` runs: "auto" (``MANYLIGHTS_DEVICE`` if set, else a hardware GPU, else the
            CPU, as ``LightMatrix``: on a 2-core machine with only lavapipe the CPU relights a 320x240 box
            at ~20/s against ~5/s on the software GPU), "gpu" (any adapter, software included) or "cpu".
            The precomputation always runs on the CPU.
        visibility: the GPU's shadow tests: None or "hybrid" (shadow maps where certain, exact rays
            elsewhere), "ray_traced" (exact rays only), "shadow_map" (biased shadow maps only); the CPU
            always casts exact rays (a shadow-map visibility with device "auto" picks the GPU).
        shadow_map_size: texels per side of the GPU's shadow maps (16..=8192).

    Attributes:
        timings: dict of seconds: gather_cloud, hierarchy, final_gather, multibounce (photon tracing and
            density estimation, or the gather-to-gather rows), glossy_final_gather; after a relight
            also relight_shadow_maps (GPU), relight_gather_direct, relight_bounces, relight_wavelet (Haar
            transform and culling), relight_transfer (sparse products, times k_d / pi, plus direct),
            relight_view_direct, relight_readback (GPU). On the GPU each stage is timed with a wait after it.
        device: dict: kind ("cpu" / "gpu"), name, backend, is_software, threads of the relighting device.
        stats: dict: gather, pixels (final-gather rows: one per pixel, or with masks one per view sample),
            coefficients_per_row, coefficients_kept, bounces,
            multibounce_coefficients_per_row, multibounce_coefficients_kept, multibounce ("photons",
            "gather", or "none" with one bounce), photons (deposited), glossy_pixels,
            glossy_coefficients_kept, bytes (all matrices), shadow_rays (F_d, F_g and the gather-to-gather
            rows), links, threshold, near_field; after a relight wavelet_lights (non-zero coefficients of the
            projected lighting), wavelet_lights_culled (those skipped by epsilon against F_d's image norms,
            including any whose image is 0 after the rows' culling) and wavelet_lights_culled_glossy (the
            same against F_g's).
        gather_positions, gather_normals, gather_geo_normals: (n_g, 3) float32 where and how each gather
            sample emits (its VPL); gather_areas (n_g,) float32 m^2; gather_k_d (n_g, 3) float32.

    Raises:
        ValueError: gather not a power of 4, final_gather_coefficients (or multibounce_coefficients with
            bounces > 1) outside 1 ..= gather, bounces outside 1 ..= 64, multibounce not "photons" or
            "gather", near_field not "disc" or "point", photons_per_sample or photon_neighbours outside
            1 ..= 2^20, a negative or non-finite threshold, clamp <= 0, K <= 0, non-integer arguments, an
            unknown device (or MANYLIGHTS_DEVICE) or visibility, a shadow-map visibility with
            device="cpu", shadow_map_size outside 16..=8192.
        TypeError: scene not a Scene, glossy not a bool, device or visibility not a string.
        GpuUnavailableError: device="gpu" without any GPU adapter.
    """

    @checked_keywords()
    def __init__(self, scene: Scene, gather: int = 4**7, final_gather_coefficients: int = 100, seed: int = 0,
                 *, bounces: int = 1, multibounce_coefficients: int = 40, multibounce: str = "photons",
                 photons_per_sample: int = 64, photon_neighbours: int = 400, glossy: bool = True,
                 threshold: float = 0.03, clamp=None, K: float = 30.0, near_field: str = "disc",
                 progress: Optional[bool] = None, device: str = "auto", visibility=None, shadow_map_size: int = 1024):
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
        if multibounce not in ("gather", "photons"):
            raise ValueError(f"multibounce must be 'photons' or 'gather', got {multibounce!r}")
        photons_per_sample = _v.integer("photons_per_sample", photons_per_sample, 1, 1 << 20)
        photon_neighbours = _v.integer("photon_neighbours", photon_neighbours, 1, 1 << 20)
        if not isinstance(glossy, (bool, np.bool_)):
            raise TypeError(f"glossy must be a bool, got {type(glossy).__name__}")
        threshold = _v.real("threshold", threshold, 0.0)
        clamp = math.inf if clamp is None else _v.real("clamp", clamp)
        if not clamp > 0:
            raise ValueError(f"clamp must be > 0 (or None for no clamp), got {clamp}")
        K = _v.real("K", K)
        if not K > 0:
            raise ValueError(f"K must be > 0, got {K}")
        if near_field not in ("disc", "point"):
            raise ValueError(f'near_field must be "disc" or "point", got {near_field!r}')
        self.scene = scene
        seed = _v.seed(seed)
        if not isinstance(device, str):
            raise TypeError(f"device must be 'auto', 'gpu' or 'cpu', got {type(device).__name__}")
        if visibility is not None and not isinstance(visibility, str):
            raise TypeError(f"visibility must be None, 'hybrid', 'ray_traced' or 'shadow_map', got {visibility!r}")
        shadow_map_size = _v.integer("shadow_map_size", shadow_map_size, 16, 8192)
        rows = scene.width * scene.height + (gather if bounces > 1 else 0)
        with progress_bar(rows, "final gather", progress, unit="pixel") as callback:
            self._t = _native.DirectToIndirect(scene, gather, coefficients, seed, threshold, clamp, K, bounces, mb,
                                               callback, multibounce, photons_per_sample, photon_neighbours,
                                               bool(glossy), near_field, device, visibility, shadow_map_size)

    def relight(self, lights: LightSet, epsilon: float = 0.0, *, error_probes: int = 0, probe_spp: int = 256,
                seed: int = 0):
        """The image lit by ``lights``: direct light plus indirect light through the transfer (Eq. 4-8):
        k_d / pi F_d (M + I) B_1 + k_g F_g (M + I) B_1, B_1 = k_d / pi E the gather samples' direct radiance.

        Args:
            lights: a non-empty LightSet of this scene (point, spot, directional, oriented points, VPLs).
            epsilon: on-the-fly wavelet-light culling threshold (Sec. 3.5; >= 0, 0 keeps every light):
                a wavelet light is skipped when |intensity| * |image| < epsilon.
            error_probes: N > 0: N probe pixels path-traced with ``probe_spp`` paths each, the scene lit by
                ``lights`` alone (``probe_pixels(lights=)``) to the transfer's depth (``bounces`` + 2), estimate
                the image's error against the converged image under those lights, bias included
                (``renderers.probe_error``). 0: no probes.
            probe_spp: paths per probe (>= 2). seed: seeds the probes (>= 0).

        Returns:
            (H, W, 3) float32 radiance without probes; with probes a ``RenderResult`` (method
            ``"direct_to_indirect"``) holding that image, ``error_estimate`` (the probes' upper bound),
            ``budget['probes']`` and ``timings`` (``relight``, ``probes``). Emitters seen directly are not
            included (``LightMatrix.emitted``).

        Raises:
            ValueError: an empty LightSet, non-finite light values (the light named), a negative or
                non-finite epsilon, error_probes outside [0, pixels], probe_spp < 2, a negative seed.
            FloatingPointError: an image that overflowed float32 (the first pixel named).
            TypeError: lights not a LightSet.
        """
        if not isinstance(lights, LightSet):
            raise TypeError(f"lights must be a manylights LightSet, got {type(lights).__name__}")
        epsilon = _v.real("epsilon", epsilon, 0.0)
        error_probes = _v.integer("error_probes", error_probes, 0, self.scene.width * self.scene.height)
        probe_spp = _v.integer("probe_spp", probe_spp, 2, 1 << 30)
        seed = _v.seed(seed)
        t = time.perf_counter()
        image = _v.finite_result("relight", self._t.relight(lights, epsilon))
        if not error_probes:
            return image
        res = RenderResult(image=image, method="direct_to_indirect", seed=seed,
                           timings={"relight": time.perf_counter() - t}, device=dict(self.device),
                           budget={"lights": len(lights), "epsilon": epsilon})
        return attach_probe_error(res, self.scene, error_probes, seed, spp=probe_spp,
                                  max_depth=int(self.stats["bounces"]) + 2, lights=lights)

    def save(self, path):
        """Writes the whole precomputation to ``path`` (a numpy ``.npz``; ``manylights.relight.store``
        describes it): written to a temporary file in the same folder, then renamed, so a failed save leaves
        no partial file. Returns the path (``pathlib.Path``).

        Raises:
            OSError: the folder does not exist or cannot be written.
        """
        return store.save(self, path)

    @classmethod
    def load(cls, path, scene: Scene, *, device: str = "auto", visibility=None,
             shadow_map_size: int = 1024) -> "DirectToIndirect":
        """A precomputation saved by ``save``, for ``scene``: the scene it was computed on, or that scene
        with other lights (emitters are free to change). Its ``relight`` is bit-identical to the saved
        object's on the same device; ``timings`` and ``stats`` are the precomputation's. ``device``,
        ``visibility``, ``shadow_map_size``: where it relights, as the constructor's (the file holds no
        device state).

        Raises:
            OSError: the file cannot be read.
            ValueError: naming the file: not a relighting file, damaged or truncated, another format
                version, or a scene whose geometry, materials, camera or film changed (named).
            TypeError: scene not a Scene.
            GpuUnavailableError: device="gpu" without any GPU adapter.
        """
        return store.load(cls, path, scene, device, visibility, shadow_map_size)

    def gather_irradiance(self, lights: LightSet) -> np.ndarray:
        """(n_g, 3) float32 direct irradiance (W/m^2) of ``lights`` at the gather samples (exact shadow rays;
        on a masked surface times its opacity, what the mask reflects). Raises ValueError as ``relight``."""
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
