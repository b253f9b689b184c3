"""Animations and pixel mappings (Hašan, Velázquez-Armendáriz, Pellacini, Bala, "Tensor Clustering for
Rendering Many-Light Animations", EGSR 2008, Sec. 4.2, 4.4 and 5).

An animation is one Scene per frame with the same topology: the same film size, shapes (ids, triangle
and vertex counts, connectivity) and emitters (count and types); camera, transforms, light positions and
mesh vertices may change. Frames come from one Mitsuba XML whose ``<default>`` parameters change per
frame, exactly as ``mitsuba.load_file(path, **params)`` animates, or from one XML per frame::

    import manylights as ml
    from manylights.scenes import animation_frames, scene_path
    anim = ml.load_animation(scene_path("bounce"), frames=animation_frames("bounce", count=8), size=(48, 48))
    len(anim); anim[3]                      # frame 3's Scene
    M = anim.mapping(3, 4)                  # (H, W) int64: per pixel of frame 4, a pixel of frame 3
    img4 = ml.apply_mapping(img3, M)        # a frame-3 image moved into frame 4

Pixel mappings: ``anim.mapping(k, l)`` is M(k -> l) of the paper, the nearest neighbour of each pixel of
frame l among the pixels of frame k in the 9-D deep framebuffer ``(K / d * position, normal, albedo)``,
d = frame 0's bounding-box diagonal, K = 30 (the weights of Eq. 9 of Hašan et al. 2006, which the 2008
paper does not state; see ``src/view/features.rs``), found with a kd-tree. Between non-adjacent frames it
is the chain of adjacent mappings (forward for l > k, backward for l < k), composed. Pixels of frame l
that see no surface map to -1 (they take 0: columns of the light matrix are 0 there); background pixels
of frame k are no source.
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Iterator, Optional, Sequence, Union

import numpy as np

from .. import _native
from .._native import Scene
from .._utils import validate as _v
from .._utils.keywords import checked_keywords
from ..scene import check_scene_parameters, load_scene

__all__ = ["Animation", "apply_mapping", "load_animation"]

PathLike = Union[str, os.PathLike]


def _frame_error(exc: BaseException, k: int, path, params: dict) -> BaseException:
    """The same kind of exception, its message prefixed with the frame."""
    shown = ", ".join(f"{key}={val!r}" for key, val in params.items()) or "no parameters"
    msg = f"load_animation: frame {k} ({os.fspath(path)}, {shown}): {exc}"
    try:
        return type(exc)(msg)
    except Exception:  # an exception type whose constructor takes other arguments
        return ValueError(msg)


def load_animation(path: Union[PathLike, Sequence[PathLike]], frames: Optional[Sequence[dict]] = None, *,
                   size: Optional[tuple[int, int]] = None, device: str = "auto", **params) -> "Animation":
    """Load an animation: one Mitsuba 3 XML with per-frame ``<default>`` parameters, or one XML per frame.

    Args:
        path: a scene XML (then ``frames`` is required), or a list of XMLs, one per frame.
        frames: one dict of parameters per frame (``[{"t": 0.0}, {"t": 0.1}, ...]``), passed to the loader
            as ``mitsuba.load_file(path, **frame)`` takes them. With a list of paths it is optional (default:
            no parameters) and, when given, needs one dict per path.
        size: optional (width, height) overriding every frame's film.
        device: where the deep framebuffers of the pixel mappings are computed ("auto", "cpu", "gpu").
        **params: parameters common to every frame (a frame's own value wins), e.g. ``res=48``.

    Returns:
        Animation: ``len(anim)`` frames, ``anim[k]`` frame k's Scene.

    Raises:
        ValueError: no frames, ``frames`` of another length than the list of paths, a bad ``size``, frames
            of different film sizes (the message names the frame).
        TypeError: a frame that is not a dict or a parameter name that is not a string; a parameter that
            no ``$name`` of the scene's files refers to (before any frame loads; the message names the
            closest one the file has).
        SceneError: a frame names a parameter the XML does not use or declare ("unused parameter"), any
            other load error, or a frame whose shapes or emitters differ from frame 0's (count, ids,
            triangles, vertices, connectivity, emitter types); the message names the frame, the shape or
            emitter and its file and line.
        FileNotFoundError: a missing scene file (the message names the frame).
    """
    if not isinstance(device, str) or device.strip().lower() not in ("auto", "cpu", "gpu"):
        raise ValueError(f"device must be 'auto', 'gpu' or 'cpu', got {device!r}")
    if isinstance(path, (str, os.PathLike)):
        if frames is None:
            raise ValueError("load_animation: frames is required with a single scene file (a list of parameter "
                             "dicts, one per frame); pass a list of paths for one file per frame")
        frames = list(frames) if not isinstance(frames, dict) else [frames]
        paths = [Path(path)] * len(frames)
    elif isinstance(path, (list, tuple)):
        paths = [Path(p) for p in path]
        if frames is None:
            frames = [{} for _ in paths]
        else:
            frames = list(frames)
            if len(frames) != len(paths):
                raise ValueError(f"load_animation: {len(paths)} scene files but {len(frames)} frame parameter dicts "
                                 "(give one dict per file, or none)")
    else:
        raise TypeError(f"load_animation: path must be a scene file or a list of them, got {type(path).__name__}")
    if len(frames) == 0:
        raise ValueError("load_animation: the frame list is empty (an animation needs at least one frame)")
    for k, f in enumerate(frames):
        if not isinstance(f, dict):
            raise TypeError(f"load_animation: frame {k} must be a dict of parameters, got {type(f).__name__}")
        for key in f:
            if not isinstance(key, str):
                raise TypeError(f"load_animation: frame {k}: parameter names must be strings, got {key!r}")
    for k, (p, f) in enumerate(zip(paths, frames)):  # every frame's parameters, before any frame loads
        if p.is_file() and (params or f):
            try:
                check_scene_parameters(p, {**params, **f})
            except TypeError as e:
                raise TypeError(f"load_animation: frame {k} ({p}): {e}") from None
    scenes = []
    merged = []
    for k, (p, f) in enumerate(zip(paths, frames)):
        fp = {**params, **f}
        try:
            scenes.append(load_scene(p, size=size, **fp))
        except (_native.SceneError, ValueError, OSError) as e:
            raise _frame_error(e, k, p, fp) from e
        merged.append(fp)
    _native.check_animation_topology(scenes)
    return Animation(scenes, paths, merged, device=device)


class Animation:
    """Frames of an animation, one Scene each (see ``load_animation``; Sec. 4.2 of the paper).

    ``len(anim)``, ``anim[k]`` (negative k counts from the end), ``for scene in anim``; ``anim.paths[k]`` and
    ``anim.params[k]`` say how frame k was loaded; ``anim.width`` / ``anim.height`` the common film size.
    """

    @checked_keywords()
    def __init__(self, frames: Sequence[Scene], paths: Sequence[Path], params: Sequence[dict], *, device: str = "auto"):
        frames = list(frames)
        if not frames:
            raise ValueError("Animation needs at least one frame, got 0")
        bad = next((k for k, s in enumerate(frames) if not isinstance(s, Scene)), None)
        if bad is not None:
            raise TypeError(f"Animation: frame {bad} must be a manylights Scene, got {type(frames[bad]).__name__}")
        if len(paths) != len(frames) or len(params) != len(frames):
            raise ValueError(f"Animation: {len(frames)} frames but {len(paths)} paths and {len(params)} parameter dicts")
        if not isinstance(device, str) or device.strip().lower() not in ("auto", "cpu", "gpu"):
            raise ValueError(f"device must be 'auto', 'gpu' or 'cpu', got {device!r}")
        self.frames = frames
        self.paths = list(paths)
        self.params = [dict(p) for p in params]
        self.device = device
        self._adjacent: dict[tuple[int, int], np.ndarray] = {}

    def __len__(self) -> int:
        return len(self.frames)

    def _index(self, k) -> int:
        if isinstance(k, (bool, np.bool_)) or not isinstance(k, (int, np.integer)):
            raise TypeError(f"frame index must be an integer, got {type(k).__name__}")
        f = len(self.frames)
        if not -f <= int(k) < f:
            raise IndexError(f"frame {k} out of range for an animation of {f} frames")
        return int(k) % f

    def __getitem__(self, k) -> Scene:
        return self.frames[self._index(k)]

    def __iter__(self) -> Iterator[Scene]:
        return iter(self.frames)

    @property
    def width(self) -> int:
        return self.frames[0].width

    @property
    def height(self) -> int:
        return self.frames[0].height

    def gbuffers(self) -> dict[str, np.ndarray]:
        """The deep framebuffers of every frame, stacked: position, normal, geo_normal, wi, albedo
        (F, H, W, 3) float32, uv (F, H, W, 2) float32, shape_index and prim_index (F, H, W) int32 (-1 =
        background); each frame's as ``Scene.gbuffer`` (pixel centres, computed on ``device`` once)."""
        per = [s.gbuffer(self.device) for s in self.frames]
        return {key: np.stack([g[key] for g in per]) for key in per[0]}

    def _adjacent_mapping(self, a: int, b: int) -> np.ndarray:
        key = (a, b)
        if key not in self._adjacent:
            self._adjacent[key] = _native.pixel_mapping(self.frames[a], self.frames[b], self.frames[0], self.device)
        return self._adjacent[key]

    def mapping(self, k: int, l: int) -> np.ndarray:
        """The pixel mapping M(k -> l) (paper Sec. 4.4): (H, W) int64, for each pixel of frame l the index
        ``y * W + x`` of its nearest neighbour among frame k's pixels in the 9-D deep framebuffer, -1 where
        frame l sees no surface. ``apply_mapping(image_k, anim.mapping(k, l))`` moves an image rendered in
        frame k into frame l. k == l gives the identity; other pairs compose the adjacent mappings
        (forward for l > k, backward for l < k), each computed once and cached.

        Raises:
            IndexError: k or l out of range. TypeError: a non-integer index.
        """
        k, l = self._index(k), self._index(l)
        if k == l:
            return np.arange(self.width * self.height, dtype=np.int64).reshape(self.height, self.width)
        step = 1 if l > k else -1
        chain = [self._adjacent_mapping(a, a + step) for a in range(k, l, step)]
        if len(chain) == 1:
            return chain[0].copy()
        return _native.compose_mappings(chain)

    def __repr__(self) -> str:
        return f"Animation({len(self)} frames, {self.width}x{self.height}, {os.fspath(self.paths[0])})"


@checked_keywords()
def apply_mapping(image, mapping, *, device: str = "auto") -> np.ndarray:
    """Apply a pixel mapping (or a chain of them) to an image: ``out[i] = image[mapping[i]]``, 0 where the
    mapping is -1 (paper Sec. 4.4: the sparse m x m matrix M(k -> l) times a column).

    Args:
        image: (H, W, 3) or a stack (K, H, W, 3) of images of the source frame (any real dtype; float32 out).
        mapping: (H, W) integer array from ``Animation.mapping`` (entries in [0, H*W) or -1), or a list of
            them applied in order (a chain k -> k+1 -> k+2: on the GPU one gather per mapping, on the CPU
            the composed mapping).
        device: "auto" (a hardware GPU if there is one, else the CPU), "cpu" (rayon) or "gpu" (a WGSL
            gather per mapping on GPU-resident images, read back once).

    Returns:
        float32 array of the shape of ``image``.

    Raises:
        ValueError: a mapping that is not (H, W), an entry outside [0, H*W) other than -1 (named with its
            position), mappings of different sizes, an image whose (H, W) differs from the mapping's, an
            empty chain, an unknown device.
        TypeError: a non-numeric image or a non-integer mapping.
    """
    maps = list(mapping) if isinstance(mapping, (list, tuple)) else [mapping]
    if not maps:
        raise ValueError("apply_mapping: the chain of mappings is empty")
    conv = []
    for k, m in enumerate(maps):
        a = np.asarray(m)
        if a.dtype.kind not in "iu":
            raise TypeError(f"apply_mapping: mapping{'' if len(maps) == 1 else f'[{k}]'} must be an integer array "
                            f"(-1 = no source), got dtype {a.dtype}")
        if a.dtype.kind == "u" and a.size and a.max() > np.iinfo(np.int64).max:
            raise ValueError("apply_mapping: mapping entries out of range")
        conv.append(np.ascontiguousarray(a, dtype=np.int64))
    img = _v.numeric_array("image", image)
    single = img.ndim == 3
    if single:
        img = img[None]
    if img.ndim != 4 or img.shape[-1] != 3:
        raise ValueError(f"apply_mapping: image must have shape (H, W, 3) or (K, H, W, 3), got {np.shape(image)}")
    if not isinstance(device, str):
        raise ValueError(f"device must be 'auto', 'gpu' or 'cpu', got {device!r}")
    out = _native.apply_mapping(np.ascontiguousarray(img, dtype=np.float32), conv, device)
    return out[0] if single else out
