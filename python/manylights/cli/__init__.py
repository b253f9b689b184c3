"""Command line: ``python -m manylights {render,demo,animate,relight,info}``, one module per command, each with
``add_parser(sub)`` and ``run(args)``; ``common`` holds what they share."""
from __future__ import annotations

import argparse
import sys

from .._native import ManyLightsError
from . import animate, demo, info, relight, render

COMMANDS = (render, demo, info, animate, relight)


def main(argv=None) -> int:
    """Parse ``argv`` (default ``sys.argv[1:]``) and run the command; returns the exit status (0, or 1 with a
    one-line ``error: ...`` on standard error for bad input, a missing file or a device error)."""
    ap = argparse.ArgumentParser(prog="python -m manylights", description="manylights: render, demo, animate, relight, info")
    sub = ap.add_subparsers(dest="cmd", required=True)
    for command in COMMANDS:
        command.add_parser(sub)
    a = ap.parse_args(argv)
    try:
        a.run(a)
    except (ManyLightsError, ValueError, FileNotFoundError, OSError) as e:  # a clean message, not a traceback
        print(f"error: {e}", file=sys.stderr)
        return 1
    return 0
