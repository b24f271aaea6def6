"""Warm-up: take an engine through every path a performance uses before a
live stream opens, so the first real note costs no more than the others.

Warming compiles or loads the numba kernels (the first call of each: the
strings', the decimator's, the body's, the listening position's,
:mod:`synth.kernels.listener`, when the preset has a ``[listener]``, and the
limiter's), faults the engine's buffers in and, through
:meth:`synth.voices.base.Voice.warm`, derives every key's physics.  It renders on a throwaway engine, so it
leaves no sound behind.
"""

from __future__ import annotations

import numpy as np

from .play import PlayRules
from .engine import CC_SOFT, CC_SUSTAIN, CONTROL, NOTE_OFF, NOTE_ON, PITCH_BEND, Engine, Event

#: arrays at least this large are faulted in by :func:`fault_in` (bytes);
#: smaller ones share pages that are already in use
FAULT_IN_MIN_BYTES = 64 * 1024
#: the page size :func:`fault_in` steps by (bytes; a huge page is many of them)
PAGE_BYTES = 4096


def warm_phrase(voice) -> list[Event]:
    """Events that take an engine through every path a performance uses:
    note-ons across the voice's range (its lowest, middle and highest key;
    a study string's own pitch), a restrike, releases with and without the
    sustain pedal, the soft pedal, a pitch bend."""
    kr = PlayRules.from_preset(voice.preset).key_range
    if kr is not None and not voice.study:
        lo, hi = kr
        keys = sorted({lo, (lo + hi) // 2, hi})
    else:
        keys = [-1]
    ev = [Event(0.0, CONTROL, CC_SOFT, 0.5)]
    ev += [Event(0.001 * i, NOTE_ON, k, 0.8) for i, k in enumerate(keys)]
    ev += [Event(0.012, NOTE_ON, keys[len(keys) // 2], 0.6),
           Event(0.015, CONTROL, CC_SUSTAIN, 1.0)]
    ev += [Event(0.020, NOTE_OFF, k, 0.5) for k in keys]
    ev += [Event(0.025, CONTROL, CC_SUSTAIN, 0.0), Event(0.026, CONTROL, CC_SOFT, 0.0),
           Event(0.030, PITCH_BEND, -1, 0.5)]
    return ev


def warm_up(voice, *, fs_out: int, block: int, **engine_kw) -> None:
    """Design every note of ``voice`` (:meth:`Voice.warm`), then play
    :func:`warm_phrase` block by block (``block`` output samples at
    ``fs_out`` Hz, about 50 ms) on a throwaway :class:`Engine` built with
    ``engine_kw``, measuring the voices as a full pool does (the
    stealing's kernel) and shedding a voice on the way (the overload
    path); then every unit the bank's kernels may call
    (:meth:`~synth.dsp.bank.StringBank.load_units`), so that none loads
    during live play."""
    voice.warm()
    scratch = Engine(voice, fs_out=fs_out, **engine_kw)
    # the units first, but for those another process is compiling (a cold
    # start, synth.apps.cold_start): the phrase waits for them
    scratch.bank.load_units(wait=False)
    scratch.schedule(warm_phrase(voice))
    for _ in range(int(0.05 * fs_out / block) + 1):
        scratch.render_block(block)
    if scratch.voices:
        scratch._quietest(list(scratch.voices))     # the voice stealing's measure
    scratch.shed(1)
    scratch.render_block(block)
    # every unit of the bank, those the phrase did not need too (the
    # engine built next finds them loaded)
    scratch.bank.load_units()


def _arrays(obj, depth: int, seen: set):
    """The numpy arrays held by ``obj`` and by the objects of this package
    it holds (lists, tuples and dicts of them included), ``depth`` levels
    down."""
    if id(obj) in seen:
        return
    seen.add(id(obj))
    if isinstance(obj, np.ndarray):
        yield obj
        return
    if depth < 0:
        return
    if isinstance(obj, (list, tuple)):
        items = obj
    elif isinstance(obj, dict):
        items = obj.values()
    elif type(obj).__module__.startswith("synth.") and hasattr(obj, "__dict__"):
        items = vars(obj).values()
    else:
        return
    for v in items:
        yield from _arrays(v, depth - 1, seen)


def _map_pages(a: np.ndarray) -> None:
    """Map every page of C-contiguous, writeable ``a`` now, keeping its
    contents: one byte per page is read and written back (and the last
    byte).  ``np.zeros``
    maps a large array's pages only when they are first written (numpy
    asks for huge pages there), so a buffer an audio callback writes would
    otherwise take those faults inside the callback: on this project's
    2-vCPU VM one 128-frame block into a fresh 9 MB array took 5.1 ms (a
    2 MB page zeroed and mapped), two periods at 128; the walk itself took
    85 ms over a fresh 40 MB array, 8 us a 4 KB page."""
    b = a.reshape(-1).view(np.uint8)
    b[::PAGE_BYTES] |= 0
    if b.size:
        b[-1] |= 0          # (the last page, when the data starts past a page's start)


def resident_zeros(shape, dtype=np.float32) -> np.ndarray:
    """A zeroed array whose pages are already mapped (:func:`_map_pages`):
    for a buffer an audio callback writes (the ``--record`` ring, a JACK
    loopback's capture)."""
    a = np.zeros(shape, dtype=dtype)
    _map_pages(a)
    return a


def fault_in(engine: Engine, depth: int = 3) -> int:
    """Map every page of the engine's large arrays now, keeping their
    contents (:func:`_map_pages`): an array the warm-up's phrase did not
    reach (a hand-over buffer, the mix rows of a longer block) would
    otherwise map them inside the audio callback the first time a
    performance needs it.  Returns the bytes walked."""
    total = 0
    for a in _arrays(engine, depth, set()):
        if a.nbytes < FAULT_IN_MIN_BYTES or not a.flags.writeable or not a.flags.c_contiguous:
            continue
        _map_pages(a)
        total += a.nbytes
    return total
