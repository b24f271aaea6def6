"""The schema engine's features beyond the presets' rows (issue 38).

The presets' schema engine (``synth.io.presets.validate``) validates three
kinds of file, each from its own rows: presets, ``synth check`` specs and
``synth batch`` specs. These tests exercise, on small made-up rows, what the
specs need: arrays of tables named by a label, optional keys and conditions
on a key being given or left out, keys that exclude one another, value
shapes (arrays, one-or-array, sweeps with range tables, "LO..HI/STEP",
literals, tables of free keys), the "path" and "any" types, patterns, the
literal-string rendering of values, and the consistency check of the rows.
"""

from __future__ import annotations

import pytest

from synth.apps import batch_spec, check
from synth.io.presets.schema import (
    ABSENT,
    GIVEN,
    Field,
    OrderCheck,
    Range,
    Section,
    When,
    _fmt_literal,
)
from synth.io.presets.validate import check_rows, validate_table


class Bad(Exception):
    pass


def run(raw, fields=(), sections=(), **kw):
    return validate_table(raw, "doc.toml", fields, sections, error=Bad, show=_fmt_literal, **kw)


def fails(raw, fields=(), sections=(), **kw) -> str:
    with pytest.raises(Bad) as e:
        run(raw, fields, sections, **kw)
    msg = str(e.value)
    assert msg.startswith("doc.toml: ") and "\n" not in msg
    return msg[len("doc.toml: "):]


# --------------------------------------------------------------------------- arrays of tables
ITEM = Section("item", "an item", dict, (
    Field("name", "line", "its name"),
    Field("kind", "str", "its kind", choices=("a", "b")),
    Field("size", "int", "its size", 1, 10, when=When("item.kind", ("a",))),
    Field("lo", "float", "low", 0.0, 1.0, optional=True),
    Field("hi", "float", "high", 0.0, 1.0, optional=True),
), checks=(OrderCheck("lo", "<=", "hi"),), array=True, label="name")


def test_an_array_of_tables_gives_one_object_per_table_in_order():
    out = run({"item": [{"name": "x", "kind": "a", "size": 3}, {"name": "y", "kind": "b"}]},
              sections=(ITEM,))
    assert out["item"] == ({"name": "x", "kind": "a", "size": 3, "lo": None, "hi": None},
                           {"name": "y", "kind": "b", "size": None, "lo": None, "hi": None})


def test_a_required_array_needs_a_table_and_tables():
    assert fails({}, sections=(ITEM,)) == "at least one [[item]] table is required"
    assert fails({"item": []}, sections=(ITEM,)) == "at least one [[item]] table is required"
    assert fails({"item": 3}, sections=(ITEM,)) == (
        "item = 3 has the wrong type (expected an array of tables [[item]])")
    assert fails({"item": [{"name": "x", "kind": "b"}, 2]}, sections=(ITEM,)) == (
        "item[1] = 2 has the wrong type (expected a table [[item]])")
    opt = Section("item", "", dict, ITEM.fields, array=True, optional=True)
    assert run({}, sections=(opt,))["item"] == ()


def test_items_are_named_by_index_then_by_their_label():
    assert fails({"item": [{"name": "x", "kind": "b", "colour": 1}]}, sections=(ITEM,)) == (
        "unknown key 'item[0].colour' (allowed: name, kind, size, lo, hi)")
    assert fails({"item": [{"kind": "b"}]}, sections=(ITEM,)) == "missing key 'item[0].name'"
    assert fails({"item": [{"name": "x", "kind": "c"}]}, sections=(ITEM,)) == (
        "item 'x'.kind = 'c' is not allowed (choices: 'a', 'b')")
    # conditions on the item's own keys, named by its label
    assert fails({"item": [{"name": "x", "kind": "a"}]}, sections=(ITEM,)) == (
        "missing key 'item 'x'.size' (required when item 'x'.kind = 'a')")
    assert fails({"item": [{"name": "x", "kind": "b", "size": 2}]}, sections=(ITEM,)) == (
        "key 'item 'x'.size' is not allowed when item 'x'.kind = 'b', only when "
        "item 'x'.kind = 'a'")
    # an order check inside an item
    assert fails({"item": [{"name": "x", "kind": "b", "lo": 0.5, "hi": 0.25}]},
                 sections=(ITEM,)) == (
        "item 'x'.lo = 0.5 must be less than or equal to item 'x'.hi = 0.25")


def test_an_items_keys_do_not_leak_into_the_next_item():
    # item 1 gives x, which excludes kind: item 0's kind = "a" must not let its size in
    sec = Section("item", "", dict, (
        Field("x", "int", "", optional=True),
        Field("kind", "str", "", choices=("a", "b"), optional=True, excludes=("x",)),
        Field("size", "int", "", 1, 10, when=When("item.kind", ("a",))),
    ), array=True)
    assert run({"item": [{"kind": "a", "size": 1}, {"x": 1}]}, sections=(sec,))["item"][1] == {
        "x": 1, "kind": None, "size": None}
    assert fails({"item": [{"kind": "a", "size": 1}, {"x": 1, "size": 2}]}, sections=(sec,)) == (
        "key 'item[1].size' is not allowed when item[1].kind = (absent), only when "
        "item[1].kind = 'a'")


# --------------------------------------------------------------------------- presence
def test_optional_keys_and_conditions_on_a_key_given_or_left_out():
    rows = (
        Field("file", "str", "a file", optional=True),
        Field("seconds", "float", "with a file", 0.0, 100.0, optional=True,
              when=When("file", (GIVEN,))),
        Field("seconds", "float", "without one", 0.0, 10.0, default=2.0,
              when=When("file", (ABSENT,))),
    )
    assert run({}, rows) == {"file": None, "seconds": 2.0}
    assert run({"file": "f"}, rows) == {"file": "f", "seconds": None}
    assert run({"file": "f", "seconds": 50}, rows) == {"file": "f", "seconds": 50.0}
    assert fails({"seconds": 50}, rows) == "seconds = 50 is out of range (0 <= value <= 10)"
    assert When("file", (GIVEN,)).describe() == "file is given"
    assert When("file", (ABSENT,)).describe() == "file is absent"


EXCL = (
    Field("wav", "str", "a file", optional=True),
    Field("preset", "str", "a preset", excludes=("wav",)),
    Field("keys", "int", "keys", 0, 127, many="list", optional=True, excludes=("wav",)),
    Field("key", "int", "a key", 0, 127, default=60, excludes=("wav", "keys")),
)


def test_excluded_keys():
    assert run({"wav": "a"}, EXCL) == {"wav": "a", "preset": None, "keys": None, "key": None}
    assert run({"preset": "p"}, EXCL) == {"wav": None, "preset": "p", "keys": None, "key": 60}
    # the default of a key does not apply when a key it excludes is given
    assert run({"preset": "p", "keys": [1, 2]}, EXCL)["key"] is None
    assert fails({"wav": "a", "preset": "p"}, EXCL) == (
        "preset = 'p' is not allowed with wav = 'a' (give one of them)")
    assert fails({"preset": "p", "keys": [1], "key": 2}, EXCL) == (
        "key = 2 is not allowed with keys = [1] (give one of them)")
    assert fails({}, EXCL) == "missing key 'preset' (or wav)"


# --------------------------------------------------------------------------- shapes
def test_arrays_one_or_array_and_span():
    rows = (
        Field("a", "int", "", 1, 5, many="list"),
        Field("b", "str", "", many="list0", default=()),
        Field("c", "line", "", many="one+"),
        Field("k", "int", "", 0, 127, many="list", span=True),
    )
    base = {"a": [1, 5], "c": "x", "k": "10..16/3"}
    assert run(base, rows) == {"a": (1, 5), "b": (), "c": ("x",), "k": (10, 13, 16)}
    assert run(base | {"b": [], "c": ["x", "y"], "k": "7..7"}, rows)["c"] == ("x", "y")
    assert run(base | {"k": " 7 .. 9 "}, rows)["k"] == (7, 8, 9)
    assert fails(base | {"a": []}, rows) == "a = [] needs at least one value"
    assert fails(base | {"a": [1, 6]}, rows) == "a[1] = 6 is out of range (1 <= value <= 5)"
    assert fails(base | {"a": 1}, rows) == (
        "a = 1 has the wrong type (expected a non-empty array (an integer each))")
    assert fails(base | {"b": ["x", 1]}, rows) == (
        "b[1] = 1 has the wrong type (expected a string)")
    assert fails(base | {"c": 3}, rows) == (
        "c = 3 has the wrong type (expected a string or an array of them)")
    assert fails(base | {"k": "16..10"}, rows) == (
        "k = '16..10' is out of range (0 <= LO <= HI <= 127, STEP >= 1)")
    assert fails(base | {"k": "10..20/0"}, rows) == (
        "k = '10..20/0' is out of range (0 <= LO <= HI <= 127, STEP >= 1)")
    assert fails(base | {"k": "ten"}, rows) == (
        "k = 'ten' has the wrong type (expected a non-empty array (an integer each) or "
        "\"LO..HI/STEP\")")


def test_sweeps_range_tables_literals_and_tables_of_free_keys():
    rows = (
        Field("v", "int", "", 1, 127, many="sweep", literals=("all",)),
        Field("s", "float", "", 0.0, 10.0, lo_open=True, many="sweep", default=(4.0,)),
        Field("q", "str", "", choices=("x", "y"), many="sweep", optional=True),
        Field("set", "any", "", many="sweep", mapping=True, default=()),
    )
    assert run({"v": 3}, rows) == {"v": (3,), "s": (4.0,), "q": None, "set": ()}
    assert run({"v": "all"}, rows)["v"] == "all"
    assert run({"v": {"low": 1, "high": 9, "steps": 3}}, rows)["v"] == Range(1, 9, 3)
    assert run({"v": {"low": 1, "high": 9}}, rows)["v"] == Range(1, 9, None)
    assert run({"v": 1, "s": [1, 2.5]}, rows)["s"] == (1.0, 2.5)
    out = run({"v": 1, "set": {"a.b": [1, "x", True], "c.d": {"low": 1, "high": 2},
                               "e.f": [[0, 1]]}}, rows)["set"]
    assert out == (("a.b", (1, "x", True)), ("c.d", Range(1.0, 2.0, None)), ("e.f", ([0, 1],)))
    assert type(out[0][1][0]) is int and type(out[1][1].low) is float
    assert fails({"v": "most"}, rows) == (
        "v = 'most' has the wrong type (expected an integer, an array of them or a range "
        "{low, high[, steps]}, or 'all')")
    assert fails({"v": {"low": 0, "high": 3}}, rows) == (
        "v.low = 0 is out of range (1 <= value <= 127)")
    assert fails({"v": {"high": 3}}, rows) == "missing key 'v.low' (a range {low, high[, steps]})"
    assert fails({"v": {"low": 1, "high": 3, "step": 2}}, rows) == (
        "unknown key 'v.step' (allowed: low, high, steps)")
    assert fails({"v": {"low": 9, "high": 3}}, rows) == (
        "v.low = 9 must be less than or equal to v.high = 3")
    assert fails({"v": {"low": 1, "high": 3, "steps": 0}}, rows) == (
        "v.steps = 0 is out of range (1 <= value <= 10000)")
    assert fails({"v": 1, "s": 0}, rows) == "s = 0 is out of range (0 < value <= 10)"
    assert fails({"v": 1, "q": {"low": 1, "high": 2}}, rows) == (
        "q = {low = 1, high = 2} has the wrong type (expected a string or an array of them)")
    assert fails({"v": 1, "q": ["x", "z"]}, rows) == (
        "q[1] = 'z' is not allowed (choices: 'x', 'y')")
    assert fails({"v": 1, "set": [1]}, rows).startswith(
        "set = [1] has the wrong type (expected a table of keys, each a value (not a table)")
    assert fails({"v": 1, "set": {"a": {"x": 1}}}, rows) == "unknown key 'set.a.x' " \
        "(allowed: low, high, steps)"
    assert fails({"v": 1, "set": {"a": [{"x": 1}]}}, rows) == (
        "set.a[0] = {x = 1} has the wrong type (expected a value (not a table))")
    assert fails({"v": 1, "set": {"a": float("nan")}}, rows) == "set.a = nan is not a finite number"
    assert fails({"v": 1, "set": {"a": {"low": "x", "high": 1}}}, rows) == (
        "set.a.low = 'x' has the wrong type (expected a number)")


# --------------------------------------------------------------------------- types
def test_paths_are_resolved_against_the_documents_folder(tmp_path):
    rows = (Field("file", "path", "a file"),)
    assert run({"file": "sub/a.wav"}, rows, base=tmp_path) == {
        "file": str((tmp_path / "sub" / "a.wav").resolve())}
    assert run({"file": "/abs/a.wav"}, rows, base=tmp_path) == {"file": "/abs/a.wav"}
    assert fails({"file": ""}, rows) == "file = '' has the wrong type (expected a file name)"
    assert fails({"file": 3}, rows) == "file = 3 has the wrong type (expected a file name)"


def test_a_pattern_and_literal_or_basic_strings_in_messages():
    rows = (Field("name", "str", "", pattern=(r"[a-z]{1,3}", "1-3 small letters")),)
    assert run({"name": "abc"}, rows) == {"name": "abc"}
    assert fails({"name": "abcd"}, rows) == "name = 'abcd' is not allowed (1-3 small letters)"
    assert fails({"name": "ab\n"}, rows) == "name = 'ab\\n' is not allowed (1-3 small letters)"
    with pytest.raises(Bad, match='name = "abcd" is not allowed'):   # the presets' rendering
        validate_table({"name": "abcd"}, "doc.toml", rows, error=Bad)


def test_the_error_class_and_the_source_are_the_callers():
    with pytest.raises(Bad, match=r"^doc\.toml: missing key 'n'$"):
        run({}, (Field("n", "int", "", 1, 2),))
    with pytest.raises(Bad, match=r"^doc\.toml: unknown key 'm' \(allowed: n\)$"):
        run({"m": 1, "n": 1}, (Field("n", "int", "", 1, 2),))


# --------------------------------------------------------------------------- rows
@pytest.mark.parametrize("fields, sections, why", [
    ((Field("a", "int", "", excludes=("b",)), Field("b", "int", "")), (), "excludes a later"),
    ((Field("a", "int", "", default=1), Field("b", "int", "", excludes=("a",))), (),
     "which has a default"),
    ((Field("k", "float", "", 0, 1, many="list", span=True),), (), "span, literals or pattern"),
    ((Field("k", "int", "", literals=("all",)),), (), "span, literals or pattern"),
    ((Field("k", "int", "", many="set"),), (), "unknown type"),
    ((Field("a", "int", "", when=When("b", (1,))), Field("b", "int", "")), (), "later/unknown"),
    ((Field("k", "str", ""),), (Section("s", "", dict, (Field("x", "int", ""),),
                                        when=When("k", ("a",)), array=True),), "takes no when"),
    ((), (Section("s", "", dict, (Field("x", "int", ""), Field("y", "str", "")),
                  array=True, label="y"),), "label must be its first key"),
    ((), (Section("s", "", dict, (Field("x", "int", ""),),
                  checks=(OrderCheck("x", "<=", "z"),)),), "bad check"),
])
def test_the_rows_are_checked(fields, sections, why):
    with pytest.raises(AssertionError, match=why):
        check_rows(fields, sections)


def test_the_specs_rows_are_consistent():
    check_rows(check.SPEC_FIELDS, check.SPEC_SECTIONS)
    check_rows(batch_spec.SPEC_FIELDS, batch_spec.SPEC_SECTIONS)
    # every check has a row set: its name is a choice of expect.check
    expect = check.SPEC_SECTIONS[1]
    assert next(f for f in expect.fields if f.name == "check").choices == tuple(check.CHECKS)
