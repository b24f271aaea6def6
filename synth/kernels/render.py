"""Rendering a bank of strings: coupled groups on their bridges, and the
bank on every core.

The per-string machinery is :mod:`synth.kernels.strings` (one string's
drivers) and the modules of its steps (:mod:`~synth.kernels.excite`: the
hammer solver; :mod:`~synth.kernels.contact`; :mod:`~synth.kernels.far_end`:
the loop filters; :mod:`~synth.kernels.coupled`: the bridge's step and the
lockstep filters; :mod:`~synth.kernels.unison`: a small coupled group's
chunks; the columns in :mod:`~synth.kernels.layout`); this module puts it
together for a whole bank, one segment at a time:

* :func:`render_bank` renders a list of strings (singles, hammered strings
  four at a time, coupled groups from their leaders, finer grids staged)
  into one mix, on the calling thread, except that a coupled group of
  more than :data:`BLOCK` members may step its blocks on ``nt`` threads.
* :func:`render_sharded` is what the bank calls: it splits the active
  strings into shards, renders the shards on ``nt`` threads, and adds
  their mixes in shard order.

Same samples for any number of threads
--------------------------------------
Which thread runs which piece never changes an operation:

* the shards are a function of the active strings alone (a coupled group
  is one unit and never spans shards; units go, in the active list's
  order, to the shard with the least cost so far, :func:`unit_cost`;
  at most :data:`MAX_SHARDS`); shard 0 renders into the caller's mix, each
  other shard into its own, added in shard order after all have rendered;
* a coupled group of more than :data:`BLOCK` members (all of a sitar's
  strings hang on its one bridge: 45 for 32 voices) is its own shard, and
  steps its members in blocks of :data:`BLOCK` consecutive members of its
  chain; the bridge, which needs every member's force, is stepped between
  the two halves of the chunk on the calling thread; each block adds its
  members' outputs into its own mix (``pb``), and the blocks' mixes are
  added in block order.

Against one mix for the whole bank only the order of some additions
changes: a bank of several units, or a group of more than BLOCK members,
differs from it by round-off (under 1e-12 of full scale,
``tests/test_threads.py``); a bank of one small unit is bit-identical.

Threads
-------
The parallel loops are numba ``prange`` loops over *tasks* (one per
thread), in functions compiled with ``parallel=True`` (``PAR_OPTS``; this
module is the only one: the architecture's kernels are otherwise plain
nogil functions, and a pool of Python threads cannot meet at a barrier
twice per 140-sample chunk: 12 us a meeting measured, against 2 us for a
numba ``prange`` on the OpenMP threading layer).  ``nt`` = 1 runs the same
tasks in a plain loop and never touches the threading layer, and so does a
loop with less work than :data:`PAR_MIN_WORK` (up to about four sitar
notes on their bridge, a few piano strings): the launch would cost more
than the second thread saves.  The caller
sets numba's thread count (:func:`numba.set_num_threads`, per calling
thread) to at least ``nt``; :mod:`synth.dsp.threads` does.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange, types

from .address import (  # noqa: F401  (the units and their signatures: re-exported)
    A_BIG, A_BLOCKA, A_HAMMERS, A_PER, A_SMALL, A_STRING, A_TAIL, BIG_SIG, BLOCKA_SIG, F1, F2,
    F3, I1, I2, INT, N_ADDRS, NEEDS, PER_SIG, SIGS, SMALL_SIG, STRING_SIG, TAIL_SIG, address_of,
    big_at, blocka_at, function_at, per_at, small_at, string_at,
)
from .config import JIT_OPTS, PAR_OPTS
from .contact import _region_step
from .coupled import _bridge_steps, _far_lanes, _force_row
from .excite import _excite_group
from .far_end import _far_filter, _far_prep, _far_write
from .layout import (
    CPL_NONE, EXC_FELT, EXC_HAMMER3, EXC_NONE, F_CURV, GROUP, GROUP_CHUNK, ROWS, I_BUS,
    I_CHUNK, I_CHUNK_FREE, I_CPL, I_CPLN, I_CPLNX, I_EXC, I_NDISP, I_NSOS, I_PROBE, I_REG_N,
    I_ROW, I_SUB, I_TELEM, S_PEAK, S_UBM, S_UBP, _CW, _GROW,
)
from .strings import _chunk_end, _render_group, _render_string, _work_windows
from .tension import tension_after, tension_limit_after
# (a small coupled group's chunks, split from here; ZERO, ONE and BLOCK are
# defined there and re-exported)
from .unison import (  # noqa: F401  (BLOCK, ONE, ZERO: re-exported)
    BLOCK, ONE, ZERO, _coupled_chunk_small_or_split, _coupled_diag, _coupled_head, _coupled_next,
    _coupled_per_sample, _coupled_tail, _coupled_tension, groups_need, loaded,
)

#: (Compile time.)  numba links each callee's optimised module into its
#: caller's and optimises and emits the whole again, so every level of a
#: call tree costs about as much as the tree below it.  The small drivers
#: between a renderer and a group's blocks (``_render_coupled_big`` and
#: ``_small``, ``_coupled_chunk_big``, ``_coupled_blocks``, ``_task_a`` and
#: ``_c``) are therefore ``inline="always"``: a cold sitar note compiled
#: 45.4 CPU s called, 34.7 inlined, with the serial ``nt`` None variant of
#: :func:`_coupled_blocks` (alternated on a 2-vCPU Xeon, ``tools/bench.py
#: compile``).  The blocks' bodies (``_block_a``, ``_c``)
#: are not: inlined, numba's typing of the nest took 113 CPU s and 1.7 GB.
#: the least work (string_cost units x samples, about 0.5 ns each) worth a
#: parallel loop, which then runs on the calling thread (that never changes
#: a sample).  A launch costs about 2 us (OpenMP threads still spinning from
#: the last loop); a sitar group's chunk on 2 threads ran at 0.9x (one note,
#: 41 000 units a chunk), 1.0x (four notes, 75 000), 1.2x (eight), 1.4x
#: (sixteen) and 1.55x (32) of one thread's speed (2-vCPU Xeon,
#: ``tools/bench.py render``)
PAR_MIN_WORK = 80_000
#: most shards of a bank's small units (the same for any thread count: a
#: machine with more threads than this renders the small units on this many)
MAX_SHARDS = 8


def n_blocks(max_group: int) -> int:
    """Blocks of a coupled group of ``max_group`` members."""
    return max(1, -(-int(max_group) // BLOCK))


def block_index_length(max_group: int, max_threads: int) -> int:
    """int64 samples of ``ib``: the blocks' first members, tasks, costs
    and sorting order, and a load per thread."""
    return 4 * n_blocks(max_group) + max(int(max_threads), n_blocks(max_group))


def block_mix_shape(max_group: int, rows: int) -> tuple[int, int, int]:
    """Shape of ``pb``: per block of the largest group, a mix of ``rows``
    rows and a row of the block's force on the bridge, a chunk's samples
    each."""
    return (n_blocks(max_group), int(rows) + 1, GROUP_CHUNK + 8)


def task_work_length(max_block: int, max_region: int, max_bend: int) -> int:
    """Samples of a thread's work row (``tw``): the chunk's windows
    (:func:`strings._work_windows`, as in ``scratch``) and C + 8 more for
    the lanes' unused outputs."""
    return (max_block + 3 * (max_block + max_region + 2 + 512) + max_bend + max_block + 8
            + GROUP_CHUNK + 8)


@njit(inline="always", **JIT_OPTS)
def string_cost(ipar, fpar, s):
    """The relative cost of a sample of string s (units of about 0.5 ns),
    from what the kernel does per sample: the ring's reads and writes and
    the output (6), the termination region's points (1 each), the sub-cell
    contact's solve (20), the loop filter's first-order (2) and
    second-order (4) dispersion sections, a running hammer's solve (24),
    times the steps of a finer grid (``I_SUB``).  Used only to balance the
    threads' work: it never changes a sample."""
    w = 6 + ipar[s, I_REG_N] + 2 * ipar[s, I_NDISP] + 4 * ipar[s, I_NSOS]
    if fpar[s, F_CURV] > 0.0:
        w += 20
    if ipar[s, I_EXC] >= EXC_HAMMER3:
        w += 24
    return w * ipar[s, I_SUB]


@njit(**JIT_OPTS)
def unit_cost(ipar, fpar, s):
    """:func:`string_cost` summed over the unit led by s (a string, or the
    members of its coupled group)."""
    G = ipar[s, I_CPLN] if ipar[s, I_CPL] >= 0 else 1
    c = 0
    for m in range(G):
        c += string_cost(ipar, fpar, s)
        s = ipar[s, I_CPLNX]
    return c


@njit(**JIT_OPTS)
def _balance(cost, n, T, task, load, order):
    """Give each of n pieces (costs ``cost[0:n]``) a task of T: the
    costliest first, each to the least loaded task (longest processing
    time first); ``task[j]`` the result; ``load``, ``order``: work."""
    for j in range(n):
        order[j] = j
    for a in range(1, n):
        j = order[a]
        c = cost[j]
        b = a - 1
        while b >= 0 and cost[order[b]] < c:
            order[b + 1] = order[b]
            b -= 1
        order[b + 1] = j
    for t in range(T):
        load[t] = 0
    for a in range(n):
        j = order[a]
        best = 0
        for t in range(1, T):
            if load[t] < load[best]:
                best = t
        task[j] = best
        load[best] += cost[j]


# ---- a big coupled group's blocks --------------------------------------------------

@njit(**JIT_OPTS)
def _block_a(b, ib, G, ring, ipar, fpar, fst, U, C, cw, lock, tw, ubm, fb):
    """The first half of a chunk for block b of a coupled group: each
    member's termination region and loop filter (into its far-end windows
    in ``cw``), as :func:`_coupled_chunk` steps them, then the block's
    share of the strings' force on the bridge held still, fb[i] = sum over
    its members of T/dx 2 dz(i) (the sum :func:`coupled._bridge` forms over
    the whole group; ``ubm``: the bridge's u_b before the chunk); ``tw``:
    this thread's work row.  The members' windows stay with the thread
    that steps them: the calling thread reads only the blocks' rows."""
    m0 = b * BLOCK
    g = G - m0 if G - m0 < BLOCK else BLOCK
    work = tw[0:tw.shape[0] - _CW]
    s = ib[b]
    for j in range(g):
        m = m0 + j
        w1, w2, w3, hb = _work_windows(work, C, ipar[s, I_REG_N])
        _region_step(s, ring, ipar, fpar, fst, U, C, w1, w2, w3)
        xw = cw[2 * m * _CW:2 * m * _CW + C + 2]
        yw = cw[(2 * m + 1) * _CW:(2 * m + 1) * _CW + C + 1]
        if lock:
            _far_prep(s, ring, ipar, fst, C, xw, yw)
        else:
            _far_filter(s, ring, ipar, fpar, fst, U, C, xw, yw, hb)
        s = ipar[s, I_CPLNX]
    if lock:
        _far_lanes(ib[b], g, ipar, fpar, fst, C, cw[2 * m0 * _CW:], work[0:4 * C],
                   tw[tw.shape[0] - _CW:tw.shape[0] - _CW + C])
    _force_row(ib[b], m0, g, ipar, fpar, C, cw, ubm, fb)


@njit(**JIT_OPTS)
def _block_c(b, ib, G, ring, ipar, fpar, fst, C, cw, iw, nrow, scratch, pm, tw):
    """The second half of a chunk for block b: each member's outgoing wave
    (its loop filter's output less the bridge's u_b, the bridge row of
    ``cw``), far-end write and output, into the block's own mix ``pm``
    (zeroed first, its first C samples), as :func:`_coupled_chunk` writes
    them (``iw[0:nrow]``: the excited strings, their g rows in
    ``scratch``), then its tension's reading if due."""
    rows = pm.shape[0]
    for r in range(rows):
        pr = pm[r]
        for i in range(C):
            pr[i] = 0.0
    m0 = b * BLOCK
    g = G - m0 if G - m0 < BLOCK else BLOCK
    work = tw[0:tw.shape[0] - _CW]
    row = cw[2 * G * _CW:2 * G * _CW + C + 1]
    ub = row[C]
    s = ib[b]
    for j in range(g):
        m = m0 + j
        # the outgoing wave y = z - u_b (as coupled._bridge ends)
        yo = cw[(2 * m + 1) * _CW + 1:(2 * m + 1) * _CW + 1 + C]
        for i in range(C):
            yo[i] -= row[1 + i]
        fst[s, S_UBP] = ub
        w1, w2, w3, hb = _work_windows(work, C, ipar[s, I_REG_N])
        peak = fst[s, S_PEAK]
        pk = _far_write(s, ring, ipar, fpar, C, cw[(2 * m + 1) * _CW:(2 * m + 1) * _CW + C + 1],
                        pm, ZERO, cw[2 * G * _CW:2 * G * _CW + C + 1], True)
        peak = pk if pk > peak else peak
        r = -1
        for q in range(nrow):
            if iw[q] == s:
                r = q
        plucking = r >= 0
        gb = scratch[(r if r >= 0 else 0) * _GROW:(r if r >= 0 else 0) * _GROW + C]
        _chunk_end(s, ring, ipar, fpar, fst, C, ZERO, pm, w1, w2, w3, gb, plucking, False, peak)
        # its tension's reading, if due (unison._coupled_tension's, for a
        # small group after its chunk): it reads and writes only this
        # string, whose chunk is complete here, so on the blocks' threads
        # (on the calling thread, the sitar's 45 strings took a 32-voice
        # render on 2 threads from 1.6x to 1.44x: tools/bench.py render)
        tension_after(s, ring, ipar, fpar, fst, C)
        s = ipar[s, I_CPLNX]


@njit(inline="always", **JIT_OPTS)
def _task_a(t, nb, ib, G, ring, ipar, fpar, fst, U, C, cw, lock, tw, ubm, pb, addrs):
    """Task t: the blocks b with ib[nb + b] = t (first half; block b's
    force row: the last row of ``pb[b]``), :func:`_block_a` called by its
    address ``addrs[A_BLOCKA]``."""
    F = pb.shape[1] - 1
    block_a = blocka_at(addrs[A_BLOCKA])
    for b in range(nb):
        if ib[nb + b] == t:
            pm = pb[b]
            block_a(b, ib, G, ring, ipar, fpar, fst, U, C, cw, lock, tw[t], ubm, pm[F])


@njit(inline="always", **JIT_OPTS)
def _task_c(t, nb, ib, G, ring, ipar, fpar, fst, C, cw, iw, row, scratch, pb, rows, tw):
    """Task t: the blocks b with ib[nb + b] = t (second half)."""
    for b in range(nb):
        if ib[nb + b] == t:
            pm = pb[b]
            _block_c(b, ib, G, ring, ipar, fpar, fst, C, cw, iw, row, scratch, pm[0:rows],
                     tw[t])


@njit(**PAR_OPTS)
def _tasks_a_par(T, nb, ib, G, ring, ipar, fpar, fst, U, C, cw, lock, tw, ubm, pb, addrs):
    for t in prange(T):
        _task_a(np.int64(t), nb, ib, G, ring, ipar, fpar, fst, U, C, cw, lock, tw, ubm, pb, addrs)


@njit(**PAR_OPTS)
def _tasks_c_par(T, nb, ib, G, ring, ipar, fpar, fst, C, cw, iw, row, scratch, pb, rows, tw):
    for t in prange(T):
        _task_c(np.int64(t), nb, ib, G, ring, ipar, fpar, fst, C, cw, iw, row, scratch, pb, rows, tw)


@njit(inline="always", **JIT_OPTS)
def _task_ca(t, nb, ib, G, ring, ipar, fpar, fst, U, C, C2, cw, lock, iw, row, scratch, pb, rows,
             tw, ubm2, addrs):
    """Task t of a fused launch: for each of its blocks (ib[nb + b] = t),
    the second half of this chunk (C samples, :func:`_block_c`) and then
    the first half of the next (C2 samples, :func:`_block_a`, with
    ``ubm2`` the bridge's u_b after this chunk).  A block's members read
    and write only their own strings and far-end windows (and its own
    mix ``pb[b]``, whose force row the first half writes and whose other
    rows the second half), so the next chunk's first half may follow the
    block's second half at once, on the same thread."""
    F = pb.shape[1] - 1
    block_a = blocka_at(addrs[A_BLOCKA])
    for b in range(nb):
        if ib[nb + b] == t:
            pm = pb[b]
            _block_c(b, ib, G, ring, ipar, fpar, fst, C, cw, iw, row, scratch, pm[0:rows], tw[t])
            block_a(b, ib, G, ring, ipar, fpar, fst, U, C2, cw, lock, tw[t], ubm2, pm[F])


@njit(**PAR_OPTS)
def _tasks_ca_par(T, nb, ib, G, ring, ipar, fpar, fst, U, C, C2, cw, lock, iw, row, scratch, pb,
                  rows, tw, ubm2, addrs):
    for t in prange(T):
        _task_ca(np.int64(t), nb, ib, G, ring, ipar, fpar, fst, U, C, C2, cw, lock, iw, row,
                 scratch, pb, rows, tw, ubm2, addrs)


@njit(inline="always", **JIT_OPTS)
def _next_free_chunk(lead, G, ipar, fpar, fst, avail, C):
    """The size of the chunk after this one (of C samples), as
    :func:`_coupled_next` will give it once this chunk has run, for a
    group none of whose members is excited (none can be before the render
    call ends: excitations start at events, between calls); 0 when there
    is none (``avail`` <= 0 samples left) or it would take the per-sample
    path.  Each member's tension limit is taken as it will be after C
    samples (:func:`synth.kernels.tension.tension_limit_after`)."""
    C2 = avail
    if C2 > GROUP_CHUNK:
        C2 = GROUP_CHUNK
    if C2 <= 0:
        return 0
    s = lead
    for m in range(G):
        if ipar[s, I_EXC] != EXC_NONE:
            return 0
        c = tension_limit_after(s, fpar, fst, ipar[s, I_CHUNK_FREE], C)
        if c <= 0:
            return 0
        if c < C2:
            C2 = c
        s = ipar[s, I_CPLNX]
    return C2


@njit(**JIT_OPTS)
def _bridge_blocks(lead, nb, fpar, fst, C, row, pb):
    """:func:`coupled._bridge` for a group in blocks: the strings' force
    f(i) summed from the blocks' rows (the last row of each ``pb[b]``, in
    block order), then the bridge's step over the chunk, u_b per sample
    into ``row[1:C+1]`` (``row[0]``: u_b before the chunk), as
    :func:`coupled._bridge` computes it (the blocks subtract u_b from their
    members' waves themselves, :func:`_block_c`)."""
    ubm = fst[lead, S_UBM]
    F = pb.shape[1] - 1
    fo = row[1:1 + C]
    p0 = pb[0]
    f0 = p0[F]
    for i in range(C):
        fo[i] = f0[i]
    for k in range(1, nb):
        pk = pb[k]
        fk = pk[F]
        for i in range(C):
            fo[i] += fk[i]
    row[0] = ubm
    _bridge_steps(lead, fpar, fst, C, fo, ubm)


@njit(inline="always", **JIT_OPTS)
def _coupled_blocks(lead, G, ring, ipar, fpar, fst, U, C, o0, mix, scratch, cw, lock, iw, row,
                    pb, tw, ib, nt, addrs, ahead, C2):
    """Steps 3 and 4 of :func:`_coupled_chunk` for a group of more than
    BLOCK members: the blocks' first halves (:func:`_block_a`), the
    bridge, the blocks' second halves (:func:`_block_c`) each into its
    mix ``pb[b]``, then those mixes added to mix[:, o0:o0+C] in block
    order.  On min(nt, blocks) threads; the same samples for any.  With
    ``nt`` None (a compile-time choice: numba prunes the branch on the
    argument's type), every block on the calling thread, and the parallel
    loops are not compiled (a single note's scene: issue 39's cold start).
    On threads, ``ahead``: the first halves already ran (fused into the
    previous chunk's launch); ``C2`` > 0: the next chunk's size, whose
    first halves run in this chunk's launch of second halves
    (:func:`_blocks_threads`; ``nt`` None ignores both: neither is set)."""
    nb = (G + BLOCK - 1) // BLOCK
    ubm = fst[lead, S_UBM]
    s = lead
    for m in range(G):
        if m % BLOCK == 0:
            ib[m // BLOCK] = s
        s = ipar[s, I_CPLNX]
    rows = mix.shape[0]
    if nt is None:
        for b in range(nb):
            ib[nb + b] = 0
        _task_a(ZERO, nb, ib, G, ring, ipar, fpar, fst, U, C, cw, lock, tw, ubm, pb, addrs)
        _bridge_blocks(lead, nb, fpar, fst, C, cw[2 * G * _CW:2 * G * _CW + C + 1], pb)
        _task_c(ZERO, nb, ib, G, ring, ipar, fpar, fst, C, cw, iw, row, scratch, pb, rows, tw)
    else:
        _blocks_threads(lead, G, ring, ipar, fpar, fst, U, C, cw, lock, iw, row, pb, tw, ib, nt,
                        nb, ubm, rows, scratch, addrs, ahead, C2)
    for b in range(nb):
        pm = pb[b]
        for r in range(rows):
            mo = mix[r, o0:o0 + C]
            pr = pm[r]
            for i in range(C):
                mo[i] += pr[i]


@njit(inline="always", **JIT_OPTS)
def _blocks_threads(lead, G, ring, ipar, fpar, fst, U, C, cw, lock, iw, row, pb, tw, ib, nt, nb,
                    ubm, rows, scratch, addrs, ahead, C2):
    """:func:`_coupled_blocks`' halves and bridge on min(nt, blocks)
    threads, balanced by cost (one thread when the chunk's work is below
    :data:`PAR_MIN_WORK`): the first halves (unless ``ahead``: the
    previous launch ran them), the bridge, then the second halves, with
    the next chunk's first halves (``C2`` samples) in the same launch when
    ``C2`` > 0 (:func:`_task_ca`: one launch and one wait a chunk instead
    of two; the same operations on each string in the same order, so the
    same samples)."""
    T = nt if nt < nb else nb
    if T > 1:
        # the blocks to the threads by cost (ib[nb:2 nb]; which thread steps
        # a block never changes its samples)
        cost = ib[2 * nb:3 * nb]
        for b in range(nb):
            cost[b] = 0
        total = 0
        s = lead
        for m in range(G):
            c = string_cost(ipar, fpar, s)
            cost[m // BLOCK] += c
            total += c
            s = ipar[s, I_CPLNX]
        if total * C < PAR_MIN_WORK:
            T = 1
    if T > 1:
        _balance(cost, nb, T, ib[nb:2 * nb], ib[3 * nb:3 * nb + T], ib[4 * nb:5 * nb])
    else:
        for b in range(nb):
            ib[nb + b] = 0
    if not ahead:
        if T > 1:
            _tasks_a_par(T, nb, ib, G, ring, ipar, fpar, fst, U, C, cw, lock, tw, ubm, pb, addrs)
        else:
            _task_a(ZERO, nb, ib, G, ring, ipar, fpar, fst, U, C, cw, lock, tw, ubm, pb, addrs)
    _bridge_blocks(lead, nb, fpar, fst, C, cw[2 * G * _CW:2 * G * _CW + C + 1], pb)
    if C2 > 0:
        ubm2 = fst[lead, S_UBM]
        if T > 1:
            _tasks_ca_par(T, nb, ib, G, ring, ipar, fpar, fst, U, C, C2, cw, lock, iw, row,
                          scratch, pb, rows, tw, ubm2, addrs)
        else:
            _task_ca(ZERO, nb, ib, G, ring, ipar, fpar, fst, U, C, C2, cw, lock, iw, row, scratch,
                     pb, rows, tw, ubm2, addrs)
    elif T > 1:
        _tasks_c_par(T, nb, ib, G, ring, ipar, fpar, fst, C, cw, iw, row, scratch, pb, rows, tw)
    else:
        _task_c(ZERO, nb, ib, G, ring, ipar, fpar, fst, C, cw, iw, row, scratch, pb, rows, tw)


# ---- coupled groups, and a list of strings into one mix ------------------------------

@njit(inline="always", **JIT_OPTS)
def _big_next(lead, G, ipar, fpar, fst, avail, diag, ahead):
    """:func:`_coupled_next` for a big group's render loop: the chunk
    ``ahead`` (> 0) whose first halves the last launch ran, else the next
    as :func:`_coupled_next` gives it."""
    if ahead > 0:
        return ahead, False
    return _coupled_next(lead, G, ipar, fpar, fst, avail, diag)


@njit(inline="always", **JIT_OPTS)
def _coupled_chunk_big(lead, G, ring, ipar, fpar, fst, U, C, o0, mix, scratch, iw, ist, pb, tw,
                       ib, nt, addrs, ahead, avail):
    """:func:`_coupled_chunk` of a group of more than BLOCK members (a
    sitar's bridge): its blocks (:func:`_coupled_blocks`).  On threads
    (``nt`` not None), with no member excited and ``avail`` samples left
    after this chunk, the next chunk's first halves run in this chunk's
    last launch: returns that chunk's size (0: none ran; ``ahead``: this
    chunk's first halves already ran so)."""
    row, work, cw, lock = _coupled_head(lead, G, ring, ipar, fpar, fst, U, C, scratch, iw, ist,
                                        addrs)
    C2 = 0
    if nt is not None:
        C2 = _next_free_chunk(lead, G, ipar, fpar, fst, avail, C)
    _coupled_blocks(lead, G, ring, ipar, fpar, fst, U, C, o0, mix, scratch, cw, lock, iw, row,
                    pb, tw, ib, nt, addrs, ahead, C2)
    return C2


@njit(**JIT_OPTS)
def render_coupled_big(lead, ring, ipar, fpar, fst, U, n, o0, mix, probe, scratch, iw, ist, po0,
                       psub, pb, tw, ib, nt, addrs):
    """:func:`_render_coupled` of a group of more than BLOCK members (a
    sitar's bridge), for :func:`render_bank`, which calls it by its address
    (:data:`BIG_SIG`, :func:`unit_address`): a bank with no such group (a
    piano, a biwa) never compiles the blocks and their parallel loops.
    ``n`` <= 0 returns at once (the call that loads it)."""
    if n <= 0:
        return
    G = ipar[lead, I_CPLN]
    diag = _coupled_diag(lead, G, ipar)
    one = scratch[scratch.shape[0] - 2:]
    done = 0
    ahead = 0                  # the size of a chunk whose first halves ran (0: none)
    while done < n:
        C, slow = _big_next(lead, G, ipar, fpar, fst, n - done, diag, ahead)
        if slow:
            per = per_at(loaded(addrs, A_PER))
            per(lead, G, ring, ipar, fpar, fst, U, C, o0 + done, mix, probe, one,
                po0 + (done // psub), psub)
        else:
            # (each member's tension reading, if due, in its block: _block_c)
            ahead = _coupled_chunk_big(lead, G, ring, ipar, fpar, fst, U, C, o0 + done, mix,
                                       scratch, iw, ist, pb, tw, ib, nt, addrs, ahead > 0,
                                       n - done - C)
        done += C


@njit(**JIT_OPTS)
def render_coupled_small(lead, ring, ipar, fpar, fst, U, n, o0, mix, probe, scratch, iw, ist, po0,
                         psub, addrs):
    """n steps of the coupled group of at most BLOCK members led by
    ``lead`` (a piano key's unison) into mix[:, o0:o0+n]: lockstep
    fast-path chunks (:func:`synth.kernels.unison.
    _coupled_chunk_small_or_split`) as long as every member allows one and
    at most ROWS of them excite (GROUP hammers), else per sample
    (:func:`_coupled_per_sample`, a member with a probe or telemetry takes
    the whole block that way).  Called by its address (:data:`SMALL_SIG`,
    :func:`unit_address`) from :func:`render_bank` and
    :func:`render_small_group`, so that its tree compiles once for both.
    ``n`` <= 0 returns at once (the call that loads it)."""
    if n <= 0:
        return
    G = ipar[lead, I_CPLN]
    diag = _coupled_diag(lead, G, ipar)
    one = scratch[scratch.shape[0] - 2:]
    done = 0
    while done < n:
        C, slow = _coupled_next(lead, G, ipar, fpar, fst, n - done, diag)
        if slow:
            per = per_at(loaded(addrs, A_PER))
            per(lead, G, ring, ipar, fpar, fst, U, C, o0 + done, mix, probe, one,
                po0 + (done // psub), psub)
        else:
            C = _coupled_chunk_small_or_split(lead, G, ring, ipar, fpar, fst, U, C, n - done,
                                              o0 + done, mix, scratch, iw, ist, addrs)
            _coupled_tension(lead, G, ring, ipar, fpar, fst, C)
        done += C


@njit(**JIT_OPTS)
def render_string(s, ring, ipar, fpar, fst, U, n, o0, mix, probe, scratch, ubx, po0, psub):
    """:func:`synth.kernels.strings._render_string` (n samples of string s
    by itself), called by its address (:data:`STRING_SIG`,
    :func:`unit_address`) from :func:`render_bank` and
    :func:`render_strings`, so that its tree compiles once for both.
    ``n`` <= 0 returns at once (the call that loads it)."""
    if n <= 0:
        return
    _render_string(s, ring, ipar, fpar, fst, U, n, o0, mix, probe, scratch, ubx, po0, psub)


@njit(inline="always", **JIT_OPTS)
def _render_coupled(lead, ring, ipar, fpar, fst, U, n, o0, mix, probe, scratch, iw, ist, po0, psub,
                    pb, tw, ib, nt, addrs):
    """n steps of the coupled group led by ``lead`` into mix[:, o0:o0+n],
    by the renderer of its kind at its address in ``addrs``:
    :func:`render_coupled_big` for more than BLOCK members (``nt``
    threads for its blocks), else :func:`render_coupled_small`."""
    if ipar[lead, I_CPLN] > BLOCK:
        big_at(addrs[A_BIG])(lead, ring, ipar, fpar, fst, U, n, o0, mix, probe, scratch, iw, ist,
                             po0, psub, pb, tw, ib, nt, addrs)
    else:
        small_at(addrs[A_SMALL])(lead, ring, ipar, fpar, fst, U, n, o0, mix, probe, scratch, iw,
                                 ist, po0, psub, addrs)


@njit(inline="always", **JIT_OPTS)
def _render_coupled_big(lead, ring, ipar, fpar, fst, U, n, o0, mix, probe, scratch, iw, ist, pb,
                        tw, ib, nt, addrs):
    """:func:`_render_coupled` of a group of more than BLOCK members on the
    engine's grid."""
    G = ipar[lead, I_CPLN]
    diag = _coupled_diag(lead, G, ipar)
    one = scratch[scratch.shape[0] - 2:]
    done = 0
    ahead = 0                  # the size of a chunk whose first halves ran (0: none)
    while done < n:
        C, slow = _big_next(lead, G, ipar, fpar, fst, n - done, diag, ahead)
        if slow:
            per = per_at(loaded(addrs, A_PER))
            per(lead, G, ring, ipar, fpar, fst, U, C, o0 + done, mix, probe, one, o0 + done, ONE)
        else:
            # (each member's tension reading, if due, in its block: _block_c)
            ahead = _coupled_chunk_big(lead, G, ring, ipar, fpar, fst, U, C, o0 + done, mix,
                                       scratch, iw, ist, pb, tw, ib, nt, addrs, ahead > 0,
                                       n - done - C)
        done += C


@njit(**JIT_OPTS)
def _unit_rows(s, G, ipar, rows):
    """The mix rows [lo, hi) that the G strings of the chain from s (one
    string: G = 1) write in a mix of ``rows`` rows."""
    lo = ipar[s, I_ROW]
    hi = lo + 1
    for m in range(G):
        r0 = ipar[s, I_ROW]
        r1 = r0 + 2 if ipar[s, I_BUS] == 1 and rows > r0 + 1 else r0 + 1
        lo = r0 if r0 < lo else lo
        hi = r1 if r1 > hi else hi
        s = ipar[s, I_CPLNX]
    return lo, hi


@njit(**JIT_OPTS)
def _shift_rows(s, G, ipar, d):
    """Add d to ``I_ROW`` of the G strings of the chain from s."""
    for m in range(G):
        ipar[s, I_ROW] += d
        s = ipar[s, I_CPLNX]


@njit(**JIT_OPTS)
def _fold_sub(mix, o0, n, sub, M, lo, hi):
    """Add the staging mix of a string on a finer grid (n engine samples of
    M steps each in sub[:, 0:n M], its row j for mix row lo + j) to
    mix[lo:hi, o0:o0+n] as the mean of each engine sample's M steps (a
    boxcar before the engine's decimator)."""
    w = 1.0 / M
    for r in range(lo, hi):
        mo = mix[r, o0:o0 + n]
        sb = sub[r - lo]
        if M == 2:
            # (the grand's top keys; the same sums: 0 + a + b)
            for i in range(n):
                acc = 0.0
                acc += sb[2 * i]
                acc += sb[2 * i + 1]
                mo[i] += w * acc
        else:
            for i in range(n):
                acc = 0.0
                for j in range(M):
                    acc += sb[i * M + j]
                mo[i] += w * acc


@njit(**JIT_OPTS)
def render_bank(ring, ipar, fpar, fst, U, active, n_active, n, o0, mix,
                probe, scratch, iwork, ubx, sub, pb, tw, ib, nt, addrs):
    """Render ``n`` internal samples of every active string into
    ``mix[:, o0:o0+n]`` (accumulating).  ``mix`` is 2-D: one row per output
    bus; string s adds its output to row r0 = ``ipar[s, I_ROW]``, or, with
    ``I_BUS`` 1, splits it between rows r0 and r0 + 1 (by ``F_PAN``) when
    the mix has row r0 + 1 (else all of it to r0).  No bounds are checked:
    ``mix`` must have more than the largest ``I_ROW`` of an active string.

    ring : float64[:]        all rings, concatenated
    ipar, fpar, fst : 2-D     parameter and state tables (columns above)
    U : float64[:]            all region profiles and g tables, concatenated
    active : int64[:]         string indices; the first ``n_active`` are used
    probe : 3-D               per-sample diagnostics [row, channel P_*, n] for
                              strings with ``ipar[s, I_PROBE] >= 0``
    scratch : float64[:]      :func:`synth.dsp.sizing.scratch_length` samples
    iwork : int64[:]          n_active + IWORK_EXTRA samples (work space)
    ubx : float64[:]          an external bridge's displacement per sample
                              (m), indexed like ``mix`` (strings with
                              ``I_CPL`` = ``CPL_EXTERNAL``; else unused); a
                              string on a finer grid reads M values per
                              sample, ubx[(o0 + i) M + m]
    sub : float64[:, :]       staging mix for strings on a finer grid
                              (:func:`synth.dsp.sizing.sub_length` columns;
                              rows: at least the span of rows any one of
                              them, or any coupled group of them, writes; 2
                              when every member of a group has the same
                              ``I_ROW``)
    pb : float64[:, :, :]     the blocks' mixes of a coupled group of more
                              than BLOCK members (:func:`block_mix_shape`)
    tw : float64[:, :]        a work row per thread (:func:`task_work_length`
                              samples each, ``nt`` rows at least)
    ib : int64[:]             :func:`block_index_length` samples (work)
    nt : int                  threads for the blocks of such a group (1: this
                              thread only); the same samples for any
    addrs : int64[:]          the addresses of the renderers of one unit,
                              :func:`render_coupled_big`, :func:`render_coupled_small`
                              and :func:`render_string` (``addrs[A_BIG]``, ...:
                              :func:`unit_address`), each called by it;
                              0 where no such unit is active (:func:`unit_kinds`)

    Strings whose hammer is running on the fast path render GROUP at a
    time (:func:`_render_group`); a coupled group (a piano key's unison on
    its bridge; a sitar's taraf with its played strings: the chain of
    ``I_CPLNX`` from the leader) renders as a unit from its leader
    (:func:`_render_coupled`; the leader must be active while it has
    members, and ``scratch`` must hold
    :func:`synth.dsp.sizing.coupled_scratch` of its size);
    a string or group on a finer grid (``I_SUB`` = M > 1) renders n M steps
    into ``sub`` and is added as the mean of each sample's M steps (the
    rows it writes, lo .. hi - 1, staged in sub rows 0 .. hi - lo - 1:
    its members' ``I_ROW`` are lowered by lo while they render and then
    restored, the one write of this function to a parameter column); the
    others render one by one.
    """
    L = iwork.shape[0]
    ist = iwork[L - 6 * GROUP:]
    iw = iwork[L - 6 * GROUP - ROWS:L - 6 * GROUP]
    rows = mix.shape[0]
    nh = 0
    for a in range(n_active):
        s = active[a]
        cpl = ipar[s, I_CPL]
        if cpl >= 0 and cpl != s:
            continue                  # rendered with its group's leader
        M = ipar[s, I_SUB]
        if M > 1:
            nm = n * M
            G = ipar[s, I_CPLN] if cpl >= 0 else 1
            lo, hi = _unit_rows(s, G, ipar, rows)
            for r in range(hi - lo):
                sr = sub[r]
                for i in range(nm):
                    sr[i] = 0.0
            # sub row j stands for mix row lo + j (the same buses split:
            # hi - lo > r0 - lo + 1 exactly when rows > r0 + 1)
            sm = sub[0:hi - lo]
            if lo != 0:
                _shift_rows(s, G, ipar, -lo)
            if cpl >= 0:
                _render_coupled(s, ring, ipar, fpar, fst, U, nm, ZERO, sm, probe, scratch, iw, ist,
                                o0, M, pb, tw, ib, nt, addrs)
            else:
                # (an external bridge's M steps per sample, from this segment's)
                string_at(addrs[A_STRING])(s, ring, ipar, fpar, fst, U, nm, ZERO, sm, probe,
                                            scratch, ubx[o0 * M:], o0, M)
            if lo != 0:
                _shift_rows(s, G, ipar, lo)
            _fold_sub(mix, o0, n, sub, M, lo, hi)
        elif cpl >= 0:
            _render_coupled(s, ring, ipar, fpar, fst, U, n, o0, mix, probe, scratch, iw, ist,
                            o0, ONE, pb, tw, ib, nt, addrs)
        elif (ipar[s, I_EXC] >= EXC_HAMMER3 and ipar[s, I_EXC] != EXC_FELT
                and ipar[s, I_PROBE] < 0 and ipar[s, I_TELEM] == 0
                and ipar[s, I_CHUNK] > 0 and cpl == CPL_NONE):
            iwork[nh] = s
            nh += 1
        else:
            string_at(addrs[A_STRING])(s, ring, ipar, fpar, fst, U, n, o0, mix, probe, scratch,
                                        ubx, o0, ONE)
    # strings with similar chunk lengths together (a group's chunk is the
    # shortest any member allows): insertion sort by I_CHUNK
    for a in range(1, nh):
        s = iwork[a]
        c = ipar[s, I_CHUNK]
        b = a - 1
        while b >= 0 and ipar[iwork[b], I_CHUNK] > c:
            iwork[b + 1] = iwork[b]
            b -= 1
        iwork[b + 1] = s
    g0 = 0
    while g0 < nh:
        G = nh - g0
        if G > GROUP:
            G = GROUP
        _render_group(iwork[g0:g0 + G], G, ring, ipar, fpar, fst, U, n, o0, mix, probe,
                      scratch, ist, ubx)
        g0 += G


# ---- the bank on every core ------------------------------------------------------

@njit(**PAR_OPTS)
def prime_threads(T, out):
    """A loop of T trivial tasks (``out[t] = t``).  OpenMP gives each thread
    that launches loops its own team of worker threads, created at its
    first loop: calling this once from a new rendering thread (the audio
    server's) creates the team before the first note needs it."""
    for t in prange(T):
        out[t] = t


def plan_length(capacity: int) -> int:
    """int64 samples of ``plan`` (:func:`render_sharded`) for a bank of
    ``capacity`` slots."""
    return 3 * int(capacity) + 3 * MAX_SHARDS + 8


# ---- render_bank by its address ----------------------------------------------

# (Compile time.)  :func:`render_sharded` calls :func:`render_bank` through
# its address, a first-class function value made from an int64, instead of
# by name: numba links a callee named in a caller's code into the caller's
# module and optimises and emits the whole tree again (in the shards'
# parallel loop three times: the loop's function, its wrapper, the caller),
# which made render_sharded the single longest compile of a cold start
# (161 of a cold ``synth demo``'s 247 CPU s; render_bank's own tree 109).
# Called by address, render_bank
# compiles once, as the bank's KIND_BANK renderer, and every shard of every
# thread count runs that same machine code.  A dispatcher passed as an
# argument would do the same at 50-80 us a call (numba converts it on each
# call); the address costs nothing, and the compiled caller caches (it
# holds no pointer of this process).  render_bank in turn calls
# :func:`render_coupled_big` (a coupled group of more than BLOCK members: its
# blocks and their parallel loops, a third of render_bank's tree) by address,
# so that a bank with no such group (a piano, a biwa) never compiles it; and
# those call a big group's blocks' first half, a small group's far half and
# any group's per-sample path by address too (:mod:`synth.kernels.address`):
# a note never loads the per-sample path, and a cold start compiles the
# units on two processes (:mod:`synth.apps.cold_start`).

#: :func:`render_bank`'s signature as the bank and :func:`render_sharded`
#: call it (every array C-contiguous; the scalars int64)
BANK_SIG = types.none(F1, I2, F2, F2, F1, I1, INT, INT, INT, F2, F3, F1, I1, F1, F2,
                      F3, F2, I1, INT, I1)
_bank_at = function_at(BANK_SIG)


def bank_address() -> int:
    """The address of :func:`render_bank` compiled for :data:`BANK_SIG`
    (the ``bank_addr`` of :func:`render_sharded`), valid for this process.
    Call render_bank once with the bank's arrays first (as the bank does):
    it then loads from numba's cache under the key a call from Python
    saves, which a compile for the full signature would miss."""
    return address_of(render_bank, BANK_SIG)


def unit_address(which: int) -> int:
    """The address of unit ``which`` for ``addrs``
    (:mod:`synth.kernels.address`): ``A_BIG``
    :func:`render_coupled_big`, ``A_SMALL`` :func:`render_coupled_small`,
    ``A_STRING`` :func:`render_string` (each after a call with ``n`` 0 from
    Python, as :func:`bank_address`); ``A_PER``
    :func:`~synth.kernels.unison._coupled_per_sample`, ``A_BLOCKA``
    :func:`_block_a`, ``A_TAIL`` :func:`~synth.kernels.unison._coupled_tail`,
    ``A_HAMMERS`` :func:`~synth.kernels.excite._excite_group` (compiled or
    loaded for their signature: no Python call)."""
    units = (render_coupled_big, render_coupled_small, render_string, _coupled_per_sample,
             _block_a, _coupled_tail, _excite_group)
    if not (isinstance(which, int) and 0 <= which < N_ADDRS):
        raise ValueError(f"which = {which!r} is not a unit (0 <= value < {N_ADDRS})")
    return address_of(units[which], SIGS[which])


@njit(**JIT_OPTS)
def unit_kinds(active, n_active, ipar):
    """Which renderers of one unit :func:`render_bank` calls for the
    ``n_active`` strings of ``active``: bit 1 << A_BIG, a coupled group of
    more than BLOCK members; 1 << A_SMALL, one of at most BLOCK; 1 <<
    A_STRING, a string by itself (not a hammer stepped with others).  The
    same branches as render_bank's."""
    m = 0
    for a in range(n_active):
        s = active[a]
        cpl = ipar[s, I_CPL]
        if cpl >= 0 and cpl != s:
            continue
        if cpl >= 0:
            m |= (1 << A_BIG) if ipar[s, I_CPLN] > BLOCK else (1 << A_SMALL)
        elif ipar[s, I_SUB] > 1 or not (
                ipar[s, I_EXC] >= EXC_HAMMER3 and ipar[s, I_EXC] != EXC_FELT
                and ipar[s, I_PROBE] < 0 and ipar[s, I_TELEM] == 0
                and ipar[s, I_CHUNK] > 0 and cpl == CPL_NONE):
            m |= 1 << A_STRING
    return m


# (inline: a function of its own linked and optimised the whole tree below
# render_bank once more, 8.7 CPU s of a cold ``synth demo``; see unison's
# compile-time note)
@njit(inline="always", **JIT_OPTS)
def _shard_task(bank_addr, addrs, t, T, S, lists, so, ring, ipar, fpar, fst, U, n, o0, mix,
                probe, scratch2, iwork2, ubx, sub3, smix, pb, tw, ib):
    """Task t of T: shards t, t + T, ... of the S small shards (their
    strings: lists[so[j]:so[j + 1]]), shard 0 into ``mix``, shard j > 0
    into smix[j - 1] (zeroed first, samples o0 .. o0 + n - 1), with this
    task's scratch rows.  ``bank_addr``: :func:`render_bank`'s address
    (:func:`bank_address`)."""
    bank = _bank_at(bank_addr)
    j = t
    while j < S:
        lst = lists[so[j]:so[j + 1]]
        if j == 0:
            bank(ring, ipar, fpar, fst, U, lst, lst.shape[0], n, o0, mix, probe,
                 scratch2[t], iwork2[t], ubx, sub3[t], pb, tw[t:t + 1], ib, ONE, addrs)
        else:
            sm = smix[j - 1]
            for r in range(sm.shape[0]):
                sr = sm[r, o0:o0 + n]
                for i in range(n):
                    sr[i] = 0.0
            bank(ring, ipar, fpar, fst, U, lst, lst.shape[0], n, o0, sm, probe,
                 scratch2[t], iwork2[t], ubx, sub3[t], pb, tw[t:t + 1], ib, ONE, addrs)
        j += T


#: what :func:`bank_kind` finds in a list of active strings, and so which
#: kernel the bank calls for it (each compiles only what it calls, the first
#: time a scene needs it: a cold ``synth note sitar`` compiled 146 CPU s of
#: kernels through :func:`render_sharded` (tools/bench.py compile))
KIND_NONE = 0         # nothing active: no call
KIND_SHARDS = 1       # several small units: :func:`render_sharded`
KIND_BANK = 2         # one shard of anything (a lone string's hammer, a finer grid):
                      # :func:`render_bank`
KIND_BIG_GROUPS = 3   # coupled groups of more than BLOCK members on the engine's grid
                      # only (a sitar's bridge): :func:`render_big_groups`
KIND_SMALL_GROUP = 4  # one coupled group of at most BLOCK members on the engine's
                      # grid (a piano key): :func:`render_small_group`
KIND_STRINGS = 5      # one single string that :func:`render_bank` renders by itself:
                      # :func:`render_strings`
KIND_BIG_GROUPS_ONE = 6   # KIND_BIG_GROUPS where no chunk has the work for a second
                          # thread (:data:`PAR_MIN_WORK`): :func:`render_big_groups` with
                          # ``nt`` None, which compiles no parallel loop


@njit(**JIT_OPTS)
def bank_kind(active, n_active, ipar, fpar, n):
    """Which kernel renders the ``n_active`` strings of ``active`` with the
    samples :func:`render_sharded` gives them (``KIND_*``).  It renders
    them as one shard, :func:`render_bank` of them all on the calling
    thread (a big group's blocks on ``nt``), when at most one unit is not a
    coupled group of more than :data:`BLOCK` members and not one of those
    alongside big groups; then, if every unit is a coupled group on the
    engine's grid (``I_SUB`` 1), :func:`render_bank` only calls
    :func:`_render_coupled` for each, in the active list's order
    (:func:`render_big_groups` and :func:`render_small_group` do the same
    for each kind of group), and if the unit is a single string on the
    engine's grid that it renders by itself (no hammer it would step with
    others), only :func:`strings._render_string` (:func:`render_strings`).
    The bank calls the kernel itself, so that a scene compiles only the
    paths it runs (the first time it needs them).  ``KIND_BIG_GROUPS_ONE``
    instead of ``KIND_BIG_GROUPS`` when no chunk of the next ``n`` samples
    can reach :data:`PAR_MIN_WORK` (a group's cost now, which only falls
    until the next note-on, times the longest chunk its members allow),
    so that :func:`_coupled_blocks` would run on one thread anyway."""
    if n_active == 0:
        return KIND_NONE
    nbig = 0
    par = False
    nsmall = 0
    grid = True
    single = False
    for a in range(n_active):
        s = active[a]
        cpl = ipar[s, I_CPL]
        if cpl >= 0 and cpl != s:
            continue
        if ipar[s, I_SUB] != 1:
            grid = False
        if cpl >= 0 and ipar[s, I_CPLN] > BLOCK:
            nbig += 1
            if not par:
                par = _group_work(s, ipar, fpar, n) >= PAR_MIN_WORK
        else:
            nsmall += 1
            single = cpl < 0 and not (
                ipar[s, I_EXC] >= EXC_HAMMER3 and ipar[s, I_EXC] != EXC_FELT
                and ipar[s, I_PROBE] < 0 and ipar[s, I_TELEM] == 0
                and ipar[s, I_CHUNK] > 0 and cpl == CPL_NONE)
            if cpl < 0 and not single:
                grid = False      # a hammer render_bank would step with others
    if not (nsmall <= 1 and (nbig == 0 or nsmall == 0)):
        return KIND_SHARDS
    if not grid:
        return KIND_BANK
    if nbig > 0:
        return KIND_BIG_GROUPS if par else KIND_BIG_GROUPS_ONE
    return KIND_STRINGS if single else KIND_SMALL_GROUP


@njit(inline="always", **JIT_OPTS)
def _group_work(lead, ipar, fpar, n):
    """An upper bound of ``total * C`` in :func:`_coupled_blocks` over the
    next ``n`` samples of the coupled group led by ``lead``: its
    :func:`unit_cost` now (costs only fall within a render call: a hammer
    ends) times the longest chunk :func:`_coupled_next` can give it."""
    G = ipar[lead, I_CPLN]
    C = n if n < GROUP_CHUNK else GROUP_CHUNK
    s = lead
    for m in range(G):
        c = ipar[s, I_CHUNK]
        cf = ipar[s, I_CHUNK_FREE]
        c = cf if cf > c else c
        C = c if c < C else C
        s = ipar[s, I_CPLNX]
    return unit_cost(ipar, fpar, lead) * C


@njit(**JIT_OPTS)
def render_big_groups(ring, ipar, fpar, fst, U, active, n_active, n, o0, mix, probe, scratch,
                      iwork, pb, tw, ib, nt, addrs):
    """:func:`render_bank` of a list of coupled groups of more than BLOCK
    members on the engine's grid (:func:`bank_kind` gives
    ``KIND_BIG_GROUPS``): the same calls, without the paths of other
    strings (arguments as :func:`render_bank`'s)."""
    L = iwork.shape[0]
    ist = iwork[L - 6 * GROUP:]
    iw = iwork[L - 6 * GROUP - ROWS:L - 6 * GROUP]
    for a in range(n_active):
        s = active[a]
        if ipar[s, I_CPL] != s:
            continue                  # rendered with its group's leader
        _render_coupled_big(s, ring, ipar, fpar, fst, U, n, o0, mix, probe, scratch, iw, ist,
                            pb, tw, ib, nt, addrs)


@njit(**JIT_OPTS)
def render_small_group(ring, ipar, fpar, fst, U, active, n_active, n, o0, mix, probe, scratch,
                       iwork, addrs):
    """:func:`render_bank` of one coupled group of at most BLOCK members on
    the engine's grid (:func:`bank_kind` gives ``KIND_SMALL_GROUP``): the
    same calls, without the paths of other strings (arguments as
    :func:`render_bank`'s)."""
    L = iwork.shape[0]
    ist = iwork[L - 6 * GROUP:]
    iw = iwork[L - 6 * GROUP - ROWS:L - 6 * GROUP]
    for a in range(n_active):
        s = active[a]
        if ipar[s, I_CPL] != s:
            continue                  # rendered with its group's leader
        small_at(addrs[A_SMALL])(s, ring, ipar, fpar, fst, U, n, o0, mix, probe, scratch, iw, ist,
                                 o0, ONE, addrs)


@njit(**JIT_OPTS)
def render_strings(ring, ipar, fpar, fst, U, active, n_active, n, o0, mix, probe, scratch, ubx,
                   addrs):
    """:func:`render_bank` of single strings on the engine's grid that it
    renders one by one (:func:`bank_kind` gives ``KIND_STRINGS`` for one):
    the same calls, without the paths of coupled groups and of hammers
    stepped together (arguments as :func:`render_bank`'s)."""
    string = string_at(addrs[A_STRING])
    for a in range(n_active):
        string(active[a], ring, ipar, fpar, fst, U, n, o0, mix, probe, scratch, ubx, o0, ONE)


@njit(**PAR_OPTS)
def render_sharded(bank_addr, addrs, ring, ipar, fpar, fst, U, active, n_active, n, o0, mix,
                   probe, scratch2, iwork2, ubx, sub3, smix, plan, pb, tw, ib, nt):
    """:func:`render_bank` of the ``n_active`` strings in ``active`` on
    ``nt`` threads, the same samples for any ``nt``.

    The units (a single string, or a coupled group from its leader) are
    split in two kinds.  A coupled group of more than :data:`BLOCK`
    members renders alone, its blocks on ``nt`` threads, into ``mix``
    (such groups one after the other, in the active list's order).  The
    other units go, in the active list's order, to the shard (of
    min(:data:`MAX_SHARDS`, their number)) with the least
    :func:`unit_cost` so far (the first such); the shards render on
    min(``nt``, shards) threads, shard 0 into ``mix`` and shard j into
    ``smix[j - 1]``, which are then added to ``mix`` in shard order.

    bank_addr : int           :func:`bank_address` (render_bank, called by its
                              address: see above)
    addrs : int64[:]          as :func:`render_bank`'s
    scratch2, iwork2, sub3 : one row (a :func:`render_bank` ``scratch``,
        ``iwork``, ``sub``) per thread, min(nt, MAX_SHARDS) at least
    smix : float64[MAX_SHARDS - 1, rows of mix, samples of mix]
    plan : int64[:]          :func:`plan_length` samples (work space)
    pb, tw, ib : as :func:`render_bank` (``tw``: nt rows at least)
    """
    bank = _bank_at(bank_addr)
    cap = ipar.shape[0]
    units = plan[0:cap]
    lists = plan[cap:2 * cap]
    ush = plan[2 * cap:3 * cap]
    so = plan[3 * cap:3 * cap + MAX_SHARDS + 1]
    cur = plan[3 * cap + MAX_SHARDS + 1:3 * cap + 2 * MAX_SHARDS + 2]
    load = plan[3 * cap + 2 * MAX_SHARDS + 2:3 * cap + 3 * MAX_SHARDS + 2]
    nu = 0
    nbig = 0
    for a in range(n_active):
        s = active[a]
        cpl = ipar[s, I_CPL]
        if cpl >= 0 and cpl != s:
            continue                  # rendered with its group's leader
        if cpl >= 0 and ipar[s, I_CPLN] > BLOCK:
            nbig += 1
            ush[nu] = -1
        else:
            ush[nu] = 0
        units[nu] = s
        nu += 1
    nsmall = nu - nbig
    if nsmall <= 1 and (nbig == 0 or nsmall == 0):
        # one unit (or none): as one shard
        bank(ring, ipar, fpar, fst, U, active, n_active, n, o0, mix, probe, scratch2[0],
             iwork2[0], ubx, sub3[0], pb, tw, ib, nt, addrs)
        return
    # the big groups, one after the other, their blocks on nt threads
    if nbig > 0:
        k = ZERO               # (not 0: see ZERO)
        for u in range(nu):
            if ush[u] < 0:
                lists[k] = units[u]
                k += 1
        bank(ring, ipar, fpar, fst, U, lists, k, n, o0, mix, probe, scratch2[0],
             iwork2[0], ubx, sub3[0], pb, tw, ib, nt, addrs)
    if nsmall == 0:
        return
    S = nsmall if nsmall < MAX_SHARDS else MAX_SHARDS
    for j in range(S):
        load[j] = 0
        so[j] = 0
    so[S] = 0
    for u in range(nu):
        if ush[u] < 0:
            continue
        best = 0
        for j in range(1, S):
            if load[j] < load[best]:
                best = j
        ush[u] = best
        load[best] += unit_cost(ipar, fpar, units[u])
        so[best + 1] += 1
    for j in range(S):
        so[j + 1] += so[j]
        cur[j] = so[j]
    for u in range(nu):
        j = ush[u]
        if j >= 0:
            lists[cur[j]] = units[u]
            cur[j] += 1
    T = nt if nt < S else S
    work = 0
    for j in range(S):
        work += load[j]
    if work * n < PAR_MIN_WORK:
        T = 1
    if T > 1:
        # (the shards' loop is here, not in a function of its own: that was
        # one more level that linked and optimised the whole tree below
        # render_bank; a cold synth demo compiled 164.7 CPU s instead of
        # 170.7, the two trees at once: tools/bench.py compile)
        for t in prange(T):
            _shard_task(bank_addr, addrs, np.int64(t), T, S, lists, so, ring, ipar, fpar, fst,
                        U, n, o0, mix, probe, scratch2, iwork2, ubx, sub3, smix, pb, tw, ib)
    else:
        _shard_task(bank_addr, addrs, ZERO, ONE, S, lists, so, ring, ipar, fpar, fst, U, n, o0,
                    mix, probe, scratch2, iwork2, ubx, sub3, smix, pb, tw, ib)
    rows = mix.shape[0]
    for j in range(1, S):
        sm = smix[j - 1]
        for r in range(rows):
            mo = mix[r, o0:o0 + n]
            sr = sm[r, o0:o0 + n]
            for i in range(n):
                mo[i] += sr[i]
