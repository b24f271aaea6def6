"""The dampers' laws (synth.physics.dampers) against their closed forms, and
the keyboard voices that use them."""

import math

import pytest

from synth.io.factory import build_voice
from synth.physics.dampers import damped_t60_s, damper_lift


def test_damped_t60_is_geometric_across_the_compass():
    assert damped_t60_s(21, 21, 108, 0.8, 0.05) == pytest.approx(0.8, rel=1e-15)
    assert damped_t60_s(108, 21, 108, 0.8, 0.05) == pytest.approx(0.05, rel=1e-15)
    # halfway in keys: the geometric mean; equal ratios for equal key steps
    assert damped_t60_s(64.5, 21, 108, 0.8, 0.05) == pytest.approx(math.sqrt(0.8 * 0.05), rel=1e-14)
    r1 = damped_t60_s(40, 21, 108, 0.8, 0.05) / damped_t60_s(30, 21, 108, 0.8, 0.05)
    r2 = damped_t60_s(90, 21, 108, 0.8, 0.05) / damped_t60_s(80, 21, 108, 0.8, 0.05)
    assert r1 == pytest.approx(r2, rel=1e-12) and r1 < 1.0


@pytest.mark.parametrize("pedal, lift", [(0.0, 0.0), (0.2, 0.0), (0.3, 0.0), (0.45, 0.5),
                                         (0.6, 1.0), (1.0, 1.0)])
def test_half_pedal_is_linear_between_its_limits(pedal, lift):
    assert damper_lift(pedal, 0.3, 0.6) == pytest.approx(lift, abs=1e-15)


@pytest.mark.parametrize("preset", ["grand-piano", "harpsichord"])
def test_keyboard_voices_use_the_preset_dampers(preset):
    v = build_voice(preset)
    d = v.preset.dampers
    assert v.release_t60_s(v.KEY_LOW) == pytest.approx(d.release_t60_bass_s, rel=1e-14)
    assert v.release_t60_s(v.KEY_HIGH) == pytest.approx(d.release_t60_treble_s, rel=1e-14)
    mid = 0.5 * (d.half_pedal_low + d.half_pedal_high)
    assert v.damper_lift(mid) == pytest.approx(0.5, abs=1e-12)
    assert v.damper_lift(0.0) == 0.0 and v.damper_lift(1.0) == 1.0
