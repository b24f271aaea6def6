"""docs/midi.md's implementation chart holds: every control-change row is
sent to the engine and must be played ("o") or listed as ignored ("x"),
and the other rows' messages are checked through the file reader and the
engine the same way."""

from __future__ import annotations

import re
from pathlib import Path

import mido
import pytest

from helpers import engine
from synth.engine.engine import CC_NAMES, Event
from synth.io.midi import dropped_name, midi_to_events, normalise_message, MidiEvent

CHART = Path(__file__).resolve().parents[1] / "docs" / "midi.md"


def chart_rows():
    rows = []
    for line in CHART.read_text().splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 5 and cells[2] in ("o", "x") and cells[3] in ("o", "x"):
            rows.append(cells)
    return rows


def cc_rows():
    out = {}
    for fn, msg, _, rec, remark in chart_rows():
        m = re.fullmatch(r"CC (\d+)(?:-(\d+))?", msg)
        if fn == "Control change" and m:
            lo, hi = int(m.group(1)), int(m.group(2) or m.group(1))
            for cc in range(lo, hi + 1):
                assert cc not in out, f"CC {cc} is in two rows of docs/midi.md"
                out[cc] = (rec, remark)
    return out


def test_the_chart_lists_every_controller_once():
    assert sorted(cc_rows()) == list(range(128))


def _ignored_after(preset, cc, value=100):
    e = engine(preset)
    lo = e.play.key_range[0]
    # (rendered just past the controller: what it does or lists is decided
    # when it acts; 50 ms of sound made this chart's 128 tests 21.6 s)
    e.render([Event(0.0, "note_on", lo + 12, 0.8), Event(0.01, "control", cc, value / 127)],
             duration_s=0.012)
    return e.ignored


@pytest.mark.parametrize("cc", range(128))
def test_each_controller_is_played_or_listed_as_the_chart_says(cc):
    rec, remark = cc_rows()[cc]
    for preset in ("grand-piano", "sitar"):
        ign = _ignored_after(preset, cc)
        listed = any(k.startswith(f"CC {cc}") or (cc in (6, 38) and "RPN" in k) for k in ign)
        if rec == "x":
            assert listed, (preset, cc, ign)
        elif cc in (1, 74) and preset == "grand-piano" or cc == 10 and preset == "sitar":
            # the chart's remark: the buzz and the pluck point on the plucked
            # presets, pan on stereo ones
            assert listed and ("listed on" in remark), (preset, cc, ign)
        elif cc in (6, 38):
            # data entry with no RPN selected is listed; RPN 0's is played
            e = engine(preset)
            e.render([Event(0.0, "control", 101, 0.0), Event(0.0, "control", 100, 0.0),
                      Event(0.0, "control", cc, (1 if cc == 6 else 0) / 127)], duration_s=0.01)
            assert (e.ignored == {} if preset == "sitar" else
                    e.ignored == {"RPN 0 (pitch-bend range): the preset does not bend": 1})
        else:
            assert not listed, (preset, cc, ign)


def test_the_controller_names_in_reports_are_the_charts():
    rows = cc_rows()
    for cc in (0, 91, 93, 96, 97):
        assert CC_NAMES[cc].split()[0] in rows[cc][1].lower()


@pytest.mark.parametrize("msg, rec", [
    (mido.Message("sysex", data=[1, 2, 3]), "x"),
    (mido.Message("songpos", pos=4), "x"),
    (mido.Message("clock"), "x"),
    (mido.Message("reset"), "x"),
    (mido.Message("program_change", program=3), "x"),
])
def test_other_messages_are_listed(msg, rec):
    n = normalise_message(msg)
    ign = {}
    if n is None:
        assert dropped_name(msg) is not None
    else:
        assert midi_to_events([MidiEvent(0.0, *n)], ignored=ign) == []
        assert ign


def test_pitch_bend_is_played_on_bending_presets_and_listed_on_the_others():
    for preset, bends in (("sitar", True), ("biwa", True), ("grand-piano", False),
                          ("harpsichord", False)):
        e = engine(preset)
        e.render([Event(0.0, "note_on", 60, 0.8), Event(0.01, "pitch_bend", -1, 0.5)],
                 duration_s=0.05)
        assert ("pitch bend (the preset does not bend)" in e.ignored) != bends, preset


def test_pressure_is_played_on_the_plucked_presets_and_listed_on_the_others():
    """The chart's aftertouch rows ("o"): channel and polyphonic key pressure
    reach the engine, which plays them on the presets with a buzz (the
    note's buzz depth) and lists them on the grand and the harpsichord."""
    rows = {msg: (rec, remark) for fn, msg, _, rec, remark in chart_rows() if fn == "Aftertouch"}
    assert {m: r[0] for m, r in rows.items()} == {"polyphonic key pressure": "o",
                                                  "channel pressure": "o"}
    for msg, name in (("polytouch", "polyphonic key pressure"),
                      ("aftertouch", "channel pressure (aftertouch)")):
        m = mido.Message(msg, value=40, **({"note": 60} if msg == "polytouch" else {}))
        evs = midi_to_events([MidiEvent(0.01, *normalise_message(m))])
        assert len(evs) == 1
        for preset, plays in (("sitar", True), ("biwa", True), ("hammered-sitar", True),
                              ("grand-piano", False), ("harpsichord", False)):
            e = engine(preset)
            e.render([Event(0.0, "note_on", 60, 0.8)] + evs, duration_s=0.03)
            assert (name in e.ignored) != plays, (preset, msg, e.ignored)
