"""The plucked instruments' bodies: their responses and what they do to a note.

Usage
-----
    python tools/body_plots.py [-o docs/img/bodies.png] [--presets sitar,biwa]
                               [--key-sitar 55] [--key-biwa 50] [--velocity 100]

Top row: the magnitude response of each preset's ``[body]`` (its diffuse
modes, its named peaks marked, and the direct part dotted) at 48 kHz,
:meth:`synth.dsp.body.Body.response`.  Bottom row: one note (``synth note
P --key K --velocity V``, 1 s) through the body and bare (``[body]``
removed, the biwa's bachi stroke off): its spectrum, 1/6-octave smoothed;
and, for a preset with a bachi stroke, the first 30 ms of the note with
the stroke and of the stroke alone (the difference from the note without).  Needs the ``[plots]`` extra (matplotlib).
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np


def _render(preset, key, velocity, seconds):
    from synth.engine.engine import Event
    from synth.io.factory import build_engine

    eng = build_engine(preset)
    y = eng.render([Event(0.0, "note_on", key, velocity / 127.0)], duration_s=seconds)
    return np.asarray(y, float), eng


def _bare(name):
    from synth.io.presets import load_preset

    p = load_preset(name)
    p = dataclasses.replace(p, body=None)
    if p.pluck is not None and p.pluck.bachi_impulse_ns:
        p = dataclasses.replace(p, pluck=dataclasses.replace(p.pluck, bachi_impulse_ns=0.0))
    return p


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-o", "--out", default="docs/img/bodies.png")
    ap.add_argument("--presets", default="sitar,biwa")
    ap.add_argument("--key-sitar", type=int, default=55)
    ap.add_argument("--key-biwa", type=int, default=50)
    ap.add_argument("--velocity", type=float, default=100.0)
    a = ap.parse_args(argv)
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise SystemExit("this tool needs matplotlib: pip install 'synth[plots]'") from None
    from synth.io.factory import build_engine
    from synth.io.presets import load_preset

    from synth.physics.soundboard import smoothed_db

    names = a.presets.split(",")
    strokes = [n for n in names if (load_preset(n).pluck.bachi_impulse_ns or 0.0) > 0]
    cols = len(names) + len(strokes)
    fig, ax = plt.subplots(2, cols, figsize=(4.6 * cols, 6.0), squeeze=False)
    f = np.geomspace(40.0, 20000.0, 6000)
    for j, name in enumerate(names):
        p = load_preset(name)
        body = build_engine(name).body
        H = np.abs(body.response(f)[0, 0])
        a0 = ax[0, j]
        a0.semilogx(f, 20 * np.log10(H), lw=0.8)
        a0.axhline(20 * np.log10(body.dry_gain), color="0.5", lw=0.6, ls=":")
        for fp, _, _ in p.body.peaks:
            a0.plot(fp, 20 * np.log10(np.abs(body.response([fp])[0, 0, 0])), "v", ms=4,
                    color="C3")
        a0.set(title=f"{name}: body response (peaks marked)", xlabel="Hz", ylabel="dB",
               ylim=(-15, 15))
        a0.grid(True, which="both", alpha=0.3)
        key = a.key_sitar if name == "sitar" else a.key_biwa
        y, eng = _render(name, key, a.velocity, 1.0)
        y0, _ = _render(_bare(name), key, a.velocity, 1.0)
        fs = eng.fs_out
        a1 = ax[1, j]
        fg = np.geomspace(50.0, 16000.0, 3000)
        for sig, style, lab in ((y, "-", "body"), (y0, "--", "bare")):
            X = np.abs(np.fft.rfft(sig * np.hanning(len(sig)))) ** 2
            fx = np.fft.rfftfreq(len(sig), 1 / fs)
            Pg = np.interp(fg, fx, X)
            a1.semilogx(fg, smoothed_db(fg, Pg, fraction=1 / 6), style, lw=0.9, label=lab)
        a1.set(title=f"{name}, key {key}, v{a.velocity:g}: spectrum 0-1 s", xlabel="Hz",
               ylabel="dB (1/6 octave)")
        a1.legend(fontsize=7)
        a1.grid(True, which="both", alpha=0.3)
    for j, name in enumerate(strokes, start=len(names)):
        key = a.key_sitar if name == "sitar" else a.key_biwa
        y, eng = _render(name, key, a.velocity, 0.05)
        p = load_preset(name)
        p = dataclasses.replace(p, pluck=dataclasses.replace(p.pluck, bachi_impulse_ns=0.0))
        y0, _ = _render(p, key, a.velocity, 0.05)
        t = np.arange(len(y)) / eng.fs_out * 1e3
        for row, (sig, lab) in enumerate(((y, "the note with its bachi stroke"),
                                          (y - y0, "the stroke alone"))):
            ax[row, j].plot(t, sig, lw=0.7)
            ax[row, j].set(title=f"{name}, key {key}, v{a.velocity:g}: {lab}", xlabel="ms",
                           ylabel="output", xlim=(0, 30), ylim=(-0.6, 0.6))
            ax[row, j].grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(a.out, dpi=72)
    print(f"wrote {a.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
