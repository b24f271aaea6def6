"""The strings on a sitar's bridge that no finger stops: taraf and chikari.

A sitar carries, besides its played string, a set of thin sympathetic
strings (*taraf*) under the frets, each on a small jawari bridge of its own,
tuned to the notes of the raga, and a few drone strings (*chikari*) over the
main bridge, struck in rhythm by the player's little finger.  Nothing damps
either: the taraf ring whenever the played string (or a drone) puts one of
their partials into the bridge, the shimmering halo of the instrument.

How it runs: a two-way bridge.  The taraf and chikari are strings of the
engine's own bank, at its internal rate, in slots after the voices'.  They
and every sounding played string hang on one bridge, an open coupled group
of the bank (:meth:`synth.dsp.bank.StringBank.open_bridge`): a dashpot of
resistance R (``taraf.bridge_resistance_ns_per_m / taraf.coupling``) with a
slow spring, driven by the summed force of all its strings, whose motion
every string's end follows, sample by sample in one kernel call
(:func:`synth.kernels.coupled._bridge`).  So a taraf string in unison with
the note takes its energy from the played string (and gives it back), and
the drones and the taraf hear each other.

(Why one bank: a one-way coupling, the taraf at 4 x 48 kHz in a bank of
their own following a bridge moved by the played strings' decimated force,
lets a unison taraf string build up, without taking the energy from the
note, to a force as large as the note's and opposite to it, and only a
bridge 10-30 times stiffer than the tabli keeps the note in tune.  The
played string cannot feel them through a bridge a block behind it, and one
kernel steps one rate, hence one bank; docs/voicing.md, "Taraf and
chikari".)

When they render.  A note-on (of the played string or a stroke) starts the
resting strings, joined to the bridge where it is; the played strings join
at their note-on and leave when freed.  While nothing is played the silent
ones are freed by the bank's silence scan (the bridge's leader last).
Drone strokes act at their internal sample (a live stream and an offline
render give the same samples).

The bridge alone.  A design with no taraf and no chikari (a preset's
``[bridge]`` table instead of ``[taraf]``: the tanpura) is the same bridge
with only played strings on it.  No string of its own leads it: the first
string to sound opens it and leads it, the others join at their note-on,
and the bank keeps the leader rendering until every other member is silent
(:meth:`synth.dsp.bank.StringBank.reap`), so the group lives as long as
anything on it sounds.  Should the leader's voice go first all the same (a
voice cut for room, all sound off), the next string to start opens the
bridge again and takes with it every string still sounding that had been
on it.
"""

from __future__ import annotations

from .free_strings import FreeStrings


class Taraf(FreeStrings):
    """The taraf and chikari of one engine, in its bank: the two-way
    configuration of :class:`synth.engine.free_strings.FreeStrings`.

    Parameters
    ----------
    design : synth.voices.base.TarafDesign
        The strings, designed at the bank's rate.
    bank : synth.dsp.bank.StringBank
        The engine's bank; slots ``first`` .. ``first + n - 1`` are ours.
    first : int
        The first of our slots (after every voice's).
    fs_hz : float
        The bank's (internal) rate, Hz.
    """

    def __init__(self, design, bank, first: int, fs_hz: float):
        super().__init__(design, bank, first, fs_hz,
                         templates=tuple(design.slots) + tuple(design.drone_slots))
        self.n_taraf = len(design.slots)
        self.n_drones = len(design.drone_slots)
        #: the bridge's leader: the first taraf string (else the first drone;
        #: for the bridge alone, the first played string that sounds: None
        #: until then)
        self.lead = self.slots[0] if self.slots else None
        #: the bridge alone: the played strings that joined it (to join a
        #: new bridge if the leader went first)
        self._joined: list = []
        #: pending drone plucks: (internal sample, drone, amplitude m)
        self._plucks: list = []
        self.n_strums = 0

    # -- membership -------------------------------------------------------------
    @property
    def awake(self) -> bool:
        """Whether the bridge sounds (its leader renders)."""
        if self.lead is None:
            return False
        if not self.slots:
            return bool(self.bank.group(self.lead))
        return bool(self.bank.is_active(self.lead))

    def wake(self) -> None:
        """A note or a stroke starts: the bridge's resting strings start, at
        rest, their ends where the bridge is.  (The bridge alone has none:
        it opens as its first string joins.)"""
        bank = self.bank
        if not self.slots:
            return
        if not self.awake:
            self.configure(0)
            bank.open_bridge(self.lead, self.R, self.return_hz)
            bank.activate(self.lead)
        for i, s in enumerate(self.slots):
            if not bank.is_active(s):
                self.configure(i)
                bank.join(self.lead, s)
                bank.activate(s)

    def join(self, slots) -> None:
        """A played note's strings (configured and active) hang on the bridge."""
        bank = self.bank
        if not self.slots:
            self._join_alone([int(s) for s in slots if bank.is_active(s)])
            return
        for s in slots:
            if bank.is_active(s):
                bank.join(self.lead, s)

    def _join_alone(self, live: list) -> None:
        """The bridge alone: ``live`` (a note's sounding strings) join it;
        the first of them opens and leads it when none is open, and the
        strings still sounding from before join it too."""
        if not live:
            return
        bank = self.bank
        if not self.awake:
            old = [s for s in self._joined if bank.is_active(s) and s not in live]
            self.lead = live[0]
            bank.open_bridge(self.lead, self.R, self.return_hz)
            live = live + old
        for s in live:
            bank.join(self.lead, s)
        self._joined = [s for s in self._joined if bank.is_active(s) and s not in live] + live

    # -- the drones --------------------------------------------------------------
    def is_trigger(self, channel: int, key) -> bool:
        """Whether a note-on on ``channel`` (0-15) at ``key`` strums the drones."""
        if not self.n_drones:
            return False
        d = self.design
        if d.channel is not None and int(channel) == d.channel:
            return True
        return key is not None and d.trigger[0] <= key <= d.trigger[1]

    def strum(self, at: int, velocity: float) -> None:
        """A stroke across the drones at internal sample ``at``, normalised
        ``velocity`` (0 .. 1]: drone i is plucked ``i strum_s`` later, with
        the pluck's amplitude times velocity**exponent."""
        d = self.design
        amps = d.pluck.amplitudes_m
        g = max(float(velocity), 0.0) ** d.pluck.velocity_exponent
        step = int(round(d.strum_s * self.fs))
        for i in range(self.n_drones):
            self._plucks.append((int(at) + i * step, i, amps[i] * g))
        self._plucks.sort()
        self.n_strums += 1

    def next_pluck(self) -> int | None:
        """The internal sample of the next drone pluck, or None."""
        return self._plucks[0][0] if self._plucks else None

    def pluck_due(self, at: int, before: int) -> None:
        """Start the drone plucks due at internal sample ``at`` (``before``
        samples into the current block)."""
        bank = self.bank
        pl = self.design.pluck
        while self._plucks and self._plucks[0][0] <= at:
            _, i, amp = self._plucks.pop(0)
            self.wake()
            s = self.slots[self.n_taraf + i]
            bank.start_pluck(s, pl.kind, amp, pl.durations_s[i], pl.alpha_per_s)
            bank.reset_quiet(s, before)

    # -- silence -------------------------------------------------------------------
    def fade(self, t60_s: float) -> None:
        """All sound off: every sounding string fades out, 60 dB in
        ``t60_s`` (s); pending strokes go.  The strings are freed, silent,
        as usual and start again from rest."""
        self._plucks.clear()
        super().fade(t60_s)

    def rest(self) -> None:
        """All sound off: every string stops and rests; pending strokes go."""
        self._plucks.clear()
        for s in self.slots[1:] + self.slots[:1]:        # the leader last
            self.bank.deactivate(s)

    def reap(self, done, idle: bool) -> None:
        """Free our slots among the bank's silent ``done`` while ``idle``
        (nothing played; the bank gives the leader only when it is alone)."""
        if not idle or self._plucks:
            return
        lead = False
        for s in done:
            if self.owns(s):
                if s == self.lead:
                    lead = True
                else:
                    self.bank.deactivate(s)
        if lead and len(self.bank.group(self.lead)) <= 1:
            self.bank.deactivate(self.lead)
