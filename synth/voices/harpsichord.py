"""Harpsichord-like voice: the grand's piano strings, plucked by a plectrum.

Plucked piano string (voice ``harpsichord``)
============================================
Built with the "new voice" recipe of ``docs/architecture.md``, from parts
the house already has: each key (``play.key_low`` .. ``play.key_high``,
within MIDI 21-108) is one string of the grand's per-key design
(:mod:`synth.physics.piano`: speaking length, tension, inharmonicity B,
decay times of one string alone on the bridge,
:func:`synth.physics.piano.single_string_t60_s`; the first string of its
unison), tuned like the grand
(``[tuning]``: partial 1 exact, stretch 0 .. 1) with its stiffness allpass
cascade (:func:`synth.physics.dispersion.tune_stiff_loop`, at most
``strings.dispersion_sections`` sections), and plucked instead of struck:
the ``[pluck]`` exciter of :mod:`synth.voices.exciters` (the thesis's
kinematic g(t), eq. 1.13, for ``model = "sitar"``: a plectrum drawing the
string aside and letting go within ``duration_s``) at ``pluck.position`` of
its length, as a harpsichord's jack plucks near the nut.  A regulated
plectrum lets go of every string at about the same force; with the force
pluck's dg/dt = F / 2Z (eq. 1.4, Z = sqrt(T mu) the string's impedance) the
amplitude is therefore ``pluck.amplitude_m`` on middle C's string and scales
as Z(C4) / Z on the others (the heavy wound bass strings take less).  The
plectra are voiced as a builder voices them, trimmed thinner towards the
treble so the compass sounds even: the amplitude also scales as (f(C4) /
f0)^``VOICING_EXPONENT`` (0.5: without it the treble's loudness rose by
about 3 dB per octave, 12 dB from F1 to F5).
Velocity changes the level only a little (``play.velocity_exponent``), as on
a harpsichord.
No termination (an ideal end at x = 0), bridge-force output, and the
``[body]`` soundboard on the mix.

Dampers: a key's release damps its string with the T60 of ``[dampers]``
(bass to treble, geometric), and a sustain pedal, which harpsichords do not
have but keyboard players send, lifts them between ``half_pedal_low`` and
``half_pedal_high`` as on the grand.

What it is not: a harpsichord's own scaling (thinner brass and steel wire
at a third of a piano's tension, a lute stop, two choirs); the strings are
the piano's.
"""

from __future__ import annotations

from dataclasses import dataclass, replace


from ..dsp.bank import SlotTemplate, StringBank, slot_template
from ..physics import piano as P
from ..physics.dispersion import tune_stiff_loop
from ..physics.string import IdealString
from .base import BankSizes, Voice
from .dampers import KeyboardDampers
from .registry import exciter_for, register_voice


@dataclass(frozen=True)
class HarpsichordSetup:
    """One key's string, ready for the bank and the exciter."""

    string: IdealString
    cells: int
    k: int
    dt_s: float
    U: None
    b0: float
    f1_hz: float
    slot: SlotTemplate
    damper: tuple
    pluck_scale: float      # the pluck's amplitude factor on this key (Z_ref / Z)


#: the plectra's voicing across the compass: amplitude x (f(C4) / f0)^this
VOICING_EXPONENT = 0.5


@register_voice("harpsichord")
class HarpsichordVoice(KeyboardDampers, Voice):
    """A plucked piano string per key (voice ``harpsichord``)."""

    KEY_LOW, KEY_HIGH = 21, 108
    #: the key whose string takes ``pluck.amplitude_m`` as it is (middle C)
    KEY_REF = 60

    def __init__(self, preset, fs_internal: float | None = None):
        super().__init__(preset, fs_internal)
        if preset.kind != "musical":
            raise ValueError(f"kind = {preset.kind!r} is not allowed for voice = 'harpsichord' "
                             f"(musical only)")
        if not (100_000 <= self.fs <= 2_000_000):
            raise ValueError(f"internal rate = {self.fs:g} Hz is out of range "
                             f"(100000 <= value <= 2000000)")
        #: the keys that play (``play.key_low`` .. ``key_high``)
        self._range = (int(preset.play.key_low), int(preset.play.key_high))
        lo, hi = self._range
        if not (self.KEY_LOW <= lo and hi <= self.KEY_HIGH):
            raise ValueError(f"play.key_low..key_high = {lo}..{hi} is out of range "
                             f"({self.KEY_LOW} <= key <= {self.KEY_HIGH}: the piano's strings)")
        self.exciter = exciter_for(preset, self.fs)
        self._keys: dict[int, HarpsichordSetup] = {}

    def warm(self) -> None:
        lo, hi = self._range
        for key in range(lo, hi + 1):
            self.setup(key)

    # -- sizes and body ---------------------------------------------------------
    def sizes(self, extra_low_key: int | None = None) -> BankSizes:
        lo, _ = self._range
        return BankSizes(strings_per_voice=1,
                         max_cells=int(self.fs / P.et_f0_hz(lo, 400.0) / 2) + 4,
                         max_gtable=self.exciter.max_gtable())

    def pitch_hz(self, key: float | None = None, f0_hz: float | None = None) -> float:
        """Partial-1 frequency of ``key`` as tuned (Hz), or ``f0_hz``."""
        if f0_hz is not None:
            return float(f0_hz)
        t = self.preset.tuning
        return P.stretched_f0_hz(int(round(key)), None, a4_hz=t.a4_hz, stretch=t.stretch)

    def setup(self, key: int) -> HarpsichordSetup:
        """The key's string (designed once, then cached)."""
        key = int(key)
        if key in self._keys:
            return self._keys[key]
        gs = P.grand_string(key)
        pre, sp = self.preset, self.preset.strings
        f1 = self.pitch_hz(key)
        dt = 1.0 / self.fs
        # one string on the bridge: its own loss and the bridge's share (its
        # own T60 the grand's earlier law, the prompt reference, which this
        # voice was voiced on: the grand's strings' own decay is fitted to a
        # recorded grand's aftersound, a piano's, not this voice's)
        t_own = P.t60_prompt_reference_s(gs.f0_hz)
        t_one = P.single_string_t60_s(key, t_own)
        t_lo = t_one * sp.t60_scale
        g_own = replace(gs, t60_low_s=t_own, t60_high_s=min(gs.t60_high_s, t_own))
        t_hi = min(g_own.t60_s(gs.f_high_hz) * t_one / t_own * sp.t60_scale, t_lo)
        loop = tune_stiff_loop(f1, gs.inharmonicity_b, self.fs, t_lo, f1, t_hi,
                               max(gs.f_high_hz, 1.5 * f1), m_max=sp.dispersion_sections,
                               f_max_hz=18000.0)
        cells = loop.cells
        k = min(max(int(round(self.exciter.position * cells)), 1), cells - 2)
        slot = slot_template(cells=cells, k=k, dt_s=dt, U=None, out_mode=1, gain=pre.output.gain,
                             tension_over_dx=gs.tension_n / (gs.c_m_per_s * dt),
                             b0=loop.b0, a1=loop.a1, eta=loop.eta, extra_delay=loop.extra_delay,
                             lossy=True, n_disp=loop.M, a_disp=loop.a_disp,
                             glide_s=self.damper_land_s,
                             bend_glide_s=StringBank.BEND_GLIDE_S)
        string = IdealString(gs.speaking_length_m, gs.tension_n, gs.linear_density_kg_per_m)
        t_damped = min(self.release_t60_s(key), t_lo)
        ref = P.grand_string(self.KEY_REF)
        su = HarpsichordSetup(string, cells, k, dt, None, loop.b0, f1, slot,
                                (loop.b0, f1, t_damped, t_lo),
                                ref.impedance_ns_per_m / gs.impedance_ns_per_m
                                * (ref.f0_hz / gs.f0_hz) ** VOICING_EXPONENT)
        self._keys[key] = su
        return su

    # -- voice contract -----------------------------------------------------------
    def note_on(self, bank, slots, key, velocity, *, f0_hz=None, probe_row=-1, restrike=False,
                speed_m_per_s=None, soft=0.0) -> None:
        """Pluck the key's string (a key outside the keyboard is not played)."""
        lo, hi = self._range
        if key is None or not (lo <= int(round(key)) <= hi):
            return
        su = self.setup(int(round(key)))
        slot = slots[0]
        if restrike and bank.is_active(slot):
            bank.set_loss(slot, su.b0)              # the damper leaves the string
        else:
            bank.configure_from(slot, su.slot, probe_row)
            bank.set_damper(slot, su.damper)
        self.exciter.start(bank, slot, su, velocity, amplitude_scale=su.pluck_scale)
        bank.activate(slot)

    def note_off(self, bank, slots, key, f0_hz, pedal) -> None:
        """Key up: the damper falls as far as the sustain pedal lets it."""
        self.drop_dampers(bank, slots[:1], pedal)
