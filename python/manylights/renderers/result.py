"""What every renderer returns (``RenderResult``) and the checks and light weights the renderers share."""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from ..io.display import png_bytes
from ..matrix.light_matrix import LightMatrix

# Rec. 709 luminance, for turning RGB powers into sampling weights.
LUMINANCE = np.array([0.2126, 0.7152, 0.0722], dtype=np.float64)


#: ``repr`` of a result stays under this many characters (a notebook cell or a log line, never an array dump).
REPR_LIMIT = 1000


def _fmt(v) -> str:
    if isinstance(v, (bool, np.bool_)):
        return str(bool(v))
    if isinstance(v, (int, np.integer)):
        return f"{int(v):,}"
    if isinstance(v, (float, np.floating)):
        return f"{float(v):.4g}"
    if isinstance(v, str):
        return v if len(v) <= 40 else v[:37] + "..."
    if isinstance(v, np.ndarray):
        return f"array{list(v.shape)}"
    if isinstance(v, (list, tuple)):
        return f"[{len(v)} items]"
    return type(v).__name__


def _items(d: dict, limit: int = 8) -> str:
    parts = [f"{k} {_fmt(v)}" for k, v in list(d.items())[:limit]]
    return ", ".join(parts) + (f", ... ({len(d) - limit} more)" if len(d) > limit else "")


def summary_lines(kind: str, method: str, seed: int, size: str, budget: dict, timings: dict, device: dict,
                  error_estimate=None, bias_sources=(), extra: Optional[dict] = None) -> list:
    """Lines of a result's summary: what ran where, its budget, error estimate and the time per stage."""
    dev = device.get("kind", "?") if device else "?"
    if device and device.get("name"):
        dev += f" ({_fmt(device['name'])})"
    lines = [f"{kind}: {method} (seed {seed}) on {dev}, {size}"]
    if budget:
        lines.append(f"  budget: {_items(budget)}")
    if error_estimate is not None:
        err = f"  error estimate: {100 * float(error_estimate):.3g}% relative L2"
        if bias_sources:
            names = sorted({str(b.get('source', '?')) for b in bias_sources if isinstance(b, dict)})
            err += f" (variance; not covered: {', '.join(names)[:120]})"
        lines.append(err)
    for k, v in (extra or {}).items():
        lines.append(f"  {k}: {_fmt(v)}")
    if timings:
        stages = sorted(((k, v) for k, v in timings.items() if float(v) > 0), key=lambda kv: -float(kv[1]))
        shown = " + ".join(f"{k} {float(v):.3g}" for k, v in stages[:8])
        more = f" + {len(stages) - 8} more" if len(stages) > 8 else ""
        lines.append(f"  time: {sum(float(v) for v in timings.values()):.3g} s = {shown}{more}")
    return lines


def short_repr(lines: list) -> str:
    """The summary as one ``repr`` under ``REPR_LIMIT`` characters."""
    text = "<" + "; ".join(s.strip() for s in lines) + ">"
    return text if len(text) < REPR_LIMIT else text[: REPR_LIMIT - 5] + "...>"


@dataclass(repr=False)
class RenderResult:
    """What a renderer did: the image (column estimate + what the camera sees of emitters) and how.

    ``print(result)`` shows a short summary (method, device, budget, error estimate, time per stage),
    ``repr`` the same on one line (under 1,000 characters); in Jupyter the result displays as its image
    (``_repr_png_``: 8-bit sRGB, clamped, as ``write_png``)."""

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
    #: (H, W) int32 clusters and lights shaded per pixel, where the renderer picks a cut per pixel (Lightcuts).
    cut_sizes: Optional[np.ndarray] = None

    @property
    def seconds(self) -> float:
        """Total time of all stages."""
        return float(sum(self.timings.values()))

    def summary(self) -> str:
        """A few lines: method, seed, device, image size, budget, error estimate, time per stage."""
        h, w = np.shape(self.image)[:2]
        extra = {}
        if self.bias_estimate is not None:
            extra["bias estimate (probes)"] = self.bias_estimate
        return "\n".join(summary_lines("RenderResult", self.method, self.seed, f"{w}x{h} image", self.budget,
                                        self.timings, self.device, self.error_estimate, self.bias_sources, extra))

    def __str__(self) -> str:
        return self.summary()

    def __repr__(self) -> str:
        return short_repr(self.summary().splitlines())

    def _repr_png_(self) -> bytes:
        return png_bytes(self.image)


def with_emitted(A, image: np.ndarray, timings: dict, add_emitted: bool = True) -> np.ndarray:
    """``image + A.emitted()`` (what the camera sees of the emitters) when ``add_emitted``, timed into
    ``timings['emitted']`` (seconds); ``image`` unchanged otherwise."""
    if not add_emitted:
        return image
    t = time.perf_counter()
    out = image + A.emitted()
    timings["emitted"] = time.perf_counter() - t
    return out


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
