"""Sympathetic strings (the pedal's halo) and the sostenuto pedal."""

import numpy as np
import pytest

from helpers import engine
from synth.analysis import as_mono, halo
from synth.engine.engine import Event
from synth.physics import piano as P

FS = 48000


def _take(events, seconds, sets=()):
    e = engine("grand-piano", sets)
    return as_mono(e.render(events, duration_s=seconds)), e


def _db(x):
    return 10 * np.log10(np.mean(np.square(x)) + 1e-300)


def test_pedal_down_the_other_strings_ring_along():
    """C4 held with the sustain pedal down sounds with a halo that the same
    note without the pedal lacks: energy at the other keys' frequencies
    (synth.analysis.halo: +28 dB), growing after the attack; the strings
    of C4 itself are not doubled (its sympathetic copy stays silent).
    (Until 2026-11-27 the note's own partials were left out on a harmonic
    series, so its stretched upper partials counted as halo without the
    pedal and the gain read 9 dB; with the strings' loss fitted to a
    recorded grand they ring longer, and it read 4.4.)"""
    note = [Event(0.0, "note_on", 60, 0.7)]
    down, e = _take([Event(0.0, "control", 64, 1.0)] + note, 3.0)
    up, _ = _take(note, 3.0)
    assert e.sym is not None and e.sym.n > 50
    i60 = e.sym.slot_of[60]
    assert not e.sym.bank.is_active(i60) or e.sym.muted[i60]
    w = slice(int(0.5 * FS), int(3.0 * FS))
    inst = e.inst
    probes = [inst.tuning_hz(k) for k in range(21, 109) if k != 60]
    # the note's own partials, on its stiff-string law (stretched: partial
    # 30 lies 50 cents above 30 f1, where a harmonic series would leave it
    # among the probes; tools/voicing_report.py does the same)
    g = P.grand_string(60)
    scale = inst.tuning_hz(60) / g.partial_hz(1)
    own = [f for f in (scale * g.partial_hz(n) for n in range(1, 60)) if f < FS / 2]
    h = halo(down[w], up[w], FS, probes, own)
    assert h["gain_db"] >= 6.0, h
    # the halo is quieter than the note, and absent without the pedal
    d = down - up
    assert _db(d[w]) < _db(up[w])
    assert _db(d[: int(0.05 * FS)]) < _db(up[: int(0.05 * FS)]) - 20


def test_no_halo_without_pedal_but_the_top_strings_ring():
    """With the pedal up only the strings without dampers (the top keys)
    answer: a low note's halo is small; sympathetic off changes nothing
    else."""
    note = [Event(0.0, "note_on", 48, 0.7)]
    a, e = _take(note, 2.0)
    b, _ = _take(note, 2.0, ["strings.sympathetic=0"])
    free = [k for k, hd in zip(e.sym.keys, e.sym.design.has_damper) if not hd]
    assert free and min(free) > 88
    assert _db((a - b)[FS // 2:]) < _db(b[FS // 2:]) - 30


def test_sostenuto_keeps_the_held_notes_dampers_off():
    """CC66 pressed while C3 is held: C3 rings on after its key comes up,
    while a note played after the pedal went down (G4) is damped at its
    key-up; released, the pedal lets C3's damper fall."""
    ev = [Event(0.0, "note_on", 48, 0.7), Event(0.1, "control", 66, 1.0),
          Event(0.2, "note_off", 48, 0.0), Event(0.3, "note_on", 67, 0.7),
          Event(0.4, "note_off", 67, 0.0)]
    e = engine("grand-piano", ["strings.sympathetic=0"])
    e.schedule(ev)
    for _ in range(int(0.9 * FS / 512)):
        e.render_block(512)
    keys = {vo.key_arg for vo in e.voices.values()}
    assert 48 in keys                            # held by the sostenuto
    assert 67 not in keys                        # damped and gone
    held = [v for v, vo in e.voices.items() if vo.key_arg == 48][0]
    assert e._latched[held]
    e.schedule([Event(e.time_in / e.fs_in_exact, "control", 66, 0.0)])
    for _ in range(int(1.0 * FS / 512)):
        e.render_block(512)
    assert 48 not in {vo.key_arg for vo in e.voices.values()}   # its damper fell


def test_sostenuto_does_not_hold_notes_played_after_it():
    y_sos, _ = _take([Event(0.0, "control", 66, 1.0), Event(0.05, "note_on", 60, 0.7),
                      Event(0.2, "note_off", 60, 0.0)], 1.0, ["strings.sympathetic=0"])
    y_none, _ = _take([Event(0.05, "note_on", 60, 0.7), Event(0.2, "note_off", 60, 0.0)], 1.0,
                      ["strings.sympathetic=0"])
    np.testing.assert_allclose(y_sos, y_none, rtol=0, atol=1e-12)


def test_a_played_keys_string_stops_rendering_once_muted():
    """With the pedal down, the sympathetic string of a key that sounds as a
    played note fades (it is that note's strings) and stops rendering
    MUTE_HOLD_S later: only the free keys' strings stay in its bank."""
    keys = [36, 40, 43, 48, 52, 55, 60, 64, 67, 72]
    e = engine("grand-piano")
    e.schedule([Event(0.0, "control", 64, 1.0)]
               + [Event(0.002, "note_on", k, 0.7) for k in keys])
    sym = e.sym
    e.render_block(256)
    assert sym.n_active == sym.n              # every string at first (the muted ones fading)
    for _ in range(int((sym.MUTE_HOLD_S + 0.02) * e.fs_out / 256) + 1):
        e.render_block(256)
    live = {sym.keys[int(s)] for s in sym.bank.active[:sym.n_active]}
    assert live == set(sym.keys) - set(keys)
    # the key let go (pedal still down): its string rings along again
    e.schedule([Event(e.time_out / e.fs_out, "note_off", 60, 0.0)])
    for _ in range(8):
        e.render_block(256)
    live = {sym.keys[int(s)] for s in sym.bank.active[:sym.n_active]}
    assert 60 not in live                 # the played note still sounds (the pedal holds it)


def test_keys_struck_as_the_pedal_goes_down_never_start_their_strings():
    """Events at one output sample set the sympathetic strings once, to the
    state the last of them leaves (a chord's note-ons read and set it once):
    the strings of keys struck at the sample the pedal goes down never
    start (they used to start and fade at once), the others do, and a chord
    at another sample reads the state once for all its keys."""
    keys = [36, 40, 43, 48, 52, 55, 60, 64, 67, 72]
    e = engine("grand-piano")
    calls = []
    orig = e._sympathetic_state

    def counted():
        calls.append(e.time_in)
        return orig()

    e._sympathetic_state = counted
    e.schedule([Event(0.0, "control", 64, 1.0)]
               + [Event(0.0, "note_on", k, 0.7) for k in keys])
    e.render_block(256)
    sym = e.sym
    live = {sym.keys[int(s)] for s in sym.bank.active[:sym.n_active]}
    assert live == set(sym.keys) - set(keys)
    assert len(calls) == 1
    t = e.time_out / e.fs_out
    e.schedule([Event(t, "note_on", k, 0.7) for k in (38, 45, 50, 57, 62)])
    e.render_block(256)
    assert len(calls) == 2
    live = {sym.keys[int(s)] for s in sym.bank.active[:sym.n_active]}
    assert {38, 45, 50, 57, 62} <= live       # struck later: fading, still rendering


def test_dampers_set_as_they_are_touch_nothing():
    """A damper state equal to the one in place (each key of a chord let go
    under the pedal) changes nothing: no string is damped, faded or
    restarted and the state stays (what lets :meth:`Sympathetic.set_dampers`
    return at once then: a release of 32 keys made 32 such calls, 0.8 ms)."""
    e = engine("grand-piano")
    e.render([Event(0.0, "control", 64, 1.0), Event(0.0, "note_on", 60, 0.8),
              Event(0.01, "note_on", 64, 0.8)], duration_s=0.05)
    sym = e.sym
    lift, muted = e._sympathetic_state()
    sym.set_dampers(lift, muted)
    before = (sym.lift.copy(), sym.muted.copy(), sym._next_stop, sym.bank.fpar.copy())

    def touched(*a, **k):
        raise AssertionError("the bank was touched")

    for name in ("apply_dampers", "fade", "deactivate", "activate", "join_bridge"):
        setattr(sym.bank, name, touched)
    sym.set_dampers(lift.copy(), muted.copy())
    assert np.array_equal(sym.lift, before[0]) and np.array_equal(sym.muted, before[1])
    assert sym._next_stop == before[2] and np.array_equal(sym.bank.fpar, before[3])
