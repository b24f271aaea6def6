"""What the sitar's taraf and chikari cost: one note with them against one without.

Usage
-----
    python tools/bench.py taraf [--keys 43,55,60,67,74] [--velocity 100]
                                [--seconds 4] [--runs 7] [--set taraf.coupling=4 ...]
                                [--cpu-name {host,haswell,generic,all}]
    python tools/bench.py taraf --quick      # CI: one short run, checks it runs
    python tools/bench.py taraf --json OUT.json   # also the figures as JSON

Each run renders one note per key (a fresh engine per note, one note-on at
t = 0, ``Engine.render`` in its default blocks) with three variants of the
shipped ``sitar`` preset, the engine built outside the timing:

* ``bare``: no ``[taraf]``, no ``[chikari]``;
* ``taraf``: the 11 taraf strings (no chikari), on one bridge with the
  played string at the internal rate;
* ``taraf and chikari``: the two chikari too (which a played note also sets
  ringing).

``--set`` overrides (as ``synth note --set``) apply to every variant.

The machine is noisy: the figures are medians over ``--runs`` of each
variant's time over the bare one's in the same run.  Issue 12's target: a
note with the 11 taraf costs at most 4x one without.  Run with
``NUMBA_NUM_THREADS=1``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import time


from synth.apps.bench import ab as bench_ab  # noqa: E402
from synth.apps.bench import harness  # noqa: E402


def variants(overrides=()):
    from synth.io.presets import load_preset

    p = load_preset("sitar", list(overrides))
    return {"bare": dataclasses.replace(p, taraf=None, chikari=None),
            "taraf": dataclasses.replace(p, chikari=None),
            "taraf and chikari": p}


def run(preset, keys, velocity, seconds):
    """Seconds to render one note per key (bench_ab's timing loop)."""
    return bench_ab.run(preset, (), keys, velocity, seconds)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--keys", default="43,55,60,67,74")
    ap.add_argument("--velocity", type=float, default=100.0)
    ap.add_argument("--seconds", type=float, default=4.0)
    ap.add_argument("--runs", type=int, default=7)
    ap.add_argument("--set", action="append", default=[], metavar="PATH=VALUE",
                    help="preset override for every variant (repeatable)")
    ap.add_argument("--quick", action="store_true", help="one short run (CI)")
    ap.add_argument("--json", metavar="OUT.json", help="also write the figures printed as JSON")
    harness.add_target_option(ap)
    a = ap.parse_args(argv)
    rc = harness.dispatch("taraf", a.cpu_name, argv)
    if rc is not None:
        return rc
    if a.quick:
        a.runs, a.seconds, a.keys = 1, 0.3, "55"
    if not (1 <= a.runs <= 1000):
        raise SystemExit(f"--runs = {a.runs} is out of range (1 <= value <= 1000)")
    if not (0.1 <= a.seconds <= 600):
        raise SystemExit(f"--seconds = {a.seconds} is out of range (0.1 <= value <= 600)")
    keys = [int(k) for k in a.keys.split(",")]
    vs = variants(a.set)
    print(f"# {time.strftime('%Y-%m-%d %H:%M')}  NUMBA_NUM_THREADS={os.environ.get('NUMBA_NUM_THREADS')}")
    print(harness.header())
    for p in vs.values():
        run(p, keys[:1], a.velocity, 0.2)
    times = harness.alternate(
        {k: (lambda p=p: run(p, keys, a.velocity, a.seconds)) for k, p in vs.items()}, a.runs)
    print(f"sitar; keys {keys}, velocity {a.velocity:g}, {a.seconds:g} s each, {a.runs} runs")
    out = {"keys": keys, "velocity": a.velocity, "seconds": a.seconds, "runs": a.runs,
           "variants": {}}
    for k, t in times.items():
        r_med, r_lo, r_hi = harness.summary(harness.ratios(t, times["bare"]))
        print(f"{k:>17}: median {harness.summary(t)[0]:.3f} s, {r_med:.2f}x bare "
              f"(range {r_lo:.2f}-{r_hi:.2f})")
        out["variants"][k] = {"median_s": harness.summary(t)[0], "times_s": list(t),
                              "ratio_median": r_med, "ratio_range": [r_lo, r_hi],
                              "strings": _strings(vs[k])}
    if a.json:
        with open(a.json, "w", encoding="utf-8") as f:
            json.dump(out, f, indent=1)
            f.write("\n")
    return 0


def _strings(preset) -> int:
    """Strings a played note of ``preset`` sounds: the played one, the taraf's, the chikari's."""
    return 1 + sum(len(t.keys) for t in (preset.taraf, preset.chikari) if t is not None)
