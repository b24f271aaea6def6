"""A small coupled group's render step by step (a piano key's unison: at
most :data:`BLOCK` strings on one bridge), on the calling thread.

A coupled group renders in lockstep chunks, all its members stepping the
same samples (:func:`synth.kernels.render._render_coupled`); here is what one
chunk does and how its length is chosen:

* :func:`_coupled_head`: the chunk's excitations (hammers stepped together,
  :func:`synth.kernels.excite._excite_group`, then plucks), for this
  module's chunks and for a big group's blocks (:mod:`synth.kernels.render`);
* :func:`_coupled_chunk_small`: the whole chunk of a small group: each
  member's region and loop filter (in lockstep lanes where they allow),
  the bridge, each member's output;
* :func:`_coupled_split` and :func:`_coupled_chunk_split`: a chunk held
  short by an excitation near the termination region (a hammer by the
  grand's capo bar), stepped in two tempi: the excitation and the regions
  in short pieces, the loop filters, the bridge and the output once;
* :func:`_coupled_per_sample`: the plain per-sample scheme (the reference;
  probes, telemetry, excitations inside a region);
* :func:`_coupled_next`, :func:`_coupled_diag`, :func:`_coupled_tension`:
  the next chunk's length, and what follows a chunk.

(Split from :mod:`synth.kernels.render` when the split chunk took it over
1,200 lines: the code moved unchanged, the samples with it.)

May import: :mod:`~synth.kernels.address`, :mod:`~synth.kernels.config`,
:mod:`~synth.kernels.layout`, :mod:`~synth.kernels.contact`, :mod:`~synth.kernels.coupled`,
:mod:`~synth.kernels.excite`, :mod:`~synth.kernels.far_end`,
:mod:`~synth.kernels.tension`, :mod:`~synth.kernels.strings`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .address import A_HAMMERS, A_PER, A_TAIL, hammers_at, tail_at
from .config import JIT_OPTS
from .contact import _region_step
from .coupled import _bridge, _far_lanes, _lanes_ok
from .excite import _excite_chunk
from .far_end import _far_filter, _far_prep, _far_write
from .layout import (
    EXC_FELT, EXC_HAMMER3, EXC_NONE, F_BRA, F_BRB, F_BRMU, F_BTDX, F_GAIN, F_PAN, F_TDX, GROUP,
    GROUP_CHUNK, I_BUS, I_CHUNK, I_CHUNK_FREE, I_CPL, I_CPLN, I_CPLNX, I_EXC, I_EXC_END, I_EXC_M,
    I_FILT, I_K,
    I_N, I_OFF, I_OUT, I_POS, I_PROBE, I_REG_N, I_ROW, I_TELEM, ROWS, S_PEAK, S_UBM, S_UBP,
    S_UBW, _CW, _GROW, _SCRATCH_GROUP,
)
from .strings import _chunk_end, _fold_if_ended, _render_per_sample, _work_windows
from .tension import tension_after, tension_limit

#: 0 and 1 as int64 arguments: a literal 0 or 1 in a call makes numba compile
#: the callee (and everything below it) once more for ``Literal[int]``: the
#: bank's renderer was compiled three times over (cold start 3 min).  A
#: counter that starts at a literal 0 (``n = 0`` ... ``n += 1``) does it
#: too: type inference first sees the call with ``Literal[int](0)`` and
#: compiles that, before the loop's int64 reaches it (25 of 146 CPU s of a
#: cold ``synth note sitar`` went to such copies, ``tools/bench.py compile``)
ZERO = np.int64(0)
ONE = np.int64(1)
#: members of a coupled group stepped together as one block (a multiple of
#: the lanes of :func:`coupled._far_lanes`, so that the lanes group the
#: members as they would over the whole group)
BLOCK = 4

#: (Compile time.)  :func:`_coupled_head` and :func:`_coupled_tail` are plain
#: functions, not ``inline="always"``: inlined, numba typed and lowered their
#: bodies (the hammers, the loop filters, the bridge, each member's output)
#: once in each chunk function that uses them (three and two), and a cold
#: ``synth demo`` compiled 250.7 CPU s; called, 219.9 with ``render._shard_task``
#: inlined too (both trees at once on a 2-vCPU Xeon, fresh caches:
#: ``NUMBA_CACHE_DIR=$(mktemp -d) python tools/bench.py compile demo -o d.wav``).
#: The samples are the same to the bit (tests/test_golden.py), and a render's
#: time did not move beyond the machine's noise (a call per chunk).


@njit(inline="always", **JIT_OPTS)
def loaded(addrs, k):
    """``addrs[k]``, the address of a unit the bank loads only where a
    group may call it (:func:`groups_need`: the per-sample path, the
    hammers); an error, not a jump to address 0, if it did not."""
    if addrs[k] == 0:
        raise RuntimeError("a coupled group calls a kernel by its address, but it is not loaded")
    return addrs[k]


@njit(**JIT_OPTS)
def _coupled_head(lead, G, ring, ipar, fpar, fst, U, C, scratch, iw, ist, addrs):
    """The start of a coupled group's lockstep chunk (C samples of the G
    strings of the chain from ``lead`` on one bridge, on the fast path; C
    within every member's fast-path limit, at most ROWS members
    exciting, GROUP of them hammers): running hammers stepped together
    (:func:`~synth.kernels.excite._excite_group`, by its address
    ``addrs[A_HAMMERS]``),
    plucks one by one (member m's g row at scratch[row * _GROW:], its
    string at iw[row]); returns (row, work, cw, lock): the rows used, the
    work windows, the coupled area and whether the lanes apply.  The rest
    of the chunk: :func:`_coupled_chunk_small` (each string's region and
    loop filter, the bridge, :func:`_bridge`, each string's far-end write
    and output) or, for a group of more than BLOCK members (a sitar's
    bridge), :func:`_coupled_chunk_big` (its blocks,
    :func:`_coupled_blocks`: the same samples whether they run on this
    thread or on ``nt``): separate kernels (one ``_coupled_chunk`` before),
    so that a scene compiles the kind of group it has."""
    # ---- 2. excitation: member m's g row at scratch[row * _GROW:]
    # (the kinds are read before any step: a hammer that ends in this chunk
    # is EXC_ENDED afterwards and must not be injected again)
    nh = ZERO                  # (not 0: see ZERO)
    s = lead
    for m in range(G):
        _fold_if_ended(s, ring, ipar, fst)
        if ipar[s, I_EXC] >= EXC_HAMMER3:
            iw[nh] = s
            nh += 1
        s = ipar[s, I_CPLNX]
    row = nh
    s = lead
    for m in range(G):
        exc = ipar[s, I_EXC]
        if exc != EXC_NONE and exc < EXC_HAMMER3:
            iw[row] = s
            row += 1
        s = ipar[s, I_CPLNX]
    if nh > 0:
        hammers_at(loaded(addrs, A_HAMMERS))(ring, ipar, fpar, fst, C, iw, nh, scratch, ist)
    for r in range(nh, row):
        _excite_chunk(iw[r], ring, ipar, fpar, fst, U, C, scratch[r * _GROW:r * _GROW + C])
    # ---- 3. regions, and 4. the loop filters into the coupled area
    work = scratch[_SCRATCH_GROUP:]
    cw = scratch[scratch.shape[0] - (2 * G + 1) * _CW:]
    lock = _lanes_ok(lead, G, ipar)
    return row, work, cw, lock


@njit(**JIT_OPTS)
def _coupled_chunk_small(lead, G, ring, ipar, fpar, fst, U, C, o0, mix, scratch, iw, ist, addrs):
    """:func:`_coupled_chunk` of a group of at most BLOCK members (a piano
    key's unison): each member's region, then :func:`_coupled_tail` (the
    loop filters, in lockstep where :func:`coupled._lanes_ok`, the bridge,
    each member's output), called by its address ``addrs[A_TAIL]``
    (:mod:`synth.kernels.address`)."""
    row, work, cw, lock = _coupled_head(lead, G, ring, ipar, fpar, fst, U, C, scratch, iw, ist,
                                        addrs)
    s = lead
    for m in range(G):
        w1, w2, w3, hb = _work_windows(work, C, ipar[s, I_REG_N])
        _region_step(s, ring, ipar, fpar, fst, U, C, w1, w2, w3)
        s = ipar[s, I_CPLNX]
    tail_at(addrs[A_TAIL])(lead, G, ring, ipar, fpar, fst, U, C, o0, mix, scratch, iw, row)


@njit(**JIT_OPTS)
def _coupled_tail(lead, G, ring, ipar, fpar, fst, U, C, o0, mix, scratch, iw, row):
    """The far half of a small group's chunk of C samples whose excitation
    and regions have stepped: each member's loop filter (the members' in
    lockstep where :func:`coupled._lanes_ok`; each touches only its own
    string, so after every region as between them), the bridge, each
    member's far-end write and output (``iw[0:row]``: the members whose g
    row, scratch[r * _GROW:], a displacement pickup reads)."""
    work = scratch[_SCRATCH_GROUP:]
    cw = scratch[scratch.shape[0] - (2 * G + 1) * _CW:]
    lock = _lanes_ok(lead, G, ipar)
    s = lead
    for m in range(G):
        w1, w2, w3, hb = _work_windows(work, C, ipar[s, I_REG_N])
        xw = cw[2 * m * _CW:2 * m * _CW + C + 2]
        yw = cw[(2 * m + 1) * _CW:(2 * m + 1) * _CW + C + 1]
        if lock:
            _far_prep(s, ring, ipar, fst, C, xw, yw)
        else:
            _far_filter(s, ring, ipar, fpar, fst, U, C, xw, yw, hb)
        s = ipar[s, I_CPLNX]
    if lock:
        # the members' loop filters in lockstep (the work windows are free)
        _far_lanes(lead, G, ipar, fpar, fst, C, cw, work[0:4 * C],
                   cw[2 * G * _CW + 1:2 * G * _CW + 1 + C])
    _bridge(lead, G, ipar, fpar, fst, C, cw)
    s = lead
    for m in range(G):
        w1, w2, w3, hb = _work_windows(work, C, ipar[s, I_REG_N])
        peak = fst[s, S_PEAK]
        pk = _far_write(s, ring, ipar, fpar, C, cw[(2 * m + 1) * _CW:(2 * m + 1) * _CW + C + 1],
                        mix, o0, cw[2 * G * _CW:2 * G * _CW + C + 1], True)
        peak = pk if pk > peak else peak
        # this member's g row (for a displacement pickup while it plucks)
        r = -1
        for q in range(row):
            if iw[q] == s:
                r = q
        plucking = r >= 0
        gb = scratch[(r if r >= 0 else 0) * _GROW:(r if r >= 0 else 0) * _GROW + C]
        _chunk_end(s, ring, ipar, fpar, fst, C, o0, mix, w1, w2, w3, gb, plucking, False, peak)
        s = ipar[s, I_CPLNX]


@njit(inline="always", **JIT_OPTS)
def _coupled_split(lead, G, ipar, fpar, fst, avail, C):
    """Whether a small group's lockstep chunk of C samples (from
    :func:`_coupled_next`) is held short only by a member's excitation
    near its termination region or its near end (a hammer, at k of the
    string's N cells, R of them the region: pieces of at most k - R - 1
    samples, 3-39 for the grand's capo keys on the finer grid, 71 for its
    middle C), while its far end could take more: returns (d, Cf), the
    excitation and the regions stepped in pieces of d samples over a span
    of Cf samples whose loop filters, bridge and output step once
    (:func:`_coupled_chunk_split`); else (0, C).  Every member must have
    the bridge-force output of a loop filter (the output does not read the
    excitation's g)."""
    Cf = avail
    if Cf > GROUP_CHUNK:
        Cf = GROUP_CHUNK
    d = Cf
    s = lead
    for m in range(G):
        if ipar[s, I_OUT] != 1 or ipar[s, I_FILT] != 1:
            return 0, C
        N = ipar[s, I_N]
        R = ipar[s, I_REG_N]
        if ipar[s, I_EXC] > EXC_NONE:
            near = ipar[s, I_K] - R - 1          # excitation-region (or the end at 0)
            far = N - ipar[s, I_K] - 1           # excitation-far end
            if N - R - 2 < far:
                far = N - R - 2                  # region-far end, the force's pickup
            if near < d:
                d = near
        else:
            far = ipar[s, I_CHUNK_FREE]
        far = tension_limit(s, fpar, fst, far)
        if far < Cf:
            Cf = far
        s = ipar[s, I_CPLNX]
    if d < 1 or Cf <= C or d >= Cf:
        return 0, C
    return d, Cf


@njit(**JIT_OPTS)
def _coupled_chunk_split(lead, G, ring, ipar, fpar, fst, U, C, d, o0, mix, scratch, iw, ist,
                         addrs):
    """:func:`_coupled_chunk_small` over C samples in two tempi
    (:func:`_coupled_split`): the excitation and the regions in pieces of
    at most d samples, each piece from its own ring position and ended at
    any excitation's end, then the members' loop filters, the bridge and
    the output once over the C samples from the span's start.  The same
    samples as chunks of d: a piece of the excitation and the region reads
    nothing written within it (their distance k - R > d), and the far end
    reads nothing the pieces write within the span, nor they anything it
    writes (the distances N - k and N - R exceed C).  So a hammer by the
    capo bar no longer runs the loop filters, the bridge and the output in
    chunks of 3-39 samples (their fixed cost per chunk, 16 biquads a
    string, was most of a treble strike's)."""
    P0 = 5 * GROUP                       # ist[P0 + m]: member m's position at the span's start
    s = lead
    for m in range(G):
        ist[P0 + m] = ipar[s, I_POS]
        s = ipar[s, I_CPLNX]
    work = scratch[_SCRATCH_GROUP:]
    done = 0
    while done < C:
        c = C - done
        if c > d:
            c = d
        s = lead
        for m in range(G):
            pos = ist[P0 + m] + done
            P = 2 * ipar[s, I_N]
            if pos >= P:
                pos -= P
            ipar[s, I_POS] = pos
            if ipar[s, I_EXC] > EXC_NONE:
                left = ipar[s, I_EXC_END] - ipar[s, I_EXC_M] + 1
                if left < c:
                    c = left
            s = ipar[s, I_CPLNX]
        if c < 1:
            c = 1
        _coupled_head(lead, G, ring, ipar, fpar, fst, U, c, scratch, iw, ist, addrs)
        s = lead
        for m in range(G):
            w1, w2, w3, hb = _work_windows(work, c, ipar[s, I_REG_N])
            _region_step(s, ring, ipar, fpar, fst, U, c, w1, w2, w3)
            s = ipar[s, I_CPLNX]
        done += c
    # back to the span's start: the far ends over all of it (an excitation
    # that ended in the last piece is folded at the next chunk's start, the
    # span's end, as after a chunk of d)
    s = lead
    for m in range(G):
        ipar[s, I_POS] = ist[P0 + m]
        s = ipar[s, I_CPLNX]
    # (every member has the force output: no g row is read, row 0)
    tail_at(addrs[A_TAIL])(lead, G, ring, ipar, fpar, fst, U, C, o0, mix, scratch, iw, ZERO)


@njit(inline="always", **JIT_OPTS)
def _coupled_chunk_small_or_split(lead, G, ring, ipar, fpar, fst, U, C, avail, o0, mix, scratch,
                                  iw, ist, addrs):
    """A small group's next chunk: C samples as :func:`_coupled_next` gave
    them or, when :func:`_coupled_split` finds an excitation holding them
    short, the far end's longer span in two tempi; returns the samples
    stepped."""
    d, Cs = _coupled_split(lead, G, ipar, fpar, fst, avail, C)
    if d > 0:
        _coupled_chunk_split(lead, G, ring, ipar, fpar, fst, U, Cs, d, o0, mix, scratch, iw, ist,
                             addrs)
        return Cs
    _coupled_chunk_small(lead, G, ring, ipar, fpar, fst, U, C, o0, mix, scratch, iw, ist, addrs)
    return C


@njit(**JIT_OPTS)
def _coupled_per_sample(lead, G, ring, ipar, fpar, fst, U, n, o0, mix, probe, one, po0, psub):
    """The plain per-sample scheme for a coupled group (the reference of
    :func:`_coupled_chunk`; probes, telemetry and excitations inside the
    region): every member steps one sample on the bridge as it would be
    with the strings' force held still, U0 = (a + r) u_b(i-1) / (1 + r);
    their summed force then gives the bridge's true u_b(i) = U0 + dU
    (:func:`_bridge`'s step), and each member's outgoing wave, its force
    output and its bridge reading are corrected by dU (the scheme is
    linear in u_b; the members' peaks keep the provisional output).  With
    the bridge's mass (``F_BRMU`` > 0) U0 = a u_b(i-1) + (mu w(i-1) - r (a
    - 1) u_b(i-1)) / (1 + mu + r) and dU = b f / (1 + mu + r) (the same
    step, :func:`_bridge`).  ``one``: two scratch values."""
    a = fpar[lead, F_BRA]
    b = fpar[lead, F_BRB]
    r = b * fpar[lead, F_BTDX]
    mu = fpar[lead, F_BRMU]
    den = 1.0 / (1.0 + r)
    if mu != 0.0:
        den = 1.0 / (1.0 + mu + r)
    ra = r * (a - 1.0)
    rows = mix.shape[0]
    for i in range(n):
        ubm = fst[lead, S_UBM]
        if mu == 0.0:
            U0 = (a + r) * ubm * den
        else:
            U0 = a * ubm + (mu * fst[lead, S_UBW] - ra * ubm) * den
        one[0] = U0
        one[1] = 0.0
        cf = one[1:2]
        corr = 0.0
        s = lead
        for m in range(G):
            corr += fpar[s, F_TDX] * (U0 - fst[s, S_UBP])
            _render_per_sample(s, ring, ipar, fpar, fst, U, ONE, o0 + i, mix, probe, one, ZERO,
                               cf, po0 + i // psub, ONE)
            s = ipar[s, I_CPLNX]
        dU = b * (one[1] + corr) * den
        ub = U0 + dU
        s = lead
        for m in range(G):
            N = ipar[s, I_N]
            jn = ipar[s, I_POS] - N
            if jn < 0:
                jn += 2 * N
            ring[ipar[s, I_OFF] + jn] -= dU
            fst[s, S_UBP] = ub
            v = -fpar[s, F_GAIN] * fpar[s, F_TDX] * dU
            r0 = ipar[s, I_ROW]
            if ipar[s, I_BUS] == 1 and rows > r0 + 1:
                pan = fpar[s, F_PAN]
                mix[r0, o0 + i] += v - pan * v
                mix[r0 + 1, o0 + i] += pan * v
            else:
                mix[r0, o0 + i] += v
            # the tension's reading, if due, on the corrected ring (where
            # the fast path reads: after the chunk, _coupled_tension)
            tension_after(s, ring, ipar, fpar, fst, ONE)
            s = ipar[s, I_CPLNX]
        fst[lead, S_UBM] = ub
        fst[lead, S_UBW] = ub - a * ubm


@njit(inline="always", **JIT_OPTS)
def _coupled_diag(lead, G, ipar):
    """Whether a member of the group has a probe or telemetry (then the
    group renders per sample)."""
    diag = False
    s = lead
    for m in range(G):
        if ipar[s, I_PROBE] >= 0 or ipar[s, I_TELEM] != 0:
            diag = True
        s = ipar[s, I_CPLNX]
    return diag


@njit(inline="always", **JIT_OPTS)
def _coupled_next(lead, G, ipar, fpar, fst, avail, diag):
    """The next piece of a coupled group's render, of at most ``avail``
    samples: (C, slow), a lockstep chunk of C samples if every member
    allows one and at most ROWS of them excite (GROUP hammers), else C
    samples per sample (slow)."""
    C = avail
    if C > GROUP_CHUNK:
        C = GROUP_CHUNK
    slow = diag
    nexc = 0
    nham = 0
    s = lead
    for m in range(G):
        exc = ipar[s, I_EXC]
        c = ipar[s, I_CHUNK] if exc > EXC_NONE else ipar[s, I_CHUNK_FREE]
        if exc > EXC_NONE:
            nexc += 1
            if exc >= EXC_HAMMER3:
                nham += 1
            left = ipar[s, I_EXC_END] - ipar[s, I_EXC_M] + 1
            if left < c:
                c = left
        c = tension_limit(s, fpar, fst, c)   # (a chunk ends at a tension's reading)
        if c <= 0 or exc == EXC_FELT:
            slow = True
        elif c < C:
            C = c
        s = ipar[s, I_CPLNX]
    if nexc > ROWS or nham > GROUP:
        slow = True                # more excitations than the chunk's g rows
    if slow and not diag and C > 64:
        C = 64                     # look again soon: the fast path may apply
    return C, slow


@njit(**JIT_OPTS)
def groups_need(active, n_active, ipar):
    """The units the coupled groups among the ``n_active`` strings of
    ``active`` may call before the next note event (bits 1 << unit,
    :mod:`synth.kernels.address`): ``A_PER`` where a group may render per
    sample (:func:`_coupled_per_sample`), :func:`_coupled_next`'s
    conditions taken where they can only fall within a render call
    (excitations end, none begins): a probe or telemetry, a felt hammer, a
    member whose chunk is 0 excited or free or whose excitation is at its
    end, or more excitations than the chunk's rows; ``A_HAMMERS`` where a
    member has a hammer running (:func:`_coupled_head`).  The bank leaves
    the others unloaded: a cold sitar note compiles neither."""
    need = 0
    for a in range(n_active):
        lead = active[a]
        if ipar[lead, I_CPL] != lead:
            continue                        # a lone string, or not its group's leader
        G = ipar[lead, I_CPLN]
        nexc = 0
        nham = 0
        s = lead
        slow = False
        for m in range(G):
            if ipar[s, I_PROBE] >= 0 or ipar[s, I_TELEM] != 0 or ipar[s, I_CHUNK_FREE] <= 0:
                slow = True
            exc = ipar[s, I_EXC]
            if exc > EXC_NONE:
                nexc += 1
                if exc >= EXC_HAMMER3:
                    nham += 1
                if exc == EXC_FELT or ipar[s, I_CHUNK] <= 0 \
                        or ipar[s, I_EXC_END] - ipar[s, I_EXC_M] + 1 <= 0:
                    slow = True
            s = ipar[s, I_CPLNX]
        if slow or nexc > ROWS or nham > GROUP:
            need |= 1 << A_PER
        if nham > 0:
            need |= 1 << A_HAMMERS
    return need


@njit(inline="always", **JIT_OPTS)
def _coupled_tension(lead, G, ring, ipar, fpar, fst, C):
    """After a lockstep chunk of C samples: each member's tension reading,
    if due (:func:`synth.kernels.tension.tension_after`)."""
    s = lead
    for m in range(G):
        tension_after(s, ring, ipar, fpar, fst, C)
        s = ipar[s, I_CPLNX]
