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

__all__ = ["loudness", "momentary_lufs", "max_momentary_lufs", "peak_dbfs", "crest_factor_db",
           "IntegratedLoudness"]

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


class IntegratedLoudness:
    """The integrated loudness (BS.1770, as :func:`loudness` reads it) of a
    signal given block by block, holding one number per 100 ms: a long
    render is measured as it is written, without being kept.

    The K-weighting is pyloudnorm's filters run on with their state from
    block to block, and the gating blocks (400 ms every 100 ms, the last
    one cut at the end, mono or up to five channels with BS.1770's
    weights) are pyloudnorm's: the same number as
    ``pyloudnorm.Meter(fs).integrated_loudness`` on the whole signal, to
    round-off (tests/test_drone.py).

    Parameters
    ----------
    fs : float
        Sample rate (Hz); 0.1 s must be a whole number of samples.
    channels : int
        1 to 5.
    """

    G = (1.0, 1.0, 1.0, 1.41, 1.41)

    def __init__(self, fs, channels: int = 1):
        from scipy.signal import lfilter_zi

        self.fs = _positive("fs", fs)
        self.hop = int(round(0.1 * self.fs))
        if abs(self.hop - 0.1 * self.fs) > 1e-9 or not 1 <= int(channels) <= 5:
            raise ValueError(f"fs = {fs!r}, channels = {channels!r}: 0.1 s must be whole samples, "
                             "1 <= channels <= 5")
        self.channels = int(channels)
        meter = _meter(self.fs)
        self._stages = [(f.b, f.a, f.passband_gain) for f in meter._filters.values()]
        self._zi = [np.zeros((self.channels, len(lfilter_zi(b, a)))) for b, a, _ in self._stages]
        self._sums: list = []               # per 100 ms: sum of squares per channel
        self._acc = np.zeros(self.channels)  # the 100 ms under way
        self._fill = 0
        self.n = 0

    def add(self, x) -> None:
        """The next samples: shape (frames,) or (frames, channels)."""
        from scipy.signal import lfilter

        x = np.asarray(x, dtype=np.float64)
        x = x.reshape(len(x), -1)
        if x.shape[1] != self.channels:
            raise ValueError(f"{x.shape[1]} channels given, {self.channels} expected")
        y = x.T.copy()
        for k, (b, a, g) in enumerate(self._stages):
            y, self._zi[k] = lfilter(b, a, y, axis=1, zi=self._zi[k])
            y = g * y
        sq = y * y
        i = 0
        n = sq.shape[1]
        while i < n:
            take = min(self.hop - self._fill, n - i)
            self._acc += sq[:, i:i + take].sum(axis=1)
            self._fill += take
            i += take
            if self._fill == self.hop:
                self._sums.append(self._acc.copy())
                self._acc[:] = 0.0
                self._fill = 0
        self.n += n

    def lufs(self) -> float:
        """The integrated loudness so far (LUFS; -inf: silent, or under 400 ms)."""
        n_block = 4 * self.hop
        if self.n < n_block:
            return SILENT_LUFS
        sums = list(self._sums) + ([self._acc.copy()] if self._fill else [])
        s = np.array(sums)                                   # (hops, channels)
        n_blocks = int(np.round((self.n / self.fs - 0.4) / 0.1)) + 1
        z = np.array([s[j:j + 4].sum(axis=0) for j in range(n_blocks)]) / n_block
        g = np.array(self.G[:self.channels])
        with np.errstate(divide="ignore"):
            lj = -0.691 + 10.0 * np.log10(z @ g)
        keep = lj >= -70.0
        if not keep.any():
            return SILENT_LUFS
        gamma_r = -0.691 + 10.0 * np.log10(z[keep].mean(axis=0) @ g) - 10.0
        keep = (lj > gamma_r) & (lj > -70.0)
        if not keep.any():
            return SILENT_LUFS
        v = -0.691 + 10.0 * np.log10(z[keep].mean(axis=0) @ g)
        return float(v) if np.isfinite(v) else SILENT_LUFS
