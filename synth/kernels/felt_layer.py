"""The hammer's felt as a medium, struck against the moving string (numba).

The optional ``"felt-layer"`` hammer model of the study presets (issue 14,
section 6; docs/felt.md): the 1-D felt column of
:func:`synth.physics.felt.strike_layer` (the numpy reference, against a
rigid string), coupled to the waveguide string at the strike point through
eq. 1.4 and sub-stepped inside each of the string's steps.  The string
kernel calls :func:`felt_layer_step` once per step for a string whose
excitation kind is ``EXC_FELT`` (:mod:`synth.kernels.strings`, per-sample
path only).

The felt column x in [0, h] (x = 0 the surface, x = h glued to the core),
face displacements s_j (j = 0 .. nc, along the string's displacement,
positive towards the string), compressive strain eps_i = (s_(i+1) - s_i) /
dx at the cells' centres:

    rho A dx s_j'' = A (sigma_j - sigma_(j-1))              (eq. 2.6)
    sigma = E_d [eps^p - (gamma / tau0) int_0^t eps^p(xi) exp((xi - t) / tau0) d xi]
                                                             (eqs. 2.1-2.3, 2.10 in SI)

(eps^p as sign(eps) |eps|^p), the core face carrying the core's mass
m - rho A h and the surface face half a cell.  The string at the strike
point is u = I + g, I the incoming waves, and a point force F on it makes
dg/dt = c F / (2T) (eq. 1.4): seen from the felt, a dashpot of 2T / c
behind the incoming motion.  Contact is unilateral: over a sub-step of dt
the surface is first moved freely (leapfrog, s0* = 2 s0 - s0_old + dt^2 A
sigma_0 / m0); if s0* would pass the string u* = I(t + dt) + g, the force
that puts it exactly on the string at t + dt,

    F = (s0* - u*) / (dt^2 / m0 + K dt),   K = c / (2T),

acts over the sub-step (s0 = s0* - dt^2 F / m0, g += K dt F), else F = 0
(the felt cannot pull).  On a held string (K -> 0) this is the reference's
held surface with F = A sigma_0 (its first sub-step adds the surface
half-cell's momentum m0 v0, which the reference drops).  Time: leapfrog;
the memory integral exact for eps^p linear over a sub-step (stiff-safe);
the reference's grid-scale damper (a hyperviscosity that damps the first
touch's shock train, second order on smooth strain); I(t) linear over the
string's step.

Sub-steps.  The stable sub-step falls with the strain (the frozen tangent
speed c(eps) = sqrt(p E_d |eps|^(p-1) / rho)), from tens of ns in flight to
a few ns at the deepest compression, so it is chosen per string step:
``nsub`` a power of two such that c(eps_ref) dt <= courant dx, with eps_ref
the larger of 1.25 x the last step's largest |eps| and the first touch's
shock strain at the strike speed (:func:`synth.physics.felt.first_touch_force_n`);
it doubles at once when a strain exceeds what the sub-step can carry
(c dt > 0.9 dx) and halves (out of contact only) when a quarter of it
would do.  At a change the leapfrog's last step is rescaled (its velocity
kept: s_old = s - (s - s_old) dt_new / dt_old), and so is the damper's
last strain.  ``L_FIXED`` > 0 holds that many sub-steps per string step
instead (the references' fixed step; the doubling still guards it).

Why a kind of the string kernel and not a study-only path: the
architecture's exciters and terminations are independent pieces (any
exciter on any string), and this one needs from the string only what the
lumped hammer does (the incoming wave I at its point, each step, and g
back), so it plugs into the kernel's excitation step like the other kinds
and inherits the string, its termination (the capo bar, "direct"), the
two-stage "injected" strike, the probes and the engine unchanged.  What
it needs that the lumped hammer does not (O(cells) state) lives in the
table array the bank already sizes per slot, so no table, column or
signature of the kernel changed; the fast paths never see it (the string
takes the per-sample path while it runs).

Everything lives in one float64 block of the bank's table array (the g
table's place, ``ipar[s, I_GT_OFF]``): constants and scalar state at the
``L_*`` offsets, then the arrays s, s_old (nc + 1 each), the memory J,
eps^p of the last sub-step, the last strain and a scratch row (nc each):
:func:`block_length`.  No allocation.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .config import JIT_OPTS

# ---- the block: constants (written by synth.dsp.bank at each strike) ----------
L_NC = 0        # cells nc
L_DX = 1        # cell length dx = h / nc (m)
L_P = 2         # exponent p
L_ED = 3        # dynamic modulus E_d (Pa)
L_GT = 4        # gamma / tau0 (1/s)
L_TAU = 5       # tau0 (s)
L_RHO = 6       # density rho (kg/m^3)
L_AREA = 7      # column cross-section A (m^2)
L_M0 = 8        # surface face mass rho A dx / 2 (kg)
L_MC = 9        # core face mass m - rho A h + rho A dx / 2 (kg)
L_K = 10        # string: c / (2T) (m per N s)
L_DTS = 11      # the string's step (s)
L_COUR = 12     # target Courant number of the sub-step (<= 0.5)
L_DAMP = 13     # grid-scale damper's strength (damping x 0.9 <= 0.5)
L_V0 = 14       # speed at the first touch (m/s)
L_ETOUCH = 15   # the first touch's shock strain at v0 (floor of eps_ref)
# ---- scalar state --------------------------------------------------------------
L_NSUB = 16     # sub-steps per string step (a power of two)
L_I0 = 17       # incoming wave at the strike point at the last step (m)
L_EMAX = 18     # largest |eps| over the last string step
L_EC = 19       # memory update over a sub-step: exp(-dt / tau0), c1, c0
L_C1 = 20
L_C0 = 21
L_EHARD = 22    # largest |eps| the current sub-step carries (c dt = 0.9 dx)
L_STEPS = 23    # sub-steps taken since the strike (the cost's count)
L_FIXED = 24    # constant: > 0, sub-steps per string step held at this (no adaptation)
L_CONTACT = 25  # state: 1 if the felt pressed the string over the last string step
L_HEAD = 26
#: largest sub-steps per string step (2^22: 0.2 fs on a 1 us step)
MAX_NSUB = 1 << 22
#: Courant number at which a sub-step is refined at once
COURANT_HARD = 0.9


def block_length(cells: int) -> int:
    """Floats of the table array one felt layer of ``cells`` cells takes."""
    return L_HEAD + 2 * (cells + 1) + 4 * cells


@njit(**JIT_OPTS)
def _set_substep(T, o, nsub, rescale):
    """Make the sub-step dts / nsub: the memory's coefficients, the strain
    it carries, and (``rescale``) the leapfrog's last step and the damper's
    last strain rescaled to it (their rates kept; the current strain must
    be in the scratch row)."""
    nc = int(T[o + L_NC])
    dx = T[o + L_DX]
    p = T[o + L_P]
    dt_old = T[o + L_DTS] / T[o + L_NSUB]
    dt = T[o + L_DTS] / nsub
    if rescale:
        r = dt / dt_old
        s = o + L_HEAD
        so = s + nc + 1
        ep = so + nc + 1 + 2 * nc
        sc = ep + nc
        for j in range(nc + 1):
            T[so + j] = T[s + j] - (T[s + j] - T[so + j]) * r
        for i in range(nc):
            T[ep + i] = T[sc + i] - (T[sc + i] - T[ep + i]) * r
    T[o + L_NSUB] = nsub
    tau = T[o + L_TAU]
    E = math.exp(-dt / tau)
    h = dt / tau
    if h > 1e-6:
        c1 = 1.0 - (1.0 - E) / h
        c0 = (1.0 - E) / h - E
    else:
        c1 = 0.5 * h
        c0 = 0.5 * h
    T[o + L_EC] = E
    T[o + L_C1] = c1
    T[o + L_C0] = c0
    # c(eps) dt = 0.9 dx  <=>  |eps|^(p-1) = (0.9 dx / dt)^2 rho / (p E_d)
    q = (COURANT_HARD * dx / dt) ** 2 * T[o + L_RHO] / (p * T[o + L_ED])
    T[o + L_EHARD] = q ** (1.0 / (p - 1.0)) if p > 1.0 else np.inf


@njit(**JIT_OPTS)
def _nsub_for(T, o, eps_ref):
    """The power-of-two sub-steps per string step with c(eps_ref) dt <=
    courant dx."""
    p = T[o + L_P]
    c = math.sqrt(p * T[o + L_ED] * eps_ref ** (p - 1.0) / T[o + L_RHO])
    need = T[o + L_DTS] * c / (T[o + L_COUR] * T[o + L_DX])
    n = 1
    while n < need and n < MAX_NSUB:
        n *= 2
    return n


@njit(**JIT_OPTS)
def felt_layer_start(T, o, u_now):
    """The layer at the strike's sample 0: every face on the string
    (``u_now``, the strike point's displacement), moving at v0 towards it,
    unstrained, no memory; the sub-step from the first touch's shock strain."""
    nc = int(T[o + L_NC])
    s = o + L_HEAD
    so = s + nc + 1
    T[o + L_NSUB] = 1.0
    fixed = int(T[o + L_FIXED])
    nsub = fixed if fixed > 0 else _nsub_for(T, o, T[o + L_ETOUCH])
    _set_substep(T, o, nsub, False)
    dt = T[o + L_DTS] / nsub
    v0 = T[o + L_V0]
    for j in range(nc + 1):
        T[s + j] = u_now
        T[so + j] = u_now - v0 * dt
    for i in range(s + 2 * (nc + 1), s + 2 * (nc + 1) + 4 * nc):
        T[i] = 0.0
    T[o + L_I0] = u_now
    T[o + L_EMAX] = 0.0
    T[o + L_STEPS] = 0.0
    T[o + L_CONTACT] = 0.0


@njit(**JIT_OPTS)
def felt_layer_step(I1, g0, T, o):
    """Advance the felt layer and the string's outgoing wave g over one
    string step, to the incoming displacement ``I1`` (m) at the strike
    point at the step's end (I linear from the last step's).

    Returns (g1, F, gap, compression, core): g at the step's end (m); F the
    mean contact force over the step (N: its impulse / dt, so that
    g1 - g0 = K dt F exactly); gap = s_0 - u (<= 0: 0 in contact, negative
    when the surface has left the string, m); the felt's compression
    s_nc - s_0 and the core's position s_nc (m), at the step's end.
    """
    nc = int(T[o + L_NC])
    dx = T[o + L_DX]
    p = T[o + L_P]
    pm1 = p - 1.0
    Ed = T[o + L_ED]
    gt = T[o + L_GT]
    tau = T[o + L_TAU]
    rho = T[o + L_RHO]
    A = T[o + L_AREA]
    m0 = T[o + L_M0]
    mc = T[o + L_MC]
    K = T[o + L_K]
    dts = T[o + L_DTS]
    cl = T[o + L_DAMP]
    pEd_rho = p * Ed / rho
    s = o + L_HEAD
    so = s + nc + 1
    Jo = so + nc + 1
    fo = Jo + nc
    ep = fo + nc
    sc = ep + nc
    # sub-steps for this step: from the last step's strain (and the first
    # touch's, for a touch to come), doubling at once, halving out of contact
    I0 = T[o + L_I0]
    nsub = int(T[o + L_NSUB])
    want = nsub
    if T[o + L_FIXED] <= 0.0:
        eref = 1.25 * T[o + L_EMAX]
        if eref < T[o + L_ETOUCH]:
            eref = T[o + L_ETOUCH]
        want = _nsub_for(T, o, eref)
    if want > nsub or (4 * want <= nsub and T[o + L_CONTACT] == 0.0):
        # (the scratch row must hold the current strain for the rescale)
        for i in range(nc):
            T[sc + i] = (T[s + i + 1] - T[s + i]) / dx
        _set_substep(T, o, want, True)
        nsub = want
    g = g0
    imp = 0.0
    emax_step = 0.0
    frac = 0.0            # the sub-step's end, as a fraction of the string step
    left = nsub
    steps = 0
    while left > 0:
        dt = dts / nsub
        # pass 1: strains; refine at once if one outgrew the sub-step
        emax = 0.0
        for i in range(nc):
            e = (T[s + i + 1] - T[s + i]) / dx
            T[sc + i] = e
            a = abs(e)
            if a > emax:
                emax = a
        while emax > T[o + L_EHARD] and nsub < MAX_NSUB:
            _set_substep(T, o, 2 * nsub, True)
            nsub *= 2
            left *= 2
            dt = dts / nsub
        if emax > emax_step:
            emax_step = emax
        E = T[o + L_EC]
        c1 = T[o + L_C1]
        c0 = T[o + L_C0]
        coef = 0.25 * rho * cl * dx / dt
        # pass 2: stress with the memory, and the grid-scale damper between
        # neighbours (flux max(c_i-1, c_i) (eps_t,i - eps_t,i-1), c the
        # frozen tangent speed)
        c_prev = 0.0
        r_prev = 0.0
        for i in range(nc):
            e = T[sc + i]
            a = abs(e)
            # |eps|^(p-1); strains below 1e-30 (stress below E_d 1e-30^p)
            # count as none: their powers and the memory's tail would be
            # subnormal, tens of times slower to compute (the felt in flight)
            y = math.exp(pm1 * math.log(a)) if a > 1e-30 else 0.0
            if pm1 == 0.0:
                y = 1.0
            fe = y * e
            Jn = E * T[Jo + i] + tau * (c1 * fe + c0 * T[fo + i])
            if -1e-280 < Jn < 1e-280:
                Jn = 0.0
            T[Jo + i] = Jn
            T[fo + i] = fe
            sig = Ed * (fe - gt * Jn)
            ci = math.sqrt(pEd_rho * y)
            ri = e - T[ep + i]
            T[ep + i] = e
            if i > 0:
                cf = ci if ci > c_prev else c_prev
                d = coef * cf * (ri - r_prev)
                T[sc + i - 1] -= d
                sig += d
            T[sc + i] = sig
            c_prev = ci
            r_prev = ri
        # faces: interior and core by leapfrog
        kin = dt * dt / (rho * dx)
        for j in range(1, nc):
            x = T[s + j]
            T[s + j] = 2.0 * x - T[so + j] + kin * (T[sc + j] - T[sc + j - 1])
            T[so + j] = x
        x = T[s + nc]
        T[s + nc] = 2.0 * x - T[so + nc] - (dt * dt * A / mc) * T[sc + nc - 1]
        T[so + nc] = x
        # the surface: free, or put on the string by the force F >= 0
        frac += 1.0 / nsub
        x = T[s]
        s0 = 2.0 * x - T[so] + (dt * dt * A / m0) * T[sc]
        uf = I0 + (I1 - I0) * frac + g
        if s0 > uf:
            F = (s0 - uf) / (dt * dt / m0 + K * dt)
            s0 -= dt * dt * F / m0
            g += K * dt * F
            imp += F * dt
        T[s] = s0
        T[so] = x
        left -= 1
        steps += 1
    T[o + L_I0] = I1
    T[o + L_EMAX] = emax_step
    T[o + L_CONTACT] = 1.0 if imp > 0.0 else 0.0
    T[o + L_STEPS] += steps
    gap = T[s] - (I1 + g)
    if gap > 0.0:
        gap = 0.0
    return g, imp / dts, gap, T[s + nc] - T[s], T[s + nc]
