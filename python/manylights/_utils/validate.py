"""Argument checks shared by the public functions: each raises TypeError / ValueError naming the argument
and the value, before anything reaches the native module (where a bad value would be an OverflowError
without the argument's name, or a silent truncation such as 1.5 -> 1)."""
from __future__ import annotations

import math
import numbers
from typing import Optional

import numpy as np

U64_MAX = 2**64 - 1


def integer(name: str, v, lo: Optional[int] = None, hi: Optional[int] = None) -> int:
    """``v`` as a Python int in [lo, hi]: integers and integral floats, never bools, NaN or strings."""
    if isinstance(v, (bool, np.bool_)):
        raise ValueError(f"{name} must be an integer, got {v!r}")
    if isinstance(v, numbers.Integral):
        out = int(v)
    elif isinstance(v, numbers.Real) and math.isfinite(float(v)) and float(v).is_integer():
        out = int(v)
    else:
        raise ValueError(f"{name} must be an integer, got {v!r}")
    if lo is not None and hi is not None and lo > hi:  # no value fits: say both bounds, not "lo..=hi"
        raise ValueError(f"{name} has no valid value here: it must be >= {lo} and also <= {hi}; got {out}")
    if (lo is not None and out < lo) or (hi is not None and out > hi):
        rng = f"in {lo}..={hi}" if lo is not None and hi is not None else f">= {lo}" if lo is not None else f"<= {hi}"
        raise ValueError(f"{name} must be {rng}, got {out}")
    return out


def seed(v, name: str = "seed") -> int:
    return integer(name, v, 0, U64_MAX)


def real(name: str, v, lo: Optional[float] = None, hi: Optional[float] = None) -> float:
    """``v`` as a finite float in [lo, hi]."""
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Real):
        raise ValueError(f"{name} must be a number, got {v!r}")
    out = float(v)
    if not math.isfinite(out) or (lo is not None and out < lo) or (hi is not None and out > hi):
        rng = f" in [{lo}, {hi}]" if lo is not None and hi is not None else ""
        raise ValueError(f"{name} must be a finite number{rng}, got {out}")
    return out


def numeric_array(name: str, a, dtype=np.float32) -> np.ndarray:
    """``a`` as a C-contiguous ``dtype`` array; complex, string and object arrays are refused (numpy would
    drop the imaginary part or fail with a message that does not name the argument)."""
    arr = np.asarray(a)
    if arr.dtype.kind not in "fiub":
        raise TypeError(f"{name} must be a real numeric array, got dtype {arr.dtype}"
                        f"{' (values like ' + repr(arr.flat[0]) + ')' if arr.size else ''}")
    return np.ascontiguousarray(arr, dtype=dtype)


def finite(name: str, a: np.ndarray) -> np.ndarray:
    """Raise ValueError naming the first NaN/inf entry of ``a`` (and how many there are)."""
    bad = ~np.isfinite(a)
    if bad.any():
        idx = tuple(int(i) for i in np.argwhere(bad)[0])
        raise ValueError(f"{name} has {int(bad.sum())} non-finite values (NaN or inf), the first at index "
                         f"{idx[0] if len(idx) == 1 else idx}: {a[idx]}")
    return a


def finite_result(what: str, img: np.ndarray) -> np.ndarray:
    """``img`` (..., H, W, 3) when every element is finite; else FloatingPointError naming how many pixels and
    the first one (frame, x, y): a result that overflowed float32 is never returned."""
    bad = ~np.isfinite(img)
    if not bad.any():
        return img
    first = np.argwhere(bad)[0]
    *frame, y, x, _ = (int(i) for i in first)
    at = f"frame {frame[0]}, " if frame else ""
    raise FloatingPointError(f"{what}: {int(bad.any(axis=-1).sum())} pixels are not finite (float32 overflow), the "
                             f"first at ({at}x {x}, y {y}): {img[tuple(first[:-1])].tolist()}; scale the lights down")


def indices(name: str, values, size: int, what: str) -> np.ndarray:
    """``values`` as a 1-D int64 array of indices in [0, size): integers only (no bools, floats or NaN),
    the first bad one named with its position. ``name`` is singular ("row index"), ``what`` names the
    range ("m = 1024 view samples")."""
    if np.isscalar(values):
        raise ValueError(f"{name} values must be a sequence of integers, got the scalar {values!r}")
    lst = values if isinstance(values, np.ndarray) else list(values)
    if not isinstance(lst, np.ndarray) and any(isinstance(v, (bool, np.bool_)) for v in lst):
        raise ValueError(f"{name} values must be integers, got a bool at position "
                         f"{next(k for k, v in enumerate(lst) if isinstance(v, (bool, np.bool_)))}")
    arr = np.asarray(lst)
    if arr.ndim > 1:
        raise ValueError(f"{name} values must be one-dimensional, got shape {arr.shape}")
    if arr.size == 0:
        return np.zeros(0, np.int64)
    if arr.dtype.kind == "O" and all(isinstance(v, numbers.Integral) for v in arr.tolist()):
        k = next(k for k, v in enumerate(arr.tolist()) if not -(2**63) <= int(v) < 2**63)
        raise ValueError(f"{name} {arr[k]} (at position {k}) is out of range for {what}")
    if arr.dtype.kind not in "iu":
        raise ValueError(f"{name} values must be integers, got dtype {arr.dtype} (e.g. {arr.reshape(-1)[0]!r})")
    arr = arr.reshape(-1)
    if arr.dtype.kind == "u" and arr.dtype.itemsize == 8:
        # uint64 above int64's range would wrap to negative numbers: name the value as given.
        big = np.flatnonzero(arr >= np.uint64(size))
        if big.size:
            k = int(big[0])
            raise ValueError(f"{name} {int(arr[k])} (at position {k}) is out of range for {what}")
    arr = arr.astype(np.int64, copy=False)
    bad = np.flatnonzero((arr < 0) | (arr >= size))
    if bad.size:
        k = int(bad[0])
        raise ValueError(f"{name} {int(arr[k])} (at position {k}) is out of range for {what}")
    return arr
