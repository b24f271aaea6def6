"""The ``synth`` command: offline rendering of presets, notes and MIDI files.

    synth demo [-o demo.wav]
    synth presets
    synth note PRESET [--key K | --f0 HZ] [--velocity V] [--seconds S]
               [--internal-rate HZ] [--quality LEVEL | --max-error CENTS,DB]
               [--set PATH=VALUE ...] -o OUT.wav [--probe OUT.npy]
    synth render MIDI_FILE --preset PRESET [--set PATH=VALUE ...] [--max-seconds S]
                 [--quality LEVEL | --max-error CENTS,DB] -o OUT.wav
    synth check SPEC.toml [...] [--shipped] [--junit OUT.xml]
    synth analyze AUDIO.wav|PRESET [--key K | --f0 HZ] [--velocity V] [--json] [--plot OUT.png]
    synth play --preset PRESET [--midi-api auto|alsa|jack] [--midi-port NAME]
               [--audio-device NAME] [--rate HZ] [--block N] [--latency-ms X]
               [--program-map 0=PRESET,...] [--set PATH=VALUE ...] [--record OUT.wav] [--stats]
    synth play --jack --preset PRESET [--jack-name NAME] [--connect] [--reconnect] [...]
    synth play --list-ports
    synth batch SPEC.toml -o DIR [--scheduler tcp://HOST:8786 | --workers N] [--csv] [--dry-run]
    synth compare STIMULUS STIMULUS [...] [--midi FILE | --key K --velocity V --seconds S]
               [--lufs X] [--trials N] -o DIR [--serve [--port P]]

MIDI values (0-127) are normalised here, once; everything below works in SI
units and [0, 1].  User errors print one line (``synth: error: ...``) and
exit with status 2; no half-written file is left behind.  Ctrl-C (and
SIGTERM during ``render``) print one line (``synth: interrupted ...``) and
exit with status 130 (143).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

from .io.errors import SynthError
from .io.interrupt import Interrupted


def _fail(msg: str) -> None:
    raise SynthError(msg)


def _check_output(path: str, option: str) -> None:
    """Fail before any work if `path` cannot be an output file (its directory is missing)."""
    if os.path.isdir(path):
        _fail(f"{option} {path}: is a directory, give a file name")
    d = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(d):
        _fail(f"{option} {path}: directory {d} does not exist")


def _add_quality(p) -> None:
    """--quality and --max-error on a command that builds an engine."""
    p.add_argument("--quality", choices=("draft", "standard", "reference"),
                   help="how finely the strings are computed (default: the preset's "
                        "play.quality, standard); docs/quality.md gives each level's error "
                        "and cost")
    p.add_argument("--max-error", metavar="CENTS,DB",
                   help="the cheapest quality level whose measured error for this preset is "
                        "within CENTS (partial frequencies) and DB (partial levels), e.g. 1,1 "
                        "(docs/quality.md)")


def _quality_overrides(args) -> list:
    """The ``--set`` overrides for --quality or --max-error (none without)."""
    q = getattr(args, "quality", None)
    me = getattr(args, "max_error", None)
    if q is not None and me is not None:
        _fail("--quality and --max-error are exclusive: give one of them")
    if me is not None:
        from .voices.quality import cheapest_within

        try:
            c, d = (float(v) for v in me.split(","))
        except ValueError:
            _fail(f"--max-error = {me!r} is not CENTS,DB (two numbers, e.g. 0.5,1)")
        name = getattr(args, "preset", None)
        if name is not None and str(name).endswith(".toml"):
            name = os.path.splitext(os.path.basename(str(name)))[0]
        try:
            q = cheapest_within(c, d, name).name
        except ValueError as e:
            _fail(f"--max-error: {e}")
    return [] if q is None else [f"play.quality={q}"]


def _engine_for(preset_name: str, overrides, internal_rate=None, probe=False, low_key=None,
                rate=None):
    from .io.factory import build_engine

    kw = {} if rate is None else {"fs_out": rate}
    eng = build_engine(preset_name, overrides, fs_internal=internal_rate, probe=probe,
                       extra_low_key=low_key, **kw)
    return eng.inst.preset, eng.inst, eng


def _write(path: str, audio: np.ndarray, fs: int, pcm24: bool) -> str:
    from .io.wav import write_wav

    res = write_wav(path, audio.astype(np.float32), fs, "pcm24" if pcm24 else "float")
    clip = f", {res.n_clipped} samples clipped" if res.n_clipped else ""
    return f"peak {res.peak_dbfs:.1f} dBFS{clip}"


# ---------------------------------------------------------------------------
def cmd_presets(args) -> int:
    from .io.presets import ENV_PRESET_PATH, list_presets, preset_dirs

    if getattr(args, "reference", False):
        from .io.presets.reference import reference_markdown

        sys.stdout.write(reference_markdown())
        return 0
    items = list_presets()
    if not items:
        # an install without its package data, or an empty SYNTH_PRESET_PATH
        # directory and no shipped presets: say so, do not list nothing and succeed
        where = ", ".join(str(d) for d in preset_dirs())
        _fail(f"no presets found (looked in: {where}; add directories with ${ENV_PRESET_PATH})")
    w = max((len(n) for n, _ in items), default=0)
    for name, desc in items:
        print(f"{name:<{w}}  {desc}")
    return 0


def cmd_note(args) -> int:
    from .engine.engine import Event

    if args.key is not None and args.f0 is not None:
        _fail("--key and --f0 are exclusive: give one of them")
    if args.key is not None and not (0 <= args.key <= 127):
        _fail(f"--key = {args.key} is out of range (0 <= value <= 127)")
    if args.f0 is not None and not (20.0 <= args.f0 <= 5000.0):
        _fail(f"--f0 = {args.f0} is out of range (20 <= value <= 5000 Hz)")
    if not (1 <= args.velocity <= 127):
        _fail(f"--velocity = {args.velocity} is out of range (1 <= value <= 127)")
    if not (0 < args.seconds <= 600):
        _fail(f"--seconds = {args.seconds} is out of range (0 < value <= 600)")
    if args.internal_rate is not None and not (20_000 <= args.internal_rate <= 2_000_000):
        _fail(f"--internal-rate = {args.internal_rate} is out of range (20000 <= value <= 2000000 Hz)")
    rate = _rate(args)
    _check_output(args.output, "-o")
    if args.probe is not None:
        _check_output(args.probe, "--probe")
    if args.hammer_log is not None:
        _check_output(args.hammer_log, "--hammer-log")
    if args.contact_log is not None:
        _check_output(args.contact_log, "--contact-log")
    if args.hammer_speed is not None and not (0.01 <= args.hammer_speed <= 20.0):
        _fail(f"--hammer-speed = {args.hammer_speed} is out of range (0.01 <= value <= 20 m/s)")
    args.set = list(args.set) + _quality_overrides(args)
    low = args.key if args.key is not None else None
    if args.f0 is not None:
        low = int(math.floor(69 + 12 * math.log2(args.f0 / 440.0)))
    preset, inst, eng = _engine_for(args.preset, args.set, args.internal_rate,
                                    probe=(args.probe is not None or args.hammer_log is not None
                                           or args.contact_log is not None),
                                    low_key=low, rate=rate)
    for opt, given in (("--hammer-speed", args.hammer_speed), ("--hammer-log", args.hammer_log)):
        if given is not None and not inst.struck:
            _fail(f"{opt}: {args.preset} is plucked (voice = {preset.voice}): it has no hammer")
    if preset.kind == "musical" and args.key is None and args.f0 is None:
        _fail(f"{args.preset} is a musical preset: give --key or --f0")
    if preset.kind == "musical" and args.key is not None:
        lo, hi = preset.play.key_low, preset.play.key_high
        if not (lo <= args.key <= hi):
            _fail(f"--key = {args.key} is outside the playable range of {args.preset} ({lo} <= key <= {hi})")
    f0 = args.f0
    ev = Event(0.0, "note_on", args.key if args.key is not None else -1, args.velocity / 127.0,
               f0_hz=f0, speed_m_per_s=args.hammer_speed)
    t = time.perf_counter()
    y = eng.render([ev], duration_s=args.seconds)
    el = time.perf_counter() - t
    info = _write(args.output, y, eng.fs_out, args.pcm24)
    pitch = inst.pitch_hz(args.key, f0)
    q = "" if inst.study else f" ({inst.quality.name})"
    print(f"{args.output}: {args.seconds:g} s of {args.preset} at {pitch:.2f} Hz, "
          f"internal rate {inst.fs:.1f} Hz{q}, {info}, rendered in {el:.2f} s")
    if args.probe:
        from .io.wav import write_npy_atomic

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
    from .analysis.contacts import contact_frames, contact_summary
    from .io.wav import write_text_atomic
    from .kernels import strings as K

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
    from .io.wav import write_text_atomic
    from .kernels import strings as K

    ch = inst.strike_log()
    src = "the first-stage strike on the ideally supported string (injected g)"
    if ch is None:
        ch = eng.probe_channels()
        src = "the strike"
    F = ch[K.P_F]
    hit = np.flatnonzero(F > 0)
    if len(hit) == 0:
        _fail("--hammer-log: the hammer never touched the string")
    n = int(hit[-1]) + 2
    t = np.arange(n) / inst.fs
    rows = ["time_s,force_n,felt_compression_m,g_m,hammer_position_m"]
    rows += [f"{t[i]:.9e},{F[i]:.9e},{ch[K.P_W][i]:.9e},{ch[K.P_G][i]:.9e},{ch[K.P_Z][i]:.9e}"
             for i in range(n)]
    write_text_atomic(path, "\n".join(rows) + "\n")
    dur = (hit[-1] - hit[0] + 1) / inst.fs
    print(f"{path}: {n} samples of {src}: contact {dur * 1e3:.3f} ms "
          f"(first to last sample with F > 0), peak force {F.max():.2f} N")


def parse_channels(text: str) -> tuple[int, ...]:
    """``--channels``: MIDI channels as users number them, 1-16, with
    ranges (``1,3-4``) -> 0-based channels (0, 2, 3)."""
    out = set()
    for part in text.split(","):
        part = part.strip()
        try:
            lo, _, hi = part.partition("-")
            a, b = int(lo), int(hi or lo)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"--channels = {text!r}: {part!r} is not a channel or a range (e.g. 1,3-4)") from None
        if not (1 <= a <= b <= 16):
            raise argparse.ArgumentTypeError(
                f"--channels = {text!r}: {part!r} is out of range (channels 1 <= value <= 16)")
        out.update(range(a - 1, b))
    return tuple(sorted(out))


def _add_channels(p) -> None:
    p.add_argument("--channels", type=parse_channels, metavar="LIST",
                   help="MIDI channels that play, 1-16, e.g. 1,3-4 (default: every channel; "
                        "the others' messages are skipped and counted)")
    p.add_argument("--drums", action="store_true",
                   help="play channel 10 too: General MIDI keeps it for drums, so by default "
                        "its notes are skipped (and counted)")


def _rate(args):
    """``--rate`` checked (None when not given)."""
    if args.rate is None:
        return None
    from .io.rates import check_rate

    try:
        return check_rate(args.rate)
    except SynthError as e:
        _fail(str(e))


def parse_mpe_option(text: str) -> tuple[tuple[int, int], ...]:
    """``--mpe``: MPE zones (:func:`synth.engine.mpe.parse_mpe`)."""
    from .engine.mpe import parse_mpe

    try:
        return parse_mpe(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def _add_mpe(p) -> None:
    p.add_argument("--mpe", type=parse_mpe_option, default=(), metavar="ZONE",
                   help="MPE zones, as if the MPE configuration message (RPN 6) had been "
                        "received: lower (manager channel 1, notes on 2-16), upper (manager "
                        "16, notes on 1-15), lower:N or upper:N (N member channels), or "
                        "lower:7,upper:7; each note's channel bends (48 semitones, plus the "
                        "manager's 2; held within the preset's range), presses (its buzz) "
                        "and sets its pluck point (CC74) for that note alone "
                        "(docs/midi.md, MPE)")


def cmd_render(args) -> int:
    """A MIDI file through a preset into a WAV file (synth.apps.render: the
    30-minute warning, --max-seconds, the progress bar, Ctrl-C and SIGTERM)."""
    from .apps.render import RenderRequest, render_midi

    _check_output(args.output, "-o")
    args.set = list(args.set) + _quality_overrides(args)
    req = RenderRequest(midi_file=args.midi_file, preset=args.preset, output=args.output,
                        overrides=tuple(args.set), internal_rate=args.internal_rate,
                        pcm24=args.pcm24, max_seconds=args.max_seconds,
                        channels=args.channels, drums=args.drums, rate=_rate(args),
                        mpe=args.mpe)
    print(render_midi(req).summary)
    return 0


def cmd_play(args) -> int:
    """Live play from a MIDI keyboard (synth.io.live; sounddevice and
    python-rtmidi are imported there, only now)."""
    from .io import live

    if args.list_ports:
        print(live.list_ports())
        return 0
    if args.preset is None:
        _fail("play needs --preset PRESET (see `synth presets`), or --list-ports")
    args.set = list(args.set) + _quality_overrides(args)
    programs = live.ProgramMap.parse(args.program_map, args.preset)
    if args.seconds is not None and not (0.0 < args.seconds <= 86400.0):
        _fail(f"--seconds = {args.seconds:g} is out of range (0 < value <= 86400)")
    if args.jack:
        from .io.live.jack import JackPlayer

        for opt, val in (("--midi-port", args.midi_port), ("--audio-device", args.audio_device),
                         ("--latency-ms", args.latency_ms), ("--midi-api", args.midi_api),
                         ("--rate", args.rate)):
            if val is not None:
                _fail(f"{opt} is not used with --jack (connect the client's ports on the server, "
                      "whose rate and period it plays at; each MIDI event plays on its own frame)")

        player = JackPlayer(args.preset, programs, name=args.jack_name, connect=args.connect,
                            stats=args.stats, overrides=args.set, channels=args.channels,
                            drums=args.drums, record=args.record, reconnect=args.reconnect,
                            mpe=args.mpe)
    else:
        for opt, val in (("--connect", args.connect), ("--reconnect", args.reconnect)):
            if val:
                _fail(f"{opt} needs --jack (PortAudio plays to --audio-device)")
        player = live.Player(args.preset, programs, block=args.block,
                             latency_s=None if args.latency_ms is None else args.latency_ms / 1e3,
                             audio_device=args.audio_device, midi_port=args.midi_port,
                             stats=args.stats, overrides=args.set, channels=args.channels,
                             drums=args.drums, record=args.record, rate=args.rate,
                             midi_api=args.midi_api or "auto", mpe=args.mpe)
    player.start()
    player.run(seconds=args.seconds)
    return 1 if player.stopped else 0


def cmd_compare(args) -> int:
    """Listening test page (synth.apps.compare): build it, then optionally serve it."""
    import functools

    from .apps import compare

    log = functools.partial(print, flush=True)
    if args.midi is not None and (args.key is not None or args.velocity is not None
                                  or args.seconds is not None):
        _fail("--midi plays the file: --key, --velocity and --seconds are for a single note")
    if args.port is not None and not args.serve:
        _fail("--port is for --serve")
    if args.stimuli or not args.serve:
        req = compare.CompareRequest(
            stimuli=tuple(args.stimuli), out_dir=args.output, midi=args.midi, key=args.key,
            velocity=100 if args.velocity is None else args.velocity,
            seconds=3.0 if args.seconds is None else args.seconds,
            lufs=args.lufs, trials=args.trials)
        compare.make_comparison(req, log=log)
    if args.serve:
        return compare.serve(args.output, 8765 if args.port is None else args.port, log=log)
    return 0


DEMO_PHRASES = {
    # (start beat, key, beats, velocity)
    "sitar": [(0, 50, 1, 110), (1, 52, 1, 90), (2, 54, 1, 95), (3, 57, 2, 120),
              (5, 55, 0.5, 85), (5.5, 54, 0.5, 80), (6, 52, 1, 95), (7, 50, 3, 115)],
    "biwa": [(0, 52, 1.5, 120), (1.5, 53, 0.5, 80), (2, 57, 1, 100), (3, 59, 1, 95),
             (4, 60, 2, 125), (6, 57, 1, 90), (7, 52, 3, 120)],
}


def cmd_demo(args) -> int:
    from .engine.engine import Event

    _check_output(args.output, "-o")
    bpm = 96.0
    beat = 60.0 / bpm
    parts = []
    fs = 48_000
    for name, phrase in DEMO_PHRASES.items():
        _, _, eng = _engine_for(name, ())
        evs = []
        for b, key, dur, vel in phrase:
            evs.append(Event(b * beat, "note_on", key, vel / 127.0))
            evs.append(Event((b + dur) * beat, "note_off", key, 0.0))
        y = eng.render(evs, tail_s=0.2, max_tail_s=2.0)
        parts += [y, np.zeros(int(0.5 * fs))]
        fs = eng.fs_out
    audio = np.concatenate(parts)
    out = Path(args.output).resolve()
    info = _write(str(out), audio, fs, False)
    print(f"demo: {len(audio) / fs:.1f} s ({', '.join(DEMO_PHRASES)} phrases), {info}")
    print(f"wrote {out}")
    return 0


def cmd_analyze(args) -> int:
    import json

    from .apps.analyze import analyze_audio, format_report, plot_report

    if args.key is not None and args.f0 is not None:
        _fail("--key and --f0 are exclusive: give one of them")
    if args.key is not None and not (0 <= args.key <= 127):
        _fail(f"--key = {args.key} is out of range (0 <= value <= 127)")
    if args.f0 is not None and not (20.0 <= args.f0 <= 10000.0):
        _fail(f"--f0 = {args.f0} is out of range (20 <= value <= 10000 Hz)")
    if not (1 <= args.velocity <= 127):
        _fail(f"--velocity = {args.velocity} is out of range (1 <= value <= 127)")
    if not (0.1 <= args.seconds <= 60):
        _fail(f"--seconds = {args.seconds} is out of range (0.1 <= value <= 60)")
    if args.plot is not None:
        _check_output(args.plot, "--plot")
    target = args.target
    audio_file = os.path.isfile(target) and target.lower().endswith((".wav", ".flac", ".aiff", ".ogg"))
    if audio_file:
        import soundfile as sf

        if args.set:
            _fail("--set applies to a preset, not to an audio file")
        if args.contacts:
            _fail("--contacts needs a preset's note (the telemetry comes from the render)")
        try:
            x, fs = sf.read(target, dtype="float64", always_2d=True)
        except (OSError, RuntimeError) as e:
            _fail(f"{target}: cannot read the audio ({str(e).splitlines()[0]})")
        if x.shape[1] > 1:
            print(f"note: {target} has {x.shape[1]} channels; analysing their mean", file=sys.stderr)
        x = x.mean(axis=1)
        title = target
    else:
        if target.lower().endswith((".wav", ".flac", ".aiff", ".ogg")):
            _fail(f"{target}: no such audio file")
        from .engine.engine import Event

        preset, inst, eng = _engine_for(target, args.set, low_key=args.key, probe=args.contacts)
        if preset.kind == "musical" and args.key is None and args.f0 is None:
            _fail(f"{target} is a musical preset: give --key or --f0")
        ev = Event(0.0, "note_on", args.key if args.key is not None else -1, args.velocity / 127.0,
                   f0_hz=args.f0)
        from .analysis import as_mono

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
    from .analysis.contacts import contact_frames, contact_summary
    from .kernels import strings as K

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


def cmd_check(args) -> int:
    from .apps.check import format_table, run_spec, write_junit
    from .io.presets import shipped_checks_dir

    specs = list(args.spec)
    if args.shipped:
        specs += sorted(str(p) for p in shipped_checks_dir().glob("*.toml"))
    if not specs:
        _fail("check: give one or more SPEC.toml files, or --shipped")
    if args.junit is not None:
        _check_output(args.junit, "--junit")
    results = []
    for path in specs:
        results += run_spec(path, progress=lambda line: print(line, file=sys.stderr))
    print(format_table(results))
    if args.junit is not None:
        write_junit(args.junit, results)
        print(f"{args.junit}: JUnit XML, {len(results)} test cases")
    return 1 if any(not r.passed for r in results) else 0


def cmd_batch(args) -> int:
    from .apps.batch import BatchError, load_spec, render_many

    if args.workers is not None and not (1 <= args.workers <= 1024):
        _fail(f"--workers = {args.workers} is out of range (1 <= value <= 1024)")
    if args.workers is not None and args.scheduler is not None:
        _fail("--workers and --scheduler are exclusive: an existing cluster has its own workers")
    jobs = load_spec(args.spec)
    n_notes = sum(j.kind == "note" for j in jobs)
    print(f"{args.spec}: {len(jobs)} jobs ({n_notes} notes, {len(jobs) - n_notes} MIDI renders)",
          file=sys.stderr)
    if args.dry_run:
        for j in jobs:
            what = f"key {j.key} velocity {j.velocity} {j.seconds:g} s" if j.kind == "note" \
                else f"{j.midi_name}"
            sets = f" [{'; '.join(j.overrides)}]" if j.overrides else ""
            print(f"{j.index}\t{j.path}\t{j.preset}: {what}{sets}")
        return 0
    client = None
    if args.scheduler is not None:
        try:
            from dask.distributed import Client
        except ImportError:
            _fail('synth batch needs the [batch] extra: pip install "synth[batch]"')
        try:
            client = Client(args.scheduler, timeout="20s")
        except (OSError, TimeoutError) as e:
            _fail(f"--scheduler {args.scheduler}: cannot connect ({str(e).splitlines()[0]})")
    try:
        res = render_many(jobs, args.output, client=client, workers=args.workers, csv=args.csv)
    except BatchError:
        raise
    finally:
        if client is not None:
            client.close()
    audio_s = sum(float(d or 0.0) for d in res.manifest["duration_s"]) if len(res.manifest) else 0.0
    print(f"{args.output}: {res.rendered} rendered, {res.skipped} already done, "
          f"{len(res.failed)} failed; {len(res.manifest)} rows in {args.output}/manifest.parquet; "
          f"{audio_s:.0f} s of audio, run took {res.wall_s:.1f} s")
    for j, why in res.failed:
        print(f"synth: error: {j.path}: {why}", file=sys.stderr)
    return 1 if res.failed else 0


def _add_threads(p) -> None:
    p.add_argument("--threads", type=int, metavar="N",
                   help="threads the strings render on (default: every core this process may "
                        "use, or SYNTH_THREADS); the samples are the same for any N")


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="synth", description="Physical-modelling string synthesizer "
                                "(waveguide strings against jawari, sawari and capo-bar terminations).")
    sub = p.add_subparsers(dest="cmd", required=True)

    d = sub.add_parser("demo", help="render a short phrase on each plucked preset to demo.wav")
    d.add_argument("-o", "--output", default="demo.wav")
    _add_threads(d)
    d.set_defaults(func=cmd_demo)

    ps = sub.add_parser("presets", help="list presets with a one-line description")
    ps.add_argument("--reference", action="store_true",
                    help="instead: print every key a preset file may hold (meaning, unit, type, "
                         "range, default, when it applies) as Markdown, the text of docs/presets.md")
    ps.set_defaults(func=cmd_presets)

    n = sub.add_parser("note", help="render one note of a preset to a WAV file")
    n.add_argument("preset", help="preset name (see `synth presets`) or path to a .toml file")
    n.add_argument("--key", type=int, help="MIDI key 0-127 (musical presets: their range)")
    n.add_argument("--f0", type=float, help="fundamental frequency in Hz instead of --key")
    n.add_argument("--velocity", type=int, default=100, help="MIDI velocity 1-127 (default 100)")
    n.add_argument("--seconds", type=float, default=2.0, help="length in seconds (default 2)")
    n.add_argument("--internal-rate", type=float, help="internal sample rate in Hz (default: "
                   "325000, or the study grid's own rate)")
    n.add_argument("--set", action="append", default=[], metavar="PATH=VALUE",
                   help="override a preset value, e.g. --set pluck.position=0.7 (repeatable)")
    _add_quality(n)
    n.add_argument("--rate", type=float, metavar="HZ",
                   help="output sample rate in Hz (default 48000; 44100, 88200, 96000, any "
                        "22050-192000)")
    n.add_argument("-o", "--output", required=True, help="output WAV file (48 kHz, or --rate)")
    n.add_argument("--probe", help="also save u(l, t) at the pluck point (m, internal rate, float64 .npy)")
    n.add_argument("--pcm24", action="store_true", help="write 24-bit PCM instead of 32-bit float")
    n.add_argument("--hammer-speed", type=float, metavar="M_PER_S",
                   help="hammer speed at contact in m/s (hammered presets; overrides --velocity)")
    n.add_argument("--contact-log", metavar="OUT.csv",
                   help="CSV of contact telemetry in 1 ms frames per string (termination points "
                        "in contact, hammer force) and a summary (time in contact, episodes, "
                        "peak force)")
    n.add_argument("--hammer-log", metavar="OUT.csv",
                   help="CSV of the strike at the internal rate: time, force, felt compression, g, "
                        "hammer position")
    _add_threads(n)
    n.set_defaults(func=cmd_note)

    r = sub.add_parser("render", help="render a MIDI file with a preset to a WAV file",
                       description="Render a Standard MIDI File with a preset to a WAV file. On a "
                       "terminal, a render longer than 2 s shows a progress bar with the time left; "
                       "more than 30 min of audio is announced with a warning first. Ctrl-C stops "
                       "it and leaves no file (an existing one as it was).")
    r.add_argument("midi_file")
    r.add_argument("--preset", required=True)
    r.add_argument("--set", action="append", default=[], metavar="PATH=VALUE")
    r.add_argument("--internal-rate", type=float)
    r.add_argument("--rate", type=float, metavar="HZ",
                   help="output sample rate in Hz (default 48000; 44100, 88200, 96000, any "
                        "22050-192000)")
    _add_quality(r)
    r.add_argument("-o", "--output", required=True)
    r.add_argument("--pcm24", action="store_true")
    r.add_argument("--max-seconds", type=float, metavar="S",
                   help="render at most the first S seconds of audio (0 < S <= 21600): later notes "
                        "are left out, the sound is cut at S with a 10 ms fade-out")
    _add_channels(r)
    _add_mpe(r)
    _add_threads(r)
    r.set_defaults(func=cmd_render)

    a = sub.add_parser("analyze", help="partials, inharmonicity, T60s, centroid and loudness of a "
                       "note: a WAV file, or a preset's note rendered first")
    a.add_argument("target", metavar="AUDIO.wav|PRESET")
    a.add_argument("--key", type=int, help="MIDI key (a preset's note, or the expected pitch of a file)")
    a.add_argument("--f0", type=float, help="expected pitch in Hz instead of --key")
    a.add_argument("--velocity", type=int, default=100, help="MIDI velocity of the rendered note (1-127)")
    a.add_argument("--seconds", type=float, default=4.0, help="length rendered (s, default 4)")
    a.add_argument("--set", action="append", default=[], metavar="PATH=VALUE",
                   help="override a preset value (repeatable)")
    a.add_argument("--partials", type=int, default=12, help="partials to measure (1-64, default 12)")
    a.add_argument("--contacts", action="store_true",
                   help="a preset's note: also summarise its contacts per string (termination and "
                        "hammer: time in contact, episodes, peak force; over time in 10 ms frames)")
    a.add_argument("--json", action="store_true", help="print the report as JSON (docs/analyze.md)")
    a.add_argument("--plot", metavar="OUT.png", help="also draw a PNG (needs the [plots] extra)")
    a.set_defaults(func=cmd_analyze)

    c = sub.add_parser("check", help="spectrum tests: render what SPEC.toml names and check its "
                       "expectations (exit 1 if one fails)")
    c.add_argument("spec", nargs="*", help="spec files (TOML, docs/check.md)")
    c.add_argument("--shipped", action="store_true",
                   help="also run the specs shipped with the presets (synth/presets/checks)")
    c.add_argument("--junit", metavar="OUT.xml", help="also write the results as JUnit XML")
    _add_threads(c)
    c.set_defaults(func=cmd_check)

    fe = sub.add_parser("felt", help="the felt wave lab: dispersion, velocities, attenuation of "
                        "deformation waves in hammer felt (thesis chapter 2)")
    fe.add_argument("what", choices=("dispersion", "velocities", "attenuation", "pulse",
                                     "hammer"),
                    help="dispersion: omega and mu against a real wavenumber (initial value "
                         "problem); velocities: phase and group velocity, the negative-group-"
                         "velocity region; attenuation: a harmonic load's wave against its "
                         "frequency (boundary value problem); pulse: a pulse by finite "
                         "differences, linear or nonlinear; hammer: a grand key's hammer on a "
                         "rigid string, the lumped law against its felt solved as a layer")
    fe.add_argument("--preset", "--felt", dest="felt", metavar="NAME|key:N",
                    help="the felt: thesis (eqs. 2.12-2.13, the default), pub3 (Publication "
                         "III's), or key:N, the grand's hammer on MIDI key N (21-108; "
                         "linearised about its strain at 2 m/s for the linear tables); SI "
                         "columns are added; --gamma/--tau0-us set values by hand")
    fe.add_argument("--delta", metavar="D[,D...]",
                    help="the dimensionless model's delta = 1 - gamma alone (0 < value <= 1), "
                         "instead of a felt; a list draws one curve (or pulse) per value")
    fe.add_argument("--gamma", type=float, help="hereditary amplitude of the felt (0 <= value < 1)")
    fe.add_argument("--tau0-us", type=float, help="relaxation time of the felt, microseconds")
    fe.add_argument("--max", type=float, default=6.0,
                    help="largest wavenumber k (dispersion, velocities) or frequency omega "
                         "(attenuation), in the units of eq. 2.11 (default 6)")
    fe.add_argument("--points", type=int, default=25, help="rows (default 25)")
    fe.add_argument("--problem", choices=("bvp", "ivp"), default="bvp",
                    help="pulse: driven into the surface (bvp, eq. 2.28) or released from "
                         "A sech(alpha x) (ivp, eq. 2.29)")
    fe.add_argument("--p", metavar="P[,P...]", help="pulse: the felt's exponent p (1-5; "
                    "default 1, or the --preset's)")
    fe.add_argument("--amplitude", metavar="A[,A...]", default="0.1",
                    help="pulse: A, a strain (default 0.1); one of --delta, --p, --amplitude, "
                         "--t-m may be a list: one pulse per value, drawn together")
    fe.add_argument("--times", default="2,3,4", help="pulse: snapshot times (default 2,3,4; "
                    "0 is the initial state)")
    fe.add_argument("--scheme", choices=("fd", "fv"), default="fd",
                    help="pulse: finite differences (fd, Publication III's; a shock rings) or "
                         "shock-capturing finite volumes (fv; for p > 1 past the steepening)")
    fe.add_argument("--absolute", action="store_true",
                    help="pulse --plot: the strain itself and the crests' fitted exp(-lambda x) "
                         "(thesis Fig. 2.6), instead of each snapshot over its peak")
    fe.add_argument("--dx", type=float, default=0.005, help="pulse: grid step (default 0.005)")
    fe.add_argument("--units", choices=("tau0", "alpha0"), default="tau0",
                    help="pulse: eq. 2.27's units as printed (tau0, Publication III's numbers; "
                         "the default) or eq. 2.11's (alpha0)")
    fe.add_argument("--t-m", metavar="T[,T...]", default="0.5",
                    help="pulse bvp: the load's rise time t_m (default 0.5)")
    fe.add_argument("--alpha", type=float, default=3.0, help="pulse ivp: the sech's alpha")
    fe.add_argument("--velocity", default="2", metavar="V[,V...]",
                    help="hammer: the hammer's speed(s) in m/s (default 2)")
    fe.add_argument("--thickness-mm", type=float,
                    help="hammer: the felt layer's thickness (default: the key's, assumed)")
    fe.add_argument("--area-mm2", type=float,
                    help="hammer: the felt column's cross-section (default 64 mm^2, assumed)")
    fe.add_argument("--cells", type=int, default=32, help="hammer: the layer's grid (default 32)")
    fe.add_argument("--json", action="store_true", help="print JSON instead of a table")
    fe.add_argument("--plot", metavar="OUT.png", help="also draw a PNG (needs the [plots] extra)")
    fe.set_defaults(func=cmd_felt)

    b = sub.add_parser("batch", help="render a spec's notes, sweeps and MIDI files on every core "
                       "or a Dask cluster, with a Parquet manifest (needs the [batch] extra)")
    b.add_argument("spec", help="batch spec (.toml; docs/batch.md) or a shipped spec's name "
                   "(nsynth-small, grand-hardness, folk-tunes)")
    b.add_argument("-o", "--output", required=True, help="output directory (created; a second "
                   "run skips the jobs it finds finished)")
    b.add_argument("--scheduler", metavar="ADDRESS", help="an existing Dask scheduler, e.g. "
                   "tcp://HOST:8786 (default: a local cluster, one worker per core)")
    b.add_argument("--workers", type=int, help="workers of the local cluster (default: one per core)")
    b.add_argument("--csv", action="store_true", help="also write manifest.csv")
    b.add_argument("--dry-run", action="store_true", help="validate the spec and list its jobs, "
                   "render nothing")
    b.set_defaults(func=cmd_batch)

    pl = sub.add_parser("play", help="play a preset live from a MIDI keyboard (needs the [live] extra)")
    pl.add_argument("--preset", help="preset played first (program 0), see `synth presets`")
    pl.add_argument("--midi-port", metavar="NAME",
                    help="MIDI input port: exact name or part of it (default: the first keyboard)")
    pl.add_argument("--audio-device", metavar="NAME",
                    help="audio output device: index, exact name or part of it (default: the system's)")
    pl.add_argument("--midi-api", choices=("auto", "alsa", "jack"),
                    help="the MIDI system --midi-port is on: the ALSA sequencer or JACK MIDI "
                         "(default auto: JACK when a JACK server runs, else ALSA)")
    pl.add_argument("--block", type=int, default=128,
                    help="audio block in samples at the output rate (default 128 = 2.7 ms at "
                         "48 kHz)")
    pl.add_argument("--rate", type=float, metavar="HZ",
                    help="output rate in Hz: 44100, 48000, 88200 or 96000 (any 22050-192000); "
                         "the decimator is designed for it (default 48000, or the device's own "
                         "rate when it cannot play 48 kHz)")
    pl.add_argument("--latency-ms", type=float, metavar="X",
                    help="delay from key to stream in ms, at least one block (default: two blocks)")
    pl.add_argument("--program-map", metavar="P=PRESET,...",
                    help="presets for MIDI program changes, e.g. 0=grand-piano,1=sitar,24=biwa "
                         "(programs 0-127; default: 0=the --preset)")
    pl.add_argument("--set", action="append", default=[], metavar="PATH=VALUE",
                    help="override a value of --preset, e.g. --set play.polyphony=32 "
                         "(repeatable)")
    _add_quality(pl)
    _add_channels(pl)
    _add_mpe(pl)
    pl.add_argument("--jack", action="store_true",
                    help="play as a JACK client (jackd, or PipeWire's JACK): a MIDI input port "
                         "and the audio outputs, every MIDI event on its frame; the server's "
                         "rate and period are played at and may change while playing")
    pl.add_argument("--jack-name", default="synth", metavar="NAME",
                    help="the JACK client's name (default: synth)")
    pl.add_argument("--connect", action="store_true",
                    help="with --jack: connect the outputs to the system's playback ports and "
                         "the first physical MIDI capture port to the input")
    pl.add_argument("--reconnect", action="store_true",
                    help="with --jack: when the server stops, wait for it and play on "
                         "(default: say so and exit with status 1)")
    pl.add_argument("--record", metavar="OUT.wav",
                    help="also write the performance, as it goes to the device, to a WAV file "
                         "(32-bit float; complete whatever stops the play)")
    pl.add_argument("--seconds", type=float, metavar="S",
                    help="stop after S seconds and print the report (default: play until Ctrl-C)")
    pl.add_argument("--stats", action="store_true",
                    help="show block time, voices and underruns once a second, and the "
                         "latest note's contacts per string (hammer, termination)")
    pl.add_argument("--list-ports", action="store_true",
                    help="list MIDI input ports (ALSA and JACK) and audio output devices, then "
                         "exit")
    _add_threads(pl)
    pl.set_defaults(func=cmd_play)

    c = sub.add_parser(
        "compare", help="compare presets or WAV files by ear: A/B, blind ABX and MUSHRA in one web page",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Render each stimulus (one note, or a MIDI file), match their loudness "
                    "(ITU-R BS.1770 integrated, within 0.1 LU, no sample peak above -1 dBFS) and "
                    "write DIR/index.html: one self-contained page (A/B switching at the same "
                    "playhead with a loop region, blind ABX with exact binomial p-values, MUSHRA "
                    "with a hidden reference and a 3.5 kHz anchor for three or more stimuli, then "
                    "the reveal: names, loudness, analysis, spectrograms; results as CSV and JSON) "
                    "and the matched audio beside it as 32-bit float WAV files.",
        epilog="stimuli:\n"
               "  grand-piano                          a preset (name or .toml path)\n"
               "  'grand-piano:strings.t60_scale=2,tuning.stretch=0'\n"
               "                                       a preset with --set style overrides,\n"
               "                                       comma-separated (commas inside [...] kept)\n"
               "  take1.wav                            a WAV file (mono; more channels are\n"
               "                                       averaged; resampled to 48 kHz)\n"
               "\n"
               "example:\n"
               "  synth compare grand-piano 'grand-piano:tuning.stretch=0' harpsichord \\\n"
               "      --key 60 --seconds 3 -o cmp && open cmp/index.html\n"
               "  synth compare -o cmp --serve      # serve it; answers go to cmp/answers.csv")
    c.add_argument("stimuli", nargs="*", metavar="STIMULUS",
                   help="2-12 presets (PRESET or PRESET:PATH=VALUE,...) or WAV files")
    c.add_argument("--midi", metavar="FILE", help="render this MIDI file with every preset "
                   "(instead of one note)")
    c.add_argument("--key", type=int, help="MIDI key of the note (musical presets need it)")
    c.add_argument("--velocity", type=int, help="MIDI velocity 1-127 (default 100)")
    c.add_argument("--seconds", type=float, help="length of the note in seconds (default 3)")
    c.add_argument("--lufs", type=float, metavar="X", help="match to X LUFS (e.g. -23), lowered "
                   "further if a peak would exceed -1 dBFS (default: the quietest stimulus)")
    c.add_argument("--trials", type=int, default=10, help="ABX trials (default 10)")
    c.add_argument("-o", "--output", required=True, metavar="DIR",
                   help="new or empty directory for index.html and the WAV files")
    c.add_argument("--serve", action="store_true", help="then serve DIR on 127.0.0.1 and append "
                   "the answers the page posts to DIR/answers.csv (Ctrl-C stops); without "
                   "stimuli, serve an existing DIR")
    c.add_argument("--port", type=int, help="port for --serve (default 8765; 0: any free port)")
    _add_threads(c)
    c.set_defaults(func=cmd_compare)
    return p


def _numbers(text, option: str, example: str) -> tuple | None:
    """A comma-separated list of numbers from the command line (None: not given)."""
    if text is None:
        return None
    try:
        return tuple(float(v) for v in str(text).split(","))
    except ValueError:
        _fail(f"{option} = {text!r} is not a list of numbers (e.g. {example})")


def cmd_felt(args) -> int:
    """The felt wave lab's tables (synth.apps.felt)."""
    import json

    from .apps.felt import format_table, make_requests, plot_table, table

    if args.plot is not None:
        _check_output(args.plot, "--plot")
    deltas = _numbers(args.delta, "--delta", "0.5 or 0.15,0.2,0.5")
    if args.what == "hammer":
        from .apps.felt import HammerRequest, format_hammer, hammer_table, plot_hammer

        vs = _numbers(args.velocity, "--velocity", "0.5,2,5")
        if deltas is not None:
            _fail("hammer takes --preset key:N, not --delta")
        t = hammer_table(HammerRequest(args.felt or "key:60", vs, args.thickness_mm,
                                       args.area_mm2, args.gamma,
                                       None if args.tau0_us is None else args.tau0_us * 1e-6,
                                       args.cells))
        strikes = t.pop("_strikes")
        print(json.dumps(t, indent=1) if args.json else format_hammer(t))
        if args.plot is not None:
            t["_strikes"] = strikes
            plot_hammer(t, args.plot)
        return 0
    if args.what == "pulse":
        from .apps.felt import (format_pulse, make_pulse_requests, plot_pulse, preset_felt,
                                pulse_table)

        times = _numbers(args.times, "--times", "2,3,4")
        ps = _numbers(args.p, "--p", "1.3,2")
        amps = _numbers(args.amplitude, "--amplitude", "0.2,0.02")
        t_ms = _numbers(args.t_m, "--t-m", "1,0.5")
        if args.gamma is not None or args.tau0_us is not None:
            _fail("pulse takes --delta (the dimensionless model) or --preset, not "
                  "--gamma/--tau0-us")
        if args.felt is not None and deltas is not None:
            _fail("pulse takes --delta or --preset, not both")
        if args.felt is not None:
            deltas = (preset_felt(args.felt).delta,)   # (a key's: its delta; its p unless --p)
            if ps is None and args.felt.startswith("key:"):
                from .physics.felt import felt_for_key

                ps = (felt_for_key(int(args.felt[4:])).felt.exponent,)
        ts = [pulse_table(r) for r in make_pulse_requests(
            args.problem, deltas or (0.5,), ps or (1.0,), amps, times, args.dx, args.units,
            t_ms, args.alpha, args.scheme)]
        rs = [t.pop("_result") for t in ts]
        if args.json:
            print(json.dumps(ts[0] if len(ts) == 1 else ts, indent=1))
        else:
            print("\n\n".join(format_pulse(t) for t in ts))
        if args.plot is not None:
            for t, r in zip(ts, rs):
                t["_result"] = r
            plot_pulse(ts, args.plot, absolute=args.absolute)
        return 0
    reqs = make_requests(args.what, args.felt, deltas, args.gamma,
                         None if args.tau0_us is None else args.tau0_us * 1e-6, args.max,
                         args.points)
    ts = [table(r) for r in reqs]
    if args.json:
        print(json.dumps(ts[0] if len(ts) == 1 else ts, indent=1))
    else:
        print("\n\n".join(format_table(t) for t in ts))
    if args.plot is not None:
        from dataclasses import replace

        # the curves finely, whatever the table's rows
        plot_table([table(replace(r, points=1000)) for r in reqs], args.plot)
    return 0


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        if getattr(args, "threads", None) is not None:
            from .io.factory import set_default_threads

            set_default_threads(args.threads)
        return int(args.func(args) or 0)
    except SynthError as e:
        print(f"synth: error: {e}", file=sys.stderr)
        return 2
    except (OSError, ValueError) as e:
        print(f"synth: error: {e}", file=sys.stderr)
        return 2
    except Interrupted as e:                 # SIGINT or SIGTERM (synth.io.interrupt)
        print(f"synth: {e}", file=sys.stderr)
        return e.exit_status
    except KeyboardInterrupt:
        print("synth: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
