"""The order of simultaneous events: one rule for the file reader, the
engine and the live player.

Events are played in time order.  Events at the same time keep the order
they were given in, with one exception that sequencers and players rely
on, about a note-off and a note-on of the same key (channel and key) at the
same time:

* a note-off that ends a note begun *earlier* comes first, so a repeated
  note (one note ends where the next, on the same key, begins) sounds
  again, whichever of the two messages the file wrote first;
* a note-off whose note begins at this same time comes after its note-on,
  so a zero-length note sounds (its strike or pluck) and stops, as a
  sequencer plays it; it is not left sounding for ever (a note-off put
  before its own note-on would release nothing);
* a note-off of a key that is not sounding at all releases nothing, and
  keeps the front place that closing note-offs take.

Concretely, a group of simultaneous events is written as: the note-offs
that close earlier notes (and stray ones), then every other event in the
given order, then the note-offs of the notes begun in the group.  A
note-on with value 0 counts as a note-off (MIDI's running-status habit).

:func:`order_events` is used by :func:`synth.io.midi.read_midi_file` (on
the file's times), :meth:`synth.engine.engine.Engine.schedule` (on the
internal samples the events act at, starting from the keys the engine has
sounding) and therefore by the live player, whose events go through the
engine's :meth:`~synth.engine.engine.Engine.schedule` as they arrive.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence

__all__ = ["ON", "OFF", "OTHER", "note_role", "note_identity", "order_events"]

ON, OFF, OTHER = 1, -1, 0


def note_role(ev) -> int:
    """:data:`ON` for a note-on with a value above 0, :data:`OFF` for a
    note-off or a note-on with value 0, :data:`OTHER` for anything else."""
    kind = ev.kind
    if kind == "note_on":
        return ON if ev.value > 0 else OFF
    if kind == "note_off":
        return OFF
    return OTHER


def note_identity(ev):
    """The identity of a sounding note: (channel, key), or (channel,
    ("f0", f0_hz)) for an event that gives its pitch in Hz; an event that
    names one of the key's strings (``string``, not None: a tanpura's two
    Sa strings share a key) adds it, (channel, key, string)."""
    f0 = getattr(ev, "f0_hz", None)
    ident = (ev.channel, ev.key if f0 is None else ("f0", f0))
    s = getattr(ev, "string", None)
    return ident if s is None else ident + (int(s),)


def order_events(events: Sequence, time_of: Callable | None = None,
                 sounding: Iterable = ()) -> list:
    """The events in playing order (see the module docstring).

    Parameters
    ----------
    events : sequence
        Objects with ``kind``, ``channel``, ``key`` and ``value`` (and
        optionally ``f0_hz``): :class:`synth.io.midi.MidiEvent` or
        :class:`synth.engine.engine.Event`.
    time_of : callable or None
        The time an event acts at (any ordered value: seconds, or the
        engine's internal sample); default ``event.time_s``.  Events whose
        times compare equal are simultaneous.
    sounding : iterable
        Note identities (:func:`note_identity`) sounding before the first
        event (the engine's held and ringing keys).

    Returns
    -------
    list
        A new list; the sort is stable, so events at different times, and
        simultaneous events other than the note-offs above, keep their
        given order.
    """
    if time_of is None:
        def time_of(e):
            return e.time_s
    times = [time_of(e) for e in events]
    order = sorted(range(len(events)), key=times.__getitem__)
    now = set(sounding)
    out: list = []
    i, n = 0, len(order)
    while i < n:
        t = times[order[i]]
        j = i + 1
        while j < n and times[order[j]] == t:
            j += 1
        if j == i + 1:                          # alone at its time: the common case
            e = events[order[i]]
            r = note_role(e)
            if r == ON:
                now.add(note_identity(e))
            elif r == OFF:
                now.discard(note_identity(e))
            out.append(e)
            i = j
            continue
        first, middle, last = [], [], []
        closed, begun = set(), set()
        for idx in order[i:j]:
            e = events[idx]
            r = note_role(e)
            if r == OFF:
                k = note_identity(e)
                if k in now and k not in closed:
                    closed.add(k)               # ends a note begun earlier
                    first.append(e)
                elif k in begun:
                    begun.discard(k)            # a zero-length note: after its note-on
                    last.append(e)
                else:
                    first.append(e)             # nothing to release
            else:
                if r == ON:
                    begun.add(note_identity(e))
                middle.append(e)
        for e in first:
            now.discard(note_identity(e))
        for e in middle:
            if note_role(e) == ON:
                now.add(note_identity(e))
        for e in last:
            now.discard(note_identity(e))
        out.extend(first)
        out.extend(middle)
        out.extend(last)
        i = j
    return out
