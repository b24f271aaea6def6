"""Keep a note's code and data warm while the keyboard is quiet
(``synth play --warm-every-ms``).

On some machines, virtual ones most of all, memory that no thread touched
for a while costs far more to touch again.  Measured on a 2-vCPU
Firecracker VM (``tools/bench.py live``'s page probe): a page left alone
for 0.3 s cost about 1 us to read back, and a ``numpy.add`` of ten floats
1.6 ms the first time after a 0.3 s pause against 0.6 us warm.  A chord's
note-ons take code paths (the engine's Python, numpy's and numba's
dispatch, the strike's branch of the render kernel) that no block runs
between notes, so a chord after a quiet moment paid milliseconds for them
inside the audio callback.

:class:`Rehearsal` is a background thread that every ``every_s`` plays one
silent note on an *understudy*: a small engine of the same preset (two
voices, one thread) sharing the live engine's voice, so its key designs
and hammer sets stay warm too.  Right after one of the audio thread's
blocks (:meth:`Rehearsal.tick`) it strikes a key and renders a few
samples; after the next block it lets the key go (every fourth note it
also moves the sustain pedal) and renders a few more: the same code as a
block's, in the quiet time between blocks, on a full pool (the steal's
path too); the keys go round the preset's range.  The messages are made
as MIDI bytes and converted as live ones are.  Nothing it does reaches
the live engine or the output: the voice's shared state is read-only
caches.  The numba kernels release the GIL, and the player's 0.1 ms
switch interval hands it to the audio thread at once.  The thread runs at
the process's normal priority, not ``SCHED_IDLE``: starved by other
processes while it held the GIL, an idle-priority thread kept the audio
thread waiting for it (a JACK test under two busy processes failed 3 of 3
at ``SCHED_IDLE``, passed 3 of 3 at normal priority).  Its cost on that VM:
about 0.9 ms of one core a part, two parts a note, 11 % of a core at the
default 20 ms (the player's report gives its CPU time).  Measured there
through JACK with 32 grand voices (``tools/bench.py live --jack --voices 32
--warm-every-ms 0,20``): the audio thread's blocks over their period 1-17
a run without it, 0-5 with it.
"""

from __future__ import annotations

import threading
import time

__all__ = ["Rehearsal", "DEFAULT_EVERY_MS", "EVERY_MS_RANGE"]

#: default period of the rehearsal (ms; ``--warm-every-ms``)
DEFAULT_EVERY_MS = 20.0
#: the periods allowed (ms, both ends included)
EVERY_MS_RANGE = (2.0, 1000.0)
#: output samples the understudy renders per part
PART_OUT = 32


def _to_event(data: bytes):
    """A MIDI message's bytes as an engine event: the live players'
    conversion (:func:`synth.io.live.player.normalise` of the parsed
    message), so that its code stays warm too."""
    import mido

    from synth.io.live.player import normalise

    return normalise(mido.Message.from_bytes(data))


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
        Seconds between two rehearsed notes (0.002 <= value <= 1,
        :data:`EVERY_MS_RANGE`).

    Attributes
    ----------
    notes : int
        Notes rehearsed so far.
    cpu_s : float
        The thread's CPU time so far (s).
    error : str or None
        Why the rehearsal stopped early (one line), or None.
    """

    def __init__(self, preset: str, voice, fs_out: int, block: int,
                 every_s: float = DEFAULT_EVERY_MS / 1e3):
        super().__init__(name="synth-rehearsal", daemon=True)
        lo, hi = (ms / 1e3 for ms in EVERY_MS_RANGE)
        if not (lo <= float(every_s) <= hi):
            raise ValueError(f"every_s = {every_s!r} is out of range ({lo:g} <= value <= {hi:g})")
        self.every_s = float(every_s)
        self.block = int(block)
        # a part renders a few output samples: the same code as a block's
        self.part_out = min(self.block, PART_OUT)
        self.fs_out = int(fs_out)
        self.notes = 0
        self.cpu_s = 0.0
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
        from synth.engine.engine import CONTROL, Event

        i = 0
        key = None
        c0 = time.thread_time()
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
                    msgs = [(0x90, max(key, 0), 40 + (i * 29) % 80)]
                    if i % 4 == 0:
                        msgs.append((0xB0, 64, 127 if (i // 4) % 2 == 0 else 0))
                else:
                    # and let it go, a block later
                    msgs = [(0x80, max(key, 0), 64)]
                    i += 1
                    self.notes += 1
                evs = []
                for m in msgs:
                    ev = _to_event(bytes(m))
                    if ev is not None:
                        # (a study string plays its own pitch: key -1)
                        k = ev.key if (key >= 0 or ev.kind == CONTROL) else -1
                        evs.append(Event(t, ev.kind, k, ev.value, ev.channel))
                eng.schedule(evs)
                eng.render_block(self.part_out)
                self._part = not self._part
                self.cpu_s = time.thread_time() - c0
                self.done.set()
        except Exception as e:          # the performance goes on without it
            self.error = f"{type(e).__name__}: {e}".splitlines()[0]
        finally:
            self.done.set()
