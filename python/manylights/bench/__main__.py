"""``python -m manylights.bench <subcommand>``: the benchmarks' command line (``manylights.bench``)."""
from __future__ import annotations

import argparse
import sys

from . import (
    backends,
    bias,
    budgets,
    calibrate,
    compare,
    cuts,
    lights,
    mrcs,
    relight,
    scale,
    targets,
    tensor,
    vs_mitsuba,
)

SUBCOMMANDS = (lights, mrcs, compare, cuts, backends, tensor, relight, vs_mitsuba, calibrate, budgets, targets, bias, scale)


def main(argv=None) -> int:
    """Parse ``argv`` and run the benchmark it names; returns 0."""
    ap = argparse.ArgumentParser(prog="python -m manylights.bench", description=sys.modules[__package__].__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    for command in SUBCOMMANDS:
        command.add_parser(sub)
    a = ap.parse_args(argv)
    a.run(a)
    return 0


if __name__ == "__main__":
    sys.exit(main())
