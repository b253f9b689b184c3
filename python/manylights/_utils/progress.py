"""Progress display for long native calls, fit for terminals, notebooks, log files and CI.

Every public function takes ``progress=None`` by default, which means: a live tqdm bar in a terminal
(stderr is a TTY) or a Jupyter kernel (``tqdm.auto``: a widget in notebooks), nothing anywhere else (output
to a pipe or a file, CI logs). ``progress=True`` asks for progress everywhere: the bar where there is one,
and elsewhere, since a bar would write thousands of carriage-return redraws, at most a few plain lines to
stderr: one when the call starts, one every ``LOG_INTERVAL`` seconds while it runs, one when it ends.
``progress=False`` shows nothing.

``MANYLIGHTS_PROGRESS`` overrides the choice for every call: ``bar``, ``log`` or ``off``.
"""
from __future__ import annotations

import os
import sys
import time
from typing import Callable, Optional

#: Seconds between two intermediate lines in log mode.
LOG_INTERVAL = 60.0


def _in_notebook() -> bool:
    """True inside a Jupyter kernel (where tqdm.auto draws a widget)."""
    if "ipykernel" not in sys.modules:
        return False
    try:
        from IPython import get_ipython

        ip = get_ipython()
        return ip is not None and "IPKernelApp" in ip.config
    except Exception:
        return False


def mode(requested: Optional[bool] = True) -> str:
    """``"bar"``, ``"log"`` or ``"off"``: how progress is shown now for a call's ``progress=requested``
    (None: the default, True, False; see module docs)."""
    if requested is not None and not requested:
        return "off"
    forced = os.environ.get("MANYLIGHTS_PROGRESS", "").strip().lower()
    if forced in ("bar", "log", "off"):
        return forced
    if _in_notebook():
        return "bar"
    try:
        if sys.stderr is not None and sys.stderr.isatty():
            return "bar"
    except (AttributeError, ValueError):
        pass
    return "log" if (requested is not None and sys.stderr is not None) else "off"


class progress_bar:
    """Context manager giving the native ``(done, total)`` callback of one call, or None when disabled.

    Args:
        total: units of work (lights, rows); no display when 0.
        desc: what is being computed ("columns", "rows").
        enabled: the caller's ``progress=`` (None: bar in a terminal or notebook, else nothing; True: also
            lines in logs; False: nothing).
        unit: name of one unit.
    """

    def __init__(self, total: int, desc: str, enabled: Optional[bool], unit: str = "light"):
        self.total, self.desc, self.unit = int(total), desc, unit
        self.mode = mode(enabled) if total > 0 else "off"
        self.bar = None
        self.start = self.last_log = 0.0
        self.done = 0

    def _log(self, msg: str) -> None:
        try:
            print(f"manylights: {self.desc}: {msg}", file=sys.stderr, flush=True)
        except (OSError, ValueError):
            pass

    def __enter__(self) -> Optional[Callable[[int, int], None]]:
        if self.mode == "off":
            return None
        self.start = self.last_log = time.perf_counter()
        if self.mode == "bar":
            from tqdm.auto import tqdm

            self.bar = tqdm(total=self.total, desc=self.desc, unit=self.unit, leave=False)

            def callback(done: int, total: int) -> None:
                # The native side knows the exact total (e.g. view samples behind masks).
                if total > self.bar.total:
                    self.bar.total = self.total = total
                # update() honours tqdm's mininterval (refresh() would redraw on every batch).
                self.bar.update(done - self.bar.n)

            return callback

        self._log(f"{self.total} {self.unit}s ...")

        def log_callback(done: int, total: int) -> None:
            self.done = done
            now = time.perf_counter()
            if now - self.last_log >= LOG_INTERVAL and done < total:
                self.last_log = now
                self._log(f"{done}/{total} {self.unit}s, {now - self.start:.0f} s")

        return log_callback

    def __exit__(self, exc_type, exc, tb) -> bool:
        if self.bar is not None:
            self.bar.close()
        elif self.mode == "log":
            took = time.perf_counter() - self.start
            if exc_type is None:
                self._log(f"done, {self.total} {self.unit}s in {took:.1f} s")
            else:
                self._log(f"stopped ({exc_type.__name__}) after {self.done}/{self.total} {self.unit}s, {took:.1f} s")
        return False
