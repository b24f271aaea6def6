"""The harpsichord preset: a plucked piano string per key, built with the
new-voice recipe of docs/architecture.md (voice module, preset, schema rows)."""

import numpy as np
import pytest

from synth.analysis import cents, estimate_f0
from synth.engine.engine import Event
from synth.io.errors import PresetError, SynthError
from synth.io.factory import build_engine
from synth.io.presets import load_preset

FS = 48_000


def _note(key, vel=0.8, seconds=1.0, off=None, overrides=()):
    e = build_engine("harpsichord", overrides)
    ev = [Event(0.0, "note_on", key, vel)]
    if off is not None:
        ev.append(Event(off, "note_off", key, 0.0))
    return e, e.render(ev, duration_s=seconds)


@pytest.mark.parametrize("key", [29, 41, 53, 60, 69, 77, 89])
def test_every_key_sounds_at_its_tuned_pitch(key):
    """Partial 1 within 1 cent of the preset's tuning (A4 = 415 Hz, equal
    temperament), at a sane level."""
    e, y = _note(key)
    f = e.inst.pitch_hz(key)
    assert abs(f / (415.0 * 2 ** ((key - 69) / 12)) - 1) < 1e-9
    f0 = estimate_f0(y[int(0.1 * FS):int(0.6 * FS)], FS, f)
    assert abs(cents(f0, f)) < 1.0
    peak_db = 20 * np.log10(np.max(np.abs(y)))
    # (the gain is set for -20 LUFS on the reference phrase: tools/calibrate_levels.py)
    assert np.all(np.isfinite(y)) and -24.0 < peak_db < -1.0


def test_level_is_even_across_the_keyboard():
    """The plectrum lets go at the same force on every key (amplitude as
    1/Z), and the plectra are voiced lighter towards the treble: peaks of
    F1..F6 within 7.5 dB of each other (7.2 dB measured, F6 the quietest);
    without the impedance law the wound bass would stand 10 dB out (checked
    below)."""
    peaks = [20 * np.log10(np.max(np.abs(_note(k, seconds=0.5)[1]))) for k in range(29, 90, 12)]
    assert max(peaks) - min(peaks) < 7.5, peaks
    from synth.physics.piano import grand_string
    from synth.voices.harpsichord import VOICING_EXPONENT

    e = build_engine("harpsichord")
    s29, s60 = e.inst.setup(29), e.inst.setup(60)
    voicing = (grand_string(60).f0_hz / grand_string(29).f0_hz) ** VOICING_EXPONENT
    assert s60.pluck_scale == 1.0 and s29.pluck_scale / voicing < 0.3


def test_velocity_moves_the_level_a_little():
    """velocity_exponent 0.3: velocity 1.0 against 0.3 is 20 log10((1/0.3)^0.3)
    = 3.1 dB (the string is linear, so exactly that)."""
    a = np.max(np.abs(_note(60, vel=1.0, seconds=0.3)[1]))
    b = np.max(np.abs(_note(60, vel=0.3, seconds=0.3)[1]))
    assert 20 * np.log10(a / b) == pytest.approx(20 * 0.3 * np.log10(1 / 0.3), abs=0.05)


def test_the_damper_stops_the_string_and_the_pedal_keeps_it_off():
    """Key up at 0.3 s: 0.4 s later the damped string is at least 30 dB
    below the string held by the sustain pedal."""
    w = slice(int(0.65 * FS), int(0.75 * FS))
    _, damped = _note(53, seconds=0.8, off=0.3)
    e = build_engine("harpsichord")
    held = e.render([Event(0.0, "control", 64, 1.0), Event(0.0, "note_on", 53, 0.8),
                     Event(0.3, "note_off", 53, 0.0)], duration_s=0.8)
    r = np.sqrt(np.mean(damped[w] ** 2)) / np.sqrt(np.mean(held[w] ** 2))
    assert 20 * np.log10(r) < -30.0


def test_it_has_a_body_and_keys_outside_its_range_are_silent():
    e = build_engine("harpsichord")
    assert e.body is not None and e.spv == 1
    y = e.render([Event(0.0, "note_on", 20, 0.8), Event(0.0, "note_on", 100, 0.8)],
                 duration_s=0.1)
    assert np.max(np.abs(y)) == 0.0


def test_the_schema_admits_only_the_harpsichord_sections():
    pre = load_preset("harpsichord")
    assert pre.voice == "harpsichord" and pre.action is None and pre.hammer is None
    assert pre.strings.capo_radius_m is None and pre.strings.detune_scale is None
    with pytest.raises(PresetError, match=r"strings\.detune_scale"):
        load_preset("harpsichord", ["strings.detune_scale=1.0"])
    with pytest.raises(PresetError, match=r"key 'action'|action"):
        load_preset("harpsichord", ["action.law=three-parameter"])
    with pytest.raises(SynthError, match=r"play.key_low..key_high = 12..89 is out of range"):
        build_engine("harpsichord", ["play.key_low=12"])
