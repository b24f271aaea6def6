"""`synth render`: a MIDI file through a preset into a WAV file (synth.apps.render)."""

from __future__ import annotations

from .common import (add_channels, add_mpe, add_quality, add_threads, check_output, output_rate,
                     quality_overrides)

NAME = "render"
HELP = "render a MIDI file with a preset to a WAV file"
DESCRIPTION = ("Render a Standard MIDI File with a preset to a WAV file. On a "
               "terminal, a render longer than 2 s shows a progress bar with the time left; "
               "more than 30 min of audio is announced with a warning first. Ctrl-C stops "
               "it and leaves no file (an existing one as it was).")


def add_arguments(parser) -> None:
    parser.add_argument("midi_file")
    parser.add_argument("--preset", required=True)
    parser.add_argument("--set", action="append", default=[], metavar="PATH=VALUE")
    parser.add_argument("--internal-rate", type=float)
    parser.add_argument("--rate", type=float, metavar="HZ",
                        help="output sample rate in Hz (default 48000; 44100, 88200, 96000, any "
                             "22050-192000)")
    add_quality(parser)
    parser.add_argument("-o", "--output", required=True)
    parser.add_argument("--pcm24", action="store_true")
    parser.add_argument("--max-seconds", type=float, metavar="S",
                        help="render at most the first S seconds of audio (0 < S <= 21600): later notes "
                             "are left out, the sound is cut at S with a 10 ms fade-out")
    add_channels(parser)
    add_mpe(parser)
    add_threads(parser)


def run(args) -> int:
    """A MIDI file through a preset into a WAV file (synth.apps.render: the
    30-minute warning, --max-seconds, the progress bar, Ctrl-C and SIGTERM)."""
    from ..apps.render import RenderRequest, render_midi

    check_output(args.output, "-o")
    args.set = list(args.set) + quality_overrides(args)
    req = RenderRequest(midi_file=args.midi_file, preset=args.preset, output=args.output,
                        overrides=tuple(args.set), internal_rate=args.internal_rate,
                        pcm24=args.pcm24, max_seconds=args.max_seconds,
                        channels=args.channels, drums=args.drums, rate=output_rate(args),
                        mpe=args.mpe)
    print(render_midi(req).summary)
    return 0
