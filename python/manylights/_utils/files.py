"""Files written whole or not at all: the one writer path of every file manylights writes.

``atomic_write(path, data=...)`` (bytes) or ``atomic_write(path, write)`` (a callback that writes a file at
the path it is given, for writers that take a path: pyarrow, imageio, numpy) does:

1. removes stale temporaries of ``path`` left by writers of this host that died (``remove_stale``);
2. creates a temporary file in the target's folder, named ``.<name>.<host>.<pid>.<random>.mltmp``
   (recognisable, unique per writer and call), with the target's mode: the existing file's, else
   ``0o666`` less the umask (as ``open`` would give a new file);
3. writes it, flushes it to disk (``fsync``), renames it over the target and syncs the folder.

Any error, ``KeyboardInterrupt`` included, removes the temporary and re-raises; the target is then the old
file (or absent), never a partial one. A process killed in the middle leaves a temporary, which the next
write of that target (by any process of the host) removes.
"""
from __future__ import annotations

import errno
import hashlib
import json
import os
import secrets
import signal
import socket
import threading
import time
from contextlib import contextmanager
from pathlib import Path
from typing import Callable, Optional

#: Suffix of every temporary file the writer creates.
TMP_SUFFIX = ".mltmp"
_active: set[str] = set()  # temporaries being written by this process (not stale)
_active_lock = threading.Lock()


def host_name() -> str:
    """This host's name as it appears in temporary and lock file names (no path separators)."""
    return (socket.gethostname() or "host").replace(os.sep, "_").replace("/", "_")


def _prefix(path: Path) -> str:
    name = path.name
    if len(name) > 150:  # keep temporary names under NAME_MAX (255)
        name = name[:100] + "." + hashlib.sha256(path.name.encode()).hexdigest()[:16]
    return f".{name}."


def temporary_path(path: Path) -> Path:
    """A new hidden temporary name beside ``path``: ``.<name>.<host>.<pid>.<random>.mltmp<suffix>``."""
    path = Path(path)
    return path.with_name(f"{_prefix(path)}{host_name()}.{os.getpid()}.{secrets.token_hex(4)}{_tail(path)}")


def _tail(path: Path) -> str:
    return TMP_SUFFIX + (path.suffix if len(path.suffix) < 16 else "")


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    except OverflowError:
        return False
    return True


def remove_stale(path: Path) -> list[Path]:
    """Remove the temporaries of ``path`` whose writer is gone: written on this host by a process that no
    longer runs, or by this process and not being written now. Returns the paths removed (temporaries of
    other hosts are left: their writers cannot be checked from here)."""
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    prefix, tail, host, me = _prefix(path), _tail(path), host_name(), os.getpid()
    removed = []
    try:
        names = os.listdir(folder)
    except OSError:
        return removed
    for name in names:
        if not (name.startswith(prefix) and name.endswith(tail)):
            continue
        parts = name[len(prefix):-len(tail)].rsplit(".", 2)
        if len(parts) != 3 or parts[0] != host or not parts[1].isdigit():
            continue
        pid = int(parts[1])
        if pid == me:
            with _active_lock:
                if name in _active:
                    continue
        elif _pid_alive(pid):
            continue
        try:
            os.unlink(folder / name)
            removed.append(folder / name)
        except FileNotFoundError:
            pass
    return removed


def current_umask() -> int:
    """The process umask, read without changing it (``/proc/self/status``); 0o022 when unreadable."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    return 0o022


def _target_mode(path: Path) -> int:
    try:
        return os.stat(path).st_mode & 0o7777
    except FileNotFoundError:
        return 0o666 & ~current_umask()


def _write_all(fd: int, data) -> None:
    view = memoryview(data).cast("B")
    while view:
        n = os.write(fd, view)
        view = view[n:]


def _fsync_path(p: Path) -> None:
    fd = os.open(p, os.O_RDONLY | getattr(os, "O_CLOEXEC", 0))
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _fsync_folder(folder: Path) -> None:
    try:
        fd = os.open(folder, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:  # some file systems cannot sync a folder; the rename itself is atomic
        pass
    finally:
        os.close(fd)


def atomic_write(path: str | os.PathLike, write: Optional[Callable[[Path], None]] = None, *,
                 data: Optional[bytes] = None) -> Path:
    """Write ``path`` whole or not at all: ``data`` (bytes), or ``write(tmp)`` writing a file at ``tmp``.

    Returns:
        ``path`` as a Path.

    Raises:
        FileNotFoundError: the folder does not exist. OSError: the file cannot be written (a full disk, no
        permission); whatever ``write`` raises. The target keeps its old content in every case and no
        temporary remains."""
    path = Path(path)
    if (write is None) == (data is None):
        raise TypeError("atomic_write takes exactly one of write and data")
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise FileNotFoundError(errno.ENOENT, f"{path}: the folder {folder} does not exist", str(path))
    if path.is_dir():
        raise IsADirectoryError(errno.EISDIR, f"{path} is a folder", str(path))
    remove_stale(path)
    mode = _target_mode(path)
    tmp = temporary_path(path)
    with _active_lock:
        _active.add(tmp.name)
    try:
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0), 0o600)
            try:
                os.fchmod(fd, mode)
                if data is not None:
                    _write_all(fd, data)
                    os.fsync(fd)
            finally:
                os.close(fd)
            if write is not None:
                write(tmp)
                _fsync_path(tmp)
                os.chmod(tmp, mode)
            os.replace(tmp, path)
        except BaseException as e:
            try:
                os.unlink(tmp)
            except OSError:
                pass
            if isinstance(e, OSError) and e.filename is None:  # name the file (a full disk says nothing else)
                if e.errno is None:
                    raise OSError(f"cannot write {path}: {e}") from e
                raise OSError(e.errno, f"cannot write: {e.strerror or e}", str(path)) from e
            raise
        _fsync_folder(folder)
    finally:
        with _active_lock:
            _active.discard(tmp.name)
    return path


@contextmanager
def held_signals():
    """Hold the Python handlers of signals (Ctrl-C's KeyboardInterrupt) for the body, then run those of the
    signals that came, in order: code that must not be cut in two (starting a helper process and recording
    it) runs whole. Outside the main thread, where no Python handler runs, it does nothing."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    came: list = []
    old: dict = {}
    try:
        for s in signal.valid_signals():
            h = signal.getsignal(s)
            if callable(h):
                old[s] = h
                signal.signal(s, lambda n, f: came.append((n, f)))
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)
        for n, f in came:
            old[n](n, f)


class LockedError(RuntimeError):
    """Another writer holds the file's lock (``exclusive``)."""


@contextmanager
def exclusive(path: str | os.PathLike, what: str = "writer"):
    """Hold ``<path>.lock`` for the body: one writer of ``path`` at a time, across threads, processes and hosts
    sharing the folder. The lock file holds the owner's pid, host, thread and start time (JSON) and is
    created whole (written under a temporary name, then hard-linked). A lock whose owner is a process of
    this host that no longer runs is stale and taken over; any other is refused.

    Raises:
        LockedError: another live writer (of this process, another process or another host) holds the lock;
            the message names it and the lock file."""
    path = Path(path)
    lock = path.with_name(path.name + ".lock")
    me = {"pid": os.getpid(), "host": host_name(), "thread": threading.get_ident(), "what": what,
          "since": time.strftime("%Y-%m-%d %H:%M:%S")}
    token = json.dumps(me, sort_keys=True)
    for _ in range(3):
        tmp = temporary_path(lock)
        with _active_lock:
            _active.add(tmp.name)
        try:
            try:
                atomic_data = token.encode()
                fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666 & ~current_umask())
                try:
                    _write_all(fd, atomic_data)
                finally:
                    os.close(fd)
                os.link(tmp, lock)  # fails when the lock exists: creation and content in one step
                taken = True
            except FileExistsError:
                taken = False
            finally:
                try:
                    os.unlink(tmp)
                except OSError:
                    pass
        finally:
            with _active_lock:
                _active.discard(tmp.name)
        if taken:
            break
        try:
            owner = json.loads(lock.read_text())
        except FileNotFoundError:
            continue  # released meanwhile
        except (OSError, ValueError):
            owner = {}
        pid = owner.get("pid")
        if owner.get("host") == me["host"] and isinstance(pid, int) and pid != me["pid"] and not _pid_alive(pid):
            try:
                if lock.read_text() == json.dumps(owner, sort_keys=True):
                    os.unlink(lock)  # stale: its writer died
            except OSError:
                pass
            continue
        who = (f"pid {pid} on host {owner.get('host')}" + (" (this process)" if pid == me["pid"] and
                                                          owner.get("host") == me["host"] else "")
               + f", since {owner.get('since')}") if owner else "an unreadable lock"
        raise LockedError(f"{path} is being written by another {owner.get('what', what)} ({who}; lock file {lock}): "
                          "wait for it to finish or pass another path (if that writer is gone and the lock "
                          "remains, remove the lock file)")
    else:
        raise LockedError(f"{path}: could not take the lock {lock} (it keeps changing owners)")
    try:
        yield lock
    finally:
        try:
            if lock.read_text() == token:
                os.unlink(lock)
        except OSError:
            pass


def npz_bytes(**arrays) -> bytes:
    """``np.savez`` of ``arrays`` into memory (for ``atomic_write(path, data=...)``). A KeyboardInterrupt
    inside it stays a KeyboardInterrupt (zipfile turns one that lands while an entry is open into a
    ValueError about closing the archive)."""
    import io

    import numpy as np

    buf = io.BytesIO()
    try:
        np.savez(buf, **arrays)
    except ValueError as e:
        if isinstance(e.__context__, KeyboardInterrupt):
            raise e.__context__ from None
        raise
    return buf.getvalue()


def atomic_write_text(path: str | os.PathLike, text: str) -> Path:
    """``atomic_write`` of ``text`` encoded as UTF-8."""
    return atomic_write(path, data=text.encode("utf-8"))


def folder_hash(xml: Path) -> str:
    """sha256 over the XML's folder: every file's relative path and bytes, in sorted order (meshes and
    textures change the image as much as the XML does)."""
    h = hashlib.sha256()
    for f in sorted(p for p in xml.parent.rglob("*") if p.is_file()):
        h.update(f.relative_to(xml.parent).as_posix().encode())
        h.update(f.read_bytes())
    return h.hexdigest()
