"""``python -m manylights info``: the device that runs (and the GPU adapter wgpu would use)."""
from __future__ import annotations

from .._native import device_info


def add_parser(sub) -> None:
    i = sub.add_parser("info", help="print the device that runs (and the GPU adapter wgpu would use)")
    i.set_defaults(run=run)


def run(a) -> None:
    """Print ``device_info()``, one ``key: value`` a line."""
    for k, v in device_info().items():
        print(f"{k}: {v}")
