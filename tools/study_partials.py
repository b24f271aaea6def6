"""Studies behind the grand's fit to a recorded grand (issue 11; docs/voicing.md, "Fitted to
a recorded grand"; their history: docs/lab/2026-11-voicing-notebook.md, "The misses that
remain, and what was tried").

    python tools/study_partials.py decay --real node_modules/@audio-samples [--keys 48,51,...]
    python tools/study_partials.py ratios --real node_modules/@audio-samples
    python tools/study_partials.py una-corda [--keys 78,81,...] [--set PATH=VALUE ...]
    python tools/study_partials.py damping --real node_modules/@audio-samples [--set ...]
    python tools/study_partials.py beats --real node_modules/@audio-samples [--scales 1,0.6] [--keys ...]
    python tools/study_partials.py tail --real node_modules/@audio-samples [--scales 1,3] [--keys ...]
    python tools/study_partials.py thump --real node_modules/@audio-samples [--keys ...] [--set ...]

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

``ratios``: the prompt ratio a real grand implies, key by key (every
minor third): ``synth.physics.piano``'s reference T60 at f0
(``t60_prompt_reference_s``, the law the prompt ratios divide; the strings'
own T60 until 2026-11-27) over the recording's early T60 of partial 1, the median of layers v4, v10 and v14,
and the running median of five keys (the smoothed curve
``synth.physics.piano.TRICHORD_PROMPT_ANCHORS`` follows), beside the
model's own ratio.

``damping``: the strings' loss at 3-8 kHz against a real grand's: the
early T60 (as ``decay``) of every partial of keys 63-99 (every minor
third) that lies at 3-8 kHz and, in the recording's first 0.05-0.35 s,
within 50 dB of its strongest partial (above the recording's floor), on
the recording (layer v10) and on the model at velocity 80, and the
median and quartiles of model / real over them: the check on
``synth.physics.piano.DAMPING_B3_S``.

``beats``: how much a unison's partials beat, against a real grand's:
each partial's level (0.1 s frames every 0.025 s, 0.1-3 s) about the best
two-segment line through it (a knee anywhere, so a two-stage decay is not
counted), as an RMS in dB, the median over partials 2-8 (those starting
within 40 dB of the strongest); on the recording (the median of layers v4,
v10 and v14) and on the model at velocity 80 with ``strings.detune_scale``
at each of ``--scales``; then, per scale, the median and the mean absolute
difference model - real over the keys: the check on
``synth.physics.piano.UNISON_SPREAD_CENTS``.

``tail``: how long and how loud a note's aftersound is, against a real
grand's: the note's level (50 ms frames, dB re its loudest) over
2.5-9 s (or to 1.5 s before the recording ends: its samples fade out),
a line through it, as a T60, and the median level over 2.5-4 s; on the
recording (layers v4, v10, v14) and on the model at velocity 80 with
``strings.t60_scale`` at each of ``--scales`` (a factor on the strings' own
T60, the bridge's loss unchanged).  ``--png F`` draws the level curves of
keys 39 and 60 (0.1 s frames, 12 s) on the recording and the model, and
those of ``--before-json J``, written by ``--curves-json J`` on an earlier
version (``PYTHONPATH=<its checkout>``: this tool runs on packages from
before the reference law).

``thump``: how loud the low thump under a note's attack is (the key on
the keybed, the action and the case: ``action.knock``), against a real
grand's: the power over the first 100 ms (Hann window, mean removed) in
20 Hz to 1 kHz or f0 / 2, whichever is lower (below the note's own
partials), in dB re the power of C4's partial 1 (within 0.3 f0 of 261.6
Hz) over the same window in the same layer, so a key's thump is read on
the keyboard's common scale, not on its own tone; on the recording
(layers v4, v10, v14) and on the model at velocities 40, 80, 110, and at
80 with ``action.knock = 0`` (what the strings and the board give without
it); then the median gap real - model at each pair and the knock that
closes the median at velocity 80 (the thump is linear in ``action.knock``
once the knock carries the band).  Keys 48-105 by default: below C3 the
band (20 Hz to f0 / 2, 46 Hz at F#2) lies under the board's lowest mode
(50 Hz), where the model's board carries nothing to compare.  Then, on
the keys whose f0 / 2 lies above 1 kHz, the thump's spectrum: its power
per Hz in 20-90, 360-720 and 720-1000 Hz re 90-360 Hz, the recording (the
mean of its layers) and the model at velocity 80 (``action.knock_s``, the
pulse's duration, sets how high it reaches).

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

from synth.analysis import attack_centroid_hz, max_momentary_lufs
from synth.apps.voicing import FS, Renderer
from synth.apps.grand_study import (  # noqa: E402
    load_recording,
    BEAT_SPAN_S,
    DAMPING_BAND_HZ,
    DAMPING_FLOOR_DB,
    N_PARTIALS,
    TAIL_LEVEL_S,
    TAIL_SPAN_S,
    THUMP_BANDS_HZ,
    beat_roughness_db,
    damping_rows,
    early_t60_s,
    level_curve_db,
    partial_levels_db,
    ratio_summary,
    tail_t60_and_level,
    thump_db,
    thump_spectrum_db,
)
from synth.physics.piano import et_f0_hz, grand_string, prompt_ratio  # noqa: E402

_NAMES = {0: "C", 3: "D#", 6: "F#", 9: "A"}


#: the recording's layers and the model's velocities read against each other
THUMP_PAIRS = ((4, 40), (10, 80), (14, 110))


def _real_folder(args, keys=()) -> Path:
    """``--real`` as a folder, with a sample for every key of ``keys``
    (the recording has one every minor third from A0); else exit 2."""
    folder = Path(args.real)
    if not folder.is_dir():
        raise SystemExit(f"study_partials: error: --real {folder} is not a folder")
    for key in keys:
        if key % 12 not in _NAMES:
            raise SystemExit(f"study_partials: error: key {key} has no real sample (every minor third from A0)")
    return folder


def _load_real(folder: Path, key: int, layer: int = 10):
    name = f"{_NAMES[key % 12]}{key // 12 - 1}v{layer}.ogg"
    p = next(folder.rglob(name), None)
    if p is None:
        raise SystemExit(f"study_partials: error: no sample {name} under {folder}")
    return load_recording(p)


def _scaled_renderers(args, path: str) -> list:
    """(scale, Renderer) for each of ``--scales``, the preset with ``--set``
    and ``path`` at that scale."""
    return [(sc, Renderer("grand-piano", tuple(args.set) + (f"{path}={sc:g}",))) for sc in args.scales]


def _row(label, values, fmt="{:5.1f}"):
    return f"| {label} | " + " | ".join(fmt.format(v) for v in values) + " |"


def decay(args) -> None:
    folder = _real_folder(args, args.keys)
    r = Renderer("grand-piano", tuple(args.set))
    ln = math.log(1000.0)
    print("Early T60 (s) of partials 1-8, 0.1-1.2 s (99: the level does not fall)\n")
    print("| key | source | " + " | ".join(str(j) for j in range(1, N_PARTIALS + 1)) + " |")
    print("|---|---|" + "---|" * N_PARTIALS)
    for key in args.keys:
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


def _reference_t60_s(key):
    # imported here: the ``tail`` study also runs against older packages
    # (PYTHONPATH), which have no reference law
    from synth.physics.piano import t60_prompt_reference_s

    return t60_prompt_reference_s(grand_string(key).f0_hz)


def implied_ratios(folder: Path, keys, layers=(4, 10, 14)):
    """{key: (early T60 of partial 1 per layer (s), their median, the
    reference T60 (:func:`synth.physics.piano.t60_prompt_reference_s`)
    over it)} of the recorded grand."""
    out = {}
    for key in keys:
        t = [float(early_t60_s(_load_real(folder, key, v), key)[0]) for v in layers]
        med = float(np.median(t))
        out[key] = (t, med, _reference_t60_s(key) / med)
    return out


def running_median(values, width=5):
    """Median of each value with its (width - 1) / 2 neighbours on each
    side (fewer at the ends)."""
    h = width // 2
    v = list(values)
    return [float(np.median(v[max(0, i - h):i + h + 1])) for i in range(len(v))]


def damping(args) -> None:
    from synth.physics.piano import DAMPING_B3_S

    folder = _real_folder(args)
    r = Renderer("grand-piano", tuple(args.set))
    print(f"Early T60 (s) of the partials at {DAMPING_BAND_HZ[0] / 1e3:.0f}-"
          f"{DAMPING_BAND_HZ[1] / 1e3:.0f} kHz within {-DAMPING_FLOOR_DB:.0f} dB of the "
          f"recording's strongest (b3 = {DAMPING_B3_S:.3g} s)\n")
    print("| key | partial | kHz | level, dB | real v10 | model |")
    print("|---|---|---|---|---|---|")
    rows = []
    for key in range(63, 100, 3):
        got = damping_rows(key, _load_real(folder, key), r.note(key, 80, 1.5))
        for p, f, lv, t, m in got:
            print(f"| {key} | {p} | {f / 1e3:.1f} | {lv:.1f} | {t:.1f} | {m:.1f} |")
        rows += got
    if not rows:
        raise SystemExit("study_partials: error: no partial in the band above the floor")
    med, lo, hi = ratio_summary(rows)
    print(f"\n{len(rows)} partials: model / real T60, median {med:.2f}, quartiles {lo:.2f}-{hi:.2f}")


def ratios(args) -> None:
    folder = _real_folder(args)
    keys = list(range(21, 109, 3))
    got = implied_ratios(folder, keys)
    smooth = running_median([got[k][2] for k in keys])
    print("| key | strings | early T60 of partial 1, v4 / v10 / v14 (s) | median | reference T60 "
          "(model) | implied ratio | running median of 5 | model's ratio |")
    print("|---|---|---|---|---|---|---|---|")
    for key, sm in zip(keys, smooth):
        t, med, r = got[key]
        print(f"| {key} | {grand_string(key).n_strings} | {' / '.join(f'{v:.1f}' for v in t)} | "
              f"{med:.1f} | {_reference_t60_s(key):.1f} | {r:.1f} | {sm:.1f} | "
              f"{prompt_ratio(key):.2f} |")


def beats(args) -> None:
    from synth.physics.piano import UNISON_SPREAD_CENTS

    folder = _real_folder(args, args.keys)
    rs = _scaled_renderers(args, "strings.detune_scale")
    print(f"Beating of partials 2-8, 0.1-3 s: RMS (dB) about the best two-segment line, median over "
          f"the partials (the law's spread: {UNISON_SPREAD_CENTS:g} cent)\n")
    print("| key | real v4 / v10 / v14 | median | " + " | ".join(f"model x{sc:g}" for sc, _ in rs) + " |")
    print("|---|---|---|" + "---|" * len(rs))
    diff = {sc: [] for sc, _ in rs}
    for key in args.keys:
        real = [float(np.nanmedian(beat_roughness_db(_load_real(folder, key, v), key)[1:]))
                for v in (4, 10, 14)]
        rm = float(np.median(real))
        got = []
        for sc, r in rs:
            m = float(np.nanmedian(beat_roughness_db(r.note(key, 80, BEAT_SPAN_S[1] + 0.05), key)[1:]))
            diff[sc].append(m - rm)
            got.append(m)
        print(f"| {key} | {' / '.join(f'{v:.1f}' for v in real)} | {rm:.1f} | "
              + " | ".join(f"{v:.1f}" for v in got) + " |")
    print("\n| scale | cents at C4 | model - real, median (dB) | mean absolute (dB) |")
    print("|---|---|---|---|")
    for sc, _ in rs:
        d = np.array(diff[sc])
        print(f"| {sc:g} | {sc * UNISON_SPREAD_CENTS:.2f} | {np.median(d):+.2f} | {np.mean(np.abs(d)):.2f} |")


#: the ``tail`` study's figure: keys and length (s)
CURVE_KEYS, CURVE_S = (39, 60), 12.0


def _tail_curves(args, folder):
    """``--curves-json`` and ``--png``: the level curves of ``CURVE_KEYS``
    (velocity 80), with the recording's and a ``--before-json``'s."""
    import json

    r = Renderer("grand-piano", tuple(args.set))
    model = {str(k): level_curve_db(r.note(k, 80, CURVE_S)).tolist() for k in CURVE_KEYS}
    if args.curves_json:
        Path(args.curves_json).write_text(json.dumps({"model": model}))
    if not args.png:
        return
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise SystemExit("study_partials: error: --png needs matplotlib: pip install 'synth[plots]'")
    before = json.loads(Path(args.before_json).read_text())["model"] if args.before_json else None
    fig, axs = plt.subplots(1, len(CURVE_KEYS), figsize=(8, 3.6), dpi=100, sharey=True)
    for ax, k in zip(axs, CURVE_KEYS):
        for i, v in enumerate((4, 10, 14)):
            c = level_curve_db(_load_real(folder, k, v))
            ax.plot((np.arange(len(c)) + 0.5) * 0.1, c, color="0.6", lw=1,
                    label="recorded grand, v4/v10/v14" if i == 0 else None)
        for curve, style, colour, label in ((before and before[str(k)], "--", "C3", "model before"),
                                            (model[str(k)], "-", "C0", "model")):
            if curve:
                ax.plot((np.arange(len(curve)) + 0.5) * 0.1, curve, style, color=colour, lw=1.3,
                        label=label)
        g = grand_string(k)
        ax.set_title(f"key {k} ({g.n_strings} strings)", fontsize=10)
        ax.set_xlim(0, CURVE_S)
        ax.set_ylim(-75, 2)
        ax.grid(alpha=0.3)
        ax.set_xlabel("s")
    axs[0].set_ylabel("level, dB re the loudest 0.1 s")
    axs[0].legend(fontsize=8, loc="lower left")
    fig.suptitle("The aftersound: velocity 80 against a recorded Yamaha C5", fontsize=10)
    fig.tight_layout()
    fig.savefig(args.png)
    plt.close(fig)
    try:
        from PIL import Image

        Image.open(args.png).convert("RGB").quantize(64).save(args.png, optimize=True)
    except ImportError:
        pass


def tail(args) -> None:
    folder = _real_folder(args, args.keys)
    rs = _scaled_renderers(args, "strings.t60_scale")
    print(f"The aftersound: T60 (s) of the note's level over {TAIL_SPAN_S[0]:g}-{TAIL_SPAN_S[1]:g} s "
          f"and its level (dB re the loudest 50 ms) over the first {TAIL_LEVEL_S:g} s of it\n")
    print("| key | real T60 v4 / v10 / v14 | real level | "
          + " | ".join(f"model x{sc:g}: T60, level" for sc, _ in rs) + " |")
    print("|---|---|---|" + "---|" * len(rs))
    for key in args.keys:
        real = [tail_t60_and_level(_load_real(folder, key, v)) for v in (4, 10, 14)]
        got = [tail_t60_and_level(r.note(key, 80, TAIL_SPAN_S[1] + 1.55, keep_s=0.1)) for _, r in rs]
        print(f"| {key} | {' / '.join(f'{a:.1f}' for a, _ in real)} | "
              f"{' / '.join(f'{b:.1f}' for _, b in real)} | "
              + " | ".join(f"{a:.1f}, {b:.1f}" for a, b in got) + " |", flush=True)
    if args.png or args.curves_json:
        _tail_curves(args, folder)


def thump(args) -> None:
    folder = _real_folder(args, list(args.keys) + [60])
    r = Renderer("grand-piano", tuple(args.set))
    knock = float(r.voice.preset.action.knock or 0.0)
    r0 = Renderer("grand-piano", tuple(args.set) + ("action.knock=0",))
    c4r = {v: _load_real(folder, 60, v) for v, _ in THUMP_PAIRS}
    c4m = {m: r.note(60, m, 0.3) for _, m in THUMP_PAIRS}
    c40 = r0.note(60, 80, 0.3)
    print(f"thump re C4's partial 1, dB (action.knock = {knock:g})")
    print("| key | recording v4 / v10 / v14 | model 40 / 80 / 110 | model 80, knock 0 | gap at 80 |")
    print("|---|---|---|---|---|")
    gaps = {m: [] for _, m in THUMP_PAIRS}
    top = [k for k in args.keys if et_f0_hz(k) / 2 >= THUMP_BANDS_HZ[-1][1]]
    kept = {}                     # the top keys' samples, for the spectrum table
    for key in args.keys:
        samples = [_load_real(folder, key, v) for v, _ in THUMP_PAIRS]
        if key in top:
            kept[key] = samples
        real = [thump_db(y, key, c4r[v]) for y, (v, _) in zip(samples, THUMP_PAIRS)]
        model = [thump_db(r.note(key, m, 0.3), key, c4m[m]) for _, m in THUMP_PAIRS]
        bare = thump_db(r0.note(key, 80, 0.3), key, c40)
        for (a, b), (_, m) in zip(zip(real, model), THUMP_PAIRS):
            gaps[m].append(a - b)
        print(f"| {key} | {' / '.join(f'{a:.1f}' for a in real)} | "
              f"{' / '.join(f'{b:.1f}' for b in model)} | {bare:.1f} | {real[1] - model[1]:+.1f} |", flush=True)
    for v, m in THUMP_PAIRS:
        g = np.array(gaps[m])
        print(f"v{v} against velocity {m}: gap real - model median {np.median(g):+.1f} dB, "
              f"quartiles {np.percentile(g, 25):+.1f} / {np.percentile(g, 75):+.1f}")
    g80 = float(np.median(gaps[80]))
    if knock > 0:
        print(f"the knock that closes the median gap at velocity 80: {knock * 10 ** (g80 / 20):.2f}")
    if top:
        names = " | ".join(f"{lo:.0f}-{hi:.0f} Hz" for lo, hi in THUMP_BANDS_HZ)
        print(f"\nthe thump's spectrum, power per Hz re 90-360 Hz, dB (action.knock_s = "
              f"{r.voice.preset.action.knock_s:g} s)")
        print(f"| key | | {names} |")
        print("|---|---|" + "---|" * len(THUMP_BANDS_HZ))
        for key in top:
            real = np.mean([thump_spectrum_db(y) for y in kept[key]], axis=0)
            model = thump_spectrum_db(r.note(key, 80, 0.3))
            print(f"| {key} | recording (v4-v14 mean) | " + " | ".join(f"{x:.1f}" for x in real) + " |")
            print(f"| {key} | model, velocity 80 | " + " | ".join(f"{x:.1f}" for x in model) + " |")


def una_corda(args) -> None:
    r = Renderer("grand-piano", tuple(args.set))
    print("| key | centroid change | centroid / f0, pedal up -> down | loudness change, dB |")
    print("|---|---|---|---|")
    for key in args.keys:
        a = r.note(key, 80, 0.3)
        b = r.note(key, 80, 0.3, soft=True)
        ca, cb = attack_centroid_hz(a, FS), attack_centroid_hz(b, FS)
        f0 = et_f0_hz(key)
        print(f"| {key} | {100 * (cb / ca - 1):+.1f} % | {ca / f0:.2f} -> {cb / f0:.2f} | "
              f"{max_momentary_lufs(b, FS) - max_momentary_lufs(a, FS):+.1f} |")


def _keys(text: str) -> list:
    try:
        keys = [int(k) for k in text.split(",") if k.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"--keys {text!r}: comma-separated MIDI keys 21-108") from None
    if not keys or any(not 21 <= k <= 108 for k in keys):
        raise argparse.ArgumentTypeError(f"--keys {text!r}: comma-separated MIDI keys 21-108")
    return keys


def _scales(text: str) -> list:
    try:
        sc = [float(k) for k in text.split(",") if k.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"--scales {text!r}: comma-separated factors 0-5") from None
    if not sc or any(not 0.0 <= v <= 5.0 for v in sc):
        raise argparse.ArgumentTypeError(f"--scales {text!r}: comma-separated factors 0-5")
    return sc


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="study", required=True)
    d = sub.add_parser("decay", help="early T60 of partials 1-8, real grand and model")
    d.add_argument("--real", required=True, help="the folder of tools/real_grand.py's samples")
    d.add_argument("--keys", type=_keys, default=_keys("48,51,54,57,60,63,66,69,72"))
    d.add_argument("--set", action="append", default=[], metavar="PATH=VALUE")
    q = sub.add_parser("ratios", help="the prompt ratio a real grand implies, key by key")
    q.add_argument("--real", required=True, help="the folder of tools/real_grand.py's samples")
    u = sub.add_parser("una-corda", help="the una corda's centroid change on any keys")
    u.add_argument("--keys", type=_keys, default=_keys("78,81,84,87,90,92,94,96,98,100,104"))
    u.add_argument("--set", action="append", default=[], metavar="PATH=VALUE")
    w = sub.add_parser("damping", help="the strings' loss at 3-8 kHz against a real grand's")
    w.add_argument("--real", required=True, help="the folder of tools/real_grand.py's samples")
    w.add_argument("--set", action="append", default=[], metavar="PATH=VALUE")
    b = sub.add_parser("beats", help="how much the unisons' partials beat, against a real grand's")
    b.add_argument("--real", required=True, help="the folder of tools/real_grand.py's samples")
    b.add_argument("--keys", type=_keys, default=_keys("39,42,45,48,51,54,57,60,63,66,69,72,75,78,81,84,87"))
    b.add_argument("--scales", type=_scales, default=_scales("1"),
                   help="comma-separated factors on the law's unison spread (strings.detune_scale)")
    b.add_argument("--set", action="append", default=[], metavar="PATH=VALUE")
    t = sub.add_parser("tail", help="the aftersound's T60 and level, against a real grand's")
    t.add_argument("--real", required=True, help="the folder of tools/real_grand.py's samples")
    t.add_argument("--keys", type=_keys, default=_keys("21,27,33,39,45,51,57,60,63,69,75,81,87,93"))
    t.add_argument("--scales", type=_scales, default=_scales("1"),
                   help="comma-separated factors on the strings' own T60 (strings.t60_scale)")
    t.add_argument("--set", action="append", default=[], metavar="PATH=VALUE")
    t.add_argument("--png", help="also draw the level curves of keys 39 and 60 (needs [plots])")
    t.add_argument("--curves-json", help="also write the model's level curves of keys 39 and 60")
    t.add_argument("--before-json", help="a --curves-json of an earlier version, drawn beside")
    h = sub.add_parser("thump", help="the low thump under the attack, against a real grand's")
    h.add_argument("--real", required=True, help="the folder of tools/real_grand.py's samples")
    h.add_argument("--keys", type=_keys, default=_keys("48,54,60,66,72,78,84,90,96,102,105"))
    h.add_argument("--set", action="append", default=[], metavar="PATH=VALUE")
    args = ap.parse_args(argv)
    try:
        {"decay": decay, "ratios": ratios, "una-corda": una_corda,
         "damping": damping, "beats": beats,
         "tail": tail, "thump": thump}[args.study](args)
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
