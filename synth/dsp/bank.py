"""A bank of waveguide strings in preallocated arrays.

The bank owns every array the string kernel touches (rings, parameter and
state tables, profiles, scratch, probes).  Voices claim string slots and
write their physics into them at note-on through the bank's methods; the
engine renders all active slots with one call of
:func:`synth.kernels.strings.render_bank` per segment, fades slots out
(:meth:`StringBank.fade`) and frees the silent ones
(:meth:`StringBank.reap`).  Nothing outside this module indexes the
kernel's tables.  Nothing is allocated per block.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass

import numpy as np

from ..kernels import felt_layer as FL
from ..kernels import strings as K
from ..kernels.energy import ring_energy

_LN1000 = math.log(1000.0)     # 60 dB of amplitude
#: per-slot columns of ``ipar`` that a template does not carry (the output
#: row is the slot's until :meth:`StringBank.set_output_row` changes it)
_SLOT_COLS = (K.I_OFF, K.I_REG_OFF, K.I_GT_OFF, K.I_BOFF, K.I_ROW)
#: ``ipar`` columns a slot keeps when it changes grid (:meth:`StringBank.hand_over`)
_HAND_OVER_KEEP = _SLOT_COLS + (K.I_PROBE, K.I_TELEM, K.I_CPL, K.I_CPLN, K.I_CPLNX)
#: ``fst`` columns it keeps as they are: the peak, the bridge, the telemetry's
#: episodes, most points and peak force
_HAND_OVER_ST = (K.S_PEAK, K.S_UBM, K.S_UBW, K.S_UBP, K.S_TC_EP, K.S_TC_PTS, K.S_HC_EP,
                 K.S_HF_PK)
#: ``fpar`` columns a hammer template sets (speed F_HV and F_HDTV are per strike)
_HAMMER_COLS = np.array([K.F_HQ, K.F_HP, K.F_HA, K.F_HT, K.F_HREL, K.F_HE, K.F_HK, K.F_HMC,
                         K.F_HDZ, K.F_HD, K.F_HKCA, K.F_HKCBY, K.F_HKCBP, K.F_HKCD, K.F_HPE,
                         K.F_HP1, K.F_HP0, K.F_HFA, K.F_HFB, K.F_HFPHI, K.F_HC2, K.F_HC3]
                        + [K.F_HB4 + j for j in range(7)] + [K.F_HTOL, K.F_HTOLG], dtype=np.int64)
#: the felt solver's default tolerance: a correction changing the felt's
#: compression by less than this (relative) ends the step; Halley's
#: iteration is cubic, so the next one would change it by ~1e-15
SOLVER_TOL = 1e-5
#: those proportional to the felt stiffness (scaled by the soft pedal)
_HAMMER_Q_COLS = np.array([K.F_HQ, K.F_HKCA, K.F_HKCBY, K.F_HKCBP, K.F_HKCD, K.F_HFA, K.F_HFB,
                           K.F_HFPHI], dtype=np.int64)


def _chained_state(xdel: int, nd: int, nb: int, n_cols: int) -> np.ndarray:
    """The far-end filter's free state, as columns of an ``fst`` row (one
    per free value): the fast path keeps each stage's input history as the
    previous stage's output history (a first-order section's x1 is the
    stage before's last output, the tuning allpass's S_APX the same, a
    biquad's x1, x2 the stage before's y1, y2) and reads only the free
    values, so a state must be chained: the unit delay's register, the
    loss's output, each first-order section's y1, the tuning allpass's y1,
    the first biquad's x2, each biquad's y1 and y2."""
    cols = []

    def col(*entries):
        v = np.zeros(n_cols)
        for c in entries:
            v[c] = 1.0
        cols.append(v)

    if xdel:
        col(K.S_XD)
    # the loss's output feeds the first first-order section's x1, or the
    # tuning allpass's
    col(K.S_LP, K.S_D0 if nd else K.S_APX)
    for d in range(nd):
        nxt = K.S_D0 + 2 * (d + 1) if d + 1 < nd else K.S_APX
        col(K.S_D0 + 2 * d + 1, nxt)
    # the tuning allpass's output: the first biquad's x1
    col(K.S_APY, *([K.S_SOS] if nb else []))
    if nb:
        col(K.S_SOS + 1)
    for b in range(nb):
        q = K.S_SOS + 4 * b
        nxt = b + 1 < nb
        col(q + 2, *([q + 4] if nxt else []))     # y1: the next biquad's x1
        col(q + 3, *([q + 5] if nxt else []))     # y2: its x2
    return np.array(cols).T


def region_reach(U: np.ndarray | None, side: int, subcell: float = 0.0) -> float:
    """The reach bound of a termination region (the kernel's ``F_REACH``):
    min over its points n = 1..R of side U(n) / n (m), over the points
    that can be touched (finite U); 0 when one of them touches the string
    at rest or beyond (side U(n) <= 0: the region always runs); inf when
    none can be touched.

    The fast path skips a chunk's region when every step of two cells on
    the part of the ring that passes it is smaller (so every |u(n)| <
    n B <= side U(n): :func:`synth.kernels.strings._out_of_reach`).
    With the sub-cell contact (``subcell`` > 0, the kernel's ``F_CURV``)
    the bound is over points 2..R: the kernel steps point 1 and the first
    cell in any case (``strings._subcell_ring``), and they only move the
    string away from the obstacle."""
    if U is None:
        return 0.0
    v = float(side) * np.asarray(U, float)
    n = np.arange(1, len(v) + 1, dtype=float)
    if subcell > 0.0:
        v, n = v[1:], n[1:]
    fin = np.isfinite(v)
    if not fin.any():
        return math.inf
    if np.any(v[fin] <= 0.0):
        return 0.0
    return float(np.min(v[fin] / n[fin]))


@dataclass(frozen=True, eq=False)
class SlotTemplate:
    """A validated string configuration (see :meth:`StringBank.configure`),
    written into a slot by :meth:`StringBank.configure_from` with a few array
    copies: what a note-on in the audio thread should cost."""

    ipar: np.ndarray          # int64[I_NI]; per-slot columns filled in by the bank
    fpar: np.ndarray          # float64[F_NF]
    U: np.ndarray | None      # termination profile at points 1..R (m)
    bend_delay: float


@dataclass(frozen=True, eq=False)
class HammerTemplate:
    """A validated felt hammer (see :meth:`StringBank.start_hammer`) for a
    string of time step ``dt_s``; the speed and a stiffness factor (soft
    pedal) are given per strike to :meth:`StringBank.start_hammer_from`."""

    law: int
    values: np.ndarray        # fpar values at _HAMMER_COLS
    e_end: int                # samples of flight at most
    dt_s: float


def _index(name: str, v, hi: int) -> int:
    """v as an int in 0 .. hi, else a ValueError naming ``name``."""
    try:
        i = int(v)
        ok = i == v and 0 <= i <= hi
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise ValueError(f"{name} = {v!r} is out of range (integer, 0 <= value <= {hi})")
    return i


def slot_template(*, cells: int, k: int, dt_s: float, U: np.ndarray | None, side: int = 1,
                  out_mode: int = 0, gain: float = 1.0, tension_over_dx: float = 0.0,
                  b0: float = 1.0, a1: float = 0.0, eta: float = 0.0,
                  extra_delay: int = 0, lossy: bool = False, force_per_sample: bool = False,
                  n_disp: int = 0, a_disp: float = 0.0, bend_len: int = 0,
                  bend_delay: float = 0.0, glide_s: float = 0.002,
                  bend_glide_s: float = 0.02, sos=None,
                  pan: float | None = None, sub: int = 1,
                  subcell: float = 0.0) -> SlotTemplate:
    """Validate a string configuration once (parameters as
    :meth:`StringBank.configure`); the bank's own limits (cells, region and
    bend-line sizes) are checked when it is written into a slot."""
    if not (8 <= cells <= 1_000_000):
        raise ValueError(f"cells = {cells!r} is out of range (8 <= value <= 1000000)")
    if not (1 <= k <= cells - 1):
        raise ValueError(f"k = {k!r} is out of range (1 <= value <= {cells - 1})")
    R = 0 if U is None else len(U)
    if R >= cells - 2:
        raise ValueError(f"region points = {R} must be smaller than cells - 2 = {cells - 2}")
    if not (0 <= n_disp <= K.MAX_DISP):
        raise ValueError(f"n_disp = {n_disp!r} is out of range (0 <= value <= {K.MAX_DISP})")
    if bend_len < 0:
        raise ValueError(f"bend_len = {bend_len!r} is out of range (value >= 0)")
    if bend_len and not (1.0 <= bend_delay <= bend_len - 3):
        raise ValueError(f"bend_delay = {bend_delay!r} is out of range (1 <= value <= {bend_len - 3})")
    sos = np.zeros((0, 2)) if sos is None else np.asarray(sos, dtype=float).reshape(-1, 2)
    if len(sos) > K.MAX_SOS:
        raise ValueError(f"sos sections = {len(sos)} is out of range (0 <= value <= {K.MAX_SOS})")
    for c1, c2 in sos:
        # a stable allpass section: poles inside the unit circle
        if not (np.isfinite(c1) and np.isfinite(c2) and abs(c2) < 1.0 and abs(c1) < 1.0 + c2):
            raise ValueError(f"sos section (c1, c2) = ({float(c1)!r}, {float(c2)!r}) is out of range "
                             f"(|c2| < 1 and |c1| < 1 + c2: a stable section)")
    if pan is not None and not (0.0 <= pan <= 1.0):
        raise ValueError(f"pan = {pan!r} is out of range (0 <= value <= 1)")
    if not (1 <= int(sub) <= K.MAX_SUB) or int(sub) != sub:
        raise ValueError(f"sub = {sub!r} is out of range (integer, 1 <= value <= {K.MAX_SUB})")
    subcell = float(subcell)
    if not (0.0 <= subcell <= 1.0):
        raise ValueError(f"subcell = {subcell!r} is out of range (0 <= value <= 1)")
    if subcell > 0.0 and not (U is not None and len(U) and side * float(U[0]) > 0.0):
        raise ValueError("subcell > 0 needs a region whose first point is off the string at "
                         "rest (side U(1) > 0)")
    if subcell > 0.0 and k < 3:
        raise ValueError(f"k = {k!r} is out of range with subcell > 0 (value >= 3: the sub-cell "
                         f"contact reads points 1 and 2)")
    ip = np.zeros(K.I_NI, dtype=np.int64)
    ip[K.I_N] = cells
    ip[K.I_K] = k
    ip[K.I_REG_N] = R
    ip[K.I_SIDE] = side
    ip[K.I_FILT] = 1 if (lossy or n_disp or bend_len or len(sos)) else 0
    ip[K.I_NDISP] = int(n_disp)
    ip[K.I_NSOS] = len(sos)
    ip[K.I_BUS] = 0 if pan is None else 1
    ip[K.I_CPL] = K.CPL_NONE
    ip[K.I_CPLNX] = -1
    ip[K.I_SUB] = int(sub)
    ip[K.I_BLEN] = int(bend_len)
    ip[K.I_XDELAY] = int(extra_delay)
    ip[K.I_OUT] = int(out_mode)
    ip[K.I_PROBE] = -1
    ip[K.I_CHUNK] = 0 if force_per_sample else K.max_fast_chunk(cells, k, R, out_mode)
    ip[K.I_CHUNK_FREE] = 0 if force_per_sample else K.max_free_chunk(cells, k, R, out_mode,
                                                                      bool(ip[K.I_FILT]))
    ip[K.I_HLAST] = -1
    fp = np.zeros(K.F_NF)
    fp[K.F_DT] = dt_s
    fp[K.F_B0] = b0
    fp[K.F_B0T] = b0
    fp[K.F_B0S] = 1.0 - math.exp(-dt_s / glide_s)
    fp[K.F_A1] = a1
    fp[K.F_ETA] = eta
    fp[K.F_GAIN] = gain
    fp[K.F_TDX] = tension_over_dx
    fp[K.F_ADISP] = a_disp
    fp[K.F_SOS:K.F_SOS + 2 * len(sos)] = sos.ravel()
    fp[K.F_PAN] = 0.0 if pan is None else float(pan)
    fp[K.F_BDT] = bend_delay
    fp[K.F_BDS] = 1.0 - math.exp(-dt_s / bend_glide_s)
    fp[K.F_REACH] = region_reach(U, side, subcell)
    fp[K.F_CURV] = subcell
    Uc = None if U is None else np.array(U, dtype=float)
    return SlotTemplate(ip, fp, Uc, float(bend_delay))


def hammer_template(*, law: int, mass_kg: float, stiffness: float, exponent: float,
                    alpha_or_gamma: float, tau0_s: float, tension_n: float, c_m_per_s: float,
                    dt_s: float, max_flight_s: float = 0.05,
                    release_s: float = 0.004, solver_tol: float = SOLVER_TOL) -> HammerTemplate:
    """Validate a felt hammer once (parameters as :meth:`StringBank.start_hammer`).

    ``solver_tol`` (1e-12 .. 0.1): the felt solver stops when a correction
    changes the compression w by at most this, relative, or g by at most
    1e-8 of it (:data:`SOLVER_TOL`, 1e-5: to round-off; a work-precision
    knob, docs/work-precision.md)."""
    if not (1e-12 <= solver_tol <= 0.1):
        raise ValueError(f"solver_tol = {solver_tol!r} is out of range (1e-12 <= value <= 0.1)")
    if law not in (K.EXC_HAMMER3, K.EXC_HAMMER4):
        raise ValueError(f"law = {law!r} is not allowed ({K.EXC_HAMMER3}: three-parameter, "
                         f"{K.EXC_HAMMER4}: four-parameter)")
    if not (mass_kg > 0 and stiffness > 0 and exponent >= 1 and tension_n > 0 and c_m_per_s > 0):
        raise ValueError(f"hammer: mass_kg = {mass_kg!r}, stiffness = {stiffness!r}, "
                         f"exponent = {exponent!r}, tension_n = {tension_n!r}, c_m_per_s = "
                         f"{c_m_per_s!r} are out of range (all > 0, exponent >= 1)")
    if law == K.EXC_HAMMER4 and not tau0_s > 0:
        raise ValueError(f"tau0_s = {tau0_s!r} is out of range (value > 0)")
    tau0 = tau0_s if law == K.EXC_HAMMER4 else 1.0
    dt, Q, p, A = float(dt_s), float(stiffness), float(exponent), float(alpha_or_gamma)
    Kk = c_m_per_s / (2.0 * tension_n)            # g per unit felt impulse (m / (N s))
    mc = 2.0 * tension_n / (c_m_per_s * mass_kg)  # deceleration per unit g (1/s)
    dz = 0.5 * dt * mc
    E = math.exp(-dt / tau0)
    # the felt impulse over a step, K int F dt = K (ca y1 + cby y0 + cbp Phi0),
    # Phi1 = pe Phi0 + p1 y1 + p0 y0 and F1 = fa y1 + fb y0 + fphi Phi1
    # (synth.kernels.strings._hammer_general: eq. 1.5 and Pub. III eq. 3)
    if law == K.EXC_HAMMER3:
        ca, cby, cbp = Q * (0.5 * dt + A), Q * (0.5 * dt - A), 0.0
        pe = p1 = p0 = 0.0
        fa, fb, fphi = Q * (1.0 + A / dt), -Q * A / dt, 0.0
    else:
        h = dt / tau0
        qq = (1.0 - E) / h
        c1, c0 = 1.0 - qq, qq - E
        ca = Q * ((1.0 - A) * 0.5 * dt + A * tau0 * c1)
        cby = Q * ((1.0 - A) * 0.5 * dt + A * tau0 * c0)
        cbp = -Q * A * (1.0 - E)
        pe, p1, p0 = E, tau0 * c1, tau0 * c0
        fa, fb, fphi = Q, 0.0, -Q * A / tau0
    D = 1.0 + dz
    # in the order of _HAMMER_COLS
    v = np.array([Q, p, A, tau0, max(1.0, round(release_s / dt_s)), E, Kk, mc,
                  dz, D, Kk * ca, Kk * cby, Kk * cbp, Kk * ca * D * p, pe, p1, p0, fa, fb, fphi,
                  0.5 * p * (p - 1.0), p * (p - 1.0) * (p - 2.0) / 6.0]
                 + [math.prod(p - i for i in range(j)) / math.factorial(j) for j in range(4, 11)]
                 + [float(solver_tol), 1e-13 if solver_tol == SOLVER_TOL else 1e-8 * solver_tol])
    return HammerTemplate(int(law), v, max(1, int(round(max_flight_s / dt_s))), float(dt_s))


class StringBank:
    """Preallocated storage for up to ``capacity`` strings.

    Loss changes (dampers, releases) are given as a target
    (:meth:`set_loss`); the kernel glides to it with a time constant of
    ``LOSS_GLIDE_S``.

    Output rows: each slot writes its buses into a block of rows of the
    mix, from its output row r (:meth:`set_output_row`, default 0): bus 0
    to row r, bus 1 (a string configured with ``pan``) to row r + 1 when
    the mix has it (else all of it to row r, as a one-row mix takes every
    string).  The row is a property of the slot, not of its string: a new
    string in the slot (:meth:`configure_from`, :meth:`hand_over`) and
    :meth:`deactivate` keep it; only :meth:`set_output_row` changes it (the
    engine sets it per note-on).  :meth:`render` wants a mix of at least
    :attr:`mix_rows` rows.

    Parameters
    ----------
    capacity : int
        Number of string slots (1 .. 4096).
    max_cells : int
        Largest N any slot may hold (ring length 2N), 8 .. 10^6.
    max_region : int
        Largest termination region R (points), 0 .. 10^4.
    max_block : int
        Longest segment (internal samples) rendered in one call.
    n_probes : int
        Rows for per-sample diagnostics (channels ``P_*`` of the kernel: u at
        the excitation point, contacts, hammer force, felt compression,
        hammer position, g), used by study renders.
    max_gtable : int
        Longest injected g(t) table per slot (samples), 0 if none.
    """

    #: time constant (s) of the loss's glide to a new value (a damper falling
    #: or lifting, a fade): a damper's felt lands over a few ms; at 2 ms the
    #: glide's kink stepped the bass strings' bridge force (a key-up click
    #: 3x the tone's own sharpest change, 1.7x at 4 ms, none at 5 ms)
    LOSS_GLIDE_S = 0.005
    BEND_GLIDE_S = 0.02
    #: the fast path skips a chunk's termination region when a bound on the
    #: string's reach says no point can touch the obstacle (the same samples;
    #: :func:`region_reach`); False (set before configuring): it always runs
    #: (the check of that, and the benchmark of what it saves)
    skip_unreachable = True

    def __init__(self, capacity: int, max_cells: int, max_region: int = 64,
                 max_block: int = 4096, n_probes: int = 0, max_gtable: int = 0,
                 max_bend: int = 0, max_group: int = K.MAX_CPL):
        if not (1 <= capacity <= 4096):
            raise ValueError(f"capacity = {capacity!r} is out of range (1 <= value <= 4096)")
        if not (8 <= max_cells <= 1_000_000):
            raise ValueError(f"max_cells = {max_cells!r} is out of range (8 <= value <= 1000000)")
        if not (1 <= max_group <= capacity or max_group == K.MAX_CPL):
            raise ValueError(f"max_group = {max_group!r} is out of range "
                             f"(1 <= value <= {capacity}, the capacity)")
        self.capacity = int(capacity)
        self.max_group = int(max_group)
        self.max_cells = int(max_cells)
        self.max_region = int(max_region)
        self.max_block = int(max_block)
        self.ring = np.zeros(self.capacity * 2 * self.max_cells)
        self.ring.fill(0.0)            # fault the pages in now, not at a note-on
        self._clean = np.ones(self.capacity, dtype=bool)
        self.ipar = np.zeros((self.capacity, K.I_NI), dtype=np.int64)
        self.fpar = np.zeros((self.capacity, K.F_NF))
        self.fst = np.zeros((self.capacity, K.S_NS))
        self.max_gtable = int(max_gtable)
        self.max_bend = int(max_bend)
        # region profiles, g tables and pitch-bend lines, in one flat table array
        self.U = np.zeros(max(1, self.capacity * (self.max_region + self.max_gtable + self.max_bend)))
        # fast-path chunks never exceed max_block (the kernel's scratch layout)
        self.scratch = np.zeros(K.scratch_length(self.max_block, self.max_region, self.max_bend,
                                                 self.max_group))
        self.iwork = np.zeros(self.capacity + K.IWORK_EXTRA, dtype=np.int64)
        # staging mix of strings on a finer grid (two buses; more rows for a
        # coupled group across rows, _fit_sub); an external bridge's
        # displacement when the caller gives none (all zero)
        self.sub = np.zeros((2, K.sub_length(self.max_block)))
        # the highest output row of any slot (:meth:`set_output_row`)
        self._row_top = 0
        self._still = np.zeros(0)
        # steps per sample of the strings on the external bridge (ubx holds
        # that many values per sample; :meth:`set_external_bridge`)
        self._ext_sub = 1
        self._ext_sub_set = False
        # dampers, per slot: loss b0 undamped, loop frequency f1 (Hz), T60 with
        # the damper down and T60 free (s; inf: no free decay to keep)
        self.damper = np.zeros((self.capacity, 4))
        self.damper[:, :] = (1.0, 1.0, math.inf, math.inf)
        self.active = np.zeros(self.capacity, dtype=np.int64)
        self.n_active = 0
        self._is_active = np.zeros(self.capacity, dtype=bool)
        self.probe = np.zeros((max(n_probes, 1), K.P_NCH, 0))
        self.n_probes = int(n_probes)
        # silence bookkeeping (:meth:`reap`): samples each slot has been quiet,
        # its peak output in the last block, the slots found silent
        self.quiet = np.zeros(self.capacity, dtype=np.int64)
        self.last_peak = np.zeros(self.capacity)
        self._done = np.zeros(self.capacity, dtype=np.int64)
        for s in range(self.capacity):
            self.ipar[s, K.I_OFF] = s * 2 * self.max_cells
            self.ipar[s, K.I_REG_OFF] = s * self.max_region
            self.ipar[s, K.I_GT_OFF] = self.capacity * self.max_region + s * self.max_gtable
            self.ipar[s, K.I_BOFF] = (self.capacity * (self.max_region + self.max_gtable)
                                      + s * self.max_bend)
            self.ipar[s, K.I_PROBE] = -1
            self.ipar[s, K.I_CPL] = K.CPL_NONE
            self.ipar[s, K.I_CPLNX] = -1
            self.ipar[s, K.I_SUB] = 1
        # coupled groups (:meth:`couple`, :meth:`open_bridge`): the members
        # of each, by leader, in their chain's order; each slot's leader
        # (-1: none); the leaders of open groups (strings join and leave)
        self._members: dict[int, list[int]] = {}
        self._leader = np.full(self.capacity, -1, dtype=np.int64)
        self._open: set[int] = set()
        # the hand-over between grids (:meth:`hand_over`): its scratch, and
        # the far-end filters' free state directions by (unit delay,
        # first-order sections, biquads)
        self._ho_buf = np.zeros(K.hand_over_buffer_length(self.max_cells, self.HAND_OVER_ROWS))
        self._ho_At = np.zeros((K.MAX_FREE, self.HAND_OVER_ROWS))
        self._ho_R = np.zeros((K.MAX_FREE, K.MAX_FREE))
        self._ho_st = np.zeros(K.S_NS)
        self._ho_fp = np.zeros(K.F_NF)
        self._ho_one = np.zeros(1)
        self._free_dirs: dict[tuple, np.ndarray] = {}
        #: internal samples rendered since the bank was built (:meth:`after`)
        self.time = 0
        # the calls :meth:`after` holds: (due sample, order, function), a heap
        self._timers: list = []
        self._timer_seq = 0

    # -- slot management ------------------------------------------------------
    def activate(self, s: int) -> None:
        self._clean[s] = False
        if not self._is_active[s]:
            self._is_active[s] = True
            self.active[self.n_active] = s
            self.n_active += 1

    def deactivate(self, s: int) -> None:
        """Stop rendering slot s and clear its state (no denormal residue);
        it leaves its coupled group (a group's leader takes the group
        with it)."""
        if self._leader[s] >= 0:
            self.leave(s)
        if self._is_active[s]:
            self._is_active[s] = False
            idx = [int(x) for x in self.active[: self.n_active] if x != s]
            self.n_active = len(idx)
            self.active[: self.n_active] = idx
        self.quiet[s] = 0
        self.clear(s)

    def clear(self, s: int) -> None:
        off = self.ipar[s, K.I_OFF]
        N = self.ipar[s, K.I_N]
        if not self._clean[s]:
            self.ring[off: off + 2 * max(N, 0)] = 0.0
            self._clean[s] = True
        self.fst[s, :] = 0.0
        self.ipar[s, K.I_POS] = 0
        self.ipar[s, K.I_EXC] = K.EXC_NONE
        self.ipar[s, K.I_EXC_M] = 0
        self.ipar[s, K.I_HLAST] = -1

    def energy(self, slots) -> np.ndarray:
        """The wave energy each of ``slots`` stores now: the sum of the
        squares of its ring's travelling waves (both rails, the whole
        string; 0 for an inactive slot), one value per slot
        (:func:`synth.kernels.energy.ring_energy`).  A measure of how loud
        a note still is that does not depend on block boundaries."""
        idx = np.asarray(slots, dtype=np.int64)
        if idx.size and (idx.min() < 0 or idx.max() >= self.capacity):
            raise ValueError(f"slots out of range (0 <= value <= {self.capacity - 1})")
        offs = np.ascontiguousarray(self.ipar[idx, K.I_OFF], dtype=np.int64)
        lens = 2 * np.ascontiguousarray(self.ipar[idx, K.I_N], dtype=np.int64)
        lens[~self._is_active[idx]] = 0
        out = np.zeros(idx.size)
        ring_energy(self.ring, offs, lens, out)
        return out

    def is_active(self, s: int) -> bool:
        return bool(self._is_active[s])

    def grid_of(self, s: int) -> int:
        """Steps per engine sample of slot s (1: the engine's grid)."""
        return int(self.ipar[s, K.I_SUB])

    #: highest output row a slot may have (:meth:`set_output_row`)
    MAX_ROW = 255

    def set_output_row(self, s: int, row: int) -> None:
        """Write slot s's output from mix row ``row`` on (0 .. ``MAX_ROW``):
        bus 0 to that row, bus 1 to the next (see the class docstring), from
        its next rendered sample.  The row stays with the slot through
        reconfiguration and deactivation."""
        s = _index("s", s, self.capacity - 1)
        r = _index("row", row, self.MAX_ROW)
        old = int(self.ipar[s, K.I_ROW])
        self.ipar[s, K.I_ROW] = r
        if r > self._row_top:
            self._row_top = r
        elif old == self._row_top and r < old:
            self._row_top = int(self.ipar[:, K.I_ROW].max())
        if self._leader[s] >= 0:
            self._fit_sub(int(self._leader[s]))

    def output_row(self, s: int) -> int:
        """Slot s's output row (its bus 0; bus 1 is the next row)."""
        return int(self.ipar[s, K.I_ROW])

    @property
    def mix_rows(self) -> int:
        """The fewest rows of a mix that :meth:`render` takes: one more than
        the highest output row of any slot (active or not)."""
        return self._row_top + 1

    def _fit_sub(self, lead: int) -> None:
        """Enough rows in the finer grid's staging mix for the group led by
        ``lead``: the rows from its members' lowest output row to their
        highest plus one (the kernel stages a group's rows there)."""
        rows = self.ipar[self._members[lead], K.I_ROW]
        span = int(rows.max()) + 2 - int(rows.min())
        if span > self.sub.shape[0]:
            self.sub = np.zeros((span, self.sub.shape[1]))

    # -- configuration ----------------------------------------------------------
    def configure(self, s: int, *, cells: int, k: int, dt_s: float,
                  U: np.ndarray | None, side: int = 1,
                  out_mode: int = 0, gain: float = 1.0, tension_over_dx: float = 0.0,
                  b0: float = 1.0, a1: float = 0.0, eta: float = 0.0,
                  extra_delay: int = 0, lossy: bool = False,
                  probe_row: int = -1, force_per_sample: bool = False,
                  n_disp: int = 0, a_disp: float = 0.0, bend_len: int = 0,
                  bend_delay: float = 0.0, sos=None, pan: float | None = None,
                  sub: int = 1, subcell: float = 0.0) -> None:
        """Set up slot s as an idle string (zero state, no excitation).

        cells : N, 8 .. max_cells.  k : excitation/pickup point, 1 .. N-1.
        U : profile at points 1..R (m), +-inf where no contact, or None for
        the ideal rigid end (the region code then does not run at all).
        sos : (M, 2) array of (c1, c2), M <= ``K.MAX_SOS``: second-order
        dispersion allpasses (c2 + c1 z^-1 + z^-2)/(1 + c1 z^-1 + c2 z^-2)
        after the tuning allpass, or None.
        pan : share (0..1) of the string's output on bus 1 of a two-bus mix
        (1 - pan on bus 0), or None: all of it on bus 0.
        sub : steps per engine sample, 1 .. ``K.MAX_SUB``: a string on a
        finer grid runs at ``sub`` times the engine's internal rate (its
        ``dt_s`` is the engine's over ``sub``) and its output is the mean
        of each engine sample's steps.
        subcell : the first cell's sub-cell contact (the kernel's
        ``F_CURV``; 0: off, the clamp at grid points alone): the share of
        U(1) that is the profile's curvature, 1 - theta dx / U(1) with
        theta its slope at x = 0 (1 for the open jawari;
        :meth:`synth.physics.profiles.Termination.subcell`).
        (Voices that configure at note-on build a :func:`slot_template`
        once and call :meth:`configure_from`.)
        """
        t = slot_template(cells=cells, k=k, dt_s=dt_s, U=U, side=side, out_mode=out_mode,
                          gain=gain, tension_over_dx=tension_over_dx, b0=b0, a1=a1, eta=eta,
                          extra_delay=extra_delay, lossy=lossy,
                          force_per_sample=force_per_sample, n_disp=n_disp, a_disp=a_disp,
                          bend_len=bend_len, bend_delay=bend_delay,
                          glide_s=self.LOSS_GLIDE_S, bend_glide_s=self.BEND_GLIDE_S, sos=sos,
                          pan=pan, sub=sub, subcell=subcell)
        self.configure_from(s, t, probe_row)

    def configure_from(self, s: int, t: SlotTemplate, probe_row: int = -1) -> None:
        """Set up slot s from a template (zero state, no excitation)."""
        cells = int(t.ipar[K.I_N])
        if cells > self.max_cells:
            raise ValueError(f"cells = {cells!r} is out of range (8 <= value <= {self.max_cells})")
        R = int(t.ipar[K.I_REG_N])
        if R > self.max_region:
            raise ValueError(f"region points = {R} is out of range (0 <= value <= {self.max_region})")
        blen = int(t.ipar[K.I_BLEN])
        if blen > self.max_bend:
            raise ValueError(f"bend_len = {blen!r} is out of range (0 <= value <= {self.max_bend})")
        if self._leader[s] >= 0:
            self.leave(s)              # a new string: off its bridge
        self.clear(s)                  # (free when the slot is already clean)
        self._write_template(s, t, _SLOT_COLS)
        ip = self.ipar[s]
        ip[K.I_PROBE] = int(probe_row)
        if blen:
            self.U[ip[K.I_BOFF]: ip[K.I_BOFF] + blen] = 0.0
        self.fst[s, K.S_BD] = t.bend_delay

    def _write_template(self, s: int, t: SlotTemplate, keep_cols) -> None:
        """Slot s's parameters and profile from template t, its ``ipar``
        columns ``keep_cols`` kept; chunks within this bank's block."""
        ip = self.ipar[s]
        keep = [int(ip[c]) for c in keep_cols]
        ip[:] = t.ipar
        for c, v in zip(keep_cols, keep):
            ip[c] = v
        ip[K.I_CHUNK] = min(int(ip[K.I_CHUNK]), self.max_block)
        ip[K.I_CHUNK_FREE] = min(int(ip[K.I_CHUNK_FREE]), self.max_block)
        self.fpar[s, :] = t.fpar
        if not self.skip_unreachable:
            self.fpar[s, K.F_REACH] = 0.0
        R = int(ip[K.I_REG_N])
        if R:
            self.U[ip[K.I_REG_OFF]: ip[K.I_REG_OFF] + R] = t.U

    def set_region(self, s: int, U: np.ndarray) -> None:
        """Replace slot s's termination profile U(1..R) (m) from its next
        sample on (a buzz control on a sounding string); R is the slot's,
        as configured."""
        R = int(self.ipar[s, K.I_REG_N])
        U = np.asarray(U, float)
        if U.shape != (R,):
            raise ValueError(f"U has shape {U.shape}; slot {s} has a region of {R} points")
        off = int(self.ipar[s, K.I_REG_OFF])
        self.U[off: off + R] = U
        self.fpar[s, K.F_REACH] = (region_reach(U, int(self.ipar[s, K.I_SIDE]),
                                                self.fpar[s, K.F_CURV])
                                   if self.skip_unreachable else 0.0)

    def fade(self, s: int, t60_s: float, fs_hz: float) -> None:
        """Fade slot s out: its loop loses 60 dB in ``t60_s`` (s) more than
        it does now (a stolen or shed voice; about 10 ms, never a cut: that
        clicks).  ``fs_hz`` is the rate the slot runs at (Hz).  The far-end
        filter is switched on if the string was lossless.  No effect on an
        inactive slot."""
        if self._is_active[s]:
            P = 2 * int(self.ipar[s, K.I_N])
            fs = fs_hz * int(self.ipar[s, K.I_SUB])       # a string on a finer grid
            self.set_loss(s, float(self.fpar[s, K.F_B0T]) * 10.0 ** (-3.0 * P / (fs * t60_s)))
            self.ipar[s, K.I_FILT] = 1

    def excitation_running(self, s: int) -> bool:
        """Whether slot s's excitation (pluck, g table or hammer) still runs."""
        return bool(self.ipar[s, K.I_EXC] > K.EXC_NONE)

    def reap(self, n_in: int, level: float, min_quiet: int) -> np.ndarray:
        """Per-block silence bookkeeping of the active slots (one kernel call,
        :func:`synth.kernels.strings.scan_silence`, no allocation): record
        each slot's peak output of the block in :attr:`last_peak`, count the
        samples it has stayed below ``level`` with no excitation running,
        and return the slots quiet for max(4 periods, ``min_quiet``
        samples) (a view, valid until the next call; the caller decides
        whether to :meth:`deactivate` them).  A slot's count restarts at
        :meth:`deactivate` and :meth:`reset_quiet`."""
        if self.n_active == 0:
            return self._done[:0]
        nd = K.scan_silence(self.active, self.n_active, self.ipar, self.fst, self.quiet,
                            self.last_peak, n_in, level, min_quiet, self._done)
        done = self._done[:nd]
        if nd and np.any(self.ipar[done, K.I_CPL] >= 0):
            # a coupled group goes only as a whole (its leader renders it);
            # a member of an open group other than its leader goes alone
            lead = self.ipar[done, K.I_CPL]
            gone = set(done.tolist())
            keep = np.ones(nd, dtype=bool)
            for j in np.flatnonzero(lead >= 0):
                L, s = int(lead[j]), int(done[j])
                if L in self._open and s != L:
                    continue
                if not all((m in gone) or not self._is_active[m] for m in self._members[L]):
                    keep[j] = False
            if not keep.all():
                nk = int(np.count_nonzero(keep))
                self._done[:nk] = done[keep]
                return self._done[:nk]
        return done

    def reset_quiet(self, s: int, before: int = 0) -> None:
        """Restart slot s's silence count (a note-on: it sounds again)
        ``before`` samples into the current block: the next :meth:`reap`
        adds the whole block, and those samples, before the note, must not
        count as its silence.  (They did: a harpsichord note plucked in the
        last 80 output samples of a 1024-sample block, its wave not yet at
        the bridge, was freed as silent before it sounded.)"""
        self.quiet[s] = -int(before)

    def set_loss(self, s: int, b0: float) -> None:
        """New loss filter gain b0 for slot s (a damper falling or lifting):
        reached smoothly within a few ``LOSS_GLIDE_S``."""
        self.fpar[s, K.F_B0T] = b0

    def set_loss_filter(self, s: int, b0: float, a1: float) -> None:
        """Give slot s the loss filter b0 / (1 + a1 z^-1) from its next
        sample: ``b0`` its undamped gain (the damper row's, :meth:`set_damper`),
        ``a1`` its feedback coefficient.  The damper's share and a glide
        under way are kept (the gain now and its target scale by ``b0``
        over the old undamped gain) and :meth:`apply_dampers` damps the new
        one.  Given the same gain at DC as before, b0 / (1 + a1), a sounding
        string's low partials do not step; only its upper ones lose more
        (or less) per round trip, and the filter's phase delay changes with
        the pole (the caller's to take back, e.g. with :meth:`set_bend_delay`).

        Parameters
        ----------
        b0 : float
            Gain, 0 < value < 1 - |a1|: below 1 at every frequency (the
            loop must not grow).
        a1 : float
            Feedback coefficient, -1 < value < 1 (a lowpass for a1 < 0).
        """
        b0, a1 = float(b0), float(a1)
        if not (-1.0 < a1 < 1.0):
            raise ValueError(f"a1 = {a1!r} is out of range (-1 < value < 1)")
        if not (0.0 < b0 < 1.0 - abs(a1)):
            raise ValueError(f"b0 = {b0!r} is out of range (0 < value < 1 - |a1| = "
                             f"{1.0 - abs(a1):g}: a loop gain below 1 at every frequency)")
        old = float(self.damper[s, 0])
        for c in (K.F_B0, K.F_B0T):
            share = float(self.fpar[s, c]) / old
            self.fpar[s, c] = b0 if share == 1.0 else b0 * share     # (undamped: exactly b0)
        self.fpar[s, K.F_A1] = a1
        self.damper[s, 0] = b0

    def set_damper(self, s: int, row) -> None:
        """Slot s's damper: ``row`` = (b0 undamped, f1_hz, t60_damped_s,
        t60_free_s) (see :meth:`apply_dampers`)."""
        self.damper[s, :] = row

    def apply_dampers(self, slots, lift) -> None:
        """Set the loss of ``slots`` for dampers lifted by ``lift`` (0: on
        the strings .. 1: off; one value, or one per slot), all at once: the T60 moves geometrically
        from the damped to the free value with the lift, and the extra
        decay rate sigma = ln(1000)/T60 - ln(1000)/T60_free (1/s, >= 0) scales the
        loop gain, b0 = b0_undamped exp(-sigma / f1) (a pure gain: the
        tuning does not move).  Glided to like :meth:`set_loss`."""
        d = self.damper[slots]
        td = d[:, 2]
        tf = d[:, 3]
        if np.ndim(lift) == 1:
            # one lift per slot
            lf = np.clip(np.asarray(lift, dtype=float), 0.0, 1.0)
            t = np.exp((1.0 - lf) * np.log(td) + lf * np.log(tf))
        elif lift <= 0.0:
            t = td
        elif lift >= 1.0:
            t = tf
        else:
            t = np.exp((1.0 - lift) * np.log(td) + lift * np.log(tf))
        sigma = np.maximum(_LN1000 / t - _LN1000 / tf, 0.0)
        self.fpar[slots, K.F_B0T] = d[:, 0] * np.exp(-sigma / d[:, 1])

    def _tune_out_samples(self, s: int) -> float:
        return float(self.fpar[s, K.F_TOG] * self.fst[s, K.S_TO])

    def set_bend_delay(self, s: int, delay: float) -> None:
        """New delay (samples) of slot s's pitch-bend line, glided to (kept
        within the line with the tune-out of :meth:`set_tune_out` added)."""
        blen = int(self.ipar[s, K.I_BLEN])
        if blen:
            to = self._tune_out_samples(s)
            self.fpar[s, K.F_BDT] = min(max(delay, 1.0 - min(to, 0.0)), blen - 3.0 - max(to, 0.0))

    def _tune_out_room(self, s: int) -> tuple[float, float]:
        """The tune-out (samples) the bend line has room for at its bend."""
        blen = int(self.ipar[s, K.I_BLEN])
        return (1.0 - min(self.fst[s, K.S_BD], self.fpar[s, K.F_BDT]),
                blen - 3.0 - max(self.fst[s, K.S_BD], self.fpar[s, K.F_BDT]))

    def set_tune_out(self, s: int, delay: float, tau_s: float, gain: float = 1.0) -> None:
        """From slot s's next sample, lengthen its pitch-bend line by ``gain``
        x ``delay`` samples (negative: shorten it), the delay decaying as
        exp(-t / ``tau_s``): a pitch offset that fades with the note, such as
        the tuning out of the rise a termination's contact gives while the
        string swings wide (:class:`synth.voices.one_string.OneStringVoice`).
        No-op on a slot without a bend line.

        Parameters
        ----------
        delay : float
            Samples of the internal rate at t = 0 (at gain 1); the line's
            length less the bend's delay bounds gain x delay.
        tau_s : float
            Time constant (s), > 0.
        gain : float
            Its scale, >= 0, changed on a sounding string by
            :meth:`set_tune_out_gain`.
        """
        if not (tau_s > 0.0 and math.isfinite(tau_s)):
            raise ValueError(f"tau_s = {tau_s!r} is not allowed (> 0 s)")
        if not (gain >= 0.0 and math.isfinite(gain)):
            raise ValueError(f"gain = {gain!r} is not allowed (>= 0)")
        if not int(self.ipar[s, K.I_BLEN]):
            return
        lo, hi = self._tune_out_room(s)
        self.fpar[s, K.F_TOG] = gain
        self.fpar[s, K.F_TOR] = math.exp(-float(self.fpar[s, K.F_DT]) / tau_s)
        self.fst[s, K.S_TO] = (min(max(gain * float(delay), lo), hi) / gain) if gain > 0.0 else float(delay)

    def set_tune_out_gain(self, s: int, gain: float) -> None:
        """Rescale slot s's tune-out (:meth:`set_tune_out`) to ``gain`` (>= 0)
        without a step: the bend line's current delay takes the difference
        and glides it away at the bend's rate."""
        if not (gain >= 0.0 and math.isfinite(gain)):
            raise ValueError(f"gain = {gain!r} is not allowed (>= 0)")
        if not int(self.ipar[s, K.I_BLEN]):
            return
        to = float(self.fst[s, K.S_TO])
        old = float(self.fpar[s, K.F_TOG])
        lo, hi = self._tune_out_room(s)
        if gain > 0.0:
            to = min(max(gain * to, lo), hi) / gain
            self.fst[s, K.S_TO] = to
        self.fst[s, K.S_BD] += (old - gain) * to
        self.fpar[s, K.F_TOG] = gain

    def start_pluck(self, s: int, model: int, amplitude_m: float, duration_s: float,
                    alpha_per_s: float = 0.0) -> None:
        """Begin a kinematic pluck on slot s at its next sample: ``model``
        ``K.EXC_SITAR`` (g(t) of eq. 1.13) or ``K.EXC_BIWA`` (force pluck,
        eq. 1.11; ``alpha_per_s``).  A pluck on a sounding string adds to it."""
        if model not in (K.EXC_SITAR, K.EXC_BIWA):
            raise ValueError(f"model = {model!r} is not allowed ({K.EXC_SITAR}: sitar g(t), "
                             f"{K.EXC_BIWA}: biwa force pluck)")
        ip, fp, st = self.ipar[s], self.fpar[s], self.fst[s]
        if ip[K.I_EXC] != K.EXC_NONE:
            self._end_excitation(s)
        dt = float(fp[K.F_DT])
        e_end = int(duration_s / dt)
        while e_end * dt <= duration_s:     # same float test as the kernel's g
            e_end += 1
        while e_end > 0 and (e_end - 1) * dt > duration_s:
            e_end -= 1
        ip[K.I_EXC] = int(model)
        ip[K.I_EXC_M] = 0
        ip[K.I_EXC_END] = e_end
        fp[K.F_A] = amplitude_m
        fp[K.F_T0] = duration_s
        fp[K.F_ALPHA] = alpha_per_s

    def _end_excitation(self, s: int) -> None:
        """Freeze a running excitation at its current g and, as the kernel
        does when one ends, fold that constant g into the ring (add it on the
        loop segment through x = 0; exact for lossy and lossless strings, see
        :mod:`synth.kernels.strings`), so that a new one can start from g = 0."""
        ip, st = self.ipar[s], self.fst[s]
        G = st[K.S_G]
        if G != 0.0:
            N = int(ip[K.I_N])
            P = 2 * N
            k = int(ip[K.I_K])
            q = np.arange(-k, k)
            idx = ip[K.I_OFF] + (int(ip[K.I_POS]) - q) % P
            self.ring[idx] += G
        st[K.S_G] = 0.0
        ip[K.I_EXC] = K.EXC_NONE

    def start_gtable(self, s: int, g: np.ndarray) -> None:
        """Inject a given outgoing wave g (m, one value per internal sample,
        held at its last value afterwards) at slot s's excitation point."""
        g = np.asarray(g, float)
        if not (1 <= len(g) <= self.max_gtable):
            raise ValueError(f"g table length = {len(g)} is out of range (1 <= value <= {self.max_gtable})")
        ip = self.ipar[s]
        if ip[K.I_EXC] != K.EXC_NONE:
            self._end_excitation(s)
        o = ip[K.I_GT_OFF]
        self.U[o: o + len(g)] = g
        ip[K.I_EXC] = K.EXC_GTABLE
        ip[K.I_EXC_M] = 0
        ip[K.I_EXC_END] = len(g)

    def start_hammer(self, s: int, *, law: int, mass_kg: float, speed_m_per_s: float,
                     stiffness: float, exponent: float, alpha_or_gamma: float,
                     tau0_s: float, tension_n: float, c_m_per_s: float,
                     max_flight_s: float = 0.05, release_s: float = 0.004,
                     solver_tol: float = SOLVER_TOL) -> None:
        """Strike slot s with a felt hammer (eq. 1.4) from its next sample.

        law : ``K.EXC_HAMMER3``, three-parameter felt (eq. 1.5; ``stiffness``
            = Q0 in N/mm^p, ``alpha_or_gamma`` = alpha in s), or
            ``K.EXC_HAMMER4``, four-parameter felt (Pub. III
            eq. 3; ``stiffness`` = F0 in N/mm^p, ``alpha_or_gamma`` = gamma,
            ``tau0_s``).
        The hammer starts touching the string where it is now (w = 0) and
        flies until it has been out of contact for ``release_s`` (it may hit
        again before that) or ``max_flight_s`` has passed.  (Voices that
        strike at note-on build a :func:`hammer_template` once and call
        :meth:`start_hammer_from`.)
        """
        t = hammer_template(law=law, mass_kg=mass_kg, stiffness=stiffness, exponent=exponent,
                            alpha_or_gamma=alpha_or_gamma, tau0_s=tau0_s, tension_n=tension_n,
                            c_m_per_s=c_m_per_s, dt_s=float(self.fpar[s, K.F_DT]),
                            max_flight_s=max_flight_s, release_s=release_s,
                            solver_tol=solver_tol)
        self.start_hammer_from(s, t, speed_m_per_s)

    def start_hammer_from(self, s: int, t: HammerTemplate, speed_m_per_s: float,
                          stiffness_factor: float = 1.0) -> None:
        """Strike slot s with the hammer ``t`` at ``speed_m_per_s`` (m/s,
        0 < value <= 20), its felt stiffness scaled by ``stiffness_factor``
        (0 < value <= 4: the soft pedal's softer felt, times the voicing's
        ``action.hardness``)."""
        if not (0.0 < speed_m_per_s <= 20.0):
            raise ValueError(f"speed_m_per_s = {speed_m_per_s!r} is out of range (0 < value <= 20)")
        if not (0.0 < stiffness_factor <= 4.0):
            raise ValueError(f"stiffness_factor = {stiffness_factor!r} is out of range (0 < value <= 4)")
        ip, fp, st = self.ipar[s], self.fpar[s], self.fst[s]
        if fp[K.F_DT] != t.dt_s:
            raise ValueError(f"hammer template dt_s = {t.dt_s!r} does not match slot {s}'s "
                             f"time step {fp[K.F_DT]!r}")
        if ip[K.I_EXC] != K.EXC_NONE:
            self._end_excitation(s)
        u_now = self.displacement_at_excitation(s)
        fp[_HAMMER_COLS] = t.values
        fp[K.F_HV] = speed_m_per_s
        fp[K.F_HDTV] = t.dt_s * speed_m_per_s
        if stiffness_factor != 1.0:
            fp[_HAMMER_Q_COLS] *= stiffness_factor
        # One time convention for every exciter (issue 13): sample i of the
        # excitation holds t = i dt, as a pluck's g(i dt) does.  A kernel
        # hammer step advances the hammer from t - dt to t, so the hammer
        # starts one step before the string: at sample 0 it arrives (z = u,
        # w = 0, F = 0, g(0) = 0) and its first contact force acts at t = dt.
        # (It started at the string, and sample i held t = (i + 1) dt.)
        st[K.S_HZ] = u_now - fp[K.F_HDTV]
        st[K.S_HY] = 0.0
        st[K.S_HPHI] = 0.0
        st[K.S_HW] = 0.0
        st[K.S_HDG] = 0.0
        st[K.S_HDG2] = 0.0
        st[K.S_HDG3] = 0.0
        st[K.S_HIW] = 0.0
        ip[K.I_EXC] = t.law
        ip[K.I_EXC_M] = 0
        ip[K.I_EXC_END] = t.e_end
        ip[K.I_HLAST] = -1

    def start_felt_layer(self, s: int, *, mass_kg: float, speed_m_per_s: float,
                         thickness_m: float, area_m2: float, density_kg_per_m3: float,
                         e_dynamic_pa: float, exponent: float, gamma: float, tau0_s: float,
                         cells: int, tension_n: float, c_m_per_s: float,
                         max_flight_s: float = 0.05, release_s: float = 0.004,
                         courant: float = 0.5, damping: float = 0.5,
                         substeps: int = 0) -> None:
        """Strike slot s with a hammer whose felt is a medium (the felt-layer
        model, :mod:`synth.kernels.felt_layer`) from its next sample.

        The head (``mass_kg`` on this string, felt included) carries a felt
        column of ``thickness_m`` (m), cross-section ``area_m2`` (m^2) and
        density ``density_kg_per_m3``, with the hereditary power law of
        thesis eqs. 2.1-2.3: ``e_dynamic_pa`` E_d (Pa, the coefficient of
        eps^p), ``exponent`` p, ``gamma``, ``tau0_s`` (s); solved on
        ``cells`` cells (2 .. 1024), sub-stepped inside each string step
        (``courant``: target Courant number, 0 < value <= 0.5; ``damping``:
        the grid-scale damper, 0 <= value <= 0.55; ``substeps``: 0 adapts
        the sub-step to the strain, N > 0 holds N per string step).  The
        string side: ``tension_n`` T and ``c_m_per_s`` c (eq. 1.4).  It
        arrives on the string at sample 0 at ``speed_m_per_s`` and flies
        until out of contact for ``release_s`` or ``max_flight_s`` has
        passed, as :meth:`start_hammer`.  Its state lives in the slot's g
        table (``max_gtable`` >= :func:`synth.kernels.felt_layer.block_length`);
        the string runs on the per-sample path while it does.
        """
        def chk(name, v, lo, hi, lo_open=False):
            v = float(v)
            if not (math.isfinite(v) and (lo < v if lo_open else lo <= v) and v <= hi):
                op = "<" if lo_open else "<="
                raise ValueError(f"{name} = {v!r} is out of range ({lo:g} {op} value <= {hi:g})")
            return v

        if not (isinstance(cells, (int, np.integer)) and 2 <= cells <= 1024):
            raise ValueError(f"cells = {cells!r} is out of range (integer, 2 <= value <= 1024)")
        nc = int(cells)
        need = FL.block_length(nc)
        if need > self.max_gtable:
            raise ValueError(f"cells = {nc} needs a g table of {need} values; the bank holds "
                             f"{self.max_gtable} (max_gtable)")
        m = chk("mass_kg", mass_kg, 0.0, 1.0, True)
        v0 = chk("speed_m_per_s", speed_m_per_s, 0.0, 20.0, True)
        h = chk("thickness_m", thickness_m, 1e-4, 0.1)
        A = chk("area_m2", area_m2, 1e-8, 1e-2)
        rho = chk("density_kg_per_m3", density_kg_per_m3, 10.0, 1e4)
        Ed = chk("e_dynamic_pa", e_dynamic_pa, 0.0, 1e18, True)
        p = chk("exponent", exponent, 1.0, 10.0)
        gm = chk("gamma", gamma, 0.0, 0.999999)
        tau = chk("tau0_s", tau0_s, 1e-9, 1.0)
        T = chk("tension_n", tension_n, 0.0, 1e15, True)
        c = chk("c_m_per_s", c_m_per_s, 0.0, 1e6, True)
        cour = chk("courant", courant, 0.0, 0.5, True)
        damp = chk("damping", damping, 0.0, 0.5 / FL.COURANT_HARD)
        if not (isinstance(substeps, (int, np.integer)) and 0 <= substeps <= FL.MAX_NSUB):
            raise ValueError(f"substeps = {substeps!r} is out of range "
                             f"(integer, 0 <= value <= {FL.MAX_NSUB})")
        m_felt = rho * A * h
        if not m_felt < 0.9 * m:
            raise ValueError(f"felt mass = {m_felt:g} kg is out of range (< 0.9 x mass_kg = "
                             f"{0.9 * m:g}: rho A h of the column against the head)")
        ip, fp, st = self.ipar[s], self.fpar[s], self.fst[s]
        if ip[K.I_EXC] != K.EXC_NONE:
            self._end_excitation(s)
        dt = float(fp[K.F_DT])
        dx = h / nc
        o = int(ip[K.I_GT_OFF])
        b = self.U[o:o + need]
        b[:] = 0.0
        b[FL.L_NC] = nc
        b[FL.L_DX] = dx
        b[FL.L_P] = p
        b[FL.L_ED] = Ed
        b[FL.L_GT] = gm / tau
        b[FL.L_TAU] = tau
        b[FL.L_RHO] = rho
        b[FL.L_AREA] = A
        b[FL.L_M0] = 0.5 * rho * A * dx
        b[FL.L_MC] = m - m_felt + 0.5 * rho * A * dx
        b[FL.L_K] = c / (2.0 * T)
        b[FL.L_DTS] = dt
        b[FL.L_COUR] = cour
        b[FL.L_DAMP] = damp
        b[FL.L_V0] = v0
        # the first touch's shock strain v0 / U, U^(p+1) = E_d v0^(p-1) / rho
        # (synth.physics.felt.first_touch_force_n): the sub-step's floor
        b[FL.L_ETOUCH] = v0 / (Ed * v0 ** (p - 1.0) / rho) ** (1.0 / (p + 1.0))
        b[FL.L_FIXED] = int(substeps)
        b[FL.L_NSUB] = 1.0
        fp[K.F_HV] = v0
        fp[K.F_HREL] = max(1.0, round(release_s / dt))
        ip[K.I_EXC] = K.EXC_FELT
        ip[K.I_EXC_M] = 0
        ip[K.I_EXC_END] = max(1, int(round(max_flight_s / dt)))
        ip[K.I_HLAST] = -1
        st[K.S_HY] = 0.0
        st[K.S_HPHI] = 0.0

    def felt_layer_substeps(self, s: int) -> int:
        """Sub-steps the felt layer of slot s has taken since its strike."""
        return int(self.U[int(self.ipar[s, K.I_GT_OFF]) + FL.L_STEPS])

    # -- bridges ----------------------------------------------------------------
    def couple(self, slots, resistance_ns_per_m: float, return_hz: float = 5.0,
               mass_hz: float = 0.0) -> None:
        """Put the strings of ``slots`` (1 .. ``max_group`` distinct slots,
        configured lossy, with the bridge-force output, the same grid) on
        one bridge: a dashpot of resistance ``resistance_ns_per_m`` (N s/m,
        > 0) with a spring that brings it back at ``return_hz`` (Hz, >= 0;
        keeps it from drifting), driven by the strings' summed force, whose
        motion every string's end follows (Weinreich's coupled unison).
        ``mass_hz`` (Hz, >= 0; 0: none) gives the bridge a mass M =
        R / (2 pi mass_hz): its admittance 1 / (R + j w M) is the dashpot's
        below ``mass_hz`` and falls as a mass's above it.
        Every slot must be activated (:meth:`activate`): the group renders
        from its first slot.  The bridge starts at rest.  The group goes as
        a whole (:meth:`reap`)."""
        slots = [int(x) for x in slots]
        G = len(slots)
        if not (1 <= G <= self.max_group) or len(set(slots)) != G:
            raise ValueError(f"slots = {slots!r} is out of range (1 to {self.max_group} "
                             f"distinct slots)")
        self._new_bridge(slots[0], resistance_ns_per_m, return_hz, mass_hz)
        for s in slots[1:]:
            self._check_member(s, slots[0])
        self._members[slots[0]] = slots
        self._chain(slots[0])

    def open_bridge(self, lead: int, resistance_ns_per_m: float, return_hz: float = 5.0) -> None:
        """A bridge (as :meth:`couple`) that strings join and leave while it
        sounds (:meth:`join`, :meth:`leave`; a deactivated member leaves),
        led by slot ``lead``, its first member: a sitar's taraf, chikari and
        played strings on one bridge.  The leader must stay active while
        the group has other members; deactivating it ends the group."""
        self._new_bridge(int(lead), resistance_ns_per_m, return_hz)
        self._members[int(lead)] = [int(lead)]
        self._open.add(int(lead))
        self._chain(int(lead))

    def join(self, lead: int, s: int) -> None:
        """Slot s (configured, lossy, bridge-force output, on the leader's
        grid) joins the open bridge led by ``lead`` from its next sample:
        from then on its end follows the bridge (a string joins at its
        note-on, so the end's step, the bridge's displacement, falls under
        the note's attack), and its force drives it."""
        lead, s = int(lead), int(s)
        if lead not in self._open:
            raise ValueError(f"lead = {lead} is out of range (the leader of an open bridge)")
        mem = self._members[lead]
        if s in mem:
            return
        if len(mem) >= self.max_group:
            raise ValueError(f"the bridge led by slot {lead} holds {len(mem)} strings, the "
                             f"most this bank takes (max_group = {self.max_group})")
        self._check_member(s, lead)
        if self._leader[s] >= 0:
            self.leave(s)
        mem.append(s)
        self._chain(lead)
        # the force of its first sample on the bridge reads the bridge's last
        # step as its own (the lockstep path's reading, :func:`_bridge`)
        self.fst[s, K.S_UBP] = self.fst[lead, K.S_UBM]

    def leave(self, s: int) -> None:
        """Slot s leaves its coupled group (its end on a rigid support from
        its next sample: a string leaves as it is freed or set up anew);
        the leader's leaving ends the group."""
        s = int(s)
        lead = int(self._leader[s])
        if lead < 0:
            return
        mem = self._members[lead]
        if s == lead:
            for m in mem:
                self._unhook(m)
            del self._members[lead]
            self._open.discard(lead)
            return
        mem.remove(s)
        self._unhook(s)
        self._chain(lead)

    def group(self, lead: int) -> tuple:
        """The slots on the bridge led by ``lead`` (empty: no such group)."""
        return tuple(self._members.get(int(lead), ()))

    def _new_bridge(self, lead: int, resistance_ns_per_m: float, return_hz: float,
                    mass_hz: float = 0.0) -> None:
        if not (resistance_ns_per_m > 0.0) or not math.isfinite(resistance_ns_per_m):
            raise ValueError(f"resistance_ns_per_m = {resistance_ns_per_m!r} is out of range (value > 0)")
        if not (return_hz >= 0.0):
            raise ValueError(f"return_hz = {return_hz!r} is out of range (value >= 0)")
        if not (mass_hz >= 0.0) or not math.isfinite(mass_hz):
            raise ValueError(f"mass_hz = {mass_hz!r} is out of range (value >= 0, finite)")
        if self._leader[lead] >= 0:
            self.leave(lead)
        self._check_member(lead, lead)
        dt = float(self.fpar[lead, K.F_DT])
        self.fpar[lead, K.F_BRB] = dt / resistance_ns_per_m
        self.fpar[lead, K.F_BRA] = math.exp(-2.0 * math.pi * return_hz * dt)
        # mu = M / (R dt) with M = R / (2 pi mass_hz): the mass's step against the dashpot's
        self.fpar[lead, K.F_BRMU] = 1.0 / (2.0 * math.pi * mass_hz * dt) if mass_hz > 0 else 0.0
        self.fst[lead, K.S_UBW] = 0.0
        self.fst[lead, K.S_UBM] = 0.0

    def _check_member(self, s: int, lead: int) -> None:
        ip = self.ipar[s]
        if ip[K.I_FILT] != 1 or ip[K.I_OUT] != 1:
            raise ValueError(f"slot {s} cannot hang on a bridge (it needs a lossy far end "
                             f"and the bridge-force output)")
        if ip[K.I_SUB] != self.ipar[lead, K.I_SUB]:
            raise ValueError(f"slot {s} runs on another grid than slot {lead}")

    def _chain(self, lead: int) -> None:
        """Write the group's chain into the kernel's columns."""
        mem = self._members[lead]
        G = len(mem)
        for i, m in enumerate(mem):
            self.ipar[m, K.I_CPL] = lead
            self.ipar[m, K.I_CPLN] = G
            self.ipar[m, K.I_CPLNX] = mem[i + 1] if i + 1 < G else -1
            self._leader[m] = lead
        self.fpar[lead, K.F_BTDX] = float(np.sum(self.fpar[mem, K.F_TDX]))
        self._fit_sub(lead)

    # -- leaving a finer grid ---------------------------------------------------
    #: rows of the least-squares fit of the far-end filter's state (samples
    #: of the coarser grid; at most N - 2, the waves that reach the far end
    #: without passing the termination again)
    HAND_OVER_ROWS = 96

    def hand_over(self, slots, templates, damper_rows) -> bool:
        """Move sounding strings from a finer grid to a coarser one without
        a click: the strings of ``slots`` (one coupled group whole, in any
        order, or single uncoupled strings), each to its template in
        ``templates`` (the same string designed on the coarser grid, whose
        ``I_SUB`` divides the slot's), with its damper row in ``damper_rows``
        (:meth:`set_damper`).  Returns False, changing nothing, while an
        excitation still runs on one of them, or one has a pitch-bend line,
        or the grids do not divide; True when done.

        The string's state is its loop: the ring holds the waves that will
        arrive at the far end in the next 2N steps.  The coarser ring takes
        them at the coarser steps (linear interpolation; a finer grid's
        engine sample is the mean of its r steps, so the coarser step m
        stands at fine step r m + (r - 1) / 2), placed so that the
        termination (x = 0) keeps its place: arrival m of the new ring is
        arrival r m + delta + (r - 1) / 2 of the old, delta = N_fine - r
        N_coarse.  The far-end filter's state does not carry over between
        two designs (its poles differ), so it is fitted: the state whose
        next outputs, with the new ring's arrivals, come nearest (least
        squares over :attr:`HAND_OVER_ROWS` steps) the old filter's, run on
        from its own state on the old ring's arrivals (one call of
        :func:`synth.kernels.strings.hand_over_loop` per string, no
        allocation in it: 0.17-0.23 ms for a key's three strings, most of
        it this method's Python; ``tools/study_capo.py cost``).  The bridge keeps its
        displacement, its step w = v dt is scaled by r, its constants are
        the coarser step's; the loss keeps its damper's share (b0 over the
        undamped b0).  ``tools/study_capo.py switch`` measured the scheme
        on the numpy reference string: the wave at the far end within -54
        to -66 dB of the fine string's own continuation (docs/voicing.md)."""
        slots = [int(s) for s in slots]
        if len(templates) != len(slots) or len(damper_rows) != len(slots):
            raise ValueError(f"slots, templates and damper_rows have lengths {len(slots)}, "
                             f"{len(templates)}, {len(damper_rows)} (one each per slot)")
        lead = int(self._leader[slots[0]])
        if lead >= 0 and sorted(self._members[lead]) != sorted(slots):
            raise ValueError(f"slots {slots} are not the whole coupled group led by slot {lead}")
        for s, t in zip(slots, templates):
            ip = self.ipar[s]
            if ip[K.I_EXC] > K.EXC_NONE or ip[K.I_BLEN] != 0:
                return False
            Mf, Mc = int(ip[K.I_SUB]), int(t.ipar[K.I_SUB])
            if Mc > Mf or Mf % Mc:
                return False
            if int(t.ipar[K.I_N]) > self.max_cells or int(t.ipar[K.I_REG_N]) > self.max_region:
                return False
            if int(t.ipar[K.I_BLEN]) != 0:
                return False
        r = int(self.ipar[slots[0], K.I_SUB]) // int(templates[0].ipar[K.I_SUB])
        if r == 1:
            return True
        for s, t, row in zip(slots, templates, damper_rows):
            self._hand_over_slot(s, t, row, r)
        if lead >= 0:
            # the bridge's constants for the coarser step (exp(-w dt), dt / R,
            # M / (R dt)); its step w = v dt scales with dt; F_BTDX anew
            fp = self.fpar[lead]
            fp[K.F_BRA] = fp[K.F_BRA] ** r
            fp[K.F_BRB] = fp[K.F_BRB] * r
            fp[K.F_BRMU] = fp[K.F_BRMU] / r
            self.fst[lead, K.S_UBW] *= r
            self._chain(lead)
        return True

    def _hand_over_slot(self, s: int, t: SlotTemplate, damper_row, r: int) -> None:
        ip = self.ipar[s]
        if ip[K.I_EXC] == K.EXC_ENDED:
            K._fold_offset(self.ring, int(ip[K.I_OFF]), 2 * int(ip[K.I_N]), int(ip[K.I_POS]),
                           int(ip[K.I_K]), float(self.fst[s, K.S_G]))
            self.fst[s, K.S_G] = 0.0
            ip[K.I_EXC] = K.EXC_NONE
        Nf, off, pm = int(ip[K.I_N]), int(ip[K.I_OFF]), int(ip[K.I_POS])
        xdel_f, nd_f, nb_f = int(ip[K.I_XDELAY]), int(ip[K.I_NDISP]), int(ip[K.I_NSOS])
        st_f, fp_f = self._ho_st, self._ho_fp
        st_f[:] = self.fst[s]
        fp_f[:] = self.fpar[s]
        Nc = int(t.ipar[K.I_N])
        pmc = pm % (2 * Nc)
        H = max(1, min(self.HAND_OVER_ROWS, Nc - 2))
        # the slot on the new grid (its group links, probe and telemetry kept)
        self._write_template(s, t, _HAND_OVER_KEEP)
        ip[K.I_EXC] = K.EXC_NONE
        ip[K.I_EXC_M] = 0
        ip[K.I_HLAST] = -1
        ip[K.I_POS] = pmc
        fp = self.fpar[s]
        for c in (K.F_BRA, K.F_BRB, K.F_BRMU):
            fp[c] = fp_f[c]                   # the leader's, converted by the caller
        fp[K.F_TGAP] = round(fp_f[K.F_TGAP] / r)      # telemetry's episode gap, in steps
        share = 1.0 / float(self.damper[s, 0])
        fp[K.F_B0] = float(damper_row[0]) * fp_f[K.F_B0] * share
        fp[K.F_B0T] = float(damper_row[0]) * fp_f[K.F_B0T] * share
        self.damper[s, :] = damper_row
        # the state: what carries over (the bridge, the peak, the telemetry's
        # counts, those in the coarser steps), the filter's to be fitted
        st = self.fst[s]
        st[:] = 0.0
        for c in _HAND_OVER_ST:
            st[c] = st_f[c]
        for c in (K.S_TC_N, K.S_HC_N, K.S_TC_GAP, K.S_HC_GAP):
            st[c] = st_f[c] / r if st_f[c] >= 0.0 else st_f[c]
        st[K.S_BD] = t.bend_delay
        xdel, nd, nb = int(ip[K.I_XDELAY]), int(ip[K.I_NDISP]), int(ip[K.I_NSOS])
        key = (xdel, nd, nb)
        T = self._free_dirs.get(key)
        if T is None:
            T = self._free_dirs[key] = np.ascontiguousarray(_chained_state(xdel, nd, nb, K.S_NS))
        K.hand_over_loop(self.ring, off, Nf, pm, st_f, fp_f, xdel_f, nd_f, nb_f, r, Nc, pmc,
                         st, fp, xdel, nd, nb, T, T.shape[1], H, float(st_f[K.S_UBP]),
                         self._ho_buf, self._ho_At, self._ho_R, self._ho_one)
        self._clean[s] = False

    def _unhook(self, s: int) -> None:
        self.fst[s, K.S_UBP] = 0.0
        self.ipar[s, K.I_CPL] = K.CPL_NONE
        self.ipar[s, K.I_CPLN] = 0
        self.ipar[s, K.I_CPLNX] = -1
        self._leader[s] = -1

    def set_external_bridge(self, s: int, ease_s: float = 0.02) -> None:
        """Hang slot s (lossy, bridge-force output, no bend line; all such
        slots of a bank on one grid) on an external bridge whose
        displacement comes to :meth:`render` as ``ubx``: a string driven by the rest of the
        instrument (a sympathetic string).  A string that joins the bridge
        while it is displaced (:meth:`join_bridge`) eases onto it with the
        time constant ``ease_s`` (s, > 0) instead of stepping there."""
        ip = self.ipar[s]
        if ip[K.I_FILT] != 1 or ip[K.I_OUT] != 1 or ip[K.I_BLEN] != 0:
            raise ValueError(f"slot {s} cannot hang on an external bridge (it needs a lossy far "
                             f"end, the bridge-force output, no pitch-bend line)")
        M = int(ip[K.I_SUB])
        if self._ext_sub_set and M != self._ext_sub:
            raise ValueError(f"slot {s} runs {M} steps per sample; the bank's other strings on "
                             f"the external bridge run {self._ext_sub} (one ubx serves them all)")
        self._ext_sub, self._ext_sub_set = M, True
        if not (ease_s > 0.0):
            raise ValueError(f"ease_s = {ease_s!r} is out of range (value > 0)")
        ip[K.I_CPL] = K.CPL_EXTERNAL
        ip[K.I_CPLN] = 0
        self.fpar[s, K.F_UBOD] = math.exp(-float(self.fpar[s, K.F_DT]) / ease_s)

    def join_bridge(self, s: int, displacement_m: float) -> None:
        """Slot s (on an external bridge, at rest) starts rendering while
        the bridge is at ``displacement_m`` (m): its end starts there and
        eases onto the bridge's motion (a string whose damper lifts was
        hanging on it all along; without this it would see the bridge's
        displacement as a step, a click)."""
        self.fst[s, K.S_UBOFF] = float(displacement_m)
        self.fst[s, K.S_UBP] = 0.0

    # -- contact telemetry (live play's --stats) -------------------------------
    TELEMETRY_GAP_S = 0.0002

    def set_telemetry(self, s: int, on: bool, min_gap_s: float = TELEMETRY_GAP_S) -> None:
        """Count slot s's contacts from its next sample (``on``), restarting
        the counts, or stop counting.  A counted slot takes the kernel's
        per-sample path (the reference of the fast path: the same samples to
        round-off), which counts, per sample, the termination points in
        contact and the hammer's felt force; contacts fewer than
        ``min_gap_s`` (s, >= 0) apart are one episode, as in
        :func:`synth.analysis.contacts.contact_summary`."""
        if not (min_gap_s >= 0.0):
            raise ValueError(f"min_gap_s = {min_gap_s!r} is out of range (value >= 0)")
        self.ipar[s, K.I_TELEM] = 1 if on else 0
        if on:
            st = self.fst[s]
            st[K.S_TC_N:K.S_HF_PK + 1] = 0.0
            st[K.S_TC_GAP] = -1.0
            st[K.S_HC_GAP] = -1.0
            dt = float(self.fpar[s, K.F_DT])
            self.fpar[s, K.F_TGAP] = max(0, int(round(min_gap_s / dt))) if dt > 0 else 0

    def telemetry(self, s: int) -> dict:
        """Slot s's contact counts since :meth:`set_telemetry` (the keys of
        :func:`synth.analysis.contacts.contact_summary`, without the first
        and last contact times): ``termination`` (``time_in_contact_s``,
        ``episodes``, ``max_points``) and ``hammer`` (``time_in_contact_s``,
        ``episodes``, ``peak_force_n``).  Read from any thread: the values
        are the kernel's running counts (a meter may see a block in flight)."""
        st = self.fst[s]
        dt = float(self.fpar[s, K.F_DT])
        return {"termination": {"time_in_contact_s": float(st[K.S_TC_N]) * dt,
                                "episodes": int(st[K.S_TC_EP]),
                                "max_points": int(st[K.S_TC_PTS])},
                "hammer": {"time_in_contact_s": float(st[K.S_HC_N]) * dt,
                           "episodes": int(st[K.S_HC_EP]),
                           "peak_force_n": float(st[K.S_HF_PK])}}

    # -- probes ---------------------------------------------------------------
    def ensure_probe_length(self, n: int) -> None:
        if self.probe.shape[2] < n:
            self.probe = np.zeros((self.probe.shape[0], K.P_NCH, n))

    # -- timed changes ----------------------------------------------------------
    def after(self, n: int, fn) -> None:
        """Call ``fn()`` (no arguments) once the bank has rendered ``n`` more
        internal samples, before it renders the next one: a render call is
        split there, so the call falls on that sample whatever blocks the
        caller renders in (a live stream and an offline render agree).
        Calls due at one sample run in the order they were asked for.  For
        a voice's timed changes of a sounding string (the buzz's drain,
        :class:`synth.voices.one_string.OneStringVoice`).

        Parameters
        ----------
        n : int
            Internal samples from now, 1 <= value <= 2**40.
        fn : callable
            Called with no arguments; it may ask for another call.
        """
        if int(n) != n or not (1 <= int(n) <= 1 << 40):
            raise ValueError(f"n = {n!r} is out of range (integer, 1 <= value <= 2**40 samples)")
        if not callable(fn):
            raise ValueError(f"fn = {fn!r} is not callable")
        self._timer_seq += 1
        heapq.heappush(self._timers, (self.time + int(n), self._timer_seq, fn))

    # -- rendering --------------------------------------------------------------
    def render(self, mix: np.ndarray, o0: int, n: int, ubx: np.ndarray | None = None) -> None:
        """Render n internal samples of all active strings into
        mix[o0:o0+n] (1-D: one row) or mix[:, o0:o0+n] (2-D, C-contiguous,
        at least :attr:`mix_rows` rows: each slot adds to the rows from its
        output row on, :meth:`set_output_row`; strings set to two buses
        split their output between that row and the next, when the mix has
        it).  ``ubx``: the displacement (m) of the
        external bridge that strings set by :meth:`set_external_bridge`
        hang on, per sample, indexed like ``mix`` (None: it stays still);
        strings on a finer grid (``sub`` M > 1) read M values per sample,
        ``ubx[(o0 + i) M + m]`` at step m of sample i."""
        if mix.ndim == 1:
            mix = mix.reshape(1, -1)
        # the kernel does not check its bounds (numba): a short mix would be
        # written past its end (found by tools/stress.py: heap corruption)
        if mix.shape[0] < self._row_top + 1:
            raise ValueError(f"mix rows = {mix.shape[0]} is out of range (value >= "
                             f"{self._row_top + 1}: the slots' output rows)")
        if mix.dtype != np.float64 or not mix.flags.c_contiguous:
            raise ValueError("mix must be a C-contiguous float64 array")
        if not (0 <= int(o0) and 0 <= int(n) and int(o0) + int(n) <= mix.shape[1]):
            raise ValueError(f"o0 + n = {int(o0)} + {int(n)} is out of range "
                             f"(0 <= o0, 0 <= n, o0 + n <= {mix.shape[1]}, the mix's samples)")
        M = self._ext_sub
        if ubx is None:
            if self._still.shape[0] < mix.shape[1] * M:
                self._still = np.zeros(mix.shape[1] * M)
            ubx = self._still
        elif ubx.shape[0] < (o0 + n) * M:
            raise ValueError(f"ubx has {ubx.shape[0]} samples, fewer than (o0 + n) x {M} = "
                             f"{(o0 + n) * M}")
        if self.n_probes:
            self.ensure_probe_length(o0 + n)
        self.render_unchecked(mix, o0, n, ubx)

    def render_unchecked(self, mix: np.ndarray, o0: int, n: int, ubx: np.ndarray) -> None:
        """:meth:`render` without its argument checks, for a caller whose
        arrays meet them by construction (the sympathetic strings' stage,
        once per block): ``mix`` 2-D, C-contiguous float64 with at least
        :attr:`mix_rows` rows and o0 + n columns, ``ubx`` at least (o0 + n)
        M samples, no probes.  (The kernel does not check bounds.)  Calls
        asked for by :meth:`after` run at their sample."""
        done = 0
        timers = self._timers
        while done < n:
            c = min(n - done, self.max_block)
            if timers:
                due = timers[0][0] - self.time
                if due <= 0:
                    heapq.heappop(timers)[2]()
                    continue
                c = min(c, due)
            K.render_bank(self.ring, self.ipar, self.fpar, self.fst, self.U,
                          self.active, self.n_active, c, o0 + done, mix,
                          self.probe, self.scratch, self.iwork, ubx, self.sub)
            done += c
            self.time += c

    # -- inspection (tests, analysis) ----------------------------------------
    def rails(self, s: int):
        """(u_r, u_l) at grid points 0..N at the last processed time."""
        N = int(self.ipar[s, K.I_N])
        P = 2 * N
        off = int(self.ipar[s, K.I_OFF])
        pm = int(self.ipar[s, K.I_POS])
        ring = self.ring[off: off + P]
        n = np.arange(N + 1)
        ur = ring[(pm - n) % P]
        vl = ring[(pm - (P - n)) % P]
        return ur.copy(), -vl.copy()

    def displacement_at_excitation(self, s: int) -> float:
        """u (m) at slot s's excitation point k, now."""
        ip = self.ipar[s]
        P = 2 * int(ip[K.I_N])
        off, pm, k = int(ip[K.I_OFF]), int(ip[K.I_POS]), int(ip[K.I_K])
        return float(self.ring[off + (pm - k) % P] - self.ring[off + (pm + k) % P]
                     - self.fst[s, K.S_G])

    def displacement(self, s: int) -> np.ndarray:
        """u(x) at grid points 0..N (m) at the last processed time."""
        ur, ul = self.rails(s)
        u = ur + ul
        k = int(self.ipar[s, K.I_K])
        u[k] -= self.fst[s, K.S_G]
        return u
