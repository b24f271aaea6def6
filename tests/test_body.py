"""Soundboard body stage: mode set (physics), kernels (numba) and Body (dsp).

The slow reference is scipy.signal.lfilter, one call per mode and path,
summed; the evenness criterion is checked on the closed-form response.
"""

import math
import tracemalloc

import numpy as np
import pytest
from scipy.signal import lfilter

from synth.dsp.body import Body
from synth.kernels.body import body_process, body_process_mimo
from synth.physics import soundboard as sb

FS = 48000
CONFIGS = [(1, 1), (1, 2), (2, 1), (2, 2)]


def db(power_ratio):
    return 10.0 * math.log10(power_ratio)


def reference_bank(x, coefs):
    """Sum over modes of b0 (1 - z^-2) / (1 + a1 z^-1 + a2 z^-2) applied to x."""
    y = np.zeros(len(x))
    for b0, a1, a2 in coefs.T:
        y += lfilter([b0, 0.0, -b0], [1.0, a1, a2], x)
    return y


def reference_body(x, body):
    """x (B, n) -> (C, n): direct part plus one lfilter per mode and path."""
    m = body.modes
    y = np.zeros((body.outputs, x.shape[1]))
    for c in range(body.outputs):
        for b in range(body.inputs):
            y[c] += body.dry_gain * m.dry[c, b] * x[b]
            y[c] += body.wet_gain * reference_bank(x[b], body._bank(c, b))
    return y


def as_io(x, body):
    """(B, n) test signal in the shape process takes (1-D for one input)."""
    return x if body.inputs == 2 else x[0]


@pytest.fixture(scope="module")
def body():
    return Body(FS)


# --- streaming, reference, identity -------------------------------------------


@pytest.mark.parametrize("io", CONFIGS)
@pytest.mark.parametrize("kw", [{}, dict(n_modes=40, wet=0.3, size=0.7, brightness=-4.0)])
def test_streaming_in_random_blocks_equals_one_shot(kw, io):
    rng = np.random.default_rng(2024)
    B, C = io
    x = rng.standard_normal((B, 30000))
    y_once = np.atleast_2d(Body(FS, inputs=B, outputs=C, **kw).process(as_io(x, Body(FS, inputs=B))))
    b = Body(FS, inputs=B, outputs=C, **kw)
    parts, pos = [], 0
    while pos < x.shape[1]:
        k = int(rng.integers(0, 8)) if rng.random() < 0.4 else int(rng.integers(8, 3000))
        parts.append(np.atleast_2d(b.process(as_io(x[:, pos:pos + k], b))).copy())
        pos += k
    y_stream = np.concatenate(parts, axis=1)
    assert y_stream.shape == (C, x.shape[1])
    np.testing.assert_allclose(y_stream, y_once, rtol=0, atol=1e-12)


@pytest.mark.parametrize("io", CONFIGS)
@pytest.mark.parametrize("kw", [{}, dict(n_modes=40, wet=0.3, size=0.7, brightness=-4.0),
                                dict(n_modes=120, wet=1.0, size=1.6, brightness=5.0, seed=9)])
def test_matches_lfilter_reference(kw, io):
    B, C = io
    b = Body(FS, inputs=B, outputs=C, **kw)
    x = np.random.default_rng(5).standard_normal((B, 12000))
    y = np.concatenate([np.atleast_2d(b.process(as_io(x[:, :777], b))),
                        np.atleast_2d(b.process(as_io(x[:, 777:], b)))], axis=1)
    np.testing.assert_allclose(y, reference_body(x, b), rtol=0, atol=1e-9)


def test_raw_kernel_matches_reference_with_odd_gains():
    """The mono kernel driven by hand (dry, wet arbitrary, odd length, in place)."""
    m = sb.soundboard_modes(FS, n_modes=17, seed=4)
    coefs = sb.resonator_coefs(FS, m.freqs_hz, m.t60_s, m.pickup[0] * m.drive[0])
    state = np.zeros((2, 18))
    x = np.random.default_rng(8).standard_normal(1003)
    buf = np.concatenate([x, [np.nan, np.nan]])
    body_process(buf, 1003, coefs, state, -0.7, 1.9, buf)  # in place
    ref = -0.7 * x + 1.9 * reference_bank(x, coefs)
    np.testing.assert_allclose(buf[:1003], ref, rtol=0, atol=1e-9)
    assert np.isnan(buf[1003:]).all()  # nothing written past n
    np.testing.assert_array_equal(state[:, 17], x[[-2, -1]])  # input history


def test_raw_mimo_kernel_in_place_with_odd_gains():
    """The 2 x 2 kernel by hand: signed drives, gains and direct matrix, odd
    length, output written over its own input."""
    rng = np.random.default_rng(3)
    m = sb.soundboard_modes(FS, n_modes=23, seed=2)
    unit = sb.resonator_coefs(FS, m.freqs_hz, m.t60_s, np.ones(23))
    drive = rng.standard_normal((2, 23))
    pick = rng.standard_normal((2, 23))
    dry = np.array([[0.3, -1.2], [0.8, 0.1]])
    state = np.zeros((2, 25))
    x = rng.standard_normal((2, 1001))
    buf = np.full((2, 1004), np.nan)
    buf[:, :1001] = x
    body_process_mimo(buf, 1001, drive, unit[0] * pick, unit, state, dry, 1.7, buf)
    for c in range(2):
        ref = dry[c] @ x
        for b in range(2):
            k = unit.copy()
            k[0] *= pick[c] * drive[b]
            ref = ref + 1.7 * reference_bank(x[b], k)
        np.testing.assert_allclose(buf[c, :1001], ref, rtol=0, atol=1e-9)
    assert np.isnan(buf[:, 1001:]).all()
    np.testing.assert_array_equal(state[:, 23], x[0, [-2, -1]])
    np.testing.assert_array_equal(state[:, 24], x[1, [-2, -1]])


@pytest.mark.parametrize("io", CONFIGS)
def test_wet_zero_is_the_direct_part(io):
    B, C = io
    b = Body(FS, wet=0.0, inputs=B, outputs=C)
    assert b.dry_gain == 1.0 and b.wet_gain == 0.0
    x = np.random.default_rng(1).standard_normal((B, 5001))
    np.testing.assert_allclose(np.atleast_2d(b.process(as_io(x, b))), b.modes.dry @ x,
                               rtol=0, atol=1e-15)
    if io == (1, 1):
        imp = b.impulse_response(100)
        assert imp[0] == 1.0 and not imp[1:].any()


def test_direct_part_per_configuration():
    """Mono: 1. One in, two out: the input on both. Two in, one out: the sum.
    Two in, two out: bass end mostly left, treble end mostly right."""
    assert Body(FS).modes.dry.tolist() == [[1.0]]
    np.testing.assert_allclose(Body(FS, outputs=2).modes.dry, [[2 ** -0.5], [2 ** -0.5]])
    np.testing.assert_allclose(Body(FS, inputs=2).modes.dry, [[1.0, 1.0]])
    d = Body(FS, inputs=2, outputs=2).modes.dry
    assert d[0, 0] == d[1, 1] > d[0, 1] == d[1, 0] > 0.0
    assert (d * d).sum() / 2 == pytest.approx(1.0)


def test_out_argument_in_place_and_strided(body):
    x = np.random.default_rng(3).standard_normal(1000)
    body.reset()
    y = body.process(x).copy()
    body.reset()
    buf = np.full(1200, -1.0)
    got = body.process(x, out=buf)
    assert got.base is buf and len(got) == 1000 and (buf[1000:] == -1.0).all()
    np.testing.assert_array_equal(got, y)
    body.reset()
    xi = x.copy()
    body.process(xi, out=xi)
    np.testing.assert_array_equal(xi, y)
    body.reset()
    strided = np.zeros(2000)[::2]
    np.testing.assert_array_equal(body.process(x, out=strided), y)
    body.reset()


@pytest.mark.parametrize("io", [(1, 2), (2, 1), (2, 2)])
def test_mimo_out_argument_in_place_and_strided(io):
    B, C = io
    b = Body(FS, inputs=B, outputs=C)
    x = np.random.default_rng(4).standard_normal((B, 999))
    y = np.atleast_2d(b.process(as_io(x, b))).copy()
    b.reset()
    buf = np.full((C, 1100), -1.0) if C == 2 else np.full(1100, -1.0)
    got = b.process(as_io(x, b), out=buf)
    assert got.base is buf and (buf[..., 999:] == -1.0).all()
    np.testing.assert_array_equal(np.atleast_2d(got), y)
    b.reset()
    strided = np.zeros((C, 2000))[:, ::2] if C == 2 else np.zeros(2000)[::2]
    np.testing.assert_array_equal(np.atleast_2d(b.process(as_io(x, b), out=strided)), y)
    if B == C == 2:  # in place
        b.reset()
        xi = x.copy()
        b.process(xi, out=xi)
        np.testing.assert_array_equal(xi, y)


@pytest.mark.parametrize("io", CONFIGS)
def test_no_allocation_per_block_when_out_is_given(io):
    B, C = io
    b = Body(FS, inputs=B, outputs=C)
    x = as_io(np.random.default_rng(0).standard_normal((B, 128)), b)
    out = np.empty((C, 128)) if C == 2 else np.empty(128)
    b.process(x, out)  # warm
    tracemalloc.start()
    for _ in range(50):
        b.process(x, out)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert peak < 4096, f"{peak} bytes allocated while streaming 50 blocks"  # views only


def test_reset_and_impulse_response_leave_stream_alone():
    b = Body(FS)
    x = np.random.default_rng(6).standard_normal(3000)
    y1 = b.process(x).copy()
    b.reset()
    b.process(x[:1500])
    h = b.impulse_response(4000)  # must not touch the streaming state
    np.testing.assert_array_equal(b.process(x[1500:]), y1[1500:])
    b.process(np.ones(77))
    b.reset()
    np.testing.assert_array_equal(b.process(x), y1)
    d = np.zeros(4000)
    d[0] = 1.0
    b.reset()
    np.testing.assert_allclose(h, b.process(d), rtol=0, atol=1e-15)


def test_mimo_impulse_response_is_the_response_per_path():
    b = Body(FS, inputs=2, outputs=2, n_modes=30)
    h = b.impulse_response(2048)
    assert h.shape == (2, 2, 2048)
    for src in range(2):
        d = np.zeros((2, 2048))
        d[src, 0] = 1.0
        b.reset()
        np.testing.assert_allclose(h[:, src], b.process(d), rtol=0, atol=1e-15)
    long = b.impulse_response(8 * FS)  # the slowest mode falls 60 dB in 2.2 s
    spec = np.fft.rfft(long)
    f = np.fft.rfftfreq(8 * FS, 1.0 / FS)
    sel = np.arange(1, len(f), 997)
    np.testing.assert_allclose(spec[..., sel], b.response(f[sel]), rtol=0, atol=1e-6)


def test_deterministic_for_fixed_seed_and_same_board_in_every_configuration():
    a, b, c = Body(FS, seed=11), Body(FS, seed=11), Body(FS, seed=12)
    np.testing.assert_array_equal(a.coefs, b.coefs)
    x = np.random.default_rng(0).standard_normal(2000)
    np.testing.assert_array_equal(a.process(x), b.process(x))
    assert not np.allclose(a.freqs_hz[1:], c.freqs_hz[1:])  # another seed, another board
    s = Body(FS, seed=11, inputs=2, outputs=2)
    np.testing.assert_array_equal(s.freqs_hz, a.freqs_hz)
    r = s.modes.drive[0] / a.modes.drive[0]
    np.testing.assert_allclose(r, r[0], rtol=1e-12)  # input 0 is the mono board's input


# --- stability, decay, spectrum -----------------------------------------------


@pytest.mark.parametrize("kw", [{}, pytest.param(dict(n_modes=1024), marks=pytest.mark.slow),  # 4.9 s
                                dict(n_modes=1), dict(n_modes=2),
                                dict(n_modes=40), dict(n_modes=75), dict(n_modes=300),
                                dict(size=0.5, brightness=12.0),
                                dict(size=2.0, brightness=-12.0, n_modes=300)])
def test_all_poles_inside_unit_circle(kw):
    b = Body(FS, inputs=2, outputs=2, **kw)
    for _, a1, a2 in b.coefs.T:
        assert np.abs(np.roots([1.0, a1, a2])).max() < 1.0
    assert np.isfinite(b.coefs).all() and np.isfinite(b.modes.pickup).all()
    assert (b.modes.drive > 0).all() and (b.modes.pickup >= 0).all() and (b.modes.dry >= 0).all()


def test_impulse_response_decays_60_db_in_2_s():
    h = Body(FS, wet=1.0).impulse_response(2 * FS)
    e = h * h
    m = len(h) // 10
    drop_db = db(e[-m:].sum() / e[:m].sum())
    assert drop_db <= -60.0, f"last 10 % only {-drop_db:.1f} dB below the first 10 %"


@pytest.mark.parametrize("seed", [sb.DEFAULT_SEED, 2, 3, 31])
def test_magnitude_peaks_at_lowest_mode_frequencies(seed):
    b = Body(FS, seed=seed, wet=1.0)
    f = b.freqs_hz
    for k in range(5):
        half = 0.5 * min(f[k + 1] - f[k], f[k] - f[k - 1] if k else np.inf)
        fr = np.linspace(f[k] - half, f[k] + half, 4001)
        f_peak = fr[np.argmax(np.abs(b.response(fr)[0, 0]))]
        assert abs(f_peak - f[k]) <= 1.0, f"mode {k}: {f[k]:.2f} Hz, peak at {f_peak:.2f} Hz"


def test_smoothed_response_flat_and_tilted():
    """Octave-band power of the modes: flat within a few dB at brightness 0
    (63 Hz .. 8 kHz), and +brightness dB per octave when tilted."""
    edges = 62.5 * 2.0 ** np.arange(8)
    fr = np.geomspace(62.5, 8000.0, 20000)

    def bands(brightness):
        p = np.abs(Body(FS, wet=1.0, brightness=brightness).response(fr)[0, 0]) ** 2
        return np.array([db(p[(fr >= lo) & (fr < 2 * lo)].mean()) for lo in edges[:-1]])

    flat = bands(0.0)
    assert flat.max() - flat.min() <= 6.0, np.round(flat, 1)
    tilt = bands(4.0) - flat
    slope = np.polyfit(np.arange(len(tilt)), tilt, 1)[0]
    assert 3.0 <= slope <= 5.0, f"tilt {slope:.2f} dB/octave for brightness 4"


def test_sections_are_positive_real():
    """Re H_k >= 0 on the unit circle for b0 > 0 (the bilinear image of a
    positive-real band-pass): the floor of the evenness argument."""
    rng = np.random.default_rng(7)
    f = rng.uniform(20.0, 20000.0, 300)
    coefs = sb.resonator_coefs(FS, f, rng.uniform(0.0005, 5.0, 300), rng.uniform(0.01, 10.0, 300))
    H = sb.section_response(FS, coefs, np.linspace(0.0, FS / 2, 20001))
    assert H.real.min() >= -1e-12


# --- evenness -------------------------------------------------------------------

GRID = np.geomspace(20.0, 21600.0, 16000)


def _fine_structure_db(body, t):
    """Body's power gain (summed over outputs) re its 1/3-octave smoothing, and
    the power of its direct part, for a string at bridge position t."""
    w = body.bridge_split(t)
    p = (np.abs(body.response(GRID, w)) ** 2).sum(axis=0)
    floor = ((body.dry_gain * body.modes.dry @ np.asarray(w)) ** 2).sum()
    return 10.0 * np.log10(p) - sb.smoothed_db(GRID, p), p, floor


@pytest.mark.parametrize("seed", [1, 2, 3, 4, 5, 6, 7, 8])
@pytest.mark.parametrize("io", [(1, 1), (2, 2)])
def test_no_isolated_notch_or_peak_on_any_key(seed, io):
    """The criterion, at the preset's wet (0.4), for any seed and bridge
    position: from 150 Hz to 13 kHz the response stays within -4.5 .. +6 dB
    of its 1/3-octave smoothed value, from 25 to 150 Hz (the lowest, isolated
    modes: overlap < 0.15) within -6.5 .. +8.5 dB; and it never falls below
    its direct part. The old board (random residue signs) went to -55 dB."""
    B, C = io
    b = Body(FS, seed=seed, wet=0.4, inputs=B, outputs=C)
    for t in ((0.0,) if B == 1 else (0.0, 0.37, 0.5, 1.0)):
        d, p, floor = _fine_structure_db(b, t)
        hi = (GRID >= 150.0) & (GRID <= 13000.0)
        lo = (GRID >= 25.0) & (GRID < 150.0)
        assert d[hi].min() >= -4.5 and d[hi].max() <= 6.0, (t, d[hi].min(), d[hi].max())
        assert d[lo].min() >= -6.5 and d[lo].max() <= 8.5, (t, d[lo].min(), d[lo].max())
        assert p.min() >= floor * (1.0 - 1e-9)


@pytest.mark.parametrize("io", CONFIGS)
def test_each_output_never_below_its_direct_part(io):
    B, C = io
    b = Body(FS, wet=0.7, inputs=B, outputs=C, seed=3)
    H = b.response(GRID)  # (C, B, F): every path on its own
    floor = b.dry_gain * b.modes.dry
    assert (np.abs(H) >= floor[:, :, None] * (1.0 - 1e-9)).all()


# --- named resonances (peaks) ----------------------------------------------------


@pytest.mark.parametrize("f_hz, q, level_db", [(180.0, 20.0, 8.0), (700.0, 30.0, 12.0),
                                               (3000.0, 60.0, 15.0)])
def test_a_named_peak_stands_its_level_over_the_diffuse_bank(f_hz, q, level_db):
    """At its frequency a peak of level L stands L dB over the octave-
    smoothed response of the diffuse modes alone (within 2.5 dB: the
    diffuse modes there add with their own phases), its bandwidth is f/q
    and the white-noise gain stays 0 dB (the normalisation includes it)."""
    plain = Body(FS, wet=1.0, size=0.5, seed=4)
    body = Body(FS, wet=1.0, size=0.5, seed=4, peaks=[(f_hz, q, level_db)])
    k = int(np.flatnonzero(body.freqs_hz == f_hz)[0])
    assert body.t60_s[k] == pytest.approx(math.log(1000.0) * q / (math.pi * f_hz))
    # the diffuse modes' smoothed level, in the peak's body's normalisation
    scale = body.modes.pickup[0, k - 1 if k else k + 1] / plain.modes.pickup[0, k - 1 if k else k + 1]
    diffuse = sb.smoothed_db(GRID, np.abs(plain.response(GRID)[0, 0]) ** 2, fraction=1.0) \
        + db(scale ** 2)
    at = db(np.abs(body.response([f_hz])[0, 0, 0]) ** 2)
    ref = float(np.interp(f_hz, GRID, diffuse))
    assert at - ref == pytest.approx(level_db, abs=2.5), (at, ref)
    half = db(np.abs(body.response([f_hz * (1 + 0.5 / q)])[0, 0, 0]) ** 2)
    assert at - half > 2.0  # a resonance of bandwidth f/q, not a broad bump
    x = np.random.default_rng(5).standard_normal(4 * FS)
    y = body.process(x)[FS // 2:]
    assert abs(db((y * y).mean() / (x[FS // 2:] ** 2).mean())) <= 1.0


@pytest.mark.parametrize("io", CONFIGS)
def test_peaks_keep_every_output_above_its_direct_part(io):
    B, C = io
    b = Body(FS, wet=0.7, inputs=B, outputs=C, seed=3, size=0.3,
             peaks=[(110.0, 15.0, 6.0), (144.0, 25.0, 8.0), (560.0, 30.0, 4.0)])
    H = b.response(GRID)
    floor = b.dry_gain * b.modes.dry
    assert (np.abs(H) >= floor[:, :, None] * (1.0 - 1e-9)).all()
    assert b.n_modes == 96 + 3 and np.all(np.diff(b.freqs_hz) >= 0)


def test_no_peaks_is_the_same_board():
    a, b = sb.soundboard_modes(FS, seed=9), sb.soundboard_modes(FS, seed=9, peaks=())
    assert np.array_equal(a.freqs_hz, b.freqs_hz) and np.array_equal(a.pickup, b.pickup)


def test_bridge_split_keeps_the_power_along_the_bridge():
    b = Body(FS, inputs=2, outputs=2)
    G = b.gram()
    x = np.random.default_rng(9).standard_normal(6 * FS)
    ref = None
    for t in (0.0, 0.25, 0.5, 0.8, 1.0):
        w = np.array(b.bridge_split(t))
        assert w @ G @ w == pytest.approx(0.5 * (G[0, 0] + G[1, 1]), rel=1e-12)
        if t in (0.0, 1.0):
            assert w[int(t == 0.0)] == 0.0
        b.reset()
        y = b.process(np.vstack((w[0] * x, w[1] * x)))[:, FS // 2:]
        p = (y * y).sum(axis=0).mean()
        ref = p if ref is None else ref
        assert abs(db(p / ref)) < 0.15, f"t = {t}: {db(p / ref):+.2f} dB"
    assert Body(FS).bridge_split(0.3) == (1.0,)
    # without the gain the middle of the bridge is low, by a fraction of a dB
    w = np.array([0.5, 0.5])
    assert -1.0 < db((w @ G @ w) / G[0, 0]) < 0.0


def test_stereo_outputs_are_decorrelated_but_equal_on_average():
    b = Body(FS, inputs=1, outputs=2, wet=1.0)
    fr = np.geomspace(200.0, 8000.0, 20000)
    H = b.response(fr)[:, 0]
    coh = np.corrcoef(20 * np.log10(np.abs(H[0])), 20 * np.log10(np.abs(H[1])))[0, 1]
    assert coh < 0.7, f"left and right fine structures correlate at {coh:.2f}"
    pl, pr = (np.abs(H) ** 2).mean(axis=1)
    assert abs(db(pl / pr)) < 1.0


# --- level ---------------------------------------------------------------------


@pytest.mark.parametrize("io", CONFIGS)
def test_energies_closed_form_match_sum_of_squares(io):
    B, C = io
    b = Body(FS, wet=1.0, inputs=B, outputs=C)
    h = b.impulse_response(8 * FS)
    h = h.reshape(C, B, -1) / b.wet_gain
    G = np.einsum("cbn,cdn->bd", h, h)
    np.testing.assert_allclose(G, b._gram_modal, rtol=1e-6)
    assert np.trace(G) / B == pytest.approx(1.0, rel=1e-6)
    np.testing.assert_allclose(h[:, :, 0], b.ir_first, rtol=0, atol=1e-15)
    mix = Body(FS, wet=0.4, inputs=B, outputs=C)
    hm = mix.impulse_response(8 * FS).reshape(C, B, -1)
    np.testing.assert_allclose(np.einsum("cbn,cdn->bd", hm, hm), mix.gram(), rtol=1e-6)


@pytest.mark.parametrize("io", CONFIGS)
@pytest.mark.parametrize("kw", [dict(wet=1.0), dict(wet=0.6), dict(wet=0.4), dict(wet=0.25),
                                dict(wet=1.0, n_modes=40, size=0.5, brightness=12.0),
                                dict(wet=0.8, n_modes=120, size=2.0, brightness=-12.0)])
def test_white_noise_gain_near_unity(kw, io):
    """Per input, summed over outputs, averaged over inputs: 0 dB (within
    1.5 dB for the size-2 board tilted -12 dB/octave, whose power sits in a
    few slow bass modes, so 3.5 s of noise measure it loosely)."""
    B, C = io
    b = Body(FS, inputs=B, outputs=C, **kw)
    x = np.random.default_rng(17).standard_normal((B, 4 * FS))
    y = np.atleast_2d(b.process(as_io(x, b)))[:, FS // 2:]  # skip the build-up
    gain_db = db((y * y).sum(axis=0).mean() / (x[:, FS // 2:] ** 2).sum(axis=0).mean())
    tol = 1.5 if kw.get("brightness", 0.0) < 0 else 1.0
    assert abs(gain_db) <= tol, f"white-noise gain {gain_db:.2f} dB"


# --- the mode set's laws -------------------------------------------------------


@pytest.mark.parametrize("size", [0.5, 1.0, 2.0])
def test_mode_set_laws(size):
    m = sb.soundboard_modes(FS, size=size)
    f, t60 = m.freqs_hz, m.t60_s
    assert len(f) == len(t60) == sb.DEFAULT_N_MODES
    assert f[0] == pytest.approx(50.0 / size, rel=1e-12)
    assert np.all(np.diff(f) > 0)
    assert f[-1] <= 0.45 * FS
    # a homogeneous plate below the ribs' frequency: one mode per ~20 Hz (x 1/size)
    plate = f[f < 1000.0 / size]
    mean_spacing = (plate[-1] - plate[0]) / (len(plate) - 1)
    assert 15.0 / size <= mean_spacing <= 25.0 / size
    # loss factor eta = ln(1000) / (pi f T60): 2 .. 3 % on the plate part, rising
    eta = math.log(1000.0) / (math.pi * f * t60)
    sel = f < 1000.0 / size
    assert np.all(eta[sel] >= 0.0199) and np.all(eta[sel] <= 0.0301)
    assert np.all(np.diff(eta[sel]) >= -1e-12)
    assert np.all(eta >= 0.0199)


def test_modal_overlap_passes_one_near_1_khz_and_stays_overlapping():
    """Board overlap eta f n(f): ~0.05 at the lowest mode, 1 near 1 kHz; the
    thinned bank above keeps its own overlap >= 1 (Ege et al. 2013)."""
    m = sb.soundboard_modes(FS)
    f = m.freqs_hz
    bw = math.log(1000.0) / (math.pi * m.t60_s)
    n = sb.mode_density_per_hz(f, FS)
    overlap = bw * n
    assert overlap[0] < 0.06
    near = (f > 800.0) & (f < 1100.0)
    assert 0.7 < overlap[near].min() and overlap[near].max() < 1.8
    assert np.all(overlap[f > 1100.0] >= 1.0 - 1e-9)


def test_size_scales_frequencies_and_decays():
    a = sb.soundboard_modes(FS, size=1.0)
    b = sb.soundboard_modes(FS, size=2.0)
    np.testing.assert_allclose(b.freqs_hz, a.freqs_hz / 2.0, rtol=1e-9)
    np.testing.assert_allclose(b.t60_s, a.t60_s * 2.0, rtol=1e-9)


def test_mode_density_follows_the_board():
    """0.05 modes per Hz up to 1.1 kHz, then falling as 1/f: ~0.008 at 2.5 kHz
    for the default count (measured: ~0.01, Ege & Boutillon)."""
    rho = sb.mode_density_per_hz([60.0, 200.0, 1000.0, 2500.0, 5000.0, 9000.0], FS)
    assert rho[0] == rho[1] == rho[2] == pytest.approx(1.0 / 20.0)
    assert 0.006 < rho[3] < 0.012
    assert rho[5] < rho[4] < rho[3] < rho[2]
    assert rho[4] * 5000.0 == pytest.approx(rho[5] * 9000.0)  # constant per octave
    # fewer modes: the uniform part ends lower; more: it goes higher
    assert sb.mode_density_per_hz([1000.0], FS, n_modes=50)[0] < 1.0 / 20.0
    assert sb.mode_density_per_hz([1500.0], FS, n_modes=400)[0] == pytest.approx(1.0 / 20.0)


@pytest.mark.parametrize("io", [(1, 1), (2, 2)])
def test_silence_flushes_state_to_exact_zero(io):
    """After an impulse, long silence leaves exact zeros (no subnormal tail)."""
    B, C = io
    b = Body(FS, wet=1.0, inputs=B, outputs=C)
    imp = np.zeros((B, 1024))
    imp[:, 0] = 1.0
    b.process(as_io(imp, b))
    y = np.atleast_2d(b.process(as_io(np.zeros((B, 40 * FS)), b)))
    assert not b._state.any()
    assert y[:, -FS:].max() == 0.0 and y[:, -FS:].min() == 0.0
    tiny = np.finfo(np.float64).tiny
    assert not np.any((y != 0.0) & (np.abs(y) < tiny))


# --- the knock ------------------------------------------------------------------


@pytest.mark.parametrize("fs, dur", [(48000, 0.002), (325000, 0.002), (48000, 0.0002),
                                     (48000, 0.013)])
def test_knock_pulse_area_shape_and_spectrum(fs, dur):
    j = 0.003
    p = sb.knock_pulse(fs, j, dur)
    n = max(1, round(dur * fs))
    assert p.shape == (n,) and (p >= 0).all()
    assert p.sum() / fs == pytest.approx(j, rel=1e-12)
    if n >= 8:
        assert p.max() == pytest.approx(2 * j / dur, rel=0.08)  # sampled at mid-points
        f = np.linspace(1.0, 0.4 / dur, 50)
        t = (np.arange(n) + 0.5) / fs
        spec = np.abs(np.exp(-2j * np.pi * f[:, None] * t[None, :]) @ p) / fs
        assert np.all(np.abs(20 * np.log10(spec / j)) < 1.0)
        f1 = 1.0 / dur
        if n >= 32:  # -6 dB at 1 / T
            assert abs(np.exp(-2j * np.pi * f1 * t) @ p) / fs / j == pytest.approx(0.5, abs=0.02)


@pytest.mark.parametrize("tau", [0.01, 0.02])
def test_a_built_up_knock_is_a_train_with_the_pulses_energy(tau):
    """``build_s`` = tau: pulses of both signs under (t / tau) exp(1 - t /
    tau), with the single pulse's energy, the same train at every rate
    (its pushes are placed in seconds) and on every call; 0 is the pulse."""
    j, dur = 0.003, 0.002
    p = sb.knock_pulse(FS, j, dur)
    np.testing.assert_array_equal(sb.knock_pulse(FS, j, dur, 0.0), p)
    y = sb.knock_pulse(FS, j, dur, tau)
    np.testing.assert_array_equal(sb.knock_pulse(FS, j, dur, tau), y)
    assert np.dot(y, y) == pytest.approx(np.dot(p, p), rel=1e-12)
    assert (y > 0).any() and (y < 0).any()
    n = len(y)
    assert n / FS == pytest.approx(sb.KNOCK_BUILD_SPAN * tau + dur, abs=2.0 / FS)
    # its energy builds up: the RMS over tau / 4 peaks near tau, not at the start
    w = int(tau / 4 * FS)
    rms = np.sqrt(np.convolve(y * y, np.ones(w) / w, mode="valid"))
    peak_s = (np.argmax(rms) + w / 2) / FS
    assert 0.4 * tau <= peak_s <= 2.5 * tau, peak_s
    assert rms[0] < 0.5 * rms.max()
    # the same train in time at twice the rate: its energy per second and its
    # envelope (10 ms RMS) agree within 1 dB wherever it is within 20 dB of its peak
    y2 = sb.knock_pulse(2 * FS, j, dur, tau)
    assert np.dot(y2, y2) / (2 * FS) == pytest.approx(np.dot(y, y) / FS, rel=1e-9)

    def env(x, fs):
        m = int(0.01 * fs)
        e = np.sqrt(np.add.reduceat(x * x, np.arange(0, len(x) - m + 1, m)) / m)
        return e[:int(len(x) / m)]
    a, b = env(y, FS), env(y2, 2 * FS)
    k = min(len(a), len(b))
    a, b = a[:k], b[:k]
    loud = a > a.max() * 0.1
    assert np.all(np.abs(20 * np.log10(b[loud] / a[loud])) < 1.0)


def test_knock_impulse_is_a_fraction_of_the_hammer_momentum():
    assert sb.knock_impulse_ns(0.01, 3.0) == pytest.approx(sb.KNOCK_IMPULSE_RATIO * 0.03)
    assert sb.knock_impulse_ns(0.01, 3.0, ratio=0.5) == pytest.approx(0.015)
    assert sb.knock_impulse_ns(0.008, 0.0) == 0.0


@pytest.mark.parametrize("call, name", [
    (lambda: sb.knock_pulse(4000, 0.001), "fs"),
    (lambda: sb.knock_pulse(FS, -0.001), "impulse_ns"),
    (lambda: sb.knock_pulse(FS, 0.001, 0.5), "duration_s"),
    (lambda: sb.knock_pulse(FS, 0.001, 0.005, 0.2), "build_s"),
    (lambda: sb.knock_pulse(FS, 0.001, 0.005, -0.01), "build_s"),
    (lambda: sb.knock_impulse_ns(0.5, 1.0), "hammer_mass_kg"),
    (lambda: sb.knock_impulse_ns(0.01, -1.0), "hammer_speed_m_per_s"),
    (lambda: sb.knock_impulse_ns(0.01, 1.0, ratio=11.0), "ratio"),
])
def test_knock_bad_parameters_rejected(call, name):
    with pytest.raises(ValueError, match=name):
        call()


# --- validation -----------------------------------------------------------------


@pytest.mark.parametrize(
    "kw, name",
    [
        (dict(fs=4000), "fs"),
        (dict(fs=float("nan")), "fs"),
        (dict(n_modes=0), "n_modes"),
        (dict(n_modes=2000), "n_modes"),
        (dict(n_modes=9.0), "n_modes"),
        (dict(seed=-1), "seed"),
        (dict(wet=1.5), "wet"),
        (dict(wet=-0.1), "wet"),
        (dict(wet=True), "wet"),
        (dict(size=0.2), "size"),
        (dict(size=5.0), "size"),
        (dict(peaks=[(10.0, 20.0, 0.0)]), "f_hz"),
        (dict(peaks=[(30000.0, 20.0, 0.0)]), "f_hz"),
        (dict(peaks=[(200.0, 0.5, 0.0)]), "q"),
        (dict(peaks=[(200.0, 20.0, 40.0)]), "level_db"),
        (dict(peaks=[(200.0, 20.0)]), "peaks"),
        (dict(peaks=[(200.0, 20.0, 0.0)] * 33), "peaks"),
        (dict(brightness=20.0), "brightness"),
        (dict(brightness=float("inf")), "brightness"),
        (dict(inputs=3), "inputs"),
        (dict(inputs=0), "inputs"),
        (dict(outputs=3), "outputs"),
        (dict(outputs=1.0), "outputs"),
    ],
)
def test_bad_parameters_rejected(kw, name):
    kw = dict(kw)
    fs = kw.pop("fs", FS)
    with pytest.raises(ValueError, match=name):
        Body(fs, **kw)


def test_bad_input_rejected_without_touching_state():
    b = Body(FS)
    x = np.random.default_rng(0).standard_normal(300)
    y_ok = Body(FS).process(np.concatenate([x, x]))
    b.process(x)
    bad = x.copy()
    bad[17] = np.inf
    with pytest.raises(ValueError, match=r"x\[17\]"):
        b.process(bad)
    with pytest.raises(ValueError, match="1-D"):
        b.process(np.zeros((2, 3)))
    with pytest.raises(ValueError, match="out"):
        b.process(x, out=np.zeros(10))
    with pytest.raises(ValueError, match="wet"):
        b.wet = 2.0
    with pytest.raises(ValueError, match=r"n = -1"):
        b.impulse_response(-1)
    np.testing.assert_array_equal(b.process(x), y_ok[300:])


def test_bad_mimo_input_rejected_without_touching_state():
    b = Body(FS, inputs=2, outputs=2)
    x = np.random.default_rng(0).standard_normal((2, 300))
    y_ok = Body(FS, inputs=2, outputs=2).process(np.concatenate([x, x], axis=1))
    b.process(x)
    bad = x.copy()
    bad[1, 17] = np.nan
    with pytest.raises(ValueError, match=r"x\[1, 17\]"):
        b.process(bad)
    with pytest.raises(ValueError, match=r"must be \(2, n\)"):
        b.process(x[0])
    with pytest.raises(ValueError, match="out"):
        b.process(x, out=np.zeros((2, 10)))
    with pytest.raises(ValueError, match="out"):
        b.process(x, out=np.zeros(300))
    with pytest.raises(ValueError, match="t = 1.5"):
        b.bridge_split(1.5)
    np.testing.assert_array_equal(b.process(x), y_ok[:, 300:])


def test_bad_mode_data_rejected():
    with pytest.raises(ValueError, match=r"freqs_hz\[1\]"):
        sb.resonator_coefs(FS, [100.0, 30000.0], [1.0, 1.0], [1.0, 1.0])
    with pytest.raises(ValueError, match=r"t60_s\[0\]"):
        sb.resonator_coefs(FS, [100.0], [0.0], [1.0])
    with pytest.raises(ValueError, match="shapes"):
        sb.resonator_coefs(FS, [100.0, 200.0], [1.0], [1.0])


# --- cost (timed by tools/bench.py body, not here) --------------------------------


@pytest.mark.parametrize("inputs,outputs", [(1, 1), (2, 2), (2, 1), (1, 2)])
def test_a_dry_body_runs_no_modes_and_gives_the_direct_part(inputs, outputs):
    """At wet = 0 the body passes the direct part (its dry mapping) without
    running the modes: the kernel's output at wet = 1e-300 to round-off,
    also when writing in place; the modes then start from rest."""
    rng = np.random.default_rng(inputs * 10 + outputs)
    x = rng.standard_normal((inputs, 3000))
    ys = []
    for wet in (0.0, 1e-300):
        b = Body(48_000, n_modes=32, seed=3, wet=wet, inputs=inputs, outputs=outputs)
        xi = x[0] if inputs == 1 else x
        ys.append(np.concatenate([np.atleast_2d(b.process(xi[..., i:i + 700]).copy())
                                  for i in range(0, 3000, 700)], axis=-1))
        if wet == 0.0:
            assert not np.any(b._state)
    assert np.max(np.abs(ys[0] - ys[1])) < 1e-14
    if inputs == outputs:
        b = Body(48_000, n_modes=32, seed=3, wet=0.0, inputs=inputs, outputs=outputs)
        xx = (x[0] if inputs == 1 else x).copy()
        b.process(xx, out=xx)
        assert np.max(np.abs(np.atleast_2d(xx) - ys[1])) < 1e-14


def test_a_board_is_kept_on_disk_for_the_next_process(tmp_path, monkeypatch):
    """With a store (the engine gives the design store), the board's modes
    and their white-noise energies are saved, and a later process (the
    per-process memo emptied) loads them without drawing the modes again:
    the same body to the bit, as without a store.  A store holding
    something else under that key is ignored."""
    from synth.dsp import body as BM
    from synth.voices import design_store

    kw = dict(n_modes=120, seed=5, inputs=2, outputs=2, peaks=[[80.0, 8.0, 10.0]])
    monkeypatch.setenv(design_store.ENV, str(tmp_path))
    monkeypatch.setattr(BM, "_BOARDS", {})
    plain = Body(FS, **kw)
    a = Body(FS, store=design_store, **kw)
    assert list(tmp_path.glob("body-*.pkl"))
    monkeypatch.setattr(BM, "_BOARDS", {})

    def no_modes(*args, **kwargs):
        raise AssertionError("drawn again")

    monkeypatch.setattr(BM, "soundboard_modes", no_modes)
    b = Body(FS, store=design_store, **kw)
    x = np.random.default_rng(4).standard_normal((2, 3000))
    outs = []
    for body in (plain, a, b):
        assert np.array_equal(body._gram_modal, plain._gram_modal)
        outs.append(body.process(x))
    assert np.array_equal(outs[0], outs[1]) and np.array_equal(outs[0], outs[2])
    monkeypatch.setattr(BM, "_BOARDS", {})
    key = (float(FS), 120, 5, 1.0, 0.0, 2, 2, ((80.0, 8.0, 10.0),))
    design_store.save("body", key, "not a board")
    with pytest.raises(AssertionError, match="drawn again"):
        Body(FS, store=design_store, **kw)
