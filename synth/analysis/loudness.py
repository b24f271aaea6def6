"""Loudness (ITU-R BS.1770-4 / EBU R 128) through pyloudnorm, and peak and crest.

Integrated loudness is pyloudnorm's :meth:`pyloudnorm.Meter.integrated_loudness`
(K-weighting, 400 ms blocks with 75 % overlap, absolute gate at -70 LUFS,
relative gate at -10 LU).  Momentary loudness (EBU Tech 3341: 400 ms
window, ungated) is the same meter applied to each 400 ms window of the
signal every ``hop_s``; each window is K-weighted on its own, so the first
few milliseconds of each carry the filters' start-up (the K filter's
highpass is at 38 Hz: a difference of a few hundredths of a LU on music,
measured in tests/test_loudness.py against a steady tone).
"""

from __future__ import annotations

import math

import numpy as np

from .spectrum import _positive, _signal

__all__ = ["loudness", "momentary_lufs", "max_momentary_lufs", "peak_dbfs", "crest_factor_db"]

#: loudness reported for silence (LUFS): below BS.1770's absolute gate
SILENT_LUFS = -np.inf


def _meter(fs, block_s=0.4):
    try:
        import pyloudnorm
    except ImportError:  # pragma: no cover - a core dependency
        raise ImportError("pyloudnorm is required for loudness: pip install pyloudnorm") from None
    return pyloudnorm.Meter(int(round(fs)), block_size=block_s)


def _integrated(meter, x):
    with np.errstate(divide="ignore"):
        v = float(meter.integrated_loudness(x))
    return v if np.isfinite(v) else SILENT_LUFS


def momentary_lufs(x, fs, hop_s=0.1):
    """Momentary loudness (LUFS, 400 ms windows every ``hop_s``) of a mono
    signal at ``fs`` (Hz); returns (window centres in s, loudness).  A
    signal shorter than 400 ms gives one value for the whole of it; silent
    windows read -inf."""
    fs = _positive("fs", fs)
    hop_s = _positive("hop_s", hop_s)
    x = _signal("x", x)
    n = int(round(0.4 * fs))
    if len(x) <= n:
        meter = _meter(fs, block_s=len(x) / fs)
        return np.array([0.5 * len(x) / fs]), np.array([_integrated(meter, x)])
    meter = _meter(fs)
    hop = max(1, int(round(hop_s * fs)))
    starts = np.arange(0, len(x) - n + 1, hop)
    vals = np.array([_integrated(meter, x[s:s + n]) for s in starts])
    return (starts + 0.5 * n) / fs, vals


def max_momentary_lufs(x, fs):
    """Maximum 400 ms momentary loudness (LUFS) of a mono signal at ``fs``
    (Hz), ungated: a note's loudness as a listener judges it.  The signal is
    measured at peak 1 and the gain taken off again (BS.1770 is linear up to
    its gates; pyloudnorm's absolute gate would read a note quieter than -70
    LUFS as silence); -inf for silence.  ``synth check``'s "momentary"
    measure and the voicing report's loudness."""
    fs = _positive("fs", fs)
    x = _signal("x", x)
    p = float(np.max(np.abs(x)))
    if p == 0.0:
        return SILENT_LUFS
    return float(np.max(momentary_lufs(x / p, fs)[1])) + 20.0 * math.log10(p)


def peak_dbfs(x):
    """Sample peak (dBFS, full scale = 1); -inf for silence."""
    x = _signal("x", x)
    p = float(np.max(np.abs(x)))
    return 20.0 * np.log10(p) if p > 0 else -np.inf


def crest_factor_db(x):
    """Peak over RMS (dB); nan for silence."""
    x = _signal("x", x)
    rms = float(np.sqrt(np.mean(x * x)))
    p = float(np.max(np.abs(x)))
    return 20.0 * np.log10(p / rms) if rms > 0 else float("nan")


def loudness(x, fs):
    """Loudness summary of a mono signal at ``fs`` (Hz).

    Returns
    -------
    dict
        ``integrated_lufs`` (BS.1770 gated; -inf when everything is below
        the -70 LUFS gate or the signal is shorter than one 400 ms block),
        ``max_momentary_lufs``, ``peak_dbfs``, ``crest_factor_db``.
    """
    fs = _positive("fs", fs)
    x = _signal("x", x)
    integrated = _integrated(_meter(fs), x) if len(x) >= int(round(0.4 * fs)) else SILENT_LUFS
    _, mom = momentary_lufs(x, fs)
    return {
        "integrated_lufs": integrated,
        "max_momentary_lufs": float(np.max(mom)),
        "peak_dbfs": peak_dbfs(x),
        "crest_factor_db": crest_factor_db(x),
    }
