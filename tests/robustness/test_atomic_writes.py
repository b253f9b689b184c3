"""Every file manylights writes is written whole or not at all (``_utils.files.atomic_write``).

A child process (``atomic_writers.py``) SIGKILLs a forked writer 20 times and lands a KeyboardInterrupt in
each writer 100 times; the target must always be the old or the complete new file and no temporary may
remain after the next write. A full disk (a small tmpfs in a user namespace, else injected ENOSPC) must
raise OSError naming the file and keep the old file. Saved files follow the umask (or the replaced file's
mode); temporaries of dead writers are removed, those of live writers and other hosts kept.
"""
from __future__ import annotations

import errno
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import manylights as ml
from manylights._utils import files

HERE = Path(__file__).parent
REPO = HERE.parents[1]
WRITERS = ["write_exr", "write_png", "write_video_gif", "write_video_mp4", "json", "write_exr_sequence",
           "sweep_parquet", "DirectToIndirect.save"]


def _child(args, tmp: Path, mount=None, timeout=300) -> dict:
    """Run atomic_writers.py with ``args``; with ``mount`` (a folder), inside a user namespace where a
    4 MiB tmpfs is mounted there. Returns {writer: result}."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO / "python"), os.environ.get("PYTHONPATH", "")]),
           "TMPDIR": str(tmp)}
    cmd = [sys.executable, str(HERE / "atomic_writers.py"), *map(str, args)]
    if mount is not None:
        cmd = ["unshare", "-rm", "sh", "-c", 'mount -t tmpfs -o size=4m tmpfs "$0" && exec "$@"', str(mount), *cmd]
    p = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=timeout)
    out = {}
    for line in p.stdout.splitlines():
        if line.startswith("{"):
            r = json.loads(line)
            out[r["writer"]] = r
    assert p.returncode == 0 and out, f"child failed ({p.returncode}): {p.stderr[-3000:]}"
    return out


@pytest.fixture(scope="module")
def killed(tmp_path_factory):
    return _child(["kill", tmp_path_factory.mktemp("kill"), 20], tmp_path_factory.mktemp("kill_tmp"))


@pytest.fixture(scope="module")
def interrupted(tmp_path_factory):
    return _child(["interrupt", tmp_path_factory.mktemp("interrupt"), 100], tmp_path_factory.mktemp("int_tmp"))


@pytest.mark.parametrize("writer", WRITERS)
def test_sigkill_in_the_middle_leaves_old_or_new_file(killed, writer):
    r = killed[writer]
    assert r["trials"] == 20 and sum(r["states"].values()) == 20
    assert r["bad"] == [], f"{writer}: unreadable or foreign target after kills {r['bad']}"
    assert set("".join(r["states"])) <= {"A", "B"}
    assert r["left_after_next_write"] == 0


def test_kills_land_inside_writes(killed):
    """The kills are not all between writes: across writers, many left a temporary (killed mid-write)."""
    assert sum(r["mid_write"] for r in killed.values()) >= 15, {w: r["mid_write"] for w, r in killed.items()}
    assert killed["write_video_mp4"]["helpers_waited"] >= 10  # ffmpeg outlived its killed parent


@pytest.mark.parametrize("writer", WRITERS)
def test_keyboard_interrupt_in_the_middle_leaves_old_or_new_file(interrupted, writer):
    r = interrupted[writer]
    assert r["trials"] == 100 and r["interrupted"] + r["completed"] == 100
    assert r["interrupted"] >= 20, r  # the interrupts landed inside the writer
    assert r["bad"] == [], f"{writer}: [trial, old, new, found, interrupted] {r['bad']}"
    assert r["left_at_once"] == 0 and r["left_after_next_write"] == 0


def _can_mount_tmpfs() -> bool:
    if not shutil.which("unshare"):
        return False
    return subprocess.run(["unshare", "-rm", "true"], capture_output=True).returncode == 0


@pytest.mark.skipif(not _can_mount_tmpfs(), reason="no unprivileged user namespace to mount a small tmpfs "
                    "(the injected-ENOSPC test below covers the writer path)")
def test_full_disk_raises_and_keeps_the_old_file(tmp_path):
    fs = tmp_path / "fs"
    fs.mkdir()
    r = _child(["diskfull", fs], tmp_path, mount=fs)
    assert sorted(r) == sorted(WRITERS)
    for w, x in r.items():
        assert x["raised"] is not None and x["is_oserror"], (w, x)
        assert x["errno"] == errno.ENOSPC and "No space left" in x["raised"], (w, x)
        assert "cannot write" in x["raised"] or "ffmpeg could not write" in x["raised"], (w, x)
        assert set(x["state"]) == {"A"}, (w, x)  # the old file, whole
        assert x["left"] == [], (w, x)


IMG_A = np.full((4, 5, 3), 0.25, np.float32)
IMG_B = np.full((4, 5, 3), 0.75, np.float32)


def _sweep_write(p, img):
    import pandas as pd

    from manylights.distributed import sweep as _sweep

    _sweep._write(p, pd.DataFrame({"task": ["a"], "rel_l2": [float(img.mean())]}), {"d": 1})


DATA_WRITERS = {  # name -> (file name, write(path, img))
    "write_exr": ("a.exr", ml.write_exr),
    "write_png": ("a.png", ml.write_png),
    "write_video_gif": ("a.gif", lambda p, img: ml.write_video(np.stack([img, img]), p)),
    "json": ("a.json", lambda p, img: files.atomic_write_text(p, json.dumps(float(img.mean())))),
}


@pytest.mark.parametrize("name", sorted(DATA_WRITERS))
def test_injected_enospc_names_the_file_and_keeps_the_old_one(tmp_path, monkeypatch, name):
    fname, write = DATA_WRITERS[name]
    p = tmp_path / fname
    write(p, IMG_A)
    old = p.read_bytes()
    real = files._write_all

    def half_then_full(fd, data):
        real(fd, memoryview(data)[: len(data) // 2])
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(files, "_write_all", half_then_full)
    with pytest.raises(OSError, match=f"cannot write: No space left.*{fname}") as e:
        write(p, IMG_B)
    assert e.value.errno == errno.ENOSPC and e.value.filename == str(p)
    assert p.read_bytes() == old
    assert sorted(os.listdir(tmp_path)) == [fname]


def test_failed_fsync_of_a_callback_writer_keeps_the_old_file(tmp_path, monkeypatch):
    """Writers that write a path themselves (pyarrow for sweeps, ffmpeg): a failing flush to disk raises."""
    import pyarrow.parquet as pq

    p = tmp_path / "out.parquet"
    _sweep_write(p, IMG_A)

    def fail(path):
        raise OSError(errno.EIO, "Input/output error")

    monkeypatch.setattr(files, "_fsync_path", fail)
    with pytest.raises(OSError, match="cannot write: .*Input/output error.*out.parquet"):
        _sweep_write(p, IMG_B)
    assert pq.read_table(p).column("rel_l2").to_pylist() == [0.25]
    assert sorted(os.listdir(tmp_path)) == ["out.parquet"]


def test_keyboard_interrupt_while_the_temporary_is_created_leaves_none(tmp_path, monkeypatch):
    """Ctrl-C right after the temporary file exists (before the writer holds it) removes it."""
    p = tmp_path / "a.exr"
    ml.write_exr(p, IMG_A)
    old = p.read_bytes()
    real_open = os.open

    def open_then_interrupt(path, flags, mode=0o777, **kw):
        fd = real_open(path, flags, mode, **kw)
        os.close(fd)
        raise KeyboardInterrupt

    monkeypatch.setattr(files.os, "open", open_then_interrupt)
    with pytest.raises(KeyboardInterrupt):
        ml.write_exr(p, IMG_B)
    monkeypatch.undo()
    assert p.read_bytes() == old
    assert sorted(os.listdir(tmp_path)) == ["a.exr"]


MODE_WRITERS = {**DATA_WRITERS, "sweep_parquet": ("a.parquet", _sweep_write),
                "write_video_mp4": ("a.mp4", lambda p, img: ml.write_video(np.stack([img[:4, :4]] * 2), p))}


@pytest.mark.parametrize("name", sorted(MODE_WRITERS))
def test_saved_files_follow_the_umask_or_the_replaced_file(tmp_path, name):
    fname, write = MODE_WRITERS[name]
    old_umask = os.umask(0o077)
    try:
        write(tmp_path / f"u077-{fname}", IMG_A)
        assert (tmp_path / f"u077-{fname}").stat().st_mode & 0o777 == 0o600
        os.umask(0o022)
        write(tmp_path / f"u022-{fname}", IMG_A)
        assert (tmp_path / f"u022-{fname}").stat().st_mode & 0o777 == 0o644
        os.umask(0o002)
        write(tmp_path / f"u002-{fname}", IMG_A)
        assert (tmp_path / f"u002-{fname}").stat().st_mode & 0o777 == 0o664
        os.umask(0o022)
        for mode in (0o640, 0o666):  # replacing a file keeps its mode
            q = tmp_path / f"m{mode:o}-{fname}"
            write(q, IMG_A)
            q.chmod(mode)
            write(q, IMG_B)
            assert q.stat().st_mode & 0o777 == mode
    finally:
        os.umask(old_umask)
    assert not [n for n in os.listdir(tmp_path) if ".mltmp" in n]


def test_stale_temporaries_of_dead_writers_are_removed_live_ones_kept(tmp_path):
    p = tmp_path / "a.exr"
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    host = files.host_name()
    names = {
        "dead": f".a.exr.{host}.{dead.pid}.0badf00d.mltmp.exr",
        "mine_not_active": f".a.exr.{host}.{os.getpid()}.0badf00d.mltmp.exr",
        "live": f".a.exr.{host}.{os.getppid()}.0badf00d.mltmp.exr",
        "other_host": f".a.exr.elsewhere-{host}.{dead.pid}.0badf00d.mltmp.exr",
        "other_target": f".b.exr.{host}.{dead.pid}.0badf00d.mltmp.exr",
        "not_ours": ".a.exr.tmp123.exr",
    }
    for n in names.values():
        (tmp_path / n).write_bytes(b"partial")
    ml.write_exr(p, IMG_A)
    left = set(os.listdir(tmp_path))
    assert names["dead"] not in left and names["mine_not_active"] not in left
    assert {names[k] for k in ("live", "other_host", "other_target", "not_ours")} <= left
    assert np.array_equal(ml.read_exr(p), IMG_A)


def test_temporary_names_are_unique_per_call_and_recognisable(tmp_path):
    p = tmp_path / "x.parquet"
    a, b = files.temporary_path(p), files.temporary_path(p)
    assert a != b and a.parent == b.parent == tmp_path
    for t in (a, b):
        assert t.name.startswith(".x.parquet.") and t.name.endswith(".mltmp.parquet")
        assert f".{os.getpid()}." in t.name
    long = tmp_path / ("n" * 240 + ".exr")
    assert len(files.temporary_path(long).name) < 255


def test_missing_folder_and_folder_target_raise(tmp_path):
    with pytest.raises(FileNotFoundError, match="no/such"):
        ml.write_png(tmp_path / "no" / "such" / "a.png", IMG_A)
    with pytest.raises(IsADirectoryError, match="is a folder"):
        ml.write_exr(tmp_path, IMG_A)
    assert os.listdir(tmp_path) == []
