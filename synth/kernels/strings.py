"""Waveguide string bank kernels (numba, nogil, no allocation).

Representation
--------------
Each string of N cells is one ring of P = 2N float64 samples: the loop
"right-going rail from x = 0 to L, then left-going rail back".  The
left-going rail is stored negated (``vl = -u_l``) so that the two ideal
reflections (``u_r(0) = -u_l(0)``, ``u_l(L) = -u_r(L)``) become plain
transport and cost nothing.  A sample at loop position q (q = n for
``u_r`` at grid point n, q = 2N - n for ``vl`` at n) at time index m lives at
ring index ``slot(q, m) = (m - q) mod P``: transport is the clock advancing,
no data moves.  Displacement ``u(n) = ring[slot(n)] - ring[slot(2N - n)]``.

Per time step, in the order of physics notes sections 1-3:
  1. transport (implicit);
  2. excitation at point k: outgoing = incoming + g(t) on both rails, so
     ``u_r(k) += g`` and ``vl(k) -= g``; then ``u(k) = u_r + u_l - g``;
  3. termination region, points n = 1..R: where ``side (u - U) > 0`` set
     ``u_r(n) = U(n) + vl(n)`` (= ``u_r += U - u``);
  4. far end x = L: identity (ideal) or the loss/tuning filter of a musical
     string, applied in place to the sample turning round at q = N.

When a pluck has ended, g stays constant (= G) forever.  Rather than keep
injecting +G and -G every sample, the constant offset field is subtracted
once from the loop positions k .. 2N-k-1 and injection stops: exact for the
lossless string (the offsets cancel in u and commute with the clamp).

Fast path (no probe, termination region entirely below the excitation
point): the chunk of C samples is processed operation by operation instead
of sample by sample.  With C no longer than the loop distance between any
two operation points, no sample meets two operations within one chunk, so
this is exact.  In the region each right-going characteristic (a ring slot)
leaves with ``min`` (side +1; ``max`` for side -1) of its entry value and
``U(n) + vl(n)`` along its path, the left-going values being untouched in
the chunk; the reduction runs point by point over contiguous scratch copies
and vectorises.  The per-sample path is the plain reference for it and
handles excitation inside the region and diagnostics (probe, contacts).

Parameter tables (columns below) are written by the voice layer at note-on;
the kernel only reads ``ipar``/``fpar`` and updates ``fst`` and the rings.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .config import JIT_OPTS

# ---- integer parameter columns (ipar[s, :]) ---------------------------------
I_OFF = 0        # ring offset in the flat ring array
I_N = 1          # cells N (ring length 2N)
I_POS = 2        # state: (time index of the last processed sample) mod 2N
I_K = 3          # excitation / pickup grid point k (1 .. N-1)
I_EXC = 4        # state: 0 none or ended, 1 sitar g (eq. 1.13), 2 biwa g (eq. 1.11)
I_EXC_M = 5      # state: samples since excitation start (t = I_EXC_M * dt)
I_REG_OFF = 6    # offset of U(1..R) in the flat profile array
I_REG_N = 7      # R, points in the termination region (0: ideal rigid end)
I_SIDE = 8       # +1 obstacle above (u <= U), -1 below (u >= U)
I_FILT = 9       # 0 ideal far end, 1 loss + tuning filter
I_XDELAY = 10    # extra unit delay in the far-end filter (0 or 1)
I_OUT = 11       # output signal: 0 displacement u(k), 1 bridge force at x = L
I_PROBE = 12     # row in probe arrays, or -1
I_CHUNK = 13     # longest exact fast-path chunk (samples); 0 forces per-sample
I_EXC_END = 14   # first excitation sample with t > t0 (g constant from there)
I_NI = 15

# ---- float parameter columns (fpar[s, :]) -----------------------------------
F_DT = 0         # time step dt (s)
F_A = 1          # pluck amplitude A (m)
F_T0 = 2         # pluck duration t0 (s)
F_ALPHA = 3      # biwa alpha (1/s)
F_B0 = 4         # one-pole b0
F_A1 = 5         # one-pole a1   (y = b0 x - a1 y1)
F_ETA = 6        # allpass coefficient
F_GAIN = 7       # output gain (signal units -> mix units)
F_TDX = 8        # T / dx (N/m), bridge force scale
F_NF = 9

# ---- float state columns (fst[s, :]) ----------------------------------------
S_G = 0          # current g (m)
S_LP = 1         # one-pole state
S_APX = 2        # allpass x[n-1]
S_APY = 3        # allpass y[n-1]
S_XD = 4         # extra-delay register
S_PEAK = 5       # peak |gain * signal| since last reset (silence detection)
S_NS = 6


@njit(**JIT_OPTS)
def _g_at(kind, e, dt, A, t0, alpha):
    """Outgoing wave g (m) at excitation sample e (t = e dt)."""
    if e < 0:
        return 0.0
    t = e * dt
    if kind == 1:
        if t > t0:
            return A
        r = t / t0
        return A * r * r * np.exp(2.0 * (1.0 - r))
    else:
        if t > t0:
            t = t0
        return A * (1.0 - (1.0 + alpha * t) * np.exp(-alpha * t))


@njit(**JIT_OPTS)
def _remove_offset(ring, off, P, pm, k, G):
    """Subtract G from loop positions k .. P-k-1 at the time whose position
    index is pm (slots (pm - q) mod P)."""
    # positions q = k..P-k-1  ->  slots pm-k down to pm-(P-k-1) = pm+k+1-P
    for q in range(k, P - k):
        j = pm - q
        if j < 0:
            j += P
        ring[off + j] -= G


@njit(**JIT_OPTS)
def _far_end(ring, off, P, N, pm, b0, a1, eta, xdel, st):
    """One sample of the far-end filter at loop position N; returns (x, y)."""
    j = pm - N
    if j < 0:
        j += P
    x = ring[off + j]
    if xdel == 1:
        xin = st[S_XD]
        st[S_XD] = x
    else:
        xin = x
    lp = b0 * xin - a1 * st[S_LP]
    st[S_LP] = lp
    y = eta * lp + st[S_APX] - eta * st[S_APY]
    st[S_APX] = lp
    st[S_APY] = y
    ring[off + j] = y
    return x, y


@njit(**JIT_OPTS)
def _render_per_sample(s, ring, ipar, fpar, fst, U, n, o0, mix, probe_u, probe_c):
    """Plain per-sample scheme for string s over n samples, mixing into
    mix[o0:o0+n].  Reference for the fast path; also used when the
    excitation lies inside the region or diagnostics are requested."""
    off = ipar[s, I_OFF]
    N = ipar[s, I_N]
    P = 2 * N
    k = ipar[s, I_K]
    R = ipar[s, I_REG_N]
    roff = ipar[s, I_REG_OFF]
    side = ipar[s, I_SIDE]
    filt = ipar[s, I_FILT]
    xdel = ipar[s, I_XDELAY]
    outm = ipar[s, I_OUT]
    prow = ipar[s, I_PROBE]
    dt = fpar[s, F_DT]
    A = fpar[s, F_A]
    t0 = fpar[s, F_T0]
    alpha = fpar[s, F_ALPHA]
    b0 = fpar[s, F_B0]
    a1 = fpar[s, F_A1]
    eta = fpar[s, F_ETA]
    gain = fpar[s, F_GAIN]
    tdx = fpar[s, F_TDX]
    st = fst[s]
    pm = ipar[s, I_POS]
    exc = ipar[s, I_EXC]
    e = ipar[s, I_EXC_M]
    e_end = ipar[s, I_EXC_END]
    g = st[S_G]
    peak = st[S_PEAK]
    for i in range(n):
        if exc == -1:
            # the pluck ended on the previous sample: cancel its offset
            # field before this sample (exactly where the fast path does)
            _remove_offset(ring, off, P, pm, k, g)
            g = 0.0
            exc = 0
        pm += 1
        if pm == P:
            pm = 0
        # 2. excitation
        if exc != 0:
            g = _g_at(exc, e, dt, A, t0, alpha)
            j1 = pm - k
            if j1 < 0:
                j1 += P
            j2 = pm + k
            if j2 >= P:
                j2 -= P
            ring[off + j1] += g
            ring[off + j2] -= g
            if e >= e_end:
                exc = -1     # g constant from now on; offset removed next sample
            e += 1
        # 3. termination region
        ncont = 0
        for r in range(R):
            nn = r + 1
            ju = pm - nn
            if ju < 0:
                ju += P
            jv = pm + nn
            if jv >= P:
                jv -= P
            u = ring[off + ju] - ring[off + jv]
            if nn == k:
                u -= g
            Ur = U[roff + r]
            if side * (u - Ur) > 0.0:
                ring[off + ju] += Ur - u
                ncont += 1
        # 4. far end
        if filt == 1:
            x, y = _far_end(ring, off, P, N, pm, b0, a1, eta, xdel, st)
        else:
            x = 0.0
            y = 0.0
        # output
        j1 = pm - k
        if j1 < 0:
            j1 += P
        j2 = pm + k
        if j2 >= P:
            j2 -= P
        uk = ring[off + j1] - ring[off + j2] - g
        if outm == 0:
            sig = uk
        else:
            ja = pm - N + 1
            if ja < 0:
                ja += P
            jb = pm - N - 1
            if jb < 0:
                jb += P
            # u(N-1) - u(N); for the ideal end u(N) = 0 and vl(N-1) = ring[jb]
            sig = tdx * ((ring[off + ja] - ring[off + jb]) - (x - y))
        v = gain * sig
        mix[o0 + i] += v
        a = abs(v)
        if a > peak:
            peak = a
        if prow >= 0:
            probe_u[prow, o0 + i] = uk
            probe_c[prow, o0 + i] = ncont
    ipar[s, I_POS] = pm
    ipar[s, I_EXC] = exc
    ipar[s, I_EXC_M] = e
    st[S_G] = g
    st[S_PEAK] = peak


@njit(**JIT_OPTS)
def _chunk_fast(s, ring, ipar, fpar, fst, U, C, o0, mix, scratch):
    """C samples (C <= ipar[s, I_CHUNK]) of string s, operation by operation."""
    off = ipar[s, I_OFF]
    N = ipar[s, I_N]
    P = 2 * N
    k = ipar[s, I_K]
    R = ipar[s, I_REG_N]
    st = fst[s]
    m0 = ipar[s, I_POS]
    gbuf = scratch[0:C]
    exc = ipar[s, I_EXC]
    if exc == -1:
        # the pluck ended on the last sample of the previous chunk: cancel
        # its offset field now, between chunks, so no output of that chunk
        # sees it
        _remove_offset(ring, off, P, m0, k, st[S_G])
        st[S_G] = 0.0
        exc = 0
        ipar[s, I_EXC] = 0
    # ---- 2. excitation -------------------------------------------------------
    # gbuf holds g per sample only while a pluck runs; otherwise g = 0 (an
    # ended pluck's offset field has been cancelled)
    plucking = exc != 0
    if plucking:
        dt = fpar[s, F_DT]
        A = fpar[s, F_A]
        t0 = fpar[s, F_T0]
        alpha = fpar[s, F_ALPHA]
        e = ipar[s, I_EXC_M]
        e_end = ipar[s, I_EXC_END]
        pm = m0
        g = 0.0
        for i in range(C):   # the caller ends the chunk at e_end at the latest
            pm += 1
            if pm == P:
                pm = 0
            g = _g_at(exc, e, dt, A, t0, alpha)
            j1 = pm - k
            if j1 < 0:
                j1 += P
            j2 = pm + k
            if j2 >= P:
                j2 -= P
            ring[off + j1] += g
            ring[off + j2] -= g
            if e >= e_end:
                exc = -1     # offset removed at the start of the next chunk
            e += 1
            gbuf[i] = g
        ipar[s, I_EXC] = exc
        ipar[s, I_EXC_M] = e
        st[S_G] = g
    # ---- 3. termination region: min/max along right-going characteristics --
    if R > 0:
        roff = ipar[s, I_REG_OFF]
        side = ipar[s, I_SIDE]
        W = C + R - 1
        acc = scratch[C:C + W]
        vwin = scratch[C + W:C + 2 * W]
        b = m0 + 1 - R          # first characteristic slot (unwrapped)
        j = b % P
        for a in range(W):       # gather entry values and left-going window
            acc[a] = ring[off + j]
            j += 1
            if j == P:
                j = 0
        j = (m0 + 2) % P
        for a in range(W):
            vwin[a] = ring[off + j]
            j += 1
            if j == P:
                j = 0
        for r in range(R):
            nn = r + 1
            Un = U[roff + r]
            if side > 0:
                if Un == np.inf:
                    continue
                lo = R - nn
                sh = 2 * nn - R - 1
                # slice views: no aliasing doubt, so LLVM vectorises the select
                av = acc[lo:lo + C]
                vv = vwin[lo + sh:lo + sh + C]
                for a in range(C):
                    x = Un + vv[a]
                    y = av[a]
                    av[a] = x if x < y else y
            else:
                if Un == -np.inf:
                    continue
                lo = R - nn
                sh = 2 * nn - R - 1
                # slice views: no aliasing doubt, so LLVM vectorises the select
                av = acc[lo:lo + C]
                vv = vwin[lo + sh:lo + sh + C]
                for a in range(C):
                    x = Un + vv[a]
                    y = av[a]
                    av[a] = x if x > y else y
        j = b % P
        for a in range(W):
            ring[off + j] = acc[a]
            j += 1
            if j == P:
                j = 0
    # ---- 4. far end, and the output ----------------------------------------
    gain = fpar[s, F_GAIN]
    peak = st[S_PEAK]
    outm = ipar[s, I_OUT]
    if ipar[s, I_FILT] == 1:
        b0 = fpar[s, F_B0]
        a1 = fpar[s, F_A1]
        eta = fpar[s, F_ETA]
        xdel = ipar[s, I_XDELAY]
        tdx = fpar[s, F_TDX]
        pm = m0
        for i in range(C):
            pm += 1
            if pm == P:
                pm = 0
            x, y = _far_end(ring, off, P, N, pm, b0, a1, eta, xdel, st)
            if outm == 1:
                ja = pm - N + 1
                if ja < 0:
                    ja += P
                jb = pm - N - 1
                if jb < 0:
                    jb += P
                v = gain * tdx * ((ring[off + ja] - ring[off + jb]) - (x - y))
                mix[o0 + i] += v
                if abs(v) > peak:
                    peak = abs(v)
    elif outm == 1:
        tdx = fpar[s, F_TDX]
        ja = (m0 + 1 - N + 1) % P
        jb = (m0 + 1 - N - 1) % P
        for i in range(C):
            v = gain * tdx * (ring[off + ja] - ring[off + jb])
            mix[o0 + i] += v
            if abs(v) > peak:
                peak = abs(v)
            ja += 1
            if ja == P:
                ja = 0
            jb += 1
            if jb == P:
                jb = 0
    if outm == 0:
        j1 = (m0 + 1 - k) % P
        j2 = (m0 + 1 + k) % P
        for i in range(C):
            gi = gbuf[i] if plucking else 0.0
            v = gain * (ring[off + j1] - ring[off + j2] - gi)
            mix[o0 + i] += v
            if abs(v) > peak:
                peak = abs(v)
            j1 += 1
            if j1 == P:
                j1 = 0
            j2 += 1
            if j2 == P:
                j2 = 0
    st[S_PEAK] = peak
    ipar[s, I_POS] = (m0 + C) % P


@njit(**JIT_OPTS)
def render_bank(ring, ipar, fpar, fst, U, active, n_active, n, o0, mix,
                probe_u, probe_c, scratch):
    """Render ``n`` internal samples of every active string into
    ``mix[o0:o0+n]`` (accumulating).

    ring : float64[:]        all rings, concatenated
    ipar, fpar, fst : 2-D     parameter and state tables (columns above)
    U : float64[:]            all region profiles, concatenated
    active : int64[:]         string indices; the first ``n_active`` are used
    probe_u, probe_c : 2-D    per-sample u(k) (m) and contact counts for
                              strings with ``ipar[s, I_PROBE] >= 0``
    scratch : float64[:]      >= 3 * (max chunk + max R) samples
    """
    for a in range(n_active):
        s = active[a]
        if ipar[s, I_PROBE] >= 0 or ipar[s, I_CHUNK] <= 0:
            _render_per_sample(s, ring, ipar, fpar, fst, U, n, o0, mix, probe_u, probe_c)
        else:
            cmax = ipar[s, I_CHUNK]
            done = 0
            while done < n:
                C = n - done
                if C > cmax:
                    C = cmax
                if ipar[s, I_EXC] > 0:
                    left = ipar[s, I_EXC_END] - ipar[s, I_EXC_M] + 1
                    if C > left:
                        C = left
                _chunk_fast(s, ring, ipar, fpar, fst, U, C, o0 + done, mix, scratch)
                done += C


def max_fast_chunk(N: int, k: int, R: int, out_mode: int) -> int:
    """Longest chunk (samples) for which the fast path is exact, or 0 when it
    does not apply (excitation inside or next to the region).

    No sample may meet two operation points within one chunk: the loop
    distances region-excitation (k - R), excitation-far end (N - k) and,
    for the bridge-force pickup next to x = L, region-far end (N - R).
    """
    if R > 0 and k <= R + 1:
        return 0
    c = min(k - R, N - k, N - R) - 1
    if out_mode == 1:
        c = min(c, N - R - 2)
    return max(c, 0)
