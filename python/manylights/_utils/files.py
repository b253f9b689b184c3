"""Files written whole or not at all: a temporary name beside the target, renamed over it."""
from __future__ import annotations

import hashlib
import os
from pathlib import Path


def temporary_path(path: Path) -> Path:
    """A hidden temporary name beside ``path``, unique to this process."""
    return path.with_name(f".{path.stem}.tmp{os.getpid()}{path.suffix}")


def atomic_write(path: Path, write) -> None:
    """``write(tmp)`` then rename ``tmp`` to ``path``; the temporary file is removed on any error."""
    if not path.parent.is_dir():
        raise FileNotFoundError(f"{path}: folder {path.parent} does not exist")
    tmp = temporary_path(path)
    try:
        write(tmp)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def folder_hash(xml: Path) -> str:
    """sha256 over the XML's folder: every file's relative path and bytes, in sorted order (meshes and
    textures change the image as much as the XML does)."""
    h = hashlib.sha256()
    for f in sorted(p for p in xml.parent.rglob("*") if p.is_file()):
        h.update(f.relative_to(xml.parent).as_posix().encode())
        h.update(f.read_bytes())
    return h.hexdigest()
