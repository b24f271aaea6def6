"""Issue 12's levels: every calibrated preset's reference phrase, as
tools/calibrate_levels.py writes it (synth.apps.levels; the levels
themselves are held by the shipped check specs, ``synth check --shipped``)."""

from __future__ import annotations

from pathlib import Path

import pytest

from synth.apps import levels as cl
from synth.apps.check import load_spec
from synth.io.midi import midi_to_events, read_midi_file
from synth.io.presets import load_preset, shipped_checks_dir

PHRASES = shipped_checks_dir() / "phrases"


def test_the_phrase_is_a_melody_in_range_at_velocity_100():
    p = load_preset("sitar")
    ev = cl.phrase_events(p)
    assert len(ev) == len(cl.MELODY)
    keys = [k for _, _, k, _ in ev]
    assert min(keys) >= p.play.key_low and max(keys) <= p.play.key_high
    assert all(v == 100 for *_, v in ev)
    assert all(b[0] >= a[1] for a, b in zip(ev, ev[1:]))      # one note at a time
    g = cl.phrase_events(load_preset("grand-piano"))
    assert len(g) == len(cl.MELODY) + 2 * 3                    # a dyad under each group of four


def test_the_midi_file_plays_the_phrase(tmp_path):
    ev = cl.phrase_events(load_preset("biwa"))
    f = tmp_path / "p.mid"
    cl.write_midi(ev, f)
    got = midi_to_events(read_midi_file(str(f)))
    on = [(e.time_s, e.key, round(e.value * 127)) for e in got if e.kind == "note_on" and e.value > 0]
    assert [(k, v) for _, k, v in on] == [(k, v) for _, _, k, v in ev]
    assert max(abs(t - e[0]) for (t, _, _), e in zip(on, ev)) < 1e-3


def test_every_musical_preset_is_calibrated():
    """Issue 12: every musical preset, not a list that a new one could miss
    (nor one that a new preset must edit: the shipped presets, as listed)."""
    from synth.io.presets import list_presets

    listed = {n for n, _ in list_presets() if load_preset(n).kind == "musical"}
    assert len(listed) >= 5 and set(cl.musical_presets()) == listed


@pytest.mark.parametrize("name", cl.musical_presets())
def test_the_shipped_phrase_is_the_tools_and_its_spec_checks_the_level(name, tmp_path):
    shipped = PHRASES / f"{name}.mid"
    fresh = tmp_path / f"{name}.mid"
    cl.write_midi(cl.phrase_events(load_preset(name)), fresh)
    assert shipped.read_bytes() == fresh.read_bytes()
    # the spec as synth check reads it (not its text): a render of this
    # preset plays the shipped phrase, with the calibrated preset's settings,
    # and a loudness check of that render holds it at -20 LUFS
    spec = load_spec(shipped_checks_dir() / f"{name}.toml")
    plays = [r for r in spec.renders if r.get("midi") is not None
             and Path(r["midi"]).resolve() == shipped.resolve()]
    assert [(r["preset"], r["set"]) for r in plays] == [(name, [])], spec.renders
    levels = [e for e in spec.expects
              if e.get("check") == "loudness" and e.get("render") == plays[0]["name"]]
    assert len(levels) == 1 and levels[0]["lufs"] == -20.0, levels
