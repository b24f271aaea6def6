"""Stiff-string loop with a biquad (second-order allpass) dispersion cascade.

The grand's 88 strings (synth.physics.piano.grand_string: B, f0, T60s; the
loss band as synth.voices.grand passes it) at fs = 325 kHz, partials up to
10 kHz (at most 40), 2 cents.  Tolerances in cents next to each assertion.
The time-domain reference (slow) runs the loop sample by sample from an
impulse, the way the kernel will: delay, loss, first-order sections,
biquads, tuning allpass.
"""

import math

import numba as nb
import numpy as np
import pytest

from synth.physics.dispersion import (
    MAX_SOS,
    BridgeLag,
    MIN_CELLS,
    SosStiffLoop,
    retune_sos_loop,
    sos_coefficients,
    sos_poles,
    stiff_partials,
    tune_stiff_loop,
    tune_stiff_loop_sos,
)
from synth.physics.piano import bridge_resistance_ns_per_m, grand_string, stretched_f0_hz

FS = 325000.0
KEYS = range(21, 109)
TOL = 2.0


def cents(f, ref):
    return 1200.0 * np.log2(np.asarray(f) / np.asarray(ref))


def string_args(key, f1=None):
    """(f1, B, t60_low, f_low, t60_high, f_high) of the key's centre string,
    as the voice passes them (f_low = f1, f_high = max(f_high, 1.5 f1))."""
    g = grand_string(key)
    B = g.inharmonicity_b
    f1 = g.f0_hz * math.sqrt(1 + B) if f1 is None else f1
    return f1, B, g.t60_low_s, f1, g.t60_high_s, max(g.f_high_hz, 1.5 * f1)


def unison_args(key, f1):
    """(f1, t60_low, f_low, t60_high, f_high) of each unison string, as
    GrandVoice.setup derives them (detune and T60 scale 1)."""
    g = grand_string(key)
    out = []
    for j, det in enumerate(g.unison_detune_cents):
        fj = f1 * 2.0 ** (det / 1200.0)
        t_lo = g.t60_low_s             # every string of the unison: the same own decay
        out.append((fj, t_lo, fj, min(g.t60_high_s, t_lo), max(g.f_high_hz, 1.5 * fj)))
    return out


@pytest.fixture(scope="module")
def grand():
    """key -> (SosStiffLoop, exact partials 1 .. K by bisection, targets)."""
    out = {}
    for key in KEYS:
        f1, B, *loss = string_args(key)
        lp = tune_stiff_loop_sos(f1, B, FS, *loss)
        K = lp.n_partials
        out[key] = (lp, lp.partials(K), lp.target_partials(K))
    return out


def loop_response(lp, f):
    """H(e^jw) of the whole loop from its coefficients, by complex arithmetic:
    z^-(2N + x) b0/(1 + a1 z^-1) ((a + z^-1)/(1 + a z^-1))^n_fo
    prod (c2 + c1 z^-1 + z^-2)/(1 + c1 z^-1 + c2 z^-2) (eta + z^-1)/(1 + eta z^-1)."""
    z1 = np.exp(-2j * np.pi * np.asarray(f, dtype=float) / lp.fs)
    H = z1 ** (2 * lp.cells + lp.extra_delay) * lp.b0 / (1 + lp.a1 * z1)
    H = H * ((lp.a_fo + z1) / (1 + lp.a_fo * z1)) ** lp.n_fo
    for c1, c2 in lp.sos:
        H = H * (c2 + c1 * z1 + z1 * z1) / (1 + c1 * z1 + c2 * z1 * z1)
    return H * (lp.eta + z1) / (1 + lp.eta * z1)


# --- the design on every grand key ---

def test_every_key_within_tolerance(grand):
    """Partials 1 .. K of every key within 2 cents of n f0 sqrt(1 + B n^2)
    (exact resonances by bisection), partial 1 within 0.01 cent of f1."""
    for key, (lp, p, t) in grand.items():
        e = np.abs(cents(p, t))
        assert e.max() <= TOL, (key, e.max())                      # cents
        assert abs(cents(p[0], lp.f1_hz)) < 0.01, key               # cents (measured ~1e-12)
        assert lp.worst_cents == pytest.approx(e.max(), abs=1e-6), key
        np.testing.assert_allclose(lp.cents, cents(p, t), atol=1e-6)  # Newton vs bisection


def test_no_grand_key_falls_back_and_the_cascades_are_small(grand):
    """K = 40 in the bass, 2 at the top; 1 .. 8 biquads (keys 21 .. 103) or
    a single first-order section (K = 2: keys 104 .. 108); at most one
    first-order section next to biquads; never more than 17 cost units."""
    for key, (lp, p, t) in grand.items():
        assert lp.kind == "sos", key
        assert lp.n_partials >= 2 and (lp.n_partials == 40 or key > 56), key
        assert lp.n_sos <= 8 and lp.n_fo <= 1, key
        assert lp.cost == 2 * lp.n_sos + lp.n_fo <= 17, key
        assert lp.cells >= MIN_CELLS
    assert [grand[k][0].n_sos for k in range(104, 109)] == [0] * 5
    assert [grand[k][0].n_fo for k in range(104, 109)] == [1] * 5
    assert max(grand[k][0].n_sos for k in KEYS) == 8 <= MAX_SOS


def test_cheaper_and_better_than_the_first_order_design(grand):
    """The voice's first-order design (m_max 8) keeps 7 .. 20 partials of the
    bass and middle within 2 cents; the biquads keep all K."""
    for key in (21, 33, 45, 57, 69):
        lp = grand[key][0]
        f1, B, *loss = string_args(key)
        old = tune_stiff_loop(f1, B, FS, *loss, m_max=8)
        assert old.n_fit < lp.n_partials, key


def test_partials_are_the_loop_resonances(grand):
    """Independent of the lag bookkeeping and of the (c1, c2) convention:
    the complex loop response built from the coefficients has phase 0 (mod
    2 pi) at every partial, and its phase turns by 2 pi between them."""
    for key in (21, 45, 60, 76, 90, 100, 108):
        lp, p, t = grand[key]
        assert np.max(np.abs(np.angle(loop_response(lp, p)))) < 1e-8, key   # rad
        fgrid = np.linspace(0.0, p[-1], 64 * len(p) + 1)
        ph = np.unwrap(np.angle(loop_response(lp, fgrid)))
        turns = (ph[0] - np.interp(p, fgrid, ph)) / (2 * np.pi)
        np.testing.assert_allclose(turns, np.arange(1, len(p) + 1), atol=1e-3)


def test_biquads_are_stable_allpasses(grand):
    for key, (lp, p, t) in grand.items():
        if lp.n_sos:
            R = np.abs(sos_poles(lp.sos))
            assert R.max() < 0.999, key           # grand: at most 0.9984 (key 21)
            assert np.all(lp.poles().imag > 0), key
            np.testing.assert_allclose(sos_coefficients(np.angle(lp.poles()), np.abs(lp.poles())),
                                       lp.sos, atol=1e-15)
        assert lp.sos.shape == (lp.n_sos, 2) and lp.sos.dtype == np.float64
        assert not lp.sos.flags.writeable and not lp.cents.flags.writeable
    with pytest.raises(AttributeError):
        grand[21][0].cells = 3


def test_loss_filter_as_tune_stiff_loop(grand):
    for key in (21, 60, 100):
        lp = grand[key][0]
        old = tune_stiff_loop(*string_args(key)[:2], FS, *string_args(key)[2:])
        assert (lp.b0, lp.a1) == (old.b0, old.a1)
        assert lp.total_phase_delay() == pytest.approx(FS / lp.f1_hz, rel=1e-10)


@pytest.mark.slow
def test_every_key_as_the_voice_tunes_it_with_its_unison_strings():
    """The voice's stretched tuning, each key designed once and its unison
    strings (detuned -0.77 .. +0.63 cent, T60 x 0.45 .. 1) retuned from that
    cascade: all within 2 cents, partial 1 within 0.01 cent."""
    worst = 0.0
    for key in KEYS:
        f1 = stretched_f0_hz(key)
        _, B, *loss = string_args(key, f1)
        lp = tune_stiff_loop_sos(f1, B, FS, *loss)
        assert lp.worst_cents <= TOL, key
        for a in unison_args(key, f1):
            r = retune_sos_loop(lp, *a)
            assert r.sos.shape == lp.sos.shape and r.n_fo == lp.n_fo
            p = r.partials(r.n_partials)
            e = np.abs(cents(p, r.target_partials(r.n_partials)))
            assert e.max() <= TOL, (key, e.max())                      # cents
            assert abs(cents(p[0], a[0])) < 0.01                       # cents
            worst = max(worst, e.max())
    assert worst > 1.5     # the check checks something


# --- unison strings ---

def test_retuned_unison_strings_within_tolerance(grand):
    """Every key's unison strings from its one design (the cascade kept,
    loss and tuning recomputed): within 2 cents, partial 1 exact."""
    n_kept = 0
    for key, (lp, p, t) in grand.items():
        for a in unison_args(key, lp.f1_hz):
            r = retune_sos_loop(lp, *a)
            assert r.n_partials == lp.n_partials and r.kind == lp.kind
            e = np.abs(r.cents)
            assert e.max() <= TOL, (key, a[0], e.max())                    # cents
            assert abs(e[0]) < 0.01                                        # cents
            assert r.f1_hz == a[0] and r.worst_cents == e.max()
            n_kept += np.shares_memory(r.sos, lp.sos) or r.n_sos == 0
    assert n_kept >= 215         # of 226 strings: 5 need the refit


def test_retune_keeps_the_cascade_and_refits_only_a_miss(grand):
    """Key 68's third string (T60 x 0.5): the kept cascade misses 2 cents
    (the loss filter's own dispersion moves by ~0.4 cent); the refit (same
    4 biquads, warm start) brings it back."""
    lp = grand[68][0]
    a = unison_args(68, lp.f1_hz)[2]
    kept = retune_sos_loop(lp, *a, refit=False)
    assert kept.sos is lp.sos and kept.a_fo == lp.a_fo
    assert kept.worst_cents > TOL
    assert kept.worst_cents == pytest.approx(
        np.max(np.abs(cents(kept.partials(kept.n_partials), kept.target_partials(
            kept.n_partials)))), abs=1e-6)
    fixed = retune_sos_loop(lp, *a)
    assert fixed.worst_cents <= TOL and fixed.n_sos == lp.n_sos and fixed.n_fo == lp.n_fo
    # the same string again is the design itself
    same = retune_sos_loop(lp, *string_args(68)[:1], *string_args(68)[2:])
    assert same.sos is lp.sos and same.cells == lp.cells and same.eta == pytest.approx(lp.eta)
    assert same.worst_cents == pytest.approx(lp.worst_cents, abs=1e-9)


# --- fallback ---

def test_fallback_is_the_first_order_design_and_tells_the_truth():
    """No biquads allowed: key 45's loop is tune_stiff_loop's (m_max
    sections), and worst_cents is its exact worst over all K partials."""
    f1, B, *loss = string_args(45)
    lp = tune_stiff_loop_sos(f1, B, FS, *loss, max_biquads=0, m_max=8)
    old = tune_stiff_loop(f1, B, FS, *loss, m_max=8)
    assert lp.kind == "first-order" and lp.n_sos == 0 and lp.sos.shape == (0, 2)
    assert (lp.cells, lp.extra_delay, lp.n_fo) == (old.cells, old.extra_delay, old.M)
    assert lp.a_fo == pytest.approx(old.a_disp, abs=1e-15)
    assert lp.eta == pytest.approx(old.eta, abs=1e-15)
    K = lp.n_partials
    e = np.abs(cents(old.partials(K), lp.target_partials(K)))
    assert lp.worst_cents == pytest.approx(e.max(), abs=1e-6) and lp.worst_cents > 20
    assert not lp.within_tol
    # retuning a fallback keeps its sections
    r = retune_sos_loop(lp, *unison_args(45, f1)[1])
    assert r.kind == "first-order" and (r.n_fo, r.a_fo) == (lp.n_fo, lp.a_fo)


def test_fallback_for_one_partial_and_for_no_stiffness():
    f1, B, *loss = string_args(100)
    one = tune_stiff_loop_sos(f1, B, FS, *loss, f_max_hz=1.5 * f1)
    assert one.n_partials == 1 and one.kind == "first-order" and one.cost == 0
    assert one.worst_cents < 1e-9
    flat = tune_stiff_loop_sos(220.0, 0.0, FS, 5.0, 220.0, 1.0, 5000.0)
    assert flat.kind == "first-order" and flat.cost == 0 and flat.worst_cents < TOL


def test_fallback_beyond_the_budget():
    """A string no cascade of MAX_SOS biquads can keep within 2 cents (B =
    1e-3 at 27.5 Hz, 40 partials: the phase budget alone is 30 sections)
    gets the first-order design, and worst_cents says how far it is."""
    f1 = 27.5 * math.sqrt(1.001)
    lp = tune_stiff_loop_sos(f1, 1e-3, FS, 10.0, 27.5, 1.0, 5000.0)
    old = tune_stiff_loop(f1, 1e-3, FS, 10.0, 27.5, 1.0, 5000.0)
    assert lp.kind == "first-order" and not lp.within_tol
    assert (lp.n_fo, lp.cells) == (old.M, old.cells)
    K = lp.n_partials
    assert lp.worst_cents == pytest.approx(
        np.max(np.abs(cents(old.partials(K), lp.target_partials(K)))), abs=1e-6)


def test_tighter_tolerance_costs_more():
    f1, B, *loss = string_args(60)
    loose = tune_stiff_loop_sos(f1, B, FS, *loss)
    tight = tune_stiff_loop_sos(f1, B, FS, *loss, tol_cents=0.5)
    assert tight.cost > loose.cost and tight.worst_cents <= 0.5
    few = tune_stiff_loop_sos(f1, B, FS, *loss, max_partials=10)
    assert few.n_partials == 10 and few.cost < loose.cost


# --- errors ---

ARGS = (100.0, 1e-4, FS, 5.0, 100.0, 1.0, 5000.0)


def _sos(**kw):
    a = dict(zip(("f1_hz", "B", "fs", "t60_low_s", "f_low_hz", "t60_high_s", "f_high_hz"), ARGS))
    a.update(kw)
    return lambda: tune_stiff_loop_sos(**a)


@pytest.mark.parametrize("call,name,allowed", [
    (_sos(f1_hz=0.0), "f1_hz", "0 < value < 20312.5"),
    (_sos(f1_hz=30000.0), "f1_hz", "0 < value < 20312.5"),
    (_sos(f1_hz=20000.0), "f1_hz", "allowed: >= 8"),
    (_sos(B=0.2), "B", "0 <= value <= 0.1"),
    (_sos(fs=-1.0), "fs", "0 < value <= 1e+08"),
    (_sos(t60_low_s=0.0), "t60_low_s", "0 < value <= 10000"),
    (_sos(t60_high_s=6.0), "t60_high_s", "0 < value <= 5"),
    (_sos(f_low_hz=2e5), "f_low_hz", "0 < value < 162500"),
    (_sos(f_high_hz=50.0), "f_high_hz", "100 < value <= inf"),
    (_sos(tol_cents=0.0), "tol_cents", "0 < value <= 100"),
    (_sos(max_partials=0), "max_partials", "integer, 1 <= value <= 200"),
    (_sos(max_partials=2.5), "max_partials", "integer, 1 <= value <= 200"),
    (_sos(f_max_hz=2e5), "f_max_hz", "0 < value <= 146250"),
    (_sos(max_biquads=MAX_SOS + 1), "max_biquads", f"integer, 0 <= value <= {MAX_SOS}"),
    (_sos(m_max=17), "m_max", "integer, 0 <= value <= 16"),
    (lambda: retune_sos_loop(None, *ARGS[:1], *ARGS[3:]), "loop", "a SosStiffLoop"),
    (lambda: retune_sos_loop(tune_stiff_loop_sos(*ARGS), -1.0, *ARGS[3:]), "f1_hz",
     "0 < value < 20312.5"),
    (lambda: retune_sos_loop(tune_stiff_loop_sos(*ARGS), 100.0, 1.0, 100.0, 2.0, 5000.0),
     "t60_high_s", "0 < value <= 1"),
    (lambda: tune_stiff_loop_sos(*ARGS).partials(0), "n", "1 <= value"),
    (lambda: tune_stiff_loop_sos(*ARGS).partials(10 ** 5), "n", "fewer than"),
])
def test_errors_name_the_parameter(call, name, allowed):
    with pytest.raises(ValueError, match=rf"^{name} = ") as ei:
        call()
    msg = str(ei.value)
    assert "\n" not in msg and "out of range" in msg and allowed in msg, msg


# --- time-domain reference ---

@nb.njit
def reference_loop(nsamp, Dint, b0, a1, n_fo, a_fo, c1, c2, eta):
    """Impulse response of the loop, sample by sample: a ring of Dint
    samples, the loss filter y = b0 x - a1 y1, n_fo first-order sections
    y = a x + x1 - a y1, the biquads (c2 x + c1 x1 + x2 - c1 y1 - c2 y2,
    direct form I), the tuning allpass y = eta x + x1 - eta y1."""
    M = c1.shape[0]
    ring = np.zeros(Dint)
    out = np.zeros(nsamp)
    lp = 0.0
    fx = np.zeros(max(n_fo, 1))
    fy = np.zeros(max(n_fo, 1))
    x1 = np.zeros(max(M, 1))
    x2 = np.zeros(max(M, 1))
    y1 = np.zeros(max(M, 1))
    y2 = np.zeros(max(M, 1))
    ax = 0.0
    ay = 0.0
    pos = 0
    for n in range(nsamp):
        u = ring[pos]
        lp = b0 * u - a1 * lp
        u = lp
        for j in range(n_fo):
            y = a_fo * u + fx[j] - a_fo * fy[j]
            fx[j] = u
            fy[j] = y
            u = y
        for i in range(M):
            y = c2[i] * u + c1[i] * x1[i] + x2[i] - c1[i] * y1[i] - c2[i] * y2[i]
            x2[i] = x1[i]
            x1[i] = u
            y2[i] = y1[i]
            y1[i] = y
            u = y
        y = eta * u + ax - eta * ay
        ax = u
        ay = y
        u = y
        if n == 0:
            u += 1.0
        out[n] = u
        ring[pos] = u
        pos += 1
        if pos == Dint:
            pos = 0
    return out


@nb.njit
def dtft_abs(x, w):
    """|sum x[n] e^{-i w n}|, the phasor rotated per sample and reset every
    4096 samples."""
    re = 0.0
    im = 0.0
    c = math.cos(w)
    s = math.sin(w)
    cr = 1.0
    ci = 0.0
    for n in range(x.shape[0]):
        if n % 4096 == 0:
            cr = math.cos(w * n)
            ci = math.sin(w * n)
        re += x[n] * cr
        im -= x[n] * ci
        t = cr * c - ci * s
        ci = cr * s + ci * c
        cr = t
    return math.sqrt(re * re + im * im)


def measured_partials(y, fs, K, f1_guess, half_width):
    """Partials 1 .. K of the signal y, found without the design: Blackman-
    Harris (4-term) windowed DTFT peaks, each searched on a 41-point grid
    within +- half_width of the guess, then by golden section around the
    grid's best point; partial 1 is searched around ``f1_guess``, partial n
    around the measured n-1 plus the measured spacing (of 1 and 2 for n = 2:
    twice partial 1)."""
    n = len(y)
    t = np.arange(n) / (n - 1)
    win = (0.35875 - 0.48829 * np.cos(2 * np.pi * t) + 0.14128 * np.cos(4 * np.pi * t)
           - 0.01168 * np.cos(6 * np.pi * t))
    xw = (y - y.mean()) * win
    out = []
    g = (math.sqrt(5.0) - 1.0) / 2.0
    for k in range(K):
        f = f1_guess if k == 0 else (2 * out[0] if k == 1 else 2 * out[-1] - out[-2])
        fg = np.linspace(f - half_width, f + half_width, 41)
        mags = [dtft_abs(xw, 2 * np.pi * x / fs) for x in fg]
        i = int(np.argmax(mags))
        lo, hi = fg[max(i - 1, 0)], fg[min(i + 1, 40)]
        for _ in range(40):
            a, b = hi - g * (hi - lo), lo + g * (hi - lo)
            if dtft_abs(xw, 2 * np.pi * a / fs) >= dtft_abs(xw, 2 * np.pi * b / fs):
                hi = b
            else:
                lo = a
        out.append(0.5 * (lo + hi))
    return np.array(out)


def run_reference(lp, seconds=0.5):
    y = reference_loop(int(seconds * FS), lp.delay_samples, lp.b0, lp.a1, lp.n_fo, lp.a_fo,
                       np.ascontiguousarray(lp.sos[:, 0]), np.ascontiguousarray(lp.sos[:, 1]),
                       lp.eta)
    return measured_partials(y, FS, lp.n_partials, lp.f1_hz, 0.3 * lp.f0_string)


@pytest.mark.slow
@pytest.mark.parametrize("key", [21, 60, 88, 104])
def test_time_domain_loop_rings_at_the_designed_partials(grand, key):
    """Bass (6 biquads), middle (6 + 1 first-order), treble (1 + 1), top (one
    first-order section): the measured partials of the running loop agree
    with partials() within 0.05 cent and with the stiff law within 2 cents."""
    lp, p, t = grand[key]
    meas = run_reference(lp)
    assert np.max(np.abs(cents(meas, p))) < 0.05, key                 # cents (measured ~1e-3)
    assert np.max(np.abs(cents(meas, t))) <= TOL + 0.05, key          # cents


@pytest.mark.slow
def test_time_domain_fallback_and_retuned_loops():
    """The first-order fallback (8 identical sections) and a refitted unison
    string run at their designed partials too."""
    f1, B, *loss = string_args(45)
    fo = tune_stiff_loop_sos(f1, B, FS, *loss, max_biquads=0, m_max=8)
    assert fo.n_fo >= 2
    meas = run_reference(fo)
    assert np.max(np.abs(cents(meas, fo.partials(fo.n_partials)))) < 0.05     # cents
    assert np.max(np.abs(cents(meas, fo.target_partials(fo.n_partials)))) == pytest.approx(
        fo.worst_cents, abs=0.05)
    f1, B, *loss = string_args(68)
    lp = tune_stiff_loop_sos(f1, B, FS, *loss)
    r = retune_sos_loop(lp, *unison_args(68, f1)[2])
    meas = run_reference(r)
    assert np.max(np.abs(cents(meas, r.partials(r.n_partials)))) < 0.05       # cents
    assert np.max(np.abs(cents(meas, r.target_partials(r.n_partials)))) <= TOL + 0.05


@pytest.mark.parametrize("key,k", [(33, 3.0), (60, 3.0), (60, 1.0), (72, 3.0)])
def test_a_bridge_with_mass_is_tuned_into_the_loop(key, k):
    """With a bridge that moves as a mass above k f0 (BridgeLag: the unison's
    in-phase reflection (Z_b - N Z) / (Z_b + N Z), Z_b = R + j w M, leads),
    the loop's resonances with the bridge's phase in it (the in-phase
    motion's) sit on the law within the tolerance, partial 1 exact; the
    same loop without it (the motions that cancel at the bridge) lies lower
    by the bridge's lead at partial 1, which the design took out."""
    g = grand_string(key)
    fm = k * g.f0_hz
    R = bridge_resistance_ns_per_m(key, fm)
    br = BridgeLag(R, R / (2 * np.pi * fm), g.n_strings * g.impedance_ns_per_m, FS)
    f1, B, *loss = string_args(key)
    lp = tune_stiff_loop_sos(f1, B, FS, *loss, bridge=br)
    K = lp.n_partials
    e = cents(lp.partials(K), lp.target_partials(K))
    assert np.max(np.abs(e)) <= TOL and abs(e[0]) < 0.01, e
    assert np.max(np.abs(np.angle(loop_response(lp, lp.partials(K))
                                  * np.exp(-1j * br.lag(2 * np.pi * lp.partials(K) / FS))))) < 1e-8
    lead = -float(br.lag(2 * np.pi * f1 / FS))                 # rad, > 0: the loop is shorter
    assert lead > 0
    bare = lp.__class__(**{**lp.__dict__, "bridge": None})
    shift = cents(bare.partials(1)[0], f1)
    assert shift == pytest.approx(-1200 / math.log(2) * lead / (2 * np.pi), rel=0.02)
    # a retuned unison string keeps the bridge
    lr = retune_sos_loop(lp, f1 * 2 ** (0.5 / 1200), *loss[:1], f1, *loss[2:])
    assert lr.bridge is br and abs(cents(lr.partials(1)[0], f1 * 2 ** (0.5 / 1200))) < 0.01
