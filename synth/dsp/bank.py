"""A bank of waveguide strings in preallocated arrays.

The bank owns every array the string kernel touches (rings, parameter and
state tables, profiles, scratch, probes).  Voices claim string slots and
write their physics into them at note-on through the bank's methods; the
engine renders all active slots with one call of
:func:`synth.kernels.render.render_sharded` per segment (on
:attr:`StringBank.threads` threads, the same samples for any number), fades
slots out
(:meth:`StringBank.fade`) and frees the silent ones
(:meth:`StringBank.reap`).  Nothing outside this module, its mixins
and :mod:`synth.dsp.templates` indexes the kernel's tables.  Nothing is allocated per block.
"""

from __future__ import annotations

import heapq
import math

import numba
import numpy as np

from ..kernels import render as KR
from ..kernels import strings as K
from .units import _ADDR, _wait_elsewhere, _with_needs, elsewhere, preloaded
from ..kernels.energy import ring_energy
from ..kernels.bend import TO_FLOOR
from . import compile_notice, sizing, threads
from .bridges import Bridges
from .groups import Groups
from .hand_over import SLOT_COLS, HandOver, _write_mask
from .telemetry import Telemetry
from .templates import (  # noqa: F401  (re-exported: the voices build their slots here)
    MIN_FAST_CHUNK, SlotTemplate, _index, region_reach, slot_template)
from .excitation import (  # noqa: F401  (re-exported: the voices build their hammers here)
    SOLVER_TOL, Excitations, HammerSet, HammerTemplate, hammer_set, hammer_template)

# compiles of the kernels counted and timed (and, from the synth command, announced)
compile_notice.listen()

_LN1000 = math.log(1000.0)     # 60 dB of amplitude
#: damper rows' loss factors, exp(-sigma / f1), by row (:func:`damper_down_factor`)
_DOWN_FACTOR: dict = {}


def damper_down_factor(row) -> float:
    """The loss factor exp(-sigma / f1) of a damper down on its string, for
    a damper row (b0 undamped, f1_hz, t60_damped_s, t60_free_s):
    sigma = ln(1000)/T60_damped - ln(1000)/T60_free (1/s, >= 0), computed
    with the numpy operations of :meth:`StringBank.apply_dampers` (so that
    b0 times it is that method's value to the bit) once per distinct row
    and kept (a voice's warm-up computes its rows' ahead of a live stream,
    :meth:`synth.voices.grand.GrandVoice.warm`)."""
    row = tuple(float(v) for v in row[:4])
    g = _DOWN_FACTOR.get(row)
    if g is None:
        if len(_DOWN_FACTOR) > 8192:
            _DOWN_FACTOR.clear()
        d = np.array([row])
        g = _DOWN_FACTOR[row] = float(_loss_factor(d[:, 2], d[:, 3], d[:, 1])[0])
    return g


def _loss_factor(t60_s, t60_free_s, f1_hz):
    """exp(-sigma / f1) with sigma = ln(1000)/T60 - ln(1000)/T60_free (1/s,
    >= 0), elementwise: the loop gain's share under a damper (arrays)."""
    sigma = np.maximum(_LN1000 / t60_s - _LN1000 / t60_free_s, 0.0)
    return np.exp(-sigma / f1_hz)
#: the kernels that may run loops on several threads (bank.render's kinds)
_THREADED = (KR.KIND_SHARDS, KR.KIND_BIG_GROUPS, KR.KIND_BANK)
#: the renderers of one unit besides a big group's (live play, synth warmup)
_ALL_UNITS = (1 << KR.A_SMALL) | (1 << KR.A_STRING)
#: the unit render_big_groups always calls (its blocks' first half)
_BIG_NEEDS = KR.NEEDS[KR.A_BIG]
#: the units a coupled group calls only where it needs them (KR.groups_need)
_GROUPS_NEED = (1 << KR.A_PER) | (1 << KR.A_HAMMERS)
#: every unit a bank may call (live play's warm-up, synth warmup)
_EVERY_UNIT = _ALL_UNITS | (1 << KR.A_BIG) | _GROUPS_NEED


class StringBank(Excitations, Bridges, Groups, HandOver, Telemetry):
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

    #: render every scene through the one kernel that handles them all
    #: (:func:`synth.kernels.render.render_sharded`) instead of the one
    #: :func:`~synth.kernels.render.bank_kind` picks for what is active.
    #: Offline (False) a scene compiles only the paths it runs; live play
    #: (:func:`synth.io.live.engines.ready_engine` sets it for its process)
    #: loads the one kernel before the stream opens, so that no scene
    #: compiles one mid-performance.  The same samples either way.
    whole_kernel = False

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
        #: slot tuples as int64 arrays (:meth:`_slot_array`)
        self._slot_rows: dict = {}
        self._no_probe_rows = np.full(8, -1, dtype=np.int64)
        self.ipar = np.zeros((self.capacity, K.I_NI), dtype=np.int64)
        self.fpar = np.zeros((self.capacity, K.F_NF))
        self.fst = np.zeros((self.capacity, K.S_NS))
        self.max_gtable = int(max_gtable)
        self.max_bend = int(max_bend)
        # region profiles, g tables and pitch-bend lines, in one flat table array
        self.U = np.zeros(max(1, self.capacity * (self.max_region + self.max_gtable + self.max_bend)))
        self.U.fill(0.0)               # (its pages too: a note-on's bend line is zeroed)
        # fast-path chunks never exceed max_block (the kernel's scratch layout)
        self._slen = sizing.scratch_length(self.max_block, self.max_region, self.max_bend,
                                           self.max_group)
        # one scratch, iwork and staging row per thread (set_threads); the
        # shards' mixes, the plan, the big groups' blocks (kernels.render)
        self.threads = 1
        #: threads or the calling thread, call by call, by their times (threads.Governor)
        self.governor = threads.Governor()
        self._scratch2 = np.zeros((1, self._slen))
        self._iwork2 = np.zeros((1, self.capacity + K.IWORK_EXTRA), dtype=np.int64)
        self._tw = np.zeros((1, KR.task_work_length(self.max_block, self.max_region,
                                                    self.max_bend)))
        self._plan = np.zeros(KR.plan_length(self.capacity), dtype=np.int64)
        self._ib = np.zeros(KR.block_index_length(self.max_group, 1), dtype=np.int64)
        #: the renderers of one unit, by address (:meth:`_units`; 0: not yet)
        self._addrs = np.zeros(KR.N_ADDRS, dtype=np.int64)
        #: the kinds of unit this bank can have whose address is not yet in
        #: ``_addrs`` (bits 1 << A_BIG, ...; a big group only where
        #: ``max_group`` allows one): 0 once all are, and then a block no
        #: longer asks which kinds are active (:meth:`_active_units`)
        #: (those this process has loaded already are in from the start: a
        #: live engine built after its warm-up has all, and no block scans)
        self._units_left = preloaded(self._addrs, _with_needs(
            _ALL_UNITS | ((1 << KR.A_BIG) if self.big_groups else 0)) | _GROUPS_NEED)
        self._pb = np.zeros(KR.block_mix_shape(self.max_group, 2))
        self._smix = np.zeros((KR.MAX_SHARDS - 1, 1, 1))
        # staging mix of strings on a finer grid (two buses; more rows for a
        # coupled group across rows, _fit_sub); an external bridge's
        # displacement when the caller gives none (all zero)
        self._sub3 = np.zeros((1, 2, sizing.sub_length(self.max_block)))
        # the highest output row of any slot (:meth:`set_output_row`)
        self._row_top = 0
        self._still = np.zeros(0)
        # steps per sample of the strings on the external bridge (ubx holds
        # that many values per sample; :meth:`set_external_bridge`)
        self._ext_sub = 1
        self._ext_sub_set = False
        # dampers, per slot: loss b0 undamped, loop frequency f1 (Hz), T60 with
        # the damper down and T60 free (s; inf: no free decay to keep), and the
        # loss factor of the damper down, exp(-sigma / f1) (:meth:`set_damper`)
        self.damper = np.zeros((self.capacity, 5))
        self.damper[:, :] = (1.0, 1.0, math.inf, math.inf, 1.0)
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
        self._ho_buf = np.zeros(sizing.hand_over_buffer_length(self.max_cells,
                                                               self.HAND_OVER_ROWS))
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

    def _slot_array(self, slots) -> np.ndarray:
        """``slots`` (distinct slot indices, at least one) as an int64 array,
        checked and kept per tuple (a voice's slots: a few tuples, so a
        note-on's call allocates nothing)."""
        key = slots if isinstance(slots, tuple) else tuple(slots)
        arr = self._slot_rows.get(key)
        if arr is None:
            arr = np.array(key, dtype=np.int64)
            if arr.ndim != 1 or arr.size == 0 or arr.min() < 0 or arr.max() >= self.capacity \
                    or len(set(key)) != arr.size:
                raise ValueError(f"slots = {key!r} are out of range (distinct, 0 <= value <= "
                                 f"{self.capacity - 1}, at least one)")
            if len(self._slot_rows) < 4096:
                self._slot_rows[key] = arr
        return arr

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
        mem = self._members[lead]
        if len(mem) < 8:
            rows = [int(self.ipar[m, K.I_ROW]) for m in mem]
            span = max(rows) + 2 - min(rows)
        else:
            rows = self.ipar[mem, K.I_ROW]
            span = int(rows.max()) + 2 - int(rows.min())
        if span > self._sub3.shape[1]:
            self._sub3 = np.zeros((self._sub3.shape[0], span, self._sub3.shape[2]))

    # -- threads ----------------------------------------------------------------
    def set_threads(self, n: int) -> None:
        """Render on ``n`` threads (1 .. :func:`synth.dsp.threads.max_threads`):
        the same samples for any ``n`` (:mod:`synth.kernels.render`).  Sizes
        a scratch row per thread (at most MAX_SHARDS rows for the shards)."""
        n = threads.check_threads(n)
        rows = min(n, KR.MAX_SHARDS)
        if self._scratch2.shape[0] < rows:
            self._scratch2 = np.zeros((rows, self._slen))
            self._iwork2 = np.zeros((rows, self._iwork2.shape[1]), dtype=np.int64)
            self._sub3 = np.zeros((rows,) + self._sub3.shape[1:])
        if self._tw.shape[0] < n:
            self._tw = np.zeros((n, self._tw.shape[1]))
        m = KR.block_index_length(self.max_group, n)
        if self._ib.shape[0] < m:
            self._ib = np.zeros(m, dtype=np.int64)
        self.threads = n

    @property
    def sub(self) -> np.ndarray:
        """The (first thread's) staging mix of strings on a finer grid."""
        return self._sub3[0]

    # -- configuration ----------------------------------------------------------
    def configure(self, s: int, *, cells: int, k: int, dt_s: float,
                  U: np.ndarray | None, side: int = 1,
                  out_mode: int = 0, gain: float = 1.0, tension_over_dx: float = 0.0,
                  b0: float = 1.0, a1: float = 0.0, eta: float = 0.0,
                  extra_delay: int = 0, lossy: bool = False,
                  probe_row: int = -1, force_per_sample: bool = False,
                  n_disp: int = 0, a_disp: float = 0.0, bend_len: int = 0,
                  bend_delay: float = 0.0, sos=None, pan: float | None = None,
                  sub: int = 1, subcell: float = 0.0, tension=None) -> None:
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
        tension : the tension's modulation (:func:`slot_template`), or None.
        (Voices that configure at note-on build a :func:`slot_template`
        once and call :meth:`configure_from`.)
        """
        t = slot_template(cells=cells, k=k, dt_s=dt_s, U=U, side=side, out_mode=out_mode,
                          gain=gain, tension_over_dx=tension_over_dx, b0=b0, a1=a1, eta=eta,
                          extra_delay=extra_delay, lossy=lossy,
                          force_per_sample=force_per_sample, n_disp=n_disp, a_disp=a_disp,
                          bend_len=bend_len, bend_delay=bend_delay,
                          glide_s=self.LOSS_GLIDE_S, bend_glide_s=self.BEND_GLIDE_S, sos=sos,
                          pan=pan, sub=sub, subcell=subcell, tension=tension)
        self.configure_from(s, t, probe_row)

    def configure_from(self, s: int, t: SlotTemplate, probe_row: int = -1) -> None:
        """Set up slot s from a template (zero state, no excitation)."""
        self._check_sizes(t.cells, t.region, t.bend_len)
        blen = t.bend_len
        if self._leader[s] >= 0:
            self.leave(s)              # a new string: off its bridge
        self.clear(s)                  # (free when the slot is already clean)
        self._write_template(s, t, SLOT_COLS)
        ip = self.ipar[s]
        ip[K.I_PROBE] = int(probe_row)
        if blen:
            self.U[ip[K.I_BOFF]: ip[K.I_BOFF] + blen] = 0.0
        self.fst[s, K.S_BD] = t.bend_delay
        # the tension's first reading (synth.kernels.tension) F_TMM samples
        # in (a string joining a bridge takes the bridge's: Bridges.join)
        self.fst[s, K.S_TMC] = self.fpar[s, K.F_TMM]

    def _check_sizes(self, cells: int, region: int, bend_len: int) -> None:
        """ValueError unless a string of ``cells`` cells, ``region``
        termination points and a bend line of ``bend_len`` fits a slot."""
        if cells > self.max_cells:
            raise ValueError(f"cells = {cells!r} is out of range (8 <= value <= {self.max_cells})")
        if region > self.max_region:
            raise ValueError(f"region points = {region} is out of range (0 <= value <= "
                             f"{self.max_region})")
        if bend_len > self.max_bend:
            raise ValueError(f"bend_len = {bend_len!r} is out of range (0 <= value <= "
                             f"{self.max_bend})")

    def _write_template(self, s: int, t: SlotTemplate, keep_cols) -> None:
        """Slot s's parameters and profile from template t, its ``ipar``
        columns ``keep_cols`` kept; chunks within this bank's block."""
        ip = self.ipar[s]
        np.copyto(ip, t.ipar, where=_write_mask(keep_cols))
        if t.chunk > self.max_block:
            ip[K.I_CHUNK] = self.max_block
        if t.chunk_free > self.max_block:
            ip[K.I_CHUNK_FREE] = self.max_block
        self.fpar[s, :] = t.fpar
        if not self.skip_unreachable:
            self.fpar[s, K.F_REACH] = 0.0
        R = t.region
        if R:
            o = int(ip[K.I_REG_OFF])
            self.U[o: o + R] = t.U

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
        t60_free_s) (see :meth:`apply_dampers`).  The loss factor of the
        damper down (:func:`damper_down_factor`) is kept beside it: a key
        let go without the pedal, the usual note-off, then costs a gather,
        not a numpy expression (32 keys let go in one block took 0.4-1.1 ms
        of a 2.67 ms period that way)."""
        self.damper[s, :4] = row[:4]
        self.damper[s, 4] = damper_down_factor(row)

    def apply_dampers(self, slots, lift) -> None:
        """Set the loss of ``slots`` for dampers lifted by ``lift`` (0: on
        the strings .. 1: off; one value, or one per slot), all at once: the T60 moves geometrically
        from the damped to the free value with the lift, and the extra
        decay rate sigma = ln(1000)/T60 - ln(1000)/T60_free (1/s, >= 0) scales the
        loop gain, b0 = b0_undamped exp(-sigma / f1) (a pure gain: the
        tuning does not move).  Glided to like :meth:`set_loss`."""
        if np.ndim(lift) == 0:
            if lift >= 1.0:
                # off the strings: sigma = 0, b0 = b0_undamped exp(-0) to the bit
                # (a chord let go under the pedal: one such call a key)
                self.fpar[slots, K.F_B0T] = self.damper[slots, 0]
                return
            if lift <= 0.0:
                # on the strings (a key let go, a pedal let up): b0_undamped
                # times the factor set_damper keeps, the same value to the bit
                self.fpar[slots, K.F_B0T] = self.damper[slots, 0] * self.damper[slots, 4]
                return
        d = self.damper[slots]
        td = d[:, 2]
        tf = d[:, 3]
        if np.ndim(lift) == 1:
            # one lift per slot
            lf = np.clip(np.asarray(lift, dtype=float), 0.0, 1.0)
            t = np.exp((1.0 - lf) * np.log(td) + lf * np.log(tf))
        else:
            # half pedal (the ends returned above)
            t = np.exp((1.0 - lift) * np.log(td) + lift * np.log(tf))
        self.fpar[slots, K.F_B0T] = d[:, 0] * _loss_factor(t, tf, d[:, 1])

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
        to = (min(max(gain * float(delay), lo), hi) / gain) if gain > 0.0 else float(delay)
        # (under the bend line's floor a tune-out is 0, as it decays there)
        self.fst[s, K.S_TO] = 0.0 if abs(to) < TO_FLOOR else to

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
            to = 0.0 if abs(to) < TO_FLOOR else to
            self.fst[s, K.S_TO] = to
        self.fst[s, K.S_BD] += (old - gain) * to
        self.fpar[s, K.F_TOG] = gain

    def _unhook(self, s: int) -> None:
        self.fst[s, K.S_UBP] = 0.0
        self.ipar[s, K.I_CPL] = K.CPL_NONE
        self.ipar[s, K.I_CPLN] = 0
        self.ipar[s, K.I_CPLNX] = -1
        self._leader[s] = -1

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
        nt = threads.enter(self.threads)
        smix = self._smix
        if smix.shape[1] != mix.shape[0] or smix.shape[2] < mix.shape[1]:
            smix = self._smix = np.zeros((KR.MAX_SHARDS - 1, mix.shape[0], mix.shape[1]))
        pb = self._pb
        if pb.shape[1] <= max(mix.shape[0], self._sub3.shape[1]):     # (+ the force row)
            pb = self._pb = np.zeros(KR.block_mix_shape(
                self.max_group, max(mix.shape[0], self._sub3.shape[1])))
        while done < n:
            c = min(n - done, self.max_block)
            if timers:
                due = timers[0][0] - self.time
                if due <= 0:
                    heapq.heappop(timers)[2]()
                    continue
                c = min(c, due)
            kind = (KR.KIND_SHARDS if self.whole_kernel
                    else KR.bank_kind(self.active, self.n_active, self.ipar, self.fpar, c))
            # (a kernel that may run loops on the threads: the governor picks
            # them or this thread, ntc, and times the call)
            gov = nt > 1 and kind in _THREADED
            ntc = nt
            if gov:
                ntc = self.governor.pick(nt, self.n_active * c, c)
                t0 = self.governor.clock()
            # the kernel for what is active (the samples render_sharded gives
            # it), so that a scene compiles only what it runs
            if kind == KR.KIND_SHARDS:
                # (what another process compiles, last: its wait then costs least)
                if elsewhere("bank"):
                    units = self._active_units()
                    bank = self._bank_addr()
                else:
                    bank = self._bank_addr()
                    units = self._active_units()
                KR.render_sharded(bank, units, self.ring, self.ipar, self.fpar,
                                  self.fst, self.U, self.active, self.n_active, c, o0 + done,
                                  mix, self.probe, self._scratch2, self._iwork2, ubx, self._sub3,
                                  smix, self._plan, pb, self._tw, self._ib, ntc)
            elif kind == KR.KIND_BIG_GROUPS or kind == KR.KIND_BIG_GROUPS_ONE:
                # (nt None: the blocks on this thread, a separate compile
                # without the parallel loops, which one note never needs)
                # (the governor's one thread: 1, the same compiled kernel)
                big_nt = ntc if kind == KR.KIND_BIG_GROUPS and nt > 1 else None
                addrs = self._addrs
                if self._units_left & (_BIG_NEEDS | _GROUPS_NEED):
                    if self._units_left & _BIG_NEEDS:
                        # the renderer first (no string: it runs no unit), then
                        # the unit it calls, which another process may be compiling
                        KR.render_big_groups(self.ring, self.ipar, self.fpar, self.fst, self.U,
                                             self.active[:0], 0, 0, 0, mix, self.probe,
                                             self._scratch2[0], self._iwork2[0], pb, self._tw,
                                             self._ib, big_nt, addrs)
                    addrs = self._units(_BIG_NEEDS)
                KR.render_big_groups(self.ring, self.ipar, self.fpar, self.fst, self.U,
                                     self.active, self.n_active, c, o0 + done, mix, self.probe,
                                     self._scratch2[0], self._iwork2[0], pb, self._tw, self._ib,
                                     big_nt, addrs)
            elif kind == KR.KIND_SMALL_GROUP:
                KR.render_small_group(self.ring, self.ipar, self.fpar, self.fst, self.U,
                                      self.active, self.n_active, c, o0 + done, mix, self.probe,
                                      self._scratch2[0], self._iwork2[0],
                                      self._units(1 << KR.A_SMALL))
            elif kind == KR.KIND_STRINGS:
                KR.render_strings(self.ring, self.ipar, self.fpar, self.fst, self.U,
                                  self.active, self.n_active, c, o0 + done, mix, self.probe,
                                  self._scratch2[0], ubx, self._units(1 << KR.A_STRING))
            elif kind == KR.KIND_BANK:
                KR.render_bank(self.ring, self.ipar, self.fpar, self.fst, self.U,
                               self.active, self.n_active, c, o0 + done, mix,
                               self.probe, self._scratch2[0], self._iwork2[0], ubx,
                               self._sub3[0], pb, self._tw, self._ib, ntc,
                               self._active_units())
            if gov:
                self.governor.record(self.governor.clock() - t0, self.n_active * c)
            done += c
            self.time += c

    def _bank_addr(self) -> int:
        """render_bank's address (:func:`synth.kernels.render.bank_address`),
        for render_sharded: render_bank is loaded (or compiled) by a call
        that renders nothing, then its address taken, once per process."""
        a = _ADDR.get("bank")
        if a is None:
            _wait_elsewhere("bank")
            mix = np.zeros((self._row_top + 1, 1))
            KR.render_bank(self.ring, self.ipar, self.fpar, self.fst, self.U, self.active[:0], 0, 0,
                           0, mix, self.probe, self._scratch2[0], self._iwork2[0],
                           np.zeros(max(1, self._ext_sub)), self._sub3[0], self._pb, self._tw,
                           self._ib, 1, self._addrs)
            a = _ADDR["bank"] = KR.bank_address()
        return a

    def _active_units(self) -> np.ndarray:
        """:meth:`_units` for the kinds of unit active now
        (:func:`~synth.kernels.render.unit_kinds`), a scan of the active
        strings that a block skips once every kind this bank can have has
        its address (live play: from :meth:`load_kernels` on)."""
        if not self._units_left:
            return self._addrs
        return self._units(KR.unit_kinds(self.active, self.n_active, self.ipar))

    def _units(self, mask: int) -> np.ndarray:
        """The bank's ``addrs`` (:func:`synth.kernels.render.render_bank`)
        with every unit in ``mask`` (bits 1 << A_BIG, ...;
        :mod:`synth.kernels.address`) and the units they call in it: each
        loaded (or compiled) the first time a scene needs it, then its
        address taken, once per process (a renderer of one unit by a call
        that renders nothing, the others for their signature).  Units
        another process is compiling (:func:`compile_elsewhere`) come last,
        after the wait.  The coupled groups' per-sample path (``A_PER``)
        and their hammers (``A_HAMMERS``) come in only where a group may
        take them before the next event
        (:func:`~synth.kernels.unison.groups_need`: a probe, a felt, a
        chord of more plucks than a chunk's rows; a hammer).  A coupled
        group of more than BLOCK members is asked for only where
        :attr:`big_groups`."""
        addrs = self._addrs
        if not self.big_groups:
            mask &= ~(1 << KR.A_BIG)
        mask = _with_needs(mask)
        if addrs[KR.A_PER] == 0 or addrs[KR.A_HAMMERS] == 0:
            # (a coupled group may render per sample, or has hammers)
            mask |= KR.groups_need(self.active, self.n_active, self.ipar)
        want = [k for k in range(KR.N_ADDRS) if (mask >> k) & 1 and addrs[k] == 0]
        for k in sorted(want, key=elsewhere):
            a = _ADDR.get(k)
            if a is None:
                _wait_elsewhere(k)
                mix = np.zeros((self._row_top + 1, 1))
                iw = self._iwork2[0][:1]
                sc = self._scratch2[0]
                if k == KR.A_BIG:
                    # (its blocks' parallel loops need numba's threading
                    # layer: loaded from the cache and called by a process
                    # that had run no parallel loop yet, it crashed)
                    numba.get_num_threads()
                    KR.render_coupled_big(0, self.ring, self.ipar, self.fpar, self.fst, self.U, 0,
                                          0, mix, self.probe, sc, iw, iw, 0, 1, self._pb,
                                          self._tw, self._ib, 1, addrs)
                elif k == KR.A_SMALL:
                    KR.render_coupled_small(0, self.ring, self.ipar, self.fpar, self.fst, self.U,
                                            0, 0, mix, self.probe, sc, iw, iw, 0, 1, addrs)
                elif k == KR.A_STRING:
                    KR.render_string(0, self.ring, self.ipar, self.fpar, self.fst, self.U, 0, 0,
                                     mix, self.probe, sc, np.zeros(1), 0, 1)
                a = _ADDR[k] = KR.unit_address(k)
            addrs[k] = a
            self._units_left &= ~(1 << k)
        return addrs

    @property
    def big_groups(self) -> bool:
        """Whether this bank can hold a coupled group of more than BLOCK
        members (a sitar's bridge, rendered by its blocks; ``max_group``
        bounds a group: :class:`~synth.dsp.bridges.Bridges`)."""
        return self.max_group > KR.BLOCK

    def load_units(self, wait: bool = True) -> None:
        """Load (or compile) every unit this bank may call
        (:mod:`synth.kernels.address`), whether or not a scene has needed
        it yet: live play's warm-up, so that no unit loads mid-performance
        (the coupled groups' per-sample path comes in offline only where a
        group takes it: a chord of more plucks than a chunk holds).  With
        ``wait`` False, only those no other process is compiling
        (:func:`synth.dsp.units.compile_elsewhere`): a cold start's first
        process compiles its share before it waits for the other's."""
        mask = _EVERY_UNIT
        if not wait:
            mask &= ~sum(1 << k for k in range(KR.N_ADDRS) if elsewhere(k))
        self._units(mask)

    #: the bank's renderers, as :meth:`load_kernels` names them
    RENDERERS = ("sharded", "big_groups", "small_group", "strings", "bank")

    def load_kernels(self, only: tuple[str, ...] | None = None) -> None:
        """Compile (or load from numba's cache) every kernel :meth:`render`
        may call, whatever the scene (``synth warmup``): each is called
        with no string and no sample, which renders nothing.  ``only``: the
        renderers of :data:`RENDERERS` to load (None: all; a warm-up on
        several processes gives each its own)."""
        if only is not None and not set(only) <= set(self.RENDERERS):
            raise ValueError(f"only = {only!r}: each must be one of {', '.join(self.RENDERERS)}")
        want = set(self.RENDERERS if only is None else only)
        mix = np.zeros((self._row_top + 1, 1))
        ubx = np.zeros(max(1, self._ext_sub))
        none = self.active[:0]
        c = 0
        nt = threads.enter(self.threads, prime=True)     # the priming kernel too
        KR.bank_kind(none, 0, self.ipar, self.fpar, c)
        # (the renderers of one unit that render_bank may call, whatever the
        # scene: a bridge of many strings where the bank has room for one)
        if "sharded" in want:
            KR.render_sharded(self._bank_addr(), self._units(_EVERY_UNIT), self.ring, self.ipar,
                              self.fpar, self.fst, self.U, none, 0, c, 0, mix,
                              self.probe, self._scratch2, self._iwork2, ubx, self._sub3,
                              self._smix, self._plan, self._pb, self._tw, self._ib, nt)
        if "big_groups" in want:
            for big_nt in (nt, None):
                KR.render_big_groups(self.ring, self.ipar, self.fpar, self.fst, self.U, none, 0, c,
                                     0, mix, self.probe, self._scratch2[0], self._iwork2[0],
                                     self._pb, self._tw, self._ib, big_nt,
                                     self._units(_BIG_NEEDS | _GROUPS_NEED))
        if "small_group" in want:
            KR.render_small_group(self.ring, self.ipar, self.fpar, self.fst, self.U, none, 0, c, 0,
                                  mix, self.probe, self._scratch2[0], self._iwork2[0],
                                  self._units(1 << KR.A_SMALL))
        if "strings" in want:
            KR.render_strings(self.ring, self.ipar, self.fpar, self.fst, self.U, none, 0, c, 0, mix,
                              self.probe, self._scratch2[0], ubx, self._units(1 << KR.A_STRING))
        if "bank" in want:
            KR.render_bank(self.ring, self.ipar, self.fpar, self.fst, self.U, none, 0, c, 0, mix,
                           self.probe, self._scratch2[0], self._iwork2[0], ubx, self._sub3[0],
                           self._pb, self._tw, self._ib, nt, self._units(_EVERY_UNIT))

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
