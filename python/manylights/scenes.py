"""The scenes bundled in the repository's ``scenes/`` folder (see ``scenes/README.md``) and in the wheel.

The README, the notebooks, the command line and the benchmarks name these scenes by folder
(``"cbox"``, ``"veach-ajar"``, ...); this module finds them relative to the package, so a clone or an
installed wheel needs nothing beside it::

    import manylights as ml
    from manylights.scenes import scene_path
    scene = ml.load_scene(scene_path("cbox"), res=64)
"""
from __future__ import annotations

import os
from pathlib import Path

from ._utils import validate as _v


def _scenes_dir() -> Path:
    """The bundled scenes: in an installed wheel the package's ``scenes_data/`` folder; in a clone the
    repository's ``scenes/`` (``python/manylights/scenes_data`` is a link to it, which the wheel build
    follows)."""
    here = Path(__file__).resolve().parent
    data = here / "scenes_data"
    if data.is_dir() and not data.is_symlink():
        return data
    return here.parents[1] / "scenes"


#: Where the bundled scenes are (``_scenes_dir``).
SCENES_DIR = _scenes_dir()


def available() -> list[str]:
    """Names of the bundled scenes (folders of ``scenes/`` holding a ``scene.xml``), sorted."""
    if not SCENES_DIR.is_dir():
        return []
    return sorted(p.parent.name for p in SCENES_DIR.glob("*/scene.xml"))


def scene_path(name: str | os.PathLike) -> Path:
    """The ``scene.xml`` of bundled scene ``name`` (a folder of ``scenes/``, e.g. ``"cbox"``).

    Raises:
        TypeError: ``name`` is not a string or path.
        FileNotFoundError: no bundled scene of that name (the message lists those there are), or the
            scenes are missing (a package built without them: pass the path of a scene XML instead).
    """
    if not isinstance(name, (str, os.PathLike)):
        raise TypeError(f"scene name must be a string, got {type(name).__name__}")
    name = os.fspath(name)
    if not SCENES_DIR.is_dir():
        raise FileNotFoundError(
            f"bundled scene {name!r}: no scenes folder at {SCENES_DIR} (this installation carries no bundled "
            "scenes; pass the path of a scene XML)")
    path = SCENES_DIR / name / "scene.xml"
    if not name or Path(name).name != name or name in (".", "..") or not path.is_file():
        raise FileNotFoundError(f"no bundled scene {name!r} in {SCENES_DIR}; bundled scenes: {', '.join(available())}")
    return path


def resolve(scene: str | os.PathLike) -> Path:
    """``scene`` as a path: an existing file as given, else the bundled scene of that name.

    Raises:
        FileNotFoundError: neither a file nor a bundled scene (the message lists the bundled ones).
    """
    p = Path(scene)
    if p.is_file():
        return p
    try:
        return scene_path(scene)
    except FileNotFoundError:
        raise FileNotFoundError(
            f"scene not found: {os.fspath(scene)!r} is neither a file nor a bundled scene "
            f"({', '.join(available())})") from None


def _bounce_frames(count: int) -> list[dict]:
    """Frames of ``scenes/bounce``: the camera orbits 40 degrees about the room (rising and sinking by
    0.3); the box bounces twice along a curved path (parabolic hops 1.0 high), squashing on contact
    (height x 0.65 at the floor, width stretched to keep its volume) and spinning half a turn."""
    import math

    out = []
    for k in range(count):
        t = k / (count - 1) if count > 1 else 0.0
        a = math.radians(-20.0 + 40.0 * t)
        phase = (2.0 * t) % 1.0 if t < 1.0 else 1.0
        hop = 4.0 * phase * (1.0 - phase)
        contact = max(0.0, 1.0 - min(phase, 1.0 - phase) / 0.15)
        sy = 0.5 * (1.0 - 0.35 * contact)
        sxz = 0.5 / math.sqrt(sy / 0.5)
        out.append({
            "cam_x": round(6.0 * math.sin(a), 6),
            "cam_y": round(2.2 + 0.3 * math.sin(math.pi * t), 6),
            "cam_z": round(6.0 * math.cos(a), 6),
            "box_x": round(-1.4 + 1.6 * t, 6),
            "box_y": round(sy + hop, 6),
            "box_z": round(0.3 + 0.4 * math.sin(math.pi * t), 6),
            "box_sy": round(sy, 6),
            "box_sxz": round(sxz, 6),
            "box_spin": round(180.0 * t, 6),
        })
    return out


#: Bundled animated scenes: name -> function(count) giving one parameter dict per frame.
_ANIMATIONS = {"bounce": _bounce_frames}


def animated() -> list[str]:
    """Names of the bundled animated scenes (those ``animation_frames`` knows), sorted."""
    return sorted(_ANIMATIONS)


def animation_frames(name: str, count: int = 40) -> list[dict]:
    """Per-frame ``<default>`` parameters of a bundled animated scene, one dict per frame, for
    ``manylights.load_animation(scene_path(name), frames=...)`` or ``mitsuba.load_file(path, **frame)``.

    Scenes: ``"bounce"`` (``scenes/bounce``: camera orbit, a bouncing, squashing, spinning box, area light,
    environment map, walls for indirect light). The motion spans the same path whatever ``count`` is
    (frame 0 at its start, frame count - 1 at its end).

    Raises:
        ValueError: an unknown animated scene (the message lists them) or count not an integer >= 1.
    """
    if name not in _ANIMATIONS:
        raise ValueError(f"no bundled animated scene {name!r}; animated scenes: {', '.join(sorted(_ANIMATIONS))}")
    return _ANIMATIONS[name](_v.integer("count", count, 1, 1_000_000))
