"""Soundboard modal bank kernels (numba).

:func:`body_process` (one input, one output) runs K two-pole resonators
with the common numerator (1 - z^-2) on one block of a mono signal and
mixes the sum with the dry input:

    v[n]   = x[n] - x[n-2]                               (shared zeros at DC, Nyquist)
    u_k[n] = v[n] - a1_k u_k[n-1] - a2_k u_k[n-2]        (one all-pole section per mode)
    out[n] = dry x[n] + wet sum_k b0_k u_k[n]

i.e. ``out = dry x + wet sum_k H_k x`` with
``H_k(z) = b0_k (1 - z^-2) / (1 + a1_k z^-1 + a2_k z^-2)``.

Loop order (measured, K = 96, 48 kHz, 256-sample blocks, one core): samples
outer / modes inner with the coefficients laid out (3, K) so each row is
contiguous and the mode loop vectorises; four samples per pass over the
modes (each pass loads a mode's coefficients and state once and runs the
four-step recursion in registers), ~16 ns per sample (~13 ns without the
denormal flush below). One sample per pass: ~26 ns; eight per pass: ~16 ns
(no gain); (K, 3) / (K, 2) layouts (strided, not vectorised): ~100 ns;
modes outer / samples inner (a serial recursion per mode): ~270 ns.

State (float64, shape (2, K + 1)):
    state[0, k] = u_k[n-2],  state[1, k] = u_k[n-1]   for k < K,
    state[0, K] = x[n-2],    state[1, K] = x[n-1]     (input history),
where n is the first sample of the next block. Zeros = silence.

Denormals: the recursions decay geometrically; when both states of a mode
are below ``TINY`` together (|u[n-1]| + |u[n]| <= 1e-30, -600 dB) the pair
is set to 0, so a silent input ends in exact zeros and never drives the bank
into subnormal arithmetic (~100x slower on x86). The pair is flushed
together: zeroing one state alone would leave the other as a kick that
re-excites a low mode (by ~1 / sin(theta)) and never lets it reach zero.

:func:`body_process_mimo` does the same from two inputs to two outputs
(one input or one output by reading or writing row 0 twice, see its
docstring):
each mode is driven by a mix of the inputs and heard at each output with
its own gain,

    v_b[n]  = x_b[n] - x_b[n-2]
    u_k[n]  = d_0k v_0[n] + d_1k v_1[n] - a1_k u_k[n-1] - a2_k u_k[n-2]
    out_c[n] = sum_b dry_cb x_b[n] + wet sum_k g_ck u_k[n],

the same four-samples-per-pass loop with four more multiply-adds per mode
and sample (~1.5x the mono cost). Its state is (2, K + 2): columns K and
K + 1 hold the histories of inputs 0 and 1.

The public wrapper with validation is :class:`synth.dsp.body.Body`.
"""

from numba import njit

from synth.kernels.config import JIT_OPTS

#: States smaller than this in magnitude are flushed to zero.
TINY = 1e-30


@njit(**JIT_OPTS)
def body_process(x, n, coefs, state, dry, wet, out):
    """Filter ``n`` samples of ``x`` through the modal bank; write ``out[:n]``.

    Parameters
    ----------
    x : float64[:]
        Input block (dimensionless audio); the first ``n`` samples are used.
    n : int
        Number of samples to process, 0 .. len(x) (and <= len(out)).
    coefs : float64[:, ::1]
        Shape (3, K): rows ``b0``, ``a1``, ``a2`` of the K resonators
        (from :func:`synth.physics.soundboard.resonator_coefs`).
    state : float64[:, ::1]
        Shape (2, K + 1), see the module docstring; updated in place.
    dry : float
        Gain of the direct path (dimensionless).
    wet : float
        Gain of the summed resonators (dimensionless).
    out : float64[:]
        Receives ``out[:n]``; may be the same array as ``x`` (in place).
    """
    K = coefs.shape[1]
    b0 = coefs[0]
    a1 = coefs[1]
    a2 = coefs[2]
    s2 = state[0]  # u[n-2]
    s1 = state[1]  # u[n-1]
    xm2 = state[0, K]
    xm1 = state[1, K]
    i = 0
    while i + 3 < n:
        w0 = x[i]
        w1 = x[i + 1]
        w2 = x[i + 2]
        w3 = x[i + 3]
        e0 = w0 - xm2
        e1 = w1 - xm1
        e2 = w2 - w0
        e3 = w3 - w1
        xm2 = w2
        xm1 = w3
        c0 = 0.0
        c1 = 0.0
        c2 = 0.0
        c3 = 0.0
        for k in range(K):
            p = a1[k]
            q = a2[k]
            g = b0[k]
            um2 = s2[k]
            um1 = s1[k]
            u0 = e0 - p * um1 - q * um2
            u1 = e1 - p * u0 - q * um1
            u2 = e2 - p * u1 - q * u0
            u3 = e3 - p * u2 - q * u1
            c0 += g * u0
            c1 += g * u1
            c2 += g * u2
            c3 += g * u3
            keep = abs(u2) + abs(u3) > TINY
            s2[k] = u2 if keep else 0.0
            s1[k] = u3 if keep else 0.0
        out[i] = dry * w0 + wet * c0
        out[i + 1] = dry * w1 + wet * c1
        out[i + 2] = dry * w2 + wet * c2
        out[i + 3] = dry * w3 + wet * c3
        i += 4
    while i < n:
        w0 = x[i]
        e0 = w0 - xm2
        xm2 = xm1
        xm1 = w0
        c0 = 0.0
        for k in range(K):
            u0 = e0 - a1[k] * s1[k] - a2[k] * s2[k]
            c0 += b0[k] * u0
            um1 = s1[k]
            keep = abs(um1) + abs(u0) > TINY
            s2[k] = um1 if keep else 0.0
            s1[k] = u0 if keep else 0.0
        out[i] = dry * w0 + wet * c0
        i += 1
    state[0, K] = xm2
    state[1, K] = xm1


@njit(**JIT_OPTS)
def body_process_mimo(x, n, drive, gains, coefs, state, dry, wet, out):
    """Filter ``n`` samples of two inputs through the modal bank into two outputs.

    Parameters
    ----------
    x : float64[:, :]
        Shape (B, >= n), B = 1 or 2: the inputs (dimensionless audio). With
        one input the second row of ``drive`` and column of ``dry`` must be
        zero (row 0 is read in its place).
    n : int
        Number of samples to process (<= x.shape[1], <= out.shape[1]).
    drive : float64[:, ::1]
        Shape (2, K): drive gain of each mode at each input.
    gains : float64[:, ::1]
        Shape (2, K): gain of each mode at each output, times the section's
        ``b0`` (the mode's peak gain is ``gains[c, k] / b0_k * drive[b, k]``).
    coefs : float64[:, ::1]
        Shape (3, K): rows ``b0`` (unused here), ``a1``, ``a2``.
    state : float64[:, ::1]
        Shape (2, K + 2), see the module docstring; updated in place.
    dry : float64[:, ::1]
        Shape (2, 2): direct gains, output by input (the mix's dry gain included).
    wet : float
        Gain of the summed resonators.
    out : float64[:, :]
        Shape (C, >= n), C = 1 or 2: receives ``out[:, :n]``; may share memory
        with ``x`` (every input sample of a pass is read before any output is
        written). With one output the two rows of ``gains`` and of ``dry``
        must be equal: row 0 is then written twice with the same values.
    """
    K = coefs.shape[1]
    a1 = coefs[1]
    a2 = coefs[2]
    d0 = drive[0]
    d1 = drive[1]
    g0 = gains[0]
    g1 = gains[1]
    s2 = state[0]  # u[n-2]
    s1 = state[1]  # u[n-1]
    pm2 = state[0, K]
    pm1 = state[1, K]
    qm2 = state[0, K + 1]
    qm1 = state[1, K + 1]
    h00 = dry[0, 0]
    h01 = dry[0, 1]
    h10 = dry[1, 0]
    h11 = dry[1, 1]
    xb = x.shape[0] - 1  # row of input 1 (0 with one input: its drive is zero)
    oc = out.shape[0] - 1  # row of output 1 (0 with one output: the same values)
    i = 0
    while i + 3 < n:
        p0 = x[0, i]
        p1 = x[0, i + 1]
        p2 = x[0, i + 2]
        p3 = x[0, i + 3]
        q0 = x[xb, i]
        q1 = x[xb, i + 1]
        q2 = x[xb, i + 2]
        q3 = x[xb, i + 3]
        e0 = p0 - pm2
        e1 = p1 - pm1
        e2 = p2 - p0
        e3 = p3 - p1
        f0 = q0 - qm2
        f1 = q1 - qm1
        f2 = q2 - q0
        f3 = q3 - q1
        pm2 = p2
        pm1 = p3
        qm2 = q2
        qm1 = q3
        l0 = 0.0
        l1 = 0.0
        l2 = 0.0
        l3 = 0.0
        r0 = 0.0
        r1 = 0.0
        r2 = 0.0
        r3 = 0.0
        for k in range(K):
            p = a1[k]
            q = a2[k]
            da = d0[k]
            db = d1[k]
            ga = g0[k]
            gb = g1[k]
            um2 = s2[k]
            um1 = s1[k]
            u0 = da * e0 + db * f0 - p * um1 - q * um2
            u1 = da * e1 + db * f1 - p * u0 - q * um1
            u2 = da * e2 + db * f2 - p * u1 - q * u0
            u3 = da * e3 + db * f3 - p * u2 - q * u1
            l0 += ga * u0
            l1 += ga * u1
            l2 += ga * u2
            l3 += ga * u3
            r0 += gb * u0
            r1 += gb * u1
            r2 += gb * u2
            r3 += gb * u3
            keep = abs(u2) + abs(u3) > TINY
            s2[k] = u2 if keep else 0.0
            s1[k] = u3 if keep else 0.0
        out[0, i] = h00 * p0 + h01 * q0 + wet * l0
        out[0, i + 1] = h00 * p1 + h01 * q1 + wet * l1
        out[0, i + 2] = h00 * p2 + h01 * q2 + wet * l2
        out[0, i + 3] = h00 * p3 + h01 * q3 + wet * l3
        out[oc, i] = h10 * p0 + h11 * q0 + wet * r0
        out[oc, i + 1] = h10 * p1 + h11 * q1 + wet * r1
        out[oc, i + 2] = h10 * p2 + h11 * q2 + wet * r2
        out[oc, i + 3] = h10 * p3 + h11 * q3 + wet * r3
        i += 4
    while i < n:
        p0 = x[0, i]
        q0 = x[xb, i]
        e0 = p0 - pm2
        f0 = q0 - qm2
        pm2 = pm1
        pm1 = p0
        qm2 = qm1
        qm1 = q0
        l0 = 0.0
        r0 = 0.0
        for k in range(K):
            u0 = d0[k] * e0 + d1[k] * f0 - a1[k] * s1[k] - a2[k] * s2[k]
            l0 += g0[k] * u0
            r0 += g1[k] * u0
            um1 = s1[k]
            keep = abs(um1) + abs(u0) > TINY
            s2[k] = um1 if keep else 0.0
            s1[k] = u0 if keep else 0.0
        out[0, i] = h00 * p0 + h01 * q0 + wet * l0
        out[oc, i] = h10 * p0 + h11 * q0 + wet * r0
        i += 1
    state[0, K] = pm2
    state[1, K] = pm1
    state[0, K + 1] = qm2
    state[1, K + 1] = qm1
