"""Type stub of the native module ``manylights._native`` (Rust, PyO3). Keep in sync with ``src/py/``."""
from os import PathLike
from typing import Any, Callable, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

class ManyLightsError(Exception):
    """Base class of manylights' own exceptions."""

class GpuUnavailableError(ManyLightsError):
    """No GPU adapter (hardware or software) could be created; the message says what to install."""

class GpuError(ManyLightsError):
    """A GPU operation failed."""

class SceneError(ManyLightsError):
    """A scene file is malformed or unsupported; the message names file, line and value."""

class Scene:
    """A scene loaded from Mitsuba 3 XML."""
    path: str
    width: int
    height: int
    resolution: tuple[int, int]
    shapes: list[dict[str, Any]]
    emitters: list[dict[str, Any]]
    bsdfs: list[dict[str, Any]]
    camera: dict[str, Any]
    """origin, left, up, forward, fov_x, fov_y (degrees), near_clip, far_clip, width, height,
    principal_point_offset (x, y) in film units."""
    bounds: tuple[tuple[float, float, float], tuple[float, float, float]]
    integrator: Optional[dict[str, Any]]
    """The first top-level ``<integrator>``: type, max_depth (Mitsuba's path depth: a path tracer's
    property, default -1; 2 for ``direct``; None for plugins without one), file (Path), line; None if absent."""
    def gbuffer(self, device: str = "auto") -> dict[str, np.ndarray]:
        """View samples at pixel centres: position, normal, geo_normal, wi, albedo (H, W, 3) float32,
        uv (H, W, 2) float32, shape_index, prim_index (H, W) int32 (-1 = background). Computed on
        ``device`` (GPU raster or CPU ray casting) by the first call that needs them, then cached."""
    def mesh(self, index: int) -> dict[str, np.ndarray]:
        """World-space positions, normals (V, 3), uvs (V, 2) float32 and indices (T, 3) uint32 of a shape.

        Raises:
            ValueError: index out of range (negative included)."""

class LightSet:
    """Lights as a struct of arrays (numpy views). kind: 0 point, 1 spot, 2 directional, 3 oriented
    point (area light sample), 4 VPL."""
    kind: npt.NDArray[np.int32]
    position: npt.NDArray[np.float32]
    direction: npt.NDArray[np.float32]
    normal: npt.NDArray[np.float32]
    geo_normal: npt.NDArray[np.float32]
    incident: npt.NDArray[np.float32]
    intensity: npt.NDArray[np.float32]
    power: npt.NDArray[np.float32]
    vpl_clamp: float
    cutoff_angle: npt.NDArray[np.float32]
    beam_width: npt.NDArray[np.float32]
    bsdf: npt.NDArray[np.uint32]
    """(n, 20) uint32: each VPL's 80-byte BSDF record (opaque; for from_arrays of the same scene)."""
    patch: npt.NDArray[np.float32]
    """(n, 4, 3) float32: each oriented point's patch corners (m); all zero = none. Receivers within 8
    patch radii get the patch's projected solid angle instead of 1/d^2."""
    vsl_radius: npt.NDArray[np.float32]
    vpl_depth: npt.NDArray[np.uint32]
    """(n,) float32: each VPL's virtual-spherical-light radius (m); 0 = a point VPL (clamped)."""
    scene_sphere: tuple[tuple[float, float, float], float]
    def __len__(self) -> int: ...
    def __getitem__(self, key: Union[int, slice, Sequence[int], npt.NDArray[Any]]) -> LightSet:
        """A new LightSet of the chosen lights (int, slice, integer array, boolean mask of shape (n,)).
        Raises IndexError (out of range, mask length) or TypeError (other keys)."""
    @staticmethod
    def from_arrays(scene: Scene, *, kind: Union[int, npt.ArrayLike], position: Optional[npt.ArrayLike] = None,
                    direction: Optional[npt.ArrayLike] = None, normal: Optional[npt.ArrayLike] = None,
                    geo_normal: Optional[npt.ArrayLike] = None, incident: Optional[npt.ArrayLike] = None,
                    intensity: Optional[npt.ArrayLike] = None, power: Optional[npt.ArrayLike] = None,
                    cutoff_angle: Optional[npt.ArrayLike] = None, beam_width: Optional[npt.ArrayLike] = None,
                    bsdf: Optional[npt.ArrayLike] = None, albedo: Optional[npt.ArrayLike] = None,
                    vpl_clamp: Optional[float] = None, patch: Optional[npt.ArrayLike] = None,
                    vsl_radius: Optional[npt.ArrayLike] = None,
                    vpl_depth: Optional[npt.ArrayLike] = None) -> LightSet:
        """A LightSet from per-light arrays (see the method's docstring: shapes, units, checks).
        Raises ValueError naming the argument, the expected and the actual shape or value."""
    @staticmethod
    def concat(sets: Sequence[LightSet]) -> LightSet:
        """All lights of sets in order. Raises ValueError for [] or sets of different scenes."""

class LightMatrix:
    """The m x n light matrix on the CPU backend (exact rays, rayon) or the GPU backend (wgpu)."""
    shape: tuple[int, int]
    device: dict[str, Any]
    visibility: str
    glossy_work: tuple[int, int]
    """(view samples with BSDF samples, BSDF samples in all) of glossy MIS; (0, 0) = none (diffuse)."""
    def __init__(self, scene: Scene, lights: LightSet, shadow_map_size: int = 1024,
                 normal_offset: Optional[float] = None, depth_bias: Optional[float] = None,
                 slope_bias: Optional[float] = None, visibility: Optional[str] = None, max_depth: int = -1,
                 device: str = "auto", glossy_roughness: float = 0.2, bsdf_samples: int = 256,
                 glossy_seed: int = 0) -> None:
        """device: "auto" (MANYLIGHTS_DEVICE, else a hardware GPU, else the CPU), "gpu" or "cpu".
        visibility: None (the device's default: "ray_traced" on the CPU, "hybrid" on a GPU), "hybrid"
        (shadow maps where certain, exact GPU rays elsewhere), "ray_traced" or "shadow_map" (shadow-map
        modes choose the GPU under "auto"). max_depth: Mitsuba's path depth for delta BSDF chains
        (mirrors, glass; -1 unlimited, 2 = direct light only). Raises ValueError for an unknown device or
        visibility, shadow maps on the CPU, bias < 0 or max_depth in {0, 1} or < -1, glossy_roughness
        outside [0, 1] or bsdf_samples outside 1..=65536 (with glossy_roughness > 0);
        GpuUnavailableError for device="gpu" without an adapter. glossy_roughness / bsdf_samples /
        glossy_seed: glossy MIS (src/matrix/glossy.rs): view samples on rough plastic / conductor with
        alpha below the threshold weight area and uniform-environment columns by the power-heuristic
        w_L, and emitted() adds their BSDF-sampled rest (bsdf_samples rays each, seeded)."""
    def visibility_stats(self) -> dict[str, int]:
        """shadow_tests, ray_casts, gave_up since creation or reset_visibility_stats()."""
    def reset_visibility_stats(self) -> None: ...
    def view_samples(self) -> dict[str, npt.NDArray[Any]]:
        """position (m_s, 3) f32, normal (m_s, 3) f32, pixel (m_s,) int64, surface (m_s,) bool: the view
        samples, pixels first, then the delta-chain samples."""
    def columns(self, indices: Sequence[int]) -> npt.NDArray[np.float32]:
        """(k, H, W, 3). Raises ValueError for an index >= n."""
    def column_sum(self, weights: Optional[npt.NDArray[np.float32]] = None,
                   progress: Optional[Callable[[int, int], None]] = None) -> npt.NDArray[np.float32]:
        """(H, W, 3) weighted sum. Raises ValueError for a wrong length or NaN/inf weights."""
    def emitted(self) -> npt.NDArray[np.float32]:
        """(H, W, 3): emitted radiance seen directly (area emitters, environment background), plus the
        BSDF strategy of glossy MIS when the matrix has glossy view samples."""
    def bias_compensation(self, max_depth: int = -1, spp: int = 1, light_samples: int = 64,
                          seed: int = 0, pixels: Optional[Sequence[int]] = None) -> npt.NDArray[np.float32]:
        """(H, W, 3): Kollig-Keller estimate of the energy the VPL clamp removes (CPU); at `pixels` (flat
        indices) only when given, 0 elsewhere. ValueError for an index out of range."""
    def weighted_sum(self, indices: Sequence[int], weights: npt.NDArray[np.float32],
                     progress: Optional[Callable[[int, int], None]] = None) -> npt.NDArray[np.float32]:
        """(H, W, 3): sum_k weights[k] * column[indices[k]], (k, 3) RGB weights; only those columns are rendered."""
    def rows(self, indices: Sequence[int], progress: Optional[Callable[[int, int], None]] = None,
             shadow_map_size: int = 256) -> tuple[npt.NDArray[np.float32], dict[str, float]]:
        """(r, n, 3) rows from cube depth maps at the view samples, and seconds per stage (setup, shadow_maps,
        evaluation, readback; batches). Raises ValueError for an index >= m or a bad shadow_map_size."""
        """(H, W, 3) radiance the camera sees directly (area emitters' front sides, the environment on
        background pixels); not part of column_sum."""
    def element(self, i: int, j: int) -> npt.NDArray[np.float32]:
        """(3,) A(i, j) by exact CPU ray casting. Raises ValueError for i >= m or j >= n."""
    def row_exact(self, i: int) -> npt.NDArray[np.float32]:
        """(n, 3) row i by exact CPU ray casting. Raises ValueError for i >= m."""
    def column_exact(self, j: int) -> npt.NDArray[np.float32]:
        """(H, W, 3) column j by exact CPU ray casting. Raises ValueError for j >= n."""
    def shadow_rays(self, view_indices: Sequence[int], light_indices: Sequence[int],
                    order: str = "columns") -> dict[str, Any]:
        """The exact shadow rays of view_indices x light_indices (src/cpu/shadow_rays.rs): origin, direction
        (r, 3) float32, t_max (r,) float32, view, light (r,) int64, elements, seconds. ValueError for an index
        out of range or an unknown order."""
    def trace_shadow_rays(self, origin: npt.NDArray[np.float32], direction: npt.NDArray[np.float32],
                          t_max: npt.NDArray[np.float32]) -> tuple[npt.NDArray[np.bool_], float]:
        """(blocked (r,) bool, seconds): the CPU ray tracer alone on the rays. ValueError for bad shapes."""

class LightTree:
    """A binary BVH over a LightSet with pbrt-v4-style light bounds (src/lights/light_tree.rs). Node arrays
    (N nodes, node 0 the root): bounds_min / bounds_max / axis (N, 3) f64, theta_o / theta_e / power (N,)
    f64, children (N, 2) int64 (-1 at leaves), leaf_light (N,) int64 (-1 inner); infinite (k,) int64 the
    directional lights outside the tree. Raises ValueError for an empty LightSet."""
    num_lights: int
    bounds_min: npt.NDArray[np.float64]
    bounds_max: npt.NDArray[np.float64]
    axis: npt.NDArray[np.float64]
    theta_o: npt.NDArray[np.float64]
    theta_e: npt.NDArray[np.float64]
    power: npt.NDArray[np.float64]
    children: npt.NDArray[np.int64]
    leaf_light: npt.NDArray[np.int64]
    infinite: npt.NDArray[np.int64]
    def __init__(self, lights: LightSet) -> None: ...
    def __len__(self) -> int: ...
    def pdf(self, matrix: LightMatrix, sample: int) -> npt.NDArray[np.float64]:
        """(n,) probability of each light at view sample `sample` of `matrix` (sums to 1, or all 0 where
        no light can reach it). Raises ValueError for another LightSet or a sample out of range."""

def light_bvh_sampling(matrix: LightMatrix, samples: int, seed: int,
                       tree: Optional[LightTree] = None) -> dict[str, Any]:
    """image (H, W, 3) f32, variance (H, W, 3) f32 or None (samples = 1), shadow_rays, seconds, tree_seconds."""
def ris(matrix: LightMatrix, samples: int, candidates: int, seed: int, tree: Optional[LightTree] = None,
        neighbours: int = 0, radius: int = 3) -> dict[str, Any]:
    """RIS over the light tree (neighbours > 0: spatial reuse over that many pixels within radius pixels):
    the same dict as light_bvh_sampling. Raises ValueError for samples, candidates or radius = 0."""
def lightcuts(matrix: LightMatrix, error: float, max_cut: int, seed: int, block: int = 0,
              criterion: str = "cluster") -> dict[str, Any]:
    """Lightcuts (block = 0) or reconstruction cuts (grid every block pixels), refined per cluster ("cluster"),
    by the sum of the bounds ("pixel") or by their root-sum-square ("hoeffding"): image (H, W, 3) f32, cut_sizes
    (H, W) f32, shadow_rays, seconds (stage -> s), tree_seconds, full_cuts, tree_nodes, exact_lights.
    Raises ValueError for error <= 0 or NaN, max_cut = 0."""
def stochastic_lightcuts(matrix: LightMatrix, cut_size: int, samples: int, seed: int,
                         tree: Optional[LightTree] = None) -> dict[str, Any]:
    """Stochastic Lightcuts (cut of cut_size tree nodes, one light each, samples estimates per view sample):
    the same dict as light_bvh_sampling. Raises ValueError for cut_size or samples = 0."""
def lightslice(matrix: LightMatrix, slices: int, columns: int, global_columns: int, neighbours: int,
               normal_weight: float, seed: int) -> dict[str, Any]:
    """LightSlice: image (H, W, 3) f32, slices (H, W) int32 (-1: no surface), rows (S,) i64,
    global_assignment (n,) i64, clusters_per_slice (S,) i64, shadow_rays, timings {stage: seconds}.
    Raises ValueError for a zero count, global_columns > columns, a bad normal_weight, no lights."""

def load_scene(path: str, params: list[tuple[str, str]], size: Optional[tuple[int, int]] = None,
               media: str = "mitsuba") -> Scene:
    """Load Mitsuba 3 XML with ``$name`` substitutions; ``size`` = (width, height) overrides the film;
    ``media``: "mitsuba" (media as the scene's integrator uses them) or "error" (refuse ``<medium>``).

    Raises:
        FileNotFoundError: the XML or a file it names does not exist.
        SceneError: the scene is malformed or uses what is not supported (file, line and value).
        OSError: a file cannot be read.
        MemoryError: an image larger than host memory allows.
        ValueError: ``media`` is neither "mitsuba" nor "error".

    Warns:
        UserWarning: input Mitsuba accepts with a warning (a mesh whose triangles all have zero area; a
            medium under an integrator that ignores media, or one that scatters)."""

def device_info(device: str = "auto", scene: Scene | None = None) -> dict[str, Any]:
    """The device ``device`` resolves to: kind ("cpu"/"gpu"), name, backend, is_software, threads, shadow_rays,
    "reason" (why "auto" took the CPU, else None) and "gpu": the adapter wgpu would use (name, backend,
    device_type, driver, driver_info, is_software) or None. With ``scene``, the device a ``LightMatrix``
    of that scene takes: "auto" falls back to the CPU for a scene the GPU backend does not support,
    with the reason (none that the XML loader accepts: masked surfaces run on both backends).

    Raises:
        ValueError: an unknown device name or MANYLIGHTS_DEVICE; device="gpu" with a ``scene`` the GPU
            backend does not support.
        GpuUnavailableError: device="gpu" without an adapter, or MANYLIGHTS_ADAPTER naming none; the
            message names the package to install."""

def scene_lights(scene: Scene) -> LightSet:
    """The scene's point, spot and directional emitters."""

def generate_lights(scene: Scene, area: int = 4096, environment: int = 0, indirect: int = 0, max_depth: int = 5,
                    clamp: Optional[float] = None, env_importance: bool = False, seed: int = 0,
                    indirect_kind: str = "vpl", vsl_radius_scale: float = 1.0, vsl_neighbours: int = 16,
                    vpl_importance: bool = False, vpl_view_samples: int = 256,
                    vpl_accept_min: float = 0.01, env_visibility: bool = False) -> LightSet:
    """Delta emitters plus area, environment and indirect (VPL) lights; see ``manylights.generate_lights``.

    Raises:
        ValueError: negative or too large counts, NaN / non-positive clamp, max_depth < 3 with indirect,
            a scene without emitters, vpl_view_samples outside 1..=65536, vpl_accept_min outside (0, 1],
            a view importance sampling cannot use, env_importance and env_visibility both True."""

def stratified_rows(width: int, height: int, r: int, seed: int = 0) -> npt.NDArray[np.int64]:
    """(r,) int64 pixel indices, one drawn uniformly per block of an r-block stratification of the image.

    Raises:
        ValueError: r = 0, r > width * height, or an r whose block list cannot be allocated."""

def tensor_reconstruct_gpu(frames: Sequence[LightMatrix], representatives: npt.NDArray[np.uint32], rec: npt.NDArray[np.float32],
                           forward: npt.NDArray[np.uint32], backward: npt.NDArray[np.uint32]
                           ) -> tuple[npt.NDArray[np.float32], float, float]:
    """Tensor clustering's reconstruction kept on the GPU (Sec. 4.5 and 5): representatives (c, 2) =
    (light, frame) rendered by their frame's native light matrix (all on one GPU), scaled by rec (c, f, 3),
    carried through the pixel mappings (f - 1, H * W; 2**32 - 1 = no source) and accumulated on the GPU,
    read back once. Returns ((f, H, W, 3) float32, columns seconds, reconstruction seconds). Raises
    ValueError for a matrix not on the GPU, a bad shape or index."""

def tensor_accumulate(acc: npt.NDArray[np.float32], columns: npt.NDArray[np.float32], source: npt.NDArray[np.uint32],
                      rec: npt.NDArray[np.float32], forward: npt.NDArray[np.uint32], backward: npt.NDArray[np.uint32]) -> None:
    """Adds representative columns (c, H, W, 3) from frames source (c,), scaled by rec (c, f, 3) and carried
    through pixel mappings (f - 1, H * W; 2**32 - 1 = no source), into acc (f, H, W, 3) in place (tensor
    clustering, Sec. 4.5). Raises ValueError naming the bad shape or index."""

def generate_animation_lights(frames: Sequence[Scene], area: int = 1024, environment: int = 0, indirect: int = 0,
                              photons: int = 0, max_depth: int = -1, clamp: Optional[float] = None,
                              seed: int = 0) -> tuple[list[LightSet], dict[str, int]]:
    """One LightSet per frame, light j the same light in every frame, and the counts per kind
    (delta, area, environment, indirect). Raises ValueError naming the frame for mismatched frames."""

def check_host_memory(what: str, bytes: int) -> None:
    """Raises MemoryError naming ``what`` when ``bytes`` of host memory break the policy (MANYLIGHTS_MEMORY_LIMIT)."""

def encode_exr(image: npt.NDArray[np.float32]) -> bytes:
    """The bytes of a float32 RGB OpenEXR file. Raises ValueError for a shape other than (H, W, 3) or an
    empty image."""
def read_exr(path: str | PathLike[str]) -> npt.NDArray[np.float32]:
    """(H, W, 3) float32. Raises OSError naming the file when missing, truncated or not an OpenEXR file."""
def encode_srgb8(image: npt.NDArray[np.float32], exposure: float = 0.0) -> npt.NDArray[np.uint8]:
    """(H, W, 3) uint8 sRGB of a linear image times 2**exposure, clamped (as write_png). Raises ValueError."""
def encode_png(image: npt.NDArray[np.float32], exposure: float = 0.0) -> bytes:
    """The bytes of an 8-bit sRGB PNG. Raises ValueError for a bad shape, an empty image or a non-finite
    exposure."""

def bsdf_eval(spec: dict[str, Any], wi: npt.NDArray[np.float32], wo: npt.NDArray[np.float32], device: str) -> npt.NDArray[np.float32]:
    """Evaluate a BSDF given as a dict ({"type": "roughplastic", "alpha": 0.1, ...; "twosided": True}) on
    (N, 3) unit directions in the local shading frame (wi toward the viewer, wo toward the light), on
    device "cpu" (Rust reference) or "gpu" (WGSL twin). Returns (N, 3) f(wi, wo) |cos theta_o|.

    Types: diffuse, plastic, roughplastic, roughconductor, conductor, dielectric, principled (base_color,
    roughness, anisotropic, metallic, specular or eta, spec_tint, spec_trans, sheen, sheen_tint, clearcoat,
    clearcoat_gloss, flatness; floats), blendbsdf (weight: float, bsdf_0 / bsdf_1: nested spec dicts, not
    blends), with Mitsuba 3.9.1's defaults. "perturbed_normal": [x, y, z] (unit, local) evaluates it inside a
    bumpmap / normalmap of that perturbed normal (a "twosided" then goes around the wrapper, unless
    "twosided_inside": True).

    Raises:
        ValueError: bad spec or shapes, NaN/inf directions or spec values. GpuUnavailableError / GpuError for
            device="gpu"."""

def cluster_reduced_columns(R: npt.NDArray[np.float32], c: int, seed: int = 0,
                            power: Optional[npt.NDArray[np.float32]] = None, projection_dim: int = 50,
                            sampling_fraction: float = 2.0 / 3.0, color_averaging: bool = False) -> dict[str, Any]:
    """MRCS clustering of the reduced columns of R ((r, n, 3) or (r, n) float32) into c clusters.

    Returns a dict: assignment (n,) int32, representatives (c,) int64, weights (c, 3) float32 (unbiased
    estimator: sum_k weights[k] * column[representatives[k]]), cost float, cluster_costs (c,) float64,
    probability (n,) float64 (chance of each light being its cluster's representative).

    Raises:
        ValueError: c = 0 or c > n, NaN/inf (names row and column), bad shapes or power."""

def clustered_shading(A: LightMatrix, light_labels: npt.NDArray[np.uint32], light_centroids: npt.NDArray[np.float32],
                      view_centroids: npt.NDArray[np.float32], view_normals: npt.NDArray[np.float32],
                      membership_clusters: npt.NDArray[np.uint32],
                      membership_weights: npt.NDArray[np.float32]) -> dict[str, Any]:
    """Clustered visibility of A with given clusterings (public wrapper: manylights.clustered_shading).
    light_labels (n,), light_centroids (k_light, 3), view_centroids / view_normals (k_view, 3),
    membership_clusters / membership_weights (m, F).

    Returns a dict: image (H, W, 3) float32 (no emitters), visibility (k_view, ceil(K / 32)) uint32 bit rows
    (V > 0), transmittance (k_view, K) float32 and crossed (k_view, ceil(K / 32)) uint32 bit rows in a scene
    with masked surfaces (None otherwise), rays, gave_up (int), visibility_seconds, shading_seconds (float), light_representatives,
    light_cluster_labels, light_cluster_sizes (K,) int64, view_representatives (k_view,) int64 (-1: none),
    light_clusters K, view_clusters k_view (int).

    Raises:
        ValueError: shapes, labels, cluster ids, weights or non-finite values (named)."""

def mrcs_row_variance(rows: npt.NDArray[np.float32], assignment: npt.NDArray[np.int32],
                      probability: npt.NDArray[np.float64], num_clusters: int) -> npt.NDArray[np.float64]:
    """(h, 3) exact variance of the MRCS estimate at h complete rows (h, n, 3) for a clustering
    (assignment (n,) labels < num_clusters, probability (n,) of each light being its cluster's
    representative). Raises ValueError for bad shapes, labels or probabilities outside [0, 1]."""
def probe_pixels(scene: Scene, pixels: npt.NDArray[np.int64], spp: int, max_depth: int, seed: int,
                 progress: Optional[Callable[[int, int], None]] = None, lights: Optional[LightSet] = None,
                 guided_env: bool = True) -> Tuple[npt.NDArray[np.float32], npt.NDArray[np.float32]]:
    """(mean, variance_of_mean), each (k, 3) float32, of the unbiased path tracer at k probe pixels
    ((k, 2) int64 (row, column)); ``spp`` >= 2 paths each, Mitsuba's ``max_depth`` (-1 or >= 1).
    Raises ValueError for bad arguments or a scene with a principled BSDF (``manylights.probe_pixels``)."""
def clustering_cost(R: npt.NDArray[np.float32], assignment: npt.NDArray[np.int32]) -> float:
    """Sum of the paper's cluster costs of a partition on the (unprojected, scalar) reduced matrix."""

def check_animation_topology(frames: Sequence[Scene]) -> None:
    """Check that every frame has frame 0's topology: film size, shapes (ids, kinds, triangle and vertex
    counts, connectivity) and emitters (count and types).

    Raises:
        ValueError: no frames or a different film size (names the frame).
        SceneError: a different shape or emitter structure (names frame, shape or emitter, file and line)."""

def pixel_mapping(src: Scene, dst: Scene, reference: Scene, device: str = "auto") -> npt.NDArray[np.int64]:
    """The nearest-neighbour pixel mapping M(src -> dst) in the 9-D deep framebuffer (positions scaled by
    30 / the diagonal of ``reference``): (H, W) int64, per pixel of ``dst`` a pixel ``y * W + x`` of ``src``,
    -1 where ``dst`` sees no surface. Raises ValueError for frames of different sizes or a bad device."""

def compose_mappings(mappings: Sequence[npt.NDArray[np.int64]]) -> npt.NDArray[np.int64]:
    """The chain mappings[0], then mappings[1], ... as one (H, W) int64 mapping.
    Raises ValueError for none, different sizes or an entry outside [0, H*W) other than -1."""

def apply_mapping(images: npt.NDArray[np.float32], mappings: Sequence[npt.NDArray[np.int64]],
                  device: str = "auto") -> npt.NDArray[np.float32]:
    """(K, H, W, 3) float32 images gathered through the chain ``mappings`` (applied in order) on the CPU
    (composed, rayon) or the GPU (one WGSL gather per mapping). Raises ValueError for bad shapes or indices."""

def antialias(image: npt.NDArray[np.float32], scene: Scene, factor: int = 3,
              device: str = "auto") -> npt.NDArray[np.float32]:
    """(H, W, C) float32 image of ``scene`` anti-aliased from a deep framebuffer at ``factor`` x the
    resolution (3x3 nearest-neighbour upsampling in the 9-D metric, box filter).
    Raises ValueError for an image of another size or a factor outside [1, 16]."""

def cluster_tensor(slices: npt.NDArray[np.float32], columns: int, seed: int = 0, chunk: int = 40,
                   init_clusters: int = 100, projection_dim: int = 50, representative: str = "max",
                   color_averaging: bool = True, time_weight: float = 1.0, frame_major: bool = False) -> dict[str, Any]:
    """Tensor clustering (Hašan et al. 2008) of the light-frame pairs of slices ((r, n, f, 3) or (r, n, f)
    float32; with frame_major the same tensor stored as (f, r, n[, 3])) into `columns` clusters in total,
    chunks of `chunk` frames.

    Returns a dict: assignment (n, f) int32, representatives (c, 2) int64 (light, frame), frames (c, 2)
    int64 [start, end), sizes (c,) int64, rec (c, f, 3) float32, cost (c,) float64, rendered (c,) bool,
    shadow_maps_per_frame (f,) int64, clusters_per_frame (f,) int64, chunks (list of dicts: frames,
    budget, init_clusters, time_splits, light_splits).

    Raises:
        ValueError: bad shapes, NaN/inf (row, light, frame, channel named), columns outside [f, n f],
            chunk / init_clusters / projection_dim of 0, representative not "max" / "sampled" / "centroid"."""

class DirectToIndirect:
    """Precomputed final-gather transfers F_d^w, F_g^w, the multi-bounce M^w and relighting on the CPU or the GPU (use
    manylights.DirectToIndirect)."""
    gather_positions: npt.NDArray[np.float32]
    gather_normals: npt.NDArray[np.float32]
    gather_geo_normals: npt.NDArray[np.float32]
    gather_areas: npt.NDArray[np.float32]
    gather_k_d: npt.NDArray[np.float32]
    timings: dict[str, float]
    stats: dict[str, Any]
    device: dict[str, Any]
    """The device relighting runs on: kind ("cpu" / "gpu"), name, backend, is_software, threads."""
    def __init__(self, scene: Scene, gather: int, coefficients: int, seed: int, threshold: float, clamp: float,
                 k_weight: float, bounces: int = 1, multibounce_coefficients: int = 40,
                 progress: Optional[Callable[[int, int], None]] = None, multibounce: str = "photons",
                 photons_per_sample: int = 64, photon_neighbours: int = 400, glossy: bool = True,
                 near_field: str = "disc", device: str = "auto", visibility: Optional[str] = None,
                 shadow_map_size: int = 1024) -> None:
        """Raises ValueError: gather not a power of 4, coefficients outside 1 ..= gather, threshold < 0,
        clamp <= 0, K <= 0, multibounce not 'photons' or 'gather', photons_per_sample or
        photon_neighbours outside 1 ..= 2^20, near_field not 'disc' or 'point', an unknown device or
        MANYLIGHTS_DEVICE, an unknown visibility or shadow maps on the CPU, shadow_map_size outside
        16..=8192; GpuUnavailableError for device="gpu" without an adapter."""
    def relight(self, lights: LightSet, epsilon: float) -> npt.NDArray[np.float32]:
        """(H, W, 3) direct + one diffuse bounce. Raises ValueError: empty set, non-finite lights, epsilon < 0."""
    def gather_irradiance(self, lights: LightSet) -> npt.NDArray[np.float32]:
        """(n_g, 3) direct irradiance at the gather samples (W/m^2)."""

def transfer_arrays(rel: Any) -> list[tuple[str, npt.NDArray[Any]]]:
    """[(name, array)] of a precomputed transfer (src/relight/store.rs names them; float32, float64, uint32,
    uint64 arrays), what ``DirectToIndirect.save`` writes; rel is a ``manylights.DirectToIndirect`` or its native
    object. Raises TypeError: rel not a DirectToIndirect."""
def transfer_from_arrays(scene: Scene, arrays: Sequence[tuple[str, npt.NDArray[Any]]], device: str = "auto",
                         visibility: Optional[str] = None, shadow_map_size: int = 1024) -> DirectToIndirect:
    """Rebuilds a DirectToIndirect of ``scene`` from ``transfer_arrays`` output (``DirectToIndirect.load``),
    relighting on ``device`` as the constructor's.
    Raises ValueError naming the array (missing, shape, dtype, range, non-finite, a gather cloud or film
    that differs from the scene's), TypeError for an unsupported dtype."""
def transfer_scene_hash(scene: Scene) -> dict[str, str]:
    """{"geometry", "materials", "camera", "film": SHA-256 hex} of what a transfer of ``scene`` depends on
    (emitters excluded). Raises TypeError: scene not a Scene."""

class GatherCloud:
    """n = 4^k gather samples spread uniformly by area over a scene's surfaces (``manylights.gather_cloud``),
    each tied to (shape, triangle, barycentrics) so ``on`` re-evaluates it on another frame."""
    positions: npt.NDArray[np.float32]
    """(n, 3) world positions (m)."""
    normals: npt.NDArray[np.float32]
    """(n, 3) unit shading normals."""
    geo_normals: npt.NDArray[np.float32]
    """(n, 3) unit geometric normals."""
    uv: npt.NDArray[np.float32]
    """(n, 2) texture coordinates."""
    areas: npt.NDArray[np.float32]
    """(n,) area each sample stands for (m^2)."""
    shape: npt.NDArray[np.int64]
    """(n,) shape index (document order)."""
    triangle: npt.NDArray[np.int64]
    """(n,) triangle within the shape; -1 on an analytic sphere."""
    barycentrics: npt.NDArray[np.float32]
    """(n, 2) (b1, b2) of vertices 1 and 2; on a sphere (triangle -1) its (u, v) = (phi / 2 pi, theta / pi)."""
    k_d: npt.NDArray[np.float32]
    """(n, 3) diffuse coefficient (textures evaluated)."""
    k_g: npt.NDArray[np.float32]
    """(n, 3) glossy coefficient (0 without a glossy lobe)."""
    roughness: npt.NDArray[np.float32]
    """(n,) microfacet alpha of the glossy lobe (0 without one)."""
    bsdf: npt.NDArray[np.uint32]
    """(m, 20) BSDF records (m >= n; rows n.. are blends' second records). Opaque."""
    total_area: float
    diagonal: float
    seed: int
    side: int
    def __len__(self) -> int: ...
    def on(self, scene: Scene) -> GatherCloud:
        """The same samples on a scene of the same topology (positions, normals, areas, coefficients recomputed).

        Raises:
            ValueError: a different topology (names the shape). SceneError: non-finite vertices."""
    def hierarchy(self, K: float = 30.0) -> dict[str, Any]:
        """Balanced quad-tree by modified 2-means (Sec. 4.2, Eq. 9): dict with order, pixel, sample_at_pixel
        ((n,) int64), side, levels, K.

        Raises:
            ValueError: K not finite and > 0."""

def gather_cloud(scene: Scene, n: int = 16384, seed: int = 0, include_emitters: bool = True) -> GatherCloud:
    """n = 4^k gather samples by the paper's area stratification (see ``manylights.gather_cloud``).

    Raises:
        ValueError: n not a power of 4 in 1 ..= 4^12, a scene without surfaces. SceneError: bad meshes."""

def haar2d(image: npt.NDArray[np.float32]) -> npt.NDArray[np.float32]:
    """Forward non-standard orthonormal 2D Haar transform of an (s, s) or (s, s, C) float32 image, s = 2^k.

    Raises:
        ValueError: non-square / non-power-of-2 shape, non-finite values."""

def ihaar2d(coeffs: npt.NDArray[np.float32]) -> npt.NDArray[np.float32]:
    """Inverse of haar2d (same shapes and errors)."""

def haar_support_area(side: int) -> npt.NDArray[np.int64]:
    """(side, side) pixels covered by each Haar basis function. Raises ValueError: side not a power of 2."""

def haar_cull_area_weighted(coeffs: npt.NDArray[np.float32], keep: int) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float32]]:
    """Keep the `keep` coefficients of highest |c| * support area (Sec. 4.3): (indices (k,) ascending, values
    (k,) or (k, C)).

    Raises:
        ValueError: bad shape, non-finite values, keep < 0."""

def cull_wavelet_lights(light: npt.NDArray[np.float32], image_norms: npt.NDArray[np.float32], epsilon: float) -> npt.NDArray[np.int64]:
    """Indices j with |light[j]| * image_norms[j] >= epsilon (Sec. 3.5 on-the-fly culling).

    Raises:
        ValueError: mismatched shapes, non-finite values, negative norms or epsilon."""

def kmeans(points: npt.NDArray[np.float32], normals: Optional[npt.NDArray[np.float32]], k: int, iterations: int = 10,
           tolerance: float = 0.0, cos_threshold: Optional[float] = 0.8660254, grid: bool = True,
           device: str = "auto", seed: int = 0) -> dict[str, Any]:
    """K-means of (N, 3) float32 points with (N, 3) float32 normals or None (then no orientation term), Eq. 7
    of the 2022 GPU fuzzy K-means paper (the public wrapper is manylights.kmeans).

    Returns a dict: centroids (k, 3) float32, centroid_normals (k, 3) float32, labels (N,) int64, objective
    (iterations + 1 floats: sum of squared distances to the nearest centroid after t updates), iterations,
    initial (k,) int64, timings (seconds: setup, iterations, readback, total), device ("cpu"/"gpu").

    Raises:
        ValueError: k outside [1, N], negative iterations / tolerance, bad shapes, NaN/inf, zero normals
            with the threshold on, cos_threshold outside [-1, 1], an unknown device."""

def fuzzy_membership(points: npt.NDArray[np.float32], normals: Optional[npt.NDArray[np.float32]],
                     centroids: npt.NDArray[np.float32], centroid_normals: Optional[npt.NDArray[np.float32]],
                     f: int = 6, cos_threshold: Optional[float] = 0.8660254, grid: bool = True,
                     device: str = "auto") -> dict[str, Any]:
    """The f nearest of the (k, 3) centroids of each (N, 3) point and the Eq. 10 weights (Alg. 2).

    Returns a dict: clusters (N, f) int64 nearest first, weights (N, f) float32 (rows sum to 1), distances
    (N, f) float32, admissible (N, f) bool, device.

    Raises:
        ValueError: f outside [1, min(k, 16)], bad shapes, NaN/inf, zero normals with the threshold on,
            normals for only one side, cos_threshold outside [-1, 1], an unknown device."""

def cluster_view_samples(points: npt.NDArray[np.float32], normals: npt.NDArray[np.float32], k: int, gamma: int = 4,
                         f: int = 6, iterations: int = 10, cos_threshold: Optional[float] = ..., grid: bool = True,
                         device: str = "auto", seed: int = 0) -> dict[str, Any]:
    """View-sample clustering of the 2022 paper (Alg. 1 with downsampling by gamma, then Alg. 2): centroids,
    centroid_normals (k, 3) float32, clusters (N, f) int64, weights (N, f) float32, gamma, subset, objective,
    iterations, device, seconds. Raises ValueError naming a bad k, gamma, f, shape or value."""
