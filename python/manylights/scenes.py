"""The scenes bundled in the repository's ``scenes/`` folder (see ``scenes/README.md``).

The README, the notebooks, the command line and the benchmarks name these scenes by folder
(``"cbox"``, ``"veach-ajar"``, ...); this module finds them relative to the package, so a clone needs
nothing beside it::

    import manylights as ml
    from manylights.scenes import scene_path
    scene = ml.load_scene(scene_path("cbox"), res=64)
"""
from __future__ import annotations

import os
from pathlib import Path

#: The repository's ``scenes/`` folder (the package lives in ``<repo>/python/manylights``).
SCENES_DIR = Path(__file__).resolve().parents[2] / "scenes"


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
            package runs outside a clone (an installed wheel carries no scenes: pass an XML path instead).
    """
    if not isinstance(name, (str, os.PathLike)):
        raise TypeError(f"scene name must be a string, got {type(name).__name__}")
    name = os.fspath(name)
    if not SCENES_DIR.is_dir():
        raise FileNotFoundError(
            f"bundled scene {name!r}: no scenes/ folder at {SCENES_DIR} (the scenes ship with the repository, "
            "not the wheel; run from a clone or pass the path of a scene XML)")
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
