"""Stiff-string targets and what both dispersion designs share.

The partials f_n = n f0 sqrt(1 + B n^2) of a stiff string, the group delay
its loop needs, the default band of a design (partials up to
:data:`F_MAX_HZ`, at most :data:`N_PARTIALS_MAX`), the phase budget that
bounds any allpass cascade (:func:`phase_budget_sections`), the stiff
loop's one-pole loss filter, the range checks and the constants of
:mod:`synth.physics.dispersion.first_order` and
:mod:`synth.physics.dispersion.biquad`.
"""

from __future__ import annotations

import math

import numpy as np

from ..losses import loop_gain_from_t60, one_pole_from_two_gains

CENTS_PER_LN = 1200.0 / math.log(2.0)
#: Largest cascade the kernel is sized for (``synth.kernels.layout.MAX_DISP``;
#: physics may not import kernels, tests/test_constants.py keeps them equal).
M_LIMIT = 16
#: Fewest grid cells a stiff loop may keep (as :func:`losses.tune_loop`).
MIN_CELLS = 8
#: Default band of the design: partials up to this frequency (Hz) ...
F_MAX_HZ = 10000.0
#: ... and at most this many partials.
N_PARTIALS_MAX = 40
#: Default tolerance (cents) on every matched partial.
TOL_CENTS = 2.0


def _num(name: str, value, lo: float, hi: float, lo_open: bool = False,
         hi_open: bool = False) -> float:
    v = float(value)
    bad = (math.isnan(v) or v < lo or v > hi or (lo_open and v == lo)
           or (hi_open and v == hi))
    if bad:
        left = "<" if lo_open else "<="
        right = "<" if hi_open else "<="
        raise ValueError(f"{name} = {value!r} is out of range ({lo:g} {left} value {right} {hi:g})")
    return v


def _int(name: str, value, lo: int, hi: int) -> int:
    if isinstance(value, bool) or int(value) != value or not (lo <= int(value) <= hi):
        raise ValueError(f"{name} = {value!r} is out of range (integer, {lo} <= value <= {hi})")
    return int(value)


# ---------------------------------------------------------------------------
# stiff-string targets


def stiff_partials(f0_hz: float, B: float, n) -> np.ndarray:
    """Partial frequencies f_n = n f0 sqrt(1 + B n^2) (Hz) of a stiff string.

    Parameters
    ----------
    f0_hz : float
        Fundamental of the same string without stiffness (Hz), > 0.
    B : float
        Inharmonicity coefficient, >= 0.
    n : int or array of int
        Partial numbers (>= 1).
    """
    n = np.asarray(n, dtype=float)
    return n * f0_hz * np.sqrt(1.0 + B * n * n)


def partial_number(f_hz, f0_hz: float, B: float) -> np.ndarray:
    """The (real) partial number n at which f_n = f, inverse of :func:`stiff_partials`."""
    x2 = (np.asarray(f_hz, dtype=float) / f0_hz) ** 2
    return np.sqrt(2.0 * x2 / (1.0 + np.sqrt(1.0 + 4.0 * B * x2)))


def stiff_group_delay(f_hz, f0_hz: float, B: float, fs: float) -> np.ndarray:
    """Group delay (samples) the loop needs at f (Hz) for f_n = n f0 sqrt(1 + B n^2).

    fs dn/df = fs / f0 * sqrt(1 + B n^2) / (1 + 2 B n^2); equals fs / f0 when
    B = 0.  This is also the round-trip time that sets a mode's decay.
    """
    n2 = partial_number(f_hz, f0_hz, B) ** 2
    return fs / f0_hz * np.sqrt(1.0 + B * n2) / (1.0 + 2.0 * B * n2)


def default_n_partials(f0_hz: float, B: float, f_max_hz: float = F_MAX_HZ,
                       n_cap: int = N_PARTIALS_MAX) -> int:
    """How many partials a design matches by default: those up to
    ``f_max_hz``, at most ``n_cap``, at least 1."""
    n = np.arange(1, n_cap + 1)
    return max(1, int(np.count_nonzero(stiff_partials(f0_hz, B, n) <= f_max_hz)))


def phase_budget_sections(f0_hz: float, B: float, n_partials: int) -> float:
    """Lower bound on the number of first-order allpass sections (with any
    coefficients, identical or not, the tuning allpass included) that can put
    partials 1 .. K = n_partials of a stiff string on target.

    The rest of the loop is a delay L and filters of nearly flat phase delay.
    Between consecutive partials the allpass phase lag must not fall, so
    2 pi - (w_{n+1} - w_n) L >= 0 for every n, i.e. L <= fs / (f_K - f_{K-1});
    the allpasses must then lag 2 pi K - w_K L >= 2 pi (K - f_K / (f_K -
    f_{K-1})) at f_K, and a first-order section lags less than pi.
    Returns 0 for K < 2 or B = 0.
    """
    K = int(n_partials)
    if K < 2 or B == 0.0:
        return 0.0
    fK, fK1 = stiff_partials(f0_hz, B, [K, K - 1])
    return float(max(0.0, 2.0 * (K - fK / (fK - fK1))))


# ---------------------------------------------------------------------------
# the loss filter


def _stiff_loss_filter(f0: float, B: float, fs: float, t60_low_s: float, f_low_hz: float,
                       t60_high_s: float, f_high_hz: float) -> tuple[float, float]:
    """(b0, a1) of the one-pole loss filter of a stiff loop (see
    :func:`tune_stiff_loop`; parameters already checked)."""
    # loss filter: gain per round trip, the round trip being the stiff
    # loop's group delay at that frequency (fs / f0 when B = 0)
    f2 = min(f_high_hz, 0.45 * fs)
    tau_lo = float(stiff_group_delay(f_low_hz, f0, B, fs))
    tau_hi = float(stiff_group_delay(f2, f0, B, fs))
    g1 = loop_gain_from_t60(fs / tau_lo, t60_low_s)
    # a stiff loop's round trip is shorter at f_high, so a nearly flat T60
    # can ask for more gain there than at f_low: the one-pole then stays flat
    g2 = min(loop_gain_from_t60(fs / tau_hi, t60_high_s), g1)
    b0, a1 = one_pole_from_two_gains(g1, f_low_hz, g2, f2, fs)
    return float(b0), float(a1)
