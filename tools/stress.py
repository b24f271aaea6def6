"""Numerical stability under stress: random presets, scenes, rates and block sizes (issue 13).

Usage
-----
    python tools/stress.py --cases 5000               # property cases, a table of counts
    python tools/stress.py --cases 2000 --seed 7      # reproducible
    python tools/stress.py --perf                     # also: denormals and a one-hour pedalled chord

The cases and their checks are :mod:`synth.apps.stress` (its notes say
what each kind of case must show, and what ``--perf`` measures); they need
hypothesis (the ``[test]`` extra).  Here: the command line, the table and
the ``--perf`` measurements.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections import Counter

import numpy as np

from synth.apps.stress import ENERGY_RTOL, RISES, _voice, run


def denormal_cost(repeats: int = 7):
    """ns per sample of one sounding sitar string (0.5 s after its pluck)
    at full level and with every signal it holds scaled 100 dB and 300 dB
    down (medians)."""
    from synth.dsp.bank import StringBank
    from synth.kernels import strings as K

    out = {}
    v = _voice("sitar")
    for label, scale in (("full level", 1.0), ("100 dB down", 1e-5), ("300 dB down", 1e-300), ("subnormal: 1e-306 of full level", 1e-306)):
        times = []
        for _ in range(repeats):
            sz = v.sizes()
            b = StringBank(1, sz.max_cells, max_region=max(sz.max_region, 1), max_block=4096,
                           max_gtable=sz.max_gtable, max_bend=sz.max_bend)
            v.note_on(b, [0], 55, 0.8)
            mix = np.zeros(4096)
            for _ in range(int(0.5 * v.fs) // 4096):
                b.render(mix, 0, 4096)
            # every signal the string holds, scaled: its rails, its filters'
            # states and its pitch-bend line (not the tune-out's own state)
            off = int(b.ipar[0, K.I_OFF])
            P = 2 * int(b.ipar[0, K.I_N])
            b.ring[off:off + P] *= scale
            cols = ([K.S_LP, K.S_APX, K.S_APY, K.S_XD] + list(range(K.S_D0, K.S_D0 + 2 * K.MAX_DISP))
                    + list(range(K.S_SOS, K.S_SOS + 4 * K.MAX_SOS)))
            b.fst[0, cols] *= scale
            bo, bl = int(b.ipar[0, K.I_BOFF]), int(b.ipar[0, K.I_BLEN])
            b.U[bo:bo + bl] *= scale
            n = int(0.2 * v.fs) // 4096
            t = time.perf_counter()
            for _ in range(n):
                b.render(mix, 0, 4096)
            times.append((time.perf_counter() - t) / (n * 4096) * 1e9)
        out[label] = float(np.median(times))
    return out


def long_chord(minutes: float = 60.0):
    """A held, pedalled 6-note grand chord for ``minutes`` of simulated time:
    (peak per simulated minute, seconds of compute per simulated minute)."""
    from synth.engine.engine import Event
    from synth.io.factory import build_engine

    e = build_engine("grand-piano", voice=_voice("grand-piano"))
    ev = [Event(0.0, "control", 64, 1.0)] + [Event(0.001 * i, "note_on", k, 0.8)
                                            for i, k in enumerate((36, 43, 48, 52, 55, 60))]
    e.schedule(ev)
    per_min = int(60 * e.fs_out)
    peaks, costs = [], []
    for m in range(int(minutes)):
        t = time.perf_counter()
        peak = 0.0
        done = 0
        while done < per_min:
            n = min(4096, per_min - done)
            y = e.render_block(n)
            if y.size:
                a = float(np.max(np.abs(y)))
                if not math.isfinite(a):
                    raise AssertionError(f"minute {m}: not finite")
                peak = max(peak, a)
            done += n
        costs.append(time.perf_counter() - t)
        peaks.append(peak)
    return peaks, costs


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=2000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--perf", action="store_true", help="also the denormal and one-hour measurements")
    ap.add_argument("--minutes", type=float, default=60.0, help="simulated minutes of the long chord")
    ap.add_argument("-v", "--verbose", action="store_true")
    ap.add_argument("--trace", action="store_true", help="print every case before it runs (stderr)")
    a = ap.parse_args(argv)
    counts, failures, secs = run(a.cases, a.seed, a.verbose, a.trace)
    kinds = sorted({k for k, _ in counts})
    print(f"{sum(counts.values())} cases in {secs:.0f} s (seed {a.seed}):\n")
    print("| kind | passed | rejected by the preset | failed |")
    print("|---|---|---|---|")
    for k in kinds:
        print(f"| {k} | {counts[(k, 'passed')]} | {counts[(k, 'rejected')]} | {counts[(k, 'failed')]} |")
    tot = Counter()
    for (k, o), n in counts.items():
        tot[o] += n
    print(f"| all | {tot['passed']} | {tot['rejected']} | {tot['failed']} |\n")
    nan = sum(1 for _, p in failures if any("finite" in s for s in p))
    print(f"NaN or Inf: {nan} cases.")
    if RISES:
        r = sorted(RISES, key=lambda x: -x[0])
        n12 = sum(1 for x, _ in r if x > 1e-12)
        print(f"Lossless strings: in {n12} of {len(r)} energy cases the grid energy rose by more than "
              f"1e-12 of E0 over 64 steps for a while (at contacts), at most {r[0][0]:.2g} "
              f"({r[0][1].describe()}); never above E0 by {ENERGY_RTOL:g}.")
    for case, probs in failures[:20]:
        print(f"FAILED: {case.describe()}: {'; '.join(probs)}")
    if a.perf:
        d = denormal_cost()
        print("\nCost of a sounding sitar string (ns per internal sample, median of 7):\n")
        print("| state | ns/sample | ratio to full level |")
        print("|---|---|---|")
        for k, v in d.items():
            print(f"| {k} | {v:.1f} | {v / d['full level']:.3f} |")
        peaks, costs = long_chord(a.minutes)
        print(f"\nA held, pedalled 6-note grand chord, {len(peaks)} simulated minutes: peak "
              f"{20 * math.log10(max(peaks)):.1f} dBFS (minute 1) .. "
              f"{(20 * math.log10(peaks[-1]) if peaks[-1] > 0 else -math.inf):.1f} dBFS (last); "
              f"compute per simulated minute: first {costs[0]:.2f} s, median of the rest "
              f"{float(np.median(costs[1:])) if len(costs) > 1 else costs[0]:.3f} s, last {costs[-1]:.3f} s.")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
