"""First-order allpass dispersion: M identical sections in a stiff loop.

The loop of a musical string (see :mod:`synth.physics.losses`) is 2N grid
samples, a one-pole loss filter, an optional unit delay and a first-order
tuning allpass.  Here a cascade of M identical first-order allpass sections

    A_d(z) = (a + z^-1) / (1 + a z^-1),      -1 < a < 1,

joins them.  With a < 0 a section's phase delay falls from (1 - a)/(1 + a)
samples at DC towards 1 at Nyquist, so high partials travel round the loop
faster than low ones: the partials stretch.

Design rule.  Partial n is a resonance of the loop when the loop's total
phase at f_n is -2 pi n, i.e. its total phase delay at f_n is
P_n = n fs / f_n samples.  The integer delay and the tuning allpass fix the
absolute delay at partial 1 (exactly, as in
:func:`synth.physics.losses.tune_loop`); the cascade has to supply the
*differences* P_n - P_1, less what the loss filter and the tuning allpass
(whose coefficient itself depends on the cascade's delay at f1) already
give.  An error of dP samples at f_n moves the partial by -1200/ln 2 *
dP / tau_n cents, tau_n the loop's group delay there.  For every M in
1 .. m_max the best a is found by minimax in cents (grid in ln(1 + a), then
golden section), and the smallest M that keeps partials 1 .. n_max within
``tol_cents`` wins.

Limit.  The loop's allpasses must lag at least 2 pi (K - f_K / (f_K -
f_{K-1})) at partial K and a first-order section lags less than pi
(:func:`phase_budget_sections`): about 9.4 sections for B = 1e-4 and 40
partials, 30 for B = 1e-3.  Identical sections do far worse than that bound
at fs ~ 325 kHz, where the audio band is a few per cent of Nyquist and every
section's phase delay has one fixed Lorentzian-like shape (2/w) atan(w/e);
a minimax over free, non-identical first-order coefficients converged to
identical ones, so this is a limit of first-order sections, not of the fit.
When m_max sections cannot keep all n_max partials within tolerance, the
design keeps the longest run of low partials 1 .. n_fit it can (with the
fewest sections that do), and the higher partials come out flat of the
target (less stretched), more so as n grows.

Kernel cost: M first-order sections, 2 state doubles each.

The stiff-string targets, the loss filter and the constants are in
:mod:`synth.physics.dispersion.common`; the biquad design in
:mod:`synth.physics.dispersion.biquad`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..losses import allpass_phase_delay, one_pole_phase_delay
from .common import (
    CENTS_PER_LN,
    F_MAX_HZ,
    M_LIMIT,
    MIN_CELLS,
    TOL_CENTS,
    _int,
    _num,
    _stiff_loss_filter,
    default_n_partials,
    stiff_group_delay,
    stiff_partials,
)

# search range of the section coefficient, as u = ln(1 + a): a from
# -1 + 1e-7 (a pole almost at z = 1) to +0.9 (anti-dispersion, only used when
# the loss filter already stretches more than the stiffness asks)
_U_LO, _U_HI, _U_GRID = math.log(1e-7), math.log(1.9), 801
_GOLDEN_ITERS = 80


# ---------------------------------------------------------------------------
# the allpass section


def section_phase_delay(a, w) -> np.ndarray:
    """Phase delay (samples) of (a + z^-1) / (1 + a z^-1) at w (rad/sample),
    vectorised over ``a`` and ``w`` (0 < w < pi, -1 < a < 1).

    Equals :func:`synth.physics.losses.allpass_phase_delay` (which is scalar);
    (1 - a)/(1 + a) at DC, 1 at Nyquist.
    """
    a = np.asarray(a, dtype=float)
    w = np.asarray(w, dtype=float)
    return 1.0 - 2.0 / w * np.arctan2(a * np.sin(w), 1.0 + a * np.cos(w))


# ---------------------------------------------------------------------------
# design


@dataclass(frozen=True)
class DispersionDesign:
    """Result of a dispersion-filter fit in a tuned loop.

    M : number of sections (0 = none).
    a : section coefficient (0.0 when M = 0).
    cells, extra_delay, eta : the tuning that puts partial 1 on target with
        this cascade (for the loss pole the design was made with).
    n_partials : partials the design was asked to match (1 .. n_partials).
    n_fit : partials kept within ``tol_cents`` (n_fit < n_partials when
        m_max sections cannot reach all of them).
    cents : predicted error (cents, + = sharp) of partials 1 .. n_partials,
        linearised: -1200/ln 2 * (loop phase delay - n fs / f_n) / tau_n;
        within ~3 % of the true error up to 5 cents, larger errors are
        overstated.
    delay_at_f1 : the cascade's phase delay at partial 1 (samples).
    """

    M: int
    a: float
    cells: int
    extra_delay: int
    eta: float
    n_partials: int
    n_fit: int
    cents: np.ndarray
    delay_at_f1: float

    @property
    def worst_cents(self) -> float:
        """Largest predicted error over partials 1 .. n_partials (cents)."""
        return float(np.max(np.abs(self.cents)))

    @property
    def worst_fit_cents(self) -> float:
        """Largest predicted error over partials 1 .. n_fit (cents)."""
        return float(np.max(np.abs(self.cents[: self.n_fit])))


class _Problem:
    """Targets of one design: partials 1 .. K of f0, B at fs in a loop with
    a loss pole a1, tuned as :func:`synth.physics.losses.tune_loop` tunes."""

    def __init__(self, f0_hz: float, B: float, fs: float, K: int, a1: float,
                 fixed_delay: float = 0.0):
        self.fixed = float(fixed_delay)               # a pure delay elsewhere in the loop
        n = np.arange(1, K + 1, dtype=float)
        fn = stiff_partials(f0_hz, B, n)
        self.w = 2.0 * math.pi * fn / fs
        self.w1 = float(self.w[0])
        self.P1 = fs / float(fn[0])                   # loop phase delay at partial 1
        P = n * fs / fn                               # ... at partial n
        lp = np.array([one_pole_phase_delay(a1, float(x)) for x in self.w])
        self.lp1 = float(lp[0])
        self.R = (P - P[0]) - (lp - lp[0])            # what cascade + tuning allpass owe
        self.tau = stiff_group_delay(fn, f0_hz, B, fs)

    def tune(self, disp1):
        """Cells, extra delay and eta for cascade delays ``disp1`` (array, samples at f1)."""
        rest = self.P1 - self.lp1 - np.asarray(disp1, dtype=float) - self.fixed
        N = np.floor((rest - 0.5) / 2.0)
        rem = rest - 2.0 * N                          # in [0.5, 2.5)
        extra = (rem >= 1.5).astype(int)
        rem = rem - extra
        # allpass_for_phase_delay(r, w1) of each r, on the array: the same
        # operations on the same floats (numpy's float64 sin is the C
        # library's, as math.sin: tests/test_dispersion.py compares them bit
        # for bit), without a Python call per value (live play's warm-up of
        # the sitar asked for 1.4 million of them)
        w = self.w1
        eta = np.sin((1.0 - rem) * w / 2.0) / np.sin((1.0 + rem) * w / 2.0)
        return N.astype(np.int64), extra, eta

    def section_delays(self, a) -> np.ndarray:
        """Phase delay (samples) of one section of each ``a`` at every
        partial, (A, K): what :meth:`cents` computes first, for any M."""
        a = np.atleast_1d(np.asarray(a, dtype=float))
        return section_phase_delay(a[:, None], self.w[None, :])

    def cents(self, M: int, a, d=None):
        """Signed errors (cents) of every partial for M sections of each ``a``
        (array of shape (A,) -> (A, K)), and the tuning (N, extra, eta).
        ``d``: :meth:`section_delays` of ``a`` if known (the same for every M)."""
        a = np.atleast_1d(np.asarray(a, dtype=float))
        if M:
            d = self.section_delays(a) if d is None else d
            disp1 = M * d[:, 0]
            Dd = M * (d - d[:, :1])
        else:
            disp1 = np.zeros_like(a)
            Dd = np.zeros((len(a), len(self.w)))
        N, extra, eta = self.tune(disp1)
        e = section_phase_delay(eta[:, None], self.w[None, :])
        err = Dd + (e - e[:, :1]) - self.R           # samples too long
        return -CENTS_PER_LN * err / self.tau, N, extra, eta, disp1


def _golden(cost, lo: float, hi: float, iters: int = _GOLDEN_ITERS) -> tuple[float, float]:
    g = (math.sqrt(5.0) - 1.0) / 2.0
    x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
    c1, c2 = cost(x1), cost(x2)
    for _ in range(iters):
        if c1 <= c2:
            hi, x2, c2 = x2, x1, c1
            x1 = hi - g * (hi - lo)
            c1 = cost(x1)
        else:
            lo, x1, c1 = x1, x2, c2
            x2 = lo + g * (hi - lo)
            c2 = cost(x2)
    return (x1, c1) if c1 <= c2 else (x2, c2)


def _design(f0_hz: float, B: float, fs: float, m_max: int, K: int, tol_cents: float,
            a1: float = 0.0, fixed_delay: float = 0.0) -> DispersionDesign:
    """Choose (M, a) and the tuning; see the module docstring for the rule."""
    pb = _Problem(f0_hz, B, fs, K, a1, fixed_delay)

    def result(M: int, a: float, n_fit: int) -> DispersionDesign:
        c, N, extra, eta, disp1 = pb.cents(M, a)
        return DispersionDesign(int(M), float(a) if M else 0.0, int(N[0]), int(extra[0]),
                                float(eta[0]), int(K), int(n_fit), c[0], float(disp1[0]))

    if B == 0.0 or m_max == 0 or K < 2:
        c = np.abs(pb.cents(0, 0.0)[0][0])
        n_fit = max(1, int(np.argmax(np.append(c, np.inf) > tol_cents)))
        return result(0, 0.0, n_fit)

    u = np.linspace(_U_LO, _U_HI, _U_GRID)
    a = np.expm1(u)                                   # -1 < a <= 0.9
    Ms = np.arange(1, m_max + 1)
    cum = np.empty((m_max, len(u), K))
    d = pb.section_delays(a)                          # the same for every M
    for i, M in enumerate(Ms):
        c, N, _, _, _ = pb.cents(int(M), a, d)
        c = np.abs(c)
        c[N < MIN_CELLS] = np.inf                     # no room left for the grid
        # worst over 1 .. k+1: np.maximum.accumulate(c, axis=1), a column
        # at a time (the same maxima, in 60 % of the time for 10-100 columns)
        ci = cum[i]
        ci[:, 0] = c[:, 0]
        for k in range(1, K):
            np.maximum(ci[:, k - 1], c[:, k], out=ci[:, k])
    best = cum.min(axis=1)                            # (M, K)
    if np.isinf(best[:, 1]).all():
        return result(0, 0.0, 1)
    ok = best <= tol_cents
    if ok[:, K - 1].any():
        n_fit = K
    else:
        reach = np.nonzero(ok.any(axis=0))[0]
        n_fit = max(2, int(reach[-1]) + 1)
    col = n_fit - 1
    okm = np.nonzero(best[:, col] <= tol_cents)[0]
    im = int(okm[0]) if len(okm) else int(np.argmin(best[:, col]))
    M = int(Ms[im])
    ia = int(np.argmin(cum[im, :, col]))

    def cost(uu: float) -> float:
        c, N, _, _, _ = pb.cents(M, math.expm1(uu))
        if N[0] < MIN_CELLS:
            return math.inf
        return float(np.max(np.abs(c[0, :n_fit])))

    ub, cb = _golden(cost, u[max(ia - 1, 0)], u[min(ia + 1, len(u) - 1)])
    if not cb <= cum[im, ia, col]:
        ub = u[ia]
    return result(M, math.expm1(ub), n_fit)


def _check_n_partials(n_partials, f0_hz: float, B: float, fs: float, f_max_hz: float) -> int:
    if n_partials is None:
        return default_n_partials(f0_hz, B, f_max_hz)
    K = _int("n_partials", n_partials, 1, 200)
    top = float(stiff_partials(f0_hz, B, K))
    if top >= 0.45 * fs:
        raise ValueError(f"n_partials = {n_partials!r} puts f_n = {top:g} Hz above "
                         f"0.45 fs = {0.45 * fs:g} Hz (allowed: f_n < 0.45 fs)")
    return K


def design_dispersion_detailed(f0_hz: float, B: float, fs: float, m_max: int = M_LIMIT,
                               n_partials: int | None = None, *,
                               tol_cents: float = TOL_CENTS,
                               f_max_hz: float = F_MAX_HZ) -> DispersionDesign:
    """:func:`design_dispersion` with the fit's tuning and diagnostics (a
    :class:`DispersionDesign`).  Parameters as there."""
    fs = _num("fs", fs, 0.0, 1e8, lo_open=True)
    f0_hz = _num("f0_hz", f0_hz, 0.0, fs / 16.0, lo_open=True, hi_open=True)
    B = _num("B", B, 0.0, 0.1)
    m_max = _int("m_max", m_max, 0, M_LIMIT)
    tol_cents = _num("tol_cents", tol_cents, 0.0, 100.0, lo_open=True)
    f_max_hz = _num("f_max_hz", f_max_hz, 0.0, fs / 2.0, lo_open=True, hi_open=True)
    K = _check_n_partials(n_partials, f0_hz, B, fs, f_max_hz)
    return _design(f0_hz, B, fs, m_max, K, tol_cents)


def design_dispersion(f0_hz: float, B: float, fs: float, m_max: int = M_LIMIT,
                      n_partials: int | None = None, *, tol_cents: float = TOL_CENTS,
                      f_max_hz: float = F_MAX_HZ) -> tuple[int, float]:
    """Dispersion cascade (M sections of (a + z^-1)/(1 + a z^-1)) for a
    stiff string in a lossless loop (a1 = 0) tuned with the integer delay and
    the tuning allpass as in :func:`synth.physics.losses.tune_loop`; see
    :func:`tune_stiff_loop` for the loop with its loss filter.

    Parameters
    ----------
    f0_hz : float
        Fundamental of the string without stiffness (Hz), 0 < f0 < fs/16;
        partial 1 is at f0 sqrt(1 + B).
    B : float
        Inharmonicity coefficient, 0 <= B <= 0.1.  B = 0 gives M = 0.
    fs : float
        Loop sample rate (Hz), > 0.
    m_max : int
        Most sections allowed, 0 .. 16.
    n_partials : int or None
        Match partials 1 .. n_partials (1 .. 200, below 0.45 fs); default:
        those up to ``f_max_hz``, at most 40.  With a single partial there
        is nothing to stretch and M = 0.
    tol_cents : float
        Accepted error (cents) on every matched partial, > 0.  The smallest
        M (>= 1 when B > 0) that meets it is used; if none up to m_max does,
        the smallest M that keeps the longest run of low partials 1 .. n_fit
        within it (higher partials then come out less stretched).
    f_max_hz : float
        Top of the default band (Hz), 0 < f_max < fs/2.

    Returns
    -------
    (M, a) : int, float
        Number of sections (0 .. m_max) and their coefficient, -1 < a <= 0.9
        (a < 0 stretches; 0.0 when M = 0).
    """
    d = design_dispersion_detailed(f0_hz, B, fs, m_max, n_partials, tol_cents=tol_cents,
                                   f_max_hz=f_max_hz)
    return d.M, d.a


# ---------------------------------------------------------------------------
# the complete loop


def loop_phase_delay(fs: float, cells: int, b0: float, a1: float, eta: float,
                     extra_delay: int, M: int, a: float, f_hz) -> np.ndarray:
    """Phase delay (samples) of the complete loop at f (Hz, array):
    z^{-2 cells} * b0/(1 + a1 z^-1) * z^{-extra} * allpass(eta) * A_d(a)^M.
    ``b0`` does not enter the phase (accepted for symmetry)."""
    w = 2.0 * math.pi * np.atleast_1d(np.asarray(f_hz, dtype=float)) / fs
    lp = np.array([one_pole_phase_delay(a1, float(x)) for x in w])
    ap = np.array([allpass_phase_delay(eta, float(x)) for x in w])
    disp = M * section_phase_delay(a, w) if M else 0.0
    return 2 * cells + extra_delay + lp + ap + disp


def loop_partials(fs: float, cells: int, b0: float, a1: float, eta: float,
                  extra_delay: int, M: int, a: float, n) -> np.ndarray:
    """Resonance frequencies (Hz) of the complete loop.

    Partial n is the f at which the loop's total phase is -2 pi n, i.e.
    f * P(f) / fs = n with P the loop phase delay (:func:`loop_phase_delay`);
    the loop's group delay is positive, so the root is unique, found by
    bisection on (0, fs/2) to double precision.

    Parameters
    ----------
    fs : float
        Loop sample rate (Hz), > 0.
    cells : int
        N, >= 1 (the loop holds 2N grid samples).
    b0, a1 : float
        Loss filter b0 / (1 + a1 z^-1), -1 < a1 < 1 (b0 does not move the
        partials).
    eta : float
        Tuning allpass coefficient, -1 < eta < 1.
    extra_delay : int
        0 or 1 extra unit delay.
    M : int
        Dispersion sections, 0 .. 64.
    a : float
        Their coefficient, -1 < a < 1 (ignored when M = 0).
    n : int or array of int
        An int K gives partials 1 .. K; an array gives those partial numbers
        (each >= 1).

    Returns
    -------
    f_hz : ndarray
        One frequency per requested partial.  Raises ValueError when a
        partial would lie above fs/2.
    """
    fs = _num("fs", fs, 0.0, 1e8, lo_open=True)
    cells = _int("cells", cells, 1, 10**9)
    _num("a1", a1, -1.0, 1.0, lo_open=True, hi_open=True)
    _num("eta", eta, -1.0, 1.0, lo_open=True, hi_open=True)
    extra_delay = _int("extra_delay", extra_delay, 0, 1)
    M = _int("M", M, 0, 64)
    if M:
        _num("a", a, -1.0, 1.0, lo_open=True, hi_open=True)
    if np.ndim(n) == 0:
        K = _int("n", n, 1, 10**6)
        ns = np.arange(1, K + 1, dtype=float)
    else:
        ns = np.asarray(n, dtype=float)
        if ns.size == 0 or np.any(ns < 1) or np.any(ns != np.round(ns)):
            raise ValueError(f"n = {n!r} is out of range (partial numbers, integers >= 1)")

    def cycles(f):
        return f * loop_phase_delay(fs, cells, b0, a1, eta, extra_delay, M, a, f) / fs

    top = float(cycles(np.array([0.5 * fs * (1.0 - 1e-12)]))[0])
    if ns.max() >= top:
        raise ValueError(f"n = {int(ns.max())} is out of range (the loop has fewer than "
                         f"{int(ns.max())} partials below fs/2; 1 <= n < {top:.3f})")
    lo = np.zeros_like(ns)
    hi = np.full_like(ns, 0.5 * fs)
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if np.all((mid == lo) | (mid == hi)):
            break
        above = cycles(mid) > ns
        hi = np.where(above, mid, hi)
        lo = np.where(above, lo, mid)
    return 0.5 * (lo + hi)


@dataclass(frozen=True)
class StiffLoop:
    """Far-end filter of a stiff musical string.

    cells : N (the loop is 2N grid samples plus the filters), >= 8.
    b0, a1 : one-pole loss filter b0 / (1 + a1 z^-1).
    eta : tuning allpass coefficient.
    extra_delay : 0 or 1 additional unit delay.
    M : dispersion sections (0 .. 16), each (a_disp + z^-1)/(1 + a_disp z^-1).
    a_disp : their coefficient (0.0 when M = 0).
    f0_string : fundamental of the string without stiffness, f1 / sqrt(1 + B) (Hz).
    fs : loop sample rate (Hz).
    f1_hz : partial 1 (Hz), exact.
    B : inharmonicity coefficient.
    n_partials, n_fit : partials the design aimed at / kept within tolerance.
    worst_cents : predicted largest error over partials 1 .. n_partials.
    """

    cells: int
    b0: float
    a1: float
    eta: float
    extra_delay: int
    M: int
    a_disp: float
    f0_string: float
    fs: float
    f1_hz: float
    B: float
    n_partials: int
    n_fit: int
    worst_cents: float

    @property
    def dispersion_delay(self) -> float:
        """The cascade's phase delay at partial 1 (samples): how much of the
        loop it takes from the grid."""
        if self.M == 0:
            return 0.0
        w1 = 2 * math.pi * self.f1_hz / self.fs
        return float(self.M * section_phase_delay(self.a_disp, w1))

    def total_phase_delay(self, f_hz: float | None = None) -> float:
        """Loop phase delay (samples) at f (default partial 1)."""
        f = self.f1_hz if f_hz is None else f_hz
        return float(loop_phase_delay(self.fs, self.cells, self.b0, self.a1, self.eta,
                                      self.extra_delay, self.M, self.a_disp, f)[0])

    def partials(self, n) -> np.ndarray:
        """Resonance frequencies (Hz) of this loop (see :func:`loop_partials`)."""
        return loop_partials(self.fs, self.cells, self.b0, self.a1, self.eta,
                             self.extra_delay, self.M, self.a_disp, n)

    def target_partials(self, n) -> np.ndarray:
        """The stiff-string partials n f0 sqrt(1 + B n^2) (Hz) it aims at."""
        if np.ndim(n) == 0:
            n = np.arange(1, int(n) + 1)
        return stiff_partials(self.f0_string, self.B, n)


def tune_stiff_loop(f1_hz: float, B: float, fs: float, t60_low_s: float, f_low_hz: float,
                    t60_high_s: float, f_high_hz: float, m_max: int = M_LIMIT, *,
                    n_partials: int | None = None, tol_cents: float = TOL_CENTS,
                    f_max_hz: float = F_MAX_HZ, fixed_delay: float = 0.0) -> StiffLoop:
    """Loss filter, dispersion cascade, integer delay and tuning allpass of a
    stiff string whose partial 1 is exactly ``f1_hz``.

    Parameters
    ----------
    f1_hz : float
        Partial 1 (Hz), f0 sqrt(1 + B); 0 < f1 < fs/16.
    B : float
        Inharmonicity coefficient, 0 <= B <= 0.1.  B = 0 gives the harmonic
        loop of :func:`synth.physics.losses.tune_loop`.
    fs : float
        Loop sample rate (Hz), > 0.
    t60_low_s, t60_high_s : float
        Decay times (s) at ``f_low_hz`` and ``f_high_hz``, 0 < t60_high <=
        t60_low <= 1e4 (0 < f_low < f_high < fs/2; f_high is clamped to
        0.45 fs).  The loop gain per round trip at f uses the stiff loop's
        round-trip time at f (its group delay, shorter at high f); when that
        would ask for more gain at f_high than at f_low the loss filter stays
        flat (T60 at f_high then comes out longer than asked).
    m_max, n_partials, tol_cents, f_max_hz
        As in :func:`design_dispersion`.
    fixed_delay : float
        Samples of pure delay taken by something else in the loop (a
        pitch-bend line at rest, as :func:`synth.physics.losses.tune_loop`),
        >= 0: the grid and the tuning allpass make up the rest.

    Returns
    -------
    StiffLoop

    Raises ValueError for an out-of-range parameter, or when the cascade
    would leave fewer than 8 grid cells.
    """
    fs = _num("fs", fs, 0.0, 1e8, lo_open=True)
    f1_hz = _num("f1_hz", f1_hz, 0.0, fs / 16.0, lo_open=True, hi_open=True)
    B = _num("B", B, 0.0, 0.1)
    _num("t60_low_s", t60_low_s, 0.0, 1e4, lo_open=True)
    _num("t60_high_s", t60_high_s, 0.0, t60_low_s, lo_open=True)
    _num("f_low_hz", f_low_hz, 0.0, fs / 2.0, lo_open=True, hi_open=True)
    _num("f_high_hz", f_high_hz, f_low_hz, math.inf, lo_open=True)
    m_max = _int("m_max", m_max, 0, M_LIMIT)
    tol_cents = _num("tol_cents", tol_cents, 0.0, 100.0, lo_open=True)
    f_max_hz = _num("f_max_hz", f_max_hz, 0.0, fs / 2.0, lo_open=True, hi_open=True)
    f0 = f1_hz / math.sqrt(1.0 + B)
    K = _check_n_partials(n_partials, f0, B, fs, f_max_hz)

    b0, a1 = _stiff_loss_filter(f0, B, fs, t60_low_s, f_low_hz, t60_high_s, f_high_hz)

    # the cascade also makes up for the loss filter's and the tuning
    # allpass's own (small) dispersion
    fixed_delay = _num("fixed_delay", fixed_delay, 0.0, fs / f1_hz / 2.0)
    des = _design(f0, B, fs, m_max, K, tol_cents, a1, fixed_delay)
    if des.cells < MIN_CELLS:
        raise ValueError(f"f1_hz = {f1_hz!r} is out of range: the loop keeps {des.cells} "
                         f"cells (allowed: >= {MIN_CELLS}, f1 < fs/16)")
    return StiffLoop(des.cells, float(b0), float(a1), des.eta, des.extra_delay, des.M, des.a,
                     f0, float(fs), float(f1_hz), float(B), des.n_partials, des.n_fit,
                     des.worst_cents)
