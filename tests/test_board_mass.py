"""The board's mass law (issue 41): its design
(synth.physics.soundboard.mass_section), kernel (synth.kernels.board_mass)
and wrapper (synth.dsp.board_mass.BoardMass), and the body that runs it.
The slow reference is scipy.signal.lfilter."""

import numpy as np
import pytest
from scipy.signal import lfilter

from synth.dsp.board_mass import BoardMass
from synth.dsp.body import Body
from synth.kernels.board_mass import mass_section
from synth.physics import soundboard as sb

FS = 48000


def reference(x, section):
    """x (C, n) through g (1 + b z^-1) / (1 - a z^-1)."""
    g, b, a = section
    return lfilter([g, g * b], [1.0, -a], np.asarray(x, dtype=float), axis=-1)


def _db(section, f, fs):
    g, b, a = section
    z1 = np.exp(-2j * np.pi * np.asarray(f) / fs)
    return 20 * np.log10(np.abs(g * (1 + b * z1) / (1 - a * z1)))


def test_the_section_and_its_range():
    """Unit gain at 0 Hz; (1, 0, 0) for no corner; out of range, at or
    over fs / 2, or not a number: refused with the name and the range."""
    g, b, a = sb.mass_section(FS, 3000.0)
    assert 0 < a < 1 and abs(b) < 1 and g == pytest.approx((1 - a) / (1 + b), rel=1e-15)
    assert sb.mass_section(FS, 0.0) == (1.0, 0.0, 0.0)
    for bad in (-1.0, 20001.0, float("nan"), True, "2000"):
        with pytest.raises(ValueError, match=r"mass_hz = .* is out of range \(0 <= value <= 20000\)"):
            sb.mass_section(FS, bad)
    with pytest.raises(ValueError, match=r"mass_hz = 12000 Hz is out of range \(0 <= value < fs / 2 = 12000\)"):
        sb.mass_section(24000, 12000)
    with pytest.raises(ValueError, match="mass_hz = 0 Hz is out of range"):
        BoardMass(FS, 0)
    with pytest.raises(ValueError, match="channels = 3"):
        BoardMass(FS, 2000.0, channels=3)


@pytest.mark.parametrize("fs, below_5k_db, below_19k_db", [
    (44_100, 0.025, 0.35), (48_000, 0.02, 0.2), (88_200, 0.002, 0.015), (96_000, 0.002, 0.015)])
def test_its_response_is_a_mass_above_the_corner_at_every_card_rate(fs, below_5k_db, below_19k_db):
    """|1 / (1 + j f / fc)| with fc = 3 kHz, the grand's: within 0.025 dB
    below 5 kHz and 0.35 dB up to 19 kHz at 44.1 kHz, closer at the
    higher rates (where the matched-z pole alone, b = 0, was 0.18 dB and
    2.8 dB off at 44.1 kHz)."""
    f = np.geomspace(30.0, 19_000.0, 1500)
    want = -10 * np.log10(1 + (f / 3000.0) ** 2)
    d = _db(sb.mass_section(fs, 3000.0), f, fs) - want
    assert np.abs(d[f < 5000]).max() < below_5k_db
    assert np.abs(d).max() < below_19k_db
    a0 = np.exp(-2 * np.pi * 3000.0 / fs)
    pole = _db(((1 - a0), 0.0, a0), f, fs) - want
    assert np.abs(pole).max() > 4 * np.abs(d).max()


def test_its_steady_sine_is_its_response():
    """Gain 1 at 0 Hz, -3 dB at the corner; a steady 4 kHz sine comes out
    at the response's level."""
    m = BoardMass(FS, 2000.0)
    f = np.array([1e-3, 2000.0, 4000.0])
    got = 20 * np.log10(np.abs(m.response(f)))
    assert got[0] == pytest.approx(0.0, abs=1e-9) and got[1] == pytest.approx(-3.0, abs=0.05)
    t = np.arange(FS) / FS
    y = np.sin(2 * np.pi * 4000.0 * t)
    m.process(y)
    level = 20 * np.log10(np.sqrt(2 * np.mean(y[FS // 2:] ** 2)))
    assert level == pytest.approx(got[2], abs=0.01)


@pytest.mark.parametrize("channels", [1, 2])
def test_the_kernel_matches_the_reference_in_blocks_of_any_length(channels):
    rng = np.random.default_rng(5)
    x = rng.standard_normal((channels, 6000))
    ref = reference(x, sb.mass_section(FS, 2000.0))
    one = BoardMass(FS, 2000.0, channels)
    y1 = x.copy()
    one.process(y1 if channels == 2 else y1[0])
    np.testing.assert_allclose(y1, ref, rtol=0, atol=1e-12)
    s = BoardMass(FS, 2000.0, channels)
    y = x.copy()
    i = 0
    for n in list(rng.integers(0, 400, 40)) + [6000]:
        n = int(min(n, 6000 - i))
        s.process(y[:, i:i + n])
        i += n
    assert i == 6000
    np.testing.assert_array_equal(y, y1)      # the same samples, wherever blocks begin


def test_the_raw_kernel_three_channels_and_a_strided_block():
    """The kernel alone on three channels against the reference; a (2, n)
    view with a stride along n goes through a temporary block and gives
    the same samples."""
    sec = (0.04, 0.25, 0.95)
    rng = np.random.default_rng(9)
    x = rng.standard_normal((3, 700))
    y = x.copy()
    state = np.zeros((3, 2))
    for lo, hi in ((0, 400), (400, 403), (403, 700)):
        mass_section(y[:, lo:], hi - lo, *sec, state)
    np.testing.assert_allclose(y, reference(x, sec), rtol=0, atol=1e-12)
    x2 = rng.standard_normal((2, 1000))
    p, q = BoardMass(FS, 3000.0, 2), BoardMass(FS, 3000.0, 2)
    y2 = x2.copy()
    p.process(y2)
    t = np.asfortranarray(x2.copy())
    q.process(t)
    np.testing.assert_array_equal(t, y2)


def test_silence_ends_in_exact_zeros():
    """After the input stops the state reaches exact zero and no output
    sample is subnormal (a silent stage does no subnormal arithmetic)."""
    m = BoardMass(FS, 2000.0, 2)
    y = np.zeros((2, FS))
    y[:, 0] = 1.0
    m.process(y)
    z = np.zeros((2, FS))
    m.process(z)
    assert not m._state.any()
    assert not np.any((z != 0) & (np.abs(z) < np.finfo(float).tiny))


@pytest.mark.parametrize("io", [(1, 1), (2, 2)])
def test_a_body_with_a_mass_is_the_body_then_the_low_pass(io):
    """Body(mass_hz=...) = the same body without it, then the low-pass on
    each output; its response is the body's times the pole's; reset and
    impulse_response leave no trace; a fresh copy starts at rest."""
    B, C = io
    plain = Body(FS, inputs=B, outputs=C, wet=0.38, spread_ms=3.4)
    heavy = Body(FS, inputs=B, outputs=C, wet=0.38, spread_ms=3.4, mass_hz=2000.0)
    rng = np.random.default_rng(2)
    x = rng.standard_normal((B, 3000))
    xin = x if B == 2 else x[0]
    y0 = np.array(plain.process(xin), ndmin=2)
    want = reference(y0, sb.mass_section(FS, 2000.0))
    h_before = heavy.impulse_response(500)
    got = np.array(heavy.process(xin), ndmin=2)
    np.testing.assert_allclose(got, want, atol=1e-12)
    np.testing.assert_array_equal(heavy.impulse_response(500), h_before)
    f = np.array([100.0, 1000.0, 3520.0])
    np.testing.assert_allclose(heavy.response(f), plain.response(f) * heavy.mass.response(f), rtol=1e-12)
    fresh = heavy.fresh_copy()
    assert not fresh.mass._state.any() and heavy.mass._state.any()
    heavy.reset()
    assert not heavy.mass._state.any()
    again = np.array(heavy.process(xin), ndmin=2)
    np.testing.assert_array_equal(again, got)


def test_the_grand_has_the_mass_and_a_preset_may_set_it():
    """The grand preset's [body] mass_hz (3 kHz, fitted to the recorded
    C5); the other presets none; a value out of range is refused with its
    name and range."""
    from synth.io.errors import PresetError
    from synth.io.factory import build_voice

    assert build_voice("grand-piano").body().mass_hz == 3000.0
    assert build_voice("sitar").body().mass_hz == 0.0
    assert build_voice("sitar", ["body.mass_hz=3000"]).body().mass_hz == 3000.0
    with pytest.raises(PresetError, match=r"mass_hz.*20000"):
        build_voice("grand-piano", ["body.mass_hz=25000"])


KEPT_SCRIPT = r"""
import sys
from synth.dsp.body import Body
from synth.voices import design_store
b = Body(48000.0, n_modes=8, inputs=2, outputs=2, store=design_store, mass_hz=3000.0)
print(repr((b.mass.g, b.mass.b, b.mass.a)), "scipy.optimize" in sys.modules)
"""


@pytest.mark.slow  # two subprocesses
def test_a_warm_start_loads_the_section_and_imports_no_fit(tmp_path):
    """A body built with the design store fits its mass section once: the
    next process loads the same (g, b, a) and does not import
    scipy.optimize (0.3-0.5 s of a warm grand note on a 2-vCPU Zen 3)."""
    import os
    import subprocess
    import sys

    env = dict(os.environ, SYNTH_DESIGN_CACHE=str(tmp_path / "designs"))
    runs = [subprocess.run([sys.executable, "-c", KEPT_SCRIPT], env=env, capture_output=True,
                           text=True, timeout=300) for _ in range(2)]
    for p in runs:
        assert p.returncode == 0, p.stderr
    (s1, fit1), (s2, fit2) = (p.stdout.rsplit(" ", 1) for p in runs)
    assert s1 == s2 == repr(sb.mass_section(48000.0, 3000.0))
    assert (fit1.strip(), fit2.strip()) == ("True", "False")


def test_a_given_section_is_checked():
    good = sb.mass_section(48000.0, 3000.0)
    assert BoardMass(48000.0, 3000.0, 2, good).a == good[2]
    with pytest.raises(ValueError, match="section"):
        BoardMass(48000.0, 3000.0, 1, (1.0, 0.0, 1.5))
    with pytest.raises(ValueError, match="mass_hz"):
        BoardMass(48000.0, 30000.0, 1, good)
