"""Every schema section and every termination profile, exercised on real presets.

The lists of sections and profiles come from the schema itself
(``SECTIONS``, ``PROFILES``), so a section or profile added without a
shipped preset (or an entry in ``EXTRA_DOCS``) that carries it, or without
a row in ``OUT_OF_RANGE``, makes these tests fail. For each section: the
preset's dataclass carries the file's values with the schema's types, an
out-of-range value of each of its ranged keys is a one-line PresetError
naming the dotted key, the value and the allowed range, and the section is
rejected where its condition (voice/kind) forbids it, or reported missing
where it is required.
"""

from __future__ import annotations

import copy
import re
import tomllib
from pathlib import Path

import pytest

from synth.io.errors import PresetError
from synth.io.presets import (
    PROFILES,
    SCHEMA_FIELDS,
    SECTIONS,
    Preset,
    load_preset,
    shipped_preset_dir,
    validate_dict,
)

SECTION_BY_NAME = {s.name: s for s in SECTIONS}
SECTION_NAMES = [s.name for s in SECTIONS]

# The shipped presets, by name, read straight from the package data.
_ROOT = shipped_preset_dir()
SHIPPED: dict[str, Path] = {
    p.relative_to(_ROOT).with_suffix("").as_posix(): p for p in sorted(_ROOT.rglob("*.toml"))
    if p.relative_to(_ROOT).parts[0] not in ("checks", "batch")}   # synth check and batch specs
DOCS: dict[str, dict] = {n: tomllib.loads(p.read_text("utf-8")) for n, p in SHIPPED.items()}

# Documents for what no shipped preset carries (validated with validate_dict).
EXTRA_DOCS: dict[str, dict] = {
    "extra/sitar-table": {
        "schema": 1,
        "description": "Sitar string on a tabulated obstacle",
        "kind": "musical",
        "voice": "plucked",
        # tension_n an integer: a float key must come out as float
        "string": {"length_m": 0.8, "tension_n": 38, "linear_density_kg_per_m": 0.000375},
        "pluck": {"model": "sitar", "position": 0.75, "amplitude_m": 0.01, "duration_s": 0.004},
        "termination": {"profile": "table", "side": 1, "region_points": 20,
                        "points": [[0, 0.0], [0.005, 1e-4], [0.01, 3e-4]]},
        "loss": {"t60_low_s": 7.0, "f_low_hz": 200.0, "t60_high_s": 1.2, "f_high_hz": 6000.0,
                 "release_t60_s": 0.35},
        "output": {"signal": "bridge_force", "gain": 0.2},
        "play": {"key_low": 43, "key_high": 74, "velocity_exponent": 1.0, "polyphony": 16,
                 "pitch_bend_semitones": 2.0},
    },
    # the open jawari of docs/voicing.md ("How the buzz is made"), with every optional key
    "extra/sitar-open-jawari": {
        "schema": 1,
        "description": "Sitar string grazing an open jawari, stiff steel",
        "kind": "musical",
        "voice": "plucked",
        "string": {"length_m": 0.8, "tension_n": 38.4, "linear_density_kg_per_m": 0.000375,
                   "inharmonicity": 1.5e-5},
        "pluck": {"model": "sitar", "position": 0.75, "amplitude_m": 0.01, "duration_s": 0.004},
        "termination": {"profile": "jawari", "side": 1, "region_points": 48, "radius_m": 0.5,
                        "extent_m": 0.02, "thread_m": 0.0004, "buzz": 1.0,
                        "pitch_rise_cents": 2.8, "pitch_rise_tau_s": 1.0},
        "loss": {"t60_low_s": 7.0, "f_low_hz": 200.0, "t60_high_s": 1.2, "f_high_hz": 6000.0,
                 "release_t60_s": 0.35},
        "output": {"signal": "bridge_force", "gain": 0.2},
        "play": {"key_low": 43, "key_high": 74, "velocity_exponent": 1.0, "polyphony": 16,
                 "pitch_bend_semitones": 2.0, "buzz_cc": 1},
    },
}
# the drone player (synth.engine.drone) on the open-jawari string, every key given
EXTRA_DOCS["extra/sitar-drone"] = {
    **EXTRA_DOCS["extra/sitar-open-jawari"],
    "description": "Sitar string plucked by the drone player",
    "drone": {"player": "on", "pattern": "Ma Sa Sa Sa", "cycle_s": 5, "onsets": [0, 0.25, 0.5, 0.7],
              "velocity": 0.5, "timing_jitter_s": 0.01, "force_jitter_db": 1.0, "seed": 3,
              "tempo_cc": 20, "pattern_cc": 21},
}
ALL_DOCS: dict[str, dict] = {**DOCS, **EXTRA_DOCS}

# One hand-written out-of-range case per section: (document, key, value, allowed range).
OUT_OF_RANGE = {
    "string": ("sitar", "tension_n", 6000.0, "1 <= value <= 5000"),
    "grid": ("paper/sitar-case1", "cells", 10, "20 <= value <= 100000"),
    "pluck": ("biwa", "position", 1.5, "0 < value < 1"),
    "hammer": ("paper/piano-a7-capo", "exponent", 7.0, "1 <= value <= 6"),
    "termination": ("sitar", "region_points", 0, "1 <= value <= 2000"),
    "loss": ("biwa", "f_high_hz", 30000.0, "200 <= value <= 20000"),
    "tuning": ("grand-piano", "a4_hz", 500.0, "380 <= value <= 480"),
    "action": ("grand-piano", "soft_stiffness", 0.05, "0.1 <= value <= 1"),
    "strings": ("grand-piano", "dispersion_sections", 17, "0 <= value <= 16"),
    "dampers": ("grand-piano", "half_pedal_high", 1.5, "0 <= value <= 1"),
    "quality_error": ("biwa", "draft_db", -1.0, "0 <= value <= 100"),
    "body": ("grand-piano", "modes", 0, "1 <= value <= 1024"),
    "output": ("grand-piano", "gain", 0.0, "1e-06 <= value <= 1e+09"),
    "listener": ("grand-piano", "distance_m", 80.0, "0.1 <= value <= 50"),
    "play": ("sitar", "key_high", 128, "0 <= value <= 127"),
    "taraf": ("sitar", "coupling", 9, "0 <= value <= 4"),
    "chikari": ("sitar", "strum_s", 0.5, "0 <= value <= 0.1"),
    "drone": ("extra/sitar-drone", "cycle_s", 20.0, "1 <= value <= 16"),
    "bridge": ("tanpura", "resistance_ns_per_m", 0.5, "1 <= value <= 100000"),
}


def source(doc: str) -> str:
    return f"synth/presets/{doc}.toml"


def build(doc: str) -> Preset:
    """The preset of a document: shipped ones through the loader (by path, so
    $SYNTH_PRESET_PATH cannot shadow them), extra ones through validate_dict."""
    if doc in SHIPPED:
        return load_preset(str(SHIPPED[doc]))
    return validate_dict(EXTRA_DOCS[doc], source(doc))


def rejected(raw: dict, doc: str) -> str:
    """The message of the PresetError that validating `raw` raises; it must be one line."""
    with pytest.raises(PresetError) as info:
        validate_dict(raw, source(doc))
    msg = str(info.value)
    assert "\n" not in msg and msg.startswith(f"{source(doc)}: "), msg
    return msg


def context(preset: Preset) -> dict:
    """Validated dotted keys of a preset, as the schema's When conditions see them."""
    ctx = {f.name: getattr(preset, f.name) for f in SCHEMA_FIELDS}
    for sec in SECTIONS:
        spec = getattr(preset, sec.name)
        if spec is None:
            continue
        for f in sec.fields:
            if getattr(spec, f.name) is not None:
                ctx[f"{sec.name}.{f.name}"] = getattr(spec, f.name)
    return ctx


def active_rows(sec, ctx: dict) -> dict:
    """Key name -> the row of `sec` that applies under `ctx` (keys with none are absent)."""
    return {f.name: f for f in sec.fields if f.when is None or f.when.holds(ctx)}


def carrier(section: str) -> str:
    for doc, raw in ALL_DOCS.items():
        if section in raw:
            return doc
    pytest.fail(f"no shipped preset or EXTRA_DOCS entry has a [{section}] table: add one")


_RANGE = re.compile(r"(?:(?P<lo>\S+) (?P<lop><=?) )?value(?: (?P<hop>[<>]=?) (?P<hi>\S+))?")


def satisfies(value: float, range_text: str) -> bool:
    """Evaluate a message's range text ("0 < value < 1", "value >= 1") at `value`."""
    m = _RANGE.fullmatch(range_text)
    assert m, f"not a range: {range_text!r}"
    ok = True
    if m["lo"] is not None:
        lo = float(m["lo"])
        ok &= lo < value if m["lop"] == "<" else lo <= value
    if m["hi"] is not None:
        ops = {"<": value < float(m["hi"]), "<=": value <= float(m["hi"]),
               ">": value > float(m["hi"]), ">=": value >= float(m["hi"])}
        ok &= ops[m["hop"]]
    return ok


def outside(row) -> list:
    """Values just outside the row's range, below and/or above it."""
    step = (lambda b: 1) if row.type == "int" else (lambda b: max(1.0, abs(b)))
    conv = int if row.type == "int" else float
    vals = []
    if row.lo is not None:
        vals.append(conv(row.lo - step(row.lo)))
    if row.hi is not None:
        vals.append(conv(row.hi + step(row.hi)))
    return vals


TYPES = {"float": float, "int": int, "str": str, "line": str}


def check_values(doc: str, section: str) -> None:
    """The section's dataclass holds exactly the file's keys, with the schema's types."""
    sec = SECTION_BY_NAME[section]
    table = ALL_DOCS[doc][section]
    preset = build(doc)
    spec = getattr(preset, section)
    assert type(spec) is sec.cls
    rows = active_rows(sec, context(preset))
    # an optional key (a row with a default, or optional: None) the file leaves out
    optional = {n for n, r in rows.items()
                if (r.default is not None or r.optional) and n not in table}
    assert set(rows) - optional == set(table), f"{doc}: [{section}] keys vs the schema's active rows"
    for name, row in rows.items():
        if name in optional:
            assert getattr(spec, name) == row.default, f"{section}.{name} takes its default"
            continue
        got, want = getattr(spec, name), table[name]
        if row.type == "points":
            assert got == tuple((float(x), float(u)) for x, u in want)
            assert all(type(c) is float for p in got for c in p)
        elif row.type == "keys":
            assert got == tuple(want) and all(type(k) is int for k in got)
        elif row.type == "ascending":
            assert got == tuple(float(x) for x in want) and all(type(x) is float for x in got)
        elif row.type == "peaks":
            assert got == tuple(tuple(float(c) for c in p) for p in want)
            assert all(type(c) is float for p in got for c in p)
        else:
            assert type(got) is TYPES[row.type], f"{section}.{name} = {got!r}"
            assert got == want, f"{section}.{name}"
    for f in sec.fields:
        if f.name not in rows:
            assert getattr(spec, f.name) is None, f"{section}.{f.name} absent in the file"


def check_out_of_range(doc: str, section: str) -> int:
    """Every active ranged key of the section, pushed out of its range, is rejected
    with a message naming the key, the value and a range the file's value is in."""
    sec = SECTION_BY_NAME[section]
    rows = active_rows(sec, context(build(doc)))
    checked = 0
    for name, row in rows.items():
        if row.type not in ("float", "int") or row.choices is not None:
            continue
        if name not in ALL_DOCS[doc][section]:
            # an optional key the file leaves out: pushed out of range from its default
            # (or, a key that may be left out without one, from inside its range)
            assert row.default is not None or row.optional, f"{section}.{name}"
        good = ALL_DOCS[doc][section].get(name, row.default)
        if good is None:
            good = row.lo if row.lo is not None else row.hi
        for bad in outside(row):
            raw = copy.deepcopy(ALL_DOCS[doc])
            raw[section][name] = bad
            msg = rejected(raw, doc)
            head = f"{source(doc)}: {section}.{name} = {bad!r} is out of range ("
            assert msg.startswith(head) and msg.endswith(")"), msg
            text = msg[len(head):-1]
            assert satisfies(good, text) and not satisfies(bad, text), msg
            checked += 1
    return checked


# --------------------------------------------------------------------------
# Coverage: derived from the schema, so a new section or profile must be added here
# --------------------------------------------------------------------------


def test_every_section_is_carried_by_a_document_and_has_a_range_case():
    carried = {s for raw in ALL_DOCS.values() for s in raw if isinstance(raw[s], dict)}
    assert carried == set(SECTION_NAMES)
    assert set(OUT_OF_RANGE) == set(SECTION_NAMES)


def test_every_profile_is_carried_by_a_document():
    carried = {raw["termination"]["profile"] for raw in ALL_DOCS.values() if "termination" in raw}
    assert carried == set(PROFILES)


# --------------------------------------------------------------------------
# Per section
# --------------------------------------------------------------------------


@pytest.mark.parametrize("section", SECTION_NAMES)
def test_section_carries_the_file_values_with_their_types(section):
    docs = [d for d, raw in ALL_DOCS.items() if section in raw]
    assert docs, f"no document has [{section}]"
    for doc in docs:
        check_values(doc, section)


@pytest.mark.parametrize("section", SECTION_NAMES)
def test_section_out_of_range_value_is_one_line_naming_key_value_and_range(section):
    assert section in OUT_OF_RANGE, f"add a hand-written case for [{section}] to OUT_OF_RANGE"
    doc, key, bad, allowed = OUT_OF_RANGE[section]
    raw = copy.deepcopy(ALL_DOCS[doc])
    raw[section][key] = bad
    assert rejected(raw, doc) == (
        f"{source(doc)}: {section}.{key} = {bad!r} is out of range ({allowed})")
    assert check_out_of_range(carrier(section), section) > 0


@pytest.mark.parametrize("section", SECTION_NAMES)
def test_section_is_forbidden_or_required_as_its_condition_says(section):
    sec = SECTION_BY_NAME[section]
    home = carrier(section)
    table = ALL_DOCS[home][section]
    if sec.when is None:
        # Always required: every document has it and dropping it is an error.
        for doc, raw in ALL_DOCS.items():
            assert section in raw, doc
        raw = copy.deepcopy(ALL_DOCS[home])
        del raw[section]
        assert rejected(raw, home) == f"{source(home)}: missing key '{section}'"
        return
    raw = copy.deepcopy(ALL_DOCS[home])
    del raw[section]
    if sec.optional:
        # optional where its condition holds: absent, it is None (and a
        # section that needs it goes with it)
        for other in SECTIONS:
            if other.requires == section:
                raw.pop(other.name, None)
        assert getattr(validate_dict(raw, source(home)), section) is None
    else:
        # required where its condition holds ...
        assert rejected(raw, home).startswith(
            f"{source(home)}: missing key '{section}' (required when {sec.when.key}")
    # ... and forbidden in every document where it does not.
    others = [d for d in ALL_DOCS if not sec.when.holds(context(build(d)))]
    assert others, f"[{section}] is allowed in every document: nothing to reject"
    for doc in others:
        assert section not in ALL_DOCS[doc]
        raw = copy.deepcopy(ALL_DOCS[doc])
        raw[section] = copy.deepcopy(table)
        disc = sec.when.key
        actual = context(build(doc)).get(disc)
        shown = f'"{actual}"' if isinstance(actual, str) else repr(actual)
        msg = rejected(raw, doc)
        assert msg.startswith(f"{source(doc)}: key '{section}' is not allowed when {disc} = "
                              f"{shown}, only when "), msg


def test_hammer_in_a_plucked_preset_is_rejected():
    raw = copy.deepcopy(DOCS["sitar"])
    raw["hammer"] = copy.deepcopy(DOCS["paper/piano-a7-capo"]["hammer"])
    assert rejected(raw, "sitar") == (
        f"{source('sitar')}: key 'hammer' is not allowed when voice = \"plucked\", "
        "only when voice = \"piano\"")


def test_tuning_in_a_sitar_preset_is_rejected():
    raw = copy.deepcopy(DOCS["sitar"])
    raw["tuning"] = {"a4_hz": 440.0, "stretch": 1.0}
    assert rejected(raw, "sitar") == (
        f"{source('sitar')}: key 'tuning' is not allowed when voice = \"plucked\", "
        "only when voice is one of \"grand\", \"harpsichord\"")


# --------------------------------------------------------------------------
# Per termination profile
# --------------------------------------------------------------------------


@pytest.mark.parametrize("profile", PROFILES)
def test_termination_profile(profile):
    sec = SECTION_BY_NAME["termination"]
    docs = [d for d, raw in ALL_DOCS.items()
            if raw.get("termination", {}).get("profile") == profile]
    assert docs, f"no document uses termination.profile = {profile!r}"
    doc = docs[0]
    check_values(doc, "termination")
    assert build(doc).termination.profile == profile
    check_out_of_range(doc, "termination")
    # A key of the section that this profile does not use is rejected.
    ctx = context(build(doc))
    unused = [f.name for f in sec.fields if f.name not in active_rows(sec, ctx)]
    assert unused, profile
    donors = {k: t[k] for raw in ALL_DOCS.values() for t in [raw.get("termination", {})]
              for k in t}
    tried = 0
    for name in dict.fromkeys(unused):
        if name not in donors:
            continue
        raw = copy.deepcopy(ALL_DOCS[doc])
        raw["termination"][name] = donors[name]
        msg = rejected(raw, doc)
        assert msg.startswith(
            f"{source(doc)}: key 'termination.{name}' is not allowed when "
            f"termination.profile = \"{profile}\", only when termination.profile "), msg
        allowing = {v for f in sec.fields if f.name == name for v in f.when.values}
        assert profile not in allowing
        assert all(f'"{p}"' in msg.split("only when", 1)[1] for p in allowing), msg
        tried += 1
    assert tried, f"no unused termination key of profile {profile!r} was tried"
