"""The soundboard body's cost per output sample, through its wrapper.

Usage:  python tools/bench.py body [--block 128] [--runs 7] [--fs 48000]
                                   [--cpu-name {host,haswell,generic,all}]

The default bank (:class:`synth.dsp.body.Body`) at ``--fs`` filters one
second of noise in ``--block``-sample blocks through ``Body.process``, for
one input and one output, for two of each (the grand's two bridge
ends), and for two of each with the grand's radiation spread and mass law
(``spread_ms`` 3.4, :class:`synth.dsp.spread.Spread`; ``mass_hz`` 3000,
:class:`synth.dsp.board_mass.BoardMass`); printed: the median over ``--runs`` runs of the thread's CPU time
(``time.thread_time``, so a busy neighbour's time is not counted) per
output sample, and that as a percentage of one core at ``--fs``.
"""

import argparse
import sys
import time

import numpy as np

from synth.apps.bench import harness
from synth.dsp.body import Body


#: the grand preset's [body] spread_ms and mass_hz, the third row's
GRAND_SPREAD_MS = 3.4
GRAND_MASS_HZ = 3000.0


def bench(fs: int, inputs: int, outputs: int, block: int, runs: int, spread_ms: float = 0.0,
          mass_hz: float = 0.0) -> dict:
    body = Body(fs, inputs=inputs, outputs=outputs, spread_ms=spread_ms, mass_hz=mass_hz)
    x = np.random.default_rng(0).standard_normal((inputs, fs))
    xi = x if inputs == 2 else x[0]
    out = np.empty((outputs, block)) if outputs == 2 else np.empty(block)
    body.process(xi[..., :block], out)           # compile and warm
    n = fs // block * block
    per = []
    for _ in range(runs):
        t0 = time.thread_time()
        for j in range(0, n, block):
            body.process(xi[..., j:j + block], out)
        per.append((time.thread_time() - t0) / n)
    ns = float(np.median(per)) * 1e9
    return {"inputs": inputs, "outputs": outputs, "modes": body.n_modes, "spread_ms": spread_ms,
            "mass_hz": mass_hz, "ns_per_sample": ns,
            "core_percent": ns * 1e-9 * fs * 100.0}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--block", type=int, default=128, help="samples per call (default 128)")
    ap.add_argument("--runs", type=int, default=7, help="runs; the median is printed (default 7)")
    ap.add_argument("--fs", type=int, default=48000, help="the body's rate in Hz (default 48000)")
    harness.add_target_option(ap)
    a = ap.parse_args(argv)
    rc = harness.dispatch("body", a.cpu_name, argv)
    if rc is not None:
        return rc
    print(f"# command: {' '.join(['python'] + sys.argv)}")
    print(harness.header())
    for io, spread, mass in (((1, 1), 0.0, 0.0), ((2, 2), 0.0, 0.0), ((2, 2), GRAND_SPREAD_MS, 0.0),
                             ((2, 2), GRAND_SPREAD_MS, GRAND_MASS_HZ)):
        r = bench(a.fs, *io, a.block, a.runs, spread, mass)
        what = (f", spread {spread:g} ms" if spread else "") + (f", mass {mass:g} Hz" if mass else "")
        print(f"{r['inputs']} in, {r['outputs']} out{what}: {r['ns_per_sample']:7.1f} ns per output "
              f"sample (thread CPU, median of {a.runs}) = {r['core_percent']:.2f} % of a core at "
              f"{a.fs} Hz, block {a.block}, {r['modes']} modes")
    return 0
