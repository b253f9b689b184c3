"""What every renderer returns (``RenderResult``) and the checks and light weights the renderers share."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from ..matrix.light_matrix import LightMatrix

# Rec. 709 luminance, for turning RGB powers into sampling weights.
LUMINANCE = np.array([0.2126, 0.7152, 0.0722], dtype=np.float64)


@dataclass
class RenderResult:
    """What a renderer did: the image (column estimate + what the camera sees of emitters) and how."""

    image: np.ndarray
    method: str
    seed: int
    timings: dict = field(default_factory=dict)
    rows: Optional[np.ndarray] = None
    clusters: Optional[np.ndarray] = None
    representatives: Optional[np.ndarray] = None
    weights: Optional[np.ndarray] = None
    budget: dict = field(default_factory=dict)
    #: The device that computed the image (``LightMatrix.device``: kind "cpu"/"gpu", name, backend, ...).
    device: dict = field(default_factory=dict)
    #: Estimated relative L2 of ``image`` against brute force, without the reference (MRCS: see
    #: ``manylights.renderers.estimates``); None for renderers without one.
    error_estimate: Optional[float] = None
    #: (H, W) float32 estimated RMS error per pixel (radiance), where the renderer has one.
    error_image: Optional[np.ndarray] = None
    #: Known sources of bias of the light model that no estimate covers (``renderers.bias``: VPL clamp, VSL
    #: radius, glossy lobes without MIS), each a dict with ``source`` and ``reason``; empty when none is known.
    #: ``error_estimate`` covers variance only: with a source listed, the error against the converged scene
    #: can be larger than it says.
    bias_sources: list = field(default_factory=list)
    #: With probes (``error_probes``): the renderer's own estimate (variance only) moves here, ``error_estimate``
    #: becomes the probes' upper bound on the error against the converged scene (``probe_error``).
    variance_estimate: Optional[float] = None
    #: With probes: relative L2 of the image's expectation against the converged scene (variance removed).
    bias_estimate: Optional[float] = None

    @property
    def seconds(self) -> float:
        """Total time of all stages."""
        return float(sum(self.timings.values()))



def light_luminance_power(lights) -> np.ndarray:
    """(n,) float64 luminance (Rec. 709) of each light's RGB power, clipped at 0: the weights of power sampling."""
    return np.maximum(np.asarray(lights.power, dtype=np.float64) @ LUMINANCE, 0.0)


def matrix_shape(A) -> tuple[int, int]:
    """(m, n) of a ``LightMatrix``.

    Raises:
        TypeError: A is not a LightMatrix."""
    if not isinstance(A, LightMatrix):
        raise TypeError(f"A must be a manylights LightMatrix, got {type(A).__name__}")
    return A.shape
