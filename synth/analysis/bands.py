"""Energy in narrow bands, and the sympathetic halo of two takes of a note.

Written with recipe 3 of ``docs/architecture.md`` (numpy only, explicit
``fs``, arrays in).

:func:`band_levels_db` is the mean square of a signal within frequency
bands, from one Hann-windowed spectrum of the whole signal (Parseval: the
one-sided power of the bins in a band, over ``N sum(w^2)``), so that a
steady sine of amplitude A inside a band reads ``10 log10(A^2 / 2)``.

:func:`halo` compares two takes of the same note, e.g. held with the
sustain pedal down and up.  With the dampers lifted the other strings are
free to ring along (sympathetic resonance): energy appears at *their*
frequencies, which the note alone does not have.  The halo is measured in
bands around those frequencies (``probe_hz``, e.g. the partial-1
frequencies of the other keys) that lie away from the note's own partials
(``exclude_hz``): their total energy in the take with, over the take
without, in dB.  The plain difference of the two takes is given too (-inf
when they are identical sample for sample).
"""

from __future__ import annotations

import numpy as np

from .spectrum import _positive, _real, _signal

__all__ = ["band_centroid_hz", "band_db", "band_levels_db", "halo", "highband_db", "highband_energy",
           "window_energy_db"]


def _bins(n, fs):
    n_fft = 1 << max(0, int(2 * n - 1).bit_length())      # >= 2n: zero padding
    return n_fft, np.fft.rfftfreq(n_fft, 1.0 / fs)


def _power(x, n_fft):
    w = np.hanning(len(x))
    X = np.fft.rfft(w * x, n_fft)
    p = 2.0 * (X.real ** 2 + X.imag ** 2) / (n_fft * np.sum(w * w))
    p[0] *= 0.5
    if n_fft % 2 == 0:
        p[-1] *= 0.5
    return p


def _edges(centres_hz, half_width_hz, fs, n):
    c = np.atleast_1d(np.asarray(centres_hz, dtype=np.float64))
    h = np.broadcast_to(np.asarray(half_width_hz, dtype=np.float64), c.shape)
    if c.ndim != 1 or not np.all(np.isfinite(c) & (c > 0) & (c < fs / 2)):
        raise ValueError(f"centres_hz must be frequencies in (0, fs/2 = {fs / 2:g}) Hz")
    if not np.all(np.isfinite(h) & (h > 0)):
        raise ValueError("half_width_hz must be finite and > 0 Hz")
    # never narrower than the Hann main lobe (2 bins of the unpadded length)
    h = np.maximum(h, 2.0 * fs / n)
    return c - h, c + h


def band_levels_db(x, fs, centres_hz, half_width_hz):
    """Mean-square level (dB re full scale squared) of ``x`` in each band
    ``centre +- half_width``.

    Parameters
    ----------
    x : array_like, 1-D
        Signal, at least 64 samples.
    fs : float
        Sample rate (Hz), > 0.
    centres_hz : array_like
        Band centres (Hz), in (0, fs/2).
    half_width_hz : float or array_like
        Half width of each band (Hz), > 0; widened to the Hann window's main
        lobe (2 fs / len(x)) where narrower.

    Returns
    -------
    ndarray
        ``10 log10`` of the band's mean square, per band (-inf for no
        energy): a sine of amplitude A inside the band (and farther than the
        main lobe from its edges) reads ``10 log10(A^2 / 2)``, white noise of
        variance s^2 reads ``10 log10(s^2 * bandwidth / (fs / 2))``.
    """
    fs = _positive("fs", fs)
    x = _signal("x", x, min_len=64)
    lo, hi = _edges(centres_hz, half_width_hz, fs, len(x))
    n_fft, f = _bins(len(x), fs)
    p = _power(x, n_fft)
    c = np.concatenate(([0.0], np.cumsum(p)))
    a = np.searchsorted(f, lo, side="left")
    b = np.searchsorted(f, hi, side="right")
    e = c[b] - c[a]
    with np.errstate(divide="ignore"):
        return np.where(e > 0, 10.0 * np.log10(np.maximum(e, 1e-300)), -np.inf)


def halo(x_with, x_without, fs, probe_hz, exclude_hz=(), probe_cents=10.0, exclude_cents=40.0):
    """The sympathetic halo of take ``x_with`` against take ``x_without``.

    Parameters
    ----------
    x_with, x_without : array_like, 1-D, same length (>= 64 samples)
        The same note played two ways (e.g. sustain pedal down and up),
        cut to the same stretch of time.
    fs : float
        Sample rate (Hz), > 0.
    probe_hz : array_like
        Frequencies where the halo may ring (Hz), in (0, fs/2): e.g. the
        partial-1 frequencies of the other keys.
    exclude_hz : array_like
        The note's own partials (Hz): a probe within ``exclude_cents`` of
        one is left out.
    probe_cents : float
        Half width of each probe band (cents, 0 < value <= 50), widened to
        the window's main lobe; overlapping bands are counted once.
    exclude_cents : float
        Distance (cents, >= 0) from the note's partials within which a probe
        is left out.

    Returns
    -------
    dict
        ``difference_db``: ``10 log10(sum (x_with - x_without)^2 / sum
        x_without^2)`` (-inf: identical); ``gain_db``: energy in the probe
        bands of ``x_with`` over that of ``x_without`` (dB; +inf if only
        ``x_with`` has any, nan if neither); ``level_with_db``,
        ``level_without_db``: the probe bands' energy re the whole take's
        (dB); ``probes_hz``: the probes used.
    """
    fs = _positive("fs", fs)
    a = _signal("x_with", x_with, min_len=64)
    b = _signal("x_without", x_without, min_len=64)
    if len(a) != len(b):
        raise ValueError(f"x_with has {len(a)} samples and x_without {len(b)}; they must be equal")
    probe_cents = _real("probe_cents", probe_cents, 0.0, 50.0, low_open=True)
    exclude_cents = _real("exclude_cents", exclude_cents, 0.0, 1200.0)
    p = np.atleast_1d(np.asarray(probe_hz, dtype=np.float64))
    ex = np.atleast_1d(np.asarray(exclude_hz, dtype=np.float64))
    if p.size == 0:
        raise ValueError("probe_hz is empty: give at least one probe frequency")
    if ex.size and not np.all(np.isfinite(ex) & (ex > 0)):
        raise ValueError("exclude_hz must be finite frequencies > 0 Hz")
    if ex.size:
        d = np.abs(1200.0 * np.log2(p[:, None] / ex[None, :])).min(axis=1)
        p = p[d > exclude_cents]
    if p.size == 0:
        raise ValueError("every probe lies within exclude_cents of an excluded frequency")
    lo, hi = _edges(p, p * (2.0 ** (probe_cents / 1200.0) - 1.0), fs, len(a))
    n_fft, f = _bins(len(a), fs)
    mask = np.zeros(len(f), dtype=bool)
    for l, h in zip(lo, hi):
        mask[np.searchsorted(f, l, side="left"):np.searchsorted(f, h, side="right")] = True
    pa, pb = _power(a, n_fft), _power(b, n_fft)
    ea, eb = float(pa[mask].sum()), float(pb[mask].sum())

    def db(num, den):
        if den > 0:
            return 10.0 * np.log10(num / den) if num > 0 else -np.inf
        return np.inf if num > 0 else np.nan

    diff = float(np.sum((a - b) ** 2))
    return {
        "difference_db": float(db(diff, float(np.sum(b * b)))),
        "gain_db": float(db(ea, eb)),
        "level_with_db": float(db(ea, float(pa.sum()))),
        "level_without_db": float(db(eb, float(pb.sum()))),
        "probes_hz": p,
    }


def highband_energy(x, fs, above_hz, start_s=None, length_s=None):
    """Energy above ``above_hz`` (a sum of squared spectrum magnitudes, linear)
    of ``x`` (1-D, sampled at ``fs`` Hz), or of its window from ``start_s``
    (s, default 0) for ``length_s`` (s, default to the end), from one
    Hann-windowed spectrum: the buzz measure of issue 12 (a render's high
    band over the same note's with buzz 0, or with a rigid end)."""
    x = np.asarray(x, float)
    if start_s is not None or length_s is not None:
        a = int(round((start_s or 0.0) * fs))
        x = x[a:] if length_s is None else x[a:a + int(round(length_s * fs))]
    spec = np.abs(np.fft.rfft(x * np.hanning(len(x)))) ** 2
    f = np.fft.rfftfreq(len(x), 1.0 / fs)
    return float(np.sum(spec[f >= above_hz]))


def highband_db(x, fs, above_hz, start_s=None, length_s=None):
    """:func:`highband_energy` in dB (re a unit sum of squared spectrum
    magnitudes; -inf if none)."""
    e = highband_energy(x, fs, above_hz, start_s, length_s)
    return 10.0 * np.log10(e) if e > 0 else -np.inf


def window_energy_db(x, fs, start_s, end_s):
    """Energy of ``x`` (1-D, sampled at ``fs`` Hz) from ``start_s`` to
    ``end_s`` (s): 10 log10 of the sum of its squared samples (-inf if
    they are all zero)."""
    x = np.asarray(x, float)[int(round(start_s * fs)):int(round(end_s * fs))]
    e = float(np.sum(x * x))
    return 10.0 * np.log10(e) if e > 0 else -np.inf


def _band_spectrum(x, fs, lo_hz, hi_hz, start_s, end_s):
    """Power spectrum (squared magnitudes of one Hann-windowed FFT) of
    ``x[start_s:end_s]`` and its frequencies, within ``lo_hz <= f < hi_hz``."""
    fs = _positive("fs", fs)
    x = _signal("x", x, min_len=2)
    lo, hi = _real("lo_hz", lo_hz, 0.0), _real("hi_hz", hi_hz, 0.0, fs / 2)
    if not lo < hi:
        raise ValueError(f"lo_hz = {lo_hz!r} is out of range (below hi_hz = {hi_hz!r})")
    a, b = int(round(_real("start_s", start_s, 0.0) * fs)), int(round(_real("end_s", end_s, 0.0) * fs))
    seg = x[a:b]
    if len(seg) < 2 or b - a > len(seg):
        raise ValueError(f"end_s = {end_s!r} is out of range (after start_s = {start_s!r}, "
                         f"within the signal's {len(x) / fs:g} s)")
    S = np.abs(np.fft.rfft(seg * np.hanning(len(seg)))) ** 2
    f = np.fft.rfftfreq(len(seg), 1.0 / fs)
    sel = (f >= lo) & (f < hi)
    return f[sel], S[sel]


def band_centroid_hz(x, fs, lo_hz, hi_hz, start_s, end_s):
    """Spectral centroid (Hz) of ``x`` (1-D, sampled at ``fs`` Hz) within the
    band ``lo_hz`` .. ``hi_hz`` over ``start_s`` .. ``end_s`` (s): the power-
    weighted mean frequency sum(f S) / sum(S) of one Hann-windowed spectrum
    of that span.  The tanpura's signature (issue 40) is this centre over
    2-8 kHz falling as the note decays: the jawari's band of overtones (the
    "precursor" of van Walstijn & Chatziioannou, ISMA 2014) moves down as
    the swing, and with it the string's wrap over the bridge, shrinks.
    NaN when the band holds no energy."""
    f, S = _band_spectrum(x, fs, lo_hz, hi_hz, start_s, end_s)
    tot = float(np.sum(S))
    return float(np.sum(f * S) / tot) if tot > 0 else float("nan")


def band_db(x, fs, lo_hz, hi_hz, start_s, end_s):
    """Energy (dB re a unit sum of squared spectrum magnitudes; -inf if
    none) of ``x`` within ``lo_hz`` .. ``hi_hz`` over ``start_s`` ..
    ``end_s`` (s), from the same spectrum as :func:`band_centroid_hz`: two
    takes of a note compared over one span and band (the tanpura's band over
    the same note at ``termination.buzz = 0``)."""
    _, S = _band_spectrum(x, fs, lo_hz, hi_hz, start_s, end_s)
    e = float(np.sum(S))
    return 10.0 * np.log10(e) if e > 0 else -np.inf
