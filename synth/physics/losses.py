"""Losses and tuning of the musical (played, not studied) string.

The ideal string is lossless and its loop is 2N grid samples long.  A played
string needs (i) frequency-dependent loss, lumped at x = L as a one-pole
filter set from T60 at two frequencies, and (ii) exact tuning at any f0,
which the integer grid cannot give: a first-order allpass (and, if needed,
one extra unit delay) in the same far-end filter supplies the fractional
part.  Everything nonlinear (the termination region near x = 0) stays on the
grid.

Loop (round trip) at frequency f: gain |H(f)| = 10^(-3 / (f0 T60(f))), i.e.
the amplitude falls by 60 dB in T60 seconds; phase delay
2N + d_lp(f0) + d_int + d_ap(f0) = fs / f0 samples exactly at f0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


def loop_gain_from_t60(f0_hz: float, t60_s: float) -> float:
    """Round-trip amplitude gain that gives decay time ``t60_s`` at a loop
    frequency ``f0_hz``: 10^(-3 / (f0 T60))."""
    return 10.0 ** (-3.0 / (f0_hz * t60_s))


def one_pole_from_two_gains(g1: float, f1_hz: float, g2: float, f2_hz: float, fs: float):
    """One-pole lowpass H(z) = b0 / (1 + a1 z^-1) with |H| = g1 at f1 and g2 at f2.

    Parameters
    ----------
    g1, g2 : float
        Magnitudes (0 < g2 <= g1 < 1).
    f1_hz, f2_hz : float
        Frequencies (0 < f1 < f2 < fs/2).
    fs : float
        Sample rate of the loop (Hz).

    Returns
    -------
    (b0, a1) with -1 < a1 <= 0.  When the requested tilt is steeper than a
    one-pole allows, the steepest one-pole (pole at 0.999) is used and g1 is
    honoured.  The gain at DC, b0 / (1 + a1), is kept at or below
    ``1 - (1 - g1) / 2`` (the loop's DC content decays at least half as fast
    as its partial at f1): a lowpass's gain rises towards DC, and a steep
    tilt on a long, high string (the grand's top octave: T60 of seconds at
    4 kHz, the high-frequency loss law steeper still) would otherwise pass
    DC with a gain above 1 and the loop would grow.  The tilt is then
    shallower than asked (|H| at f2 above g2), with g1 still exact.
    """
    if not (0 < g2 <= g1 < 1):
        raise ValueError(f"loop gains g1 = {g1!r}, g2 = {g2!r} must satisfy 0 < g2 <= g1 < 1")
    w1, w2 = 2 * math.pi * f1_hz / fs, 2 * math.pi * f2_hz / fs
    if g1 == g2:
        return g1, 0.0
    D = g1 * g1 - g2 * g2
    Bq = (g1 * g1 * math.cos(w1) - g2 * g2 * math.cos(w2)) / D
    if Bq * Bq <= 1.0:
        a = -0.999
    else:
        a = -Bq + math.sqrt(Bq * Bq - 1.0) if Bq > 0 else -Bq - math.sqrt(Bq * Bq - 1.0)
        a = max(a, -0.999)
    b0 = g1 * math.sqrt(1.0 + 2.0 * a * math.cos(w1) + a * a)
    g_dc = 1.0 - 0.5 * (1.0 - g1)
    if b0 / (1.0 + a) > g_dc:
        # |H(0)| = g_dc and |H(w1)| = g1: g_dc^2 (1 + a)^2 = g1^2 (1 + 2 a cos w1 + a^2),
        # a^2 + 2 (c / r) a + 1 = 0 with r = g_dc^2 - g1^2, c = g_dc^2 - g1^2 cos w1
        r = g_dc * g_dc - g1 * g1
        c = (g_dc * g_dc - g1 * g1 * math.cos(w1)) / r
        a = -c + math.sqrt(c * c - 1.0)
        b0 = g_dc * (1.0 + a)
    return b0, a


def one_pole_phase_delay(a1: float, w: float) -> float:
    """Phase delay (samples) of b0 / (1 + a1 z^-1) at angular frequency w (rad/sample)."""
    phase = -math.atan2(-a1 * math.sin(w), 1.0 + a1 * math.cos(w))
    return -phase / w


def allpass_for_phase_delay(d: float, w: float) -> float:
    """Coefficient eta of A(z) = (eta + z^-1) / (1 + eta z^-1) whose phase
    delay at w (rad/sample) is exactly ``d`` samples (0 < d < 2)."""
    return math.sin((1.0 - d) * w / 2.0) / math.sin((1.0 + d) * w / 2.0)


def allpass_phase_delay(eta: float, w: float) -> float:
    """Phase delay (samples) of the first-order allpass at w."""
    z = complex(math.cos(w), -math.sin(w))
    H = (eta + z) / (1.0 + eta * z)
    ph = math.atan2(H.imag, H.real)
    if ph > 0:
        ph -= 2 * math.pi
    return -ph / w


@dataclass(frozen=True)
class LoopTuning:
    """Far-end filter of a musical string.

    cells : N (the loop is 2N grid samples plus the filter).
    b0, a1 : one-pole loss filter.
    eta : allpass coefficient.
    extra_delay : 0 or 1 additional unit delay.
    """

    cells: int
    b0: float
    a1: float
    eta: float
    extra_delay: int
    fs: float
    f0_hz: float

    def total_phase_delay(self, f_hz: float | None = None) -> float:
        """Loop phase delay (samples) at f (default f0)."""
        w = 2 * math.pi * (self.f0_hz if f_hz is None else f_hz) / self.fs
        return (2 * self.cells + one_pole_phase_delay(self.a1, w) + self.extra_delay
                + allpass_phase_delay(self.eta, w))


def tune_loop(f0_hz: float, fs: float, t60_low_s: float, f_low_hz: float,
              t60_high_s: float, f_high_hz: float, fixed_delay: float = 0.0) -> LoopTuning:
    """Choose N, the loss filter and the fractional delay so that the loop
    resonates at exactly ``f0_hz`` with the requested decay times.

    fixed_delay : samples of the loop taken by something else at x = L (the
        pitch-bend line's rest delay), left out of the grid.
    Raises ValueError if f0 is too high for the rate (fewer than 8 cells).
    """
    if not (0 < f0_hz < fs / 16):
        raise ValueError(f"f0_hz = {f0_hz!r} is out of range (0 < value < fs/16 = {fs / 16:g})")
    g1 = loop_gain_from_t60(f0_hz, t60_low_s)
    g2 = loop_gain_from_t60(f0_hz, t60_high_s)
    f2 = min(f_high_hz, 0.45 * fs)
    b0, a1 = one_pole_from_two_gains(g1, f_low_hz, g2, f2, fs)
    w0 = 2 * math.pi * f0_hz / fs
    rest = fs / f0_hz - one_pole_phase_delay(a1, w0) - fixed_delay
    N = int(math.floor((rest - 0.5) / 2.0))
    rem = rest - 2 * N  # in [0.5, 2.5)
    extra = 0
    if rem >= 1.5:
        extra, rem = 1, rem - 1.0
    eta = allpass_for_phase_delay(rem, w0)
    return LoopTuning(N, b0, a1, eta, extra, float(fs), float(f0_hz))
