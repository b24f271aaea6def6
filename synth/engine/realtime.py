"""Real-time driver: the same engine as offline rendering, fed by a live
event stream and pulled by an audio callback.

Timing
------
Live MIDI messages carry no timestamp, so each event is stamped with the
clock when it arrives (:meth:`Realtime.push`) and played at a constant
latency after that: the event acts at stream time

    t = (arrival - t0) + latency_s

where ``t0`` is the clock time of output sample 0 (:meth:`start`).  The
engine places it at internal sample round(t * fs_in), so the timing jitter
is at most one internal sample (3 us), not one block, provided the latency
covers a block plus the callback's scheduling slack (default: two blocks).
Rendering offline the same events with ``time_s = t`` gives exactly the same
samples (tested): live play and offline rendering are one engine.

The callback
------------
:meth:`callback` (sounddevice's signature) drains the event queue, renders
one block into a preallocated buffer and copies it to the float32 output.
It does no per-voice Python work and allocates no arrays: the engine renders
all strings with one kernel call per segment, decimates and runs the
soundboard in place.  Rendering time is measured per block; when
``slow_blocks`` blocks in a row take more than ``overload`` of their
real-time budget *and* the time they ran over has eaten ``max_late`` of the
device's spare period (slow blocks eat into it, fast ones refill it), the
quietest voices are faded out (``shed_fraction`` of them), so that a heavy
passage thins out instead of dropping out.  The attack of a dense chord
(one or two blocks near or over budget, then fast ones) is absorbed by the
device's buffer and sheds nothing; a single stall of the machine does not
shed either.  Underruns reported by the audio device are counted.

Program changes swap the instrument: a new engine (built and warmed outside
the callback) takes the new notes while the old one renders until its
voices have died away.
"""

from __future__ import annotations

import collections
import gc
import threading
import time
from dataclasses import dataclass, field

import numpy as np

from .engine import Engine, Event


@dataclass
class RealtimeStats:
    """What the meter shows (``synth play --stats``) and the exit report."""

    blocks: int = 0
    worst_fraction: float = 0.0      # slowest block, as a fraction of its real-time budget
    sum_fraction: float = 0.0
    underruns: int = 0               # reported by the audio device
    overloads: int = 0               # blocks over the overload threshold
    over_budget: int = 0             # blocks that took longer than the time they play for
    #: blocks whose own work (the audio thread's CPU time) took longer: the
    #: rest of an over-budget block is time the thread did not run (the
    #: machine or the audio server held it)
    over_budget_cpu: int = 0
    worst_cpu_fraction: float = 0.0  # most CPU time a block took, as a fraction of its budget
    shed_voices: int = 0
    late_events: int = 0             # events that arrived after their slot had been rendered
    errors: int = 0                  # blocks lost to an exception (silence written)
    block_times_s: collections.deque = field(default_factory=lambda: collections.deque(maxlen=100000))

    @property
    def mean_fraction(self) -> float:
        return self.sum_fraction / self.blocks if self.blocks else 0.0

    def percentile_fraction(self, q: float, budget_s: float) -> float:
        if not self.block_times_s:
            return 0.0
        return float(np.percentile(np.asarray(self.block_times_s), q)) / budget_s


class Realtime:
    """Drive ``engine`` block by block from a live event stream.

    Parameters
    ----------
    engine : Engine
        The engine that renders (its ``fs_out`` is the stream's rate).
    block : int
        Output block size (samples), 16 .. 4096.
    latency_s : float or None
        Constant delay from an event's arrival to its sound (s); default two
        blocks.
    clock : callable
        Monotonic clock in seconds (``time.monotonic``).
    overload : float or None
        Fraction of the block budget above which voices are shed (0 < x <= 2);
        None: never shed (rendering is then independent of the machine's speed).
    shed_fraction : float
        Share of the sounding voices faded out at an overload (0..1).
    slow_blocks : int
        Consecutive blocks over the threshold before voices are shed.
    max_late : float
        Accumulated lateness (in blocks, 0 .. 1: the share of one spare
        device period eaten) that must also be reached before voices are
        shed; 0 sheds on ``slow_blocks`` alone.  Lateness grows by
        (block time / budget - 1) per block, never below 0, and starts again
        from 0 once it passes a whole period (the device has then run dry).
    """

    def __init__(self, engine: Engine, block: int = 128, latency_s: float | None = None,
                 clock=time.monotonic, overload: float = 0.9, shed_fraction: float = 0.25,
                 slow_blocks: int = 2, max_late: float = 0.5):
        if not (16 <= int(block) <= Engine.MAX_BLOCK_OUT):
            raise ValueError(f"block = {block!r} is out of range (16 <= value <= {Engine.MAX_BLOCK_OUT})")
        if overload is not None and not (0.0 < overload <= 2.0):
            raise ValueError(f"overload = {overload!r} is out of range (0 < value <= 2, or None)")
        self.engines = [engine]
        #: every engine that has played in this stream (program changes
        #: add one), for the report's counts
        self.engines_seen = [engine]
        self.fs = engine.fs_out
        self.block = int(block)
        self.latency_s = 2.0 * self.block / self.fs if latency_s is None else float(latency_s)
        self.clock = clock
        self.overload = None if overload is None else float(overload)
        self.shed_fraction = float(shed_fraction)
        self.slow_blocks = max(1, int(slow_blocks))
        if not (0.0 <= max_late <= 1.0):
            raise ValueError(f"max_late = {max_late!r} is out of range (0 <= value <= 1)")
        self.max_late = float(max_late)
        self._slow = 0
        self._late = 0.0               # blocks of lateness the device buffer absorbs now
        self.budget_s = self.block / self.fs
        self._queue: collections.deque = collections.deque()
        self._buf = np.zeros((2, Engine.MAX_BLOCK_OUT))
        self._acc = np.zeros((2, Engine.MAX_BLOCK_OUT))
        self.t0 = None
        self.n_out = 0
        self.stats = RealtimeStats()
        self._lock = threading.Lock()
        self._pending_swap = None
        self._gc_was_enabled = None
        self._last_tel = None          # the contact telemetry the last meter line showed

    @property
    def engine(self) -> Engine:
        """The engine that takes new notes."""
        return self.engines[-1]

    # -- control thread ---------------------------------------------------------
    def start(self, t0: float | None = None, quiet_gc: bool = True) -> None:
        """Set the clock time of output sample 0 (default: now); call it
        before the stream starts, not from the callback.

        quiet_gc : collect garbage once, freeze what exists and switch the
            cyclic collector off until :meth:`stop` (it runs in whichever
            thread allocates, and a pass in the audio callback cost up to 4
            block budgets in tools/bench.py live); reference counting still
            frees everything the engine drops.  The control thread may call
            ``gc.collect(0)`` now and then.
        """
        if quiet_gc and self._gc_was_enabled is None:
            gc.collect()
            gc.freeze()
            self._gc_was_enabled = gc.isenabled()
            gc.disable()
        self.t0 = self.clock() if t0 is None else float(t0)

    def stop(self) -> None:
        """Undo :meth:`start`'s garbage-collector settings."""
        if self._gc_was_enabled is not None:
            if self._gc_was_enabled:
                gc.enable()
            gc.unfreeze()
            self._gc_was_enabled = None

    def push(self, event: Event, arrival_s: float | None = None) -> None:
        """Queue an event that arrived at clock time ``arrival_s`` (default:
        now).  Thread-safe; ``event.time_s`` is ignored."""
        t = self.clock() if arrival_s is None else float(arrival_s)
        self._queue.append((t, None, event))

    def push_at(self, event: Event, t_s: float) -> None:
        """Queue an event that acts at stream time ``t_s`` (s from output
        sample 0), exactly: for a server that stamps each message with its
        frame in the audio cycle (JACK), so no clock and no latency margin
        enter.  A time already rendered is played at once and counted late.
        Thread-safe; ``event.time_s`` is ignored."""
        self._queue.append((None, float(t_s), event))

    def swap(self, engine: Engine) -> None:
        """Program change: ``engine`` (built and warmed by the caller) takes
        the notes from the next block on, with the current one's MPE zones
        (:meth:`Engine.take_mpe_zones`); the current one fades out."""
        if engine.fs_out != self.fs:
            raise ValueError(f"engine fs_out = {engine.fs_out} differs from the stream's {self.fs}")
        self._pending_swap = engine

    # -- audio thread ---------------------------------------------------------------
    def _drain(self) -> None:
        """The queued events to the engine, in one :meth:`Engine.schedule`
        call (as an offline render schedules its events): each call orders
        all the pending events anew, so one call per event cost a chord's
        block O(n^2) (32 note-offs and a pedal in one JACK cycle: 0.8 ms)."""
        q = self._queue
        if not q:
            return
        now_s = self.n_out / self.fs
        evs = []
        while q:
            t_arr, t_at, ev = q.popleft()
            t = (t_arr - self.t0) + self.latency_s if t_at is None else t_at
            if t < now_s:
                self.stats.late_events += 1
                t = now_s
            evs.append(Event(t, ev.kind, ev.key, ev.value, ev.channel, ev.f0_hz,
                             ev.speed_m_per_s))
        self.engine.schedule(evs)

    def render(self, out: np.ndarray, frames: int) -> None:
        """Render the next ``frames`` output samples into ``out``: shape
        (frames,) (mono: the mean of left and right) or (frames, channels)
        (left, right, and further channels copies of them in turn), any
        float dtype.  The audio callback's body; a mono engine sounds the
        same on both sides."""
        if self.t0 is None:                    # nobody called start(): stamp only
            self.t0 = self.clock()
        t_start = time.perf_counter()
        c_start = time.thread_time()
        try:
            if self._pending_swap is not None:
                new, self._pending_swap = self._pending_swap, None
                new.time_in = 0
                # align the new engine's clock with the stream
                new.time_in = int(round(self.n_out / self.fs * new.fs_in_exact))
                for d in new.decs:
                    d.reset()
                # the MPE zones a keyboard configured once (or --mpe) stay
                new.take_mpe_zones(self.engine)
                for e in self.engines:
                    # all notes off on every channel: the old instrument's keys up
                    e.schedule([Event(self.n_out / self.fs, "control", 123, 0.0, c)
                                for c in range(16)])
                self.engines.append(new)
                self.engines_seen.append(new)
            self._drain()
            acc = self._acc[:, :frames]
            acc[:] = 0.0
            keep = []
            for e in self.engines:
                if e.channels == 1:
                    y = e.render_block(frames, self._buf[0])
                    acc += y                       # both sides
                else:
                    acc += e.render_block(frames, self._buf[:e.channels])[:2]
                if e is self.engine or e.n_voices:
                    keep.append(e)
            self.engines = keep
            if out.ndim == 1:
                np.add(acc[0], acc[1], out=self._buf[0, :frames])
                self._buf[0, :frames] *= 0.5
                np.copyto(out[:frames], self._buf[0, :frames], casting="unsafe")
            else:
                for c in range(out.shape[1]):
                    np.copyto(out[:frames, c], acc[c % 2], casting="unsafe")
        except Exception:                      # never let the stream die
            self.stats.errors += 1
            out[:frames] = 0.0
        self.n_out += frames
        # the CPU time's span inside the wall time's (read after its start,
        # before its end): a block's CPU time never reads above its wall time
        c_span = time.thread_time() - c_start
        dt = time.perf_counter() - t_start
        span = frames / self.fs                # the time the block plays for
        frac = dt / span
        cfrac = c_span / span
        st = self.stats
        st.blocks += 1
        st.sum_fraction += frac
        st.block_times_s.append(dt * self.block / frames)
        if frac > st.worst_fraction:
            st.worst_fraction = frac
        if frac > 1.0:
            st.over_budget += 1
        if cfrac > 1.0:
            st.over_budget_cpu += 1
        if cfrac > st.worst_cpu_fraction:
            st.worst_cpu_fraction = cfrac
        late = self._late + frac - 1.0
        self._late = 0.0 if (late < 0.0 or late > 1.0) else late
        if self.overload is not None and frac > self.overload:
            st.overloads += 1
            self._slow += 1
            # one slow block is often the machine, not the music (another
            # process, a page fault), and a chord's attack is absorbed by the
            # device's spare period: shed only when the overload lasts and
            # has eaten into that period
            if self._slow >= self.slow_blocks and self._late >= self.max_late:
                n = int(np.ceil(self.shed_fraction * self.engine.n_live))
                if n:
                    st.shed_voices += self.engine.shed(n)
                self._slow = 0
        else:
            self._slow = 0

    def callback(self, outdata, frames, time_info, status) -> None:
        """sounddevice output callback: ``outdata`` (frames, channels), one
        channel (mono: left and right mixed) or more (left, right, ...)."""
        if status and status.output_underflow:
            self.stats.underruns += 1
        self.render(outdata[:, 0] if outdata.shape[1] == 1 else outdata, frames)

    # -- reporting ----------------------------------------------------------------
    def meter(self) -> str:
        """One line: blocks, worst and mean block time (fraction of the
        budget), voices, underruns; with the engine's contact telemetry on
        (:attr:`Engine.telemetry`), the latest note's contacts per string
        (:func:`contact_meter`)."""
        st = self.stats
        line = (f"blocks {st.blocks}  worst {st.worst_fraction * 100:5.1f}%  mean "
                f"{st.mean_fraction * 100:5.1f}%  voices {self.engine.n_live:3d}  "
                f"underruns {st.underruns}  shed {st.shed_voices}")
        if self.engine.telemetry:
            tel = self.engine.contact_telemetry()
            line += "  | " + contact_meter(tel, self._last_tel)
            self._last_tel = tel
        return line

    def report(self) -> str:
        st = self.stats
        return (f"{st.blocks} blocks of {self.block} at {self.fs} Hz; block time worst "
                f"{st.worst_fraction * 100:.1f}%, 99th percentile "
                f"{st.percentile_fraction(99, self.budget_s) * 100:.1f}%, mean "
                f"{st.mean_fraction * 100:.1f}% of the budget, {st.over_budget} blocks over it "
                f"({st.over_budget_cpu} in the audio thread's CPU time, whose worst is "
                f"{st.worst_cpu_fraction * 100:.1f}%); "
                f"{st.underruns} underruns, "
                f"{st.overloads} overloaded blocks, {st.shed_voices} voices shed, "
                f"{st.late_events} late events, {st.errors} errors, "
                f"{sum(e.n_stolen for e in self.engines_seen)} voices stolen")


def contact_meter(tel: dict | None, prev: dict | None = None) -> str:
    """The contact part of the meter: for the latest note (``tel``, from
    :meth:`Engine.contact_telemetry`), per string ``s<i>``: the hammer's
    time in contact (ms), contact episodes and peak force (N), and the
    termination's time in contact (ms), episodes and most points in
    contact; with ``prev`` (the dict the previous line showed, same note)
    the termination contact time added since then, so the meter shows the
    contacts over time as well as since the note-on."""
    if tel is None:
        return "contacts: no note yet"
    key = tel["key"]
    name = "note" if key is None else f"key {key:g}"
    if not tel["strings"]:
        return f"contacts {name}: silent"
    same = prev is not None and prev.get("key") == key and len(prev["strings"]) == len(tel["strings"])
    parts = []
    for i, st in enumerate(tel["strings"]):
        h, t = st["hammer"], st["termination"]
        p = (f"s{i} hammer {h['time_in_contact_s'] * 1e3:.2f} ms/{h['episodes']} ep/"
             f"{h['peak_force_n']:.1f} N, termination {t['time_in_contact_s'] * 1e3:.1f} ms/"
             f"{t['episodes']} ep/{t['max_points']} pts")
        if same:
            d = t["time_in_contact_s"] - prev["strings"][i]["termination"]["time_in_contact_s"]
            if d >= 0:
                p += f" (+{d * 1e3:.1f} ms)"
        parts.append(p)
    return f"contacts {name}: " + "; ".join(parts)
