"""Draw the figures of docs/figures.md that no `synth` command draws.

Usage
-----
    python tools/figures.py tanpura-thread [-o docs/img/tanpura/thread.png]
    python tools/figures.py drone [-o docs/img/tanpura/drone.png]
    python tools/figures.py harpsichord [-o docs/img/keyboard/harpsichord.png]
    python tools/figures.py hammered-sitar [-o docs/img/keyboard/hammered-sitar.png]
    python tools/figures.py list

``tanpura-thread``: the tanpura's Sa (key 49, velocity 90, 5 s) with the
thread (jiva) at 1.0, 1.15 (the preset) and 1.4 times the open jawari's
extent^2 / (2 radius), and the linear string (``termination.buzz=0``):
spectrograms to 8 kHz with the centre of the 2-8 kHz band
(:func:`synth.analysis.band_centroid_hz`) over 0.5 s windows.

``drone``: 60 s of the tanpura's drone (``synth drone --preset tanpura
--sa 49``: Pa Sa Sa Sa every 4 s) beside the sitar plucked at the same
times, keys and velocities (its taraf ringing along): spectrograms to 8
kHz with the 2-8 kHz centre, and the momentary loudness (400 ms, BS.1770)
of both over time.

``harpsichord``, ``hammered-sitar``: the preset across its keyboard, as a
player judges it: the loudness of each key (the loudest 400 ms, BS.1770)
at velocities 30, 64, 100 and 127; the brightness of each attack (the
spectral centroid of its first 100 ms,
:func:`synth.analysis.attack_centroid_hz`) at velocity 100 beside the
instrument it is voiced against (the grand, the plucked sitar); and
spectrograms of a low, a middle and a high key at velocity 100.  The keys
are those of the preset's spec (``synth/presets/checks``).

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


def _spectrogram(ax, y, fs, title, top_hz=8000.0, centre=True):
    from synth.analysis import band_centroid_hz

    ax.specgram(y, NFFT=2048, Fs=fs, noverlap=1536, cmap="magma", vmin=-150, vmax=-40)
    if centre:
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


def drone(out: str, seconds: float = 60.0) -> None:
    from synth.analysis import as_mono, momentary_lufs
    from synth.engine.engine import Event
    from synth.io.factory import build_engine

    plt = _plt()
    tan = build_engine("tanpura", extra_low_key=37)
    y_t = as_mono(tan.render([Event(0.0, "note_on", 49, 0.8)], duration_s=seconds))
    fs_in = tan.fs_in_exact
    plucks = [Event(t / fs_in, "note_on", key, vel, string=i)
              for t, i, key, vel in tan.drone.history if t / fs_in < seconds]
    sit = build_engine("sitar", extra_low_key=37)
    y_s = as_mono(sit.render(plucks, duration_s=seconds))
    fs = tan.fs_out
    fig = plt.figure(figsize=(16, 8))
    grid = fig.add_gridspec(2, 2, height_ratios=(2, 1))
    for col, (name, y) in enumerate((("tanpura", y_t), ("sitar, the same plucks", y_s))):
        ax = fig.add_subplot(grid[0, col])
        _spectrogram(ax, y, fs, f"{name}: key 49, Pa Sa Sa Sa every 4 s")
        if col == 0:
            ax.set_ylabel("Hz")
            ax.legend(loc="upper right", fontsize=8)
    ax = fig.add_subplot(grid[1, :])
    for name, y in (("tanpura", y_t), ("sitar", y_s)):
        t, m = momentary_lufs(y, fs)
        ax.plot(t, m, label=name)
    ax.set_ylabel("momentary loudness (LUFS)")
    ax.set_xlabel("s")
    ax.set_ylim(-45, -5)
    ax.grid(alpha=0.3)
    ax.legend()
    fig.suptitle(f"{seconds:g} s of the drone, tanpura beside the sitar")
    fig.tight_layout()
    fig.savefig(out, dpi=70)


#: preset -> the preset its attack's brightness is shown beside
KEYBOARDS = {"harpsichord": "grand-piano", "hammered-sitar": "sitar"}
VELOCITIES = (30, 64, 100, 127)
#: each key's note for the loudness and the centroid (s)
NOTE_S = 1.5


def keyboard(preset: str, out: str) -> None:
    from functools import lru_cache

    import synth
    from synth.analysis import as_mono, attack_centroid_hz, max_momentary_lufs
    from synth.apps.check import load_spec
    from synth.io.presets import shipped_checks_dir

    plt = _plt()
    beside = KEYBOARDS[preset]
    # the keys of the preset's spec (its first render)
    keys = list(load_spec(shipped_checks_dir() / f"{preset}.toml").renders[0]["keys"])

    @lru_cache(maxsize=None)
    def note(name, key, velocity, secs=NOTE_S):
        # (velocity 100 serves both the loudness and the centroid)
        a = synth.render_note(name, key=key, velocity=velocity, seconds=secs)
        return as_mono(np.asarray(a)), a.fs

    fig = plt.figure(figsize=(16, 9))
    grid = fig.add_gridspec(2, 3)
    ax = fig.add_subplot(grid[0, :2])
    for v in VELOCITIES:
        lufs = [max_momentary_lufs(*note(preset, k, v)) for k in keys]
        ax.plot(keys, lufs, "o-", label=f"velocity {v}")
    ax.set_xlabel("MIDI key")
    ax.set_ylabel("loudest 400 ms (LUFS)")
    ax.set_title(f"{preset}: loudness across the keyboard")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax = fig.add_subplot(grid[0, 2])
    for name, style in ((preset, "o-"), (beside, "s--")):
        c = [attack_centroid_hz(*note(name, k, 100)) for k in keys]
        ax.plot(keys, c, style, label=name)
    ax.set_yscale("log")
    ax.set_xlabel("MIDI key")
    ax.set_ylabel("centroid of the first 100 ms (Hz)")
    ax.set_title("brightness of the attack, velocity 100")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    shown = (keys[0], keys[len(keys) // 2], keys[-1])
    for col, k in enumerate(shown):
        y, fs = note(preset, k, 100, 3.0)
        _spectrogram(fig.add_subplot(grid[1, col]), y, fs, f"key {k}, velocity 100, 3 s",
                     top_hz=12000.0, centre=False)
    fig.suptitle(f"{preset} across its keys and velocities")
    fig.tight_layout()
    fig.savefig(out, dpi=70)


FIGURES = {"tanpura-thread": (tanpura_thread, "docs/img/tanpura/thread.png"),
           "drone": (drone, "docs/img/tanpura/drone.png")}
FIGURES.update({name: (lambda out, name=name: keyboard(name, out), f"docs/img/keyboard/{name}.png")
                for name in KEYBOARDS})


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
    from pathlib import Path
    Path(a.output or path).parent.mkdir(parents=True, exist_ok=True)
    fn(a.output or path)
    print(f"wrote {a.output or path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
