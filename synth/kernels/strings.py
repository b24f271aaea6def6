"""Waveguide string bank kernels (numba, nogil, no allocation).

Representation
--------------
Each string of N cells is one ring of P = 2N float64 samples: the loop
"right-going rail from x = 0 to L, then left-going rail back".  The
left-going rail is stored negated (``vl = -u_l``) so that the two ideal
reflections (``u_r(0) = -u_l(0)``, ``u_l(L) = -u_r(L)``) become plain
transport and cost nothing.  A sample at loop position q (q = n for
``u_r`` at grid point n, q = 2N - n for ``vl`` at n) at time index m lives at
ring index ``slot(q, m) = (m - q) mod P``: transport is the clock advancing,
no data moves.  Displacement ``u(n) = ring[slot(n)] - ring[slot(2N - n)]``.

Per time step, in the order of physics notes sections 1-3:
  1. transport (implicit);
  2. excitation at point k: outgoing = incoming + g(t) on both rails, so
     ``u_r(k) += g`` and ``vl(k) -= g``; then ``u(k) = u_r + u_l - g``;
  3. termination region, points n = 1..R: where ``side (u - U) > 0`` set
     ``u_r(n) = U(n) + vl(n)`` (= ``u_r += U - u``); then, on a string
     whose profile is curved from x = 0 (``F_CURV`` > 0, the jawari), the
     sub-cell contact of the first cell: ``u_r(0) = -u_l(0) + delta``
     (:func:`_subcell_delta`);
  4. far end x = L: identity (ideal) or the loss/tuning filter of a musical
     string, applied in place to the sample turning round at q = N.

When an excitation has ended, g stays constant (= G) forever.  Rather than
keep injecting +G and -G every sample, the change of variables ring' = ring
+ G on the loop positions 2N-k .. 2N-1, 0 .. k-1 (the segment through x = 0
that holds the termination region) is made once and injection stops.  It is
exact on every string, lossy or not, at any time (not only in a steady
state): a value crossing k on either rail changes segment exactly when it
would have been injected; both rails of every region point carry the same
offset, which cancels in u and commutes with the clamp; and the far-end
filter never sees it.  (The opposite segment, through the far end, must not
be used on a lossy string: the loop filter would see a step of G and strike
the string with a broadband transient.)  With no excitation running, the
excitation point is no operation point, so the fast path's chunks may be
longer (``I_CHUNK_FREE``).

Fast path (no probe; while an excitation runs, the termination region
entirely below the excitation point): the chunk of C samples is processed
operation by operation instead of sample by sample.  With C no longer than
the loop distance between any two operation points, no sample meets two
operations within one chunk, so this is exact.  The excitation is one of
them only while it runs (``I_CHUNK``; afterwards ``I_CHUNK_FREE``), and a
hammer steps inside the chunk like a pluck: the wave arriving at k during
the chunk was already in the ring at its start.  In the region each
right-going characteristic (a ring slot) leaves with ``min`` (side +1;
``max`` for side -1) of its entry value and ``U(n) + vl(n)`` along its
path, the left-going values being untouched in the chunk; the step is
skipped when a bound on the values that pass the region in the chunk
says none can reach the obstacle (:func:`_out_of_reach`: the same
samples).  The per-sample path is the plain reference for it and handles an excitation running
inside or next to the region and diagnostics (probe, contacts, and the
contact telemetry of ``I_TELEM`` strings: live play's ``--stats``).

How the fast path is written, so that it is fast on every x86-64 target
(AVX-512, AVX2 and plain SSE2 builds; measured in docs/benchmarks.md):

* every window of the ring a step needs is copied to contiguous scratch
  with two loops split at the ring's wrap (:func:`_ring_get`,
  :func:`_ring_put`), never a wrap test per element;
* inner loops index slice views with the bare loop index (an index of
  unknown sign gets numba's negative-index fix-up per element, which stops
  vectorisation);
* the region takes four points per pass and writes a second buffer
  (:func:`_region_pass`): in place, LLVM turns "store min(x, a[i]) to a[i]"
  into a masked store, which AVX2 code emits as ``vmaskmovpd``, microcoded
  and several times slower on AMD CPUs before Zen 4;
* the far-end filter runs over the chunk with its state in registers
  (:func:`_far_chunk`): one multiply-add per recurrence and sample, where
  state read from and written to the state table every sample put a
  store-to-load round trip on each recurrence;
* the members of a coupled group (a piano key's unison) with the same
  loop-filter sections run their loss, allpasses and biquads as the lanes
  of one four-double vector (:func:`_far_lanes`, ``synth.kernels.lanes``:
  numba has no vector type and runs no SLP vectoriser), each lane the
  scalar code's operations in the same order; the running maxima (peaks,
  the region's reach test) also take four samples to a vector
  (:func:`_force_out`, :func:`_pairs_below`), which LLVM does not do for
  a maximum without no-NaN fast-math;
* strings whose hammer is running are rendered four at a time in lockstep
  chunks, their hammer steps interleaved (:func:`_render_group`,
  :func:`_excite_group`; in steady contact the step is short and
  branch-free, :func:`_hammer_steady`), so the CPU overlaps four ~100-cycle
  dependency chains instead of waiting on one;
* scratch windows are spaced so that no two sit a multiple of 4 KiB apart
  (a load whose low 12 address bits match an earlier store's waits for it);
* no call passes a literal constant (numba compiles a separate copy of the
  callee for each), and ``_nrt=False`` (synth.kernels.config) keeps slice
  views free of reference counting.

Parameter tables (columns below) are written at note-on by the string bank
(:class:`synth.dsp.bank.StringBank`, the only code outside this module that
indexes them).  The kernel reads them and writes back only its running
state: the rings, every ``fst`` column, the ``ipar`` state columns
``I_POS``, ``I_EXC`` (an excitation ending: ``EXC_ENDED``, then
``EXC_NONE``), ``I_EXC_M`` and ``I_HLAST``, and the ``fpar`` column ``F_B0``
(the loss gain gliding towards ``F_B0T``); :func:`scan_silence` also resets
``fst[:, S_PEAK]`` and writes its own outputs.
(:func:`synth.kernels.render.render_bank` lowers a finer-grid string's
``I_ROW`` while it stages it, and restores it.)  The bank's renderer, its
coupled groups and its threads are :mod:`synth.kernels.render`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .config import JIT_OPTS, LANES, SERIAL_OPTS, VECTOR_REGS
from .felt_layer import felt_layer_start, felt_layer_step
from .lanes import abs4, lane, load4, loadv, max4, splat, splat2, splat4, store4, v4, vec, width

# ---- integer parameter columns (ipar[s, :]) ---------------------------------
I_OFF = 0        # ring offset in the flat ring array
I_N = 1          # cells N (ring length 2N)
I_POS = 2        # state: (time index of the last processed sample) mod 2N
I_K = 3          # excitation / pickup grid point k (1 .. N-1)
I_EXC = 4        # state: excitation kind, EXC_* below (0 none/ended, -1 ended with its
                 #   offset still to fold, 1-2 plucks, 3 g table, 4-6 felt hammers)
I_EXC_M = 5      # state: samples since excitation start (t = I_EXC_M * dt)
I_REG_OFF = 6    # offset of U(1..R) in the flat profile array
I_REG_N = 7      # R, points in the termination region (0: ideal rigid end)
I_SIDE = 8       # +1 obstacle above (u <= U), -1 below (u >= U)
I_FILT = 9       # 0 ideal far end, 1 loss + tuning filter
I_XDELAY = 10    # extra unit delay in the far-end filter (0 or 1)
I_OUT = 11       # output signal: 0 displacement u(k), 1 bridge force at x = L
I_PROBE = 12     # row in probe arrays, or -1
I_CHUNK = 13     # longest exact fast-path chunk (samples) while an excitation runs; 0: per-sample
I_EXC_END = 14   # first excitation sample with t > t0 (g constant from there);
                 #   g table: its length; hammer: latest end of the hammer's flight
I_GT_OFF = 15    # offset of the g table in the flat table array (kind 3)
I_HLAST = 16     # state: excitation sample of the hammer's last contact (-1: none yet)
I_NDISP = 17     # dispersion: number M of identical first-order allpass sections (0..MAX_DISP)
I_BOFF = 18      # offset of the pitch-bend delay line in the flat table array
I_BLEN = 19      # its length (0: no bend line)
I_CHUNK_FREE = 20  # the same with no excitation running (0 forces per-sample)
I_TELEM = 21     # 1: contact telemetry into the fst T_* columns (per-sample path), else 0
I_NSOS = 22      # dispersion: number of second-order allpass sections (0..MAX_SOS)
I_BUS = 23       # output buses: 0 bus 0 only; 1 split between buses 0 and 1 by F_PAN
I_CPL = 24       # bridge coupling: CPL_NONE; the leader slot of a coupled group (>= 0);
                 #   or CPL_EXTERNAL (the bridge's motion comes from the ``ubx`` array)
I_CPLN = 25      # strings in the coupled group (its leader's row counts them)
I_SUB = 26       # steps per engine sample (a finer grid: the string runs at I_SUB x the rate)
I_CPLNX = 27     # the next member of the coupled group after this one (-1: the last);
                 #   a group is the chain leader -> ... (any slots, not only consecutive)
I_ROW = 28       # first mix row of the string's buses: bus 0 to row I_ROW, bus 1 to I_ROW + 1
I_NI = 29

CPL_NONE = -1
CPL_EXTERNAL = -2
#: most strings in a coupled group by default (a piano key's unison); a bank
#: sized for more (``max_group``: a sitar's taraf and its played strings on one
#: bridge) holds :func:`coupled_scratch` samples more scratch
MAX_CPL = 4
#: finest grid: steps per engine sample
MAX_SUB = 8

# ---- excitation kinds (ipar[s, I_EXC]); the only place they are defined: the
# bank (synth.dsp.bank) and the voices' exciters use these names --------------
EXC_ENDED = -1   # ended on the last sample: its constant g is folded into the ring next
EXC_NONE = 0     # no excitation running
EXC_SITAR = 1    # kinematic pluck g(t) (eq. 1.13)
EXC_BIWA = 2     # force pluck g(t) (eq. 1.11); kinds <= EXC_BIWA have a closed-form g
EXC_GTABLE = 3   # g(t) from a table (the injected strike of Publication I)
EXC_HAMMER3 = 4  # felt hammer, three-parameter law (eq. 1.5); kinds >= EXC_HAMMER3 are hammers
EXC_HAMMER4 = 5  # felt hammer, four-parameter law (Pub. III eq. 3)
EXC_FELT = 6     # felt hammer, the felt as a medium (synth.kernels.felt_layer): its state in
                 #   the g table's place (I_GT_OFF); per-sample path only

# ---- float parameter columns (fpar[s, :]) -----------------------------------
F_DT = 0         # time step dt (s)
F_A = 1          # pluck amplitude A (m)
F_T0 = 2         # pluck duration t0 (s)
F_ALPHA = 3      # biwa alpha (1/s)
F_B0 = 4         # one-pole b0
F_A1 = 5         # one-pole a1   (y = b0 x - a1 y1)
F_ETA = 6        # allpass coefficient
F_GAIN = 7       # output gain (signal units -> mix units)
F_TDX = 8        # T / dx (N/m), bridge force scale
F_HMC = 9        # hammer: 2T / (c m) (1/s): its deceleration per unit g (mass m, string T, c)
F_HV = 10        # hammer speed V at first contact (m/s)
F_HQ = 11        # felt stiffness Q0 (3-par) or F0 (4-par), N/mm^p
F_HP = 12        # felt exponent p
F_HA = 13        # 3-par: alpha (s); 4-par: gamma
F_HT = 14        # 4-par: tau0 (s)
F_HK = 15        # hammer: c / 2T (m per N s): g increment per unit felt impulse
F_HE = 16        # 4-par hammer: exp(-dt / tau0)
F_HREL = 17      # samples without contact after which the hammer is gone
F_ADISP = 18     # dispersion allpass coefficient a (string stiffness)
F_B0T = 19       # target of the loss filter's b0: dampers and releases glide there
F_B0S = 20       # glide rate per sample (1 - exp(-dt / 2 ms)); an instant change of the
                 #   end's loss would step the bridge force (u(L) = x - y) and click
F_BDT = 21       # pitch bend: target delay of the bend line (samples, >= 1)
F_BDS = 22       # its glide rate per sample (20 ms: a pitch wheel moves, it does not jump)
# hammer constants of the step (:func:`_hammer_general`), set at each strike by
# the voice layer (synth.voices.bank.hammer_template): both felt laws in one
# form, the felt impulse over a step K int F dt = KCA y1 + KCBY y0 + KCBP Phi0
F_HDZ = 23       # dt T / (c m): z1 = z0 + dt V - dz (g0 + g1)
F_HD = 24        # 1 + dz: w1 = W0 - D x
F_HKCA = 25      # K ca (per unit y1)
F_HKCBY = 26     # K cb / y0
F_HKCBP = 27     # K cb / Phi0 (4-par only)
F_HKCD = 28      # K ca D p: Newton's derivative term
F_HPE = 29       # Phi1 = PE Phi0 + P1 y1 + P0 y0 (4-par; 0 for the 3-par law)
F_HP1 = 30
F_HP0 = 31
F_HFA = 32       # F1 = FA y1 + FB y0 + FPHI Phi1 (N)
F_HFB = 33
F_HFPHI = 34
F_HDTV = 35      # dt V (m): the hammer's free travel per step
F_HC2 = 36       # p (p - 1) / 2 and p (p - 1) (p - 2) / 6: Taylor terms of w^p
F_HC3 = 37
F_HB4 = 38       # binomial coefficients C(p, 4) .. C(p, 10) (F_HB4 + j = C(p, 4 + j))
F_TGAP = 45      # telemetry: contacts fewer than this many samples apart are one episode
# second-order dispersion allpasses (c2 + c1 z^-1 + z^-2) / (1 + c1 z^-1 + c2 z^-2),
# after the tuning allpass: section j has c1 at F_SOS + 2 j, c2 at F_SOS + 2 j + 1
F_SOS = 46
MAX_SOS = 12
F_PAN = F_SOS + 2 * MAX_SOS   # share of the output on bus 1 (I_BUS = 1): (1 - pan) to bus 0
# the bridge of a coupled group (on its leader): u_b(n) = BRA u_b(n-1) + BRB F(n), with
# F(n) the strings' summed force on it (N), solved in the same sample (_bridge);
# BTDX = the members' summed T / dx (N/m)
F_BRA = F_PAN + 1
F_BRB = F_BRA + 1
F_BTDX = F_BRB + 1
F_UBOD = F_BTDX + 1   # external bridge: the offset S_UBOFF decays by this factor per sample
F_TOR = F_UBOD + 1    # pitch bend: the tune-out S_TO decays by this factor per sample
F_TOG = F_TOR + 1     # and the bend line reads F_TOG S_TO samples further back
F_HTOL = F_TOG + 1    # hammer solver: stop when a correction changes w by at most this,
                      #   relative (1e-5: the next would be ~1e-15; Halley's is cubic)
F_HTOLG = F_HTOL + 1  # or changes g by at most this, relative (1e-13 with 1e-5)
F_REACH = F_HTOLG + 1  # the region's reach: min over its points of side U(n) / n (m; 0: never
#                        out of reach; inf: no point can be touched), see _out_of_reach
F_CURV = F_REACH + 1   # sub-cell contact in the first cell (0: off; see _subcell_delta): the share
#                        of U(1) that is the profile's curvature, 1 - theta dx / U(1) (0 < value <= 1)
F_BRMU = F_CURV + 1   # the bridge's mass (coupled group, on its leader): mu = M / (R_b dt)
#                        (0: a dashpot, the old bridge; see _bridge)
F_NF = F_BRMU + 1

# ---- float state columns (fst[s, :]) ----------------------------------------
S_G = 0          # current g (m)
S_LP = 1         # one-pole state
S_APX = 2        # allpass x[n-1]
S_APY = 3        # allpass y[n-1]
S_XD = 4         # extra-delay register
S_PEAK = 5       # peak |gain * signal| since last reset (silence detection)
S_HZ = 6         # hammer position z (m)
S_HY = 7         # felt y = w_mm^p at the last step
S_HPHI = 8       # 4-par: memory integral Phi (mm^p s)
S_HW = 9         # felt compression w at the last step (m)
S_BD = 10        # pitch bend: current delay of the bend line (samples)
S_BW = 11        # its write position
S_HDG = 12       # hammer: g increment of the last step (Newton's predictor)
S_D0 = 13        # dispersion sections' states: x1, y1 per section
MAX_DISP = 16
S_HDG2 = S_D0 + 2 * MAX_DISP   # hammer: g increment of the step before the last
S_HDG3 = S_HDG2 + 1   # and the one before that
S_HIW = S_HDG3 + 1    # hammer: 1 / w at the last step (1/m; 0 out of contact)
# contact telemetry (I_TELEM = 1), the same quantities as
# synth.analysis.contacts.contact_summary, accumulated sample by sample:
S_TC_N = S_HIW + 1    # samples with a termination point in contact
S_TC_EP = S_TC_N + 1  # termination contact episodes (runs F_TGAP or more samples apart)
S_TC_GAP = S_TC_EP + 1  # samples since the last termination contact (-1: none yet)
S_TC_PTS = S_TC_GAP + 1  # most termination points in contact at one sample
S_HC_N = S_TC_PTS + 1  # samples with the hammer felt pressing (F > 0)
S_HC_EP = S_HC_N + 1  # hammer contact episodes
S_HC_GAP = S_HC_EP + 1  # samples since the last hammer contact (-1: none yet)
S_HF_PK = S_HC_GAP + 1  # peak hammer force (N)
# second-order sections' states: x1, x2, y1, y2 per section (direct form I)
S_SOS = S_HF_PK + 1
S_UBW = S_SOS + 4 * MAX_SOS   # coupled group (leader): the bridge's last step w = u_b(i) - a u_b(i-1)
#                               (m; its velocity times dt: the state of its mass, F_BRMU > 0)
S_UBM = S_UBW + 1             # coupled group (leader): the bridge displacement of the last sample (m)
S_UBP = S_UBM + 1             # a string on a bridge: the bridge displacement of its last sample
S_UBOFF = S_UBP + 1           # a string on an external bridge: the offset its end eases off
S_TO = S_UBOFF + 1            # pitch bend: the tune-out, extra delay of the bend line (samples,
                              #   times F_TOG), decaying by F_TOR per sample (the contact's pitch
                              #   rise, undone)
S_U1P = S_TO + 1              # sub-cell contact (F_CURV > 0): u(1) at the last sample (m), after
                              #   point 1's clamp
S_NS = S_U1P + 1

# ---- probe channels (probe[row, ch, n]) ---------------------------------------
P_U = 0          # u at the excitation point (m)
P_CONTACT = 1    # region points in contact with the termination
P_F = 2          # hammer force (N)
P_W = 3          # felt compression w (m)
P_Z = 4          # hammer position z (m)
P_G = 5          # outgoing wave g (m)
P_NCH = 6


@njit(**JIT_OPTS)
def _g_at(kind, e, dt, A, t0, alpha):
    """Outgoing wave g (m) at excitation sample e (t = e dt)."""
    if e < 0:
        return 0.0
    t = e * dt
    if kind == EXC_SITAR:
        if t > t0:
            return A
        r = t / t0
        return A * r * r * np.exp(2.0 * (1.0 - r))
    else:
        if t > t0:
            t = t0
        return A * (1.0 - (1.0 + alpha * t) * np.exp(-alpha * t))


@njit(inline="always", **SERIAL_OPTS)
def _hammer_steady(I1, g0, fp, st):
    """The hammer step (:func:`_hammer_general`) in steady contact, short
    and branch-free, or nothing.

    When the last three steps pressed the string, w^p is continued from the
    last step's w0 by its binomial series in e0 = w / w0 - 1 (to
    C(p, 10) e0^10: error < 1e-18 for |e0| < 0.05) instead of a power, and
    two Halley corrections follow, the second with w^p by a fifth-order
    Taylor step (error < 1e-16 for a first correction below 1e-3).  One
    test at the end says whether the result is the solution to round-off
    (the second correction within the solver's tolerance F_HTOL);
    if not (contact starting or ending, a jump of the incoming wave),
    nothing has been written and the last return value is False: the caller
    takes the general step.  Kept small so that it inlines and the steps of
    several hammers overlap in the CPU (:func:`_excite_group`).  Returns
    (g1, F1, w1, done).
    """
    y0 = st[S_HY]
    h3 = st[S_HDG3]
    if not (h3 > 0.0 and y0 > 0.0):
        return g0, 0.0, 0.0, False
    dz = fp[F_HDZ]
    D = fp[F_HD]
    z0 = st[S_HZ]
    phi0 = st[S_HPHI]
    zc = z0 + fp[F_HDTV] - dz * g0
    W0 = zc - I1 - D * g0
    p = fp[F_HP]
    c2 = fp[F_HC2]
    c3 = fp[F_HC3]
    Kca = fp[F_HKCA]
    kcd = fp[F_HKCD]
    kh = kcd * D * (p - 1.0)
    Kcb = fp[F_HKCBY] * y0 + fp[F_HKCBP] * phi0
    h1 = st[S_HDG]
    h2 = st[S_HDG2]
    x = 3.0 * (h1 - h2) + h3
    w = W0 - D * x
    e0 = (w - st[S_HW]) * st[S_HIW]
    q = fp[F_HB4 + 6]
    q = q * e0 + fp[F_HB4 + 5]
    q = q * e0 + fp[F_HB4 + 4]
    q = q * e0 + fp[F_HB4 + 3]
    q = q * e0 + fp[F_HB4 + 2]
    q = q * e0 + fp[F_HB4 + 1]
    q = q * e0 + fp[F_HB4]
    q = q * e0 + c3
    q = q * e0 + c2
    q = q * e0 + p
    q = q * e0 + 1.0
    y = y0 * q
    imp = Kca * y + Kcb
    r = x - imp
    Aw = w + kcd * y
    inv = 1.0 / (2.0 * Aw * Aw + r * kh * y)
    x1 = x - 2.0 * r * w * Aw * inv
    e1 = 2.0 * D * r * Aw * inv
    w = W0 - D * x1
    y = y * (1.0 + e1 * (p + e1 * (c2 + e1 * (c3 + e1 * (fp[F_HB4] + e1 * fp[F_HB4 + 1])))))
    imp2 = Kca * y + Kcb
    r = x1 - imp2
    Aw = w + kcd * y
    inv = 1.0 / (2.0 * Aw * Aw + r * kh * y)
    x2 = x1 - 2.0 * r * w * Aw * inv
    e2 = 2.0 * D * r * Aw * inv
    etol = fp[F_HTOL]
    if (-0.05 < e0 < 0.05 and -1e-3 < e1 < 1e-3 and -etol < e2 < etol
            and imp > 0.0 and imp2 > 0.0 and w > 0.0 and x2 > 0.0):
        y1 = y * (1.0 + e2 * (p + e2 * (c2 + e2 * c3)))
        st[S_HDG3] = h2
        st[S_HDG2] = h1
        st[S_HDG] = x2
        g1 = g0 + x2
        w1 = W0 - D * x2
        phi1 = fp[F_HPE] * phi0 + fp[F_HP1] * y1 + fp[F_HP0] * y0
        F1 = fp[F_HFA] * y1 + fp[F_HFB] * y0 + fp[F_HFPHI] * phi1
        if F1 < 0.0:
            F1 = 0.0
        st[S_HPHI] = phi1
        st[S_HZ] = zc - dz * g1
        st[S_HY] = y1
        st[S_HW] = w1
        st[S_HIW] = 1.0 / w1
        return g1, F1, w1, True
    return g0, 0.0, 0.0, False


@njit(**SERIAL_OPTS)
def _head_sos(xin, yo, n, st, fp, ns, s0, s1, c0, c1, cnt):
    """The far end's first pass over a chunk for a string with second-order
    dispersion: the loss glide and the one-pole loss, ``ns`` (1 or 2)
    first-order allpass sections (as :func:`_head`), then the first ``cnt``
    (1..4) biquads (as :func:`_biquads`), from xin[0:n] into yo[0:n], in one
    loop.  Each stage's recurrence waits on one multiply-add of the sample
    before; in one loop the stages of successive samples overlap, where in
    separate passes each pass waits on its own chain (a pedalled 64-note
    chord: see docs/benchmarks.md).  Compiled without
    re-association, as :func:`_biquads`."""
    b0 = fp[F_B0]
    gk = 1.0 - fp[F_B0S]
    gc = fp[F_B0S] * fp[F_B0T]
    a1 = fp[F_A1]
    lp = st[S_LP]
    x0 = st[s0]
    y0 = st[s0 + 1]
    x1 = st[s1]
    y1 = st[s1 + 1]
    q0 = S_SOS
    x10 = st[q0]
    x20 = st[q0 + 1]
    ca0 = fp[F_SOS + 0] if cnt > 0 else 0.0
    cb0 = fp[F_SOS + 1] if cnt > 0 else 0.0
    y10 = st[q0 + 2] if cnt > 0 else 0.0
    y20 = st[q0 + 3] if cnt > 0 else 0.0
    ca1 = fp[F_SOS + 2] if cnt > 1 else 0.0
    cb1 = fp[F_SOS + 3] if cnt > 1 else 0.0
    y11 = st[q0 + 6] if cnt > 1 else 0.0
    y21 = st[q0 + 7] if cnt > 1 else 0.0
    ca2 = fp[F_SOS + 4] if cnt > 2 else 0.0
    cb2 = fp[F_SOS + 5] if cnt > 2 else 0.0
    y12 = st[q0 + 10] if cnt > 2 else 0.0
    y22 = st[q0 + 11] if cnt > 2 else 0.0
    ca3 = fp[F_SOS + 6] if cnt > 3 else 0.0
    cb3 = fp[F_SOS + 7] if cnt > 3 else 0.0
    y13 = st[q0 + 14] if cnt > 3 else 0.0
    y23 = st[q0 + 15] if cnt > 3 else 0.0
    if ns == 1 and cnt == 1:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * xin[i] - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            h = y0
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            y20 = y10
            y10 = o0
            yo[i] = o0
    elif ns == 1 and cnt == 2:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * xin[i] - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            h = y0
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            o1 = (cb1 * (o0 - y21) + y20 + ca1 * y10) - ca1 * y11
            y20 = y10
            y10 = o0
            y21 = y11
            y11 = o1
            yo[i] = o1
    elif ns == 1 and cnt == 3:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * xin[i] - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            h = y0
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            o1 = (cb1 * (o0 - y21) + y20 + ca1 * y10) - ca1 * y11
            y20 = y10
            y10 = o0
            o2 = (cb2 * (o1 - y22) + y21 + ca2 * y11) - ca2 * y12
            y21 = y11
            y11 = o1
            y22 = y12
            y12 = o2
            yo[i] = o2
    elif ns == 1 and cnt == 4:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * xin[i] - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            h = y0
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            o1 = (cb1 * (o0 - y21) + y20 + ca1 * y10) - ca1 * y11
            y20 = y10
            y10 = o0
            o2 = (cb2 * (o1 - y22) + y21 + ca2 * y11) - ca2 * y12
            y21 = y11
            y11 = o1
            o3 = (cb3 * (o2 - y23) + y22 + ca3 * y12) - ca3 * y13
            y22 = y12
            y12 = o2
            y23 = y13
            y13 = o3
            yo[i] = o3
    elif ns == 2 and cnt == 1:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * xin[i] - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            y1 = c1 * y0 + x1 - c1 * y1
            x1 = y0
            h = y1
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            y20 = y10
            y10 = o0
            yo[i] = o0
    elif ns == 2 and cnt == 2:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * xin[i] - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            y1 = c1 * y0 + x1 - c1 * y1
            x1 = y0
            h = y1
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            o1 = (cb1 * (o0 - y21) + y20 + ca1 * y10) - ca1 * y11
            y20 = y10
            y10 = o0
            y21 = y11
            y11 = o1
            yo[i] = o1
    elif ns == 2 and cnt == 3:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * xin[i] - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            y1 = c1 * y0 + x1 - c1 * y1
            x1 = y0
            h = y1
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            o1 = (cb1 * (o0 - y21) + y20 + ca1 * y10) - ca1 * y11
            y20 = y10
            y10 = o0
            o2 = (cb2 * (o1 - y22) + y21 + ca2 * y11) - ca2 * y12
            y21 = y11
            y11 = o1
            y22 = y12
            y12 = o2
            yo[i] = o2
    elif ns == 2 and cnt == 4:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * xin[i] - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            y1 = c1 * y0 + x1 - c1 * y1
            x1 = y0
            h = y1
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            o1 = (cb1 * (o0 - y21) + y20 + ca1 * y10) - ca1 * y11
            y20 = y10
            y10 = o0
            o2 = (cb2 * (o1 - y22) + y21 + ca2 * y11) - ca2 * y12
            y21 = y11
            y11 = o1
            o3 = (cb3 * (o2 - y23) + y22 + ca3 * y12) - ca3 * y13
            y22 = y12
            y12 = o2
            y23 = y13
            y13 = o3
            yo[i] = o3
    st[s0] = x0
    st[s0 + 1] = y0
    if ns == 2:
        st[s1] = x1
        st[s1 + 1] = y1
    st[S_LP] = lp
    fp[F_B0] = b0
    st[q0] = x10
    st[q0 + 1] = x20
    if cnt > 0:
        st[q0 + 2] = y10
        st[q0 + 3] = y20
    if cnt > 1:
        st[q0 + 4] = y10
        st[q0 + 5] = y20
        st[q0 + 6] = y11
        st[q0 + 7] = y21
    if cnt > 2:
        st[q0 + 8] = y11
        st[q0 + 9] = y21
        st[q0 + 10] = y12
        st[q0 + 11] = y22
    if cnt > 3:
        st[q0 + 12] = y12
        st[q0 + 13] = y22
        st[q0 + 14] = y13
        st[q0 + 15] = y23


@njit(**SERIAL_OPTS)
def _hammer_general(I1, g0, fp, st):
    """Advance the hammer-string contact (eq. 1.4) by one step.

    Unknown: g1 = g(t_{n+1}), written g1 = g0 + x.  With the incoming
    displacement I1 at the strike point known (it arrives from the
    neighbours), z1 = z0 + dt (V - (2T/cm)(g0 + g1)/2), so the compression
    w1 = z1 - I1 - g1 = W0 - D x is linear in x (D = 1 + dt T/(cm)), and
    g1 = g0 + (c/2T) max(0, int F dt).  The felt impulse over the step, with
    y = w_mm^p linear in the step, is integrated exactly:

    law 4 (eq. 1.5):  int F = Q0 [dt (y0 + y1)/2 + alpha (y1 - y0)];
    law 5 (Pub. III eq. 3, recursive convolution):
        int F = F0 [(1 - gamma) dt (y0 + y1)/2 + gamma J - gamma (1 - E) Phi0],
        J = tau0 (c1 y1 + c0 y0), E = exp(-dt/tau0);

    both are ``ca y1 + cb`` with ca > 0, and the strike's constants (columns
    F_HDZ .. F_HC3, one form for both laws) are computed once per strike.
    So the residual r(x) = x - K max(0, ca y(W0 - D x) + cb) is increasing
    (r' >= 1) and concave (y is convex in w, w linear in x).  The solve
    starts from the last three steps' increments extrapolated
    quadratically and takes Halley steps (r'' costs three multiplies more
    than Newton's r' and makes the convergence cubic: 1.04-1.57 iterations
    per step over keys 36-76, against 1.2-2.1 with Newton), falling back to
    Newton's step, which converges from any start, monotonically from the
    left after its first step, with no bracket, where Halley's denominator
    says the iterate is far from the root.  It stops when a correction
    changes w by less than F_HTOL relative (1e-5 by default: the next would
    be ~1e-15) or x by less than F_HTOLG of g (1e-13).  One power per step, as exp(p ln w) (later
    iterates update w^p by a Taylor step in the relative change of w,
    which the step gives with its one division).  A-stable (the stiff felt
    terms are integrated exactly), second order.  Returns (g1, F1, w1,
    contact).
    """
    dz = fp[F_HDZ]
    D = fp[F_HD]
    z0 = st[S_HZ]
    y0 = st[S_HY]
    phi0 = st[S_HPHI]
    zc = z0 + fp[F_HDTV] - dz * g0          # z1 = zc - dz g1
    W0 = zc - I1 - D * g0                   # w1 if g1 = g0
    if W0 <= 0.0 and y0 == 0.0 and phi0 == 0.0:
        # in flight (law 4: cb = 0; law 5: no felt memory left): w < 0 for
        # every x >= 0 and no force, so x = 0
        st[S_HDG3] = st[S_HDG2]
        st[S_HDG2] = st[S_HDG]
        st[S_HDG] = 0.0
        st[S_HZ] = zc - dz * g0
        st[S_HY] = 0.0
        st[S_HW] = W0
        st[S_HIW] = 0.0
        return g0, 0.0, W0, False
    p = fp[F_HP]
    c2 = fp[F_HC2]
    c3 = fp[F_HC3]
    Kca = fp[F_HKCA]
    kcd = fp[F_HKCD]
    kh = kcd * D * (p - 1.0)
    Kcb = fp[F_HKCBY] * y0 + fp[F_HKCBP] * phi0
    # predictor: the increments change slowly from one sample to the next
    h1 = st[S_HDG]
    h2 = st[S_HDG2]
    h3 = st[S_HDG3]
    x = 3.0 * (h1 - h2) + h3
    if x < 0.0:
        x = 0.0
    y = 0.0
    e = 1.0              # relative change of w to this iterate (>= 1e-4: pow)
    etol = fp[F_HTOL]
    tol_g = fp[F_HTOLG] * (abs(g0) + 1e-30)
    for it in range(60):
        w = W0 - D * x
        if w > 0.0:
            if -1e-4 < e < 1e-4:
                # a correction: w^p by a third-order Taylor step from the
                # last point (error < 1e-16 relative), no pow
                y = y * (1.0 + e * (p + e * (c2 + e * c3)))
            else:
                # w_mm^p as exp(p ln w_mm): two short calls, faster than
                # pow's one here (38 vs 44 ns a step, AVX2 build, Zen 5)
                y = np.exp(p * np.log(1000.0 * w))
            imp = Kca * y + Kcb
            if imp > 0.0:
                # Halley's step (r' = Aw / w, r'' = -kh y / w^2): cubic, so
                # the predictor's error of ~1e-6 is gone in one step
                r = x - imp
                Aw = w + kcd * y
                den = 2.0 * Aw * Aw + r * kh * y
                if den > Aw * Aw:
                    inv = 1.0 / den
                    dx = 2.0 * r * w * Aw * inv
                    e = 2.0 * D * r * Aw * inv      # (w_next - w) / w
                else:                               # far from the root: Newton
                    inv = 1.0 / Aw
                    dx = r * w * inv
                    e = D * r * inv
            else:
                dx = x
                e = D * x / w
        else:
            y = 0.0
            dx = x - Kcb if Kcb > 0.0 else x
            e = 1.0
        xn = x - dx
        if xn < 0.0:
            xn = 0.0                 # the root is >= 0 (r(0) <= 0)
            dx = x
            e = D * dx / w if w > 0.0 else 1.0
        x = xn
        if w <= 0.0:
            # r is linear where w <= 0: exact if the new point stays there
            if W0 - D * x <= 0.0:
                y = 0.0
                break
        elif -etol <= e <= etol:
            # converged (the next step would change w by ~e^3: < 1e-15 at 1e-5):
            # w^p at the final point by a third-order step
            y = y * (1.0 + e * (p + e * (c2 + e * c3)))
            break
        if abs(dx) <= tol_g:
            w = W0 - D * x
            y = np.exp(p * np.log(1000.0 * w)) if w > 0.0 else 0.0
            break
    st[S_HDG3] = h2
    st[S_HDG2] = h1
    st[S_HDG] = x
    g1 = g0 + x
    # state update at t_{n+1}
    w1 = W0 - D * x
    y1 = y if w1 > 0.0 else 0.0
    phi1 = fp[F_HPE] * phi0 + fp[F_HP1] * y1 + fp[F_HP0] * y0
    F1 = fp[F_HFA] * y1 + fp[F_HFB] * y0 + fp[F_HFPHI] * phi1
    contact = x > 0.0
    if F1 < 0.0 or not contact:
        F1 = 0.0
    st[S_HPHI] = phi1
    st[S_HZ] = zc - dz * g1
    st[S_HY] = y1
    st[S_HW] = w1
    st[S_HIW] = 1.0 / w1 if w1 > 0.0 else 0.0
    return g1, F1, w1, contact


@njit(**JIT_OPTS)
def _fold_offset(ring, off, P, pm, k, G):
    """End a constant injection G at k: add G to the loop positions
    P-k .. P-1, 0 .. k-1 at the time whose position index is pm (slots
    (pm - q) mod P); see the module notes."""
    for q in range(-k, k):
        j = pm - q
        if j < 0:
            j += P
        elif j >= P:
            j -= P
        ring[off + j] += G


@njit(**SERIAL_OPTS)
def _lagrange3(f):
    """Third-order Lagrange taps for the fraction f of a delay i + f, at
    delays i-1 .. i+2 (one function, so that the bend line's per-sample and
    chunk paths compute them with the same operations)."""
    return (-f * (f - 1.0) * (f - 2.0) / 6.0, (f + 1.0) * (f - 1.0) * (f - 2.0) / 2.0,
            -(f + 1.0) * f * (f - 2.0) / 2.0, (f + 1.0) * f * (f - 1.0) / 6.0)


@njit(**SERIAL_OPTS)
def _bend_line(y, st, U, boff, blen, bdt, bds, tor, tog):
    """Pitch-bend line: write y, read at the (gliding) delay plus the
    (decaying) tune-out tog S_TO with third-order Lagrange interpolation
    (taps at delays i-1 .. i+2)."""
    w = int(st[S_BW])
    U[boff + w] = y
    D = st[S_BD] + bds * (bdt - st[S_BD])
    if abs(bdt - D) < 1e-9:
        D = bdt                   # at rest: the fast path's block FIR takes over
    st[S_BD] = D
    to = st[S_TO]
    D += tog * to
    to *= tor
    if abs(to) < 1e-9:
        to = 0.0
    st[S_TO] = to
    i = int(D)
    f = D - i
    h0, h1, h2, h3 = _lagrange3(f)
    r = w - i + 1
    if r < 0:
        r += blen
    out = h0 * U[boff + r]
    r -= 1
    if r < 0:
        r += blen
    out += h1 * U[boff + r]
    r -= 1
    if r < 0:
        r += blen
    out += h2 * U[boff + r]
    r -= 1
    if r < 0:
        r += blen
    out += h3 * U[boff + r]
    w += 1
    if w == blen:
        w = 0
    st[S_BW] = w
    return out


@njit(**JIT_OPTS)
def _far_end(ring, off, P, N, pm, b0, a1, eta, xdel, nd, ad, st, nb, fsos):
    """One sample of the far-end filter at loop position N; returns (x, y, j)
    with j the ring index written.  (The caller glides b0 toward its target
    and, for a string with a pitch-bend line, passes y through
    :func:`_bend_line` and writes the result at j: kept apart, because with
    the bend code inside, this function stopped being inlined and every
    string-sample cost 35 ns instead of 10.)"""
    j = pm - N
    if j < 0:
        j += P
    x = ring[off + j]
    if xdel == 1:
        xin = st[S_XD]
        st[S_XD] = x
    else:
        xin = x
    lp = b0 * xin - a1 * st[S_LP]
    st[S_LP] = lp
    # string stiffness: M identical first-order allpasses (a + z^-1)/(1 + a z^-1)
    for d in range(nd):
        xo = st[S_D0 + 2 * d]
        yo = st[S_D0 + 2 * d + 1]
        yd = ad * lp + xo - ad * yo
        st[S_D0 + 2 * d] = lp
        st[S_D0 + 2 * d + 1] = yd
        lp = yd
    y = eta * lp + st[S_APX] - eta * st[S_APY]
    st[S_APX] = lp
    st[S_APY] = y
    # string stiffness: second-order allpasses, direct form I written so that
    # the recurrence on y1 is one multiply-add (as :func:`_biquads`)
    for b in range(nb):
        c1 = fsos[2 * b]
        c2 = fsos[2 * b + 1]
        q = S_SOS + 4 * b
        x1 = st[q]
        x2 = st[q + 1]
        y1 = st[q + 2]
        y2 = st[q + 3]
        t = c2 * (y - y2) + x2 + c1 * x1
        yb = t - c1 * y1
        st[q] = y
        st[q + 1] = x1
        st[q + 2] = yb
        st[q + 3] = y1
        y = yb
    ring[off + j] = y
    return x, y, j


@njit(**JIT_OPTS)
def far_end_run(st, fp, xdel, nd, nb, x, y, one):
    """The far-end filter chain of a string alone (:func:`_far_end`: the
    unit delay, the one-pole loss at ``fp[F_B0]``, held, the first-order
    and tuning allpasses, the second-order sections) from the state row
    ``st`` (an ``fst`` row, advanced in place) on the arriving waves ``x``:
    its outputs into ``y`` (no bridge, no bend line).  ``fp``: the
    string's ``fpar`` row; ``one``: one scratch value.  Used by the hand-over
    between grids (:func:`hand_over_loop`)."""
    b0 = fp[F_B0]
    a1 = fp[F_A1]
    eta = fp[F_ETA]
    ad = fp[F_ADISP]
    fsos = fp[F_SOS:F_SOS + 2 * MAX_SOS]
    for i in range(x.shape[0]):
        one[0] = x[i]
        _, yi, _ = _far_end(one, 0, 1, 0, 0, b0, a1, eta, xdel, nd, ad, st, nb, fsos)
        y[i] = yi


#: most free values of a far-end filter's state (:func:`hand_over_loop`):
#: the unit delay, the loss, the first-order sections' outputs, the tuning
#: allpass's, the first biquad's x2, two per biquad
MAX_FREE = 4 + MAX_DISP + 2 * MAX_SOS


def hand_over_buffer_length(max_cells: int, rows: int) -> int:
    """Samples of ``buf`` that :func:`hand_over_loop` needs for strings of
    at most ``max_cells`` cells (on the finer grid) and ``rows`` fitted
    outputs."""
    n_run = MAX_SUB * rows + MAX_SUB + 2
    return 2 * max_cells + 2 * n_run + S_NS + 3 * rows + 2 * max_cells + 2 * MAX_FREE


@njit(inline="always", **SERIAL_OPTS)
def _lerp(a, n, f):
    """a[0:n] linearly interpolated at the (fractional) index f, clamped."""
    i = int(np.floor(f))
    if i < 0:
        return a[0]
    if i >= n - 1:
        return a[n - 1]
    w = f - i
    return a[i] + w * (a[i + 1] - a[i])


@njit(inline="always", **SERIAL_OPTS)
def _dot(a, b, n):
    """sum of a[k] b[k], k < n, in order."""
    s = 0.0
    for k in range(n):
        s += a[k] * b[k]
    return s


@njit(**SERIAL_OPTS)
def hand_over_loop(ring, off, Nf, pm, st_f, fp_f, xdel_f, nd_f, nb_f, r, Nc, pmc,
                   st_c, fp_c, xdel_c, nd_c, nb_c, T, m, H, ub, buf, At, R, one):
    """One string's loop from a finer grid (``Nf`` cells, position ``pm``,
    its ``fst`` and ``fpar`` rows ``st_f``, ``fp_f``) to one ``r`` times
    coarser (``Nc`` cells, position ``pmc``, rows ``st_c``, ``fp_c``), in
    the ring at ``off`` (the finer ring's 2 Nf slots are cleared, the
    coarser's 2 Nc written).

    The ring holds the waves that will arrive at the far end, in order;
    the coarser ring's arrival k is the finer one's r k + delta + (r - 1)
    / 2 (linear interpolation; delta = Nf - r Nc keeps the termination's
    place; a coarser step stands for the mean of r finer ones).  The finer
    far-end filter, run on from its state over its next arrivals
    (:func:`far_end_run`), gives the outputs the coarser filter must go on
    with: its state is the least-squares fit, over ``H`` outputs, of the
    ``m`` free directions ``T[:, 0:m]`` (chained states: the fast path
    reads each stage's input history from the stage before), added into
    ``st_c`` (whose filter columns are zero on entry).  ``ub``: the
    bridge's displacement (the ring holds the filter's output less it).
    ``buf`` (:func:`hand_over_buffer_length`), ``At`` (>= m x H), ``R``
    (>= m x m): scratch; ``one``: one value."""
    Pf = 2 * Nf
    Pc = 2 * Nc
    ns = st_f.shape[0]
    n_run = r * H + r + 2
    nX = Pf + n_run
    X = buf[0:nX]
    q = nX
    yf = buf[q:q + n_run]
    q += n_run
    tmp = buf[q:q + ns]
    q += ns
    res = buf[q:q + H]
    q += H
    zero = buf[q:q + H]
    q += H
    tgt = buf[q:q + H]
    q += H
    xc = buf[q:q + Pc]
    q += Pc
    sol = buf[q:q + m]
    q += m
    keep = buf[q:q + m]
    # the finer ring's arrivals, then the outputs its filter goes on with
    j0 = pm + 1 - Nf
    if j0 < 0:
        j0 += Pf
    _ring_get(ring, off, Pf, j0, X[0:Pf], 1.0)
    for i in range(ns):
        tmp[i] = st_f[i]
    far_end_run(tmp, fp_f, xdel_f, nd_f, nb_f, X[0:n_run], yf, one)
    for t in range(n_run):
        X[Pf + t] = yf[t] - ub
    delta = Nf - r * Nc
    phase = 0.5 * (r - 1)
    for k in range(Pc):
        xc[k] = _lerp(X, nX, r * k + delta + phase)
    for k in range(H):
        tgt[k] = _lerp(X, nX, r * k - delta + phase + Pf) + ub
        zero[k] = 0.0
    for i in range(Pf):
        ring[off + i] = 0.0
    j0 = pmc + 1 - Nc
    if j0 < 0:
        j0 += Pc
    _ring_put(ring, off, Pc, j0, xc, 1.0)
    # the coarser filter from zero on the new arrivals, and each free
    # direction's zero-input response
    for i in range(ns):
        tmp[i] = st_c[i]
    far_end_run(tmp, fp_c, xdel_c, nd_c, nb_c, xc[0:H], res, one)
    for k in range(H):
        res[k] = tgt[k] - res[k]
    for j in range(m):
        for i in range(ns):
            tmp[i] = T[i, j]
        far_end_run(tmp, fp_c, xdel_c, nd_c, nb_c, zero, At[j, 0:H], one)
    # least squares: modified Gram-Schmidt, twice, dropping a direction the
    # others already span (the chained state has one more value than the
    # filter's order)
    big = 0.0
    for j in range(m):
        big = max(big, np.sqrt(_dot(At[j], At[j], H)))
    for j in range(m):
        for i in range(m):
            R[i, j] = 0.0
        for rep in range(2):
            for i in range(j):
                if keep[i] == 0.0:
                    continue
                c = _dot(At[i], At[j], H)
                R[i, j] += c
                for k in range(H):
                    At[j, k] -= c * At[i, k]
        s = np.sqrt(_dot(At[j], At[j], H))
        if s <= 1e-9 * big:
            keep[j] = 0.0
            R[j, j] = 0.0
        else:
            keep[j] = 1.0
            R[j, j] = s
            for k in range(H):
                At[j, k] /= s
    for j in range(m - 1, -1, -1):
        if keep[j] == 0.0:
            sol[j] = 0.0
            continue
        c = _dot(At[j], res, H)
        for i in range(j + 1, m):
            c -= R[j, i] * sol[i]
        sol[j] = c / R[j, j]
    for i in range(ns):
        s = 0.0
        for j in range(m):
            s += T[i, j] * sol[j]
        st_c[i] += s


@njit(**JIT_OPTS)
def _subcell_q(r):
    """q(r) = 1 - sqrt(1 - r) = r / (1 + sqrt(1 - r)) for 0 <= r <= 1 (the
    first cell's tangent point over dx, :func:`_subcell_delta`); 0 below,
    1 above."""
    if not (r > 0.0):
        return 0.0
    if r >= 1.0:
        return 1.0
    return r / (1.0 + np.sqrt(1.0 - r))


@njit(**JIT_OPTS)
def _subcell_delta(ut, up, U1, G):
    """The first cell's sub-cell contact: delta (m), the string's virtual
    displacement at x = 0 at this sample, added to the wave leaving x = 0.
    Side-scaled: the obstacle above, ``U1`` = side U(1) > 0 (m), ``G`` =
    F_CURV U1 (m, 0 < G <= U1) the part of it due to the profile's
    curvature; ``ut`` = u(1) at the next sample as it would be without
    delta, ``up`` = u(1) at the last sample (m, side-scaled).  Returns
    delta <= 0 (side-scaled).

    Between x = 0 and the first grid point x = dx the profile is taken as
    U(x) = theta x + G (x / dx)^2 (theta dx = U1 - G; the jawari's
    theta x + x^2 / (2R), thesis eq. 1.15's ramp and parabola, exactly).
    A string whose slope at x = 0 exceeds theta towards the obstacle lies
    on it from x = 0 to the point x_c where it leaves it tangentially (a
    string under tension wraps a smooth obstacle), and its straight part,
    extended back to x = 0, is there at f = -G q^2, where q = x_c / dx =
    1 - sqrt(1 - r) and r = (u(1) - theta dx) / G is the share of point
    1's gap the string has crossed (f = 0 for r <= 0, -G for r >= 1, where
    point 1 touches and the grid's clamp takes over).  For small r, f =
    -(R / 2) a^2 with a = u(1) / dx the string's slope (theta = 0): the
    contact shrinks with the amplitude instead of ending when the string
    no longer reaches point 1's gap U(1) = dx^2 / (2R).

    Quasi-static in the cell (x_c < dx, a sixteenth of a wavelength at
    20 kHz on the 325 kHz grid), f is a nonlinear spring at the end: the
    work the string does on it is a potential, T / dx Phi, Phi = G^2
    Qi(r), Qi(r) = q^3 (2/3 - q/2) the integral of q^2 (r - 5/6 beyond
    1).  Taken explicitly, delta = f(u(1)) pumped energy into a lossless
    string (27 % in 0.7 s at a 0.5 mm pluck).  The kernel takes the
    discrete gradient instead: delta solves

        delta = -(Phi(ut + delta) - Phi(up)) / (ut + delta - up),

    so that the energy it gives the string at this sample, T/(2 dx)
    delta (u1(next) - u1(last)) (the CFL-1 scheme's energy, physics notes
    section 2, with u(1) changed by delta), is -T/(2 dx) (Phi(next) -
    Phi(last)): over a note it telescopes, the string's energy plus Phi
    at two samples never grows, and a clamp at point 1 in between only
    lowers it.  It equals f(u(1)) to first order.  In y = r(ut + delta)
    the right side, minus the secant slope of the convex Phi, makes
    delta + that slope increasing in y: one root, y <= r(ut).  Where it
    lies is read from the sign at y = 0 and y = 1; below 0 and beyond 1
    the equation is a quadratic (Qi is 0, or linear); between, with y =
    2a - a^2, a polynomial in a = q(y) without square roots (a cubic where
    0 < rp < 1): Halley's steps (Newton's where P P'' > P'^2), kept in
    their bracket, until one moves a by less than 1e-5 of it (the error
    is then below 1e-14 of a).  Where 0 < rp < 1 they start from the root
    of the same equation with the mean of q^2 over the step taken with a
    uniform weight in a (the potential's weight is 1 - a): a quadratic,
    exact where a = b, which on a fading sitar chord lies within 6e-6 of
    the root at the median and 6e-4 at the 90th percentile, so that 53 %
    of the solves take one step and 97 % at most two (1.5 on average;
    from a = q(r(ut)), where delta = 0, it took 3.1).  Elsewhere they
    start from q(r(ut)).  The solve is the sub-cell contact's whole cost:
    each step is a division on the loop-carried path (through u(1), the
    solve at one sample sets the one two samples later)."""
    base = U1 - G
    rt = (ut - base) / G
    rp = (up - base) / G
    if rp > 1.0:
        rp = 1.0                 # u(1) after its clamp: at most U(1) but for rounding
    if not (rt > 0.0) and not (rp > 0.0):
        return 0.0
    b = 0.0
    Qp = 0.0
    if rp > 0.0:
        b = _subcell_q(rp)
        Qp = b * b * b * (2.0 / 3.0 - 0.5 * b)
        # the root at or below 0 (the string leaves the cell): there Qi = 0
        # and (y - rt)(rp - y) + Qp = 0; r(0) rp = Qp - rt rp >= 0
        if Qp - rt * rp >= 0.0:
            h = rt - rp
            y = 0.5 * ((rt + rp) - np.sqrt(h * h + 4.0 * Qp))
            return G * (y - rt)
    if rt > 1.0:
        # the root at or beyond 1 (point 1 touches): there Qi = y - 5/6 and
        # (y - rt)(y - rp) + y - 5/6 - Qp = 0, the larger root; r(1) <= 0.
        # In z = y - rp: z^2 + B z + k = 0, B = rp - rt + 1, k = rp - 5/6
        # - Qp <= 0.  Where rp > 0, with u = 1 - q(rp) (rp = 1 - u^2, Qp =
        # 1/6 - u^2 + 4/3 u^3 - u^4 / 2): k = -u^3 (4/3 - u/2), and r(1) <=
        # 0 is u^2 ((2 - rt) - u (4/3 - u/2)) <= 0, free of the
        # cancellation of rp - 5/6 - Qp (at rt = 2, rp = 1 the root is
        # double, and k's rounding cost sqrt(eps) of G: a hypothesis test
        # found -0.99999999 G for -G)
        if rp > 0.0:
            u = 1.0 - b
            w = u * (4.0 / 3.0 - 0.5 * u)
            beyond = (2.0 - rt) - w <= 0.0
            k = -u * u * w
        else:
            beyond = (1.0 - rt) * (1.0 - rp) + 1.0 / 6.0 <= 0.0
            k = rp - 5.0 / 6.0
        if beyond:
            B = rp - rt + 1.0
            sq = np.sqrt(B * B - 4.0 * k)
            if B > 0.0:
                z = -2.0 * k / (B + sq)
            else:
                z = 0.5 * (sq - B)
            return G * (z + (rp - rt))
    # the root in 0 < y < 1, in a: P(a) has the sign of the equation's
    # residual (times (2 - a - b) or (y - rp), both > 0 there), and it is
    # positive for y >= rt: [0, 1] brackets the root
    lo = 0.0
    hi = 1.0
    a = -1.0
    if rp > 0.0 and rp < 1.0:
        # the first guess: the root of the equation with the mean of q^2 over
        # the step taken with a uniform weight in a instead of (1 - a),
        # 2a + (b^2 + a b - 2 a^2) / 3 = rt, exact where a = b (rt = 2a)
        b3 = b * (1.0 / 3.0)
        h = 2.0 + b3
        c = rt - b * b3
        dd = h * h - (8.0 / 3.0) * c
        if dd < 0.0:
            dd = 0.0
        ag = 2.0 * c / (h + np.sqrt(dd))
        if ag > 0.0 and ag < 1.0:
            a = ag
    if a < 0.0:
        hi = _subcell_q(rt)
        a = hi
    for it in range(64):
        y = a * (2.0 - a)
        e = y - rt
        if rp >= 1.0:
            P = e + a * (0.5 * a + 1.0 / 3.0) + 1.0 / 6.0
            dP = 2.0 - a + 1.0 / 3.0
            d2 = -1.0
        elif rp > 0.0:
            sb = 2.0 - a - b
            a2 = a * a
            b2 = b * b
            P = e * sb + (2.0 / 3.0) * (a2 + a * b + b2) - 0.5 * (a + b) * (a2 + b2)
            dP = ((2.0 - 2.0 * a) * sb - e + (4.0 * a + 2.0 * b) / 3.0
                  - 0.5 * (3.0 * a2 + 2.0 * a * b + b2))
            d2 = 3.0 * a + b - 20.0 / 3.0
        else:
            f = y - rp
            P = e * f + a * a * a * (2.0 / 3.0 - 0.5 * a)
            dP = (2.0 - 2.0 * a) * (e + f) + 2.0 * a * a * (1.0 - a)
            ea = 2.0 - 2.0 * a
            d2 = -2.0 * (e + f) + 2.0 * ea * ea + 4.0 * a - 6.0 * a * a
        if P > 0.0:
            hi = a
        elif P < 0.0:
            lo = a
        else:
            break
        if hi - lo <= 1e-15 * hi:
            break               # (delta = 0 within rounding: P(q(rt)) < 0 by an ulp)
        if dP > 0.0:
            # Halley's step (P'' = d2), Newton's where P P'' is large
            Pd = P * d2
            if abs(Pd) <= dP * dP:
                an = a - 2.0 * P * dP / (2.0 * dP * dP - Pd)
            else:
                an = a - P / dP
            # (a step onto an end of the bracket is allowed: the root may
            # lie within rounding of a point already evaluated)
            if an >= lo and an <= hi:
                if abs(an - a) <= 1e-5 * a:
                    # Halley's steps cube their error: the next would be
                    # below 1e-14 of a
                    a = an
                    break
                a = an
                continue
        a = 0.5 * (lo + hi)
    return G * (a * (2.0 - a) - rt)


@njit(**JIT_OPTS)
def _render_per_sample(s, ring, ipar, fpar, fst, U, n, o0, mix, probe, ubx, uo, cf, po0, psub):
    """Plain per-sample scheme for string s over n samples, mixing into
    mix[:, o0:o0+n] (row ``I_ROW``, and the next for a second bus).
    Reference for the fast path; also used when the excitation lies inside
    or next to the region (I_CHUNK = 0, e.g. the top keys' hammers on the
    capo bar) and for probes.

    A string on a bridge (``I_CPL`` not ``CPL_NONE``) has the bridge's
    displacement ubx[uo + i] subtracted from its outgoing wave at x = L at
    sample i; a member of a coupled group adds its force on the bridge
    (N, before the output gain) to cf[0].  Probe values of sample i go to
    index po0 + i // psub (a string on a finer grid: its last step of each
    engine sample)."""
    off = ipar[s, I_OFF]
    N = ipar[s, I_N]
    P = 2 * N
    k = ipar[s, I_K]
    R = ipar[s, I_REG_N]
    roff = ipar[s, I_REG_OFF]
    side = ipar[s, I_SIDE]
    curv = fpar[s, F_CURV] if R > 0 else 0.0
    u1p = fst[s, S_U1P]
    filt = ipar[s, I_FILT]
    xdel = ipar[s, I_XDELAY]
    outm = ipar[s, I_OUT]
    prow = ipar[s, I_PROBE]
    goff = ipar[s, I_GT_OFF]
    fp = fpar[s]
    dt = fp[F_DT]
    A = fp[F_A]
    t0 = fp[F_T0]
    alpha = fp[F_ALPHA]
    b0 = fp[F_B0]
    a1 = fp[F_A1]
    eta = fp[F_ETA]
    gain = fp[F_GAIN]
    tdx = fp[F_TDX]
    hrel = int(fp[F_HREL])
    nd = ipar[s, I_NDISP]
    ad = fp[F_ADISP]
    nb = ipar[s, I_NSOS]
    fsos = fp[F_SOS:F_SOS + 2 * MAX_SOS]
    b0t = fp[F_B0T]
    gk = 1.0 - fp[F_B0S]          # glide b0 <- gk b0 + gc: one multiply-add on
    gc = fp[F_B0S] * b0t          # its recurrence (b0 += b0s (b0t - b0) has two)
    boff = ipar[s, I_BOFF]
    blen = ipar[s, I_BLEN]
    bdt = fp[F_BDT]
    bds = fp[F_BDS]
    tor = fp[F_TOR]
    tog = fp[F_TOG]
    st = fst[s]
    pm = ipar[s, I_POS]
    exc = ipar[s, I_EXC]
    e = ipar[s, I_EXC_M]
    e_end = ipar[s, I_EXC_END]
    hlast = ipar[s, I_HLAST]
    g = st[S_G]
    peak = st[S_PEAK]
    r0 = ipar[s, I_ROW]
    r1 = r0 + 1
    two = ipar[s, I_BUS] == 1 and mix.shape[0] > r1
    pan = fp[F_PAN]
    cpl = ipar[s, I_CPL]
    telem = ipar[s, I_TELEM]
    tmin = fp[F_TGAP]
    tcn = st[S_TC_N]
    tep = st[S_TC_EP]
    tgap = st[S_TC_GAP]
    tpts = st[S_TC_PTS]
    hcn = st[S_HC_N]
    hep = st[S_HC_EP]
    hgap = st[S_HC_GAP]
    hpk = st[S_HF_PK]
    for i in range(n):
        if exc == EXC_ENDED:
            # the excitation ended on the previous sample: fold its constant
            # g into the ring before this sample, where the fast path does
            _fold_offset(ring, off, P, pm, k, g)
            g = 0.0
            exc = EXC_NONE
        pm += 1
        if pm == P:
            pm = 0
        # 2. excitation at k: outgoing = incoming + g on both rails
        j1 = pm - k
        if j1 < 0:
            j1 += P
        j2 = pm + k
        if j2 >= P:
            j2 -= P
        F = 0.0
        if exc != EXC_NONE:
            if exc <= EXC_BIWA:
                g = _g_at(exc, e, dt, A, t0, alpha)
                if e >= e_end:
                    exc = EXC_ENDED
            elif exc == EXC_GTABLE:
                g = U[goff + e]
                if e >= e_end - 1:
                    exc = EXC_ENDED
            elif exc == EXC_FELT:
                # the felt layer, sub-stepped inside this step; at sample 0
                # it arrives on the string (as the lumped hammer does)
                I1 = ring[off + j1] - ring[off + j2]
                if e == 0:
                    felt_layer_start(U, goff, I1 + g)
                    w = 0.0
                    contact = False
                    st[S_HW] = 0.0
                    st[S_HZ] = I1 + g
                else:
                    g, F, w, comp, core = felt_layer_step(I1, g, U, goff)
                    contact = F > 0.0
                    st[S_HW] = comp
                    st[S_HZ] = core
                if contact:
                    hlast = e
                if e >= e_end or (hlast >= 0 and e - hlast > hrel and w < 0.0):
                    exc = EXC_ENDED          # the hammer is gone
            else:
                I1 = ring[off + j1] - ring[off + j2]
                # the general step only: the reference does not take the
                # steady-contact shortcut of the fast path
                g, F, w, contact = _hammer_general(I1, g, fp, st)
                if contact:
                    hlast = e
                if e >= e_end or (hlast >= 0 and e - hlast > hrel and w < 0.0):
                    exc = EXC_ENDED          # the hammer is gone
            e += 1
        gt = g                        # injected at k this sample
        if gt != 0.0:
            ring[off + j1] += gt
            ring[off + j2] -= gt
        # 3. termination region
        ncont = 0
        for r in range(R):
            nn = r + 1
            ju = pm - nn
            if ju < 0:
                ju += P
            jv = pm + nn
            if jv >= P:
                jv -= P
            u = ring[off + ju] - ring[off + jv]
            if nn == k:
                u -= gt
            Ur = U[roff + r]
            if side * (u - Ur) > 0.0:
                ring[off + ju] += Ur - u
                ncont += 1
        if curv > 0.0:
            # the first cell's sub-cell contact (k >= 3): u_r(0) += delta,
            # from u(1) now (after its clamp), at the last sample, and at
            # the next without delta (slot pm there, against vl(2) now)
            jm = pm - 1
            if jm < 0:
                jm += P
            jp = pm + 1
            if jp >= P:
                jp -= P
            jq = pm + 2
            if jq >= P:
                jq -= P
            u = ring[off + jm] - ring[off + jp]
            U1 = side * U[roff]
            if U1 > 0.0 and U1 < np.inf:
                dl = _subcell_delta(side * (ring[off + pm] - ring[off + jq]), side * u1p, U1,
                                    curv * U1)
                if dl != 0.0:
                    ring[off + pm] += side * dl
                    ncont += 1
            u1p = u
        # 4. far end
        if filt == 1:
            b0 = gk * b0 + gc             # the loss glide toward b0t
            x, y, jn = _far_end(ring, off, P, N, pm, b0, a1, eta, xdel, nd, ad, st, nb, fsos)
            if blen > 0:
                y = _bend_line(y, st, U, boff, blen, bdt, bds, tor, tog)
                ring[off + jn] = y
            ubn = 0.0
            if cpl != CPL_NONE:
                # the end moves with the bridge: the wave leaving it is the
                # loop filter's minus the bridge's displacement (an external
                # bridge's less the offset the string eases off since it
                # joined it)
                ubn = ubx[uo + i]
                if cpl == CPL_EXTERNAL:
                    ubn -= st[S_UBOFF]
                    st[S_UBOFF] *= fp[F_UBOD]
                y -= ubn
                ring[off + jn] = y
        else:
            x = 0.0
            y = 0.0
        # output
        uk = ring[off + j1] - ring[off + j2] - gt
        if outm == 0:
            sig = uk
        else:
            ja = pm - N + 1
            if ja < 0:
                ja += P
            jb = pm - N - 1
            if jb < 0:
                jb += P
            if filt == 1:
                # the force on the bridge: the loop filter stands just before
                # the end, so the wave that reaches it is z = y + u_b and the
                # force is Z (v_in - v_out) = T/dx (dz + dy) (each a step's
                # difference; vl(N-1) = ring[jb] is the last sample's y)
                sig = tdx * (2.0 * (y - ring[off + jb]) + (ubn - st[S_UBP]))
                st[S_UBP] = ubn
            else:
                # ideal end: u(N-1) - u(N) with u(N) = 0, vl(N-1) = ring[jb]
                sig = tdx * (ring[off + ja] - ring[off + jb])
            if cpl >= 0:
                cf[0] += sig
        v = gain * sig
        if two:
            mix[r0, o0 + i] += v - pan * v
            mix[r1, o0 + i] += pan * v
        else:
            mix[r0, o0 + i] += v
        a = abs(v)
        if a > peak:
            peak = a
        if telem == 1:
            # contact telemetry, as synth.analysis.contacts.contact_summary
            # counts it: a run of contact starts an episode unless it follows
            # the last contact by fewer than tmin samples
            if ncont > 0:
                tcn += 1.0
                if tgap < 0.0 or tgap >= tmin:
                    tep += 1.0
                tgap = 0.0
                if ncont > tpts:
                    tpts = float(ncont)
            elif tgap >= 0.0:
                tgap += 1.0
            if F > 0.0:
                hcn += 1.0
                if hgap < 0.0 or hgap >= tmin:
                    hep += 1.0
                hgap = 0.0
                if F > hpk:
                    hpk = F
            elif hgap >= 0.0:
                hgap += 1.0
        if prow >= 0:
            pi = po0 + i // psub
            probe[prow, P_U, pi] = uk
            probe[prow, P_CONTACT, pi] = ncont
            probe[prow, P_G, pi] = gt
            probe[prow, P_F, pi] = F
            probe[prow, P_W, pi] = st[S_HW]
            probe[prow, P_Z, pi] = st[S_HZ]
    ipar[s, I_POS] = pm
    ipar[s, I_EXC] = exc
    ipar[s, I_EXC_M] = e
    ipar[s, I_HLAST] = hlast
    fp[F_B0] = b0
    st[S_G] = g
    st[S_PEAK] = peak
    st[S_U1P] = u1p
    if telem == 1:
        st[S_TC_N] = tcn
        st[S_TC_EP] = tep
        st[S_TC_GAP] = tgap
        st[S_TC_PTS] = tpts
        st[S_HC_N] = hcn
        st[S_HC_EP] = hep
        st[S_HC_GAP] = hgap
        st[S_HF_PK] = hpk


@njit(**JIT_OPTS)
def _excite_chunk(s, ring, ipar, fpar, fst, U, C, gbuf):
    """Step 2 of the fast path over a chunk of C samples: inject the
    excitation at k and record the injected g per sample in ``gbuf``.
    (Kept out of
    :func:`_chunk_fast`: with the hammer code inside it, the region's
    min/max loops ran 35 % slower.)"""
    off = ipar[s, I_OFF]
    N = ipar[s, I_N]
    P = 2 * N
    k = ipar[s, I_K]
    st = fst[s]
    m0 = ipar[s, I_POS]
    exc = ipar[s, I_EXC]
    # gbuf holds the injected g per sample.  Within a chunk the incoming
    # wave at k does not depend on this chunk's injections (they leave k and
    # come back after 2k samples through the region, or 2(N-k) through the
    # far end, both longer than the chunk), so a hammer runs here exactly as
    # in the per-sample path.  An excitation that ends inside the chunk
    # (a hammer gone) keeps its last g for the rest of it, as the per-sample
    # path does, until the next chunk folds it into the ring.
    if exc != EXC_NONE:
        fp = fpar[s]
        dt = fp[F_DT]
        A = fp[F_A]
        t0 = fp[F_T0]
        alpha = fp[F_ALPHA]
        hrel = int(fp[F_HREL])
        goff = ipar[s, I_GT_OFF]
        hlast = ipar[s, I_HLAST]
        e = ipar[s, I_EXC_M]
        e_end = ipar[s, I_EXC_END]
        pm = m0
        g = st[S_G]
        n_step = C               # samples left to step one by one
        if exc >= EXC_HAMMER3 and hlast >= 0 and st[S_HY] == 0.0 and st[S_HPHI] == 0.0:
            # a hammer in free flight after a contact (felt relaxed): if its
            # compression w = z - u(k) stays <= 0 over the whole chunk, no
            # step touches the string and the chunk is a constant injection
            # (the incoming u(k) of every sample is in the ring already)
            vz = fp[F_HV] - fp[F_HMC] * g
            z0 = st[S_HZ]
            j1 = (m0 + 1 - k) % P
            j2 = (m0 + 1 + k) % P
            wmax = -np.inf
            w = 0.0
            for i in range(C):
                w = z0 + (i + 1) * dt * vz - (ring[off + j1] - ring[off + j2]) - g
                wmax = max(wmax, w)
                j1 += 1
                if j1 == P:
                    j1 = 0
                j2 += 1
                if j2 == P:
                    j2 = 0
            if wmax <= 0.0:
                gt = g
                j1 = (m0 + 1 - k) % P
                j2 = (m0 + 1 + k) % P
                for i in range(C):
                    ring[off + j1] += gt
                    ring[off + j2] -= gt
                    gbuf[i] = gt
                    j1 += 1
                    if j1 == P:
                        j1 = 0
                    j2 += 1
                    if j2 == P:
                        j2 = 0
                e += C
                st[S_HZ] = z0 + C * dt * vz
                st[S_HW] = w
                st[S_HIW] = 0.0
                st[S_HDG2] = 0.0
                st[S_HDG3] = 0.0
                st[S_HDG] = 0.0
                if e - 1 >= e_end or (e - 1 - hlast > hrel and w < 0.0):
                    exc = EXC_ENDED         # the hammer is gone
                n_step = 0
        for i in range(n_step):   # the caller ends the chunk at e_end at the latest
            pm += 1
            if pm == P:
                pm = 0
            j1 = pm - k
            if j1 < 0:
                j1 += P
            j2 = pm + k
            if j2 >= P:
                j2 -= P
            if exc > EXC_NONE:
                # (the same dispatch as the per-sample path's, written out:
                # as a shared function returning a tuple it cost 35 % more
                # per string-sample in hammer contact, 76 -> 103 ns)
                if exc <= EXC_BIWA:
                    g = _g_at(exc, e, dt, A, t0, alpha)
                    if e >= e_end:
                        exc = EXC_ENDED     # ended: folded at the start of the next chunk
                elif exc == EXC_GTABLE:
                    g = U[goff + e]
                    if e >= e_end - 1:
                        exc = EXC_ENDED
                else:
                    I1 = ring[off + j1] - ring[off + j2]
                    g1, F, w, contact = _hammer_steady(I1, g, fp, st)
                    if not contact:
                        g1, F, w, contact = _hammer_general(I1, g, fp, st)
                    g = g1
                    if contact:
                        hlast = e
                    if e >= e_end or (hlast >= 0 and e - hlast > hrel and w < 0.0):
                        exc = EXC_ENDED     # the hammer is gone
                e += 1
            ring[off + j1] += g
            ring[off + j2] -= g
            gbuf[i] = g
        ipar[s, I_EXC] = exc
        ipar[s, I_EXC_M] = e
        ipar[s, I_HLAST] = hlast
        st[S_G] = g


@njit(inline="always", **JIT_OPTS)
def _ring_get_in(ring, off, P, j, dst, sc):
    """dst = sc * the ring slots j, j+1, ... (mod P); 0 <= j < P,
    len(dst) <= P; ``sc`` is +-1 (exact).  Two contiguous loops split at
    the wrap (no wrap test per element), over slice views with the bare
    loop index: an index such as d0 + a, whose sign numba cannot know, gets
    a negative-index fix-up per element that stops the loop vectorising.
    (The ring helpers take no constant arguments: numba compiles a separate
    copy of a function for every literal constant passed to it.)

    Inlined into its caller (``inline="always"``): the per-chunk callers
    of the fast path take it so (a call passes each array as its fields,
    and a slice argument costs as much again); :func:`_ring_get` is the
    same as a function.  One multiply by
    +-1 per element: the caller's fast-math flags cannot change it."""
    n = dst.shape[0]
    n1 = P - j
    if n1 > n:
        n1 = n
    r = ring[off + j:off + j + n1]
    d = dst[0:n1]
    for a in range(n1):
        d[a] = sc * r[a]
    r = ring[off:off + n - n1]
    d = dst[n1:n]
    for a in range(n - n1):
        d[a] = sc * r[a]


@njit(**JIT_OPTS)
def _ring_get(ring, off, P, j, dst, sc):
    """:func:`_ring_get_in` as a function (for the callers outside the
    per-chunk fast path, and the serial ones)."""
    _ring_get_in(ring, off, P, j, dst, sc)


@njit(inline="always", **JIT_OPTS)
def _ring_put_in(ring, off, P, j, src, sc):
    """The ring slots j, j+1, ... (mod P) = sc * src (see
    :func:`_ring_get_in`; inlined)."""
    n = src.shape[0]
    n1 = P - j
    if n1 > n:
        n1 = n
    r = ring[off + j:off + j + n1]
    d = src[0:n1]
    for a in range(n1):
        r[a] = sc * d[a]
    r = ring[off:off + n - n1]
    d = src[n1:n]
    for a in range(n - n1):
        r[a] = sc * d[a]


@njit(**JIT_OPTS)
def _ring_put(ring, off, P, j, src, sc):
    """:func:`_ring_put_in` as a function."""
    _ring_put_in(ring, off, P, j, src, sc)


@njit(**JIT_OPTS)
def _ring_add(ring, off, P, j, src, sc):
    """The ring slots j, j+1, ... (mod P) += sc * src (see :func:`_ring_get`)."""
    n = src.shape[0]
    n1 = P - j
    if n1 > n:
        n1 = n
    r = ring[off + j:off + j + n1]
    d = src[0:n1]
    for a in range(n1):
        r[a] += sc * d[a]
    r = ring[off:off + n - n1]
    d = src[n1:n]
    for a in range(n - n1):
        r[a] += sc * d[a]


@njit(**JIT_OPTS)
def _region_pass(src, dst, vw, W, C, R, n0, n1, n2, n3, U0, U1, U2, U3):
    """Four region points of the fast path's termination step, ``dst = src``
    with the points' constraints applied (min; see :func:`_region_chunk`).

    Element i of the window is the right-going characteristic that meets
    point n where R - n <= i < R - n + C, against the left-going value
    ``vw[i + 2n - R - 1]``.  Points n0 <= n1 <= n2 <= n3 (one may repeat:
    min is idempotent).  Reading ``src`` and writing the other buffer
    ``dst`` keeps the select a plain vector min: in place, LLVM turns
    "store min(x, a[i]) to a[i]" into a masked store of x, which AMD CPUs
    before Zen 4 run as microcode (vmaskmovpd: several times slower).
    """
    lo0 = R - n0
    lo1 = R - n1
    lo2 = R - n2
    lo3 = R - n3
    for i in range(lo3):
        dst[i] = src[i]
    s = src[lo0 + C:W]
    o = dst[lo0 + C:W]
    for t in range(W - lo0 - C):
        o[t] = s[t]
    d0 = 2 * n0 - R - 1
    d1 = 2 * n1 - R - 1
    d2 = 2 * n2 - R - 1
    d3 = 2 * n3 - R - 1
    i0 = lo0                      # every point's window holds [lo0, lo3 + C)
    i1 = lo3 + C
    if i1 > i0:
        m_ = i1 - i0
        s = src[i0:i1]
        o = dst[i0:i1]
        v0 = vw[i0 + d0:i1 + d0]
        v1 = vw[i0 + d1:i1 + d1]
        v2 = vw[i0 + d2:i1 + d2]
        v3 = vw[i0 + d3:i1 + d3]
        for t in range(m_):
            m = s[t]
            x = U0 + v0[t]
            m = x if x < m else m
            x = U1 + v1[t]
            m = x if x < m else m
            x = U2 + v2[t]
            m = x if x < m else m
            x = U3 + v3[t]
            m = x if x < m else m
            o[t] = m
        _region_edge(src, dst, vw, C, lo3, i0, lo0, lo1, lo2, lo3, d0, d1, d2, d3, U0, U1, U2, U3)
        _region_edge(src, dst, vw, C, i1, lo0 + C, lo0, lo1, lo2, lo3, d0, d1, d2, d3,
                     U0, U1, U2, U3)
    else:
        _region_edge(src, dst, vw, C, lo3, lo0 + C, lo0, lo1, lo2, lo3, d0, d1, d2, d3,
                     U0, U1, U2, U3)


@njit(**JIT_OPTS)
def _region_edge(src, dst, vw, C, ia, ib, lo0, lo1, lo2, lo3, d0, d1, d2, d3, U0, U1, U2, U3):
    """Elements ia .. ib-1 of a :func:`_region_pass`, which only some of
    the four windows hold (a few per pass)."""
    for i in range(ia, ib):
        m = src[i]
        if lo0 <= i < lo0 + C:
            x = U0 + vw[i + d0]
            m = x if x < m else m
        if lo1 <= i < lo1 + C:
            x = U1 + vw[i + d1]
            m = x if x < m else m
        if lo2 <= i < lo2 + C:
            x = U2 + vw[i + d2]
            m = x if x < m else m
        if lo3 <= i < lo3 + C:
            x = U3 + vw[i + d3]
            m = x if x < m else m
        dst[i] = m


@njit(**JIT_OPTS)
def _region_chunk(ring, off, P, m0, C, U, roff, R, side, acc, tmp, vw, curv, st):
    """Step 3 of the fast path: each right-going characteristic leaves the
    region with the min (side +1; max for side -1) of its entry value and
    U(n) + vl(n) along its path.  The values are multiplied by ``side`` on
    the way in and out, so one min serves both sides (max(a, b) =
    -min(-a, -b), exact); points where the profile is side * inf (no
    contact) are skipped; the points are taken four at a time
    (:func:`_region_pass`), ping-ponging between ``acc`` and ``tmp``.

    With ``curv`` > 0 (``F_CURV``) the first cell's sub-cell contact runs
    first, sample by sample (:func:`_subcell_chunk`): it adds to each
    characteristic's entry value its delta, which depends on the one
    before it through point 1; ``st`` is the string's state row
    (``S_U1P``)."""
    W = C + R - 1
    sc = float(side)
    b = m0 + 1 - R                 # first characteristic slot (unwrapped)
    if b < 0:
        b += P
    _ring_get(ring, off, P, b, acc[0:W], sc)
    jv = m0 + 2
    if jv >= P:
        jv -= P
    _ring_get(ring, off, P, jv, vw[0:W], sc)
    last = 0.0
    if curv > 0.0:
        last = _subcell_chunk(ring, off, P, m0, acc, vw, C, R, sc, sc * U[roff], curv, st)
    src = acc
    dst = tmp
    q = 0
    n0 = n1 = n2 = n3 = R - R       # (not the constant 0: see _ring_get)
    U0 = U1 = U2 = U3 = 0.0
    for r in range(R):
        Un = sc * U[roff + r]
        if Un == np.inf:
            continue
        nn = r + 1
        if q == 0:
            n0 = nn
            U0 = Un
        elif q == 1:
            n1 = nn
            U1 = Un
        elif q == 2:
            n2 = nn
            U2 = Un
        else:
            n3 = nn
            U3 = Un
        q += 1
        if q == 4:
            _region_pass(src, dst, vw, W, C, R, n0, n1, n2, n3, U0, U1, U2, U3)
            src, dst = dst, src
            q = 0
    if q > 0:
        if q < 2:
            n1 = n0
            U1 = U0
        if q < 3:
            n2 = n1
            U2 = U1
        n3 = n2
        U3 = U2
        _region_pass(src, dst, vw, W, C, R, n0, n1, n2, n3, U0, U1, U2, U3)
        src = dst
    _ring_put(ring, off, P, b, src[0:W], sc)
    if last != 0.0:
        # the delta of the chunk's last sample, on slot m0 + C: it enters
        # the region in the next chunk
        j = m0 + C
        if j >= P:
            j -= P
        ring[off + j] += sc * last


@njit(**JIT_OPTS)
def _subcell_needed(sm, vn, ut, up, base, lim):
    """Whether a fast-path chunk must solve the first cell's sub-cell
    contact at this sample (:func:`_subcell_chunk`, :func:`_subcell_ring`;
    side-scaled: ``sm`` the wave leaving x = 0 now, ``vn`` = vl(2), ``ut`` =
    sm - vn = u(1) at the next sample without delta, ``up`` u(1) at the last
    sample, ``base`` = U1 - G, ``lim`` = U1 + G).  Not when the delta can
    change no sample:

    * u(1) at neither sample past ``base`` (r <= 0 at both): the delta is 0
      (the first return of :func:`_subcell_delta`, the same test without
      its divisions);
    * ``ut`` past U1 + G by more than 1e-9 of the values: the delta lies in
      [-G, 0] (minus the secant slope of the potential, whose derivative
      G q^2 lies in [0, G]), so sm + delta stays past U1 + vn and point 1's
      clamp at the next sample replaces it by U1 + vn, whatever delta was
      (the fast path's clamp is ``min(sm + delta, U1 + vn)``: its result
      does not depend on the value it discards).  With the sitar played
      loud this is half the samples with a delta; the solve is the sub-cell
      contact's whole cost (docs/benchmarks.md, "The sitar's sub-cell
      contact")."""
    if not (ut > base or up > base):
        return False
    return not (ut - lim > 1e-9 * (abs(sm) + abs(vn) + lim))


@njit(**JIT_OPTS)
def _subcell_chunk(ring, off, P, m0, acc, vw, C, R, sc, U1, curv, st):
    """The first cell's sub-cell contact over a fast-path chunk, on the
    region's windows (side-scaled by ``sc``: ``U1`` = side U(1)).  At the
    chunk's sample t (time m = m0 + 1 + t) point 1 holds characteristic
    ``acc[R - 1 + t]`` against ``vw[t]``; its clamp (the region pass's
    min, which then repeats it exactly) gives u(1) now; u(1) at the next
    sample without delta is the characteristic leaving x = 0 now (slot m,
    ``acc[R + t]``) against ``vw[t + 1]``; u(1) at the last sample is the
    previous t's (``st[S_U1P]`` at t = 0).  :func:`_subcell_delta` gives
    the delta added to slot m, which passes point 1 at the next sample: a
    recursion, hence sample by sample.  Returns the last sample's delta
    (its slot m0 + C lies past the window; the caller adds it) and
    updates ``st[S_U1P]``."""
    W = C + R - 1
    last = 0.0
    i0 = R - 1
    if not (U1 > 0.0 and U1 < np.inf):
        # out of reach (a buzz of 0): no contact, u(1) kept for the state
        st[S_U1P] = sc * (acc[i0 + C - 1] - vw[C - 1])
        return 0.0
    G = curv * U1
    base = U1 - G
    lim = U1 + G
    up = sc * st[S_U1P]
    for t in range(C):
        v = vw[t]
        a = acc[i0 + t]
        x = U1 + v
        if x < a:
            a = x
            acc[i0 + t] = a
        if t < C - 1:
            sm = acc[i0 + t + 1]
        else:
            j = m0 + C
            if j >= P:
                j -= P
            sm = sc * ring[off + j]
        if t + 1 < W:
            vn = vw[t + 1]
        else:
            j = m0 + 3 + t
            if j >= P:
                j -= P
            vn = sc * ring[off + j]
        ut = sm - vn
        if _subcell_needed(sm, vn, ut, up, base, lim):
            dl = _subcell_delta(ut, up, U1, G)
            if dl != 0.0:
                if t < C - 1:
                    acc[i0 + t + 1] += dl
                else:
                    last = dl
        up = a - v
    st[S_U1P] = sc * up
    return last


@njit(**JIT_OPTS)
def _subcell_ring(ring, off, P, m0, C, sc, U1, curv, st, X):
    """The first cell's sub-cell contact over a fast-path chunk whose
    points 2..R are out of reach (their passes skipped): the same steps as
    :func:`_subcell_chunk` (point 1's clamp, delta, ``st[S_U1P]``) on the
    ring's slots m0 .. m0 + C + 2 alone, copied to ``X`` (C + 3 values,
    side-scaled by ``sc``; ``U1`` = side U(1)): at sample t point 1 holds
    ``X[t]`` against ``X[t + 2]``, and u(1) at the next sample without
    delta is ``X[t + 1] - X[t + 3]``, which no earlier step has changed."""
    j = m0
    _ring_get(ring, off, P, j, X, sc)
    if not (U1 > 0.0 and U1 < np.inf):
        st[S_U1P] = sc * (X[C - 1] - X[C + 1])
        return
    G = curv * U1
    base = U1 - G
    lim = U1 + G
    up = sc * st[S_U1P]
    for t in range(C):
        v = X[t + 2]
        a = X[t]
        x = U1 + v
        if x < a:
            a = x
            X[t] = a
        sm = X[t + 1]
        vn = X[t + 3]
        ut = sm - vn
        if _subcell_needed(sm, vn, ut, up, base, lim):
            dl = _subcell_delta(ut, up, U1, G)
            if dl != 0.0:
                X[t + 1] += dl
        up = a - v
    st[S_U1P] = sc * up
    _ring_put(ring, off, P, j, X[0:C + 1], sc)


@njit(**SERIAL_OPTS)
def _sections(v_, n, st, cnt, s0, s1, s2, s3, c0, c1, c2, c3):
    """``cnt`` (1..4) first-order allpasses (c + z^-1)/(1 + c z^-1) in a row
    over v_[0:n], in place.  Section j has coefficient c_j and its state
    (x1, y1) at st[s_j], st[s_j + 1]; the states stay in registers for the
    run.  Written y = c x + x1 - c y1 and compiled without re-association,
    so the recurrence on y1 is one multiply-add (4 cycles a sample);
    re-associated to c (x - y1) + x1 it is a subtraction and a
    multiply-add."""
    x0 = st[s0]
    y0 = st[s0 + 1]
    if cnt == 1:
        for i in range(n):
            v = v_[i]
            y0 = c0 * v + x0 - c0 * y0
            x0 = v
            v_[i] = y0
    elif cnt == 2:
        x1 = st[s1]
        y1 = st[s1 + 1]
        for i in range(n):
            v = v_[i]
            y0 = c0 * v + x0 - c0 * y0
            x0 = v
            y1 = c1 * y0 + x1 - c1 * y1
            x1 = y0
            v_[i] = y1
        st[s1] = x1
        st[s1 + 1] = y1
    elif cnt == 3:
        x1 = st[s1]
        y1 = st[s1 + 1]
        x2 = st[s2]
        y2 = st[s2 + 1]
        for i in range(n):
            v = v_[i]
            y0 = c0 * v + x0 - c0 * y0
            x0 = v
            y1 = c1 * y0 + x1 - c1 * y1
            x1 = y0
            y2 = c2 * y1 + x2 - c2 * y2
            x2 = y1
            v_[i] = y2
        st[s1] = x1
        st[s1 + 1] = y1
        st[s2] = x2
        st[s2 + 1] = y2
    else:
        x1 = st[s1]
        y1 = st[s1 + 1]
        x2 = st[s2]
        y2 = st[s2 + 1]
        x3 = st[s3]
        y3 = st[s3 + 1]
        for i in range(n):
            v = v_[i]
            y0 = c0 * v + x0 - c0 * y0
            x0 = v
            y1 = c1 * y0 + x1 - c1 * y1
            x1 = y0
            y2 = c2 * y1 + x2 - c2 * y2
            x2 = y1
            y3 = c3 * y2 + x3 - c3 * y3
            x3 = y2
            v_[i] = y3
        st[s1] = x1
        st[s1 + 1] = y1
        st[s2] = x2
        st[s2 + 1] = y2
        st[s3] = x3
        st[s3 + 1] = y3
    st[s0] = x0
    st[s0 + 1] = y0


@njit(**SERIAL_OPTS)
def _biquads(v_, n, st, fp, j0, cnt):
    """Second-order allpass sections j0 .. j0+cnt-1 (cnt 1..4) of the
    string's dispersion, (c2 + c1 z^-1 + z^-2) / (1 + c1 z^-1 + c2 z^-2),
    over v_[0:n] in place, states in registers for the run.  Direct form I,
    written y = (c2 (x - y2) + x2 + c1 x1) - c1 y1 and compiled without
    re-association, so that the recurrence on y1 is one multiply-add (the
    rest waits on values of earlier samples); a cascade's section j+1
    takes section j's output, so the sections of one pass overlap across
    samples."""
    q0 = S_SOS + 4 * j0
    a0 = fp[F_SOS + 2 * j0]
    b0 = fp[F_SOS + 2 * j0 + 1]
    x10 = st[q0]
    x20 = st[q0 + 1]
    y10 = st[q0 + 2]
    y20 = st[q0 + 3]
    if cnt == 1:
        for i in range(n):
            x = v_[i]
            y = (b0 * (x - y20) + x20 + a0 * x10) - a0 * y10
            x20 = x10
            x10 = x
            y20 = y10
            y10 = y
            v_[i] = y
    elif cnt == 2:
        q1 = q0 + 4
        a1 = fp[F_SOS + 2 * j0 + 2]
        b1 = fp[F_SOS + 2 * j0 + 3]
        y11 = st[q1 + 2]
        y21 = st[q1 + 3]
        for i in range(n):
            x = v_[i]
            y = (b0 * (x - y20) + x20 + a0 * x10) - a0 * y10
            x20 = x10
            x10 = x
            z = (b1 * (y - y21) + y20 + a1 * y10) - a1 * y11
            y20 = y10
            y10 = y
            y21 = y11
            y11 = z
            v_[i] = z
        st[q1] = y10
        st[q1 + 1] = y20
        st[q1 + 2] = y11
        st[q1 + 3] = y21
    elif cnt == 3:
        q1 = q0 + 4
        q2 = q0 + 8
        a1 = fp[F_SOS + 2 * j0 + 2]
        b1 = fp[F_SOS + 2 * j0 + 3]
        a2 = fp[F_SOS + 2 * j0 + 4]
        b2 = fp[F_SOS + 2 * j0 + 5]
        y11 = st[q1 + 2]
        y21 = st[q1 + 3]
        y12 = st[q2 + 2]
        y22 = st[q2 + 3]
        for i in range(n):
            x = v_[i]
            y = (b0 * (x - y20) + x20 + a0 * x10) - a0 * y10
            x20 = x10
            x10 = x
            z = (b1 * (y - y21) + y20 + a1 * y10) - a1 * y11
            y20 = y10
            y10 = y
            w = (b2 * (z - y22) + y21 + a2 * y11) - a2 * y12
            y21 = y11
            y11 = z
            y22 = y12
            y12 = w
            v_[i] = w
        st[q1] = y10
        st[q1 + 1] = y20
        st[q1 + 2] = y11
        st[q1 + 3] = y21
        st[q2] = y11
        st[q2 + 1] = y21
        st[q2 + 2] = y12
        st[q2 + 3] = y22
    else:
        q1 = q0 + 4
        q2 = q0 + 8
        q3 = q0 + 12
        a1 = fp[F_SOS + 2 * j0 + 2]
        b1 = fp[F_SOS + 2 * j0 + 3]
        a2 = fp[F_SOS + 2 * j0 + 4]
        b2 = fp[F_SOS + 2 * j0 + 5]
        a3 = fp[F_SOS + 2 * j0 + 6]
        b3 = fp[F_SOS + 2 * j0 + 7]
        y11 = st[q1 + 2]
        y21 = st[q1 + 3]
        y12 = st[q2 + 2]
        y22 = st[q2 + 3]
        y13 = st[q3 + 2]
        y23 = st[q3 + 3]
        for i in range(n):
            x = v_[i]
            y = (b0 * (x - y20) + x20 + a0 * x10) - a0 * y10
            x20 = x10
            x10 = x
            z = (b1 * (y - y21) + y20 + a1 * y10) - a1 * y11
            y20 = y10
            y10 = y
            w = (b2 * (z - y22) + y21 + a2 * y11) - a2 * y12
            y21 = y11
            y11 = z
            u = (b3 * (w - y23) + y22 + a3 * y12) - a3 * y13
            y22 = y12
            y12 = w
            y23 = y13
            y13 = u
            v_[i] = u
        st[q1] = y10
        st[q1 + 1] = y20
        st[q1 + 2] = y11
        st[q1 + 3] = y21
        st[q2] = y11
        st[q2 + 1] = y21
        st[q2 + 2] = y12
        st[q2 + 3] = y22
        st[q3] = y12
        st[q3 + 1] = y22
        st[q3 + 2] = y13
        st[q3 + 3] = y23
    st[q0] = x10
    st[q0 + 1] = x20
    st[q0 + 2] = y10
    st[q0 + 3] = y20


@njit(**SERIAL_OPTS)
def _head(xin, yo, n, st, fp, cnt, s0, s1, s2, s3, c0, c1, c2, c3):
    """The far end's first pass over a chunk: the loss glide
    (b0 <- gk b0 + gc, toward F_B0T), the one-pole loss
    y = b0 x - a1 y1, then ``cnt`` (1..4) allpass sections as in
    :func:`_sections`, from xin[0:n] into yo[0:n]."""
    b0 = fp[F_B0]
    gk = 1.0 - fp[F_B0S]
    gc = fp[F_B0S] * fp[F_B0T]
    a1 = fp[F_A1]
    lp = st[S_LP]
    x0 = st[s0]
    y0 = st[s0 + 1]
    if cnt == 1:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * xin[i] - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            yo[i] = y0
    elif cnt == 2:
        x1 = st[s1]
        y1 = st[s1 + 1]
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * xin[i] - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            y1 = c1 * y0 + x1 - c1 * y1
            x1 = y0
            yo[i] = y1
        st[s1] = x1
        st[s1 + 1] = y1
    elif cnt == 3:
        x1 = st[s1]
        y1 = st[s1 + 1]
        x2 = st[s2]
        y2 = st[s2 + 1]
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * xin[i] - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            y1 = c1 * y0 + x1 - c1 * y1
            x1 = y0
            y2 = c2 * y1 + x2 - c2 * y2
            x2 = y1
            yo[i] = y2
        st[s1] = x1
        st[s1 + 1] = y1
        st[s2] = x2
        st[s2 + 1] = y2
    else:
        x1 = st[s1]
        y1 = st[s1 + 1]
        x2 = st[s2]
        y2 = st[s2 + 1]
        x3 = st[s3]
        y3 = st[s3 + 1]
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * xin[i] - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            y1 = c1 * y0 + x1 - c1 * y1
            x1 = y0
            y2 = c2 * y1 + x2 - c2 * y2
            x2 = y1
            y3 = c3 * y2 + x3 - c3 * y3
            x3 = y2
            yo[i] = y3
        st[s1] = x1
        st[s1 + 1] = y1
        st[s2] = x2
        st[s2 + 1] = y2
        st[s3] = x3
        st[s3 + 1] = y3
    st[s0] = x0
    st[s0 + 1] = y0
    st[S_LP] = lp
    fp[F_B0] = b0


@njit(**SERIAL_OPTS)
def _bend_chunk(yb, b, n, st, U, boff, blen, bdt, bds, tor, tog, hb):
    """The pitch-bend line over yb[b:b+n], in place.  While the delay glides,
    sample by sample (:func:`_bend_line`); at rest (the usual case) its
    third-order Lagrange read is a four-tap FIR over the line's last samples
    and the new ones, laid out contiguously in ``hb``: fixed taps, or, while
    a tune-out decays (tog S_TO), taps and integer delay computed per sample
    exactly as :func:`_bend_line` computes them (the same operations in the
    same order, each from its own sample's delay, so that the output does
    not depend on where chunks start)."""
    to = st[S_TO]
    if st[S_BD] != bdt:
        for i in range(n):
            yb[b + i] = _bend_line(yb[b + i], st, U, boff, blen, bdt, bds, tor, tog)
        return
    D = bdt + tog * to
    iD = int(D)
    if to != 0.0:
        # the history covers the run's integer delays (monotonic: its ends)
        iE = int(bdt + tog * (to * tor ** n))
        if iE > iD:
            iD = iE
        iD += 1
        if iD > blen - 2:
            iD = blen - 2
    w = int(st[S_BW])
    H = iD + 2                    # history: the H samples before this run
    j = w - H
    if j < 0:
        j += blen
    _ring_get(U, boff, blen, j, hb[0:H], 1.0)
    y_ = yb[b:b + n]
    hn = hb[H:H + n]
    for i in range(n):
        hn[i] = y_[i]
    if to == 0.0:
        f = D - iD
        h0, h1, h2, h3 = _lagrange3(f)
        t0 = hb[3:3 + n]
        t1 = hb[2:2 + n]
        t2 = hb[1:1 + n]
        for i in range(n):
            y_[i] = h0 * t0[i] + h1 * t1[i] + h2 * t2[i] + h3 * hb[i]
    else:
        for i in range(n):
            D = bdt
            D += tog * to
            to *= tor
            if abs(to) < 1e-9:
                to = 0.0
            k = int(D)
            f = D - k
            h0, h1, h2, h3 = _lagrange3(f)
            r = H + i - k + 1     # delay k - 1
            out = h0 * hb[r]
            out += h1 * hb[r - 1]
            out += h2 * hb[r - 2]
            out += h3 * hb[r - 3]
            y_[i] = out
        st[S_TO] = to
    m = n if n < blen else blen   # the new samples go into the line (its last blen)
    _ring_put(U, boff, blen, (w + n - m) % blen, hb[H + n - m:H + n], 1.0)
    st[S_BW] = (w + n) % blen


@njit(inline="always", **JIT_OPTS)
def _io(ipar, s):
    """Where a string's filter input starts in its far-end window: 0 with
    the extra unit delay (the register S_XD first), else 1."""
    return 0 if ipar[s, I_XDELAY] == 1 else 1


@njit(inline="always", **JIT_OPTS)
def _far_prep(s, ring, ipar, fst, C, xb, yb):
    """The far end's windows of a chunk: xb[1:C+2] gets the samples arriving
    at x = L (contiguous ring slots j0 .. j0+C), xb[0] the extra-delay
    register, yb[0] the previous chunk's last output.  Returns where the
    filter's input starts in xb (:func:`_io`)."""
    off = ipar[s, I_OFF]
    N = ipar[s, I_N]
    P = 2 * N
    m0 = ipar[s, I_POS]
    j0 = m0 + 1 - N
    if j0 < 0:
        j0 += P
    # xb[1 + i] = x_i, the sample arriving at x = L at the chunk's sample i,
    # for i = 0..C (x_C: its right neighbour at the last sample, u_r(N-1));
    # xb[0] = the extra-delay register, so the filter's input is
    # xb[i] (with the unit delay) or xb[1 + i] (without)
    xb[0] = fst[s, S_XD]
    _ring_get_in(ring, off, P, j0, xb[1:C + 2], 1.0)
    jp = j0 - 1
    if jp < 0:
        jp += P
    yb[0] = ring[off + jp]          # the previous chunk's last output, vl(N-1)
    return _io(ipar, s)


#: biquads the scalar head loop (:func:`_head_sos`) takes all of, with the
#: loss and first-order sections: four where the vector registers are 32
#: (AVX-512), three where they are 16 (AVX2, SSE2: a head of four kept its
#: states on the stack).  With more, the head takes one (16 registers) or
#: what passes of four leave (32), the rest run in passes (microbenchmark:
#: ``tools/bench_heads.py``; docs/benchmarks.md, "Issue 11's cost, third
#: pass")
_HEAD_SOS = 4 if VECTOR_REGS >= 32 else 3

#: biquads the lockstep head loop (:func:`_lanes_head`) takes all of, with
#: the loss and first-order sections: its states and coefficients (16 + 13
#: vectors with four biquads) fit in the 32 vector registers of an AVX-512
#: build, not in the 16 of an AVX2 or SSE2 one, where the head of four
#: biquads kept seven states on the stack (23 of 59 instructions a sample)
#: and cost 1.2-1.6 x the head of one and passes of the rest.  With more,
#: as :data:`_HEAD_SOS`.  Any split computes the same operations in the
#: same order.
_LANES_HEAD_SOS = 4 if VECTOR_REGS >= 32 else 2

#: the lockstep filters' vector type, by its zero's constructor: four lanes
#: (``<4 x double>``) where the target has AVX, two (one xmm register) in
#: an SSE2 build (:data:`synth.kernels.config.LANES`), where a
#: ``<4 x double>`` took two registers and two instructions an operation:
#: a key's three strings then run as two lanes and one, a bichord as two
#: (instead of four lanes of which two were idle), with half the registers
#: a loop.  The lanes compute the same operations either way.
_LANES_ZERO = splat4 if LANES == 4 else splat2

#: :data:`_LANES_HEAD_SOS` for a string with a dispersion section (two
#: first-order sections in the head, three more vectors): the same where
#: the lanes are four; none in two lanes (SSE2), where the head of one
#: biquad kept states on the stack and cost as much as the head alone and
#: a pass of it (``ns`` 2, 1-8 biquads, 2.1-2.4 ns a two-lane sample more
#: than the head of none and passes; docs/benchmarks.md, "Issue 11's cost,
#: fifth pass")
_LANES_HEAD_SOS2 = 0 if LANES == 2 else _LANES_HEAD_SOS


@njit(**JIT_OPTS)
def _far_filter(s, ring, ipar, fpar, fst, U, C, xb, yb, hb):
    """Step 4 of the fast path over a chunk, first half: the far-end filter
    on the C samples turning round at x = L (contiguous ring slots j0 ..
    j0+C-1), its state in registers, into yb[1:C+1] (not yet written back);
    xb[1:C+2] gets the arriving samples x_0 .. x_C and yb[0] the previous
    output.  :func:`_far_write` finishes the step."""
    st = fst[s]
    fp = fpar[s]
    io = _far_prep(s, ring, ipar, fst, C, xb, yb)
    xin = xb[io:io + C]             # the filter's input
    yo = yb[1:1 + C]                # its output
    # the allpass sections (dispersion, then tuning): the first four run in
    # the loss's pass, the rest four per pass (states in registers)
    nd = ipar[s, I_NDISP]
    ad = fp[F_ADISP]
    eta = fp[F_ETA]
    ns = nd + 1
    cnt = ns if ns < 4 else 4
    # section j: state column and coefficient (the nd dispersion sections,
    # then the tuning allpass)
    s0 = S_D0 if 0 < nd else S_APX
    c0 = ad if 0 < nd else eta
    s1 = S_D0 + 2 if 1 < nd else S_APX
    c1 = ad if 1 < nd else eta
    s2 = S_D0 + 4 if 2 < nd else S_APX
    c2 = ad if 2 < nd else eta
    s3 = S_D0 + 6 if 3 < nd else S_APX
    c3 = ad if 3 < nd else eta
    nb = ipar[s, I_NSOS]
    j = 0
    if nb > 0 and ns <= 2:
        # loss, first-order sections and the first biquads in one loop: all
        # of them up to _HEAD_SOS, else one (16 vector registers) or what
        # passes of four leave (32)
        if nb <= _HEAD_SOS:
            j = nb
        elif VECTOR_REGS >= 32:
            j = (nb - 1) % 4 + 1
        else:
            j = 1
        _head_sos(xin, yo, C, st, fp, ns, s0, s1, c0, c1, j)
        cnt = ns
    else:
        _head(xin, yo, C, st, fp, cnt, s0, s1, s2, s3, c0, c1, c2, c3)
    jb = j
    j = cnt
    while j < ns:
        cnt = ns - j
        if cnt > 4:
            cnt = 4
        s0 = S_D0 + 2 * j if j < nd else S_APX
        c0 = ad if j < nd else eta
        s1 = S_D0 + 2 * j + 2 if j + 1 < nd else S_APX
        c1 = ad if j + 1 < nd else eta
        s2 = S_D0 + 2 * j + 4 if j + 2 < nd else S_APX
        c2 = ad if j + 2 < nd else eta
        s3 = S_D0 + 2 * j + 6 if j + 3 < nd else S_APX
        c3 = ad if j + 3 < nd else eta
        _sections(yo, C, st, cnt, s0, s1, s2, s3, c0, c1, c2, c3)
        j += cnt
    j = jb
    while j < nb:
        # the rest in passes as even as passes of at most four allow (a
        # pass of one biquad waits on its own recurrence)
        left = nb - j
        passes = (left + 3) // 4
        cnt = (left + passes - 1) // passes
        _biquads(yo, C, st, fp, j, cnt)
        j += cnt
    if io == 0:
        st[S_XD] = xb[C]
    blen = ipar[s, I_BLEN]
    if blen > 0:
        _bend_chunk(yb, 1, C, st, U, ipar[s, I_BOFF], blen, fp[F_BDT], fp[F_BDS], fp[F_TOR],
                    fp[F_TOG], hb)


@njit(inline="always", **SERIAL_OPTS)
def _hmax4(v, peak):
    """The running maximum ``a if a > peak else peak`` over the lanes of v
    (comparisons only: inlined, the caller's fast-math flags change
    nothing)."""
    for k in range(4):
        a = lane(v, k)
        peak = a if a > peak else peak
    return peak


@njit(inline="always", **JIT_OPTS)
def _force_out(yo, yp, un, up, has_ub, m0, m1, two, g0, g1, C):
    """The bridge force of a chunk, v = 2 (yo - yp) (+ (un - up) if
    ``has_ub``), added to the buses (g0 v to m0 and, if ``two``, g1 v to
    m1); returns max |v| (from 0).  Four samples to a vector (the running
    maximum is a reduction LLVM does not vectorise without no-NaN
    fast-math; :func:`synth.kernels.lanes.max4` keeps its NaN rule), the
    same operations per sample as the scalar loop.

    Inlined into its callers (``inline="always"``, saving a call that
    passes six slices as their fields).  Its arithmetic keeps the serial
    kernels' fast-math flags (no re-association) whatever the caller's:
    the vector loops' is the lanes' (``synth.kernels.lanes``), which carry
    them, and the C % 4 samples after the last full vector go through
    :func:`_force_one`, a ``SERIAL_OPTS`` function (this was one
    ``SERIAL_OPTS`` function, not inlined, before 2026-11-27: the same
    samples)."""
    two4 = splat4(2.0)
    g04 = splat4(g0)
    g14 = splat4(g1)
    p4 = splat4(0.0)
    n4 = C - C % 4
    if has_ub and two:
        for i in range(0, n4, 4):
            v = two4 * (load4(yo, i) - load4(yp, i)) + (load4(un, i) - load4(up, i))
            store4(m0, i, load4(m0, i) + g04 * v)
            store4(m1, i, load4(m1, i) + g14 * v)
            p4 = max4(p4, abs4(v))
    elif has_ub:
        for i in range(0, n4, 4):
            v = two4 * (load4(yo, i) - load4(yp, i)) + (load4(un, i) - load4(up, i))
            store4(m0, i, load4(m0, i) + g04 * v)
            p4 = max4(p4, abs4(v))
    elif two:
        for i in range(0, n4, 4):
            v = two4 * (load4(yo, i) - load4(yp, i))
            store4(m0, i, load4(m0, i) + g04 * v)
            store4(m1, i, load4(m1, i) + g14 * v)
            p4 = max4(p4, abs4(v))
    else:
        for i in range(0, n4, 4):
            v = two4 * (load4(yo, i) - load4(yp, i))
            store4(m0, i, load4(m0, i) + g04 * v)
            p4 = max4(p4, abs4(v))
    peak = _hmax4(p4, 0.0)
    for i in range(n4, C):
        v, a0, a1 = _force_one(yo[i], yp[i], un[i], up[i], has_ub, m0[i], m1[i], g0, g1)
        m0[i] = a0
        if two:
            m1[i] = a1
        a = abs(v)
        peak = a if a > peak else peak
    return peak


@njit(**SERIAL_OPTS)
def _force_one(yo, yp, un, up, has_ub, m0, m1, g0, g1):
    """One sample of :func:`_force_out` after its last full vector: v and
    the buses' m0 + g0 v, m1 + g1 v, in the serial kernels' fast-math flags
    (a function of its own, not inlined by numba: inlined, its arithmetic
    would take the caller's flags; LLVM may still inline it, keeping each
    instruction's own).  The same samples as the scalar loop of the
    ``SERIAL_OPTS`` function :func:`_force_out` was before 2026-11-27 (not
    always those of the vector loop's lanes: written in lane 0 of vectors,
    the last bit of some samples differed)."""
    if has_ub:
        v = 2.0 * (yo - yp) + (un - up)
    else:
        v = 2.0 * (yo - yp)
    return v, m0 + g0 * v, m1 + g1 * v


@njit(inline="always", **JIT_OPTS)
def _far_write(s, ring, ipar, fpar, C, yb, mix, o0, ubw, has_ub):
    """Step 4, second half: write the far end's outputs yb[1:C+1] back into
    the ring and, for the bridge-force output (``I_OUT`` 1), add the output
    to the mix's buses (rows ``I_ROW`` and ``I_ROW`` + 1 of mix[:, o0:o0+C],
    split by ``F_PAN`` as :func:`_bus_add`), in the same pass.  Returns the
    chunk's peak output.

    The force on the bridge.  The loop filter (loss, dispersion, tuning)
    stands for the whole string but acts at x = L; read as sitting just
    before the end, the wave that reaches the end is its output z, and the
    end reflects it at once: the force is Z (v_in - v_out) = T/dx (dz + dy)
    with y = z - u_b the wave leaving (u_b the bridge's displacement: 0 on
    a rigid bridge), i.e. T/dx (2 dy + du_b), each d a step's difference
    (yb[0] = the last chunk's y; ubw[0:C+1] = u_b of the sample before the
    chunk and of its C samples, if ``has_ub``).  (Taking u(N-1) - u(N) of
    the grid instead, with the filter's input arriving at N, adds the
    incoming wave before the filter to the wave after it: for a dispersive
    loop, whose filter delays partial n by a phase phi_n, that is a comb
    |cos(phi_n / 2)| over the partials, -10 to -60 dB on some of them.)"""
    off = ipar[s, I_OFF]
    N = ipar[s, I_N]
    P = 2 * N
    j0 = ipar[s, I_POS] + 1 - N
    if j0 < 0:
        j0 += P
    _ring_put_in(ring, off, P, j0, yb[1:C + 1], 1.0)
    peak = 0.0
    if ipar[s, I_OUT] == 1:
        sc = fpar[s, F_GAIN] * fpar[s, F_TDX]
        r0 = ipar[s, I_ROW]
        two = ipar[s, I_BUS] == 1 and mix.shape[0] > r0 + 1
        pan = fpar[s, F_PAN]
        g0 = sc * (1.0 - pan) if two else sc
        g1 = sc * pan
        m0 = mix[r0, o0:o0 + C]
        m1 = mix[r0 + 1 if two else r0, o0:o0 + C]
        peak = _force_out(yb[1:1 + C], yb[0:C], ubw[1:1 + C], ubw[0:C], has_ub, m0, m1, two,
                          g0, g1, C)
        peak *= abs(sc)
    return peak


@njit(**JIT_OPTS)
def _far_chunk(s, ring, ipar, fpar, fst, U, C, xb, yb, hb, mix, ubx, o0):
    """Step 4 of the fast path over a chunk (:func:`_far_filter`, then
    :func:`_far_write`); a string on an external bridge (``I_CPL`` =
    ``CPL_EXTERNAL``) has the bridge's displacement ubx[o0:o0+C] subtracted
    from its outgoing wave (u(L) = that of the loop filter + u_b).
    Returns the chunk's peak output."""
    _far_filter(s, ring, ipar, fpar, fst, U, C, xb, yb, hb)
    if ipar[s, I_CPL] == CPL_EXTERNAL:
        yo = yb[1:1 + C]
        ubw = hb[0:C + 1]           # (no bend line on a bridge: hb is free)
        ubw[0] = fst[s, S_UBP]
        ub = ubx[o0:o0 + C]
        un = ubw[1:1 + C]
        eo = fst[s, S_UBOFF]
        if eo != 0.0:
            # the offset the string eases off since it joined the bridge
            dk = fpar[s, F_UBOD]
            for i in range(C):
                un[i] = ub[i] - eo
                eo *= dk
            fst[s, S_UBOFF] = eo if abs(eo) > 1e-30 else 0.0
        else:
            for i in range(C):
                un[i] = ub[i]
        for i in range(C):
            yo[i] -= un[i]
        fst[s, S_UBP] = un[C - 1]
        return _far_write(s, ring, ipar, fpar, C, yb, mix, o0, ubw, True)
    return _far_write(s, ring, ipar, fpar, C, yb, mix, o0, hb, False)


@njit(**JIT_OPTS)
def _bus_add(mix, o0, C, ob, r0, two, pan):
    """Add a string's chunk output ob[0:C] to the mix: all of it to bus 0
    (mix row r0), or (with ``two``) (1 - pan) of it to bus 0 and pan to
    bus 1 (row r0 + 1)."""
    m0 = mix[r0, o0:o0 + C]
    o = ob[0:C]
    if two:
        m1 = mix[r0 + 1, o0:o0 + C]
        g0 = 1.0 - pan
        for i in range(C):
            m0[i] += g0 * o[i]
            m1[i] += pan * o[i]
    else:
        for i in range(C):
            m0[i] += o[i]


#: hammered strings the fast path steps together (:func:`_render_group`)
GROUP = 4
#: their chunks' longest length (samples)
GROUP_CHUNK = 512
#: distance (samples) between the group's rows: 4288 bytes, 192 more than a
#: page, so that member m's row and member m+1's are not 4 KiB apart (a load
#: whose address matches an earlier store's in its low 12 bits waits for it:
#: "4K aliasing")
_GROW = GROUP_CHUNK + 24
#: the rows of incoming waves start here (1088 bytes past a page multiple
#: from the g rows)
_GIB = GROUP * _GROW + 40
#: scratch samples before the per-chunk windows (the group's g and I1 rows)
_SCRATCH_GROUP = _GIB + GROUP * _GROW + GROUP + 8
#: int64 work samples :func:`synth.kernels.render.render_bank` needs besides the
#: string list
IWORK_EXTRA = 8 * GROUP


@njit(inline="always", **JIT_OPTS)
def _fold_if_ended(s, ring, ipar, fst):
    """An excitation that ended on the last sample of the previous chunk:
    fold its constant g into the ring now, between chunks."""
    if ipar[s, I_EXC] == EXC_ENDED:
        _fold_offset(ring, ipar[s, I_OFF], 2 * ipar[s, I_N], ipar[s, I_POS], ipar[s, I_K],
                     fst[s, S_G])
        fst[s, S_G] = 0.0
        ipar[s, I_EXC] = EXC_NONE


@njit(**JIT_OPTS)
def _chunk_fast(s, ring, ipar, fpar, fst, U, C, o0, mix, scratch, ubx):
    """C samples of string s, operation by operation (C <= ipar[s, I_CHUNK]
    while an excitation runs, else <= ipar[s, I_CHUNK_FREE]).

    ``scratch`` (see :func:`scratch_length`) holds the injected g per
    sample, the region's three windows and the far end's buffers."""
    _fold_if_ended(s, ring, ipar, fst)
    gbuf = scratch[_SCRATCH_GROUP:_SCRATCH_GROUP + C]
    # ---- 2. excitation -------------------------------------------------------
    plucking = ipar[s, I_EXC] != EXC_NONE
    if plucking:
        _excite_chunk(s, ring, ipar, fpar, fst, U, C, gbuf)
    _chunk_rest(s, ring, ipar, fpar, fst, U, C, o0, mix, scratch[_SCRATCH_GROUP + C:], gbuf,
                plucking, ubx)


@njit(inline="always", **JIT_OPTS)
def _work_windows(work, C, R):
    """The three windows of a chunk's region and far-end steps, and the rest
    (bend history).  Windows Wm samples apart with Wm = 168 mod 512: 1344
    and 2688 bytes apart modulo a 4 KiB page whatever the chunk, so that no
    load of one window waits on a store to another at the same low 12
    address bits ("4K aliasing": with C + R + 2 apart the plain-x86-64
    build of the region ran at 6.7 or 16 ns per sample depending on the
    chunk length)."""
    Wm = C + R + 2
    Wm += (168 - Wm) % 512
    return work[0:Wm], work[Wm:2 * Wm], work[2 * Wm:3 * Wm], work[3 * Wm:]


@njit(inline="always", **JIT_OPTS)
def _pairs_below(r, n, th):
    """Whether |r[a] - r[a + 2]| < th for a = 0 .. n - 3: blocks of 64
    pairs, leaving at the first block with one at or over ``th`` (a NaN
    counts as over).  Inlined into :func:`_out_of_reach`."""
    a0 = 0
    while a0 < n - 2:
        a1 = a0 + 64
        if a1 > n - 2:
            a1 = n - 2
        x = r[a0:a1]
        y = r[a0 + 2:a1 + 2]
        # four running maxima of |x - y| in the lanes of a vector, and their
        # sum, which carries a NaN to the end (a NaN counts as over)
        k = a1 - a0
        k4 = k - k % 4
        m4 = splat4(0.0)
        z4 = splat4(0.0)
        for t in range(0, k4, 4):
            d = abs4(load4(x, t) - load4(y, t))
            m4 = max4(m4, d)
            z4 = z4 + d
        m = _hmax4(m4, 0.0)
        z = lane(z4, 0) + lane(z4, 1) + lane(z4, 2) + lane(z4, 3)
        if z != z:
            return False
        for t in range(k4, k):
            d = abs(x[t] - y[t])
            m = m if d <= m else d
        if not (m < th):
            return False
        a0 = a1
    return True


@njit(inline="always", **JIT_OPTS)
def _out_of_reach(ring, off, P, m0, C, R, B):
    """Whether no point of the termination region can touch the obstacle
    during the fast-path chunk of C samples after time m0, so that its
    step may be skipped (it would not change a sample).

    Within the chunk the values that pass the region are those now in the
    ring's slots m0 + 1 - R .. m0 + C + R (loop positions 2N - C - R ..
    2N + R - 1): the chunk's limits keep every other operation out of
    them.  On that window w, u(n) at any time of the chunk is w[a] -
    w[a + 2n] for some a, a sum of n steps w[b] - w[b + 2], so
    |u(n)| <= n max |w[b] - w[b + 2]|; with B = min over the points of
    side U(n) / n (``F_REACH``), max |w[b] - w[b + 2]| < B keeps every
    point strictly off its obstacle (side (u - U) < 0), and no clamp
    fires.  The threshold keeps 1e-12 of B and of the window's values
    (at most |w[0]| + |w[1]| + (C + 2R) B) for the rounding of the region
    pass's U + v.  B = 0: never skipped; B = inf (no point can be
    touched): always."""
    if not (B > 0.0):
        return False
    if B == np.inf:
        return True
    L = C + 2 * R
    j = m0 + 1 - R
    if j < 0:
        j += P
    j1 = j + 1
    if j1 >= P:
        j1 -= P
    V = abs(ring[off + j]) + abs(ring[off + j1]) + L * B
    th = B * (1.0 - 1e-12) - 1e-12 * V
    if not (th > 0.0):
        return False
    n1 = P - j                     # window values before the ring's wrap
    if n1 > L:
        n1 = L
    # the window's part before the wrap, then the part after it (none if
    # n1 = L), in one loop: the inlined test has one copy of the pairs' loop
    a0 = off + j
    k = n1
    for _ in range(2):
        if not _pairs_below(ring[a0:a0 + k], k, th):
            return False
        a0 = off
        k = L - n1
    if n1 == L:
        return True
    # the (at most two) pairs across the wrap
    for a in range(n1 - 2, n1):
        if a >= 0 and a + 2 < L:
            b = j + a
            if b >= P:
                b -= P
            c = j + a + 2
            if c >= P:
                c -= P
            d = abs(ring[off + b] - ring[off + c])
            if not (d < th):
                return False
    return True


@njit(inline="always", **JIT_OPTS)
def _region_step(s, ring, ipar, fpar, fst, U, C, w1, w2, w3):
    """Step 3 of the fast path over a chunk (the termination region),
    skipped when no point can reach the obstacle (:func:`_out_of_reach`)."""
    R = ipar[s, I_REG_N]
    if R > 0:
        off = ipar[s, I_OFF]
        P = 2 * ipar[s, I_N]
        m0 = ipar[s, I_POS]
        curv = fpar[s, F_CURV]
        if _out_of_reach(ring, off, P, m0, C, R, fpar[s, F_REACH]):
            # (with the sub-cell contact the reach is that of points 2..R:
            # point 1 and the first cell are stepped here; delta and point
            # 1's clamp only move the string away from the obstacle)
            if curv > 0.0:
                sc = float(ipar[s, I_SIDE])
                _subcell_ring(ring, off, P, m0, C, sc, sc * U[ipar[s, I_REG_OFF]], curv, fst[s],
                              w1[0:C + 3])
            return
        _region_chunk(ring, off, P, m0, C, U, ipar[s, I_REG_OFF], R, ipar[s, I_SIDE], w1, w2, w3,
                      curv, fst[s])


@njit(**JIT_OPTS)
def _chunk_rest(s, ring, ipar, fpar, fst, U, C, o0, mix, work, gbuf, plucking, ubx):
    """Steps 3 and 4 of the fast path over a chunk whose excitation (step 2)
    has been injected (g per sample in ``gbuf`` if ``plucking``): the
    termination region, the far end and the output; ``work`` holds their
    windows."""
    w1, w2, w3, hb = _work_windows(work, C, ipar[s, I_REG_N])
    # ---- 3. termination region: min/max along right-going characteristics --
    _region_step(s, ring, ipar, fpar, fst, U, C, w1, w2, w3)
    # ---- 4. far end, and the output ----------------------------------------
    peak = fst[s, S_PEAK]
    if ipar[s, I_FILT] == 1:
        # (the bridge-force output goes to the mix in the far end's pass)
        pk = _far_chunk(s, ring, ipar, fpar, fst, U, C, w1, w2, hb, mix, ubx, o0)
        peak = pk if pk > peak else peak
    _chunk_end(s, ring, ipar, fpar, fst, C, o0, mix, w1, w2, w3, gbuf, plucking, False, peak)


@njit(inline="always", **JIT_OPTS)
def _chunk_end(s, ring, ipar, fpar, fst, C, o0, mix, w1, w2, w3, gbuf, plucking, out, peak):
    """The end of a fast-path chunk: the output (the far end's bridge force
    already in w3 if ``out``; the ideal end's bridge force; or u at k,
    read after the chunk's region and far-end steps), added to the mix's
    buses; the peak; the ring position advanced by C."""
    off = ipar[s, I_OFF]
    N = ipar[s, I_N]
    P = 2 * N
    k = ipar[s, I_K]
    m0 = ipar[s, I_POS]
    outm = ipar[s, I_OUT]
    gain = fpar[s, F_GAIN]
    if ipar[s, I_FILT] != 1 and outm == 1:
        # ideal far end: u(N-1) - u(N) = u_r(N-1) - vl(N-1)
        sc = gain * fpar[s, F_TDX]
        ja = m0 + 2 - N
        if ja < 0:
            ja += P
        jb = m0 - N
        if jb < 0:
            jb += P
        _ring_get_in(ring, off, P, ja, w1[0:C], 1.0)
        _ring_get_in(ring, off, P, jb, w2[0:C], 1.0)
        mo = w3[0:C]
        for i in range(C):
            v = sc * (w1[i] - w2[i])
            mo[i] = v
            a = abs(v)
            peak = a if a > peak else peak
        out = True
    if outm == 0:
        j1 = m0 + 1 - k
        if j1 < 0:
            j1 += P
        j2 = m0 + 1 + k
        if j2 >= P:
            j2 -= P
        _ring_get_in(ring, off, P, j1, w1[0:C], 1.0)
        _ring_get_in(ring, off, P, j2, w2[0:C], 1.0)
        mo = w3[0:C]
        if plucking:
            for i in range(C):
                v = gain * (w1[i] - w2[i] - gbuf[i])
                mo[i] = v
                a = abs(v)
                peak = a if a > peak else peak
        else:
            for i in range(C):
                v = gain * (w1[i] - w2[i])
                mo[i] = v
                a = abs(v)
                peak = a if a > peak else peak
        out = True
    if out:
        r0 = ipar[s, I_ROW]
        _bus_add(mix, o0, C, w3, r0, ipar[s, I_BUS] == 1 and mix.shape[0] > r0 + 1,
                 fpar[s, F_PAN])
    fst[s, S_PEAK] = peak
    m1 = m0 + C
    if m1 >= P:
        m1 -= P
    ipar[s, I_POS] = m1


#: the coupled groups' far-end buffers at the end of ``scratch``: per member
#: x (C + 2) and y (C + 1) windows, and the bridge's row, for chunks of at most
#: GROUP_CHUNK samples
_CW = GROUP_CHUNK + 8


def coupled_scratch(max_group: int) -> int:
    """Samples at the end of ``scratch`` for coupled groups of at most
    ``max_group`` strings (a group of G uses its last (2 G + 1) _CW)."""
    return (2 * int(max_group) + 1) * _CW


def scratch_length(max_block: int, max_region: int, max_bend: int,
                   max_group: int = MAX_CPL) -> int:
    """Samples of ``scratch`` that :func:`synth.kernels.render.render_bank`
    needs for chunks of at most ``max_block`` samples, regions of at most
    ``max_region`` points, pitch-bend lines of at most ``max_bend`` samples
    and coupled groups of at most ``max_group`` strings."""
    return (_SCRATCH_GROUP + max_block + 3 * (max_block + max_region + 2 + 512) + max_bend
            + max_block + 8 + coupled_scratch(max_group))


def sub_length(max_block: int) -> int:
    """Samples per bus of the staging mix (``sub``) that
    :func:`synth.kernels.render.render_bank` needs for strings on a finer
    grid (``I_SUB`` > 1)."""
    return max_block * MAX_SUB


@njit(**JIT_OPTS)
def _excite_group(ring, ipar, fpar, fst, C, mem, G, scratch, ist):
    """Step 2 of the fast path for G (<= GROUP) strings struck by hammers,
    over the same C samples, their hammer steps interleaved.

    A hammer step is a chain of dependent operations (a power or a series,
    divisions, a Newton or Halley solve: ~100 cycles); stepping several
    independent hammers in one loop lets the CPU overlap their chains.  The
    incoming displacement at k over the chunk is in the ring at its start
    (see :func:`_excite_chunk`), so it is gathered first; the injections
    follow as whole windows.  Member m's g per sample goes to
    ``scratch[m * _GROW:][:C]``; ``ist`` holds the members' integer
    state during the loop.
    """
    GC = _GROW                        # member m: g row at m GC, I1 row at ib0 + m GC
    ib0 = _GIB
    gm0 = _GIB + GROUP * _GROW        # current g per member
    for m in range(G):
        s = mem[m]
        off = ipar[s, I_OFF]
        P = 2 * ipar[s, I_N]
        k = ipar[s, I_K]
        m0 = ipar[s, I_POS]
        j1 = m0 + 1 - k
        if j1 < 0:
            j1 += P
        j2 = m0 + 1 + k
        if j2 >= P:
            j2 -= P
        # I1_i = u_r(k) + u_l(k) before the injection at sample i
        _ring_get(ring, off, P, j1, scratch[ib0 + m * GC:ib0 + m * GC + C], 1.0)
        _ring_get(ring, off, P, j2, scratch[m * GC:m * GC + C], 1.0)
        row = scratch[ib0 + m * GC:ib0 + m * GC + C]
        tmp = scratch[m * GC:m * GC + C]
        for i in range(C):
            row[i] -= tmp[i]
        st = fst[s]
        fp = fpar[s]
        g = st[S_G]
        scratch[gm0 + m] = g
        e = ipar[s, I_EXC_M]
        hlast = ipar[s, I_HLAST]
        e_end = ipar[s, I_EXC_END]
        hrel = int(fp[F_HREL])
        run = 1
        if hlast >= 0 and st[S_HY] == 0.0 and st[S_HPHI] == 0.0:
            # free flight after a contact (felt relaxed): if w = z - u(k) - g
            # stays <= 0 over the chunk, nothing touches the string
            vz = fp[F_HV] - fp[F_HMC] * g
            z0 = st[S_HZ]
            dt = fp[F_DT]
            wmax = -np.inf
            w = 0.0
            for i in range(C):
                w = z0 + (i + 1) * dt * vz - row[i] - g
                wmax = w if w > wmax else wmax
            if wmax <= 0.0:
                run = 0
                gr = scratch[m * GC:m * GC + C]
                for i in range(C):
                    gr[i] = g
                e += C
                st[S_HZ] = z0 + C * dt * vz
                st[S_HW] = w
                st[S_HIW] = 0.0
                st[S_HDG2] = 0.0
                st[S_HDG3] = 0.0
                st[S_HDG] = 0.0
                if e - 1 >= e_end or (e - 1 - hlast > hrel and w < 0.0):
                    ipar[s, I_EXC] = EXC_ENDED      # the hammer is gone
        ist[m] = run
        ist[GROUP + m] = e
        ist[2 * GROUP + m] = hlast
        ist[3 * GROUP + m] = e_end
        ist[4 * GROUP + m] = hrel
    # the interleaved steps
    for i in range(C):
        for m in range(G):
            if ist[m] != 0:
                s = mem[m]
                st = fst[s]
                fp = fpar[s]
                I1 = scratch[ib0 + m * GC + i]
                g = scratch[gm0 + m]
                g1, F, w, contact = _hammer_steady(I1, g, fp, st)
                if not contact:
                    g1, F, w, contact = _hammer_general(I1, g, fp, st)
                scratch[gm0 + m] = g1
                e = ist[GROUP + m]
                if contact:
                    ist[2 * GROUP + m] = e
                hl = ist[2 * GROUP + m]
                if e >= ist[3 * GROUP + m] or (hl >= 0 and e - hl > ist[4 * GROUP + m]
                                               and w < 0.0):
                    ist[m] = 0               # the hammer is gone: g stays
                    ipar[s, I_EXC] = EXC_ENDED
                ist[GROUP + m] = e + 1
                scratch[m * GC + i] = g1
            elif ipar[mem[m], I_EXC] == EXC_ENDED:
                scratch[m * GC + i] = scratch[gm0 + m]
    # state back, and the injections: outgoing = incoming + g on both rails
    for m in range(G):
        s = mem[m]
        ipar[s, I_EXC_M] = ist[GROUP + m]
        ipar[s, I_HLAST] = ist[2 * GROUP + m]
        fst[s, S_G] = scratch[gm0 + m]
        off = ipar[s, I_OFF]
        P = 2 * ipar[s, I_N]
        k = ipar[s, I_K]
        m0 = ipar[s, I_POS]
        j1 = m0 + 1 - k
        if j1 < 0:
            j1 += P
        j2 = m0 + 1 + k
        if j2 >= P:
            j2 -= P
        _ring_add(ring, off, P, j1, scratch[m * GC:m * GC + C], 1.0)
        _ring_add(ring, off, P, j2, scratch[m * GC:m * GC + C], -1.0)


@njit(**JIT_OPTS)
def _render_string(s, ring, ipar, fpar, fst, U, n, o0, mix, probe, scratch, ubx, po0, psub):
    """n samples of string s into mix[:, o0:o0+n]: the per-sample path or
    fast-path chunks (``ubx``: an external bridge's displacement, indexed
    like ``mix``; ``po0``, ``psub``: probe indexing, see
    :func:`_render_per_sample`)."""
    exc = ipar[s, I_EXC]
    cmax = ipar[s, I_CHUNK] if exc > EXC_NONE else ipar[s, I_CHUNK_FREE]
    if ipar[s, I_PROBE] >= 0 or ipar[s, I_TELEM] != 0 or cmax <= 0 or exc == EXC_FELT:
        _render_per_sample(s, ring, ipar, fpar, fst, U, n, o0, mix, probe, ubx, o0, scratch,
                           po0, psub)
        return
    done = 0
    while done < n:
        C = n - done
        if C > cmax:
            C = cmax
        if ipar[s, I_EXC] > EXC_NONE:
            left = ipar[s, I_EXC_END] - ipar[s, I_EXC_M] + 1
            if C > left:
                C = left
        _chunk_fast(s, ring, ipar, fpar, fst, U, C, o0 + done, mix, scratch, ubx)
        done += C
        if ipar[s, I_EXC] <= EXC_NONE:
            cmax = ipar[s, I_CHUNK_FREE]


@njit(**JIT_OPTS)
def _render_group(mem, G, ring, ipar, fpar, fst, U, n, o0, mix, probe, scratch, ist, ubx):
    """n samples of G (<= GROUP) strings whose hammers are running, in
    lockstep chunks (the shortest any of them allows) so that their hammer
    steps interleave (:func:`_excite_group`); a string whose hammer has gone
    renders the rest of the block alone.  ``mem`` (the strings) is
    reordered in place."""
    done = 0
    live = G
    while done < n and live > 0:
        C = n - done
        if C > GROUP_CHUNK:
            C = GROUP_CHUNK
        for m in range(live):
            s = mem[m]
            c = ipar[s, I_CHUNK]
            left = ipar[s, I_EXC_END] - ipar[s, I_EXC_M] + 1
            if left < c:
                c = left
            if c < C:
                C = c
        _excite_group(ring, ipar, fpar, fst, C, mem, live, scratch, ist)
        work = scratch[_SCRATCH_GROUP:]
        for m in range(live):
            _chunk_rest(mem[m], ring, ipar, fpar, fst, U, C, o0 + done, mix, work,
                        scratch[m * _GROW:m * _GROW + C],
                        ipar[mem[m], I_EXC] != EXC_NONE, ubx)   # (True; not a constant: see _ring_get)
        done += C
        j = 0
        for m in range(live):
            s = mem[m]
            if ipar[s, I_EXC] > EXC_NONE:
                mem[j] = s
                j += 1
            elif done < n:
                _render_string(s, ring, ipar, fpar, fst, U, n - done, o0 + done, mix, probe,
                               scratch, ubx, o0 + done, 1)
        live = j


@njit(**JIT_OPTS)
def _bridge(lead, G, ipar, fpar, fst, C, cw):
    """The bridge of a coupled group over a chunk: from the members'
    loop-filter outputs z (their far-end windows in ``cw``), the bridge
    displacement u_b per sample, in the same sample as the strings' force:

        F(i) = f(i) - B (u_b(i) - u_b(i-1)),   f(i) = sum_m T_m/dx_m 2 dz_m(i),
        u_b(i) = a u_b(i-1) + b F(i)
        =>  u_b(i) = ((a + r) u_b(i-1) + b f(i)) / (1 + r),   r = b B,

    (f the strings' summed force with the bridge held still, B = BTDX the
    members' summed T/dx, b = BRB = dt / R_b for a bridge of resistance
    R_b, a = BRA = exp(-2 pi f_r dt) its spring's slow return; d a step's
    difference); then every member's outgoing wave y = z - u_b.  A string
    of impedance Z on it is reflected by (R_b - Z) / (R_b + Z) at every
    frequency, the dashpot's own: passive for any R_b.  (The step one
    sample behind the force, u_b(i+1) = a u_b(i) + b F(i), used until
    2026-11-25, reflects by (1 - r z^-1) / (1 + r z^-1): more than 1 above
    fs/4, and a sitar's taraf on a soft bridge blew up.)

    With a mass (``F_BRMU`` = mu = M / (R_b dt) > 0; the grand's bridge
    moves as a mass above f_m = 1 / (2 pi mu dt)), the dashpot's step w(i)
    = u_b(i) - a u_b(i-1) = b F(i) becomes the backward-Euler step of
    M dv/dt = F - R_b v, w = v dt:

        mu (w(i) - w(i-1)) + w(i) = b F(i),   F(i) = f(i) - B (w(i) + (a - 1) u_b(i-1))
        =>  w(i) = (mu w(i-1) + b f(i) - r (a - 1) u_b(i-1)) / (1 + mu + r),

    w kept in ``S_UBW``: the strings meet the impedance R_b + j w M
    (its backward-Euler form, whose real part only grows with frequency:
    passive), and a unison's in-phase motion loses 1 / (1 + (f / f_m)^2)
    of the dashpot's decay rate at f.  mu = 0 takes the dashpot's loop
    (the same samples as before the mass).  The bridge row of
    ``cw`` (after the G members' windows) gets u_b of the sample before the
    chunk and of its C samples (for the members' force outputs).  The
    members are the chain from ``lead`` (``I_CPLNX``)."""
    a = fpar[lead, F_BRA]
    b = fpar[lead, F_BRB]
    r = b * fpar[lead, F_BTDX]
    ar = a + r
    den = 1.0 / (1.0 + r)
    ubm = fst[lead, S_UBM]
    if LANES == 2 and G <= 3 and fpar[lead, F_BRMU] == 0.0:
        # the SSE2 build (no FMA; the loop below is compiled as ubm =
        # (ar den) ubm + (b den) f: re-association distributes the
        # reciprocal); with FMA, which products LLVM fuses differs between
        # the two forms (last bits), so the AVX2 and AVX-512 builds keep this
        _bridge_fused(lead, G, ipar, fpar, fst, C, cw, ubm, ar * den, b * den)
        return
    row = cw[2 * G * _CW:2 * G * _CW + C + 1]
    fo = row[1:1 + C]
    for i in range(C):
        fo[i] = 0.0
    s = lead
    for m in range(G):
        yb = cw[(2 * m + 1) * _CW:(2 * m + 1) * _CW + C + 1]
        t2 = 2.0 * fpar[s, F_TDX]
        s = ipar[s, I_CPLNX]
        y_prev = yb[0]
        yb[0] = y_prev + ubm          # z(-1), the filter's own previous output
        zo = yb[1:1 + C]
        zp = yb[0:C]
        for i in range(C):
            fo[i] += t2 * (zo[i] - zp[i])
        yb[0] = y_prev
    row[0] = ubm
    ubm = _bridge_steps(lead, fpar, fst, C, fo, ubm)
    s = lead
    for m in range(G):
        yo = cw[(2 * m + 1) * _CW + 1:(2 * m + 1) * _CW + 1 + C]
        for i in range(C):
            yo[i] -= fo[i]
        fst[s, S_UBP] = ubm
        s = ipar[s, I_CPLNX]


@njit(inline="always", **JIT_OPTS)
def _bridge_steps(lead, fpar, fst, C, fo, ubm):
    """The bridge's steps over a chunk (:func:`_bridge`): from the strings'
    summed force with the bridge held still, fo[0:C], and u_b before the
    chunk, ``ubm``, u_b per sample into fo (in place) and the bridge's
    state (``S_UBM``, and ``S_UBW`` with a mass); returns the last u_b."""
    a = fpar[lead, F_BRA]
    b = fpar[lead, F_BRB]
    r = b * fpar[lead, F_BTDX]
    mu = fpar[lead, F_BRMU]
    if mu == 0.0:
        ar = a + r
        den = 1.0 / (1.0 + r)
        for i in range(C):
            ubm = (ar * ubm + b * fo[i]) * den
            fo[i] = ubm
    else:
        # the bridge with its mass: w(i) = u_b(i) - a u_b(i-1) solves
        # mu (w(i) - w(i-1)) + w(i) = b F(i), F(i) = f(i) - B (w(i) + (a - 1) u_b(i-1))
        w = fst[lead, S_UBW]
        dm = 1.0 / (1.0 + mu + r)
        ra = r * (a - 1.0)
        for i in range(C):
            w = (mu * w + b * fo[i] - ra * ubm) * dm
            ubm = a * ubm + w
            fo[i] = ubm
        fst[lead, S_UBW] = w
    fst[lead, S_UBM] = ubm
    return ubm


@njit(**SERIAL_OPTS)
def _bridge_fused(lead, G, ipar, fpar, fst, C, cw, ubm, ard, bd):
    """:func:`_bridge` for a group of one to three strings in one loop: the
    bridge's recurrence (``ubm = bd f + ard ubm``, ard = (a + r) / (1 + r),
    bd = b / (1 + r) as products with the reciprocal: what :func:`_bridge`'s
    loop compiles to, re-association having distributed its ``* den``; a
    multiply and an add or a multiply-add on its path) with the members'
    forces and outgoing waves beside it, where :func:`_bridge` runs them as
    vector loops of their own before and after it.  The same operations in
    the same order (each sample's force summed over the members in turn
    from 0.0; the serial flags: no re-association may reorder that sum),
    bit for bit where there is no FMA (the SSE2 build, its only caller): with
    FMA, LLVM contracts other products of the fused loop than of
    :func:`_bridge`'s (renders differed by up to 4e-12)."""
    s0 = lead
    s1 = ipar[s0, I_CPLNX] if G > 1 else s0
    s2 = ipar[s1, I_CPLNX] if G > 2 else s1
    t0 = 2.0 * fpar[s0, F_TDX]
    t1 = 2.0 * fpar[s1, F_TDX]
    t2 = 2.0 * fpar[s2, F_TDX]
    y0 = cw[_CW:_CW + C + 1]
    y1 = cw[3 * _CW:3 * _CW + C + 1] if G > 1 else y0
    y2 = cw[5 * _CW:5 * _CW + C + 1] if G > 2 else y0
    row = cw[2 * G * _CW:2 * G * _CW + C + 1]
    # z(-1), each filter's own previous output
    p0 = y0[0] + ubm
    p1 = y1[0] + ubm
    p2 = y2[0] + ubm
    row[0] = ubm
    if G == 3:
        for i in range(1, C + 1):
            z0 = y0[i]
            z1 = y1[i]
            z2 = y2[i]
            f = 0.0
            f += t0 * (z0 - p0)
            f += t1 * (z1 - p1)
            f += t2 * (z2 - p2)
            p0 = z0
            p1 = z1
            p2 = z2
            ubm = bd * f + ard * ubm
            row[i] = ubm
            y0[i] = z0 - ubm
            y1[i] = z1 - ubm
            y2[i] = z2 - ubm
    elif G == 2:
        for i in range(1, C + 1):
            z0 = y0[i]
            z1 = y1[i]
            f = 0.0
            f += t0 * (z0 - p0)
            f += t1 * (z1 - p1)
            p0 = z0
            p1 = z1
            ubm = bd * f + ard * ubm
            row[i] = ubm
            y0[i] = z0 - ubm
            y1[i] = z1 - ubm
    else:
        for i in range(1, C + 1):
            z0 = y0[i]
            f = 0.0
            f += t0 * (z0 - p0)
            p0 = z0
            ubm = bd * f + ard * ubm
            row[i] = ubm
            y0[i] = z0 - ubm
    fst[lead, S_UBM] = ubm
    fst[s0, S_UBP] = ubm
    fst[s1, S_UBP] = ubm
    fst[s2, S_UBP] = ubm


# ---- the loop filters of a coupled group in lockstep (four lanes) ------------
# The members of a coupled group run their far ends over the same chunk.
# When they have the same filter structure (the strings of a piano key do),
# their recurrences run as the four lanes of one vector (synth.kernels.lanes):
# every lane computes what :func:`_head_sos` / :func:`_head` and
# :func:`_biquads` compute for its string, the same operations in the same
# order (the same samples).  Lanes past the group's last member repeat
# member 0 and are not written back.


@njit(**SERIAL_OPTS)
def _lanes_ok(lead, G, ipar):
    """True if the G members of the chain from ``lead`` can be filtered in
    lockstep: each has the loss filter, no bend line, at most one
    dispersion first-order section (then the tuning allpass), and they
    have the same sections."""
    nd = ipar[lead, I_NDISP]
    nb = ipar[lead, I_NSOS]
    if nd > 1:
        return False
    s = lead
    for m in range(G):
        if (ipar[s, I_FILT] != 1 or ipar[s, I_BLEN] != 0 or ipar[s, I_NDISP] != nd
                or ipar[s, I_NSOS] != nb):
            return False
        s = ipar[s, I_CPLNX]
    return True


@njit(**SERIAL_OPTS)
def _col4(z, a, r0, r1, r2, r3, c):
    """Column c of rows r0..r3 of a as lanes of z's type (r0, r1 for two)."""
    return vec(z, a[r0, c], a[r1, c], a[r2, c], a[r3, c])


@njit(**SERIAL_OPTS)
def _put4(a, r0, r1, r2, r3, G, c, v):
    a[r0, c] = lane(v, 0)
    if G > 1:
        a[r1, c] = lane(v, 1)
    if G > 2:
        a[r2, c] = lane(v, 2)
    if G > 3:
        a[r3, c] = lane(v, 3)


@njit(inline="always", **SERIAL_OPTS)
def _put_biquads(fst, r0, r1, r2, r3, G, q0, cnt, x10, x20, y10, y20, y11, y21, y12, y22,
                 y13, y23):
    """The states of a pass of ``cnt`` (0-4) biquads in lanes, from state
    column q0 on (x1, x2, y1, y2 each; a biquad's x are the one before's
    y), written back to the G strings r0..r3 (:func:`_lanes_head`,
    :func:`_lanes_biquads`)."""
    if cnt > 0:
        _put4(fst, r0, r1, r2, r3, G, q0, x10)
        _put4(fst, r0, r1, r2, r3, G, q0 + 1, x20)
        _put4(fst, r0, r1, r2, r3, G, q0 + 2, y10)
        _put4(fst, r0, r1, r2, r3, G, q0 + 3, y20)
    if cnt > 1:
        _put4(fst, r0, r1, r2, r3, G, q0 + 4, y10)
        _put4(fst, r0, r1, r2, r3, G, q0 + 5, y20)
        _put4(fst, r0, r1, r2, r3, G, q0 + 6, y11)
        _put4(fst, r0, r1, r2, r3, G, q0 + 7, y21)
    if cnt > 2:
        _put4(fst, r0, r1, r2, r3, G, q0 + 8, y11)
        _put4(fst, r0, r1, r2, r3, G, q0 + 9, y21)
        _put4(fst, r0, r1, r2, r3, G, q0 + 10, y12)
        _put4(fst, r0, r1, r2, r3, G, q0 + 11, y22)
    if cnt > 3:
        _put4(fst, r0, r1, r2, r3, G, q0 + 12, y12)
        _put4(fst, r0, r1, r2, r3, G, q0 + 13, y22)
        _put4(fst, r0, r1, r2, r3, G, q0 + 14, y13)
        _put4(fst, r0, r1, r2, r3, G, q0 + 15, y23)


@njit(**SERIAL_OPTS)
def _lanes_head(X0, X1, X2, X3, buf, n, fpar, fst, r0, r1, r2, r3, G, ns, cnt, zt):
    """The first pass of four strings' far ends (lanes): the loss glide and
    one-pole loss, ``ns`` (1 or 2) first-order sections (the dispersion
    section at S_D0 if ns is 2, then the tuning allpass at S_APX) and the
    first ``cnt`` (0..4) biquads, from X0..X3[0:n] into buf[0:4n]
    (interleaved: sample i of lane m at 4 i + m), as :func:`_head_sos`
    (:func:`_head` for cnt 0) computes each string's."""
    b0 = _col4(zt, fpar, r0, r1, r2, r3, F_B0)
    W = width(zt)
    gk = splat(zt, 1.0) - _col4(zt, fpar, r0, r1, r2, r3, F_B0S)
    gc = _col4(zt, fpar, r0, r1, r2, r3, F_B0S) * _col4(zt, fpar, r0, r1, r2, r3, F_B0T)
    a1 = _col4(zt, fpar, r0, r1, r2, r3, F_A1)
    lp = _col4(zt, fst, r0, r1, r2, r3, S_LP)
    s0 = S_D0 if ns == 2 else S_APX
    c0 = _col4(zt, fpar, r0, r1, r2, r3, F_ADISP if ns == 2 else F_ETA)
    x0 = _col4(zt, fst, r0, r1, r2, r3, s0)
    y0 = _col4(zt, fst, r0, r1, r2, r3, s0 + 1)
    c1 = _col4(zt, fpar, r0, r1, r2, r3, F_ETA)
    x1 = _col4(zt, fst, r0, r1, r2, r3, S_APX)
    y1 = _col4(zt, fst, r0, r1, r2, r3, S_APX + 1)
    q0 = S_SOS
    x10 = _col4(zt, fst, r0, r1, r2, r3, q0)
    x20 = _col4(zt, fst, r0, r1, r2, r3, q0 + 1)
    z = splat(zt, 0.0)
    ca0 = _col4(zt, fpar, r0, r1, r2, r3, F_SOS + 0) if cnt > 0 else z
    cb0 = _col4(zt, fpar, r0, r1, r2, r3, F_SOS + 1) if cnt > 0 else z
    y10 = _col4(zt, fst, r0, r1, r2, r3, q0 + 2) if cnt > 0 else z
    y20 = _col4(zt, fst, r0, r1, r2, r3, q0 + 3) if cnt > 0 else z
    ca1 = _col4(zt, fpar, r0, r1, r2, r3, F_SOS + 2) if cnt > 1 else z
    cb1 = _col4(zt, fpar, r0, r1, r2, r3, F_SOS + 3) if cnt > 1 else z
    y11 = _col4(zt, fst, r0, r1, r2, r3, q0 + 6) if cnt > 1 else z
    y21 = _col4(zt, fst, r0, r1, r2, r3, q0 + 7) if cnt > 1 else z
    ca2 = _col4(zt, fpar, r0, r1, r2, r3, F_SOS + 4) if cnt > 2 else z
    cb2 = _col4(zt, fpar, r0, r1, r2, r3, F_SOS + 5) if cnt > 2 else z
    y12 = _col4(zt, fst, r0, r1, r2, r3, q0 + 10) if cnt > 2 else z
    y22 = _col4(zt, fst, r0, r1, r2, r3, q0 + 11) if cnt > 2 else z
    ca3 = _col4(zt, fpar, r0, r1, r2, r3, F_SOS + 6) if cnt > 3 else z
    cb3 = _col4(zt, fpar, r0, r1, r2, r3, F_SOS + 7) if cnt > 3 else z
    y13 = _col4(zt, fst, r0, r1, r2, r3, q0 + 14) if cnt > 3 else z
    y23 = _col4(zt, fst, r0, r1, r2, r3, q0 + 15) if cnt > 3 else z
    if ns == 1 and cnt == 0:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * vec(zt, X0[i], X1[i], X2[i], X3[i]) - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            store4(buf, W * i, y0)
    elif ns == 2 and cnt == 0:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * vec(zt, X0[i], X1[i], X2[i], X3[i]) - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            y1 = c1 * y0 + x1 - c1 * y1
            x1 = y0
            store4(buf, W * i, y1)
    elif ns == 1 and cnt == 1:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * vec(zt, X0[i], X1[i], X2[i], X3[i]) - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            h = y0
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            y20 = y10
            y10 = o0
            store4(buf, W * i, o0)
    elif ns == 2 and cnt == 1:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * vec(zt, X0[i], X1[i], X2[i], X3[i]) - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            y1 = c1 * y0 + x1 - c1 * y1
            x1 = y0
            h = y1
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            y20 = y10
            y10 = o0
            store4(buf, W * i, o0)
    elif ns == 1 and cnt == 2:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * vec(zt, X0[i], X1[i], X2[i], X3[i]) - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            h = y0
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            o1 = (cb1 * (o0 - y21) + y20 + ca1 * y10) - ca1 * y11
            y20 = y10
            y10 = o0
            y21 = y11
            y11 = o1
            store4(buf, W * i, o1)
    elif ns == 2 and cnt == 2:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * vec(zt, X0[i], X1[i], X2[i], X3[i]) - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            y1 = c1 * y0 + x1 - c1 * y1
            x1 = y0
            h = y1
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            o1 = (cb1 * (o0 - y21) + y20 + ca1 * y10) - ca1 * y11
            y20 = y10
            y10 = o0
            y21 = y11
            y11 = o1
            store4(buf, W * i, o1)
    elif ns == 1 and cnt == 3:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * vec(zt, X0[i], X1[i], X2[i], X3[i]) - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            h = y0
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            o1 = (cb1 * (o0 - y21) + y20 + ca1 * y10) - ca1 * y11
            y20 = y10
            y10 = o0
            o2 = (cb2 * (o1 - y22) + y21 + ca2 * y11) - ca2 * y12
            y21 = y11
            y11 = o1
            y22 = y12
            y12 = o2
            store4(buf, W * i, o2)
    elif ns == 2 and cnt == 3:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * vec(zt, X0[i], X1[i], X2[i], X3[i]) - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            y1 = c1 * y0 + x1 - c1 * y1
            x1 = y0
            h = y1
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            o1 = (cb1 * (o0 - y21) + y20 + ca1 * y10) - ca1 * y11
            y20 = y10
            y10 = o0
            o2 = (cb2 * (o1 - y22) + y21 + ca2 * y11) - ca2 * y12
            y21 = y11
            y11 = o1
            y22 = y12
            y12 = o2
            store4(buf, W * i, o2)
    elif ns == 1:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * vec(zt, X0[i], X1[i], X2[i], X3[i]) - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            h = y0
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            o1 = (cb1 * (o0 - y21) + y20 + ca1 * y10) - ca1 * y11
            y20 = y10
            y10 = o0
            o2 = (cb2 * (o1 - y22) + y21 + ca2 * y11) - ca2 * y12
            y21 = y11
            y11 = o1
            o3 = (cb3 * (o2 - y23) + y22 + ca3 * y12) - ca3 * y13
            y22 = y12
            y12 = o2
            y23 = y13
            y13 = o3
            store4(buf, W * i, o3)
    else:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * vec(zt, X0[i], X1[i], X2[i], X3[i]) - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            y1 = c1 * y0 + x1 - c1 * y1
            x1 = y0
            h = y1
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            o1 = (cb1 * (o0 - y21) + y20 + ca1 * y10) - ca1 * y11
            y20 = y10
            y10 = o0
            o2 = (cb2 * (o1 - y22) + y21 + ca2 * y11) - ca2 * y12
            y21 = y11
            y11 = o1
            o3 = (cb3 * (o2 - y23) + y22 + ca3 * y12) - ca3 * y13
            y22 = y12
            y12 = o2
            y23 = y13
            y13 = o3
            store4(buf, W * i, o3)
    _put4(fpar, r0, r1, r2, r3, G, F_B0, b0)
    _put4(fst, r0, r1, r2, r3, G, S_LP, lp)
    _put4(fst, r0, r1, r2, r3, G, s0, x0)
    _put4(fst, r0, r1, r2, r3, G, s0 + 1, y0)
    if ns == 2:
        _put4(fst, r0, r1, r2, r3, G, S_APX, x1)
        _put4(fst, r0, r1, r2, r3, G, S_APX + 1, y1)
    _put_biquads(fst, r0, r1, r2, r3, G, q0, cnt, x10, x20, y10, y20, y11, y21, y12, y22,
                 y13, y23)


@njit(**SERIAL_OPTS)
def _lanes_biquads(buf, n, fpar, fst, r0, r1, r2, r3, G, j0, cnt, zt):
    """Biquads j0 .. j0+cnt-1 (cnt 1..4) of four strings (lanes) over the
    interleaved buf[0:4n] in place, as :func:`_biquads` computes each
    string's."""
    q0 = S_SOS + 4 * j0
    f0 = F_SOS + 2 * j0
    W = width(zt)
    z = splat(zt, 0.0)
    ca0 = _col4(zt, fpar, r0, r1, r2, r3, f0)
    cb0 = _col4(zt, fpar, r0, r1, r2, r3, f0 + 1)
    x10 = _col4(zt, fst, r0, r1, r2, r3, q0)
    x20 = _col4(zt, fst, r0, r1, r2, r3, q0 + 1)
    y10 = _col4(zt, fst, r0, r1, r2, r3, q0 + 2)
    y20 = _col4(zt, fst, r0, r1, r2, r3, q0 + 3)
    ca1 = _col4(zt, fpar, r0, r1, r2, r3, f0 + 2) if cnt > 1 else z
    cb1 = _col4(zt, fpar, r0, r1, r2, r3, f0 + 3) if cnt > 1 else z
    y11 = _col4(zt, fst, r0, r1, r2, r3, q0 + 6) if cnt > 1 else z
    y21 = _col4(zt, fst, r0, r1, r2, r3, q0 + 7) if cnt > 1 else z
    ca2 = _col4(zt, fpar, r0, r1, r2, r3, f0 + 4) if cnt > 2 else z
    cb2 = _col4(zt, fpar, r0, r1, r2, r3, f0 + 5) if cnt > 2 else z
    y12 = _col4(zt, fst, r0, r1, r2, r3, q0 + 10) if cnt > 2 else z
    y22 = _col4(zt, fst, r0, r1, r2, r3, q0 + 11) if cnt > 2 else z
    ca3 = _col4(zt, fpar, r0, r1, r2, r3, f0 + 6) if cnt > 3 else z
    cb3 = _col4(zt, fpar, r0, r1, r2, r3, f0 + 7) if cnt > 3 else z
    y13 = _col4(zt, fst, r0, r1, r2, r3, q0 + 14) if cnt > 3 else z
    y23 = _col4(zt, fst, r0, r1, r2, r3, q0 + 15) if cnt > 3 else z
    if cnt == 1:
        for i in range(n):
            h = loadv(zt, buf, W * i)
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            y20 = y10
            y10 = o0
            store4(buf, W * i, o0)
    elif cnt == 2:
        for i in range(n):
            h = loadv(zt, buf, W * i)
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            o1 = (cb1 * (o0 - y21) + y20 + ca1 * y10) - ca1 * y11
            y20 = y10
            y10 = o0
            y21 = y11
            y11 = o1
            store4(buf, W * i, o1)
    elif cnt == 3:
        for i in range(n):
            h = loadv(zt, buf, W * i)
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            o1 = (cb1 * (o0 - y21) + y20 + ca1 * y10) - ca1 * y11
            y20 = y10
            y10 = o0
            o2 = (cb2 * (o1 - y22) + y21 + ca2 * y11) - ca2 * y12
            y21 = y11
            y11 = o1
            y22 = y12
            y12 = o2
            store4(buf, W * i, o2)
    else:
        for i in range(n):
            h = loadv(zt, buf, W * i)
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            o1 = (cb1 * (o0 - y21) + y20 + ca1 * y10) - ca1 * y11
            y20 = y10
            y10 = o0
            o2 = (cb2 * (o1 - y22) + y21 + ca2 * y11) - ca2 * y12
            y21 = y11
            y11 = o1
            o3 = (cb3 * (o2 - y23) + y22 + ca3 * y12) - ca3 * y13
            y22 = y12
            y12 = o2
            y23 = y13
            y13 = o3
            store4(buf, W * i, o3)
    _put_biquads(fst, r0, r1, r2, r3, G, q0, cnt, x10, x20, y10, y20, y11, y21, y12, y22,
                 y13, y23)


@njit(**SERIAL_OPTS)
def _lanes_out(buf, n, Y0, Y1, Y2, Y3, zt):
    """The W lanes (zt's type) of buf[0:Wn] into Y0..Y3[0:n] (Y0, Y1 for
    two)."""
    W = width(zt)
    if W == 4:
        for i in range(n):
            v = loadv(zt, buf, 4 * i)
            Y0[i] = lane(v, 0)
            Y1[i] = lane(v, 1)
            Y2[i] = lane(v, 2)
            Y3[i] = lane(v, 3)
    else:
        for i in range(n):
            v = loadv(zt, buf, W * i)
            Y0[i] = lane(v, 0)
            Y1[i] = lane(v, 1)


@njit(**JIT_OPTS)
def _far_lanes(lead, G, ipar, fpar, fst, C, cw, buf, dummy):
    """The loop filters of the G members of a coupled group (the chain from
    ``lead``) over a chunk, four at a time in lockstep (:func:`_lanes_ok`
    holds), from their far-end windows in ``cw`` (set up by
    :func:`_far_prep`; member m's at 2 m _CW) into them, as
    :func:`_far_filter` computes each string's (each lane the same
    operations, whatever lane a member takes); ``buf``: 4 C samples of
    scratch; ``dummy``: C samples that the unused lanes of a last pass
    write."""
    ns = ipar[lead, I_NDISP] + 1
    nb = ipar[lead, I_NSOS]
    # the head loop takes all the biquads while its states fit in the
    # vector registers (_LANES_HEAD_SOS; _LANES_HEAD_SOS2 with a dispersion
    # section), else one (16 registers; none if it may take none) or what
    # passes of four leave (32); the rest run in passes of two to four (a
    # pass of one waits on its own recurrence)
    hmax = _LANES_HEAD_SOS if ns == 1 else _LANES_HEAD_SOS2
    if nb <= hmax:
        cnt = nb
    elif VECTOR_REGS >= 32:
        cnt = (nb - 1) % 4 + 1
    else:
        cnt = 1 if hmax > 0 else 0
    zt = _LANES_ZERO(0.0)           # the lanes' type: four, or two in an SSE2 build
    L = width(zt)
    s = lead
    m = 0
    while m < G:
        g = G - m if G - m < L else L
        r0 = s
        x0 = cw[2 * m * _CW + _io(ipar, r0):][:C]
        y0 = cw[(2 * m + 1) * _CW + 1:(2 * m + 1) * _CW + 1 + C]
        r1 = r0
        x1 = x0
        y1 = dummy
        r2 = r0
        x2 = x0
        y2 = dummy
        r3 = r0
        x3 = x0
        y3 = dummy
        s = ipar[s, I_CPLNX]
        if g > 1:
            r1 = s
            x1 = cw[2 * (m + 1) * _CW + _io(ipar, r1):][:C]
            y1 = cw[(2 * m + 3) * _CW + 1:(2 * m + 3) * _CW + 1 + C]
            s = ipar[s, I_CPLNX]
        if g > 2:
            r2 = s
            x2 = cw[2 * (m + 2) * _CW + _io(ipar, r2):][:C]
            y2 = cw[(2 * m + 5) * _CW + 1:(2 * m + 5) * _CW + 1 + C]
            s = ipar[s, I_CPLNX]
        if g > 3:
            r3 = s
            x3 = cw[2 * (m + 3) * _CW + _io(ipar, r3):][:C]
            y3 = cw[(2 * m + 7) * _CW + 1:(2 * m + 7) * _CW + 1 + C]
            s = ipar[s, I_CPLNX]
        _lanes_head(x0, x1, x2, x3, buf, C, fpar, fst, r0, r1, r2, r3, g, ns, cnt, zt)
        j = cnt
        while j < nb:
            # the biquads left in passes as even as passes of at most four
            # allow (5 -> 3 + 2, 7 -> 4 + 3)
            left = nb - j
            passes = (left + 3) // 4
            c = (left + passes - 1) // passes
            _lanes_biquads(buf, C, fpar, fst, r0, r1, r2, r3, g, j, c, zt)
            j += c
        _lanes_out(buf, C, y0, y1, y2, y3, zt)
        m += g
    # the extra-delay registers: the last arriving sample
    s = lead
    for m in range(G):
        if ipar[s, I_XDELAY] == 1:
            fst[s, S_XD] = cw[2 * m * _CW + C]
        s = ipar[s, I_CPLNX]


def max_fast_chunk(N: int, k: int, R: int, out_mode: int) -> int:
    """Longest chunk (samples) for which the fast path is exact, or 0 when it
    does not apply (excitation inside or next to the region).

    No sample may meet two operation points within one chunk: the loop
    distances region-excitation (k - R), excitation-far end (N - k) and,
    for the bridge-force pickup next to x = L, region-far end (N - R).
    """
    if R > 0 and k <= R + 1:
        return 0
    c = min(k - R, N - k, N - R) - 1
    if out_mode == 1:
        c = min(c, N - R - 2)
    return max(c, 0)


def max_free_chunk(N: int, k: int, R: int, out_mode: int, filt: bool = False) -> int:
    """Longest exact chunk with no excitation running: the excitation point
    is then no operation point, except as the pickup of ``out_mode`` 0 (u
    at k is read after the chunk's region and far-end steps).

    With the bridge-force output of a far-end filter (``filt``: the force
    comes from the filter's output, not from the ring) and no region, the
    far end is the only operation point: a sample it writes comes back to
    it after the loop's 2N steps, so a chunk may take 2N - 2 (its C + 1
    arriving samples and the previous output are C + 2 distinct slots),
    where the region's distance bounds it at N - R - 2."""
    if out_mode == 0:
        if R > 0 and k <= R + 1:
            return 0
        c = min(k - R, N - k, N - R) - 1
    elif filt and R == 0:
        c = 2 * N - 2
    else:
        c = N - R - 2
    return max(c, 0)


@njit(**JIT_OPTS)
def scan_silence(active, n_active, ipar, fst, quiet, last_peak, n_in, level, min_quiet, done):
    """Per-block bookkeeping of the active strings, without allocation.

    For each active string: remember its block peak in ``last_peak`` and
    reset it; add ``n_in`` to its quiet count if its peak stayed below
    ``level`` and no excitation runs, else reset the count; list in ``done``
    the strings quiet for max(4 periods, ``min_quiet``) samples.  Returns
    how many were listed.
    """
    nd = 0
    for a in range(n_active):
        s = active[a]
        pk = fst[s, S_PEAK]
        last_peak[s] = pk
        fst[s, S_PEAK] = 0.0
        if pk < level and ipar[s, I_EXC] == EXC_NONE:
            quiet[s] += n_in
        else:
            quiet[s] = 0
        need = 4 * ipar[s, I_N] // ipar[s, I_SUB]     # four periods (engine samples)
        if need < min_quiet:
            need = min_quiet
        if quiet[s] >= need:
            done[nd] = s
            nd += 1
    return nd
