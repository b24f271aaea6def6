"""The played strings on one bridge (a preset's ``[bridge]``, the tanpura):
every sounding string hangs on it, the first to sound leads it, and the
strings ring into each other (issue 40, item 3)."""

import numpy as np
import pytest

from helpers import engine
from synth.engine.engine import Event
from synth.io.errors import SynthError
from synth.io.presets import load_preset
from synth.io.factory import build_voice

NO_PLAYER = "drone.player=off"


def _voice_slot(e, key, string):
    v = [i for i, vo in e.voices.items()
         if vo.key[1] == key and (vo.key[2] if len(vo.key) > 2 else None) == string]
    return e._slots(v[0])[0] if v else None


def _energies(sets, plucks, seconds, at_s):
    """Each plucked string's ring energy at the times ``at_s``."""
    e = engine("tanpura", [NO_PLAYER] + sets)
    e.schedule([Event(t, "note_on", k, v, string=s) for t, k, v, s in plucks])
    blk = 480
    want = {int(round(t * 48000 / blk)) for t in at_s}
    out = {}
    for b in range(1, int(seconds * 48000 / blk) + 1):
        e.render_block(blk)
        if b in want:
            out[b] = [float(e.bank.energy([_voice_slot(e, k, s)])[0]) for _, k, _, s in plucks]
    return np.array([out[b] for b in sorted(out)]), e


def test_the_tanpura_s_four_strings_hang_on_one_bridge():
    """A drone cycle (Pa, Sa, Sa, low Sa): every sounding string is a member
    of one open bridge, led by the first string plucked."""
    e = engine("tanpura", [])
    e.schedule([Event(0.0, "note_on", 49, 0.8)])          # Sa = 49 starts the cycle
    for _ in range(int(3.0 * 48000 / 480)):
        e.render_block(480)
    slots = sorted(e._slots(v)[0] for v in e.voices)
    assert len(slots) == 4                                # Pa, Sa, Sa, low Sa
    lead = e.taraf.lead
    assert lead in slots and sorted(e.bank.group(lead)) == slots


def test_a_resting_unison_string_takes_up_the_plucked_ones_energy():
    """Sa plucked at 0.6, the other Sa at 0.02 a quarter second later: on
    the bridge the quiet string holds several dB more by 2-3 s than with
    the bridge all but rigid (R 200 times stiffer)."""
    plucks = [(0.0, 49, 0.6, 1), (0.25, 49, 0.02, 2)]
    a, e = _energies([], plucks, 3.0, [2.0, 2.9])
    b, _ = _energies(["bridge.resistance_ns_per_m=100000"], plucks, 3.0, [2.0, 2.9])
    assert sorted(e.bank.group(e.taraf.lead)) == sorted(
        [_voice_slot(e, 49, 1), _voice_slot(e, 49, 2)])
    gain_db = 10 * np.log10(a[:, 1] / b[:, 1])
    assert np.all(gain_db > 2.0), gain_db                 # measured +3.3, +5.6 dB at R 500
    assert np.all(np.isfinite(a)) and np.all(a[:, 0] < 10 * b[:, 0])


def test_the_strings_still_sounding_join_a_bridge_opened_again():
    """The leader's voice cut (all the others still sounding): the next
    string to start opens the bridge again with every string on it."""
    e = engine("tanpura", [NO_PLAYER])
    e.schedule([Event(0.0, "note_on", 37, 0.6), Event(0.01, "note_on", 44, 0.6)])
    for _ in range(5):
        e.render_block(480)
    lead = e.taraf.lead
    other = _voice_slot(e, 44, None)
    e._free(next(v for v in e.voices if e._slots(v)[0] == lead))
    assert not e.bank.group(lead) and e.bank.is_active(other)
    e.schedule([Event(0.1, "note_on", 49, 0.6)])
    for _ in range(10):
        e.render_block(480)
    new = _voice_slot(e, 49, None)
    assert e.taraf.lead == new and sorted(e.bank.group(new)) == sorted([new, other])


def test_a_lone_note_s_pitch_and_decay_keep_to_the_voicing():
    """One string on the bridge alone: in tune as before within 0.2 cent
    (measured 0.02-0.13 on keys 37-56), and it loses at most 4 dB more
    by 3-4 s (the bridge's dashpot; measured 0.5-3.7 dB)."""
    from synth.analysis import cents, estimate_f0
    from synth.api import render_note
    from synth.physics.string import midi_key_to_hz

    def measure(key, sets):
        a = render_note("tanpura", key=key, velocity=80, seconds=4.0, set=[NO_PLAYER] + sets)
        y = np.asarray(a.samples, float).mean(axis=1)
        ref = midi_key_to_hz(key)
        c = cents(estimate_f0(y[int(0.05 * a.fs):int(1.05 * a.fs)], a.fs, ref, search_cents=60.0),
                  ref)
        lv = lambda t0, t1: 10 * np.log10(np.mean(y[int(t0 * a.fs):int(t1 * a.fs)] ** 2))
        return c, lv(3.0, 4.0) - lv(0.1, 0.5)

    for key in (37, 56):
        c1, d1 = measure(key, [])
        c0, d0 = measure(key, ["bridge.resistance_ns_per_m=100000"])
        assert abs(c1 - c0) < 0.2 and d0 - 4.0 < d1 <= d0 + 0.5, (key, c1, c0, d1, d0)


def test_bridge_and_taraf_are_one_or_the_other():
    with pytest.raises((ValueError, SynthError), match=r"\[bridge\] and \[taraf\]"):
        build_voice("sitar", ["bridge.resistance_ns_per_m=500"])


def test_a_preset_without_the_table_plays_its_strings_apart():
    e = engine("tanpura", [NO_PLAYER])
    assert e.taraf is not None and e.taraf.slots == ()
    p = load_preset("biwa")
    assert getattr(p, "bridge", None) is None and engine("biwa").taraf is None
