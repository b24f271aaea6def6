"""How hard the output limiter works on a MIDI file.

Usage
-----
    python tools/limiter_report.py FILE.mid [--preset grand-piano] [--seconds 60]

Renders the first ``--seconds`` of the file with the preset as shipped
(its ``[output] limiter``) and with ``output.limiter=off``; both renders are
aligned (offline renders remove the limiter's latency), so the ratio of
their per-sample peaks (over the channels) is the limiter's gain.  Prints
the peaks with and without it, how often the gain is reduced by more than
0.1 dB and 1 dB, the largest reduction and the integrated loudness of both.
"""

from __future__ import annotations

import argparse
import time

import numpy as np


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("midi")
    ap.add_argument("--preset", default="grand-piano")
    ap.add_argument("--seconds", type=float, default=60.0)
    a = ap.parse_args(argv)
    from synth.analysis.loudness import loudness
    from synth.io.factory import build_engine
    from synth.io.midi import midi_to_events, read_midi_file

    ev = [e for e in midi_to_events(read_midi_file(a.midi)) if e.time_s < a.seconds]
    out = {}
    for tag, sets in (("on", []), ("off", ["output.limiter=off"])):
        t = time.perf_counter()
        y = build_engine(a.preset, sets).render(ev, duration_s=a.seconds)
        out[tag] = y if y.ndim == 2 else y[:, None]
        print(f"limiter {tag}: rendered in {time.perf_counter() - t:.0f} s", flush=True)
    on, off = np.abs(out["on"]).max(axis=1), np.abs(out["off"]).max(axis=1)
    sel = off > 1e-3
    g = np.ones_like(off)
    g[sel] = np.minimum(on[sel] / off[sel], 1.0)
    red = -20 * np.log10(np.maximum(g, 1e-9))
    print(f"peak without the limiter {20 * np.log10(off.max()):+.2f} dBFS, "
          f"with it {20 * np.log10(on.max()):+.2f} dBFS")
    print(f"gain reduced by > 0.1 dB {100 * np.mean(red > 0.1):.2f} % of the time, "
          f"> 1 dB {100 * np.mean(red > 1):.3f} %, at most {red.max():.2f} dB")
    lu = [loudness(out[k].mean(axis=1), 48000)["integrated_lufs"] for k in ("on", "off")]
    print(f"integrated loudness {lu[0]:.1f} LUFS with, {lu[1]:.1f} without")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
