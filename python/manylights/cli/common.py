"""What the commands share: ``-D name=value`` scene parameters, a stopwatch of stages, and writing an image as
EXR (+ PNG)."""
from __future__ import annotations

import time
from pathlib import Path

from ..io.images import write_exr, write_png


def scene_params(pairs) -> dict:
    """``-D name=value`` pairs as a dict of strings (the loader's ``<default>`` parameters)."""
    out = {}
    for p in pairs or []:
        if "=" not in p:
            raise SystemExit(f"-D expects name=value, got {p!r}")
        k, v = p.split("=", 1)
        out[k] = v
    return out


class Stopwatch:
    """Times named stages of a command: ``sw("load scene", fn, *args)`` runs and times ``fn``."""

    def __init__(self):
        self.stages = []

    def __call__(self, name, fn, *a, **kw):
        t = time.perf_counter()
        r = fn(*a, **kw)
        self.stages.append((name, time.perf_counter() - t))
        return r

    def report(self):
        for name, s in self.stages:
            print(f"  {name:<28s} {s * 1000:9.1f} ms")


def write_image(sw, out: Path, img, png: bool) -> list[Path]:
    """Write ``img`` to ``out`` (EXR) and, with ``png``, beside it as PNG, timed by ``sw``; returns the paths."""
    out.parent.mkdir(parents=True, exist_ok=True)
    sw("write exr", write_exr, out, img)
    written = [out]
    if png:
        p = out.with_suffix(".png")
        sw("write png", write_png, p, img)
        written.append(p)
    return written
