"""Compile the numba kernels for this CPU ahead of time (``synth warmup``).

Each preset's engine plays a short phrase that takes it through the paths a
performance uses (several notes at once, one alone, a restrike, the pedals,
a bend: :func:`synth.engine.warm.warm_phrase`), on a throwaway engine, after
loading the kernel every live scene runs
(:meth:`synth.dsp.bank.StringBank.load_kernels`).  What numba compiles stays
in its cache (:mod:`synth.kernels.cache`), keyed on the kernels' sources and
the toolchain, so every later process loads it.

numba compiles on the calling thread, one function after another: a cold
warm-up of every musical preset keeps one core busy for minutes while the
others idle.  :func:`warm_presets` with ``jobs`` > 1 runs it in that many
worker processes at once, each writing into the same cache (the cache's
save lock, :func:`synth.kernels.cache.install_save_lock`, keeps two
processes that save one function from mixing its entries).  The presets
share most of the string kernels, and the costliest, the renderer of
several units on the threads (``render_sharded`` and the ``render_bank``
it calls by address), is one for all of them; two workers that
reach one kernel at the same time both compile it.  So the work goes in
two rounds: first one worker compiles that renderer while the others play
one note on each preset (the narrower renderers a single note runs: a
bridge of many strings, a piano key's unison, a lone string); then each
preset loads every renderer and plays its whole phrase, finding nearly
everything compiled.  Were render_sharded to compile render_bank's tree
into itself rather than call it by address, that one renderer would be the
longest path whatever the cores (160-190 s on a 2-vCPU Xeon), which
bounded the gain at about 1.5x: every musical preset on a fresh cache,
253 s on one process and 207 s on two (``synth warmup --jobs 1`` / ``--jobs 2``; docs/benchmarks.md,
"Start-up").
"""

from __future__ import annotations

import time
from typing import Callable, NamedTuple

#: presets warmed first, in this order: each brings kernels the ones before it
#: do not (a piano key's unison and the sympathetic strings; a bridge of
#: many strings; a lone string with its sawari; the tanpura's strings on one
#: bridge); the others follow in the order given
ORDER = ("grand-piano", "sitar", "biwa", "tanpura")


class Warmed(NamedTuple):
    """A preset's warm-up, or one part of it: ``preset``; ``seconds``, its
    wall time; ``compiled``, the numba functions compiled (0: all loaded
    from the cache); ``compile_s``, the wall seconds spent compiling;
    ``part``, which part (:data:`PARTS`; "all" for a whole preset)."""
    preset: str
    seconds: float
    compiled: int
    compile_s: float
    part: str = "all"


#: the parts of a warm-up (:func:`warm_one`)
PARTS = ("all", "sharded", "note", "phrase")


def warm_one(name: str, threads: int | None = None, part: str = "all") -> Warmed:
    """Warm preset ``name`` in this process (on ``threads`` threads; None:
    the default, :func:`synth.dsp.threads.default_threads`).  ``part``:
    ``"sharded"``, the bank's renderer of several units on the threads
    (:meth:`~synth.dsp.bank.StringBank.load_kernels`, the costliest to
    compile); ``"note"``, one note in the middle of the preset's range,
    alone (the narrower renderer a single note runs); ``"phrase"``, :func:`synth.engine.warm.warm_phrase`
    (several notes at once, a restrike, the pedals, a bend) after every
    renderer of the bank; ``"all"``, the same as ``"phrase"``."""
    from ..dsp import compile_notice
    from ..engine.engine import NOTE_OFF, NOTE_ON, Event
    from ..engine.warm import warm_phrase
    from ..io.factory import build_engine

    if part not in PARTS:
        raise ValueError(f"part = {part!r} is not one of {', '.join(PARTS)}")
    compile_notice.listen()
    c0, s0, t0 = compile_notice.kernels_compiled(), compile_notice.compile_seconds(), time.perf_counter()
    eng = build_engine(name, (), extra_low_key=0, threads=threads)
    if part == "sharded":
        eng.bank.load_kernels(("sharded",))
    elif part == "note":
        ons = [e for e in warm_phrase(eng.inst) if e.kind == NOTE_ON]
        key = ons[len(ons) // 2].key
        eng.render([Event(0.0, NOTE_ON, key, 0.8), Event(0.02, NOTE_OFF, key, 0.5)],
                   duration_s=0.06)
    else:
        # "all", "phrase": the kernel of every scene (what live play and
        # several notes run), then the narrower ones a phrase takes (what a
        # single note runs offline)
        eng.bank.load_kernels()
        eng.render(warm_phrase(eng.inst), duration_s=0.06)
    return Warmed(name, time.perf_counter() - t0, compile_notice.kernels_compiled() - c0,
                  compile_notice.compile_seconds() - s0, part)


def _warm_job(name: str, threads: int, part: str) -> Warmed:
    """:func:`warm_one` in a worker process of :func:`warm_presets`."""
    from ..dsp.threads import set_default

    set_default(threads)
    return warm_one(name, threads, part)


def ordered(names) -> list[str]:
    """``names`` with those of :data:`ORDER` first (in its order), the rest
    after them as given (duplicates dropped)."""
    names = list(dict.fromkeys(names))
    first = [n for n in ORDER if n in names]
    return first + [n for n in names if n not in first]


def _rounds(names) -> list[list[tuple[str, str]]]:
    """The worker processes' tasks, (preset, part), in two rounds: the
    bank's costliest renderer and one note of each preset, then each
    phrase."""
    return [[(names[0], "sharded")] + [(n, "note") for n in names],
            [(n, "phrase") for n in names]]


def n_tasks(names, jobs: int) -> int:
    """How many parts :func:`warm_presets` runs for ``names`` on ``jobs``
    processes (one per preset on one)."""
    names = ordered(names)
    return len(names) if jobs <= 1 else sum(len(r) for r in _rounds(names))


def warm_presets(names, jobs: int = 1, threads: int | None = None,
                 done: Callable[[Warmed], None] | None = None) -> list[Warmed]:
    """Warm every preset of ``names`` (:func:`warm_one`), in :func:`ordered`
    order; with ``jobs`` > 1 in that many worker processes at once
    (``spawn``), each on ``threads // jobs`` threads (at least 1; ``threads``
    None: every core).  ``done`` is called with each preset's
    :class:`Warmed` as it finishes (in the order they finish; with ``jobs``
    > 1, with each part's, :func:`n_tasks` calls in all).  Returns one per
    preset, its parts added up, in :func:`ordered` order.  ``jobs``: 1 .. :data:`synth.apps.check.MAX_JOBS`.

    Raises ValueError for a bad ``jobs`` or ``threads``, and whatever
    building a preset raises (an unknown name: before any work, as the
    presets are loaded first)."""
    from ..dsp.threads import resolve
    from ..io.presets import load_preset
    from .check import check_jobs

    check_jobs(jobs)
    names = ordered(names)
    for n in names:
        load_preset(n)                 # an unknown or broken preset: before any compile
    jobs = min(jobs, n_tasks(names, jobs))
    if jobs <= 1:
        out = []
        for n in names:
            w = warm_one(n, threads)
            if done is not None:
                done(w)
            out.append(w)
        return out
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    each = max(1, resolve(threads) // jobs)
    # round 1: render_sharded in one worker, one note of each preset in the
    # others; round 2: each preset's phrase (_rounds)
    spent = {n: Warmed(n, 0.0, 0, 0.0) for n in names}
    # spawn, not fork: the parent may hold numba's thread pool and locks
    with ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("spawn")) as ex:
        for tasks in _rounds(names):
            futures = [ex.submit(_warm_job, n, each, part) for n, part in tasks]
            try:
                for f in as_completed(futures):
                    w = f.result()
                    a = spent[w.preset]
                    spent[w.preset] = Warmed(w.preset, a.seconds + w.seconds, a.compiled + w.compiled,
                                             a.compile_s + w.compile_s)
                    if done is not None:
                        done(w)
            except BaseException:
                for f in futures:      # a failed preset (or Ctrl-C): start no more
                    f.cancel()
                raise
    return [spent[n] for n in names]

