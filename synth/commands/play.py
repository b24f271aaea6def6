"""`synth play`: live play from a MIDI keyboard, through PortAudio or as a JACK
client (synth.io.live)."""

from __future__ import annotations

from .common import (add_channels, add_mpe, add_quality, add_threads, check_not_inputs, fail,
                     preset_file, quality_overrides)

NAME = "play"
HELP = "play a preset live from a MIDI keyboard (needs the [live] extra)"
EPILOG = ("examples:\n"
          "  synth play --list-ports                         # MIDI inputs and audio devices\n"
          "  synth play --preset grand-piano                 # the first keyboard, the default device\n"
          "  synth play --preset sitar --program-map 0=sitar,1=biwa --record take.wav\n"
          "  synth play --jack --preset harpsichord --connect\n"
          "\n"
          "What is played of the MIDI messages: synth help midi.")


def add_arguments(parser) -> None:
    parser.add_argument("--preset", help="preset played first (program 0), see `synth presets` (default: none; "
                             "required unless --list-ports)")
    parser.add_argument("--midi-port", metavar="NAME",
                        help="MIDI input port: exact name or part of it (default: the first keyboard)")
    parser.add_argument("--audio-device", metavar="NAME",
                        help="audio output device: index, exact name or part of it (default: the "
                             "system's)")
    parser.add_argument("--midi-api", choices=("auto", "alsa", "jack"),
                        help="the MIDI system --midi-port is on: the ALSA sequencer or JACK MIDI "
                             "(default auto: JACK when a JACK server runs, else ALSA)")
    parser.add_argument("--block", type=int, default=128,
                        help="audio block in samples at the output rate (default %(default)s = "
                             "2.7 ms at 48 kHz)")
    parser.add_argument("--rate", type=float, metavar="HZ",
                        help="output rate in Hz: 44100, 48000, 88200 or 96000 (any 22050-192000); "
                             "the decimator is designed for it (default 48000, or the device's own "
                             "rate when it cannot play 48 kHz)")
    parser.add_argument("--latency-ms", type=float, metavar="X",
                        help="delay from key to stream in ms, at least one block (default: two blocks)")
    parser.add_argument("--program-map", metavar="P=PRESET,...",
                        help="presets for MIDI program changes, e.g. 0=grand-piano,1=sitar,24=biwa "
                             "(programs 0-127; default: 0=the --preset)")
    parser.add_argument("--set", action="append", default=[], metavar="PATH=VALUE",
                        help="override a value of --preset, e.g. --set play.polyphony=32 "
                             "(repeatable; default: none)")
    add_quality(parser)
    add_channels(parser)
    add_mpe(parser)
    parser.add_argument("--jack", action="store_true",
                        help="play as a JACK client (jackd, or PipeWire's JACK): a MIDI input port "
                             "and the audio outputs, every MIDI event on its frame; the server's "
                             "rate and period are played at and may change while playing (default: "
                             "PortAudio)")
    parser.add_argument("--jack-name", default="synth", metavar="NAME",
                        help="the JACK client's name (default: %(default)s)")
    parser.add_argument("--connect", action="store_true",
                        help="with --jack: connect the outputs to the system's playback ports and "
                             "the first physical MIDI capture port to the input (default: off)")
    parser.add_argument("--reconnect", action="store_true",
                        help="with --jack: when the server stops, wait for it and play on "
                             "(default: say so and exit with status 1)")
    parser.add_argument("--record", metavar="OUT.wav",
                        help="also write the performance, as it goes to the device, to a WAV file "
                             "(32-bit float; complete whatever stops the play; default: none)")
    parser.add_argument("--seconds", type=float, metavar="S",
                        help="stop after S seconds and print the report (default: play until Ctrl-C)")
    parser.add_argument("--stats", action="store_true",
                        help="show block time, voices and underruns once a second, and the "
                             "latest note's contacts per string (hammer, termination; default: "
                             "off)")
    parser.add_argument("--warm-every-ms", type=float, default=20.0, metavar="MS",
                        help="every MS milliseconds a background thread plays a silent note on a "
                             "small copy of the instrument, so that a chord after a quiet moment "
                             "does not find its code cold (on a virtual machine that cost "
                             "milliseconds a chord); 0: off, else 2 .. 1000 (default: 20)")
    parser.add_argument("--list-ports", action="store_true",
                        help="list MIDI input ports (ALSA and JACK) and audio output devices, then "
                             "exit (default: off)")
    add_threads(parser)


def run(args) -> int:
    """Live play from a MIDI keyboard (synth.io.live; sounddevice and
    python-rtmidi are imported there, only now)."""
    from ..io import live

    if args.list_ports:
        print(live.list_ports())
        return 0
    if args.preset is None:
        fail("play needs --preset PRESET (see `synth presets`), or --list-ports")
    check_not_inputs([("--record", args.record)], [("preset", preset_file(args.preset))])
    # (the [live] extra is checked by the players before any slow work, with the
    # system packages' names: synth.io.live.devices.check_audio, check_midi, check_jack)
    args.set = list(args.set) + quality_overrides(args)
    programs = live.ProgramMap.parse(args.program_map, args.preset)
    if args.seconds is not None and not (0.0 < args.seconds <= 86400.0):
        fail(f"--seconds = {args.seconds:g} is out of range (0 < value <= 86400)")
    if args.jack:
        from ..io.live.jack import JackPlayer

        for opt, val in (("--midi-port", args.midi_port), ("--audio-device", args.audio_device),
                         ("--latency-ms", args.latency_ms), ("--midi-api", args.midi_api),
                         ("--rate", args.rate)):
            if val is not None:
                fail(f"{opt} is not used with --jack (connect the client's ports on the server, "
                      "whose rate and period it plays at; each MIDI event plays on its own frame)")

        player = JackPlayer(args.preset, programs, name=args.jack_name, connect=args.connect,
                            stats=args.stats, overrides=args.set, channels=args.channels,
                            drums=args.drums, record=args.record, reconnect=args.reconnect,
                            mpe=args.mpe, warm_every_ms=args.warm_every_ms)
    else:
        for opt, val in (("--connect", args.connect), ("--reconnect", args.reconnect)):
            if val:
                fail(f"{opt} needs --jack (PortAudio plays to --audio-device)")
        player = live.Player(args.preset, programs, block=args.block,
                             latency_s=None if args.latency_ms is None else args.latency_ms / 1e3,
                             audio_device=args.audio_device, midi_port=args.midi_port,
                             stats=args.stats, overrides=args.set, channels=args.channels,
                             drums=args.drums, record=args.record, rate=args.rate,
                             midi_api=args.midi_api or "auto", mpe=args.mpe,
                             warm_every_ms=args.warm_every_ms)
    from ..apps import cold_start

    # (a cold cache: a second process compiles part of the kernels meanwhile)
    with cold_start.meanwhile(cold_start.start_live(args.preset, args.set, args.threads)):
        player.start()
    player.run(seconds=args.seconds)
    return 1 if player.stopped else 0
