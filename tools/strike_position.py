"""Where to strike the hammered sitar: peak over loudness, and buzz, against the strike position.

Usage
-----
    python tools/strike_position.py                       # positions 0.75 0.5 0.35 0.25 0.2 0.15
    python tools/strike_position.py --positions 0.25 0.75 --set play.velocity_exponent=1

For each strike position (``hammer.position``, l/L from the jawari), with
the preset's other values and any ``--set``:

* the reference phrase (``synth/presets/checks/phrases/<preset>.mid``,
  velocity 100) at its integrated loudness L (BS.1770, pyloudnorm);
* its sample peak, and the loudest single note's at velocity 127 (keys
  43-74, every other key, 0.4 s), both as they would be with the gain that
  puts the phrase at -20 LUFS (peak + (-20 - L)): what a limiter would have
  to take off;
* the buzz: the energy above 1 kHz, 50-500 ms after the strike, over the
  same note with ``termination.buzz=0``, at keys 43-74 in steps of 3,
  velocities 40 and 100 (the hammered-sitar check's measure); its worst key.

The output limiter is turned off for the measurement (``output.limiter=off``).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
TARGET_LUFS = -20.0


def measure(preset: str, sets: list[str]) -> dict:
    from synth.analysis import highband_db
    from synth.analysis.loudness import loudness
    from synth.analysis.spectrum import as_mono
    from synth.engine.engine import Event
    from synth.io.factory import build_engine
    from synth.io.midi import midi_to_events, read_midi_file

    sets = list(sets) + ["output.limiter=off"]
    midi = ROOT / "synth" / "presets" / "checks" / "phrases" / f"{preset}.mid"
    events = midi_to_events(read_midi_file(str(midi)))
    eng = build_engine(preset, sets, extra_low_key=43)
    y = as_mono(eng.render(events, duration_s=5.7, tail_s=0.5))
    fs = eng.fs_out
    L = float(loudness(y, fs)["integrated_lufs"])
    phrase_peak = 20.0 * math.log10(float(np.abs(y).max()))
    worst, worst_key = -math.inf, 0
    for key in range(43, 75, 2):
        yy = build_engine(preset, sets).render([Event(0.0, "note_on", key, 1.0)], duration_s=0.4)
        p = 20.0 * math.log10(float(np.abs(yy).max()))
        if p > worst:
            worst, worst_key = p, key
    buzz = []
    for key in range(43, 75, 3):
        for vel in (40, 100):
            ev = [Event(0.0, "note_on", key, vel / 127.0)]
            a = as_mono(build_engine(preset, sets).render(ev, duration_s=1.2))
            b = as_mono(build_engine(preset, sets + ["termination.buzz=0"]).render(ev, duration_s=1.2))
            buzz.append((highband_db(a, fs, 1000.0, 0.05, 0.45) - highband_db(b, fs, 1000.0, 0.05, 0.45),
                         key, vel))
    buzz.sort()
    off = TARGET_LUFS - L
    return dict(lufs=L, phrase_peak=phrase_peak + off, note_peak=worst + off, note_key=worst_key,
                buzz=buzz[0])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--preset", default="hammered-sitar")
    ap.add_argument("--positions", type=float, nargs="+", default=[0.75, 0.5, 0.35, 0.25, 0.2, 0.15])
    ap.add_argument("--set", action="append", default=[], metavar="PATH=VALUE")
    a = ap.parse_args(argv)
    print(f"{a.preset} {' '.join(a.set)}: peaks as they would be with the phrase at -20 LUFS")
    print("position | phrase LUFS | phrase peak | v127 peak (key) | buzz, worst (key, velocity)")
    for pos in a.positions:
        m = measure(a.preset, a.set + [f"hammer.position={pos:g}"])
        b = m["buzz"]
        print(f"{pos:8.3g} | {m['lufs']:+11.1f} | {m['phrase_peak']:+8.1f} dBFS | "
              f"{m['note_peak']:+7.1f} dBFS ({m['note_key']}) | {b[0]:+6.1f} dB ({b[1]}, {b[2]})",
              flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
