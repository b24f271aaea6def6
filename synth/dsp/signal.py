"""Validation of the sample blocks handed to the engine's stream stages."""

from __future__ import annotations

import math

import numpy as np


def as_mono_block(x) -> np.ndarray:
    """``x`` as a C-contiguous float64 1-D array of finite samples, or a
    one-line ValueError naming what is wrong.  Cheap on valid input: a finite
    sum means finite samples; only then is the block looked at closely."""
    x = np.asarray(x)
    if x.ndim != 1:
        raise ValueError(f"x has shape {x.shape}; must be 1-D (one channel)")
    if x.dtype.kind not in "fiu":
        raise ValueError(f"x has dtype {x.dtype}; must be real (float or integer)")
    if x.dtype != np.float64 or not x.flags.c_contiguous:
        x = np.ascontiguousarray(x, dtype=np.float64)
    if not math.isfinite(x.sum()) and not np.isfinite(x).all():
        bad = int(np.flatnonzero(~np.isfinite(x))[0])
        raise ValueError(f"x[{bad}] = {x[bad]} is not finite; input samples must be finite")
    return x


def output_block(out, n: int, what: str) -> np.ndarray:
    """The buffer to write ``n`` output samples into: ``out`` checked (1-D,
    float64, writeable, at least ``n`` long; ``what`` names the required
    length in the error), or a new array when ``out`` is None."""
    if out is None:
        return np.empty(n, dtype=np.float64)
    if not isinstance(out, np.ndarray) or out.dtype != np.float64 or out.ndim != 1:
        raise ValueError("out must be a 1-D float64 ndarray")
    if out.shape[0] < n:
        raise ValueError(f"out has length {out.shape[0]}; must be >= {n} ({what})")
    if not out.flags.writeable:
        raise ValueError("out must be writeable")
    return out


def channel_blocks(x, out, channels: int):
    """A multichannel stage's input and output checked: ``x`` float64 of
    shape (n,) (one channel) or (``channels``, n); ``out`` the same shape
    (may be ``x``: in place) or None for a new array.  Returns (x as 2-D,
    out, out as 2-D); a one-line ValueError otherwise.  (The limiter and
    the listener take their blocks this way.)"""
    if not isinstance(x, np.ndarray) or x.dtype != np.float64:
        raise ValueError("x must be a float64 ndarray")
    x2 = x.reshape(1, -1) if x.ndim == 1 else x
    if x2.ndim != 2 or x2.shape[0] != channels:
        raise ValueError(f"x has shape {x.shape}; must be (n,) or ({channels}, n)")
    if out is None:
        out = np.empty_like(x)
    if out.shape != x.shape or out.dtype != np.float64:
        raise ValueError(f"out has shape {out.shape}; must be {x.shape} (float64)")
    return x2, out, (out.reshape(1, -1) if out.ndim == 1 else out)


def in_place_rows(y, channels: int, run):
    """Run an in-place kernel on ``y``: shape (n,) for one channel or
    (``channels``, n), float64, writeable (else a one-line ValueError).
    ``run(t, n)`` gets a (``channels``, n) array whose rows are contiguous:
    ``y`` itself, or for rows with a stride one temporary block, copied
    back.  Returns ``y``.  (The board's spread and mass law filter their
    outputs this way.)"""
    if not isinstance(y, np.ndarray) or y.dtype != np.float64 or not y.flags.writeable:
        raise ValueError("y must be a writeable float64 ndarray")
    y2 = y[None, :] if y.ndim == 1 else y
    if y2.ndim != 2 or y2.shape[0] != channels:
        raise ValueError(f"y has shape {y.shape}; must be ({channels}, n)"
                         + (" or (n,)" if channels == 1 else ""))
    n = y2.shape[1]
    if n:
        t = y2 if n == 1 or y2.strides[1] == 8 else np.ascontiguousarray(y2)
        run(t, n)
        if t is not y2:
            y2[:] = t
    return y
