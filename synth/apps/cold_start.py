"""A cold start on two cores: a second process compiles part of the kernels.

numba compiles on the calling thread, one function after another, so a
first ``synth note`` on a machine keeps one core busy for most of a minute
while the others idle.  The renderers' units called by address
(:mod:`synth.kernels.address`) compile on their own, each into its own
entry of numba's cache; so, when the cache is cold and the command may use
two threads or more, :func:`start` spawns one process that compiles the
heaviest unit the scene will need, about half of its compile, while this
process compiles the rest.  The bank, when it needs that unit, waits for
the process and loads the unit from the cache
(:func:`synth.dsp.units.compile_elsewhere`).  The samples are the same
(the same machine code, loaded instead of compiled).

What the second process takes, by the bank's kind (measured on a cold
cache, 2-vCPU Xeon, ``tools/bench.py compile``):

* a bank with a bridge of more than BLOCK strings (the sitar, the
  tanpura): the bridge's blocks' first half, ``_block_a`` (16 of a note's
  36 CPU s);
* any other (a piano, the plucked presets): ``render_bank``, the renderer
  of several strings (30 of a grand note's 58 CPU s).

The process is spawned (numba's threads and locks are not forked), prints
nothing, and is stopped when the command ends (:meth:`Helper.close`): a
unit it has not finished then never reaches the cache half-written
(numba writes each entry to a temporary file first).  Where it fails, the
bank compiles the unit itself.
"""

from __future__ import annotations

import contextlib
import multiprocessing


def plan(eng) -> tuple:
    """The units a second process should compile for engine ``eng``'s
    scenes (unit indices of :mod:`synth.kernels.address`, or ``"bank"``)."""
    from ..kernels import address as KA

    if eng.bank.big_groups:
        return (KA.A_BLOCKA,)
    return ("bank",)


def _index(u) -> str:
    """Unit ``u``'s cache index file, as a pattern
    (:func:`synth.dsp.compile_notice.cache_looks_warm`)."""
    from ..kernels import address as KA

    return {"bank": "render.render_bank-*.nbi", KA.A_BLOCKA: "render._block_a-*.nbi"}[u]


def _compile(units, preset, overrides) -> None:
    """The second process: load (compiling into the cache) ``units``; a
    bank of ``preset`` (with ``overrides``) gives ``render_bank`` its
    arrays' types, and a big group's unit is compiled only where that bank
    can have one."""
    import signal

    from ..dsp import threads
    from ..kernels import render as KR

    # (Ctrl-C at a terminal reaches this process too: the command stops it)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    threads.set_default(1)
    from ..io.factory import build_engine

    eng = build_engine(preset, overrides, extra_low_key=0, threads=1)
    for u in units:
        if u == "bank":
            eng.bank._bank_addr()
        elif u == KR.A_BLOCKA and not eng.bank.big_groups:
            continue                    # (no big group in this preset)
        else:
            KR.unit_address(u)


class Helper:
    """A second process compiling ``units`` (:func:`start`); ``wait()``
    returns once it has ended, ``close()`` stops it if it has not."""

    def __init__(self, proc, units):
        self.proc = proc
        self.units = tuple(units)

    def wait(self) -> None:
        self.proc.join()

    def close(self) -> None:
        if self.proc.is_alive():
            self.proc.terminate()
        self.proc.join()


@contextlib.contextmanager
def meanwhile(helper: "Helper | None"):
    """The command's work with ``helper`` (:func:`start`, :func:`start_live`;
    None: no second process) compiling beside it, stopped when the work
    ends, however it ends."""
    try:
        yield helper
    finally:
        if helper is not None:
            helper.close()


def start_live(preset, overrides, threads: int | None = None) -> Helper | None:
    """:func:`start` for ``synth play``, before its engine is built: live
    play compiles every renderer of the bank (the shards', each unit's),
    about 90 s on a cold cache; the second process compiles ``render_bank``
    and, where the preset has a bridge of more than four strings, its
    blocks' first half."""
    from ..kernels import address as KA

    return _spawn(("bank", KA.A_BLOCKA), preset, overrides, threads)


def start(eng, preset, overrides, threads: int | None = None) -> Helper | None:
    """Start the second process for engine ``eng`` (built from ``preset``
    with ``overrides``) when it helps: the cache holds none of its units
    (:func:`plan`) and the command may use two threads or more
    (``threads``; None: every core this process may use).  None when it
    would not help."""
    return _spawn(plan(eng), preset, overrides, threads)


def _spawn(units, preset, overrides, threads) -> Helper | None:
    """The second process for ``units`` not in the cache yet, when the
    command may use two threads or more."""
    from ..dsp.compile_notice import cache_looks_warm
    from ..dsp.threads import resolve
    from ..dsp.units import compile_elsewhere

    units = tuple(u for u in units if not cache_looks_warm(_index(u)))
    if not units or resolve(threads) < 2:
        return None
    ctx = multiprocessing.get_context("spawn")
    proc = ctx.Process(target=_compile, args=(units, preset, list(overrides)), daemon=True)
    proc.start()
    helper = Helper(proc, units)
    compile_elsewhere(units, helper.wait)
    return helper
