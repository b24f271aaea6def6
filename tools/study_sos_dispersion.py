"""Study: stiffness dispersion with second-order allpass sections, against
the first-order cascade the grand voice uses (not yet in the voice).

    python tools/study_sos_dispersion.py [--keys 21,24,...|all] [--tol 2] [--m-max 8]
    python tools/study_sos_dispersion.py --simulate 21,45 [--seconds 1]

The design now lives in the physics layer, in numpy only
(:func:`synth.physics.dispersion.tune_stiff_loop_sos`); this study keeps
its scipy version (below) for comparison: the table shows both.

The grand's strings (synth.voices.grand) get their stiffness from M
identical first-order allpasses (synth.physics.dispersion), which at the
325 kHz internal rate keep only the lowest 8-24 partials within 2 cents.
This study designs instead a cascade of M second-order allpass sections
with individual poles,

    H_i(z) = (a2 + a1 z^-1 + z^-2) / (1 + a1 z^-1 + a2 z^-2),
    a1 = -2 R_i cos(theta_i),  a2 = R_i^2,

(and at most one first-order section), for the same loop (2N + extra
samples, the same one-pole loss filter, a first-order tuning allpass that
makes partial 1 exact):

1. start (Abel, Valimaki and Smith 2010): the phase the cascade must add
   to the loop's delay and loss filter so that partial n has a total lag of
   2 pi n is split into M parts of 2 pi; pole i sits where it crosses
   (i - 1/2) 2 pi, with R_i = exp(-0.7 x half the spacing of its
   neighbours' angles);
2. Levenberg-Marquardt (scipy, analytic Jacobian, 40 evaluations) on the
   cents errors of partials 2..K, the rest of the loop modelled as a
   continuous delay that keeps partial 1 exact (fixing the integer delay
   during the fit stalls it);
3. a few Lawson reweighting passes towards minimax when the least-squares
   worst error is within 2.2x the tolerance;
4. the fewest cost units (a biquad = 2 first-order sections) from the
   phase budget up that meet the tolerance; the integer delay, extra delay
   and tuning allpass then as :func:`synth.physics.dispersion.tune_stiff_loop`.

The table gives, per key, the first-order design (sections, partials
within tolerance, worst error over 1..K, design time) and this one
(sections, worst error from the exact loop partials, design time), the
scipy version of this study and the physics layer's numpy version.
``--simulate`` runs the complete loop of the physics design from an
impulse for ``--seconds`` and measures the partials (Blackman-Harris
windowed DTFT peaks).  The scipy column needs scipy (installed with the
test extras; ``--no-scipy`` leaves it out).
"""

from __future__ import annotations

import argparse
import math
import sys
import time

import numba as nb
import numpy as np

from synth.physics import dispersion as D
from synth.physics.dispersion.first_order import _golden
from synth.physics.losses import loop_gain_from_t60, one_pole_from_two_gains
from synth.physics.piano import grand_string

FS = 325000.0
KEYS = (21, 24, 28, 33, 40, 45, 52, 57, 60, 64, 69, 76)
TWO_PI = 2.0 * math.pi

CPL = 1200.0 / math.log(2.0)


# ---------------------------------------------------------------------------
# phase lags (vectorised) and their derivatives

def biquad_lag(w, th, R):
    """Lag (rad) of each section at each w: shape (M, K)."""
    w = w[None, :]
    th = th[:, None]
    R = R[:, None]
    x = w - th
    y = w + th
    return 2 * w + 2 * np.arctan2(R * np.sin(x), 1 - R * np.cos(x)) \
        + 2 * np.arctan2(R * np.sin(y), 1 - R * np.cos(y))


def biquad_lag_jac(w, th, R):
    """Lag (M, K) and d lag / d theta, d lag / d R (each (M, K))."""
    w = w[None, :]
    th = th[:, None]
    R = R[:, None]
    x = w - th
    y = w + th
    cx, sx, cy, sy = np.cos(x), np.sin(x), np.cos(y), np.sin(y)
    dx = 1 - 2 * R * cx + R * R
    dy = 1 - 2 * R * cy + R * R
    lag = 2 * w + 2 * np.arctan2(R * sx, 1 - R * cx) + 2 * np.arctan2(R * sy, 1 - R * cy)
    dth = 2 * (-(R * cx - R * R) / dx + (R * cy - R * R) / dy)
    dR = 2 * (sx / dx + sy / dy)
    return lag, dth, dR


def fo_lag(w, a):
    return w - 2 * np.arctan2(a * np.sin(w), 1 + a * np.cos(w))


def fo_lag_da(w, a):
    return -2 * np.sin(w) / (1 + 2 * a * np.cos(w) + a * a)


def lp_lag(w, a1):
    """Phase lag of b0/(1 + a1 z^-1)."""
    return np.arctan2(-a1 * np.sin(w), 1 + a1 * np.cos(w))


def eta_of_rem(rem, w1):
    return np.sin((1 - rem) * w1 / 2) / np.sin((1 + rem) * w1 / 2)


# ---------------------------------------------------------------------------
# problem


class Problem:
    def __init__(self, f1_hz, B, fs, t60_low_s, f_low_hz, t60_high_s, f_high_hz,
                 n_partials=None, f_max_hz=D.F_MAX_HZ):
        f0 = f1_hz / math.sqrt(1 + B)
        self.f0, self.B, self.fs, self.f1 = f0, B, fs, f1_hz
        K = D.default_n_partials(f0, B, f_max_hz) if n_partials is None else int(n_partials)
        self.K = K
        # loss filter exactly as tune_stiff_loop
        f2 = min(f_high_hz, 0.45 * fs)
        tau_lo = float(D.stiff_group_delay(f_low_hz, f0, B, fs))
        tau_hi = float(D.stiff_group_delay(f2, f0, B, fs))
        g1 = loop_gain_from_t60(fs / tau_lo, t60_low_s)
        g2 = min(loop_gain_from_t60(fs / tau_hi, t60_high_s), g1)
        self.b0, self.a1 = one_pole_from_two_gains(g1, f_low_hz, g2, f2, fs)
        n = np.arange(1, K + 1, dtype=float)
        self.n = n
        fn = D.stiff_partials(f0, B, n)
        self.fn = fn
        self.w = TWO_PI * fn / fs
        self.w1 = float(self.w[0])
        self.P1 = fs / float(fn[0])
        self.lpl = lp_lag(self.w, self.a1)
        self.lpd1 = float(self.lpl[0]) / self.w1
        self.tau = D.stiff_group_delay(fn, f0, B, fs)
        self.scale = -CPL / (self.w * self.tau)      # cents per rad of lag error

    # -- tuning as tune_stiff_loop: partial 1 exact
    def tuning(self, C1):
        """Integer delay (2N + extra), N, extra, rem for cascade lag C1 at w1."""
        rest = self.P1 - self.lpd1 - C1 / self.w1
        N = math.floor((rest - 0.5) / 2.0)
        rem = rest - 2 * N
        extra = 1 if rem >= 1.5 else 0
        return 2 * N + extra, N, extra, rem - extra

    def cascade(self, th, R, m1=0, a=0.0, jac=False):
        if jac:
            lag, dth, dR = biquad_lag_jac(self.w, th, R)
        else:
            lag = biquad_lag(self.w, th, R)
        C = lag.sum(axis=0)
        if m1:
            C = C + m1 * fo_lag(self.w, a)
        if jac:
            da = m1 * fo_lag_da(self.w, a) if m1 else None
            return C, dth, dR, da
        return C

    def cents(self, th, R, m1=0, a=0.0):
        """Linearised cents errors of partials 1..K (+ = sharp), and tuning."""
        C = self.cascade(th, R, m1, a)
        Dt, N, extra, rem = self.tuning(float(C[0]))
        eta = float(eta_of_rem(rem, self.w1))
        lag = Dt * self.w + self.lpl + fo_lag(self.w, eta) + C
        return self.scale * (lag - TWO_PI * self.n), (N, extra, eta)

    # -- AVS initial design
    def avs(self, M, c=2.0, m1=0, a0=None):
        """Pole angles where the desired cascade phase crosses (k - 1/2) 2 pi,
        radii R = exp(-c * half-spacing).  The desired biquad phase is
        2 pi n(w) - lp_lag(w) - L w (- the first-order section's lag, pole
        ``a0``, when m1 = 1) with L such that it is 2 pi M at n = K + 1/2;
        when that is not increasing (too few sections for the whole band) L
        is the smallest group delay and the pole targets are scaled to the
        phase left."""
        f0, B, fs = self.f0, self.B, self.fs
        n_top = self.K + 0.5
        w_top = TWO_PI * float(D.stiff_partials(f0, B, n_top)) / fs
        fo_top = m1 * float(fo_lag(np.array([w_top]), a0)[0]) if m1 else 0.0
        tot = TWO_PI * M + fo_top
        L = (TWO_PI * n_top - float(lp_lag(np.array([w_top]), self.a1)[0]) - tot) / w_top
        wg = np.linspace(0.0, w_top, 512)
        ngr = D.partial_number(wg * fs / TWO_PI, f0, B)
        base = TWO_PI * ngr - lp_lag(wg, self.a1)
        fo = m1 * fo_lag(wg, a0) if m1 else 0.0
        phi = base - L * wg - fo
        targets = TWO_PI * (np.arange(1, M + 1) - 0.5)
        if np.any(np.diff(phi) <= 0):
            L = float(np.gradient(base, wg).min()) * (1 - 1e-3)
            phi = base - L * wg - fo
            targets = targets * (phi[-1] / (phi[-1] if m1 else tot))
        th = np.interp(targets, phi, wg)
        ext = np.concatenate(([-th[0]], th, [2 * th[-1] - th[-2] if M > 1 else 2 * th[0]]))
        R = np.exp(-c * 0.5 * (ext[2:] - ext[:-2]))
        return th, R

    # -- refinement
    def refine(self, th, R, m1=0, a=0.0, max_nfev=30, xtol=1e-10):
        """Gauss-Newton / Levenberg-Marquardt on the cents errors of partials
        2..K.  The rest of the loop (2N + extra + tuning allpass) is modelled
        as a continuous ideal delay D = P1 - lp_delay(w1) - C(w1)/w1, so that
        partial 1 stays exact and the integer/fractional split does not make
        the residual discontinuous; the tuning allpass's own dispersion
        (< 0.006 samples at 10 kHz) is left to the final exact evaluation."""
        M = len(th)
        w1 = self.w1
        w = self.w
        ratio = (w / w1)[1:]
        base = (self.P1 - self.lpd1) * w[1:] + self.lpl[1:] - TWO_PI * self.n[1:]
        sc = self.scale[1:]

        def unpack(x):
            th = np.exp(x[:M])
            R = np.exp(-np.exp(x[M:2 * M]))
            aa = math.expm1(x[2 * M]) if m1 else 0.0
            return th, R, aa

        def fun(x):
            th, R, aa = unpack(x)
            C = self.cascade(th, R, m1, aa)
            return sc * (base + C[1:] - ratio * C[0])

        def jac(x):
            th, R, aa = unpack(x)
            C, dth, dR, da = self.cascade(th, R, m1, aa, jac=True)
            Jth = (dth[:, 1:] - ratio[None, :] * dth[:, :1]) * th[:, None]
            JR = (dR[:, 1:] - ratio[None, :] * dR[:, :1]) * (R * np.log(R))[:, None]
            cols = [Jth, JR]
            if m1:
                cols.append(((da[1:] - ratio * da[0]) * (1 + aa))[None, :])
            return sc[:, None] * np.concatenate(cols, axis=0).T

        x0 = [np.log(th), np.log(-np.log(R))]
        if m1:
            x0.append([math.log1p(a)])
        x0 = np.concatenate(x0)
        from scipy.optimize import least_squares
        method = "lm" if self.K - 1 >= len(x0) else "trf"
        sol = least_squares(fun, x0, jac=jac, method=method, max_nfev=max_nfev,
                            xtol=xtol, ftol=1e-12, gtol=1e-12)
        th, R, aa = unpack(sol.x)
        return th, R, aa, sol


def lawson(pb: Problem, th, R, m1, a, passes=6, nfev=20):
    """Towards minimax: Lawson reweighting, w_n <- w_n |e_n| (normalised),
    each pass a weighted Levenberg-Marquardt warm-started from the last."""
    c = pb.cents(th, R, m1, a)[0]
    wts = np.ones(pb.K)
    sc0 = pb.scale
    for _ in range(passes):
        wts = wts * (np.abs(c) + 1e-3 * np.max(np.abs(c)))
        wts = wts / wts.mean()
        pb.scale = sc0 * np.sqrt(wts)
        try:
            th, R, a, _ = pb.refine(th, R, m1, a, max_nfev=nfev)
        finally:
            pb.scale = sc0
        c = pb.cents(th, R, m1, a)[0]
    return th, R, a


def design_sos(pb: Problem, tol=2.0, u_max=32, c=0.7, r_fo=2.0, max_nfev=40, passes=6,
            skip_factor=2.2):
    """Cheapest cascade (U = 2 M + m1 first-order-section units) whose
    LS + Lawson (near-minimax) design keeps partials 1..K within ``tol``.
    Starts at U = ceil(phase budget); AVS init with the fallback (delay
    slope = smallest group delay) when the phase is not monotone."""
    K = pb.K
    if K < 2 or pb.B == 0:
        return dict(M=0, m1=0, th=np.zeros(0), R=np.zeros(0), a=0.0, worst=0.0,
                    tuning=pb.tuning(0.0)[1:3] + (0.0,), nfev=0, tried=0)
    u0 = max(2, int(math.ceil(D.phase_budget_sections(pb.f0, pb.B, K) - 1e-9)))
    best = None
    tried = 0
    for U in range(u0, u_max + 1):
        M, m1 = U // 2, U % 2
        a0 = -1.0 + r_fo * pb.w1 if m1 else None
        th, R = pb.avs(M, c, m1=m1, a0=a0)
        tried += 1
        th, R, aa, sol = pb.refine(th, R, m1, a0 if m1 else 0.0, max_nfev=max_nfev)
        w_ls = float(np.max(np.abs(pb.cents(th, R, m1, aa)[0])))
        if w_ls > tol and w_ls <= skip_factor * tol and passes:
            th, R, aa = lawson(pb, th, R, m1, aa, passes)
        cents, tun = pb.cents(th, R, m1, aa)
        worst = float(np.max(np.abs(cents)))
        rec = dict(M=M, m1=m1, th=th, R=R, a=aa, worst=worst, cents=cents, tuning=tun,
                   nfev=sol.nfev, tried=tried)
        if best is None or worst < best["worst"]:
            best = rec
        if worst <= tol:
            return rec
    return best


# ---------------------------------------------------------------------------
# exact partials of the complete loop (bisection on the continuous lag)

def loop_lag(pb, th, R, m1, a, N, extra, eta, w):
    return ((2 * N + extra) * w + lp_lag(w, pb.a1) + fo_lag(w, eta)
            + biquad_lag(w, th, R).sum(axis=0) + (m1 * fo_lag(w, a) if m1 else 0.0))


def exact_partials(pb, th, R, m1, a, N, extra, eta, K):
    n = np.arange(1, K + 1, dtype=float)
    lo = np.zeros(K)
    hi = np.full(K, math.pi * 0.999999)
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        above = loop_lag(pb, th, R, m1, a, N, extra, eta, mid) > TWO_PI * n
        hi = np.where(above, mid, hi)
        lo = np.where(above, lo, mid)
    return 0.5 * (lo + hi) * pb.fs / TWO_PI


def sos_coeffs(th, R):
    return -2 * R * np.cos(th), R * R


@nb.njit
def run_loop(nsamp, Dint, b0, a1, eta, m1, afo, c1, c2):
    """The loop from an impulse: ``m1`` identical first-order sections of
    coefficient ``afo``, biquads (c1, c2)."""
    M = c1.shape[0]
    ring = np.zeros(Dint)
    out = np.zeros(nsamp)
    lp_y = 0.0
    ap_x = 0.0
    ap_y = 0.0
    fo_x = np.zeros(max(m1, 1))
    fo_y = np.zeros(max(m1, 1))
    x1 = np.zeros(M)
    x2 = np.zeros(M)
    y1 = np.zeros(M)
    y2 = np.zeros(M)
    pos = 0
    for n in range(nsamp):
        s = ring[pos]                            # loop signal Dint samples ago
        # loss filter b0 / (1 + a1 z^-1)
        lp_y = b0 * s - a1 * lp_y
        u = lp_y
        # tuning allpass (eta + z^-1)/(1 + eta z^-1)
        y = eta * u + ap_x - eta * ap_y
        ap_x = u
        ap_y = y
        u = y
        for j in range(m1):
            y = afo * u + fo_x[j] - afo * fo_y[j]
            fo_x[j] = u
            fo_y[j] = y
            u = y
        # biquad allpasses (a2 + a1 z^-1 + z^-2)/(1 + a1 z^-1 + a2 z^-2), DF-I
        for i in range(M):
            y = c2[i] * u + c1[i] * x1[i] + x2[i] - c1[i] * y1[i] - c2[i] * y2[i]
            x2[i] = x1[i]
            x1[i] = u
            y2[i] = y1[i]
            y1[i] = y
            u = y
        if n == 0:
            u += 1.0                             # impulse
        out[n] = u
        ring[pos] = u
        pos += 1
        if pos == Dint:
            pos = 0
    return out


def bh4(n):
    t = np.arange(n) / (n - 1)
    return (0.35875 - 0.48829 * np.cos(2 * np.pi * t) + 0.14128 * np.cos(4 * np.pi * t)
            - 0.01168 * np.cos(6 * np.pi * t))


def peak_freq(xw, fs, f_guess, half_width):
    """Frequency of the largest |DTFT| of xw within f_guess +- half_width:
    a 41-point grid, then golden section (dispersion's) around its best."""
    t = np.arange(len(xw)) / fs

    def mag(f):
        return -abs(np.dot(xw, np.exp(-2j * np.pi * f * t)))

    fg = np.linspace(f_guess - half_width, f_guess + half_width, 41)
    i = int(np.argmin([mag(f) for f in fg]))
    return _golden(mag, fg[max(i - 1, 0)], fg[min(i + 1, 40)], 40)[0]



def string_args(key):
    """(f1, B, t60 low, t60 high, f high) of the grand's key as the voice uses them."""
    g = grand_string(key)
    B = g.inharmonicity_b
    f1 = g.f0_hz * math.sqrt(1 + B)
    return f1, B, g.t60_low_s, g.t60_high_s, max(g.f_high_hz, 1.5 * f1)


def table(keys, tol, reps, m_max, scipy_too=True):
    print(f"| key | partials K | first-order (m_max {m_max}): sections / within tol / worst 1..K "
          "(cents) / ms "
          + ("| second-order, scipy study: biquads + first-order (cost) / worst 1..K (cents) / ms "
             if scipy_too else "")
          + "| second-order, physics (numpy): biquads + first-order (cost) / worst 1..K "
          "(cents) / ms |")
    print("|---|---|---|" + ("---|" if scipy_too else "") + "---|")
    tot = 0.0
    for key in keys:
        f1, B, tlo, thi, fh = string_args(key)
        to = []
        for _ in range(3):
            t0 = time.perf_counter()
            old = D.tune_stiff_loop(f1, B, FS, tlo, f1, thi, fh, m_max=m_max)
            to.append(time.perf_counter() - t0)
        tn = []
        for _ in range(reps):
            t0 = time.perf_counter()
            new = D.tune_stiff_loop_sos(f1, B, FS, tlo, f1, thi, fh, tol_cents=tol)
            tn.append(time.perf_counter() - t0)
        tot += float(np.median(tn))
        K = new.n_partials
        co = 1200 * np.log2(old.partials(K) / new.target_partials(K))
        row = (f"| {key} | {K} | {old.M} / {old.n_fit} / {np.max(np.abs(co)):.1f} / "
               f"{1e3 * np.median(to):.1f} |")
        if scipy_too:
            ts = []
            for _ in range(reps):
                t0 = time.perf_counter()
                pb = Problem(f1, B, FS, tlo, f1, thi, fh)
                d = design_sos(pb, tol=tol)
                ts.append(time.perf_counter() - t0)
            N, extra, eta = d["tuning"]
            fe = exact_partials(pb, d["th"], d["R"], d["m1"], d["a"], N, extra, eta, pb.K)
            ce = 1200 * np.log2(fe / pb.fn)
            row += (f" {d['M']} + {d['m1']} ({2 * d['M'] + d['m1']}) / "
                    f"{np.max(np.abs(ce)):.2f} / {1e3 * np.median(ts):.1f} |")
        fb = " fallback" if new.kind != "sos" else ""
        row += (f" {new.n_sos} + {new.n_fo} ({new.cost}){fb} / {new.worst_cents:.2f} / "
                f"{1e3 * np.median(tn):.1f} |")
        print(row, flush=True)
    print(f"\nphysics design, sum of the median times over {len(keys)} keys: {tot:.3f} s")


def simulate(keys, seconds, tol):
    """Run the physics layer's design (tune_stiff_loop_sos) in the time domain."""
    for key in keys:
        f1, B, tlo, thi, fh = string_args(key)
        lp = D.tune_stiff_loop_sos(f1, B, FS, tlo, f1, thi, fh, tol_cents=tol)
        K = lp.n_partials
        fn = lp.target_partials(K)
        nsamp = int(seconds * FS)
        y = run_loop(nsamp, lp.delay_samples, lp.b0, lp.a1, lp.eta, lp.n_fo, lp.a_fo,
                     np.ascontiguousarray(lp.sos[:, 0]), np.ascontiguousarray(lp.sos[:, 1]))
        xw = (y - y.mean()) * bh4(nsamp)
        meas = np.array([peak_freq(xw, FS, f, 0.3 * lp.f0_string) for f in fn])
        model = lp.partials(K)
        c_meas = 1200 * np.log2(meas / fn)
        print(f"key {key}: {K} partials, {lp.n_sos} biquads + {lp.n_fo} first-order, "
              f"{lp.cells} cells: worst |measured - target| {np.max(np.abs(c_meas)):.3f} cents, "
              f"worst |measured - designed| {np.max(np.abs(1200 * np.log2(meas / model))):.5f} cents",
              flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--keys", default=",".join(map(str, KEYS)), help="comma list or 'all'")
    ap.add_argument("--m-max", type=int, default=8,
                    help="most first-order sections of the old design (default 8, the preset's)")
    ap.add_argument("--no-scipy", action="store_true", help="leave out the scipy column")
    ap.add_argument("--tol", type=float, default=2.0, help="cents (default 2)")
    ap.add_argument("--reps", type=int, default=7, help="timing repetitions (default 7)")
    ap.add_argument("--simulate", metavar="KEYS", help="run the loops of these keys instead")
    ap.add_argument("--seconds", type=float, default=1.0)
    a = ap.parse_args(argv)
    print(f"# {time.strftime('%Y-%m-%d %H:%M')}  python {' '.join(sys.argv)}")
    if a.simulate:
        simulate([int(k) for k in a.simulate.split(",")], a.seconds, a.tol)
    else:
        keys = range(21, 109) if a.keys == "all" else [int(k) for k in a.keys.split(",")]
        table(keys, a.tol, a.reps, a.m_max, not a.no_scipy)
    return 0


if __name__ == "__main__":
    sys.exit(main())
