"""The sitar's two-way bridge against its resistance: tuning, halo, decay and
the taraf's own jawari (docs/voicing.md, "Taraf and chikari").

Usage
-----
    python tools/taraf_bridge.py [--resistances 1000,500,300,60] [--keys 43-74]
                                 [--set PATH=VALUE ...]
    python tools/taraf_bridge.py --quick      # CI: one bridge, two keys

For each bridge resistance R (``taraf.bridge_resistance_ns_per_m``, the
preset's other values as shipped or as ``--set``) it prints:

* ``worst``: the key furthest from equal temperament, partial 1 over
  0.8-1.6 s of a note at velocity 0.8 (``tests/test_pitch.py``'s measure);
* ``halo``: energy 1.5-3 s of G3 (velocity 100, damped at 1 s) over the
  string alone's (``taraf.coupling=0``), dB;
* ``held``: energy 0.05-0.9 s of that note over the string alone's, dB;
* ``decay``: the drop from 0.1-0.3 s to 0.7-0.9 s, over the string alone's
  drop, dB (negative: the bridge takes the note's energy);
* ``lufs``: momentary loudness (BS.1770, 400 ms) of C4 (velocity 0.8,
  damped at 1 s) at 0.3, 1.6 and 2.5 s;
* ``contact``: how long the C4 taraf string touches its own jawari under a
  held C4 (velocity 100, 2 s), s.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from synth.analysis import window_energy_db

FS = 48_000


def _keys(text):
    if "-" in text:
        lo, hi = (int(v) for v in text.split("-"))
        return list(range(lo, hi + 1))
    return [int(v) for v in text.split(",")]


def measure(R: float, keys, overrides=()) -> dict:
    """The figures above for bridge resistance ``R`` (N s/m)."""
    from synth.analysis import cents, estimate_f0
    from synth.analysis.loudness import momentary_lufs
    from synth.engine.engine import Event
    from synth.io.factory import build_engine
    from synth.physics.string import midi_key_to_hz

    ov = list(overrides) + [f"taraf.bridge_resistance_ns_per_m={R:g}"]

    def eng(extra=()):
        return build_engine("sitar", ov + list(extra))

    def note(key, vel, off=None):
        ev = [Event(0.0, "note_on", key, vel)]
        if off is not None:
            ev.append(Event(off, "note_off", key, 0.0))
        return ev

    worst = (None, 0.0)
    for key in keys:
        y = eng().render(note(key, 0.8), duration_s=1.6)
        f_ref = midi_key_to_hz(key)
        c = cents(estimate_f0(y[int(0.8 * FS):], FS, f_ref, search_cents=60), f_ref)
        if abs(c) >= abs(worst[1]):
            worst = (key, c)
    ev = note(55, 100 / 127, off=1.0)
    y = eng().render(ev, duration_s=3.0)
    y0 = eng(["taraf.coupling=0"]).render(ev, duration_s=3.0)
    t, m = momentary_lufs(eng().render(note(60, 0.8, off=1.0), duration_s=3.0), FS, hop_s=0.05)
    e = eng()
    e.taraf.wake()                     # set up now, to count its contacts from the start
    s = e.taraf.slots[e.taraf.design.keys.index(60)] if 60 in e.taraf.design.keys else None
    contact = float("nan")
    if s is not None:
        e.bank.set_telemetry(s, True)
        e.render(note(60, 100 / 127, off=1.0), duration_s=2.0)
        contact = e.bank.telemetry(s)["termination"]["time_in_contact_s"]
    return {
        "R": R, "worst_key": worst[0], "worst_cents": worst[1],
        "halo_db": window_energy_db(y, FS, 1.5, 3.0) - window_energy_db(y0, FS, 1.5, 3.0),
        "held_db": window_energy_db(y, FS, 0.05, 0.9) - window_energy_db(y0, FS, 0.05, 0.9),
        "decay_db": ((window_energy_db(y, FS, 0.7, 0.9) - window_energy_db(y, FS, 0.1, 0.3))
                     - (window_energy_db(y0, FS, 0.7, 0.9) - window_energy_db(y0, FS, 0.1, 0.3))),
        "lufs": [float(m[int(np.argmin(np.abs(t - x)))]) for x in (0.3, 1.6, 2.5)],
        "contact_s": contact,
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--resistances", default="1000,500,300,250,60,30",
                    help="bridge resistances to measure, N s/m (comma-separated)")
    ap.add_argument("--keys", default="43-74", help="keys for the tuning (lo-hi or a,b,c)")
    ap.add_argument("--set", action="append", default=[], metavar="PATH=VALUE",
                    help="preset override (repeatable), as synth note --set")
    ap.add_argument("--quick", action="store_true", help="one bridge, two keys (CI)")
    a = ap.parse_args(argv)
    if a.quick:
        a.resistances, a.keys = "500", "60,72"
    try:
        Rs = [float(v) for v in a.resistances.split(",")]
        keys = _keys(a.keys)
    except ValueError:
        raise SystemExit(f"--resistances = {a.resistances!r} / --keys = {a.keys!r}: "
                         f"expected numbers (e.g. 1000,500 and 43-74)")
    for R in Rs:
        if not (1.0 <= R <= 1e5):
            raise SystemExit(f"--resistances: {R:g} is out of range (1 <= value <= 100000 N s/m)")
    print(f"{'R N s/m':>8} {'worst':>16} {'halo':>8} {'held':>8} {'decay':>8} "
          f"{'LUFS at 0.3/1.6/2.5 s':>24} {'contact':>8}")
    for R in Rs:
        r = measure(R, keys, a.set)
        lu = "/".join(f"{v:.1f}" for v in r["lufs"])
        print(f"{R:8g} {r['worst_cents']:+7.2f} c key {r['worst_key']:<3d} {r['halo_db']:+7.1f} "
              f"{r['held_db']:+8.2f} {r['decay_db']:+8.2f} {lu:>24} {r['contact_s']:8.3f}",
              flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
