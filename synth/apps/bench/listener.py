"""The listening position's cost: the stage alone, and in a grand's render, live and offline.

Usage:  python tools/bench.py listener [--seconds 4] [--repeats 5] [--positions close,player,hall]
                                      [--blocks 128,1024] [--cpu-name ...]

Two measures, CPU time of the calling thread (``time.thread_time``: the
machine's other load does not count; the engine renders on one thread), the
ways alternated round by round, medians (min-max) over ``--repeats``:

* **the stage alone** (:class:`synth.dsp.listener.Listener`, stereo at
  48 kHz): ns per output sample and the share of one core it takes in real
  time, per position, in blocks of each of ``--blocks`` (128: the live
  callback's; 1024: an offline render's);
* **in the grand**: a pedalled eight-note chord (C2-C6, velocity 100) played
  for ``--seconds`` through the grand's engine with its listener (the
  default, close) and with the stage taken out (``engine.listener = None``),
  rendered in blocks of each of ``--blocks`` (``render_block``, as the live
  callback does; 1024 as ``synth render``): CPU ms per second of audio, and
  the paired ratio with / without.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from synth.apps.bench import harness

FS = 48_000
CHORD = (36, 43, 48, 55, 60, 64, 67, 84)


def _stage(position: str, block: int, seconds: float):
    from synth.dsp.listener import Listener

    L = Listener.design(FS, 2, position)
    x = np.random.default_rng(0).standard_normal((2, int(seconds * FS)))
    out = np.empty((2, block))
    L.process(x[:, :block], out=out)            # compiled / loaded

    def run() -> float:
        L.reset()
        t0 = time.thread_time()
        for i in range(0, x.shape[1] - block + 1, block):
            L.process(x[:, i:i + block], out=out)
        n = (x.shape[1] // block) * block
        return (time.thread_time() - t0) / n * 1e9
    return run


def _grand(block: int, seconds: float, with_listener: bool):
    from synth.engine.engine import CONTROL, NOTE_ON, Event
    from synth.io.factory import build_engine

    def run() -> float:
        eng = build_engine("grand-piano", (), threads=1)
        if not with_listener:
            eng.listener = None
        eng.schedule([Event(0.0, CONTROL, 64, 1.0)] + [Event(0.001 * i, NOTE_ON, k, 100 / 127)
                                                      for i, k in enumerate(CHORD)])
        n = int(seconds * FS) // block
        t0 = time.thread_time()
        for _ in range(n):
            eng.render_block(block)
        return (time.thread_time() - t0) / (n * block / FS) * 1e3
    return run


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=4.0, help="audio per measure (s)")
    ap.add_argument("--repeats", type=int, default=5, help="alternated rounds (medians)")
    ap.add_argument("--positions", default="close,player,hall", help="positions of the stage alone")
    ap.add_argument("--blocks", default="128,1024", help="block sizes (output samples)")
    ap.add_argument("--skip-grand", action="store_true", help="the stage alone only")
    harness.add_target_option(ap)
    a = ap.parse_args(argv)
    rc = harness.dispatch("listener", a.cpu_name, argv)
    if rc is not None:
        return rc
    blocks = [int(b) for b in a.blocks.split(",")]
    positions = [p.strip() for p in a.positions.split(",") if p.strip()]
    print(f"# command: {harness.command_line('listener', sys.argv[2:] if argv is None else argv)}")
    print(harness.header())
    print("# CPU time of the calling thread, medians (min-max) over alternated rounds")
    ways = {(p, b): _stage(p, b, min(a.seconds, 2.0)) for p in positions for b in blocks}
    got = harness.alternate({f"{p} {b}": f for (p, b), f in ways.items()}, a.repeats, warmup=True)
    print("\nthe stage alone (stereo, 48 kHz)")
    print(f"{'position':<9} {'block':>5}  {'ns/sample':>22}  {'% of a core':>11}")
    for k, v in got.items():
        p, b = k.split()
        med, lo, hi = harness.summary(v)
        print(f"{p:<9} {b:>5}  {med:8.1f} ({lo:6.1f}-{hi:6.1f})  {med * FS / 1e7:10.2f}")
    if a.skip_grand:
        return 0
    print(f"\nthe grand, a pedalled 8-note chord for {a.seconds:g} s (CPU ms per s of audio)")
    print(f"{'block':>5}  {'with the listener':>22}  {'without':>22}  {'ratio':>6}  {'listener ms/s':>13}")
    for b in blocks:
        g = harness.alternate({"with": _grand(b, a.seconds, True),
                               "without": _grand(b, a.seconds, False)}, a.repeats, warmup=True)
        w, wo = harness.summary(g["with"]), harness.summary(g["without"])
        r = harness.summary(harness.ratios(g["with"], g["without"]))
        diff = harness.summary([x - y for x, y in zip(g["with"], g["without"])])
        print(f"{b:>5}  {w[0]:8.1f} ({w[1]:6.1f}-{w[2]:6.1f})  {wo[0]:8.1f} ({wo[1]:6.1f}-{wo[2]:6.1f})"
              f"  {r[0]:6.3f}  {diff[0]:13.1f}")
    return 0
