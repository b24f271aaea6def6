"""Keep a note's code and data warm while the keyboard is quiet
(``synth play --warm-every-ms``).

On some machines, virtual ones most of all, memory that no thread touched
for a while costs far more to touch again.  Measured on a 2-vCPU
Firecracker VM (``docs/lab/2026-11-30-page-aging.md``): a page left alone
for 0.3 s cost about 1 us to read back, and a ``numpy.add`` of ten floats
1.6 ms the first time after a 0.3 s pause against 0.6 us warm.  A chord's
note-ons take code paths (the engine's Python, numpy's and numba's
dispatch, the strike's branch of the render kernel) that no block runs
between notes, so a chord after a quiet moment paid milliseconds for them
inside the audio callback.

:class:`Rehearsal` is a background thread that every ``every_s`` plays one
silent note on an *understudy*: a small engine of the same preset (two
voices, one thread) sharing the live engine's voice, so its key designs
and hammer sets stay warm too.  It strikes a key, renders a block, lets
the key go (every fourth note it also moves the sustain pedal), renders
another block, on a full pool (the steal's path too); the keys go round the
preset's range.  Nothing it does reaches the live engine or the output:
the voice's shared state is read-only caches.  The thread runs at Linux's
``SCHED_IDLE`` policy where it can, so it only takes a core no one else
wants, and the numba kernels release the GIL; the player's 0.1 ms switch
interval hands the GIL to the audio thread at once.  Its cost: about 0.6
ms of one core a note on that VM (6 % of a core at the default 10 ms).
"""

from __future__ import annotations

import os
import threading

__all__ = ["Rehearsal", "DEFAULT_EVERY_MS"]

#: default period of the rehearsal (ms; ``--warm-every-ms``)
DEFAULT_EVERY_MS = 10.0


def rehearsal_keys(voice) -> list:
    """The keys to rehearse: the preset's playable range (``[play]
    key_range``), or the study string's own pitch (key -1)."""
    from synth.engine.play import PlayRules

    kr = PlayRules.from_preset(voice.preset).key_range
    if kr is None or voice.study:
        return [-1]
    lo, hi = (int(k) for k in kr)
    return list(range(lo, hi + 1))


class Rehearsal(threading.Thread):
    """Play one silent note on an understudy engine every ``every_s``.

    Parameters
    ----------
    preset : str
        The live engine's preset (name or ``.toml`` path).
    voice : synth.voices.base.Voice
        The live engine's voice (shared, read-only).
    fs_out : int
        The stream's rate (Hz).
    block : int
        The stream's block (output samples, 16 <= value <= 4096).
    every_s : float
        Seconds between two rehearsed notes (0.002 <= value <= 1).

    Attributes
    ----------
    notes : int
        Notes rehearsed so far.
    error : str or None
        Why the rehearsal stopped early (one line), or None.
    """

    def __init__(self, preset: str, voice, fs_out: int, block: int,
                 every_s: float = DEFAULT_EVERY_MS / 1e3):
        super().__init__(name="synth-rehearsal", daemon=True)
        if not (0.002 <= float(every_s) <= 1.0):
            raise ValueError(f"every_s = {every_s!r} is out of range (0.002 <= value <= 1)")
        self.every_s = float(every_s)
        self.block = int(block)
        self.fs_out = int(fs_out)
        self.notes = 0
        self.error = None
        self._halt = threading.Event()
        self._go = threading.Event()
        #: set after each part rehearsed (and when the thread ends)
        self.done = threading.Event()
        # a strike at tick E, its release at tick E + 1, the counter then back to 0:
        # a note every E + 1 blocks
        self._every_blocks = max(2, int(round(self.every_s * self.fs_out / self.block))) - 1
        self._count = 0
        self._part = False               # False: a strike is next; True: its release
        self._next = None
        self._engine, self._keys = self.understudy(preset, voice)

    @property
    def engine(self):
        """The understudy engine rehearsed on now."""
        return self._engine

    def understudy(self, preset: str, voice) -> tuple:
        """The understudy of ``preset`` (its live ``voice``) and the keys it
        plays, built in the calling thread, for :meth:`follow`."""
        from synth.io.factory import build_engine

        eng = build_engine(preset, voice=voice, fs_out=self.fs_out, extra_low_key=0,
                           polyphony=2, threads=1, block=self.block)
        return eng, rehearsal_keys(voice)

    def follow(self, understudy: tuple) -> None:
        """A program change: rehearse on ``understudy`` (from
        :meth:`understudy`) from the next note on."""
        self._next = understudy

    def tick(self) -> bool:
        """The audio thread's block is done (the player calls this after
        each block): the next part of a rehearsal runs now, in the quiet
        time before the next block.  One counter and, when a part is due,
        one ``Event.set``; returns whether a part was due (:attr:`done` is
        set when it has run)."""
        self._count += 1
        if self._count >= self._every_blocks:
            # the strike, and the release at the next block
            self._count = 0 if self._count > self._every_blocks else self._count
            self._go.set()
            return True
        return False

    def stop(self) -> None:
        """Stop after the part being rehearsed (join to wait for it)."""
        self._halt.set()
        self._go.set()

    def run(self) -> None:
        from synth.engine.engine import CC_SUSTAIN, CONTROL, NOTE_OFF, NOTE_ON, Event

        if hasattr(os, "sched_setscheduler") and hasattr(os, "SCHED_IDLE"):
            try:
                os.sched_setscheduler(threading.get_native_id(), os.SCHED_IDLE,
                                      os.sched_param(0))
            except OSError:
                pass
        i = 0
        key = None
        try:
            while True:
                self._go.wait()
                self._go.clear()
                if self._halt.is_set():
                    break
                if self._next is not None and not self._part:
                    (self._engine, self._keys), self._next = self._next, None
                eng = self._engine
                t = eng.time_out / eng.fs_out
                if not self._part:
                    # strike a key (every fourth note, the pedal moves too)
                    key = self._keys[(i * 37) % len(self._keys)]
                    evs = [Event(t, NOTE_ON, key, 0.3 + 0.06 * ((i * 7) % 10))]
                    if i % 4 == 0:
                        evs.append(Event(t, CONTROL, CC_SUSTAIN, float((i // 4) % 2 == 0)))
                    eng.schedule(evs)
                else:
                    # and let it go, a block later
                    eng.schedule([Event(t, NOTE_OFF, key, 0.5)])
                    i += 1
                    self.notes += 1
                eng.render_block(self.block)
                self._part = not self._part
                self.done.set()
        except Exception as e:          # the performance goes on without it
            self.error = f"{type(e).__name__}: {e}".splitlines()[0]
        finally:
            self.done.set()
