"""Which numba kernels a ``synth`` command compiles, and what each costs.

    NUMBA_CACHE_DIR=$(mktemp -d) python tools/bench.py compile note sitar --key 57 \
        --seconds 1 -o /tmp/x.wav [--top 25] [--json OUT.json]

Runs the command in this process (``synth.cli.main``, which
``tools/bench.py`` hands in: the package's apps do not import the command
line above them) with a listener on
numba's ``numba:compile`` event (one event per function and signature that
numba compiles, i.e. did not find in its cache) and on ``numba:llvm_lock``
(LLVM's share).  Compiles nest: a caller's type inference compiles its
callees inside its own event, so each row gives

* *inclusive*: CPU seconds (``time.process_time``) from the start to the end
  of the function's compile, its callees' compiles included;
* *exclusive*: inclusive less the callees' inclusive times (what compiling
  this one function cost: its typing, lowering and LLVM's optimisation of
  its library, into which its callees' code is linked, and inlined where
  LLVM chooses);
* *llvm*: the part of exclusive spent holding numba's LLVM lock.

A function compiled twice (two rows of one name) was typed with two
signatures, often a ``Literal[int]`` copy (see ``synth.kernels.render.ZERO``).

Use an empty ``NUMBA_CACHE_DIR`` for a cold compile; the machine's load
inflates wall time, so the table is in CPU seconds.
"""

from __future__ import annotations

import argparse
import json
import sys
import time


def _name(disp) -> str:
    f = disp.py_func
    return f"{f.__module__.rsplit('.', 1)[-1]}.{f.__qualname__}"


class Recorder:
    def __init__(self):
        self.stack = []          # [name, t0, child_time, llvm_time]
        self.rows = []           # dicts
        self.llvm_t0 = None

    def compile_start(self, data):
        self.stack.append([_name(data["dispatcher"]), time.process_time(), 0.0, 0.0,
                           time.perf_counter()])

    def compile_end(self, data):
        name, t0, child, llvm, w0 = self.stack.pop()
        inc = time.process_time() - t0
        self.rows.append(dict(name=name, inclusive=inc, exclusive=inc - child, llvm=llvm,
                              wall=time.perf_counter() - w0, depth=len(self.stack),
                              args=str(data.get("args"))[:60]))
        if self.stack:
            self.stack[-1][2] += inc

    def llvm(self, dur):
        if self.stack:
            self.stack[-1][3] += dur


def install(rec: Recorder):
    from numba.core import event as ev

    class L(ev.Listener):
        def on_start(self, event):
            rec.compile_start(event.data)

        def on_end(self, event):
            rec.compile_end(event.data)

    ev.register("numba:compile", L())
    ev.register("numba:llvm_lock", _LLVM(rec))


def _LLVM(rec):
    from numba.core import event as ev

    class T(ev.Listener):
        def on_start(self, event):
            self.t = time.process_time()

        def on_end(self, event):
            rec.llvm(time.process_time() - self.t)

    return T()


def main(argv=None, synth_main=None) -> int:
    """Profile ``synth ARGV`` run by ``synth_main`` (``synth.cli.main``)."""
    if synth_main is None:
        raise SystemExit("bench compile: run it as python tools/bench.py compile COMMAND ... "
                         "(it profiles the synth command line)")
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--top", type=int, default=30)
    ap.add_argument("--json", help="write every row as JSON here")
    a, rest = ap.parse_known_args(argv)
    rec = Recorder()
    install(rec)
    t0, w0 = time.process_time(), time.perf_counter()
    rc = synth_main(rest)
    cpu, wall = time.process_time() - t0, time.perf_counter() - w0
    rows = sorted(rec.rows, key=lambda r: -r["exclusive"])
    tot = sum(r["exclusive"] for r in rows)
    top = sum(r["inclusive"] for r in rows if r["depth"] == 0)
    print(f"# synth {' '.join(rest)}: {len(rows)} compiles, {tot:.1f} CPU s compiling "
          f"(top-level inclusive {top:.1f}); process {cpu:.1f} CPU s, {wall:.1f} s wall",
          file=sys.stderr)
    print("| function | inclusive (CPU s) | exclusive (CPU s) | share | LLVM (CPU s) | depth |",
          file=sys.stderr)
    print("|---|---|---|---|---|---|", file=sys.stderr)
    for r in rows[:a.top]:
        print(f"| {r['name']} | {r['inclusive']:.2f} | {r['exclusive']:.2f} | "
              f"{100 * r['exclusive'] / max(tot, 1e-9):.1f} % | {r['llvm']:.2f} | {r['depth']} |",
              file=sys.stderr)
    if a.json:
        with open(a.json, "w") as f:
            json.dump(dict(cmd=rest, cpu=cpu, wall=wall, rows=rec.rows), f, indent=1)
    return rc

