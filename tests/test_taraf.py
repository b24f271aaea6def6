"""The sitar's taraf (sympathetic strings, each on a jawari of its own) and
chikari (drone strings strummed by a key range or a channel), issue 12:
on rendered audio and on the strings' contact counts.

The kernel pieces (an open bridge that strings join and leave) are tested
against the naive scheme in ``test_bridge.py``."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from helpers import engine, note
from synth.analysis import window_energy_db
from synth.engine.engine import Event
from synth.io.errors import PresetError
from synth.io.presets import load_preset, validate_dict

FS = 48_000


def _band_db(y, f_hz, a_s, b_s, half_width_hz=6.0):
    """Energy (dB) of y[a_s:b_s] within f_hz +- half_width_hz."""
    x = y[int(a_s * FS):int(b_s * FS)]
    X = np.abs(np.fft.rfft(x * np.hanning(len(x)))) ** 2
    f = np.fft.rfftfreq(len(x), 1 / FS)
    return 10 * np.log10(X[np.abs(f - f_hz) <= half_width_hz].sum() + 1e-300)


def _bare():
    p = load_preset("sitar")
    return dataclasses.replace(p, taraf=None, chikari=None)


def test_the_sitar_carries_eleven_taraf_and_two_chikari():
    p = load_preset("sitar")
    assert len(p.taraf.keys) == 11 and len(p.chikari.keys) == 2
    eng = engine("sitar")
    assert eng.taraf.n_taraf == 11 and eng.taraf.n_drones == 2
    # without the tables (or with no taraf and no chikari) there is no stage
    assert engine(_bare()).taraf is None
    assert engine("sitar", ["taraf.coupling=0"]).taraf is None   # the played string alone


def test_the_halo_rings_at_the_taraf_pitches_after_the_note_is_damped():
    """G3 (key 55) played and damped at 1 s: its partial 2 (G4, 392 Hz) is a
    taraf string's pitch and rings on; 415 Hz (G#4) is neither a taraf
    string nor a partial of G3.  Without taraf (coupling 0) the note's
    release leaves nothing there."""
    ev = note(55, vel=100 / 127, off=1.0)
    y = engine("sitar").render(ev, duration_s=3.0)
    y0 = engine("sitar", ["taraf.coupling=0"]).render(ev, duration_s=3.0)
    assert window_energy_db(y, FS, 1.5, 3.0) - window_energy_db(y0, FS, 1.5, 3.0) > 15.0
    assert _band_db(y, 392.0, 1.5, 3.0) - _band_db(y, 415.3, 1.5, 3.0) > 25.0
    # while the note sounds the taraf add to it, not take over
    assert abs(window_energy_db(y, FS, 0.05, 0.9) - window_energy_db(y0, FS, 0.05, 0.9)) < 3.0


@pytest.mark.slow  # over 2 s on a quiet 2-core machine: ~2.3 s of CPU
def test_each_taraf_string_touches_its_own_jawari():
    """The C4 taraf string under a C4 note reaches its own open jawari (the
    thread at the drop: grazing) on a bridge of 300 N s/m (``taraf.coupling``
    5/3 of the shipped 500; measured 88 ms in contact), longer on one of
    125 N s/m (coupling 4, toward the tabli's own; measured 0.35 s); a
    thread of 3 mm (a closed jawari) lifts the strings clear of it.  (On
    the one-way bridge before, at 1000 N s/m, none touched it:
    docs/lab/2026-11-voicing-notebook.md, "Taraf and chikari".)"""
    def contact(ov):
        eng = engine("sitar", ov)
        eng.taraf.wake()                # the strings set up, to count from the start
        sl = eng.taraf.slots[:eng.taraf.n_taraf]
        for s in sl:
            eng.bank.set_telemetry(s, True)
        eng.render(note(60, vel=100 / 127, off=1.0), duration_s=2.0)
        return [eng.bank.telemetry(s)["termination"]["time_in_contact_s"] for s in sl]

    c = contact(["taraf.coupling=1.6666667"])
    assert c[0] > 0.03 and max(c[1:]) == 0.0     # only the unison string
    assert contact(["taraf.coupling=4"])[0] > 0.25
    assert max(contact(["taraf.coupling=4", "taraf.thread_m=0.003"])) == 0.0


def test_the_played_string_feels_the_bridge():
    """Two-way: the played string's energy goes into the bridge (its
    resistance) and the strings on it.  Its own energy at 1.5 s (held key
    60) falls as the bridge grows more mobile; on a rigid bridge (coupling
    0) it keeps the most.  (One-way, it never changed.)"""
    def energy(ov):
        eng = engine("sitar", ov)
        eng.render(note(60, vel=0.8), duration_s=1.5)
        u = eng.bank.displacement(0)
        return float(np.sum(u * u))

    e = [energy([f"taraf.coupling={c}"]) for c in (0, 1, 4)]
    assert e[0] > e[1] > e[2]
    assert 10 * np.log10(e[0] / e[2]) > 2.0


def test_a_trigger_key_strums_the_drones_and_plays_no_note():
    """Key 36 (in chikari.trigger_key_low..high) strums both drones, C5 and
    C6; no played note."""
    eng = engine("sitar")
    y = eng.render([Event(0.0, "note_on", 36, 100 / 127), Event(0.3, "note_off", 36, 0.0)],
                   duration_s=1.0)
    assert eng.n_voices == 0 and eng.taraf.n_strums == 1
    for f in (523.25, 1046.5):
        # against a major third above: no partial of either drone
        assert _band_db(y, f, 0.1, 1.0) - _band_db(y, 1.25 * f, 0.1, 1.0) > 20.0
    # the stroke sounds from its note-on
    lead = np.flatnonzero(np.abs(y) > 1e-3 * np.max(np.abs(y)))[0] / FS
    assert lead < 0.002
    # at the trigger range's edge and with the channel
    assert engine("sitar").render(note(42, vel=0.8), duration_s=0.1).any()
    eng = engine("sitar", ["chikari.channel=2"])
    eng.render([Event(0.0, "note_on", 60, 0.8, channel=1)], duration_s=0.2)
    assert eng.n_voices == 0 and eng.taraf.n_strums == 1
    eng = engine("sitar")
    eng.render([Event(0.0, "note_on", 60, 0.8, channel=1)], duration_s=0.2)
    assert eng.n_voices == 1 and eng.taraf.n_strums == 0


def test_taraf_renders_do_not_depend_on_the_block_size():
    """Strokes and note-ons act at their output sample: an offline render in
    1024-sample blocks and one in 100-sample blocks agree to round-off."""
    ev = [Event(0.0, "note_on", 60, 0.7), Event(0.11, "note_on", 37, 0.9),
          Event(0.2, "note_off", 60, 0.0), Event(0.31, "note_on", 64, 0.5)]
    a = engine("sitar").render(ev, duration_s=0.6, block=1024)
    b = engine("sitar").render(ev, duration_s=0.6, block=100)
    assert np.max(np.abs(a - b)) < 1e-12 * np.max(np.abs(a))


def test_the_render_waits_for_the_halo_and_all_sound_off_stops_it():
    eng = engine("sitar")
    y = eng.render(note(60, vel=0.8, off=0.3))
    assert len(y) / FS > 5.0                    # the halo rings long after the release
    eng = engine("sitar")
    eng.render(note(60, vel=0.8, off=0.3) + [Event(0.5, "control", 120, 0.0)], duration_s=0.6)
    assert eng.taraf.n_active == 0


def test_taraf_tables_are_validated():
    raw = {"schema": 1, "description": "x", "kind": "musical", "voice": "plucked",
           "string": {"length_m": 0.8, "tension_n": 38.4, "linear_density_kg_per_m": 3.75e-4},
           "pluck": {"model": "sitar", "position": 0.75, "amplitude_m": 0.01, "duration_s": 0.004},
           "termination": {"profile": "none"},
           "loss": {"t60_low_s": 7.0, "f_low_hz": 200.0, "t60_high_s": 1.2, "f_high_hz": 6000.0,
                    "release_t60_s": 0.35},
           "output": {"signal": "bridge_force", "gain": 0.2},
           "play": {"key_low": 43, "key_high": 74, "velocity_exponent": 1.0, "polyphony": 4,
                    "pitch_bend_semitones": 2.0}}
    assert validate_dict(raw, "x").taraf is None       # optional
    p = load_preset("sitar")
    taraf = {f.name: getattr(p.taraf, f.name) for f in dataclasses.fields(p.taraf)}
    taraf["keys"] = list(taraf["keys"])
    chikari = {f.name: getattr(p.chikari, f.name) for f in dataclasses.fields(p.chikari)}
    chikari["keys"] = list(chikari["keys"])
    with pytest.raises(PresetError, match=r"\[chikari\] needs a \[taraf\] table"):
        validate_dict(dict(raw, chikari=chikari), "x")
    assert validate_dict(dict(raw, taraf=taraf, chikari=chikari), "x").chikari.keys == (72, 84)
    with pytest.raises(PresetError, match=r"taraf.keys\[2\] = 200 is not a MIDI key"):
        validate_dict(dict(raw, taraf=dict(taraf, keys=[60, 62, 200])), "x")
    with pytest.raises(PresetError, match=r"taraf.keys = \[\] has the wrong type"):
        validate_dict(dict(raw, taraf=dict(taraf, keys=[])), "x")
    with pytest.raises(PresetError, match="taraf.coupling = 9 is out of range"):
        validate_dict(dict(raw, taraf=dict(taraf, coupling=9)), "x")
    # the strings' own grid is gone: they run on the played strings' bridge
    with pytest.raises(PresetError, match="unknown key 'taraf.grid'"):
        validate_dict(dict(raw, taraf=dict(taraf, grid=4)), "x")


@pytest.mark.slow  # over 2 s on a quiet 2-core machine: a benchmark in a subprocess
def test_the_cost_benchmark_runs_in_its_quick_mode(tmp_path):
    """tools/bench.py taraf (docs/benchmarks.md, "Sitar taraf") in CI's quick mode."""
    import subprocess
    import sys
    from pathlib import Path

    import json

    root = Path(__file__).resolve().parents[1]
    out = Path(tmp_path) / "taraf.json"
    p = subprocess.run([sys.executable, str(root / "tools" / "bench.py"), "taraf", "--quick",
                        "--json", str(out)], capture_output=True, text=True, cwd=root, timeout=600)
    assert p.returncode == 0, p.stderr
    d = json.loads(out.read_text())
    assert d["keys"] == [55] and d["runs"] == 1 and d["seconds"] == 0.3
    v = d["variants"]
    assert list(v) == ["bare", "taraf", "taraf and chikari"]
    # the variants are what they say: the played string, the 11 taraf, the 2 chikari
    assert [v[k]["strings"] for k in v] == [1, 12, 14]
    assert v["bare"]["ratio_median"] == 1.0
    for k, r in v.items():
        assert len(r["times_s"]) == 1 and r["median_s"] == r["times_s"][0] > 0.0
        assert f"{k}: median {r['median_s']:.3f} s, {r['ratio_median']:.2f}x bare" in p.stdout


@pytest.mark.slow  # over 2 s on a quiet 2-core machine: a study in a subprocess
def test_the_bridge_study_runs_in_its_quick_mode():
    """tools/taraf_bridge.py (docs/voicing.md, "Taraf and chikari") in
    CI's quick mode: the shipped bridge keeps keys 60 and 72 within 1 cent
    and the halo far above the string alone's."""
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    p = subprocess.run([sys.executable, str(root / "tools" / "taraf_bridge.py"), "--quick"],
                       capture_output=True, text=True, cwd=root, timeout=600)
    assert p.returncode == 0, p.stderr
    row = p.stdout.splitlines()[1].split()
    assert float(row[0]) == 500.0 and abs(float(row[1])) < 1.0 and float(row[5]) > 15.0


@pytest.mark.slow  # over 2 s on a quiet 2-core machine
def test_a_soft_bridge_stays_bounded_under_a_chord_and_strokes():
    """At the schema's softest bridge (1 N s/m, against the strings' summed
    impedance of up to 3.5 N s/m: the bridge step before 2026-11-25 gave
    NaN there within 0.1 s, found by tools/stress.py), six held notes and
    two strokes of the drones for 8 s stay finite and die away."""
    ev = [Event(0.0, "note_on", k, 0.9) for k in (48, 55, 60, 64, 67, 72)]
    ev += [Event(0.5, "note_on", 36, 1.0), Event(2.0, "note_on", 37, 1.0)]
    y = engine("sitar", ["taraf.bridge_resistance_ns_per_m=1"]).render(ev, duration_s=8.0)
    assert np.all(np.isfinite(y))
    assert np.max(np.abs(y[7 * FS:])) < 0.1 * np.max(np.abs(y[:FS]))


def test_the_taraf_and_the_pianos_sympathetic_strings_are_one_component():
    """Issue 38: free strings on a bridge (synth.engine.free_strings), in two
    configurations picked by the design the voice returns from its one hook:
    the sitar's in the engine's bank (two-way), the grand's on a bank of
    their own at the output rate (one way); the same set-up, membership
    and all-sound-off on both."""
    from synth.engine.free_strings import FreeStrings
    from synth.voices.base import FreeStringsDesign, SympatheticDesign, TarafDesign, Voice

    assert not hasattr(Voice, "taraf") and not hasattr(Voice, "sympathetic")
    sitar, grand = engine("sitar"), engine("grand-piano")
    assert isinstance(sitar.inst.free_strings(sitar.fs_out), TarafDesign)
    assert isinstance(grand.inst.free_strings(grand.fs_out), SympatheticDesign)
    assert sitar.sym is None and grand.taraf is None
    # the played strings' force per unit of their output: the engine's gain
    assert grand.sym.force_per_unit == 1.0 / grand.output.gain
    grand.render([Event(0.0, "control", 64, 1.0)] + note(48, vel=0.9), duration_s=0.1)
    sitar.render(note(57, vel=0.9), duration_s=0.1)
    for fs, bank in ((sitar.taraf, sitar.bank), (grand.sym, grand.sym.bank)):
        assert isinstance(fs, FreeStrings) and isinstance(fs.design, FreeStringsDesign)
        assert fs.bank is bank and len(fs.slots) == len(fs.templates) >= 11
        assert all(fs.owns(s) for s in fs.slots) and not fs.owns(fs.slots[-1] + 1)
        assert fs.R == fs.design.resistance_ns_per_m and fs.return_hz == fs.design.return_hz
        assert fs.n_active > 0
        before = bank.fpar.copy()
        fs.fade(0.01)                       # all sound off: a fade ...
        assert not np.array_equal(bank.fpar, before)
        fs.rest()                           # ... then rest
        assert fs.n_active == 0


def test_a_coupling_too_small_for_the_bridge_is_the_rigid_bridge():
    """taraf.coupling > 0 so small that R / coupling overflows (2.2e-311, a
    draw of tests/test_stress.py) plays the string alone, as coupling 0."""
    e = engine("sitar", ["taraf.coupling=2.225073858507e-311"])
    assert e.inst.free_strings(48_000.0) is None
    y = e.render(note(55, 0.0, 0.8), duration_s=0.03)
    assert np.all(np.isfinite(y)) and np.max(np.abs(y)) > 0.0
