"""The lighting tensor of an animation and the per-frame MRCS baseline.

Hašan, Velázquez, Pellacini, Bala, "Tensor Clustering for Rendering Many-Light Animations", EGSR 2008,
Sec. 4.1-4.2: the m x n x f tensor A(i, j, k) = contribution of light j to view sample i in frame k; an
animation is its sum over lights, one image per frame. ``LightTensor`` is that oracle, built from one
``LightMatrix`` per frame (either backend): ``frame(k)`` is A(:, :, k), ``slices(I)`` the reduced tensor
R = A(I, :, :) with the same view-sample rows I in every frame, ``brute_force()`` every element.

Light j must be "the same" light in every frame (a light-frame pair (j, k) is the paper's unit): pass one
``LightSet`` per frame, all of the same size, in which light j of frame k is light j of frame 0 moved with
its surface (``generate_animation_lights`` makes such sets), or a single ``LightSet`` for lights that do
not move.

Symbols (the paper's Table 1): m view samples (H W pixels), n lights, f frames, r slices (rows),
c clusters (columns), A the full tensor, R the reduced tensor (r, n, f, 3).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Optional, Sequence

import numpy as np

from .. import _native
from .._native import LightSet, Scene
from .._utils import validate as _v
from .._utils.keywords import checked_keywords
from ..io.display import png_bytes
from ..matrix.light_matrix import LightMatrix
from ..matrix.rows import stratified_rows
from ..renderers.bias import bias_sources
from ..renderers.mrcs import mrcs
from ..renderers.result import short_repr, summary_lines
from .frames import Animation


@dataclass(repr=False)
class AnimationResult:
    """What an animation renderer did: the frames and how.

    ``frames`` (f, H, W, 3) float32 (column estimate + what the camera sees of emitters, per frame);
    ``shadow_maps_per_frame`` (f,) int, counted: rows plus representative columns rendered in that frame
    (a row is one cube shadow map and a column one shadow map on the GPU; one shadow ray per element on the
    CPU); ``timings`` seconds per stage; ``budget`` rows, columns (total), lights, frames."""

    frames: np.ndarray
    method: str
    seed: int
    shadow_maps_per_frame: np.ndarray
    timings: dict = field(default_factory=dict)
    budget: dict = field(default_factory=dict)
    device: dict = field(default_factory=dict)
    rows: Optional[np.ndarray] = None
    clustering: Optional[object] = None
    #: Known bias sources of the light model (``RenderResult.bias_sources``), from frame 0's matrix: every
    #: frame has the same kinds of lights and materials.
    bias_sources: list = field(default_factory=list)
    #: With probes (``error_probes``): per frame (f,) float64, the probes' upper bound on the frame's relative L2
    #: against the converged frame (variance and bias; ``renderers.probe_error``); None without.
    error_estimate: Optional[np.ndarray] = None

    @property
    def seconds(self) -> float:
        """Total time of all stages."""
        return float(sum(self.timings.values()))

    def summary(self) -> str:
        """A few lines: method, seed, device, frames and size, budget, shadow maps per frame, time per stage."""
        f, h, w = np.shape(self.frames)[:3]
        maps = np.asarray(self.shadow_maps_per_frame)
        unit = "shadow maps" if self.device.get("kind") == "gpu" else "rows + columns"
        extra = {f"{unit} per frame": f"mean {maps.mean():.4g}, max {maps.max():,}"} if maps.size else {}
        if self.error_estimate is not None and np.size(self.error_estimate):
            e = np.asarray(self.error_estimate)
            extra["error estimate per frame (probes)"] = f"mean {e.mean():.3g}, max {e.max():.3g}"
        return "\n".join(summary_lines("AnimationResult", self.method, self.seed, f"{f} frames of {w}x{h}",
                                        self.budget, self.timings, self.device, None, self.bias_sources, extra))

    def __str__(self) -> str:
        return self.summary()

    def __repr__(self) -> str:
        return short_repr(self.summary().splitlines())

    def _repr_png_(self) -> bytes:
        return png_bytes(self.frames)


class LightTensor:
    """The m x n x f lighting tensor of an animation (module docs; the paper's Sec. 4.1).

    Args:
        animation: the frames' Scenes: an ``Animation`` (``load_animation``) or a sequence of ``Scene``, all
            with the same image size.
        lights: one ``LightSet`` per frame (light j of every frame is the same light, moved), or one
            ``LightSet`` for every frame.
        device, visibility, max_depth, shadow_map_size: as ``LightMatrix`` (every frame the same).

    Raises:
        ValueError: no frames, frames of different image sizes, a light-set count other than the frame count,
            light sets of different sizes (the frame is named), or what ``LightMatrix`` raises.
    """

    @checked_keywords()
    def __init__(self, animation, lights, *, device: str = "auto", visibility: Optional[str] = None,
                 max_depth: int = -1, shadow_map_size: Optional[int] = None):
        scenes = [animation[k] for k in range(len(animation))]
        if not scenes:
            raise ValueError("the animation has no frames")
        for k, s in enumerate(scenes):
            if not isinstance(s, Scene):
                raise ValueError(f"frame {k} is {type(s).__name__}, not a Scene")
            if (s.width, s.height) != (scenes[0].width, scenes[0].height):
                raise ValueError(f"frame {k} is {s.width}x{s.height} but frame 0 is "
                                 f"{scenes[0].width}x{scenes[0].height}: every frame needs the same image size")
        if isinstance(lights, LightSet):
            lights = [lights] * len(scenes)
        lights = list(lights)
        if len(lights) != len(scenes):
            raise ValueError(f"{len(lights)} light sets for {len(scenes)} frames: give one per frame (or one for all)")
        for k, ls in enumerate(lights):
            if not isinstance(ls, LightSet):
                raise ValueError(f"lights of frame {k} is {type(ls).__name__}, not a LightSet")
            if len(ls) != len(lights[0]):
                raise ValueError(f"frame {k} has {len(ls)} lights but frame 0 has {len(lights[0])}: light j must be "
                                 "the same light in every frame")
        self.animation = animation
        self.scenes = scenes
        self.lights = lights
        self._options = dict(device=device, visibility=visibility, max_depth=max_depth, shadow_map_size=shadow_map_size)
        self._frames: dict[int, object] = {}
        self._animation = None
        self.frame(0)  # checks the options once, up front

    @property
    def shape(self) -> tuple[int, int, int]:
        """(m, n, f): view samples per frame, lights, frames."""
        s = self.scenes[0]
        return (s.width * s.height, len(self.lights[0]), len(self.scenes))

    def __len__(self) -> int:
        return len(self.scenes)

    def frame(self, k: int):
        """A(:, :, k), the ``LightMatrix`` of frame k (built once, then cached).

        Raises:
            IndexError: k outside [0, f)."""
        f = len(self.scenes)
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)):
            raise ValueError(f"frame index must be an integer, got {k!r}")
        if not -f <= k < f:
            raise IndexError(f"frame {k} out of range for {f} frames")
        k = int(k) % f
        if k not in self._frames:
            self._frames[k] = LightMatrix(self.scenes[k], self.lights[k], **self._options)
        return self._frames[k]

    @property
    def device(self) -> dict:
        """The device of the frames' light matrices (``LightMatrix.device``)."""
        return self.frame(0).device

    def mapping(self, k: int, l: int) -> np.ndarray:
        """The pixel mapping M(k -> l) between frames (the paper's Sec. 4.4; ``Animation.mapping``): (H, W)
        int64, for each pixel of frame l the pixel ``y * W + x`` of frame k nearest to it in the 9-D deep
        framebuffer, -1 where frame l sees no surface. Computed once per adjacent pair and cached.

        Raises:
            IndexError: k or l out of range."""
        if self._animation is None:
            anim = self.animation
            if not isinstance(anim, Animation):
                dev = self._options["device"]
                anim = Animation(self.scenes, [s.path for s in self.scenes], [{}] * len(self.scenes),
                                 device=dev if dev in ("auto", "cpu", "gpu") else "auto")
            self._animation = anim
        return self._animation.mapping(k, l)

    def slices(self, rows: Sequence[int], *, progress: Optional[bool] = None) -> np.ndarray:
        """The reduced tensor R = A(I, :, :) (the paper's r slices), (r, n, f, 3) float32: R[a, j, k] is
        light j's contribution to view sample ``rows[a]`` in frame k. Stored frame by frame: the result is a
        view of an (f, r, n, 3) array (``np.ascontiguousarray`` for an (r, n, f, 3) copy).

        Raises:
            ValueError: rows as ``LightMatrix.rows`` (empty, out of range). MemoryError: R would not fit the
                host-memory policy (``MANYLIGHTS_MEMORY_LIMIT``)."""
        m, n, f = self.shape
        idx = _v.indices("row index", rows, m, f"m = {m} view samples")
        if idx.size == 0:
            raise ValueError("slices needs at least one row index, got 0")
        _native.check_host_memory(f"reduced tensor: {idx.size} rows x {n} lights x {f} frames x RGB float32",
                                  int(idx.size) * n * f * 12)
        # Stored frame by frame (each frame's rows are one contiguous block, no strided copy), returned as the
        # (r, n, f, 3) view; cluster_tensor takes that view without copying.
        frames = np.empty((f, idx.size, n, 3), np.float32)
        for k in range(f):
            frames[k] = self.frame(k).rows(idx, progress=progress)
        return np.moveaxis(frames, 0, 2)

    def brute_force(self, *, progress: Optional[bool] = None) -> np.ndarray:
        """Every element summed per frame plus what the camera sees of emitters: (f, H, W, 3) float32, the
        reference the renderers approximate."""
        return np.stack([self.frame(k).column_sum(progress=progress) + self.frame(k).emitted()
                         for k in range(len(self))])

    def __repr__(self) -> str:
        m, n, f = self.shape
        return f"LightTensor(m={m}, n={n}, f={f}, device={self.device.get('kind')!r})"


@checked_keywords()
def mrcs_per_frame(T: LightTensor, rows: int = 300, columns: int = 900, seed: int = 0, *,
                   progress: Optional[bool] = None) -> AnimationResult:
    """The baseline of the tensor-clustering paper: independent MRCS (Hašan et al. 2007) on every frame,
    through the same ``mrcs`` code path, with the same stratified rows in every frame and seed ``seed + k``
    for frame k (independent sampling per frame, which is what makes it flicker).

    Returns:
        AnimationResult with frames (f, H, W, 3), shadow_maps_per_frame = rows + columns in every frame, and
        timings summed over frames per MRCS stage.

    Raises:
        ValueError: rows or columns out of range for a frame's matrix, a negative seed."""
    if not isinstance(T, LightTensor):
        raise TypeError(f"T must be a LightTensor, got {type(T).__name__}")
    seed = _v.seed(seed)
    m, n, f = T.shape
    rows = _v.integer("rows", rows, 1, m)
    columns = _v.integer("columns", columns, 1, n)
    t = time.perf_counter()
    row_idx = stratified_rows(T.scenes[0], rows, seed=seed)
    timings = {"row_selection": time.perf_counter() - t}
    frames = []
    for k in range(f):
        res = mrcs(T.frame(k), rows=rows, columns=columns, seed=seed + k, row_indices=row_idx, progress=progress)
        frames.append(res.image)
        for name, v in res.timings.items():
            if name != "row_selection":
                timings[name] = timings.get(name, 0.0) + v
    spf = np.full(f, rows + columns, dtype=np.int64)
    return AnimationResult(frames=np.stack(frames), method="mrcs_per_frame", seed=seed, shadow_maps_per_frame=spf,
                           timings=timings, budget={"rows": rows, "columns": columns * f, "lights": n, "frames": f},
                           device=T.device, rows=row_idx, bias_sources=bias_sources(T.frame(0)))
