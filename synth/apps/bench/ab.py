"""Cost of one preset change, A against B, measured in one run.

Usage
-----
    python tools/bench.py ab --preset sitar --b termination.pitch_rise_cents=0
                             [--a PATH=VALUE ...] [--keys 43,55,67,74]
                             [--velocity 102] [--seconds 4] [--runs 9] [--clock cpu]
                             [--cpu-name {host,haswell,generic,all}]

Each run renders one note per key (``synth note``'s way: one note-on at
t = 0, a fresh engine per note, ``Engine.render`` in its default blocks)
with the preset plus the ``--a`` overrides, then with the ``--b``
overrides, and times both renders (the engine built outside the timing;
one untimed warm-up of each first).  The machine is noisy, so the figure
is the median over ``--runs`` of the ratio of the two times of the same
run (A / B), with its range.  Run with ``NUMBA_NUM_THREADS=1``.

Example (docs/voicing.md, "Pitch"): what the sitar's decaying tune-out
costs, ``--b termination.pitch_rise_cents=0``.
"""

from __future__ import annotations

import argparse
import os
import time


from synth.apps.bench import harness  # noqa: E402


#: the clocks of ``--clock``: wall time, or this thread's CPU time (with
#: NUMBA_NUM_THREADS=1 the render runs in the calling thread: on a machine
#: loaded by other work, CPU time leaves out the time it waits for a core)
CLOCKS = {"wall": time.perf_counter, "cpu": time.thread_time}


def run(preset, overrides, keys, velocity, seconds, clock=time.perf_counter):
    from synth.engine.engine import Event
    from synth.io.factory import build_engine

    t = 0.0
    for k in keys:
        eng = build_engine(preset, list(overrides))
        t0 = clock()
        eng.render([Event(0.0, "note_on", k, velocity / 127.0)], duration_s=seconds)
        t += clock() - t0
    return t


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--preset", default="sitar")
    ap.add_argument("--a", action="append", default=[], metavar="PATH=VALUE",
                    help="overrides of A (repeatable; default: the preset as shipped)")
    ap.add_argument("--b", action="append", default=[], metavar="PATH=VALUE",
                    help="overrides of B (repeatable)")
    ap.add_argument("--keys", default="43,55,67,74")
    ap.add_argument("--velocity", type=float, default=102.0)
    ap.add_argument("--seconds", type=float, default=4.0)
    ap.add_argument("--runs", type=int, default=9)
    ap.add_argument("--clock", choices=sorted(CLOCKS), default="wall",
                    help="wall time, or the rendering thread's CPU time (cpu; with "
                         "NUMBA_NUM_THREADS=1) on a loaded machine")
    harness.add_target_option(ap)
    a = ap.parse_args(argv)
    rc = harness.dispatch("ab", a.cpu_name, argv)
    if rc is not None:
        return rc
    if not (1 <= a.runs <= 1000):
        raise SystemExit(f"--runs = {a.runs} is out of range (1 <= value <= 1000)")
    if not (0.1 <= a.seconds <= 600):
        raise SystemExit(f"--seconds = {a.seconds} is out of range (0.1 <= value <= 600)")
    if not (1 <= a.velocity <= 127):
        raise SystemExit(f"--velocity = {a.velocity} is out of range (1 <= value <= 127)")
    keys = [int(k) for k in a.keys.split(",")]
    print(f"# {time.strftime('%Y-%m-%d %H:%M')}  NUMBA_NUM_THREADS={os.environ.get('NUMBA_NUM_THREADS')}")
    print(harness.header())
    run(a.preset, a.a, keys, a.velocity, 0.2)
    run(a.preset, a.b, keys, a.velocity, 0.2)
    clk = CLOCKS[a.clock]
    t = harness.alternate({
        "A": lambda: run(a.preset, a.a, keys, a.velocity, a.seconds, clk),
        "B": lambda: run(a.preset, a.b, keys, a.velocity, a.seconds, clk)}, a.runs)
    r_med, r_lo, r_hi = harness.summary(harness.ratios(t["A"], t["B"]))
    print(f"preset {a.preset}; keys {keys}, velocity {a.velocity:g}, {a.seconds:g} s each, {a.runs} runs, "
          f"{a.clock} time")
    print(f"A ({' '.join(a.a) or 'as shipped'}): median {harness.summary(t['A'])[0]:.3f} s")
    print(f"B ({' '.join(a.b) or 'as shipped'}): median {harness.summary(t['B'])[0]:.3f} s")
    print(f"A / B: median {r_med:.3f} (range {r_lo:.3f}-{r_hi:.3f})")
    return 0
