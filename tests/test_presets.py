"""Tests of synth.io.presets: the schema of /tmp/schema.md, its error messages, --set, lookup."""

from __future__ import annotations

import copy
import dataclasses
import glob
import importlib.resources
import math
import os
import tomllib
from pathlib import Path

import pytest

import synth
from synth.io import presets as P
from synth.io.errors import PresetError, SynthError
from synth.io.presets import (
    Preset,
    list_presets,
    load_preset,
    parse_override,
    preset_dirs,
    validate_dict,
)

SRC = "synth/presets/sitar.toml"


def musical() -> dict:
    return {
        "schema": 1,
        "description": "Sitar with a case-1 jawari",
        "kind": "musical",
        "voice": "plucked",
        "string": {"length_m": 0.9, "tension_n": 100, "linear_density_kg_per_m": 5e-4},
        "pluck": {"model": "sitar", "position": 0.75, "amplitude_m": 1e-3, "duration_s": 1e-3},
        "termination": {"profile": "jawari-case1", "side": -1, "region_points": 20,
                        "slope": 0.01, "x_c_m": 0.005},
        "loss": {"t60_low_s": 5.0, "f_low_hz": 100.0, "t60_high_s": 1.0, "f_high_hz": 5000.0,
                 "release_t60_s": 0.2},
        "output": {"signal": "displacement", "gain": 300.0},
        "play": {"key_low": 40, "key_high": 80, "velocity_exponent": 1.0, "polyphony": 8,
                 "pitch_bend_semitones": 2.0},
    }


def study() -> dict:
    d = musical()
    d["kind"] = "study"
    del d["loss"], d["play"]
    d["grid"] = {"cells": 1000}
    d["pluck"] = {"model": "biwa", "position": 0.75, "amplitude_m": 1e-3, "duration_s": 1e-3,
                  "alpha_per_s": 1000.0}
    return d


PROFILE_PARAMS = {
    "none": {},
    "capo": {"radius_m": 0.01},
    "sawari": {"radius_m": 1.0, "extent_m": 0.01},
    "jawari-case1": {"slope": 0.01, "x_c_m": 0.005},
    "jawari-case2": {"slope": 0.01, "x_b_m": 0.005, "radius_m": 0.1},
    "jawari-case3": {"slope": 0.01, "x_a_m": 0.002, "x_b_m": 0.005, "radius_m": 0.1,
                     "step_m": 1e-4},
    "table": {"points": [[0.0, 0.0], [0.01, -1e-4], [0.02, -5e-4]]},
}


def with_profile(profile: str) -> dict:
    d = musical()
    t = {"profile": profile}
    if profile != "none":
        t.update(side=1, region_points=10)
    t.update(copy.deepcopy(PROFILE_PARAMS[profile]))
    d["termination"] = t
    return d


def error_of(raw: dict, source: str = SRC, **kw) -> str:
    with pytest.raises(PresetError) as ei:
        validate_dict(raw, source, **kw)
    msg = str(ei.value)
    assert "\n" not in msg
    assert msg.startswith(f"{source}: ")
    return msg


# --------------------------------------------------------------------------
# Valid presets
# --------------------------------------------------------------------------


def test_valid_musical_builds_typed_frozen_hashable_preset():
    p = validate_dict(musical(), SRC)
    assert isinstance(p, Preset)
    assert p.name == "sitar" and p.path == SRC
    assert p.grid is None and p.loss is not None and p.play is not None
    # An int in the file is a float in the result; an absent key is None.
    assert p.string.tension_n == 100.0 and isinstance(p.string.tension_n, float)
    assert isinstance(p.play.key_low, int) and isinstance(p.termination.side, int)
    assert p.pluck.alpha_per_s is None and p.termination.radius_m is None
    assert hash(p) == hash(validate_dict(musical(), SRC))
    assert p == validate_dict(musical(), SRC)
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.pluck.position = 0.5  # type: ignore[misc]


def test_valid_study_has_grid_and_no_loss_or_play():
    p = validate_dict(study(), "x.toml")
    assert p.kind == "study" and p.grid.cells == 1000
    assert p.loss is None and p.play is None
    assert p.pluck.model == "biwa" and p.pluck.alpha_per_s == 1000.0


@pytest.mark.parametrize("profile", sorted(PROFILE_PARAMS))
def test_every_profile_with_its_parameters_is_valid(profile):
    p = validate_dict(with_profile(profile), SRC)
    t = p.termination
    assert t.profile == profile
    for name in ("radius_m", "extent_m", "slope", "x_c_m", "x_a_m", "x_b_m", "step_m", "points"):
        assert (getattr(t, name) is not None) == (name in PROFILE_PARAMS[profile])
    if profile == "none":
        assert t.side is None and t.region_points is None
    if profile == "table":
        assert t.points == ((0.0, 0.0), (0.01, -1e-4), (0.02, -5e-4))
        assert all(isinstance(c, float) for pt in t.points for c in pt)
        hash(t)


# --------------------------------------------------------------------------
# The schema table implements /tmp/schema.md (ranges copied from the spec)
# --------------------------------------------------------------------------

SPEC_RANGES = {  # dotted key (profile-qualified where rows differ) -> (lo, hi)
    "string.length_m": (0.01, 3.0),
    "string.tension_n": (1, 5000),
    "string.linear_density_kg_per_m": (1e-5, 0.1),
    "grid.cells": (20, 100000),
    "pluck.amplitude_m": (1e-6, 0.05),
    "pluck.duration_s": (1e-4, 0.05),
    "pluck.alpha_per_s": (1, 1e6),
    "termination.region_points": (1, 2000),
    "capo:radius_m": (0.0005, 10),
    "sawari:radius_m": (0.01, 100),
    "sawari:extent_m": (1e-4, 0.2),
    "jawari-case1:slope": (0, 0.2),
    "jawari-case1:x_c_m": (1e-4, 0.2),
    "jawari-case2:x_b_m": (1e-4, 0.2),
    "jawari-case2:radius_m": (1e-4, 10),
    "jawari-case3:step_m": (0, 0.01),
    "loss.t60_low_s": (0.01, 120),
    "loss.f_low_hz": (10, 2000),
    "loss.t60_high_s": (0.005, 120),
    "loss.f_high_hz": (200, 20000),
    "loss.release_t60_s": (0.005, 10),
    "output.gain": (1e-6, 1e9),
    "play.key_low": (0, 127),
    "play.key_high": (0, 127),
    "play.velocity_exponent": (0.2, 5),
    "play.polyphony": (1, 512),
    "play.pitch_bend_semitones": (0, 12),
}


def _base_for(key: str) -> tuple[dict, str, str]:
    """A valid dict in which `key` is present, plus its section and name."""
    if ":" in key:
        profile, name = key.split(":")
        return with_profile(profile), "termination", name
    sec, name = key.split(".")
    if sec == "grid":
        return study(), sec, name
    if name == "alpha_per_s":
        return study(), sec, name
    return musical(), sec, name


@pytest.mark.parametrize("key", sorted(SPEC_RANGES))
def test_spec_ranges_inclusive_bounds(key):
    lo, hi = SPEC_RANGES[key]
    d, sec, name = _base_for(key)
    is_int = isinstance(d[sec][name], int) and name not in ("tension_n",)
    # keep cross-key constraints satisfied while probing one bound
    if sec == "play":
        d["play"].update(key_low=0, key_high=127)
    if sec == "loss":
        d["loss"].update(t60_low_s=120.0, t60_high_s=0.005, f_low_hz=10.0, f_high_hz=20000.0)
    for v in (lo, hi):
        dd = copy.deepcopy(d)
        dd[sec][name] = int(v) if is_int else float(v)
        if sec == "loss" and name in ("t60_low_s", "t60_high_s"):
            dd["loss"]["t60_low_s"] = max(dd["loss"]["t60_low_s"], dd["loss"]["t60_high_s"])
        if sec == "loss" and name in ("f_low_hz", "f_high_hz"):
            dd["loss"]["f_low_hz"], dd["loss"]["f_high_hz"] = (
                (float(v), 20000.0) if name == "f_low_hz" else (10.0, float(v)))
        validate_dict(dd, SRC)  # both bounds are accepted
    step = 1 if is_int else max(abs(hi), abs(lo), 1e-12) * 1e-9
    for v, side in ((lo - step, "below"), (hi + step, "above")):
        dd = copy.deepcopy(d)
        dd[sec][name] = v
        msg = error_of(dd)
        assert f"{sec}.{name} = " in msg and "is out of range" in msg, (side, msg)


@pytest.mark.parametrize("key,value", [
    ("pluck.position", 0.0), ("pluck.position", 1.0), ("pluck.position", 1.5),
    ("pluck.position", -0.1),
])
def test_exclusive_bounds_of_position(key, value):
    d = musical()
    d["pluck"]["position"] = value
    assert error_of(d) == f"{SRC}: pluck.position = {value!r} is out of range (0 < value < 1)"


def test_position_just_inside_is_fine():
    for v in (1e-9, 1 - 1e-9):
        d = musical()
        d["pluck"]["position"] = v
        assert validate_dict(d, SRC).pluck.position == v


# --------------------------------------------------------------------------
# Messages in the exact style of the schema
# --------------------------------------------------------------------------


def test_message_examples_of_the_schema():
    d = musical()
    d["pluck"]["position"] = 1.5
    assert error_of(d) == "synth/presets/sitar.toml: pluck.position = 1.5 is out of range (0 < value < 1)"
    d = musical()
    d["pluck"]["positon"] = 0.5
    assert error_of(d) == ("synth/presets/sitar.toml: unknown key 'pluck.positon' "
                           "(allowed: model, position, amplitude_m, duration_s, alpha_per_s, "
                           "bachi_impulse_ns, bachi_duration_s)")
    d = musical()
    del d["string"]["tension_n"]
    assert error_of(d) == "synth/presets/sitar.toml: missing key 'string.tension_n'"


def test_unknown_top_level_key_and_section():
    d = musical()
    d["strng"] = {}
    msg = error_of(d)
    assert "unknown key 'strng'" in msg and "string" in msg and "termination" in msg


@pytest.mark.parametrize("make", [musical, study])
def test_every_required_key_missing_is_named(make):
    base = make()
    for top in list(base):
        d = make()
        del d[top]
        assert error_of(d).endswith(f"missing key '{top}'") or \
            f"missing key '{top}' (required when" in error_of(d)
        if isinstance(base[top], dict):
            for k in base[top]:
                if top == "termination" and k == "profile":
                    continue
                d = make()
                del d[top][k]
                assert f"missing key '{top}.{k}'" in error_of(d)


@pytest.mark.parametrize("bad", [True, "0.7", [0.7], {"a": 1}])
def test_wrong_type_for_float(bad):
    d = musical()
    d["pluck"]["position"] = bad
    msg = error_of(d)
    assert "pluck.position = " in msg and "wrong type (expected a number)" in msg


@pytest.mark.parametrize("key,bad", [("cells", 1000.0), ("cells", True), ("cells", "1000")])
def test_wrong_type_for_int(key, bad):
    d = study()
    d["grid"][key] = bad
    assert "wrong type (expected an integer)" in error_of(d)


@pytest.mark.parametrize("bad", [math.inf, -math.inf, math.nan])
def test_non_finite_float_rejected(bad):
    d = musical()
    d["output"]["gain"] = bad
    assert "output.gain" in error_of(d) and "finite" in error_of(d)


@pytest.mark.parametrize("key,bad", [
    ("kind", "toy"), ("voice", "organ"), ("schema", 2), ("schema", 0),
])
def test_top_level_choices(key, bad):
    d = musical()
    d[key] = bad
    msg = error_of(d)
    assert f"{key} = " in msg and "is not allowed (choices:" in msg


def test_schema_must_be_int_not_float_or_bool():
    for bad in (1.0, True):
        d = musical()
        d["schema"] = bad
        assert "wrong type" in error_of(d)


@pytest.mark.parametrize("bad", ["", "   ", "two\nlines", 3])
def test_description_one_nonempty_line(bad):
    d = musical()
    d["description"] = bad
    assert "description" in error_of(d)


def test_choices_of_string_keys():
    d = musical()
    d["pluck"]["model"] = "guitar"
    assert error_of(d) == (f'{SRC}: pluck.model = "guitar" is not allowed '
                           '(choices: "sitar", "biwa")')
    d = musical()
    d["output"]["signal"] = "velocity"
    assert "output.signal" in error_of(d)
    d = musical()
    d["termination"]["side"] = 0
    assert error_of(d) == f"{SRC}: termination.side = 0 is not allowed (choices: -1, 1)"


def test_section_must_be_a_table():
    d = musical()
    d["pluck"] = 3
    assert "pluck = 3 has the wrong type (expected a table [pluck])" in error_of(d)


# --------------------------------------------------------------------------
# Conditional keys
# --------------------------------------------------------------------------


def test_kind_decides_grid_loss_play():
    d = musical()
    d["grid"] = {"cells": 100}
    msg = error_of(d)
    assert "key 'grid' is not allowed when kind = \"musical\"" in msg and '"study"' in msg
    d = study()
    d["loss"] = musical()["loss"]
    assert "key 'loss' is not allowed when kind = \"study\"" in error_of(d)
    d = study()
    d["play"] = musical()["play"]
    assert "key 'play' is not allowed" in error_of(d)
    d = study()
    del d["grid"]
    assert error_of(d) == f"{SRC}: missing key 'grid' (required when kind = \"study\")"


def test_alpha_only_for_biwa():
    d = musical()
    d["pluck"]["alpha_per_s"] = 100.0
    assert "pluck.alpha_per_s' is not allowed when pluck.model = \"sitar\"" in error_of(d)
    d = musical()
    d["pluck"]["model"] = "biwa"
    assert "missing key 'pluck.alpha_per_s' (required when pluck.model = \"biwa\")" in error_of(d)


@pytest.mark.parametrize("profile", sorted(PROFILE_PARAMS))
def test_profile_parameters_required_exactly(profile):
    # every parameter of the profile is required
    for k in PROFILE_PARAMS[profile]:
        d = with_profile(profile)
        del d["termination"][k]
        assert f"missing key 'termination.{k}'" in error_of(d)
    # every parameter of another profile is forbidden
    others = {k for p, ks in PROFILE_PARAMS.items() for k in ks} - set(PROFILE_PARAMS[profile])
    for k in sorted(others):
        d = with_profile(profile)
        donor = next(p for p, ks in PROFILE_PARAMS.items() if k in ks)
        d["termination"][k] = copy.deepcopy(PROFILE_PARAMS[donor][k])
        msg = error_of(d)
        assert f"key 'termination.{k}' is not allowed when termination.profile = \"{profile}\"" in msg
    # side and region_points: forbidden for "none", required otherwise
    for k in ("side", "region_points"):
        d = with_profile(profile)
        if profile == "none":
            d["termination"][k] = 1
            assert "is not allowed" in error_of(d)
        else:
            del d["termination"][k]
            assert f"missing key 'termination.{k}'" in error_of(d)


def test_radius_range_depends_on_profile():
    d = with_profile("capo")
    d["termination"]["radius_m"] = 50.0  # fine for sawari, too large for capo
    assert "(0.0005 <= value <= 10)" in error_of(d)
    d = with_profile("sawari")
    d["termination"]["radius_m"] = 50.0
    assert validate_dict(d, SRC).termination.radius_m == 50.0
    d["termination"]["radius_m"] = 0.005  # fine for capo, too small for sawari
    assert "(0.01 <= value <= 100)" in error_of(d)


# --------------------------------------------------------------------------
# Cross-key checks and the table profile
# --------------------------------------------------------------------------


def test_x_a_less_than_x_b():
    d = with_profile("jawari-case3")
    d["termination"].update(x_a_m=0.005, x_b_m=0.005)
    assert error_of(d) == (f"{SRC}: termination.x_a_m = 0.005 must be less than "
                           "termination.x_b_m = 0.005")


def test_loss_order_checks():
    d = musical()
    d["loss"].update(f_low_hz=1000.0, f_high_hz=1000.0)
    assert "loss.f_low_hz = 1000.0 must be less than loss.f_high_hz" in error_of(d)
    d = musical()
    d["loss"].update(t60_low_s=1.0, t60_high_s=2.0)
    assert "loss.t60_high_s = 2.0 must be less than or equal to loss.t60_low_s" in error_of(d)
    d = musical()
    d["loss"].update(t60_low_s=2.0, t60_high_s=2.0)
    validate_dict(d, SRC)  # equal T60s are allowed


def test_key_range_order():
    d = musical()
    d["play"].update(key_low=60, key_high=59)
    assert "play.key_low = 60 must be less than or equal to play.key_high = 59" in error_of(d)
    d["play"].update(key_high=60)
    validate_dict(d, SRC)


@pytest.mark.parametrize("points,fragment", [
    ([[0.0, 0.0]], "at least 2"),
    ([], "at least 2"),
    ("0,0", "wrong type"),
    ([[0.0, 0.0], [0.0, 1.0]], "strictly increasing"),
    ([[0.0, 0.0], [0.02, 0.0], [0.01, 0.0]], "termination.points[2]"),
    ([[-0.001, 0.0], [0.01, 0.0]], "x_m < 0"),
    ([[0.0, 0.0], [0.01]], "pair"),
    ([[0.0, 0.0], [0.01, "a"]], "pair"),
    ([[0.0, 0.0], [0.01, True]], "pair"),
    ([[0.0, 0.0], [0.01, math.nan]], "finite"),
])
def test_table_points_validation(points, fragment):
    d = with_profile("table")
    d["termination"]["points"] = points
    assert fragment in error_of(d)


# --------------------------------------------------------------------------
# --set overrides
# --------------------------------------------------------------------------


@pytest.mark.parametrize("text,expected", [
    ("pluck.position=0.7", ("pluck.position", 0.7)),
    ("loss.t60_low_s=3", ("loss.t60_low_s", 3)),
    ('termination.profile="capo"', ("termination.profile", "capo")),
    ("termination.profile=capo", ("termination.profile", "capo")),
    ("termination.profile=jawari-case1", ("termination.profile", "jawari-case1")),
    ("termination.side=-1", ("termination.side", -1)),
    ("output.gain=1e3", ("output.gain", 1000.0)),
    ("termination.points=[[0, 0], [0.01, -1e-4]]", ("termination.points", [[0, 0], [0.01, -1e-4]])),
    ("description=a bare sentence", ("description", "a bare sentence")),
    (" kind = study ", ("kind", "study")),
    # decimals TOML rejects are read as floats
    ("pluck.position=.5", ("pluck.position", 0.5)),
    ("pluck.position= .75 ", ("pluck.position", 0.75)),
    ("termination.slope=-.5", ("termination.slope", -0.5)),
    ("output.gain=5.", ("output.gain", 5.0)),
    ("output.gain=+.5e3", ("output.gain", 500.0)),
    ("output.gain=1.e-3", ("output.gain", 0.001)),
    ("output.gain=01.5", ("output.gain", 1.5)),
    # ... but not text that is no decimal
    ("output.gain=.", ("output.gain", ".")),
    ("output.gain=0.5.1", ("output.gain", "0.5.1")),
    ("output.gain=007", ("output.gain", "007")),
    ("output.gain=.5x", ("output.gain", ".5x")),
])
def test_parse_override(text, expected):
    got = parse_override(text)
    assert got == expected
    assert type(got[1]) is type(expected[1])


def test_bare_decimal_set_is_validated_as_a_number(preset_dir):
    assert load_preset("sitar", ["pluck.position=.6"]).pluck.position == 0.6
    with pytest.raises(PresetError, match=r"pluck.position = 1.5 \(from --set\) is out of range"):
        load_preset("sitar", ["pluck.position=1.5"])
    with pytest.raises(PresetError, match=r"grid.cells = 5.0 \(from --set\) has the wrong type"):
        load_preset("paper/sitar-case1", ["grid.cells=5."])


@pytest.mark.parametrize("text,fragment", [
    ("pluck.position", "expected PATH=VALUE"),
    ("=3", "expected PATH=VALUE"),
    ("pluck.positon=0.7", "unknown key 'pluck.positon' (allowed: model, position"),
    ("plack.position=0.7", "unknown key 'plack.position'"),
    ("pluck=0.7", "'pluck' is a section"),
    ("name=foo", "unknown key 'name'"),
])
def test_parse_override_errors(text, fragment):
    with pytest.raises(PresetError) as ei:
        parse_override(text)
    assert fragment in str(ei.value) and "--set" in str(ei.value)
    assert "\n" not in str(ei.value)


# --------------------------------------------------------------------------
# Finding and loading files
# --------------------------------------------------------------------------


def _write(path: Path, raw: dict) -> Path:
    """Minimal TOML writer for the test dicts."""
    def val(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
        if isinstance(v, list):
            return "[" + ", ".join(val(x) for x in v) + "]"
        return repr(v)

    lines = [f"{k} = {val(v)}" for k, v in raw.items() if not isinstance(v, dict)]
    for k, v in raw.items():
        if isinstance(v, dict):
            lines.append(f"\n[{k}]")
            lines += [f"{kk} = {val(vv)}" for kk, vv in v.items()]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


@pytest.fixture
def fake_shipped(tmp_path, monkeypatch):
    """Point preset_dirs()' shipped entry at tmp_path/shipped/presets (not created).

    Patched where preset_dirs() looks it up: the loader module, not the package."""
    d = tmp_path / "shipped" / "presets"
    monkeypatch.setattr(P.loader, "shipped_preset_dir", lambda: d)
    return d


@pytest.fixture
def preset_dir(tmp_path, monkeypatch, fake_shipped):
    d = tmp_path / "presets"
    _write(d / "sitar.toml", musical())
    s = study()
    s["description"] = "Paper case 1"
    _write(d / "paper" / "sitar-case1.toml", s)
    monkeypatch.setenv("SYNTH_PRESET_PATH", str(d))
    return d


def test_preset_dirs_env_first_then_shipped(tmp_path, monkeypatch):
    a, b = tmp_path / "a", tmp_path / "b"
    monkeypatch.setenv("SYNTH_PRESET_PATH", f"{a}{os.pathsep}{os.pathsep}{b}")
    dirs = preset_dirs()
    shipped = P.shipped_preset_dir()
    assert dirs[:2] == [a, b]
    assert dirs[-1] == shipped and len(dirs) == 3
    monkeypatch.delenv("SYNTH_PRESET_PATH")
    assert preset_dirs() == [shipped]


def test_shipped_presets_are_the_package_data_folder():
    """Inside the imported package (package data, so a wheel carries it), not beside it."""
    shipped = P.shipped_preset_dir()
    assert shipped == importlib.resources.files("synth") / "presets"
    assert shipped.resolve() == Path(synth.__file__).resolve().parent / "presets"
    assert shipped.is_dir() and any(shipped.rglob("*.toml"))


def test_load_by_name_and_subdirectory_name(preset_dir):
    p = load_preset("sitar")
    assert p.name == "sitar" and p.kind == "musical"
    assert Path(p.path).resolve() == (preset_dir / "sitar.toml").resolve()
    q = load_preset("paper/sitar-case1")
    assert q.name == "paper/sitar-case1" and q.kind == "study"


def test_load_by_path_gets_relative_name(preset_dir, tmp_path):
    p = load_preset(str(preset_dir / "paper" / "sitar-case1.toml"))
    assert p.name == "paper/sitar-case1"
    outside = _write(tmp_path / "elsewhere" / "mine.toml", musical())
    assert load_preset(outside).name == "mine"


def test_list_presets_sorted_with_descriptions(preset_dir):
    listing = dict(list_presets())
    assert listing["sitar"] == "Sitar with a case-1 jawari"
    assert listing["paper/sitar-case1"] == "Paper case 1"
    names = [n for n, _ in list_presets()]
    assert names == sorted(names)


def test_list_presets_survives_a_broken_file(preset_dir):
    (preset_dir / "broken.toml").write_text("schema = = 1\n")
    listing = dict(list_presets())
    assert listing["broken"].startswith("(invalid:")
    assert listing["sitar"] == "Sitar with a case-1 jawari"


def test_env_directory_wins_over_a_later_one(preset_dir, tmp_path, monkeypatch, fake_shipped):
    other = tmp_path / "other"
    d = musical()
    d["description"] = "shadowed"
    _write(other / "sitar.toml", d)
    monkeypatch.setenv("SYNTH_PRESET_PATH", f"{preset_dir}{os.pathsep}{other}")
    assert dict(list_presets())["sitar"] == "Sitar with a case-1 jawari"
    assert load_preset("sitar").description == "Sitar with a case-1 jawari"
    # ... and over the shipped presets (synth/presets)
    d["description"] = "shipped version"
    _write(fake_shipped / "sitar.toml", d)
    _write(fake_shipped / "only-shipped.toml", d)
    monkeypatch.setenv("SYNTH_PRESET_PATH", str(preset_dir))
    assert load_preset("sitar").description == "Sitar with a case-1 jawari"
    assert load_preset("only-shipped").description == "shipped version"
    monkeypatch.delenv("SYNTH_PRESET_PATH")
    assert load_preset("sitar").description == "shipped version"


def test_unknown_name_lists_available(preset_dir):
    with pytest.raises(PresetError) as ei:
        load_preset("sitr")
    msg = str(ei.value)
    assert "\n" not in msg
    assert msg.startswith("unknown preset 'sitr'")
    assert "did you mean 'sitar'" in msg
    assert "available: paper/sitar-case1, sitar" in msg


def test_missing_file_and_bad_toml(preset_dir, tmp_path):
    with pytest.raises(PresetError, match="preset file not found"):
        load_preset(str(tmp_path / "nope.toml"))
    bad = tmp_path / "bad.toml"
    bad.write_text('schema = 1\ndescription = "x\n')
    with pytest.raises(PresetError) as ei:
        load_preset(str(bad))
    assert "invalid TOML" in str(ei.value) and "bad.toml" in str(ei.value)
    assert "\n" not in str(ei.value)
    bad.write_bytes(b'description = "\xff"\n')
    with pytest.raises(PresetError, match="not UTF-8"):
        load_preset(str(bad))


def test_file_errors_name_the_file(preset_dir):
    d = musical()
    d["pluck"]["position"] = 2.0
    f = _write(preset_dir / "wrong.toml", d)
    with pytest.raises(PresetError) as ei:
        load_preset("wrong")
    assert str(ei.value).endswith("wrong.toml: pluck.position = 2.0 is out of range (0 < value < 1)")
    assert f.name in str(ei.value)


def test_set_overrides_are_applied_and_validated(preset_dir):
    p = load_preset("sitar", ["pluck.position=0.6", "loss.t60_low_s=3", "output.gain=10"])
    assert p.pluck.position == 0.6 and p.loss.t60_low_s == 3.0 and p.output.gain == 10.0
    assert load_preset("sitar").pluck.position == 0.75  # the file is not changed
    with pytest.raises(PresetError) as ei:
        load_preset("sitar", ["pluck.position=1.5"])
    assert str(ei.value).endswith("pluck.position = 1.5 (from --set) is out of range (0 < value < 1)")
    with pytest.raises(PresetError, match=r"termination.profile = \"capo!\" \(from --set\) is not allowed"):
        load_preset("sitar", ["termination.profile=capo!"])
    # later --set wins
    assert load_preset("sitar", ["pluck.position=0.6", "pluck.position=0.55"]).pluck.position == 0.55


def test_set_can_add_keys_for_a_new_variant(preset_dir):
    with pytest.raises(PresetError) as ei:
        load_preset("sitar", ["pluck.model=biwa"])
    assert "missing key 'pluck.alpha_per_s' (required when pluck.model = \"biwa\", set by --set)" \
        in str(ei.value)
    p = load_preset("sitar", ["pluck.model=biwa", "pluck.alpha_per_s=500"])
    assert p.pluck.model == "biwa" and p.pluck.alpha_per_s == 500.0
    # jawari-case1 -> case2 keeps side, region_points and slope, adds x_b_m/radius_m and
    # drops the file's x_c_m (case 2 forbids it; this used to be an error)
    p = load_preset("sitar", ["termination.profile=jawari-case2", "termination.x_b_m=0.005",
                              "termination.radius_m=0.1"])
    t = p.termination
    assert (t.profile, t.side, t.region_points, t.slope) == ("jawari-case2", -1, 20, 0.01)
    assert (t.x_b_m, t.radius_m, t.x_c_m) == (0.005, 0.1, None)
    # ... but what case 2 requires and the file lacks must still be given
    with pytest.raises(PresetError) as ei:
        load_preset("sitar", ["termination.profile=jawari-case2", "termination.x_b_m=0.005"])
    assert str(ei.value).endswith("missing key 'termination.radius_m' (required when "
                                  "termination.profile is one of \"jawari-case2\", "
                                  "\"jawari-case3\", set by --set)")


def test_set_of_a_forbidden_key_says_from_set(preset_dir):
    with pytest.raises(PresetError) as ei:
        load_preset("sitar", ["pluck.alpha_per_s=5"])
    assert "key 'pluck.alpha_per_s' (from --set) is not allowed when pluck.model = \"sitar\"" \
        in str(ei.value)


def test_set_switching_variants(preset_dir):
    # study -> musical: the file's [grid] is dropped (this used to be the error
    # "key 'grid' is not allowed"); [loss] and [play] are then required
    with pytest.raises(PresetError) as ei:
        load_preset("paper/sitar-case1", ["kind=musical"])
    assert str(ei.value).endswith("missing key 'loss' (required when kind = \"musical\" and voice "
                                  "is one of \"plucked\", \"piano\", set by --set)")
    m = musical()
    sets = ["kind=musical"] + [f"{sec}.{k}={v}" for sec in ("loss", "play")
                               for k, v in m[sec].items()]
    p = load_preset("paper/sitar-case1", sets)
    assert p.kind == "musical" and p.grid is None
    assert p.loss == validate_dict(m, SRC).loss and p.play == validate_dict(m, SRC).play
    assert load_preset("paper/sitar-case1", ["grid.cells=50"]).grid.cells == 50
    # none -> capo adds side, region_points and radius_m; nothing has to be removed
    d = with_profile("none")
    _write(preset_dir / "plain.toml", d)
    p = load_preset("plain", ["termination.profile=capo", "termination.side=1",
                              "termination.region_points=5", "termination.radius_m=0.002"])
    assert p.termination.profile == "capo" and p.termination.radius_m == 0.002
    # musical -> study: grid is added, the file's [loss] and [play] are dropped
    # (this used to be the error "key 'loss' is not allowed when kind = "study"")
    p = load_preset("plain", ["kind=study", "grid.cells=100"])
    assert p.kind == "study" and p.grid.cells == 100 and p.loss is None and p.play is None
    # the same pluck, less the musical-only stroke on the body
    assert p.pluck == dataclasses.replace(load_preset("plain").pluck, bachi_impulse_ns=None,
                                          bachi_duration_s=None)


def test_set_profile_none_drops_the_file_parameters(preset_dir):
    p = load_preset("paper/sitar-case1", ["termination.profile=none"])
    ideal = validate_dict(with_profile("none"), SRC).termination
    assert p.termination == ideal
    assert p.termination.side is None and p.termination.slope is None


def test_set_profile_capo_keeps_side_and_region_points(preset_dir):
    p = load_preset("sitar", ["termination.profile=capo", "termination.radius_m=0.015"])
    t = p.termination
    assert (t.profile, t.radius_m, t.side, t.region_points) == ("capo", 0.015, -1, 20)
    assert t.slope is None and t.x_c_m is None
    # the file is untouched, and the other sections come through
    assert load_preset("sitar").termination.slope == 0.01
    assert p.pluck == load_preset("sitar").pluck


def test_set_model_sitar_drops_alpha(preset_dir):
    p = load_preset("paper/sitar-case1", ["pluck.model=sitar"])
    assert p.pluck.model == "sitar" and p.pluck.alpha_per_s is None


def test_shipped_jawari_preset_with_profile_none_is_the_ideal_string():
    case1 = load_preset("paper/sitar-case1", ["termination.profile=none"])
    ideal = load_preset("paper/sitar-ideal")
    for sec in ("kind", "string", "grid", "pluck", "termination", "output"):
        if sec != "output":
            assert getattr(case1, sec) == getattr(ideal, sec), sec
    assert case1.output.signal == ideal.output.signal
    # capo from the jawari preset: side and region_points of the file are kept
    capo = load_preset("paper/sitar-case1", ["termination.profile=capo",
                                              "termination.radius_m=0.015"])
    file_t = load_preset("paper/sitar-case1").termination
    assert (capo.termination.side, capo.termination.region_points) == \
        (file_t.side, file_t.region_points)
    assert capo.termination.slope is None and capo.termination.x_c_m is None


def test_forbidden_key_given_by_set_stays_an_error(preset_dir):
    with pytest.raises(PresetError) as ei:
        load_preset("sitar", ["termination.profile=none", "termination.slope=0.02"])
    msg = str(ei.value)
    assert "\n" not in msg
    assert msg.endswith("key 'termination.slope' (from --set) is not allowed when "
                        "termination.profile = \"none\" (from --set), only when "
                        "termination.profile is one of \"jawari-case1\", \"jawari-case2\", "
                        "\"jawari-case3\"")
    # order of the --set arguments does not matter
    with pytest.raises(PresetError, match=r"'termination.slope' \(from --set\)"):
        load_preset("sitar", ["termination.slope=0.02", "termination.profile=none"])
    # a --set key inside a section that the new kind forbids is named
    with pytest.raises(PresetError) as ei:
        load_preset("sitar", ["kind=study", "grid.cells=100", "play.polyphony=4"])
    assert "key 'play.polyphony' (from --set) is not allowed when kind = \"study\" (from --set)" \
        in str(ei.value)


def test_key_the_file_itself_may_not_have_is_still_an_error(preset_dir):
    # radius_m is not a jawari-case1 key: the file is wrong whatever --set does to the profile
    d = musical()
    d["termination"]["radius_m"] = 0.1
    _write(preset_dir / "stray.toml", d)
    with pytest.raises(PresetError, match="key 'termination.radius_m' is not allowed when "
                                          "termination.profile = \"jawari-case1\""):
        load_preset("stray")
    with pytest.raises(PresetError, match="key 'termination.radius_m' is not allowed when "
                                          "termination.profile = \"none\" \\(from --set\\)"):
        load_preset("stray", ["termination.profile=none"])
    # setting the discriminator to the file's own value drops nothing either
    with pytest.raises(PresetError, match="'termination.radius_m' is not allowed"):
        load_preset("stray", ["termination.profile=jawari-case1"])


def test_validate_dict_drops_keys_not_named_as_overridden():
    d = musical()
    d["termination"]["profile"] = "none"
    # without the flag, the jawari keys are the file's error
    assert "'termination.side' is not allowed" in error_of(d)
    p = validate_dict(d, SRC, overridden=["termination.profile"])
    assert p.termination == validate_dict(with_profile("none"), SRC).termination
    # with the document before the overrides, only keys it allowed are dropped
    p = validate_dict(d, SRC, overridden=["termination.profile"], file_raw=musical())
    assert p.termination.profile == "none"
    stray = musical()
    stray["termination"]["radius_m"] = 0.1
    d["termination"]["radius_m"] = 0.1
    assert "'termination.radius_m' is not allowed" in error_of(
        d, overridden=["termination.profile"], file_raw=stray)


def test_preset_error_is_a_synth_error():
    assert issubclass(PresetError, SynthError)


# --------------------------------------------------------------------------
# The presets shipped in the checkout (synth/presets) validate, and a wheel carries them
# --------------------------------------------------------------------------

_ROOT = Path(__file__).resolve().parents[1]
_REPO_PRESETS = _ROOT / "synth" / "presets"
#: every TOML file shipped (presets and the spectrum-test specs under checks/)
_SHIPPED_ALL = sorted(_REPO_PRESETS.rglob("*.toml")) if _REPO_PRESETS.is_dir() else []
#: the presets (checks/ holds specs for `synth check`, batch/ for `synth batch`: not presets)
_SHIPPED = [p for p in _SHIPPED_ALL
            if p.relative_to(_REPO_PRESETS).parts[0] not in ("checks", "batch")]


@pytest.mark.parametrize("path", _SHIPPED, ids=[p.relative_to(_REPO_PRESETS).as_posix()
                                                for p in _SHIPPED])
def test_shipped_preset_is_valid(path):
    p = load_preset(str(path))
    assert p.description and p.name == path.relative_to(_REPO_PRESETS).with_suffix("").as_posix()


def _package_data_files(package_dir: Path, patterns) -> set[Path]:
    """The files setuptools' build_py takes for `patterns` (glob, recursive ``**``)."""
    out: set[Path] = set()
    for pat in patterns:
        out |= {Path(f).resolve() for f in glob.glob(str(package_dir / pat), recursive=True)
                if os.path.isfile(f)}
    return out


def test_package_data_declares_every_shipped_preset():
    """pyproject.toml's [tool.setuptools.package-data] must match every
    synth/presets/**/*.toml: a preset it misses (say in a new subfolder that
    the patterns do not reach) works in a checkout but is absent from a
    wheel. Nothing is built; the patterns are expanded as setuptools does."""
    assert _SHIPPED, "no presets shipped"
    cfg = tomllib.loads((_ROOT / "pyproject.toml").read_text("utf-8"))
    data = cfg["tool"]["setuptools"].get("package-data", {})
    patterns = [*data.get("synth", []), *data.get("", [])]
    declared = _package_data_files(_ROOT / "synth", patterns)
    missing = [p.relative_to(_ROOT).as_posix() for p in _SHIPPED_ALL if p.resolve() not in declared]
    assert not missing, f"not in [tool.setuptools.package-data] (a wheel would lack them): {missing}"


def test_package_data_check_catches_a_preset_in_a_new_subfolder(tmp_path):
    """The check above is not vacuous: a one-level pattern misses a deeper file."""
    pkg = tmp_path / "synth"
    top = _write(pkg / "presets" / "a.toml", musical())
    deep = _write(pkg / "presets" / "new" / "deeper" / "b.toml", musical())
    assert _package_data_files(pkg, ["presets/*.toml"]) == {top.resolve()}
    assert _package_data_files(pkg, ["presets/*.toml", "presets/**/*.toml"]) == {
        top.resolve(), deep.resolve()}


def test_every_shipped_preset_is_found_through_importlib_resources(monkeypatch):
    """Each file is reached from importlib.resources.files("synth") and listed by name."""
    monkeypatch.delenv("SYNTH_PRESET_PATH", raising=False)
    root = importlib.resources.files("synth") / "presets"

    def walk(node, prefix=""):
        for child in node.iterdir():
            if child.is_dir() and not (prefix == "" and child.name in ("checks", "batch")):
                yield from walk(child, f"{prefix}{child.name}/")
            elif child.is_file() and child.name.endswith(".toml"):
                yield prefix + child.name[:-len(".toml")]

    via_resources = sorted(walk(root))
    in_checkout = sorted(p.relative_to(_REPO_PRESETS).with_suffix("").as_posix() for p in _SHIPPED)
    assert via_resources == in_checkout
    assert [n for n, _ in list_presets()] == in_checkout


def test_schema_rows_document_themselves():
    for f in P.SCHEMA_FIELDS:
        assert f.doc
    for s in P.SECTIONS:
        assert s.doc
        for f in s.fields:
            assert f.doc, f"{s.name}.{f.name}"
