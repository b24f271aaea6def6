"""Issue 13: a termination out of the string's reach is not run.

The fast path skips a chunk's termination region when a bound on the
string says no point can touch the obstacle (``strings._out_of_reach``,
the bound ``bank.region_reach``).  The skip must never change a sample: a
render with it equals the render that runs every region, bit for bit."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from helpers import engine, note
from synth.dsp.bank import StringBank, region_reach
from synth.kernels import strings as K


# ---- the bound and the kernel's test, against numpy ---------------------------------
def reach_ref(U, side):
    """min over the touchable points of side U(n) / n, 0 if one touches at rest."""
    best = np.inf
    for n, u in enumerate(U, start=1):
        v = side * u
        if np.isinf(v):
            continue
        if v <= 0:
            return 0.0
        best = min(best, v / n)
    return best


def out_of_reach_ref(ring, P, m0, C, R, B):
    """The kernel's test, slowly: every step of two slots of the window the
    chunk's region reads is under the threshold."""
    if not B > 0:
        return False
    if B == np.inf:
        return True
    L = C + 2 * R
    w = ring[(m0 + 1 - R + np.arange(L)) % P]
    th = B * (1 - 1e-12) - 1e-12 * (abs(w[0]) + abs(w[1]) + L * B)
    return bool(th > 0 and np.all(np.abs(w[:-2] - w[2:]) < th))


def region_pass_clamps(ring, P, m0, C, U, side):
    """Whether the fast path's region step, run on this ring, would change
    it (numpy, point by point and sample by sample, in the kernel's float
    operations: min(side u_r, side U + side vl) along each characteristic)."""
    sc = float(side)
    for n, Un in enumerate(U, start=1):
        if sc * Un == np.inf:
            continue
        for i in range(1, C + 1):
            m = m0 + i
            acc = sc * ring[(m - n) % P]
            x = sc * Un + sc * ring[(m + n) % P]
            if x < acc:
                return True
    return False


def test_region_reach_is_the_smallest_gap_per_point():
    U = np.array([2e-5, 1e-5, np.inf, 9e-5])
    assert region_reach(U, 1) == pytest.approx(min(2e-5, 1e-5 / 2, 9e-5 / 4))
    assert region_reach(-U, -1) == region_reach(U, 1)
    assert region_reach(np.array([1e-5, -1e-6]), 1) == 0.0          # touches at rest
    assert region_reach(np.array([1e-5, 0.0]), 1) == 0.0
    assert region_reach(np.full(3, np.inf), 1) == np.inf
    assert region_reach(np.full(3, -np.inf), -1) == np.inf
    assert region_reach(None, 1) == 0.0
    rng = np.random.default_rng(0)
    for _ in range(50):
        U = rng.normal(1e-4, 1e-4, 7)
        U[rng.random(7) < 0.3] = np.inf
        side = int(rng.choice([1, -1]))
        assert region_reach(side * U, side) == reach_ref(side * U, side)


@settings(max_examples=300, deadline=None)
@given(seed=st.integers(0, 2**31), P2=st.integers(10, 200), R=st.integers(1, 12),
       C=st.integers(1, 80), m0=st.integers(0, 400), side=st.sampled_from([1, -1]),
       scale=st.floats(0.3, 1.2), offset=st.sampled_from([0.0, 1e-3, -0.02]))
def test_out_of_reach_against_numpy_and_never_hides_a_clamp(seed, P2, R, C, m0, side, scale,
                                                             offset):
    """The kernel's test equals the numpy one, on rings with and without a
    wrap inside the window, steps near the threshold and a large common
    offset (an ended excitation's folded g); and whenever it says "out of
    reach", the region step would not have changed the ring."""
    N = P2
    P = 2 * N
    if C + 2 * R > N:
        return
    rng = np.random.default_rng(seed)
    m0 = m0 % P
    x = 1e-3 * np.arange(1, R + 1)
    U = side * (x * x / 0.03 + rng.uniform(0, 2e-6) * x)          # a capo-like gap
    U[rng.random(R) < 0.2] = side * np.inf
    B = region_reach(U, side)
    # a random walk in steps of two slots near the threshold
    ring = np.zeros(P)
    steps = rng.uniform(-1, 1, P) * scale * (B if np.isfinite(B) else 1e-5)
    ring[0], ring[1] = rng.normal(0, 1e-5, 2)
    for j in range(2, P):
        ring[j] = ring[j - 2] + steps[j]
    ring += offset
    off = 3
    big = np.concatenate([np.full(off, 7.0), ring, np.full(5, -7.0)])
    got = K._out_of_reach(big, off, P, m0, C, R, B)
    assert got == out_of_reach_ref(ring, P, m0, C, R, B)
    if got:
        assert not region_pass_clamps(ring, P, m0, C, U, side)


@pytest.mark.parametrize("m0", [0, 5, 37, 59])
def test_the_window_is_exactly_what_the_chunk_reads(m0):
    """A single step over the threshold inside the window (at either end)
    keeps the region running; one slot outside it does not."""
    N, R, C = 30, 3, 20
    P = 2 * N
    U = 1e-3 * np.arange(1, R + 1) ** 2
    B = region_reach(U, 1)
    first = (m0 + 1 - R) % P
    last = (m0 + C + R) % P
    for slot, inside in ((first, True), (last, True), ((first - 1) % P, False),
                         ((last + 1) % P, False)):
        ring = np.zeros(P)
        ring[slot] = 3 * B            # steps of 3 B to both its neighbours two slots away
        assert K._out_of_reach(ring, 0, P, m0, C, R, B) == (not inside), (slot, inside)
    assert K._out_of_reach(np.zeros(P), 0, P, m0, C, R, 0.0) is False
    assert K._out_of_reach(np.zeros(P), 0, P, m0, C, R, np.inf) is True


# ---- renders: the same samples with the skip as without -------------------------------
def _string_render(skip, seed, side, N, k, R, C_block, lossy, amp):
    """A string with a narrow pulse travelling on it (written into the ring),
    rendered in blocks: pulses enter the region at every phase of the chunks."""
    StringBank.skip_unreachable = skip
    try:
        rng = np.random.default_rng(seed)
        b = StringBank(1, N + 2, R, 2048)
        x = 1e-3 * np.arange(1, R + 1)
        U = side * x * x / 0.03
        kw = dict(b0=0.999, a1=-0.01, eta=0.2, n_disp=2, a_disp=-0.3) if lossy else {}
        b.configure(0, cells=N, k=k, dt_s=1e-5, U=U, side=side, lossy=lossy, **kw)
        b.activate(0)
        P = 2 * N
        off = int(b.ipar[0, K.I_OFF])
        for _ in range(3):
            c = int(rng.integers(0, P))
            w = int(rng.integers(1, 4))
            b.ring[off + c: off + min(P, c + w)] += amp * rng.normal()
        n = 6 * N
        mix = np.zeros(n)
        done = 0
        while done < n:
            m = min(C_block, n - done)
            b.render(mix, done, m)
            done += m
        return mix
    finally:
        StringBank.skip_unreachable = True


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**31), side=st.sampled_from([1, -1]), N=st.integers(40, 160),
       R=st.integers(1, 8), kf=st.floats(0.3, 0.8), block=st.integers(1, 300),
       lossy=st.booleans(), amp=st.sampled_from([1e-5, 1e-4, 1e-3]))
def test_pulses_render_the_same_with_and_without_the_skip(seed, side, N, R, kf, block, lossy, amp):
    k = int(round(kf * N))
    if k <= R + 1 or k >= N - 2:
        return
    a = _string_render(True, seed, side, N, k, R, block, lossy, amp)
    b = _string_render(False, seed, side, N, k, R, block, lossy, amp)
    assert np.array_equal(a, b)


def _render_scene(preset, sets, events, seconds, skip, monkeypatch):
    monkeypatch.setattr(StringBank, "skip_unreachable", skip)
    e = engine(preset, sets)
    return e.render(events, duration_s=seconds), e


def _skips_now(e):
    """The played strings with a region whose next free chunk the kernel
    would skip, and those with a region."""
    b = e.bank
    n_skip = n_reg = 0
    for s in b.active[: b.n_active]:
        s = int(s)
        R = int(b.ipar[s, K.I_REG_N])
        if R == 0:
            continue
        n_reg += 1
        C = int(b.ipar[s, K.I_CHUNK_FREE])
        n_skip += bool(C > 0 and K._out_of_reach(b.ring, int(b.ipar[s, K.I_OFF]), 2 * int(b.ipar[s, K.I_N]),
                                                 int(b.ipar[s, K.I_POS]), C, R,
                                                 float(b.fpar[s, K.F_REACH])))
    return n_skip, n_reg


def test_grand_treble_notes_are_the_same_with_the_skip(monkeypatch):
    """The grand's treble (capo bar; keys 103 up on the finer grid), a soft
    and a loud note of each, a restrike during the first, the sustain
    pedal and the una corda: the same samples with and without the skip,
    and the skip does fire once the strike is over."""
    from synth.engine.engine import Event

    ev = []
    for j, key in enumerate((73, 80, 85, 92, 99, 103, 106, 108)):
        t = 0.07 * j
        ev += [Event(t, "note_on", key, 0.25 if j % 2 else 0.95)]
    ev += [Event(0.02, "control", 64, 1.0), Event(0.3, "note_on", 73, 0.8),
           Event(0.45, "control", 67, 1.0), Event(0.5, "note_on", 85, 0.6),
           Event(0.9, "control", 64, 0.0), Event(0.95, "note_off", 80, 0.0)]
    ev.sort(key=lambda e: e.time_s)
    a, ea = _render_scene("grand-piano", (), ev, 1.2, True, monkeypatch)
    b, _ = _render_scene("grand-piano", (), ev, 1.2, False, monkeypatch)
    assert np.array_equal(a, b)
    n_skip, n_reg = _skips_now(ea)
    assert n_reg >= 10 and n_skip >= n_reg // 2, (n_skip, n_reg)


def test_sitar_with_the_buzz_turned_down_is_the_same_with_the_skip(monkeypatch):
    """The sitar at buzz 0.2 (its taraf and chikari on the bridge, the buzz
    moved by CC1 while notes sound): the same samples with and without the
    skip, and some regions are skipped."""
    from synth.engine.engine import Event

    ev = [Event(0.0, "note_on", 62, 0.8), Event(0.25, "note_on", 55, 0.5),
          Event(0.5, "control", 1, 0.05), Event(0.6, "note_on", 67, 0.3), Event(0.9, "control", 1, 0.3)]
    a, ea = _render_scene("sitar", ("termination.buzz=0.2",), ev, 1.3, True, monkeypatch)
    b, _ = _render_scene("sitar", ("termination.buzz=0.2",), ev, 1.3, False, monkeypatch)
    assert np.array_equal(a, b)
    n_skip, n_reg = _skips_now(ea)
    assert n_skip >= 1, (n_skip, n_reg)
