"""Public functions with no bad-input case, and why."""
from __future__ import annotations

# Functions that are public but not entry points for data, with why they need no corpus entry.
NOT_COVERED: dict[str, str] = {
    "RenderResult": "a dataclass that only holds results (no validation of its own)",
    "TensorClustering": "a dataclass that only holds results; made by cluster_tensor (covered)",
    "KMeansResult": "a dataclass that only holds results; made by kmeans (covered)",
    "AnimationLights": "a container of the per-frame LightSets that generate_animation_lights makes (covered)",
    "scenes.available": "takes no arguments",
    "scenes.animated": "takes no arguments",
    "Animation.gbuffers": "takes no arguments (the device is the Animation's, checked when it is made)",
    "AnimationResult": "a dataclass that only holds results (no validation of its own)",
    "LightTensor.brute_force": "takes only a progress flag (None, True or False; any other value counts as True)",
    "LightMatrix.view_samples": "takes no arguments",
    "RenderResult.summary": "takes no arguments",
    "AnimationResult.summary": "takes no arguments",
}
