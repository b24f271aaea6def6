"""MPE zones and per-note expression: a mixin of the engine.

MIDI Polyphonic Expression (MPE, MMA/AMEI RP-053) gives every sounding
note a MIDI channel of its own, so that the channel's pitch bend, pressure
and CC74 are that note's.  The engine already plays every message on its
own channel's notes (:mod:`synth.engine.channels`); what MPE adds, and this
module plays, is the *zone*:

* A zone is a manager channel and its member channels: the lower zone is
  managed by channel 1 (0-based 0) with members 2 .. n + 1, the upper zone
  by channel 16 (0-based 15) with members 15 - n + 1 .. 15 (1-based).  The
  MPE Configuration Message, RPN 6 (CC101 = 0, CC100 = 6, CC6 = n) on
  channel 1 or 16, sets one (n = 0 turns it off); ``synth render --mpe``
  and ``synth play --mpe`` set it as if it had been received
  (:func:`parse_mpe`).  A zone that overlaps the other one shrinks it (or
  turns it off when nothing is left), as the specification asks.
* Setting a zone sets its bend ranges to MPE's defaults: 48 semitones on
  the member channels (:data:`MEMBER_RANGE`), 2 on the manager
  (:data:`MANAGER_RANGE`).  RPN 0 sets them again (on a member channel:
  every member channel of the zone), and in a zone they are not held at the
  preset's range: a bend is read with the channel's own range first.
* A member note bends by its own channel's bend plus the manager
  channel's, in semitones; the sum is then held within the preset's
  ``play.pitch_bend_semitones`` (a 1-semitone slide on a 48-semitone
  member channel plays 1 semitone; 5 semitones on the sitar play its 2, and
  the message is listed as ignored).  The manager's own notes bend by its
  bend alone.  Presets that do not bend (the grand, the harpsichord) list
  the bends, as outside a zone.

Per-note pressure (in a zone or not):

* Channel pressure (aftertouch) sets the buzz depth of its channel's
  sounding notes (in a zone: a member channel's one note), and polyphonic
  key pressure that of its key's note, on the presets whose voice plays a
  pressure control (:attr:`synth.voices.base.Voice.pressure_cc`: the
  plucked presets' buzz, ``play.buzz_cc``).  It acts as that control's
  message would, on those notes only: the last message wins, so a CC1
  afterwards sets every note of its channel again, and a new note starts
  at its channel's CC1 value.  Presets without the control (the grand, the
  harpsichord) list the pressure as ignored.

(CC74, the pluck point, is a control of the voice's own,
:meth:`synth.voices.one_string.OneStringVoice.controls`: a note takes its
channel's value at its note-on, as it takes the buzz depth.)
"""

from __future__ import annotations

import math

import numpy as np

#: MPE's default bend range of a zone's member channels (semitones)
MEMBER_RANGE = 48.0
#: MPE's default bend range of a zone's manager channel (semitones)
MANAGER_RANGE = 2.0
#: the manager channels (0-based) of the lower and the upper zone
LOWER, UPPER = 0, 15
#: the most member channels a zone can have
MAX_MEMBERS = 15
#: the registered parameter of the MPE Configuration Message (CC101, CC100)
RPN_MPE = (0, 6)
ZONE_NAMES = {"lower": LOWER, "upper": UPPER}

#: how pressure messages are named in the list of ignored messages
CHANNEL_PRESSURE_NAME = "channel pressure (aftertouch)"
POLY_PRESSURE_NAME = "polyphonic key pressure"


def zone_channels(manager: int, members: int) -> tuple[int, ...]:
    """The member channels (0-based) of the zone managed by ``manager``
    (:data:`LOWER` or :data:`UPPER`) with ``members`` of them, nearest the
    manager first."""
    if manager == LOWER:
        return tuple(range(1, members + 1))
    return tuple(range(UPPER - 1, UPPER - 1 - members, -1))


def parse_mpe(text: str) -> tuple[tuple[int, int], ...]:
    """``--mpe``: ``lower``, ``upper``, ``lower:N``, ``upper:N`` or both,
    comma-separated (``lower:7,upper:7``) -> ((manager channel, members),
    ...).  A zone without N has 15 member channels (the whole of MIDI's
    channels).  Raises ValueError, one line naming the option, the value
    and what is allowed."""
    out: dict[int, int] = {}
    for part in text.split(","):
        part = part.strip().lower()
        name, _, n = part.partition(":")
        if name not in ZONE_NAMES:
            raise ValueError(f"--mpe = {text!r}: {part!r} is not a zone (lower, upper, lower:N, "
                             "upper:N, e.g. lower:7,upper:7)")
        try:
            members = MAX_MEMBERS if not n else int(n)
        except ValueError:
            raise ValueError(f"--mpe = {text!r}: {n!r} is not a number of member channels "
                             f"(1 <= value <= {MAX_MEMBERS})") from None
        if not (1 <= members <= MAX_MEMBERS):
            raise ValueError(f"--mpe = {text!r}: {members} member channels is out of range "
                             f"(1 <= value <= {MAX_MEMBERS})")
        if ZONE_NAMES[name] in out:
            raise ValueError(f"--mpe = {text!r}: the {name} zone is given twice")
        out[ZONE_NAMES[name]] = members
    if len(out) == 2 and out[LOWER] + out[UPPER] > MAX_MEMBERS - 1:
        raise ValueError(f"--mpe = {text!r}: the zones overlap (lower + upper member channels "
                         f"<= {MAX_MEMBERS - 1}, e.g. lower:7,upper:7)")
    return tuple(sorted(out.items()))


class MpeZones:
    """The engine's MPE zones and per-note pressure (a mixin of
    :class:`synth.engine.engine.Engine`; see the module docstring)."""

    def _init_mpe(self) -> None:
        #: per channel: the manager channel of its zone (the manager's own
        #: included), -1 outside every zone
        self.mpe_manager = np.full(16, -1, dtype=np.int64)
        #: the zones: manager channel -> number of member channels
        self.mpe_zones: dict[int, int] = {}
        #: per channel in a zone: its bend range (semitones; RPN 0 sets it)
        self.mpe_range = np.zeros(16)

    # -- zones ----------------------------------------------------------------------
    def set_mpe_zone(self, manager: int, members: int) -> None:
        """Set the zone managed by channel ``manager`` (0: the lower zone,
        15: the upper) to ``members`` member channels (0: no zone), as the
        MPE Configuration Message does: the zone's bend ranges become 48
        semitones on its members and 2 on its manager, and the other zone,
        if it overlaps, shrinks (or ends).  Sounding notes take their new
        bends at once."""
        if manager not in (LOWER, UPPER):
            raise ValueError(f"manager = {manager!r} is out of range (0: the lower zone, "
                             f"15: the upper)")
        if not (0 <= members <= MAX_MEMBERS):
            raise ValueError(f"members = {members!r} is out of range (0 <= value <= {MAX_MEMBERS})")
        before = set(np.flatnonzero(self.mpe_manager >= 0).tolist())
        self.mpe_zones.pop(manager, None)
        if members:
            self.mpe_zones[manager] = members
            other = UPPER if manager == LOWER else LOWER
            if other in self.mpe_zones:
                room = MAX_MEMBERS - 1 - members    # the other's members left (and its manager)
                if room <= 0:
                    del self.mpe_zones[other]
                else:
                    self.mpe_zones[other] = min(self.mpe_zones[other], room)
        self.mpe_manager[:] = -1
        for m, n in self.mpe_zones.items():
            self.mpe_manager[m] = m
            self.mpe_manager[list(zone_channels(m, n))] = m
        if members:
            self.mpe_range[manager] = MANAGER_RANGE
            self.mpe_range[list(zone_channels(manager, members))] = MEMBER_RANGE
        after = set(np.flatnonzero(self.mpe_manager >= 0).tolist())
        for c in sorted(before | after):
            self._rebend(c, zone=False)

    def set_mpe_zones(self, zones) -> None:
        """Set each ``(manager, members)`` of ``zones`` in turn
        (:func:`parse_mpe`'s result: ``--mpe``)."""
        for manager, members in zones:
            self.set_mpe_zone(int(manager), int(members))

    def take_mpe_zones(self, other) -> None:
        """Take the zones and their bend ranges of the engine ``other`` (a
        program change: the keyboard configured its zone once, on the
        engine playing then)."""
        self.mpe_zones = dict(other.mpe_zones)
        self.mpe_manager[:] = other.mpe_manager
        self.mpe_range[:] = other.mpe_range

    def _zone_members(self, manager: int) -> tuple[int, ...]:
        return zone_channels(manager, self.mpe_zones.get(manager, 0))

    def _inert(self, kind: str) -> bool:
        """Whether an event of ``kind`` leaves the strings alone on this
        preset (a bend on one that does not bend, pressure on one without a
        pressure control: listed, not played): the block's strings are then
        not rendered in two pieces at its sample, so that a file with such
        events renders the samples of the file without them, bit for bit."""
        if kind == "pitch_bend":
            return not self.play.bends
        if kind in ("channel_pressure", "poly_pressure"):
            return self.inst.pressure_cc is None
        return False

    # -- bend -------------------------------------------------------------------------
    def _zone_bend(self, c: int) -> tuple[float, bool]:
        """Channel c's (in a zone) bend as a share of the preset's range:
        its own in semitones plus its manager's (a member channel), held
        within the preset's ``play.pitch_bend_semitones``; and whether it
        was held."""
        top = float(self.play.bend_range_semitones)
        if top <= 0.0:
            return 0.0, False
        m = int(self.mpe_manager[c])
        semis = float(self.bend.get(c, 0.0)) * float(self.mpe_range[c])
        if c != m:
            semis += float(self.bend.get(m, 0.0)) * float(self.mpe_range[m])
        held = min(max(semis, -top), top)
        return held / top, held != semis

    def _rebend(self, c: int, zone: bool = True) -> bool:
        """The sounding notes of channel c (with ``zone``: of every
        channel of its zone, when c is a manager) take their channel's
        bend now.  Returns whether a bend of a channel with sounding notes,
        or of c itself, was held within the preset's range."""
        if not self.play.bends:
            return False
        m = int(self.mpe_manager[c])
        chans = (c,) + (self._zone_members(m) if zone and m == c else ())
        held = False
        for ch in chans:
            notes = self._channel_voices(ch)
            b = self._bend_value(ch)
            if m >= 0 and (notes or ch == c):
                held = self._zone_bend(ch)[1] or held
            for _, vo in notes:
                self.inst.pitch_bend(self.bank, vo.slots, vo.key_arg, vo.f0_hz, b)
        return held

    def _pitch_bend(self, c: int, value: float) -> None:
        """A pitch-bend message on channel c (value in [-1, 1] of its range)."""
        self.bend[c] = float(value)
        if not self.play.bends:
            self._ignore("pitch bend (the preset does not bend)")
            return
        if self._rebend(c):
            top = float(self.play.bend_range_semitones)
            self._ignore(f"pitch bend beyond the preset's {top:g} semitones: held at {top:g}")

    def _mpe_data_entry(self, c: int, msb: bool, raw: int) -> None:
        """RPN 6 on channel c: the MPE Configuration Message (its data entry
        MSB, ``raw`` member channels; the LSB carries nothing)."""
        if not msb:
            return
        if c not in (LOWER, UPPER):
            self._ignore("RPN 6 (MPE configuration) off the manager channels 1 and 16")
            return
        if raw > MAX_MEMBERS:
            self._ignore(f"RPN 6 (MPE configuration) of more than {MAX_MEMBERS} member channels: "
                         f"held at {MAX_MEMBERS}")
        self.set_mpe_zone(c, min(raw, MAX_MEMBERS))

    def _mpe_bend_range(self, c: int, msb: bool, raw: int) -> None:
        """RPN 0 on channel c of a zone: its bend range in semitones (a data
        entry MSB; the LSB: its cents), on every member channel of the zone
        when c is one; not held at the preset's range (the bends are)."""
        old = float(self.mpe_range[c])
        semis = math.floor(old + 1e-9)
        cents = (old - semis) * 100.0
        if msb:
            semis, cents = raw, 0.0
        else:
            cents = float(raw)
        m = int(self.mpe_manager[c])
        chans = (c,) if c == m else self._zone_members(m)
        self.mpe_range[list(chans)] = semis + cents / 100.0
        for ch in chans:
            self._rebend(ch, zone=False)

    # -- pressure ---------------------------------------------------------------------
    def _pressure(self, c: int, key, value: float) -> None:
        """Channel pressure (``key`` None: channel c's sounding notes) or
        polyphonic key pressure (that key's note on channel c): the voice's
        pressure control (the buzz depth) for those notes only."""
        cc = self.inst.pressure_cc
        if cc is None:
            self._ignore(CHANNEL_PRESSURE_NAME if key is None else POLY_PRESSURE_NAME)
            return
        if key is None:
            notes = [vo for _, vo in self._channel_voices(c)]
        else:
            v = self.by_key.get((c, key))
            vo = None if v is None else self.voices.get(v)
            notes = [] if vo is None or vo.dying else [vo]
        if not notes:
            return                                # nothing sounds to press
        self._inst_ctl[cc] = value                # (the next note-on sets its channel's again)
        self.inst.control_change(self.bank, cc, value,
                                 [(vo.slots, vo.key_arg, vo.f0_hz) for vo in notes])
