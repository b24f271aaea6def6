"""The waveguide string kernels' scheme, and one string's render drivers (numba, nogil).

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
     ``u_r(n) = U(n) + vl(n)`` (= ``u_r += U - u``); then, on a string
     whose profile is curved from x = 0 (``F_CURV`` > 0, the jawari), the
     sub-cell contact of the first cell: ``u_r(0) = -u_l(0) + delta``
     (:func:`_subcell_delta`);
  4. far end x = L: identity (ideal) or the loss/tuning filter of a musical
     string, applied in place to the sample turning round at q = N.

When an excitation has ended, g stays constant (= G) forever.  Rather than
keep injecting +G and -G every sample, the change of variables ring' = ring
+ G on the loop positions 2N-k .. 2N-1, 0 .. k-1 (the segment through x = 0
that holds the termination region) is made once and injection stops.  It is
exact on every string, lossy or not, at any time (not only in a steady
state): a value crossing k on either rail changes segment exactly when it
would have been injected; both rails of every region point carry the same
offset, which cancels in u and commutes with the clamp; and the far-end
filter never sees it.  (The opposite segment, through the far end, must not
be used on a lossy string: the loop filter would see a step of G and strike
the string with a broadband transient.)  With no excitation running, the
excitation point is no operation point, so the fast path's chunks may be
longer (``I_CHUNK_FREE``).

Fast path (no probe; while an excitation runs, the termination region
entirely below the excitation point): the chunk of C samples is processed
operation by operation instead of sample by sample.  With C no longer than
the loop distance between any two operation points, no sample meets two
operations within one chunk, so this is exact.  The excitation is one of
them only while it runs (``I_CHUNK``; afterwards ``I_CHUNK_FREE``), and a
hammer steps inside the chunk like a pluck: the wave arriving at k during
the chunk was already in the ring at its start.  In the region each
right-going characteristic (a ring slot) leaves with ``min`` (side +1;
``max`` for side -1) of its entry value and ``U(n) + vl(n)`` along its
path, the left-going values being untouched in the chunk; the step is
skipped when a bound on the values that pass the region in the chunk
says none can reach the obstacle (:func:`_out_of_reach`: the same
samples).  The per-sample path is the plain reference for it and handles an excitation running
inside or next to the region and diagnostics (probe, contacts, and the
contact telemetry of ``I_TELEM`` strings: live play's ``--stats``).

How the fast path is written, so that it is fast on every x86-64 target
(AVX-512, AVX2 and plain SSE2 builds; docs/benchmarks.md, "String bank
kernel" and "Code targets"):

* every window of the ring a step needs is copied to contiguous scratch
  with two loops split at the ring's wrap (:func:`_ring_get`,
  :func:`_ring_put`), never a wrap test per element;
* inner loops index slice views with the bare loop index (an index of
  unknown sign gets numba's negative-index fix-up per element, which stops
  vectorisation);
* the region takes four points per pass and writes a second buffer
  (:func:`_region_pass`): in place, LLVM turns "store min(x, a[i]) to a[i]"
  into a masked store, which AVX2 code emits as ``vmaskmovpd``, microcoded
  and several times slower on AMD CPUs before Zen 4;
* the far-end filter runs over the chunk with its state in registers
  (:func:`_far_chunk`): one multiply-add per recurrence and sample, where
  state read from and written to the state table every sample put a
  store-to-load round trip on each recurrence;
* the members of a coupled group (a piano key's unison) with the same
  loop-filter sections run their loss, allpasses and biquads as the lanes
  of one four-double vector (:func:`_far_lanes`, ``synth.kernels.lanes``:
  numba has no vector type and runs no SLP vectoriser), each lane the
  scalar code's operations in the same order; the running maxima (peaks,
  the region's reach test) also take four samples to a vector
  (:func:`_force_out`, :func:`_pairs_below`), which LLVM does not do for
  a maximum without no-NaN fast-math;
* strings whose hammer is running are rendered four at a time in lockstep
  chunks, their hammer steps interleaved (:func:`_render_group`,
  :func:`_excite_group`; in steady contact the step is short and
  branch-free, :func:`_hammer_steady`), so the CPU overlaps four ~100-cycle
  dependency chains instead of waiting on one;
* scratch windows are spaced so that no two sit a multiple of 4 KiB apart
  (a load whose low 12 address bits match an earlier store's waits for it);
* no call passes a literal constant (numba compiles a separate copy of the
  callee for each), and ``_nrt=False`` (synth.kernels.config) keeps slice
  views free of reference counting.

Where each job lives
--------------------
The columns of the tables these kernels read and write (``I_*``, ``F_*``,
``S_*``, ``P_*``, ``EXC_*``) and the scratch's layout are
:mod:`synth.kernels.layout`, which says which columns a kernel writes
back.  The steps above each have a module of their own; imports point down
this list, and none points up:

* :mod:`~synth.kernels.layout`: the columns, kinds and sizes (constants);
* :mod:`~synth.kernels.ring`: the ring's windows (:func:`_ring_get`...);
* :mod:`~synth.kernels.excite` (step 2: plucks, g tables, the felt
  hammers), :mod:`~synth.kernels.contact` (step 3: the termination region,
  the sub-cell contact, the reach test), :mod:`~synth.kernels.bend` (the
  pitch-bend line), :mod:`~synth.kernels.tension` (the tension's reading
  from the rails, which the bend line follows; the drivers below end a
  chunk at a reading);
* :mod:`~synth.kernels.far_end` (step 4: the loop filter and the bridge
  force), then :mod:`~synth.kernels.hand_over` (a loop moved to a coarser
  grid) and :mod:`~synth.kernels.coupled` (a coupled group's bridge and
  its lockstep filters);
* this module: the drivers that put the steps together for one string
  (the per-sample path :func:`_render_per_sample`; the fast path's chunks
  :func:`_chunk_fast`, :func:`_chunk_rest`, :func:`_chunk_end`;
  :func:`_render_string`, and :func:`_render_group` for hammered strings
  four at a time), and :func:`scan_silence`;
* :mod:`synth.kernels.render`: the bank's renderer, its coupled groups and
  its threads.

The plain-Python sizes (scratch lengths, chunk limits) are
:mod:`synth.dsp.sizing` (no kernel needs them).  Every kernel and
constant this module defined before those modules were split from it can
still be imported from it (the imports below re-export them), so that
``from synth.kernels import strings as K`` then ``K.I_OFF``,
``K._subcell_delta`` or ``K.far_end_run`` keeps working; new code may
import a name from the module that defines it.

May import: :mod:`~synth.kernels.config`, :mod:`~synth.kernels.felt_layer`
and the modules listed above it.
"""

from __future__ import annotations

import numpy as np
from numba import njit

# The steps the drivers below call, and every name this module defined
# before its jobs moved to the modules above (re-exported: the bank, the
# voices, the tests and the tools read them as ``strings.<name>``).
from .bend import _bend_chunk, _bend_line, _lagrange3
from .config import JIT_OPTS, LANES, SERIAL_OPTS, VECTOR_REGS
from .contact import (
    _out_of_reach, _pairs_below, _region_chunk, _region_edge, _region_pass, _region_step,
    _subcell_chunk, _subcell_delta, _subcell_needed, _subcell_q, _subcell_ring,
)
from .coupled import (
    _LANES_HEAD_SOS, _LANES_HEAD_SOS2, _LANES_ZERO, _bridge, _bridge_fused, _bridge_steps, _col4,
    _far_lanes, _lanes_biquads, _lanes_head, _lanes_ok, _lanes_out, _put4, _put_biquads,
)
from .excite import (
    _excite_chunk, _excite_group, _fold_offset, _g_at, _hammer_general, _hammer_steady,
)
from .far_end import (
    _HEAD_SOS, _biquads, _far_chunk, _far_end, _far_filter, _far_prep, _far_write, _force_one,
    _force_out, _head, _head_sos, _io, _sections, far_end_run,
)
from .felt_layer import felt_layer_start, felt_layer_step
from .hand_over import _dot, _lerp, hand_over_loop
from .layout import *  # noqa: F401,F403  (every column, kind and limit)
from .layout import _CW, _GIB, _GROW, _SCRATCH_GROUP
from .ring import _hmax4, _ring_add, _ring_get, _ring_get_in, _ring_put, _ring_put_in
from .tension import slope_sum, tension_after, tension_limit, tension_read

#: 1 as an int64 argument (a literal 1 in a call compiles the callee, and
#: everything below it, once more for ``Literal[int](1)``; render.ONE)
_ONE = np.int64(1)


@njit(**JIT_OPTS)
def _render_per_sample(s, ring, ipar, fpar, fst, U, n, o0, mix, probe, ubx, uo, cf, po0, psub):
    """Plain per-sample scheme for string s over n samples, mixing into
    mix[:, o0:o0+n] (row ``I_ROW``, and the next for a second bus).
    Reference for the fast path; also used when the excitation lies inside
    or next to the region (I_CHUNK = 0, e.g. the top keys' hammers on the
    capo bar) and for probes.

    A string on a bridge (``I_CPL`` not ``CPL_NONE``) has the bridge's
    displacement ubx[uo + i] subtracted from its outgoing wave at x = L at
    sample i; a member of a coupled group adds its force on the bridge
    (N, before the output gain) to cf[0].  Probe values of sample i go to
    index po0 + i // psub (a string on a finer grid: its last step of each
    engine sample)."""
    off = ipar[s, I_OFF]
    N = ipar[s, I_N]
    P = 2 * N
    k = ipar[s, I_K]
    R = ipar[s, I_REG_N]
    roff = ipar[s, I_REG_OFF]
    side = ipar[s, I_SIDE]
    curv = fpar[s, F_CURV] if R > 0 else 0.0
    u1p = fst[s, S_U1P]
    filt = ipar[s, I_FILT]
    xdel = ipar[s, I_XDELAY]
    outm = ipar[s, I_OUT]
    prow = ipar[s, I_PROBE]
    goff = ipar[s, I_GT_OFF]
    fp = fpar[s]
    dt = fp[F_DT]
    A = fp[F_A]
    t0 = fp[F_T0]
    alpha = fp[F_ALPHA]
    b0 = fp[F_B0]
    a1 = fp[F_A1]
    eta = fp[F_ETA]
    gain = fp[F_GAIN]
    tdx = fp[F_TDX]
    hrel = int(fp[F_HREL])
    nd = ipar[s, I_NDISP]
    ad = fp[F_ADISP]
    nb = ipar[s, I_NSOS]
    fsos = fp[F_SOS:F_SOS + 2 * MAX_SOS]
    b0t = fp[F_B0T]
    gk = 1.0 - fp[F_B0S]          # glide b0 <- gk b0 + gc: one multiply-add on
    gc = fp[F_B0S] * b0t          # its recurrence (b0 += b0s (b0t - b0) has two)
    boff = ipar[s, I_BOFF]
    blen = ipar[s, I_BLEN]
    bdt = fp[F_BDT]
    bds = fp[F_BDS]
    tor = fp[F_TOR]
    tog = fp[F_TOG]
    st = fst[s]
    pm = ipar[s, I_POS]
    exc = ipar[s, I_EXC]
    e = ipar[s, I_EXC_M]
    e_end = ipar[s, I_EXC_END]
    hlast = ipar[s, I_HLAST]
    g = st[S_G]
    peak = st[S_PEAK]
    r0 = ipar[s, I_ROW]
    r1 = r0 + 1
    two = ipar[s, I_BUS] == 1 and mix.shape[0] > r1
    pan = fp[F_PAN]
    cpl = ipar[s, I_CPL]
    telem = ipar[s, I_TELEM]
    tmin = fp[F_TGAP]
    tcn = st[S_TC_N]
    tep = st[S_TC_EP]
    tgap = st[S_TC_GAP]
    tpts = st[S_TC_PTS]
    hcn = st[S_HC_N]
    hep = st[S_HC_EP]
    hgap = st[S_HC_GAP]
    hpk = st[S_HF_PK]
    tmk = fp[F_TMK]
    for i in range(n):
        if exc == EXC_ENDED:
            # the excitation ended on the previous sample: fold its constant
            # g into the ring before this sample, where the fast path does
            _fold_offset(ring, off, P, pm, k, g)
            g = 0.0
            exc = EXC_NONE
        pm += 1
        if pm == P:
            pm = 0
        # 2. excitation at k: outgoing = incoming + g on both rails
        j1 = pm - k
        if j1 < 0:
            j1 += P
        j2 = pm + k
        if j2 >= P:
            j2 -= P
        F = 0.0
        if exc != EXC_NONE:
            if exc <= EXC_BIWA:
                g = _g_at(exc, e, dt, A, t0, alpha)
                if e >= e_end:
                    exc = EXC_ENDED
            elif exc == EXC_GTABLE:
                g = U[goff + e]
                if e >= e_end - 1:
                    exc = EXC_ENDED
            elif exc == EXC_FELT:
                # the felt layer, sub-stepped inside this step; at sample 0
                # it arrives on the string (as the lumped hammer does)
                I1 = ring[off + j1] - ring[off + j2]
                if e == 0:
                    felt_layer_start(U, goff, I1 + g)
                    w = 0.0
                    contact = False
                    st[S_HW] = 0.0
                    st[S_HZ] = I1 + g
                else:
                    g, F, w, comp, core = felt_layer_step(I1, g, U, goff)
                    contact = F > 0.0
                    st[S_HW] = comp
                    st[S_HZ] = core
                if contact:
                    hlast = e
                if e >= e_end or (hlast >= 0 and e - hlast > hrel and w < 0.0):
                    exc = EXC_ENDED          # the hammer is gone
            else:
                I1 = ring[off + j1] - ring[off + j2]
                # the general step only: the reference does not take the
                # steady-contact shortcut of the fast path
                g, F, w, contact = _hammer_general(I1, g, fp, st)
                if contact:
                    hlast = e
                if e >= e_end or (hlast >= 0 and e - hlast > hrel and w < 0.0):
                    exc = EXC_ENDED          # the hammer is gone
            e += 1
        gt = g                        # injected at k this sample
        if gt != 0.0:
            ring[off + j1] += gt
            ring[off + j2] -= gt
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
                u -= gt
            Ur = U[roff + r]
            if side * (u - Ur) > 0.0:
                ring[off + ju] += Ur - u
                ncont += 1
        if curv > 0.0:
            # the first cell's sub-cell contact (k >= 3): u_r(0) += delta,
            # from u(1) now (after its clamp), at the last sample, and at
            # the next without delta (slot pm there, against vl(2) now)
            jm = pm - 1
            if jm < 0:
                jm += P
            jp = pm + 1
            if jp >= P:
                jp -= P
            jq = pm + 2
            if jq >= P:
                jq -= P
            u = ring[off + jm] - ring[off + jp]
            U1 = side * U[roff]
            if U1 > 0.0 and U1 < np.inf:
                dl = _subcell_delta(side * (ring[off + pm] - ring[off + jq]), side * u1p, U1,
                                    curv * U1)
                if dl != 0.0:
                    ring[off + pm] += side * dl
                    ncont += 1
            u1p = u
        # 4. far end
        if filt == 1:
            b0 = gk * b0 + gc             # the loss glide toward b0t
            x, y, jn = _far_end(ring, off, P, N, pm, b0, a1, eta, xdel, nd, ad, st, nb, fsos)
            if blen > 0:
                y = _bend_line(y, st, U, boff, blen, bdt, bds, tor, tog)
                ring[off + jn] = y
            ubn = 0.0
            if cpl != CPL_NONE:
                # the end moves with the bridge: the wave leaving it is the
                # loop filter's minus the bridge's displacement (an external
                # bridge's less the offset the string eases off since it
                # joined it)
                ubn = ubx[uo + i]
                if cpl == CPL_EXTERNAL:
                    ubn -= st[S_UBOFF]
                    st[S_UBOFF] *= fp[F_UBOD]
                y -= ubn
                ring[off + jn] = y
        else:
            x = 0.0
            y = 0.0
        # output
        uk = ring[off + j1] - ring[off + j2] - gt
        if outm == 0:
            sig = uk
        else:
            ja = pm - N + 1
            if ja < 0:
                ja += P
            jb = pm - N - 1
            if jb < 0:
                jb += P
            if filt == 1:
                # the force on the bridge: the loop filter stands just before
                # the end, so the wave that reaches it is z = y + u_b and the
                # force is Z (v_in - v_out) = T/dx (dz + dy) (each a step's
                # difference; vl(N-1) = ring[jb] is the last sample's y)
                sig = tdx * (2.0 * (y - ring[off + jb]) + (ubn - st[S_UBP]))
                st[S_UBP] = ubn
            else:
                # ideal end: u(N-1) - u(N) with u(N) = 0, vl(N-1) = ring[jb]
                sig = tdx * (ring[off + ja] - ring[off + jb])
            if cpl >= 0:
                cf[0] += sig
        v = gain * sig
        if two:
            mix[r0, o0 + i] += v - pan * v
            mix[r1, o0 + i] += pan * v
        else:
            mix[r0, o0 + i] += v
        a = abs(v)
        if a > peak:
            peak = a
        if telem == 1:
            # contact telemetry, as synth.analysis.contacts.contact_summary
            # counts it: a run of contact starts an episode unless it follows
            # the last contact by fewer than tmin samples
            if ncont > 0:
                tcn += 1.0
                if tgap < 0.0 or tgap >= tmin:
                    tep += 1.0
                tgap = 0.0
                if ncont > tpts:
                    tpts = float(ncont)
            elif tgap >= 0.0:
                tgap += 1.0
            if F > 0.0:
                hcn += 1.0
                if hgap < 0.0 or hgap >= tmin:
                    hep += 1.0
                hgap = 0.0
                if F > hpk:
                    hpk = F
            elif hgap >= 0.0:
                hgap += 1.0
        if prow >= 0:
            pi = po0 + i // psub
            probe[prow, P_U, pi] = uk
            probe[prow, P_CONTACT, pi] = ncont
            probe[prow, P_G, pi] = gt
            probe[prow, P_F, pi] = F
            probe[prow, P_W, pi] = st[S_HW]
            probe[prow, P_Z, pi] = st[S_HZ]
        if tmk > 0.0 and cpl < 0:
            # the tension's reading (synth.kernels.tension), at the same
            # samples as the fast path's (the ring as it stands after this
            # one; a coupled group's member reads after the bridge's
            # correction of its sample at x = L, in _coupled_per_sample)
            st[S_TMC] -= 1.0
            if st[S_TMC] <= 0.0:
                ipar[s, I_POS] = pm
                ipar[s, I_EXC] = exc
                tension_read(s, ring, ipar, fpar, fst)
    ipar[s, I_POS] = pm
    ipar[s, I_EXC] = exc
    ipar[s, I_EXC_M] = e
    ipar[s, I_HLAST] = hlast
    fp[F_B0] = b0
    st[S_G] = g
    st[S_PEAK] = peak
    st[S_U1P] = u1p
    if telem == 1:
        st[S_TC_N] = tcn
        st[S_TC_EP] = tep
        st[S_TC_GAP] = tgap
        st[S_TC_PTS] = tpts
        st[S_HC_N] = hcn
        st[S_HC_EP] = hep
        st[S_HC_GAP] = hgap
        st[S_HF_PK] = hpk


@njit(**JIT_OPTS)
def _bus_add(mix, o0, C, ob, r0, two, pan):
    """Add a string's chunk output ob[0:C] to the mix: all of it to bus 0
    (mix row r0), or (with ``two``) (1 - pan) of it to bus 0 and pan to
    bus 1 (row r0 + 1)."""
    m0 = mix[r0, o0:o0 + C]
    o = ob[0:C]
    if two:
        m1 = mix[r0 + 1, o0:o0 + C]
        g0 = 1.0 - pan
        for i in range(C):
            m0[i] += g0 * o[i]
            m1[i] += pan * o[i]
    else:
        for i in range(C):
            m0[i] += o[i]


@njit(inline="always", **JIT_OPTS)
def _fold_if_ended(s, ring, ipar, fst):
    """An excitation that ended on the last sample of the previous chunk:
    fold its constant g into the ring now, between chunks."""
    if ipar[s, I_EXC] == EXC_ENDED:
        _fold_offset(ring, ipar[s, I_OFF], 2 * ipar[s, I_N], ipar[s, I_POS], ipar[s, I_K],
                     fst[s, S_G])
        fst[s, S_G] = 0.0
        ipar[s, I_EXC] = EXC_NONE


@njit(**JIT_OPTS)
def _chunk_fast(s, ring, ipar, fpar, fst, U, C, o0, mix, scratch, ubx):
    """C samples of string s, operation by operation (C <= ipar[s, I_CHUNK]
    while an excitation runs, else <= ipar[s, I_CHUNK_FREE]).

    ``scratch`` (see :func:`scratch_length`) holds the injected g per
    sample, the region's three windows and the far end's buffers."""
    _fold_if_ended(s, ring, ipar, fst)
    gbuf = scratch[_SCRATCH_GROUP:_SCRATCH_GROUP + C]
    # ---- 2. excitation -------------------------------------------------------
    plucking = ipar[s, I_EXC] != EXC_NONE
    if plucking:
        _excite_chunk(s, ring, ipar, fpar, fst, U, C, gbuf)
    _chunk_rest(s, ring, ipar, fpar, fst, U, C, o0, mix, scratch[_SCRATCH_GROUP + C:], gbuf,
                plucking, ubx)


@njit(inline="always", **JIT_OPTS)
def _work_windows(work, C, R):
    """The three windows of a chunk's region and far-end steps, and the rest
    (bend history).  Windows Wm samples apart with Wm = 168 mod 512: 1344
    and 2688 bytes apart modulo a 4 KiB page whatever the chunk, so that no
    load of one window waits on a store to another at the same low 12
    address bits ("4K aliasing": with C + R + 2 apart the plain-x86-64
    build of the region ran at 6.7 or 16 ns per sample depending on the
    chunk length)."""
    Wm = C + R + 2
    Wm += (168 - Wm) % 512
    return work[0:Wm], work[Wm:2 * Wm], work[2 * Wm:3 * Wm], work[3 * Wm:]


@njit(**JIT_OPTS)
def _chunk_rest(s, ring, ipar, fpar, fst, U, C, o0, mix, work, gbuf, plucking, ubx):
    """Steps 3 and 4 of the fast path over a chunk whose excitation (step 2)
    has been injected (g per sample in ``gbuf`` if ``plucking``): the
    termination region, the far end and the output; ``work`` holds their
    windows."""
    w1, w2, w3, hb = _work_windows(work, C, ipar[s, I_REG_N])
    # ---- 3. termination region: min/max along right-going characteristics --
    _region_step(s, ring, ipar, fpar, fst, U, C, w1, w2, w3)
    # ---- 4. far end, and the output ----------------------------------------
    peak = fst[s, S_PEAK]
    if ipar[s, I_FILT] == 1:
        # (the bridge-force output goes to the mix in the far end's pass)
        pk = _far_chunk(s, ring, ipar, fpar, fst, U, C, w1, w2, hb, mix, ubx, o0)
        peak = pk if pk > peak else peak
    _chunk_end(s, ring, ipar, fpar, fst, C, o0, mix, w1, w2, w3, gbuf, plucking, False, peak)


@njit(inline="always", **JIT_OPTS)
def _chunk_end(s, ring, ipar, fpar, fst, C, o0, mix, w1, w2, w3, gbuf, plucking, out, peak):
    """The end of a fast-path chunk: the output (the far end's bridge force
    already in w3 if ``out``; the ideal end's bridge force; or u at k,
    read after the chunk's region and far-end steps), added to the mix's
    buses; the peak; the ring position advanced by C."""
    off = ipar[s, I_OFF]
    N = ipar[s, I_N]
    P = 2 * N
    k = ipar[s, I_K]
    m0 = ipar[s, I_POS]
    outm = ipar[s, I_OUT]
    gain = fpar[s, F_GAIN]
    if ipar[s, I_FILT] != 1 and outm == 1:
        # ideal far end: u(N-1) - u(N) = u_r(N-1) - vl(N-1)
        sc = gain * fpar[s, F_TDX]
        ja = m0 + 2 - N
        if ja < 0:
            ja += P
        jb = m0 - N
        if jb < 0:
            jb += P
        _ring_get_in(ring, off, P, ja, w1[0:C], 1.0)
        _ring_get_in(ring, off, P, jb, w2[0:C], 1.0)
        mo = w3[0:C]
        for i in range(C):
            v = sc * (w1[i] - w2[i])
            mo[i] = v
            a = abs(v)
            peak = a if a > peak else peak
        out = True
    if outm == 0:
        j1 = m0 + 1 - k
        if j1 < 0:
            j1 += P
        j2 = m0 + 1 + k
        if j2 >= P:
            j2 -= P
        _ring_get_in(ring, off, P, j1, w1[0:C], 1.0)
        _ring_get_in(ring, off, P, j2, w2[0:C], 1.0)
        mo = w3[0:C]
        if plucking:
            for i in range(C):
                v = gain * (w1[i] - w2[i] - gbuf[i])
                mo[i] = v
                a = abs(v)
                peak = a if a > peak else peak
        else:
            for i in range(C):
                v = gain * (w1[i] - w2[i])
                mo[i] = v
                a = abs(v)
                peak = a if a > peak else peak
        out = True
    if out:
        r0 = ipar[s, I_ROW]
        _bus_add(mix, o0, C, w3, r0, ipar[s, I_BUS] == 1 and mix.shape[0] > r0 + 1,
                 fpar[s, F_PAN])
    fst[s, S_PEAK] = peak
    m1 = m0 + C
    if m1 >= P:
        m1 -= P
    ipar[s, I_POS] = m1


@njit(**JIT_OPTS)
def _render_string(s, ring, ipar, fpar, fst, U, n, o0, mix, probe, scratch, ubx, po0, psub):
    """n samples of string s into mix[:, o0:o0+n]: the per-sample path or
    fast-path chunks (``ubx``: an external bridge's displacement, indexed
    like ``mix``; ``po0``, ``psub``: probe indexing, see
    :func:`_render_per_sample`)."""
    exc = ipar[s, I_EXC]
    cmax = ipar[s, I_CHUNK] if exc > EXC_NONE else ipar[s, I_CHUNK_FREE]
    if ipar[s, I_PROBE] >= 0 or ipar[s, I_TELEM] != 0 or cmax <= 0 or exc == EXC_FELT:
        _render_per_sample(s, ring, ipar, fpar, fst, U, n, o0, mix, probe, ubx, o0, scratch,
                           po0, psub)
        return
    done = 0
    while done < n:
        C = n - done
        if C > cmax:
            C = cmax
        if ipar[s, I_EXC] > EXC_NONE:
            left = ipar[s, I_EXC_END] - ipar[s, I_EXC_M] + 1
            if C > left:
                C = left
        C = tension_limit(s, fpar, fst, C)
        _chunk_fast(s, ring, ipar, fpar, fst, U, C, o0 + done, mix, scratch, ubx)
        tension_after(s, ring, ipar, fpar, fst, C)
        done += C
        if ipar[s, I_EXC] <= EXC_NONE:
            cmax = ipar[s, I_CHUNK_FREE]


@njit(**JIT_OPTS)
def _render_group(mem, G, ring, ipar, fpar, fst, U, n, o0, mix, probe, scratch, ist, ubx):
    """n samples of G (<= GROUP) strings whose hammers are running, in
    lockstep chunks (the shortest any of them allows) so that their hammer
    steps interleave (:func:`_excite_group`); a string whose hammer has gone
    renders the rest of the block alone.  ``mem`` (the strings) is
    reordered in place."""
    done = 0
    live = G
    while done < n and live > 0:
        C = n - done
        if C > GROUP_CHUNK:
            C = GROUP_CHUNK
        for m in range(live):
            s = mem[m]
            c = ipar[s, I_CHUNK]
            left = ipar[s, I_EXC_END] - ipar[s, I_EXC_M] + 1
            if left < c:
                c = left
            c = tension_limit(s, fpar, fst, c)
            if c < C:
                C = c
        _excite_group(ring, ipar, fpar, fst, C, mem, live, scratch, ist)
        work = scratch[_SCRATCH_GROUP:]
        for m in range(live):
            _chunk_rest(mem[m], ring, ipar, fpar, fst, U, C, o0 + done, mix, work,
                        scratch[m * _GROW:m * _GROW + C],
                        ipar[mem[m], I_EXC] != EXC_NONE, ubx)   # (True; not a constant: see _ring_get)
            tension_after(mem[m], ring, ipar, fpar, fst, C)
        done += C
        j = 0
        for m in range(live):
            s = mem[m]
            if ipar[s, I_EXC] > EXC_NONE:
                mem[j] = s
                j += 1
            elif done < n:
                _render_string(s, ring, ipar, fpar, fst, U, n - done, o0 + done, mix, probe,
                               scratch, ubx, o0 + done, _ONE)
        live = j


@njit(**JIT_OPTS)
def scan_silence(active, n_active, ipar, fst, quiet, last_peak, n_in, level, min_quiet, done):
    """Per-block bookkeeping of the active strings, without allocation.

    For each active string: remember its block peak in ``last_peak`` and
    reset it; add ``n_in`` to its quiet count if its peak stayed below
    ``level`` and no excitation runs, else reset the count; list in ``done``
    the strings quiet for max(4 periods, ``min_quiet``) samples.  Returns
    how many were listed.
    """
    nd = 0
    for a in range(n_active):
        s = active[a]
        pk = fst[s, S_PEAK]
        last_peak[s] = pk
        fst[s, S_PEAK] = 0.0
        if pk < level and ipar[s, I_EXC] == EXC_NONE:
            quiet[s] += n_in
        else:
            quiet[s] = 0
        need = 4 * ipar[s, I_N] // ipar[s, I_SUB]     # four periods (engine samples)
        if need < min_quiet:
            need = min_quiet
        if quiet[s] >= need:
            done[nd] = s
            nd += 1
    return nd
