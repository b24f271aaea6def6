"""Quick timing of the streaming decimator.

Usage:  python tools/bench.py decimator [--seconds 1] [--block 64] [--runs 7]
                                       [--cpu-name {host,haswell,generic,all}]
        python tools/bench.py decimator --card-rates [...]

For each internal rate (``--card-rates``: 325 kHz to each card rate, 44.1,
48, 88.2 and 96 kHz), pushes ``--seconds`` of noise through a fresh
Decimator in engine-like blocks (``inputs_needed(block)`` inputs for ``block``
outputs at a time) and prints the median over ``--runs`` runs of: ns per
output sample, and ms of CPU per second of audio.

``--cpu-name`` picks numba's code-generation target (:mod:`synth.apps.bench.harness`:
host, haswell = AVX2 only, generic = SSE2, or all three in turn); the header
names the CPU and the target in effect.
"""

import argparse
import sys
import time

import numpy as np

from synth.apps.bench import harness  # noqa: E402
from synth.dsp.decimator import Decimator


def bench(fs_in, seconds, block, runs, fs_out=48000):
    dec = Decimator(fs_in, fs_out)
    rng = np.random.default_rng(0)
    n_out_total = int(round(seconds * dec.fs_out))
    x = rng.standard_normal(dec.inputs_needed(n_out_total) + 1)
    out = np.empty(block, dtype=np.float64)
    dec.process(x[:1000])  # compile / warm up
    times = []
    for _ in range(runs):
        dec.reset()
        pos = 0
        made = 0
        t0 = time.perf_counter()
        while made < n_out_total:
            n = min(block, n_out_total - made)
            k = dec.inputs_needed(n)
            dec.process(x[pos:pos + k], out)
            pos += k
            made += n
        times.append(time.perf_counter() - t0)
    t = float(np.median(times))
    return dec, t / n_out_total * 1e9, t / seconds * 1e3


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=1.0)
    ap.add_argument("--block", type=int, default=64)
    ap.add_argument("--runs", type=int, default=7)
    ap.add_argument("--card-rates", action="store_true",
                    help="325 kHz to 44.1, 48, 88.2 and 96 kHz instead of the internal rates")
    harness.add_target_option(ap)
    a = ap.parse_args(argv)
    rc = harness.dispatch("decimator", a.cpu_name, argv)
    if rc is not None:
        return rc
    print(f"# command: {' '.join(['python'] + sys.argv)}")
    print(harness.header())
    pairs = ([(325000, r) for r in (44100, 48000, 88200, 96000)] if a.card_rates
             else [(fs, 48000) for fs in (325000, 336000, 324800)])
    for fs, fs_out in pairs:
        dec, ns, ms = bench(fs, a.seconds, a.block, a.runs, fs_out)
        print(f"fs_in={fs:7d}  fs_out={fs_out:6d}  L/M={dec.L}/{dec.M:<4d} taps/phase={dec.taps_per_phase}  "
              f"latency={dec.latency_s * 1e3:.3f} ms  {ns:7.1f} ns/output  "
              f"{ms:6.2f} ms per s of audio  (block {a.block} outputs)")
    return 0
