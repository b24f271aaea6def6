"""The benchmarks, one harness (:mod:`synth.apps.bench.harness`): run as
``python tools/bench.py NAME [options]`` (or ``python -m synth.apps.bench
NAME ...``); ``python tools/bench.py`` alone lists them.

Each benchmark is a module here with ``main(argv) -> int``; it prints the
harness's header (CPU, code target, software), takes ``--cpu-name`` (one
target, a comma list, or all: each re-runs in a subprocess with its own
``NUMBA_CACHE_DIR``) where code generation matters, and reports medians of
repeats run in turn.  docs/benchmarks.md gives each one's command and its
latest figures.

Importing this package imports neither numpy nor numba: a benchmark may set
``NUMBA_NUM_THREADS`` before numba starts.
"""

from __future__ import annotations

import importlib
import sys

#: name -> (module, what it measures); the order of ``tools/bench.py``'s list
BENCHMARKS: dict[str, tuple[str, str]] = {
    "strings": ("strings", "the string bank kernel, ns per string-sample, per code target"),
    "grand": ("grand", "grand-piano notes and a pedalled chord against real time"),
    "render": ("render", "synth render per voice per internal sample; --threads: scaling"),
    "live": ("live", "the live callback per block against its budget; --jack: latency"),
    "batch": ("batch", "batch rendering's throughput and Dask's overhead"),
    "taraf": ("taraf", "the sitar's taraf and chikari against a bare note"),
    "ab": ("ab", "one preset change, A against B, paired per run"),
    "heads": ("heads", "the far end's loop-filter variants of the grand"),
    "reach": ("reach", "what skipping an out-of-reach termination saves (--callgrind: instructions)"),
    "decimator": ("decimator", "the streaming decimator, ns per output sample"),
    "body": ("body", "the soundboard body's cost per output sample, through its wrapper"),
    "listener": ("listener", "the listening position's stage, alone and in the grand, live and offline"),
    "busy": ("busy", "offline renders beside busy processes: 1 thread, governed, always threaded"),
    "startup": ("startup", "live play's start-up: import, build and warm the engine"),
    "compile": ("compile", "which kernels a synth command compiles, and what each costs"),
    "callgrind": ("callgrind", "one grand note's instructions per numba function (valgrind)"),
}


def usage() -> str:
    w = max(map(len, BENCHMARKS))
    rows = "\n".join(f"  {k:<{w}}  {what}" for k, (_, what) in BENCHMARKS.items())
    return ("usage: python tools/bench.py NAME [options]   (NAME --help: its options)\n\n"
            f"benchmarks:\n{rows}")


def main(argv=None, synth_main=None) -> int:
    """Run benchmark ``argv[0]`` with the rest of ``argv`` (``synth_main``:
    ``synth.cli.main``, for ``compile``, which profiles a synth command;
    ``tools/bench.py`` hands it in)."""
    argv = sys.argv[1:] if argv is None else list(argv)
    if not argv or argv[0] in ("-h", "--help"):
        print(usage())
        return 0
    name, rest = argv[0], argv[1:]
    if name not in BENCHMARKS:
        print(f"bench: NAME = {name!r} is not a benchmark; one of: {', '.join(BENCHMARKS)}",
              file=sys.stderr)
        return 2
    mod = importlib.import_module(f"synth.apps.bench.{BENCHMARKS[name][0]}")
    rc = mod.main(rest, synth_main) if name == "compile" else mod.main(rest)
    return int(rc or 0)
