"""One string per note, with any exciter and any termination.

One-string voice (preset ``voice = "plucked"`` or ``"piano"``)
==============================================================
One waveguide string per note, excited at ``position`` of its length by the
exciter its preset describes (:mod:`synth.voices.exciters`: ``[pluck]``, the
thesis's plucks, eq. 1.13 sitar and eqs. 1.10-1.11 biwa; ``[hammer]``, the
hereditary felt hammer of eq. 1.4), and touching the preset's termination
at x = 0 (``[termination]``: any registered profile of
:mod:`synth.physics.profiles`, or the ideal rigid end).

* Study presets (``kind = "study"``) are the thesis's experiments: lossless,
  on the paper grid (c dt = dx, ``grid.cells`` cells), pluck amplitude or
  hammer speed exactly the preset's whatever the velocity.  With an
  explicit key or f0 the string is fretted to that pitch and the remaining
  fractional delay is a lossless allpass at x = L.
* Musical presets (``kind = "musical"``) tune every key exactly (loop filter
  from two T60 values plus a fractional-delay allpass, see
  :mod:`synth.physics.losses`), scale the excitation with velocity, and
  damp the string at note-off (``loss.release_t60_s``).  The string is
  fretted (shorter, same tension) above its open pitch and retuned below it
  (:func:`synth.physics.string.fretted_string`).  Pitch bend moves a delay
  line in the loop (``play.pitch_bend_semitones``).
* A musical plucked preset may carry a ``[taraf]`` table (sympathetic
  strings on the bridge, each on a jawari of its own) and a ``[chikari]``
  table (drone strings on the main bridge's jawari, strummed by a key range
  or a MIDI channel): :meth:`OneStringVoice.free_strings` designs them and the
  engine runs them (:mod:`synth.engine.taraf`).
* A musical preset may carry a ``[body]`` table (:meth:`Voice.body`: the
  sitar's gourd and tabli, the biwa's wooden box, as named resonances over
  a diffuse modal bank, :func:`synth.physics.soundboard.soundboard_modes`)
  that the engine puts on the bridge force.  A plucked one may add the
  plectrum's stroke on that body (``pluck.bachi_impulse_ns``, the biwa's
  bachi): a short force pulse into the body at every note-on, scaled with
  velocity as the pluck (:meth:`OneStringVoice.knock_impulse_ns`).
* The buzz depth (``termination.buzz``, live on ``play.buzz_cc``) moves the
  obstacle of the sounding notes at once (a glide of 1 ms); lowered, it
  also drains the energy the buzz has put into their upper partials
  (:meth:`OneStringVoice.set_buzz`): the linear string would keep it,
  ringing about as long as the buzz itself would have.  Pressure (channel
  pressure, polyphonic key pressure: :attr:`OneStringVoice.pressure_cc`)
  sets it on one note.
* CC74 (:data:`OneStringVoice.POSITION_CC`, MPE's timbre, General MIDI 2's
  brightness) sets the excitation point of a musical preset's notes to come
  (:meth:`OneStringVoice.excitation_cell`): 64 the preset's own, 0 the
  middle of the sounding string, 127 near its end (the pluck's size
  unchanged: the level stays within 3 dB over 0.5 s on the sitar's and the
  biwa's keys 43-74).

The voice names are the preset schema's: ``plucked`` presets carry
``[pluck]``, ``piano`` presets (the A7 study of Publication I) ``[hammer]``.
The playable 88-key piano is :mod:`synth.voices.grand`.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass, replace

import numpy as np

from ..dsp.bank import StringBank, slot_template
from ..kernels import strings as K
from ..physics.dispersion import tune_stiff_loop
from ..physics.losses import allpass_for_phase_delay, one_pole_phase_delay, tune_loop
from ..physics.profiles import (Termination, buzz_profile, jawari, termination_from_spec,
                                trim_unreachable)
from ..physics.soundboard import KnockShape
from ..physics.string import IdealString, fretted_string, midi_key_to_hz, tension_gain
from . import design_store
from .base import BankSizes, DronePluck, TarafDesign, Voice
from .exciters import PLUCK_MODELS
from .registry import exciter_for, register_voice

#: each preset's free strings (taraf and chikari, or the bridge alone) for
#: this process, by (voice class, preset, rate): :meth:`OneStringVoice.free_strings`
_FREE_STRINGS: dict = {}


@dataclass(frozen=True)
class OneStringSetup:
    """Everything the bank needs for one note (derived at note-on)."""

    string: IdealString
    cells: int
    k: int
    dt_s: float
    U: np.ndarray | None
    side: int
    b0: float
    a1: float
    eta: float
    extra_delay: int
    lossy: bool
    f0_hz: float
    bend_len: int = 0          # pitch-bend line length (samples), 0: none
    bend_delay: float = 0.0    # its rest delay (samples)
    n_disp: int = 0            # stiffness: first-order dispersion allpasses ...
    a_disp: float = 0.0        # ... and their coefficient
    subcell: float = 0.0       # the first cell's sub-cell contact (Termination.subcell), 0: off
    tension: tuple | None = None   # tension modulation (slot_template's ``tension``), None: off


@dataclass
class _Drain:
    """A sounding note's drain (:meth:`OneStringVoice.set_buzz`): its setup,
    the attenuation still to come (dB at ``DRAIN_HZ``), the loss pole's
    phase delay at f0 now and the first of the two lags that lead it to
    its target (samples), and the delay the bend line gives back (samples);
    ``token`` tells this note's drain from a later one's in the same slot."""

    su: OneStringSetup
    token: int
    db: float
    tau: float
    mid: float
    comp: float = 0.0


@register_voice("plucked", "piano")
class OneStringVoice(Voice):
    """A preset turned into string setups and excitations.

    Parameters
    ----------
    preset : synth.io.presets.Preset
        Validated preset with ``voice`` ``"plucked"`` or ``"piano"``.
    fs_internal : float or None
        Internal rate (Hz).  None: the study grid's own rate
        (``cells * c / L``) for study presets, 325 000 Hz for musical ones.
        For a study preset a given rate re-grids the string:
        cells = round(L fs / c) and the rate becomes cells c / L exactly.
    """

    def __init__(self, preset, fs_internal: float | None = None):
        super().__init__(preset, fs_internal)
        sp = preset.string
        self.open_string = IdealString(sp.length_m, sp.tension_n, sp.linear_density_kg_per_m)
        self.study = preset.kind == "study"
        self.struck = preset.voice == "piano"
        c = self.open_string.c_m_per_s
        if self.study:
            cells = preset.grid.cells
            if fs_internal is not None:
                cells = max(16, int(round(sp.length_m * float(fs_internal) / c)))
            self.cells = int(cells)
            self.fs = self.cells * c / sp.length_m
        else:
            self.cells = None          # (self.fs: the quality level's rate, Voice.__init__)
        #: the tension's modulation by the swing (``string.tension_modulation``, 0: off)
        self.tension_modulation = 0.0 if self.study else float(sp.tension_modulation or 0.0)
        if self.tension_modulation > 0.0:
            for name in ("youngs_modulus_pa", "diameter_m"):
                if getattr(sp, name) is None:
                    raise ValueError(f"string.{name} is missing: string.tension_modulation = "
                                     f"{self.tension_modulation!r} needs it (or 0: off)")
        if getattr(preset, "bridge", None) is not None and preset.taraf is not None:
            raise ValueError("[bridge] and [taraf] both give the played strings' bridge: keep one "
                             "(with a taraf, taraf.bridge_resistance_ns_per_m sets it)")
        if not (20_000 <= self.fs <= 2_000_000):
            raise ValueError(f"internal rate = {self.fs:g} Hz is out of range (20000 <= value <= 2000000)")
        # the region keeps its metres at any rate: region_points counts at
        # the study grid's own rate, or at DEFAULT_RATE for a musical preset
        scale = (self.cells / preset.grid.cells) if self.study else self.fs / self.DEFAULT_RATE
        self.termination = termination_from_spec(preset.termination, scale)
        #: buzz depth 0 .. 1 (:func:`synth.physics.profiles.buzz_profile`):
        #: the preset's ``termination.buzz``, then the ``play.buzz_cc`` control
        self.buzz = 1.0 if self.termination is None else float(preset.termination.buzz)
        cc = preset.play.buzz_cc if preset.play is not None else None
        self.buzz_cc = None if cc is None or self.termination is None else int(cc)
        self.exciter = exciter_for(preset, self.fs)
        self._setups: dict = {}
        #: each cached setup's slot template (at the full buzz depth): a note-on
        #: copies it into its slot instead of building it again
        self._templates: dict = {}
        #: per bank slot: the pitch bend of its note, -1 .. 1
        self._bend: dict = {}
        #: per bank slot: its note's drain (:meth:`set_buzz`), while it runs
        self._drains: dict = {}
        self._drain_tokens = 0
        self._drain_ticking = False
        #: per bank slot: its note's obstacle, [setup, depth now, depth it
        #: goes to, glide steps done of BUZZ_GLIDE_STEPS] (:meth:`set_buzz`)
        self._depth: dict = {}
        self._glide_ticking = False
        #: the bank (a weak reference) the drains and the glide are in
        self._buzz_bank = None
        #: CC74 for the notes to come, 0 .. 1 (:meth:`excitation_cell`)
        self.position_value = self.POSITION_CENTRE
        #: per bank slot: the setup its note was configured with (its own
        #: excitation point, :meth:`setup`'s ``k``)
        self._slot_su: dict = {}

    def warm(self, keys=range(128)) -> None:
        """Derive every key's string now, so that no note-on has to.  The
        designs of all 128 keys are kept on disk between runs
        (:mod:`synth.voices.design_store`: named by the code, the preset and
        the rate, so never stale)."""
        keys = tuple(keys)
        every = keys == tuple(range(128))
        store = (type(self).__name__, self.preset, self.fs)
        if every and not self._setups:
            kept = design_store.load("setups", store)
            if isinstance(kept, dict):
                self._setups.update(kept)
        n = len(self._setups)
        for k in keys:
            try:
                self.setup(k)
            except ValueError:
                pass    # a pitch this rate cannot hold
        if every and len(self._setups) > n:
            design_store.save("setups", store, dict(self._setups))
        # each setup's slot template at the full buzz, as a note-on makes it:
        # a key's first note-on in a live stream made it in the audio thread
        # (56-76 us of the sitar's on a 2-vCPU Xeon)
        for su in list(self._setups.values()):
            try:
                self._own_template(su)
            except ValueError:
                # a string too short for its termination's contact (the
                # hammered sitar's keys 126-127: 2 region points): its
                # note-on raises the same, and the engine drops the note
                pass

    # -- physics at note-on -------------------------------------------------------
    @property
    def excitation_position(self) -> float:
        """Pluck (or strike) point as a fraction of the string length."""
        return self.exciter.position

    def nominal_f0(self, key: float | None = None, f0_hz: float | None = None) -> float:
        if f0_hz is not None:
            return float(f0_hz)
        if key is not None:
            return midi_key_to_hz(key)
        if self.study:
            return self.open_string.f0_hz
        raise ValueError("key or f0_hz is required for a musical preset")

    def pitch_hz(self, key: float | None = None, f0_hz: float | None = None) -> float:
        """Nominal pitch of a note (Hz); a study string's own without key or f0."""
        return self.nominal_f0(key, f0_hz)

    #: the controller that sets the excitation point (CC74: MPE's timbre,
    #: General MIDI 2's brightness)
    POSITION_CC = 74
    #: CC74's value that plays the preset's own point (64 / 127: MPE's default)
    POSITION_CENTRE = 64 / 127
    #: how near CC74 127 brings the excitation point to the grid's end on
    #: the preset's side (fraction of the sounding string)
    POSITION_EDGE = 0.05

    @staticmethod
    def position_for(value: float, mid: float, own: float, edge: float) -> float:
        """The excitation point for CC74 ``value`` (0 .. 1; clamped), in
        grid points from x = 0: linear from ``mid`` (the sounding string's
        middle) at 0 to ``own`` (the preset's point) at
        :data:`POSITION_CENTRE` (64), and on to ``edge`` (near the end on
        the preset's side) at 1 (127)."""
        v = min(max(float(value), 0.0), 1.0)
        c = OneStringVoice.POSITION_CENTRE
        if v <= c:
            return mid + (own - mid) * (v / c)
        return own + (edge - own) * ((v - c) / (1.0 - c))

    def excitation_cell(self, su: OneStringSetup, value: float) -> int:
        """The grid point a note of setup ``su`` is excited at for CC74
        ``value`` (:meth:`position_for`): 64 the preset's own (``su.k``);
        0 the middle of the sounding string, whose length is half the loop,
        fs / (2 f0) samples (the cells and, at x = L, the loop filter's and
        the bend line's delays: a pluck there leaves out the even
        partials); 127 :data:`POSITION_EDGE` of that length from the grid's
        end on the preset's side of the middle (x = L for the sitar's and
        the biwa's 0.75, x = 0 for the hammered sitar's 0.25).  At least
        one past the termination's region (the jawari) and 3 (the sub-cell
        contact), at most N - 1."""
        if value == self.POSITION_CENTRE:
            return su.k
        half = self.fs / (2.0 * su.f0_hz)
        lo = max(1, 0 if su.U is None else len(su.U) + 1, 3 if su.subcell > 0.0 else 1)
        gap = max(1.0, self.POSITION_EDGE * half)
        edge = su.cells - gap if self.exciter.position > 0.5 else gap
        k = self.position_for(value, 0.5 * half, su.k, edge)
        return min(max(int(round(k)), lo), su.cells - 1)

    def setup(self, key: float | None = None, f0_hz: float | None = None,
              k: int | None = None) -> OneStringSetup:
        """The string for a note (cached per pitch, and per excitation
        point: ``k``, the grid point, None: the exciter's own)."""
        if k is not None:
            su = self.setup(key, f0_hz)
            if k == su.k:
                return su
            ck = ("k", None if key is None and f0_hz is None else round(su.f0_hz, 9), int(k))
            if ck not in self._setups:
                self._setups[ck] = replace(su, k=int(k))
            return self._setups[ck]
        own = key is None and f0_hz is None
        f0 = self.nominal_f0(key, f0_hz)
        ck = (None if own else round(f0, 9))
        if ck in self._setups:
            return self._setups[ck]
        pre = self.preset
        n_disp, a_disp = 0, 0.0
        if self.study and own:
            st = self.open_string
            cells = self.cells
            dt = st.length_m / (cells * st.c_m_per_s)
            b0, a1, eta, xd, lossy = 1.0, 0.0, 0.0, 0, False
        else:
            st = fretted_string(self.open_string, f0)
            fs = self.fs
            dt = 1.0 / fs
            if self.study:
                # lossless: all of the fractional delay in an allpass
                w0 = 2 * math.pi * f0 / fs
                rest = fs / f0
                cells = int(math.floor((rest - 0.5) / 2.0))
                rem = rest - 2 * cells
                xd = 0
                if rem >= 1.5:
                    xd, rem = 1, rem - 1.0
                b0, a1, eta, lossy = 1.0, 0.0, allpass_for_phase_delay(rem, w0), True
            else:
                L = pre.loss
                loop = fs / f0
                r = pre.play.pitch_bend_semitones
                # the bend line: at rest D0, down to 2 samples for +r semitones,
                # up to D0 + loop (2^(r/12) - 1) for -r (without pitch bend, a
                # tension's modulation has a line of TENSION_ROOM_CENTS)
                D0 = self._bend_rest(loop)
                blen = (int(math.ceil(D0 + loop * (2.0 ** (r / 12.0) - 1.0))) + 6
                        + self._rise_margin(loop) if D0 > 0 else 0)
                B = self.inharmonicity(st)
                if B > 0.0:
                    # partial 1 on the key, partials n f0 sqrt(1 + B n^2) above it
                    tl = tune_stiff_loop(f0, B, fs, L.t60_low_s, L.f_low_hz, L.t60_high_s,
                                         L.f_high_hz, fixed_delay=D0)
                    n_disp, a_disp = tl.M, tl.a_disp
                else:
                    tl = tune_loop(f0, fs, L.t60_low_s, L.f_low_hz, L.t60_high_s, L.f_high_hz,
                                   fixed_delay=D0)
                cells, b0, a1, eta, xd, lossy = tl.cells, tl.b0, tl.a1, tl.eta, tl.extra_delay, True
        # the grid spacing of this string
        dx = st.c_m_per_s * dt
        U = None
        side = 1
        subcell = 0.0
        if self.termination is not None:
            U = self.termination.sample(dx)
            side = self.termination.side
            # a very short (high, fretted) string keeps the region within its
            # first third, below the pluck point (3/4): the obstacle then
            # reaches as far along this string as it can
            U = trim_unreachable(U[: max(1, min(len(U), cells // 3))])
            if U is not None:
                subcell = self.termination.subcell(dx)
        k = int(round(self.excitation_position * cells))
        k = min(max(k, 1), cells - 1)
        bl = blen if (not self.study and not own and D0 > 0) else 0
        tension = None
        if bl and self.tension_modulation > 0.0:
            tension = self._tension(st, int(cells), dx, self.fs / f0)
        s = OneStringSetup(st, int(cells), k, dt, U, side, b0, a1, eta, xd, lossy, f0,
                        bl, D0 if bl else 0.0, n_disp, a_disp, subcell, tension)
        self._setups[ck] = s
        return s

    #: without pitch bend, the bend line a tension's modulation moves has
    #: room for this rise (cents).  With pitch bend it has the bend's room
    #: (a full bend up leaves it one sample): more room would move the
    #: string's design (more of its loop in the bend line), and with it the
    #: note: the biwa's key 50 glided +0.47 cent more at velocity 127 with
    #: 100 cents more room and the modulation all but off (kappa 1e-9)
    TENSION_ROOM_CENTS = 100.0
    #: internal samples between two readings of the tension (3.2 ms at 325 kHz):
    #: the glide of every 256 within 0.14 cent and its bands within 0.9 dB, and
    #: a sitar cluster 5-6 % of the block cheaper, since a bridge's chunks end
    #: at its readings (synth.kernels.tension)
    TENSION_EVERY = 1024
    #: the readings are smoothed over this many periods (one pole)
    TENSION_PERIODS = 2.0

    def _bend_rest(self, loop: float) -> float:
        """The bend line's delay at rest (samples; 0: no line): 2 samples
        plus the shortening of ``play.pitch_bend_semitones`` up, else of
        ``TENSION_ROOM_CENTS`` for a tension's modulation."""
        r = self.preset.play.pitch_bend_semitones
        if r <= 0 and self.tension_modulation > 0.0:
            r = self.TENSION_ROOM_CENTS / 100.0
        return loop * (1.0 - 2.0 ** (-r / 12.0)) + 2.0 if r > 0 else 0.0

    def _tension(self, st: IdealString, cells: int, dx: float, loop: float) -> tuple:
        """The string's tension modulation (:mod:`synth.kernels.tension`):
        (kappa, loop, every, alpha) with kappa = tension_modulation E A loop
        / (4 L T0 N dx), the ring's slope sum S to dT / T0 (the ring's 2N
        samples of the loop's ``loop``: int (u_r'^2 + u_l'^2) dx = S loop /
        (2 N dx), the time average of int u_x^2 dx, times E A / (2 L T0):
        :func:`synth.physics.string.tension_gain`)."""
        sp = self.preset.string
        g = tension_gain(st, sp.youngs_modulus_pa, sp.diameter_m)
        kappa = self.tension_modulation * g * loop / (2.0 * cells * dx)
        every = float(self.TENSION_EVERY)
        alpha = 1.0 - math.exp(-every / (self.TENSION_PERIODS * loop))
        return kappa, loop, every, alpha

    #: largest B a note gets (:meth:`inharmonicity`)
    B_MAX = 2e-3

    def inharmonicity(self, st: IdealString) -> float:
        """B of the string ``st`` (fretted or retuned from the open one):
        B = pi^3 E d^4 / (64 T L^2) with the wire's E and d unchanged, i.e.
        the open string's ``string.inharmonicity`` times (T0 / T) (L0 / L)^2
        (Fletcher & Rossing eq. 12.4; 0 for study presets)."""
        B0 = self.preset.string.inharmonicity or 0.0
        if self.study or B0 <= 0.0:
            return 0.0
        o = self.open_string
        B = B0 * (o.tension_n / st.tension_n) * (o.length_m / st.length_m) ** 2
        # retuned far below the playing range (key 5, 10.9 Hz: 0.1 N on the
        # sitar's wire) the stiffness would rule the partials (B 5e-3,
        # partial 8 +40 cents): held at a piano's top treble, 2e-3
        return min(B, self.B_MAX)

    def max_cells(self, key_low: int | None = None) -> int:
        """Largest N any playable note needs (for sizing the bank)."""
        if self.study:
            lo = key_low if key_low is not None else None
            n = self.cells
            if lo is not None:
                n = max(n, int(self.fs / midi_key_to_hz(lo) / 2) + 2)
            return n + 2
        # every MIDI key can sound (a file may go beyond the playable range):
        # rings for key 0 cost 2 * 19 900 samples a voice at 325 kHz
        lo = 0 if key_low is None else min(key_low, 0)
        return int(self.fs / midi_key_to_hz(lo) / 2) + 2

    def sizes(self, extra_low_key: int | None = None) -> BankSizes:
        R = 0 if self.termination is None else self.termination.points
        return BankSizes(strings_per_voice=1, max_cells=self.max_cells(extra_low_key),
                         max_region=R, max_gtable=self.exciter.max_gtable(),
                         max_bend=self.max_bend_len())

    def strike_log(self):
        return self.exciter.strike_log

    def _template(self, su: OneStringSetup, U):
        """The slot template of the setup ``su`` with the profile ``U`` (the
        bank's loss and bend glides: :class:`StringBank`'s, as every voice's)."""
        pre = self.preset
        out_mode = 1 if pre.output.signal == "bridge_force" else 0
        return slot_template(cells=su.cells, k=su.k, dt_s=su.dt_s, U=U, side=su.side,
                             out_mode=out_mode, gain=pre.output.gain,
                             tension_over_dx=su.string.tension_n / (su.string.c_m_per_s * su.dt_s),
                             b0=su.b0, a1=su.a1, eta=su.eta, extra_delay=su.extra_delay,
                             lossy=su.lossy, bend_len=su.bend_len, bend_delay=su.bend_delay,
                             n_disp=su.n_disp, a_disp=su.a_disp, subcell=su.subcell,
                             glide_s=StringBank.LOSS_GLIDE_S,
                             bend_glide_s=StringBank.BEND_GLIDE_S, tension=su.tension)

    def _own_template(self, su: OneStringSetup):
        """The slot template of ``su`` with its own profile, made once and
        kept (with the setup beside it: its id names no other object)."""
        hit = self._templates.get(id(su))
        if hit is None or hit[0] is not su:
            hit = self._templates[id(su)] = (su, self._template(su, su.U))
        return hit[1]

    def _configure(self, bank: StringBank, slot: int, su: OneStringSetup, probe_row: int) -> None:
        U = self._region(su)
        # the cached profile keeps its template; a buzz depth's is made anew
        t = self._own_template(su) if U is su.U else self._template(su, U)
        bank.configure_from(slot, t, probe_row)
        # the thesis's strings are lossless and never damped
        t_damped = math.inf if self.study else self.preset.loss.release_t60_s
        bank.set_damper(slot, (su.b0, su.f0_hz, t_damped, math.inf))

    def max_bend_len(self) -> int:
        """Longest pitch-bend line any playable note needs (samples)."""
        loop = self.fs / midi_key_to_hz(0)
        if self.study or self._bend_rest(loop) <= 0:
            return 0
        r = self.preset.play.pitch_bend_semitones
        return int(math.ceil(self._bend_rest(loop)
                             + loop * (2.0 ** (r / 12.0) - 1.0))) + 6 + self._rise_margin(loop)

    def _region(self, su: OneStringSetup):
        """The note's profile at the current buzz depth (:func:`buzz_profile`;
        the cached one itself at full depth)."""
        if su.U is None or self.buzz == 1.0:
            return su.U
        return buzz_profile(su.U, self.buzz, su.side)

    # -- strings on the bridge ----------------------------------------------------
    #: the bridge's slow spring under the taraf (Hz): keeps u_b from drifting
    BRIDGE_RETURN_HZ = 5.0

    def _bridge_string(self, key: int, length_m: float, term, fs: float, k_frac: float):
        """One string on the bridge, tuned to ``key`` at rate ``fs`` (Hz):
        the ``[taraf]`` material (T = mu (2 L f0)^2, B from the first taraf
        key's as 1/T), its decay, and the termination ``term`` (a
        :class:`Termination` or None).  Returns (SlotTemplate, cells,
        region points)."""
        t = self.preset.taraf
        f0 = midi_key_to_hz(key)
        mu = t.linear_density_kg_per_m
        T = mu * (2.0 * length_m * f0) ** 2
        T_first = mu * (2.0 * t.length_m * midi_key_to_hz(t.keys[0])) ** 2
        B = t.inharmonicity * T_first / T
        st = IdealString(length_m, T, mu)
        f_hi = min(t.f_high_hz, 0.4 * fs)
        if f_hi <= 1.5 * f0:
            raise ValueError(f"key = {key} is too high for the taraf's grid ({fs:g} Hz)")
        if B > 0.0:
            loop = tune_stiff_loop(f0, min(B, self.B_MAX), fs, t.t60_low_s, f0, t.t60_high_s,
                                   f_hi, m_max=4, f_max_hz=0.4 * fs)
            n_disp, a_disp = loop.M, loop.a_disp
        else:
            loop = tune_loop(f0, fs, t.t60_low_s, f0, t.t60_high_s, f_hi)
            n_disp, a_disp = 0, 0.0
        dt = 1.0 / fs
        dx = st.c_m_per_s * dt
        U = None if term is None else term.sample(dx)
        subcell = 0.0
        if U is not None:
            U = trim_unreachable(U[: max(1, min(len(U), loop.cells // 3))])
            if U is not None:
                subcell = term.subcell(dx)
        k = min(max(int(round(k_frac * loop.cells)), 1), loop.cells - 2)
        tpl = slot_template(cells=loop.cells, k=k, dt_s=dt, U=U, side=1, out_mode=1,
                            gain=self.preset.output.gain, tension_over_dx=T / dx,
                            b0=loop.b0, a1=loop.a1, eta=loop.eta,
                            extra_delay=loop.extra_delay, lossy=True, n_disp=n_disp,
                            a_disp=a_disp, glide_s=StringBank.LOSS_GLIDE_S, subcell=subcell)
        return tpl, loop.cells, 0 if U is None else len(U)

    def knock_impulse_ns(self, key, velocity: float, speed_m_per_s: float | None = None) -> float:
        """The plectrum's stroke on the body at a note-on (N s):
        ``pluck.bachi_impulse_ns`` x velocity^velocity_exponent (the pluck
        amplitude's law; velocity normalised 0 .. 1), 0 without one (the
        schema allows it on musical plucked presets only)."""
        p = getattr(self.preset, "pluck", None)
        J = float(getattr(p, "bachi_impulse_ns", None) or 0.0)
        if J <= 0.0:
            return 0.0
        return J * max(float(velocity), 0.0) ** float(self.preset.play.velocity_exponent)

    def knock_shape(self) -> KnockShape:
        """The stroke's pulse: ``pluck.bachi_duration_s`` (s), one pulse."""
        p = getattr(self.preset, "pluck", None)
        d = getattr(p, "bachi_duration_s", None)
        return KnockShape(float(d)) if d else super().knock_shape()

    def free_strings(self, fs_out: float | None = None) -> TarafDesign | None:
        """The ``[taraf]`` and ``[chikari]`` strings at the voice's internal
        rate (the played strings': one bridge steps them all; ``fs_out`` is
        not theirs), or, with a ``[bridge]`` table instead, the bridge alone
        (a design with no strings: the played strings ring into each other
        on it), or None without either.

        Taraf: one string per ``taraf.keys``, on a jawari of its own
        (:func:`synth.physics.profiles.jawari` with the table's radius,
        extent and thread, at most ``region_points`` grid points), hanging on
        the bridge of resistance ``bridge_resistance_ns_per_m / coupling``
        (coupling 0: a rigid bridge, the played string alone: no taraf and
        no chikari, None).  Chikari: one string per ``chikari.keys``, of
        ``chikari.length_m``, on the main string's ``[termination]`` (they
        cross the main bridge), plucked at ``pluck.position`` by
        ``pluck.model`` with ``chikari.amplitude_m`` at velocity 127 and
        the pluck's duration scaled by length (as a fretted main string's).
        """
        # designed once per process (13 strings: 0.11 s, paid by every
        # engine built; the bank copies the templates into its slots), and
        # kept on disk between runs as the keys' designs are (named by the
        # code, the preset and the rate: a warm `synth note sitar` designed
        # them anew); stored as a 1-tuple, since None (no free strings) is
        # the store's "not found"
        key = (type(self).__name__, self.preset, self.fs)
        return design_store.kept(
            _FREE_STRINGS, "free-strings", key, lambda: (self._design_taraf(),),
            lambda v: isinstance(v, tuple) and len(v) == 1
            and (v[0] is None or isinstance(v[0], TarafDesign)))[0]

    def _design_taraf(self) -> TarafDesign | None:
        t = self.preset.taraf
        b = getattr(self.preset, "bridge", None)
        if t is None and b is not None and not self.study:
            # the played strings on one bridge of their own (a tanpura):
            # no free strings; the first sounding string leads it
            return TarafDesign(slots=(), keys=(), resistance_ns_per_m=float(b.resistance_ns_per_m),
                               return_hz=self.BRIDGE_RETURN_HZ, max_cells=8)
        if (t is None or self.study or t.coupling <= 0.0
                or not math.isfinite(t.bridge_resistance_ns_per_m / t.coupling)):
            # (a coupling so small that the bridge's resistance overflows: rigid too)
            return None
        fs = float(self.fs)
        # the taraf's own jawari: the clamp at grid points alone.  Their
        # swing stays far below the first point's gap (the shipped taraf
        # never touch it, docs/voicing.md "Taraf and chikari"), where the sub-cell
        # contact's delta, of the order of its square, is nothing to hear,
        # and it would have cost every taraf string a solve per sample
        own = Termination(jawari(t.radius_m, t.extent_m, t.thread_m), 1, int(t.region_points))
        slots, keys, drones, dkeys = [], [], [], []
        max_cells, max_region = 8, 1
        for key in t.keys:
            tpl, cells, R = self._bridge_string(key, t.length_m, own, fs, 0.5)
            slots.append(tpl)
            keys.append(int(key))
            max_cells, max_region = max(max_cells, cells), max(max_region, R)
        c = self.preset.chikari
        trigger = channel = None
        pluck = DronePluck(K.EXC_NONE, (), (), 0.0, 1.0)
        strum = 0.0
        if c is not None:
            # the main jawari with the clamp at grid points alone, as the
            # taraf's: ringing along, the drones never reach its first
            # point (a strummed drone's buzz still ends in one step, as the
            # played string's did before the sub-cell contact), and their
            # region takes no buzz control (buzz 0 keeps the rigid end's
            # samples)
            term = self.termination
            if term is not None:
                term = replace(term, contact_subcell=False)
            pos = self.exciter.position
            amps, durs = [], []
            ls = c.length_m / self.open_string.length_m
            for key in c.keys:
                tpl, cells, R = self._bridge_string(key, c.length_m, term, fs, pos)
                drones.append(tpl)
                dkeys.append(int(key))
                max_cells, max_region = max(max_cells, cells), max(max_region, R)
                amps.append(c.amplitude_m)
                durs.append(self.exciter.duration_s(ls))
            ps = self.preset.pluck
            pluck = DronePluck(PLUCK_MODELS[ps.model], tuple(amps), tuple(durs),
                               float(ps.alpha_per_s or 0.0),
                               float(self.preset.play.velocity_exponent))
            trigger = (int(c.trigger_key_low), int(c.trigger_key_high))
            channel = None if c.channel == 0 else int(c.channel) - 1
            strum = float(c.strum_s)
        R = t.bridge_resistance_ns_per_m / t.coupling
        return TarafDesign(slots=tuple(slots), keys=tuple(keys), resistance_ns_per_m=R,
                           return_hz=self.BRIDGE_RETURN_HZ, max_cells=max_cells,
                           drone_slots=tuple(drones), drone_keys=tuple(dkeys), trigger=trigger,
                           channel=channel, pluck=pluck, strum_s=strum, max_region=max_region)

    # -- voice contract ------------------------------------------------------------
    #: lowering the buzz depth by 1 (from 1 to 0) drains DRAIN_DB (dB) from
    #: a sounding note's partials at DRAIN_HZ (Hz), less below (a one-pole's
    #: loss: ~ f^2, a quarter of it an octave down, under 1 dB below 1 kHz)
    #: and more above; a smaller fall in proportion.  30 dB: CC1 127 -> 0 at
    #: 1 s takes the band above 4 kHz 7.2-22.0 dB below the note's own over
    #: 1.0-1.2 s, 13.8-29.9 over 1.1-1.2 s, on keys 43-74 of the sitar, biwa
    #: and hammered sitar at velocity 100 (without the drain: +4.0 to -8.3
    #: and +3.3 to -8.1), the band below 500 Hz within 0.3 dB (the hammered
    #: sitar's key 67: -1.0, -0.9 without the drain); tests/test_buzz_control.py
    DRAIN_DB = 30.0
    DRAIN_HZ = 5000.0
    #: the drain's rate falls as exp(-t / DRAIN_TAU_S): half of it in 49 ms
    DRAIN_TAU_S = 0.07
    #: the drain's loss is set anew every DRAIN_STEP_S (s), by
    #: :meth:`StringBank.after` (the same samples in any blocks): every 2
    #: ms, each step of the coefficients left a spike in the output's
    #: second difference up to twice the note's own (key 50: 17.7 dB on
    #: analysis.clicks' scan, the note's own 12.3); every 0.5 ms none, at
    #: no cost to see (a six-note chord's render as fast as without).  It
    #: ends when less than DRAIN_END_DB (dB) is left to come
    DRAIN_STEP_S = 0.0005
    DRAIN_END_DB = 0.3
    #: the drain's loss pole at most (its phase delay: 99 samples)
    DRAIN_POLE_MAX = 0.99
    #: a sounding note's obstacle moves to its new depth over BUZZ_GLIDE_S
    #: (s) in BUZZ_GLIDE_STEPS equal steps of the depth (ten internal
    #: samples each): moved in one step, the string let go of the jawari
    #: (or met it) within a sample, a click on some keys (analysis.clicks'
    #: scan: the hammered sitar's key 43 at CC1 127 -> 0 a jump of 24.9 dB,
    #: 16.2 in the note before it; the sitar's key 62 at 0 -> 127, 24.8 dB);
    #: so gliding, 16.2 and 15.8.  (In 8 steps the sitar's key 43 read 19.1
    #: dB where one step read 13.0; in 32, 13.0.)  Within 1 ms: after it the
    #: string is clear of the obstacle at 0 (tests/test_buzz.py)
    BUZZ_GLIDE_S = 0.001
    BUZZ_GLIDE_STEPS = 32

    def set_buzz(self, bank: StringBank, value: float, sounding=()) -> None:
        """Buzz depth ``value`` (0 .. 1; clamped) for the notes to come and,
        from the next sample, for the ``sounding`` ones ((slots, key,
        f0_hz) tuples): their obstacle moves to U / value
        (:func:`buzz_profile`; 0: out of reach, the linear string),
        gliding there over ``BUZZ_GLIDE_S`` (1 ms).  Each note keeps its
        own depth: notes left out of ``sounding`` (another MIDI channel's)
        stay where they are, and a value a note has already is no change.

        Lowered, the sounding notes also lose what the buzz has put into
        their upper partials.  A linear string keeps it: it rings at the
        loop's own loss (T60 1.2 s at 6 kHz on the sitar), about as slowly
        as the buzzing note's band falls by itself, so that CC1 127 -> 0
        left the band above 4 kHz within +4.0 and -8.3 dB of the note's
        own for a second (louder on the top keys, whose contact had been
        taking some of the band's energy; tests/test_buzz_control.py).  A
        fall of a note's depth by d drains ``DRAIN_DB`` x d dB at
        ``DRAIN_HZ`` from it: its loss filter's pole moves up
        (:meth:`StringBank.set_loss_filter`), the gain at DC kept (the low
        partials do not step), at a rate falling as exp(-t /
        ``DRAIN_TAU_S``), stepped every ``DRAIN_STEP_S`` by
        :meth:`StringBank.after`, and the bend line takes back the delay
        the pole adds at f0 (the note stays in tune: within 0.4 cent of the
        same change without the drain).  Falls add up; a rise ends the
        drain (the buzz comes back from the contact alone); a restrike, a
        new note in the slot or the drain's end give the note its own loss
        filter back, exactly.  A preset without pitch bend has no line to
        take the delay back: its drain adds at most 1 cent's delay.
        """
        self._own(bank)
        old = self.buzz
        self.buzz = min(max(float(value), 0.0), 1.0)
        if self.termination is None:
            return
        glide = False
        for slots, key, f0 in sounding:
            slot = slots[0]
            su = self._note_setup(slot, key, f0)
            if su.U is None:
                continue
            ob = self._depth.get(slot)
            if ob is None or ob[0] is not su:
                ob = self._depth[slot] = [su, old, old, self.BUZZ_GLIDE_STEPS]
            fall = ob[2] - self.buzz            # this note's own (a channel's notes may differ)
            if su.bend_len:
                bank.set_tune_out_gain(slot, self.buzz ** self.RISE_EXPONENT)
            if fall > 0.0:
                self._drain(bank, slot, su, self.DRAIN_DB * fall)
            elif fall < 0.0 and slot in self._drains:
                self._drains[slot].db = 0.0
            if ob[1] != self.buzz:
                # steps of at most 1 / BUZZ_GLIDE_STEPS of the depth: a
                # wheel's small moves go in one, as they come
                n = self.BUZZ_GLIDE_STEPS
                ob[2], ob[3] = self.buzz, n - math.ceil(abs(ob[1] - self.buzz) * n)
                self._glide_step(bank, slot, ob)
                glide = glide or ob[3] < n
            else:
                ob[2], ob[3] = self.buzz, self.BUZZ_GLIDE_STEPS
        if glide and not self._glide_ticking and self._glide_samples() >= 1:
            self._glide_ticking = True
            bank.after(self._glide_samples(), lambda: self._glide_tick(bank))

    def __getstate__(self):
        """A pickled voice (a batch worker's, a cache's) carries no bank's
        drains or glides: they belong to the engine that plays it."""
        st = self.__dict__.copy()
        st.update(_buzz_bank=None, _drains={}, _depth={}, _drain_ticking=False,
                  _glide_ticking=False, _slot_su={})
        return st

    def _note_setup(self, slot: int, key, f0_hz) -> OneStringSetup:
        """The setup the note sounding in ``slot`` was configured with (its
        own excitation point), or the pitch's."""
        su = self._slot_su.get(slot)
        if su is not None and su.f0_hz == self.nominal_f0(key, f0_hz):
            return su
        return self.setup(key, f0_hz)

    def _own(self, bank: StringBank) -> None:
        """The drains and the glides run in one bank (one engine's); a voice
        played by another engine (the warm-up's scratch one, or a program
        change back to a cached voice) starts that one's afresh."""
        if self._buzz_bank is None or self._buzz_bank() is not bank:
            self._buzz_bank = weakref.ref(bank)
            self._drains = {}
            self._drain_ticking = False
            self._depth = {}
            self._glide_ticking = False
            self._slot_su = {}

    def _glide_samples(self) -> int:
        """Internal samples a step of the obstacles' glide (floor: all the
        steps within ``BUZZ_GLIDE_S``; 0: no glide)."""
        return int(self.BUZZ_GLIDE_S * self.fs / max(1, int(self.BUZZ_GLIDE_STEPS)))

    def _glide_step(self, bank: StringBank, slot: int, ob: list) -> None:
        """The next step of a note's obstacle to its new depth: equal
        steps of at most 1 / ``BUZZ_GLIDE_STEPS`` of the depth, as many as
        the change needs (``ob[3]``, the steps done, starts at
        ``BUZZ_GLIDE_STEPS`` less them)."""
        su, b, to, i = ob
        n = max(1, int(self.BUZZ_GLIDE_STEPS))
        k = n - i                                   # steps left, this one's included
        b = to if (k <= 1 or self._glide_samples() < 1) else b + (to - b) / k
        ob[1], ob[3] = b, (n if b == to else i + 1)
        bank.set_region(slot, su.U if b == 1.0 else buzz_profile(su.U, b, su.side))

    def _glide_tick(self, bank: StringBank) -> None:
        """Every glide step: each gliding note's next step."""
        if self._buzz_bank is None or self._buzz_bank() is not bank:
            return                          # an engine the voice has left
        n = max(1, int(self.BUZZ_GLIDE_STEPS))
        more = False
        for slot, ob in self._depth.items():
            if ob[3] < n and bank.is_active(slot):
                self._glide_step(bank, slot, ob)
                more = more or ob[3] < n
        if more:
            bank.after(self._glide_samples(), lambda: self._glide_tick(bank))
        else:
            self._glide_ticking = False

    def _drain(self, bank: StringBank, slot: int, su: OneStringSetup, db: float) -> None:
        """Start (or add ``db`` dB to) the drain of the note in ``slot``."""
        if self.study or not su.lossy or su.a1 > 0.0 or su.b0 / (1.0 + su.a1) >= 1.0:
            return                  # the thesis's lossless strings: nothing to drain into
        d = self._drains.get(slot)
        if d is None or d.su is not su:
            self._drain_tokens += 1
            tau0 = self._pole_delay(su, -su.a1)
            d = _Drain(su, self._drain_tokens, 0.0, tau0, tau0)
            self._drains[slot] = d
        d.db += db
        self._drain_step(bank, slot, d)
        if not self._drain_ticking:
            self._drain_ticking = True
            bank.after(self._drain_samples(), lambda: self._drain_tick(bank))

    def _drain_samples(self) -> int:
        return max(1, int(round(self.DRAIN_STEP_S * self.fs)))

    def _drain_tick(self, bank: StringBank) -> None:
        """Every ``DRAIN_STEP_S``: each running drain's next step."""
        if self._buzz_bank is None or self._buzz_bank() is not bank:
            return                          # an engine the voice has left
        for slot, d in list(self._drains.items()):
            if not bank.is_active(slot):
                del self._drains[slot]          # freed (its next note configures anew)
            else:
                self._drain_step(bank, slot, d)
        if self._drains:
            bank.after(self._drain_samples(), lambda: self._drain_tick(bank))
        else:
            self._drain_ticking = False

    def _drain_step(self, bank: StringBank, slot: int, d: _Drain) -> None:
        """The loss of the drain ``d`` for its next ``DRAIN_STEP_S``: the
        pole that adds db / DRAIN_TAU_S dB/s at DRAIN_HZ (db / (DRAIN_TAU_S
        f0) dB a round trip), as far as the bend line can take its delay
        back; then db decays.  The pole's phase delay at f0 follows that
        pole's through two lags of half the bend line's glide (10 ms: the
        pole sets off without a jump in its rate), and the bend line, whose
        own glide is one lag of 20 ms, is given 2 m - D (m the first lag, D
        the second), so that its delay follows D itself.  At the end the
        note's own loss filter comes back exactly."""
        su = d.su
        p = -su.a1
        w0 = 2.0 * math.pi * su.f0_hz / self.fs
        tau0 = self._pole_delay(su, p)
        room = self._drain_room(slot, su)
        if d.db < self.DRAIN_END_DB:
            d.db = 0.0                  # what is left to come: nothing to hear
        q = self._drain_pole(p, d.db / (self.DRAIN_TAU_S * su.f0_hz))
        tau_t = min(self._pole_delay(su, q), tau0 + room)
        a = 1.0 - math.exp(-2.0 * self.DRAIN_STEP_S / StringBank.BEND_GLIDE_S)
        d.mid += a * (tau_t - d.mid)
        d.tau += a * (d.mid - d.tau)
        d.db *= math.exp(-self.DRAIN_STEP_S / self.DRAIN_TAU_S)
        if d.db == 0.0 and abs(d.tau - tau0) < 1e-3 and abs(d.mid - tau0) < 1e-3:
            # over: the note's own filter, and its bend line as the bend says
            bank.set_loss_filter(slot, su.b0, su.a1)
            del self._drains[slot]
            self._retune(bank, slot, su)
            return
        t = math.tan(d.tau * w0)
        q = t / (math.sin(w0) + t * math.cos(w0))     # the pole of phase delay d.tau at w0
        bank.set_loss_filter(slot, su.b0 * (1.0 - q) / (1.0 - p), -q)
        if su.bend_len:
            d.comp = min(2.0 * d.mid - d.tau - tau0, room)
            self._retune(bank, slot, su)

    def _pole_delay(self, su: OneStringSetup, q: float) -> float:
        """Phase delay (samples) at the note's f0 of the loss pole ``q``."""
        return one_pole_phase_delay(-q, 2.0 * math.pi * su.f0_hz / self.fs)

    def _drain_pole(self, p: float, loss_db: float) -> float:
        """The pole q >= p of the one-pole (1 - q) / (1 - p) b0 / (1 - q
        z^-1), whose gain at DC is the loss filter's (pole p), that loses
        ``loss_db`` (dB a round trip) more than it at ``DRAIN_HZ``: with c =
        1 - cos w, K = 1 + 2 p c / (1 - p)^2 and the power ratio r, q = B -
        sqrt(B^2 - 1), B = 1 + r c / (K - r).  At most ``DRAIN_POLE_MAX``."""
        if loss_db <= 0.0:
            return p
        c = 1.0 - math.cos(2.0 * math.pi * self.DRAIN_HZ / self.fs)
        r = 10.0 ** (-loss_db / 10.0)
        B = 1.0 + r * c / (1.0 + 2.0 * p * c / (1.0 - p) ** 2 - r)
        q = B - math.sqrt(B * B - 1.0)
        return min(max(q, p), max(p, self.DRAIN_POLE_MAX))

    def _drain_room(self, slot: int, su: OneStringSetup) -> float:
        """Samples of delay the note's bend line can give back now: its
        bend's delay above 2 samples (the line's shortest is 1; the
        tune-out only lengthens it); without a bend line the drain's pole
        may add 1 cent's worth."""
        loop = self.fs / su.f0_hz
        if not su.bend_len:
            return loop * (2.0 ** (1.0 / 1200.0) - 1.0)
        r = self.preset.play.pitch_bend_semitones * self._bend.get(slot, 0.0)
        # (less the room kept for a tension's modulation)
        rb = self.preset.play.pitch_bend_semitones
        keep = self._bend_rest(loop) - (loop * (1.0 - 2.0 ** (-rb / 12.0)) + 2.0 if rb > 0 else 0.0)
        return max(0.0, su.bend_delay + loop * (2.0 ** (-r / 12.0) - 1.0) - 2.0 - keep)

    def _end_drain(self, bank: StringBank, slot: int) -> None:
        """The note in ``slot`` is restruck: its own loss filter at once."""
        d = self._drains.pop(slot, None)
        if d is not None:
            bank.set_loss_filter(slot, d.su.b0, d.su.a1)

    def controls(self) -> dict:
        """The buzz depth on ``play.buzz_cc`` (CC1 by default), at the
        preset's ``termination.buzz`` (none for a voice without a
        termination or without the control), and, on musical presets, the
        excitation point on CC74 (:data:`POSITION_CC`, at 64 / 127: the
        preset's own; unless ``play.buzz_cc`` is 74)."""
        out = {}
        if self.buzz_cc is not None and self.termination is not None:
            out[int(self.buzz_cc)] = float(self.buzz)
        if not self.study and self.POSITION_CC not in out:
            out[self.POSITION_CC] = float(self.position_value)
        return out

    @property
    def pressure_cc(self) -> int | None:
        """Pressure sets one note's buzz depth: ``play.buzz_cc`` (None
        without a buzz control)."""
        return None if self.termination is None else self.buzz_cc

    def control_change(self, bank: StringBank, cc: int, value: float, sounding) -> bool:
        """``play.buzz_cc`` (default CC1, the modulation wheel) sets the buzz
        depth, 0 .. 127 to 0 .. 1 (:meth:`set_buzz`); CC74 the excitation
        point of the notes to come (:meth:`position_for`; a sounding
        string was plucked where it was)."""
        if self.buzz_cc is not None and int(cc) == self.buzz_cc:
            self.set_buzz(bank, value, sounding)
            return True
        if int(cc) == self.POSITION_CC and not self.study:
            self.position_value = min(max(float(value), 0.0), 1.0)
            return True
        return False

    #: the contact's pitch rise grows as (velocity x buzz)**RISE_EXPONENT
    #: (fit to the sitar's keys 43-74 at velocities 20-127: 0.61, 1.02,
    #: 1.48, 1.73 cents mean at 20, 40, 80, 127; ``tools/study_jawari.py
    #: --pitch``)
    RISE_EXPONENT = 0.6

    def _rise_cents(self, velocity: float) -> float:
        """The rise at the pluck at buzz 1 (cents): pitch_rise_cents x velocity^0.6."""
        rise = self.preset.termination.pitch_rise_cents or 0.0
        if rise <= 0.0 or self.study:
            return 0.0
        return rise * max(float(velocity), 0.0) ** self.RISE_EXPONENT

    def _rise_margin(self, loop: float) -> int:
        """Samples of bend line the tune-out may take (the rise at velocity 127)."""
        rise = self.preset.termination.pitch_rise_cents or 0.0
        return int(math.ceil(loop * (2.0 ** (rise / 1200.0) - 1.0))) if rise > 0.0 else 0

    def _retune(self, bank: StringBank, slot: int, su: OneStringSetup) -> None:
        """Set the bend line of ``slot`` from its bend."""
        if not su.bend_len:
            return
        r = self.preset.play.pitch_bend_semitones * self._bend.get(slot, 0.0)
        loop = self.fs / su.f0_hz
        d = self._drains.get(slot)
        comp = d.comp if d is not None else 0.0     # a drain's pole's delay, given back
        bank.set_bend_delay(slot, su.bend_delay + loop * (2.0 ** (-r / 12.0) - 1.0) - comp)

    def _tune_out(self, bank: StringBank, slot: int, su: OneStringSetup, velocity: float) -> None:
        """Start the note's decaying tune-out (``StringBank.set_tune_out``):
        the cents the player's tuning takes off the note so that it sounds
        its key with the termination touching it, ``termination.pitch_rise_cents``
        (the rise at the pluck, velocity 127 and buzz 1) times (velocity
        buzz)^0.6, fading as exp(-t / ``termination.pitch_rise_tau_s``); the
        buzz's share is the bank's gain (:meth:`set_buzz` changes it).  A
        grazing jawari shortens the string a little for as long as, and as
        much as, the string swings against it, and a sitar is tuned by ear
        with the jawari on; the rise fades with the swing (measured:
        ``docs/voicing.md``, "Pitch")."""
        c = self._rise_cents(velocity)
        if not su.bend_len or c == 0.0:
            return
        loop = self.fs / su.f0_hz
        bank.set_tune_out(slot, loop * (2.0 ** (c / 1200.0) - 1.0),
                          self.preset.termination.pitch_rise_tau_s,
                          gain=self.buzz ** self.RISE_EXPONENT)

    def pitch_bend(self, bank: StringBank, slots, key, f0_hz, value: float) -> None:
        """Pitch bend, ``value`` in [-1, 1] of ``play.pitch_bend_semitones``:
        the string's loop is shortened or lengthened (as a player deflecting
        the string raises its tension) through the bend line's delay."""
        self._own(bank)
        for slot in slots:
            self._bend[slot] = min(max(float(value), -1.0), 1.0)
            self._retune(bank, slot, self._note_setup(slot, key, f0_hz))

    def note_on(self, bank: StringBank, slots, key: float | None, velocity: float, *,
                f0_hz: float | None = None, probe_row: int = -1, restrike: bool = False,
                speed_m_per_s: float | None = None, soft: float = 0.0,
                rest: bool = False) -> None:
        """Excite the voice's string (configuring it for the pitch, at the
        excitation point CC74 sets, unless ``restrike``: a sounding string is
        excited again where it is, at its own point).  With ``rest`` the
        string is configured and activated at rest, excited by nothing (it
        sounds only by what its bridge gives it: a drone's string before
        its first pluck, which then comes as a ``restrike``)."""
        if rest and restrike:
            raise ValueError("rest and restrike exclude each other")
        slot = slots[0]
        self._own(bank)
        if restrike:
            su = self._note_setup(slot, key, f0_hz)
        else:
            su = self.setup(key, f0_hz)
            if self.position_value != self.POSITION_CENTRE and not self.study:
                su = self.setup(key, f0_hz, self.excitation_cell(su, self.position_value))
            self._slot_su[slot] = su
        if restrike:
            self._end_drain(bank, slot)
            bank.set_loss(slot, su.b0)           # undo a release damping
        else:
            # a new string in the slot: no drain, no glide of the old one's
            self._drains.pop(slot, None)
            self._depth.pop(slot, None)
            self._configure(bank, slot, su, probe_row)
            if su.U is not None:
                self._depth[slot] = [su, self.buzz, self.buzz, self.BUZZ_GLIDE_STEPS]
        ls = su.string.length_m / self.open_string.length_m
        if not rest:
            self.exciter.start(bank, slot, su, velocity, amplitude_scale=ls,
                               speed_m_per_s=speed_m_per_s, length_scale=ls)
        if not restrike:
            self._bend[slot] = 0.0
        self._retune(bank, slot, su)
        if not rest:
            self._tune_out(bank, slot, su, velocity)
        bank.activate(slot)

    def note_off(self, bank: StringBank, slots, key: float | None, f0_hz: float | None,
                 pedal: float) -> None:
        """The key is up: damp the string (loop gain down to the release T60,
        a pure gain on the loss filter so the tuning does not move) unless
        the sustain pedal is down (>= 0.5, :meth:`Voice.damper_lift`)."""
        bank.apply_dampers(np.asarray(slots, dtype=np.int64), self.damper_lift(pedal))
