"""`synth warmup`: compile the numba kernels for this CPU ahead of time.

The first ``synth note``, ``render`` or ``play`` on a machine (and the first
after an update of ``synth/kernels``) compiles the string kernels, a minute
or more; ``synth warmup`` does it beforehand (a studio machine before a
concert, an image being built): each preset's engine plays a short phrase
that takes it through the paths a performance uses (several notes at once,
one alone, a restrike, the pedals, a bend: :func:`synth.engine.warm.warm_phrase`),
on a throwaway engine.  What numba compiles stays in its cache
(:mod:`synth.kernels.cache`); run again on a warm cache it loads the
kernels, compiles nothing, and says so.
"""

from __future__ import annotations

import sys
import time

from .common import add_threads, fail

NAME = "warmup"
HELP = "compile the kernels for this CPU now, so that the first note starts at once"
EPILOG = ("examples:\n"
          "  synth warmup                          # every musical preset's paths, with a progress bar\n"
          "  synth warmup --presets sitar,biwa     # only these\n"
          "  synth warmup --presets all            # the study presets too\n"
          "\n"
          "Run again on a warm cache, it compiles nothing and says so.  Where the kernels are\n"
          "kept: synth.kernels.cache_dir() (NUMBA_CACHE_DIR if set).")


def add_arguments(parser) -> None:
    parser.add_argument("--presets", metavar="LIST",
                        help="comma-separated presets to warm (default: every musical preset; "
                             "'all': every preset found, the study presets too)")
    add_threads(parser)


def _presets(text):
    from ..io.presets import list_presets, load_preset

    names = [n for n, _ in list_presets()]
    if text is None or text == "all":
        if text is None:
            names = [n for n in names if load_preset(n).kind == "musical"]
        return names
    chosen = [p.strip() for p in text.split(",") if p.strip()]
    if not chosen:
        fail(f"--presets = {text!r}: give at least one preset")
    return chosen


def _warm(name: str, threads) -> None:
    from ..engine.warm import warm_phrase
    from ..io.factory import build_engine

    eng = build_engine(name, (), extra_low_key=0, threads=threads)
    # the kernel of every scene (what live play and several notes run), then
    # the narrower ones a phrase takes (what a single note runs offline)
    eng.bank.load_kernels()
    eng.render(warm_phrase(eng.inst), duration_s=0.06)


def run(args) -> int:
    from ..dsp import compile_notice

    names = _presets(args.presets)
    t0 = time.perf_counter()
    c0 = compile_notice.kernels_compiled() if compile_notice._state["listening"] else 0
    tty = sys.stderr.isatty()
    bar = None
    if tty:
        try:
            from tqdm import tqdm

            bar = tqdm(names, desc="synth warmup", unit=" presets", file=sys.stderr, leave=False)
        except ImportError:
            bar = None
    it = bar if bar is not None else names
    for i, name in enumerate(it):
        if bar is not None:
            bar.set_postfix_str(name)
        t = time.perf_counter()
        _warm(name, args.threads)
        if bar is None:
            print(f"warmup: {name} ({i + 1}/{len(names)}) {time.perf_counter() - t:.1f} s",
                  file=sys.stderr, flush=True)
    if bar is not None:
        bar.close()
    el = time.perf_counter() - t0
    n = compile_notice.kernels_compiled() - c0
    if n == 0:
        print(f"warmup: the kernels were already compiled for this CPU: nothing to do "
              f"({len(names)} presets checked in {el:.1f} s)")
    else:
        print(f"warmup: compiled {n} kernels for this CPU in {compile_notice.compile_seconds():.1f} s "
              f"({len(names)} presets, {el:.1f} s in all); the next notes start without compiling")
    return 0
