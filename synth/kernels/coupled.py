"""A coupled group on its bridge: the bridge's step, the lockstep loop filters (numba).

The strings of a coupled group (a piano key's unison; a sitar's played
strings, taraf and chikari on their one bridge) hang on a bridge that moves
with their summed force: :func:`_bridge` (with :func:`_bridge_steps`, and
:func:`_bridge_fused` in the SSE2 build) gives its displacement at each
sample of a chunk, in the same sample as the force, and subtracts it from
every member's outgoing wave.  Members with the same filter sections
(:func:`_lanes_ok`) run their loop filters as the lanes of one vector
(:func:`_far_lanes`, with :func:`_lanes_head`, :func:`_lanes_biquads` and
:func:`_lanes_out`): each lane the operations of
:func:`synth.kernels.far_end._far_filter` for its string, in the same order.
:mod:`synth.kernels.render` drives the groups (member windows at
``_CW`` spacing in the end of the scratch, :mod:`synth.kernels.layout`).

May import: :mod:`~synth.kernels.config`, :mod:`~synth.kernels.lanes`,
:mod:`~synth.kernels.layout`, :mod:`~synth.kernels.far_end`.
"""

from __future__ import annotations

from numba import njit

from .config import JIT_OPTS, LANES, SERIAL_OPTS, VECTOR_REGS
from .far_end import _io
from .lanes import lane, loadv, splat, splat2, splat4, store4, vec, width
from .layout import (
    F_A1, F_ADISP, F_B0, F_B0S, F_B0T, F_BRA, F_BRB, F_BRMU, F_BTDX, F_ETA, F_SOS, F_TDX, I_BLEN,
    I_CPLNX, I_FILT, I_NDISP, I_NSOS, I_XDELAY, S_APX, S_D0, S_LP, S_SOS, S_UBM, S_UBP, S_UBW,
    S_XD, _CW,
)


#: biquads the lockstep head loop (:func:`_lanes_head`) takes all of, with
#: the loss and first-order sections: its states and coefficients (16 + 13
#: vectors with four biquads) fit in the 32 vector registers of an AVX-512
#: build, not in the 16 of an AVX2 or SSE2 one, where the head of four
#: biquads kept seven states on the stack (23 of 59 instructions a sample)
#: and cost 1.2-1.6 x the head of one and passes of the rest.  With more,
#: as :data:`_HEAD_SOS`.  Any split computes the same operations in the
#: same order.
_LANES_HEAD_SOS = 4 if VECTOR_REGS >= 32 else 2


#: the lockstep filters' vector type, by its zero's constructor: four lanes
#: (``<4 x double>``) where the target has AVX, two (one xmm register) in
#: an SSE2 build (:data:`synth.kernels.config.LANES`), where a
#: ``<4 x double>`` took two registers and two instructions an operation:
#: a key's three strings then run as two lanes and one, a bichord as two
#: (instead of four lanes of which two were idle), with half the registers
#: a loop.  The lanes compute the same operations either way.
_LANES_ZERO = splat4 if LANES == 4 else splat2


#: :data:`_LANES_HEAD_SOS` for a string with a dispersion section (two
#: first-order sections in the head, three more vectors): the same where
#: the lanes are four; none in two lanes (SSE2), where the head of one
#: biquad kept states on the stack and cost as much as the head alone and
#: a pass of it (``ns`` 2, 1-8 biquads, 2.1-2.4 ns a two-lane sample more
#: than the head of none and passes; SSE2 build, Zen 4, ``python
#: tools/bench.py heads``)
_LANES_HEAD_SOS2 = 0 if LANES == 2 else _LANES_HEAD_SOS


@njit(inline="always", **JIT_OPTS)
def _force_row(s, m0, g, ipar, fpar, C, cw, ubm, fo):
    """fo[0:C] = the force on the bridge held still over a chunk of the
    group's members m0 .. m0 + g - 1 (member m0 is slot ``s``, the next ones
    follow ``I_CPLNX``): the sum over them of T/dx 2 dz(i), dz the change
    of each one's loop-filter output in its far-end window of ``cw`` (its
    z(-1) taken with ``ubm``, the bridge's u_b before the chunk, added, and
    restored).  The whole group (:func:`_bridge`) or one block of a big
    group (``synth.kernels.render._block_a``)."""
    for i in range(C):
        fo[i] = 0.0
    for j in range(g):
        m = m0 + j
        yb = cw[(2 * m + 1) * _CW:(2 * m + 1) * _CW + C + 1]
        t2 = 2.0 * fpar[s, F_TDX]
        s = ipar[s, I_CPLNX]
        y_prev = yb[0]
        yb[0] = y_prev + ubm          # z(-1), the filter's own previous output
        zo = yb[1:1 + C]
        zp = yb[0:C]
        for i in range(C):
            fo[i] += t2 * (zo[i] - zp[i])
        yb[0] = y_prev


@njit(**JIT_OPTS)
def _bridge(lead, G, ipar, fpar, fst, C, cw):
    """The bridge of a coupled group over a chunk: from the members'
    loop-filter outputs z (their far-end windows in ``cw``), the bridge
    displacement u_b per sample, in the same sample as the strings' force:

        F(i) = f(i) - B (u_b(i) - u_b(i-1)),   f(i) = sum_m T_m/dx_m 2 dz_m(i),
        u_b(i) = a u_b(i-1) + b F(i)
        =>  u_b(i) = ((a + r) u_b(i-1) + b f(i)) / (1 + r),   r = b B,

    (f the strings' summed force with the bridge held still, B = BTDX the
    members' summed T/dx, b = BRB = dt / R_b for a bridge of resistance
    R_b, a = BRA = exp(-2 pi f_r dt) its spring's slow return; d a step's
    difference); then every member's outgoing wave y = z - u_b.  A string
    of impedance Z on it is reflected by (R_b - Z) / (R_b + Z) at every
    frequency, the dashpot's own: passive for any R_b.  (The step one
    sample behind the force, u_b(i+1) = a u_b(i) + b F(i), would reflect
    by (1 - r z^-1) / (1 + r z^-1): more than 1 above
    fs/4, and a sitar's taraf on a soft bridge blew up.)

    With a mass (``F_BRMU`` = mu = M / (R_b dt) > 0; the grand's bridge
    moves as a mass above f_m = 1 / (2 pi mu dt)), the dashpot's step w(i)
    = u_b(i) - a u_b(i-1) = b F(i) becomes the backward-Euler step of
    M dv/dt = F - R_b v, w = v dt:

        mu (w(i) - w(i-1)) + w(i) = b F(i),   F(i) = f(i) - B (w(i) + (a - 1) u_b(i-1))
        =>  w(i) = (mu w(i-1) + b f(i) - r (a - 1) u_b(i-1)) / (1 + mu + r),

    w kept in ``S_UBW``: the strings meet the impedance R_b + j w M
    (its backward-Euler form, whose real part only grows with frequency:
    passive), and a unison's in-phase motion loses 1 / (1 + (f / f_m)^2)
    of the dashpot's decay rate at f.  mu = 0 takes the dashpot's loop
    (the same samples as before the mass).  The bridge row of
    ``cw`` (after the G members' windows) gets u_b of the sample before the
    chunk and of its C samples (for the members' force outputs).  The
    members are the chain from ``lead`` (``I_CPLNX``)."""
    a = fpar[lead, F_BRA]
    b = fpar[lead, F_BRB]
    r = b * fpar[lead, F_BTDX]
    ar = a + r
    den = 1.0 / (1.0 + r)
    ubm = fst[lead, S_UBM]
    if LANES == 2 and G <= 3 and fpar[lead, F_BRMU] == 0.0:
        # the SSE2 build (no FMA; the loop below is compiled as ubm =
        # (ar den) ubm + (b den) f: re-association distributes the
        # reciprocal); with FMA, which products LLVM fuses differs between
        # the two forms (last bits), so the AVX2 and AVX-512 builds keep this
        _bridge_fused(lead, G, ipar, fpar, fst, C, cw, ubm, ar * den, b * den)
        return
    row = cw[2 * G * _CW:2 * G * _CW + C + 1]
    fo = row[1:1 + C]
    _force_row(lead, G - G, G, ipar, fpar, C, cw, ubm, fo)   # (not the constant 0: see _ring_get)
    row[0] = ubm
    ubm = _bridge_steps(lead, fpar, fst, C, fo, ubm)
    s = lead
    for m in range(G):
        yo = cw[(2 * m + 1) * _CW + 1:(2 * m + 1) * _CW + 1 + C]
        for i in range(C):
            yo[i] -= fo[i]
        fst[s, S_UBP] = ubm
        s = ipar[s, I_CPLNX]


@njit(inline="always", **JIT_OPTS)
def _bridge_steps(lead, fpar, fst, C, fo, ubm):
    """The bridge's steps over a chunk (:func:`_bridge`): from the strings'
    summed force with the bridge held still, fo[0:C], and u_b before the
    chunk, ``ubm``, u_b per sample into fo (in place) and the bridge's
    state (``S_UBM``, and ``S_UBW`` with a mass); returns the last u_b."""
    a = fpar[lead, F_BRA]
    b = fpar[lead, F_BRB]
    r = b * fpar[lead, F_BTDX]
    mu = fpar[lead, F_BRMU]
    if mu == 0.0:
        ar = a + r
        den = 1.0 / (1.0 + r)
        for i in range(C):
            ubm = (ar * ubm + b * fo[i]) * den
            fo[i] = ubm
    else:
        # the bridge with its mass: w(i) = u_b(i) - a u_b(i-1) solves
        # mu (w(i) - w(i-1)) + w(i) = b F(i), F(i) = f(i) - B (w(i) + (a - 1) u_b(i-1))
        w = fst[lead, S_UBW]
        dm = 1.0 / (1.0 + mu + r)
        ra = r * (a - 1.0)
        for i in range(C):
            w = (mu * w + b * fo[i] - ra * ubm) * dm
            ubm = a * ubm + w
            fo[i] = ubm
        fst[lead, S_UBW] = w
    fst[lead, S_UBM] = ubm
    return ubm


@njit(**SERIAL_OPTS)
def _bridge_fused(lead, G, ipar, fpar, fst, C, cw, ubm, ard, bd):
    """:func:`_bridge` for a group of one to three strings in one loop: the
    bridge's recurrence (``ubm = bd f + ard ubm``, ard = (a + r) / (1 + r),
    bd = b / (1 + r) as products with the reciprocal: what :func:`_bridge`'s
    loop compiles to, re-association having distributed its ``* den``; a
    multiply and an add or a multiply-add on its path) with the members'
    forces and outgoing waves beside it, where :func:`_bridge` runs them as
    vector loops of their own before and after it.  The same operations in
    the same order (each sample's force summed over the members in turn
    from 0.0; the serial flags: no re-association may reorder that sum),
    bit for bit where there is no FMA (the SSE2 build, its only caller): with
    FMA, LLVM contracts other products of the fused loop than of
    :func:`_bridge`'s (renders differed by up to 4e-12)."""
    s0 = lead
    s1 = ipar[s0, I_CPLNX] if G > 1 else s0
    s2 = ipar[s1, I_CPLNX] if G > 2 else s1
    t0 = 2.0 * fpar[s0, F_TDX]
    t1 = 2.0 * fpar[s1, F_TDX]
    t2 = 2.0 * fpar[s2, F_TDX]
    y0 = cw[_CW:_CW + C + 1]
    y1 = cw[3 * _CW:3 * _CW + C + 1] if G > 1 else y0
    y2 = cw[5 * _CW:5 * _CW + C + 1] if G > 2 else y0
    row = cw[2 * G * _CW:2 * G * _CW + C + 1]
    # z(-1), each filter's own previous output
    p0 = y0[0] + ubm
    p1 = y1[0] + ubm
    p2 = y2[0] + ubm
    row[0] = ubm
    if G == 3:
        for i in range(1, C + 1):
            z0 = y0[i]
            z1 = y1[i]
            z2 = y2[i]
            f = 0.0
            f += t0 * (z0 - p0)
            f += t1 * (z1 - p1)
            f += t2 * (z2 - p2)
            p0 = z0
            p1 = z1
            p2 = z2
            ubm = bd * f + ard * ubm
            row[i] = ubm
            y0[i] = z0 - ubm
            y1[i] = z1 - ubm
            y2[i] = z2 - ubm
    elif G == 2:
        for i in range(1, C + 1):
            z0 = y0[i]
            z1 = y1[i]
            f = 0.0
            f += t0 * (z0 - p0)
            f += t1 * (z1 - p1)
            p0 = z0
            p1 = z1
            ubm = bd * f + ard * ubm
            row[i] = ubm
            y0[i] = z0 - ubm
            y1[i] = z1 - ubm
    else:
        for i in range(1, C + 1):
            z0 = y0[i]
            f = 0.0
            f += t0 * (z0 - p0)
            p0 = z0
            ubm = bd * f + ard * ubm
            row[i] = ubm
            y0[i] = z0 - ubm
    fst[lead, S_UBM] = ubm
    fst[s0, S_UBP] = ubm
    fst[s1, S_UBP] = ubm
    fst[s2, S_UBP] = ubm


# ---- the loop filters of a coupled group in lockstep (four lanes) ------------
# The members of a coupled group run their far ends over the same chunk.
# When they have the same filter structure (the strings of a piano key do),
# their recurrences run as the four lanes of one vector (synth.kernels.lanes):
# every lane computes what :func:`_head_sos` / :func:`_head` and
# :func:`_biquads` compute for its string, the same operations in the same
# order (the same samples).  Lanes past the group's last member repeat
# member 0 and are not written back.
@njit(**SERIAL_OPTS)
def _lanes_ok(lead, G, ipar):
    """True if the G members of the chain from ``lead`` can be filtered in
    lockstep: each has the loss filter, no bend line, at most one
    dispersion first-order section (then the tuning allpass), and they
    have the same sections."""
    nd = ipar[lead, I_NDISP]
    nb = ipar[lead, I_NSOS]
    if nd > 1:
        return False
    s = lead
    for m in range(G):
        if (ipar[s, I_FILT] != 1 or ipar[s, I_BLEN] != 0 or ipar[s, I_NDISP] != nd
                or ipar[s, I_NSOS] != nb):
            return False
        s = ipar[s, I_CPLNX]
    return True


@njit(**SERIAL_OPTS)
def _col4(z, a, r0, r1, r2, r3, c):
    """Column c of rows r0..r3 of a as lanes of z's type (r0, r1 for two)."""
    return vec(z, a[r0, c], a[r1, c], a[r2, c], a[r3, c])


@njit(**SERIAL_OPTS)
def _put4(a, r0, r1, r2, r3, G, c, v):
    a[r0, c] = lane(v, 0)
    if G > 1:
        a[r1, c] = lane(v, 1)
    if G > 2:
        a[r2, c] = lane(v, 2)
    if G > 3:
        a[r3, c] = lane(v, 3)


@njit(inline="always", **SERIAL_OPTS)
def _put_biquads(fst, r0, r1, r2, r3, G, q0, cnt, x10, x20, y10, y20, y11, y21, y12, y22,
                 y13, y23):
    """The states of a pass of ``cnt`` (0-4) biquads in lanes, from state
    column q0 on (x1, x2, y1, y2 each; a biquad's x are the one before's
    y), written back to the G strings r0..r3 (:func:`_lanes_head`,
    :func:`_lanes_biquads`)."""
    if cnt > 0:
        _put4(fst, r0, r1, r2, r3, G, q0, x10)
        _put4(fst, r0, r1, r2, r3, G, q0 + 1, x20)
        _put4(fst, r0, r1, r2, r3, G, q0 + 2, y10)
        _put4(fst, r0, r1, r2, r3, G, q0 + 3, y20)
    if cnt > 1:
        _put4(fst, r0, r1, r2, r3, G, q0 + 4, y10)
        _put4(fst, r0, r1, r2, r3, G, q0 + 5, y20)
        _put4(fst, r0, r1, r2, r3, G, q0 + 6, y11)
        _put4(fst, r0, r1, r2, r3, G, q0 + 7, y21)
    if cnt > 2:
        _put4(fst, r0, r1, r2, r3, G, q0 + 8, y11)
        _put4(fst, r0, r1, r2, r3, G, q0 + 9, y21)
        _put4(fst, r0, r1, r2, r3, G, q0 + 10, y12)
        _put4(fst, r0, r1, r2, r3, G, q0 + 11, y22)
    if cnt > 3:
        _put4(fst, r0, r1, r2, r3, G, q0 + 12, y12)
        _put4(fst, r0, r1, r2, r3, G, q0 + 13, y22)
        _put4(fst, r0, r1, r2, r3, G, q0 + 14, y13)
        _put4(fst, r0, r1, r2, r3, G, q0 + 15, y23)


@njit(**SERIAL_OPTS)
def _lanes_head(X0, X1, X2, X3, buf, n, fpar, fst, r0, r1, r2, r3, G, ns, cnt, zt):
    """The first pass of four strings' far ends (lanes): the loss glide and
    one-pole loss, ``ns`` (1 or 2) first-order sections (the dispersion
    section at S_D0 if ns is 2, then the tuning allpass at S_APX) and the
    first ``cnt`` (0..4) biquads, from X0..X3[0:n] into buf[0:4n]
    (interleaved: sample i of lane m at 4 i + m), as :func:`_head_sos`
    (:func:`_head` for cnt 0) computes each string's."""
    b0 = _col4(zt, fpar, r0, r1, r2, r3, F_B0)
    W = width(zt)
    gk = splat(zt, 1.0) - _col4(zt, fpar, r0, r1, r2, r3, F_B0S)
    gc = _col4(zt, fpar, r0, r1, r2, r3, F_B0S) * _col4(zt, fpar, r0, r1, r2, r3, F_B0T)
    a1 = _col4(zt, fpar, r0, r1, r2, r3, F_A1)
    lp = _col4(zt, fst, r0, r1, r2, r3, S_LP)
    s0 = S_D0 if ns == 2 else S_APX
    c0 = _col4(zt, fpar, r0, r1, r2, r3, F_ADISP if ns == 2 else F_ETA)
    x0 = _col4(zt, fst, r0, r1, r2, r3, s0)
    y0 = _col4(zt, fst, r0, r1, r2, r3, s0 + 1)
    c1 = _col4(zt, fpar, r0, r1, r2, r3, F_ETA)
    x1 = _col4(zt, fst, r0, r1, r2, r3, S_APX)
    y1 = _col4(zt, fst, r0, r1, r2, r3, S_APX + 1)
    q0 = S_SOS
    x10 = _col4(zt, fst, r0, r1, r2, r3, q0)
    x20 = _col4(zt, fst, r0, r1, r2, r3, q0 + 1)
    z = splat(zt, 0.0)
    ca0 = _col4(zt, fpar, r0, r1, r2, r3, F_SOS + 0) if cnt > 0 else z
    cb0 = _col4(zt, fpar, r0, r1, r2, r3, F_SOS + 1) if cnt > 0 else z
    y10 = _col4(zt, fst, r0, r1, r2, r3, q0 + 2) if cnt > 0 else z
    y20 = _col4(zt, fst, r0, r1, r2, r3, q0 + 3) if cnt > 0 else z
    ca1 = _col4(zt, fpar, r0, r1, r2, r3, F_SOS + 2) if cnt > 1 else z
    cb1 = _col4(zt, fpar, r0, r1, r2, r3, F_SOS + 3) if cnt > 1 else z
    y11 = _col4(zt, fst, r0, r1, r2, r3, q0 + 6) if cnt > 1 else z
    y21 = _col4(zt, fst, r0, r1, r2, r3, q0 + 7) if cnt > 1 else z
    ca2 = _col4(zt, fpar, r0, r1, r2, r3, F_SOS + 4) if cnt > 2 else z
    cb2 = _col4(zt, fpar, r0, r1, r2, r3, F_SOS + 5) if cnt > 2 else z
    y12 = _col4(zt, fst, r0, r1, r2, r3, q0 + 10) if cnt > 2 else z
    y22 = _col4(zt, fst, r0, r1, r2, r3, q0 + 11) if cnt > 2 else z
    ca3 = _col4(zt, fpar, r0, r1, r2, r3, F_SOS + 6) if cnt > 3 else z
    cb3 = _col4(zt, fpar, r0, r1, r2, r3, F_SOS + 7) if cnt > 3 else z
    y13 = _col4(zt, fst, r0, r1, r2, r3, q0 + 14) if cnt > 3 else z
    y23 = _col4(zt, fst, r0, r1, r2, r3, q0 + 15) if cnt > 3 else z
    # <generated: tools/gen_kernels.py _lanes_head>
    if ns == 1 and cnt == 0:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * vec(zt, X0[i], X1[i], X2[i], X3[i]) - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            store4(buf, W * i, y0)
    elif ns == 2 and cnt == 0:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * vec(zt, X0[i], X1[i], X2[i], X3[i]) - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            y1 = c1 * y0 + x1 - c1 * y1
            x1 = y0
            store4(buf, W * i, y1)
    elif ns == 1 and cnt == 1:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * vec(zt, X0[i], X1[i], X2[i], X3[i]) - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            h = y0
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            y20 = y10
            y10 = o0
            store4(buf, W * i, o0)
    elif ns == 2 and cnt == 1:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * vec(zt, X0[i], X1[i], X2[i], X3[i]) - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            y1 = c1 * y0 + x1 - c1 * y1
            x1 = y0
            h = y1
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            y20 = y10
            y10 = o0
            store4(buf, W * i, o0)
    elif ns == 1 and cnt == 2:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * vec(zt, X0[i], X1[i], X2[i], X3[i]) - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            h = y0
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            o1 = (cb1 * (o0 - y21) + y20 + ca1 * y10) - ca1 * y11
            y20 = y10
            y10 = o0
            y21 = y11
            y11 = o1
            store4(buf, W * i, o1)
    elif ns == 2 and cnt == 2:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * vec(zt, X0[i], X1[i], X2[i], X3[i]) - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            y1 = c1 * y0 + x1 - c1 * y1
            x1 = y0
            h = y1
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            o1 = (cb1 * (o0 - y21) + y20 + ca1 * y10) - ca1 * y11
            y20 = y10
            y10 = o0
            y21 = y11
            y11 = o1
            store4(buf, W * i, o1)
    elif ns == 1 and cnt == 3:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * vec(zt, X0[i], X1[i], X2[i], X3[i]) - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            h = y0
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            o1 = (cb1 * (o0 - y21) + y20 + ca1 * y10) - ca1 * y11
            y20 = y10
            y10 = o0
            o2 = (cb2 * (o1 - y22) + y21 + ca2 * y11) - ca2 * y12
            y21 = y11
            y11 = o1
            y22 = y12
            y12 = o2
            store4(buf, W * i, o2)
    elif ns == 2 and cnt == 3:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * vec(zt, X0[i], X1[i], X2[i], X3[i]) - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            y1 = c1 * y0 + x1 - c1 * y1
            x1 = y0
            h = y1
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            o1 = (cb1 * (o0 - y21) + y20 + ca1 * y10) - ca1 * y11
            y20 = y10
            y10 = o0
            o2 = (cb2 * (o1 - y22) + y21 + ca2 * y11) - ca2 * y12
            y21 = y11
            y11 = o1
            y22 = y12
            y12 = o2
            store4(buf, W * i, o2)
    elif ns == 1:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * vec(zt, X0[i], X1[i], X2[i], X3[i]) - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            h = y0
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            o1 = (cb1 * (o0 - y21) + y20 + ca1 * y10) - ca1 * y11
            y20 = y10
            y10 = o0
            o2 = (cb2 * (o1 - y22) + y21 + ca2 * y11) - ca2 * y12
            y21 = y11
            y11 = o1
            o3 = (cb3 * (o2 - y23) + y22 + ca3 * y12) - ca3 * y13
            y22 = y12
            y12 = o2
            y23 = y13
            y13 = o3
            store4(buf, W * i, o3)
    else:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * vec(zt, X0[i], X1[i], X2[i], X3[i]) - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            y1 = c1 * y0 + x1 - c1 * y1
            x1 = y0
            h = y1
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            o1 = (cb1 * (o0 - y21) + y20 + ca1 * y10) - ca1 * y11
            y20 = y10
            y10 = o0
            o2 = (cb2 * (o1 - y22) + y21 + ca2 * y11) - ca2 * y12
            y21 = y11
            y11 = o1
            o3 = (cb3 * (o2 - y23) + y22 + ca3 * y12) - ca3 * y13
            y22 = y12
            y12 = o2
            y23 = y13
            y13 = o3
            store4(buf, W * i, o3)
    # </generated>
    _put4(fpar, r0, r1, r2, r3, G, F_B0, b0)
    _put4(fst, r0, r1, r2, r3, G, S_LP, lp)
    _put4(fst, r0, r1, r2, r3, G, s0, x0)
    _put4(fst, r0, r1, r2, r3, G, s0 + 1, y0)
    if ns == 2:
        _put4(fst, r0, r1, r2, r3, G, S_APX, x1)
        _put4(fst, r0, r1, r2, r3, G, S_APX + 1, y1)
    _put_biquads(fst, r0, r1, r2, r3, G, q0, cnt, x10, x20, y10, y20, y11, y21, y12, y22,
                 y13, y23)


@njit(**SERIAL_OPTS)
def _lanes_biquads(buf, n, fpar, fst, r0, r1, r2, r3, G, j0, cnt, zt):
    """Biquads j0 .. j0+cnt-1 (cnt 1..4) of four strings (lanes) over the
    interleaved buf[0:4n] in place, as :func:`_biquads` computes each
    string's."""
    q0 = S_SOS + 4 * j0
    f0 = F_SOS + 2 * j0
    W = width(zt)
    z = splat(zt, 0.0)
    ca0 = _col4(zt, fpar, r0, r1, r2, r3, f0)
    cb0 = _col4(zt, fpar, r0, r1, r2, r3, f0 + 1)
    x10 = _col4(zt, fst, r0, r1, r2, r3, q0)
    x20 = _col4(zt, fst, r0, r1, r2, r3, q0 + 1)
    y10 = _col4(zt, fst, r0, r1, r2, r3, q0 + 2)
    y20 = _col4(zt, fst, r0, r1, r2, r3, q0 + 3)
    ca1 = _col4(zt, fpar, r0, r1, r2, r3, f0 + 2) if cnt > 1 else z
    cb1 = _col4(zt, fpar, r0, r1, r2, r3, f0 + 3) if cnt > 1 else z
    y11 = _col4(zt, fst, r0, r1, r2, r3, q0 + 6) if cnt > 1 else z
    y21 = _col4(zt, fst, r0, r1, r2, r3, q0 + 7) if cnt > 1 else z
    ca2 = _col4(zt, fpar, r0, r1, r2, r3, f0 + 4) if cnt > 2 else z
    cb2 = _col4(zt, fpar, r0, r1, r2, r3, f0 + 5) if cnt > 2 else z
    y12 = _col4(zt, fst, r0, r1, r2, r3, q0 + 10) if cnt > 2 else z
    y22 = _col4(zt, fst, r0, r1, r2, r3, q0 + 11) if cnt > 2 else z
    ca3 = _col4(zt, fpar, r0, r1, r2, r3, f0 + 6) if cnt > 3 else z
    cb3 = _col4(zt, fpar, r0, r1, r2, r3, f0 + 7) if cnt > 3 else z
    y13 = _col4(zt, fst, r0, r1, r2, r3, q0 + 14) if cnt > 3 else z
    y23 = _col4(zt, fst, r0, r1, r2, r3, q0 + 15) if cnt > 3 else z
    # <generated: tools/gen_kernels.py _lanes_biquads>
    if cnt == 1:
        for i in range(n):
            h = loadv(zt, buf, W * i)
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            y20 = y10
            y10 = o0
            store4(buf, W * i, o0)
    elif cnt == 2:
        for i in range(n):
            h = loadv(zt, buf, W * i)
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            o1 = (cb1 * (o0 - y21) + y20 + ca1 * y10) - ca1 * y11
            y20 = y10
            y10 = o0
            y21 = y11
            y11 = o1
            store4(buf, W * i, o1)
    elif cnt == 3:
        for i in range(n):
            h = loadv(zt, buf, W * i)
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            o1 = (cb1 * (o0 - y21) + y20 + ca1 * y10) - ca1 * y11
            y20 = y10
            y10 = o0
            o2 = (cb2 * (o1 - y22) + y21 + ca2 * y11) - ca2 * y12
            y21 = y11
            y11 = o1
            y22 = y12
            y12 = o2
            store4(buf, W * i, o2)
    else:
        for i in range(n):
            h = loadv(zt, buf, W * i)
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            o1 = (cb1 * (o0 - y21) + y20 + ca1 * y10) - ca1 * y11
            y20 = y10
            y10 = o0
            o2 = (cb2 * (o1 - y22) + y21 + ca2 * y11) - ca2 * y12
            y21 = y11
            y11 = o1
            o3 = (cb3 * (o2 - y23) + y22 + ca3 * y12) - ca3 * y13
            y22 = y12
            y12 = o2
            y23 = y13
            y13 = o3
            store4(buf, W * i, o3)
    # </generated>
    _put_biquads(fst, r0, r1, r2, r3, G, q0, cnt, x10, x20, y10, y20, y11, y21, y12, y22,
                 y13, y23)


@njit(**SERIAL_OPTS)
def _lanes_out(buf, n, Y0, Y1, Y2, Y3, zt):
    """The W lanes (zt's type) of buf[0:Wn] into Y0..Y3[0:n] (Y0, Y1 for
    two)."""
    W = width(zt)
    if W == 4:
        for i in range(n):
            v = loadv(zt, buf, 4 * i)
            Y0[i] = lane(v, 0)
            Y1[i] = lane(v, 1)
            Y2[i] = lane(v, 2)
            Y3[i] = lane(v, 3)
    else:
        for i in range(n):
            v = loadv(zt, buf, W * i)
            Y0[i] = lane(v, 0)
            Y1[i] = lane(v, 1)


@njit(**JIT_OPTS)
def _far_lanes(lead, G, ipar, fpar, fst, C, cw, buf, dummy):
    """The loop filters of the G members of a coupled group (the chain from
    ``lead``) over a chunk, four at a time in lockstep (:func:`_lanes_ok`
    holds), from their far-end windows in ``cw`` (set up by
    :func:`_far_prep`; member m's at 2 m _CW) into them, as
    :func:`_far_filter` computes each string's (each lane the same
    operations, whatever lane a member takes); ``buf``: 4 C samples of
    scratch; ``dummy``: C samples that the unused lanes of a last pass
    write."""
    ns = ipar[lead, I_NDISP] + 1
    nb = ipar[lead, I_NSOS]
    # the head loop takes all the biquads while its states fit in the
    # vector registers (_LANES_HEAD_SOS; _LANES_HEAD_SOS2 with a dispersion
    # section), else one (16 registers; none if it may take none) or what
    # passes of four leave (32); the rest run in passes of two to four (a
    # pass of one waits on its own recurrence)
    hmax = _LANES_HEAD_SOS if ns == 1 else _LANES_HEAD_SOS2
    if nb <= hmax:
        cnt = nb
    elif VECTOR_REGS >= 32:
        cnt = (nb - 1) % 4 + 1
    else:
        cnt = 1 if hmax > 0 else 0
    zt = _LANES_ZERO(0.0)           # the lanes' type: four, or two in an SSE2 build
    L = width(zt)
    s = lead
    m = 0
    while m < G:
        g = G - m if G - m < L else L
        r0 = s
        x0 = cw[2 * m * _CW + _io(ipar, r0):][:C]
        y0 = cw[(2 * m + 1) * _CW + 1:(2 * m + 1) * _CW + 1 + C]
        r1 = r0
        x1 = x0
        y1 = dummy
        r2 = r0
        x2 = x0
        y2 = dummy
        r3 = r0
        x3 = x0
        y3 = dummy
        s = ipar[s, I_CPLNX]
        if g > 1:
            r1 = s
            x1 = cw[2 * (m + 1) * _CW + _io(ipar, r1):][:C]
            y1 = cw[(2 * m + 3) * _CW + 1:(2 * m + 3) * _CW + 1 + C]
            s = ipar[s, I_CPLNX]
        if g > 2:
            r2 = s
            x2 = cw[2 * (m + 2) * _CW + _io(ipar, r2):][:C]
            y2 = cw[(2 * m + 5) * _CW + 1:(2 * m + 5) * _CW + 1 + C]
            s = ipar[s, I_CPLNX]
        if g > 3:
            r3 = s
            x3 = cw[2 * (m + 3) * _CW + _io(ipar, r3):][:C]
            y3 = cw[(2 * m + 7) * _CW + 1:(2 * m + 7) * _CW + 1 + C]
            s = ipar[s, I_CPLNX]
        _lanes_head(x0, x1, x2, x3, buf, C, fpar, fst, r0, r1, r2, r3, g, ns, cnt, zt)
        j = cnt
        while j < nb:
            # the biquads left in passes as even as passes of at most four
            # allow (5 -> 3 + 2, 7 -> 4 + 3)
            left = nb - j
            passes = (left + 3) // 4
            c = (left + passes - 1) // passes
            _lanes_biquads(buf, C, fpar, fst, r0, r1, r2, r3, g, j, c, zt)
            j += c
        _lanes_out(buf, C, y0, y1, y2, y3, zt)
        m += g
    # the extra-delay registers: the last arriving sample
    s = lead
    for m in range(G):
        if ipar[s, I_XDELAY] == 1:
            fst[s, S_XD] = cw[2 * m * _CW + C]
        s = ipar[s, I_CPLNX]
