"""The validated, immutable result objects of a preset.

One frozen dataclass per schema section (:mod:`.sections` maps each TOML
table onto its class) and :class:`Preset`, which holds them. Fields are plain
``int``/``float``/``str``/``tuple`` values in SI units; keys that are absent
for the preset's variant are ``None``. A new section brings a new class
here; the import-time check in :mod:`.validate` makes sure its fields match
the section's keys and that :class:`Preset` lists the sections in schema
order.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    "StringSpec",
    "GridSpec",
    "PluckSpec",
    "HammerSpec",
    "TuningSpec",
    "ActionSpec",
    "StringsSpec",
    "DampersSpec",
    "BodySpec",
    "TerminationSpec",
    "TarafSpec",
    "ChikariSpec",
    "LossSpec",
    "OutputSpec",
    "PlaySpec",
    "DroneSpec",
    "Preset",
]


@dataclass(frozen=True)
class StringSpec:
    """Physical string: speaking length (m), tension (N), linear density (kg/m),
    and the open string's inharmonicity coefficient B (musical presets); the
    tension's modulation by the string's swing (0..1, musical presets) and
    the wire's Young's modulus (Pa) and diameter (m) it needs."""

    length_m: float
    tension_n: float
    linear_density_kg_per_m: float
    inharmonicity: float | None = None
    tension_modulation: float | None = None
    youngs_modulus_pa: float | None = None
    diameter_m: float | None = None


@dataclass(frozen=True)
class GridSpec:
    """Study grid: number of cells N (c*dt = dx exactly, internal rate N*c/L)."""

    cells: int


@dataclass(frozen=True)
class PluckSpec:
    """Pluck model and its parameters (position is a fraction of L; SI otherwise)."""

    model: str
    position: float
    amplitude_m: float
    duration_s: float
    alpha_per_s: float | None = None
    bachi_impulse_ns: float | None = None
    bachi_duration_s: float | None = None


@dataclass(frozen=True)
class HammerSpec:
    """A felt hammer striking one string (thesis eqs. 1.4-1.9, Pub. III eq. 3).

    law: "three-parameter" (F = Q0 (w^p + alpha d(w^p)/dt)) or
    "four-parameter" (F = F0 (w^p - gamma/tau0 int w^p e^((s-t)/tau0) ds));
    stiffness is Q0 or F0 in N/mm^p; capo_coupling: "direct" (the hammer
    strikes the string with its termination) or "injected" (g(t) from a strike
    on the ideally supported string is injected, as Publication I does).
    """

    law: str
    position: float
    mass_kg: float
    speed_m_per_s: float
    stiffness_n_per_mm_p: float
    exponent: float
    capo_coupling: str
    alpha_s: float | None = None
    gamma: float | None = None
    tau0_s: float | None = None
    model: str | None = None                     # study: "lumped" or "felt-layer"
    felt_thickness_m: float | None = None        # felt-layer: the column (SI)
    felt_area_m2: float | None = None
    felt_density_kg_per_m3: float | None = None
    felt_cells: int | None = None
    felt_tau0_s: float | None = None             # felt-layer, three-parameter law


@dataclass(frozen=True)
class TuningSpec:
    """Grand piano tuning: A4 (Hz) and octave stretch (0 equal temperament,
    1 the stretch a tuner sets for the strings' inharmonicity)."""

    a4_hz: float
    stretch: float
    octave_k_bass: int | None = None     # grand: octave type tuned down from A4 (None: 2:1)


@dataclass(frozen=True)
class ActionSpec:
    """Grand piano action: felt law of the per-key hammers, hammer speed at
    velocity 1 and 127 (m/s; play.velocity_exponent shapes the curve), felt
    stiffness factor with the soft pedal fully down, and a factor on every
    key's felt stiffness (``hardness``: how the hammers are voiced)."""

    law: str
    speed_min_m_per_s: float
    speed_max_m_per_s: float
    soft_stiffness: float
    voicing: str = "thesis"      # constants of the three-parameter laws (synth.physics.piano.VOICINGS)
    knock: float | None = None   # the knock's impulse re the hammer's momentum (0: none)
    hardness: float = 1.0        # factor on every key's felt stiffness (voicing: lacquer > 1, needles < 1)
    knock_s: float = 0.005       # duration of the knock's force pulse (s)
    knock_build_s: float = 0.0   # the knock's build-up time constant (s; 0: one pulse)


@dataclass(frozen=True)
class StringsSpec:
    """Grand piano strings: scale factors on the per-key data, stiffness
    filter size, capo d'astro bar of the treble strings."""

    detune_scale: float
    t60_scale: float
    dispersion_sections: int
    capo_radius_m: float
    capo_region_m: float
    capo_grid: int | None = None          # grand: steps per engine sample of the capo strings
    capo_grid_from_key: int | None = None  # grand: the first key on that finer grid
    capo_window_s: float | None = None    # grand: a strike's time on it (0 / None: the whole note)
    bridge_coupling: float | None = None  # grand: factor on the bridge's admittance (0: rigid)
    sympathetic: float | None = None      # grand: factor on the board's bridge the free strings see
    bridge_mass_f0: float | None = None   # grand: the bridge moves as a mass above this x f0 (0: dashpot)
    t60_treble_scale: float = 1.0         # grand: factor on the treble strings' own T60 (from t60_treble_from_key up)
    t60_treble_from_key: int = 108        # grand: the first key at that factor (a half-octave ramp below it)
    bridge_coupling_treble: float = 1.0   # grand: factor on the bridge's admittance from there up
    unison_spread_hz: float = 0.6         # grand: the most a unison's outer strings differ, Hz (a tuner's beats)
    t60_top_factor: float = 1.0           # grand: a further factor on the treble's own T60, reached at C8
    polarization: float = 0.0             # grand: the strings' second polarization, its share of the output (0: none)
    polarization_from_key: int = 49       # grand: the first key that has it
    polarization_to_key: int = 83         # grand: the last key that has it


@dataclass(frozen=True)
class DampersSpec:
    """Dampers: T60 of a damped string in the bass and the treble (s), and
    the sustain-pedal range over which the dampers lift (half pedal)."""

    release_t60_bass_s: float
    release_t60_treble_s: float
    half_pedal_low: float
    half_pedal_high: float
    land_s: float | None = None   # time constant of a damper taking hold (s); the schema's default 5 ms


@dataclass(frozen=True)
class BodySpec:
    """Body: modal bank on the 48 kHz bridge signal(s) (synth.physics.soundboard);
    ``peaks``: named resonances ((f_hz, q, level_db), ...);
    ``inputs``/``outputs`` (grand only, else None): bridge inputs and outputs, 1 or 2;
    ``spread_ms``: the radiation's spread (0: none); ``mass_hz``: the
    board's mass corner (0: none)."""

    wet: float
    modes: int
    size: float
    brightness: float
    seed: int
    peaks: tuple = ()
    inputs: int | None = None
    outputs: int | None = None
    spread_ms: float = 0.0
    mass_hz: float = 0.0


@dataclass(frozen=True)
class TerminationSpec:
    """Nonlinear termination profile; parameters not used by the profile are None.

    ``points`` (profile ``"table"``) is a tuple of ``(x_m, U_m)`` float pairs.
    """

    profile: str
    side: int | None = None
    region_points: int | None = None
    radius_m: float | None = None
    extent_m: float | None = None
    slope: float | None = None
    x_c_m: float | None = None
    x_a_m: float | None = None
    x_b_m: float | None = None
    thread_m: float | None = None
    contact: str | None = None
    step_m: float | None = None
    points: tuple[tuple[float, float], ...] | None = None
    buzz: float | None = None
    pitch_rise_cents: float | None = None
    pitch_rise_tau_s: float | None = None


@dataclass(frozen=True)
class TarafSpec:
    """Sympathetic strings (a sitar's taraf) on the main bridge, each on a
    small jawari of its own: tunings (MIDI keys), the strings (speaking
    length m, linear density kg/m, B at the first key), their decay (T60 s
    at their own pitch and at ``f_high_hz``), the bridge they hang on
    (resistance N s/m, ``coupling`` factor on its admittance, 0: a rigid
    bridge, no taraf and no chikari; the played strings hang on it too) and
    their jawari (radius, extent, thread m, region grid points)."""

    keys: tuple[int, ...]
    length_m: float
    linear_density_kg_per_m: float
    inharmonicity: float
    t60_low_s: float
    t60_high_s: float
    f_high_hz: float
    bridge_resistance_ns_per_m: float
    coupling: float
    radius_m: float
    extent_m: float
    thread_m: float
    region_points: int


@dataclass(frozen=True)
class BridgeSpec:
    """The bridge a plucked instrument's played strings share without a
    ``[taraf]`` (a tanpura's four strings): its resistance (N s/m), a
    two-way bridge every sounding string hangs on, so that the strings ring
    into each other."""

    resistance_ns_per_m: float


@dataclass(frozen=True)
class ChikariSpec:
    """Drone strings (a sitar's chikari) on the main bridge and its jawari,
    strummed by a key range or a MIDI channel: tunings (MIDI keys), speaking
    length (m), pluck amplitude at velocity 127 (m), the delay between
    successive strings of a stroke (s), the trigger key range and channel
    (1-16, 0: none); the material, decay and bridge are the ``[taraf]``'s."""

    keys: tuple[int, ...]
    length_m: float
    amplitude_m: float
    strum_s: float
    trigger_key_low: int
    trigger_key_high: int
    channel: int


@dataclass(frozen=True)
class LossSpec:
    """Frequency-dependent decay: T60 (s) at two frequencies (Hz), release T60 (s)."""

    t60_low_s: float
    f_low_hz: float
    t60_high_s: float
    f_high_hz: float
    release_t60_s: float


@dataclass(frozen=True)
class OutputSpec:
    """Output signal ("displacement" in m or "bridge_force" in N) and its gain to full
    scale; the output's peak limiter ("on"/"off", ceiling dBFS, release s)."""

    signal: str
    gain: float
    limiter: str = "off"
    limit_dbfs: float = -1.0
    limit_release_s: float = 0.05


@dataclass(frozen=True)
class ListenerSpec:
    """The listening position (synth.physics.listener): ``position`` ("close",
    "player", "hall"), ``room`` (a designed room's name, "none", or a WAV
    file's path; None: the position's), ``distance_m`` and ``directivity_db``
    (None: the position's), the air (C, % relative humidity) and how the
    level is set ("matched" or "distance")."""

    position: str
    room: str | None = None
    distance_m: float | None = None
    directivity_db: float | None = None
    temperature_c: float = 20.0
    humidity_percent: float = 50.0
    level: str = "matched"


@dataclass(frozen=True)
class PlaySpec:
    """Musical play range and behaviour."""

    key_low: int
    key_high: int
    velocity_exponent: float
    polyphony: int
    pitch_bend_semitones: float
    buzz_cc: int | None = None
    quality: str = "standard"
    steal: str = "quietest"


@dataclass(frozen=True)
class QualityErrorSpec:
    """The measured error of each quality level on this preset: the worst
    partial-frequency error (cents) and partial-level error (dB) over the
    first second of a low, a middle and a high note, against the same
    notes at 1.3 MHz with 0.5-cent stiffness filters (``python
    tools/quality_levels.py notes``; docs/quality.md)."""

    draft_cents: float
    draft_db: float
    standard_cents: float
    standard_db: float
    reference_cents: float
    reference_db: float

    def of(self, level: str) -> tuple[float, float]:
        """(cents, dB) of the quality level called ``level``."""
        return (float(getattr(self, f"{level}_cents")), float(getattr(self, f"{level}_db")))

    def table(self) -> dict[str, tuple[float, float]]:
        """{level: (cents, dB)} for every level."""
        return {lv: self.of(lv) for lv in ("draft", "standard", "reference")}


@dataclass(frozen=True)
class DroneSpec:
    """The drone player (synth.engine.drone): a key starts and stops a cycle
    of plucks of four strings (the first, Sa, Sa, the low Sa).  ``player``
    "on" (a key plays the drone) or "off" (a key plucks one string);
    ``pattern`` the strings in pluck order ("Pa Sa Sa Sa": the first token
    Pa, Ma, Ni or Sa tunes the first string); ``cycle_s`` the cycle's
    length (s); ``onsets`` each pluck's time as a fraction of the cycle;
    ``velocity`` the plucks' (0-1); the humanisation's bounds (s, dB) and
    its seed; the controllers of the cycle's length and the first string."""

    player: str
    pattern: str
    cycle_s: float
    onsets: tuple
    velocity: float
    timing_jitter_s: float
    force_jitter_db: float
    seed: int
    tempo_cc: int
    pattern_cc: int


@dataclass(frozen=True)
class Preset:
    """A validated preset.

    ``name`` is the preset name (path relative to its preset directory without
    ``.toml``, or the file stem for a file outside the preset directories);
    ``path`` is the source it was read from: the absolute file path (``str``)
    for :func:`load_preset`, the ``source`` label for :func:`validate_dict`. Sections that are forbidden for
    the preset's ``kind`` are ``None``.
    """

    name: str
    path: str
    schema: int
    description: str
    kind: str
    voice: str
    string: StringSpec | None
    grid: GridSpec | None
    pluck: PluckSpec | None
    hammer: HammerSpec | None
    termination: TerminationSpec | None
    taraf: TarafSpec | None
    chikari: ChikariSpec | None
    loss: LossSpec | None
    tuning: TuningSpec | None
    action: ActionSpec | None
    strings: StringsSpec | None
    dampers: DampersSpec | None
    body: BodySpec | None
    output: OutputSpec
    play: PlaySpec | None
    quality_error: QualityErrorSpec | None = None
    drone: DroneSpec | None = None
    listener: ListenerSpec | None = None
    bridge: BridgeSpec | None = None
