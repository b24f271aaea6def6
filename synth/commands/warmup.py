"""`synth warmup`: compile the numba kernels for this CPU ahead of time.

The first ``synth note``, ``render`` or ``play`` on a machine (and the first
after an update of ``synth/kernels``) compiles the string kernels, a minute
or more; ``synth warmup`` does it beforehand (a studio machine before a
concert, an image being built): each preset's engine plays a short phrase
that takes it through the paths a performance uses
(:func:`synth.apps.warmup.warm_presets`), in one process per core at once
(``--jobs``).  What numba compiles stays in its cache
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
          "  synth warmup --jobs 1                 # in this process only (default: one process a core)\n"
          "\n"
          "Run again on a warm cache, it compiles nothing and says so.  Where the kernels are\n"
          "kept: synth.kernels.cache_dir() (NUMBA_CACHE_DIR if set).")


def add_arguments(parser) -> None:
    parser.add_argument("--presets", metavar="LIST",
                        help="comma-separated presets to warm (default: every musical preset; "
                             "'all': every preset found, the study presets too)")
    parser.add_argument("--jobs", type=int, metavar="N",
                        help="worker processes compiling at once, all into the one cache (default: "
                             "one per core; 1: in this process)")
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


def run(args) -> int:
    from ..apps.check import check_jobs
    from ..apps.warmup import n_tasks, ordered, warm_presets
    from ..dsp import compile_notice
    from ..dsp.threads import available_cores

    names = ordered(_presets(args.presets))
    if args.jobs is None:
        jobs = available_cores()
    else:
        try:
            jobs = check_jobs(args.jobs, "--jobs")
        except ValueError as e:
            fail(f"warmup: {e}")
    total = n_tasks(names, jobs)           # parts: one per preset, or the rounds' (jobs > 1)
    t0 = time.perf_counter()
    tty = sys.stderr.isatty()
    bar = None
    if tty:
        try:
            from tqdm import tqdm

            bar = tqdm(total=total, desc="synth warmup", unit=" parts",
                       file=sys.stderr, leave=False)
        except ImportError:
            bar = None
    count = [0]

    def done(w):
        count[0] += 1
        what = w.preset if w.part == "all" else f"{w.preset} {w.part}"
        if bar is not None:
            bar.set_postfix_str(what)
            bar.update(1)
        else:
            print(f"warmup: {what} ({count[0]}/{total}) {w.seconds:.1f} s",
                  file=sys.stderr, flush=True)

    if jobs > 1:
        # the workers compile; this process only waits: no compile notice here
        compile_notice.disarm()
    try:
        warmed = warm_presets(names, jobs, args.threads, done=done)
    except ValueError as e:
        fail(f"warmup: {e}")
    finally:
        if bar is not None:
            bar.close()
    el = time.perf_counter() - t0
    n = sum(w.compiled for w in warmed)
    if n == 0:
        print(f"warmup: the kernels were already compiled for this CPU: nothing to do "
              f"({len(names)} presets checked in {el:.1f} s)")
    else:
        how = f" in {min(jobs, total)} processes at once" if jobs > 1 else ""
        print(f"warmup: compiled {n} kernels for this CPU{how} in {el:.1f} s "
              f"({sum(w.compile_s for w in warmed):.1f} s of compiling, {len(names)} presets); "
              f"the next notes start without compiling")
    return 0
