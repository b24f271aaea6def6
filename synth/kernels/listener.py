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
samples, do not depend on where blocks begin.  The kernel takes a block in
segments in which neither history wraps, of at most S = ``SEGMENT``
samples and the shortest line's length: it writes a segment's input, then
runs each sum as a vector loop over the segment, one term at a time in the
equation's order (each sample's sum has the same terms in the same order as
a sample-by-sample loop); the network reads the segment's line outputs,
filters them (the lines side by side, sample by sample), and writes the
new values back (no line is read after its write within a segment).  The
histories hold S samples more than the longest lag, so no write of the
segment overtakes a read.  A line value under ``TINY``
(1e-30, -600 dB) is written as 0, so the network's state ends in exact
zeros after the sound and never in subnormal arithmetic.

State (persistent between calls; blocks of any length give the one-shot
result): ``hist`` (C, 2H) the input history, ``ehist`` (C, 2E) the early
taps' sum's history (E = len(he) + S), ``lines`` (sum m_i) the delay lines one
after another from ``off``, ``lpos`` (N,) int64 their positions, ``z``
(N,) the filters' states, ``istate`` [pos, epos].
The public wrapper is :class:`synth.dsp.listener.Listener`; the slow
reference is in ``tests/test_listener.py``.
"""

from numba import njit

from synth.kernels.config import JIT_OPTS

#: a delay line's value smaller than this in magnitude is written as 0
TINY = 1e-30

#: the samples of a segment (the scratch's length the wrapper gives): the
#: histories hold this many samples more than the longest lag
SEGMENT = 256


@njit(**JIT_OPTS)
def listener_process(x, n, hd, le, ge, he, pre, lens, off, fa, fb, fin, fout, hist, ehist, lines,
                     lpos, z, istate, sc, out):
    """Process ``n`` samples of ``x`` (C, >= n) into ``out`` (C, >= n) (may be ``x``).

    Parameters
    ----------
    x : float64[:, :]
        Input, C channels (the body's outputs).
    n : int
        Samples to process.
    hd, he : float64[:]
        The direct and the early reflections' FIRs (same length L).
    le : int64[:, :], ge : float64[:, :]
        (C, K): the early taps' lags (1 .. H - S samples) and gains.
    pre : int
        The network's input delay (0 .. H - S samples).
    lens, off : int64[:]
        (N,): the lines' lengths (samples, >= 1) and their offsets in ``lines``.
    fa, fb : float64[:]
        (N,): the absorption filters a_i / (1 - b_i z^-1).
    fin : float64[:]
        (N,): the input vector.
    fout : float64[:, :]
        (C, N): the output vectors (the late level folded in).
    hist, ehist, lines, lpos, z, istate : arrays
        The state, see the module docstring; updated in place.  ``hist``
        holds H >= max(lags, pre, L) + S samples a channel, ``ehist`` E >=
        L + S (S = ``sc``'s length): a segment's samples are written before
        its sums read them.
    sc : float64[:, :]
        (N + 2, S) scratch, S >= 1.
    out : float64[:, :]
        Output, C channels.
    """
    C = x.shape[0]
    H = hist.shape[1] // 2
    E = ehist.shape[1] // 2
    L = hd.shape[0]
    K = le.shape[1]
    N = lens.shape[0]
    S = sc.shape[1]
    pos = istate[0]
    epos = istate[1]
    scale = 1.0
    if N > 0:
        scale = 1.0 / N ** 0.5
    inv_c = 1.0 / C
    lmin = S
    for j in range(N):
        if lens[j] < lmin:
            lmin = lens[j]
    i0 = 0
    while i0 < n:
        # a segment in which neither history wraps: its sums read windows
        # that slide one sample a sample, as vector loops over the segment
        m = n - i0
        if m > S:
            m = S
        if m > H - pos:
            m = H - pos
        if m > E - epos:
            m = E - epos
        if m > lmin:
            m = lmin
        for c in range(C):
            xc = x[c, i0:i0 + m]
            lo = hist[c, pos:pos + m]
            hi = hist[c, pos + H:pos + H + m]
            for i in range(m):
                v = xc[i]
                lo[i] = v
                hi[i] = v
        for c in range(C):
            base = pos + H
            # direct: d[i] = sum_k hd[k] x[i - k], each sample's terms in k's order
            o = out[c, i0:i0 + m]
            for i in range(m):
                o[i] = 0.0
            for k in range(L):
                h = hd[k]
                xs = hist[c, base - k:base - k + m]
                for i in range(m):
                    o[i] += h * xs[i]
            # early taps into their history (both halves)
            eb = epos + E
            eo = ehist[c, eb:eb + m]
            for i in range(m):
                eo[i] = 0.0
            for j in range(K):
                g = ge[c, j]
                xs = hist[c, base - le[c, j]:base - le[c, j] + m]
                for i in range(m):
                    eo[i] += g * xs[i]
            el = ehist[c, epos:epos + m]
            for i in range(m):
                el[i] = eo[i]
            # ... through the early FIR
            ef = sc[0, :m]
            for i in range(m):
                ef[i] = 0.0
            for k in range(L):
                h = he[k]
                es = ehist[c, eb - k:eb - k + m]
                for i in range(m):
                    ef[i] += h * es[i]
            for i in range(m):
                o[i] = o[i] + ef[i]
        if N > 0:
            # the network over the segment: no line is read after its write
            # within it (m <= the shortest line), so each line's outputs are
            # read first, then its new values written in one pass
            u = sc[1, :m]
            for i in range(m):
                u[i] = 0.0
            for c in range(C):
                hs = hist[c, pos + H - pre:pos + H - pre + m]
                for i in range(m):
                    u[i] += hs[i]
            for i in range(m):
                u[i] *= inv_c
            # its outputs through the absorption filters (the lines side by side)
            for i in range(m):
                for j in range(N):
                    q = lpos[j] + i
                    if q >= lens[j]:
                        q -= lens[j]
                    zj = fa[j] * lines[off[j] + q] + fb[j] * z[j]
                    z[j] = zj
                    sc[2 + j, i] = zj
            # out_c += fout[c] . z, each sample's terms in the lines' order
            r = sc[0, :m]
            for c in range(C):
                for i in range(m):
                    r[i] = 0.0
                for j in range(N):
                    g = fout[c, j]
                    zr = sc[2 + j, :m]
                    for i in range(m):
                        r[i] += g * zr[i]
                o = out[c, i0:i0 + m]
                for i in range(m):
                    o[i] = o[i] + r[i]
            # feedback through the Hadamard matrix, the input added
            h2 = 1
            while h2 < N:
                for a0 in range(0, N, 2 * h2):
                    for b in range(a0, a0 + h2):
                        P = sc[2 + b, :m]
                        Q = sc[2 + b + h2, :m]
                        for i in range(m):
                            p = P[i]
                            q = Q[i]
                            P[i] = p + q
                            Q[i] = p - q
                h2 *= 2
            for j in range(N):
                wr = sc[2 + j, :m]
                f = fin[j]
                for i in range(m):
                    v = scale * wr[i] + f * u[i]
                    if abs(v) < TINY:
                        v = 0.0
                    wr[i] = v
                Lj = lens[j]
                p0 = lpos[j]
                first = Lj - p0
                if first > m:
                    first = m
                dst = lines[off[j] + p0:off[j] + p0 + first]
                for i in range(first):
                    dst[i] = wr[i]
                if first < m:
                    dst = lines[off[j]:off[j] + m - first]
                    for i in range(m - first):
                        dst[i] = wr[first + i]
                p0 += m
                if p0 >= Lj:
                    p0 -= Lj
                lpos[j] = p0
        i0 += m
        pos += m
        if pos == H:
            pos = 0
        epos += m
        if epos == E:
            epos = 0
    istate[0] = pos
    istate[1] = epos
