"""Tension modulation: a string's tension read from its own rails (numba).

A string that swings is longer than at rest, so its tension rises (Kirchhoff
and Carrier; Tolonen, Valimaki & Karjalainen, "Modeling of tension
modulation nonlinearity in plucked strings", IEEE Trans. Speech Audio
Process. 8(3), 2000).  Its elongation is dL = 1/2 int u_x^2 dx (to second
order in the slope u_x), and the tension

    T = T0 + E A dL / L = T0 + (E A / (2 L)) int u_x^2 dx,

with Young's modulus E, the cross-section A and the length L.  The wave
speed follows, c = sqrt(T / mu), and with it every partial: the loop's
delay is D0 / sqrt(1 + dT / T0) (D0 the loop at T0, samples).

What is read.  The waves of a string, u = u_r + u_l, give u_x^2 = (u_r' +
u_l')^2, whose cross term averages out over a period: the time average is
<int u_x^2 dx> = int (u_r'^2 + u_l'^2) dx = E_wave / T0, the wave energy
over the tension, which is constant on a lossless string and falls with
the note on a lossy one.  On the ring (both rails in one loop, see
:mod:`synth.kernels.strings`) it is the sum S of the squared differences
of neighbouring samples over dx, less the pair at x = L (the sample the
loop filter wrote last and the one arriving at it are a loop filter and a
bend line apart, not dx) and the two pairs at x = 0 (the slot there holds
the first cell's sub-cell delta, which the next sample's clamp at point 1
may overwrite: the per-sample path and the fast path leave it different
there, to no effect on the sound, and the reading must not see it:
:func:`slope_sum_x0`); the ring holds 2N of the loop's D0 samples and
the rest are in the loop filter and the bend line, so that
int (u_r'^2 + u_l'^2) dx = S D0 / (2 N dx), and

    dT / T0 = kappa S,    kappa = E A D0 / (4 L T0 N dx)   (``F_TMK``).

Why the mean, and why per chunk.  It is the mean tension that a plucked
string's pitch glide follows (the 2 f0 ripple of the instantaneous
tension moves no partial to first order; what it adds, the partials it
mixes, is not modelled).  The mean is read from the energy with a pass
over the ring every ``F_TMM`` samples (the voice's 1024 at 325 kHz: 3.2
ms; a string joining a bridge takes a member's phase, so that a bridge's
strings all read at the same samples), smoothed by one pole over two
periods (``F_TMA``: what the loop filter and the bend line hold at a
reading is not in S, and a sharp corner there leaves a reading up to 2x
low on the sitar).  Measured on the sitar's key 50 at 0.08 (3 s, glide =
pitch over 0.05-0.3 s against 2-3 s): a reading every sample, 16, 256 or
1024 samples gives the same glide within 0.005 cent (+8.93 cents at
velocity 127, +2.30 at 20), and every sample costs 15x the render of
every 256 (3.42 against 0.22 s CPU); the whole modulation costs the
sitar 1.01-1.05x.  On the
shipped sitar at velocity 127, every 1024 gives the glide of every 256
within 0.3 cent on key 43 and 0.03 on keys 50, 62 and 74, but its steps
(the delay set at each reading, as then) left 4 dB more above 4 kHz on a
linear string (60 dB under partial 1).
With the delay moving every sample (below), 1024 leaves the same bands as
256, and since the readings run on
the bridge's blocks' threads it costs less: a bridge's chunks end at its
readings, and fewer chunks mean fewer loop launches and bridge heads.  The
128-note sitar cluster on two threads 66-69 % of the block on mean, 82-85
% at the 99th percentile, against 72-74 % and 88-91 % at 256; 32 held
voices 7 % less on one thread; the glide within 0.14 cent and the bands
within 0.9 dB.

Where it acts.  The reading sets where ``S_TM``, the change of the bend
line's delay (:mod:`synth.kernels.bend`), goes: D0 (1 / sqrt(1 + kappa S)
- 1) samples, negative (shorter: higher).  The bend line moves ``S_TM``
there in equal steps (``S_TMD``) over the samples to the next reading, per
sample and in fast-path chunks alike (the drivers end a chunk at a
reading, so that a string renders the same samples whatever its blocks).
A reading that set ``S_TM`` at once would step the delay every ``F_TMM``
samples: each step cut into the wave arriving at the
bend line, a comb of clicks at fs / ``F_TMM`` (1.27 kHz) and its multiples.
That was the modulation's "5 kHz residue": on the tanpura's key 37 at
velocity 127 with the contact off, 2-8 kHz over 0.5-4 s +12.0 dB and 8-16
kHz +56 dB over the string without modulation; a reading every 16 samples
left both within 0.3 dB of it.
With ``F_TMK`` = 0 nothing is read and the bend line adds nothing: the
samples are those of a string without it, bit for bit.

May import: :mod:`~synth.kernels.config`, :mod:`~synth.kernels.layout`.
"""

from __future__ import annotations

import math

from numba import njit

from .config import JIT_OPTS
from .layout import (
    EXC_NONE, F_TMA, F_TMK, F_TML, F_TMM, I_EXC, I_N, I_OFF, I_POS, S_TM, S_TMC, S_TMD, S_TMS,
)


@njit(**JIT_OPTS)
def slope_sum(ring, off, P, jn):
    """Sum over the ring ``ring[off:off+P]`` of (ring[j+1] - ring[j])^2
    over its P neighbour pairs (circular), less the pair (jn, jn + 1) (m^2
    for displacement waves)."""
    acc = 0.0
    # pairs jn + 1 .. P - 2, then the wrap (P - 1, 0), then 0 .. jn - 1;
    # over slices (views), whose indices LLVM sees non-negative: indexing
    # ring[j + 1] kept numba's negative-index wraparound (2.7x slower)
    a = ring[off + jn + 1:off + P]
    for j in range(a.shape[0] - 1):
        d = a[j + 1] - a[j]
        acc += d * d
    if jn != P - 1:
        d = ring[off] - ring[off + P - 1]
        acc += d * d
    b = ring[off:off + jn + 1]
    for j in range(b.shape[0] - 1):
        d = b[j + 1] - b[j]
        acc += d * d
    return acc


@njit(inline="always", **JIT_OPTS)
def slope_sum_x0(ring, off, P, pm):
    """The two pairs of :func:`slope_sum` at x = 0, around slot ``pm``
    (u_r(1), u_r(0) and u_r(0), vl(1)): m^2."""
    jm = pm - 1 if pm > 0 else P - 1
    jp = pm + 1 if pm < P - 1 else 0
    a = ring[off + pm] - ring[off + jm]
    b = ring[off + jp] - ring[off + pm]
    return a * a + b * b


@njit(**JIT_OPTS)
def tension_read(s, ring, ipar, fpar, fst):
    """Read string s's tension now (after its last sample): the smoothed
    slope sum, and the step per sample ``S_TMD`` that takes the bend line's
    delay change ``S_TM`` from its value now to the reading's over the
    ``F_TMM`` samples to the next reading; the countdown to the next
    reading restarts.  While an excitation runs the ring holds its
    injection's step at the excitation point: the reading is skipped and
    ``S_TM`` holds."""
    fp = fpar[s]
    st = fst[s]
    st[S_TMC] = fp[F_TMM]
    if ipar[s, I_EXC] != EXC_NONE:
        st[S_TMD] = 0.0
        return
    N = ipar[s, I_N]
    P = 2 * N
    jn = ipar[s, I_POS] - N
    if jn < 0:
        jn += P
    off = ipar[s, I_OFF]
    S = slope_sum(ring, off, P, jn) - slope_sum_x0(ring, off, P, ipar[s, I_POS])
    m = st[S_TMS]
    m += fp[F_TMA] * (S - m)
    st[S_TMS] = m
    target = fp[F_TML] * (1.0 / math.sqrt(1.0 + fp[F_TMK] * m) - 1.0)
    st[S_TMD] = (target - st[S_TM]) / fp[F_TMM]


@njit(inline="always", **JIT_OPTS)
def tension_limit(s, fpar, fst, C):
    """The longest chunk (at most C) that ends no later than string s's
    next reading (C when it has no tension modulation)."""
    if fpar[s, F_TMK] > 0.0:
        return _countdown_limit(fst[s, S_TMC], C)
    return C


@njit(inline="always", **JIT_OPTS)
def tension_limit_after(s, fpar, fst, C, done):
    """:func:`tension_limit` as it will be once ``done`` more samples of
    string s have run through :func:`tension_after` (the countdown less
    ``done``, or ``F_TMM`` again if the reading fell due): the next
    chunk's limit, known before this chunk runs."""
    if fpar[s, F_TMK] > 0.0:
        c = fst[s, S_TMC] - done
        if c <= 0.0:
            c = fpar[s, F_TMM]    # (as tension_read restarts it)
        return _countdown_limit(c, C)
    return C


@njit(inline="always", **JIT_OPTS)
def _countdown_limit(countdown, C):
    """min(C, the countdown's whole samples), at least 1."""
    c = int(countdown)
    if c < 1:
        c = 1                     # (a countdown the bank has not set: read after one sample)
    return c if c < C else C


@njit(inline="always", **JIT_OPTS)
def tension_after(s, ring, ipar, fpar, fst, C):
    """After C samples of string s: count them down, and read its tension
    if the reading is due (no operation without tension modulation)."""
    if fpar[s, F_TMK] > 0.0:
        c = fst[s, S_TMC] - C
        fst[s, S_TMC] = c
        if c <= 0.0:
            tension_read(s, ring, ipar, fpar, fst)
