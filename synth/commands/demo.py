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
BEAT_S = 60.0 / 96.0   # 96 beats a minute


def add_arguments(parser) -> None:
    parser.add_argument("-o", "--output", default="demo.wav", metavar="OUT.wav",
                        help="output audio file, its format by extension: .wav, .flac or .ogg "
                             "(default %(default)s)")
    add_threads(parser)


def _events(phrase, beat):
    from ..engine.engine import Event

    evs = []
    for b, key, dur, vel in phrase:
        evs.append(Event(b * beat, "note_on", key, vel / 127.0))
        evs.append(Event((b + dur) * beat, "note_off", key, 0.0))
    return evs


def _render(name: str, threads: int | None = None):
    """One preset's phrase: (samples, fs, seconds rendering, seconds compiling).
    ``threads``: set in a worker process (as ``--threads`` sets it in this one)."""
    import time

    from ..dsp.compile_notice import compile_seconds

    if threads is not None:
        from ..io.factory import set_default_threads
        set_default_threads(threads)
    t0, c0 = time.perf_counter(), compile_seconds()
    _, _, eng = engine_for(name, ())
    y = eng.render(_events(DEMO_PHRASES[name], BEAT_S), tail_s=0.2, max_tail_s=2.0)
    comp = compile_seconds() - c0
    return y, eng.fs_out, time.perf_counter() - t0 - comp, comp


def _other_process(threads: int | None) -> bool:
    """Whether to render the phrases after the first in a second process:
    only when the kernels are not compiled yet (numba compiles on the
    calling thread, one function after another, so a cold demo keeps one
    core busy; the sitar's bridge and the biwa's lone strings compile
    mostly different kernels, each on its own core) and the demo may use
    two threads or more (``--threads``; default: every core this process
    may use).  On a warm cache a second process would only add its
    start-up."""
    from ..dsp.compile_notice import cache_looks_warm
    from ..dsp.threads import resolve

    return resolve(threads) >= 2 and not cache_looks_warm()


def run(args) -> int:
    import time

    import numpy as np

    from ..dsp.compile_notice import timing_note
    from ..dsp.threads import resolve

    check_output(args.output, "-o")
    fmt = audio_format(args.output, "-o")
    t0 = time.perf_counter()
    names = list(DEMO_PHRASES)
    results = {}
    if len(names) > 1 and _other_process(args.threads):
        # (spawn, not fork: numba's threads and locks; each process on half
        # the threads: the samples are the same for any thread count)
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        half = max(1, resolve(args.threads) // 2)
        with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as ex:
            later = {n: ex.submit(_render, n, half) for n in names[1:]}
            results[names[0]] = _render(names[0])
            for n, f in later.items():
                results[n] = f.result()
    else:
        for n in names:
            results[n] = _render(n)
    wall = time.perf_counter() - t0
    el = sum(r[2] for r in results.values())
    parts = []
    fs = 48_000
    for n in names:
        y, fs = results[n][0], results[n][1]
        parts += [y, np.zeros(int(0.5 * fs))]
    # the compile's share of the wall time (its processes overlap)
    comp = wall - el if any(r[3] > 0 for r in results.values()) else 0.0
    audio = np.concatenate(parts)
    out = Path(args.output).resolve()
    info = write_audio(str(out), audio, fs, False, fmt)
    print(f"demo: {len(audio) / fs:.1f} s ({', '.join(DEMO_PHRASES)} phrases), {info}, "
          f"rendered in {el:.2f} s{timing_note(comp)}")
    print(f"wrote {out}")
    return 0
