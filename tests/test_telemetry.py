"""Live contact telemetry (``synth play --stats``): the kernel's running
counts equal the offline analysis of the same note's probes, and counting
does not change the sound."""

import numpy as np
import pytest

from helpers import engine, note
from synth.analysis.contacts import contact_summary
from synth.engine.realtime import Realtime, contact_meter
from synth.kernels import strings as K

CASES = [
    ("sitar", 50, 1.0, 0.6),          # jawari: many termination episodes, no hammer
    ("biwa", 55, 1.0, 0.6),           # sawari (side -1)
    ("grand-piano", 83, 0.9, 0.3),    # capo bar, and the felt hammer (three strings)
    ("grand-piano", 60, 0.7, 0.3),    # agraffe: hammer only
]


@pytest.mark.parametrize("name,key,vel,seconds", CASES)
def test_telemetry_equals_the_probe_analysis(name, key, vel, seconds):
    """With telemetry and probes on the same note, every string's counts
    (time in contact, episodes, most points, peak force) are exactly what
    synth.analysis.contacts.contact_summary finds in the probe signals."""
    e = engine(name, probe=True)
    e.telemetry = True
    e.render(note(key, vel=vel), duration_s=seconds)
    tel = e.contact_telemetry()
    assert tel is not None and tel["key"] == key
    assert len(tel["strings"]) >= 1
    any_contact = False
    for i, live in enumerate(tel["strings"]):
        ch = e.probe_channels(i)
        ref = contact_summary(ch[K.P_CONTACT], ch[K.P_F], e.inst.fs)
        for part in ("termination", "hammer"):
            got, want = live[part], ref[part]
            assert got["episodes"] == want["episodes"], (i, part, got, want)
            assert got["time_in_contact_s"] == pytest.approx(want["time_in_contact_s"],
                                                            rel=1e-12, abs=1e-15), (i, part)
        assert live["termination"]["max_points"] == ref["termination"]["max_points"]
        assert live["hammer"]["peak_force_n"] == ref["hammer"]["peak_force_n"]
        any_contact |= live["termination"]["episodes"] + live["hammer"]["episodes"] > 0
    assert any_contact                     # the cases are chosen to touch something


def test_telemetry_through_a_strike_on_the_finer_grid():
    """Key 100 strikes on the 1.3 MHz grid for 20 ms, then its strings go
    on at 325 kHz (StringBank.hand_over keeps the counts, in the coarser
    steps).  The probe holds one of each engine sample's four steps where
    the telemetry counts them all: the episodes and the most points agree
    exactly (53 and 8 on the first string), the time in contact within 1 %
    (0.14 % measured)."""
    e = engine("grand-piano", probe=True)
    e.telemetry = True
    e.render(note(100, vel=0.9), duration_s=0.3)
    tel = e.contact_telemetry()
    for i, live in enumerate(tel["strings"]):
        assert e.bank.grid_of(e.voices[next(iter(e.voices))].slots[i]) == 1
        ch = e.probe_channels(i)
        ref = contact_summary(ch[K.P_CONTACT], ch[K.P_F], e.inst.fs)
        got, want = live["termination"], ref["termination"]
        assert got["episodes"] == want["episodes"] > 20, (i, got, want)
        assert got["max_points"] == want["max_points"]
        assert got["time_in_contact_s"] == pytest.approx(want["time_in_contact_s"], rel=0.01)
        assert live["hammer"]["episodes"] == ref["hammer"]["episodes"]


@pytest.mark.parametrize("name,key", [("sitar", 50), ("grand-piano", 100), ("biwa", 50)])
def test_counting_does_not_change_the_sound(name, key):
    """A counted note takes the per-sample path, the fast path's reference:
    the same samples to round-off (the sitar and the biwa with the tension's
    modulation, whose reading leaves out the first cell's slot, where the
    two paths may hold different deltas that the next clamp overwrites: a
    1e-3 difference on the sitar, 3e-5 on the biwa, before it did)."""
    ev = note(key, vel=1.0) + note(key - 5, t=0.05, vel=0.6)
    plain = engine(name).render(ev, duration_s=0.4)
    e = engine(name)
    e.telemetry = True
    counted = e.render(ev, duration_s=0.4)
    assert e.contact_telemetry()["key"] == key - 5      # the latest note is counted
    assert np.max(np.abs(plain)) > 1e-3
    assert np.max(np.abs(counted - plain)) <= 1e-9 * np.max(np.abs(plain))


def test_the_latest_note_is_counted_and_restarts():
    """A new note moves the count to its strings; the previous note's
    strings stop counting (and go back to the fast path)."""
    e = engine("sitar")
    e.telemetry = True
    e.render(note(50, vel=1.0), duration_s=0.3)
    first = e.contact_telemetry()
    assert first["strings"][0]["termination"]["episodes"] > 0
    e.schedule(note(55, t=0.3, vel=0.9))
    e.render([], duration_s=0.001)
    e.render([], duration_s=0.05)
    tel = e.contact_telemetry()
    assert tel["key"] == 55
    counted = [s for s in range(e.bank.capacity) if e.bank.ipar[s, K.I_TELEM]]
    v = e.by_key[(0, 55)]
    assert counted == list(e._slots(v))
    assert tel["strings"][0]["termination"]["time_in_contact_s"] < 0.05 + 1e-9


def test_meter_shows_the_contacts():
    """The --stats meter line carries the latest note's contacts per string,
    and what was added since the previous line."""
    e = engine("grand-piano")
    e.telemetry = True
    rt = Realtime(e, block=128, overload=None)
    rt.start(0.0, quiet_gc=False)
    assert "contacts: no note yet" in rt.meter()
    e.schedule(note(100, vel=0.9))
    buf = np.zeros((128, 1), dtype=np.float32)
    for _ in range(40):
        rt.callback(buf, 128, None, None)
    line1 = rt.meter()
    for _ in range(40):
        rt.callback(buf, 128, None, None)
    line2 = rt.meter()
    assert "contacts key 100: s0 hammer " in line1 and "; s2 hammer" in line1
    assert " N, termination " in line1 and "(+" in line2


def test_contact_meter_text():
    tel = {"key": 57, "strings": [{"termination": {"time_in_contact_s": 0.0123, "episodes": 34,
                                                   "max_points": 3},
                                   "hammer": {"time_in_contact_s": 0.0, "episodes": 0,
                                              "peak_force_n": 0.0}}]}
    assert contact_meter(tel) == ("contacts key 57: s0 hammer 0.00 ms/0 ep/0.0 N, "
                                  "termination 12.3 ms/34 ep/3 pts")
    prev = {"key": 57, "strings": [{"termination": {"time_in_contact_s": 0.0100}}]}
    assert contact_meter(tel, prev).endswith("(+2.3 ms)")
    assert contact_meter({"key": 57, "strings": []}) == "contacts key 57: silent"
