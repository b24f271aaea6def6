"""`synth render`: a MIDI file through a preset into an audio file (synth.api.stream_midi,
written by synth.apps.render.write_render)."""

from __future__ import annotations

import sys

from .common import (add_audio_output, add_channels, add_mpe, add_quality, add_threads, audio_format,
                     check_not_inputs, check_output, fail, output_rate, peak_warning, preset_file,
                     quality_overrides)

NAME = "render"
HELP = "render a MIDI file with a preset to a WAV, FLAC or Ogg file"
DESCRIPTION = ("Render a Standard MIDI File with a preset to an audio file. On a "
               "terminal, a render longer than 2 s shows a progress bar with the time left; "
               "more than 30 min of audio is announced with a warning first. Ctrl-C stops "
               "it and leaves no file (an existing one as it was). A render that peaks over "
               "0 dBFS is written as it is, with a warning saying by how much to lower it.")
EPILOG = ("examples:\n"
          "  synth render song.mid --preset grand-piano -o song.wav\n"
          "  synth render song.mid --preset sitar --max-seconds 30 -o first30s.flac\n"
          "  synth render song.mid --preset biwa --channels 1,3-4 --rate 44100 --pcm24 -o cd.wav\n"
          "  synth render song.mid --preset harpsichord --set output.gain=0.01 -o quieter.ogg\n"
          "\n"
          "The output's extension chooses its format: .wav (32-bit float, or --pcm24), .flac\n"
          "(24-bit) or .ogg (Vorbis); an output that names the MIDI file or the preset file\n"
          "is refused.  What is played of a MIDI file: synth help midi.")


def add_arguments(parser) -> None:
    parser.add_argument("midi_file", metavar="MIDI_FILE",
                        help="a Standard MIDI File (.mid, format 0 or 1, or RIFF RMID .rmi)")
    parser.add_argument("--preset", required=True, metavar="PRESET",
                        help="preset name (see `synth presets`) or path to a .toml file (required)")
    parser.add_argument("--set", action="append", default=[], metavar="PATH=VALUE",
                        help="override a preset value, e.g. --set output.gain=0.01 (repeatable; "
                             "default: none; every key: synth help presets)")
    parser.add_argument("--internal-rate", type=float, metavar="HZ",
                        help="internal sample rate in Hz (default: 325000, or the study grid's own "
                             "rate)")
    add_audio_output(parser)
    add_quality(parser)
    parser.add_argument("--max-seconds", type=float, metavar="S",
                        help="render at most the first S seconds of audio (0 < S <= 21600): later notes "
                             "are left out, the sound is cut at S with a 10 ms fade-out (default: "
                             "the whole file and its release tails)")
    add_channels(parser)
    add_mpe(parser)
    add_threads(parser)


def run(args) -> int:
    """A MIDI file through a preset into an audio file: the Python API's
    stream (:func:`synth.api.stream_midi`: its checks, the file read and
    planned, the engine built), written as it renders by
    :func:`synth.apps.render.write_render` (the 30-minute warning,
    --max-seconds, the progress bar, Ctrl-C and SIGTERM, the atomic
    write).  Options are checked here first, under their own names."""
    from ..api.render import stream_midi
    from ..apps import cold_start
    from ..apps.render import (check_max_seconds, log_stderr, output_interruptible,
                               write_render)
    from ..engine.mpe import LOWER

    check_output(args.output, "-o")
    fmt = audio_format(args.output, "-o")
    if args.pcm24 and fmt == "ogg":
        fail(f"--pcm24 is for WAV files: -o {args.output} is Ogg Vorbis (give a .wav file)")
    check_not_inputs([("-o", args.output)], [("MIDI file", args.midi_file),
                                              ("preset", preset_file(args.preset))])
    check_max_seconds(args.max_seconds)
    if args.internal_rate is not None and not (20_000 <= args.internal_rate <= 2_000_000):
        fail(f"--internal-rate = {args.internal_rate} is out of range "
             "(20000 <= value <= 2000000 Hz)")
    args.set = list(args.set) + quality_overrides(args)
    rate = output_rate(args)
    mpe = ",".join(f"{'lower' if m == LOWER else 'upper'}:{n}" for m, n in args.mpe) or None
    channels = None if args.channels is None else [c + 1 for c in args.channels]   # 1-16
    with output_interruptible(args.output):
        midi = stream_midi(args.midi_file, args.preset, args.set, max_seconds=args.max_seconds,
                           channels=channels, drums=args.drums, rate=rate,
                           internal_rate=args.internal_rate, mpe=mpe, log=log_stderr)
        # (a cold cache: a second process compiles part of the kernels meanwhile)
        with cold_start.meanwhile(cold_start.start(midi.engine, args.preset, args.set,
                                                   args.threads)):
            res = write_render(midi, args.output, pcm24=args.pcm24, fmt=fmt, log=log_stderr,
                               stream=sys.stderr)
    warn = peak_warning(args.output, res.peak_dbfs, res.output_gain, res.n_clipped)
    if warn:
        print(warn, file=sys.stderr)
    print(res.summary)
    return 0
