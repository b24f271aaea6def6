"""`synth note`: one note of a preset to a WAV file, with its probe, hammer and
contact logs on request."""

from __future__ import annotations

import time

from .common import (DEFAULT_SECONDS, add_audio_output, add_quality, add_threads, audio_format, check_not_inputs,
                     check_output, fail, output_rate, preset_file, quality_overrides,
                     write_audio)

NAME = "note"
HELP = "render one note of a preset to a WAV, FLAC or Ogg file"
EPILOG = ("examples:\n"
          "  synth note sitar --key 57 -o a3.wav                 # 3 s of the sitar's A3\n"
          "  synth note grand-piano --key 60 --velocity 40 --seconds 6 -o c4-soft.flac\n"
          "  synth note paper/sitar-ideal --probe u.npy -o ideal.wav   # a study preset and u(l, t)\n"
          "  synth note biwa --key 52 --set pluck.position=0.7 -o e3.ogg\n"
          "\n"
          "The output's extension chooses its format: .wav (32-bit float, or --pcm24), .flac\n"
          "(24-bit) or .ogg (Vorbis); an output that names an input file is refused.")


def add_arguments(parser) -> None:
    parser.add_argument("preset", metavar="PRESET",
                        help="preset name (see `synth presets`) or path to a .toml file")
    parser.add_argument("--key", type=int, metavar="K",
                        help="MIDI key 0-127, A4 = 69 (musical presets: within their range; "
                             "default: none, a study preset's own pitch)")
    parser.add_argument("--f0", type=float, metavar="HZ",
                        help="fundamental frequency in Hz, 20-5000, instead of --key (default: none)")
    parser.add_argument("--velocity", type=int, default=100, metavar="V",
                        help="MIDI velocity 1-127 (default %(default)s)")
    parser.add_argument("--seconds", type=float, default=DEFAULT_SECONDS, metavar="S",
                        help="length of the audio in seconds, 0-600 (default %(default)g)")
    parser.add_argument("--internal-rate", type=float, metavar="HZ",
                        help="internal sample rate in Hz, 20000-2000000 (default: 325000, or the "
                             "study grid's own rate)")
    parser.add_argument("--set", action="append", default=[], metavar="PATH=VALUE",
                        help="override a preset value, e.g. --set pluck.position=0.7 (repeatable; "
                             "default: none; every key: synth help presets)")
    add_quality(parser)
    add_audio_output(parser, when="48 kHz, or --rate; ")
    parser.add_argument("--probe", metavar="OUT.npy",
                        help="also save u(l, t) at the pluck point (m, internal rate, float64 .npy; "
                             "default: not saved)")
    parser.add_argument("--hammer-speed", type=float, metavar="M_PER_S",
                        help="hammer speed at contact in m/s, 0.01-20 (hammered presets; overrides "
                             "--velocity; default: from --velocity)")
    parser.add_argument("--contact-log", metavar="OUT.csv",
                        help="CSV of contact telemetry in 1 ms frames per string (termination points "
                             "in contact, hammer force in N) and a summary (time in contact, "
                             "episodes, peak force; default: not written)")
    parser.add_argument("--hammer-log", metavar="OUT.csv",
                        help="CSV of the strike at the internal rate: time (s), force (N), felt "
                             "compression (m), g (m), hammer position (m) (default: not written)")
    add_threads(parser)


def run(args) -> int:
    """One note through the Python API's rendering path (:mod:`synth.api.render`:
    the same checks, under the options' names, the same engine, the same
    samples as :func:`synth.render_note`), then the files asked for."""
    import numpy as np

    from ..api.checks import CLI_NAMES, check_note
    from ..api.render import check_playable, note_engine, play_note

    try:
        key, f0, velocity, seconds = check_note(args.key, args.f0, args.velocity, args.seconds,
                                                CLI_NAMES)
    except ValueError as e:
        fail(str(e))
    if args.internal_rate is not None and not (20_000 <= args.internal_rate <= 2_000_000):
        fail(f"--internal-rate = {args.internal_rate} is out of range (20000 <= value <= 2000000 Hz)")
    rate = output_rate(args)
    check_output(args.output, "-o")
    fmt = audio_format(args.output, "-o")
    if args.pcm24 and fmt == "ogg":
        fail(f"--pcm24 is for WAV files: -o {args.output} is Ogg Vorbis (give a .wav file)")
    check_not_inputs([("-o", args.output), ("--probe", args.probe),
                      ("--hammer-log", args.hammer_log), ("--contact-log", args.contact_log)],
                     [("preset", preset_file(args.preset))])
    if args.probe is not None:
        check_output(args.probe, "--probe")
    if args.hammer_log is not None:
        check_output(args.hammer_log, "--hammer-log")
    if args.contact_log is not None:
        check_output(args.contact_log, "--contact-log")
    if args.hammer_speed is not None and not (0.01 <= args.hammer_speed <= 20.0):
        fail(f"--hammer-speed = {args.hammer_speed} is out of range (0.01 <= value <= 20 m/s)")
    args.set = list(args.set) + quality_overrides(args)
    eng = note_engine(args.preset, args.set, key, f0, internal_rate=args.internal_rate,
                      probe=(args.probe is not None or args.hammer_log is not None
                             or args.contact_log is not None),
                      rate=rate)
    preset, inst = eng.inst.preset, eng.inst
    for opt, given in (("--hammer-speed", args.hammer_speed), ("--hammer-log", args.hammer_log)):
        if given is not None and not inst.struck:
            fail(f"{opt}: {args.preset} is plucked (voice = {preset.voice}): it has no hammer")
    try:
        check_playable(eng, args.preset, key, f0, CLI_NAMES)
    except ValueError as e:
        fail(str(e))
    from ..dsp.compile_notice import compile_seconds, timing_note

    from ..apps import cold_start

    c0 = compile_seconds()
    t = time.perf_counter()
    # (a cold cache: a second process compiles part of the kernels meanwhile)
    with cold_start.meanwhile(cold_start.start(eng, args.preset, args.set, args.threads)):
        y = play_note(eng, key, f0, velocity, seconds, args.hammer_speed)
    comp = compile_seconds() - c0
    el = time.perf_counter() - t - comp
    info = write_audio(args.output, y, eng.fs_out, args.pcm24, fmt, gain=preset.output.gain)
    pitch = inst.pitch_hz(args.key, f0)
    q = "" if inst.study else f" ({inst.quality.name})"
    print(f"{args.output}: {args.seconds:g} s of {args.preset} at {pitch:.2f} Hz, "
          f"internal rate {inst.fs:.1f} Hz{q}, {info}, rendered in {el:.2f} s{timing_note(comp)}")
    if args.probe:
        from ..io.wav import write_npy_atomic

        u, _ = eng.probe_signals()
        n = int(round(args.seconds * inst.fs))
        write_npy_atomic(args.probe, u[:n].astype(np.float64))
        print(f"{args.probe}: u(l, t) in metres, {n} samples at {inst.fs:.1f} Hz")
    if args.hammer_log:
        _write_hammer_log(args.hammer_log, inst, eng)
    if args.contact_log:
        _write_contact_log(args.contact_log, inst, eng, args.seconds)
    return 0


def _write_contact_log(path: str, inst, eng, seconds: float) -> None:
    """CSV of the note's contacts in 1 ms frames, per string (termination
    region points in contact, hammer felt force), and a summary per string
    on stdout (synth.analysis.contacts)."""
    import numpy as np

    from ..analysis.contacts import contact_frames, contact_summary
    from ..io.wav import write_text_atomic
    from ..kernels import strings as K

    n = int(round(seconds * inst.fs))
    rows = ["string,time_s,termination_contact_share,termination_points_max,"
            "hammer_contact_share,hammer_force_max_n"]
    lines = []
    for s in range(eng.spv):
        ch = eng.probe_channels(s)[:, :n]
        if not np.any(ch):
            continue                        # a string this note does not use
        fr = contact_frames(ch[K.P_CONTACT], ch[K.P_F], inst.fs, 0.001)
        rows += [f"{s},{r[0]:.4f},{r[1]:.4f},{int(r[2])},{r[3]:.4f},{r[4]:.6g}" for r in fr]
        sm = contact_summary(ch[K.P_CONTACT], ch[K.P_F], inst.fs)
        t, h = sm["termination"], sm["hammer"]
        lines.append(f"  string {s}: termination {t['time_in_contact_s'] * 1e3:.2f} ms in contact, "
                     f"{t['episodes']} episodes, up to {t['max_points']} points; hammer "
                     f"{h['time_in_contact_s'] * 1e3:.3f} ms in contact, {h['episodes']} episodes, "
                     f"peak {h['peak_force_n']:.2f} N")
    write_text_atomic(path, "\n".join(rows) + "\n")
    print(f"{path}: contacts in 1 ms frames, {len(lines)} strings")
    print("\n".join(lines))


def _write_hammer_log(path: str, inst, eng) -> None:
    """CSV of the strike at the internal rate, from the hammer's first
    sample to the end of its last contact: t, F, w, g, z."""
    import numpy as np

    from ..io.wav import write_text_atomic
    from ..kernels import strings as K

    ch = inst.strike_log()
    src = "the first-stage strike on the ideally supported string (injected g)"
    if ch is None:
        ch = eng.probe_channels()
        src = "the strike"
    F = ch[K.P_F]
    hit = np.flatnonzero(F > 0)
    if len(hit) == 0:
        fail("--hammer-log: the hammer never touched the string")
    n = int(hit[-1]) + 2
    t = np.arange(n) / inst.fs
    rows = ["time_s,force_n,felt_compression_m,g_m,hammer_position_m"]
    rows += [f"{t[i]:.9e},{F[i]:.9e},{ch[K.P_W][i]:.9e},{ch[K.P_G][i]:.9e},{ch[K.P_Z][i]:.9e}"
             for i in range(n)]
    write_text_atomic(path, "\n".join(rows) + "\n")
    dur = (hit[-1] - hit[0] + 1) / inst.fs
    print(f"{path}: {n} samples of {src}: contact {dur * 1e3:.3f} ms "
          f"(first to last sample with F > 0), peak force {F.max():.2f} N")
