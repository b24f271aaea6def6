"""Does the sitar's buzz fade with the note, or stop in one step?

Usage
-----
    python tools/buzz_decay.py [--preset sitar] [--set PATH=VALUE ...]
                               [--keys 43,49,55,61,67,74] [--velocities 40,80,127]
                               [--seconds 5] [--band 6000,20000] [--within 40] [--rows K,V]
                               [--internal-rate HZ]
    python tools/buzz_decay.py --keys 64 --velocities 100 --seconds 4 \
                               --plot docs/img/sitar-buzz-decay.png --before termination.contact=grid

Each note is rendered as ``synth note`` renders it (one note-on at t = 0,
48 kHz output, the preset with its ``--set``).  In consecutive 100 ms
windows (:func:`synth.analysis.buzz.band_decay`) it measures the energy
in the band (default 6-20 kHz, where the linear string has next to
nothing) and of the whole note; ``drop`` is the largest fall of the band
from one window to the next while the note is within ``--within`` dB of
its first window (from 100 ms on, :meth:`BandDecay.largest_drop`), ``at``
the window it falls into; ``drop3`` the same of the band's running mean
over three windows (300 ms, as energy), which a single window's dip (two
components of the buzz beating) does not move much but a step does; ``band@2s`` the band at 2.0-2.1 s against
0.1-0.2 s; ``40dB`` when the note has fallen 40 dB.  ``--rows K,V``
prints that note's windows, one per line.  The last line gives the worst
drop.  ``--plot`` draws the first key and velocity only: its spectrogram
with the ``--before`` overrides and without, and the band per window.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np


def render(preset, overrides, key, velocity, seconds, fs_internal=None):
    from synth.engine.engine import Event
    from synth.io.factory import build_engine

    eng = build_engine(preset, list(overrides), extra_low_key=key, fs_internal=fs_internal)
    y = eng.render([Event(0.0, "note_on", key, velocity / 127.0)], duration_s=seconds)
    return np.asarray(y, float), eng.fs_out


def measure(preset, overrides, key, velocity, seconds=5.0, band=(6000.0, 20000.0), within=40.0,
            fs_internal=None):
    from synth.analysis.buzz import band_decay

    y, fs = render(preset, overrides, key, velocity, seconds, fs_internal)
    d = band_decay(y, fs, band[0], band[1])
    drop, at = d.largest_drop(within)
    sdrop, sat = d.largest_drop(within, smooth=3)
    below = np.flatnonzero(d.note_db < d.note_db[0] - within)
    i2 = int(round(2.0 / d.window_s))
    return {"decay": d, "drop": drop, "at": at, "sdrop": sdrop, "sat": sat,
            "at2": (d.band_db[i2] - d.band_db[1]) if i2 < len(d.t_s) else float("nan"),
            "t40": float(d.t_s[below[0]]) if len(below) else float("nan")}


def plot(out, preset, overrides, before, key, velocity, seconds, band, fs_internal=None):
    """Two spectrograms of one note (0-12 kHz, Hann 45 ms, the same colour
    scale), with ``before`` added to the overrides and without, and the
    band's level per window under them; a small PNG at ``out``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from synth.analysis.buzz import band_decay
    from synth.analysis.spectrum import spectrogram

    runs = [("before: " + " ".join(before), list(overrides) + list(before)),
            ("after: the shipped preset" + (" " + " ".join(overrides) if overrides else ""),
             list(overrides))]
    res = []
    for title, ov in runs:
        y, fs = render(preset, ov, key, velocity, seconds, fs_internal)
        y = y.mean(axis=1) if y.ndim == 2 else y
        res.append((title, spectrogram(y, fs), band_decay(y, fs, band[0], band[1])))
    top = max(float(np.max(r[1][2])) for r in res)
    fig = plt.figure(figsize=(8.0, 4.2))
    gs = fig.add_gridspec(2, 2, height_ratios=[2.2, 1.0])
    for j, (title, (t, f, L), _) in enumerate(res):
        ax = fig.add_subplot(gs[0, j])
        sel = f <= 12000.0
        ax.pcolormesh(t, f[sel] / 1000.0, L[sel] - top, vmin=-90, vmax=0, cmap="magma",
                      shading="nearest", rasterized=True)
        ax.set_title(title, fontsize=8)
        ax.tick_params(labelsize=7)
        ax.set_ylabel("kHz", fontsize=7)
    ax = fig.add_subplot(gs[1, :])
    for (title, _, d), st in zip(res, ("--", "-")):
        ax.plot(d.t_s + 0.5 * d.window_s, d.band_db - res[1][2].band_db[1], st, lw=1.2,
                label=title.split(":")[0])
    ax.plot(res[1][2].t_s + 0.05, res[1][2].note_db - res[1][2].note_db[1], ":", lw=1.0,
            color="grey", label="whole note (after)")
    ax.set_ylim(-100, 15)
    ax.set_xlabel("s", fontsize=7)
    ax.set_ylabel(f"dB, {band[0] / 1000:g}-{band[1] / 1000:g} kHz", fontsize=7)
    ax.tick_params(labelsize=7)
    ax.legend(fontsize=7, loc="lower left")
    ax.grid(alpha=0.3)
    fig.suptitle(f"{preset}, key {key}, velocity {velocity}: spectrogram (dB re the loudest bin, "
                 f"0 to -90) and the band per 100 ms window", fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=72)
    plt.close(fig)
    try:                        # a 64-colour palette: a third of the bytes, the same picture
        from PIL import Image

        Image.open(out).convert("RGB").quantize(colors=64).save(out, optimize=True)
    except ImportError:
        pass
    print(f"wrote {out}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--preset", default="sitar")
    ap.add_argument("--set", action="append", default=[], metavar="PATH=VALUE")
    ap.add_argument("--keys", default="43,49,55,61,67,74")
    ap.add_argument("--velocities", default="40,80,127")
    ap.add_argument("--seconds", type=float, default=5.0)
    ap.add_argument("--band", default="6000,20000", help="f_lo,f_hi in Hz")
    ap.add_argument("--within", type=float, default=40.0)
    ap.add_argument("--rows", default=None, metavar="K,V")
    ap.add_argument("--internal-rate", type=float, default=None,
                    help="internal rate, Hz (default: the preset's, 325 kHz)")
    ap.add_argument("--plot", default=None, metavar="OUT.png",
                    help="only draw the first key and velocity's spectrogram with --before "
                         "added and without (needs matplotlib)")
    ap.add_argument("--before", action="append", default=[], metavar="PATH=VALUE",
                    help="the overrides of --plot's 'before' panel (repeatable)")
    a = ap.parse_args(argv)
    keys = [int(k) for k in a.keys.split(",")]
    vels = [int(v) for v in a.velocities.split(",")]
    band = tuple(float(f) for f in a.band.split(","))
    if a.plot:
        plot(a.plot, a.preset, a.set, a.before, keys[0], vels[0], a.seconds, band,
             a.internal_rate)
        return 0
    print(f"preset {a.preset}, overrides: {' '.join(a.set) or '(none)'}"
          + (f", internal rate {a.internal_rate:g} Hz" if a.internal_rate else "")
          + f"; band {band[0]:g}-{band[1]:g} Hz, "
          f"100 ms windows; drop: largest window-to-window fall (dB) while the note is within "
          f"{a.within:g} dB of its start")
    print("key " + "".join(f"| v{v:<3d} drop   at  drop3   at  band@2s  40dB " for v in vels))
    worst = (0.0, None)
    worst3 = (0.0, None)
    res = {}
    for k in keys:
        row = f"{k:3d} "
        for v in vels:
            m = measure(a.preset, a.set, k, v, a.seconds, band, a.within, a.internal_rate)
            res[(k, v)] = m
            row += (f"| {m['drop']:8.1f} {m['at']:5.1f} {m['sdrop']:5.1f} {m['sat']:5.1f} "
                    f"{m['at2']:7.1f} {m['t40']:5.1f} ")
            if m["drop"] > worst[0]:
                worst = (m["drop"], (k, v))
            if m["sdrop"] > worst3[0]:
                worst3 = (m["sdrop"], (k, v))
        print(row, flush=True)
    if worst[1] is not None:
        print(f"worst drop: {worst[0]:.1f} dB (key {worst[1][0]}, v{worst[1][1]})")
    if worst3[1] is not None:
        print(f"worst drop of the band's 300 ms running mean (drop3): {worst3[0]:.1f} dB "
              f"(key {worst3[1][0]}, v{worst3[1][1]})")
    if a.rows:
        k, v = (int(x) for x in a.rows.split(","))
        m = res.get((k, v)) or measure(a.preset, a.set, k, v, a.seconds, band, a.within,
                                       a.internal_rate)
        d = m["decay"]
        print(f"key {k} v{v}: t (s), band (dB re window 0.1 s), note (dB re window 0)")
        for i, t in enumerate(d.t_s):
            print(f"{t:5.1f} {d.band_db[i] - d.band_db[1]:8.1f} {d.note_db[i] - d.note_db[0]:7.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
