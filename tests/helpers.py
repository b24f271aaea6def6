"""Shared test helpers: build engines from presets (through the one factory)."""

from synth.engine.engine import Event
from synth.io.factory import build_engine


def engine(name, overrides=(), probe=False, **kw):
    return build_engine(name, overrides, probe=probe, **kw)


def note(key, t=0.0, vel=0.8, off=None):
    ev = [Event(t, "note_on", key, vel)]
    if off is not None:
        ev.append(Event(off, "note_off", key, 0.0))
    return ev


def shared_dir():
    """The workplace's shared/ folder: beside the checkout (as in CI), else
    /work/shared."""
    from pathlib import Path

    here = Path(__file__).resolve().parents[2] / "shared"
    return here if here.is_dir() else Path("/work/shared")


def cli(capsys, *argv):
    """``synth ARGV`` through :func:`synth.cli.main` in this process: the
    program's parsing, errors and exit status without a cold start (a
    subprocess costs 1-2 s of imports).  Returns (returncode, stdout,
    stderr) as a ``subprocess.CompletedProcess``; argparse's exits (--help,
    a bad choice) are taken as their status.  A traceback fails the test."""
    import subprocess

    from synth.cli import main

    argv = [str(a) for a in argv]
    capsys.readouterr()
    try:
        rc = main(argv)
    except SystemExit as e:
        rc = e.code if isinstance(e.code, int) else 2
    cap = capsys.readouterr()
    assert "Traceback" not in cap.err, cap.err
    return subprocess.CompletedProcess(argv, rc, cap.out, cap.err)


def string_table(n):
    """An ``ipar`` table of ``n`` strings, each by itself on the engine's
    grid, no probe, chunks of 8 samples while excited (for the render
    kernels' choices)."""
    import numpy as np

    from synth.kernels import layout as L

    ip = np.zeros((n, L.I_NI), dtype=np.int64)
    ip[:, L.I_CPL] = L.CPL_NONE
    ip[:, L.I_SUB] = 1
    ip[:, L.I_PROBE] = -1
    ip[:, L.I_CHUNK] = 8
    return ip


def couple(ip, lead, size):
    """Strings ``lead`` .. ``lead + size - 1`` of ``ip`` as one coupled
    group (one bridge) led by ``lead``."""
    from synth.kernels import layout as L

    for j in range(size):
        s = lead + j
        ip[s, L.I_CPL] = lead
        ip[s, L.I_CPLNX] = s + 1 if j + 1 < size else -1
    ip[lead, L.I_CPLN] = size
