"""Saving and loading a ``DirectToIndirect`` precomputation (``rel.save(path)``,
``DirectToIndirect.load(path, scene)``).

The file is a numpy ``.npz`` archive (a zip of ``.npy`` arrays, written and read by numpy; the zip's CRC-32s
catch damaged or truncated data) holding:

- ``format`` (str ``"manylights.DirectToIndirect"``) and ``version`` (uint32, ``VERSION``);
- ``scene_hash`` (str, JSON ``{section: sha256 hex}``): the content of the scene the transfer depends on,
  per section: ``geometry`` (shapes' vertices, shading normals, uvs, triangles), ``materials`` (their BSDFs
  and textures), ``camera`` (frame, field of view, clip planes), ``film`` (width, height). Emitters are not
  part of it: a scene whose lights changed loads (relighting exists to change them);
- ``info`` (str, JSON): the options, stats and timings of the precomputation, and the scene file's path, for
  people reading the file (the native arrays below are what loading uses);
- the transfer's arrays, named as ``src/relight/store.rs`` names them (options, the gather cloud checked
  against the scene's on load, the hierarchy, the sparse wavelet rows of each matrix, stats, timings).

Saving writes through ``_utils.files.atomic_write`` (a temporary file in the destination folder, synced and
renamed over the destination, with the umask's mode or the replaced file's): a save that fails (an
unwritable folder, a full disk, Ctrl-C, a killed process) leaves no partial file and keeps an older file of
that name as it was; a temporary left by a killed process is removed by the next save to that path.
"""
from __future__ import annotations

import json
import os
import zipfile
from pathlib import Path

import numpy as np

from .. import _native
from .._utils.files import atomic_write, npz_bytes

__all__ = ["FORMAT", "VERSION", "save", "load", "scene_hash"]

FORMAT = "manylights.DirectToIndirect"
#: Version of the file layout; a file of another version is refused.
VERSION = 1
_META = ("format", "version", "scene_hash", "info")


def scene_hash(scene) -> dict:
    """{section: SHA-256 hex digest} of what a precomputed transfer of ``scene`` depends on: ``geometry``,
    ``materials``, ``camera``, ``film`` (see the module docs; emitters excluded)."""
    return dict(_native.transfer_scene_hash(scene))


def save(rel, path) -> Path:
    """Writes the precomputation ``rel`` (a ``DirectToIndirect``) to ``path`` (any name; ``.npz`` is
    customary) atomically. Returns the path.

    Raises:
        OSError: the folder does not exist or cannot be written (no file is left behind).
        TypeError: path not a str / PathLike.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a str or os.PathLike, got {type(path).__name__}")
    path = Path(path)
    arrays = dict(_native.transfer_arrays(rel))
    info = {"options": _native_options(arrays), "stats": _plain(rel.stats), "timings": _plain(rel.timings),
            "scene": str(getattr(rel.scene, "path", ""))}
    meta = {"format": np.array(FORMAT), "version": np.array(VERSION, dtype=np.uint32),
            "scene_hash": np.array(json.dumps(scene_hash(rel.scene), sort_keys=True)),
            "info": np.array(json.dumps(info, sort_keys=True))}
    return atomic_write(path, data=npz_bytes(**meta, **arrays))


def load(cls, path, scene, device: str = "auto", visibility=None, shadow_map_size: int = 1024):
    """Reads a precomputation saved by ``save`` for ``scene`` (the same scene, or one whose emitters
    changed). The result relights bit-identically to the saved object on the same device; ``device``,
    ``visibility`` and ``shadow_map_size`` choose where it relights, as ``DirectToIndirect``'s.

    Raises:
        FileNotFoundError / OSError: the file cannot be read.
        ValueError: (naming the file) not a manylights relighting file (another format, a foreign zip),
            a damaged or truncated file, another format version, a scene whose geometry, materials, camera
            or film changed since the precomputation (the changed sections named), arrays of the wrong
            shape, dtype or range (the array named).
        TypeError: scene not a Scene, path not a str / PathLike.
    """
    if not isinstance(scene, _native.Scene):
        raise TypeError(f"scene must be a manylights Scene, got {type(scene).__name__}")
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a str or os.PathLike, got {type(path).__name__}")
    path = Path(path)
    with open(path, "rb") as f:
        head = f.read(4)
    if head != b"PK\x03\x04":
        raise ValueError(f"{path}: not a manylights relighting file (a .npz zip archive; the file starts with "
                         f"{head!r})")
    try:
        with np.load(path, allow_pickle=False) as z:
            names = list(z.files)
            if "format" not in names or "version" not in names:
                raise ValueError(f"{path}: not a manylights relighting file (no 'format' and 'version' entries; "
                                 f"entries: {', '.join(names[:8])}{', ...' if len(names) > 8 else ''})")
            fmt = z["format"]
            if fmt.shape != () or str(fmt) != FORMAT:
                raise ValueError(f"{path}: not a manylights relighting file (format {str(fmt)[:80]!r}, "
                                 f"expected {FORMAT!r})")
            version = z["version"]
            if version.shape != () or version.dtype.kind not in "iu" or int(version) != VERSION:
                raise ValueError(f"{path}: format version {_scalar(version)}, this manylights reads version {VERSION}; "
                                 "precompute again")
            saved = json.loads(str(z["scene_hash"]))
            now = scene_hash(scene)
            changed = sorted(k for k in set(saved) | set(now) if saved.get(k) != now.get(k))
            if changed:
                raise ValueError(
                    f"{path}: the scene {getattr(scene, 'path', scene)} is not the one precomputed "
                    f"({', '.join(changed)} changed since the precomputation on "
                    f"{_saved_scene(z)}); precompute again (emitters may change, nothing else)")
            arrays = [(n, z[n]) for n in names if n not in _META]
    except (zipfile.BadZipFile, EOFError, zlib_error()) as e:
        raise ValueError(f"{path}: damaged or truncated relighting file ({e})") from e
    except (KeyError, json.JSONDecodeError) as e:
        raise ValueError(f"{path}: damaged relighting file ({e})") from e
    except ValueError as e:
        if str(e).startswith(str(path)):
            raise
        raise ValueError(f"{path}: damaged relighting file ({e})") from e
    try:
        t = _native.transfer_from_arrays(scene, arrays, device, visibility, shadow_map_size)
    except ValueError as e:
        raise ValueError(f"{path}: {e}") from e
    obj = cls.__new__(cls)
    obj.scene = scene
    obj._t = t
    return obj


def _scalar(a):
    return a.item() if a.shape == () else a.tolist()


def zlib_error():
    import zlib

    return zlib.error


def _saved_scene(z) -> str:
    try:
        return json.loads(str(z["info"])).get("scene") or "another scene"
    except Exception:  # the info entry is for people; a damaged one does not hide the real error
        return "another scene"


def _native_options(arrays) -> dict:
    return {k[len("options."):]: v.item() for k, v in arrays.items() if k.startswith("options.")}


def _plain(d) -> dict:
    return {k: (v.item() if isinstance(v, np.generic) else v) for k, v in dict(d).items()}
