"""Loading Mitsuba 3 XML scenes."""
from __future__ import annotations

import os
from pathlib import Path
from typing import Optional

import numpy as np

from . import _native
from ._native import Scene
from ._utils import validate as _v


def load_scene(path: str | os.PathLike, *, size: Optional[tuple[int, int]] = None, **params) -> Scene:
    """Load a Mitsuba 3 XML scene.

    Args:
        path: the scene's XML file.
        size: optional (width, height) overriding the film (for scenes whose film size is no parameter).
        **params: values for the file's ``<default name=...>`` parameters, as ``mitsuba.load_file`` takes
            them (``res=128``); converted with ``str``.

    Raises:
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
