"""The radiation's spread (issue 41): the allpass cascade's design
(synth.physics.soundboard.spread_allpasses), kernel
(synth.kernels.spread) and wrapper (synth.dsp.spread.Spread), and the
body that runs it.  The slow reference is scipy.signal.lfilter, one call
per allpass."""

import numpy as np
import pytest
from scipy.signal import lfilter

from synth.dsp.body import Body
from synth.dsp.spread import Spread
from synth.kernels.spread import allpass_cascade
from synth.physics import soundboard as sb

FS = 48000


def reference(x, delays, gains):
    """x (C, n) through each (-g + z^-D) / (1 - g z^-D) in turn."""
    y = np.array(x, dtype=float)
    for D, g in zip(delays, gains):
        b = np.zeros(D + 1)
        a = np.zeros(D + 1)
        b[0], b[D], a[0], a[D] = -g, 1.0, 1.0, -g
        y = lfilter(b, a, y, axis=-1)
    return y


def test_the_design_is_three_allpasses_in_the_golden_ratio():
    """spread_ms times 0.382, 0.618 and 1, rounded to samples, gain 0.5;
    none at 0; the range named in the error."""
    d, g = sb.spread_allpasses(FS, 3.4)
    assert list(d) == [62, 101, 163] and list(g) == [0.5, 0.5, 0.5]
    d, _ = sb.spread_allpasses(96000, 3.4)
    assert list(d) == [125, 202, 326]
    d, _ = sb.spread_allpasses(FS, 0.01)          # too short for three delays: 1, 2, 3 samples
    assert list(d) == [1, 2, 3]
    d, g = sb.spread_allpasses(FS, 0.0)
    assert d.size == 0 and g.size == 0
    for bad in (-1.0, 20.5, float("nan"), True, "3"):
        with pytest.raises(ValueError, match=r"spread_ms = .* is out of range \(0 <= value <= 20\)"):
            sb.spread_allpasses(FS, bad)
    with pytest.raises(ValueError, match="spread_ms = 0 ms is out of range"):
        Spread(FS, 0)
    with pytest.raises(ValueError, match="channels = 3"):
        Spread(FS, 3.4, channels=3)


@pytest.mark.parametrize("channels", [1, 2])
def test_the_kernel_matches_the_reference_in_blocks_of_any_length(channels):
    rng = np.random.default_rng(5)
    x = rng.standard_normal((channels, 6000))
    ref = reference(x, *sb.spread_allpasses(FS, 3.4))
    one = Spread(FS, 3.4, channels)
    y1 = x.copy()
    one.process(y1 if channels == 2 else y1[0])
    np.testing.assert_allclose(y1, ref, rtol=0, atol=1e-12)
    s = Spread(FS, 3.4, channels)
    y = x.copy()
    i = 0
    for n in list(rng.integers(0, 400, 40)) + [6000]:
        n = int(min(n, 6000 - i))
        s.process(y[:, i:i + n])
        i += n
    assert i == 6000
    np.testing.assert_array_equal(y, y1)      # the same samples, wherever blocks begin


def test_a_strided_block_gives_the_same_samples():
    """A (2, n) view with a stride along n (a transposed array) goes
    through a temporary block."""
    rng = np.random.default_rng(1)
    x = rng.standard_normal((2, 1000))
    a = Spread(FS, 2.0, 2)
    b = Spread(FS, 2.0, 2)
    y = x.copy()
    a.process(y)
    t = np.asfortranarray(x.copy())
    b.process(t)
    np.testing.assert_array_equal(t, y)


def test_gain_one_at_every_frequency_and_the_first_arrival_an_eighth():
    """The cascade changes no partial's steady level: |H| = 1 (closed form)
    and a steady sine comes out at its own amplitude; white noise keeps its
    power; the impulse response starts at (-g)^3 = -0.125 and its energy
    arrives over the delays (half of it after 2 ms at 3.4 ms)."""
    s = Spread(FS, 3.4)
    f = np.linspace(20.0, 20000.0, 5001)
    np.testing.assert_allclose(np.abs(s.response(f)), 1.0, atol=1e-12)
    t = np.arange(FS) / FS
    y = np.sin(2 * np.pi * 3520.0 * t)
    s.process(y)
    assert np.sqrt(2 * np.mean(y[FS // 2:] ** 2)) == pytest.approx(1.0, abs=2e-3)
    s.reset()
    h = np.zeros(FS)
    h[0] = 1.0
    s.process(h)
    assert h[0] == -0.125 and np.sum(h ** 2) == pytest.approx(1.0, abs=1e-9)
    e = np.cumsum(h ** 2)
    assert e[int(0.002 * FS)] < 0.5 < e[int(0.006 * FS)]


def test_silence_ends_in_exact_zeros():
    """After the input stops the lines reach exact zeros (no subnormal
    arithmetic in a silent stage)."""
    s = Spread(FS, 3.4, 2)
    y = np.zeros((2, FS))
    y[:, 0] = 1.0
    s.process(y)
    z = np.zeros((2, 10 * FS))
    s.process(z)
    assert not s._lines.any()
    assert not np.any((z != 0) & (np.abs(z) < np.finfo(float).tiny))


@pytest.mark.parametrize("io", [(1, 1), (2, 2)])
def test_a_body_with_a_spread_is_the_body_then_the_cascade(io):
    """Body(spread_ms=...) = the same body without it, then Spread on each
    output; its response is the body's times the cascade's (same
    magnitude); reset and impulse_response leave no trace; a fresh copy
    starts at rest."""
    B, C = io
    plain = Body(FS, inputs=B, outputs=C, wet=0.38)
    spread = Body(FS, inputs=B, outputs=C, wet=0.38, spread_ms=3.4)
    rng = np.random.default_rng(2)
    x = rng.standard_normal((B, 3000))
    xin = x if B == 2 else x[0]
    y0 = plain.process(xin)
    y0 = np.array(y0, ndmin=2)
    want = reference(y0, *sb.spread_allpasses(FS, 3.4))
    h_before = spread.impulse_response(500)
    got = np.array(spread.process(xin), ndmin=2)
    np.testing.assert_allclose(got, want, atol=1e-12)
    np.testing.assert_array_equal(spread.impulse_response(500), h_before)
    f = np.array([100.0, 1000.0, 3520.0])
    np.testing.assert_allclose(np.abs(spread.response(f)), np.abs(plain.response(f)), rtol=1e-12)
    fresh = spread.fresh_copy()
    assert not fresh.spread._lines.any() and spread.spread._lines.any()
    spread.reset()
    assert not spread.spread._lines.any()
    again = np.array(spread.process(xin), ndmin=2)
    np.testing.assert_array_equal(again, got)


def test_the_grand_has_the_spread_and_a_preset_may_set_it():
    """The grand preset's [body] spread_ms (3.4 ms, fitted to the recorded
    C5's time to the RMS peak); the other presets none; a value out of
    range is refused with its name and range."""
    from synth.io.factory import build_voice
    from synth.io.errors import PresetError

    assert build_voice("grand-piano").body().spread_ms == 3.4
    assert build_voice("sitar").body().spread_ms == 0.0
    assert build_voice("sitar", ["body.spread_ms=2"]).body().spread_ms == 2.0
    with pytest.raises(PresetError, match=r"spread_ms.*20"):
        build_voice("grand-piano", ["body.spread_ms=25"])


def test_the_raw_kernel_with_odd_delays_and_gains():
    """The kernel alone (no wrapper): delays 1, 7 and 50 samples, gains of
    both signs, three channels, a block longer than every line and then
    short ones, against the reference."""
    delays = np.array([1, 7, 50], dtype=np.int64)
    gains = np.array([-0.7, 0.3, 0.9])
    offsets = np.array([0, 1, 8], dtype=np.int64)
    rng = np.random.default_rng(9)
    x = rng.standard_normal((3, 700))
    lines = np.zeros((3, 58))
    pos = np.zeros(3, dtype=np.int64)
    y = x.copy()
    for a, b in ((0, 400), (400, 403), (403, 700)):
        allpass_cascade(y[:, a:], b - a, delays, gains, offsets, lines, pos)
    np.testing.assert_allclose(y, reference(x, delays, gains), rtol=0, atol=1e-12)
    assert list(pos) == [0, 700 % 7, 700 % 50]
