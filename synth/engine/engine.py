"""Block engine: sample-accurate events, voice pool, mixing, decimation.

The engine knows nothing of MIDI or files: it receives :class:`Event` s whose
values are already normalised (velocity and controllers in [0, 1]) and time
stamped in seconds, and produces output blocks at ``fs_out``.

Per output block of ``n_out`` samples it renders exactly the number of
internal samples the decimator needs, split at the internal sample of each
event (an event at time t acts at internal sample round(t fs_in), not at a
block boundary), mixes every active string at the internal rate, decimates
once, and frees voices that have fallen silent (they then cost nothing).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..kernels import strings as K
from ..voices.bank import StringBank
from .decimator import Decimator

NOTE_ON = "note_on"
NOTE_OFF = "note_off"
CONTROL = "control"
CC_SUSTAIN = 64
CC_ALL_SOUND_OFF = 120
CC_ALL_NOTES_OFF = 123


@dataclass(frozen=True)
class Event:
    """A normalised performance event.

    time_s : float        time from the start of the render (s), >= 0
    kind : str            "note_on" | "note_off" | "control"
    key : float           MIDI key (may be fractional) or controller number
    value : float         velocity in (0, 1] or controller value in [0, 1]
    channel : int         0..15
    f0_hz : float | None  explicit pitch instead of the key (note_on only)
    speed_m_per_s : float | None  hammer speed instead of the velocity's
    """

    time_s: float
    kind: str
    key: float = -1
    value: float = 0.0
    channel: int = 0
    f0_hz: float | None = None
    speed_m_per_s: float | None = None


@dataclass
class _Voice:
    key: object
    start: int
    released: bool = False
    held_by_pedal: bool = False


class Engine:
    """Offline/online renderer for one instrument.

    Parameters
    ----------
    instrument : PluckedInstrument
        Supplies string setups and the voice contract.
    fs_out : int
        Output rate (Hz), 48 000 by default.
    polyphony : int or None
        Voice pool size (default: the preset's).
    probe : bool
        Record u at the excitation point and the number of region points in
        contact, per internal sample, for the first voice (study renders).
    silence_dbfs : float
        A released/decayed voice whose output stays below this level for two
        periods (and at least 20 ms) is freed.
    """

    MAX_BLOCK_OUT = 4096

    def __init__(self, instrument, fs_out: int = 48_000, polyphony: int | None = None,
                 probe: bool = False, silence_dbfs: float = -110.0, extra_low_key: int | None = None):
        self.inst = instrument
        self.fs_in_exact = float(instrument.fs)
        # the decimator needs an integer rate with a small ratio; the physics
        # keeps its exact dt (study grids), the audio is off by < 0.3 cent
        fs_int = int(round(self.fs_in_exact))
        if abs(fs_int - self.fs_in_exact) > 1e-6 or math.gcd(fs_int, int(fs_out)) < 100:
            fs_int = int(round(self.fs_in_exact / 100.0)) * 100
        self.fs_in = fs_int
        self.fs_out = int(fs_out)
        self.dec = Decimator(self.fs_in, self.fs_out)
        self.polyphony = int(polyphony or instrument.polyphony)
        max_in = self.dec.inputs_needed(self.MAX_BLOCK_OUT) + 16
        R = 0 if instrument.termination is None else instrument.termination.region_points
        gt = instrument.gtable_length() if hasattr(instrument, "gtable_length") else 0
        self.bank = StringBank(self.polyphony, instrument.max_cells(extra_low_key),
                               max_region=max(R, 1), max_block=4096,
                               n_probes=1 if probe else 0, max_gtable=gt)
        self.mix = np.zeros(max_in)
        self.probe = probe
        self._probe: list[np.ndarray] = []
        self.time_in = 0                    # internal samples rendered so far
        self.voices: dict[int, _Voice] = {}  # slot -> voice
        self.by_key: dict[object, int] = {}  # (channel, key) -> slot
        self.sustain = False
        self._quiet = np.zeros(self.polyphony, dtype=np.int64)
        self.silence_level = 10.0 ** (silence_dbfs / 20.0)
        self._pending: list[tuple[int, int, Event]] = []
        self._seq = 0

    # -- events -----------------------------------------------------------------
    def sample_of(self, time_s: float) -> int:
        """Internal sample index at which an event at ``time_s`` acts."""
        return int(round(time_s * self.fs_in_exact))

    def schedule(self, events) -> None:
        """Queue events (any order); they act at their own internal sample."""
        for ev in events:
            self._pending.append((self.sample_of(ev.time_s), self._seq, ev))
            self._seq += 1
        self._pending.sort(key=lambda t: (t[0], t[2].kind != NOTE_OFF, t[1]))

    def _alloc(self) -> int:
        for s in range(self.polyphony):
            if s not in self.voices:
                return s
        # steal: the oldest released voice, else the oldest voice
        rel = [s for s, v in self.voices.items() if v.released]
        pool = rel if rel else list(self.voices)
        s = min(pool, key=lambda q: self.voices[q].start)
        self._free(s)
        return s

    def _free(self, s: int) -> None:
        v = self.voices.pop(s, None)
        if v is not None and self.by_key.get(v.key) == s:
            del self.by_key[v.key]
        self.bank.deactivate(s)
        self._quiet[s] = 0

    @staticmethod
    def _voice_key(ev: Event):
        """Identity of a sounding note: channel and key (or explicit f0)."""
        return (ev.channel, ev.key if ev.f0_hz is None else ("f0", ev.f0_hz))

    @staticmethod
    def _extra(ev: Event) -> dict:
        return {} if ev.speed_m_per_s is None else {"speed_m_per_s": ev.speed_m_per_s}

    def _apply(self, ev: Event, at: int) -> None:
        vk = self._voice_key(ev)
        if ev.kind == NOTE_ON and ev.value > 0:
            key = None if ev.key is None or ev.key < 0 else ev.key
            s = self.by_key.get(vk)
            if s is not None and self.bank.is_active(s):
                # a sounding key is re-plucked on the same string
                self.inst.note_on(self.bank, s, key, ev.value, f0_hz=ev.f0_hz, restrike=True,
                                  **self._extra(ev))
                self.voices[s] = _Voice(vk, at)
            else:
                s = self._alloc()
                self.inst.note_on(self.bank, s, key, ev.value, f0_hz=ev.f0_hz,
                                  probe_row=0 if (self.probe and not self.voices) else -1,
                                  **self._extra(ev))
                self.voices[s] = _Voice(vk, at)
                self.by_key[vk] = s
            self._quiet[s] = 0
        elif ev.kind in (NOTE_OFF, NOTE_ON):
            s = self.by_key.get(vk)
            if s is None:
                return
            v = self.voices[s]
            if self.sustain:
                v.held_by_pedal = True
            else:
                self._release(s)
        elif ev.kind == CONTROL:
            cc = int(ev.key)
            if cc == CC_SUSTAIN:
                down = ev.value >= 0.5
                if self.sustain and not down:
                    for s, v in list(self.voices.items()):
                        if v.held_by_pedal:
                            v.held_by_pedal = False
                            self._release(s)
                self.sustain = down
            elif cc == CC_ALL_NOTES_OFF:
                for s in list(self.voices):
                    self._release(s)
            elif cc == CC_ALL_SOUND_OFF:
                for s in list(self.voices):
                    self._free(s)

    def _release(self, s: int) -> None:
        v = self.voices[s]
        if v.released:
            return
        v.released = True
        key = v.key[1]
        if isinstance(key, tuple):
            self.inst.note_off(self.bank, s, None, f0_hz=key[1])
        else:
            self.inst.note_off(self.bank, s, None if key is None or key < 0 else key)

    # -- rendering ----------------------------------------------------------------
    def render_block(self, n_out: int, out: np.ndarray | None = None) -> np.ndarray:
        """Render the next ``n_out`` output samples (float64)."""
        if not (1 <= n_out <= self.MAX_BLOCK_OUT):
            raise ValueError(f"n_out = {n_out!r} is out of range (1 <= value <= {self.MAX_BLOCK_OUT})")
        n_in = self.dec.inputs_needed(n_out)
        mix = self.mix[:n_in]
        mix[:] = 0.0
        start = self.time_in
        end = start + n_in
        bank = self.bank
        if self.probe:
            bank.ensure_probe_length(n_in)
            bank.probe[:, :, :n_in] = 0.0
        cursor = 0
        pend = self._pending
        while pend and pend[0][0] < end:
            at, _, ev = pend.pop(0)
            off = max(at - start, 0)
            if off > cursor:
                bank.render(self.mix, cursor, off - cursor)
                cursor = off
            self._apply(ev, start + off)
        if cursor < n_in:
            bank.render(self.mix, cursor, n_in - cursor)
        self.time_in = end
        if self.probe:
            self._probe.append(bank.probe[0, :, :n_in].copy())
        y = self.dec.process(mix, out)
        self._reap(n_in)
        return y

    def _reap(self, n_in: int) -> None:
        """Free voices that are silent: output below the silence level for two
        periods and 20 ms, excitation over."""
        bank = self.bank
        na = bank.n_active
        if na == 0:
            return
        act = bank.active[:na]
        peak = bank.fst[act, K.S_PEAK]
        quiet = (peak < self.silence_level) & (bank.ipar[act, K.I_EXC] == 0)
        self._quiet[act] = np.where(quiet, self._quiet[act] + n_in, 0)
        need = np.maximum(4 * bank.ipar[act, K.I_N], int(0.02 * self.fs_in))
        done = act[(self._quiet[act] >= need)]
        bank.fst[act, K.S_PEAK] = 0.0
        for s in done.tolist():
            if s in self.voices and (self.voices[s].released or not self.inst.study):
                self._free(s)

    @property
    def n_voices(self) -> int:
        return len(self.voices)

    def probe_channels(self) -> np.ndarray:
        """All probe channels (kernel ``P_*``) per internal sample, shape
        (channels, samples): u at the excitation point (m), region points in
        contact, hammer force (N), felt compression (m), hammer position (m),
        outgoing wave g (m)."""
        if not self.probe:
            raise ValueError("probe = False: this engine records no probe")
        return np.concatenate(self._probe, axis=1)

    def probe_signals(self):
        """(u at the excitation point (m), contact counts) per internal sample."""
        ch = self.probe_channels()
        return ch[K.P_U], ch[K.P_CONTACT]

    def render(self, events, duration_s: float | None = None, tail_s: float = 1.0,
               max_tail_s: float = 30.0, block: int = 1024, compensate_latency: bool = True) -> np.ndarray:
        """Render events offline.

        duration_s : exact length of the result (s); None: until the last
            event plus the release tails (voices silent), plus ``tail_s``,
            at most ``max_tail_s`` after the last event.
        Returns float64 mono audio at ``fs_out``, aligned so that an event
        at t sounds at t (the decimator's integer latency is removed).
        """
        events = list(events)
        self.schedule(events)
        lat = int(self.dec.latency_samples) if compensate_latency else 0
        last = max((e.time_s for e in events), default=0.0)
        chunks = []
        n_done = 0
        if duration_s is not None:
            total = int(round(duration_s * self.fs_out)) + lat
            while n_done < total:
                n = min(block, total - n_done)
                chunks.append(self.render_block(n))
                n_done += n
        else:
            hard = int((last + max_tail_s) * self.fs_out) + lat
            quiet_after = None
            while n_done < hard:
                chunks.append(self.render_block(block))
                n_done += block
                t = n_done / self.fs_out
                if t > last and not self._pending and not self.voices:
                    if quiet_after is None:
                        quiet_after = n_done + int(tail_s * self.fs_out) + lat
                    if n_done >= quiet_after:
                        break
        y = np.concatenate(chunks) if chunks else np.zeros(0)
        return y[lat:]
