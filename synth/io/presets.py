"""Presets: TOML files describing one instrument voice (schema version 1).

A preset is a TOML file in a directory listed in ``$SYNTH_PRESET_PATH`` or
in the shipped ``synth/presets/`` folder; its *name* is its path relative to
that directory without ``.toml``, e.g. ``"sitar"`` or ``"paper/sitar-case1"``.

The shipped presets are package data so a wheel carries them: they live
inside the ``synth`` package, are declared in ``pyproject.toml``
(``[tool.setuptools.package-data]``) and are found with
``importlib.resources.files("synth") / "presets"``, which names the package's
own directory whether it was installed editable (the checkout's
``synth/presets``), from a wheel or by a plain ``pip install .`` (the copy in
``site-packages/synth/presets``). A folder beside the package (the old
``presets/`` at the top of the checkout, found by ``__file__`` arithmetic)
exists only in a checkout, so an installed wheel had no presets. The folder
is not a Python package (no ``__init__.py``); pip always unpacks wheels onto
the file system, so the resource is a real directory and presets keep real
paths (for error messages and ``Preset.path``); an import from a zip file,
where it would not be one, is not supported and finds no shipped presets.

The schema is declared once, as data, in :data:`SCHEMA_FIELDS` and
:data:`SECTIONS`: every key has a type, a range or a set of choices, a short
doc string with its unit, and a presence condition (:class:`When`). A key
with a condition is required when the condition holds and forbidden
otherwise; a key without one is always required. The same key may appear in
several rows with disjoint conditions and different ranges (e.g.
``termination.radius_m`` for ``capo`` and for ``sawari``). Adding a voice
(``"piano"``) or a termination profile is adding rows and, if it brings a
new section, one frozen dataclass.

Validation raises :class:`~synth.io.errors.PresetError` whose message is a
single line naming the file, the dotted key, the value and what is allowed::

    synth/presets/sitar.toml: pluck.position = 1.5 is out of range (0 < value < 1)
    synth/presets/sitar.toml: unknown key 'pluck.positon' (allowed: model, ...)
    synth/presets/sitar.toml: missing key 'string.tension_n'

The validated result is an immutable, hashable :class:`Preset` built from
plain ``int``/``float``/``str``/``tuple`` fields (keys that are absent for
the preset's variant are ``None``). All quantities are SI (m, N, kg/m, s,
Hz), as the key names say.
"""

from __future__ import annotations

import copy
import dataclasses
import difflib
import importlib.resources
import json
import math
import os
import re
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields as dc_fields
from pathlib import Path
from typing import Any

from synth.io.errors import PresetError, display_path as _display_path

__all__ = [
    "StringSpec",
    "GridSpec",
    "PluckSpec",
    "TerminationSpec",
    "LossSpec",
    "OutputSpec",
    "PlaySpec",
    "Preset",
    "When",
    "Field",
    "Section",
    "OrderCheck",
    "SCHEMA_VERSION",
    "SCHEMA_FIELDS",
    "SECTIONS",
    "preset_dirs",
    "shipped_preset_dir",
    "list_presets",
    "load_preset",
    "validate_dict",
    "parse_override",
]

SCHEMA_VERSION = 1
ENV_PRESET_PATH = "SYNTH_PRESET_PATH"


# --------------------------------------------------------------------------
# Validated, immutable result objects
# --------------------------------------------------------------------------


@dataclass(frozen=True)
class StringSpec:
    """Physical string: speaking length (m), tension (N), linear density (kg/m)."""

    length_m: float
    tension_n: float
    linear_density_kg_per_m: float


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


@dataclass(frozen=True)
class TuningSpec:
    """Grand piano tuning: A4 (Hz) and octave stretch (0 equal temperament,
    1 the stretch a tuner sets for the strings' inharmonicity)."""

    a4_hz: float
    stretch: float


@dataclass(frozen=True)
class ActionSpec:
    """Grand piano action: felt law of the per-key hammers, hammer speed at
    velocity 1 and 127 (m/s; play.velocity_exponent shapes the curve), felt
    stiffness factor with the soft pedal fully down."""

    law: str
    speed_min_m_per_s: float
    speed_max_m_per_s: float
    soft_stiffness: float


@dataclass(frozen=True)
class StringsSpec:
    """Grand piano strings: scale factors on the per-key data, stiffness
    filter size, capo d'astro bar of the treble strings."""

    detune_scale: float
    t60_scale: float
    dispersion_sections: int
    capo_radius_m: float
    capo_region_m: float


@dataclass(frozen=True)
class DampersSpec:
    """Dampers: T60 of a damped string in the bass and the treble (s), and
    the sustain-pedal range over which the dampers lift (half pedal)."""

    release_t60_bass_s: float
    release_t60_treble_s: float
    half_pedal_low: float
    half_pedal_high: float


@dataclass(frozen=True)
class BodySpec:
    """Soundboard: modal bank on the 48 kHz mix (synth.physics.soundboard)."""

    wet: float
    modes: int
    size: float
    brightness: float
    seed: int


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
    step_m: float | None = None
    points: tuple[tuple[float, float], ...] | None = None


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
    """Output signal ("displacement" in m or "bridge_force" in N) and its gain to full scale."""

    signal: str
    gain: float


@dataclass(frozen=True)
class PlaySpec:
    """Musical play range and behaviour."""

    key_low: int
    key_high: int
    velocity_exponent: float
    polyphony: int
    pitch_bend_semitones: float


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
    loss: LossSpec | None
    tuning: TuningSpec | None
    action: ActionSpec | None
    strings: StringsSpec | None
    dampers: DampersSpec | None
    body: BodySpec | None
    output: OutputSpec
    play: PlaySpec | None


# --------------------------------------------------------------------------
# The declarative schema
# --------------------------------------------------------------------------


@dataclass(frozen=True)
class When:
    """Presence condition: the already-validated key ``key`` (dotted) has one of ``values``."""

    key: str
    values: tuple
    also: "When | None" = None    # a second condition that must hold too

    def holds(self, ctx: Mapping[str, Any]) -> bool:
        return (self.key in ctx and ctx[self.key] in self.values
                and (self.also is None or self.also.holds(ctx)))

    def describe(self) -> str:
        vals = [_fmt_value(v) for v in self.values]
        if len(vals) == 1:
            text = f"{self.key} = {vals[0]}"
        else:
            text = f"{self.key} is one of {', '.join(vals)}"
        return text if self.also is None else f"{text} and {self.also.describe()}"


def _when_not(key: str, choices: Sequence, excluded: Sequence) -> When:
    """Condition "key is anything but `excluded`" spelt out over the key's choices."""
    return When(key, tuple(c for c in choices if c not in excluded))


@dataclass(frozen=True)
class Field:
    """One schema row.

    Parameters
    ----------
    name : str
        Key inside its section.
    type : str
        ``"float"`` (int accepted, bool never, must be finite), ``"int"``,
        ``"str"``, ``"line"`` (non-empty single-line string) or ``"points"``
        (array of ``[x_m, U_m]`` pairs, at least 2, x >= 0 strictly increasing).
    doc : str
        Meaning and unit, one line.
    lo, hi : float or None
        Range bounds; ``lo_open``/``hi_open`` make them exclusive.
    choices : tuple or None
        Allowed values (for ``str`` and ``int`` keys).
    when : When or None
        Required iff the condition holds, forbidden otherwise; None = always required.
    """

    name: str
    type: str
    doc: str
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    choices: tuple | None = None
    when: When | None = None

    def range_text(self) -> str:
        lo_op = "<" if self.lo_open else "<="
        hi_op = "<" if self.hi_open else "<="
        if self.lo is not None and self.hi is not None:
            return f"{_fmt_num(self.lo)} {lo_op} value {hi_op} {_fmt_num(self.hi)}"
        if self.lo is not None:
            return f"value {'>' if self.lo_open else '>='} {_fmt_num(self.lo)}"
        if self.hi is not None:
            return f"value {hi_op} {_fmt_num(self.hi)}"
        return "any value"

    def in_range(self, v: float) -> bool:
        if self.lo is not None and (v <= self.lo if self.lo_open else v < self.lo):
            return False
        if self.hi is not None and (v >= self.hi if self.hi_open else v > self.hi):
            return False
        return True


@dataclass(frozen=True)
class OrderCheck:
    """Cross-key constraint ``section.a <op> section.b`` (op is "<" or "<="), when both present."""

    a: str
    op: str
    b: str


@dataclass(frozen=True)
class Section:
    """One TOML table of the schema, mapped onto the frozen dataclass ``cls``."""

    name: str
    doc: str
    cls: type
    fields: tuple[Field, ...]
    when: When | None = None
    checks: tuple[OrderCheck, ...] = ()


KINDS = ("study", "musical")
VOICES = ("plucked", "piano", "grand")
_ONE_STRING = When("voice", ("plucked", "piano"))
HAMMER_LAWS = ("three-parameter", "four-parameter")
CAPO_COUPLINGS = ("direct", "injected")
PLUCK_MODELS = ("sitar", "biwa")
PROFILES = (
    "none",
    "capo",
    "sawari",
    "jawari-case1",
    "jawari-case2",
    "jawari-case3",
    "table",
)
SIGNALS = ("displacement", "bridge_force")

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
    ), when=When("voice", ("plucked",))),
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
    ), when=When("voice", ("piano",))),
    Section("termination", "nonlinear contact termination", TerminationSpec, (
        Field("profile", "str", "obstacle profile at the termination", choices=PROFILES),
        Field("side", "int", "+1: obstacle above the string (u <= U); -1: below it (u >= U)",
              choices=(-1, 1),
              when=_when_not(_PROFILE, PROFILES, ("none",))),
        Field("region_points", "int", "number of grid points in the contact region", 1, 2000,
              when=_when_not(_PROFILE, PROFILES, ("none",))),
        Field("radius_m", "float", "capo bar radius, m", 0.0005, 10.0, when=_prof("capo")),
        Field("radius_m", "float", "sawari curvature radius, m", 0.01, 100.0, when=_prof("sawari")),
        Field("radius_m", "float", "jawari curved-part radius, m", 1e-4, 10.0,
              when=_prof("jawari-case2", "jawari-case3")),
        Field("extent_m", "float", "sawari extent along the string, m", 1e-4, 0.2,
              when=_prof("sawari")),
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
    ), when=_ONE_STRING, checks=(OrderCheck("x_a_m", "<", "x_b_m"),)),
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
    Section("tuning", "grand piano tuning", TuningSpec, (
        Field("a4_hz", "float", "frequency of A4 (partial 1), Hz", 380.0, 480.0),
        Field("stretch", "float", "octave stretch: 0 equal temperament, 1 a tuner's stretch for "
              "this inharmonicity", 0.0, 1.5),
    ), when=When("voice", ("grand",))),
    Section("action", "grand piano hammers", ActionSpec, (
        Field("law", "str", "felt law of the per-key hammers (thesis eqs. 1.5-1.9 or Pub. III eqs. 3-7)",
              choices=HAMMER_LAWS),
        Field("speed_min_m_per_s", "float", "hammer speed at velocity 1, m/s", 0.05, 10.0),
        Field("speed_max_m_per_s", "float", "hammer speed at velocity 127, m/s", 0.1, 15.0),
        Field("soft_stiffness", "float", "felt stiffness factor with the soft pedal fully down "
              "(the hammer meets the strings with a softer part of the felt)", 0.1, 1.0),
    ), when=When("voice", ("grand",)), checks=(
        OrderCheck("speed_min_m_per_s", "<", "speed_max_m_per_s"),)),
    Section("strings", "grand piano strings", StringsSpec, (
        Field("detune_scale", "float", "factor on the unison detuning of the per-key data", 0.0, 5.0),
        Field("t60_scale", "float", "factor on the per-key decay times", 0.05, 5.0),
        Field("dispersion_sections", "int", "largest stiffness allpass cascade per string (cost "
              "~1.5 ns each per string-sample)", 0, 16),
        Field("capo_radius_m", "float", "capo d'astro bar radius R, m", 0.0005, 1.0),
        Field("capo_region_m", "float", "length of string next to the bar that may touch it, m",
              0.0, 0.05),
    ), when=When("voice", ("grand",))),
    Section("dampers", "grand piano dampers and sustain pedal", DampersSpec, (
        Field("release_t60_bass_s", "float", "T60 of a damped bass string, s", 0.02, 5.0),
        Field("release_t60_treble_s", "float", "T60 of a damped treble string, s", 0.01, 5.0),
        Field("half_pedal_low", "float", "pedal value below which the dampers rest fully", 0.0, 1.0),
        Field("half_pedal_high", "float", "pedal value above which the dampers are fully lifted",
              0.0, 1.0),
    ), when=When("voice", ("grand",)), checks=(OrderCheck("half_pedal_low", "<", "half_pedal_high"),)),
    Section("body", "soundboard", BodySpec, (
        Field("wet", "float", "share of the soundboard in the output (0: bare strings)", 0.0, 1.0),
        Field("modes", "int", "number of soundboard modes", 1, 1024),
        Field("size", "float", "board size factor (divides all mode frequencies)", 0.25, 4.0),
        Field("brightness", "float", "spectral tilt of the board, dB/octave", -12.0, 12.0),
        Field("seed", "int", "random seed of the mode set (deterministic)", 0, 2 ** 31 - 1),
    ), when=When("voice", ("grand",))),
    Section("output", "what is written to the WAV", OutputSpec, (
        Field("signal", "str", "displacement u(l,t) at the pluck point (m) or bridge force at x=L (N)",
              choices=SIGNALS),
        Field("gain", "float", "linear factor from the signal to WAV full scale (1.0)", 1e-6, 1e9),
    )),
    Section("play", "musical play range", PlaySpec, (
        Field("key_low", "int", "lowest playable MIDI key", 0, 127),
        Field("key_high", "int", "highest playable MIDI key", 0, 127),
        Field("velocity_exponent", "float",
              "amplitude = amplitude_m * (velocity/127)**velocity_exponent", 0.2, 5.0),
        Field("polyphony", "int", "maximum simultaneous voices", 1, 512),
        Field("pitch_bend_semitones", "float", "pitch-bend range, semitones", 0.0, 12.0),
    ), when=When("kind", ("musical",)), checks=(OrderCheck("key_low", "<=", "key_high"),)),
)

_SECTION_BY_NAME = {s.name: s for s in SECTIONS}
_TOP_BY_NAME = {f.name: f for f in SCHEMA_FIELDS}
_TOP_KEYS = tuple(f.name for f in SCHEMA_FIELDS) + tuple(s.name for s in SECTIONS)


def _unique_names(section: Section) -> list[str]:
    seen: list[str] = []
    for f in section.fields:
        if f.name not in seen:
            seen.append(f.name)
    return seen


def _check_schema() -> None:
    """Import-time consistency check of the schema table (programming errors only)."""
    known: list[str] = [f.name for f in SCHEMA_FIELDS]
    for sec in SECTIONS:
        if sec.when is not None and sec.when.key not in known:
            raise AssertionError(f"section {sec.name}: condition on later/unknown key {sec.when.key}")
        names = _unique_names(sec)
        cls_names = [f.name for f in dc_fields(sec.cls)]
        if sorted(names) != sorted(cls_names):
            raise AssertionError(f"section {sec.name}: schema keys {names} != {sec.cls.__name__} {cls_names}")
        for name in names:
            rows = [f for f in sec.fields if f.name == name]
            if len(rows) > 1:
                # Several rows: all conditional on the same key with disjoint values.
                if any(r.when is None for r in rows) or len({r.when.key for r in rows}) != 1:
                    raise AssertionError(f"{sec.name}.{name}: ambiguous rows")
                vals = [v for r in rows for v in r.when.values]
                if len(vals) != len(set(vals)):
                    raise AssertionError(f"{sec.name}.{name}: overlapping conditions")
            for r in rows:
                if r.when is not None and r.when.key not in known:
                    raise AssertionError(f"{sec.name}.{name}: condition on later/unknown key {r.when.key}")
            known.append(f"{sec.name}.{name}")
        for chk in sec.checks:
            if chk.a not in names or chk.b not in names or chk.op not in ("<", "<="):
                raise AssertionError(f"section {sec.name}: bad check {chk}")
    preset_names = [f.name for f in dc_fields(Preset)]
    if preset_names != ["name", "path"] + list(_TOP_KEYS):
        raise AssertionError(f"Preset fields {preset_names} do not follow the schema {_TOP_KEYS}")


_check_schema()


# --------------------------------------------------------------------------
# Formatting helpers
# --------------------------------------------------------------------------


def _fmt_num(x: float) -> str:
    if isinstance(x, int):
        return str(x)
    if float(x).is_integer() and abs(x) < 1e6:
        return str(int(x))
    return format(x, "g")


def _fmt_value(v: Any, limit: int = 60) -> str:
    """TOML-like rendering of a value for messages, shortened to about `limit` chars."""
    if isinstance(v, bool):
        s = "true" if v else "false"
    elif isinstance(v, str):
        s = json.dumps(v, ensure_ascii=False)
    elif isinstance(v, (int, float)):
        s = repr(v)
    elif isinstance(v, (list, tuple)):
        s = "[" + ", ".join(_fmt_value(x, limit) for x in v) + "]"
    elif isinstance(v, Mapping):
        s = "{" + ", ".join(f"{k} = {_fmt_value(x, limit)}" for k, x in v.items()) + "}"
    else:
        s = repr(v)
    if len(s) > limit:
        s = s[: limit - 3] + "..."
    return s


_ABSENT: Any = When("<absent>", ())  # sentinel returned by _Validator.presence

_TYPE_TEXT = {
    "float": "a number",
    "int": "an integer",
    "str": "a string",
    "line": "a string",
    "points": "an array of [x_m, U_m] pairs",
}


# --------------------------------------------------------------------------
# Validation
# --------------------------------------------------------------------------


class _Validator:
    def __init__(self, source: str, overridden: frozenset[str],
                 file_raw: Mapping[str, Any] | None = None):
        self.src = source
        self.overridden = overridden
        self.file_raw = file_raw
        self.ctx: dict[str, Any] = {}
        self.dropped: list[str] = []

    # -- messages ---------------------------------------------------------
    def _origin(self, key: str) -> str:
        return " (from --set)" if key in self.overridden else ""

    def fail(self, msg: str) -> PresetError:
        return PresetError(f"{self.src}: {msg}")

    def _when_text(self, when: When) -> str:
        set_by = ", set by --set" if when.key in self.overridden else ""
        return f"{when.describe()}{set_by}"

    # -- scalar values ----------------------------------------------------
    def value(self, key: str, row: Field, v: Any) -> Any:
        shown = f"{key} = {_fmt_value(v)}{self._origin(key)}"
        t = row.type
        if t == "float":
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise self.fail(f"{shown} has the wrong type (expected {_TYPE_TEXT[t]})")
            v = float(v)
            if not math.isfinite(v):
                raise self.fail(f"{shown} is not a finite number ({row.range_text()})")
        elif t == "int":
            if isinstance(v, bool) or not isinstance(v, int):
                raise self.fail(f"{shown} has the wrong type (expected {_TYPE_TEXT[t]})")
        elif t in ("str", "line"):
            if not isinstance(v, str):
                raise self.fail(f"{shown} has the wrong type (expected {_TYPE_TEXT[t]})")
            if t == "line" and (not v.strip() or "\n" in v or "\r" in v):
                raise self.fail(f"{shown} must be a non-empty single line")
        elif t == "points":
            return self.points(key, v)
        else:  # pragma: no cover - schema error
            raise AssertionError(f"unknown field type {t!r}")
        if row.choices is not None:
            if v not in row.choices:
                allowed = ", ".join(_fmt_value(c) for c in row.choices)
                raise self.fail(f"{shown} is not allowed (choices: {allowed})")
        elif t in ("float", "int") and not row.in_range(v):
            raise self.fail(f"{shown} is out of range ({row.range_text()})")
        return v

    def points(self, key: str, v: Any) -> tuple[tuple[float, float], ...]:
        o = self._origin(key)
        if not isinstance(v, list):
            raise self.fail(f"{key} = {_fmt_value(v)}{o} has the wrong type "
                            f"(expected {_TYPE_TEXT['points']})")
        if len(v) < 2:
            raise self.fail(f"{key} = {_fmt_value(v)}{o} needs at least 2 [x_m, U_m] points")
        out: list[tuple[float, float]] = []
        for i, p in enumerate(v):
            item = f"{key}[{i}] = {_fmt_value(p)}{o}"
            if (not isinstance(p, list) or len(p) != 2
                    or any(isinstance(c, bool) or not isinstance(c, (int, float)) for c in p)):
                raise self.fail(f"{item} is not an [x_m, U_m] pair of numbers")
            x, u = float(p[0]), float(p[1])
            if not (math.isfinite(x) and math.isfinite(u)):
                raise self.fail(f"{item} is not finite")
            if x < 0:
                raise self.fail(f"{item} has x_m < 0 (x_m >= 0 required)")
            if out and x <= out[-1][0]:
                raise self.fail(f"{item} has x_m not strictly increasing "
                                f"(previous x_m = {_fmt_value(out[-1][0])})")
            out.append((x, u))
        return tuple(out)

    # -- tables -----------------------------------------------------------
    def unknown_keys(self, prefix: str, table: Mapping[str, Any], allowed: Sequence[str]) -> None:
        for k in table:
            if k not in allowed:
                dotted = f"{prefix}{k}"
                raise self.fail(f"unknown key '{dotted}'{self._origin(dotted)} "
                                f"(allowed: {', '.join(allowed)})")

    def _overridden_under(self, key: str) -> str | None:
        """The first dotted key given by --set that is `key` itself or inside section `key`."""
        if key in self.overridden:
            return key
        return next((k for k in sorted(self.overridden) if k.startswith(key + ".")), None)

    def _file_value(self, dotted: str) -> Any:
        """Value of `dotted` in the file before the overrides (``_ABSENT`` if not there)."""
        node: Any = self.file_raw
        for part in dotted.split("."):
            if not isinstance(node, Mapping) or part not in node:
                return _ABSENT
            node = node[part]
        return node

    def _droppable(self, key: str, whens: Sequence[When]) -> bool:
        """Whether the forbidden, present `key` is a key of the file left over by a
        --set that changed its discriminator (it is then dropped, not an error).

        True when the discriminator was given by --set, neither `key` nor
        (for a section) any key inside it was, and the file's own value of
        the discriminator allowed `key` (a key the file could not have is
        still the file's error). Without the file (``file_raw`` None) every
        such key counts as coming from the file.
        """
        disc = whens[0].key
        if disc not in self.overridden or self._overridden_under(key) is not None:
            return False
        if self.file_raw is None:
            return True
        fv = self._file_value(disc)
        return fv is not _ABSENT and any(fv in w.values for w in whens)

    def presence(self, key: str, present: bool, whens: Sequence[When | None]) -> When | None:
        """Check presence of `key` whose schema rows have conditions `whens`.

        Returns the condition of the active row (None if unconditional) when
        the key is required and present; raises if it is missing but required
        or present but forbidden; returns the sentinel ``_ABSENT`` when it is
        (correctly) absent, or when it is a key of the file that a --set of
        its discriminator made forbidden (it is then dropped, see
        :meth:`_droppable`, and recorded in ``self.dropped``).
        """
        active = [w for w in whens if w is None or w.holds(self.ctx)]
        if active:
            if not present:
                w = active[0]
                cond = "" if w is None else f" (required when {self._when_text(w)})"
                raise self.fail(f"missing key '{key}'{cond}")
            return active[0]
        if present:
            if self._droppable(key, whens):
                self.dropped.append(key)
                return _ABSENT
            disc = whens[0].key  # rows of one key share their discriminator (_check_schema)
            if len(whens) == 1 and whens[0].also is not None:
                allowed = whens[0].describe()
            else:
                allowed = When(disc, tuple(v for w in whens for v in w.values)).describe()
            actual = _fmt_value(self.ctx[disc]) if disc in self.ctx else "(absent)"
            shown = self._overridden_under(key) or key  # name the --set key inside a section
            raise self.fail(f"key '{shown}'{self._origin(shown)} is not allowed when "
                            f"{disc} = {actual}{self._origin(disc)}, only when {allowed}")
        return _ABSENT

    def run(self, raw: Mapping[str, Any]) -> dict[str, Any]:
        if not isinstance(raw, Mapping):
            raise self.fail("a preset must be a TOML table")
        self.unknown_keys("", raw, _TOP_KEYS)
        out: dict[str, Any] = {}
        for row in SCHEMA_FIELDS:
            if self.presence(row.name, row.name in raw, [row.when]) is not _ABSENT:
                out[row.name] = self.ctx[row.name] = self.value(row.name, row, raw[row.name])
        for sec in SECTIONS:
            if self.presence(sec.name, sec.name in raw, [sec.when]) is _ABSENT:
                out[sec.name] = None
                continue
            table = raw[sec.name]
            if not isinstance(table, Mapping):
                raise self.fail(f"{sec.name} = {_fmt_value(table)}{self._origin(sec.name)} "
                                f"has the wrong type (expected a table [{sec.name}])")
            names = _unique_names(sec)
            self.unknown_keys(f"{sec.name}.", table, names)
            values: dict[str, Any] = {}
            for name in names:
                dotted = f"{sec.name}.{name}"
                rows = [f for f in sec.fields if f.name == name]
                when = self.presence(dotted, name in table, [r.when for r in rows])
                if when is _ABSENT:
                    values[name] = None
                    continue
                row = next(r for r in rows if r.when is when)
                values[name] = self.ctx[dotted] = self.value(dotted, row, table[name])
            for chk in sec.checks:
                a, b = values.get(chk.a), values.get(chk.b)
                if a is None or b is None:
                    continue
                if not (a < b if chk.op == "<" else a <= b):
                    ka, kb = f"{sec.name}.{chk.a}", f"{sec.name}.{chk.b}"
                    word = "less than" if chk.op == "<" else "less than or equal to"
                    raise self.fail(f"{ka} = {_fmt_value(a)}{self._origin(ka)} must be {word} "
                                    f"{kb} = {_fmt_value(b)}{self._origin(kb)}")
            out[sec.name] = sec.cls(**values)
        return out


def validate_dict(raw: Mapping[str, Any], source: str, *, name: str | None = None,
                  overridden: Sequence[str] = (),
                  file_raw: Mapping[str, Any] | None = None) -> Preset:
    """Validate a parsed preset table and build the :class:`Preset`.

    Parameters
    ----------
    raw : mapping
        The TOML document as parsed by :mod:`tomllib` (overrides already applied).
    source : str
        File name (or any label) used at the start of every error message and
        stored as ``Preset.path``.
    name : str, optional
        Preset name; defaults to the stem of ``source``.
    overridden : sequence of str
        Dotted keys whose values came from ``--set``; errors about them say so.
        When one of them is a discriminating key (``kind``, ``pluck.model``,
        ``termination.profile``, ...), the keys and sections *not* given by
        ``--set`` that its new value forbids are dropped instead of being an
        error; forbidden keys given by ``--set`` stay an error.
    file_raw : mapping, optional
        The document before the overrides. With it, only keys the file's own
        value of the discriminator allowed are dropped (a key the file could
        not have had is still reported). None: every key not in `overridden`
        counts as the file's.

    Raises
    ------
    PresetError
        One line: source, dotted key, value and the allowed range or choices.
    """
    v = _Validator(source, frozenset(overridden), file_raw)
    out = v.run(raw)
    if name is None:
        name = Path(source).stem
    return Preset(name=name, path=source, **out)


# --------------------------------------------------------------------------
# Overrides (--set PATH=VALUE)
# --------------------------------------------------------------------------


#: A decimal with a point that TOML rejects (".5", "5.", "-.5e-3", "01.5"); parsed as float.
_LOOSE_FLOAT = re.compile(r"[+-]?(?:\d+\.\d*|\.\d+)(?:[eE][+-]?\d+)?")


def _known_path(path: str) -> bool:
    if path in _TOP_BY_NAME:
        return True
    sec, dot, key = path.partition(".")
    return bool(dot) and sec in _SECTION_BY_NAME and key in _unique_names(_SECTION_BY_NAME[sec])


def parse_override(text: str) -> tuple[str, Any]:
    """Parse one ``--set`` argument ``"PATH=VALUE"`` into ``(dotted_path, value)``.

    VALUE is read as a TOML value (``0.7``, ``3``, ``"capo"``, ``[[0, 0], [0.01, 1e-4]]``,
    ``true``); a decimal TOML rejects but Python reads (``.5``, ``-.5``,
    ``5.``, ``007.5``) is a float; other text that is not valid TOML is
    taken as a plain string, so ``termination.profile=capo`` works without
    quotes. PATH must be a key of
    the schema (``kind``, ``pluck.position``, ...).

    Raises
    ------
    PresetError
        Missing ``=`` or a PATH that is not a key of the schema.
    """
    path, eq, value_text = text.partition("=")
    path = path.strip()
    if not eq or not path:
        raise PresetError(f"--set {text!r}: expected PATH=VALUE, e.g. pluck.position=0.7")
    if not _known_path(path):
        if path in _SECTION_BY_NAME:
            keys = ", ".join(f"{path}.{k}" for k in _unique_names(_SECTION_BY_NAME[path]))
            raise PresetError(f"--set {text!r}: '{path}' is a section; set one of its keys ({keys})")
        sec, dot, _ = path.partition(".")
        if dot and sec in _SECTION_BY_NAME:
            allowed = ", ".join(_unique_names(_SECTION_BY_NAME[sec]))
        else:
            allowed = ", ".join(_TOP_KEYS)
        raise PresetError(f"--set {text!r}: unknown key '{path}' (allowed: {allowed})")
    try:
        value = tomllib.loads(f"v = {value_text}")["v"]
    except tomllib.TOMLDecodeError:
        value = value_text.strip()
        if _LOOSE_FLOAT.fullmatch(value):
            value = float(value)  # ".5", "-.5", "5.", "1.e-3": decimals TOML rejects
    return path, value


def _apply_overrides(raw: dict[str, Any], overrides: Sequence[str], source: str
                     ) -> tuple[dict[str, Any], list[str]]:
    raw = copy.deepcopy(raw)
    keys: list[str] = []
    for text in overrides:
        path, value = parse_override(text)
        if "." in path:
            sec, _, key = path.partition(".")
            table = raw.setdefault(sec, {})
            if not isinstance(table, dict):
                raise PresetError(f"{source}: --set {text!r}: '{sec}' in the file is not a table")
            table[key] = value
        else:
            raw[path] = value
        keys.append(path)
    return raw, keys


# --------------------------------------------------------------------------
# Finding and loading presets
# --------------------------------------------------------------------------


def shipped_preset_dir() -> Path:
    """The presets shipped with the package: ``synth/presets`` (package data).

    Found through :mod:`importlib.resources`, so it is the installed package's
    directory for editable, non-editable and wheel installs alike (see the
    module notes). If the package is not on the file system (a zip import),
    the returned path does not exist and no shipped preset is found.
    """
    res = importlib.resources.files("synth").joinpath("presets")
    if isinstance(res, Path):
        return res
    return Path(str(res))  # not a real directory: callers skip it


def preset_dirs() -> list[Path]:
    """Directories searched for presets, in priority order.

    The entries of ``$SYNTH_PRESET_PATH`` (``os.pathsep``-separated, empty
    entries ignored) come first, then the shipped presets
    (:func:`shipped_preset_dir`). Directories that do not exist are included
    (callers skip them).
    """
    dirs: list[Path] = []
    for entry in os.environ.get(ENV_PRESET_PATH, "").split(os.pathsep):
        if entry.strip():
            dirs.append(Path(entry).expanduser())
    dirs.append(shipped_preset_dir())
    unique: list[Path] = []
    seen: set[Path] = set()
    for d in dirs:
        key = d.resolve()
        if key not in seen:
            seen.add(key)
            unique.append(d)
    return unique


def _scan() -> dict[str, Path]:
    """Map preset name -> file; an earlier directory wins over a later one."""
    found: dict[str, Path] = {}
    for d in preset_dirs():
        if not d.is_dir():
            continue
        for f in sorted(d.rglob("*.toml")):
            if not f.is_file():
                continue
            name = f.relative_to(d).with_suffix("").as_posix()
            found.setdefault(name, f)
    return found


def _read_toml(path: Path, shown: str) -> dict[str, Any]:
    try:
        data = path.read_bytes()
    except OSError as e:
        raise PresetError(f"{shown}: cannot read preset file ({e.strerror or e})") from None
    try:
        return tomllib.loads(data.decode("utf-8"))
    except UnicodeDecodeError as e:
        raise PresetError(f"{shown}: not UTF-8 text (byte {e.start})") from None
    except tomllib.TOMLDecodeError as e:
        raise PresetError(f"{shown}: invalid TOML: {str(e).splitlines()[0]}") from None


def list_presets() -> list[tuple[str, str]]:
    """All presets found in :func:`preset_dirs` as sorted ``(name, description)``.

    A file that cannot be parsed is listed with the description
    ``"(invalid: <reason>)"`` instead of failing the whole listing.
    """
    out: list[tuple[str, str]] = []
    for name, path in sorted(_scan().items()):
        try:
            raw = _read_toml(path, _display_path(path))
            desc = raw.get("description")
            if not isinstance(desc, str) or not desc.strip():
                desc = "(invalid: no description)"
        except PresetError as e:
            desc = f"(invalid: {e})"
        out.append((name, desc.strip()))
    return out


def _name_for_path(path: Path) -> str:
    rp = path.resolve()
    for d in preset_dirs():
        try:
            return rp.relative_to(d.resolve()).with_suffix("").as_posix()
        except ValueError:
            continue
    return path.stem


def load_preset(name_or_path: str | os.PathLike, overrides: Sequence[str] = ()) -> Preset:
    """Load, override and validate a preset.

    Parameters
    ----------
    name_or_path : str or path
        A preset name (``"sitar"``, ``"paper/sitar-case1"``) looked up in
        :func:`preset_dirs`, or a path to a ``.toml`` file (anything ending in
        ``.toml`` is taken as a path).
    overrides : sequence of str
        ``"PATH=VALUE"`` strings from the CLI's repeatable ``--set`` (see
        :func:`parse_override`), applied in order to the parsed file *before*
        validation, so they are checked exactly like the file; errors about
        such keys say ``(from --set)``. A ``--set`` may add a key the file
        lacks (e.g. ``pluck.alpha_per_s`` when switching ``pluck.model`` to
        ``biwa``, or a whole section when switching ``kind``). When a
        ``--set`` changes a discriminating key (``kind``, ``pluck.model``,
        ``termination.profile``), the keys of the file that the new value
        forbids are dropped (``--set termination.profile=none`` on a jawari
        preset gives the ideal string; ``--set termination.profile=capo
        --set termination.radius_m=0.015`` keeps the file's ``side`` and
        ``region_points`` and drops the jawari parameters); keys the new
        value requires and the file lacks must be given with further
        ``--set``. A forbidden key given by ``--set`` itself is an error.

    Returns
    -------
    Preset

    Raises
    ------
    PresetError
        Unknown name (the message lists the available names), missing or
        unreadable file, invalid TOML, bad ``--set``, or a schema violation.
    """
    text = os.fspath(name_or_path)
    if text.endswith(".toml"):
        path = Path(text)
        shown = _display_path(path)
        if not path.is_file():
            raise PresetError(f"{shown}: preset file not found")
        name = _name_for_path(path)
    else:
        found = _scan()
        if text not in found:
            names = sorted(found)
            close = difflib.get_close_matches(text, names, n=1)
            hint = f"; did you mean '{close[0]}'?" if close else ""
            avail = ", ".join(names) if names else (
                "none found in " + os.pathsep.join(str(d) for d in preset_dirs()))
            raise PresetError(f"unknown preset '{text}'{hint} (available: {avail})")
        path = found[text]
        shown = _display_path(path)
        name = text
    raw = _read_toml(path, shown)
    file_raw = raw
    raw, keys = _apply_overrides(raw, overrides, shown)
    preset = validate_dict(raw, shown, name=name, overridden=keys, file_raw=file_raw)
    return dataclasses.replace(preset, path=str(path.resolve()))
