"""The radiation's spread: a cascade of Schroeder allpasses (numba kernel; no validation).

:func:`allpass_cascade` runs C channels, in place, through S allpasses in
series (the same ones on every channel), each in the one-delay-line form

    w[n] = x[n] + g w[n - D]
    y[n] = w[n - D] - g w[n]          i.e.  Y / X = (-g + z^-D) / (1 - g z^-D),

(Schroeder, JAES 10, 1962; the design is
:func:`synth.physics.soundboard.spread_allpasses`).  Each allpass's line
holds its last D values of w; the loop over a block is split where the
line's position wraps, so the inner loop has no modulo and no branch, and
within one piece every step reads a value written D samples before, so the
piece's steps are independent (the loop vectorises).  A value of w under
``TINY`` (1e-30, -600 dB) is written as 0, so the lines end in exact zeros
after the sound and never in subnormal arithmetic.

State: ``lines`` (C, sum D_s) each channel's lines one after another from
``offsets``; ``pos`` (S,) int64 each line's position (shared by the
channels: they run the same samples).  Blocks of any length give the
one-shot result.  The wrapper is :class:`synth.dsp.spread.Spread`; the slow
reference is in ``tests/test_spread.py``.
"""

from numba import njit

from synth.kernels.config import JIT_OPTS

#: a line value smaller than this in magnitude is written as 0
TINY = 1e-30


@njit(**JIT_OPTS)
def allpass_cascade(y, n, delays, gains, offsets, lines, pos):
    """Filter ``y[:, :n]`` in place through the allpasses.

    Parameters
    ----------
    y : float64[:, :]
        (C, >= n): the channels, each row contiguous; overwritten.
    n : int
        Samples to process.
    delays : int64[:]
        (S,): each allpass's delay D_s, samples (>= 1).
    gains : float64[:]
        (S,): each allpass's gain g_s (|g| < 1).
    offsets : int64[:]
        (S,): where each line starts in a row of ``lines``.
    lines : float64[:, :]
        (C, >= sum D_s): the lines' values of w; updated.
    pos : int64[:]
        (S,): each line's position, 0 .. D_s - 1; updated.
    """
    C = y.shape[0]
    for s in range(delays.shape[0]):
        D = delays[s]
        g = gains[s]
        o = offsets[s]
        p = pos[s]
        for c in range(C):
            row = y[c]
            line = lines[c]
            p = pos[s]
            i = 0
            while i < n:
                m = min(n - i, D - p)
                for j in range(m):
                    wo = line[o + p + j]
                    w = row[i + j] + g * wo
                    row[i + j] = wo - g * w
                    line[o + p + j] = w if abs(w) > TINY else 0.0
                i += m
                p += m
                if p == D:
                    p = 0
        pos[s] = p
