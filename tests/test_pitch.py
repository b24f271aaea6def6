"""Musical presets: every key within 1 cent of equal temperament."""

import numpy as np
import pytest

from helpers import engine, note
from synth.analysis import cents, estimate_f0
from synth.io.presets import load_preset
from synth.physics.string import midi_key_to_hz


@pytest.mark.parametrize("name", ["sitar", "biwa"])
def test_every_key_within_one_cent(name):
    play = load_preset(name).play
    worst = 0.0
    for key in range(play.key_low, play.key_high + 1):
        y = engine(name).render(note(key, 0.0, 0.8), duration_s=1.6)
        f_ref = midi_key_to_hz(key)
        f = estimate_f0(y[int(0.8 * 48000):], 48000, f_ref, search_cents=60)
        worst = max(worst, abs(cents(f, f_ref)))
        assert abs(cents(f, f_ref)) < 1.0, f"{name} key {key}: {cents(f, f_ref):+.3f} cent"
    print(f"{name}: worst {worst:.4f} cent")


@pytest.mark.parametrize("f0", [98.0, 200.0, 587.33])
def test_loss_filter_gives_the_preset_t60(f0):
    """Without the termination, the fundamental decays with the preset's
    T60 (interpolated by the one-pole between its two frequencies; at
    f_low exactly t60_low)."""
    import dataclasses

    from synth.engine.engine import Engine, Event
    from synth.voices.plucked import PluckedInstrument

    pre = load_preset("sitar")
    nt = dataclasses.replace(pre, termination=dataclasses.replace(pre.termination, profile="none"))
    inst = PluckedInstrument(nt)
    y = Engine(inst).render([Event(0.0, "note_on", -1, 1.0, f0_hz=f0)], duration_s=3.0)
    fs = 48000
    # fundamental amplitude in successive 0.25 s frames by single-bin DTFT
    frames = []
    n = int(0.25 * fs)
    for i in range(2, 11):
        seg = y[i * n:(i + 1) * n] * np.hanning(n)
        t = np.arange(n) / fs
        frames.append(abs(np.sum(seg * np.exp(-2j * np.pi * f0 * t))))
    slope_db_per_s = np.polyfit(np.arange(len(frames)) * 0.25, 20 * np.log10(frames), 1)[0]
    t60 = -60.0 / slope_db_per_s
    # expected: the loop's magnitude at f0 (the one-pole fitted through both points)
    su = inst.setup(f0_hz=f0)
    w = 2 * np.pi * f0 / inst.fs
    g = abs(su.b0 / (1 + su.a1 * np.exp(-1j * w)))
    t60_expected = -3.0 / (f0 * np.log10(g))
    assert abs(t60 / t60_expected - 1) < 0.03
    if f0 == 200.0:
        assert abs(t60 / pre.loss.t60_low_s - 1) < 0.03
