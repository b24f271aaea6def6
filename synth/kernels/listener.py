"""The listening position's stage (numba kernel; no validation).

:func:`listener_process` turns the body's output (C channels, 1 or 2) into
what a listener hears at a position in a room: per channel c and sample n,

    d_c[n]  = sum_k hd[k] x_c[n - k]                          direct: FIR (distance,
                                                              directivity, air)
    e_c[n]  = sum_j ge[c, j] x_c[n - le[c, j]]                early reflections: taps
    E_c[n]  = sum_k he[k] e_c[n - k]                          through one shared FIR
    u[n]    = (1 / C) sum_c x_c[n - pre]                      the network's input
    s_i[n]  = v_i[n - m_i]                                    line i's output (N lines)
    z_i[n]  = a_i s_i[n] + b_i z_i[n - 1]                     its absorption (one pole)
    v[n]    = (1 / sqrt N) W z[n] + fin u[n]                  W: Sylvester-Hadamard
    out_c[n] = d_c[n] + E_c[n] + sum_i fout[c, i] z_i[n]

(a feedback delay network, Jot and Chaigne 1991; the design is
:mod:`synth.physics.listener`).  The input history is mirrored (each sample
written at ``pos`` and ``pos + H``), so each FIR reads one contiguous
window and every read has a fixed length: the operations, and so the
samples, do not depend on where blocks begin.  A line value under ``TINY``
(1e-30, -600 dB) is written as 0, so the network's state ends in exact
zeros after the sound and never in subnormal arithmetic.

State (persistent between calls; blocks of any length give the one-shot
result): ``hist`` (C, 2H) the input history, ``ehist`` (C, 2E) the early
taps' sum's history (E = len(he)), ``lines`` (sum m_i) the delay lines one
after another from ``off``, ``lpos`` (N,) int64 their positions, ``z``
(N,) the filters' states, ``w`` (N,) scratch, ``istate`` [pos, epos].
The public wrapper is :class:`synth.dsp.listener.Listener`; the slow
reference is in ``tests/test_listener.py``.
"""

from numba import njit

from synth.kernels.config import JIT_OPTS

#: a delay line's value smaller than this in magnitude is written as 0
TINY = 1e-30


@njit(**JIT_OPTS)
def listener_process(x, n, hd, le, ge, he, pre, lens, off, fa, fb, fin, fout, hist, ehist, lines,
                     lpos, z, w, istate, out):
    """Process ``n`` samples of ``x`` (C, >= n) into ``out`` (C, >= n) (may be ``x``).

    Parameters
    ----------
    x : float64[:, :]
        Input, C channels (the body's outputs).
    n : int
        Samples to process.
    hd, he : float64[:]
        The direct and the early reflections' FIRs (same length L <= E).
    le : int64[:, :], ge : float64[:, :]
        (C, K): the early taps' lags (1 .. H - 1 samples) and gains.
    pre : int
        The network's input delay (0 .. H - 1 samples).
    lens, off : int64[:]
        (N,): the lines' lengths (samples, >= 1) and their offsets in ``lines``.
    fa, fb : float64[:]
        (N,): the absorption filters a_i / (1 - b_i z^-1).
    fin : float64[:]
        (N,): the input vector.
    fout : float64[:, :]
        (C, N): the output vectors (the late level folded in).
    hist, ehist, lines, lpos, z, w, istate : arrays
        The state, see the module docstring; updated in place.
    out : float64[:, :]
        Output, C channels.
    """
    C = x.shape[0]
    H = hist.shape[1] // 2
    E = ehist.shape[1] // 2
    L = hd.shape[0]
    K = le.shape[1]
    N = lens.shape[0]
    pos = istate[0]
    epos = istate[1]
    scale = 1.0
    if N > 0:
        scale = 1.0 / N ** 0.5
    inv_c = 1.0 / C
    for i in range(n):
        for c in range(C):
            v = x[c, i]
            hist[c, pos] = v
            hist[c, pos + H] = v
        u = 0.0
        for c in range(C):
            u += hist[c, pos + H - pre]
        u *= inv_c
        # the network: outputs, absorption, feedback through the Hadamard matrix
        for j in range(N):
            s = lines[off[j] + lpos[j]]
            zj = fa[j] * s + fb[j] * z[j]
            z[j] = zj
            w[j] = zj
        h = 1
        while h < N:
            for a0 in range(0, N, 2 * h):
                for b in range(a0, a0 + h):
                    p = w[b]
                    q = w[b + h]
                    w[b] = p + q
                    w[b + h] = p - q
            h *= 2
        for j in range(N):
            v = scale * w[j] + fin[j] * u
            if abs(v) < TINY:
                v = 0.0
            lines[off[j] + lpos[j]] = v
            nxt = lpos[j] + 1
            if nxt == lens[j]:
                nxt = 0
            lpos[j] = nxt
        for c in range(C):
            base = pos + H
            d = 0.0
            for k in range(L):
                d += hd[k] * hist[c, base - k]
            e = 0.0
            for k in range(K):
                e += ge[c, k] * hist[c, base - le[c, k]]
            ehist[c, epos] = e
            ehist[c, epos + E] = e
            eb = epos + E
            ef = 0.0
            for k in range(L):
                ef += he[k] * ehist[c, eb - k]
            r = 0.0
            for j in range(N):
                r += fout[c, j] * z[j]
            out[c, i] = d + ef + r
        pos += 1
        if pos == H:
            pos = 0
        epos += 1
        if epos == E:
            epos = 0
    istate[0] = pos
    istate[1] = epos
