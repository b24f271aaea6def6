"""Musical presets: every key within 1 cent of equal temperament (the shipped specs play
them; the loss filter and the tuning laws here)."""

import numpy as np
import pytest

from helpers import engine
from synth.apps.check import load_spec
from synth.analysis import cents, estimate_f0
from synth.io.presets import load_preset, shipped_checks_dir
from synth.physics.string import midi_key_to_hz


#: where a plucked preset's settled note is judged (s): the sitar's strong
#: pluck glides down from up to 43 cents sharp as its swing decays
#: (string.tension_modulation; key 43 at velocity 102: +3.2 cents over
#: 0.8-1.6 s, +0.4 over 2-3 s)
SETTLED_FROM_S = {"sitar": 2.0}


@pytest.mark.parametrize("name", ["sitar", "biwa", "hammered-sitar"])
def test_every_key_is_tuned_by_the_shipped_spec(name):
    """Every key of the preset within 1 cent of its tuning, at a soft and a
    hard pluck: the shipped spec's "range" render (``synth check
    --shipped``, run by CI beside the suite) plays each of its keys at two
    velocities and checks partial 1 of the settled note with the same
    estimator (synth.analysis.estimate_f0, 60 cents of search).  This
    suite rendered them again at one velocity (30 s of a CI run) until
    2026-12-03; it now checks that the spec still covers them."""
    play = load_preset(name).play
    spec = load_spec(shipped_checks_dir() / f"{name}.toml")
    renders = {r["name"]: r for r in spec.renders}
    covered = set()
    for e in spec.expects:
        r = renders.get(e.get("render"))
        if e["check"] != "f0" or r is None or "keys" not in r:
            continue
        if r["set"] or r["preset"] != name or e["cents"] > 1.0 or len(r["velocities"]) < 2:
            continue
        if e.get("start_s", 0.05) >= SETTLED_FROM_S.get(name, 0.0):
            covered |= set(r["keys"])
    assert covered >= set(range(play.key_low, play.key_high + 1)), sorted(
        set(range(play.key_low, play.key_high + 1)) - covered)


@pytest.mark.parametrize("f0", [98.0, 200.0, 587.33])
def test_loss_filter_gives_the_preset_t60(f0):
    """Without the termination, the fundamental decays with the preset's
    T60 (interpolated by the one-pole between its two frequencies; at
    f_low exactly t60_low)."""
    import dataclasses

    from synth.engine.engine import Event
    from synth.io.factory import build_engine

    pre = load_preset("sitar")
    nt = dataclasses.replace(pre, termination=dataclasses.replace(pre.termination, profile="none"),
                             taraf=None, chikari=None)
    eng = build_engine(nt)
    inst = eng.inst
    y = eng.render([Event(0.0, "note_on", -1, 1.0, f0_hz=f0)], duration_s=3.0)
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


@pytest.mark.parametrize("name", ["sitar", "biwa"])
@pytest.mark.parametrize("bend", [1.0, -1.0, 0.5])
def test_pitch_bend_moves_the_string_by_the_preset_range(name, bend):
    """A bend of value b moves f0 by b * play.pitch_bend_semitones (2) within
    1 cent, gliding (no step in the output), and back at 0."""
    from synth.engine.engine import Event

    e = engine(name)
    y = e.render([Event(0.0, "note_on", 57, 0.8), Event(0.6, "pitch_bend", -1, bend),
                  Event(1.8, "pitch_bend", -1, 0.0)], duration_s=3.0)
    f_ref = midi_key_to_hz(57)
    f_bent = estimate_f0(y[int(1.0 * 48000):int(1.8 * 48000)], 48000,
                         f_ref * 2 ** (2 * bend / 12), search_cents=60)
    assert abs(cents(f_bent, f_ref) - 200 * bend) < 1.0
    f_back = estimate_f0(y[int(2.1 * 48000):], 48000, f_ref, search_cents=60)
    assert abs(cents(f_back, f_ref)) < 1.0
    d2 = np.abs(np.diff(y, 2))
    assert d2[int(0.59 * 48000):int(0.7 * 48000)].max() < 3 * d2[int(0.45 * 48000):int(0.59 * 48000)].max()
