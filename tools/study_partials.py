"""Two studies behind docs/voicing.md's "misses that remain" (issue 11).

    python tools/study_partials.py decay --real node_modules/@audio-samples [--keys 48,51,...]
    python tools/study_partials.py una-corda [--keys 78,81,...] [--set PATH=VALUE ...]

``decay``: the early T60 of partials 1-8 of each key, on a real grand's
samples (the folder of ``tools/real_grand.py``, layer v10) and on the
``grand-piano`` preset at velocity 80, with the model's prompt T60 (the
bridge's loss on top of the string's own, ``synth.physics.piano``) beside
them.  Early T60: a least-squares line through the partial's peak level
(``synth.analysis.track_partials``) in 0.2 s frames every 0.05 s whose
centres lie in 0.15-1.2 s; 99 where the line does not fall.  Then C4's
partials 1-10 over 0.05-0.35 s and 0.05-1.05 s re the strongest, as peak
levels (the voicing report's measure) and as band levels (the power within
0.45 f0 of each partial: a unison's partial splits into its strings' peaks
in a one-second window, which a peak level reads low).

``una-corda``: the voicing report's una corda measure (the centroid of the
first 100 ms, CC67 down against up, velocity 80) on any keys, with the
attack's centroid in units of f0 and the loudness change.

Exit 0 after printing; 2 with a one-line error on stderr.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from voicing_report import FS, Renderer, attack_centroid_hz, max_momentary  # noqa: E402

from synth.analysis import estimate_f0, track_partials  # noqa: E402
from synth.physics.piano import et_f0_hz, grand_string  # noqa: E402

N_PARTIALS = 8
_NAMES = {0: "C", 3: "D#", 6: "F#", 9: "A"}


def _f0_law(y, key):
    g = grand_string(key)
    B = g.inharmonicity_b
    f1 = estimate_f0(y[int(0.05 * FS):int(1.05 * FS)], FS, g.partial_hz(1), search_cents=60.0)
    return f1 / math.sqrt(1.0 + B), B


def early_t60_s(y, key, hi_s=1.2, hop_s=0.05, win_s=0.2):
    """Early T60 (s) of partials 1..8 of ``y`` (48 kHz, note-on at 0)."""
    f0, B = _f0_law(y, key)
    ts, levels = [], []
    t = 0.05
    while t + win_s <= hi_s + win_s / 2:
        seg = y[int(t * FS):int((t + win_s) * FS)]
        _, lv, _ = track_partials(seg, FS, f0, N_PARTIALS, inharmonicity=B)
        ts.append(t + win_s / 2)
        levels.append(lv)
        t += hop_s
    ts, levels = np.array(ts), np.array(levels)
    out = []
    for k in range(N_PARTIALS):
        slope = np.polyfit(ts, levels[:, k], 1)[0]
        out.append(-60.0 / slope if slope < -1e-3 else 99.0)
    return np.array(out)


def partial_levels_db(y, key, t0, t1, n=10):
    """(peak levels, band levels) of partials 1..n over t0..t1 s, dB re
    the strongest of each."""
    f0, B = _f0_law(y, key)
    seg = y[int(t0 * FS):int(t1 * FS)]
    _, peak, _ = track_partials(seg, FS, f0, n, inharmonicity=B)
    P = np.abs(np.fft.rfft(seg * np.hanning(len(seg)))) ** 2
    fr = np.fft.rfftfreq(len(seg), 1.0 / FS)
    band = np.array([10 * np.log10(P[np.abs(fr - j * f0 * math.sqrt(1 + B * j * j)) < 0.45 * f0].sum()
                                   + 1e-300) for j in range(1, n + 1)])
    return peak - np.nanmax(peak), band - band.max()


def _load_real(folder: Path, key: int):
    from real_grand import load

    name = f"{_NAMES[key % 12]}{key // 12 - 1}v10.ogg"
    p = next(folder.rglob(name), None)
    if p is None:
        raise SystemExit(f"study_partials: error: no sample {name} under {folder}")
    return load(p)


def _row(label, values, fmt="{:5.1f}"):
    return f"| {label} | " + " | ".join(fmt.format(v) for v in values) + " |"


def decay(args) -> None:
    folder = Path(args.real)
    if not folder.is_dir():
        raise SystemExit(f"study_partials: error: --real {folder} is not a folder")
    r = Renderer("grand-piano", tuple(args.set))
    ln = math.log(1000.0)
    print("Early T60 (s) of partials 1-8, 0.1-1.2 s (99: the level does not fall)\n")
    print("| key | source | " + " | ".join(str(j) for j in range(1, N_PARTIALS + 1)) + " |")
    print("|---|---|" + "---|" * N_PARTIALS)
    for key in args.keys:
        if key % 12 not in _NAMES:
            raise SystemExit(f"study_partials: error: key {key} has no real sample (every minor third from A0)")
        g = grand_string(key)
        law = np.array([g.t60_s(g.partial_hz(j)) for j in range(1, N_PARTIALS + 1)])
        sig_b = ln / g.t60_prompt_s - ln / g.t60_low_s
        prompt = ln / (ln / law + sig_b)
        print(_row(f"{key} | real v10", early_t60_s(_load_real(folder, key), key)))
        print(_row(f"{key} | model", early_t60_s(r.note(key, 80, 1.5), key)))
        print(_row(f"{key} | model's prompt T60", prompt))
    print("\nC4: partials 1-10 re the strongest, dB (peak / band)\n")
    for label, y in (("real v10", _load_real(folder, 60)), ("model", r.note(60, 80, 1.5))):
        for t0, t1 in ((0.05, 0.35), (0.05, 1.05)):
            pk, bd = partial_levels_db(y, 60, t0, t1)
            print(_row(f"{label}, {t0}-{t1} s, peak", pk))
            print(_row(f"{label}, {t0}-{t1} s, band", bd))


def una_corda(args) -> None:
    r = Renderer("grand-piano", tuple(args.set))
    print("| key | centroid change | centroid / f0, pedal up -> down | loudness change, dB |")
    print("|---|---|---|---|")
    for key in args.keys:
        a = r.note(key, 80, 0.3)
        b = r.note(key, 80, 0.3, soft=True)
        ca, cb = attack_centroid_hz(a), attack_centroid_hz(b)
        f0 = et_f0_hz(key)
        print(f"| {key} | {100 * (cb / ca - 1):+.1f} % | {ca / f0:.2f} -> {cb / f0:.2f} | "
              f"{max_momentary(b) - max_momentary(a):+.1f} |")


def _keys(text: str) -> list:
    try:
        keys = [int(k) for k in text.split(",") if k.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"--keys {text!r}: comma-separated MIDI keys 21-108") from None
    if not keys or any(not 21 <= k <= 108 for k in keys):
        raise argparse.ArgumentTypeError(f"--keys {text!r}: comma-separated MIDI keys 21-108")
    return keys


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="study", required=True)
    d = sub.add_parser("decay", help="early T60 of partials 1-8, real grand and model")
    d.add_argument("--real", required=True, help="the folder of tools/real_grand.py's samples")
    d.add_argument("--keys", type=_keys, default=_keys("48,51,54,57,60,63,66,69,72"))
    d.add_argument("--set", action="append", default=[], metavar="PATH=VALUE")
    u = sub.add_parser("una-corda", help="the una corda's centroid change on any keys")
    u.add_argument("--keys", type=_keys, default=_keys("78,81,84,87,90,92,94,96,98,100,104"))
    u.add_argument("--set", action="append", default=[], metavar="PATH=VALUE")
    args = ap.parse_args(argv)
    try:
        decay(args) if args.study == "decay" else una_corda(args)
    except SystemExit as e:
        if isinstance(e.code, str):
            print(e.code, file=sys.stderr)
            return 2
        raise
    except (ValueError, OSError) as e:
        print(f"study_partials: error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
