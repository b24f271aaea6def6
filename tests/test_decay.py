"""synth.analysis.decay against signals whose decay is known in closed form."""

import numpy as np
import pytest

from synth.analysis import decay_curve_db, t60_s
from synth.engine.engine import Event
from synth.io.factory import build_engine

FS = 48_000


def _decaying(f_hz, t60, amp=0.5, seconds=3.0, phase=0.3):
    t = np.arange(int(seconds * FS)) / FS
    return amp * np.exp(-np.log(1000.0) * t / t60) * np.sin(2 * np.pi * f_hz * t + phase)


def test_a_steady_sine_reads_its_amplitude():
    t = np.arange(FS) / FS
    _, db = decay_curve_db(0.25 * np.sin(2 * np.pi * 440 * t), FS, f_hz=440.0)
    assert np.allclose(db, 20 * np.log10(0.25), atol=0.01)
    # broadband RMS: exact over whole periods (450 Hz: 9 in a 20 ms frame),
    # within 0.15 dB otherwise
    _, db = decay_curve_db(0.25 * np.sin(2 * np.pi * 450 * t), FS)
    assert np.allclose(db, 20 * np.log10(0.25 / np.sqrt(2)), atol=1e-9)
    _, db = decay_curve_db(0.25 * np.sin(2 * np.pi * 440 * t), FS)
    assert np.allclose(db, 20 * np.log10(0.25 / np.sqrt(2)), atol=0.15)


@pytest.mark.parametrize("t60", [0.3, 1.5, 6.0])
def test_t60_of_an_exponential_decay(t60):
    x = _decaying(220.0, t60, seconds=min(3.0, 1.2 * t60) if t60 < 3 else 3.0)
    rng = np.random.default_rng(1)
    x = x + 1e-6 * rng.standard_normal(len(x))              # a noise floor at -120 dB
    assert t60_s(x, FS, stop_db=-25.0 if t60 > 3 else -35.0) == pytest.approx(t60, rel=0.02)
    assert t60_s(x, FS, f_hz=220.0, stop_db=-25.0 if t60 > 3 else -35.0) == \
        pytest.approx(t60, rel=0.02)


def test_each_partial_has_its_own_t60():
    """Two partials decaying at 2.0 s and 0.4 s: f_hz picks each one."""
    x = _decaying(200.0, 2.0) + _decaying(1000.0, 0.4, amp=0.3)
    assert t60_s(x, FS, f_hz=200.0) == pytest.approx(2.0, rel=0.02)
    assert t60_s(x, FS, f_hz=1000.0) == pytest.approx(0.4, rel=0.02)


def test_bad_arguments_are_one_line_errors():
    x = _decaying(200.0, 1.0)
    with pytest.raises(ValueError, match=r"f_hz=30000.0 out of range"):
        decay_curve_db(x, FS, f_hz=30000.0)
    with pytest.raises(ValueError, match=r"at least 4 periods of f_hz=50"):
        decay_curve_db(x, FS, f_hz=50.0, frame_s=0.02)
    with pytest.raises(ValueError, match=r"does not fall from -5 to -35 dB"):
        t60_s(np.sin(np.arange(FS) * 0.1), FS)
    with pytest.raises(ValueError, match=r"stop_db=-1 out of range"):
        t60_s(x, FS, start_db=-5.0, stop_db=-1)


def test_a_rendered_string_decays_as_its_loop_is_designed():
    """A biwa string without its sawari: the fundamental's T60 equals the
    one its loop filter gives at f0 (the filter's magnitude there)."""
    e = build_engine("biwa", ["termination.profile=none", "loss.t60_low_s=2.0"])
    f0 = e.inst.pitch_hz(52)
    y = e.render([Event(0.0, "note_on", 52, 1.0)], duration_s=2.5)
    su = e.inst.setup(52)
    w = 2 * np.pi * f0 / e.inst.fs
    g = abs(su.b0 / (1 + su.a1 * np.exp(-1j * w)))
    expected = -3.0 / (f0 * np.log10(g))
    assert t60_s(y[int(0.2 * FS):], FS, f_hz=f0, stop_db=-20.0) == pytest.approx(expected, rel=0.03)


def test_two_stage_summary_reads_a_prompt_sound_and_an_aftersound():
    """A tone of two components, one falling with T60 1 s from 0 dB, one
    with T60 8 s from -25 dB: the knee near where they cross, the ratio near
    8, visible; one component alone has no visible knee."""
    from synth.analysis import two_stage_summary

    fs = 8000
    t = np.arange(int(6 * fs)) / fs
    fast = np.sin(2 * np.pi * 200 * t) * 10 ** (-3 * t / 1.0)
    slow = 10 ** (-25 / 20) * np.sin(2 * np.pi * 201 * t + 0.4) * 10 ** (-3 * t / 8.0)
    r = two_stage_summary(fast + slow, fs)
    assert r["visible"]
    assert 5.0 < r["ratio"] < 14.0       # (the two components beat near the knee)
    assert 0.25 < r["knee_s"] < 0.7
    assert r["knee_drop_db"] > 15 and r["late_span_db"] > 10
    one = two_stage_summary(fast, fs)
    assert one["ratio"] == pytest.approx(1.0, abs=0.05) and not one["visible"]
