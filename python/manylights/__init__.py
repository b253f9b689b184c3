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
# Scene and lights
from ._native import (
    GatherCloud,
    GpuError,
    GpuUnavailableError,
    LightSet,
    LightTree,
    ManyLightsError,
    Scene,
    SceneError,
    device_info,
)
from ._native import __version__ as __version__

# Animation
from .animation.frames import Animation, apply_mapping, load_animation
from .animation.lights import AnimationLights, generate_animation_lights
from .animation.tensor import AnimationResult, LightTensor, mrcs_per_frame
from .animation.tensor_clustering import tensor_clustering
from .animation.tensor_clusters import TensorClustering, cluster_tensor

# Sweeps (dask and pandas are imported when a sweep runs)
from .distributed.sweep import sweep
from .io.display import show

# I/O and metrics
from .io.images import read_exr, write_exr, write_png
from .io.video import side_by_side, write_exr_sequence, write_video
from .lights.gather import gather_cloud
from .lights.generate import generate_lights, scene_lights

# The light matrix
from .matrix.light_matrix import LightMatrix
from .matrix.rows import stratified_rows
from .metrics import flicker, fraction_within, relative_l2, relative_l2_per_frame, relmse, smape

# Relighting
from .relight.direct_to_indirect import DirectToIndirect
from .renderers.antialias import antialias
from .renderers.baselines import instant_radiosity, power_sampling
from .renderers.brute_force import render_brute_force
from .renderers.clustered_visibility import clustered_shading, clustered_visibility
from .renderers.clustering import cluster_reduced_columns, clustering_cost
from .renderers.kmeans import KMeansResult, fuzzy_membership, kmeans
from .renderers.light_tree import light_bvh_sampling, ris_sampling, stochastic_lightcuts
from .renderers.lightcuts import lightcuts, reconstruction_cuts
from .renderers.lightslice import lightslice
from .renderers.mrcs import mrcs
from .renderers.probes import probe_pixels
from .renderers.progressive import mrcs_progressive
from .renderers.render import render

# Renderers
from .renderers.result import RenderResult
from .scene import load_scene

__all__ = [
    # scene and lights
    "Scene", "LightSet", "LightTree", "GatherCloud", "load_scene", "scene_lights", "generate_lights", "gather_cloud",
    "device_info",
    # the light matrix
    "LightMatrix", "stratified_rows",
    # renderers
    "RenderResult", "render", "render_brute_force", "mrcs", "mrcs_progressive", "cluster_reduced_columns",
    "clustering_cost", "power_sampling", "instant_radiosity", "clustered_visibility", "clustered_shading",
    "KMeansResult", "kmeans", "fuzzy_membership", "antialias", "probe_pixels", "light_bvh_sampling", "ris_sampling",
    "lightcuts", "reconstruction_cuts",
    "stochastic_lightcuts", "lightslice",
    # animation
    "Animation", "load_animation", "apply_mapping", "AnimationLights", "generate_animation_lights",
    "LightTensor", "AnimationResult", "mrcs_per_frame", "TensorClustering", "cluster_tensor", "tensor_clustering",
    # relighting
    "DirectToIndirect",
    # sweeps
    "sweep",
    # I/O and metrics
    "read_exr", "write_exr", "write_png", "show", "write_exr_sequence", "write_video", "side_by_side", "relative_l2",
    "relative_l2_per_frame", "fraction_within", "flicker", "relmse", "smape",
    # exceptions
    "ManyLightsError", "SceneError", "GpuError", "GpuUnavailableError",
]
