"""The bank's thread governor (synth.dsp.threads.Governor): a kernel that
could run on several threads runs on them while they are faster, on the
calling thread while they are slower (a busy machine), and the samples are
the same either way."""

import numpy as np
import pytest

from synth.dsp import threads
from synth.engine.engine import Event
from synth.io.factory import build_engine


@pytest.fixture(autouse=True)
def _governed(monkeypatch):
    """The governor on (live play's ready_engine turns it off for the
    process, and a test before may have called it)."""
    monkeypatch.setattr(threads.Governor, "auto", True)
    monkeypatch.setattr(threads.Governor, "realtime_dt_s", None)


class Clock:
    def __init__(self):
        self.t = 0.0

    def __call__(self):
        return self.t


def drive(gov, clock, calls, seconds_per_unit, nt=2, units=1000.0, dt=0.01):
    """``calls`` calls: each picks, takes ``seconds_per_unit(parallel)`` per
    unit, and advances the clock by ``dt``; returns the modes picked."""
    modes = []
    for _ in range(calls):
        n = gov.pick(nt)
        par = n > 1
        modes.append(par)
        gov.record(seconds_per_unit(par) * units, units)
        clock.t += dt
    return modes


def test_threads_kept_while_they_are_faster():
    clock = Clock()
    gov = threads.Governor(probe_calls=8, probe_s=0.05, clock=clock)
    modes = drive(gov, clock, 400, lambda par: 1e-8 if par else 1.6e-8)
    assert gov.parallel
    # only the probes ran on one thread: a burst every 8 calls at most
    assert 0 < modes.count(False) <= 3 * (400 // 8 + 1)
    assert modes.count(False) / len(modes) <= 3 / (8 + 3) + 0.01


def test_a_busy_machine_moves_to_one_thread_and_back():
    clock = Clock()
    gov = threads.Governor(probe_calls=8, probe_s=0.2, clock=clock)
    busy = [True]
    # busy: the threads' calls 10x slower, one in four an outlier either way
    # (one in twenty on the quiet machine)
    rng = np.random.default_rng(1)

    def rate(par):
        base = (1e-7 if busy[0] else 1e-8) if par else 1.6e-8
        odd = 0.25 if busy[0] else 0.05
        return base * (rng.choice([0.2, 5.0]) if rng.random() < odd else 1.0)

    modes = drive(gov, clock, 400, rate)
    assert not gov.parallel
    # after the first probe, one thread but for the probes (a burst per 0.2 s)
    late = modes[50:]
    assert late.count(True) <= 3 * (len(late) * 0.01 / 0.2 + 1)
    busy[0] = False
    modes = drive(gov, clock, 400, rate)
    assert gov.parallel
    # (back within 8 x 0.2 s, the longest wait between probes; then a probe
    # of one thread every 0.2-1.6 s, and an outlier's stretch on one thread
    # now and then)
    assert modes[-200:].count(True) >= 0.7 * 200


def drive_live(gov, clock, calls, seconds_per_unit, units, samples, nt=2, dt=0.003):
    modes = []
    for _ in range(calls):
        par = gov.pick(nt, units, samples) > 1
        modes.append(par)
        gov.record(seconds_per_unit(par) * units, units)
        clock.t += dt
    return modes


def test_live_probes_one_thread_only_where_the_call_fits_it(monkeypatch):
    """Live (a budget of 1 / 325 kHz per internal sample): a heavy scene,
    whose threads take 60 % of the budget (one thread could take 120 %),
    never tries one thread, busy machine or not; a light one (5 %) moves
    to one thread when the threads stall and back when they recover."""
    monkeypatch.setattr(threads.Governor, "realtime_dt_s", 1 / 325_000)
    samples = 867                                  # a 128-sample block at 48 kHz
    budget = samples / 325_000
    heavy, light = 1000.0, 50.0                    # units of the call
    clock = Clock()
    gov = threads.Governor(probe_calls=8, probe_s=0.0, clock=clock)
    r = 0.6 * budget / heavy                       # the threads: 60 % of the budget
    modes = drive_live(gov, clock, 300, lambda par: r if par else 2 * r, heavy, samples)
    assert all(modes) and gov.calls[0] == 0
    # stalled threads (10x): still no probe, the call would not fit one thread
    modes = drive_live(gov, clock, 300, lambda par: 10 * r if par else 2 * r, heavy, samples)
    assert all(modes)

    clock = Clock()
    gov = threads.Governor(probe_calls=8, probe_s=0.0, clock=clock)
    q = 0.05 * budget / light                      # 5 % of the budget on the threads
    busy = [False]
    modes = drive_live(gov, clock, 100, lambda par: (10 * q if busy[0] else q) if par else 1.5 * q,
                       light, samples)
    assert gov.parallel and modes.count(False) > 0            # probed, stayed
    busy[0] = True
    modes = drive_live(gov, clock, 200, lambda par: (10 * q if busy[0] else q) if par else 1.5 * q,
                       light, samples)
    assert not gov.parallel and modes[-100:].count(False) >= 70


def test_one_thread_is_not_governed():
    gov = threads.Governor()
    assert [gov.pick(1) for _ in range(50)] == [1] * 50
    assert gov.calls == [0, 0]


def test_off_always_gives_the_threads(monkeypatch):
    monkeypatch.setattr(threads.Governor, "auto", False)
    clock = Clock()
    gov = threads.Governor(probe_calls=1, probe_s=0.0, clock=clock)
    assert set(drive(gov, clock, 50, lambda par: 1e-6 if par else 1e-9)) == {True}


@pytest.mark.parametrize("kw, message", [
    (dict(probe_calls=0), "probe_calls = 0 is out of range"),
    (dict(probe_calls=2.5), "probe_calls = 2.5 is out of range"),
    (dict(probe_s=-1.0), "probe_s = -1.0 is out of range"),
    (dict(margin=0.9), "margin = 0.9 is out of range"),
])
def test_bad_settings_name_themselves(kw, message):
    with pytest.raises(ValueError, match=message):
        threads.Governor(**kw)


@pytest.mark.skipif(threads.max_threads() < 2, reason="needs 2 threads (NUMBA_NUM_THREADS)")
def test_a_governor_switching_every_call_plays_the_same_samples():
    """Probing on every call (probe_calls 1, no wait, bursts of 3) flips the
    mode every few calls: a pedalled grand chord (its keys in shards)
    renders exactly as on one thread."""
    evs = [Event(0.0, "control", 64, 1.0)] + [
        Event(0.001 * i, "note_on", k, 0.8) for i, k in enumerate(range(40, 90, 5))]
    ref = build_engine("grand-piano", (), threads=1).render(evs, duration_s=0.25, block=128)
    eng = build_engine("grand-piano", (), threads=2)
    eng.bank.governor = threads.Governor(probe_calls=1, probe_s=0.0)
    out = eng.render(evs, duration_s=0.25, block=128)
    g = eng.bank.governor
    assert g.calls[0] > 0 and g.calls[1] > 0, g.calls
    assert np.array_equal(out, ref)


def test_short_and_long_calls_are_decided_apart():
    """Calls of 325 internal samples faster on one thread (what they pay
    once outweighs the threads), calls of 4096 faster on the threads, the
    short ones first (a sitar's note-ons 1 ms apart, then the held notes):
    each size class ends in its own faster mode, and the long calls run on
    the threads from their first probe on (one set of timings kept them on
    one thread for a second of a 2 s render)."""
    clock = Clock()
    gov = threads.Governor(probe_calls=8, probe_s=0.5, clock=clock)

    def run(calls, samples, rate):
        modes = []
        for _ in range(calls):
            par = gov.pick(2, 45.0 * samples, samples) > 1
            modes.append(par)
            gov.record(rate(par) * 45.0 * samples, 45.0 * samples)
            clock.t += 0.002
        return modes

    short = run(40, 325, lambda par: 4e-8 if par else 2.5e-8)
    assert not gov.parallel and short[-20:].count(False) >= 19
    long = run(300, 4096, lambda par: 1.3e-8 if par else 2.0e-8)
    assert gov.parallel
    assert long[10:].count(False) <= 3 * (290 * 0.002 / 0.5 + 2), long.count(False)
    assert gov.size_class(325) != gov.size_class(4096) == gov.size_class(8191) != gov.size_class(8192)


def test_a_class_s_cold_first_call_does_not_decide_it():
    """The first call of a mode in a size class is not kept: a pedalled
    grand chord's blocks are calls of 4096 and 2837 internal samples, and
    the first 2837-sample call on the threads took 7.0 ns per unit, the
    next ones 2.8 (4.8 on one thread); kept, that one call moved its class
    to one thread for the rest of the render."""
    clock = Clock()
    gov = threads.Governor(probe_calls=8, probe_s=0.5, clock=clock)
    seen = set()
    modes = {4096: [], 2837: []}
    for _ in range(100):
        for samples in (4096, 2837):
            par = gov.pick(2, 20.0 * samples, samples) > 1
            cold = par and samples not in seen
            seen.add(samples) if par else None
            rate = 7.0e-9 if cold else (2.8e-9 if par else 4.8e-9)
            gov.record(rate * 20.0 * samples, 20.0 * samples)
            modes[samples].append(par)
            clock.t += 0.001
    assert modes[2837][10:].count(False) <= 3 and gov.parallel
