"""Bad-input cases: ml.sweep, and those after it (host memory, sRGB encoding, animation output writers)."""
from __future__ import annotations

import numpy as np

from .common import _nan_at, cases_for


# ml.sweep: everything is refused before a cluster starts or a file is written.
def _sweep(c, **kw):
    args = {"methods": ["mrcs"], "budgets": [(4, 8)], "seeds": [0], "lights": 50, "device": "cpu", "progress": False,
            "workers": 0, "reference_dir": c.tmp / "sweep-refs", **kw}
    return c.ml.sweep(args.pop("scenes", [("demo", {"res": 8})]), **args)


def _sweep_other_definition(c):
    out = c.tmp / "sweep-other.parquet"
    _sweep(c, out=out, seeds=[0])
    return _sweep(c, out=out, seeds=[0, 1])


cases_for("sweep", [
    ("unknown method", lambda c: _sweep(c, methods=["mrcs", "raytrace"]), ["raytrace", "power_sampling"]),
    ("empty scenes", lambda c: _sweep(c, scenes=[]), ["scenes is empty"]),
    ("empty budget list", lambda c: _sweep(c, budgets=[]), ["budgets is empty"]),
    ("budget not a pair", lambda c: _sweep(c, budgets=[(8,)]), ["budgets[0]", "(8,)"]),
    ("budget of 0 rows", lambda c: _sweep(c, budgets=[(0, 8)]), ["budgets[0] rows", "0"]),
    ("budget of negative columns", lambda c: _sweep(c, budgets=[(4, -8)]), ["budgets[0] columns", "-8"]),
    ("budget not integers", lambda c: _sweep(c, budgets=[(4, "many")]), ["budgets[0] columns", "many"]),
    ("budget repeated", lambda c: _sweep(c, budgets=[(4, 8), (4, 8)]), ["twice"]),
    ("negative seed", lambda c: _sweep(c, seeds=[0, -1]), ["seeds[1]", "-1"]),
    ("empty seeds", lambda c: _sweep(c, seeds=[]), ["seeds is empty"]),
    ("zero lights", lambda c: _sweep(c, lights=0), ["lights", "0"]),
    ("unknown lights key", lambda c: _sweep(c, lights={"area": 4, "vpl": 9}), ["vpl"]),
    ("unknown device", lambda c: _sweep(c, device="tpu"), ["tpu"]),
    ("scene parameter of a bad type", lambda c: _sweep(c, scenes=[("demo", {"res": [8]})]), ["res"]),
    ("frames not a list of dicts", lambda c: _sweep(c, methods=["tensor_clustering"],
                                                    scenes=[("bounce", {"frames": [1, 2]})]), ["frames"]),
    ("animation method on a still scene", lambda c: _sweep(c, methods=["tensor_clustering"]),
     ["tensor_clustering", "still"]),
    ("options for a method not swept", lambda c: _sweep(c, options={"power_sampling": {}}), ["power_sampling"]),
    ("Parquet file of another sweep", _sweep_other_definition, ["another definition", "seeds"]),
    ("Parquet file not a sweep's", lambda c: _sweep(c, out=c.file("sweep-foreign.parquet", b"PAR1 not really")),
     ["sweep-foreign.parquet"]),
])
cases_for("sweep", [
    ("missing scene file", lambda c: _sweep(c, scenes=[str(c.tmp / "no-such-scene.xml")]), ["no-such-scene.xml"]),
    ("out in a missing directory", lambda c: _sweep(c, out=c.tmp / "no-such-dir" / "s.parquet"), ["no-such-dir"]),
], raises=("FileNotFoundError",))
cases_for("sweep", [
    ("unreachable scheduler", lambda c: _sweep(c, client="tcp://127.0.0.1:9", connect_timeout=1),
     ["scheduler", "127.0.0.1:9"]),
], raises=("OSError",))
cases_for("sweep", [
    ("scenes not a list", lambda c: _sweep(c, scenes=42), ["scenes"]),
], raises=("TypeError",))
cases_for("native.check_host_memory", [
    ("more than addressable", lambda c: c.native.check_host_memory("test request", 2**100), ["test request"]),
], raises=("MemoryError", "OverflowError"))
cases_for("native.encode_srgb8", [
    ("2-D image", lambda c: c.native.encode_srgb8(np.zeros((2, 2), np.float32)), ["(H, W, 3)"]),
    ("NaN exposure", lambda c: c.native.encode_srgb8(np.zeros((1, 1, 3), np.float32), float("nan")), ["exposure"]),
], raises=("ValueError", "TypeError"))
cases_for("write_exr_sequence", [
    ("3-D frames", lambda c: c.ml.write_exr_sequence(np.zeros((2, 2, 3)), c.tmp / "seq"), ["(f, H, W, 3)"]),
    ("no frames", lambda c: c.ml.write_exr_sequence(np.zeros((0, 2, 2, 3)), c.tmp / "seq"), ["empty"]),
    ("NaN pixel", lambda c: c.ml.write_exr_sequence(_nan_at(np.zeros((2, 2, 2, 3)), (1, 0, 1, 2)), c.tmp / "seq"),
     ["frame 1", "row 0", "column 1"]),
    ("prefix with a separator", lambda c: c.ml.write_exr_sequence(np.zeros((1, 2, 2, 3)), c.tmp / "seq", prefix="a/b"),
     ["prefix"]),
])
cases_for("write_video", [
    ("unknown format", lambda c: c.ml.write_video(np.zeros((2, 4, 4, 3)), c.tmp / "a.avi"), [".avi"]),
    ("zero fps", lambda c: c.ml.write_video(np.zeros((2, 4, 4, 3)), c.tmp / "a.gif", fps=0), ["fps"]),
    ("inf value", lambda c: c.ml.write_video(_nan_at(np.zeros((2, 4, 4, 3)), (0, 1, 1, 0), np.inf), c.tmp / "a.gif"),
     ["frame 0"]),
    ("missing folder", lambda c: c.ml.write_video(np.zeros((2, 4, 4, 3)), c.tmp / "no" / "a.gif"), ["does not exist"]),
], raises=("ValueError", "FileNotFoundError"))
cases_for("side_by_side", [
    ("no panels", lambda c: c.ml.side_by_side([]), ["at least one"]),
    ("shapes differ", lambda c: c.ml.side_by_side([np.zeros((2, 2, 3)), np.zeros((2, 3, 3))]), ["all must match"]),
    ("label count", lambda c: c.ml.side_by_side([np.zeros((2, 2, 3))], labels=[]), ["0 labels"]),
    ("negative gap", lambda c: c.ml.side_by_side([np.zeros((2, 2, 3))], gap=-1), ["gap"]),
])
