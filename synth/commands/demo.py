"""`synth demo`: a short phrase on each plucked preset, into one WAV file."""

from __future__ import annotations

from pathlib import Path

from .common import add_threads, audio_format, check_output, engine_for, write_audio

NAME = "demo"
HELP = "render a short phrase on each plucked preset to demo.wav"
EPILOG = ("examples:\n"
          "  synth demo                   # demo.wav: a phrase on the sitar, then on the biwa\n"
          "  synth demo -o demo.flac      # the same as FLAC (.wav, .flac or .ogg)")

DEMO_PHRASES = {
    # (start beat, key, beats, velocity)
    "sitar": [(0, 50, 1, 110), (1, 52, 1, 90), (2, 54, 1, 95), (3, 57, 2, 120),
              (5, 55, 0.5, 85), (5.5, 54, 0.5, 80), (6, 52, 1, 95), (7, 50, 3, 115)],
    "biwa": [(0, 52, 1.5, 120), (1.5, 53, 0.5, 80), (2, 57, 1, 100), (3, 59, 1, 95),
             (4, 60, 2, 125), (6, 57, 1, 90), (7, 52, 3, 120)],
}


def add_arguments(parser) -> None:
    parser.add_argument("-o", "--output", default="demo.wav", metavar="OUT.wav",
                        help="output audio file, its format by extension: .wav, .flac or .ogg "
                             "(default %(default)s)")
    add_threads(parser)


def run(args) -> int:
    import time

    import numpy as np

    from ..dsp.compile_notice import compile_seconds, timing_note
    from ..engine.engine import Event

    check_output(args.output, "-o")
    fmt = audio_format(args.output, "-o")
    t0, c0 = time.perf_counter(), compile_seconds()
    bpm = 96.0
    beat = 60.0 / bpm
    parts = []
    fs = 48_000
    for name, phrase in DEMO_PHRASES.items():
        _, _, eng = engine_for(name, ())
        evs = []
        for b, key, dur, vel in phrase:
            evs.append(Event(b * beat, "note_on", key, vel / 127.0))
            evs.append(Event((b + dur) * beat, "note_off", key, 0.0))
        y = eng.render(evs, tail_s=0.2, max_tail_s=2.0)
        parts += [y, np.zeros(int(0.5 * fs))]
        fs = eng.fs_out
    comp = compile_seconds() - c0
    el = time.perf_counter() - t0 - comp
    audio = np.concatenate(parts)
    out = Path(args.output).resolve()
    info = write_audio(str(out), audio, fs, False, fmt)
    print(f"demo: {len(audio) / fs:.1f} s ({', '.join(DEMO_PHRASES)} phrases), {info}, "
          f"rendered in {el:.2f} s{timing_note(comp)}")
    print(f"wrote {out}")
    return 0
