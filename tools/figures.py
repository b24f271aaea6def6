"""Draw the figures of docs/figures.md that no `synth` command draws.

Usage
-----
    python tools/figures.py tanpura-thread [-o docs/img/tanpura/thread.png]
    python tools/figures.py list

``tanpura-thread``: the tanpura's Sa (key 49, velocity 90, 5 s) with the
thread (jiva) at 1.0, 1.15 (the preset) and 1.4 times the open jawari's
extent^2 / (2 radius), and the linear string (``termination.buzz=0``):
spectrograms to 8 kHz with the centre of the 2-8 kHz band
(:func:`synth.analysis.band_centroid_hz`) over 0.5 s windows.

Needs matplotlib (the ``[plots]`` extra).  Exit 0 after writing the PNG;
2 with a one-line error.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np


def _plt():
    try:
        import matplotlib
    except ImportError:
        sys.exit('figures.py: error: needs the [plots] extra: pip install "synth[plots]"')
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def _spectrogram(ax, y, fs, title, top_hz=8000.0):
    from synth.analysis import band_centroid_hz

    ax.specgram(y, NFFT=2048, Fs=fs, noverlap=1536, cmap="magma", vmin=-150, vmax=-40)
    t = np.arange(0.25, len(y) / fs - 0.3, 0.25)
    c = [band_centroid_hz(y, fs, 2000.0, 8000.0, x - 0.25, x + 0.25) for x in t]
    ax.plot(t, c, "c-", lw=2, label="centre of 2-8 kHz")
    ax.set_ylim(0, top_hz)
    ax.set_title(title, fontsize=10)
    ax.set_xlabel("s")


def tanpura_thread(out: str) -> None:
    import synth
    from synth.analysis import as_mono
    from synth.io.presets import load_preset

    plt = _plt()
    term = load_preset("tanpura").termination
    open_m = term.extent_m ** 2 / (2.0 * term.radius_m)
    own = term.thread_m / open_m
    cases = [("thread 1.0 x open (grazing)", [f"termination.thread_m={open_m:.6g}"]),
             (f"thread {own:.2f} x open (the preset)", []),
             ("thread 1.4 x open", [f"termination.thread_m={1.4 * open_m:.6g}"]),
             ("buzz 0: the linear string", ["termination.buzz=0"])]
    fig, axs = plt.subplots(1, 4, figsize=(16, 4.2), sharey=True)
    for ax, (title, ov) in zip(axs, cases):
        a = synth.render_note("tanpura", key=49, velocity=90, seconds=5.0, set=ov)
        _spectrogram(ax, as_mono(np.asarray(a)), a.fs, title)
    axs[0].set_ylabel("Hz")
    axs[0].legend(loc="upper right", fontsize=8)
    fig.suptitle("tanpura, key 49 (Sa = C#3), velocity 90: the thread moves the band")
    fig.tight_layout()
    fig.savefig(out, dpi=80)


FIGURES = {"tanpura-thread": (tanpura_thread, "docs/img/tanpura/thread.png")}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="figures.py", description=__doc__.splitlines()[0])
    ap.add_argument("figure", choices=tuple(FIGURES) + ("list",))
    ap.add_argument("-o", "--output", help="the PNG (default: the one docs/figures.md shows)")
    a = ap.parse_args(argv)
    if a.figure == "list":
        for name, (_, path) in FIGURES.items():
            print(f"{name}  ->  {path}")
        return 0
    fn, path = FIGURES[a.figure]
    fn(a.output or path)
    print(f"wrote {a.output or path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
