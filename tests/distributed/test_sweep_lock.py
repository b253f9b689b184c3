"""One sweep at a time per ``out`` file: a second sweep (another thread, another process) into the same out
gets LockedError naming the owner while the first one runs; no row of the first is lost; a lock left by a
dead process is taken over; the lock is released when the sweep ends."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import pandas as pd
import pytest

import manylights as ml
from manylights._utils.files import LockedError

REPO = Path(__file__).resolve().parents[2]
TINY = dict(scenes=[("demo", {"res": 8})], methods=["power_sampling"], budgets=[(4, 8)], seeds=[0, 1], lights=50,
            device="cpu", progress=False, workers=0)


def test_second_sweep_in_another_thread_is_refused_and_no_row_is_lost(tmp_path):
    out, refs = tmp_path / "s.parquet", tmp_path / "refs"
    first_row, go_on = threading.Event(), threading.Event()
    result = {}

    def hold(row):
        first_row.set()
        go_on.wait(30)

    def first():
        result["df"] = ml.sweep(out=out, reference_dir=refs, on_row=hold, **TINY)

    t = threading.Thread(target=first)
    t.start()
    assert first_row.wait(60)
    with pytest.raises(LockedError, match=rf"s\.parquet is being written by another sweep \(pid {os.getpid()} .*"
                                          r"\(this process\).*s\.parquet\.lock"):
        ml.sweep(out=out, reference_dir=refs, **{**TINY, "seeds": [7]})
    go_on.set()
    t.join(60)
    stored = pd.read_parquet(out)
    assert len(result["df"]) == len(stored) == 2 and sorted(stored["seed"]) == [0, 1]
    assert not (tmp_path / "s.parquet.lock").exists()
    assert not [n for n in os.listdir(tmp_path) if ".mltmp" in n]


def test_second_sweep_in_another_process_is_refused(tmp_path):
    out, refs = tmp_path / "s.parquet", tmp_path / "refs"
    child = subprocess.Popen([sys.executable, "-c", f"""
import time, manylights as ml
ml.sweep(out={str(out)!r}, reference_dir={str(refs)!r}, on_row=lambda r: time.sleep(1.5), **{TINY!r})
"""], env={**os.environ, "PYTHONPATH": str(REPO / "python")})
    lock = tmp_path / "s.parquet.lock"
    t0 = time.time()
    while not lock.exists() and time.time() - t0 < 60:
        time.sleep(0.02)
    owner = json.loads(lock.read_text())
    assert owner["pid"] == child.pid and owner["what"] == "sweep"
    with pytest.raises(LockedError, match=rf"another sweep \(pid {child.pid} on host "):
        ml.sweep(out=out, reference_dir=refs, **{**TINY, "seeds": [3]})
    assert child.wait(120) == 0
    stored = pd.read_parquet(out)
    assert sorted(stored["seed"]) == [0, 1] and (stored["status"] == "ok").all()
    assert not lock.exists()


def test_stale_lock_of_a_dead_process_is_taken_over(tmp_path):
    out = tmp_path / "s.parquet"
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    from manylights._utils.files import host_name

    (tmp_path / "s.parquet.lock").write_text(json.dumps({"pid": dead.pid, "host": host_name(), "what": "sweep",
                                                         "since": "then", "thread": 1}, sort_keys=True))
    df = ml.sweep(out=out, reference_dir=tmp_path / "refs", **TINY)
    assert len(df) == len(pd.read_parquet(out)) == 2
    assert not (tmp_path / "s.parquet.lock").exists()
    # A lock of another host is not judged from here: refused, naming it.
    (tmp_path / "s.parquet.lock").write_text(json.dumps({"pid": 1, "host": "elsewhere", "what": "sweep",
                                                         "since": "then", "thread": 1}, sort_keys=True))
    with pytest.raises(LockedError, match="pid 1 on host elsewhere"):
        ml.sweep(out=out, reference_dir=tmp_path / "refs", **TINY)
