"""Self-test cases of the runner (only with BAD_INPUT_SELFTEST=1)."""
from __future__ import annotations

import os

from .common import CASES, Case

# Self-test cases of the runner (only with BAD_INPUT_SELFTEST=1): each must be reported as a failure.
if os.environ.get("BAD_INPUT_SELFTEST"):
    class PanicException(BaseException):  # the name pyo3 gives its panics (pyo3_runtime.PanicException)
        pass

    def _panic(c):
        raise PanicException("called `Option::unwrap()` on a `None` value")

    def _hang(c):
        import time
        time.sleep(3600)

    CASES[:] = [Case("selftest:panic", "selftest", _panic), Case("selftest:abort", "selftest", lambda c: os.abort()),
                Case("selftest:returns", "selftest", lambda c: 42),
                Case("selftest:vague", "selftest", lambda c: int("x"), match=("nothing like this",)),
                Case("selftest:hang", "selftest", _hang), Case("selftest:ok", "selftest", lambda c: int("x"))]
