"""`synth drone`: a preset's drone player (a tanpura's four strings plucked in
a cycle) from Sa into an audio file (synth.apps.drone, written by
synth.apps.render.write_render)."""

from __future__ import annotations

import sys

from .common import (add_audio_output, add_quality, add_threads, audio_format, check_not_inputs,
                     check_output, fail, output_rate, peak_warning, preset_file,
                     quality_overrides)

NAME = "drone"
HELP = "play a preset's drone (a tanpura's strings plucked in a cycle) into an audio file"
DESCRIPTION = ("Play the drone player of a preset with a [drone] table (the tanpura): its four "
               "strings (the first: Pa, Ma, Ni or Sa; two Sa in unison; the low Sa) plucked in "
               "a cycle from Sa, humanised in time and force from a seed, for exactly "
               "--seconds.  The file is written as `synth render` writes its own (atomically, "
               "its format by extension, a progress bar on a terminal, Ctrl-C leaves no file); "
               "the summary gives the plucks, the integrated loudness (LUFS) and the peak.  "
               "Live, `synth play --preset tanpura` plays the same player: a key starts it, "
               "the same key stops it (synth help drone).")
EPILOG = ("examples:\n"
          "  synth drone --preset tanpura --sa C#3 -o drone.wav           # 60 s, the preset's cycle\n"
          "  synth drone --preset tanpura --sa 49 --pattern \"Pa Sa Sa Sa\" --cycle-s 4 --seconds 60 -o drone.wav\n"
          "  synth drone --preset tanpura --sa D3 --pattern \"Ma Sa Sa Sa\" --seed 3 -o ma.flac\n"
          "\n"
          "Sa is a MIDI key (12-127) or a note name with an octave, C4 = 60: C#3 = Db3 = 49.")


def add_arguments(parser) -> None:
    parser.add_argument("--preset", default="tanpura", metavar="PRESET",
                        help="preset name or path to a .toml file, with a [drone] table "
                             "(default %(default)s)")
    parser.add_argument("--sa", required=True, metavar="KEY",
                        help="Sa: a MIDI key 12-127 or a note name such as C#3 or Db3 (C4 = 60); "
                             "the first string and the two middle ones are in its octave, the "
                             "low Sa an octave below (required)")
    parser.add_argument("--pattern", metavar="TEXT",
                        help="the strings in pluck order: Pa, Ma, Ni or Sa (the first string's "
                             "note), then Sa Sa Sa, e.g. \"Ma Sa Sa Sa\" (default: the preset's "
                             "drone.pattern)")
    parser.add_argument("--cycle-s", type=float, metavar="S",
                        help="the cycle's length in seconds, 1-16 (default: the preset's "
                             "drone.cycle_s)")
    parser.add_argument("--seconds", type=float, default=60.0, metavar="S",
                        help="length of the audio in seconds, 0-21600 (default %(default)g)")
    parser.add_argument("--seed", type=int, metavar="N",
                        help="seed of the humanisation (timing and force), 0-2147483647: the "
                             "same seed gives the same file (default: the preset's drone.seed)")
    parser.add_argument("--velocity", type=int, metavar="V",
                        help="the plucks' MIDI velocity 1-127 (default: the preset's "
                             "drone.velocity)")
    parser.add_argument("--set", action="append", default=[], metavar="PATH=VALUE",
                        help="override a preset value, e.g. --set drone.timing_jitter_s=0.01 "
                             "(repeatable; default: none; every key: synth help presets)")
    parser.add_argument("--internal-rate", type=float, metavar="HZ",
                        help="internal sample rate in Hz (default: 325000)")
    add_audio_output(parser, default="drone.wav")
    add_quality(parser)
    add_threads(parser)


def run(args) -> int:
    """The drone's options checked under their own names (the Python API's
    checks, :func:`synth.api.drone.check_drone`), then the render written
    (:func:`synth.apps.drone.render_drone_file`)."""
    from ..api.drone import DRONE_CLI_NAMES, check_drone
    from ..apps.drone import DroneRequest, render_drone_file
    from ..apps.render import log_stderr

    check_output(args.output, "-o")
    fmt = audio_format(args.output, "-o")
    if args.pcm24 and fmt == "ogg":
        fail(f"--pcm24 is for WAV files: -o {args.output} is Ogg Vorbis (give a .wav file)")
    check_not_inputs([("-o", args.output)], [("preset", preset_file(args.preset))])
    try:
        sa, seconds, drone = check_drone(args.sa, args.seconds, args.pattern, args.cycle_s,
                                         args.seed, args.velocity, DRONE_CLI_NAMES)
    except ValueError as e:
        fail(str(e))
    if args.internal_rate is not None and not (20_000 <= args.internal_rate <= 2_000_000):
        fail(f"--internal-rate = {args.internal_rate} is out of range "
             "(20000 <= value <= 2000000 Hz)")
    overrides = tuple(args.set) + tuple(quality_overrides(args))
    req = DroneRequest(args.preset, sa, seconds, args.output, overrides, tuple(drone),
                       rate=output_rate(args), internal_rate=args.internal_rate,
                       pcm24=args.pcm24, fmt=fmt)
    res = render_drone_file(req, log=log_stderr, stream=sys.stderr)
    warn = peak_warning(args.output, res.peak_dbfs, res.output_gain, res.n_clipped)
    if warn:
        print(warn, file=sys.stderr)
    print(res.summary)
    return 0
