"""Loading Mitsuba 3 XML scenes."""
from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Optional

import numpy as np

from . import _native
from ._native import Scene
from ._utils import validate as _v
from ._utils.keywords import unknown_keyword_error


def load_scene(path: str | os.PathLike, *, size: Optional[tuple[int, int]] = None, **params) -> Scene:
    """Load a Mitsuba 3 XML scene.

    Args:
        path: the scene's XML file.
        size: optional (width, height) overriding the film (for scenes whose film size is no parameter).
        **params: values for the file's ``<default name=...>`` parameters, as ``mitsuba.load_file`` takes
            them (``res=128``); converted with ``str``.

    Raises:
        TypeError: a keyword that no ``$name`` of the file (or the files it includes) refers to, before
            anything is loaded; the message names the closest parameter the file has (``rez`` -> ``res``).
        FileNotFoundError: the scene or a file it names is missing.
        SceneError: malformed XML or an unsupported plugin (the message names file, line and value); an
            image (texture, environment map) declaring more than 16384^2 pixels.
        MemoryError: an image whose decoding needs more host memory than is available or allowed by
            ``MANYLIGHTS_MEMORY_LIMIT`` (the message names the file, its size and the limit).

    Warns:
        UserWarning: for input Mitsuba accepts with a warning (e.g. a mesh whose triangles all have zero
            area: it stays as an empty shape, so shape indices match Mitsuba's).
    """
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"scene file not found: {p}")
    if params:
        check_scene_parameters(p, params)
    conv = []
    for k, v in params.items():
        if isinstance(v, bool):
            v = "true" if v else "false"
        conv.append((k, str(v)))
    if size is not None:
        if np.ndim(size) != 1 or len(size) != 2:
            raise ValueError(f"size must be (width, height) positive integers, got {size!r}")
        size = (_v.integer("size[0] (width)", size[0], 1, 2**32 - 1),
                _v.integer("size[1] (height)", size[1], 1, 2**32 - 1))
    return _native.load_scene(str(p), conv, size)


_PARAM = re.compile(r"\$([A-Za-z_][A-Za-z0-9_]*)")
_INCLUDE = re.compile(r"<include\s[^>]*filename\s*=\s*[\"']([^\"']+)[\"']")


def _scene_texts(path: Path, depth: int = 0) -> Optional[list]:
    """The text of ``path`` and of every file it includes (relative to the including file); None when one
    cannot be read or names a parameter in its file name (the loader then reports it)."""
    try:
        text = path.read_text(errors="replace")
    except OSError:
        return None
    texts = [text]
    for inc in _INCLUDE.findall(text):
        if "$" in inc or depth > 16:
            return None
        sub = _scene_texts(path.parent / inc, depth + 1)
        if sub is None:
            return None
        texts += sub
    return texts


def check_scene_parameters(path: Path, params: dict) -> None:
    """Refuse a parameter that no ``$name`` of the scene's files refers to (the loader would refuse it too,
    after parsing), with the closest parameter the files have."""
    texts = _scene_texts(path)
    if texts is None:
        return
    for k in params:
        if not any("$" + k in text for text in texts):
            names = {m for text in texts for m in _PARAM.findall(text)} | {"size"}
            raise unknown_keyword_error("load_scene", k, names, "scene parameter")
