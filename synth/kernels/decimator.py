"""Streaming polyphase rational decimator kernel (numba).

Computes, one input block at a time, the output of "zero-stuff by L, filter
with the prototype h, keep every M-th sample":

    y[n] = sum_k h[k] u[n M - k],   u[j] = x[j / L] if L divides j else 0.

Writing ``n M = q L + p`` (``0 <= p < L``), only the taps ``h[p + j L]`` meet
non-zero samples, so ``y[n] = sum_j E[p, j] x[q - j]`` with the polyphase
matrix ``E[p, j] = h[p + j L]``. The kernel takes that matrix with each row
reversed, ``phases[p, i] = E[p, T - 1 - i]`` (``T`` taps per phase), so the
inner loop is a forward dot product with the last ``T`` inputs.

History: a doubled ring of length ``2 T``; every input is written at ``w`` and
``w + T``, so the last ``T`` inputs, oldest first, are always the contiguous
slice ``hist[w + 1 : w + 1 + T]`` (``w`` = ring slot of the newest input). No
modulo in the tap loop, no allocation.

State (``int64[3]``):
    state[0] = p, the phase of the next output (0 .. L-1);
    state[1] = d, how many more inputs the next output needs (>= 1 between
               calls, because M > L);
    state[2] = w, ring slot of the newest input (0 .. T-1).

The public wrapper with validation is ``synth.engine.decimator.Decimator``.
"""

from numba import njit

from synth.kernels.config import JIT_OPTS, LANES
from synth.kernels.lanes import lane, load4, splat4


@njit(inline="always", **JIT_OPTS)
def _dot16(row, win, T):
    """sum_j row[j] win[j], j < T, as sixteen partial sums (four
    ``<4 x double>``, eight xmm registers in an SSE2 build) over blocks of
    sixteen taps, then the T % 16 last taps.  The SSE2 build's dot product
    (:data:`synth.kernels.config.LANES` 2): LLVM's own vectorisation of the
    loop there keeps two xmm partial sums, so the loop waits on the adds'
    latency (3 cycles a block of 4 taps); sixteen keep it on its loads.  The
    partial sums' order differs from the other builds' (their last bits)."""
    a0 = splat4(0.0)
    a1 = splat4(0.0)
    a2 = splat4(0.0)
    a3 = splat4(0.0)
    T16 = T - T % 16
    for j in range(0, T16, 16):
        a0 = a0 + load4(row, j) * load4(win, j)
        a1 = a1 + load4(row, j + 4) * load4(win, j + 4)
        a2 = a2 + load4(row, j + 8) * load4(win, j + 8)
        a3 = a3 + load4(row, j + 12) * load4(win, j + 12)
    a = (a0 + a1) + (a2 + a3)
    acc = (lane(a, 0) + lane(a, 1)) + (lane(a, 2) + lane(a, 3))
    for j in range(T16, T):
        acc += row[j] * win[j]
    return acc


@njit(**JIT_OPTS)
def decimate(x, n_in, phases, L, M, hist, state, out):
    """Push ``n_in`` input samples through the decimator; return outputs made.

    Parameters
    ----------
    x : float64[:]
        Input block at the internal rate; the first ``n_in`` samples are used.
    n_in : int
        Number of samples to consume from ``x`` (0 .. len(x)).
    phases : float64[:, ::1]
        Polyphase matrix, shape (L, T), rows reversed (see module docstring),
        already scaled by L (unit passband gain).
    L, M : int
        Interpolation and decimation factors (coprime, M > L).
    hist : float64[:]
        Doubled history ring, length 2 T; updated in place.
    state : int64[:]
        ``[p, d, w]`` (see module docstring); updated in place.
    out : float64[:]
        Receives the outputs; must hold every output this block produces
        (the wrapper sizes it exactly).

    Returns
    -------
    int
        Number of outputs written to ``out[0 : n_out]``.
    """
    T = phases.shape[1]
    p = state[0]
    d = state[1]
    w = state[2]
    n_out = 0
    i = 0
    while i < n_in:
        # Copy inputs up to the one that completes the next output (or the
        # end of the block) into the doubled ring.
        n_copy = d
        if n_copy > n_in - i:
            n_copy = n_in - i
        for k in range(n_copy):
            w += 1
            if w == T:
                w = 0
            v = x[i + k]
            hist[w] = v
            hist[w + T] = v
        i += n_copy
        d -= n_copy
        if d == 0:
            # Slices (views, no allocation) let LLVM see non-negative indices
            # and vectorise the dot product; indexing hist[w + 1 + j] directly
            # keeps numba's negative-index wraparound and runs ~2x slower.
            row = phases[p]
            win = hist[w + 1:w + 1 + T]
            if LANES == 2:
                acc = _dot16(row, win, T)
            else:
                acc = 0.0
                for j in range(T):
                    acc += row[j] * win[j]
            out[n_out] = acc
            n_out += 1
            p += M
            d = p // L
            p -= d * L
    state[0] = p
    state[1] = d
    state[2] = w
    return n_out
