"""Animations people can watch: EXR sequences, MP4/GIF videos and side-by-side strips.

Tensor clustering (Hašan, Velázquez, Pellacini, Bala, "Tensor Clustering for Rendering Many-Light
Animations", EGSR 2008) renders f frames at once; its results are compared by eye as much as by numbers
(temporal flicker is the paper's point). This module writes an animation (f, H, W, 3) of linear radiance:

- ``write_exr_sequence``: one float32 OpenEXR per frame (``frame_0000.exr`` ...), bit-exact;
- ``write_video``: 8-bit sRGB (the same encoding as ``write_png``: scaled by 2**exposure, clamped) as MP4
  (H.264 through imageio's bundled ffmpeg, ``imageio-ffmpeg``) or GIF (Pillow through imageio);
- ``side_by_side``: panels of equal size concatenated left to right with a labelled header, e.g.
  tensor | per-frame MRCS | brute force | error.

Every file appears complete or not at all (``_utils.files.atomic_write``: a temporary name in the target
folder, synced and renamed over the target), so an error, a full disk, Ctrl-C or a killed process in the
middle leaves the old file (or none), never a partial one.

Symbols: f frames, H x W pixels, k panels.
"""
from __future__ import annotations

import errno
import os
from pathlib import Path
from typing import Optional, Sequence

import numpy as np

from .. import _native
from .._utils import validate as _v
from .._utils.files import atomic_write, held_signals
from .._utils.keywords import checked_keywords
from .images import write_exr

#: Header height (pixels) of labelled strips.
LABEL_HEIGHT = 12


def _frames(frames, what: str = "frames") -> np.ndarray:
    a = _v.numeric_array(what, frames)
    if a.ndim != 4 or a.shape[3] != 3:
        raise ValueError(f"{what} must have shape (f, H, W, 3), got {a.shape}")
    if a.size == 0:
        raise ValueError(f"{what} is empty: shape {a.shape}")
    a = np.ascontiguousarray(a, dtype=np.float32)
    bad = ~np.isfinite(a)
    if bad.any():
        k, i, j, c = np.argwhere(bad)[0]
        raise ValueError(f"{what}: frame {k} pixel (row {i}, column {j}) channel {c} is {a[k, i, j, c]} (not finite)")
    return a


def to_srgb8(image: np.ndarray, exposure: float = 0.0) -> np.ndarray:
    """An (H, W, 3) (or (f, H, W, 3)) linear image as uint8 sRGB: scaled by 2**exposure, clamped to [0, 1],
    encoded exactly as ``write_png`` encodes it.

    Raises:
        ValueError: a last axis other than 3, an empty array, a non-finite exposure."""
    a = _v.numeric_array("image", image)
    if a.ndim not in (3, 4) or a.shape[-1] != 3 or a.size == 0:
        raise ValueError(f"image must have shape (H, W, 3) or (f, H, W, 3) and not be empty, got {a.shape}")
    flat = np.ascontiguousarray(a, dtype=np.float32).reshape(-1, 1, 3)
    return np.asarray(_native.encode_srgb8(flat, _v.real("exposure", exposure))).reshape(a.shape)


@checked_keywords()
def write_exr_sequence(frames, folder: str | os.PathLike, prefix: str = "frame") -> list[Path]:
    """Write each frame of an (f, H, W, 3) animation as float32 RGB OpenEXR ``<prefix>_<k:04d>.exr``.

    The folder is created if missing. Each file is written under a temporary name and renamed.

    Returns:
        The f paths, in frame order.

    Raises:
        ValueError: a shape other than (f, H, W, 3), no frames, a non-finite value (frame and pixel named),
            a prefix with a path separator. OSError: a file cannot be written (named)."""
    a = _frames(frames)
    if not prefix or os.sep in prefix or (os.altsep and os.altsep in prefix):
        raise ValueError(f"prefix must be a non-empty file-name prefix without path separators, got {prefix!r}")
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for k, frame in enumerate(a):
        p = folder / f"{prefix}_{k:04d}.exr"
        write_exr(p, frame)
        paths.append(p)
    return paths


@checked_keywords()
def write_video(frames, path: str | os.PathLike, fps: float = 12.0, exposure: float = 0.0) -> Path:
    """Write an (f, H, W, 3) linear animation as an 8-bit sRGB video: ``.mp4`` (H.264, yuv420p, through
    imageio-ffmpeg; odd sizes are padded by one black row/column) or ``.gif`` (looping).

    Args:
        frames: (f, H, W, 3) float linear radiance.
        path: the output file; its suffix picks the format.
        fps: frames per second (> 0).
        exposure: scale 2**exposure before clamping, as ``write_png``.

    Returns:
        The path written.

    Raises:
        ValueError: a bad shape, no frames, a non-finite value, fps <= 0, a suffix other than .mp4/.gif.
        ImportError: imageio (or imageio-ffmpeg for MP4) is not installed (``pip install imageio
        imageio-ffmpeg``). OSError: the file cannot be written (named); no partial file is left."""
    a = _frames(frames)
    path = Path(path)
    fps = _v.real("fps", fps)
    if not fps > 0:
        raise ValueError(f"fps must be > 0, got {fps}")
    suffix = path.suffix.lower()
    if suffix not in (".mp4", ".gif"):
        raise ValueError(f"{path}: video format from the suffix must be .mp4 or .gif, got {path.suffix!r}")
    rgb = to_srgb8(a, exposure)
    try:
        import imageio.v3 as iio
    except ImportError as e:
        raise ImportError("write_video needs imageio: pip install imageio imageio-ffmpeg") from e
    if suffix == ".mp4":
        try:
            import imageio_ffmpeg  # noqa: F401
        except ImportError as e:
            raise ImportError("MP4 output needs imageio-ffmpeg: pip install imageio-ffmpeg") from e
        f, h, w, _ = rgb.shape
        if h % 2 or w % 2:  # yuv420p needs even sizes
            rgb = np.pad(rgb, ((0, 0), (0, h % 2), (0, w % 2), (0, 0)))

        atomic_write(path, lambda tmp: _ffmpeg_mp4(rgb, fps, tmp, path))
    else:
        data = iio.imwrite("<bytes>", rgb, plugin="pillow", extension=".gif", duration=1000.0 / fps, loop=0)
        atomic_write(path, data=data)
    return path


def _ffmpeg_mp4(rgb: np.ndarray, fps: float, tmp: Path, path: Path) -> None:
    """Encode (f, H, W, 3) uint8 frames (even H and W) as H.264 MP4 at ``tmp`` with imageio-ffmpeg's ffmpeg and
    the arguments imageio's FFMPEG plugin gives it (the same bytes). ffmpeg is waited for on every error and
    on Ctrl-C (killed first), so that no ffmpeg still writes ``tmp`` once the writer removes it."""
    import subprocess
    from fractions import Fraction

    import imageio_ffmpeg

    f, h, w, _ = rgb.shape
    cmd = [imageio_ffmpeg.get_ffmpeg_exe(), "-y", "-f", "rawvideo", "-vcodec", "rawvideo", "-s", f"{w}x{h}",
           "-pix_fmt", "rgb24", "-r", str(Fraction(fps).limit_denominator()), "-i", "-", "-an",
           "-vcodec", "libx264", "-pix_fmt", "yuv420p", "-v", "warning", "-crf", "18", str(tmp)]
    started: list = []
    try:
        # Ctrl-C (any signal with a Python handler) is held while ffmpeg starts, so that a KeyboardInterrupt
        # cannot leave an ffmpeg that nobody waits for; it is raised once the process is in ``started``.
        with held_signals():
            started.append(subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL,
                                            stderr=subprocess.PIPE))
        p = started[0]
        _, err = p.communicate(np.ascontiguousarray(rgb).tobytes())
    except BaseException:
        for q in started:
            q.kill()
            q.wait()
        raise
    if p.returncode != 0:
        text = err.decode(errors="replace").strip()
        code = errno.ENOSPC if "No space left" in text else errno.EIO
        raise OSError(code, f"ffmpeg could not write the video (exit status {p.returncode}): {text[-500:]}", str(path))


def _label_band(labels: Sequence[str], widths: Sequence[int], gap: int) -> np.ndarray:
    """A (LABEL_HEIGHT, total width) mask: 1 where label text is drawn (Pillow's default bitmap font)."""
    from PIL import Image, ImageDraw

    total = sum(widths) + gap * (len(widths) - 1)
    img = Image.new("L", (total, LABEL_HEIGHT), 0)
    draw = ImageDraw.Draw(img)
    x = 0
    for label, w in zip(labels, widths):
        draw.text((x + 2, 0), str(label), fill=255)
        x += w + gap
    return np.asarray(img, dtype=np.float32) / 255.0


@checked_keywords()
def side_by_side(panels: Sequence, labels: Optional[Sequence[str]] = None, gap: int = 2,
                 label_value: float = 1.0) -> np.ndarray:
    """Concatenate animations (or single images) of equal size left to right, ``gap`` black pixels apart,
    with an optional header of labels (white text of radiance ``label_value`` on black).

    Args:
        panels: k arrays, each (f, H, W, 3) or (H, W, 3), all the same shape.
        labels: k strings, or None for no header.

    Returns:
        float32 (f, H + header, k W + (k - 1) gap, 3), or (H + header, ..., 3) for single images; header is
        ``LABEL_HEIGHT`` with labels, else 0.

    Raises:
        ValueError: no panels, panels of different shapes, a label count other than k, gap < 0."""
    if len(panels) == 0:
        raise ValueError("side_by_side needs at least one panel")
    if gap < 0:
        raise ValueError(f"gap must be >= 0, got {gap}")
    arrs = [np.asarray(_v.numeric_array(f"panels[{k}]", p), dtype=np.float32) for k, p in enumerate(panels)]
    single = arrs[0].ndim == 3
    arrs = [a[None] if a.ndim == 3 else a for a in arrs]
    for k, a in enumerate(arrs):
        if a.ndim != 4 or a.shape[3] != 3:
            raise ValueError(f"panels[{k}] must have shape (f, H, W, 3) or (H, W, 3), got {a.shape}")
        if a.shape != arrs[0].shape:
            raise ValueError(f"panels[{k}] has shape {a.shape}, panels[0] {arrs[0].shape}: all must match")
    f, h, w, _ = arrs[0].shape
    pieces = []
    for k, a in enumerate(arrs):
        if k:
            pieces.append(np.zeros((f, h, gap, 3), np.float32))
        pieces.append(a)
    strip = np.concatenate(pieces, axis=2)
    if labels is not None:
        if len(labels) != len(arrs):
            raise ValueError(f"{len(labels)} labels for {len(arrs)} panels")
        band = _label_band(labels, [w] * len(arrs), gap) * np.float32(label_value)
        band = np.broadcast_to(band[None, :, :, None], (f, LABEL_HEIGHT, strip.shape[2], 3))
        strip = np.concatenate([band, strip], axis=1)
    return strip[0] if single else strip


def error_panel(frames, reference, scale: float = 4.0) -> np.ndarray:
    """|frames - reference| times ``scale`` (grey, the channel mean), for an error panel of a strip.

    Raises:
        ValueError: shapes differ."""
    x = np.asarray(frames, dtype=np.float32)
    r = np.asarray(reference, dtype=np.float32)
    if x.shape != r.shape:
        raise ValueError(f"frames {x.shape} and reference {r.shape} must have the same shape")
    e = np.abs(x - r).mean(axis=-1, keepdims=True) * np.float32(scale)
    return np.repeat(e, 3, axis=-1)
