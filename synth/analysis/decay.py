"""Decay: the level of a sound, or of one partial, over time, and its T60.

Written with recipe 3 of ``docs/architecture.md`` (numpy only, explicit
``fs``, arrays in).

The level curve is measured in frames of ``frame_s`` every ``hop_s``: the
RMS of the frame (broadband), or, with ``f_hz``, the amplitude of the
component at ``f_hz`` from a single-bin DFT of the Hann-windowed frame,
scaled so that a steady sine of amplitude a reads 20 log10(a) dB.  The T60
is -60 / slope of a least-squares line through the curve where it lies
between ``start_db`` and ``stop_db`` below its maximum (after the maximum):
the same evaluation-range idea as ISO 3382's T20/T30, applied to the level
curve of a free decay rather than to a Schroeder integral.
"""

from __future__ import annotations

import numpy as np

from .spectrum import _positive, _real, _signal

__all__ = ["decay_curve_db", "t60_s", "two_stage_decay"]

#: level reported for a silent frame (dB)
_FLOOR_DB = -300.0


def decay_curve_db(x, fs, f_hz=None, frame_s=None, hop_s=0.01):
    """Level over time of ``x`` (dB re amplitude 1), broadband or of one partial.

    Parameters
    ----------
    x : array_like, 1-D
        Signal (e.g. a rendered note, full scale 1).
    fs : float
        Sample rate (Hz), > 0.
    f_hz : float or None
        Frequency of the partial to follow (Hz), 0 < f_hz < fs/2; None: the
        broadband RMS level.
    frame_s : float or None
        Frame length (s), > 0; a frame must hold at least 16 samples, and,
        with ``f_hz``, at least 4 periods of it (so that the partial's
        neighbours, a harmonic apart, fall outside the window's main lobe).
        None: 20 ms, or 8 periods of ``f_hz`` if that is longer.
    hop_s : float
        Hop between frames (s), > 0.

    Returns
    -------
    t_s : ndarray
        Frame centres (s).
    level_db : ndarray
        Level of each frame (dB; -300 for a silent frame).
    """
    fs = _positive("fs", fs)
    if frame_s is None:
        frame_s = 0.02 if f_hz is None else max(0.02, 8.0 / _positive("f_hz", f_hz))
    frame_s, hop_s = _positive("frame_s", frame_s), _positive("hop_s", hop_s)
    n = int(round(frame_s * fs))
    hop = max(1, int(round(hop_s * fs)))
    if n < 16:
        raise ValueError(f"frame_s={frame_s!r} out of range: must hold at least 16 samples "
                         f"(>= {16 / fs:g} s at fs={fs:g})")
    if f_hz is not None:
        f_hz = _real("f_hz", f_hz, 0.0, fs / 2, low_open=True, high_open=True)
        if n * f_hz / fs < 4.0:
            raise ValueError(f"frame_s={frame_s!r} out of range: must hold at least 4 periods "
                             f"of f_hz={f_hz:g} (>= {4.0 / f_hz:g} s)")
    x = _signal("x", x, min_len=n)
    starts = np.arange(0, len(x) - n + 1, hop)
    frames = np.lib.stride_tricks.sliding_window_view(x, n)[starts]
    if f_hz is None:
        level = np.sqrt(np.mean(frames * frames, axis=1))
    else:
        w = 0.5 - 0.5 * np.cos(2.0 * np.pi * np.arange(n) / n)       # periodic Hann
        ph = np.exp(-2j * np.pi * f_hz * np.arange(n) / fs)
        level = 2.0 * np.abs(frames @ (w * ph)) / np.sum(w)
    with np.errstate(divide="ignore"):
        db = np.where(level > 0, 20.0 * np.log10(np.maximum(level, 1e-300)), _FLOOR_DB)
    return (starts + 0.5 * n) / fs, db


def t60_s(x, fs, f_hz=None, start_db=-5.0, stop_db=-35.0, frame_s=None, hop_s=0.01):
    """60 dB decay time (s) of ``x``, or of its partial at ``f_hz``.

    Parameters
    ----------
    x, fs, f_hz, frame_s, hop_s
        As :func:`decay_curve_db`.
    start_db, stop_db : float
        Evaluation range below the curve's maximum (dB), 0 >= start_db >
        stop_db >= -120: the fit uses the frames after the maximum whose
        level lies in it (-5 .. -35: a T30).

    Returns
    -------
    float
        T60 (s) = -60 / slope of the fitted line (dB/s); ``inf`` if the
        fitted level does not fall.

    Raises
    ------
    ValueError
        A parameter out of range, or fewer than 3 frames in the range (the
        signal does not decay that far: render longer or narrow the range).
    """
    start_db = _real("start_db", start_db, -120.0, 0.0)
    stop_db = _real("stop_db", stop_db, -120.0, start_db, high_open=True)
    t, db = decay_curve_db(x, fs, f_hz, frame_s, hop_s)
    i0 = int(np.argmax(db))
    top = db[i0]
    t, db = t[i0:], db[i0:]
    # the first frame that falls below the range ends it (later noise is not fitted)
    below = np.flatnonzero(db < top + stop_db)
    end = int(below[0]) if below.size else len(db)
    sel = np.flatnonzero(db[:end] <= top + start_db)
    if sel.size < 3:
        raise ValueError(f"the level does not fall from {start_db:g} to {stop_db:g} dB below its "
                         f"maximum within the signal ({sel.size} frames in that range; at least "
                         f"3 needed)")
    slope = np.polyfit(t[sel], db[sel], 1)[0]
    return float(-60.0 / slope) if slope < 0 else float("inf")


def two_stage_decay(x, fs, f_hz=None, stop_db=-50.0, frame_s=None, hop_s=0.01, min_frames=3):
    """Early and late decay of ``x`` (or of its partial at ``f_hz``): two
    straight lines with a knee, fitted to the level curve.

    The curve (:func:`decay_curve_db`) is taken from its maximum until it
    first falls ``stop_db`` below it (or to the end).  Every knee frame with
    at least ``min_frames`` frames on each side is tried; the knee is the
    one whose two least-squares lines leave the smallest squared error (a
    piano's prompt sound and aftersound, Weinreich).  A single line over the
    same frames gives the overall T60.

    Returns
    -------
    dict
        ``t60_s`` (one line), ``t60_early_s``, ``t60_late_s`` (s; ``inf``
        where a line does not fall) and ``knee_s`` (time of the knee from
        the start of ``x``, s); the two-slope values are None when fewer
        than ``2 min_frames`` frames decay.

    Raises
    ------
    ValueError
        Fewer than 3 frames after the maximum.
    """
    stop_db = _real("stop_db", stop_db, -200.0, 0.0, high_open=True)
    t, db = decay_curve_db(x, fs, f_hz, frame_s, hop_s)
    i0 = int(np.argmax(db))
    t, db = t[i0:], db[i0:]
    below = np.flatnonzero(db < db[0] + stop_db)
    end = int(below[0]) if below.size else len(db)
    t, db = t[:end], db[:end]
    if len(t) < 3:
        raise ValueError(f"the level curve has {len(t)} frames after its maximum; at least 3 needed")

    def t60(slope):
        return float(-60.0 / slope) if slope < 0 else float("inf")

    one = np.polyfit(t, db, 1)[0]
    out = {"t60_s": t60(one), "t60_early_s": None, "t60_late_s": None, "knee_s": None}
    m = int(min_frames)
    if len(t) < 2 * m:
        return out
    k, s1, s2 = _best_knee(t, db, m)
    out.update(t60_early_s=t60(s1), t60_late_s=t60(s2), knee_s=float(t[k - 1]))
    return out


def _line_fits(t, y):
    """Least-squares lines through the first j points of (t, y), for every
    j = 1 .. n: (slope, squared error), each of shape (n,), from running
    sums of the centred data (j = 1: slope nan, error 0)."""
    t = t - t.mean()
    y = y - y.mean()
    j = np.arange(1, len(t) + 1, dtype=np.float64)
    st, sy = np.cumsum(t), np.cumsum(y)
    stt, sty, syy = np.cumsum(t * t), np.cumsum(t * y), np.cumsum(y * y)
    vt = stt - st * st / j
    cty = sty - st * sy / j
    vy = syy - sy * sy / j
    with np.errstate(divide="ignore", invalid="ignore"):
        slope = cty / vt
        err = np.where(vt > 0.0, vy - cty * slope, 0.0)
    return slope, np.maximum(err, 0.0)


def _best_knee(t, db, m):
    """The knee of :func:`two_stage_decay`: the frame count k (m .. n - m)
    whose lines through frames ``[0, k)`` and ``[k - 1, n)`` leave the
    smallest summed squared error, and the two slopes (dB/s).  All knees at
    once from running sums (two polyfits per knee took 0.11 s of a 2 s
    note's analysis)."""
    n = len(t)
    s_head, e_head = _line_fits(t, db)                  # lines through [0, j)
    s_tail, e_tail = _line_fits(t[::-1], db[::-1])      # lines through [n - j, n)
    ks = np.arange(m, n - m + 1)
    err = e_head[ks - 1] + e_tail[n - ks]               # [k - 1, n) has n - k + 1 points
    i = int(np.argmin(err))
    k = int(ks[i])
    return k, float(s_head[k - 1]), float(s_tail[n - k])


def two_stage_summary(x, fs, f_hz=None, stop_db=-50.0, hop_s=0.01, min_drop_db=6.0,
                      min_late_db=10.0, min_ratio=2.0):
    """The two-stage decay of ``x`` (or of its partial at ``f_hz``) as a
    listener reads it: :func:`two_stage_decay`'s early and late T60 and
    knee, their ratio late / early, how far the level has fallen at the
    knee (``knee_drop_db``) and how far it falls after it within the fit
    (``late_span_db``), both read off a 5-frame smoothing of the level
    curve, and whether the knee is visible: the level falls at least
    ``min_drop_db`` before it and ``min_late_db`` after it.

    Returns
    -------
    dict
        ``t60_early_s``, ``t60_late_s``, ``knee_s`` (None without a knee),
        ``ratio`` (late / early; inf when the late line does not fall; None
        without a knee), ``knee_drop_db``, ``late_span_db`` (dB, None
        without a knee) and ``visible`` (bool).
    """
    min_drop_db = _real("min_drop_db", min_drop_db, 0.0, 200.0)
    min_late_db = _real("min_late_db", min_late_db, 0.0, 200.0)
    min_ratio = _real("min_ratio", min_ratio, 0.0, 1e6)
    d = two_stage_decay(x, fs, f_hz=f_hz, stop_db=stop_db, hop_s=hop_s)
    out = {"t60_early_s": d["t60_early_s"], "t60_late_s": d["t60_late_s"], "knee_s": d["knee_s"],
           "ratio": None, "knee_drop_db": None, "late_span_db": None, "visible": False}
    if d["knee_s"] is None:
        return out
    t, db = decay_curve_db(x, fs, f_hz, None, hop_s)
    i0 = int(np.argmax(db))
    top = db[i0]
    t, db = t[i0:], db[i0:]
    below = np.flatnonzero(db < top + stop_db)
    end = int(below[0]) if below.size else len(db)
    t, db = t[:end], db[:end]
    k = int(np.argmin(np.abs(t - d["knee_s"])))
    sm = np.convolve(db, np.ones(5) / 5, mode="same")
    drop = float(top - sm[k])
    span = float(sm[k] - sm[max(len(sm) - 3, k)])
    e, late = d["t60_early_s"], d["t60_late_s"]
    ratio = (late / e) if (e and late and np.isfinite(e) and e > 0) else (np.inf if e else None)
    out.update(ratio=ratio, knee_drop_db=drop, late_span_db=span,
               visible=bool(ratio is not None and ratio >= min_ratio and drop >= min_drop_db
                            and span >= min_late_db))
    return out
