"""`synth compare`: a listening-test page for presets or WAV files (synth.apps.compare)."""

from __future__ import annotations

import argparse

from .common import DEFAULT_SECONDS, add_threads, check_not_inputs, fail

NAME = "compare"
HELP = "compare presets or WAV files by ear: A/B, blind ABX and MUSHRA in one web page"
FORMATTER_CLASS = argparse.RawDescriptionHelpFormatter
DESCRIPTION = ("Render each stimulus (one note, or a MIDI file), match their loudness "
               "(ITU-R BS.1770 integrated, within 0.1 LU, no sample peak above -1 dBFS) and "
               "write DIR/index.html: one self-contained page (A/B switching at the same "
               "playhead with a loop region, blind ABX with exact binomial p-values, MUSHRA "
               "with a hidden reference and a 3.5 kHz anchor for three or more stimuli, then "
               "the reveal: names, loudness, analysis, spectrograms; results as CSV and JSON) "
               "and the matched audio beside it as 32-bit float WAV files.")
EPILOG = ("stimuli:\n"
          "  grand-piano                          a preset (name or .toml path)\n"
          "  'grand-piano:strings.t60_scale=2,tuning.stretch=0'\n"
          "                                       a preset with --set style overrides,\n"
          "                                       comma-separated (commas inside [...] kept)\n"
          "  take1.wav                            a WAV file (mono; more channels are\n"
          "                                       averaged; resampled to 48 kHz)\n"
          "\n"
          "examples:\n"
          "  synth compare grand-piano 'grand-piano:tuning.stretch=0' harpsichord \\\n"
          "      --key 60 --seconds 3 -o cmp && open cmp/index.html\n"
          "  synth compare take1.wav take2.wav -o takes\n"
          "  synth compare sitar biwa --midi tune.mid -o tune --serve\n"
          "  synth compare -o cmp --serve      # serve it; answers go to cmp/answers.csv")


def add_arguments(parser) -> None:
    parser.add_argument("stimuli", nargs="*", metavar="STIMULUS",
                        help="2-12 presets (PRESET or PRESET:PATH=VALUE,...) or WAV files")
    parser.add_argument("--midi", metavar="FILE", help="render this MIDI file with every preset "
                        "(default: none, one note)")
    parser.add_argument("--key", type=int, metavar="K",
                        help="MIDI key of the note, 0-127 (musical presets need it; default: none)")
    parser.add_argument("--velocity", type=int, metavar="V",
                        help="MIDI velocity of the note, 1-127 (default 100)")
    parser.add_argument("--seconds", type=float, metavar="S",
                        help=f"length of the note in seconds (default {DEFAULT_SECONDS:g})")
    parser.add_argument("--lufs", type=float, metavar="X", help="match to X LUFS (e.g. -23), lowered "
                        "further if a peak would exceed -1 dBFS (default: the quietest stimulus)")
    parser.add_argument("--trials", type=int, default=10, metavar="N",
                        help="ABX trials, 1 or more (default %(default)s)")
    parser.add_argument("-o", "--output", required=True, metavar="DIR",
                        help="new or empty directory for index.html and the WAV files (required)")
    parser.add_argument("--serve", action="store_true", help="then serve DIR on 127.0.0.1 and append "
                        "the answers the page posts to DIR/answers.csv (Ctrl-C stops); without "
                        "stimuli, serve an existing DIR (default: off)")
    parser.add_argument("--port", type=int, metavar="P",
                        help="port for --serve (default 8765; 0: any free port)")
    add_threads(parser)


def run(args) -> int:
    """Listening test page (synth.apps.compare): build it, then optionally serve it."""
    import functools

    from ..apps import compare

    log = functools.partial(print, flush=True)
    if args.midi is not None and (args.key is not None or args.velocity is not None
                                  or args.seconds is not None):
        fail("--midi plays the file: --key, --velocity and --seconds are for a single note")
    if args.port is not None and not args.serve:
        fail("--port is for --serve")
    import os

    check_not_inputs([("-o", args.output)],
                     [("MIDI file", args.midi)] + [("stimulus", st) for st in args.stimuli
                                                   if os.path.isfile(st)])
    if args.stimuli or not args.serve:
        req = compare.CompareRequest(
            stimuli=tuple(args.stimuli), out_dir=args.output, midi=args.midi, key=args.key,
            velocity=100 if args.velocity is None else args.velocity,
            seconds=DEFAULT_SECONDS if args.seconds is None else args.seconds,
            lufs=args.lufs, trials=args.trials)
        compare.make_comparison(req, log=log)
    if args.serve:
        return compare.serve(args.output, 8765 if args.port is None else args.port, log=log)
    return 0
