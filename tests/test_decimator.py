"""Tests of the streaming polyphase decimator (synth.dsp.decimator).

Reference: the slow, obvious definition of rational decimation, "zero-stuff
by L, np.convolve with the prototype h, keep every M-th sample".
"""

import time

import numpy as np
import pytest

from synth.dsp.decimator import Decimator, design_prototype
from synth.kernels.decimator import decimate

RATES = [325000, 336000, 324800]
FS_OUT = 48000
RIPPLE_DB = 0.01
STOP_DB = 100.0
MAX_LATENCY_S = 1.5e-3


@pytest.fixture(scope="module", params=RATES, ids=lambda fs: f"{fs}Hz")
def dec(request):
    return Decimator(request.param, FS_OUT)


def reference_decimate(x, h, L, M):
    """Zero-stuff by L, convolve with h, keep every M-th sample (slow, obvious)."""
    u = np.zeros(len(x) * L)
    u[::L] = x
    return np.convolve(u, h)[::M]


def fit_sine(y, f_hz, fs):
    """Least-squares complex amplitude of a sine at f_hz in y; returns (A, residual rms)."""
    t = np.arange(len(y)) / fs
    basis = np.stack([np.cos(2 * np.pi * f_hz * t), np.sin(2 * np.pi * f_hz * t)], axis=1)
    coef, *_ = np.linalg.lstsq(basis, y, rcond=None)
    resid = y - basis @ coef
    # y = a cos + b sin = Re{(a - i b) e^{i w t}}
    return coef[0] - 1j * coef[1], np.sqrt(np.mean(resid**2))


def db(v):
    return 20.0 * np.log10(v)


def settle_outputs(d):
    """Output samples to skip before the history is full of signal."""
    return int(np.ceil(len(d.h) / (d.L * d.fs_in) * d.fs_out)) + 4


# --- (1) the prototype --------------------------------------------------------


@pytest.mark.parametrize("fs_in", RATES)
def test_prototype_ripple_stopband_latency(fs_in):
    t0 = time.perf_counter()
    h, L, M = design_prototype(fs_in, FS_OUT)
    design_s = time.perf_counter() - t0
    assert design_s < 1.0, f"design took {design_s:.3f} s"
    assert L * fs_in == M * FS_OUT and np.gcd(L, M) == 1
    assert len(h) % L == 0
    np.testing.assert_allclose(h, h[::-1], rtol=0, atol=1e-15 * L)  # linear phase
    fs_proto = L * fs_in
    nfft = 1 << int(np.ceil(np.log2(32 * len(h))))  # bins of fs_proto/nfft < 20 Hz
    H = np.abs(np.fft.rfft(h / L, nfft))
    f = np.arange(len(H)) * fs_proto / nfft
    pass_db = db(H[f <= 20000.0])
    stop_db = -db(H[f >= 24000.0].max())
    assert np.abs(pass_db).max() <= RIPPLE_DB, f"ripple {np.abs(pass_db).max():.2e} dB"
    assert stop_db >= STOP_DB, f"stopband only {stop_db:.1f} dB"
    latency_s = (len(h) - 1) / 2 / fs_proto
    assert latency_s <= MAX_LATENCY_S


def test_polyphase_matrix_layout(dec):
    assert dec.phases.shape == (dec.L, dec.taps_per_phase)
    assert dec.phases.flags.c_contiguous and dec.phases.dtype == np.float64
    # row p, reversed, holds h[p], h[p + L], h[p + 2L], ...
    for p in (0, dec.L - 1):
        np.testing.assert_array_equal(dec.phases[p, ::-1], dec.h[p::dec.L])


# --- (2) end to end: passband and stopband sines -------------------------------


@pytest.mark.parametrize("f_hz", [100.0, 997.0, 5000.0, 12345.6, 19000.0, 20000.0])
def test_passband_sine_gain_and_frequency(dec, f_hz):
    n_in = int(0.05 * dec.fs_in)
    x = 0.7 * np.sin(2 * np.pi * f_hz * np.arange(n_in) / dec.fs_in + 0.3)
    y = dec.__class__(dec.fs_in, dec.fs_out).process(x)
    y = y[settle_outputs(dec):]
    half = len(y) // 2
    a1, r1 = fit_sine(y[:half], f_hz, dec.fs_out)
    a2, r2 = fit_sine(y[half:2 * half], f_hz, dec.fs_out)
    gain_db = db(0.5 * (abs(a1) + abs(a2)) / 0.7)
    assert abs(gain_db) <= RIPPLE_DB, f"gain {gain_db:.4f} dB at {f_hz} Hz"
    # residual: nothing else in the output (no alias, no wrong frequency)
    assert db(max(r1, r2) / 0.7) <= -90.0
    # frequency from the phase advance between the two halves
    dphi = np.angle(a2 / a1)
    dphi_expected = np.angle(np.exp(2j * np.pi * f_hz * half / dec.fs_out))
    err = np.angle(np.exp(1j * (dphi - dphi_expected)))
    f_meas = f_hz + err / (2 * np.pi * half / dec.fs_out)
    cents = 1200 * np.log2(f_meas / f_hz)
    assert abs(cents) <= 0.01, f"{cents:.4f} cents at {f_hz} Hz"


@pytest.mark.parametrize(
    "f_hz", [24000.0, 24300.0, 28000.0, 47000.0, 48000.0, 71000.0, 96500.0, 130000.0, 160000.0]
)
def test_stopband_sine_rejected(dec, f_hz):
    n_in = int(0.03 * dec.fs_in)
    x = np.sin(2 * np.pi * f_hz * np.arange(n_in) / dec.fs_in + 0.1)
    y = Decimator(dec.fs_in, dec.fs_out).process(x)[settle_outputs(dec):]
    level_db = db(np.sqrt(np.mean(y**2)) / np.sqrt(0.5))
    assert level_db <= -STOP_DB, f"{f_hz} Hz only {-level_db:.1f} dB down"


# --- (3) latency ---------------------------------------------------------------


def test_latency_ramp_and_sine_phase(dec):
    assert 0.0 < dec.latency_s <= MAX_LATENCY_S
    assert dec.latency_samples == pytest.approx(dec.latency_s * dec.fs_out)
    d = Decimator(dec.fs_in, dec.fs_out)
    # A ramp x(t) = t - t0 comes out as y(t) = t - t0 - latency: linear phase.
    n_in = int(0.02 * dec.fs_in)
    t0 = 0.01
    x = np.arange(n_in) / dec.fs_in - t0
    y = d.process(x)
    n = np.arange(len(y))
    sl = slice(settle_outputs(dec), len(y))
    delay_s = (n / dec.fs_out - t0 - y)[sl]
    assert np.max(np.abs(delay_s - dec.latency_s)) <= 1e-8, (
        f"ramp delay {delay_s.min() * 1e3:.6f}..{delay_s.max() * 1e3:.6f} ms, "
        f"latency_s {dec.latency_s * 1e3:.6f} ms"
    )
    # A 250 Hz sine (period 4 ms > latency) comes out delayed by latency_s
    # (phase delay = group delay for a linear-phase filter).
    d.reset()
    f_hz = 250.0
    x = np.cos(2 * np.pi * f_hz * np.arange(int(0.03 * dec.fs_in)) / dec.fs_in)
    y = d.process(x)
    k0 = settle_outputs(dec)
    a, _ = fit_sine(y[k0:], f_hz, dec.fs_out)
    # y[k0 + m] = cos(2 pi f ((k0 + m)/fs_out - delay)); the fit's time origin is k0.
    phase_expected = 2 * np.pi * f_hz * (k0 / dec.fs_out)
    delay_meas = -np.angle(a * np.exp(-1j * phase_expected)) / (2 * np.pi * f_hz)
    assert abs(delay_meas - dec.latency_s) <= 1e-8


def test_impulse_peak_at_latency(dec):
    d = Decimator(dec.fs_in, dec.fs_out)
    k0 = 1000  # impulse at input sample k0
    x = np.zeros(k0 + 3 * d.inputs_needed(200))
    x[k0] = 1.0
    y = d.process(x)
    t_peak = k0 / dec.fs_in + dec.latency_s  # where the prototype's centre lands
    n_peak = int(np.argmax(np.abs(y)))
    assert abs(n_peak - t_peak * dec.fs_out) <= 0.5 + 1e-9


# --- (4) streaming equals one-shot equals the reference ------------------------


def test_streaming_equals_one_shot(dec):
    rng = np.random.default_rng(1234)
    x = rng.standard_normal(60000)
    y_once = Decimator(dec.fs_in, dec.fs_out).process(x)
    d = Decimator(dec.fs_in, dec.fs_out)
    parts = []
    pos = 0
    while pos < len(x):
        k = int(rng.integers(1, 5001)) if rng.random() < 0.8 else int(rng.integers(1, 8))
        parts.append(d.process(x[pos:pos + k]))
        pos += k
    y_stream = np.concatenate(parts)
    assert len(y_stream) == len(y_once)
    np.testing.assert_allclose(y_stream, y_once, rtol=0, atol=1e-12)


@pytest.mark.slow  # over 2 s on a quiet 2-core machine
def test_matches_numpy_reference(dec):
    rng = np.random.default_rng(7)
    n_in = 2 * (len(dec.h) // dec.L) + 100  # well past the first full history
    x = rng.standard_normal(n_in)
    d = Decimator(dec.fs_in, dec.fs_out)
    y = np.concatenate([d.process(x[:333]), d.process(x[333:])])
    ref = reference_decimate(x, dec.h, dec.L, dec.M)
    assert len(y) == len(range(0, (n_in - 1) * dec.L + 1, dec.M))  # outputs at n M <= last input
    np.testing.assert_allclose(y, ref[:len(y)], rtol=0, atol=1e-12)


def test_kernel_matches_reference_directly():
    """The raw kernel, driven by hand, against the reference (small odd ratio)."""
    h, L, M = design_prototype(56000, 16000, 6000, 8000, 60)  # L/M = 2/7
    T = len(h) // L
    phases = np.ascontiguousarray(h.reshape(T, L).T[:, ::-1])
    hist = np.zeros(2 * T)
    state = np.array([0, 1, T - 1], dtype=np.int64)
    x = np.random.default_rng(3).standard_normal(4 * T + 11)
    out = np.full(len(x), np.nan)
    n = decimate(x, len(x), phases, L, M, hist, state, out)
    ref = reference_decimate(x, h, L, M)
    np.testing.assert_allclose(out[:n], ref[:n], rtol=0, atol=1e-12)
    assert np.isnan(out[n:]).all()  # nothing written past n_out


def test_reset_restarts(dec):
    x = np.random.default_rng(5).standard_normal(5000)
    d = Decimator(dec.fs_in, dec.fs_out)
    y1 = d.process(x)
    d.process(np.ones(777))
    d.reset()
    np.testing.assert_array_equal(d.process(x), y1)


# --- (5) inputs_needed ---------------------------------------------------------


def test_inputs_needed_gives_exactly_n_out(dec):
    rng = np.random.default_rng(99)
    d = Decimator(dec.fs_in, dec.fs_out)
    for _ in range(300):
        n_out = int(rng.integers(0, 600)) if rng.random() < 0.9 else int(rng.integers(0, 4))
        k = d.inputs_needed(n_out)
        assert d.outputs_for(k) == n_out
        if n_out > 0:
            assert d.outputs_for(k - 1) == n_out - 1  # no input more than needed
        y = d.process(rng.standard_normal(k))
        assert len(y) == n_out
    assert d.inputs_needed(0) == 0


def test_outputs_for_matches_kernel_for_odd_pushes(dec):
    rng = np.random.default_rng(11)
    d = Decimator(dec.fs_in, dec.fs_out)
    total_in = total_out = 0
    for _ in range(300):
        k = int(rng.integers(0, 40))
        expected = d.outputs_for(k)
        assert len(d.process(rng.standard_normal(k))) == expected
        total_in += k
        total_out += expected
    # overall count: outputs n with n M / L <= last input index
    assert total_out == (total_in - 1) * dec.L // dec.M + 1


def test_out_argument(dec):
    d = Decimator(dec.fs_in, dec.fs_out)
    x = np.random.default_rng(2).standard_normal(d.inputs_needed(50))
    buf = np.full(60, -1.0)
    y = d.process(x, out=buf)
    assert y.base is buf and len(y) == 50
    assert (buf[50:] == -1.0).all()
    d.reset()
    strided = np.zeros(100)[::2]
    y2 = d.process(x, out=strided)
    np.testing.assert_array_equal(y2, y)
    with pytest.raises(ValueError, match="out"):
        d.process(x, out=np.zeros(3))


# --- validation ----------------------------------------------------------------


@pytest.mark.parametrize(
    "fs_in, fs_out, name",
    [
        (48000, 48000, "fs_in"),
        (44100, 48000, "fs_in"),
        (325000.5, 48000, "fs_in"),
        (325000, 4000, "fs_out"),
        ("325000", 48000, "fs_in"),
        (True, 48000, "fs_in"),
        (325001, 48000, "fs_in"),  # L = 48000: prototype far too long
    ],
)
def test_bad_rates_rejected(fs_in, fs_out, name):
    with pytest.raises(ValueError, match=name):
        Decimator(fs_in, fs_out)


def test_integral_float_rates_accepted():
    d = Decimator(336000.0, 48000.0)
    assert (d.L, d.M, d.fs_in) == (1, 7, 336000)


@pytest.mark.parametrize(
    "kw, name",
    [
        (dict(passband_hz=24000.0, stopband_hz=24000.0), "passband_hz"),
        (dict(passband_hz=20000.0, stopband_hz=25000.0), "stopband_hz"),
        (dict(passband_hz=-1.0), "passband_hz"),
        (dict(atten_db=300.0), "atten_db"),
    ],
)
def test_bad_bands_rejected(kw, name):
    with pytest.raises(ValueError, match=name):
        design_prototype(336000, 48000, **kw)


def test_bad_input_rejected_without_touching_state():
    d = Decimator(336000)
    x = np.random.default_rng(0).standard_normal(100)
    y_ok = Decimator(336000).process(np.concatenate([x, x]))
    d.process(x)
    bad = x.copy()
    bad[17] = np.nan
    with pytest.raises(ValueError, match=r"x\[17\]"):
        d.process(bad)
    with pytest.raises(ValueError, match="1-D"):
        d.process(np.zeros((2, 3)))
    with pytest.raises(ValueError, match="n_out"):
        d.inputs_needed(-1)
    # the failed calls changed nothing
    np.testing.assert_array_equal(np.concatenate([Decimator(336000).process(x), d.process(x)]), y_ok)
