"""The action's knocks mixed block by block (numba kernel; no validation).

A note-on's knock is one pulse shape ``unit`` (the force of the key's and
hammer's impacts reaching the board, :func:`synth.physics.soundboard.knock_pulse`)
times a gain per output channel, starting at an output sample.  The knocks
still sounding are a list of (start, end, gains), in the order of their
note-ons; :func:`knock_mix` adds the next block of all of them to the buses:

    acc_c[i] = sum over k, in order, of unit[t0 + i - start_k] gains[k, c]
               (for start_k <= t0 + i < end_k),        i = 0 .. n_out - 1
    out_c[i] += acc_c[i]

The sum starts at +0.0 and adds the products in the list's order, each
product rounded first (IEEE, no contraction): the samples a buffer gave
that every note-on added its whole scaled pulse to, and that each block
then read and shifted, bit for bit -- without a note-on writing 2 x 7777
samples (22 us on a 2-vCPU Xeon) or every block moving the buffer's
tail (60 us).

The public wrapper is :class:`synth.dsp.knock.Knocks`; the reference in
``tests/test_knock.py`` is that buffer.
"""

from numba import njit

from synth.kernels.config import EXACT_OPTS


@njit(**EXACT_OPTS)
def knock_mix(unit, starts, ends, gains, n, t0, n_out, acc, out):
    """Add output samples t0 .. t0 + n_out - 1 of the first ``n`` knocks
    to ``out`` and drop those that end within them.

    Parameters
    ----------
    unit : float64[L]           the pulse shape
    starts, ends : int64[>= n]  each knock's first output sample and the
        sample after its last (at most start + L)
    gains : float64[>= n, C]    each knock's gain per channel
    n : int                     knocks in the list
    t0 : int                    the block's first output sample
    n_out : int                 the block's samples (<= acc's and out's columns)
    acc : float64[C, >= n_out]  work space
    out : float64[C, >= n_out]  the buses, added to

    Returns
    -------
    int
        The knocks left (the list compacted in place, its order kept): those
        with a sample after t0 + n_out - 1.
    """
    C = out.shape[0]
    for c in range(C):
        for i in range(n_out):
            acc[c, i] = 0.0
    for k in range(n):
        a = t0 - starts[k]                 # the unit's sample at the block's first
        lo = -a if a < 0 else 0
        hi = ends[k] - t0
        if hi > n_out:
            hi = n_out
        for c in range(C):
            g = gains[k, c]
            for i in range(lo, hi):
                acc[c, i] += unit[a + i] * g
    for c in range(C):
        for i in range(n_out):
            out[c, i] += acc[c, i]
    t1 = t0 + n_out
    m = 0
    for k in range(n):
        if ends[k] > t1 and ends[k] > starts[k]:     # (a cut may leave one nothing)
            starts[m] = starts[k]
            ends[m] = ends[k]
            for c in range(gains.shape[1]):
                gains[m, c] = gains[k, c]
            m += 1
    return m
