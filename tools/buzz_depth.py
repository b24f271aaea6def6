"""Where the buzz's energy goes as the buzz depth grows (issue 12's "grows monotonically").

Usage
-----
    python tools/buzz_depth.py [--preset sitar] [--keys 46,62,74] [--velocity 80]
                               [--buzz 0,0.25,0.5,0.75,1] [--set PATH=VALUE ...]

Each note is rendered as ``synth note`` renders it (0.6 s, one note-on at
t = 0) at every ``termination.buzz`` value.  Per key and buzz: the energy
above 1 kHz (``>1k``), below it and in all (dB, one Hann-windowed spectrum
of 50-500 ms: tests/test_buzz.py's measure), the share above 1 kHz
(``>1k`` - ``all``), and the note's fall from 50-150 ms to 400-500 ms
(``decay``, dB of all its energy).
"""

from __future__ import annotations

import argparse
import sys

import numpy as np


def bands(y, fs, t0, t1, f_cut=1000.0):
    x = np.asarray(y[int(t0 * fs):int(t1 * fs)], float)
    X = np.abs(np.fft.rfft(x * np.hanning(len(x)))) ** 2
    f = np.fft.rfftfreq(len(x), 1.0 / fs)
    return (10 * np.log10(X[f >= f_cut].sum()), 10 * np.log10(X[f < f_cut].sum()),
            10 * np.log10(X.sum()))


def main(argv=None) -> int:
    from synth.engine.engine import Event
    from synth.io.factory import build_engine

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--preset", default="sitar")
    ap.add_argument("--keys", default="46,62,74")
    ap.add_argument("--velocity", type=int, default=80)
    ap.add_argument("--buzz", default="0,0.25,0.5,0.75,1")
    ap.add_argument("--set", action="append", default=[], metavar="PATH=VALUE")
    a = ap.parse_args(argv)
    print(f"preset {a.preset}, overrides: {' '.join(a.set) or '(none)'}, velocity {a.velocity}")
    print("key buzz |   >1k    <1k    all | share>1k | decay")
    for k in (int(x) for x in a.keys.split(",")):
        for b in (float(x) for x in a.buzz.split(",")):
            e = build_engine(a.preset, list(a.set) + [f"termination.buzz={b:g}"], extra_low_key=k)
            y = np.asarray(e.render([Event(0.0, "note_on", k, a.velocity / 127.0)], duration_s=0.6))
            y = y.mean(axis=1) if y.ndim == 2 else y
            hi, lo, tot = bands(y, e.fs_out, 0.05, 0.5)
            t1 = bands(y, e.fs_out, 0.05, 0.15)[2]
            t2 = bands(y, e.fs_out, 0.4, 0.5)[2]
            print(f"{k:3d} {b:4.2f} | {hi:6.2f} {lo:6.2f} {tot:6.2f} | {hi - tot:8.2f} | {t2 - t1:6.2f}",
                  flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
