"""Clicks: where a rendering's output jumps instead of moving smoothly.

Written with recipe 3 of ``docs/architecture.md`` (numpy only, explicit
``fs``, arrays in).

The signal is cut into frames of ``frame_s`` (5 ms) and every frame gets two
scores:

* **jump** (dB): the largest magnitude of the second difference
  ``d[n] = x[n+1] - 2 x[n] + x[n-1]`` in the frame over the RMS of ``d`` in
  the ``context_frames`` frames on either side (the frame itself left out).
  A sum of partials, or a felt hammer's force pulse, moves smoothly from
  sample to sample and reads a few dB (a steady sine: 3.01 dB, its crest
  factor); a step or a spike of height ``a`` adds ``a`` to ``d`` at one
  sample and stands out of its surroundings by ``20 log10(a / rms(d))``.
  Because the context is the neighbours' RMS, an onset after silence (the
  frames after it are as loud) is not taken for a click.
* **high band** (dB): the share of the frame's energy above
  ``highband_hz`` (Hann window): the scan of ``docs/reproduction.md``
  ("Clicks").  It finds high-frequency bursts (an
  alternating jump), but not a low step, and a high note's own partials
  above 14 kHz read like a click (a lone C8 reaches -12 dB).

Frames more than ``floor_db`` below the loudest frame are not judged, nor
those of ``ignore_s`` (e.g. the notes' onsets).
"""

from __future__ import annotations

import numpy as np

from .spectrum import _int, _positive, _real, _signal

__all__ = ["click_scan"]


def click_scan(x, fs, frame_s=0.005, context_frames=5, floor_db=-50.0, highband_hz=14000.0,
               ignore_s=(), ignore_window_s=0.01):
    """Scan ``x`` for clicks, frame by frame.

    Parameters
    ----------
    x : array_like, 1-D
        Signal (full scale 1), at least ``2 context_frames + 1`` frames long.
    fs : float
        Sample rate (Hz), > 0.
    frame_s : float
        Frame length (s), > 0, at least 16 samples; default 5 ms.
    context_frames : int
        Frames on each side whose second difference is the reference of a
        frame's jump, 1 .. 100; default 5 (25 ms either side).
    floor_db : float
        Frames whose RMS level is more than this below the loudest frame's
        are not judged (dB, -200 .. 0); default -50.
    highband_hz : float
        Lower edge of the high band (Hz), 0 < highband_hz < fs/2.
    ignore_s : array_like
        Times (s) whose frames are not judged: the frames overlapping
        [t, t + ``ignore_window_s``] for each t (a note's attack: a
        hammer's first millisecond moves the output as sharply as a click,
        and is meant to).
    ignore_window_s : float
        Length (s, >= 0) after each ignored time; default 10 ms.

    Returns
    -------
    dict
        ``time_s`` (frame starts), ``level_db`` (frame RMS level re the
        loudest frame), ``jump_db``, ``highband_db`` (per frame; -inf where
        not judged), ``judged`` (bool per frame), and ``worst_jump_db``,
        ``worst_jump_s``, ``worst_highband_db``, ``worst_highband_s`` (the
        largest score over the judged frames and its frame's start; -inf and
        None for a silent signal).
    """
    fs = _positive("fs", fs)
    frame_s = _positive("frame_s", frame_s)
    k = _int("context_frames", context_frames, 1, 100)
    floor_db = _real("floor_db", floor_db, -200.0, 0.0)
    highband_hz = _real("highband_hz", highband_hz, 0.0, fs / 2, low_open=True, high_open=True)
    n = int(round(frame_s * fs))
    if n < 16:
        raise ValueError(f"frame_s={frame_s!r} out of range: must hold at least 16 samples "
                         f"(>= {16 / fs:g} s at fs={fs:g})")
    x = _signal("x", x, min_len=(2 * k + 1) * n)
    frames = len(x) // n
    xf = x[:frames * n].reshape(frames, n)
    # second difference, aligned with x (d[i] belongs to sample i; ends 0)
    d = np.zeros(frames * n)
    d[1:-1] = np.diff(x[:frames * n], 2)
    df = d.reshape(frames, n)
    peak = np.max(np.abs(df), axis=1)
    ms = np.mean(df * df, axis=1)
    # neighbours' mean square, the frame itself left out (edges: the frames there are)
    c = np.concatenate(([0.0], np.cumsum(ms)))
    i = np.arange(frames)
    lo, hi = np.maximum(i - k, 0), np.minimum(i + k + 1, frames)
    ctx = (c[hi] - c[lo] - ms) / np.maximum(hi - lo - 1, 1)
    # energy above highband_hz, Hann window
    w = np.hanning(n)
    P = np.abs(np.fft.rfft(xf * w, axis=1)) ** 2
    f = np.fft.rfftfreq(n, 1.0 / fs)
    tot = P.sum(axis=1)
    high = P[:, f >= highband_hz].sum(axis=1)
    rms = np.sqrt(np.mean(xf * xf, axis=1))
    top = float(rms.max())
    with np.errstate(divide="ignore", invalid="ignore"):
        level = np.where(rms > 0, 20.0 * np.log10(rms / top), -np.inf) if top > 0 else \
            np.full(frames, -np.inf)
        judged = level >= floor_db
        ign = np.asarray(ignore_s, dtype=float).ravel()
        if ign.size:
            if not np.all(np.isfinite(ign)):
                raise ValueError("ignore_s must hold finite times (s)")
            w = _real("ignore_window_s", ignore_window_s, 0.0, 10.0)
            a = np.floor(ign * fs / n).astype(np.int64)
            b = np.floor((ign + w) * fs / n).astype(np.int64)
            mask = np.zeros(frames + 1, dtype=np.int64)
            a, b = np.clip(a, 0, frames), np.clip(b + 1, 0, frames)
            np.add.at(mask, a, 1)
            np.add.at(mask, b, -1)
            judged &= np.cumsum(mask)[:frames] == 0
        jump = np.where(judged & (peak > 0),
                        20.0 * np.log10(peak / np.sqrt(np.maximum(ctx, 1e-300))), -np.inf)
        hb = np.where(judged & (tot > 0), 10.0 * np.log10(np.maximum(high, 1e-300) / tot), -np.inf)
    out = {"time_s": i * n / fs, "level_db": level, "jump_db": jump, "highband_db": hb,
           "judged": judged}
    for name, v in (("jump", jump), ("highband", hb)):
        j = int(np.argmax(v))
        ok = bool(judged.any() and np.isfinite(v[j]))
        out[f"worst_{name}_db"] = float(v[j]) if ok else -np.inf
        out[f"worst_{name}_s"] = float(j * n / fs) if ok else None
    return out
