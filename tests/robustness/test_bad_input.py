"""Bad-input corpus: every public function of manylights with malformed arguments and
every file reader with truncated and foreign files must raise a Python exception naming the problem --
never a panic (pyo3's PanicException, a BaseException, counts as a failure), an abort, a hang or a
silently returned result. The cases live in ``tests/robustness/corpus/`` (run by ``bad_input_corpus.py``); they
run in a child process so that an abort or hang is pinned to its case (the rest continue in a fresh child).
"""
from __future__ import annotations

import inspect
import json
import os
import queue
import re
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from conftest import REPO

sys.path.insert(0, str(Path(__file__).parent))
import bad_input_corpus as corpus  # noqa: E402

CASE_TIMEOUT_S = 120.0  # a case that runs longer is a hang (the slowest good case takes ~1 s)
CASE_IDS = [c.id for c in corpus.CASES]


def _run_child(out_dir: Path, ids: list[str], env_extra: dict | None = None,
               timeout: float = CASE_TIMEOUT_S) -> tuple[dict, str | None, str]:
    """Run ``ids`` in one child; returns (results by id, id of the case it died or hung in, stderr tail)."""
    env = os.environ.copy()
    env["BAD_INPUT_ONLY"] = json.dumps(ids)
    env.setdefault("RUST_BACKTRACE", "0")
    env.update(env_extra or {})
    proc = subprocess.Popen([sys.executable, str(Path(corpus.__file__)), str(out_dir)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env)
    lines: queue.Queue = queue.Queue()
    threading.Thread(target=lambda: [lines.put(l) for l in proc.stdout] + [lines.put(None)], daemon=True).start()
    err_chunks: list[str] = []
    threading.Thread(target=lambda: err_chunks.extend(proc.stderr), daemon=True).start()
    results, current = {}, None
    deadline = time.monotonic() + timeout
    while True:
        try:
            line = lines.get(timeout=max(deadline - time.monotonic(), 0.01))
        except queue.Empty:
            proc.kill()
            proc.wait()
            if current is not None:
                results[current] = {"verdict": "hang", "msg": f"no result after {timeout:.0f} s"}
            return results, current, "".join(err_chunks)[-3000:]
        if line is None:
            break
        try:
            msg = json.loads(line)
        except json.JSONDecodeError:
            continue  # stray output of a case
        if "start" in msg:
            current = msg["start"]
            deadline = time.monotonic() + timeout
        else:
            results[msg["id"]] = msg
            current = None
    rc = proc.wait()
    stderr = "".join(err_chunks)[-3000:]
    if current is not None:
        results[current] = {"verdict": "abort", "msg": f"the process died (exit status {rc})", "stderr": stderr}
    return results, current, stderr


@pytest.fixture(scope="session")
def corpus_results(tmp_path_factory) -> dict:
    out = tmp_path_factory.mktemp("bad-input")
    results: dict = {}
    in_child = [c.id for c in corpus.CASES if not c.subprocess]
    while pending := [i for i in in_child if i not in results]:
        got, died_in, _ = _run_child(out, pending)
        results.update(got)
        if died_in is None and not got:
            break
    for c in corpus.CASES:
        if c.subprocess:
            got, _, _ = _run_child(out, [c.id], corpus.SUBPROCESS_ENV.get(c.id))
            results.update(got)
    return results


@pytest.mark.parametrize("case_id", CASE_IDS)
def test_bad_input(case_id, corpus_results):
    c = next(c for c in corpus.CASES if c.id == case_id)
    r = corpus_results.get(case_id)
    assert r is not None, f"{case_id}: no result (the child stopped before it)"
    detail = json.dumps({k: v for k, v in r.items() if k != "id"}, indent=1)[:4000]
    assert r["verdict"] == "ok", (f"{case_id} ({c.target}): expected {'/'.join(c.raises)} naming "
                                  f"{list(c.match)}, got {r['verdict']}:\n{detail}")


def test_runner_reports_panic_abort_hang(tmp_path):
    """The harness itself: a PanicException (BaseException), an abort, a returned value, a vague message and
    a hang are each reported as a failure of their own case, and the cases after them still run."""
    ids = ["selftest:panic", "selftest:abort", "selftest:returns", "selftest:vague", "selftest:hang", "selftest:ok"]
    results = {}
    while pending := [i for i in ids if i not in results]:
        got, _, _ = _run_child(tmp_path, pending, {"BAD_INPUT_SELFTEST": "1"}, timeout=5.0)
        results.update(got)
    verdicts = {i: results[i]["verdict"] for i in ids}
    assert verdicts == {"selftest:panic": "panic", "selftest:abort": "abort", "selftest:returns": "returned",
                        "selftest:vague": "unclear", "selftest:hang": "hang", "selftest:ok": "ok"}


def test_case_ids_unique():
    assert len(set(CASE_IDS)) == len(CASE_IDS)


def public_functions() -> set[str]:
    """Every public callable: manylights.__all__ (functions, classes and their public methods),
    the native module's functions, manylights.metrics and manylights.scenes."""
    import manylights as ml
    from manylights import _native, metrics, scenes

    names: set[str] = set()

    def add_class(prefix, cls):
        names.add(prefix)
        for k, v in vars(cls).items():
            if not k.startswith("_") and (callable(v) or isinstance(v, (classmethod, staticmethod))) \
                    and not isinstance(v, (property, type)):
                names.add(f"{prefix}.{k}")
        if "__len__" in vars(cls):
            names.add(prefix)

    for name in ml.__all__:
        obj = getattr(ml, name)
        if inspect.isclass(obj):
            if issubclass(obj, BaseException):
                continue
            add_class(name, obj)
        elif callable(obj):
            names.add(name)
    for name in dir(_native):
        obj = getattr(_native, name)
        if name.startswith("_") or not callable(obj) or inspect.isclass(obj):
            continue
        names.add(name if getattr(ml, name, None) is obj else f"native.{name}")
    for mod, prefix in [(metrics, "metrics"), (scenes, "scenes")]:
        for name, obj in vars(mod).items():
            if not name.startswith("_") and inspect.isfunction(obj) and obj.__module__ == mod.__name__:
                if getattr(ml, name, None) is not obj:
                    names.add(f"{prefix}.{name}")
    return names


def test_every_public_function_has_bad_input_cases():
    """A new public function fails here until the corpus lists bad input for it (or NOT_COVERED says why
    it takes none)."""
    covered = {c.target.split("[")[0] for c in corpus.CASES}
    missing = sorted(public_functions() - covered - set(corpus.NOT_COVERED))
    assert not missing, f"public functions without a bad-input case in tests/robustness/corpus/: {missing}"
    # every case targets something that exists (a renamed function leaves no stale entry)
    stale = sorted(t for t in covered if t not in public_functions() and not t.startswith("native."))
    assert not stale, stale


def test_pyi_functions_are_enumerated():
    """Functions the stub declares are the native module's (so the enumeration above sees them all)."""
    from manylights import _native

    stub = (REPO / "python" / "manylights" / "_native.pyi").read_text()
    declared = set(re.findall(r"^def (\w+)\(", stub, flags=re.M))
    assert declared and declared <= set(dir(_native)), declared - set(dir(_native))
    for cls, methods in re.findall(r"^class (\w+)[^\n]*:\n((?:    [^\n]*\n|\n)*)", stub, flags=re.M):
        for meth in re.findall(r"^    def (\w+)\(", methods, flags=re.M):
            if not meth.startswith("_"):
                assert hasattr(getattr(_native, cls), meth), f"{cls}.{meth} in the stub but not in _native"
