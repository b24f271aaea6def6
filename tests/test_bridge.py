"""Strings on a bridge (coupled unisons, external bridges) and strings on a
finer grid: the kernel against the naive scheme, and the physics of the
bridge's loss."""

import math

import numpy as np
import pytest

from reference import naive_bridge_strings
from synth.dsp.bank import StringBank
from synth.kernels import strings as K
from synth.kernels.layout import ROWS
from synth.physics.plucks import sitar_g


def _profile(rng, R, dx):
    return 0.3e-3 + (np.arange(1, R + 1) * dx) ** 2 / 0.02 + rng.uniform(0, 1e-5, R)


def _group(rng, n_str, per_sample, sos=True, region=True, n_disp=None, n_sos=2):
    """Strings of slightly different length on one bridge, plucked at
    different amplitudes (kernel and naive definitions); ``n_disp``: every
    string's first-order sections (default 1 + its index), ``n_sos`` its
    biquads (if ``sos``)."""
    dt, dx = 1e-5, 1e-3
    defs = []
    for j in range(n_str):
        N = 240 + 3 * j
        k = 180 - j
        U = _profile(rng, 10, dx) if region else None
        th = rng.uniform(0.1, 2.0, n_sos)
        rad = rng.uniform(0.5, 0.9, n_sos)
        d = dict(N=N, k=k, b0=0.995 - 0.002 * j, a1=-0.01, eta=0.1 + 0.05 * j, extra_delay=j % 2,
                 n_disp=1 + j if n_disp is None else n_disp, a_disp=-0.2,
                 tdx=500.0 + 40 * j, gain=1e-3, U=U, side=1,
                 sos=np.column_stack([-2 * rad * np.cos(th), rad * rad]) if sos else np.zeros((0, 2)),
                 A=0.002 * (1 + 0.3 * j), t0=0.0006 + 0.0001 * j)
        defs.append(d)
    return dt, defs


def _bank_for(defs, dt, per_sample, cap=None, sub=1, max_group=K.MAX_CPL):
    b = StringBank(cap or len(defs), max(d["N"] for d in defs) + 2, 16, 2048,
                   max_group=max_group)
    for s, d in enumerate(defs):
        b.configure(s, cells=d["N"], k=d["k"], dt_s=dt, U=d["U"], side=1, out_mode=1,
                    gain=d["gain"], tension_over_dx=d["tdx"], b0=d["b0"], a1=d["a1"],
                    eta=d["eta"], extra_delay=d["extra_delay"], lossy=True,
                    force_per_sample=per_sample, n_disp=d["n_disp"], a_disp=d["a_disp"],
                    sos=d["sos"], sub=sub)
    return b


def _g(d, n, dt):
    t = np.arange(n) * dt
    return sitar_g(t, d["A"], d["t0"])


def _pluck_and_render(b, defs, n, block):
    """Activate and pluck every string of ``defs`` on bank ``b``; render n
    samples in blocks of ``block``."""
    for s, d in enumerate(defs):
        b.activate(s)
        b.start_pluck(s, K.EXC_SITAR, d["A"], d["t0"])
    mix = np.zeros(n)
    for o in range(0, n, block):
        b.render(mix, o, min(block, n - o))
    return mix


def _assert_dies_away(seed, ratio, mass_hz=0.0):
    """A plucked group of three on a bridge of ``ratio`` times their summed
    impedance (with a mass above ``mass_hz``) stays finite and is no louder
    after 35,000 samples than in its first 5,000."""
    rng = np.random.default_rng(seed)
    dt, defs = _group(rng, 3, False, region=False)
    z = sum(d["tdx"] for d in defs) * dt
    b = _bank_for(defs, dt, False, cap=4)
    b.couple([0, 1, 2], ratio * z, 0.0, mass_hz)
    mix = _pluck_and_render(b, defs, 40_000, 1000)
    assert np.all(np.isfinite(mix))
    assert np.max(np.abs(mix[35_000:])) <= np.max(np.abs(mix[:5000]))


@pytest.mark.parametrize("per_sample", [False, True], ids=["fast", "per-sample"])
@pytest.mark.parametrize("n_str", [1, 2, 3])
def test_coupled_strings_equal_the_naive_bridge(per_sample, n_str):
    """Strings on one bridge (loop filters with first- and second-order
    dispersion, a region, plucks) equal the naive scheme's, to round-off,
    on the fast path's lockstep chunks and on the per-sample path."""
    rng = np.random.default_rng(7 + n_str)
    dt, defs = _group(rng, n_str, per_sample)
    b = _bank_for(defs, dt, per_sample)
    R_b, f_ret = 3.0, 5.0
    b.couple(range(n_str), R_b, f_ret)
    n = 9 * defs[0]["N"]
    mix = _pluck_and_render(b, defs, n, 211)
    bra, brb = math.exp(-2 * math.pi * f_ret * dt), dt / R_b
    ref, ub = naive_bridge_strings([dict(d, g=_g(d, n, dt)) for d in defs], n, bra=bra, brb=brb)
    assert np.max(np.abs(ub)) > 1e-4 * max(d["A"] for d in defs)      # the bridge moves
    assert np.max(np.abs(mix - ref)) < 1e-10 * np.max(np.abs(ref))


@pytest.mark.parametrize("n_str", [5, 9, ROWS, ROWS + 1])
def test_many_plucks_at_once_stay_on_the_fast_path(n_str):
    """More strings plucked at once on one bridge than the hammers' GROUP (a
    chord or a strum on a sitar's bridge): up to ROWS of them exciting, the
    group steps in lockstep chunks (its samples then differ from the
    per-sample path's by round-off, not a bit-identical copy of them); with
    more it steps per sample while they excite (the per-sample bank's
    samples exactly).  Either
    way it equals the naive scheme's to round-off."""
    rng = np.random.default_rng(29 + n_str)
    dt, defs = _group(rng, n_str, False, n_disp=1, n_sos=1)
    n = 6 * defs[0]["N"]
    for j, d in enumerate(defs):
        d["t0"] = (n + 10 * j) * dt            # every pluck lasts the whole render
    R_b, f_ret = 3.0, 5.0
    outs = []
    for per_sample in (False, True):
        b = _bank_for(defs, dt, per_sample, max_group=max(n_str, K.MAX_CPL))
        b.couple(range(n_str), R_b, f_ret)
        outs.append(_pluck_and_render(b, defs, n, 211))
    bra, brb = math.exp(-2 * math.pi * f_ret * dt), dt / R_b
    ref, ub = naive_bridge_strings([dict(d, g=_g(d, n, dt)) for d in defs], n, bra=bra, brb=brb)
    assert np.max(np.abs(ub)) > 1e-4 * max(d["A"] for d in defs)      # the bridge moves
    scale = np.max(np.abs(ref))
    assert np.max(np.abs(outs[0] - ref)) < 1e-10 * scale
    assert np.max(np.abs(outs[0] - outs[1])) < 1e-12 * scale
    assert np.array_equal(outs[0], outs[1]) == (n_str > ROWS)


@pytest.mark.parametrize("n_str,n_disp,n_sos", [(1, 1, 2), (2, 0, 0), (2, 1, 3), (3, 0, 4),
                                                 (3, 1, 5), (3, 0, 6), (4, 1, 8), (5, 0, 1),
                                                 (6, 1, 7), (2, 1, 12)])
def test_coupled_strings_in_lockstep_equal_the_naive_bridge(n_str, n_disp, n_sos):
    """Strings with the same loop-filter sections on one bridge (as a piano
    key's: at most one first-order dispersion section, 0-8 biquads), whose
    filters the fast path runs in lockstep, four strings to a vector
    (:func:`synth.kernels.strings._far_lanes`; groups of 5 and 6 in two
    passes), equal the naive scheme's to round-off, and each string's own
    filter's (the per-sample path) to round-off."""
    rng = np.random.default_rng(11 + n_str + 3 * n_sos)
    dt, defs = _group(rng, n_str, False, n_disp=n_disp, n_sos=n_sos)
    R_b, f_ret = 3.0, 5.0
    outs = []
    for per_sample in (False, True):
        b = _bank_for(defs, dt, per_sample, max_group=max(n_str, K.MAX_CPL))
        b.couple(range(n_str), R_b, f_ret)
        if not per_sample:
            assert K._lanes_ok(0, n_str, b.ipar)
        for s, d in enumerate(defs):
            b.activate(s)
            b.start_pluck(s, K.EXC_SITAR, d["A"], d["t0"])
        n = 9 * defs[0]["N"]
        mix = np.zeros(n)
        for o in range(0, n, 211):
            b.render(mix, o, min(211, n - o))
        outs.append(mix)
    bra, brb = math.exp(-2 * math.pi * f_ret * dt), dt / R_b
    ref, ub = naive_bridge_strings([dict(d, g=_g(d, n, dt)) for d in defs], n, bra=bra, brb=brb)
    assert np.max(np.abs(ub)) > 1e-4 * max(d["A"] for d in defs)      # the bridge moves
    assert np.max(np.abs(outs[0] - ref)) < 1e-10 * np.max(np.abs(ref))
    assert np.max(np.abs(outs[0] - outs[1])) < 1e-12 * np.max(np.abs(ref))


def test_the_bridge_changes_the_sound_and_a_still_bridge_does_not():
    """With a very stiff bridge (huge resistance) the group sounds as the
    same strings uncoupled; with a soft one it does not."""
    rng = np.random.default_rng(3)
    dt, defs = _group(rng, 2, False)
    n = 6 * defs[0]["N"]
    outs = []
    for R_b in (None, 1e9, 2.0):
        b = _bank_for(defs, dt, False)
        if R_b is not None:
            b.couple([0, 1], R_b, 0.0)
        for s, d in enumerate(defs):
            b.activate(s)
            b.start_pluck(s, K.EXC_SITAR, d["A"], d["t0"])
        mix = np.zeros(n)
        b.render(mix, 0, n)
        outs.append(mix)
    pk = np.max(np.abs(outs[0]))
    assert np.max(np.abs(outs[1] - outs[0])) < 1e-5 * pk
    assert np.max(np.abs(outs[2] - outs[0])) > 1e-2 * pk


def test_external_bridge_equals_the_naive_scheme():
    """A string hung on an external bridge follows the given displacement
    (a sympathetic string driven by the rest of the instrument)."""
    rng = np.random.default_rng(5)
    dt, defs = _group(rng, 1, False)
    d = defs[0]
    n = 8 * d["N"]
    ubx = 1e-5 * np.sin(2 * np.pi * np.arange(n) * dt * 1.0 / (2 * d["N"] * dt)) \
        * np.exp(-np.arange(n) / (3 * d["N"]))
    for per_sample in (False, True):
        b = _bank_for(defs, dt, per_sample)
        b.set_external_bridge(0)
        b.activate(0)                      # not plucked: only the bridge drives it
        mix = np.zeros(n)
        for o in range(0, n, 173):
            b.render(mix, o, min(173, n - o), ubx=ubx)
        ref, _ = naive_bridge_strings([dict(d, g=np.zeros(1))], n, bra=0.0, brb=0.0, ubx=ubx)
        assert np.max(np.abs(ref)) > 0
        assert np.max(np.abs(mix - ref)) < 1e-10 * np.max(np.abs(ref))


def test_bridge_loss_of_a_single_string():
    """A string on a bridge of resistance R_b loses, on top of its loop's own
    loss, sigma_b = 2 f0 Z / R_b (amplitude decay rate, 1/s; Z = T / c its
    impedance): each reflection from a dashpot keeps (R_b - Z)/(R_b + Z) of
    the wave."""
    fs = 200_000.0
    dt = 1 / fs
    N = 400                                   # f0 = fs / 2N = 250 Hz
    T, c = 700.0, 300.0
    dx = c * dt
    Z = T / c
    b0 = 0.9995
    rates = []
    for R_b in (None, 300.0):
        b = StringBank(1, N + 2, 1, 2048)
        b.configure(0, cells=N, k=N // 7, dt_s=dt, U=None, out_mode=1, gain=1.0,
                    tension_over_dx=T / dx, b0=b0, lossy=True)
        if R_b is not None:
            b.couple([0], R_b, 0.0)
        b.activate(0)
        b.start_pluck(0, K.EXC_SITAR, 0.001, 0.0003)
        n = int(0.4 * fs)
        mix = np.zeros(n)
        b.render(mix, 0, n)
        # envelope: peak per period, fitted line in log
        per = mix[: (n // (2 * N)) * 2 * N].reshape(-1, 2 * N)
        env = np.log(np.max(np.abs(per), axis=1))[20:]
        t = (np.arange(len(env)) + 20) * 2 * N * dt
        rates.append(-np.polyfit(t, env, 1)[0])
    f0 = fs / (2 * N)
    expected = 2 * f0 * Z / 300.0
    assert rates[1] - rates[0] == pytest.approx(expected, rel=0.03)


def test_a_coupled_group_is_reaped_whole():
    rng = np.random.default_rng(9)
    dt, defs = _group(rng, 3, False, region=False)
    b = _bank_for(defs, dt, False, cap=4)
    b.couple([0, 1, 2], 5.0)
    for s in range(3):
        b.activate(s)
    b.start_pluck(0, K.EXC_SITAR, 0.001, 0.0005)    # 1 and 2 only follow the bridge
    mix = np.zeros(2048)
    b.render(mix, 0, 2048)
    # a level between the plucked string's and the followers': only some are quiet
    lv = np.sort(b.fst[:3, K.S_PEAK])
    done = b.reap(2048, float(np.sqrt(lv[0] * lv[2]) if lv[0] > 0 else lv[2] / 2), 1)
    assert len(done) == 0
    done = b.reap(2048, 1e9, 1)
    assert sorted(done.tolist()) == [0, 1, 2]


@pytest.mark.parametrize("per_sample", [False, True], ids=["fast", "per-sample"])
@pytest.mark.parametrize("M", [2, 4])
def test_finer_grid_is_the_mean_of_its_steps(per_sample, M):
    """A string with ``sub`` = M steps per engine sample gives, per engine
    sample, the mean of the M steps of the same string run on its own grid."""
    rng = np.random.default_rng(M)
    dt, defs = _group(rng, 1, per_sample)
    d = defs[0]
    n = 5 * d["N"] // M
    ref_b = _bank_for(defs, dt, per_sample)
    ref_b.activate(0)
    ref_b.start_pluck(0, K.EXC_SITAR, d["A"], d["t0"])
    fine = np.zeros(n * M)
    ref_b.render(fine, 0, n * M)
    b = _bank_for([d], dt, per_sample, sub=M)
    b.activate(0)
    b.start_pluck(0, K.EXC_SITAR, d["A"], d["t0"])
    mix = np.zeros(n)
    for o in range(0, n, 97):
        b.render(mix, o, min(97, n - o))
    want = fine.reshape(n, M).mean(axis=1)
    assert np.max(np.abs(mix - want)) < 1e-12 * np.max(np.abs(want))


@pytest.mark.parametrize("per_sample", [False, True], ids=["fast", "per-sample"])
def test_coupled_group_on_the_finer_grid_equals_the_naive_bridge(per_sample):
    """The grand's top keys (105-108): three strings on one bridge, a region
    each, no biquads, two steps per engine sample (``sub`` = 2) in short
    chunks: per engine sample, the mean of the naive scheme's two steps on
    the fine grid, to round-off, whatever the blocks."""
    rng = np.random.default_rng(105)
    dt, defs = _group(rng, 3, per_sample, sos=False)
    M = 2
    b = _bank_for(defs, dt, per_sample, sub=M)
    R_b, f_ret = 3.0, 5.0
    b.couple(range(3), R_b, f_ret)
    for s, d in enumerate(defs):
        b.activate(s)
        b.start_pluck(s, K.EXC_SITAR, d["A"], d["t0"])
    n = 9 * defs[0]["N"] // M
    mix = np.zeros(n)
    for o in range(0, n, 73):
        b.render(mix, o, min(73, n - o))
    bra, brb = math.exp(-2 * math.pi * f_ret * dt), dt / R_b
    ref, ub = naive_bridge_strings([dict(d, g=_g(d, n * M, dt)) for d in defs], n * M,
                                   bra=bra, brb=brb)
    want = ref.reshape(n, M).mean(axis=1)
    assert np.max(np.abs(ub)) > 1e-4 * max(d["A"] for d in defs)      # the bridge moves
    assert np.max(np.abs(mix - want)) < 1e-10 * np.max(np.abs(want))


@pytest.mark.parametrize("per_sample", [False, True], ids=["fast", "per-sample"])
@pytest.mark.parametrize("M", [2, 4])
def test_finer_grid_on_an_external_bridge_reads_m_values_per_sample(per_sample, M):
    """A string with ``sub`` = M steps per engine sample on an external
    bridge (a sitar's taraf string on its jawari) reads ubx[(o0 + i) M + m]
    at step m of sample i, and gives the mean of its M steps: the same as
    the naive scheme run on its own grid with that displacement, plucked
    too, whatever the blocks."""
    rng = np.random.default_rng(10 + M)
    dt, defs = _group(rng, 1, per_sample)
    d = defs[0]
    n = 6 * d["N"] // M
    t = np.arange(n * M) * dt
    ubx = 2e-4 * np.sin(2 * np.pi * t / (2 * d["N"] * dt)) * np.exp(-t / (2 * d["N"] * dt))
    b = _bank_for([d], dt, per_sample, sub=M)
    b.set_external_bridge(0)
    b.activate(0)
    b.start_pluck(0, K.EXC_SITAR, d["A"], d["t0"])
    mix = np.zeros(n)
    for o in range(0, n, 61):
        b.render(mix, o, min(61, n - o), ubx=ubx)
    ref, _ = naive_bridge_strings([dict(d, g=_g(d, n * M, dt))], n * M, bra=0.0, brb=0.0, ubx=ubx)
    want = ref.reshape(n, M).mean(axis=1)
    assert np.max(np.abs(want)) > 0
    assert np.max(np.abs(mix - want)) < 1e-10 * np.max(np.abs(want))
    with pytest.raises(ValueError, match=r"ubx has .* fewer than \(o0 \+ n\) x"):
        b.render(mix, 0, n, ubx=ubx[: n])


def test_bridge_arguments_are_checked():
    rng = np.random.default_rng(1)
    dt, defs = _group(rng, 2, False)
    b = _bank_for(defs, dt, False, cap=3)
    with pytest.raises(ValueError, match=r"slots = \[1, 1\] is out of range"):
        b.couple([1, 1], 5.0)
    with pytest.raises(ValueError, match=r"slots = \[0, 1, 2, 0, 1\] is out of range"):
        b.couple([0, 1, 2, 0, 1], 5.0)
    with pytest.raises(ValueError, match="resistance_ns_per_m = 0.0 is out of range"):
        b.couple([0, 1], 0.0)
    b.configure(2, cells=100, k=10, dt_s=dt, U=None, out_mode=0, lossy=True)
    with pytest.raises(ValueError, match="slot 2 cannot hang on a bridge"):
        b.couple([1, 2], 5.0)
    with pytest.raises(ValueError, match="slot 2 cannot hang on an external bridge"):
        b.set_external_bridge(2)
    with pytest.raises(ValueError, match="lead = 0 is out of range"):
        b.join(0, 1)                   # no open bridge led by slot 0
    b.open_bridge(0, 5.0)
    with pytest.raises(ValueError, match="slot 2 cannot hang on a bridge"):
        b.join(0, 2)
    with pytest.raises(ValueError, match=r"holds 4 strings, the most this bank takes"):
        full = StringBank(6, 300, 16, 256)
        for s in range(6):
            full.configure(s, cells=100, k=10, dt_s=dt, U=None, out_mode=1, lossy=True)
        full.open_bridge(0, 5.0)
        for s in range(1, 5):
            full.join(0, s)


@pytest.mark.parametrize("key,law,block", [(40, 4, 866), (60, 5, 97), (80, 4, 301),
                                           (84, 4, 866), (90, 5, 301), (96, 4, 866)])
def test_struck_unison_on_its_bridge_fast_equals_per_sample(key, law, block):
    """A grand key's unison on one bridge, its strings struck by hammers at
    different speeds (and one left to ring through the bridge, as una
    corda): the lockstep fast path (hammers stepped together) gives the
    per-sample reference's output to round-off.  Every case's hammers sit
    close enough to the near end (or, from key 84, the capo bar's region on
    the finer grid: pieces of 39, 15 and 3 samples) that the chunks step in
    two tempi (:func:`synth.kernels.unison._coupled_chunk_split`)."""
    from synth.kernels import unison
    from synth.io.factory import build_voice
    from synth.physics import piano as P

    inst = build_voice("grand-piano")
    sus = inst.setup(key)
    outs = []
    for per_sample in (True, False):
        R = max(0 if su.U is None else len(su.U) for su in sus)
        b = StringBank(len(sus), max(su.cells for su in sus) + 2, max(1, R), 4096)
        for s, su in enumerate(sus):
            b.configure(s, cells=su.cells, k=su.k, dt_s=su.dt_s, U=su.U, side=1, out_mode=1,
                        tension_over_dx=su.tension_n / (su.c_m_per_s * su.dt_s), b0=su.b0,
                        a1=su.a1, eta=su.eta, extra_delay=su.extra_delay, lossy=True,
                        n_disp=su.n_disp, a_disp=su.a_disp, force_per_sample=per_sample,
                        gain=1.0)
        b.couple(range(len(sus)), 800.0, 5.0)
        for s, su in enumerate(sus):
            b.activate(s)
            if s < len(sus) - 1 or len(sus) == 1:
                hp = dict(inst._hammer(key, len(sus), su), speed_m_per_s=2.0 + 1.5 * s)
                if law == 5:
                    f0, p, gamma, tau0 = P.hammer_four_param(key)
                    hp.update(law=5, stiffness=f0, exponent=p, alpha_or_gamma=gamma, tau0_s=tau0)
                b.start_hammer(s, **hp)
        n = int(0.02 / sus[0].dt_s)
        if not per_sample:
            C, slow = unison._coupled_next(0, len(sus), b.ipar, b.fpar, b.fst, 512, False)
            d, Cf = unison._coupled_split(0, len(sus), b.ipar, b.fpar, b.fst, 512, C)
            assert not slow and 1 <= d <= C < Cf, (C, d, Cf)  # the split's case
        mix = np.zeros(n)
        for o in range(0, n, block):
            b.render(mix, o, min(block, n - o))
        outs.append(mix)
    slow, fast = outs
    assert np.all(np.isfinite(fast)) and np.max(np.abs(slow)) > 0
    assert np.max(np.abs(fast - slow)) <= 1e-10 * np.max(np.abs(slow))


@pytest.mark.parametrize("per_sample", [False, True], ids=["fast", "per-sample"])
def test_an_open_bridge_equals_the_naive_scheme_as_strings_join_and_leave(per_sample):
    """An open bridge (a sitar's taraf and played strings): its members are
    any slots, in any order, with strings off the bridge rendering between
    them; one string joins while the bridge moves and another leaves, at
    block boundaries.  Equal to the naive scheme to round-off, on the fast
    path's lockstep chunks and per sample."""
    rng = np.random.default_rng(21)
    dt, defs = _group(rng, 5, per_sample)
    b = _bank_for(defs, dt, per_sample, cap=6, max_group=6)
    R_b, f_ret = 3.0, 5.0
    n = 8 * defs[0]["N"]
    j_in, j_out = 3 * 211, 5 * 211
    b.open_bridge(3, R_b, f_ret)
    b.join(3, 0)
    b.join(3, 2)
    assert b.group(3) == (3, 0, 2)
    for s, d in enumerate(defs):
        b.activate(s)
        b.start_pluck(s, K.EXC_SITAR, d["A"], d["t0"])
    mix = np.zeros(n)
    for o in range(0, n, 211):
        if o == j_in:
            b.join(3, 4)               # string 4 (ringing, off the bridge) joins
        if o == j_out:
            b.leave(0)
        b.render(mix, o, min(211, n - o))
    assert b.group(3) == (3, 2, 4)
    on = {3: (0, n), 0: (0, j_out), 2: (0, n), 4: (j_in, n), 1: (n, n)}
    order = [3, 0, 2, 4, 1]
    bra, brb = math.exp(-2 * math.pi * f_ret * dt), dt / R_b
    ref, ub = naive_bridge_strings([dict(defs[s], g=_g(defs[s], n, dt), on=on[s]) for s in order],
                                   n, bra=bra, brb=brb)
    assert np.max(np.abs(ub[j_in:])) > 1e-4 * max(d["A"] for d in defs)   # it moves as 4 joins
    assert np.max(np.abs(mix - ref)) < 1e-10 * np.max(np.abs(ref))


@pytest.mark.parametrize("per_sample", [False, True], ids=["fast", "per-sample"])
def test_a_string_with_a_pitch_bend_line_hangs_on_a_bridge(per_sample):
    """A played sitar string carries its tune-out's bend line onto the
    bridge: the lockstep chunks equal the per-sample path (the bend line
    between the loop filter and the bridge in both)."""
    outs = []
    for ps in (per_sample, True):
        b = StringBank(3, 400, 16, 1024, max_bend=64)
        dt = 1e-5
        for s, N in enumerate((300, 331, 277)):
            b.configure(s, cells=N, k=40 + s, dt_s=dt, U=None, out_mode=1, gain=1e-3,
                        tension_over_dx=400.0 + 50 * s, b0=0.998, a1=-0.01, eta=0.2,
                        lossy=True, force_per_sample=ps, bend_len=64 if s == 1 else 0,
                        bend_delay=7.3 if s == 1 else 0.0)
        b.set_tune_out(1, 5.0, 0.003)
        b.open_bridge(0, 2.0)
        b.join(0, 1)
        b.join(0, 2)
        for s in range(3):
            b.activate(s)
        b.start_pluck(1, K.EXC_SITAR, 0.002, 0.0007)
        mix = np.zeros(4000)
        for o in range(0, 4000, 397):
            b.render(mix, o, min(397, 4000 - o))
        outs.append(mix)
    assert np.max(np.abs(outs[0])) > 0
    assert np.max(np.abs(outs[0] - outs[1])) < 1e-11 * np.max(np.abs(outs[1]))


def test_an_open_bridge_frees_its_members_alone_and_its_leader_last():
    rng = np.random.default_rng(9)
    dt, defs = _group(rng, 3, False, region=False)
    b = _bank_for(defs, dt, False, cap=4)
    b.open_bridge(0, 5.0)
    b.join(0, 1)
    b.join(0, 2)
    for s in range(3):
        b.activate(s)
    b.start_pluck(1, K.EXC_SITAR, 0.001, 0.0005)
    mix = np.zeros(2048)
    b.render(mix, 0, 2048)
    assert b.fst[2, K.S_PEAK] > 0               # string 2 rings through the bridge
    # every string quiet: the members may go alone, the leader only with them
    done = sorted(b.reap(2048, 1e9, 1).tolist())
    assert done == [0, 1, 2]
    b.deactivate(2)
    assert b.group(0) == (0, 1) and b.ipar[1, K.I_CPLNX] == -1
    b.deactivate(0)                             # the leader ends the group
    assert b.group(0) == () and b.ipar[1, K.I_CPL] == K.CPL_NONE
    # a member reconfigured is off its bridge
    b.open_bridge(1, 5.0)
    b.configure(2, cells=defs[2]["N"], k=5, dt_s=dt, U=None, out_mode=1, lossy=True)
    b.join(1, 2)
    b.configure(2, cells=defs[2]["N"], k=5, dt_s=dt, U=None, out_mode=1, lossy=True)
    assert b.group(1) == (1,) and b.ipar[2, K.I_CPL] == K.CPL_NONE


@pytest.mark.parametrize("ratio", [0.01, 0.5, 1.0, 2.05, 10.0, 1000.0])
def test_a_bridge_of_any_resistance_is_passive(ratio):
    """The bridge steps in the same sample as the strings' force, so a
    string is reflected by the dashpot's (R - Z) / (R + Z) at every
    frequency: a plucked group on a bridge of any resistance (here 0.01 to
    1000 times the strings' summed impedance) stays bounded and dies away
    over 40,000 samples.  (The step one sample behind the force reflected
    by (1 - r z^-1) / (1 + r z^-1), more than 1 above fs/4: this group grew
    without bound at every ratio up to 10; tools/stress.py found the
    sitar's taraf blowing up at 1 N s/m.)"""
    _assert_dies_away(5, ratio)


@pytest.mark.parametrize("per_sample", [False, True], ids=["fast", "per-sample"])
@pytest.mark.parametrize("n_str,mass_hz", [(1, 2000.0), (3, 300.0), (3, 5000.0)])
def test_a_bridge_with_mass_equals_the_naive_bridge(per_sample, n_str, mass_hz):
    """A bridge with a mass above ``mass_hz`` (its admittance 1 / (R + j w
    M)) equals the naive scheme's, the mass stepped in the same sample as
    the strings' force, on both paths, to round-off."""
    rng = np.random.default_rng(31 + n_str)
    dt, defs = _group(rng, n_str, per_sample)
    b = _bank_for(defs, dt, per_sample)
    R_b, f_ret = 3.0, 5.0
    b.couple(range(n_str), R_b, f_ret, mass_hz)
    n = 9 * defs[0]["N"]
    mix = _pluck_and_render(b, defs, n, 211)
    bra, brb = math.exp(-2 * math.pi * f_ret * dt), dt / R_b
    mu = 1.0 / (2 * math.pi * mass_hz * dt)
    ref, ub = naive_bridge_strings([dict(d, g=_g(d, n, dt)) for d in defs], n, bra=bra, brb=brb,
                                   mu=mu)
    still, _ = naive_bridge_strings([dict(d, g=_g(d, n, dt)) for d in defs], n, bra=bra, brb=brb)
    assert np.max(np.abs(ub)) > 1e-5 * max(d["A"] for d in defs)      # the bridge moves
    assert np.max(np.abs(ref - still)) > 1e-3 * np.max(np.abs(ref))    # and its mass matters
    assert np.max(np.abs(mix - ref)) < 1e-10 * np.max(np.abs(ref))


@pytest.mark.parametrize("ratio,mass_hz", [(0.5, 100.0), (2.05, 3000.0), (10.0, 300.0),
                                           (1000.0, 50.0), (1.0, 1e5)])
def test_a_bridge_with_mass_is_passive(ratio, mass_hz):
    """The mass is stepped backward (Euler) in the same sample as the
    strings' force: the impedance R + M (1 - z^-1) / dt has a real part R +
    M (1 - cos w dt) / dt >= R, so a plucked group on it stays bounded and
    dies away whatever the resistance and the mass."""
    _assert_dies_away(9, ratio, mass_hz)


def test_the_mass_argument_is_checked():
    rng = np.random.default_rng(3)
    dt, defs = _group(rng, 2, False, region=False)
    b = _bank_for(defs, dt, False)
    for bad in (-1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="mass_hz"):
            b.couple([0, 1], 3.0, 5.0, bad)
