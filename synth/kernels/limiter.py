"""Look-ahead peak limiter on the output (numba kernel; no validation).

:func:`limiter_process` holds the output's sample peak at or below a
ceiling without clipping: a gain g[n] <= 1, common to all channels, that
reaches the gain a peak needs by the time the peak leaves the delay line
and then returns to 1 with a release time.  With ``N`` the look-ahead in
samples (the latency is ``N - 1``):

    t[n]  = min(1, ceiling / max_c |x_c[n]|)          target gain of sample n
    h[n]  = min(t[n - N + 1 .. n])                     the window's need (sliding minimum)
    r[n]  = h[n]                       if h[n] < r[n-1]  (attack: at once)
          = h[n] + a (r[n-1] - h[n])   otherwise         (release, a = exp(-1 / (T_rel fs));
                                                            1 once above 1 - 1e-9)
    g[n]  = mean(r[n - N + 1 .. n])                    box average: a smooth N-sample ramp
    y_c[n] = g[n] x_c[n - N + 1]

r[n] <= h[n] always, and for a peak at sample p every h in n = p .. p+N-1
is <= t[p]; the box average at n = p + N - 1, when x[p] is output, is
therefore <= t[p]: |y| <= ceiling at every sample, with the gain ramped
down over N samples before the peak (no step, no overshoot).  Below the
ceiling g returns to exactly 1 (r is clamped there) and the output is the
input delayed by N - 1 samples, bit for bit.

State (persistent between calls; blocks of any length give the one-shot
result):

* ``delay`` (C, N): the input ring; ``box`` (N,): the ring of r values;
* ``dq_val`` (Q,), ``dq_idx`` (Q,) int64, Q a power of two >= N + 1: the
  monotonic deque of the sliding minimum (values increasing from head to
  tail, their sample indices);
* ``fstate`` [r, box sum]; ``istate`` [pos, head, tail, t] (ring position,
  deque head and tail counters, sample counter).

The box sum is re-added from the ring every N samples, so its rounding
error never accumulates.  The public wrapper is
:class:`synth.dsp.limiter.Limiter`; the naive reference is in
``tests/test_limiter.py``.
"""

from numba import njit

from synth.kernels.config import JIT_OPTS

#: A releasing gain above this is set to 1 (1 + a (r - 1) rounds back to r
#: once 1 - r is an ulp, so the release would never end exactly; 1e-9 is
#: -9e-9 dB)
SNAP = 1.0 - 1e-9


@njit(**JIT_OPTS)
def limiter_process(x, n, ceiling, release_coef, delay, box, dq_val, dq_idx, fstate, istate,
                    out):
    """Limit ``n`` samples of ``x`` (C, >= n) into ``out`` (C, >= n) (may be ``x``).

    Parameters
    ----------
    x : float64[:, :]
        Input, C channels; the first ``n`` samples of each are used.
    n : int
        Samples to process.
    ceiling : float
        Largest allowed |output|, linear (> 0).
    release_coef : float
        ``exp(-1 / (T_rel fs))``, 0 <= value < 1.
    delay, box, dq_val, dq_idx, fstate, istate : arrays
        The state, see the module docstring; updated in place.
    out : float64[:, :]
        Output, C channels.
    """
    C = x.shape[0]
    N = box.shape[0]
    mask = dq_val.shape[0] - 1
    r = fstate[0]
    s = fstate[1]
    pos = istate[0]
    head = istate[1]
    tail = istate[2]
    t = istate[3]
    inv_n = 1.0 / N
    for i in range(n):
        a = 0.0
        for c in range(C):
            v = abs(x[c, i])
            if v > a:
                a = v
        g_t = 1.0
        if a > ceiling:
            g_t = ceiling / a
        # sliding minimum: drop the values the new one hides, then the expired head
        while tail > head and dq_val[(tail - 1) & mask] >= g_t:
            tail -= 1
        dq_val[tail & mask] = g_t
        dq_idx[tail & mask] = t
        tail += 1
        if dq_idx[head & mask] <= t - N:
            head += 1
        h = dq_val[head & mask]
        if h < r:
            r = h
        else:
            r = h + release_coef * (r - h)
            if r > SNAP:  # 1 - r would stick at an ulp: back to exact unity
                r = 1.0
        s += r - box[pos]
        box[pos] = r
        g = s * inv_n
        if s >= N:  # all ones (exact sums): unity, whatever 1 / N rounds to
            g = 1.0
        nxt = pos + 1
        if nxt == N:
            nxt = 0
        for c in range(C):
            xc = x[c, i]
            delay[c, pos] = xc
            out[c, i] = g * delay[c, nxt]
        pos = nxt
        t += 1
        if pos == 0:
            s = 0.0
            for k in range(N):
                s += box[k]
    fstate[0] = r
    fstate[1] = s
    istate[0] = pos
    istate[1] = head
    istate[2] = tail
    istate[3] = t
