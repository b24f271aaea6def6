"""Grand piano voice: 88 keys of hammered, stiff, detuned strings.

Grand piano
===========
Each key (MIDI 21-108) is one, two or three strings
(:mod:`synth.physics.piano`), each a waveguide string on the engine's grid
with, at x = L, a loop filter from the key's two T60 values, a cascade of
second-order allpasses for the string's stiffness (inharmonic partials
f_n = n f0 sqrt(1 + B n^2): partials up to 40, or up to 10 kHz, within 1.2
cents, :func:`synth.physics.dispersion.tune_stiff_loop_sos`, designed for
the key and retuned for each string of its unison; a first-order cascade of
at most ``strings.dispersion_sections`` where no second-order one meets
that) and a fractional-delay allpass tuning partial 1 exactly to the
preset's tuning (equal temperament at ``tuning.stretch = 0``, a tuner's
stretch for this inharmonicity at 1; ``tuning.octave_k_bass`` the octave
type below A4).  Treble strings from C#5 up bear against the capo
d'astro bar (thesis section 1.3.2) near x = 0; the others start at an
agraffe (ideal end).

Every string is struck by its share of the key's hammer (the thesis's
per-key felt laws, their constants voiced by ``action.voicing``,
:data:`synth.physics.piano.VOICINGS`; mass divided by the number of
strings struck), at the key's strike distance from the agraffe or bar,
with the hammer speed given by the velocity curve
``speed_min + (speed_max - speed_min) v^e``, v = (velocity - 1/127) /
(1 - 1/127), e = ``play.velocity_exponent``.

Two-stage decay: the strings of a key hang on one bridge (the kernel's
coupled group, :meth:`synth.dsp.bank.StringBank.couple`): a dashpot whose
motion under the strings' summed force every string's end follows
(Weinreich 1977).  Each string's loop keeps its own loss (the aftersound's
T60, ``t60_low_s``); the bridge takes energy fast from the strings' in-phase
motion (the prompt sound's T60, ``t60_prompt_s``, which sets the bridge's
resistance, :func:`synth.physics.piano.bridge_resistance_ns_per_m`, scaled
by ``strings.bridge_coupling``) and little from the motions that cancel at
the bridge.  The strings are slightly detuned and the hammer meets them
unequally (``synth.physics.piano.UNISON_STRIKE``), so a note beats, falls
fast, then decays slowly, and a string left unstruck (una corda) rings
through the bridge.  A trichord's bridge also moves as a mass above
``strings.bridge_mass_f0`` times its f0 (:func:`synth.physics.piano.
bridge_mass_hz`): the prompt sound takes its energy from the low partials,
and the upper ones keep their own decay, as a recorded grand's; the mass's
reactance raises the in-phase motion, which the loops are tuned with
(:meth:`GrandVoice.bridge_lag`).

Dampers: a key's release damps its strings (T60 from
``dampers.release_t60_bass_s`` to ``..._treble_s`` across the keyboard),
except the top keys, which have no dampers; the sustain pedal lifts the
dampers gradually between ``half_pedal_low`` and ``half_pedal_high`` (half
pedal: the T60 lies geometrically between the damped and the free value).
Soft pedal: at 0.5 and above the hammer misses one string of a two- or
three-string unison (una corda shift), which then sounds only through the
bridge; the felt gets softer continuously (stiffness times 1 - (1 -
soft_stiffness) * soft).

A strike from ``strings.capo_grid_from_key`` up (C6: the capo keys whose
colour a listener hears) runs on a finer grid (``strings.capo_grid`` steps
per engine sample, the kernel's ``I_SUB``): at the engine's 325 kHz a grid
cell is 1.3 mm, wider than the part of the string that lifts onto the bar
in free vibration, so there the bar acts only while the hammer presses the
string; at 1.3 MHz (4) the string reaches the bar after the hammer has
left (33-77 episodes per string in the first 20 ms at V = 5 m/s), and the
low partials lose energy to the high ones, as the thesis's study finds
(Publication I).  That colour is made in the attack (``tools/study_capo.py
window``: the bar's first 5-20 ms give most of it), so after
``strings.capo_window_s`` the strings go on at the engine's rate
(:meth:`GrandVoice.leave_fine_grid`, :meth:`synth.dsp.bank.
StringBank.hand_over`: the rings resampled with the bar's end in place,
the loop filters' states fitted to go on where the finer ones would), and
a sustaining treble note costs what it did on the engine's grid.  A key
struck again after that meets its strings on the engine's grid.  Window 0
keeps the finer grid for the whole note (the thesis's study).

Output: each string writes the force on the bridge into two buses, split by
the key's place along the bridge (bus 0 the bass end, bus 1 the treble
end).

The soundboard is a modal bank on the decimated bridge signal(s): the voice
describes it (:meth:`GrandVoice.body`, from ``[body]``: one or two
bridge inputs, one or two outputs) and the engine builds it
(:class:`synth.dsp.body.Body`).
"""

from __future__ import annotations

import math
import pickle
from dataclasses import dataclass, replace

import numpy as np

from ..dsp.bank import (HammerTemplate, SlotTemplate, StringBank, hammer_set,
                        hammer_template, slot_template)
from ..dsp.groups import GroupTemplate, group_template
from ..kernels import strings as K
from ..physics import piano as P
from ..physics.dispersion import BridgeLag, retune_sos_loop, tune_stiff_loop_sos
from ..physics.profiles import Termination, capo
from ..physics.soundboard import KnockShape, knock_impulse_ns
from ..physics.dispersion import tune_stiff_loop
from . import design_store
from .base import BankSizes, SympatheticDesign, Voice
from .dampers import KeyboardDampers
from .quality import quality_level
from .registry import register_voice

#: per-key string designs, by (preset, internal rate, dispersion tolerance)
_DESIGNS: dict = {}
#: the mark of a ``_DESIGNS`` entry filled from the design store
#: (:meth:`GrandVoice._kept`): in the dict itself, so that a dict made
#: anew (a test's fresh process) loads again
_FROM_STORE = ("filled from the design store",)
#: sympathetic-string designs, by (preset, output rate): designing the 72
#: strings took 0.41 s, paid by every engine built (a batch worker builds
#: one per job; a 4-s grand note renders in 0.09 s)
_SYMPATHETIC: dict = {}

#: the return frequency of the bridge's spring (Hz): far below the lowest
#: note, it only keeps the dashpot from drifting (at 5 Hz its reactance
#: flattened A0's single string by 1.2 cents; at 1 Hz by 0.2)
BRIDGE_RETURN_HZ = 1.0
#: each string's partials within this of the stiff-string law (cents) at the
#: standard quality level (set there, synth.voices.quality; reference: 0.5):
#: 1.2 leaves room for the unison's spread and the coupled strings' pull, so
#: the note's partials stay within 2 cents (1.5 left 2.1-2.7 cents on some
#: bass keys' partials 17-21; the design's cost: 5 % more sections than at 2)
DISPERSION_TOL_CENTS = quality_level("standard").dispersion_tol_cents
#: semitones over which a treble string's own loss rises to
#: ``strings.t60_treble_scale`` (log-linear in key, reaching it at
#: ``strings.t60_treble_from_key``): the recorded grand's partial 1 at 3 s
#: falls 10-20 dB from B5 to C6 (tools/real_grand.py)
TREBLE_LOSS_RAMP_ST = 6


@dataclass(frozen=True)
class GrandSetup:
    """One string of a key, ready for the bank."""

    cells: int
    k: int
    dt_s: float
    U: np.ndarray | None
    b0: float
    a1: float
    eta: float
    extra_delay: int
    n_disp: int
    a_disp: float
    sos: np.ndarray               # second-order dispersion sections (c1, c2), shape (M, 2)
    tension_n: float
    c_m_per_s: float
    f1_hz: float
    sub: int = 1                            # steps per engine sample (a finer grid)
    slot: SlotTemplate | None = None        # the bank configuration, validated once
    hammer: HammerTemplate | None = None    # its hammer (speed and soft pedal per strike)
    hammer_soft: HammerTemplate | None = None  # with the una corda: its share of one string fewer
    damper: tuple | None = None             # its damper row (StringBank.set_damper)
    bridge: tuple | None = None             # its key's bridge (R_b N s/m, mass corner Hz); None: rigid


#: partials of the second polarization's string tuned to the stiff-string
#: law (within the quality's tolerance): heard at a tenth of the unison's
#: level, in an aftersound whose partials above the third are gone within a
#: second, its loop needs 0-2 biquads over keys 49-83 where all 40 took 2-8
#: (a middle key cost 1.33-1.42x with them, ``tools/bench.py grand``)
POLAR_PARTIALS = 10


@register_voice("grand")
class GrandVoice(KeyboardDampers, Voice):
    """The 88-key grand (voice ``grand``)."""

    KEY_LOW, KEY_HIGH = 21, 108
    strings_per_voice = 3
    buses = 2
    struck = True

    def __init__(self, preset, fs_internal: float | None = None):
        super().__init__(preset, fs_internal)
        if not (100_000 <= self.fs <= 2_000_000):
            raise ValueError(f"internal rate = {self.fs:g} Hz is out of range (100000 <= value <= 2000000)")
        # per-key designs are shared by every instrument of the same preset
        # and rate in this process (designing a key takes ~17 ms)
        self._keys: dict[int, tuple[GrandSetup, ...]] = _DESIGNS.setdefault(
            (preset, self.fs, self.quality.dispersion_tol_cents), {})
        st = preset.strings
        self._capo = capo(st.capo_radius_m)
        #: the unison's strings and, with ``strings.polarization``, one more
        #: for the keys' second polarization (:meth:`polar_setup`)
        self.strings_per_voice = 3 + (1 if self.polarization > 0.0 else 0)
        #: per key: (``action.knock``, the whole hammer's mass (kg)), validated
        #: once (:meth:`knock_impulse_ns`)
        self._knock: dict[int, tuple[float, float]] = {}
        #: hammer speeds by velocity (:meth:`hammer_speed`)
        self._speeds: dict = {}
        #: the strike's hammers stacked, by (key, grid, strings struck)
        #: (:meth:`note_on`: one kernel call a strike)
        self._hammer_sets: dict = {}
        #: a fresh strike's strings packed, by (key, grid, polarization)
        #: (:meth:`note_on`: one call sets them up)
        self._groups: dict = {}

    def warm(self) -> None:
        """Design every key now (about 0.4 s), so that no note-on has to:
        call before a live stream opens.  The designs are kept on disk
        between runs (:mod:`synth.voices.design_store`: named by the code,
        the preset, the rate and the tolerance, so never stale).  Each
        key's hammer sets (struck on every string and, una corda, on one
        fewer) and its strings packed for a fresh strike (with their dampers'
        loss factors, :meth:`_group_of`) are made too: without them a
        key's first strike in a live stream cost 160-180 us of the audio
        thread against 25-35 us for the next on a 2-vCPU Xeon (a chord of
        eight keys not yet played, about 1 ms of a 2.67 ms period)."""
        store = self._store_key()
        packed = self._kept(store)
        n = len(packed)
        self._warming = True                # (one save at the end: _designed)
        try:
            for key in range(self.KEY_LOW, self.KEY_HIGH + 1):
                pol = self.polar_setup(key)
                for sus in (self.setup(key), self.coarse_setup(key)):
                    m = len(sus)
                    self._hammer_set_of(key, sus, m, pol)
                    self._group_of(key, sus, pol)
                    if pol is not None:
                        self._group_of(key, sus, None)      # (its polarization still sounding)
                    if m >= 2:
                        self._hammer_set_of(key, sus, m - 1, pol)
        finally:
            self._warming = False
        if len(packed) > n:
            design_store.save("grand-keys", store, dict(packed))

    #: set while :meth:`warm` designs every key (it saves them once, at the end)
    _warming = False

    def _kept(self, store) -> dict:
        """The designs the design store keeps under ``store`` (this voice's
        preset, rate and tolerance), each still pickled (design key ->
        bytes): read once per process, kept beside the process's designs
        (shared by every voice of the preset, rate and tolerance).  Each
        design is unpickled when a note first needs it: the whole file of
        a warmed grand (0.66 MB) unpickled took 25-40 ms, as long as
        designing one key."""
        packed = self._keys.get(_FROM_STORE)
        if packed is None:
            kept = design_store.load("grand-keys", store)
            packed = self._keys[_FROM_STORE] = (
                dict(kept) if isinstance(kept, dict)
                and all(isinstance(v, bytes) for v in kept.values()) else {})
        return packed

    def _designed(self, dk, make):
        """``self._keys[dk]`` (a key's strings on a grid, or its second
        polarization): this process's, else the design store's
        (:meth:`_kept`), else made by ``make()``.  A design made outside
        :meth:`warm` is saved at once with the others (one file per preset,
        rate and tolerance, which :meth:`warm` fills, not one per key: the
        store keeps its 128 newest files): a key took 35-40 ms to design
        (its strings' dispersion cascades) and 5-8 ms to load, so a
        note or a piece played again, in another process, designs
        nothing."""
        keys = self._keys
        if dk not in keys:
            store = self._store_key()
            packed = self._kept(store)
            value = None
            if dk in packed:
                try:
                    value = pickle.loads(packed[dk])
                except Exception:               # (a bad entry: designed anew)
                    value = None
                if not isinstance(value, (tuple, GrandSetup)):
                    value = None
            if value is None:
                value = make()
                packed[dk] = pickle.dumps(value, protocol=pickle.HIGHEST_PROTOCOL)
                if not self._warming:
                    design_store.save("grand-keys", store, dict(packed))
            keys[dk] = value
        return keys[dk]

    def _hammer_set_of(self, key: int, sus, struck: int, polar=None):
        """The hammer set striking ``struck`` of the strings ``sus`` of
        ``key`` (una corda: the whole hammer on one string fewer), and the
        second polarization ``polar`` (a :class:`GrandSetup`, struck at the
        hammer's whole speed) after them, made once per key, grid, strings
        struck and polarization."""
        hk = (key, sus[0].sub, struck, polar is not None)
        hs = self._hammer_sets.get(hk)
        if hs is None:
            n = len(sus)
            soft = struck != n
            temps = [su.hammer_soft if soft else su.hammer for su in sus[:struck]]
            factors = tuple(P.UNISON_STRIKE[n][:struck])
            if polar is not None:
                temps.append(polar.hammer_soft if soft else polar.hammer)
                factors += (1.0,)
            hs = self._hammer_sets[hk] = hammer_set(temps, factors)
        return hs

    def _group_of(self, key: int, sus, polar=None) -> GroupTemplate:
        """The strings a fresh strike of ``key`` sets up, packed for one
        call (:meth:`synth.dsp.bank.StringBank.configure_group`): the unison
        ``sus`` on its bridge and the second polarization ``polar``; made
        once per key, grid and polarization."""
        gk = (key, sus[0].sub, polar is not None)
        g = self._groups.get(gk)
        if g is None:
            strings = tuple(sus) + ((polar,) if polar is not None else ())
            bridge = sus[0].bridge
            g = self._groups[gk] = group_template(
                [su.slot for su in strings], [su.damper for su in strings],
                n_coupled=len(sus) if bridge is not None else 0,
                resistance_ns_per_m=None if bridge is None else bridge[0],
                return_hz=BRIDGE_RETURN_HZ, mass_hz=0.0 if bridge is None else bridge[1])
        return g

    def _store_key(self) -> tuple:
        return (self.preset, self.fs, self.quality.dispersion_tol_cents)

    # -- sizes for the engine -----------------------------------------------------
    @property
    def capo_grid(self) -> int:
        """Steps per engine sample of the strings on the finer grid."""
        return int(self.preset.strings.capo_grid or 1)

    @property
    def fine_grid_key(self) -> int:
        """The first key whose capo-bar strings run on the finer grid."""
        k = self.preset.strings.capo_grid_from_key
        return int(k) if k is not None else P.CAPO_FIRST_MIDI

    def max_cells(self, key_low: int | None = None) -> int:
        low = int(self.fs / P.et_f0_hz(self.KEY_LOW, 400.0) / 2) + 4
        capo = int(self.capo_grid * self.fs
                   / P.et_f0_hz(max(P.CAPO_FIRST_MIDI, self.fine_grid_key), 400.0) / 2) + 4
        return max(low, capo)

    def max_region_points(self) -> int:
        c_min = min(g.c_m_per_s for g in P.grand_piano_strings() if g.has_capo)
        return int(math.ceil(self.preset.strings.capo_region_m * self.capo_grid * self.fs
                             / c_min)) + 1

    def sizes(self, extra_low_key: int | None = None) -> BankSizes:
        return BankSizes(strings_per_voice=self.strings_per_voice,
                         max_cells=self.max_cells(extra_low_key),
                         max_region=self.max_region_points())

    def free_strings(self, fs_out: float) -> SympatheticDesign | None:
        """One string per key (standing for its unison: output x the
        strings per key) at the output rate, for the keys whose loop holds
        at least 12 cells there (up to about D7 at 48 kHz: the halo is the
        low and middle strings'), decaying as one string on the bridge
        (:func:`synth.physics.piano.single_string_t60_s`), damped as the
        played strings are; the board's bridge they hang on has the median
        of the keys' bridge resistances over ``strings.sympathetic`` (0:
        none)."""
        sp = self.preset.strings
        amount = sp.sympathetic or 0.0
        if amount <= 0.0:
            return None
        fs = float(fs_out)
        k = (self.preset, fs)
        # (the design is data: the bank copies the templates into its
        # slots); kept on disk between runs, as the keys' designs
        return design_store.kept(_SYMPATHETIC, "grand-sympathetic", k,
                                 lambda: self._design_sympathetic(fs, amount),
                                 lambda v: isinstance(v, SympatheticDesign))

    def _design_sympathetic(self, fs: float, amount: float) -> SympatheticDesign:
        sp = self.preset.strings
        keys, slots, dampers, has_damper = [], [], [], []
        max_cells = 8
        for key in range(self.KEY_LOW, self.KEY_HIGH + 1):
            gs = P.grand_string(key)
            f1 = self.tuning_hz(key)
            if fs / (2.0 * f1) < 14.0:
                continue
            t_free = self._free_string_t60_s(key) * sp.t60_scale
            t_hi = min(gs.t60_s(gs.f_high_hz) * t_free / gs.t60_low_s, t_free)
            f_hi = min(max(gs.f_high_hz, 1.5 * f1), 0.4 * fs)
            if f_hi <= f1:
                continue
            try:
                loop = tune_stiff_loop(f1, gs.inharmonicity_b, fs, t_free, f1, t_hi, f_hi,
                                       m_max=4, f_max_hz=0.4 * fs)
            except ValueError:
                continue
            if loop.cells < 12:
                continue
            dt = 1.0 / fs
            k = min(max(int(round(gs.strike_distance_m / (gs.c_m_per_s * dt))), 1), loop.cells - 2)
            slots.append(slot_template(
                cells=loop.cells, k=k, dt_s=dt, U=None, side=1, out_mode=1,
                gain=self.preset.output.gain * gs.n_strings,
                tension_over_dx=gs.tension_n / (gs.c_m_per_s * dt), b0=loop.b0, a1=loop.a1,
                eta=loop.eta, extra_delay=loop.extra_delay, lossy=True, n_disp=loop.M,
                a_disp=loop.a_disp, glide_s=self.damper_land_s,
                bend_glide_s=StringBank.BEND_GLIDE_S, pan=self.pan(key)))
            t_damped = min(self.release_t60_s(key), t_free) if gs.has_damper else t_free
            dampers.append((loop.b0, f1, t_damped, t_free))
            has_damper.append(gs.has_damper)
            keys.append(key)
            max_cells = max(max_cells, loop.cells)
        R = float(np.median([P.bridge_resistance_ns_per_m(k) for k in keys])) / amount
        return SympatheticDesign(slots=tuple(slots), keys=tuple(keys), resistance_ns_per_m=R,
                                 return_hz=BRIDGE_RETURN_HZ, max_cells=max_cells,
                                 dampers=tuple(dampers), has_damper=tuple(has_damper))

    # -- physics at note-on -------------------------------------------------------
    def tuning_hz(self, key: int) -> float:
        """Partial-1 frequency this preset tunes ``key`` to (Hz)."""
        t = self.preset.tuning
        return P.stretched_f0_hz(key, None, a4_hz=t.a4_hz, stretch=t.stretch,
                                 octave_k_bass=t.octave_k_bass)

    def pitch_hz(self, key: float | None = None, f0_hz: float | None = None) -> float:
        """Partial-1 frequency of ``key`` as tuned (Hz), or ``f0_hz``."""
        if f0_hz is not None:
            return float(f0_hz)
        return self.tuning_hz(int(round(key)))

    def setup(self, key: int) -> tuple[GrandSetup, ...]:
        """The key's strings as a strike sets them up: on the finer grid
        from ``strings.capo_grid_from_key`` up (the capo keys)."""
        key = int(key)
        if key not in self._keys:
            gs = P.grand_string(key)
            M = self.capo_grid if (gs.has_capo and key >= self.fine_grid_key) else 1
            return self._designed(key, lambda: self._design(key, M))
        return self._keys[key]

    def coarse_setup(self, key: int) -> tuple[GrandSetup, ...]:
        """The key's strings on the engine's grid: where they go on after
        a strike on the finer grid (:meth:`leave_fine_grid`); the same as
        :meth:`setup` for a key that has no finer grid."""
        key = int(key)
        fine = self.setup(key)
        if fine[0].sub == 1:
            return fine
        return self._designed(("coarse", key), lambda: self._design(key, 1))

    @property
    def polarization(self) -> float:
        """``strings.polarization``: the second polarization's share of a
        string's output (0: none)."""
        return float(self.preset.strings.polarization or 0.0)

    def polar_setup(self, key: int) -> GrandSetup | None:
        """The key's second polarization, or None (``strings.polarization``
        0, or the key outside ``strings.polarization_from_key`` ..
        ``polarization_to_key``): one string standing for the unison's
        motion parallel to the board.

        Weinreich (1977): the bridge is stiff in that direction, so the
        string there loses only its own loss (to air and in the wire: the
        unison's slow T60, :attr:`synth.physics.piano.GrandString.t60_low_s`,
        with the treble's factors) and is tuned on a rigid end to the key's
        partial 1; the hammer's slant starts it with the strike, and the
        board hears it through the bridge's small coupling that way.  Both
        are one factor on a linear string, its output share
        ``strings.polarization``: it is struck by its own felt at the
        hammer's whole speed, so its spectrum is the unison's, and heard at
        that share.  It stays on the engine's grid (it has no finer grid to
        leave) and on no bridge; its damper falls with the unison's."""
        sp = self.preset.strings
        share = self.polarization
        key = int(key)
        if share <= 0.0 or not (int(sp.polarization_from_key) <= key <= int(sp.polarization_to_key)):
            return None
        return self._designed(("polar", key), lambda: self._design_polar(key, share))

    def _design_polar(self, key: int, share: float) -> GrandSetup:
        """:meth:`polar_setup`'s string, designed on the engine's grid."""
        gs = P.grand_string(key)
        pre = self.preset
        sp = pre.strings
        f1 = self.tuning_hz(key)
        fs = self.fs
        dt = 1.0 / fs
        dx = gs.c_m_per_s * dt
        t_lo, t_hi = self._loop_t60s(gs, gs.t60_low_s * self.own_t60_factor(key))
        loop = tune_stiff_loop_sos(f1, gs.inharmonicity_b, fs, t_lo, f1, t_hi,
                                   max(gs.f_high_hz, 1.5 * f1),
                                   tol_cents=self.quality.dispersion_tol_cents,
                                   m_max=sp.dispersion_sections, max_partials=POLAR_PARTIALS)
        k, U = self._strike_point_and_bar(gs, dx, loop.cells)
        su = GrandSetup(loop.cells, k, dt, U, loop.b0, loop.a1, loop.eta, loop.extra_delay,
                        loop.n_fo, loop.a_fo, loop.sos, gs.tension_n, gs.c_m_per_s, f1, sub=1)
        slot = self._slot(key, su, pre.output.gain * share)
        n = gs.n_strings
        t_damped = min(self.release_t60_s(key), t_lo) if gs.has_damper else t_lo
        return replace(su, slot=slot,
                       hammer=hammer_template(dt_s=dt, **self._hammer(key, n, su)),
                       hammer_soft=hammer_template(dt_s=dt, **self._hammer(key, max(n - 1, 1), su)),
                       damper=(su.b0, f1, t_damped, t_lo))

    def fine_window_s(self, key) -> float | None:
        """How long (s) a strike of ``key`` stays on its finer grid before
        its strings go on at the engine's rate (``strings.capo_window_s``),
        or None: the key has no finer grid, or it keeps it for the whole
        note (window 0 or unset)."""
        if key is None or not (self.KEY_LOW <= int(round(key)) <= self.KEY_HIGH):
            return None
        w = self.preset.strings.capo_window_s
        if not w or self.setup(int(round(key)))[0].sub == 1:
            return None
        return float(w)

    def leave_fine_grid(self, bank: StringBank, slots, key) -> bool:
        """Move the key's sounding strings from the finer grid to the
        engine's (:meth:`synth.dsp.bank.StringBank.hand_over`); False while
        a hammer is still on them (try again later)."""
        key = int(round(key))
        coarse = self.coarse_setup(key)
        use = [(sl, su) for sl, su in zip(slots, coarse) if bank.is_active(sl)]
        if not use:
            return True
        return bank.hand_over([sl for sl, _ in use], [su.slot for _, su in use],
                              [su.damper for _, su in use])

    def _design(self, key: int, M: int) -> tuple[GrandSetup, ...]:
        """The key's strings designed on a grid of ``M`` steps per engine
        sample."""
        gs = P.grand_string(key)
        pre = self.preset
        sp = pre.strings
        f1 = self.tuning_hz(key)
        B = gs.inharmonicity_b
        fs = self.fs * M
        dt = 1.0 / fs
        dx = gs.c_m_per_s * dt
        # a rigid bridge (coupling 0): the string's own decay is the whole
        # decay, as before the bridge was modelled: the prompt T60
        cpl = sp.bridge_coupling if sp.bridge_coupling is not None else 0.0
        t_own = (gs.t60_low_s if cpl > 0 else gs.t60_prompt_s) * self.own_t60_factor(key)
        out = []
        t_lo, t_hi = self._loop_t60s(gs, t_own)
        # the key's stiffness: second-order allpasses putting partials up to
        # 40 (or 10 kHz) within 2 cents of the stiff-string law, designed once
        # for the key and retuned for each string of its unison
        key_loop = tune_stiff_loop_sos(f1, B, fs, t_lo, f1, t_hi, max(gs.f_high_hz, 1.5 * f1),
                                       tol_cents=self.quality.dispersion_tol_cents,
                                       m_max=sp.dispersion_sections, bridge=self.bridge_lag(key, fs))
        # the unison's detuning: the key's law with the tuner's limit of
        # ``strings.unison_spread_hz`` (the per-key data carries the law's
        # default, UNISON_SPREAD_HZ)
        dets = P.unison_detune_cents(key, len(gs.unison_detune_cents), self.unison_spread_hz)
        for j, det in enumerate(dets):
            fj = f1 * 2.0 ** (det * sp.detune_scale / 1200.0)
            loop = key_loop if fj == f1 else retune_sos_loop(
                key_loop, fj, t_lo, fj, t_hi, max(gs.f_high_hz, 1.5 * fj))
            cells = loop.cells
            k, U = self._strike_point_and_bar(gs, dx, cells)
            out.append(GrandSetup(cells, k, dt, U, loop.b0, loop.a1, loop.eta,
                                        loop.extra_delay, loop.n_fo, loop.a_fo, loop.sos,
                                        gs.tension_n, gs.c_m_per_s, fj, sub=M))
        # validated bank rows, so that a note-on in the audio thread only
        # copies them (~10 us per key instead of ~35)
        R_b = self.bridge_resistance_ns_per_m(key)
        bridge = None if R_b is None else (R_b, self.bridge_mass_hz(key))
        full = []
        for su in out:
            slot = self._slot(key, su, pre.output.gain)
            hp = self._hammer(key, len(out), su)
            hps = self._hammer(key, max(len(out) - 1, 1), su)
            # the damper's felt: T60 from the damped value (release_t60_s, at
            # most the free one) to the free one as the pedal lifts it; keys
            # without dampers ring on (damped = free)
            t_nat = t_own * sp.t60_scale
            t_damped = min(self.release_t60_s(key), t_nat) if gs.has_damper else t_nat
            full.append(replace(su, slot=slot, hammer=hammer_template(dt_s=su.dt_s, **hp),
                                hammer_soft=hammer_template(dt_s=su.dt_s, **hps),
                                damper=(su.b0, su.f1_hz, t_damped, t_nat), bridge=bridge))
        return tuple(full)

    def _loop_t60s(self, gs, t_own_s: float) -> tuple[float, float]:
        """A string's loop T60s (s) at f0 and at its high frequency
        ``gs.f_high_hz`` for its own T60 at f0 ``t_own_s``: the law's
        high-frequency decay scaled alike, times ``strings.t60_scale``, the
        upper at most the lower."""
        sc = self.preset.strings.t60_scale
        t_lo = t_own_s * sc
        return t_lo, min(gs.t60_s(gs.f_high_hz) * t_own_s / gs.t60_low_s * sc, t_lo)

    def _strike_point_and_bar(self, gs, dx: float, cells: int):
        """A string's strike point (cells from the end: at its distance from
        the agraffe or bar, as the loop filter takes its delay out of the
        cells; l/L x cells would strike nearer the end, at 0.35 l on F7) and
        its capo bar's profile U (None without a bar)."""
        sp = self.preset.strings
        k = min(max(int(round(gs.strike_distance_m / dx)), 1), cells - 2)
        U = None
        if gs.has_capo and sp.capo_region_m > 0:
            R = max(1, int(round(sp.capo_region_m / dx)))
            R = min(R, cells // 3)
            U = Termination(self._capo, 1, R).sample(dx)
        return k, U

    def _slot(self, key: int, su: GrandSetup, gain: float) -> SlotTemplate:
        """The bank's validated row for string ``su`` of ``key``, heard at
        ``gain`` (so that a note-on in the audio thread only copies it: ~10
        us per key instead of ~35)."""
        return slot_template(cells=su.cells, k=su.k, dt_s=su.dt_s, U=su.U, side=1,
                             out_mode=1, gain=gain,
                             tension_over_dx=su.tension_n / (su.c_m_per_s * su.dt_s),
                             b0=su.b0, a1=su.a1, eta=su.eta, extra_delay=su.extra_delay,
                             lossy=True, n_disp=su.n_disp, a_disp=su.a_disp, sos=su.sos,
                             glide_s=self.damper_land_s,
                             bend_glide_s=StringBank.BEND_GLIDE_S,
                             pan=self.pan(key), sub=su.sub)

    def _treble_weight(self, key: int) -> float:
        """0 up to :data:`TREBLE_LOSS_RAMP_ST` below
        ``strings.t60_treble_from_key``, rising linearly in key to 1 there."""
        k0 = int(self.preset.strings.t60_treble_from_key)
        return min(max((int(key) - k0 + TREBLE_LOSS_RAMP_ST) / TREBLE_LOSS_RAMP_ST, 0.0), 1.0)

    def own_t60_factor(self, key: int) -> float:
        """Factor on the key's strings' own T60 (their loss to air and wire,
        the aftersound's decay): 1 up to :data:`TREBLE_LOSS_RAMP_ST` below
        ``strings.t60_treble_from_key``, log-linear in key to
        ``strings.t60_treble_scale`` there, and that above, times
        ``strings.t60_top_factor`` reached log-linearly at C8.  The bridge's
        resistance stays the key's (the prompt sound takes the added loss
        too)."""
        f = self._treble_ramp(self.preset.strings.t60_treble_scale, key)
        top = float(self.preset.strings.t60_top_factor)
        k0 = int(self.preset.strings.t60_treble_from_key)
        if top == 1.0 or key <= k0 or k0 >= P.MIDI_HIGH:
            return f
        # ``strings.t60_top_factor``: further, log-linear from 1 at k0 to it at C8
        return f * top ** ((min(int(key), P.MIDI_HIGH) - k0) / (P.MIDI_HIGH - k0))

    def treble_coupling_factor(self, key: int) -> float:
        """Factor on the bridge's admittance the key's unison feels
        (``strings.bridge_coupling_treble``, with the same ramp as
        :meth:`own_t60_factor`): the prompt sound's loss to the board."""
        return self._treble_ramp(self.preset.strings.bridge_coupling_treble, key)

    @property
    def unison_spread_hz(self) -> float:
        """The tuner's limit on a unison's outer strings, Hz of beating
        (``strings.unison_spread_hz``): with the 0.6 cent limit it sets the
        key's detuning (:func:`synth.physics.piano.unison_detune_cents`;
        the same as the law's 0.6 Hz below about A6).  More detuning passes
        more of the struck motion on to the unison's slowly decaying modes,
        the aftersound (Weinreich 1977)."""
        return float(self.preset.strings.unison_spread_hz)

    def _treble_ramp(self, factor: float, key: int) -> float:
        """``factor`` at and above ``strings.t60_treble_from_key``, 1 up to
        :data:`TREBLE_LOSS_RAMP_ST` below it, log-linear in key between."""
        f = float(factor)
        return 1.0 if f == 1.0 else f ** self._treble_weight(key)

    def _free_string_t60_s(self, key: int) -> float:
        """T60 (s) at f0 of one of the key's strings alone on the bridge
        (:func:`synth.physics.piano.single_string_t60_s`) with its own loss
        as :meth:`own_t60_factor` sets it."""
        f = self.own_t60_factor(key)
        if f == 1.0:
            return P.single_string_t60_s(key)
        gs = P.grand_string(key)
        n = max(gs.n_strings, 2)
        bridge = 1.0 / gs.t60_prompt_s - 1.0 / gs.t60_low_s
        return 1.0 / (1.0 / (gs.t60_low_s * f) + bridge / n)

    def pan(self, key: int) -> float:
        """Where the key's strings meet the bridge, 0 (the bass end, bus 0)
        .. 1 (the treble end, bus 1): linear in the key."""
        return (int(key) - self.KEY_LOW) / (self.KEY_HIGH - self.KEY_LOW)

    def knock_shape(self) -> KnockShape:
        """The knock's force (:func:`synth.physics.soundboard.knock_pulse`):
        pulses of ``action.knock_s``, built up over ``action.knock_build_s``
        (0: one pulse)."""
        a = self.preset.action
        return KnockShape(float(a.knock_s), float(a.knock_build_s or 0.0))

    def knock_impulse_ns(self, key, velocity: float, speed_m_per_s: float | None = None) -> float:
        """The action's knock at a note-on (:func:`synth.physics.soundboard.
        knock_impulse_ns`: ``action.knock`` of the whole hammer's momentum
        at its speed; 0 for a key off the keyboard)."""
        if key is None or not (self.KEY_LOW <= int(round(key)) <= self.KEY_HIGH):
            return 0.0
        k = int(round(key))
        rm = self._knock.get(k)
        if rm is None:
            ratio = self.preset.action.knock or 0.0
            m = P.hammer_mass_kg(k, 1)
            if not ratio <= 0.0:
                knock_impulse_ns(m, 0.0, ratio)       # (validates the mass and the ratio)
            rm = self._knock[k] = (float(ratio), float(m))
        ratio, m = rm
        if ratio <= 0.0:
            return 0.0
        V = self.hammer_speed(velocity) if speed_m_per_s is None else float(speed_m_per_s)
        if not (0.0 <= V <= 20.0):
            return knock_impulse_ns(m, V, ratio)      # (raises: the speed is out of range)
        return ratio * m * V

    def bridge_resistance_ns_per_m(self, key: int) -> float | None:
        """The resistance (N s/m) of the bridge the key's strings hang on
        (:func:`synth.physics.piano.bridge_resistance_ns_per_m` over
        ``strings.bridge_coupling``), or None for a rigid bridge."""
        c = self.preset.strings.bridge_coupling
        if not c:
            return None
        return (P.bridge_resistance_ns_per_m(int(key), self.bridge_mass_hz(key))
                / (c * self.treble_coupling_factor(key)))

    def bridge_lag(self, key: int, fs: float) -> BridgeLag | None:
        """The phase of the key's unison's in-phase reflection from its
        bridge (a loop at ``fs`` Hz), which the strings' loops are tuned
        with: a bridge with mass raises that motion (the prompt sound, what
        a tuner tunes); None for a rigid bridge or a dashpot."""
        R = self.bridge_resistance_ns_per_m(key)
        f_m = self.bridge_mass_hz(key)
        if R is None or not (f_m > 0.0):
            return None
        gs = P.grand_string(int(key))
        return BridgeLag(R, R / (2.0 * math.pi * f_m), gs.n_strings * gs.impedance_ns_per_m, fs)

    def bridge_mass_hz(self, key: int) -> float:
        """Frequency (Hz) above which the key's bridge moves as a mass
        (:func:`synth.physics.piano.bridge_mass_hz` of
        ``strings.bridge_mass_f0``; 0: a dashpot)."""
        return P.bridge_mass_hz(int(key), float(self.preset.strings.bridge_mass_f0 or 0.0))

    def hammer_speed(self, velocity: float) -> float:
        """The hammer's speed (m/s) at ``velocity`` (0 .. 1) by the
        velocity curve (the module docstring); remembered per velocity (a
        note-on asks twice: the strike and the knock)."""
        V = self._speeds.get(velocity)
        if V is None:
            a = self.preset.action
            v = (float(velocity) - 1.0 / 127.0) / (1.0 - 1.0 / 127.0)
            v = min(max(v, 0.0), 1.0)
            V = a.speed_min_m_per_s + (a.speed_max_m_per_s - a.speed_min_m_per_s) * v ** (
                self.preset.play.velocity_exponent)
            if len(self._speeds) >= 4096:       # (velocities from anywhere: a bound)
                self._speeds.clear()
            self._speeds[velocity] = V
        return V

    #: a hammer out of contact with its string for this long (s) is gone
    #: (it may hit again before: :func:`synth.dsp.excitation.hammer_template`)
    RELEASE_S = 0.004
    #: ... or for this many of the string's periods, if that is shorter: a
    #: hammer flying freely has met the string's widest swing at its strike
    #: point within a period, and recedes (the treble's 0.24-1 ms periods).
    #: Measured: the longest gap between two contacts of one strike is
    #: 0.34 ms from key 51 up, 0.08 ms from key 84 up, 1.22 ms on key 21
    #: (every third key, velocities 0.1-1, 20 ms); keys 48-108 (every third,
    #: velocities 0.05-1) render the same samples as with the 4 ms rule to
    #: 1.3e-12 of their peak with one period, and still with a quarter
    #: (tests/test_hammer.py).  Two periods would cost a
    #: treble strike's first block 15-19 % more CPU (keys 96 and 105:
    #: 418 -> 353 and 433 -> 350 us on one thread).
    RELEASE_PERIODS = 1.0

    def release_s(self, su: GrandSetup) -> float:
        """How long (s) the hammer of string ``su`` stays on after its last
        contact: min(:data:`RELEASE_S`, :data:`RELEASE_PERIODS` periods of
        the string).  Until then the string renders in chunks no longer than
        the distance from the strike point to the near end (1-35 samples from
        key 72 up), so this sets most of what a treble strike costs."""
        return min(self.RELEASE_S, self.RELEASE_PERIODS / su.f1_hz)

    def _hammer(self, key: int, n_strings: int, su: GrandSetup) -> dict:
        """The key's felt hammer for one of its ``n_strings`` strings
        (:func:`synth.dsp.bank.hammer_template` arguments but dt; the
        speed and the soft pedal's stiffness factor come per strike)."""
        a = self.preset.action
        mass = P.hammer_mass_kg(key, n_strings)
        rel = self.release_s(su)
        if a.law == "three-parameter":
            q0, p, alpha = P.hammer_three_param(key, P.VOICINGS[a.voicing or "thesis"])
            return dict(law=K.EXC_HAMMER3, mass_kg=mass, stiffness=q0, exponent=p, alpha_or_gamma=alpha,
                        tau0_s=0.0, tension_n=su.tension_n, c_m_per_s=su.c_m_per_s,
                        max_flight_s=0.05, release_s=rel)
        f0, p, gamma, tau0 = P.hammer_four_param(key)
        return dict(law=K.EXC_HAMMER4, mass_kg=mass, stiffness=f0, exponent=p, alpha_or_gamma=gamma,
                    tau0_s=tau0, tension_n=su.tension_n, c_m_per_s=su.c_m_per_s,
                    max_flight_s=0.05, release_s=rel)

    # -- voice contract -----------------------------------------------------------
    def note_on(self, bank: StringBank, slots, key, velocity: float, *, f0_hz=None,
                probe_row: int = -1, restrike: bool = False, speed_m_per_s: float | None = None,
                soft: float = 0.0) -> None:
        """Strike the key's strings (all of them, or all but one with the
        soft pedal at 0.5 or more)."""
        if key is None or not (self.KEY_LOW <= int(round(key)) <= self.KEY_HIGH):
            return  # no such key on a piano
        key = int(round(key))
        sus = self.setup(key)
        n = len(sus)
        if restrike and sus[0].sub > 1 and all(bank.is_active(s) for s in slots[:n]) \
                and bank.grid_of(slots[0]) != sus[0].sub:
            # struck again after its strings left the finer grid: they stay
            # on the engine's (the hammer meets them there)
            sus = self.coarse_setup(key)
        struck = n - 1 if (soft >= 0.5 and n >= 2) else n
        V = self.hammer_speed(velocity) if speed_m_per_s is None else float(speed_m_per_s)
        a = self.preset.action
        # the soft pedal's softer felt, on hammers voiced `hardness` times stiffer
        stiff = a.hardness * (1.0 - (1.0 - a.soft_stiffness) * min(max(soft, 0.0), 1.0))
        bridge = sus[0].bridge
        fresh = not restrike or not all(bank.is_active(s) for s in slots[:n])
        pol = self.polar_setup(key)
        hit = slots[:struck]
        # a second polarization still sounding after its unison died away is
        # struck again where it is, not set up anew (that would cut it)
        ring_on = pol is not None and restrike and bank.is_active(slots[n])
        if fresh:
            # the unison on its bridge and the second polarization, in one call
            both = pol is not None and not ring_on
            bank.configure_group(slots[:n + both], self._group_of(key, sus, pol if both else None),
                                 probe_row)
        else:
            for slot, su in zip(slots, sus):
                bank.set_loss(slot, su.b0)          # dampers off: the key is down
        if pol is not None:
            ps = slots[n]
            if not fresh or ring_on:
                if bank.is_active(ps):
                    bank.set_loss(ps, pol.b0)
                else:
                    bank.configure_from(ps, pol.slot, probe_row + n if probe_row >= 0 else -1)
                    bank.set_damper(ps, pol.damper)
            hit = tuple(hit) + (ps,)
        bank.start_hammers_from(hit, self._hammer_set_of(key, sus, struck, pol), V, stiff)
        for j, slot in enumerate(slots[:n]):
            # every string sounds: an unstruck one (una corda) through the bridge
            if bridge is not None or j < struck:
                bank.activate(slot)
        if pol is not None:
            bank.activate(slots[n])

    def note_off(self, bank: StringBank, slots, key, f0_hz, pedal: float) -> None:
        """Key up: the damper falls on the strings, as far as the sustain
        pedal lets it (half pedal: partly; the felt resting more or less
        firmly moves the T60 geometrically between the damped and the free
        value, :meth:`StringBank.apply_dampers`); keys without dampers ring
        on."""
        if key is None or not (self.KEY_LOW <= int(round(key)) <= self.KEY_HIGH):
            return
        key = int(round(key))
        n = len(self.setup(key)) + (self.polar_setup(key) is not None)
        self.drop_dampers(bank, slots[:n], pedal)
