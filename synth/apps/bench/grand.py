"""Cost of grand-piano notes at the default 325 kHz internal rate, one core.

    NUMBA_NUM_THREADS=1 python tools/bench.py grand [--runs 5]
                                                    [--cpu-name {host,haswell,generic,all}]
                                                    [--set PATH=VALUE ...] [--only keys|chord]

``--set`` prices a feature (``--set strings.sympathetic=0``: the grand
without sympathetic strings); ``--only`` runs one of the two main measures.

Prints, medians over ``--runs`` repetitions (each after a warm-up render):

1. per key (a sample across the keyboard): CPU time per second of a
   sounding note, after its attack (the hammer phase is timed apart), and ns
   per string-sample: the engine's time less that of an engine with no note,
   so it holds the note's strings (with their bridge) and the sympathetic
   strings of the undamped top keys, which ring whenever a note sounds;
2. a 64-note chord spread over the keyboard, sustain pedal down: the time to
   render 2 s of it through the whole engine (bank, decimator, soundboard),
   as a fraction of real time, and the number of such notes one core plays in
   real time;
3. the fixed cost of the engine with no note (decimation + soundboard);
4. the attack of a 10-note chord (C2 .. E5, velocity 0.8, 27 strings) in
   0.25 ms steps: ns per string-sample of the whole engine while the
   hammers press the strings (0.25-1 ms), while they fly off (3.5-4.5 ms)
   and after they have gone (8-12 ms), and the block in which the ten
   note-ons land;
5. a sustain-pedal change (CC64) with 64 released voices held by the
   pedal: the engine's time to apply the event (the dampers of all of them).

``--cpu-name`` picks numba's code-generation target (:mod:`synth.apps.bench.harness`:
host, haswell = AVX2 only, generic = SSE2, or all three in turn); the header
names the CPU and the target in effect.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

if "numba" not in sys.modules:
    # one core; only before numba is imported (imported by a test, after numba
    # started its threads, a changed NUMBA_NUM_THREADS fails the next compile)
    os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from synth.apps.bench import harness  # noqa: E402
from synth.engine.engine import Engine, Event  # noqa: E402
from synth.io.factory import build_engine  # noqa: E402

KEYS = (21, 33, 45, 57, 60, 69, 81, 93, 105, 108)


#: preset overrides of this run (``--set``)
OVERRIDES: tuple = ()
#: the clock every measure reads (``--clock``): the wall clock, or this
#: process's CPU time, which time-slicing on a loaded machine does not
#: inflate (at a load of 6-7 on 2 vCPUs, the wall clock read a chord of
#: 33 % at 72-224 %, CPU time at 35-44 %)
clock = time.perf_counter


def make_engine(polyphony=96):
    return build_engine("grand-piano", OVERRIDES, polyphony=polyphony)


def time_blocks(e: Engine, seconds: float, block: int = 256) -> float:
    n = int(seconds * e.fs_out / block)
    t = clock()
    for _ in range(n):
        e.render_block(block)
    return clock() - t


def per_key(runs: int):
    print("| key | strings | dispersion: biquads + first-order | attack (first 50 ms), ms CPU | sustain, ms CPU per note-second | ns per string-sample |")
    print("|---|---|---|---|---|---|")
    costs = []
    for key in KEYS:
        att, sus = [], []
        for _ in range(runs):
            e = make_engine(4)
            base = make_engine(4)
            e.schedule([Event(0.0, "note_on", key, 0.8)])
            ta = time_blocks(e, 0.05)
            ts = time_blocks(e, 1.0)
            tb = time_blocks(base, 1.05)          # engine without notes, same blocks
            att.append(ta - tb * 0.05 / 1.05)
            sus.append(ts - tb * 1.0 / 1.05)
        ns = len(e.inst.setup(key))
        sus_ms = float(np.median(sus)) * 1e3
        costs.append(sus_ms)
        su0 = e.inst.setup(key)[0]
        print(f"| {key} | {ns} | {len(su0.sos)} + {su0.n_disp} | "
              f"{float(np.median(att)) * 1e3:.2f} | {sus_ms:.2f} | "
              f"{sus_ms * 1e-3 / (ns * e.fs_in) * 1e9:.2f} |")
    return costs


def chord(runs: int, n_notes: int = 64):
    keys = np.linspace(21, 108, n_notes).round().astype(int)
    out = []
    for _ in range(runs):
        e = make_engine(n_notes + 8)
        e.schedule([Event(0.0, "control", 64, 1.0)] +
                   [Event(0.001 * i, "note_on", int(k), 0.7) for i, k in enumerate(keys)])
        time_blocks(e, 0.1)                       # attacks
        assert e.n_voices == len(set(keys.tolist())), e.n_voices
        out.append(time_blocks(e, 2.0) / 2.0)     # CPU seconds per second of audio
    return float(np.median(out)), len(set(keys.tolist()))


def attack(runs: int):
    """Engine time per 0.25 ms step after a 10-note chord (medians over
    max(runs, 9) fresh engines: the window while the hammers press is 3
    steps long, so a few repetitions left it at the mercy of a slow moment
    of a shared machine)."""
    from synth.kernels import strings as K

    keys = (36, 43, 48, 52, 55, 60, 64, 67, 72, 76)
    steps = 48
    res = []
    runs = max(runs, 9)
    for _ in range(runs + 1):                   # the first one designs the keys
        e = make_engine(64)
        e.render_block(12)
        e.schedule([Event(e.time_in / e.fs_in_exact, "note_on", k, 0.8) for k in keys])
        t = np.zeros(steps)
        for b in range(steps):
            t0 = clock()
            e.render_block(12)
            t[b] = clock() - t0
        res.append(t)
    t = np.median(res[1:], axis=0)
    n_str = e.bank.n_active
    assert int(np.sum(e.bank.ipar[e.bank.active[:n_str], K.I_EXC] > 0)) == 0  # hammers gone
    per = t / (n_str * 0.25e-3 * e.fs_in) * 1e9

    def span(a_ms, b_ms):
        return float(np.mean(per[int(a_ms / 0.25):int(b_ms / 0.25)]))

    return n_str, t[0], span(0.25, 1.0), span(3.5, 4.5), span(8.0, 12.0)


def pedal_event(runs: int) -> float:
    """Median time (s) to apply one CC64 with 64 released voices sounding."""
    e = make_engine(64)
    keys = list(range(30, 94))
    e.schedule([Event(0.0, "control", 64, 1.0)]
               + [Event(0.001 * i, "note_on", k, 0.7) for i, k in enumerate(keys)]
               + [Event(0.2, "note_off", k, 0.0) for k in keys])
    time_blocks(e, 0.3)
    assert int(e._released.sum()) == 64
    evs = (Event(0.0, "control", 64, 0.0), Event(0.0, "control", 64, 1.0))
    out = []
    for _ in range(runs):
        t = clock()
        for i in range(100):
            e._apply(evs[i % 2], e.time_in)
        out.append((clock() - t) / 100)
    return float(np.median(out))


def idle(runs: int) -> float:
    return float(np.median([time_blocks(make_engine(4), 1.0) for _ in range(runs)]))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--set", action="append", default=[], metavar="PATH=VALUE",
                    help="a preset value for this run, as `synth note --set` (repeatable), "
                         "e.g. strings.sympathetic=0 to price a feature")
    ap.add_argument("--only", choices=("keys", "chord"), default=None,
                    help="only the per-key table or only the 64-note chord")
    ap.add_argument("--clock", choices=("wall", "cpu"), default="wall",
                    help="time with the wall clock (default) or this process's CPU time "
                         "(time.process_time: on a loaded machine)")
    harness.add_target_option(ap)
    a = ap.parse_args(argv)
    rc = harness.dispatch("grand", a.cpu_name, argv)
    if rc is not None:
        return rc

    global OVERRIDES, clock
    OVERRIDES = tuple(a.set)
    clock = time.process_time if a.clock == "cpu" else time.perf_counter
    print(f"# {time.strftime('%Y-%m-%d %H:%M')}  NUMBA_NUM_THREADS={os.environ.get('NUMBA_NUM_THREADS')}"
          f"  clock: {a.clock}")
    if OVERRIDES:
        print(f"# preset overrides: {' '.join(OVERRIDES)}")
    print(f"# command: {' '.join([os.path.basename(sys.executable)] + sys.argv)}")
    print(harness.header())
    # warm-up (compilation, caches)
    e = make_engine(4)
    e.schedule([Event(0.0, "note_on", 60, 0.8)])
    time_blocks(e, 0.2)
    print()
    if a.only in (None, "keys"):
        costs = per_key(a.runs)
        mean_ms = float(np.mean(costs))
        print(f"\nMean over these keys: {mean_ms:.2f} ms of CPU per note-second after the attack "
              f"-> {1000.0 / mean_ms:.0f} sustained notes in real time on one core (the note's "
              f"strings, and the undamped top keys' sympathetic strings that ring while it sounds).")
        t_idle = idle(a.runs)
        print(f"Engine with no note (decimator + soundboard, 256-sample blocks): "
              f"{t_idle * 1e3:.1f} ms per second of audio.")
    if a.only in (None, "chord"):
        frac, n = chord(a.runs)
        print(f"\n{n}-note chord over the keyboard, sustain pedal down, whole engine: "
              f"{frac * 100:.1f} % of real time -> about {n / frac:.0f} such notes in real time "
              f"on one core.")
    if a.only is not None:
        return 0
    n_str, first, contact, flight, free = attack(a.runs)
    print(f"\n10-note chord ({n_str} strings), whole engine, ns per string-sample: hammers "
          f"pressing {contact:.0f}, flying off {flight:.0f}, gone {free:.0f}; the 0.25 ms step "
          f"with the ten note-ons: {first * 1e6:.0f} us.")
    print(f"A sustain-pedal change with 64 released voices: {pedal_event(a.runs) * 1e6:.0f} us "
          f"to apply.")
    return 0
