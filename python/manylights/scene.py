"""Loading Mitsuba 3 XML scenes."""
from __future__ import annotations

import os
import re
import warnings
from pathlib import Path
from typing import Optional

import numpy as np

from . import _native
from ._native import Scene
from ._utils import validate as _v
from ._utils.keywords import unknown_keyword_error


def load_scene(path: str | os.PathLike, *, size: Optional[tuple[int, int]] = None, media: str = "mitsuba",
               **params) -> Scene:
    """Load a Mitsuba 3 XML scene.

    Args:
        path: the scene's XML file.
        size: optional (width, height) overriding the film (for scenes whose film size is no parameter).
        media: what to do with participating media (``<medium type="homogeneous">`` as a shape's interior or
            exterior): ``"mitsuba"`` (default) as Mitsuba 3.9.1 does for the scene's integrator: ``volpath``,
            ``volpathmis`` and ``prbvolpath`` use them (light along delta chains, e.g. through glass, is
            attenuated by Beer-Lambert with ``sigma_t`` per unit length; in-scattering is not modelled, a
            warning says so when a medium's albedo is not 0), every other integrator (``path``, the default)
            ignores them (a warning says the medium has no effect); ``"error"`` refuses any ``<medium>``.
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
        ValueError: ``media`` is neither ``"mitsuba"`` nor ``"error"``; a bad ``size``.

    Warns:
        UserWarning: for input Mitsuba accepts with a warning (e.g. a mesh whose triangles all have zero
            area: it stays as an empty shape, so shape indices match Mitsuba's); one warning per kind and
            scene (many such shapes: one line naming how many, the first ids and the first location); a
            medium that has no effect under the scene's integrator, or whose scattering is not modelled.
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
    if media not in ("mitsuba", "error"):
        raise ValueError(f'media must be "mitsuba" or "error", got {media!r}')
    if size is not None:
        if np.ndim(size) != 1 or len(size) != 2:
            raise ValueError(f"size must be (width, height) positive integers, got {size!r}")
        size = (_v.integer("size[0] (width)", size[0], 1, 2**32 - 1),
                _v.integer("size[1] (height)", size[1], 1, 2**32 - 1))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = _native.load_scene(str(p), conv, size, media)
    for category, message in grouped_warnings(caught):
        warnings.warn(message, category, stacklevel=2)
    return scene


_SHAPE_WARNING = re.compile(r'^(?P<loc>.+?): shape "(?P<id>[^"]*)": (?P<what>.+)$', re.S)


def grouped_warnings(caught) -> list:
    """The loader's warnings, one line per kind: those about single shapes (``file:line: shape "id": what``)
    with the same ``what`` become one line naming how many shapes, the first few ids and the first location;
    other warnings pass as they are (repeats once). Returns (category, message) pairs in first-seen order."""
    out: dict = {}
    for w in caught:
        text = str(w.message)
        m = _SHAPE_WARNING.match(text)
        key = (w.category, m.group("what") if m else text)
        out.setdefault(key, []).append(m)
    lines = []
    for (category, what), matches in out.items():
        if len(matches) == 1 or matches[0] is None:
            lines.append((category, matches[0].string if matches[0] is not None else what))
            continue
        ids = [m.group("id") for m in matches]
        shown = ", ".join(f'"{i}"' for i in ids[:5]) + (f" and {len(ids) - 5} more" if len(ids) > 5 else "")
        lines.append((category, f"{matches[0].group('loc')} (first of {len(ids)}): shapes {shown}: {what}"))
    return lines


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
