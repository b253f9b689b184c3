"""The bad-input corpus: malformed arguments for every public function of manylights
and truncated / foreign files for every file reader. Each case must raise a Python ``Exception`` of the
listed kinds whose message names the problem; a pyo3 ``PanicException`` (a ``BaseException``), an
abort, a hang or a return counts as a failure.

The cases live in the package ``tests/robustness/corpus/`` (``common.py``: ``Case``, ``CASES``, the context
``Ctx`` and the byte helpers; one module per domain); this file is the runner, and re-exports what
``tests/robustness/test_bad_input.py`` uses (``CASES``, ``NOT_COVERED``, ``SUBPROCESS_ENV``).

Run by ``tests/robustness/test_bad_input.py`` in a child process (``python tests/robustness/bad_input_corpus.py OUT_DIR``)
that reports one JSON line per case as it goes, so that an abort or a hang is pinned to its case and
the remaining cases run in a fresh child.
"""
from __future__ import annotations

import json
import os
import sys
import traceback
from pathlib import Path

from corpus import CASES, NOT_COVERED, REPO, SUBPROCESS_ENV, Case, Ctx, case, cases_for

__all__ = ["CASES", "NOT_COVERED", "REPO", "SUBPROCESS_ENV", "Case", "Ctx", "case", "cases_for", "run"]

# --------------------------------------------------------------------------------------------------
# The runner (in the child process).

def _classify(exc: BaseException, c: Case) -> dict:
    names = [k.__name__ for k in type(exc).__mro__]
    msg = str(exc)
    out = {"type": type(exc).__name__, "mro": names, "msg": msg[:2000]}
    if not isinstance(exc, Exception):
        out["verdict"] = "panic" if "PanicException" in names else "base-exception"
    elif not any(r in names for r in c.raises):
        out["verdict"] = "wrong-type"
    elif missing := [m for m in c.match if m.lower() not in msg.lower()]:
        out["verdict"] = "unclear"
        out["missing"] = missing
    else:
        out["verdict"] = "ok"
    return out


def run(out_dir: Path, only: list[str] | None = None) -> None:
    """Run the cases (or those in ``only``), printing one JSON line per case: {"start": id} then the result."""
    out_dir.mkdir(parents=True, exist_ok=True)
    ctx = Ctx(out_dir)
    for c in CASES:
        if only is not None and c.id not in only:
            continue
        print(json.dumps({"start": c.id}), flush=True)
        try:
            r = c.fn(ctx)
        except BaseException as e:  # PanicException is a BaseException: that is the point
            res = _classify(e, c)
            if res["verdict"] != "ok":
                res["traceback"] = traceback.format_exc()[-3000:]
        else:
            res = {"verdict": "returned", "returned": repr(r)[:300]}
        res["id"] = c.id
        print(json.dumps(res), flush=True)


if __name__ == "__main__":
    only = json.loads(os.environ["BAD_INPUT_ONLY"]) if os.environ.get("BAD_INPUT_ONLY") else None
    run(Path(sys.argv[1]), only)
