"""A drone player: the tanpura's four strings plucked in a cycle, by the engine.

A tanpura accompanies a performance with one figure, played over and over:
its four strings plucked one after the other, each left to ring into the
next, then a pause, then the figure again.  The strings are tuned, in
playing order, to the first string (Pa, the fifth below Sa; or Ma, the
fourth, or Ni, the seventh, as the raga asks), two middle strings in
unison on Sa, and the low Sa (*kharaj*) an octave below.  With Sa at MIDI
key K:

====  ===========  =========================================
Pa    K - 5        the first string, in the lower octave, between
Ma    K - 7        the low Sa and Sa (the player retunes it for
Ni    K - 1        the raga; Ni sits a semitone below Sa)
Sa    K            (the first string on Sa as well)
====  ===========  =========================================

then Sa (K), Sa (K) and the low Sa (K - 12).

The player is an engine component, present when the preset has a
``[drone]`` table with ``player = "on"`` (:meth:`Drone.from_preset`).  It
turns a key into the figure, the same live and offline:

* a note-on at key K starts the cycle with Sa = K at that note-on's
  internal sample (its velocity does not matter: the strings are plucked
  at ``drone.velocity``);
* a note-on at the same key while it runs stops it: no more plucks, the
  strings ring out through their own decay;
* a note-on at another key moves Sa from the next cycle (the figure under
  way is finished on the old Sa);
* note-offs do nothing (a player presses a key once); All Notes Off
  (CC123) and All Sound Off (CC120) stop it (a sequencer's stop, a panic),
  and the engine damps or fades the strings as it does any note's;
* ``drone.tempo_cc`` sets the cycle's length, ``drone.pattern_cc`` the first
  string (Pa, Ma, Ni, Sa), each from the next cycle; Reset All Controllers
  (CC121) gives back the preset's.

Each pluck is a note-on of its string's key whose event carries the
string's number (:attr:`synth.engine.engine.Event.string`, 0-3 in playing
order), so that the engine gives every string a voice of its own: the two
middle Sa strings share a key and sound together, a string is never cut by
the next, and a string plucked again is restruck on its own voice.

The cycles are counted in internal samples from the note-on that started
them, and each pluck acts at its own internal sample (the engine splits its
block there, as for an event): a render gives the same samples for any
block size, and a live performance the samples of its offline render.

The strings rest on the bridge from the cycle's start.  A tanpura's four
strings are always on its bridge: the first pluck sets the bridge moving
and the strings not yet plucked ring with it, the Sa strings with the
partials of Pa they share.  So each cycle starts, at its first sample and
before its first pluck, every string it plucks later and that does not
sound already, at rest (its pluck later excites it where it is, as a
string plucked again).  Without that, a string joined the bridge only at
its own pluck, and in the first cycle Pa rang alone for a second.

Humanisation.  Each pluck is moved in time by a uniform draw in
[-``timing_jitter_s``, +``timing_jitter_s``] and its strength by one in
[-``force_jitter_db``, +``force_jitter_db``] dB (of the pluck's amplitude,
through ``play.velocity_exponent``: velocity x 10^(dB / (20 exponent)),
held within (0, 1]).  The draws come from a numpy Generator seeded with
``drone.seed``, two per pluck in pluck order, drawn when its cycle starts:
the same events give the same plucks, whatever the blocks.  A pluck is
never moved before its cycle's start (a first pluck at onset 0 is only
ever late; it cannot sound before the key that starts the drone).

Beyond the first sketch of this player (issue 40, item 3), and why:

* ``drone.player = "off"`` turns the player off while the table stays: a
  drone preset's own checks (tuning, level) and ``synth note`` must pluck
  one string, and a key that starts a cycle would play the first string
  (Pa) instead.
* All Notes Off and All Sound Off stop the drone: a sequencer sends them
  when it stops, a panic button on every channel; a drone that went on
  plucking after either would be stuck on.
* The key's velocity is not the plucks': a key only starts and stops the
  figure (a player's hand on the tanpura is steady); ``drone.velocity``
  (and channel volume, CC7) set its level.
* The "same key" is the one that last set Sa (a pending move's key too):
  pressed again it stops the drone; the old Sa pressed during a pending
  move takes the move back.
"""

from __future__ import annotations

from collections import deque

import numpy as np

__all__ = ["Drone", "FIRST_STRINGS", "FIRST_OFFSETS", "LOW_SA_OFFSET", "CYCLE_RANGE_S",
           "STRINGS", "parse_pattern", "first_from_cc", "cycle_from_cc", "string_keys"]

#: the drone's strings: the first, two middle Sa, the low Sa
STRINGS = 4
#: the first string's tunings, in the order ``drone.pattern_cc`` steps through them
FIRST_STRINGS = ("Pa", "Ma", "Ni", "Sa")
#: each first string's key re Sa (semitones): in the lower octave, between
#: the low Sa and Sa
FIRST_OFFSETS = {"Pa": -5, "Ma": -7, "Ni": -1, "Sa": 0}
#: the low Sa (kharaj) re Sa
LOW_SA_OFFSET = -12
#: the cycle's length (s): the schema's range of ``drone.cycle_s``, and the
#: range ``drone.tempo_cc`` sweeps (geometrically: CC 0 the slowest, 127 the
#: fastest, 64 about 4 s)
CYCLE_RANGE_S = (1.0, 16.0)
#: the history of plucks kept (:attr:`Drone.history`)
HISTORY = 4096


def parse_pattern(text: str) -> str:
    """The first string of a pattern ``"Pa Sa Sa Sa"`` (one token per
    string in pluck order: Pa, Ma, Ni or Sa, then Sa Sa Sa; any case, any
    spaces), as one of :data:`FIRST_STRINGS`.  ValueError otherwise."""
    tokens = str(text).split()
    names = {n.lower(): n for n in FIRST_STRINGS}
    if (len(tokens) != STRINGS or tokens[0].lower() not in names
            or any(t.lower() != "sa" for t in tokens[1:])):
        raise ValueError(f"pattern = {text!r} is not allowed (four tokens in pluck order: "
                         "Pa, Ma, Ni or Sa, then Sa Sa Sa)")
    return names[tokens[0].lower()]


def string_keys(sa: float, first: str) -> tuple:
    """The four strings' keys in playing order for Sa at key ``sa``."""
    return (sa + FIRST_OFFSETS[first], sa, sa, sa + LOW_SA_OFFSET)


def first_from_cc(value: float) -> str:
    """``drone.pattern_cc``'s value (0..1) as the first string: four equal
    zones, MIDI 0-31 Pa, 32-63 Ma, 64-95 Ni, 96-127 Sa."""
    return FIRST_STRINGS[min(int(float(value) * 127.0 + 0.5) // 32, len(FIRST_STRINGS) - 1)]


def cycle_from_cc(value: float) -> float:
    """``drone.tempo_cc``'s value (0..1) as the cycle's length (s): 0 the
    longest of :data:`CYCLE_RANGE_S`, 1 the shortest, geometrically
    between (MIDI 64: 3.96 s)."""
    lo, hi = CYCLE_RANGE_S
    v = min(max(float(value), 0.0), 1.0)
    return hi * (lo / hi) ** v


class Drone:
    """The drone player of one engine.

    Parameters
    ----------
    spec : synth.io.presets.model.DroneSpec
        The preset's ``[drone]``.
    fs_hz : float
        The engine's internal rate (Hz): plucks act at its samples.
    velocity_exponent : float
        The voice's ``play.velocity_exponent`` (the pluck's amplitude goes
        as velocity to this power): the force jitter's dB become a factor
        on the velocity through it.
    """

    def __init__(self, spec, fs_hz: float, velocity_exponent: float = 1.0):
        self.spec = spec
        self.fs = float(fs_hz)
        self.exponent = float(velocity_exponent)
        self.onsets = tuple(float(x) for x in spec.onsets)
        if len(self.onsets) != STRINGS:
            raise ValueError(f"drone.onsets = {list(self.onsets)} needs {STRINGS} values "
                             "(one per string)")
        self.tempo_cc = int(spec.tempo_cc)
        self.pattern_cc = int(spec.pattern_cc)
        if self.tempo_cc == self.pattern_cc:
            raise ValueError(f"drone.tempo_cc = {self.tempo_cc} and drone.pattern_cc = "
                             f"{self.pattern_cc} must differ")
        self.rng = np.random.default_rng(int(spec.seed))
        #: the settings the next cycle takes: first string, length (s)
        self.first = parse_pattern(spec.pattern)
        self.cycle_s = float(spec.cycle_s)
        #: the key that last set Sa and its channel (the next cycle's Sa)
        self.key = None
        self.channel = 0
        #: whether the cycle runs
        self.running = False
        #: the internal sample of the next cycle's start (None: stopped)
        self._cycle_at = None
        #: pending plucks: (internal sample, string, key, velocity, channel)
        self._plucks: list = []
        #: plucks done, and the latest (internal sample, string, key,
        #: velocity) of them (at most :data:`HISTORY`)
        self.n_plucks = 0
        self.history: deque = deque(maxlen=HISTORY)
        #: cycles begun
        self.n_cycles = 0

    @classmethod
    def from_preset(cls, preset, fs_hz: float):
        """The player of a preset with ``[drone] player = "on"``, else None."""
        spec = getattr(preset, "drone", None)
        if spec is None or spec.player != "on":
            return None
        play = getattr(preset, "play", None)
        exp = 1.0 if play is None else float(play.velocity_exponent)
        return cls(spec, fs_hz, exp)

    # -- the player's hands ---------------------------------------------------------
    @property
    def ccs(self) -> tuple:
        """The controllers the drone takes: tempo and pattern."""
        return (self.tempo_cc, self.pattern_cc)

    def press(self, key: float, channel: int, at: int) -> None:
        """A note-on at ``key`` on ``channel`` at internal sample ``at``:
        starts the cycle (stopped), stops it (the key that last set Sa) or
        moves Sa from the next cycle (another key)."""
        key = float(key)
        if not self.running:
            self._plucks.clear()             # (a finished cycle's last plucks)
            self.key, self.channel = key, int(channel)
            self.running = True
            self._cycle_at = int(at)
        elif key == self.key:
            self.stop()
        else:
            self.key, self.channel = key, int(channel)

    def stop(self) -> None:
        """No more plucks; the strings ring on."""
        self.running = False
        self._cycle_at = None
        self._plucks.clear()

    def finish(self) -> None:
        """No new cycle: the plucks left of the cycle that runs still sound,
        then the strings ring on (the end of a rendered MIDI file that
        leaves the drone running)."""
        self.running = False
        self._cycle_at = None

    def control(self, cc: int, value: float) -> bool:
        """A controller (0..1); True if it is one of the drone's."""
        if cc == self.tempo_cc:
            self.cycle_s = cycle_from_cc(value)
        elif cc == self.pattern_cc:
            self.first = first_from_cc(value)
        else:
            return False
        return True

    def reset_controls(self) -> None:
        """Reset All Controllers: the preset's cycle and first string."""
        self.first = parse_pattern(self.spec.pattern)
        self.cycle_s = float(self.spec.cycle_s)

    # -- the engine's clock ----------------------------------------------------------
    def next_due(self) -> int | None:
        """The internal sample of the next pluck or cycle start, or None."""
        t = self._plucks[0][0] if self._plucks else None
        c = self._cycle_at
        if c is not None and (t is None or c <= t):
            return c
        return t

    def due(self, at: int) -> list:
        """The plucks due at internal sample ``at`` (cycles due begin
        first): a list of (string, key, velocity, channel), in pluck order.
        A cycle that begins lists first, with velocity None, the strings it
        plucks later than its start: they are on the instrument from its
        start, resting on the bridge (the engine starts a string at rest
        unless it sounds)."""
        out = []
        while True:
            if self._cycle_at is not None and self._cycle_at <= at:
                out += self._begin_cycle()
                continue
            if self._plucks and self._plucks[0][0] <= at:
                t, i, key, vel, ch = self._plucks.pop(0)
                self.n_plucks += 1
                self.history.append((int(at), i, key, vel))
                out.append((i, key, vel, ch))
                continue
            return out

    def _begin_cycle(self) -> list:
        """The cycle starting at ``_cycle_at``: its four plucks drawn and
        scheduled with the settings now, the next cycle's start set; returns
        the strings at rest at its start, (string, key, None, channel) for
        each string plucked after it."""
        start = self._cycle_at
        cycle_s = self.cycle_s
        keys = string_keys(self.key, self.first)
        sp = self.spec
        base = min(max(float(sp.velocity), 0.0), 1.0)
        rest = []
        for i in range(STRINGS):
            dt = self.rng.uniform(-1.0, 1.0) * float(sp.timing_jitter_s)
            db = self.rng.uniform(-1.0, 1.0) * float(sp.force_jitter_db)
            t = start + int(round((self.onsets[i] * cycle_s + dt) * self.fs))
            vel = base * 10.0 ** (db / (20.0 * self.exponent))
            vel = min(max(vel, 1.0 / 127.0), 1.0)
            self._plucks.append((max(t, start), i, keys[i], vel, self.channel))
            if t > start:
                rest.append((i, keys[i], None, self.channel))
        self._plucks.sort(key=lambda p: (p[0], p[1]))
        self._cycle_at = start + int(round(cycle_s * self.fs))
        self.n_cycles += 1
        return rest
