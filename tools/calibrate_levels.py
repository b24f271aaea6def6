"""Set every musical preset's output gain from a measurement: its reference phrase at -20 LUFS.

Usage
-----
    python tools/calibrate_levels.py            # measure, write the gains and the phrases
    python tools/calibrate_levels.py --dry-run  # measure and report only
    python tools/calibrate_levels.py --limiter FILE.mid [PRESET] [--seconds 60]
                                                # how hard the output limiter works on a file

Issue 12: switching presets must not jump in level, so every shipped musical
preset renders its reference phrase at -20 +- 2 LUFS integrated (BS.1770,
pyloudnorm), velocity 100.  The gain is not set by hand: this tool

1. writes each preset's reference phrase as a MIDI file,
   ``synth/presets/checks/phrases/<preset>.mid`` (:func:`phrase_events`: a
   melody of 12 notes over the middle of the preset's range, and for the
   keyboards a left-hand dyad under every group of four; all at velocity
   100; 5.7 s with the last note's ring);
2. renders it with the preset as shipped and measures its integrated
   loudness L;
3. scales ``[output] gain`` by 10^((-20 - L) / 20) in the preset file (the
   output is linear in the gain: the strings' physics does not see it; the
   sympathetic strings and the taraf are driven by the force, gain / gain)
   and renders again to confirm.

The shipped check specs (``synth/presets/checks/<preset>.toml``) render the
same phrase and hold it within 2 LU of -20 LUFS in CI.

``--limiter FILE.mid`` renders the first ``--seconds`` of the file with the
preset (default grand-piano) as shipped (its ``[output] limiter``) and with
``output.limiter=off``; both renders are aligned (offline renders remove the
limiter's latency), so the ratio of their per-sample peaks (over the
channels) is the limiter's gain.  It prints the peaks with and without it,
how often the gain is reduced by more than 0.1 dB and 1 dB, the largest
reduction and the integrated loudness of both.
"""

from __future__ import annotations

import argparse
import math
import re
import sys
from pathlib import Path

from synth.apps.levels import (  # the phrases (tests/test_levels.py tests them there)
    PHRASE_SECONDS,
    TARGET_LUFS,
    musical_presets,
    phrase_events,
    write_midi,
)

ROOT = Path(__file__).resolve().parents[1]
PRESETS = ROOT / "synth" / "presets"
PHRASES = PRESETS / "checks" / "phrases"


def phrase_lufs(name: str, midi: Path) -> float:
    """Integrated loudness (LUFS) of ``midi`` rendered with preset ``name``."""
    from synth.analysis.loudness import loudness
    from synth.analysis.spectrum import as_mono
    from synth.io.factory import build_engine
    from synth.io.midi import midi_to_events, read_midi_file

    events = midi_to_events(read_midi_file(str(midi)))
    keys = [int(e.key) for e in events if e.kind == "note_on" and e.value > 0]
    eng = build_engine(name, extra_low_key=min(keys))
    y = as_mono(eng.render(events, duration_s=PHRASE_SECONDS, tail_s=0.5))
    return float(loudness(y, eng.fs_out)["integrated_lufs"])

_GAIN = re.compile(r"^(gain\s*=\s*)([0-9.eE+-]+)(.*)$", re.M)


def set_gain(path: Path, gain: float, lufs_before: float) -> None:
    """Rewrite ``gain`` in the [output] table of ``path``, with a comment
    saying where it came from."""
    text = path.read_text("utf-8")
    head, sep, rest = text.partition("[output]")
    if not sep:
        raise SystemExit(f"{path}: no [output] table")
    m = _GAIN.search(rest)
    if m is None:
        raise SystemExit(f"{path}: no gain in [output]")
    new = (f"{m.group(1)}{gain:.4g}"
           f"  # tools/calibrate_levels.py: reference phrase at -20 LUFS (was {lufs_before:+.1f} dB off)")
    path.write_text(head + sep + rest[:m.start()] + new + rest[m.end():], "utf-8")


def limiter_report(midi: str, preset: str, seconds: float) -> None:
    """How hard ``preset``'s output limiter works on the first ``seconds``
    of ``midi`` (see the module's notes)."""
    import time

    import numpy as np

    from synth.analysis.loudness import loudness
    from synth.io.factory import build_engine
    from synth.io.midi import midi_to_events, read_midi_file

    ev = [e for e in midi_to_events(read_midi_file(midi)) if e.time_s < seconds]
    out = {}
    for tag, sets in (("on", []), ("off", ["output.limiter=off"])):
        t = time.perf_counter()
        eng = build_engine(preset, sets)
        y = eng.render(ev, duration_s=seconds)
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
    lu = [loudness(out[k].mean(axis=1), eng.fs_out)["integrated_lufs"] for k in ("on", "off")]
    print(f"integrated loudness {lu[0]:.1f} LUFS with, {lu[1]:.1f} without")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--dry-run", action="store_true", help="measure and report; write nothing")
    ap.add_argument("--limiter", metavar="FILE.mid",
                    help="instead: how hard the output limiter works on this MIDI file "
                         "(one preset, default grand-piano)")
    ap.add_argument("--seconds", type=float, default=60.0,
                    help="--limiter: the file's first seconds to render (default 60)")
    ap.add_argument("presets", nargs="*", help="preset names (default: every shipped musical one)")
    a = ap.parse_args(argv)
    from synth.io.presets import load_preset

    if a.limiter is not None:
        if len(a.presets) > 1:
            ap.error(f"--limiter takes one preset, not {len(a.presets)}")
        if not 0 < a.seconds <= 3600:
            ap.error(f"--seconds = {a.seconds} is out of range (0 < value <= 3600)")
        limiter_report(a.limiter, (a.presets or ["grand-piano"])[0], a.seconds)
        return 0

    names = a.presets or musical_presets(PRESETS)
    for name in names:
        p = load_preset(name)
        midi = PHRASES / f"{name}.mid"
        if not a.dry_run:
            write_midi(phrase_events(p), midi)
        elif not midi.is_file():
            import tempfile

            midi = Path(tempfile.mkdtemp()) / f"{name}.mid"
            write_midi(phrase_events(p), midi)
        L = phrase_lufs(name, midi)
        off = L - TARGET_LUFS
        gain = p.output.gain * 10.0 ** (-off / 20.0)
        line = f"{name:16s} {L:+7.2f} LUFS at gain {p.output.gain:.4g}"
        if a.dry_run:
            print(f"{line}; -20 LUFS at gain {gain:.4g}")
            continue
        if abs(off) > 0.05:
            set_gain(PRESETS / f"{name}.toml", gain, off)
        L2 = phrase_lufs(name, midi)
        print(f"{line} -> {L2:+7.2f} LUFS at gain {gain:.4g}")
        if not math.isfinite(L2) or abs(L2 - TARGET_LUFS) > 0.5:
            print(f"{name}: the phrase reads {L2:+.2f} LUFS after the change", file=sys.stderr)
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
