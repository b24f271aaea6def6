"""`synth analyze`: partials, inharmonicity, T60s, centroid and loudness of a note
(synth.apps.analyze): an audio file, or a preset's note rendered first."""

from __future__ import annotations

import os
import sys

from .common import (DEFAULT_SECONDS, check_not_inputs, check_output, engine_for, fail,
                     require_extra)

NAME = "analyze"
HELP = ("partials, inharmonicity, T60s, centroid and loudness of a "
        "note: an audio file, or a preset's note rendered first")
EPILOG = ("examples:\n"
          "  synth analyze take.wav --key 60            # a recording (WAV, FLAC, Ogg, AIFF)\n"
          "  synth analyze sitar --key 57 --seconds 4   # a preset's note, rendered first\n"
          "  synth analyze grand-piano --key 60 --json > c4.json\n"
          "  synth analyze biwa --key 52 --plot e3.png  # and a PNG (the [plots] extra)\n"
          "\n"
          "A sound without a pitch (noise) is reported as such, without partials.\n"
          "The report's fields: synth help analyze.")

#: the audio files analyze reads (libsndfile's formats)
AUDIO_SUFFIXES = (".wav", ".flac", ".aiff", ".aif", ".ogg")


def add_arguments(parser) -> None:
    parser.add_argument("target", metavar="AUDIO.wav|PRESET",
                        help="an audio file (WAV, FLAC, Ogg, AIFF; channels averaged) or a preset "
                             "name or .toml file, whose note is rendered first")
    parser.add_argument("--key", type=int, metavar="K",
                        help="MIDI key 0-127 (a preset's note, or the expected pitch of a file; "
                             "default: none, the strongest peak of a file)")
    parser.add_argument("--f0", type=float, metavar="HZ",
                        help="expected pitch in Hz, 20-10000, instead of --key (default: none)")
    parser.add_argument("--velocity", type=int, default=100, metavar="V",
                        help="MIDI velocity of the rendered note, 1-127 (default %(default)s)")
    parser.add_argument("--seconds", type=float, default=DEFAULT_SECONDS, metavar="S",
                        help="length of the rendered note in seconds, 0.1-60 (default %(default)g)")
    parser.add_argument("--set", action="append", default=[], metavar="PATH=VALUE",
                        help="override a preset value (repeatable; default: none)")
    parser.add_argument("--partials", type=int, default=12, metavar="N",
                        help="partials to measure, 1-64 (default %(default)s)")
    parser.add_argument("--contacts", action="store_true",
                        help="a preset's note: also summarise its contacts per string (termination and "
                             "hammer: time in contact, episodes, peak force in N; over time in 10 ms "
                             "frames; default: off)")
    parser.add_argument("--json", action="store_true",
                        help="print the report as JSON (its fields: synth help analyze; default: a "
                             "table)")
    parser.add_argument("--plot", metavar="OUT.png",
                        help="also draw a PNG (needs the [plots] extra; default: none)")


def run(args) -> int:
    import json

    from ..apps.analyze import analyze_audio, format_report, plot_report

    if args.key is not None and args.f0 is not None:
        fail("--key and --f0 are exclusive: give one of them")
    if args.key is not None and not (0 <= args.key <= 127):
        fail(f"--key = {args.key} is out of range (0 <= value <= 127)")
    if args.f0 is not None and not (20.0 <= args.f0 <= 10000.0):
        fail(f"--f0 = {args.f0} is out of range (20 <= value <= 10000 Hz)")
    if not (1 <= args.velocity <= 127):
        fail(f"--velocity = {args.velocity} is out of range (1 <= value <= 127)")
    if not (0.1 <= args.seconds <= 60):
        fail(f"--seconds = {args.seconds} is out of range (0.1 <= value <= 60)")
    if args.plot is not None:
        check_output(args.plot, "--plot")
        require_extra("plots", "--plot")
    target = args.target
    # an existing file that is not a preset's .toml is audio, whatever its name
    audio_file = os.path.isfile(target) and not target.lower().endswith(".toml")
    check_not_inputs([("--plot", args.plot)], [("file", target if os.path.isfile(target) else None)])
    if audio_file:
        import soundfile as sf

        try:
            sf.info(target)
        except (OSError, RuntimeError):
            fail(f"not a WAV file: {target} (analyze reads WAV, FLAC, Ogg or AIFF audio, or a "
                 f"preset: see synth presets)")
        if args.set:
            fail("--set applies to a preset, not to an audio file")
        if args.contacts:
            fail("--contacts needs a preset's note (the telemetry comes from the render)")
        try:
            x, fs = sf.read(target, dtype="float64", always_2d=True)
        except (OSError, RuntimeError) as e:
            fail(f"{target}: cannot read the audio ({str(e).splitlines()[0]})")
        if x.shape[1] > 1:
            print(f"note: {target} has {x.shape[1]} channels; analysing their mean", file=sys.stderr)
        x = x.mean(axis=1)
        title = target
    else:
        if target.lower().endswith(AUDIO_SUFFIXES):
            fail(f"{target}: no such audio file")
        from ..engine.engine import Event

        preset, inst, eng = engine_for(target, args.set, low_key=args.key, probe=args.contacts)
        if preset.kind == "musical" and args.key is None and args.f0 is None:
            fail(f"{target} is a musical preset: give --key or --f0")
        ev = Event(0.0, "note_on", args.key if args.key is not None else -1, args.velocity / 127.0,
                   f0_hz=args.f0)
        from ..analysis import as_mono

        x = as_mono(eng.render([ev], duration_s=args.seconds))     # stereo: the mean
        fs = eng.fs_out
        title = f"{target}, key {args.key}, velocity {args.velocity}" if args.key is not None \
            else f"{target}, velocity {args.velocity}"
        if args.key is not None and args.f0 is None:
            args.f0 = inst.pitch_hz(args.key)     # the voice's own tuning as the reference
    r = analyze_audio(x, fs, key=args.key, f0_hz=args.f0, n_partials=args.partials)
    if args.contacts:
        r["contacts"] = _contact_report(inst, eng, args.seconds)
    if args.json:
        print(json.dumps(r, indent=1))
    else:
        print(format_report(r, title))
        for c in r.get("contacts", []):
            t, h = c["termination"], c["hammer"]
            print(f"contacts, string {c['string']}: termination {t['time_in_contact_s'] * 1e3:.2f} ms, "
                  f"{t['episodes']} episodes, up to {t['max_points']} points; hammer "
                  f"{h['time_in_contact_s'] * 1e3:.3f} ms, {h['episodes']} episodes, peak "
                  f"{h['peak_force_n']:.2f} N")
    if args.plot is not None:
        plot_report(x, fs, r, args.plot, title)
        print(f"{args.plot}: spectrogram, partial decays, centroid", file=sys.stderr)
    return 0


def _contact_report(inst, eng, seconds: float) -> list:
    """Contact telemetry of the rendered note, per string: the summary of
    synth.analysis.contacts and the same in 10 ms frames over time."""
    import numpy as np

    from ..analysis.contacts import contact_frames, contact_summary
    from ..kernels import strings as K

    n = int(round(seconds * inst.fs))
    out = []
    for s in range(eng.spv):
        ch = eng.probe_channels(s)[:, :n]
        if not np.any(ch):
            continue
        d = {"string": s, **contact_summary(ch[K.P_CONTACT], ch[K.P_F], inst.fs)}
        fr = contact_frames(ch[K.P_CONTACT], ch[K.P_F], inst.fs, 0.01)
        d["frames"] = {"time_s": fr[:, 0].tolist(), "termination_contact_share": fr[:, 1].tolist(),
                       "termination_points_max": fr[:, 2].astype(int).tolist(),
                       "hammer_contact_share": fr[:, 3].tolist(), "hammer_force_max_n": fr[:, 4].tolist()}
        out.append(d)
    return out
