"""synth.analysis.click_scan against signals whose answer is known in closed form."""

import numpy as np
import pytest

from synth.analysis import click_scan

FS = 48_000


def _sine(f, amp=0.5, seconds=1.0):
    t = np.arange(int(seconds * FS)) / FS
    return amp * np.sin(2 * np.pi * f * t + 0.3)


def test_a_steady_sine_reads_its_crest_factor():
    """d of a sine is a sine of amplitude A (2 sin(pi f / fs))^2: its peak
    over its RMS is sqrt(2), 3.01 dB, in every frame."""
    r = click_scan(_sine(1000.0), FS)
    assert r["judged"].all()
    inner = r["jump_db"][5:-5]
    assert np.allclose(inner, 20 * np.log10(np.sqrt(2)), atol=0.05)
    assert r["worst_jump_db"] < 3.2
    assert r["worst_highband_db"] < -100          # nothing above 14 kHz


@pytest.mark.parametrize("where_s", [0.3001, 0.61237])
def test_a_step_stands_out_by_its_height_over_the_smooth_second_difference(where_s):
    """A step of height a on a 100 Hz sine: d gets +-a at the step, the
    sine's own d has RMS A (2 sin(pi f/fs))^2 / sqrt(2)."""
    A, a, f = 0.5, 0.01, 100.0
    x = _sine(f, A)
    i = int(where_s * FS)
    x[i:] += a
    r = click_scan(x, FS)
    d_rms = A * (2 * np.sin(np.pi * f / FS)) ** 2 / np.sqrt(2)
    expect = 20 * np.log10(a / d_rms)
    assert r["worst_jump_db"] == pytest.approx(expect, abs=0.1)
    assert r["worst_jump_s"] <= where_s < r["worst_jump_s"] + 0.005 + 1 / FS


def test_a_smooth_onset_after_silence_is_not_a_click_but_a_switched_on_sine_is():
    """A tone faded in over 2 ms (as a felt hammer's force rises) after
    silence reads a few dB; the same tone switched on at zero phase has a
    kink: d jumps to A sin(2 pi f / fs), 1 / (2 sin(pi f / fs)) times the
    tone's own peak d, plus its crest factor."""
    A, f = 0.5, 440.0
    t = np.arange(FS // 2) / FS
    tone = A * np.sin(2 * np.pi * f * t)
    x = np.zeros(FS)
    x[FS // 2:] = tone * np.minimum(1.0, 0.5 - 0.5 * np.cos(np.pi * np.minimum(t / 0.002, 1.0)))
    assert click_scan(x, FS)["worst_jump_db"] < 8.0
    x[FS // 2:] = tone
    r = click_scan(x, FS)
    w = 2 * np.pi * f / FS
    expect = 20 * np.log10(np.sin(w) / (4 * np.sin(w / 2) ** 2 / np.sqrt(2)))
    # the context is the tone on one side, silence on the other: half its mean square
    assert r["worst_jump_db"] == pytest.approx(expect - 10 * np.log10(0.5), abs=0.2)
    assert r["worst_jump_s"] == 0.5


def test_white_noise_has_its_share_above_the_high_band_edge():
    rng = np.random.default_rng(3)
    r = click_scan(0.1 * rng.standard_normal(FS), FS)
    # the share of a flat spectrum above 14 kHz: (24 - 14) / 24
    assert np.median(r["highband_db"]) == pytest.approx(10 * np.log10(10 / 24), abs=0.3)


def test_quiet_frames_are_not_judged_and_silence_has_no_worst():
    x = _sine(200.0)
    x[: FS // 2] *= 1e-4                                   # -80 dB
    r = click_scan(x, FS, floor_db=-50.0)
    assert not r["judged"][: 90].any() and r["judged"][110:].all()
    s = click_scan(np.zeros(FS), FS)
    assert s["worst_jump_db"] == -np.inf and s["worst_jump_s"] is None


def test_bad_arguments_are_one_line_errors():
    with pytest.raises(ValueError, match="frame_s=0.0001 out of range"):
        click_scan(_sine(100.0), FS, frame_s=1e-4)
    with pytest.raises(ValueError, match="context_frames=0 out of range"):
        click_scan(_sine(100.0), FS, context_frames=0)
    with pytest.raises(ValueError, match="at least 2640 required"):
        click_scan(np.zeros(100), FS)


def test_ignored_times_are_not_judged():
    """A step inside the window after an ignored time (a note's attack) is
    not judged; the same step elsewhere still is."""
    A, a, f = 0.5, 0.01, 100.0
    x = _sine(f, A)
    i = int(0.3001 * FS)
    x[i:] += a
    hit = click_scan(x, FS)["worst_jump_db"]
    r = click_scan(x, FS, ignore_s=[0.2995], ignore_window_s=0.01)
    assert r["worst_jump_db"] < hit - 20
    assert not r["judged"][int(0.3001 * FS) // 240]
    r2 = click_scan(x, FS, ignore_s=[0.5], ignore_window_s=0.01)
    assert r2["worst_jump_db"] == pytest.approx(hit)
    with pytest.raises(ValueError, match="ignore_s must hold finite times"):
        click_scan(x, FS, ignore_s=[np.nan])
