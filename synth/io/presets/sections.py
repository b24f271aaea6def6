"""The schema rows (data only): edit this file to add a voice, a profile or a key.

:data:`SCHEMA_FIELDS` are the top-level keys, validated first;
:data:`SECTIONS` are the TOML tables, validated in this order. A row is a
:class:`~.schema.Field`: key name, type, doc with its unit, range
(``lo``/``hi``, ``lo_open``/``hi_open`` for exclusive bounds) or
``choices``, and an optional presence condition ``when``. A
:class:`~.schema.When` names an *earlier* key (dotted, e.g.
``"termination.profile"``) and the values for which the row applies: the key
is then required, and forbidden otherwise; no condition means always
required. One key may have several rows with disjoint conditions on the same
key (``termination.radius_m``). ``When(..., also=When(...))`` requires both.
A :class:`~.schema.Section` takes a ``when`` the same way for its whole table.

To add a voice, add its name to :data:`VOICES` and list it in the ``when``
of the sections it uses; to add a termination profile, add it to
:data:`PROFILES` and give its keys rows conditioned with ``_prof(...)``. A
new section also needs a frozen dataclass in :mod:`.model` and a field of
:class:`~.model.Preset`; :mod:`.validate` checks all this at import time.
"""

from __future__ import annotations

from .model import (
    ActionSpec,
    BodySpec,
    BridgeSpec,
    ChikariSpec,
    DampersSpec,
    DroneSpec,
    GridSpec,
    HammerSpec,
    ListenerSpec,
    LossSpec,
    OutputSpec,
    PlaySpec,
    PluckSpec,
    QualityErrorSpec,
    StringSpec,
    StringsSpec,
    TarafSpec,
    TerminationSpec,
    TuningSpec,
)
from synth.physics.listener import (
    DIRECTIVITY_RANGE_DB, DISTANCE_RANGE_M, HUMIDITY_RANGE_PERCENT, LEVELS, POSITIONS, ROOM_NAMES,
    TEMPERATURE_RANGE_C)
from synth.physics.soundboard import MASS_RANGE_HZ, PEAK_HZ_RANGE, SPREAD_RANGE_MS

#: the drone player's cycle length range (s); synth.engine.drone.CYCLE_RANGE_S
#: (the range its tempo controller sweeps) is the same, checked by
#: tests/test_drone.py (io may not be imported by the engine, nor the engine here)
DRONE_CYCLE_RANGE_S = (1.0, 16.0)
#: a drone pattern: four tokens in pluck order, the first string's note then Sa Sa Sa
DRONE_PATTERN = (r"(?i)\s*(pa|ma|ni|sa)\s+sa\s+sa\s+sa\s*",
                 "four tokens in pluck order: Pa, Ma, Ni or Sa, then Sa Sa Sa")

from .schema import Field, OrderCheck, Section, When, _when_not

__all__ = [
    "SCHEMA_VERSION",
    "KINDS",
    "VOICES",
    "HAMMER_LAWS",
    "HAMMER_MODELS",
    "CAPO_COUPLINGS",
    "PLUCK_MODELS",
    "PROFILES",
    "SIGNALS",
    "QUALITIES",
    "SCHEMA_FIELDS",
    "SECTIONS",
]

SCHEMA_VERSION = 1

KINDS = ("study", "musical")
VOICES = ("plucked", "piano", "grand", "harpsichord")
_KEYBOARD = When("voice", ("grand", "harpsichord"))     # per-key piano strings
_ONE_STRING = When("voice", ("plucked", "piano"))
_PLUCKED_MUSICAL = When("kind", ("musical",), also=When("voice", ("plucked",)))
HAMMER_LAWS = ("three-parameter", "four-parameter")
#: the study hammer's models: the felt law as a massless spring (the voices'
#: hammer) or the felt solved as a medium on the moving string (docs/felt.md)
HAMMER_MODELS = ("lumped", "felt-layer")
CAPO_COUPLINGS = ("direct", "injected")
#: termination.contact of the jawari (synth.physics.profiles.Termination.subcell)
JAWARI_CONTACTS = ("subcell", "grid")
PLUCK_MODELS = ("sitar", "biwa")
PROFILES = (
    "none",
    "capo",
    "sawari",
    "jawari-case1",
    "jawari-case2",
    "jawari-case3",
    "jawari",
    "table",
)
SIGNALS = ("displacement", "bridge_force")
#: quality levels, cheapest first (synth.voices.quality: each one's rate,
#: filters and measured error)
QUALITIES = ("draft", "standard", "reference")

_PROFILE = "termination.profile"


def _prof(*names: str) -> When:
    return When(_PROFILE, tuple(names))


#: Top-level scalar keys, validated first (other rows' conditions refer to them).
SCHEMA_FIELDS: tuple[Field, ...] = (
    Field("schema", "int", "schema version of the file", choices=(SCHEMA_VERSION,)),
    Field("description", "line", "one-line description shown by `synth presets`"),
    Field("kind", "str", "study: exact paper set-up on a fixed grid; musical: playable instrument",
          choices=KINDS),
    Field("voice", "str", "voice model that renders the preset", choices=VOICES),
)

#: Sections (TOML tables) in validation order.
SECTIONS: tuple[Section, ...] = (
    Section("string", "the physical string", StringSpec, (
        Field("length_m", "float", "speaking length L (musical: of the open string), m", 0.01, 3.0),
        Field("tension_n", "float", "tension T, N", 1.0, 5000.0),
        Field("linear_density_kg_per_m", "float", "linear mass density mu, kg/m", 1e-5, 0.1),
        Field("inharmonicity", "float", "the open string's stiffness B = pi^3 E d^4 / (64 T L^2) "
              "(partials n f0 sqrt(1 + B n^2); fretted and retuned strings scale it); 0: an "
              "ideal string", 0.0, 0.01, when=When("kind", ("musical",)), default=0.0),
        Field("tension_modulation", "float", "the tension follows the string's stretch as it "
              "swings (Kirchhoff-Carrier: a hard pluck starts sharp and settles): a scale on the "
              "effect, 0 (off: a constant tension) to 1 (the full effect of the string's E and d; "
              "needs youngs_modulus_pa and diameter_m)", 0.0, 1.0,
              when=When("kind", ("musical",)), default=0.0),
        Field("youngs_modulus_pa", "float", "Young's modulus E of the string's material, Pa "
              "(steel 2.0e11; for tension_modulation)", 1e8, 1e12,
              when=When("kind", ("musical",)), optional=True),
        Field("diameter_m", "float", "the string's diameter d, m (its cross-section pi d^2 / 4; "
              "for tension_modulation)", 1e-5, 0.01,
              when=When("kind", ("musical",)), optional=True),
    ), when=_ONE_STRING),
    Section("grid", "study grid (c*dt = dx exactly)", GridSpec, (
        Field("cells", "int", "number of cells N; internal rate = N*c/L", 20, 100000),
    ), when=When("kind", ("study",))),
    Section("pluck", "excitation", PluckSpec, (
        Field("model", "str", "sitar: kinematic g(t) (eq. 1.13); biwa: force pluck (eqs. 1.10-1.11)",
              choices=PLUCK_MODELS),
        Field("position", "float", "pluck point l as a fraction of L from x=0", 0.0, 1.0,
              lo_open=True, hi_open=True),
        Field("amplitude_m", "float", "pluck amplitude A (musical: at velocity 127), m", 1e-6, 0.05),
        Field("duration_s", "float", "pluck duration t0, s", 1e-4, 0.05),
        Field("alpha_per_s", "float", "biwa force-pluck rate alpha, 1/s", 1.0, 1e6,
              when=When("pluck.model", ("biwa",))),
        Field("bachi_impulse_ns", "float", "the plectrum's stroke on the body (the biwa's bachi) "
              "at velocity 127: impulse of its force pulse into [body], N s (0: none; scales "
              "as the amplitude with velocity; at most 0.01 N s, 67 times the biwa's: a 50 g bachi "
              "stopped from 0.2 m/s)", 0.0, 0.01, when=_PLUCKED_MUSICAL, default=0.0),
        Field("bachi_duration_s", "float", "duration of the stroke's force pulse, s", 2e-4, 0.02,
              when=_PLUCKED_MUSICAL, default=0.001),
    ), when=When("voice", ("plucked", "harpsichord"))),
    Section("hammer", "felt hammer striking the string (voice piano)", HammerSpec, (
        Field("law", "str", "felt law: three-parameter (eq. 1.5) or four-parameter (Pub. III eq. 3)",
              choices=HAMMER_LAWS),
        Field("position", "float", "striking point l as a fraction of L from x=0", 0.0, 1.0,
              lo_open=True, hi_open=True),
        Field("mass_kg", "float", "hammer mass acting on this string, kg", 1e-4, 0.05),
        Field("speed_m_per_s", "float", "hammer speed V at first contact (musical: at velocity 127), m/s",
              0.01, 20.0),
        Field("stiffness_n_per_mm_p", "float", "felt stiffness Q0 (three-parameter) or F0 "
              "(four-parameter), N/mm^p", 1.0, 1e9),
        Field("exponent", "float", "felt nonlinearity exponent p", 1.0, 6.0),
        Field("capo_coupling", "str", "direct: the hammer strikes the terminated string; injected: "
              "g(t) of a strike on the ideal string is injected (Publication I)", choices=CAPO_COUPLINGS),
        Field("alpha_s", "float", "hereditary time alpha, s", 0.0, 0.01,
              when=When("hammer.law", ("three-parameter",))),
        Field("gamma", "float", "hereditary amplitude gamma", 0.0, 1.0, hi_open=True,
              when=When("hammer.law", ("four-parameter",))),
        Field("tau0_s", "float", "relaxation time tau0, s", 1e-9, 1e-2,
              when=When("hammer.law", ("four-parameter",))),
        Field("model", "str", "lumped: the felt law as a massless spring (the voices' hammer); "
              "felt-layer: the felt solved as a medium (a column of felt on the core, thesis "
              "eqs. 2.1-2.6, the law above its quasi-static limit) pressing the moving string, "
              "offline (docs/felt.md)", choices=HAMMER_MODELS, when=When("kind", ("study",)),
              default="lumped"),
        Field("felt_thickness_m", "float", "felt-layer: the felt's thickness over the core, m "
              "(default 10.2 mm: the felt lab's assumed felt at A7)", 5e-4, 0.05,
              when=When("hammer.model", ("felt-layer",)), default=0.0102),
        Field("felt_area_m2", "float", "felt-layer: the felt column's cross-section under the "
              "string, m^2 (default 64 mm^2, assumed: a contact 8 mm along the string by 8 mm)",
              1e-6, 1e-3, when=When("hammer.model", ("felt-layer",)), default=64e-6),
        Field("felt_density_kg_per_m3", "float", "felt-layer: the felt's density, kg/m^3 "
              "(default 1000: the thesis's felt pads, eq. 2.13)", 100.0, 3000.0,
              when=When("hammer.model", ("felt-layer",)), default=1000.0),
        Field("felt_cells", "int", "felt-layer: cells across the felt (run time grows as "
              "cells^2: the sub-step with the cell; 32: g(t) within 1.4e-4 of converged, "
              "docs/felt.md)", 4, 256,
              when=When("hammer.model", ("felt-layer",)), default=32),
        Field("felt_tau0_s", "float", "felt-layer with the three-parameter law: the felt's "
              "relaxation time tau0, s (gamma = 1 - tau0 / alpha_s; default 1.8 us: Publication "
              "III eq. 6 at A7)", 1e-8, 1e-3,
              when=When("hammer.model", ("felt-layer",),
                        also=When("hammer.law", ("three-parameter",))), default=1.8e-6),
    ), when=When("voice", ("piano",))),
    Section("termination", "nonlinear contact termination", TerminationSpec, (
        Field("profile", "str", "obstacle profile at the termination", choices=PROFILES),
        Field("side", "int", "+1: obstacle above the string (u <= U); -1: below it (u >= U)",
              choices=(-1, 1),
              when=_when_not(_PROFILE, PROFILES, ("none",))),
        Field("region_points", "int", "number of grid points in the contact region, counted on the "
              "preset's own grid (a study preset's grid.cells; 325 kHz for a musical one): at another "
              "internal rate the region keeps its length in metres", 1, 2000,
              when=_when_not(_PROFILE, PROFILES, ("none",))),
        Field("radius_m", "float", "capo bar radius, m", 0.0005, 10.0, when=_prof("capo")),
        Field("radius_m", "float", "sawari curvature radius, m", 0.01, 100.0, when=_prof("sawari")),
        Field("radius_m", "float", "jawari curved-part radius, m", 1e-4, 10.0,
              when=_prof("jawari-case2", "jawari-case3")),
        Field("radius_m", "float", "jawari bridge surface radius, m", 0.01, 100.0,
              when=_prof("jawari")),
        Field("extent_m", "float", "sawari extent along the string, m", 1e-4, 0.2,
              when=_prof("sawari")),
        Field("extent_m", "float", "jawari bridge length from its far edge to the thread, m",
              1e-3, 0.1, when=_prof("jawari")),
        Field("thread_m", "float", "jawari thread diameter (it lifts the string off the bridge's "
              "front edge; at extent_m^2/(2 radius_m) the string grazes the bridge), m", 0.0, 0.005,
              when=_prof("jawari")),
        Field("contact", "str", "subcell: the string wraps the curve of the jawari (or the "
              "sawari) between x = 0 and the first grid point too (a grazing contact that "
              "shrinks with the amplitude, so the buzz fades with the note); grid: the clamp "
              "at grid points alone (the thesis's scheme; the buzz then stops in one step when "
              "the first point's gap exceeds the string's reach)",
              choices=JAWARI_CONTACTS, when=_prof("jawari", "sawari"), default="subcell"),
        Field("slope", "float", "jawari slope (dimensionless)", 0.0, 0.2,
              when=_prof("jawari-case1", "jawari-case2", "jawari-case3")),
        Field("x_c_m", "float", "jawari case-1 contact end, m", 1e-4, 0.2,
              when=_prof("jawari-case1")),
        Field("x_a_m", "float", "jawari case-3 start of the curved part, m", 1e-4, 0.2,
              when=_prof("jawari-case3")),
        Field("x_b_m", "float", "jawari end of the curved part, m", 1e-4, 0.2,
              when=_prof("jawari-case2", "jawari-case3")),
        Field("step_m", "float", "jawari case-3 step height, m", 0.0, 0.01,
              when=_prof("jawari-case3")),
        Field("points", "points", "obstacle table [[x_m, U_m], ...], x >= 0 strictly increasing",
              when=_prof("table")),
        Field("buzz", "float", "buzz depth: the obstacle's gap to the string over this (0: out "
              "of reach, the linear string; 1: the profile as given); live: play.buzz_cc",
              0.0, 1.0, when=_when_not(_PROFILE, PROFILES, ("none",)), default=1.0),
        Field("pitch_rise_cents", "float", "how far the contact raises the pitch at the pluck, "
              "at velocity 127 and buzz 1, tuned out as (velocity buzz)^0.6 "
              "exp(-t/pitch_rise_tau_s) through the bend line (musical presets with "
              "pitch_bend_semitones > 0; measure: tools/study_jawari.py --pitch --set "
              "termination.pitch_rise_cents=0)",
              0.0, 50.0, when=_when_not(_PROFILE, PROFILES, ("none",)), default=0.0),
        Field("pitch_rise_tau_s", "float", "time constant of the rise's fading as the note "
              "decays, s (the sitar's, measured: 1.0)",
              0.05, 60.0, when=_when_not(_PROFILE, PROFILES, ("none",)), default=1.0),
    ), when=_ONE_STRING, checks=(OrderCheck("x_a_m", "<", "x_b_m"),)),
    Section("taraf", "sympathetic strings on the main bridge, each on a jawari of its own "
            "(optional)", TarafSpec, (
        Field("keys", "keys", "MIDI keys the strings are tuned to (1 to 24 strings)", 12, 108),
        Field("length_m", "float", "speaking length of every taraf string, m", 0.05, 2.0),
        Field("linear_density_kg_per_m", "float", "linear mass density, kg/m (tension follows "
              "from the key: T = mu (2 L f0)^2)", 1e-5, 0.1),
        Field("inharmonicity", "float", "B of the string tuned to the first key (the others "
              "scale as 1/T)", 0.0, 0.01),
        Field("t60_low_s", "float", "free decay T60 at each string's own pitch, s", 0.05, 120.0),
        Field("t60_high_s", "float", "free decay T60 at f_high_hz, s", 0.01, 120.0),
        Field("f_high_hz", "float", "high reference frequency of the decay, Hz", 500.0, 20000.0),
        Field("bridge_resistance_ns_per_m", "float", "the main bridge that the played strings, "
              "the taraf and the chikari hang on (the tabli's driving point): u_b = integral "
              "of F / R, N s/m", 1.0, 1e5),
        Field("coupling", "float", "factor on that bridge's admittance (0: a rigid bridge, "
              "the played string alone: no taraf and no [chikari])", 0.0, 4.0),
        Field("radius_m", "float", "taraf jawari surface radius, m", 0.01, 100.0),
        Field("extent_m", "float", "taraf jawari length from its far edge to the thread, m",
              1e-3, 0.1),
        Field("thread_m", "float", "taraf jawari thread diameter (extent_m^2/(2 radius_m): the "
              "string grazes it), m", 0.0, 0.005),
        Field("region_points", "int", "largest number of grid points in a taraf string's "
              "contact region", 1, 200),
    ), when=_PLUCKED_MUSICAL, optional=True,
       checks=(OrderCheck("t60_high_s", "<=", "t60_low_s"),)),
    Section("chikari", "drone strings on the main bridge, strummed by a key range or a MIDI "
            "channel (optional; needs [taraf])", ChikariSpec, (
        Field("keys", "keys", "MIDI keys the drone strings are tuned to", 12, 108),
        Field("length_m", "float", "speaking length of the drone strings, m", 0.05, 2.0),
        Field("amplitude_m", "float", "pluck amplitude at velocity 127 (pluck.model, "
              "pluck.position, pluck.duration_s), m", 1e-6, 0.05),
        Field("strum_s", "float", "delay between successive strings of one stroke, s", 0.0, 0.1),
        Field("trigger_key_low", "int", "lowest MIDI key that strums the drones (outside "
              "play.key_low..key_high: those keys play the main string)", 0, 127),
        Field("trigger_key_high", "int", "highest MIDI key that strums the drones", 0, 127),
        Field("channel", "int", "MIDI channel (1-16) whose every note strums the drones "
              "(0: none)", 0, 16),
    ), when=_PLUCKED_MUSICAL, optional=True,
       requires="taraf", checks=(OrderCheck("trigger_key_low", "<=", "trigger_key_high"),)),
    Section("loss", "frequency-dependent losses of a musical string", LossSpec, (
        Field("t60_low_s", "float", "T60 decay time at f_low_hz, s", 0.01, 120.0),
        Field("f_low_hz", "float", "low reference frequency, Hz", 10.0, 2000.0),
        Field("t60_high_s", "float", "T60 decay time at f_high_hz, s", 0.005, 120.0),
        Field("f_high_hz", "float", "high reference frequency, Hz", 200.0, 20000.0),
        Field("release_t60_s", "float", "T60 after note-off (damped by the player), s", 0.005, 10.0),
    ), when=When("kind", ("musical",), also=_ONE_STRING), checks=(
        OrderCheck("f_low_hz", "<", "f_high_hz"),
        OrderCheck("t60_high_s", "<=", "t60_low_s"),
    )),
    Section("tuning", "tuning of the per-key piano strings", TuningSpec, (
        Field("a4_hz", "float", "frequency of A4 (partial 1), Hz", 380.0, 480.0),
        Field("stretch", "float", "octave stretch: 0 equal temperament, 1 a tuner's stretch for "
              "this inharmonicity", 0.0, 1.5),
        Field("octave_k_bass", "int", "octaves tuned down from A4 make partial 2k of the lower "
              "key beat-free with partial k of the upper (1: 2:1; 3: 6:3, a wider bass)", 1, 8,
              when=When("voice", ("grand",))),
    ), when=_KEYBOARD),
    Section("action", "grand piano hammers", ActionSpec, (
        Field("law", "str", "felt law of the per-key hammers (thesis eqs. 1.5-1.9 or Pub. III eqs. 3-7)",
              choices=HAMMER_LAWS),
        Field("speed_min_m_per_s", "float", "hammer speed at velocity 1, m/s", 0.05, 10.0),
        Field("speed_max_m_per_s", "float", "hammer speed at velocity 127, m/s", 0.1, 15.0),
        Field("soft_stiffness", "float", "felt stiffness factor with the soft pedal fully down "
              "(the hammer meets the strings with a softer part of the felt)", 0.1, 1.0),
        Field("voicing", "str", "constants of the three-parameter felt laws: the thesis's, or "
              "voiced for a concert grand (synth.physics.piano.VOICINGS)",
              choices=("thesis", "concert")),
        Field("knock", "float", "impulse of the action's knock on the board (the key on the "
              "keybed: the thump under a note) re the hammer's momentum (0: none)", 0.0, 10.0),
        Field("hardness", "float", "factor on every key's felt stiffness (Q0 or F0): above 1 "
              "hammers voiced harder (lacquered, brighter), below 1 softer (needled)", 0.25, 4.0,
              default=1.0),
        Field("knock_s", "float", "duration of the knock's force pulse, s (the shorter, the "
              "higher its thump reaches: 5 ms up to ~400 Hz, 1.5 ms ~1.3 kHz)", 2e-4, 0.02,
              default=0.005),
        Field("knock_build_s", "float", "time constant over which the knock builds up, s: its "
              "pulses as a train of pushes of both signs under (t / tau) exp(1 - t / tau), with "
              "the single pulse's energy (0: one pulse; synth.physics.soundboard.knock_pulse)",
              0.0, 0.05, default=0.0),
    ), when=When("voice", ("grand",)), checks=(
        OrderCheck("speed_min_m_per_s", "<", "speed_max_m_per_s"),)),
    Section("strings", "per-key piano strings (scale factors on synth.physics.piano)", StringsSpec, (
        Field("detune_scale", "float", "factor on the unison detuning of the per-key data", 0.0, 5.0,
              when=When("voice", ("grand",))),
        Field("t60_scale", "float", "factor on the per-key decay times", 0.05, 5.0),
        Field("dispersion_sections", "int", "largest stiffness allpass cascade per string (cost "
              "~1.5 ns each per string-sample)", 0, 16),
        Field("capo_radius_m", "float", "capo d'astro bar radius R, m", 0.0005, 1.0,
              when=When("voice", ("grand",))),
        Field("capo_region_m", "float", "length of string next to the bar that may touch it, m",
              0.0, 0.05, when=When("voice", ("grand",))),
        Field("capo_grid", "int", "steps per engine sample of the strings on the capo bar (a "
              "finer grid resolves the bar's contacts in free vibration; cost x this)", 1, 8,
              when=When("voice", ("grand",))),
        Field("capo_grid_from_key", "int", "the first key whose capo-bar strings run on that "
              "finer grid (MIDI; the bar starts at 73)", 21, 128, when=When("voice", ("grand",))),
        Field("capo_window_s", "float", "how long a strike's strings stay on that finer grid "
              "before they go on at the engine's rate, s (the bar's colour is made in the "
              "attack; 0: the whole note, at the finer grid's cost)", 0.0, 1.0,
              when=When("voice", ("grand",)), default=0.0),
        Field("bridge_coupling", "float", "factor on the bridge's admittance that couples a "
              "key's strings (1: the designed two-stage decay; 0: a rigid bridge)", 0.0, 4.0,
              when=When("voice", ("grand",))),
        Field("sympathetic", "float", "factor on the board's bridge admittance that drives the "
              "strings whose dampers are off (the pedal's halo; 0: no sympathetic strings)",
              0.0, 4.0, when=When("voice", ("grand",))),
        Field("bridge_mass_f0", "float", "the bridge a key's strings share moves as a mass, not "
              "a dashpot, above this multiple of the key's f0 (its loss falls there: the low "
              "partials' prompt sound fast, the high ones' slow; 0: a dashpot at every "
              "frequency)", 0.0, 100.0, when=When("voice", ("grand",)), default=0.0),
        Field("t60_treble_scale", "float", "factor on the treble strings' own T60 (their loss "
              "to air and wire, which sets the aftersound's decay) from t60_treble_from_key up, "
              "log-linear in key over the half octave below it (1: the loss law of "
              "synth.physics.piano)", 0.05, 1.0, when=When("voice", ("grand",)), default=1.0),
        Field("t60_treble_from_key", "int", "the first key whose strings have t60_treble_scale "
              "times the law's own T60 (MIDI)", 21, 108, when=When("voice", ("grand",)),
              default=108),
        Field("t60_top_factor", "float", "a further factor on the treble strings' own T60, "
              "log-linear in key from 1 at t60_treble_from_key to this at C8 (key 108)", 0.1, 1.0,
              when=When("voice", ("grand",)), default=1.0),
        Field("bridge_coupling_treble", "float", "factor on the bridge's admittance a treble "
              "unison feels (its prompt sound's loss to the board), from t60_treble_from_key "
              "up, log-linear in key over the half octave below it", 0.25, 4.0,
              when=When("voice", ("grand",)), default=1.0),
        Field("unison_spread_hz", "float", "the most a unison's outer strings may differ, Hz: "
              "a tuner's tolerance in beats a second, which holds the treble's unisons closer "
              "than the 0.6 cent of the keys below (synth.physics.piano.UNISON_SPREAD_HZ; the "
              "aftersound's level: detuned strings pass the struck motion on to the slowly "
              "decaying modes)", 0.05, 5.0, when=When("voice", ("grand",)), default=0.6),
        Field("polarization", "float", "the strings' second polarization, parallel to the "
              "board: one more string per key, on a rigid end with the strings' own loss (the "
              "bridge hardly moves that way), struck with the unison and heard at this share of "
              "a string's force (the hammer's slant times the board's coupling): the middle's "
              "aftersound (Weinreich 1977); 0: none, and the key has its unison alone", 0.0, 1.0,
              when=When("voice", ("grand",)), default=0.0),
        Field("polarization_from_key", "int", "the first key with the second polarization "
              "(MIDI)", 21, 108, when=When("voice", ("grand",)), default=49),
        Field("polarization_to_key", "int", "the last key with the second polarization (MIDI)",
              21, 108, when=When("voice", ("grand",)), default=83),
    ), when=_KEYBOARD),
    Section("dampers", "dampers and sustain pedal of the per-key strings", DampersSpec, (
        Field("release_t60_bass_s", "float", "T60 of a damped bass string, s", 0.02, 5.0),
        Field("release_t60_treble_s", "float", "T60 of a damped treble string, s", 0.01, 5.0),
        Field("half_pedal_low", "float", "pedal value below which the dampers rest fully", 0.0, 1.0),
        Field("half_pedal_high", "float", "pedal value above which the dampers are fully lifted",
              0.0, 1.0),
        Field("land_s", "float", "time constant over which a damper's felt takes hold of its "
              "string (or lets go), s: the string's loss glides to its new value (a shorter "
              "one clicks when many dampers fall together, a pedal let up)", 0.001, 0.1,
              default=0.005),   # StringBank.LOSS_GLIDE_S, the bank's own glide
    ), when=_KEYBOARD, checks=(OrderCheck("half_pedal_low", "<", "half_pedal_high"),)),
    Section("body", "the instrument's body (soundboard, gourd, wooden box) as a modal filter "
            "on the bridge force (optional: absent, the bare strings)", BodySpec, (
        Field("wet", "float", "share of the body's modes in the output (0: its direct part "
              "only, flat)", 0.0, 1.0),
        Field("modes", "int", "number of diffuse modes", 1, 1024),
        Field("size", "float", "body size factor (divides all diffuse mode frequencies: "
              "lowest 50/size Hz)", 0.25, 4.0),
        Field("brightness", "float", "spectral tilt of the body, dB/octave", -12.0, 12.0),
        Field("seed", "int", "random seed of the mode set (deterministic)", 0, 2 ** 31 - 1),
        Field("peaks", "peaks", "named resonances on top of the diffuse modes (air mode, "
              "top-plate modes): [f_hz, q, level_db re the diffuse level], ...", *PEAK_HZ_RANGE,
              default=()),
        Field("inputs", "int", "bridge inputs of the board: 1 (whole bridge) or 2 (bass end, "
              "treble end)", 1, 2, when=When("voice", ("grand",))),
        Field("outputs", "int", "outputs of the board: 1 (mono) or 2 (left, right)", 1, 2,
              when=When("voice", ("grand",))),
        Field("spread_ms", "float", "the radiation's spread, ms: the sound of each part of the "
              "board arrives at its own time, so a note builds up over a few ms (an allpass "
              "cascade: no change to a partial's steady level; 0: none)", *SPREAD_RANGE_MS,
              default=0.0),
        Field("mass_hz", "float", "the board's mass corner, Hz: above it the board moves as a "
              "mass and its sound falls 6 dB per octave (0: none)", *MASS_RANGE_HZ, default=0.0),
    ), when=When("kind", ("musical",)), optional=True),
    Section("output", "what is written to the WAV", OutputSpec, (
        Field("signal", "str", "displacement u(l,t) at the pluck point (m) or bridge force at x=L (N)",
              choices=SIGNALS),
        Field("gain", "float", "linear factor from the signal to WAV full scale (1.0)", 1e-6, 1e9),
        Field("limiter", "str", "look-ahead peak limiter on the output (1.5 ms; the rare "
              "loudest peaks held under limit_dbfs)", choices=("off", "on"), default="off"),
        Field("limit_dbfs", "float", "the limiter's ceiling, dBFS", -20.0, 0.0, default=-1.0),
        Field("limit_release_s", "float", "the limiter's release time constant, s", 0.001, 2.0,
              default=0.05),
    )),
    Section("play", "musical play range", PlaySpec, (
        Field("key_low", "int", "lowest playable MIDI key", 0, 127),
        Field("key_high", "int", "highest playable MIDI key", 0, 127),
        Field("velocity_exponent", "float",
              "amplitude = amplitude_m * (velocity/127)**velocity_exponent", 0.2, 5.0),
        Field("polyphony", "int", "maximum simultaneous voices", 1, 512),
        Field("pitch_bend_semitones", "float", "pitch-bend range, semitones (the widest RPN 0 "
              "may set)", 0.0, 12.0),
        Field("steal", "str", "which voice a note takes when every voice sounds: the quietest "
              "or the oldest of those sounding before it, released ones first",
              choices=("quietest", "oldest"), default="quietest"),
        Field("buzz_cc", "int", "MIDI controller that sets termination.buzz live (1: the "
              "modulation wheel; the pedals 64, 66, 67 stay the engine's)", 1, 119,
              when=_ONE_STRING, default=1),
        Field("quality", "str", "how finely the strings are computed: draft (half the internal "
              "rate), standard (325 kHz), reference (twice, finer stiffness filters); "
              "docs/quality.md gives each one's error and cost", choices=QUALITIES,
              default="standard"),
    ), when=When("kind", ("musical",)), checks=(OrderCheck("key_low", "<=", "key_high"),)),
    Section("quality_error", "the measured error of each quality level on this preset "
            "(`python tools/quality_levels.py notes`; docs/quality.md): --max-error picks the "
            "cheapest level within it (optional: absent, the worst over the shipped presets)",
            QualityErrorSpec, tuple(
                row for q in QUALITIES for row in (
                    Field(f"{q}_cents", "float", f"worst partial-frequency error at {q}, cents",
                          0.0, 1200.0),
                    Field(f"{q}_db", "float", f"worst partial-level error at {q}, dB",
                          0.0, 100.0))),
            when=When("kind", ("musical",)), optional=True),
    Section("drone", "the drone player: a key starts a cycle of plucks of four strings (the "
            "first, two Sa in unison, the low Sa an octave below), the same key stops it, "
            "another key moves Sa from the next cycle (optional; synth drone, docs/drone.md)",
            DroneSpec, (
        Field("player", "str", "on: a note-on plays the drone as above; off: a note-on plucks "
              "one string, as on the other plucked presets", choices=("on", "off"),
              default="on"),
        Field("pattern", "str", "the strings in pluck order: the first token (Pa, Ma or Ni: "
              "Sa -5, -7 or -1 semitones; or Sa) tunes the first string, then the two middle "
              "Sa strings (Sa) and the low Sa (Sa -12); live: pattern_cc",
              pattern=DRONE_PATTERN, default="Pa Sa Sa Sa"),
        Field("cycle_s", "float", "the cycle's length, s; live: tempo_cc", *DRONE_CYCLE_RANGE_S,
              default=4.0),
        Field("onsets", "ascending", "each string's pluck time in the cycle, as a fraction of "
              "its length, in pluck order", 0.0, 1.0, hi_open=True, count=4,
              default=(0.0, 0.3, 0.45, 0.6)),
        Field("velocity", "float", "the plucks' velocity (1: MIDI 127)", 0.0, 1.0,
              lo_open=True, default=0.6),
        Field("timing_jitter_s", "float", "humanisation: each pluck moves by up to this, "
              "uniformly, s (never before its cycle's start)", 0.0, 0.1, default=0.02),
        Field("force_jitter_db", "float", "humanisation: each pluck's amplitude varies by up "
              "to this, uniformly, dB (velocity held within 0-1)", 0.0, 6.0, default=1.5),
        Field("seed", "int", "seed of the humanisation's draws (the same seed, the same "
              "render)", 0, 2 ** 31 - 1, default=1),
        Field("tempo_cc", "int", "MIDI controller of the cycle's length, from the next cycle: "
              "0 the longest (16 s), 127 the shortest (1 s), geometrically (64: 4 s)",
              1, 119, default=16),
        Field("pattern_cc", "int", "MIDI controller of the first string, from the next cycle: "
              "0-31 Pa, 32-63 Ma, 64-95 Ni, 96-127 Sa", 1, 119, default=17),
    ), when=When("kind", ("musical",)), optional=True),
    Section("listener", "where the instrument is heard from: the body's sound radiated to a "
            "position in a room (distance, directivity, air absorption, early reflections, "
            "late reverberation; optional: absent, the body's output as it is; docs/listener.md)",
            ListenerSpec, (
        Field("position", "str", "close (microphones 0.5 m over the strings, as recorded piano "
              "libraries are made), player (the player's seat, 1 m) or hall (a seat 12 m away)",
              choices=tuple(POSITIONS)),
        Field("room", "str", "the room: " + ", ".join(repr(r) for r in ROOM_NAMES) + " (none: "
              "the direct sound alone), or a measured impulse response's WAV file (its decay "
              "and early reflections drive the designed reverberation); absent: the position's "
              "(close, player: studio; hall: hall)", optional=True),
        Field("distance_m", "float", "distance from the board's centre, m (absent: the "
              "position's: 0.5, 1, 12)", *DISTANCE_RANGE_M, optional=True),
        Field("directivity_db", "float", "the direct sound's level at high frequencies re the "
              "board's power average, dB (+ on the board's axis, - off it; absent: the "
              "position's: 0, -3, +3)", *DIRECTIVITY_RANGE_DB, optional=True),
        Field("temperature_c", "float", "air temperature, degrees C (the air's absorption, "
              "ISO 9613-1)", *TEMPERATURE_RANGE_C, default=20.0),
        Field("humidity_percent", "float", "relative humidity of the air, %",
              *HUMIDITY_RANGE_PERCENT, default=50.0),
        Field("level", "str", "matched (the same mean level, 125 Hz - 4 kHz, at every position: "
              "output.gain holds) or distance (the direct sound at 1 m is unity: farther is "
              "quieter)", choices=LEVELS, default="matched"),
    ), when=When("kind", ("musical",)), optional=True),
    Section("bridge", "the bridge the played strings share, without [taraf] (optional): "
            "every sounding string hangs on it, two-way, so that the strings ring into each "
            "other (a tanpura's four strings on its one bridge)", BridgeSpec, (
        Field("resistance_ns_per_m", "float", "the bridge's resistance (the top plate's "
              "driving point): u_b = integral of F / R, N s/m", 1.0, 1e5),
    ), when=_PLUCKED_MUSICAL, optional=True),
)
