"""Slow, obvious numpy references for the kernels (never used by the package).

``naive_string`` is the shift-every-array scheme of Publication II (eqs.
9-13) with the conventions of physics notes sections 1-3: two explicit rails
u_r[0..N], u_l[0..N]; each step shift, reflect (u_l(L) = -u_r(L),
u_r(0) = -u_l(0)), inject g at k on both outgoing rails, clamp the region,
read u(k) = u_r + u_l - g.
"""

from __future__ import annotations

import numpy as np


def _q2(r):
    """q(r)^2, q = 1 - sqrt(1 - r) (the first cell's tangent point over
    dx), 0 below r = 0 and 1 above r = 1."""
    r = min(max(r, 0.0), 1.0)
    return (1.0 - np.sqrt(1.0 - r)) ** 2


_GL40 = np.polynomial.legendre.leggauss(40)


def _secant(a, b):
    """(phi(a) - phi(b)) / (a - b): the mean of q^2 between a and b, its
    integral taken over the interval itself (Gauss-Legendre in t = sqrt(1
    - r), where q^2 dr = (1 - t)^2 2t dt is a polynomial; 1 beyond r = 1),
    so that no difference of two nearly equal integrals is formed; q^2(a)
    at a = b.  (Until 2026-11-27 the secant of two close points was q^2
    at their midpoint, whose error next to r = 1, where q^2 has a square
    root's slope, reached 1.2e-6 of G where the kernel was right.)"""
    lo, hi = (a, b) if a <= b else (b, a)
    if hi <= 0.0:
        return 0.0
    if lo >= 1.0:
        return 1.0
    if hi == lo:
        return _q2(lo)
    r0, r1 = max(lo, 0.0), min(hi, 1.0)
    xg, wg = _GL40
    t_lo, t_hi = np.sqrt(1.0 - r1), np.sqrt(1.0 - r0)
    width = (r1 - r0) / (t_hi + t_lo)     # t_hi - t_lo, without its cancellation
    t = 0.5 * width * xg + 0.5 * (t_hi + t_lo)
    I = 0.5 * width * np.sum(wg * (1.0 - t) ** 2 * 2.0 * t)
    I += max(hi - max(lo, 1.0), 0.0)
    return float(I / (hi - lo))


def subcell_delta(ut, up, U1, G):
    """The first cell's sub-cell contact, written out (side-scaled, U1 > 0,
    0 < G <= U1): the delta that solves delta (ut + delta - up) =
    -G^2 (phi(r(ut + delta)) - phi(r(up))), r(u) = (u - U1 + G) / G, by
    bisection on [-G, 0] (the kernel: closed forms and Newton's steps)."""
    base = U1 - G

    def res(d):
        a = (ut + d - base) / G
        b = (up - base) / G
        return d + G * _secant(a, b)

    if (ut - base) <= 0.0 and (up - base) <= 0.0:
        return 0.0
    lo, hi = -G, 0.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if res(mid) > 0.0:
            hi = mid
        else:
            lo = mid
        if hi - lo <= 1e-17 * G:
            break
    return 0.5 * (lo + hi)


def _step(ur, ul, k, gm, U, side, R, curv=0.0, u1p=None):
    """One step of the naive scheme except the far end x = L: shift both
    rails, reflect at x = 0, inject gm at k on both outgoing rails, clamp
    the region points 1..R (the far end's u_l[N] is set by the caller);
    with ``curv`` > 0 (the kernel's ``F_CURV``) the wave leaving x = 0
    then takes the first cell's sub-cell contact (:func:`subcell_delta`;
    ``u1p``, a one-element list, holds u(1) at the last step)."""
    ur[1:] = ur[:-1].copy()
    ul[:-1] = ul[1:].copy()
    ur[0] = -ul[0]
    ur[k] += gm
    ul[k] += gm
    for n in range(1, R + 1):
        u = ur[n] + ul[n] - (gm if n == k else 0.0)
        if side * (u - U[n - 1]) > 0:
            ur[n] += U[n - 1] - u
    if curv > 0.0 and R > 0:
        u1 = ur[1] + ul[1]                    # (k >= 3)
        U1 = side * U[0]
        if 0.0 < U1 < np.inf:
            # u(1) at the next step without delta: ur[0] and ul[2] move there
            ut = ur[0] + ul[2]
            ur[0] += side * subcell_delta(side * ut, side * u1p[0], U1, curv * U1)
        u1p[0] = u1


def naive_string(N, k, g, U=None, side=1, n_steps=None, record_shape_at=(), curv=0.0):
    """Run the ideal string for ``n_steps`` with outgoing wave samples ``g``
    (g[m] used at step m = 1..n_steps; g beyond its length stays at g[-1]).

    U : array of U at points 1..R (inf = no contact) or None.
    curv : the first cell's sub-cell contact (``_step``), 0: off.
    Returns (u_k per step, dict step -> (u, v) shapes) where shapes are
    the displacement along x = 0..N and u_r, u_l.
    """
    g = np.asarray(g, float)
    n_steps = len(g) if n_steps is None else n_steps
    ur = np.zeros(N + 1)
    ul = np.zeros(N + 1)
    out = np.zeros(n_steps)
    shapes = {}
    R = 0 if U is None else len(U)
    u1p = [0.0]
    for m in range(n_steps):
        gm = g[m] if m < len(g) else g[-1]
        _step(ur, ul, k, gm, U, side, R, curv, u1p)
        ul[N] = -ur[N]
        out[m] = ur[k] + ul[k] - gm
        if m in record_shape_at:
            u = ur + ul
            u[k] -= gm
            shapes[m] = (u.copy(), ur.copy(), ul.copy())
    return out, shapes


def naive_lossy_string(N, k, g, U=None, side=1, n_steps=None, *, b0, a1, eta,
                       extra_delay=0, n_disp=0, a_disp=0.0, sos=(), bend=None, curv=0.0):
    """``naive_string`` with the musical far end: the wave arriving at x = L
    goes through [unit delay], the one-pole loss y = b0 x - a1 y1, ``n_disp``
    first-order allpasses (a + z^-1)/(1 + a z^-1) and the tuning allpass
    (eta), then the second-order allpasses ``sos`` ((c1, c2) per section,
    (c2 + c1 z^-1 + z^-2)/(1 + c1 z^-1 + c2 z^-2)), then, with ``bend`` =
    (D, to, r), a delay line read at D + to r^m samples at step m (third-order
    Lagrange over delays i-1 .. i+2, i = floor; D at rest, a tune-out to
    decaying by r per step), and leaves inverted: u_l(L) = -y.  g is
    injected every step, held at its last value forever (no folding).
    Returns u_k per step."""
    g = np.asarray(g, float)
    n_steps = len(g) if n_steps is None else n_steps
    ur = np.zeros(N + 1)
    ul = np.zeros(N + 1)
    out = np.zeros(n_steps)
    R = 0 if U is None else len(U)
    u1p = [0.0]
    xd = lp = apx = apy = 0.0
    dx1 = np.zeros(n_disp)
    dy1 = np.zeros(n_disp)
    bq = [[0.0, 0.0, 0.0, 0.0] for _ in sos]      # x1, x2, y1, y2 per section
    hist = np.zeros(n_steps + 8)                  # the bend line's input, hist[m + 4] at step m
    for m in range(n_steps):
        gm = g[m] if m < len(g) else g[-1]
        _step(ur, ul, k, gm, U, side, R, curv, u1p)
        x = ur[N]
        if extra_delay:
            x, xd = xd, x
        lp = b0 * x - a1 * lp
        y = lp
        for d in range(n_disp):
            yd = a_disp * y + dx1[d] - a_disp * dy1[d]
            dx1[d], dy1[d] = y, yd
            y = yd
        yo = eta * y + apx - eta * apy
        apx, apy = y, yo
        for j, (c1, c2) in enumerate(sos):
            # (c2 + c1 z^-1 + z^-2) / (1 + c1 z^-1 + c2 z^-2), its own history
            h = bq[j]
            yb = c2 * yo + c1 * h[0] + h[1] - c1 * h[2] - c2 * h[3]
            bq[j] = [yo, h[0], yb, h[2]]
            yo = yb
        if bend is not None:
            D0, to, r = bend
            hist[m + 4] = yo
            D = D0 + to * r ** m
            i = int(np.floor(D))
            f = D - i
            taps = (-f * (f - 1) * (f - 2) / 6, (f + 1) * (f - 1) * (f - 2) / 2,
                    -(f + 1) * f * (f - 2) / 2, (f + 1) * f * (f - 1) / 6)
            yo = sum(h * (hist[m + 4 - d] if m + 4 - d >= 4 else 0.0)
                     for h, d in zip(taps, (i - 1, i, i + 1, i + 2)))
        ul[N] = -yo
        out[m] = ur[k] + ul[k] - gm
    return out


def closed_form_uk(g, N, k):
    """Publication I eq. (4) on the grid (delays 2iL/c = 2iN samples,
    2aL/c = 2k, 2bL/c = 2(N-k)): u(l, m) for g[m], m = 0.."""
    g = np.asarray(g, float)
    n = len(g)

    def G(d):
        out = np.zeros(n)
        if d < n:
            out[d:] = g[: n - d]
        return out

    u = g.copy()
    i = 1
    while 2 * i * N < n:
        u += 2 * G(2 * i * N)
        i += 1
    i = 0
    while 2 * (i * N + k) < n or 2 * (i * N + N - k) < n:
        u -= G(2 * (i * N + k))
        u -= G(2 * (i * N + N - k))
        i += 1
    return u


def hammer_on_ideal_string(N, k, dt, n_steps, *, law, m, V, Q, p, A, tau0, T, c):
    """Slow reference of the hammer kernel on the ideally supported string.

    The incoming displacement at the strike point comes from Publication I
    eq. (4) (every earlier g, reflected), the felt impulse over a step from
    direct quadrature (scipy.integrate.quad) of y linear in the step, and the
    implicit step is solved with scipy.optimize.brentq.  Returns g per step.
    law 4: three-parameter (A = alpha); law 5: four-parameter (A = gamma).

    Time convention (every exciter's, issue 13): step mm holds t = mm dt.
    The hammer reaches the string at t = 0 (g[0] = 0, no force yet); step
    mm >= 1 advances it from t - dt to t against the incoming wave of step mm.
    """
    from scipy.integrate import quad
    from scipy.optimize import brentq

    g = np.zeros(n_steps)
    K = c / (2 * T)
    mc = 2 * T / (c * m)
    z, y0, phi = 0.0, 0.0, 0.0

    def incoming(mm):
        s = 0.0
        i = 1
        while mm - 2 * i * N >= 0:
            s += 2 * g[mm - 2 * i * N]
            i += 1
        i = 0
        while mm - 2 * (i * N + k) >= 0 or mm - 2 * (i * N + N - k) >= 0:
            for d in (2 * (i * N + k), 2 * (i * N + N - k)):
                if mm - d >= 0:
                    s -= g[mm - d]
            i += 1
        return s

    def impulse(y1):
        if law == 4:
            return Q * (quad(lambda r: y0 + (y1 - y0) * r / dt, 0, dt)[0] + A * (y1 - y0))
        # F = F0 (y - gamma/tau0 Phi), Phi' = y - Phi/tau0, y linear in the step
        yl = lambda r: y0 + (y1 - y0) * r / dt
        Phi = lambda s: phi * np.exp(-s / tau0) + quad(lambda r: np.exp(-(s - r) / tau0) * yl(r), 0, s)[0]
        return Q * quad(lambda s: yl(s) - A / tau0 * Phi(s), 0, dt, limit=200)[0]

    gprev = 0.0
    for mm in range(1, n_steps):
        I1 = incoming(mm)

        def parts(g1):
            z1 = z + dt * (V - mc * (gprev + g1) / 2)
            w1 = z1 - I1 - g1
            y1 = (1000 * w1) ** p if w1 > 0 else 0.0
            return z1, w1, y1

        def resid(g1):
            return g1 - gprev - K * max(0.0, impulse(parts(g1)[2]))

        top = gprev + K * max(0.0, impulse(parts(gprev)[2]))
        g1 = gprev if top == gprev else brentq(resid, gprev, top, xtol=1e-18, rtol=1e-14)
        z, w1, y1 = parts(g1)
        if law == 5:
            phi = phi * np.exp(-dt / tau0) + quad(
                lambda r: np.exp(-(dt - r) / tau0) * (y0 + (y1 - y0) * r / dt), 0, dt)[0]
        y0 = y1
        g[mm] = g1
        gprev = g1
    return g


def felt_layer_on_ideal_string(N, k, dt, n_steps, *, m, V, h, A, rho, Ed, p, gamma, tau0,
                               T, c, cells, substeps, damping=0.5):
    """Slow numpy reference of the felt-layer hammer (synth.kernels.felt_layer)
    on the ideally supported string, with a fixed number of sub-steps.

    The incoming displacement at the strike point from Publication I eq. (4)
    (every earlier g, reflected), linear in each string step; the felt as
    the column of synth.physics.felt.strike_layer (faces s_0..s_nc,
    leapfrog; stress E_d [eps^p - gamma/tau0 J], J the memory integral
    updated exactly for eps^p linear in a sub-step; the grid-scale damper),
    its surface put on the string by the force F = (s0* - u*) / (dt^2/m0 +
    K dt) when it would pass it (K = c/2T, g += K dt F).  Step mm holds
    t = mm dt; at step 0 the felt arrives (every face on the string, moving
    at V).  Returns (g, the mean force over each step) per step.
    """
    K = c / (2 * T)
    dx = h / cells
    d = dt / substeps
    m0 = 0.5 * rho * A * dx
    mface = np.full(cells + 1, rho * A * dx)
    mface[0] = m0
    mface[-1] = m - rho * A * h + 0.5 * rho * A * dx
    s = np.zeros(cells + 1)
    so = s - V * d
    J = np.zeros(cells)
    fo = np.zeros(cells)
    ep = np.zeros(cells)
    E = np.exp(-d / tau0)
    r = d / tau0
    c1, c0 = 1 - (1 - E) / r, (1 - E) / r - E
    g = np.zeros(n_steps)
    Fm = np.zeros(n_steps)

    def incoming(mm):
        acc = 0.0
        i = 1
        while mm - 2 * i * N >= 0:
            acc += 2 * g[mm - 2 * i * N]
            i += 1
        i = 0
        while mm - 2 * (i * N + k) >= 0 or mm - 2 * (i * N + N - k) >= 0:
            for dd in (2 * (i * N + k), 2 * (i * N + N - k)):
                if mm - dd >= 0:
                    acc -= g[mm - dd]
            i += 1
        return acc

    I0 = 0.0
    gc = 0.0
    for mm in range(1, n_steps):
        I1 = incoming(mm)
        imp = 0.0
        for j in range(substeps):
            eps = np.diff(s) / dx
            y = np.abs(eps) ** (p - 1)
            fe = y * eps
            J = E * J + tau0 * (c1 * fe + c0 * fo)
            fo = fe
            sig = Ed * (fe - gamma / tau0 * J)
            cl = np.sqrt(p * Ed * y / rho)
            dd = np.maximum(cl[1:], cl[:-1]) * np.diff(eps - ep)
            q = np.zeros(cells)
            q[:-1] -= dd
            q[1:] += dd
            sig = sig + 0.25 * rho * damping * dx / d * q
            ep = eps
            acc = np.empty(cells + 1)
            acc[0] = sig[0]
            acc[1:-1] = sig[1:] - sig[:-1]
            acc[-1] = -sig[-1]
            sn = 2 * s - so + d * d * A * acc / mface
            uf = I0 + (I1 - I0) * (j + 1) / substeps + gc
            if sn[0] > uf:
                F = (sn[0] - uf) / (d * d / m0 + K * d)
                sn[0] -= d * d * F / m0
                gc += K * d * F
                imp += F * d
            so, s = s, sn
        I0 = I1
        g[mm] = gc
        Fm[mm] = imp / dt
    return g, Fm


def naive_bridge_strings(strings, n_steps, *, bra, brb, ubx=None, mu=0.0):
    """Lossy strings (``naive_lossy_string``'s far end, bridge-force output)
    whose ends at x = L sit on one bridge.  Each step every string's loop
    filter gives z (the wave reaching the end); their summed force with the
    bridge held still, f = sum T/dx 2 (z - z_prev), moves the bridge in the
    same step: u_b(m) = ((bra + r) u_b(m-1) + brb f) / (1 + r), r = brb sum
    T/dx (from R_b du_b/dt = f - sum T/dx du_b); then each string's outgoing
    wave is y = z - u_b(m) and its force on the bridge T/dx (2 (y - y_prev)
    + (u_b - u_b_prev)) (the loop filter read as standing just before the
    end) is its output.  With ``ubx`` (one value per step) the bridge is
    external: u_b(m) = ubx[m] and nothing is fed back.  With ``mu`` > 0 the
    bridge has a mass M = mu R_b dt (R_b = dt / brb): M (v(m) - v(m-1)) / dt
    = F(m) - R_b v(m), u_b(m) = bra u_b(m-1) + dt v(m), F(m) = f - sum T/dx
    (u_b(m) - u_b(m-1)), solved for v(m) in the same step.  A string with
    ``on`` = (m0, m1) hangs on the bridge only at steps m0 <= m < m1 (an
    open bridge: it joins and leaves); off it its end is still; at its first
    step on it, its previous z and u_b read as the bridge's previous
    displacement more than they were (the kernel's lockstep reading), and
    after it leaves its u_b_prev is 0.

    strings : list of dicts with N, k, g (outgoing wave per step, held at
        its last value), b0, a1, eta, tdx (T/dx, N/m), gain, and optional
        extra_delay, n_disp, a_disp, sos, U, side, on.
    Returns (summed output per step, u_b per step).
    """
    st = []
    for d in strings:
        N = d["N"]
        st.append(dict(d, ur=np.zeros(N + 1), ul=np.zeros(N + 1), xd=0.0, lp=0.0, apx=0.0,
                       apy=0.0, dx1=np.zeros(d.get("n_disp", 0)), dy1=np.zeros(d.get("n_disp", 0)),
                       bq=[[0.0] * 4 for _ in d.get("sos", ())],
                       g=np.asarray(d["g"], float), zprev=0.0))
    out = np.zeros(n_steps)
    ubs = np.zeros(n_steps)
    ub_last = 0.0
    v_last = 0.0
    for m in range(n_steps):
        f = 0.0
        B = 0.0
        zs = []
        for d in st:
            ur, ul, N, k = d["ur"], d["ul"], d["N"], d["k"]
            g = d["g"]
            gm = g[m] if m < len(g) else g[-1]
            U = d.get("U")
            _step(ur, ul, k, gm, U, d.get("side", 1), 0 if U is None else len(U))
            x = ur[N]
            if d.get("extra_delay", 0):
                x, d["xd"] = d["xd"], x
            d["lp"] = d["b0"] * x - d["a1"] * d["lp"]
            y = d["lp"]
            for j in range(d.get("n_disp", 0)):
                a = d["a_disp"]
                yd = a * y + d["dx1"][j] - a * d["dy1"][j]
                d["dx1"][j], d["dy1"][j] = y, yd
                y = yd
            yo = d["eta"] * y + d["apx"] - d["eta"] * d["apy"]
            d["apx"], d["apy"] = y, yo
            for j, (c1, c2) in enumerate(d.get("sos", ())):
                h = d["bq"][j]
                yb = c2 * yo + c1 * h[0] + h[1] - c1 * h[2] - c2 * h[3]
                d["bq"][j] = [yo, h[0], yb, h[2]]
                yo = yb
            on0, on1 = d.get("on", (0, n_steps))
            hang = on0 <= m < on1
            if m == on0 and on0 > 0:
                d["zprev"] += ub_last
                d["ubprev"] = ub_last
            elif m == on1:
                d["ubprev"] = 0.0
            if hang:
                f += d["tdx"] * 2 * (yo - d["zprev"])
                B += d["tdx"]
            zs.append((yo, hang))
        if ubx is None and mu > 0.0:
            dt = 1.0                      # (time in steps: R_b = 1 / brb, M = mu R_b)
            Rb = dt / brb
            M = mu * Rb * dt
            # M (v - v_last) / dt = f - B ((bra - 1) u_last + dt v) - Rb v
            v = (M / dt * v_last + f - B * (bra - 1.0) * ub_last) / (M / dt + Rb + B * dt)
            ub = bra * ub_last + dt * v
            v_last = v
        elif ubx is None:
            r = brb * B
            ub = ((bra + r) * ub_last + brb * f) / (1 + r)
        else:
            ub = ubx[m]
        ubs[m] = ub
        for d, (z, hang) in zip(st, zs):
            ube = ub if hang else 0.0
            yo = z - ube
            d["ul"][d["N"]] = -yo
            # the force on the bridge, Z (v_in - v_out) with the loop filter
            # just before the end: T/dx (2 (y - y_prev) + (u_b - u_b_prev))
            fo = d["tdx"] * (2 * (yo - d.get("yprev", 0.0)) + (ube - d.get("ubprev", 0.0)))
            d["yprev"], d["ubprev"], d["zprev"] = yo, ube, z
            out[m] += d["gain"] * fo
        ub_last = ub
    return out, ubs
