"""Bad-input cases: image files and arrays (read_exr, write_exr, write_png, show)."""
from __future__ import annotations

import numpy as np

from .common import IMG, JUNK, cases_for, exr_window

# --------------------------------------------------------------------------------------------------
# Image files and arrays: read_exr, write_exr, write_png.

cases_for("read_exr", [
    ("missing file", lambda c: c.ml.read_exr(c.tmp / "nope.exr"), ["nope.exr"]),
    ("a directory", lambda c: c.ml.read_exr(c.tmp), ["tmp"]),
    ("empty file", lambda c: c.ml.read_exr(c.file("empty.exr", b"")), ["empty.exr"]),
    ("binary junk", lambda c: c.ml.read_exr(c.file("junk.exr", JUNK)), ["junk.exr"]),
    ("truncated", lambda c: c.ml.read_exr(c.file("trunc.exr", c.exr_bytes[: len(c.exr_bytes) // 2])),
     ["trunc.exr"]),
    ("header only", lambda c: c.ml.read_exr(c.file("head.exr", c.exr_bytes[:100])), ["head.exr"]),
    ("PNG renamed .exr", lambda c: c.ml.read_exr(c.file("png.exr", c.png_bytes)), ["png.exr"]),
    ("header claiming 10^5 x 10^5", lambda c: c.ml.read_exr(c.file(
        "big.exr", exr_window(c.exr_bytes, (0, 0, 99999, 99999)))), ["big.exr"]),
    ("negative window", lambda c: c.ml.read_exr(c.file("neg.exr", exr_window(c.exr_bytes, (0, 0, -5, -5)))), ["neg.exr"]),
    ("window over int32", lambda c: c.ml.read_exr(c.file(
        "huge.exr", exr_window(c.exr_bytes, (-2**31, -2**31, 2**31 - 1, 2**31 - 1)))), ["huge.exr"]),
    ("not a path", lambda c: c.ml.read_exr(3), ["path"]),
], raises=("OSError", "ValueError", "TypeError"))

for _w, _ext in [("write_exr", "exr"), ("write_png", "png")]:
    cases_for(_w, [
        ("2-D image", lambda c, w=_w, e=_ext: getattr(c.ml, w)(c.tmp / f"o.{e}", IMG(4, 4)), ["(H, W, 3)"]),
        ("4 channels", lambda c, w=_w, e=_ext: getattr(c.ml, w)(c.tmp / f"o.{e}", IMG(4, 4, 4)), ["(H, W, 3)"]),
        ("empty image", lambda c, w=_w, e=_ext: getattr(c.ml, w)(c.tmp / f"o.{e}", IMG(0, 4, 3)), ["empty"]),
        ("complex dtype", lambda c, w=_w, e=_ext: getattr(c.ml, w)(c.tmp / f"o.{e}", np.zeros((2, 2, 3), complex)),
         ["complex"]),
        ("strings", lambda c, w=_w, e=_ext: getattr(c.ml, w)(c.tmp / f"o.{e}", np.full((2, 2, 3), "a")), ["'a'"]),
        ("folder missing", lambda c, w=_w, e=_ext: getattr(c.ml, w)(c.tmp / "no" / "dir" / f"o.{e}", IMG(2, 2, 3)),
         [f"o.{_ext}"]),
        ("path is a directory", lambda c, w=_w: getattr(c.ml, w)(c.tmp, IMG(2, 2, 3)), ["tmp"]),
    ], raises=("ValueError", "TypeError", "OSError"))
cases_for("write_png", [
    ("NaN exposure", lambda c: c.ml.write_png(c.tmp / "o.png", IMG(2, 2, 3), exposure=float("nan")),
     ["exposure"]),
    ("inf exposure", lambda c: c.ml.write_png(c.tmp / "o.png", IMG(2, 2, 3), exposure=float("inf")),
     ["exposure"]),
])
cases_for("show", [
    ("five channels", lambda c: c.ml.show(IMG(2, 3, 5), path=c.tmp / "s.png"), ["(2, 3, 5)"]),
    ("empty image", lambda c: c.ml.show(IMG(0, 3, 3), path=c.tmp / "s.png"), ["empty"]),
    ("NaN exposure", lambda c: c.ml.show(IMG(2, 2, 3), exposure=float("nan"), path=c.tmp / "s.png"), ["exposure"]),
])
cases_for("show", [
    ("strings", lambda c: c.ml.show([["a", "b"]], path=c.tmp / "s.png"), ["dtype"]),
], raises=("TypeError",))
