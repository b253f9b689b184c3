"""What the commands share: one flag vocabulary (``-o/--output``; ``--res N`` the scene's ``res`` parameter,
``--size W H`` a film override, ``-D name=value`` any scene parameter), a stopwatch of stages, and writing an
image as EXR (+ PNG)."""
from __future__ import annotations

import argparse
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


def add_output(parser, default: str, help: str) -> None:
    """``-o/--output`` (the older ``--out`` still works, hidden from the help)."""
    parser.add_argument("-o", "--output", default=default, help=f"{help} (default {default})")
    parser.add_argument("--out", dest="output", help=argparse.SUPPRESS)


def add_scene_options(parser, size: bool = True) -> None:
    """``--res N`` (the scene's ``res`` parameter), ``--size W H`` (film override) and ``-D name=value``."""
    parser.add_argument("--res", type=int, default=None, help="the scene's 'res' parameter (image width and height)")
    if size:
        parser.add_argument("--size", type=int, nargs=2, metavar=("W", "H"), help="film size override")
    parser.add_argument("-D", dest="params", action="append", metavar="NAME=VALUE", help="scene parameter")


def scene_options(a) -> tuple:
    """(size or None, params dict) from ``add_scene_options``' arguments (``--res`` becomes ``res``)."""
    params = scene_params(getattr(a, "params", None))
    if getattr(a, "res", None) is not None:
        params["res"] = str(a.res)
    size = getattr(a, "size", None)
    return (tuple(size) if size else None), params


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
