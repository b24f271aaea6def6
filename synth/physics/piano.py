"""Physics data for an 88-key concert grand: strings, hammers, stretch tuning.

Pure laws and numbers (numpy + math only), keyed by MIDI note 21 (A0) ..
108 (C8).  The thesis numbers the keys 1..88 (A0 = 1): ``thesis_key(midi) =
midi - 20``; its A7 study is thesis note 85 = MIDI 105 = 3520 Hz.

Strings (``GrandString``, ``grand_piano_strings()``)
----------------------------------------------------
Every quantity comes from a few smooth scaling laws, anchored at a handful of
documented design values, not from a table of 88 typed numbers:

* Sections (a concert-grand stringing pattern): MIDI 21..30 (A0..F#1, 10
  keys) one wound string; 31..48 (G1..C3, 18 keys) two wound strings;
  49..108 (C#3..C8, 60 keys) three plain steel strings.  226 strings.
* Plain strings (MIDI >= 49): speaking length ``L = 61 mm * r^((105 - m)/12)``
  with the octave ratio ``r = 1.88`` (treble scaling of modern grands lies
  between about 1.88 and 1.94 per octave instead of the 2 of a "just" scale;
  Fletcher & Rossing, *The Physics of Musical Instruments*, ch. 12; Conklin,
  *Design and tone in the mechanoacoustic piano*, Part III, JASA 1996).  Wire
  diameter log-linear in pitch from 0.8254 mm at A7 (the steel wire of
  mu = 4.2 g/m, the study's string) to 1.04 mm at C#3.  mu = rho pi d^2 / 4
  (steel, rho = 7850 kg/m^3), and the tension FOLLOWS from the nominal pitch:
  ``T = mu (2 L f0)^2``.  Result: T = 690..780 N per string, the nearly
  level tension of a modern treble scale.
* Wound strings (MIDI <= 48): the bass is foreshortened: ``L`` is a power law
  of f0 from 2.00 m at A0 to 1.20 m at C3 (so L stays monotone across the
  break: C#3, the first plain string, is 1.16 m).  Tension per string is
  log-linear within each section (singles 1150 -> 1300 N, rising towards the
  single/bichord transition; bichords 900 -> 820 N: the usual large step in
  per-string tension where singles pass to bichords), the steel core diameter
  log-linear within each section (singles 1.60 -> 1.40 mm, bichords 1.27 ->
  1.05 mm; the first bichord core is thinner so that B stays continuous
  across that step).  The copper winding is whatever mass the pitch needs, so
  here the linear density FOLLOWS: ``mu = T / (2 L f0)^2`` (effective, core +
  winding).
* Either way the string's own fundamental ``c / 2L`` equals the key's nominal
  equal-tempered f0 (A4 = 440 Hz) to round-off.  To play a stretched tuning,
  a voice takes ``f1 = stretched_f0_hz(...)``, converts it with
  ``string_f0_for_partial1(f1, B)`` and retunes T at fixed L and mu (B then
  moves by a fraction of a percent, negligible).
* Inharmonicity ``B = pi^3 E d^4 / (64 T L^2)`` with the (core) diameter d and
  E = 2.0e11 Pa; for wound strings only the core counts (the winding adds mass,
  not bending stiffness, in this model; measured bass B is usually somewhat
  higher than the core-only value).  Shape: about 1.0e-4 through the bichords,
  rising towards A0 (1.4e-4, the foreshortened bass), a STEP UP at the bass
  break (C3 wound 1.0e-4 -> C#3 plain 1.2e-4), then rising monotonically to
  about 2e-2 at C8 (A7: 1.56e-2).  B is therefore monotone only from MIDI 48
  upward; its minimum is in the wound bichord section.
* Strike position l/L: 1/8.6 up to about C5 (grands strike at 1/7 to 1/9,
  Fletcher & Rossing ch. 12; Chaigne & Askenfelt's C4 0.12; exactly 1/8
  would null partial 8, 16, ...), then falling smoothly (a softplus
  ramp in semitones from E5) so that A7 reproduces the study's l = 2.6 mm of
  L = 61 mm (0.0426) exactly; C6 is about 1/12, C8 about 1/26 (l = 2.0 mm).
* Dampers on MIDI <= 88 (E6); the top 20 keys (F6..C8) are undamped.
* Capo d'astro bar: MIDI >= 73 (C#5) terminate on the capo bar (the first
  capo section of a Steinway D starts at C#5); lower strings run through
  agraffes.
* Unison detune (cents, per string): spread s = 0.6 cent between the
  outer strings, or less where that would beat faster than 0.6 Hz (from
  about A6 up: 0.5 cent at C7, 0.25 cent at C8; a tuner tunes unisons by
  ear to a slow beat or none, and the same cents beat faster the higher
  the note); one string (0,), two (-s/2, +s/2), three (-0.55 s, 0,
  +0.45 s) (slightly asymmetric, as a tuner leaves them).  The 0.6 cent
  is fitted to a recorded grand (the Salamander Yamaha C5 of
  ``tools/real_grand.py``): how much partials 2-8 beat over 0.1-3 s, as
  the RMS of their level about the best two-segment line, on keys 39-87
  every minor third (``python tools/study_partials.py beats``): the model
  minus the recording reads +1.61 dB on median with 1 cent (the spread
  Kirk 1959 suggests, who found unisons mistuned by up to 1-2 cents in the
  middle range), +0.52 with 0.7, -0.09 with 0.6 and
  -0.14 with 0.5 (mean absolute 1.45, 0.71, 0.65, 0.74 dB).
* Decay, in two stages (Weinreich, "Coupled piano strings", JASA 62, 1977):
  the strings of a unison share the bridge, whose motion under their summed
  force takes energy fast from their in-phase motion (the "prompt" sound)
  and hardly any from the motions in which they cancel at the bridge (the
  "aftersound").  ``t60_low_s`` is a string's own decay at f0, the
  aftersound: a log-log quadratic in f0 through A0 = 120 s, C4 = 50 s and
  C8 = 6 s (``T60_ANCHORS``).  A0 and C4 are fitted to a recorded grand's
  tails (a Yamaha C5, the samples of ``tools/real_grand.py``; ``python
  tools/study_partials.py tail``, docs/voicing.md "The aftersound"): with
  40 s and 20 s (the literature's orders of measured late decay times:
  Martin 1947; Weinreich 1977 fig. 8; Bank, Zambon & Fontana
  2010) the middle's notes fell 2.5-3 times too fast and 8-18 dB too low
  after 2.5 s; at C8 the lower end of the late T60s, 6-47 s, that the
  two-stage fit of ``tools/voicing_report.py`` gives the same recording's
  top keys (with 3.6 s the top octave's aftersound had fallen to the
  fit's -50 dB floor within 1.5 s; the top octave's prompt sound, 1.1 s, is
  what one hears of its 1-2 s); monotone decreasing over the keyboard.
  ``t60_prompt_s`` is the in-phase motion's: the reference law
  ``PROMPT_REFERENCE_ANCHORS`` (A0 = 40 s, C4 = 20 s, C8 = 6 s, the strings'
  own law before that fit) over ``PROMPT_RATIO`` (Weinreich's prompt decay
  rates are 3-10 times the aftersound's; 4 for trichords, up to 7.4 in the
  middle as a recorded grand's early decay (``TRICHORD_PROMPT_ANCHORS``),
  easing to 3 over the top octave, 3 for bichords as the recording's,
  :func:`prompt_ratio`), which fixes the bridge's resistance per key
  (:func:`bridge_resistance_ns_per_m`): R_b = 2 f0 Z n / (sigma_p -
  sigma_a), Z = sqrt(T mu) the string's impedance, n the strings on it (2
  for the single bass strings, whose bridge is as stiff as their
  neighbours'), sigma = ln(1000) / T60 (each reflection from a dashpot
  keeps (R_b - n Z)/(R_b + n Z) of the in-phase wave).  The order of R_b:
  1-3 kg/s per string against 500-3000 kg/s for the bridge, the measured
  driving-point impedance of a grand's board (Giordano 1998; Conklin 1996).
  The bridge may also move as a mass above a corner (:func:`bridge_mass_hz`,
  the grand preset's ``strings.bridge_mass_f0``): its admittance 1 / (R_b +
  j w M) keeps the prompt decay at f0 (R_b over 1 + (f0 / f_m)^2) and takes
  less and less from the partials above f_m, so the fundamental falls fast
  and the upper partials keep their own decay, as a recorded grand's do
  (docs/voicing.md, "The bridge's mass"); its reactance raises the in-phase
  motion, which the strings' loops are tuned with
  (``synth.physics.dispersion.BridgeLag``).
  High frequencies: the decay-rate law of Chaigne & Askenfelt (1994),
  ``sigma(f) = b1 + b3 (2 pi f)^2`` (amplitude decay rate, 1/s; T60 = ln(1000)
  / sigma) with b1 set by T60 at f0 and b3 = 5.0e-9 s, fitted to a recorded
  grand (the Salamander Yamaha C5 of ``tools/real_grand.py``): over the 28
  partials of keys 63-99 at 3-8 kHz that lie within 50 dB of their note's
  strongest, the model's early T60 over the recording's has a median of
  0.96 (quartiles 0.81-1.36) with 5.0e-9, 0.76 (0.66-1.20) with Chaigne &
  Askenfelt's 6.25e-9 for their C4, whose faster loss left the treble's
  partials above 4 kHz dying in half the recording's time (``python
  tools/study_partials.py damping --real DIR``).  ``f_high_hz = max(5 kHz,
  2 f0)``: 5 kHz up to D#7, the second harmonic above that (up to 8.4 kHz
  at C8).  ``GrandString.t60_s(f)`` gives
  the same law at any frequency.

Hammers (thesis eqs. 1.5-1.9; Publication III eqs. 3-7; physics notes sec. 4)
------------------------------------------------------------------------------
``hammer_three_param``, ``hammer_four_param``, ``hammer_mass_kg``.  Stiffness
is returned per mm^p as in the thesis; ``stiffness_per_m_p`` converts.

Stretch tuning
--------------
``stretch_curve_cents`` / ``stretched_f0_hz``: tuned outward from A4 by
octaves on the A keys (A4 -> A5 -> ... -> A7 and A4 -> A3 -> ... -> A0), each
octave beatless between partial 2k of the lower key and partial k of the
upper key (k = 1, the default: the 2:1 octave; partials f_j = j f0
sqrt(1 + B j^2)), a monotone cubic (PCHIP) in cents between the A keys, and
the last three keys (A#7..C8) by the same octave rule from A#6..C7.  With the
2:1 rule this grand comes out at +27.5 cents at C8 (Railsback-like) but only
-1.5 cents at A0: its bass B (~1e-4) is low and the 2:1 octave hardly feels
it.  Railsback's -10..-30 cents in the bass come from tuners widening bass
octaves (and from the higher bass B of smaller pianos); ``octave_k_bass = 3``
(6:3 octaves below A4) gives about -10 cents at A0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import lru_cache
from typing import Callable, NamedTuple, Sequence, Union

import numpy as np

# ---------------------------------------------------------------- constants

MIDI_LOW = 21
MIDI_HIGH = 108
N_KEYS = 88

STEEL_DENSITY_KG_PER_M3 = 7850.0
STEEL_YOUNGS_MODULUS_PA = 2.0e11

#: Last key of each stringing section (inclusive).
SINGLE_LAST_MIDI = 30   # A0..F#1: one wound string
PAIR_LAST_MIDI = 48     # G1..C3: two wound strings; C#3 (49) up: three plain
DAMPER_LAST_MIDI = 88   # E6 has the last damper; F6..C8 undamped
CAPO_FIRST_MIDI = 73    # C#5 and up terminate on the capo d'astro bar

# Anchors of the scaling laws (see module docstring).
A7_MIDI = 105
A7_LENGTH_M = 0.061
A7_LINEAR_DENSITY = 0.0042                      # kg/m (study value)
A7_STRIKE_DISTANCE_M = 0.0026
TREBLE_OCTAVE_LENGTH_RATIO = 1.88
PLAIN_DIAMETER_LOW_M = 1.04e-3                  # at C#3 (MIDI 49)
BASS_LENGTH_A0_M = 2.00
BASS_LENGTH_TOP_M = 1.20                        # at C3 (MIDI 48)
SINGLE_TENSION_N = (1150.0, 1300.0)             # A0 .. F#1
PAIR_TENSION_N = (900.0, 820.0)                 # G1 .. C3
SINGLE_CORE_M = (1.60e-3, 1.40e-3)              # A0 .. F#1
PAIR_CORE_M = (1.27e-3, 1.05e-3)                # G1 .. C3
STRIKE_RATIO_LOW = 8.6                          # L / l below the treble ramp
STRIKE_RAMP_START_MIDI = 76.0
STRIKE_RAMP_WIDTH_ST = 2.0
#: unison spread: at most UNISON_SPREAD_CENTS, and at most UNISON_SPREAD_HZ
#: between the outer strings (a tuner tunes unisons by their beats: the same
#: cents beat faster the higher the note, so the treble is tuned closer)
UNISON_SPREAD_CENTS = 0.6
UNISON_SPREAD_HZ = 0.6
T60_ANCHORS = ((27.5, 120.0), (261.6255653005986, 50.0), (4186.009044809578, 6.0))
#: the law the prompt ratios divide (s at f0, the same log-log quadratic):
#: ``t60_prompt_s = `` this ``/ prompt_ratio``.  It is the law the strings'
#: own decay followed before that (``T60_ANCHORS``) was fitted to a recorded
#: grand's aftersound; the prompt ratios, fitted to the same recording's
#: early decay against this law, keep the prompt sound where it was
PROMPT_REFERENCE_ANCHORS = ((27.5, 40.0), (261.6255653005986, 20.0), (4186.009044809578, 6.0))
#: reference T60 (``PROMPT_REFERENCE_ANCHORS``, the strings' own T60 before
#: its fit to the recording's tails) / prompt T60 at f0 (the unison's
#: in-phase motion decays this much faster than the reference), by strings
#: per key.  The bichords' 3 is
#: the recorded grand's (``python tools/study_partials.py ratios``: 2.5-3.4
#: on keys 33-45, the running median 2.8-3.4): their prompt sound falls in
#: 7.6-13.3 s (the recording's 4-15 s), and with the strings' own decay fitted
#: to the same recording's tails every bichord still shows its knee
#: (late/early 3.7-4.6).  With the strings' own T60 at 40 s at A0 they
#: showed no knee at the recording's ratio, and a ratio of 7 made them fall
#: in 4-5 s, their aftersound 12-18 dB under the recording's
#: (docs/voicing.md, "The aftersound")
PROMPT_RATIO = {1: 4.0, 2: 3.0, 3: 4.0}
#: a trichord's ratio by key, where it departs from PROMPT_RATIO[3] (linear
#: between the anchors, MIDI key -> ratio): the middle's fundamentals fall
#: faster.  Measured on a real grand (a Yamaha C5, the samples of
#: tools/real_grand.py; `python tools/study_partials.py ratios --real DIR`):
#: the ratio of this module's reference T60 at f0 to the recording's early
#: T60 of partial 1 (0.1-1.2 s), the median of three velocity layers per key
#: (every minor third), then the running median of five keys, which the
#: anchors take at 54-84: up to 7.4 at D#4-F#4, 5.8 at C4 (a single key reads
#: 0.2 to 11, C4 11: a board's modes lie under some keys and not others);
#: 4 from 87 (the running median 3.9 there), easing to 3 over the top
#: octave (:func:`prompt_ratio`).  At 51, the first trichord, the
#: recording's own 5.2 (its running median, 2.5, mixes in the bichords 45
#: and 48; with the unison's spread of 0.6 cent key 51's late/early reads
#: 2.95 at a ratio of 4, 3.33 at 5.2).
TRICHORD_PROMPT_ANCHORS = ((51, 5.2), (54, 5.2), (57, 5.2), (60, 5.8), (63, 7.4), (66, 7.4),
                           (69, 7.3), (72, 6.9), (75, 6.9), (78, 5.2), (81, 4.9), (84, 4.9),
                           (87, 4.0))
#: relative hammer speed on each string of a unison: the hammer's crown is
#: never level, so the strings start unequally and the out-of-phase motions,
#: which make the aftersound, are excited too (Weinreich 1977, section V)
UNISON_STRIKE = {1: (1.0,), 2: (1.0, 0.93), 3: (0.97, 1.0, 0.92)}
DAMPING_B3_S = 5.0e-9
F_HIGH_MIN_HZ = 5000.0

_LN1000 = 3.0 * math.log(10.0)


# ---------------------------------------------------------------- helpers

def _range_error(name: str, value, lo, hi) -> ValueError:
    return ValueError(f"{name} = {value!r} is out of range ({lo} <= value <= {hi})")


def _check(name: str, value: float, lo: float, hi: float) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise _range_error(name, value, lo, hi) from None
    if math.isnan(v) or not (lo <= v <= hi):
        raise _range_error(name, value, lo, hi)
    return v


def _check_midi(midi) -> int:
    msg = f"midi = {midi!r} is out of range (integer, {MIDI_LOW} <= value <= {MIDI_HIGH})"
    try:
        v = float(midi)
    except (TypeError, ValueError):
        raise ValueError(msg) from None
    if not (math.isfinite(v) and v == int(v) and MIDI_LOW <= v <= MIDI_HIGH):
        raise ValueError(msg)
    return int(v)


def thesis_key(midi: int) -> int:
    """Key number n = 1..88 of the thesis (A0 = 1) for a MIDI note 21..108."""
    return _check_midi(midi) - 20


def et_f0_hz(midi: int, a4_hz: float = 440.0) -> float:
    """Equal-tempered frequency (Hz) of MIDI key ``midi`` with A4 = ``a4_hz``
    (a4_hz in 300..600 Hz)."""
    m = _check_midi(midi)
    a4 = _check("a4_hz", a4_hz, 300.0, 600.0)
    return a4 * 2.0 ** ((m - 69) / 12.0)


def _loglin(m: int, m0: int, m1: int, v0: float, v1: float) -> float:
    """Log-linear (geometric) interpolation of v0 at key m0 .. v1 at key m1."""
    return v0 * (v1 / v0) ** ((m - m0) / (m1 - m0))


def n_strings_for(midi: int) -> int:
    """Strings per note: 1 (MIDI 21..30), 2 (31..48), 3 (49..108)."""
    m = _check_midi(midi)
    return 1 if m <= SINGLE_LAST_MIDI else (2 if m <= PAIR_LAST_MIDI else 3)


# ---------------------------------------------------------------- the string

@dataclass(frozen=True)
class GrandString:
    """One key's string (each string of the unison is identical but for its
    tuning offset).

    Parameters
    ----------
    midi : int
        MIDI key, 21 (A0) .. 108 (C8).
    n_strings : int
        Strings in the unison, 1, 2 or 3.
    wound : bool
        Copper-wound (True) or plain steel wire.
    speaking_length_m : float
        Speaking length L (m), 0.02 .. 3.
    tension_n : float
        Tension per string T (N), 100 .. 5000.
    linear_density_kg_per_m : float
        Effective linear density mu (kg/m), core plus winding, 1e-3 .. 1.
    core_diameter_m : float
        Diameter of the steel (core) wire d (m), 0.3e-3 .. 3e-3.
    youngs_modulus_pa : float
        Young's modulus of the core E (Pa), 1e10 .. 5e11.
    strike_position : float
        Relative striking point l/L, 0.01 .. 0.5.
    has_damper : bool
        Whether the key has a damper.
    has_capo : bool
        Whether the string terminates on the capo d'astro bar.
    unison_detune_cents : tuple of float
        Tuning offset of each string of the unison (cents), one entry per
        string, each within +-5 cents.
    t60_low_s : float
        60 dB decay time at f0 (s), 0.01 .. 200: the string's own (the
        aftersound of a coupled unison).
    t60_prompt_s : float
        60 dB decay time at f0 of the unison's in-phase motion on its
        bridge (s), 0.01 .. t60_low_s (the prompt sound).
    t60_high_s : float
        60 dB decay time at ``f_high_hz`` (s), 0.001 .. t60_low_s.
    f_high_hz : float
        Frequency of ``t60_high_s`` (Hz), above f0, at most 30 kHz.
    """

    midi: int
    n_strings: int
    wound: bool
    speaking_length_m: float
    tension_n: float
    linear_density_kg_per_m: float
    core_diameter_m: float
    youngs_modulus_pa: float
    strike_position: float
    has_damper: bool
    has_capo: bool
    unison_detune_cents: tuple
    t60_low_s: float
    t60_high_s: float
    f_high_hz: float
    t60_prompt_s: float

    def __post_init__(self) -> None:
        _check_midi(self.midi)
        if self.n_strings not in (1, 2, 3):
            raise ValueError(f"n_strings = {self.n_strings!r} is out of range (1, 2 or 3)")
        _check("speaking_length_m", self.speaking_length_m, 0.02, 3.0)
        _check("tension_n", self.tension_n, 100.0, 5000.0)
        _check("linear_density_kg_per_m", self.linear_density_kg_per_m, 1e-3, 1.0)
        _check("core_diameter_m", self.core_diameter_m, 0.3e-3, 3e-3)
        _check("youngs_modulus_pa", self.youngs_modulus_pa, 1e10, 5e11)
        _check("strike_position", self.strike_position, 0.01, 0.5)
        det = tuple(self.unison_detune_cents)
        if len(det) != self.n_strings:
            raise ValueError(f"unison_detune_cents = {det!r} is out of range "
                             f"(one offset per string, {self.n_strings} entries)")
        for c in det:
            _check("unison_detune_cents", c, -5.0, 5.0)
        _check("t60_low_s", self.t60_low_s, 0.01, 200.0)
        _check("t60_high_s", self.t60_high_s, 0.001, self.t60_low_s)
        _check("f_high_hz", self.f_high_hz, self.f0_hz, 30000.0)
        _check("t60_prompt_s", self.t60_prompt_s, 0.01, self.t60_low_s)

    # -- derived quantities
    @property
    def thesis_key(self) -> int:
        """Thesis key number n = midi - 20 (1..88)."""
        return self.midi - 20

    @property
    def c_m_per_s(self) -> float:
        """Transverse wave speed c = sqrt(T / mu) (m/s)."""
        return math.sqrt(self.tension_n / self.linear_density_kg_per_m)

    @property
    def f0_hz(self) -> float:
        """Fundamental of the flexible string, c / (2 L) (Hz)."""
        return self.c_m_per_s / (2.0 * self.speaking_length_m)

    @property
    def inharmonicity_b(self) -> float:
        """B = pi^3 E d^4 / (64 T L^2) (dimensionless), core diameter d."""
        return (math.pi ** 3 * self.youngs_modulus_pa * self.core_diameter_m ** 4
                / (64.0 * self.tension_n * self.speaking_length_m ** 2))

    @property
    def strike_distance_m(self) -> float:
        """Distance l of the striking point from the near end (m)."""
        return self.strike_position * self.speaking_length_m

    @property
    def impedance_ns_per_m(self) -> float:
        """Wave impedance Z = T / c = sqrt(T mu) (N s/m)."""
        return math.sqrt(self.tension_n * self.linear_density_kg_per_m)

    @property
    def mass_kg(self) -> float:
        """Mass of one string's speaking length, mu L (kg)."""
        return self.linear_density_kg_per_m * self.speaking_length_m

    def partial_hz(self, k: int) -> float:
        """Frequency of partial k >= 1: k f0 sqrt(1 + B k^2) (Hz)."""
        k = int(_check("k", k, 1, 10000))
        return k * self.f0_hz * math.sqrt(1.0 + self.inharmonicity_b * k * k)

    def t60_s(self, f_hz: float) -> float:
        """60 dB decay time (s) at ``f_hz`` (0 < f_hz <= 100 kHz) from the law
        sigma(f) = b1 + b3 (2 pi f)^2, b1 fixed by ``t60_low_s`` at f0.
        Returns t60_low_s at f0 and t60_high_s at f_high_hz."""
        f = _check("f_hz", f_hz, 1e-3, 1e5)
        sigma0 = _LN1000 / self.t60_low_s
        sigma = sigma0 + DAMPING_B3_S * (2.0 * math.pi) ** 2 * (f * f - self.f0_hz ** 2)
        sigma = max(sigma, 1e-9)
        return _LN1000 / sigma


def _plain_diameter_m(m: int) -> float:
    return _loglin(m, A7_MIDI, PAIR_LAST_MIDI + 1, _A7_DIAMETER_M, PLAIN_DIAMETER_LOW_M)


_A7_DIAMETER_M = math.sqrt(4.0 * A7_LINEAR_DENSITY / (math.pi * STEEL_DENSITY_KG_PER_M3))


def _strike_ramp(m: float) -> float:
    """Softplus ramp (semitones) starting near STRIKE_RAMP_START_MIDI."""
    w = STRIKE_RAMP_WIDTH_ST
    return w * math.log1p(math.exp((m - STRIKE_RAMP_START_MIDI) / w))


# semitones per doubling of L/l in the treble, fixed by the A7 study point
_STRIKE_K = _strike_ramp(A7_MIDI) / (math.log2(A7_LENGTH_M / A7_STRIKE_DISTANCE_M)
                                     - math.log2(STRIKE_RATIO_LOW))


def strike_position_for(midi: int) -> float:
    """Relative striking point l/L of the key (see module docstring)."""
    m = _check_midi(midi)
    return 1.0 / (STRIKE_RATIO_LOW * 2.0 ** (_strike_ramp(m) / _STRIKE_K))


def _t60_coeffs(anchors):
    # log2 T60 = c0 + c1 x + c2 x^2, x = log2(f / C4): exact through the anchors
    xs = [math.log2(f / anchors[1][0]) for f, _ in anchors]
    ys = [math.log2(t) for _, t in anchors]
    A = np.array([[1.0, x, x * x] for x in xs])
    return np.linalg.solve(A, np.array(ys))


_T60_C = _t60_coeffs(T60_ANCHORS)
_PROMPT_REF_C = _t60_coeffs(PROMPT_REFERENCE_ANCHORS)


def _t60_law(f0_hz: float, anchors, c) -> float:
    f = _check("f0_hz", f0_hz, 20.0, 5000.0)
    x = math.log2(f / anchors[1][0])
    return 2.0 ** (c[0] + c[1] * x + c[2] * x * x)


def t60_fundamental_s(f0_hz: float) -> float:
    """Aftersound decay time (s) of a grand-piano fundamental at ``f0_hz``
    (20..5000 Hz), a string's own: the log-log quadratic through
    ``T60_ANCHORS`` (A0 = 120 s, C4 = 50 s, C8 = 6 s)."""
    return _t60_law(f0_hz, T60_ANCHORS, _T60_C)


def t60_prompt_reference_s(f0_hz: float) -> float:
    """The law the prompt ratios divide (s, 20..5000 Hz): the log-log
    quadratic through ``PROMPT_REFERENCE_ANCHORS`` (A0 = 40 s, C4 = 20 s,
    C8 = 6 s); a key's prompt sound decays with this over
    :func:`prompt_ratio`."""
    return _t60_law(f0_hz, PROMPT_REFERENCE_ANCHORS, _PROMPT_REF_C)


def prompt_ratio(midi: int) -> float:
    """Reference T60 (:func:`t60_prompt_reference_s`) / prompt T60 of the
    key's unison (not the aftersound over the prompt: the strings' own T60
    is fitted to a recorded grand's tails, and the prompt kept where this
    puts it): ``PROMPT_RATIO`` by
    its strings; a trichord's along ``TRICHORD_PROMPT_ANCHORS`` (D#3 to D#6;
    up to 7.4 in the middle, as a real grand's), easing from 4 to 3 over
    the top octave (C7 to C8), whose prompt sound is most of what is heard
    of them."""
    m = _check_midi(midi)
    r = PROMPT_RATIO[n_strings_for(m)]
    if n_strings_for(m) == 3:
        ks, rs = zip(*TRICHORD_PROMPT_ANCHORS)
        if ks[0] <= m <= ks[-1]:
            r = float(np.interp(m, ks, rs))
        if m > 96:
            r -= (r - 3.0) * (m - 96) / (MIDI_HIGH - 96)
    return r


def unison_spread_cents(m: int, spread_hz: float = UNISON_SPREAD_HZ) -> float:
    """The detuning between key ``m``'s outer unison strings, cents: at most
    :data:`UNISON_SPREAD_CENTS`, and at most ``spread_hz`` (Hz) at its f0."""
    return min(UNISON_SPREAD_CENTS, 1200.0 / math.log(2.0) * spread_hz / et_f0_hz(m))


def unison_detune_cents(m: int, n: int, spread_hz: float = UNISON_SPREAD_HZ) -> tuple:
    """Tuning offset (cents) of each of the ``n`` strings of key ``m``'s
    unison: spread s = :func:`unison_spread_cents` (``spread_hz``: the
    tuner's limit in beats a second, Hz) between the outer strings; one
    string (0,), two (-s/2, +s/2), three (-0.55 s, 0, +0.45 s)."""
    s = unison_spread_cents(m, spread_hz)
    if n == 1:
        return (0.0,)
    if n == 2:
        return (-0.5 * s, 0.5 * s)
    return (-0.55 * s, 0.0, 0.45 * s)


def _build_string(m: int) -> GrandString:
    f0 = et_f0_hz(m)
    n = n_strings_for(m)
    if m > PAIR_LAST_MIDI:  # plain steel: L and d from the laws, T follows
        wound = False
        L = A7_LENGTH_M * TREBLE_OCTAVE_LENGTH_RATIO ** ((A7_MIDI - m) / 12.0)
        d = _plain_diameter_m(m)
        mu = STEEL_DENSITY_KG_PER_M3 * math.pi * d * d / 4.0
        T = mu * (2.0 * L * f0) ** 2
    else:  # wound: L, T and core from the laws, mu (winding) follows
        wound = True
        f_a0, f_top = et_f0_hz(MIDI_LOW), et_f0_hz(PAIR_LAST_MIDI)
        s = math.log(BASS_LENGTH_A0_M / BASS_LENGTH_TOP_M) / math.log(f_top / f_a0)
        L = BASS_LENGTH_A0_M * (f0 / f_a0) ** (-s)
        if n == 1:
            T = _loglin(m, MIDI_LOW, SINGLE_LAST_MIDI, *SINGLE_TENSION_N)
            d = _loglin(m, MIDI_LOW, SINGLE_LAST_MIDI, *SINGLE_CORE_M)
        else:
            T = _loglin(m, SINGLE_LAST_MIDI + 1, PAIR_LAST_MIDI, *PAIR_TENSION_N)
            d = _loglin(m, SINGLE_LAST_MIDI + 1, PAIR_LAST_MIDI, *PAIR_CORE_M)
        mu = T / (2.0 * L * f0) ** 2
    t60_low = t60_fundamental_s(f0)
    f_high = max(F_HIGH_MIN_HZ, 2.0 * f0)
    proto = GrandString(
        midi=m, n_strings=n, wound=wound, speaking_length_m=L, tension_n=T,
        linear_density_kg_per_m=mu, core_diameter_m=d,
        youngs_modulus_pa=STEEL_YOUNGS_MODULUS_PA, strike_position=strike_position_for(m),
        has_damper=m <= DAMPER_LAST_MIDI, has_capo=m >= CAPO_FIRST_MIDI,
        unison_detune_cents=unison_detune_cents(m, n), t60_low_s=t60_low, t60_high_s=t60_low,
        f_high_hz=f_high, t60_prompt_s=t60_prompt_reference_s(f0) / prompt_ratio(m))
    return replace(proto, t60_high_s=proto.t60_s(f_high))


@lru_cache(maxsize=1)
def grand_piano_strings() -> tuple:
    """The 88 strings of the concert grand, MIDI 21..108 in order (cached)."""
    return tuple(_build_string(m) for m in range(MIDI_LOW, MIDI_HIGH + 1))


def grand_string(midi: int) -> GrandString:
    """The ``GrandString`` of one MIDI key (21..108)."""
    return grand_piano_strings()[_check_midi(midi) - MIDI_LOW]


def bridge_resistance_ns_per_m(midi: int, mass_hz: float = 0.0) -> float:
    """Resistance R_b (N s/m) of the bridge a key's unison hangs on, such
    that the unison's in-phase motion decays with ``t60_prompt_s`` at f0
    while each string alone keeps ``t60_low_s`` (see the module docstring):
    R_b = 2 f0 Z n / (sigma_p - sigma_a), n = the key's strings (2 for a
    single string).  With a mass above ``mass_hz`` (Hz, > 0; the bridge's
    admittance 1 / (R + j w M), M = R / (2 pi mass_hz), whose real part is
    1 / (R (1 + (f / mass_hz)^2))), R is that over 1 + (f0 / mass_hz)^2, so
    that the real part at f0, and the prompt T60 there, stay."""
    g = grand_string(midi)
    n = max(g.n_strings, 2)
    sig = _LN1000 * (1.0 / g.t60_prompt_s - 1.0 / g.t60_low_s)
    R = 2.0 * g.f0_hz * g.impedance_ns_per_m * n / sig
    if mass_hz > 0.0:
        R /= 1.0 + (g.f0_hz / mass_hz) ** 2
    return R


#: the bridge's mass corner (``bridge_mass_hz``) moves away from f0 above
#: this key, doubling every BRIDGE_MASS_FADE_ST semitones: a real grand's
#: treble partials 1-3 fall alike in their first second (tools/
#: study_partials.py decay: keys 75-105 of the recorded C5), as a dashpot
#: makes them, where its middle and bass fundamentals fall faster than
#: their upper partials
BRIDGE_MASS_FADE_FROM_MIDI = 72
BRIDGE_MASS_FADE_ST = 6.0
#: a corner at or above this (Hz) is no mass at all: it would change nothing
#: heard (from D#6 up at a ratio of 3), and the dashpot's step is cheaper
BRIDGE_MASS_MAX_HZ = 20000.0


def bridge_mass_hz(midi: int, ratio: float) -> float:
    """Frequency (Hz) above which the key's bridge moves as a mass:
    ``ratio`` (> 0; 0: no mass, returns 0) times the key's f0, up to
    ``BRIDGE_MASS_FADE_FROM_MIDI``, then twice as far every
    ``BRIDGE_MASS_FADE_ST`` semitones (at C7 16 times as far: the mass is
    gone from the treble), and 0 where that reaches
    ``BRIDGE_MASS_MAX_HZ``.  Trichords only (0 for the bass's one- and
    two-string keys): the recorded grand's bass fundamentals show no prompt
    sound at all (early T60 of partial 1 8-125 s on keys 33-45), so the
    model's bass bridge is voiced for the two-stage decay the voicing asks
    for, which a mass there weakens (bichords' late/early 2.7-2.9 with it,
    docs/voicing.md, "The bridge's mass"), not after this recording."""
    m = _check_midi(midi)
    r = _check("ratio", ratio, 0.0, 100.0)
    if r == 0.0 or n_strings_for(m) < 3:
        return 0.0
    up = max(0, m - BRIDGE_MASS_FADE_FROM_MIDI) / BRIDGE_MASS_FADE_ST
    f = r * grand_string(m).f0_hz * 2.0 ** up
    return f if f < BRIDGE_MASS_MAX_HZ else 0.0


def single_string_t60_s(midi: int, t60_own_s: float | None = None) -> float:
    """T60 (s) at f0 of one of the key's strings alone on its bridge (no
    unison partner): its own loss and the bridge's share of one string,
    ln(1000) / T60 = sigma_a + (sigma_p - sigma_a) / n (n as in
    :func:`bridge_resistance_ns_per_m`): a voice with a single string per
    key and no coupled unison.  ``t60_own_s``: the string's own T60 at f0
    (s; None: the key's ``t60_low_s``), at least its prompt T60."""
    g = grand_string(midi)
    n = max(g.n_strings, 2)
    t_own = g.t60_low_s if t60_own_s is None else _check("t60_own_s", t60_own_s, g.t60_prompt_s, 200.0)
    sa = 1.0 / t_own
    return 1.0 / (sa + (1.0 / g.t60_prompt_s - sa) / n)


def grand_piano_inharmonicity() -> np.ndarray:
    """B of the 88 keys (MIDI 21..108) as a float64 array (a fresh copy)."""
    return np.array([s.inharmonicity_b for s in grand_piano_strings()])


# ---------------------------------------------------------------- hammers

class ThreeParamHammer(NamedTuple):
    q0_n_per_mm_p: float   #: static stiffness Q0 (N/mm^p)
    p: float               #: nonlinearity exponent
    alpha_s: float         #: hereditary (retarded time) parameter (s)


class FourParamHammer(NamedTuple):
    f0_n_per_mm_p: float   #: instantaneous stiffness F0 (N/mm^p)
    p: float               #: nonlinearity exponent
    gamma: float           #: hereditary amplitude (dimensionless)
    tau0_s: float          #: relaxation time (s)


class HammerVoicing(NamedTuple):
    """Constants of the three-parameter felt laws (the thesis's forms,
    eqs. 1.6-1.8): Q0 = q_a exp(q_b n) N/mm^p, p = p_c + p_d n, alpha =
    alpha_scale exp(alpha_tilt (n - 44)) (259.5 + 0.58 n + 6.6e-2 n^2 -
    1.25e-3 n^3 + 1.172e-5 n^4) microseconds, n = midi - 20; then, for the
    treble, Q0 times treble_q ** w and alpha times treble_alpha ** w with
    w = (n - treble_from) / treble_span clipped to 0 .. 1 (the defaults
    change nothing)."""

    q_a: float
    q_b: float
    p_c: float
    p_d: float
    alpha_scale: float
    alpha_tilt: float
    treble_from: float = 88.0
    treble_span: float = 1.0
    treble_q: float = 1.0
    treble_alpha: float = 1.0


#: the felt laws as the thesis prints them (its Abel hammer set, unvoiced)
THESIS_VOICING = HammerVoicing(183.0, 0.045, 3.7, 0.015, 1.0, 0.0)

#: the same laws voiced for a concert grand (the grand preset's default,
#: ``action.voicing = "concert"``): a technician voices a set softer in the
#: bass and harder in the treble than it leaves the factory.  The static
#: force at 0.3 mm of compression is x0.05 the thesis's at A0, x0.24 at C4
#: (1.47 N, a fifth of Chaigne & Askenfelt 1994's C4 felt, K = 4.5e9
#: N/m^2.5: 7.0 N), rising over F#5-C7 to 24.4 N at C7 (x1.5 the thesis's;
#: Chaigne & Askenfelt's C7 felt, K = 1.0e12 N/m^3, gives 27 N) and x2.4
#: at C8; the exponent rises from 3.7 to 4.3 (thesis 3.7 to
#: 5.0; Chaigne & Askenfelt's 2.3, 2.5, 3.0 at C2, C4, C7 and Hall &
#: Askenfelt 1988's 2.2-3.5 rise the same way, less steeply); the
#: hereditary time is x0.3 at A0, x0.85 at C4, x1.4 at C#5 (its largest),
#: x0.7 at C7 and x0.9 at C8.  From F#5 (thesis key 58) to C7 (76) the
#: treble stiffens by ``treble_q`` = 1.5 and its hereditary time eases by
#: ``treble_alpha`` = 0.3 (the concert tilts gave x8 stiffness and x3
#: hereditary time at C8): with the harder, more hereditary felt the una
#: corda's softer felt could not darken keys 90-98 (docs/voicing.md "The
#: treble's felt"), while the top keys keep their pp and loudness.
#: Q0's scale was fitted to a recorded grand (issue 41: the Salamander's
#: Yamaha C5, its layer v10 played at velocity 78, the loudness step
#: tools/real_grand.py --layer-velocities matches): at 5x Chaigne &
#: Askenfelt's force below F#5 (q_a 44, treble_q 0.3, issue 11's fit to a
#: guessed C4 partials 2-8 within 25 dB, which the recording contradicts)
#: the first 50 ms were 1.6-1.8x the recording's centroid from C2 to B5,
#: and the felt rose to 13.7 N within 50 us of touching C4 at 5.6 m/s;
#: softer, 1.1-1.4x on every octave and held-out layer.  The exponent and hereditary time
#: were fitted on the rendered grand (the hammer study of issue 11: C4's
#: 35 dB from velocity 1 to 127, the top octave alive at pp), within those
#: measured orders;
#: with the preset's hammer speeds 0.2-7.5 m/s (Askenfelt & Jansson 1991: ~1
#: (p) to 5-7 m/s (ff); 0.2 m/s about the slowest hammer that reaches the
#: string after let-off).  The masses stay the thesis's (eq. 1.9): their
#: share per string, 4.96 / 2.76 / 2.01 g at C2 / C4 / C7, is Chaigne &
#: Askenfelt's 4.9 / 2.97 / 2.2 g.
CONCERT_VOICING = HammerVoicing(8.8, 0.0750, 3.7, 0.0069, 0.95, 0.0265,
                               treble_from=58.0, treble_span=18.0, treble_q=1.5, treble_alpha=0.3)

#: the voicings a preset may name (``action.voicing``)
VOICINGS = {"thesis": THESIS_VOICING, "concert": CONCERT_VOICING}


def hammer_three_param(midi: int, voicing: HammerVoicing = THESIS_VOICING) -> ThreeParamHammer:
    """Three-parameter hereditary hammer of the key (thesis eqs. 1.6-1.8).

    Q0 = 183 exp(0.045 n) N/mm^p, p = 3.7 + 0.015 n, alpha = 259.5 + 0.58 n
    + 6.6e-2 n^2 - 1.25e-3 n^3 + 1.172e-5 n^4 microseconds (the thesis prints
    "ms"; n = 85 gives 0.630 ms while its A7 study uses 0.5312 ms), with the
    thesis key n = midi - 20; another ``voicing`` (:class:`HammerVoicing`,
    e.g. :data:`CONCERT_VOICING`) changes the constants of the same laws.
    Returns (Q0 in N/mm^p, p, alpha in s).
    """
    n = thesis_key(midi)
    v = voicing
    q0 = v.q_a * math.exp(v.q_b * n)
    p = v.p_c + v.p_d * n
    alpha_us = 259.5 + 0.58 * n + 6.6e-2 * n ** 2 - 1.25e-3 * n ** 3 + 1.172e-5 * n ** 4
    alpha_us *= v.alpha_scale * math.exp(v.alpha_tilt * (n - 44))
    w = min(max((n - v.treble_from) / v.treble_span, 0.0), 1.0)
    q0 *= v.treble_q ** w
    alpha_us *= v.treble_alpha ** w
    return ThreeParamHammer(q0, p, alpha_us * 1e-6)


def hammer_four_param(midi: int) -> FourParamHammer:
    """Four-parameter hysteretic hammer of the key (Publication III eqs. 4-7).

    p = 3.7 + 0.015 n, gamma = 0.9894 + 0.000088 n, tau0 = 2.72 - 0.02 n +
    0.00009 n^2 microseconds, F0 = 15500 exp(0.059 n) N/mm^p, n = midi - 20.
    Returns (F0 in N/mm^p, p, gamma, tau0 in s).  (The paper's printed range
    p <= 4.98 is p at n = 85; the law gives 5.02 at n = 88.)
    """
    n = thesis_key(midi)
    return FourParamHammer(15500.0 * math.exp(0.059 * n), 3.7 + 0.015 * n,
                           0.9894 + 0.000088 * n, (2.72 - 0.02 * n + 0.00009 * n * n) * 1e-6)


def hammer_mass_kg(midi: int, n_strings: int | None = None) -> float:
    """Hammer mass acting on one string (kg): (11.074 - 0.074 n + 1e-4 n^2) g
    (thesis eq. 1.9; 11.0 g at A0, 5.3 g at C8) divided by ``n_strings``
    (1..3; default: the grand's strings for that key, as the thesis's A7
    study, 5.51 g / 3 = 1.84 g, "1.8 g")."""
    n = thesis_key(midi)
    ns = n_strings_for(midi) if n_strings is None else int(_check("n_strings", n_strings, 1, 3))
    return (11.074 - 0.074 * n + 1e-4 * n * n) * 1e-3 / ns


def stiffness_per_m_p(k_n_per_mm_p: float, p: float) -> float:
    """Convert a stiffness in N/mm^p to SI N/m^p (multiply by 1000^p)."""
    return float(k_n_per_mm_p) * 1000.0 ** float(p)


# ---------------------------------------------------------------- stretch tuning

BOfKey = Union[None, Callable[[int], float], Sequence[float], np.ndarray]


def string_f0_for_partial1(f1_hz: float, b: float) -> float:
    """Flexible-string fundamental c/2L (Hz) whose first partial
    f1 = f0 sqrt(1 + B) is ``f1_hz`` (0 < f1_hz <= 1e5; 0 <= b <= 0.5)."""
    f1 = _check("f1_hz", f1_hz, 1e-6, 1e5)
    bb = _check("b", b, 0.0, 0.5)
    return f1 / math.sqrt(1.0 + bb)


def _b_array(b_of_key: BOfKey) -> np.ndarray:
    if b_of_key is None:
        return grand_piano_inharmonicity()
    if callable(b_of_key):
        b = np.array([float(b_of_key(m)) for m in range(MIDI_LOW, MIDI_HIGH + 1)])
    else:
        b = np.asarray(b_of_key, dtype=float).ravel()
        if b.shape != (N_KEYS,):
            raise ValueError(f"B_of_key has {b.size} values, out of range "
                             f"(88 values, MIDI 21..108, or a callable)")
    bad = ~np.isfinite(b) | (b < 0.0) | (b > 0.5)
    if bad.any():
        i = int(np.argmax(bad))
        raise _range_error(f"B_of_key({MIDI_LOW + i})", float(b[i]), 0.0, 0.5)
    return b


def octave_stretch_cents(b_low: float, b_up: float, octave_k: int = 1) -> float:
    """Excess (cents over 1200) of the first-partial octave f1_up / f1_low that
    makes partial 2k of the lower key beatless with partial k of the upper key.

    With f_j = j f0 sqrt(1 + B j^2) and f1 = f0 sqrt(1 + B):
    f1_up / f1_low = 2 sqrt((1 + 4 k^2 B_low)(1 + B_up) / ((1 + k^2 B_up)(1 + B_low))).
    """
    k = int(_check("octave_k", octave_k, 1, 8))
    r2 = ((1.0 + 4.0 * k * k * b_low) * (1.0 + b_up)) / ((1.0 + k * k * b_up) * (1.0 + b_low))
    return 600.0 * math.log2(r2)


def _pchip(x: np.ndarray, y: np.ndarray, xe: np.ndarray) -> np.ndarray:
    """Monotone piecewise-cubic Hermite interpolation (Fritsch-Carlson, with
    the same end slopes as scipy's PchipInterpolator)."""
    h = np.diff(x)
    d = np.diff(y) / h
    m = np.zeros_like(y)
    for k in range(1, len(x) - 1):
        if d[k - 1] * d[k] > 0:
            w1, w2 = 2 * h[k] + h[k - 1], h[k] + 2 * h[k - 1]
            m[k] = (w1 + w2) / (w1 / d[k - 1] + w2 / d[k])

    def end(h0, h1, d0, d1):
        s = ((2 * h0 + h1) * d0 - h0 * d1) / (h0 + h1)
        if np.sign(s) != np.sign(d0):
            return 0.0
        if np.sign(d0) != np.sign(d1) and abs(s) > abs(3 * d0):
            return 3 * d0
        return s

    m[0] = end(h[0], h[1], d[0], d[1])
    m[-1] = end(h[-1], h[-2], d[-1], d[-2])
    idx = np.clip(np.searchsorted(x, xe, side="right") - 1, 0, len(x) - 2)
    t = (xe - x[idx]) / h[idx]
    h00 = (1 + 2 * t) * (1 - t) ** 2
    h10 = t * (1 - t) ** 2
    h01 = t * t * (3 - 2 * t)
    h11 = t * t * (t - 1)
    return h00 * y[idx] + h10 * h[idx] * m[idx] + h01 * y[idx + 1] + h11 * h[idx] * m[idx + 1]


def _stretch_curve(b: np.ndarray, octave_k: int, octave_k_bass: int) -> np.ndarray:
    a_idx = np.arange(0, 85, 12)               # A0, A1, ..., A7 (MIDI 21..105)
    d = np.zeros(len(a_idx))
    i4 = 4                                     # A4 = a_idx[4] = index 48
    for j in range(i4, len(a_idx) - 1):        # upwards
        lo, up = a_idx[j], a_idx[j + 1]
        d[j + 1] = d[j] + octave_stretch_cents(b[lo], b[up], octave_k)
    for j in range(i4 - 1, -1, -1):            # downwards
        lo, up = a_idx[j], a_idx[j + 1]
        d[j] = d[j + 1] - octave_stretch_cents(b[lo], b[up], octave_k_bass)
    curve = np.empty(N_KEYS)
    curve[:85] = _pchip(a_idx.astype(float), d, np.arange(85, dtype=float))
    for i in range(85, N_KEYS):                # A#7..C8 by octaves from A#6..C7
        curve[i] = curve[i - 12] + octave_stretch_cents(b[i - 12], b[i], octave_k)
    return curve


@lru_cache(maxsize=16)
def _default_curve(octave_k: int, octave_k_bass: int) -> np.ndarray:
    c = _stretch_curve(grand_piano_inharmonicity(), octave_k, octave_k_bass)
    c.setflags(write=False)
    return c


def stretch_curve_cents(B_of_key: BOfKey = None, octave_k: int = 1,
                        octave_k_bass: int | None = None) -> np.ndarray:
    """Full-stretch tuning curve: cents of each key's first partial relative to
    equal temperament, MIDI 21..108 (88 values, A4 = 0).

    Parameters
    ----------
    B_of_key : callable, sequence of 88 floats, or None
        Inharmonicity per key: ``B_of_key(midi)`` or ``B_of_key[midi - 21]``
        (each 0..0.5); None uses the concert grand of this module.
    octave_k : int
        Octave type 1..8 of the octaves tuned upward from A4: partial 2k of
        the lower key beatless with partial k of the upper key (1: the 2:1
        octave; 2: 4:2; 3: 6:3, wider).
    octave_k_bass : int or None
        Octave type 1..8 of the octaves tuned downward from A4 (None: same
        as ``octave_k``).  Tuners often widen the bass octaves (6:3); with
        this grand's low bass B the 2:1 rule alone leaves A0 only about
        1.5 cents flat, (1, 3) gives about -10 cents, Railsback-like.
    """
    k = int(_check("octave_k", octave_k, 1, 8))
    kb = k if octave_k_bass is None else int(_check("octave_k_bass", octave_k_bass, 1, 8))
    if B_of_key is None:
        return np.array(_default_curve(k, kb))
    return _stretch_curve(_b_array(B_of_key), k, kb)


def stretched_f0_hz(midi: int, B_of_key: BOfKey = None, a4_hz: float = 440.0,
                    stretch: float = 1.0, octave_k: int = 1,
                    octave_k_bass: int | None = None) -> float:
    """Target frequency (Hz) of the FIRST PARTIAL f1 = f0 sqrt(1 + B) of a key.

    Parameters
    ----------
    midi : int
        MIDI key 21..108.
    B_of_key : callable, sequence of 88 floats, or None
        Inharmonicity per key (see ``stretch_curve_cents``); None: this
        module's concert grand.
    a4_hz : float
        Pitch of A4 (Hz), 300..600; A4's first partial is exactly this.
    stretch : float
        0 = exact equal temperament, 1 = the octave stretch of
        ``stretch_curve_cents`` (tuned outward from A4 by beatless octaves),
        linear in cents in between; 0..2.
    octave_k, octave_k_bass : int
        Octave types, 1..8, upward and downward from A4 (see
        ``stretch_curve_cents``).

    Use ``string_f0_for_partial1(f1, B)`` for the string's own c/2L.
    """
    m = _check_midi(midi)
    s = _check("stretch", stretch, 0.0, 2.0)
    f_et = et_f0_hz(m, a4_hz)
    if s == 0.0:
        return f_et
    cents = s * float(stretch_curve_cents(B_of_key, octave_k, octave_k_bass)[m - MIDI_LOW])
    return f_et * 2.0 ** (cents / 1200.0)
