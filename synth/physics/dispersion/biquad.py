"""Second-order (biquad) allpass dispersion: individual poles in a stiff loop.

:func:`tune_stiff_loop_sos` designs, for the loop of
:mod:`synth.physics.dispersion.first_order`, a cascade of biquad allpasses
with individual poles (and at most one first-order section) instead of M
identical first-order sections: Abel-Valimaki-Smith initial poles,
Levenberg-Marquardt on the cents errors and Lawson reweighting towards
minimax, all in numpy.  It keeps every grand key's partials up to 10 kHz
(at most 40) within 2 cents with at most 8 biquads (4 state doubles each);
:func:`retune_sos_loop` reuses a key's cascade for its unison strings.

The stiff-string targets, the loss filter and the constants are in
:mod:`synth.physics.dispersion.common`; the first-order design (the
fallback here) in :mod:`synth.physics.dispersion.first_order`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..losses import allpass_for_phase_delay
from .common import (
    CENTS_PER_LN,
    F_MAX_HZ,
    M_LIMIT,
    MIN_CELLS,
    N_PARTIALS_MAX,
    TOL_CENTS,
    _int,
    _num,
    _stiff_loss_filter,
    default_n_partials,
    partial_number,
    phase_budget_sections,
    stiff_group_delay,
    stiff_partials,
)
from .first_order import _U_HI, _U_LO, _design

# ---------------------------------------------------------------------------
# second-order (biquad) allpass sections
#
# A cascade of M second-order allpass sections with individual poles
#
#     H_i(z) = (c2 + c1 z^-1 + z^-2) / (1 + c1 z^-1 + c2 z^-2),
#     c1 = -2 R_i cos(theta_i),  c2 = R_i^2,  0 < R_i < 1,
#
# (and at most one first-order section) in the same loop keeps every
# partial of a grand key up to 10 kHz (at most 40) within 2 cents with 1 to
# 8 biquads, where M identical first-order sections keep 8 .. 24 (see
# tune_stiff_loop_sos).
#
# Every filter of the loop is "a linear phase and some poles": its phase lag
# at w (rad/sample) is
#
#     lag(w) = L w + sum_j m_j arg(1 - q_j e^{-iw})
#
# with pole q_j (|q_j| < 1) counted m_j times.  The loss filter b0/(1 + a1
# z^-1) is L = 0, q = -a1, m = 1; a first-order allpass (a + z^-1)/(1 + a
# z^-1) is L = 1, q = -a, m = 2; a biquad is L = 2 with its poles p and
# conj(p), m = 2 each.  The group delay is then L + sum_j m_j Re(v_j / (1 -
# v_j)), v_j = q_j e^{-iw}.

#: Most biquads :func:`tune_stiff_loop_sos` may use, i.e. the state the
#: kernel must hold.  The grand's 88 keys need at most 8 at 2 cents and
#: partials up to 10 kHz (at most 40), 12 with partials up to 18 kHz.
#: Equal to ``synth.kernels.layout.MAX_SOS`` (physics may not import
#: kernels; tests/test_constants.py keeps them equal).
MAX_SOS = 12
#: Cost of a biquad in first-order-section units (twice a first-order
#: section's state and about twice its arithmetic).
SOS_COST = 2

# fit settings (see _SosProblem)
_AVS_C = 0.7            # initial radii R = exp(-c x half the spacing of the pole angles)
_LS_ITERS = 40          # Levenberg-Marquardt iterations of the least-squares fit ...
_LS_RTOL = 1e-6         # ... or until a step gains less than this (relative)
_LAWSON_FACTOR = 2.2    # Lawson passes only when the LS worst is within this x tol
_LAWSON_PASSES = 6
_LAWSON_ITERS = 20      # LM iterations per Lawson pass (warm-started) ...
_LAWSON_RTOL = 1e-4     # ... or until a step gains less than this (relative)
_FO_START = 2.0         # a first-order section starts at a = -1 + 2 w1
_X2_MIN = -25.0         # -ln R >= e^-25: R <= 1 - 1.4e-11 during the fit ...
_X2_MAX = 3.0           # ... and -ln R <= e^3: R >= 2e-9
_X1_MIN = -40.0         # theta >= 4e-18 ...
_X1_MAX = math.log(math.pi)   # ... and <= pi


def _lp_lag(w, a1: float):
    """Phase lag (rad) of b0 / (1 + a1 z^-1) at w (rad/sample, array)."""
    return np.arctan2(-a1 * np.sin(w), 1.0 + a1 * np.cos(w))


def _fo_lag(w, a: float):
    """Phase lag (rad) of (a + z^-1) / (1 + a z^-1) at w (rad/sample, array)."""
    return w - 2.0 * np.arctan2(a * np.sin(w), 1.0 + a * np.cos(w))


def sos_coefficients(theta, R) -> np.ndarray:
    """Biquad allpass coefficients from pole angles and radii.

    Parameters
    ----------
    theta : array_like
        Pole angles (rad/sample), one per section.
    R : array_like
        Pole radii, 0 <= R < 1, one per section.

    Returns
    -------
    sos : ndarray, shape (M, 2)
        (c1, c2) = (-2 R cos(theta), R^2) per section, the coefficients of
        (c2 + c1 z^-1 + z^-2) / (1 + c1 z^-1 + c2 z^-2).
    """
    theta = np.atleast_1d(np.asarray(theta, dtype=float))
    R = np.atleast_1d(np.asarray(R, dtype=float))
    return np.stack([-2.0 * R * np.cos(theta), R * R], axis=-1).reshape(-1, 2)


def sos_poles(sos) -> np.ndarray:
    """Both poles of every biquad given as (c1, c2) rows, the roots of z^2 +
    c1 z + c2: complex array of shape (M, 2) (a conjugate pair, or two real
    poles)."""
    sos = np.asarray(sos, dtype=float).reshape(-1, 2)
    half = -0.5 * sos[:, 0]
    s = np.sqrt((half * half - sos[:, 1]).astype(complex))
    return np.stack([half + s, half - s], axis=-1)


def _loop_lag_terms(eta: float, a1: float, n_fo: int, a_fo: float, sos):
    """The loop's filters as (L, poles q, multiplicities m): loss filter,
    tuning allpass, first-order sections and biquads (the integer delay
    2N + extra is added to L by the caller)."""
    q = [complex(-a1), complex(-eta)]
    m = [1.0, 2.0]
    if n_fo:
        q.append(complex(-a_fo))
        m.append(2.0 * n_fo)
    p = sos_poles(sos).ravel()
    q.extend(p)
    m.extend([2.0] * len(p))
    return 1.0 + n_fo + len(p), np.array(q, dtype=complex), np.array(m)


@dataclass(frozen=True)
class BridgeLag:
    """The phase of a unison's reflection from its bridge, as a lag of the
    loop: strings of summed impedance ``nz`` (N s/m) moving together meet
    the bridge's impedance Z_b = R + j w M (``resistance``, N s/m; ``mass``,
    kg) and come back by rho = (Z_b - nz) / (Z_b + nz), whose phase
    arctan(w M / (R - nz)) - arctan(w M / (R + nz)) is a lead (the loop
    shorter: a mass raises the in-phase motion); a dashpot (M = 0) has none.
    ``fs`` the loop's rate (Hz): w in rad/sample is w fs rad/s."""

    resistance: float
    mass: float
    nz: float
    fs: float

    def lag(self, w):
        """Lag (rad) at w (rad/sample, array): minus rho's phase."""
        x = np.asarray(w, dtype=float) * self.fs * self.mass
        return np.arctan2(x, self.resistance + self.nz) - np.arctan2(x, self.resistance - self.nz)

    def delay(self, w):
        """d lag / d w (samples)."""
        x = np.asarray(w, dtype=float) * self.fs * self.mass
        k = self.fs * self.mass
        ap, am = self.resistance + self.nz, self.resistance - self.nz
        return k * (ap / (ap * ap + x * x) - am / (am * am + x * x))


def _lag_and_delay(w, L: float, q, m, want_delay: bool = True, extra: BridgeLag | None = None):
    """Loop lag (rad) and group delay (samples) at w (array, rad/sample),
    with a bridge's lag (``extra``) if given."""
    v = q[:, None] * np.exp(-1j * w)[None, :]
    u = 1.0 - v
    lag = L * w + m @ np.angle(u)
    if extra is not None:
        lag = lag + extra.lag(w)
    if not want_delay:
        return lag, None
    gd = L + m @ (v / u).real
    if extra is not None:
        gd = gd + extra.delay(w)
    return lag, gd


def _loop_partials_w(Dint: int, L: float, q, m, n, w_guess=None,
                     extra: BridgeLag | None = None) -> np.ndarray:
    """w (rad/sample) at which the loop's lag is 2 pi n, for partial numbers n.

    Newton's method from ``w_guess`` when it is given and converges (the
    design's check), else bisection on (0, pi) to double precision (the lag
    of the loop rises monotonically: its group delay is positive)."""
    n = np.asarray(n, dtype=float)
    target = 2.0 * math.pi * n
    Ltot = Dint + L
    if w_guess is not None:
        w = np.array(w_guess, dtype=float)
        for _ in range(8):
            lag, gd = _lag_and_delay(w, Ltot, q, m, extra=extra)
            step = (lag - target) / gd
            w = w - step
            if np.all(np.abs(step) <= 1e-15 * w):
                break
        lag, _ = _lag_and_delay(w, Ltot, q, m, False, extra)
        if np.all(np.isfinite(w)) and np.all((w > 0) & (w < math.pi)) and \
                np.all(np.abs(lag - target) <= 1e-9 * target):
            return w
    lo = np.zeros_like(n)
    hi = np.full_like(n, math.pi)
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if np.all((mid == lo) | (mid == hi)):
            break
        above = _lag_and_delay(mid, Ltot, q, m, False, extra)[0] > target
        hi = np.where(above, mid, hi)
        lo = np.where(above, lo, mid)
    return 0.5 * (lo + hi)


class _SosProblem:
    """Targets of one design: partials 1 .. K of (f0, B) at fs in a loop with
    the loss pole a1, partial 1 exact through the integer delay, the extra
    unit delay and the tuning allpass (as :func:`tune_stiff_loop`).

    The fit works on the loop's lag excess at partials 2 .. K,

        e_n = D w_n + lp(w_n) + C(w_n) - 2 pi n,   D = P1 - lp(w1)/w1 - C(w1)/w1,

    with D the rest of the loop taken as one continuous delay that keeps
    partial 1 exact (fixing the integer delay during the fit would make the
    residual jump), plus the tuning allpass's own small dispersion (fixed
    per evaluation).  e_n in cents is -1200/ln 2 e_n / (w_n tau_n), tau_n
    the stiff loop's group delay at partial n.  Parameters: ln theta_i and
    ln(-ln R_i) per biquad (so 0 < R < 1, theta > 0), ln(1 + a) for the
    first-order section.
    """

    def __init__(self, f0: float, B: float, fs: float, K: int, a1: float,
                 bridge: BridgeLag | None = None):
        self.f0, self.B, self.fs, self.K, self.a1 = f0, B, fs, K, a1
        self.bridge = bridge
        n = np.arange(1, K + 1, dtype=float)
        fn = stiff_partials(f0, B, n)
        w = 2.0 * math.pi * fn / fs
        self.n, self.fn, self.w = n, fn, w
        self.w1 = float(w[0])
        self.Ewc = np.exp(-1j * w)
        self.P1 = fs / float(fn[0])
        lpl = self.fixed_lag(w)
        self.lpd1 = float(lpl[0]) / self.w1
        self.wr = w[1:]
        self.ratio = w[1:] / self.w1
        self.base = (self.P1 - self.lpd1) * w[1:] + lpl[1:] - 2.0 * math.pi * n[1:]
        tau = stiff_group_delay(fn, f0, B, fs)
        self.scale = -CENTS_PER_LN / (w * tau)          # cents per rad of excess lag
        self.sc = self.scale[1:]
        self._avs_grid = None

    def fixed_lag(self, w):
        """The loss filter's lag and the bridge's (rad) at w."""
        lag = _lp_lag(w, self.a1)
        return lag if self.bridge is None else lag + self.bridge.lag(w)

    # -- tuning (partial 1 exact)
    def tuning(self, C1: float):
        """(N, extra, eta, rem) for a cascade lag C1 (rad) at partial 1."""
        rest = self.P1 - self.lpd1 - C1 / self.w1
        N = math.floor((rest - 0.5) / 2.0)
        rem = rest - 2.0 * N                             # in [0.5, 2.5)
        extra = 1 if rem >= 1.5 else 0
        rem -= extra
        return int(N), extra, allpass_for_phase_delay(rem, self.w1), rem

    # -- the model and its Jacobian
    def unpack(self, x, M: int, m1: int):
        th = np.exp(np.minimum(np.maximum(x[:M], _X1_MIN), _X1_MAX))
        R = np.exp(-np.exp(np.minimum(np.maximum(x[M:2 * M], _X2_MIN), _X2_MAX)))
        a = math.expm1(min(max(x[2 * M], _U_LO), _U_HI)) if m1 else 0.0
        return th, R, a

    def cascade(self, x, M: int, m1: int):
        """Cascade lag C at w_1 .. w_K and what the Jacobian needs."""
        th, R, a = self.unpack(x, M, m1)
        C = 2.0 * M * self.w
        v = u = None
        if M:
            p = R * np.exp(1j * th)
            v = np.concatenate([p, p.conj()])[:, None] * self.Ewc[None, :]
            u = 1.0 - v
            C = C + 2.0 * np.angle(u).sum(axis=0)
        if m1:
            C = C + _fo_lag(self.w, a)
        return C, (th, R, a, v, u)

    def excess(self, x, M: int, m1: int):
        """Lag excess e_n (rad) at partials 2 .. K, and the cache."""
        C, cache = self.cascade(x, M, m1)
        C1 = float(C[0])
        _, _, eta, rem = self.tuning(C1)
        e = self.base + C[1:] - self.ratio * C1 + (_fo_lag(self.wr, eta) - rem * self.wr)
        return e, cache

    def jacobian(self, cache, M: int, m1: int) -> np.ndarray:
        """d e_n / d x, shape (K - 1, 2 M + m1) (the tuning allpass's
        dispersion taken as fixed)."""
        th, R, a, v, u = cache
        rows = []
        if M:
            h = v / u
            hr, hi = h.real, h.imag
            rows.append(2.0 * (hr[M:] - hr[:M]) * th[:, None])                 # d/d ln theta
            rows.append(-2.0 * (hi[:M] + hi[M:]) * np.log(R)[:, None])         # d/d ln(-ln R)
        if m1:
            w = self.w
            rows.append((-2.0 * np.sin(w) / (1.0 + 2.0 * a * np.cos(w) + a * a)
                         * (1.0 + a))[None, :])                                  # d/d ln(1 + a)
        G = np.concatenate(rows, axis=0)
        return (G[:, 1:] - self.ratio[None, :] * G[:, :1]).T

    def lm(self, x, M: int, m1: int, s, iters: int, rtol: float = _LS_RTOL):
        """Levenberg-Marquardt on sum (s_n e_n)^2: steps (J^T J + lam
        diag(J^T J)) dx = -J^T r, lam / 3 after a step that lowers the cost,
        x 4 (same J) after one that does not; stops after ``iters`` trial
        steps, or when a step lowers the cost by < 1e-10 relative, or lam >
        1e10.  Returns (x, e)."""
        e, cache = self.excess(x, M, m1)
        r = s * e
        cost = float(r @ r)
        lam = 1e-3
        J = A = g = dA = None
        for _ in range(iters):
            if J is None:
                J = s[:, None] * self.jacobian(cache, M, m1)
                A = J.T @ J
                g = J.T @ r
                dA = np.diag(A).copy()
                dA = np.maximum(dA, 1e-12 * max(float(dA.max()), 1e-300))
            Ad = A.copy()
            Ad.flat[::len(dA) + 1] += lam * dA
            try:
                step = np.linalg.solve(Ad, -g)
            except np.linalg.LinAlgError:
                lam *= 4.0
                continue
            xn = x + step
            if not np.all(np.isfinite(xn)):
                lam *= 4.0
                continue
            en, cn = self.excess(xn, M, m1)
            rn = s * en
            costn = float(rn @ rn)
            if costn < cost:
                done = cost - costn < rtol * cost
                x, e, cache, r, cost = xn, en, cn, rn, costn
                J = None
                lam = max(lam / 3.0, 1e-12)
                if done:
                    break
            else:
                lam *= 4.0
                if lam > 1e10:
                    break
        return x, e

    def lawson(self, x, e, M: int, m1: int, passes: int, iters: int, stop: float):
        """Towards minimax: Lawson's reweighting w_n <- w_n |c_n| (normalised
        to mean 1) before each weighted LM pass, warm-started; keeps the
        iterate of smallest worst error, stops early once it is <= ``stop``
        cents."""
        c = self.sc * e
        best = (float(np.max(np.abs(c))), x, e)
        wts = np.ones_like(c)
        for _ in range(passes):
            ac = np.abs(c)
            wts = wts * (ac + 1e-3 * ac.max())
            wts = wts / wts.mean()
            x, e = self.lm(x, M, m1, self.sc * np.sqrt(wts), iters, _LAWSON_RTOL)
            c = self.sc * e
            worst = float(np.max(np.abs(c)))
            if worst < best[0]:
                best = (worst, x, e)
            if best[0] <= stop:
                break
        return best[1], best[2]

    # -- Abel-Valimaki-Smith initial poles
    def avs(self, M: int, m1: int, a0: float, c: float = _AVS_C):
        """Initial pole angles and radii (Abel, Valimaki & Smith 2010).

        The phase the biquads must add to the loop's delay and loss filter
        so that partial n lags 2 pi n, phi(w) = 2 pi n(w) - lp(w) - L w (-
        the first-order section's lag), with L such that phi = 2 pi M at n
        = K + 1/2, is split into M bands of 2 pi: pole i sits where phi
        crosses (i - 1/2) 2 pi, R_i = exp(-c x half the spacing of its
        neighbours' angles).  When phi is not increasing (too few sections
        for the band) L is the smallest group delay and the targets scale to
        the phase left."""
        f0, B, fs = self.f0, self.B, self.fs
        if self._avs_grid is None:
            n_top = self.K + 0.5
            w_top = 2.0 * math.pi * float(stiff_partials(f0, B, n_top)) / fs
            wg = np.linspace(0.0, w_top, 512)
            base = (2.0 * math.pi * partial_number(wg * fs / (2.0 * math.pi), f0, B)
                    - self.fixed_lag(wg))
            self._avs_grid = (n_top, w_top, wg, base, float(np.gradient(base, wg).min()))
        n_top, w_top, wg, base, slope_min = self._avs_grid
        fo_top = float(_fo_lag(np.array([w_top]), a0)[0]) if m1 else 0.0
        tot = 2.0 * math.pi * M + fo_top
        L = (2.0 * math.pi * n_top - float(self.fixed_lag(np.array([w_top]))[0]) - tot) / w_top
        fo = _fo_lag(wg, a0) if m1 else 0.0
        phi = base - L * wg - fo
        targets = 2.0 * math.pi * (np.arange(1, M + 1) - 0.5)
        if np.any(np.diff(phi) <= 0):
            L = slope_min * (1.0 - 1e-3)
            phi = base - L * wg - fo
            if not m1:
                targets = targets * (phi[-1] / tot)
        th = np.interp(targets, phi, wg)
        th = np.maximum(th, 1e-3 * self.w1)
        ext = np.concatenate(([-th[0]], th, [2 * th[-1] - th[-2] if M > 1 else 2 * th[0]]))
        R = np.exp(-c * 0.5 * np.maximum(ext[2:] - ext[:-2], 1e-3 * self.w1))
        return th, np.minimum(R, 1.0 - 1e-9)

    def x0(self, M: int, m1: int):
        a0 = -1.0 + _FO_START * self.w1 if m1 else 0.0
        parts = []
        if M:
            th, R = self.avs(M, m1, a0)
            parts += [np.log(th), np.log(-np.log(R))]
        if m1:
            parts.append([math.log1p(a0)])
        return np.concatenate(parts) if parts else np.zeros(0)

    # -- the exact loop
    def exact(self, M: int, m1: int, x):
        """(N, extra, eta, sos, a_fo, cents of partials 1 .. K) of the tuned
        loop, the cents from its exact resonances."""
        C, (th, R, a, _, _) = self.cascade(x, M, m1)
        N, extra, eta, _ = self.tuning(float(C[0]))
        sos = sos_coefficients(th, R) if M else np.zeros((0, 2))
        L, q, m = _loop_lag_terms(eta, self.a1, m1, a, sos)
        w = _loop_partials_w(2 * N + extra, L, q, m, self.n, self.w, self.bridge)
        cents = CENTS_PER_LN * np.log(w / self.w)
        return N, extra, eta, sos, a, cents

    def design(self, tol: float, max_biquads: int):
        """Cheapest cascade (U = 2 M + m1 units) whose fit keeps partials 1
        .. K within ``tol`` in the exact loop, trying U from the phase budget
        (:func:`phase_budget_sections`, a lower bound; U = 0, no cascade at
        all, when it is below 2) up to 2 max_biquads + 1.  Returns ((M, m1,
        exact design), number of U tried); the design is None when no U
        meets the tolerance with at least MIN_CELLS cells."""
        u_max = SOS_COST * max_biquads + 1
        u0 = int(math.ceil(phase_budget_sections(self.f0, self.B, self.K) - 1e-9))
        if u0 <= 1:
            u0 = 0                           # no cascade costs only an evaluation
        tried = 0
        for U in range(u0, u_max + 1):
            M, m1 = U // 2, U % 2
            tried += 1
            x = self.x0(M, m1)
            s = self.sc
            if U:
                x, e = self.lm(x, M, m1, s, _LS_ITERS)
            else:                                # no cascade at all (B ~ 0)
                e = self.excess(x, M, m1)[0]
            worst = float(np.max(np.abs(s * e)))
            if U and tol < worst <= _LAWSON_FACTOR * tol:
                x, e = self.lawson(x, e, M, m1, _LAWSON_PASSES, _LAWSON_ITERS, 0.0)
                worst = float(np.max(np.abs(s * e)))
            # the linearised error overstates larger errors by a few per cent:
            # the exact loop decides near the tolerance
            if worst > 1.1 * tol:
                continue
            ex = self.exact(M, m1, x)
            if ex[0] >= MIN_CELLS and float(np.max(np.abs(ex[5]))) <= tol:
                return (M, m1, ex), tried
        return None, tried


@dataclass(frozen=True, eq=False)
class SosStiffLoop:
    """Far-end filter of a stiff string with a biquad dispersion cascade.

    The loop (one round trip) is

        z^-(2 cells + extra_delay) * b0 / (1 + a1 z^-1)
            * A_fo(z)^n_fo * prod_i H_i(z) * A_eta(z),

    A_fo(z) = (a_fo + z^-1)/(1 + a_fo z^-1) (the kernel runs it as y = a x +
    x1 - a y1), H_i(z) = (c2 + c1 z^-1 + z^-2)/(1 + c1 z^-1 + c2 z^-2) with
    (c1, c2) = sos[i], A_eta the first-order tuning allpass.  The kernel
    applies the biquads after the first-order sections and before the
    tuning allpass (the order does not move the partials).

    Attributes
    ----------
    cells : int
        N: the loop holds 2N grid samples, >= 8.
    extra_delay : int
        0 or 1 additional unit delay.
    b0, a1 : float
        One-pole loss filter b0 / (1 + a1 z^-1) (y = b0 x - a1 y1).
    eta : float
        Tuning allpass coefficient (partial 1 exact).
    n_fo : int
        Identical first-order dispersion sections (0 or 1 in a biquad
        design; 0 .. 16 in the first-order fallback).
    a_fo : float
        Their common coefficient, -1 < a_fo < 1 (0.0 when n_fo = 0).
    sos : ndarray, shape (n_sos, 2)
        (c1, c2) per biquad, float64, read-only; empty in the fallback.
    n_partials : int
        K: partials 1 .. K were designed (those up to ``f_max_hz``, at most
        ``max_partials``, at least 1).
    worst_cents : float
        Largest |error| (cents) of the exact loop's partials 1 .. K against
        n f0 sqrt(1 + B n^2) (from its resonances, not a linearisation).
    cents : ndarray, shape (K,)
        Those errors, signed (+ = sharp), read-only.
    kind : str
        ``"sos"`` (biquads and at most one first-order section, fitted) or
        ``"first-order"`` (the fallback: the design of
        :func:`tune_stiff_loop`, identical first-order sections).
    f0_string : float
        Fundamental without stiffness, f1 / sqrt(1 + B) (Hz).
    f1_hz : float
        Partial 1 (Hz), exact.
    B : float
        Inharmonicity coefficient.
    fs : float
        Loop sample rate (Hz).
    tol_cents, f_max_hz, max_partials : float, float, int
        The design's tolerance and band (:func:`retune_sos_loop` uses them).
    bridge : BridgeLag or None
        The bridge whose reflection phase the loop was tuned with (partial
        1 exact, partials 1 .. K within the tolerance of the law, with it
        in the loop); None: a rigid end or a dashpot.
    """

    cells: int
    extra_delay: int
    b0: float
    a1: float
    eta: float
    n_fo: int
    a_fo: float
    sos: np.ndarray
    n_partials: int
    worst_cents: float
    cents: np.ndarray
    kind: str
    f0_string: float
    f1_hz: float
    B: float
    fs: float
    tol_cents: float
    f_max_hz: float
    max_partials: int
    bridge: BridgeLag | None = None

    @property
    def n_sos(self) -> int:
        """Number of biquads."""
        return int(self.sos.shape[0])

    @property
    def cost(self) -> int:
        """Cost in first-order-section units: 2 per biquad, 1 per first-order section."""
        return SOS_COST * self.n_sos + self.n_fo

    @property
    def within_tol(self) -> bool:
        """Whether partials 1 .. K are all within ``tol_cents``."""
        return self.worst_cents <= self.tol_cents

    @property
    def delay_samples(self) -> int:
        """The loop's integer delay 2 cells + extra_delay (samples)."""
        return 2 * self.cells + self.extra_delay

    def poles(self) -> np.ndarray:
        """Upper pole R e^{i theta} of each biquad (complex, shape (n_sos,))."""
        return sos_poles(self.sos)[:, 0]

    def _terms(self):
        L, q, m = _loop_lag_terms(self.eta, self.a1, self.n_fo, self.a_fo, self.sos)
        return self.delay_samples + L, q, m

    def phase_lag(self, f_hz) -> np.ndarray:
        """Continuous phase lag (rad) of the loop at f (Hz, array), 0 .. fs/2
        (with its bridge's, :class:`BridgeLag`, if it has one: so do
        :meth:`group_delay` and :meth:`partials`)."""
        L, q, m = self._terms()
        w = 2.0 * math.pi * np.atleast_1d(np.asarray(f_hz, dtype=float)) / self.fs
        return _lag_and_delay(w, L, q, m, False, self.bridge)[0]

    def total_phase_delay(self, f_hz: float | None = None) -> float:
        """Loop phase delay (samples) at f (Hz; default partial 1)."""
        f = self.f1_hz if f_hz is None else float(f_hz)
        return float(self.phase_lag(f)[0] / (2.0 * math.pi * f / self.fs))

    def group_delay(self, f_hz) -> np.ndarray:
        """Loop group delay (samples) at f (Hz, array): the round-trip time
        of a mode there."""
        L, q, m = self._terms()
        w = 2.0 * math.pi * np.atleast_1d(np.asarray(f_hz, dtype=float)) / self.fs
        return _lag_and_delay(w, L, q, m, extra=self.bridge)[1]

    def partials(self, n) -> np.ndarray:
        """Resonance frequencies (Hz) of the loop.

        Partial n is where the loop's continuous phase lag is 2 pi n; the
        lag rises monotonically, so bisection on (0, fs/2) finds it to double
        precision.

        Parameters
        ----------
        n : int or array of int
            An int K gives partials 1 .. K; an array gives those partial
            numbers (each >= 1).

        Returns
        -------
        f_hz : ndarray
            One frequency (Hz) per partial.  Raises ValueError when a partial
            would lie above fs/2.
        """
        if np.ndim(n) == 0:
            K = _int("n", n, 1, 10**6)
            ns = np.arange(1, K + 1, dtype=float)
        else:
            ns = np.asarray(n, dtype=float)
            if ns.size == 0 or np.any(ns < 1) or np.any(ns != np.round(ns)):
                raise ValueError(f"n = {n!r} is out of range (partial numbers, integers >= 1)")
        L, q, m = self._terms()
        top = float(_lag_and_delay(np.array([math.pi * (1.0 - 1e-12)]), L, q, m, False,
                                   self.bridge)[0][0])
        top /= 2.0 * math.pi
        if ns.max() >= top:
            raise ValueError(f"n = {int(ns.max())} is out of range (the loop has fewer than "
                             f"{int(ns.max())} partials below fs/2; 1 <= n < {top:.3f})")
        w = _loop_partials_w(self.delay_samples, L - self.delay_samples, q, m, ns,
                             extra=self.bridge)
        return w * self.fs / (2.0 * math.pi)

    def target_partials(self, n) -> np.ndarray:
        """The stiff-string partials n f0 sqrt(1 + B n^2) (Hz) it aims at (an
        int K: partials 1 .. K)."""
        if np.ndim(n) == 0:
            n = np.arange(1, int(n) + 1)
        return stiff_partials(self.f0_string, self.B, n)


def _frozen(a) -> np.ndarray:
    """A read-only float64 array (``a`` itself when it already is one)."""
    a = np.asarray(a, dtype=float)
    if a.flags.writeable:
        a = a.copy()
        a.setflags(write=False)
    return a


def _check_sos_band(fs: float, tol_cents, max_partials, f_max_hz):
    tol_cents = _num("tol_cents", tol_cents, 0.0, 100.0, lo_open=True)
    max_partials = _int("max_partials", max_partials, 1, 200)
    f_max_hz = _num("f_max_hz", f_max_hz, 0.0, 0.45 * fs, lo_open=True)
    return tol_cents, max_partials, f_max_hz


def _check_loss(fs: float, t60_low_s, f_low_hz, t60_high_s, f_high_hz):
    _num("t60_low_s", t60_low_s, 0.0, 1e4, lo_open=True)
    _num("t60_high_s", t60_high_s, 0.0, t60_low_s, lo_open=True)
    _num("f_low_hz", f_low_hz, 0.0, fs / 2.0, lo_open=True, hi_open=True)
    _num("f_high_hz", f_high_hz, f_low_hz, math.inf, lo_open=True)


def _first_order_loop(pb: _SosProblem, m_max: int, tol: float):
    """The first-order design of :func:`tune_stiff_loop` for this problem,
    with the errors of its exact loop: (N, extra, eta, n_fo, a_fo, cents)."""
    des = _design(pb.f0, pb.B, pb.fs, m_max, pb.K, tol, pb.a1)
    L, q, m = _loop_lag_terms(des.eta, pb.a1, des.M, des.a, np.zeros((0, 2)))
    w = _loop_partials_w(2 * des.cells + des.extra_delay, L, q, m, pb.n, pb.w)
    return (des.cells, des.extra_delay, des.eta, des.M, des.a,
            CENTS_PER_LN * np.log(w / pb.w))


def tune_stiff_loop_sos(f1_hz: float, B: float, fs: float, t60_low_s: float, f_low_hz: float,
                        t60_high_s: float, f_high_hz: float, *, tol_cents: float = TOL_CENTS,
                        max_partials: int = N_PARTIALS_MAX, f_max_hz: float = F_MAX_HZ,
                        max_biquads: int = MAX_SOS, m_max: int = M_LIMIT,
                        bridge: BridgeLag | None = None) -> SosStiffLoop:
    """Loss filter, biquad dispersion cascade, integer delay and tuning
    allpass of a stiff string whose partial 1 is exactly ``f1_hz`` and whose
    partials 1 .. K lie within ``tol_cents`` of n f0 sqrt(1 + B n^2).

    Design.  The loss filter is that of :func:`tune_stiff_loop`.  For U = 2 M
    + m1 cost units (M biquads, m1 = 0 or 1 first-order section) from the
    phase budget (:func:`phase_budget_sections`) up to 2 ``max_biquads`` +
    1, the poles start where Abel, Valimaki & Smith (2010) put them (the
    cascade's required phase split into bands of 2 pi, radii from the
    spacing of the angles), then Levenberg-Marquardt (analytic Jacobian,
    J^T J + lambda diag(J^T J)) minimises the squared cents errors of
    partials 2 .. K, the rest of the loop taken as a continuous delay that
    keeps partial 1 exact; when the least-squares worst error lies within
    2.2 x the tolerance, Lawson's reweighting (6 weighted LM passes) moves it
    towards minimax.  The integer delay, extra delay and tuning allpass then
    put partial 1 exactly on ``f1_hz`` (as :func:`tune_stiff_loop`), and the
    first U whose exact loop keeps partials 1 .. K within the tolerance
    wins: the cheapest cascade that meets it.  U = 1 is one first-order
    section with a free coefficient.

    Fallback.  With K < 2 or B = 0 (nothing to stretch), or when no cascade
    up to ``max_biquads`` meets the tolerance (or leaves 8 cells), the loop
    is the first-order design of :func:`tune_stiff_loop` (at most ``m_max``
    identical sections, the longest run of low partials within the
    tolerance): ``kind == "first-order"``, ``sos`` empty, ``n_fo = M``,
    ``a_fo = a_disp``, and ``worst_cents`` its true worst over partials 1
    .. K.  For the grand (:func:`synth.physics.piano.grand_string`, 2 cents,
    partials up to 10 kHz) no key falls back: keys 21 .. 103 use 1 .. 8
    biquads (and at most one first-order section), keys 104 .. 108 (K = 2)
    one first-order section.  (With partials up to 18 kHz, as the voice asks
    of the first-order design, keys 57 .. 69 need 9 .. 12 biquads: within
    MAX_SOS = 12, and none falls back either.)

    Parameters
    ----------
    f1_hz : float
        Partial 1 (Hz), f0 sqrt(1 + B); 0 < f1 < fs/16.
    B : float
        Inharmonicity coefficient, 0 <= B <= 0.1.
    fs : float
        Loop sample rate (Hz), > 0.
    t60_low_s, f_low_hz, t60_high_s, f_high_hz : float
        Decay times (s) at two frequencies (Hz), as :func:`tune_stiff_loop`:
        0 < t60_high <= t60_low <= 1e4, 0 < f_low < fs/2, f_high > f_low
        (clamped to 0.45 fs).
    tol_cents : float
        Accepted error (cents) on partials 1 .. K, 0 < tol <= 100.
    max_partials : int
        At most this many partials, 1 .. 200.
    f_max_hz : float
        Only partials with n f0 sqrt(1 + B n^2) <= f_max_hz (Hz), 0 < f_max
        <= 0.45 fs.
    max_biquads : int
        Most biquads, 0 .. MAX_SOS.
    m_max : int
        Most identical sections of the first-order fallback, 0 .. 16.
    bridge : BridgeLag or None
        A bridge at the loop's end whose reflection phase (a unison's
        in-phase motion on a bridge with mass) the design takes into the
        loop: partial 1 exact and partials 2 .. K on the law with it.  The
        first-order fallback does not (its partials then lie off by the
        bridge's shift).

    Returns
    -------
    SosStiffLoop

    Raises ValueError (one line: the parameter, its value and the allowed
    range) for an out-of-range parameter, or when the loop would keep fewer
    than 8 grid cells.

    References
    ----------
    J. S. Abel, V. Valimaki and J. O. Smith, "Robust, efficient design of
    allpass filters for dispersive string sound synthesis", IEEE Signal
    Processing Letters 17(4), 406-409, 2010.
    J. Rauhala and V. Valimaki, "Tunable dispersion filter design for piano
    synthesis", IEEE Signal Processing Letters 13(5), 253-256, 2006.
    C. L. Lawson, "Contributions to the theory of linear least maximum
    approximation", PhD thesis, UCLA, 1961 (iteratively reweighted least
    squares towards minimax).
    """
    fs = _num("fs", fs, 0.0, 1e8, lo_open=True)
    f1_hz = _num("f1_hz", f1_hz, 0.0, fs / 16.0, lo_open=True, hi_open=True)
    B = _num("B", B, 0.0, 0.1)
    _check_loss(fs, t60_low_s, f_low_hz, t60_high_s, f_high_hz)
    tol_cents, max_partials, f_max_hz = _check_sos_band(fs, tol_cents, max_partials, f_max_hz)
    max_biquads = _int("max_biquads", max_biquads, 0, MAX_SOS)
    m_max = _int("m_max", m_max, 0, M_LIMIT)
    f0 = f1_hz / math.sqrt(1.0 + B)
    K = default_n_partials(f0, B, f_max_hz, max_partials)
    b0, a1 = _stiff_loss_filter(f0, B, fs, t60_low_s, f_low_hz, t60_high_s, f_high_hz)
    pb = _SosProblem(f0, B, fs, K, a1, bridge)

    found = None
    if K >= 2 and B > 0.0:
        found = pb.design(tol_cents, max_biquads)[0]
    if found is not None:
        M, m1, (N, extra, eta, sos, a, cents) = found
        kind, n_fo, a_fo = "sos", m1, (float(a) if m1 else 0.0)
    else:
        N, extra, eta, n_fo, a_fo, cents = _first_order_loop(pb, m_max, tol_cents)
        kind, sos = "first-order", np.zeros((0, 2))
        a_fo = float(a_fo) if n_fo else 0.0
    if N < MIN_CELLS:
        raise ValueError(f"f1_hz = {f1_hz!r} is out of range: the loop keeps {N} "
                         f"cells (allowed: >= {MIN_CELLS}, f1 < fs/16)")
    return SosStiffLoop(int(N), int(extra), b0, a1, float(eta), int(n_fo), a_fo, _frozen(sos),
                        int(K), float(np.max(np.abs(cents))), _frozen(cents), kind, f0,
                        float(f1_hz), float(B), float(fs), tol_cents, f_max_hz, max_partials,
                        bridge if kind == "sos" else None)


def retune_sos_loop(loop: SosStiffLoop, f1_hz: float, t60_low_s: float, f_low_hz: float,
                    t60_high_s: float, f_high_hz: float, *, refit: bool = True) -> SosStiffLoop:
    """The same key's cascade in a loop tuned to another partial 1 and other
    decay times: the unison strings of a key, detuned by about +-1 cent,
    with their own T60s.

    The loss filter, N, the extra delay and the tuning allpass are
    recomputed for this string and the cascade (biquads and first-order
    sections) is kept, for the same K partials as ``loop``.  The loss
    filter's own dispersion changes with the T60s, which moves the errors by
    up to ~0.4 cent on the grand's strings; when that takes the string out
    of ``loop.tol_cents`` and ``refit`` is true, the cascade (same number of
    biquads and first-order sections, so the same cost) is refitted for
    this string, warm-started from the key's poles (Lawson passes as in
    :func:`tune_stiff_loop_sos`, ~2 ms), and the better of the two loops is
    returned.  ``worst_cents`` is that of the returned exact loop either way.

    Parameters
    ----------
    loop : SosStiffLoop
        The key's design (B, fs, K, the tolerance and the cascade come from
        it).
    f1_hz : float
        Partial 1 (Hz) of this string, 0 < f1 < fs/16.
    t60_low_s, f_low_hz, t60_high_s, f_high_hz : float
        Its decay times, as :func:`tune_stiff_loop_sos`.
    refit : bool
        Refit the cascade when the kept one misses the tolerance (only for
        ``kind == "sos"``).

    Returns
    -------
    SosStiffLoop
        Same ``kind``, number of biquads and first-order sections.  Raises
        ValueError for an out-of-range parameter or when fewer than 8 cells
        would remain.
    """
    if not isinstance(loop, SosStiffLoop):
        raise ValueError(f"loop = {type(loop).__name__} is out of range (allowed: a SosStiffLoop)")
    fs, B, K = loop.fs, loop.B, loop.n_partials
    f1_hz = _num("f1_hz", f1_hz, 0.0, fs / 16.0, lo_open=True, hi_open=True)
    _check_loss(fs, t60_low_s, f_low_hz, t60_high_s, f_high_hz)
    f0 = f1_hz / math.sqrt(1.0 + B)
    top = float(stiff_partials(f0, B, K))
    if top >= 0.45 * fs:
        raise ValueError(f"f1_hz = {f1_hz!r} is out of range: partial {K} would be at {top:g} Hz "
                         f"(allowed: below 0.45 fs = {0.45 * fs:g} Hz)")
    b0, a1 = _stiff_loss_filter(f0, B, fs, t60_low_s, f_low_hz, t60_high_s, f_high_hz)
    pb = _SosProblem(f0, B, fs, K, a1, loop.bridge)

    def build(sos, a_fo):
        # the cascade's lag at this string's partial 1, then the tuning
        C1 = float(2.0 * len(sos) * pb.w1)
        if len(sos):
            C1 += 2.0 * float(np.sum(np.angle(1.0 - sos_poles(sos).ravel() * pb.Ewc[0])))
        if loop.n_fo:
            C1 += loop.n_fo * float(_fo_lag(pb.w1, a_fo))
        N, extra, eta, _ = pb.tuning(C1)
        L, q, m = _loop_lag_terms(eta, a1, loop.n_fo, a_fo, sos)
        w = _loop_partials_w(2 * N + extra, L, q, m, pb.n, pb.w, pb.bridge)
        return N, extra, eta, sos, a_fo, CENTS_PER_LN * np.log(w / pb.w)

    best = build(loop.sos, loop.a_fo)
    worst = float(np.max(np.abs(best[5])))
    M, m1 = loop.n_sos, loop.n_fo
    p = loop.poles()
    if (refit and worst > loop.tol_cents and loop.kind == "sos" and K >= 2 and B > 0.0
            and np.all(p.imag > 0.0)):
        x = [np.log(np.angle(p)), np.log(-np.log(np.abs(p)))]
        if m1:
            x.append([math.log1p(loop.a_fo)])
        x = np.concatenate(x)
        e, _ = pb.excess(x, M, m1)
        x, e = pb.lawson(x, e, M, m1, _LAWSON_PASSES, _LAWSON_ITERS, 0.0)
        N, extra, eta, sos, a, cents = pb.exact(M, m1, x)
        if N >= MIN_CELLS and float(np.max(np.abs(cents))) < worst:
            best = (N, extra, eta, sos, float(a) if m1 else 0.0, cents)
            worst = float(np.max(np.abs(cents)))
    N, extra, eta, sos, a_fo, cents = best
    if N < MIN_CELLS:
        raise ValueError(f"f1_hz = {f1_hz!r} is out of range: the loop keeps {N} "
                         f"cells (allowed: >= {MIN_CELLS}, f1 < fs/16)")
    return SosStiffLoop(int(N), int(extra), b0, a1, float(eta), loop.n_fo, a_fo, _frozen(sos),
                        int(K), worst, _frozen(cents), loop.kind, f0, float(f1_hz), float(B),
                        float(fs), loop.tol_cents, loop.f_max_hz, loop.max_partials, loop.bridge)
