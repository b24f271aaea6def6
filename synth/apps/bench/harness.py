"""The one harness of the benchmarks (``python tools/bench.py NAME ...``).

Every benchmark of :mod:`synth.apps.bench` uses it for the four things they
share:

* the header: the CPU, numba's code-generation target in effect and the
  software (:func:`header`, from :func:`synth.apps.cpu_target.describe`),
  and the command that printed it (:func:`command_line`);
* code targets: ``--cpu-name host,haswell,generic`` (or ``all``) re-runs the
  benchmark once per target in a subprocess with that target's environment,
  each target compiling into its own ``NUMBA_CACHE_DIR``
  (:func:`add_target_option`, :func:`dispatch`; the targets are described in
  :mod:`synth.apps.cpu_target`);
* alternation: the ways being compared run in turn within each repeat, so
  that a machine's drift (other processes, the clock) falls on all of them
  alike (:func:`alternate`);
* medians: a figure is the median of its repeats, with their range
  (:func:`summary`).
"""

from __future__ import annotations

import os
import shlex
import statistics
import subprocess
import sys
from pathlib import Path
from typing import Callable, Iterable, Mapping

from synth.apps import cpu_target

#: the code targets ``--cpu-name`` accepts (besides "all" and comma lists)
TARGETS = cpu_target.TARGETS


def header(prefix: str = "# ") -> str:
    """The benchmark header: CPU, code target in effect, software."""
    return cpu_target.describe(prefix)


def command_line(name: str, argv: Iterable[str]) -> str:
    """The command that reproduces this run, as a user types it."""
    return shlex.join(["python", "tools/bench.py", name, *argv])


def parse_targets(value: str) -> tuple[str, ...]:
    """``"all"`` or a comma list of targets -> the targets, in order.

    Raises ValueError naming the value and the allowed targets."""
    if value == "all":
        return TARGETS
    out = tuple(t.strip() for t in value.split(",") if t.strip())
    bad = [t for t in out if t not in TARGETS]
    if not out or bad:
        raise ValueError(f"--cpu-name {value!r}: each target must be one of "
                         f"{', '.join(TARGETS)} (or all)")
    return out


def _target_arg(value: str) -> str:
    import argparse

    try:
        parse_targets(value)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None
    return value


def add_target_option(parser) -> None:
    """``--cpu-name TARGETS`` on an argparse parser (see :func:`dispatch`)."""
    parser.add_argument(
        "--cpu-name", type=_target_arg, default=None, metavar="TARGETS",
        help="numba code-generation target(s), comma-separated or all: host (this CPU, "
             "the default), haswell (AVX2 only, x86-64-v3), generic (x86-64, SSE2); a "
             "target other than this process's re-runs the benchmark in a subprocess "
             "with its own NUMBA_CACHE_DIR")


def child_command(name: str, argv: Iterable[str]) -> list[str]:
    """``python -m synth.apps.bench NAME *argv`` (the interpreter of this process)."""
    return [sys.executable, "-m", "synth.apps.bench", name, *argv]


def child_environ(env: Mapping[str, str]) -> dict[str, str]:
    """``env`` with this process's ``synth`` first on PYTHONPATH, so that a
    child runs the same checkout."""
    import synth

    root = str(Path(synth.__file__).resolve().parents[1])
    out = dict(env)
    parts = [p for p in out.get("PYTHONPATH", "").split(os.pathsep) if p]
    out["PYTHONPATH"] = os.pathsep.join([root] + [p for p in parts if p != root])
    return out


def dispatch(name: str, cpu_name: str | None, argv=None) -> int | None:
    """Handle ``--cpu-name`` of benchmark ``name``: None if it should run in
    this process (no value, or this process's own target), else the exit
    status of its runs for each target (0 if all succeeded; a target this
    CPU cannot run is skipped with a note)."""
    argv = sys.argv[1:] if argv is None else list(argv)
    here = cpu_target.current_target()
    if cpu_name is None or cpu_name == here:
        return None
    if os.environ.get(cpu_target.ENV_TARGET):
        raise SystemExit(f"--cpu-name {cpu_name}: this process was started for target {here}")
    rest = cpu_target.strip_cpu_option(argv)
    status = 0
    for t in parse_targets(cpu_name):
        why = cpu_target.runnable(t)
        if why:
            print(f"# --cpu-name {t}: skipped, {why}", flush=True)
            continue
        env = cpu_target.environ_for(t)
        print(f"# ==== --cpu-name {t} (NUMBA_CPU_NAME={env.get('NUMBA_CPU_NAME', '(unset)')}, "
              f"NUMBA_CACHE_DIR={env['NUMBA_CACHE_DIR']})", flush=True)
        sys.stderr.flush()
        rc = subprocess.call(child_command(name, [*rest, "--cpu-name", t]),
                             env=child_environ(env))
        if rc != 0:
            print(f"# --cpu-name {t}: exit status {rc}", flush=True)
            status = rc
    return status


def alternate(ways: Mapping[str, Callable[[], float]], repeats: int,
              warmup: bool = False) -> dict[str, list[float]]:
    """Run each of ``ways`` (name -> a function returning its measure) in
    turn, ``repeats`` rounds; returns name -> its ``repeats`` measures in
    round order.  ``warmup``: one round first whose measures are dropped."""
    if repeats < 1:
        raise ValueError(f"repeats = {repeats}: must be >= 1")
    out: dict[str, list[float]] = {k: [] for k in ways}
    for r in range(repeats + (1 if warmup else 0)):
        for k, f in ways.items():
            v = f()
            if r or not warmup:
                out[k].append(float(v))
    return out


def summary(values: Iterable[float]) -> tuple[float, float, float]:
    """(median, min, max) of a benchmark's repeats."""
    v = [float(x) for x in values]
    if not v:
        raise ValueError("summary of no values")
    return statistics.median(v), min(v), max(v)


def ratios(a: Iterable[float], b: Iterable[float]) -> list[float]:
    """Round-by-round ratios a / b of two alternated ways (paired, so a
    drift common to a round cancels)."""
    return [x / y for x, y in zip(a, b, strict=True)]
