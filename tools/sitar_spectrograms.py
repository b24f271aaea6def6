"""Spectrograms of a low, a middle and a high sitar note at three buzz depths.

Usage
-----
    python tools/sitar_spectrograms.py [-o docs/img/sitar-buzz.png] [--preset sitar]
                                       [--keys 45,57,69] [--buzz 0,0.5,1]
                                       [--velocity 100] [--seconds 2.5] [--set PATH=VALUE ...]

One panel per key (rows) and buzz depth (columns): each note rendered as
``synth note P --key K --velocity V --set termination.buzz=B`` renders it
(one note-on at t = 0, 48 kHz output), its spectrogram the thesis's (Hann
45 ms, 55 % overlap, :func:`synth.analysis.spectrum.spectrogram`), 0-8 kHz,
the colour scale the same on every panel (0 to -70 dB re the loudest bin of
all nine).  Each panel's title gives the high band of issue 12 (energy
above 1 kHz 50-500 ms after the pluck) in dB above that of buzz 0.  Needs
the ``[plots]`` extra (matplotlib).
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from study_jawari import high_band  # noqa: E402  (tools/, on sys.path when run as a script)


def render(preset, overrides, key, velocity, seconds):
    from synth.engine.engine import Event
    from synth.io.factory import build_engine

    eng = build_engine(preset, list(overrides))
    y = eng.render([Event(0.0, "note_on", key, velocity / 127.0)], duration_s=seconds)
    y = np.asarray(y, float)
    return (y.mean(axis=1) if y.ndim == 2 else y), eng.fs_out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-o", "--out", default="docs/img/sitar-buzz.png")
    ap.add_argument("--preset", default="sitar")
    ap.add_argument("--keys", default="45,57,69")
    ap.add_argument("--buzz", default="0,0.5,1")
    ap.add_argument("--velocity", type=float, default=100.0)
    ap.add_argument("--seconds", type=float, default=2.5)
    ap.add_argument("--set", action="append", default=[], metavar="PATH=VALUE")
    a = ap.parse_args(argv)
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise SystemExit("this tool needs matplotlib: pip install 'synth[plots]'") from None
    from synth.analysis.spectrum import spectrogram
    from synth.physics.string import midi_key_to_hz

    keys = [int(k) for k in a.keys.split(",")]
    buzz = [float(b) for b in a.buzz.split(",")]
    if not (0.6 <= a.seconds <= 30):
        raise SystemExit(f"--seconds = {a.seconds} is out of range (0.6 <= value <= 30)")
    if not (1 <= a.velocity <= 127):
        raise SystemExit(f"--velocity = {a.velocity} is out of range (1 <= value <= 127)")
    panels = {}
    for k in keys:
        for b in buzz:
            y, fs = render(a.preset, a.set + [f"termination.buzz={b:g}"], k, a.velocity, a.seconds)
            t, f, L = spectrogram(y, fs)
            panels[(k, b)] = (t, f, L, high_band(y, fs, 0.05, 0.5))
    top = max(float(np.max(p[2])) for p in panels.values())
    fig, axes = plt.subplots(len(keys), len(buzz), figsize=(3.0 * len(buzz), 2.2 * len(keys)),
                             sharex=True, sharey=True, squeeze=False)
    names = ["C", "C#", "D", "D#", "E", "F", "F#", "G", "G#", "A", "A#", "B"]
    print(f"high band above 1 kHz, 50-500 ms, dB above buzz {buzz[0]:g}")
    for i, k in enumerate(keys):
        ref = panels[(k, buzz[0])][3]
        row = []
        for j, b in enumerate(buzz):
            t, f, L, hb = panels[(k, b)]
            sel = f <= 8000.0
            ax = axes[i][j]
            ax.pcolormesh(t, f[sel] / 1000.0, L[sel] - top, vmin=-70, vmax=0, cmap="magma",
                          shading="nearest", rasterized=True)
            d = 10.0 * np.log10(hb / ref) if ref > 0 and hb > 0 else 0.0
            row.append(d)
            name = f"{names[k % 12]}{k // 12 - 1}"
            ax.set_title(f"{name} ({midi_key_to_hz(k):.0f} Hz), buzz {b:g}: {d:+.1f} dB", fontsize=8)
            ax.tick_params(labelsize=7)
            if j == 0:
                ax.set_ylabel("kHz", fontsize=7)
            if i == len(keys) - 1:
                ax.set_xlabel("s", fontsize=7)
        print(f"key {k}: " + "  ".join(f"buzz {b:g}: {d:+.1f}" for b, d in zip(buzz, row)))
    fig.suptitle(f"{a.preset}, velocity {a.velocity:g}: spectrogram (Hann 45 ms), dB re the "
                 "loudest bin, 0 to -70", fontsize=9)
    fig.tight_layout()
    fig.savefig(a.out, dpi=80)
    print(f"wrote {a.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
