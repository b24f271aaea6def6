"""How a buzz decays: a band's level in consecutive windows, and its
largest drop from one window to the next while the note still sounds.

A jawari's buzz is generated at the bridge for as long as the string
touches it; the band it fills (above a few kHz, where the linear string
has little) then follows the contact.  A contact that ends in one step
leaves the band to its own free decay, a sudden fall of the band from one
window to the next; a contact that shrinks with the amplitude lets it fade
with the note (docs/voicing.md, "The buzz decays with the note").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class BandDecay:
    """Per window of ``window_s`` from t = 0: ``t_s`` (window starts, s),
    ``band_db`` (energy between the band's edges, dB re 1, Hann window)
    and ``note_db`` (energy of the whole signal, dB re 1)."""

    t_s: np.ndarray
    band_db: np.ndarray
    note_db: np.ndarray
    window_s: float

    def smoothed_band_db(self, windows: int = 1) -> np.ndarray:
        """``band_db`` averaged (as energy) over ``windows`` (odd) windows
        centred on each; the ends over the windows there are."""
        w = int(windows)
        if w < 1 or w % 2 == 0:
            raise ValueError(f"windows = {windows!r} is out of range (an odd number >= 1)")
        if w == 1:
            return self.band_db.copy()
        p = 10.0 ** (self.band_db / 10.0)
        h = w // 2
        out = np.empty_like(p)
        for i in range(len(p)):
            out[i] = np.mean(p[max(0, i - h):i + h + 1])
        return 10.0 * np.log10(out)

    def largest_drop(self, within_db: float = 40.0, skip_s: float = 0.1, smooth: int = 1):
        """(drop dB, t_s): the largest fall of the band (``band_db``, or
        its running mean over ``smooth`` windows: :meth:`smoothed_band_db`)
        from one window to the next, over the windows from ``skip_s`` on
        whose note level is within ``within_db`` of the first window's (the
        note "still sounds"); (0.0, nan) when no pair qualifies.  The pair
        counts when its first window qualifies, and its mean takes no
        window before ``skip_s`` (the pluck's own transient).  ``t_s`` is the
        start of the window the band falls into."""
        b = self.smoothed_band_db(smooth)
        first = skip_s + (int(smooth) // 2) * self.window_s
        ok = (self.note_db >= self.note_db[0] - within_db) & (self.t_s >= first - 1e-9)
        best, at = 0.0, float("nan")
        for i in range(len(self.t_s) - 1):
            if ok[i]:
                d = b[i] - b[i + 1]
                if d > best:
                    best, at = float(d), float(self.t_s[i + 1])
        return best, at

    def largest_fall(self, span_s: float = 0.2, start_s: float = 0.3, end_s: float = 2.5):
        """(fall dB, t_s): the largest fall of ``band_db`` over ``span_s``
        (s, a whole number of windows) between two windows that both lie
        within ``start_s`` .. ``end_s`` (s); ``t_s`` is the start of the
        window it falls into; (0.0, nan) when no pair of windows fits."""
        w = self.window_s
        k = int(round(span_s / w))
        if k < 1 or abs(k * w - span_s) > 1e-9 * max(1.0, span_s):
            raise ValueError(f"span_s = {span_s!r} is out of range (a whole number >= 1 of "
                             f"window_s = {w:g} s)")
        if not (0.0 <= start_s < end_s):
            raise ValueError(f"start_s..end_s = {start_s!r}..{end_s!r} is out of range "
                             f"(0 <= start_s < end_s)")
        b, t = self.band_db, self.t_s
        best, at = 0.0, float("nan")
        for i in range(len(t) - k):
            if t[i] >= start_s - 1e-9 and t[i + k] + w <= end_s + 1e-9:
                fall = float(b[i] - b[i + k])
                if fall > best:
                    best, at = fall, float(t[i + k])
        return best, at


def largest_fall_db(y, fs_hz: float, f_lo_hz: float, f_hi_hz: float, span_s: float = 0.2,
                    start_s: float = 0.3, end_s: float = 2.5, window_s: float = 0.1):
    """(fall dB, t_s): :meth:`BandDecay.largest_fall` of the band f_lo..f_hi
    (Hz) of ``y`` in windows of ``window_s`` (:func:`band_decay`).  A
    contact that ends in one step shows as one large fall (the biwa's
    sawari on the grid: 31 dB in 200 ms at its knee); a buzz that fades with
    the note falls about as fast as the note's own high partials (issue
    40: at most 15 dB)."""
    return band_decay(y, fs_hz, f_lo_hz, f_hi_hz, window_s).largest_fall(span_s, start_s, end_s)


def band_decay(y, fs_hz: float, f_lo_hz: float = 6000.0, f_hi_hz: float = 20000.0,
               window_s: float = 0.1) -> BandDecay:
    """The band f_lo..f_hi (Hz) and the whole signal of ``y`` (sampled at
    ``fs_hz``) in consecutive windows of ``window_s`` (s), each one
    Hann-windowed spectrum (:class:`BandDecay`)."""
    x = np.asarray(y, float)
    if x.ndim > 1:
        x = x.mean(axis=1)
    n = int(round(window_s * fs_hz))
    if n < 16 or len(x) < 2 * n:
        raise ValueError(f"window_s = {window_s!r} is out of range (16 samples <= window <= half "
                         f"the signal, {len(x)} samples at {fs_hz:g} Hz)")
    if not (0.0 <= f_lo_hz < f_hi_hz):
        raise ValueError(f"band {f_lo_hz:g}..{f_hi_hz:g} Hz is out of range (0 <= f_lo < f_hi)")
    m = len(x) // n
    seg = x[: m * n].reshape(m, n) * np.hanning(n)
    S = np.abs(np.fft.rfft(seg, axis=1)) ** 2
    f = np.fft.rfftfreq(n, 1.0 / fs_hz)
    sel = (f >= f_lo_hz) & (f < f_hi_hz)
    tiny = 1e-300
    return BandDecay(np.arange(m) * window_s, 10.0 * np.log10(S[:, sel].sum(axis=1) + tiny),
                     10.0 * np.log10(S.sum(axis=1) + tiny), float(window_s))
