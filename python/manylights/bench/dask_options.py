"""The Dask options every sweeping benchmark shares (``bench mrcs``, ``bench compare``, ``bench tensor``).

``--workers N``: a Dask LocalCluster of N processes (0, the default: every render in this process, no
cluster); ``--scheduler ADDRESS``: a running Dask scheduler instead; ``--reference-dir``: where the
brute-force references, cached by content hash, are shared by the workers (default ``<out>/references``).
"""
from __future__ import annotations

import argparse


def add_dask_arguments(p: argparse.ArgumentParser, reference_dir: bool = True) -> None:
    """Add ``--workers``, ``--scheduler`` and (when ``reference_dir``) ``--reference-dir`` to ``p``."""
    p.add_argument("--workers", type=int, default=0,
                   help="Dask LocalCluster worker processes (0: every render in this process, no cluster)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="a running Dask scheduler (tcp://host:8786) instead of a LocalCluster")
    if reference_dir:
        p.add_argument("--reference-dir", default=None,
                       help="brute-force references shared by the workers (default: <out>/references)")


def check_dask_arguments(args: argparse.Namespace) -> None:
    """Raise ValueError for ``--workers`` < 0."""
    if args.workers is not None and args.workers < 0:
        raise ValueError(f"--workers must be >= 0, got {args.workers}")
