"""Quality levels (issue 13): each level's error and cost, on notes and on music.

Usage
-----
    python tools/quality_levels.py notes [--repeats 3]       # the levels' errors (docs/quality.md)
    python tools/quality_levels.py files [--seconds 60]      # speed-ups on the piano files and folk tunes
    python tools/quality_levels.py notes --quick              # CI: one preset, one key

``notes``: for every musical preset, a low, a middle and a high key of its
range (velocity 80, 1.05 s) rendered at each level
(:mod:`synth.voices.quality`) and at the converged setting (1.3 MHz with
0.5-cent stiffness filters: the finest of docs/work-precision.md).
Partials 1..16 (under 10 kHz, within 40 dB of the strongest of the
converged note) over 0.05-1.05 s (:func:`synth.analysis.track_partials`):
the worst frequency error (cents) and level error (dB) of each level
against the converged note, and its run time (median of ``--repeats``)
over ``standard``'s.  Each preset's worst over its keys is what its
``[quality_error]`` table states (the preset's data); every musical preset
is measured (:func:`synth.apps.levels.musical_presets`).

``files``: the five piano files of ``../shared/midi`` on ``grand-piano``
and the three folk tunes on ``sitar`` and ``biwa`` (the first
``--seconds`` of each), rendered at each level as ``synth render --quality``
does: the run time, the speed-up over ``standard``, and how the music
differs from the ``reference`` render: integrated loudness (LU) and the
worst third-octave band level from 50 Hz to 16 kHz (dB).

Run with ``NUMBA_NUM_THREADS=1``; the machine is noisy: times are medians
(notes) or single renders (files, minutes each).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from synth.apps.work_precision import note_partials, partial_errors

from synth.apps.levels import musical_presets  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
LEVELS = ("draft", "standard", "reference")
CONVERGED_HZ = 1_300_000.0
PIANO_FILES = ("chpn_op25_e11.mid", "deb_clai.mid", "rac_op23_5.mid", "hp956bx4547_exp.mid",
               "kw569bw0899_exp.mid")
FOLK_FILES = ("ButchersMarchiiThe.mid", "HerGoldenHairWasCurlingDown.mid", "PatWardsslide.mid")


def shared_midi() -> Path:
    for d in (ROOT.parent / "shared" / "midi", Path("/work/shared/midi")):
        if d.is_dir():
            return d
    raise SystemExit("../shared/midi: not found (the workplace's MIDI files)")


def _b_of(preset, key: int) -> float:
    """The inharmonicity the partial tracker follows for ``key``."""
    if preset.voice in ("grand", "harpsichord"):
        from synth.physics import piano as PI

        return float(PI.grand_string(key).inharmonicity_b)
    return float(getattr(preset.string, "inharmonicity", 0.0) or 0.0)


def _render_note(name, key, overrides, fs_internal):
    from synth.analysis.spectrum import as_mono
    from synth.engine.engine import Event
    from synth.io.factory import build_engine

    # drone=False: a drone preset's key plucks its one string (the tanpura's
    # key otherwise starts its four-string cycle, and the partials tracked
    # were a drone's: key 39's standard level read 14.7-19.8 cents from the
    # converged "note")
    e = build_engine(name, overrides, fs_internal=fs_internal, drone=False)
    t0 = time.perf_counter()
    y = e.render([Event(0.0, "note_on", key, 80 / 127)], duration_s=1.05)
    return as_mono(y), e.fs_out, e.inst.pitch_hz(key), time.perf_counter() - t0


def note_errors(name: str, keys, repeats: int) -> list[dict]:
    """Rows (preset, key, level, partials, cents, db, time_s) for ``name``."""
    from synth.io.presets import load_preset

    preset = load_preset(name)
    rows = []
    for key in keys:
        B = _b_of(preset, key)
        res = {}
        settings = [(lv, [f"play.quality={lv}"], None) for lv in LEVELS]
        settings.append(("converged", ["play.quality=reference"], CONVERGED_HZ))
        for label, ov, fs in settings:
            times = []
            for _ in range(repeats if label != "converged" else 1):
                y, fo, f1, tm = _render_note(name, key, ov, fs)
                times.append(tm)
            res[label] = (*note_partials(y, fo, f1, B), float(np.median(times)))
        fr, lr, _ = res["converged"]
        for label in LEVELS:
            f, lv, tm = res[label]
            n, cents, db = partial_errors(f, lv, fr, lr)
            rows.append(dict(preset=name, key=key, level=label, partials=n,
                             cents=cents, db=db, time_s=tm))
    return rows


def _keys_of(name):
    from synth.io.presets import load_preset

    p = load_preset(name).play
    lo, hi = p.key_low, p.key_high
    return (lo + 2, (lo + hi) // 2, hi - 2)


def cmd_notes(a) -> int:
    names = ("sitar",) if a.quick else tuple(musical_presets())
    print("| preset | key | level | partials | worst cents | worst dB | time (s) | x standard |")
    print("|---|---:|---|---:|---:|---:|---:|---:|")
    worst = {lv: [0.0, 0.0, []] for lv in LEVELS}
    for name in names:
        keys = (60,) if a.quick else _keys_of(name)
        rows = note_errors(name, keys, 1 if a.quick else a.repeats)
        std = {r["key"]: r["time_s"] for r in rows if r["level"] == "standard"}
        for r in rows:
            ratio = r["time_s"] / std[r["key"]]
            print(f"| {r['preset']} | {r['key']} | {r['level']} | {r['partials']} | "
                  f"{r['cents']:.3f} | {r['db']:.2f} | {r['time_s']:.3f} | {ratio:.2f} |",
                  flush=True)
            w = worst[r["level"]]
            w[0] = max(w[0], r["cents"])
            w[1] = max(w[1], r["db"])
            w[2].append(ratio)
    print("\n| level | worst cents | worst dB | cost x standard (median) |")
    print("|---|---:|---:|---:|")
    for lv in LEVELS:
        w = worst[lv]
        print(f"| {lv} | {w[0]:.3f} | {w[1]:.2f} | {np.median(w[2]):.2f} |")
    return 0


def _third_octaves(x, fs):
    from synth.analysis.bands import band_levels_db

    centres = 1000.0 * 2.0 ** (np.arange(-13, 13) / 3.0)          # 50 Hz .. 16 kHz
    centres = centres[(centres >= 50) & (centres <= 16_000)]
    return band_levels_db(x, fs, centres, centres * (2 ** (1 / 6) - 1))


def cmd_files(a) -> int:
    import soundfile as sf

    from synth.analysis.loudness import loudness
    from synth.analysis.spectrum import as_mono
    from synth.apps.render import RenderRequest, render_midi

    d = shared_midi()
    jobs = [(f, "grand-piano") for f in PIANO_FILES]
    jobs += [(f, p) for f in FOLK_FILES for p in ("sitar", "biwa")]
    if a.quick:
        jobs = jobs[:1]
    print(f"first {a.seconds:g} s of each; differences against the reference render\n")
    print("| file | preset | level | render (s) | x real time | speed-up over standard | "
          "loudness diff (LU) | worst third-octave diff (dB) |")
    print("|---|---|---|---:|---:|---:|---:|---:|")
    tot = {lv: 0.0 for lv in LEVELS}
    with tempfile.TemporaryDirectory() as tmp:
        for f, preset in jobs:
            res = {}
            for lv in LEVELS:
                out = os.path.join(tmp, f"{lv}.wav")
                r = render_midi(RenderRequest(midi_file=str(d / f), preset=preset, output=out,
                                              overrides=(f"play.quality={lv}",),
                                              max_seconds=a.seconds))
                y, fs = sf.read(out)
                y = as_mono(y)
                res[lv] = (r.elapsed_s, r.seconds, loudness(y, fs)["integrated_lufs"],
                           _third_octaves(y, fs))
                tot[lv] += r.elapsed_s
            ref = res["reference"]
            for lv in LEVELS:
                el, sec, lu, bands = res[lv]
                ok = np.isfinite(bands) & np.isfinite(ref[3]) & (ref[3] > ref[3].max() - 60)
                print(f"| {f} | {preset} | {lv} | {el:.1f} | {el / sec:.3f} | "
                      f"{res['standard'][0] / el:.2f} | {lu - ref[2]:+.2f} | "
                      f"{np.max(np.abs(bands[ok] - ref[3][ok])):.2f} |", flush=True)
    print("\n| level | total render (s) | speed-up over standard |")
    print("|---|---:|---:|")
    for lv in LEVELS:
        print(f"| {lv} | {tot[lv]:.1f} | {tot['standard'] / tot[lv]:.2f} |")
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="what", required=True)
    n = sub.add_parser("notes", help="each level's error against the converged notes")
    n.add_argument("--repeats", type=int, default=3)
    n.add_argument("--quick", action="store_true", help="one preset, one key (CI)")
    n.set_defaults(func=cmd_notes)
    f = sub.add_parser("files", help="speed-ups on the piano files and folk tunes")
    f.add_argument("--seconds", type=float, default=60.0)
    f.add_argument("--quick", action="store_true", help="one file (CI)")
    f.set_defaults(func=cmd_files)
    a = ap.parse_args(argv)
    if getattr(a, "repeats", 1) < 1:
        raise SystemExit(f"--repeats = {a.repeats} is out of range (value >= 1)")
    if not (0.5 <= getattr(a, "seconds", 1.0) <= 21600):
        raise SystemExit(f"--seconds = {a.seconds} is out of range (0.5 <= value <= 21600)")
    return a.func(a)


if __name__ == "__main__":
    sys.exit(main())
