"""The engine's playing rules (``synth.engine.play.PlayRules``): the preset's
``[play]`` table read by the engine, not by the voice."""

import ast
import pathlib

import pytest

from helpers import engine
from synth.engine.play import DEFAULT_POLYPHONY, PlayRules
from synth.io.presets import load_preset


def test_a_musical_presets_rules_are_its_play_table():
    p = load_preset("grand-piano")
    r = PlayRules.from_preset(p)
    assert r.polyphony == p.play.polyphony
    assert r.key_range == (p.play.key_low, p.play.key_high) == (21, 108)
    assert r.steal == (p.play.steal or "quietest")
    assert r.bend_range_semitones == 0.0 and not r.bends     # a piano does not bend
    sitar = PlayRules.from_preset(load_preset("sitar"))
    assert sitar.bends and sitar.bend_range_semitones == load_preset("sitar").play.pitch_bend_semitones


def test_a_study_preset_has_the_defaults():
    p = load_preset("paper/sitar-case1")
    assert getattr(p, "play", None) is None
    r = PlayRules.from_preset(p)
    assert (r.polyphony, r.steal, r.key_range, r.bends) == (DEFAULT_POLYPHONY, "quietest", None, False)


def test_the_engine_plays_by_them():
    e = engine("biwa", ["play.steal=oldest", "play.polyphony=5", "play.pitch_bend_semitones=3"])
    assert (e.play.steal, e.play.polyphony, e.play.bend_range_semitones) == ("oldest", 5, 3.0)
    assert e.polyphony == 5 and e.steal == "oldest"
    # an explicit pool size still wins over the preset's
    assert engine("biwa", ["play.polyphony=5"], polyphony=3).polyphony == 3


@pytest.mark.parametrize("kw, name", [({"steal": "loudest"}, "play.steal"),
                                      ({"polyphony": 0}, "play.polyphony")])
def test_bad_rules_are_refused_by_name(kw, name):
    with pytest.raises(ValueError, match=name):
        PlayRules(**kw)


def test_the_voice_contract_does_not_read_play():
    """The five members that only read ``[play]`` left ``Voice``: a voice
    class does not answer the pool's size, the steal rule, the key range or
    the bend range."""
    src = pathlib.Path(__file__).parents[1] / "synth" / "voices" / "base.py"
    tree = ast.parse(src.read_text())
    cls = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == "Voice")
    names = {n.name for n in cls.body if isinstance(n, ast.FunctionDef)}
    assert not names & {"polyphony", "steal_rule", "key_range", "bend_range_semitones", "bends"}
