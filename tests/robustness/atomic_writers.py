"""Child process of ``test_atomic_writes.py``: every file writer of manylights killed, interrupted and run
out of disk space in the middle of a write.

``python tests/robustness/atomic_writers.py MODE DIR [KILLS INTERRUPTS]`` prints one JSON line per writer:

- ``kill``: a forked copy of this process writes the target over and over (old and new content in turn)
  and is sent SIGKILL at a random time within about three writes; the target must then be the old or the
  new file, whole, and the next write (by this process, once helpers the writer started, i.e. ffmpeg, have
  exited) must leave no temporary. ``mid_write`` counts the kills that left a temporary (kills that landed inside a write).
- ``interrupt``: a KeyboardInterrupt (SIGALRM handler) lands at a random time within about one write; the
  target must be the old or the new file and no temporary may remain, then or after the next write.
- ``diskfull``: DIR is a small file system (the parent mounts a tmpfs); the old file is written, the disk is
  filled, and the new write must raise OSError and keep the old file, without a temporary.
"""
from __future__ import annotations

import json
import os
import random
import signal
import sys
import time
import zipfile
from pathlib import Path

import numpy as np

import manylights as ml
from manylights._utils.files import atomic_write_text
from manylights.distributed import sweep as _sweep

REPO = Path(__file__).resolve().parents[2]
BOX = REPO / "tests" / "data" / "relight_box.xml"


def temporaries(folder: Path) -> list[str]:
    return sorted(n for n in os.listdir(folder) if ".mltmp" in n)


def writers(d: Path, rel_too: bool = True) -> dict:
    """name -> (target folder, write(variant), state() -> 'A' | 'B' | 'ok' | None)."""
    rng = np.random.default_rng(7)
    img = {v: rng.random((8, 8, 3), dtype=np.float32) * (1 + k) for k, v in enumerate("AB")}
    frames = {v: np.stack([img[v], img[v][::-1]]) for v in "AB"}
    out = {}

    def by_bytes(name, target, write):
        ref = {}
        for v in "AB":
            write(v)
            ref[v] = Path(target).read_bytes() if Path(target).is_file() else None

        def state():
            try:
                b = Path(target).read_bytes()
            except OSError:
                return None
            return next((v for v in "AB" if ref[v] == b), None)
        out[name] = (Path(target).parent, write, state)

    f = d / "exr"
    f.mkdir()
    by_bytes("write_exr", f / "img.exr", lambda v: ml.write_exr(f / "img.exr", img[v]))
    g = d / "png"
    g.mkdir()
    by_bytes("write_png", g / "img.png", lambda v: ml.write_png(g / "img.png", img[v]))
    h = d / "gif"
    h.mkdir()
    by_bytes("write_video_gif", h / "v.gif", lambda v: ml.write_video(frames[v], h / "v.gif"))
    m = d / "mp4"
    m.mkdir()
    by_bytes("write_video_mp4", m / "v.mp4", lambda v: ml.write_video(frames[v], m / "v.mp4"))
    j = d / "json"
    j.mkdir()
    by_bytes("json", j / "s.json", lambda v: atomic_write_text(j / "s.json", json.dumps({"v": v * 500})))

    s = d / "seq"
    ml.write_exr_sequence(frames["A"], s)
    seq_ref = {v: [Path(p).read_bytes() for p in ml.write_exr_sequence(frames[v], d / f"seq_ref_{v}")] for v in "AB"}

    def seq_state():
        got = []
        for k in range(2):
            try:
                b = (s / f"frame_{k:04d}.exr").read_bytes()
            except OSError:
                return None
            v = next((v for v in "AB" if seq_ref[v][k] == b), None)
            if v is None:
                return None
            got.append(v)
        return "".join(got)
    out["write_exr_sequence"] = (s, lambda v: ml.write_exr_sequence(frames[v], s), seq_state)

    import pandas as pd
    import pyarrow.parquet as pq

    q = d / "sweep"
    q.mkdir()
    dfs = {v: pd.DataFrame({"task": [f"t{i}" for i in range(n)], "rel_l2": np.linspace(0, 1, n)})
           for v, n in (("A", 3), ("B", 40))}
    definition = {"d": 1}

    def pq_state():
        try:
            n = pq.read_table(q / "out.parquet").num_rows
        except Exception:  # noqa: BLE001
            return None
        return {3: "A", 40: "B"}.get(n)
    out["sweep_parquet"] = (q, lambda v: _sweep._write(q / "out.parquet", dfs[v], definition), pq_state)

    if rel_too:
        r = d / "rel"
        r.mkdir()
        scene = ml.load_scene(BOX)
        rels = {v: ml.DirectToIndirect(scene, gather=4**(3 if v == "B" else 2), final_gather_coefficients=8,
                                       bounces=1, multibounce_coefficients=4) for v in "AB"}
        keys = {}
        for v in "AB":
            rels[v].save(r / "rel.npz")
            with zipfile.ZipFile(r / "rel.npz") as z:
                keys[v] = sorted((i.filename, i.file_size, i.CRC) for i in z.infolist())

        def rel_state():
            try:
                with zipfile.ZipFile(r / "rel.npz") as z:
                    if z.testzip() is not None:
                        return None
                    k = sorted((i.filename, i.file_size, i.CRC) for i in z.infolist())
            except (OSError, zipfile.BadZipFile):
                return None
            return next((v for v in "AB" if keys[v] == k), None)
        out["DirectToIndirect.save"] = (r, lambda v: rels[v].save(r / "rel.npz"), rel_state)
    for name, (folder, write, state) in out.items():
        write("A")
        assert set(state()) == {"A"}, (name, state())
    return out


def seconds_per_write(write) -> float:
    """The shortest of six writes (a slow outlier would put most random times after the write)."""
    times = []
    for v in "BABABA":
        t = time.perf_counter()
        write(v)
        times.append(time.perf_counter() - t)
    return min(times)


def kill(d: Path, n: int) -> None:
    import ctypes

    # Orphans of the killed writer (ffmpeg) become this process's children, so that they can be waited for.
    ctypes.CDLL(None, use_errno=True).prctl(36, 1, 0, 0, 0)  # PR_SET_CHILD_SUBREAPER
    rnd = random.Random(11)
    for name, (folder, write, state) in writers(d).items():
        span = 3 * seconds_per_write(write)
        res = {"writer": name, "mode": "kill", "trials": n, "states": {}, "mid_write": 0, "bad": [],
               "left_after_next_write": 0, "helpers_waited": 0, "span_ms": round(span * 1000, 2)}
        for i in range(n):
            r, w = os.pipe()
            pid = os.fork()
            if pid == 0:  # the writer
                try:
                    os.close(r)
                    os.write(w, b"x")
                    k = 0
                    while True:
                        write("B" if k % 2 == 0 else "A")
                        k += 1
                finally:
                    os._exit(0)
            os.close(w)
            os.read(r, 1)
            os.close(r)
            time.sleep(rnd.uniform(0, span))
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
            while True:  # helpers the writer started (ffmpeg) finish on their own; wait for them
                try:
                    os.waitpid(-1, 0)
                    res["helpers_waited"] += 1
                except ChildProcessError:
                    break
            s = state()
            res["states"][str(s)] = res["states"].get(str(s), 0) + 1
            if s is None:
                res["bad"].append(i)
            if temporaries(folder):
                res["mid_write"] += 1
            write("A")  # the next write
            if temporaries(folder):
                res["left_after_next_write"] += 1
        print(json.dumps(res), flush=True)


def interrupt(d: Path, n: int) -> None:
    rnd = random.Random(12)

    def handler(signum, frame):
        raise KeyboardInterrupt

    signal.signal(signal.SIGALRM, handler)
    for name, (folder, write, state) in writers(d).items():
        span = seconds_per_write(write)
        res = {"writer": name, "mode": "interrupt", "trials": n, "interrupted": 0, "completed": 0, "raised": {}, "states": {},
               "bad": [], "left_at_once": 0, "left_after_next_write": 0, "span_ms": round(span * 1000, 2)}
        for i in range(n):
            old = state()
            new = "B" if old[0] == "A" else "A"
            got = False
            try:
                try:
                    signal.setitimer(signal.ITIMER_REAL, max(rnd.uniform(0, span), 1e-6))
                    write(new)
                finally:
                    signal.setitimer(signal.ITIMER_REAL, 0)
            except BaseException as e:  # noqa: BLE001  (a KeyboardInterrupt, or what a library turned it into)
                got = True
                kind = type(e).__name__ if isinstance(e, KeyboardInterrupt) else f"{type(e).__name__}: {e}"[:200]
                res["raised"][kind] = res["raised"].get(kind, 0) + 1
            res["interrupted" if got else "completed"] += 1
            s = state()
            res["states"][str(s)] = res["states"].get(str(s), 0) + 1
            if s is None or len(s) != len(old) or not all(c in (o, new) for c, o in zip(s, old)) or (
                    not got and s != new * len(s)):
                res["bad"].append([i, old, new, s, got])
            if temporaries(folder):
                res["left_at_once"] += 1
                write("A")
                if temporaries(folder):
                    res["left_after_next_write"] += 1
        print(json.dumps(res), flush=True)


def diskfull(d: Path) -> None:
    ws = writers(d)
    fd = os.open(d / "filler", os.O_WRONLY | os.O_CREAT)
    try:  # fill the file system
        while True:
            os.write(fd, b"\0" * 4096)
    except OSError:
        pass
    finally:
        os.close(fd)
    for name, (folder, write, state) in ws.items():
        code = None
        try:
            write("B")
            raised = None
        except Exception as e:  # noqa: BLE001
            raised = f"{type(e).__name__}: {e}"[:300]
            code = getattr(e, "errno", None)
        print(json.dumps({"writer": name, "mode": "diskfull", "raised": raised,
                          "is_oserror": raised is not None and raised.split(":")[0] in (
                              "OSError", "IOError", "FileNotFoundError") or "No space left" in str(raised),
                          "errno": code, "state": state(), "left": temporaries(folder)}), flush=True)


if __name__ == "__main__":
    signal.signal(signal.SIGINT, signal.default_int_handler)
    mode, d = sys.argv[1], Path(sys.argv[2])
    if mode == "kill":
        kill(d, int(sys.argv[3]))
    elif mode == "interrupt":
        interrupt(d, int(sys.argv[3]))
    elif mode == "diskfull":
        diskfull(d)
    else:
        raise SystemExit(f"unknown mode {mode}")
