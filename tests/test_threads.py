"""The string bank on several threads: the same samples for any count.

The bank splits its strings into shards (a coupled group is one unit) and a
coupled group of more than ``BLOCK`` members (the sitar's bridge) into
blocks; the pieces run on numba's threads and their mixes are added in a
fixed order (:mod:`synth.kernels.render`).  So a render on N threads must be
bit-identical to one on 1, on every preset; against a plain reference
(each unit rendered alone, the mixes summed) it may differ only by the
order of additions.  ``NUMBA_NUM_THREADS`` (by default the machine's cores)
caps the count; on one core the tests check what one thread can (the shard
and block structure does not depend on the thread count).
"""

import subprocess
import sys

import numpy as np
import pytest

from synth.dsp import threads
from synth.dsp.bank import StringBank
from synth.engine.engine import Event
from synth.io.factory import build_engine
from synth.io.presets.loader import list_presets, load_preset
from synth.kernels import render as KR
from synth.kernels import strings as K

MAX = threads.max_threads()
COUNTS = sorted({1, 2, MAX})
COUNTS = [n for n in COUNTS if n <= MAX]
FS_IN = 325_000.0


def phrase(preset):
    """A short phrase reaching every path the preset has: a chord (pedal
    down, so that the grand's undamped strings ring along) over its range,
    both ends included (the grand's top keys, undamped, on the capo bar's
    finer grid), a drone stroke where the preset has drones, a restrike, a
    release.  Derived from the preset's data: a new preset needs no entry."""
    p = load_preset(preset)
    evs = [Event(0.0, "control", 64, 1.0)]
    if p.kind == "study":
        # a study preset: its own string (key -1, as `synth note` sends it)
        return evs + [Event(0.0, "note_on", -1, 0.8)]
    lo, hi = p.play.key_low, p.play.key_high
    keys = tuple(sorted({int(round(lo + (hi - lo) * i / 7)) for i in range(8)}))
    ch = getattr(p, "chikari", None)
    if ch is not None and ch.trigger_key_low is not None:
        keys = (ch.trigger_key_low,) + keys          # a stroke across the drones
    evs += [Event(0.002 * i, "note_on", k, 0.5 + 0.05 * i) for i, k in enumerate(keys)]
    return evs + [Event(0.15, "note_on", keys[1], 0.9), Event(0.2, "note_off", keys[0], 0.0)]


@pytest.fixture(autouse=True)
def _threads_always(monkeypatch):
    """Every call on the threads it is given: the bank's governor would run
    calls on one thread when the machine is busy, and these tests must run
    the parallel loops (tests/test_governor.py tests the governor)."""
    monkeypatch.setattr(threads.Governor, "auto", False)


#: every shipped preset: the musical ones and the thesis's study presets
PRESETS = [name for name, _ in list_presets()]


@pytest.mark.parametrize("preset", PRESETS)
def test_every_thread_count_plays_the_same_samples(preset):
    assert len(PRESETS) >= 13
    outs = {}
    for n in COUNTS:
        eng = build_engine(preset, (), threads=n)
        assert eng.threads == n
        outs[n] = eng.render(phrase(preset), duration_s=0.35, block=256)
    assert np.abs(outs[1]).max() > 1e-4
    for n in COUNTS[1:]:
        assert np.array_equal(outs[n], outs[1]), f"{preset}: {n} threads differ from 1"


def test_changing_the_thread_count_between_blocks_changes_no_sample():
    evs = phrase("sitar")
    ref = build_engine("sitar", (), threads=1).render(evs, duration_s=0.3, block=128)
    eng = build_engine("sitar", (), threads=MAX)
    blocks = []
    for i, y in enumerate(eng.render_blocks(evs, 0.3, block=128)):
        blocks.append(y)
        eng.set_threads(1 + i % MAX)
    assert np.array_equal(np.concatenate(blocks), ref)


def plucked_bank(n_single, group=0, seed=5):
    """``n_single`` plucked strings with lossy far ends and the bridge-force
    output, and (if ``group``) that many more on one bridge, all active."""
    rng = np.random.default_rng(seed)
    cap = n_single + group
    b = StringBank(cap, 300, 8, 512, max_group=group if group > K.MAX_CPL else K.MAX_CPL)
    U = np.full(6, 2e-4)
    for s in range(cap):
        b.configure(s, cells=int(rng.integers(60, 280)), k=20, dt_s=1.0 / FS_IN, U=U,
                    lossy=True, b0=0.999, a1=-0.001, out_mode=1, tension_over_dx=1e3,
                    n_disp=int(rng.integers(0, 3)), a_disp=-0.2)
        b.activate(s)
        b.start_pluck(s, K.EXC_SITAR, float(rng.uniform(-1e-3, 1e-3)), 0.0005)
    if group:
        b.couple(list(range(n_single, cap)), 2.0, 5.0)
    return b


def render(b, n=3000, threads_=1):
    b.set_threads(threads_)
    mix = np.zeros((1, n))
    b.render(mix, 0, n)
    return mix


def test_shards_equal_each_string_alone_up_to_the_order_of_additions():
    """Twelve single strings (eight shards) against the same strings
    rendered one bank each and summed: the same within round-off, and the
    same bytes on every thread count."""
    mix = render(plucked_bank(12))
    ref = np.zeros_like(mix)
    for s in range(12):
        one = plucked_bank(12)
        for t in range(12):
            if t != s:
                one.deactivate(t)
        ref += render(one)
    assert np.abs(ref).max() > 1e-6
    np.testing.assert_allclose(mix, ref, rtol=0, atol=1e-13 * np.abs(ref).max())
    for n in COUNTS[1:]:
        assert np.array_equal(render(plucked_bank(12), threads_=n), mix)


@pytest.mark.parametrize("group", [5, 9, 13])
def test_a_big_group_in_blocks_is_the_same_on_every_thread_count(group):
    """A bridge of 5, 9 or 13 strings (blocks of 4: a last block of 1) with
    three single strings beside it."""
    out = [render(plucked_bank(3, group), threads_=n) for n in COUNTS]
    assert np.abs(out[0]).max() > 1e-6
    for o in out[1:]:
        assert np.array_equal(o, out[0])


def test_a_groups_cost_is_its_members_costs():
    b = plucked_bank(2, 6)
    costs = [KR.string_cost(b.ipar, b.fpar, s) for s in range(8)]
    assert costs[0] == 6 + 6 + 2 * int(b.ipar[0, K.I_NDISP])     # ring, 6 region points
    assert KR.unit_cost(b.ipar, b.fpar, 2) == sum(costs[2:])      # the leader: all six
    assert KR.unit_cost(b.ipar, b.fpar, 0) == costs[0]


def test_thread_counts_are_checked():
    with pytest.raises(ValueError, match=r"threads = 0 is out of range \(1 <= value <= "):
        threads.check_threads(0)
    with pytest.raises(ValueError, match="threads = 'x' is not an integer"):
        threads.check_threads("x")
    with pytest.raises(ValueError, match="threads = 1.5 is not an integer"):
        threads.check_threads(1.5)
    assert threads.check_threads("1") == 1


def test_synth_threads_and_the_command_line(tmp_path, monkeypatch):
    monkeypatch.setenv("SYNTH_THREADS", "1")
    assert threads.default_threads() == 1
    monkeypatch.setenv("SYNTH_THREADS", str(MAX + 1))
    with pytest.raises(ValueError, match=f"SYNTH_THREADS = {MAX + 1} is out of range"):
        threads.default_threads()
    r = subprocess.run([sys.executable, "-m", "synth.cli", "note", "sitar", "--key", "57",
                        "--seconds", "0.1", "--threads", str(MAX + 1), "-o",
                        str(tmp_path / "x.wav")], capture_output=True, text=True)
    assert r.returncode == 2
    assert r.stderr.strip() == (f"synth: error: --threads = {MAX + 1} is out of range "
                                f"(1 <= value <= {MAX}, this machine's threads"
                                + ("; NUMBA_NUM_THREADS limits it)" if MAX == 1 else ")"))
    assert not (tmp_path / "x.wav").exists()


def test_the_next_chunk_is_known_before_this_one_runs():
    """The fused launch (:func:`synth.kernels.render._task_ca`) steps the
    next chunk's first halves before this chunk's tension readings: the
    size :func:`~synth.kernels.render._next_free_chunk` gives before a
    chunk is the size :func:`~synth.kernels.render._coupled_next` gives
    after it, chunk by chunk over a held sitar chord's bridge (45 strings,
    their tension read every F_TMM samples, readings inside the span)."""
    eng = build_engine("sitar", (), threads=1)
    eng.render([Event(0.0, "note_on", k, 0.8) for k in (50, 57, 62)], duration_s=0.05,
               tail_s=0.0, max_tail_s=0.0)
    b = eng.bank
    act = b.active[:b.n_active]
    lead = int(next(s for s in act if b.ipar[s, K.I_CPL] == s and b.ipar[s, K.I_CPLN] > KR.BLOCK))
    G = int(b.ipar[lead, K.I_CPLN])
    members = [lead]
    for _ in range(G - 1):
        members.append(int(b.ipar[members[-1], K.I_CPLNX]))
    assert all(b.ipar[s, K.I_EXC] == K.EXC_NONE for s in members)
    tm = [s for s in members if b.fpar[s, K.F_TMK] > 0]
    assert tm, "no member's tension is read"
    mix = np.zeros((b.mix_rows, 4096))
    readings = 0
    avail = 4096
    for _ in range(60):
        C, slow = KR._coupled_next(lead, G, b.ipar, b.fpar, b.fst, avail, False)
        assert not slow
        ahead = KR._next_free_chunk(lead, G, b.ipar, b.fpar, b.fst, avail - C, C)
        before = b.fst[tm, K.S_TMC].copy()
        b.render(mix, 0, C)
        readings += int(np.sum(b.fst[tm, K.S_TMC] > before))
        assert ahead == KR._coupled_next(lead, G, b.ipar, b.fpar, b.fst, avail - C, False)[0]
    assert readings >= len(tm)
    # none left, or an excited member: no next chunk to fuse
    assert KR._next_free_chunk(lead, G, b.ipar, b.fpar, b.fst, 0, 64) == 0
