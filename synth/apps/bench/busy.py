"""Offline renders while other programs keep the cores busy: one thread, the
threads as the bank's governor uses them, and the threads on every call.

Usage:  python tools/bench.py busy [--busy 0,2] [--scenes drone,grand,sitar]
                                   [--repeats 5] [--quick] [--cpu-name ...]

For each count K of ``--busy``, K processes spinning a Python loop run beside
the measure (0: a quiet machine).  Each scene renders in ``synth render``'s
1024-sample blocks, on a fresh engine each time (its kernels loaded first,
untimed), three ways alternated round by round: ``1 thread``; ``governed``:
every core (:func:`synth.dsp.threads.default_threads`) with the bank's
:class:`~synth.dsp.threads.Governor` choosing, call by call, the threads or
the calling thread by their times (what ``synth`` does); ``always``: every
core on every call (``Governor.auto = False``, how the bank ran before the
governor).  Wall seconds, medians (min-max) over ``--repeats``, and the
governor's calls on one thread and on the threads in its last round.

Scenes: ``drone``, the tanpura's drone (4 strings, Sa 49) for 10 s;
``grand``, an eight-note chord (C2-C6, velocity 100, pedal down) for 4 s;
``sitar``, an eight-note sitar chord (its bridge in blocks) for 4 s.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time

from synth.apps.bench import harness

SCENES = ("drone", "grand", "sitar")


def _scene(name: str, quick: bool):
    from synth.engine.engine import Event

    if name == "drone":
        return "tanpura", [Event(0.0, "note_on", 49, 0.8)], 3.0 if quick else 10.0
    if name == "grand":
        keys = (36, 43, 48, 55, 60, 64, 67, 84)
        return ("grand-piano", [Event(0.0, "control", 64, 1.0)]
                + [Event(0.0, "note_on", k, 100 / 127) for k in keys], 1.0 if quick else 4.0)
    if name == "sitar":
        keys = (43, 50, 55, 57, 62, 67, 69, 74)
        return "sitar", [Event(0.0, "note_on", k, 100 / 127) for k in keys], 1.0 if quick else 4.0
    raise ValueError(f"scene = {name!r} is not one of {', '.join(SCENES)}")


def _way(preset, events, seconds, n_threads, auto):
    from synth.dsp import threads
    from synth.io.factory import build_engine

    last = {}

    def run() -> float:
        eng = build_engine(preset, (), threads=n_threads)
        eng.bank.load_kernels()
        saved = threads.Governor.auto
        threads.Governor.auto = auto
        try:
            t0 = time.perf_counter()
            eng.render(events, duration_s=seconds, block=1024)
            dt = time.perf_counter() - t0
        finally:
            threads.Governor.auto = saved
        last["calls"] = list(eng.bank.governor.calls)
        return dt
    return run, last


def _spin(k: int):
    return [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(k)]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="bench.py busy", description=__doc__.split("\n\n")[0])
    ap.add_argument("--busy", default="0,2", help="comma list of busy processes beside the "
                    "measure (default 0,2)")
    ap.add_argument("--scenes", default=",".join(SCENES), help="comma list of "
                    f"{', '.join(SCENES)} (default all)")
    ap.add_argument("--repeats", type=int, default=5, help="rounds (default 5)")
    ap.add_argument("--quick", action="store_true", help="short scenes, 2 rounds (CI)")
    harness.add_target_option(ap)
    args = ap.parse_args(argv)
    rc = harness.dispatch("busy", args.cpu_name, argv)
    if rc is not None:
        return rc
    try:
        busy = [int(x) for x in args.busy.split(",") if x.strip()]
        if not busy or min(busy) < 0:
            raise ValueError
    except ValueError:
        ap.error(f"--busy = {args.busy!r}: give counts >= 0, comma-separated")
    scenes = [s.strip() for s in args.scenes.split(",") if s.strip()]
    for s in scenes:
        if s not in SCENES:
            ap.error(f"--scenes: {s!r} is not one of {', '.join(SCENES)}")
    repeats = 2 if args.quick else args.repeats
    if repeats < 1:
        ap.error(f"--repeats = {repeats}: must be >= 1")
    from synth.dsp import threads

    nt = threads.default_threads()
    print(harness.header())
    print(harness.command_line("busy", sys.argv[2:] if argv is None else argv))
    print(f"# every core: {nt} threads; wall s, median (min-max) of {repeats}")
    print("| busy processes | scene | 1 thread | governed | always | governed: calls on 1 / on "
          f"{nt} |")
    print("|---|---|---|---|---|---|")
    for k in busy:
        for s in scenes:
            preset, events, seconds = _scene(s, args.quick)
            ways, lasts = {}, {}
            for name, n, auto in (("1 thread", 1, True), ("governed", nt, True),
                                  ("always", nt, False)):
                ways[name], lasts[name] = _way(preset, events, seconds, n, auto)
                ways[name]()                 # untimed: kernels and designs loaded first
            procs = _spin(k)
            try:
                time.sleep(0.2 if k else 0.0)
                res = harness.alternate(ways, repeats)
            finally:
                for p in procs:
                    p.kill()
                for p in procs:
                    p.wait()
            cells = []
            for name in ways:
                med, lo, hi = harness.summary(res[name])
                cells.append(f"{med:.2f} ({lo:.2f}-{hi:.2f})")
            c = lasts["governed"].get("calls", [0, 0])
            print(f"| {k} | {s} {seconds:g} s | " + " | ".join(cells) + f" | {c[0]} / {c[1]} |",
                  flush=True)
    return 0
