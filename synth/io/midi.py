"""Reading Standard MIDI Files into a flat, time-ordered list of normalised events.

MIDI's 7- and 14-bit integers are normalised here, once, so that nothing
downstream ever sees a raw MIDI value:

====================  ======  ======================================================
kind                  key     value
====================  ======  ======================================================
``note_on``           note    velocity / 127, in (0, 1]
``note_off``          note    release velocity / 127, in [0, 1]; a note-on with
                              velocity 0 becomes a note-off with the MIDI-spec
                              default 64/127
``control``           CC no.  controller value / 127, in [0, 1]
``program``           prog.   0.0
``pitch_bend``        -1      bend in [-1, 1] (-8192 -> -1, 0 -> 0, +8191 -> +1)
``channel_pressure``  -1      channel pressure (aftertouch) / 127, in [0, 1]
``poly_pressure``     note    polyphonic key pressure / 127, in [0, 1]
====================  ======  ======================================================

System messages (SysEx, clock, ...) are dropped, and counted by
:func:`read_midi_file` when asked (the render's report lists them); the
engine lists the channel messages a preset does not play (pressure on the
grand, say).  Meta events carry no sound. Times are in
seconds from the start of the file and follow every tempo change (and SMPTE
time division). Events are sorted by time; simultaneous events keep their
file order (track order for simultaneous events of different tracks),
except note-offs and note-ons of one key, which follow
:func:`synth.engine.order.order_events`: the note-off of an earlier note
first, the note-off of a zero-length note after its note-on.

The byte-level framing (RIFF RMID wrapper, MThd header, track chunks, unknown
chunks, truncation) is done here; the event data of each track is decoded by
mido. Every failure is a :class:`~synth.io.errors.MidiFileError` whose
message is one line naming the file and what is wrong.
"""

from __future__ import annotations

import io
import os
import struct
from dataclasses import dataclass

import mido

from synth.engine.order import order_events
from synth.io.errors import MidiFileError, display_path

__all__ = [
    "MidiEvent",
    "EVENT_KINDS",
    "MAX_DURATION_S",
    "read_midi_file",
    "read_midi_bytes",
    "read_mido_file",
    "is_mido_file",
    "normalise_fields",
    "midi_to_events",
    "midi_file_duration_s",
    "normalise_message",
    "dropped_name",
    "plays_channel",
    "DRUM_CHANNEL",
]

#: Files longer than this (seconds) are rejected as implausible (broken delta times).
MAX_DURATION_S = 6 * 3600.0

EVENT_KINDS = ("note_on", "note_off", "control", "program", "pitch_bend", "channel_pressure",
               "poly_pressure")

_DEFAULT_TEMPO_US = 500_000  # 120 BPM
_NOTE_OFF_DEFAULT_VELOCITY = 64  # MIDI 1.0: note-on velocity 0 == note-off velocity 64
_SMPTE_FPS = {24: 24.0, 25: 25.0, 29: 30000.0 / 1001.0, 30: 30.0}


@dataclass(frozen=True)
class MidiEvent:
    """One normalised channel event.

    Attributes
    ----------
    time_s : float
        Time from the start of the file, s (>= 0).
    kind : str
        One of :data:`EVENT_KINDS`: ``"note_on"``, ``"note_off"``,
        ``"control"``, ``"program"``, ``"pitch_bend"``,
        ``"channel_pressure"``, ``"poly_pressure"``.
    channel : int
        MIDI channel 0..15.
    key : int
        Note number (note events, poly_pressure), controller number
        (control), program number (program), or -1 (pitch_bend,
        channel_pressure).
    value : float
        Normalised value, see the module docstring.
    """

    time_s: float
    kind: str
    channel: int
    key: int
    value: float


# --------------------------------------------------------------------------
# Byte-level framing
# --------------------------------------------------------------------------


@dataclass(frozen=True)
class _Framed:
    fmt: int
    division: int  # raw 16-bit header word
    tracks: tuple[bytes, ...]  # payloads of the MTrk chunks, in order


def _fail(shown: str, what: str) -> MidiFileError:
    return MidiFileError(f"{shown}: {what}")


def _unwrap_riff(data: bytes, shown: str) -> bytes:
    """Return the SMF embedded in a RIFF RMID file (the payload of its 'data' chunk)."""
    if len(data) < 12:
        raise _fail(shown, "truncated RIFF header")
    form = data[8:12]
    if form != b"RMID":
        kind = " (a WAV file)" if form == b"WAVE" else ""
        raise _fail(shown, f"not a MIDI file: RIFF file of type {form.decode('latin1')!r}{kind}, "
                           "not RIFF RMID")
    off = 12
    while off + 8 <= len(data):
        cid = data[off:off + 4]
        (size,) = struct.unpack("<I", data[off + 4:off + 8])
        body = data[off + 8:off + 8 + size]
        if cid == b"data":
            if len(body) < size:
                raise _fail(shown, f"truncated: RMID data chunk declares {size} bytes, "
                                   f"{len(body)} present")
            return body
        off += 8 + size + (size & 1)  # RIFF chunks are padded to even sizes
    raise _fail(shown, "RIFF RMID file without a 'data' chunk")


def _frame(data: bytes, shown: str) -> _Framed:
    if data[:4] == b"RIFF":
        data = _unwrap_riff(data, shown)
    if data[:4] != b"MThd":
        if not data:
            raise _fail(shown, "not a MIDI file: empty file")
        raise _fail(shown, f"not a MIDI file: no MThd header of a Standard MIDI File "
                           f"(starts with {data[:4]!r})")
    if len(data) < 14:
        raise _fail(shown, f"truncated: {len(data)} bytes, the MThd header alone needs 14")
    (hlen,) = struct.unpack(">I", data[4:8])
    if hlen < 6:
        raise _fail(shown, f"MThd header length {hlen} is too short (at least 6)")
    if 8 + hlen > len(data):
        raise _fail(shown, f"truncated: MThd header declares {hlen} bytes")
    fmt, ntrks, division = struct.unpack(">HHH", data[8:14])
    if fmt == 2:
        raise _fail(shown, "SMF format 2 (independent sequence patterns) is not supported; "
                           "use format 0 or 1")
    if fmt > 2:
        raise _fail(shown, f"unknown SMF format {fmt} (supported: 0, 1)")
    if ntrks == 0:
        raise _fail(shown, "the MThd header declares 0 tracks")
    if division & 0x8000:
        fps = 256 - (division >> 8)
        tpf = division & 0xFF
        if fps not in _SMPTE_FPS or tpf == 0:
            raise _fail(shown, f"invalid SMPTE time division 0x{division:04x} "
                               "(frames per second must be 24, 25, 29 or 30, ticks per frame > 0)")
    elif division == 0:
        raise _fail(shown, "time division is 0 ticks per quarter note (must be > 0)")

    tracks: list[bytes] = []
    off = 8 + hlen
    while off < len(data) and len(tracks) < ntrks:
        if off + 8 > len(data):
            raise _fail(shown, f"truncated: file ends inside a chunk header after "
                               f"{len(tracks)} of {ntrks} tracks")
        cid = data[off:off + 4]
        (size,) = struct.unpack(">I", data[off + 4:off + 8])
        body = data[off + 8:off + 8 + size]
        if len(body) < size:
            what = f"track {len(tracks) + 1} of {ntrks}" if cid == b"MTrk" else \
                f"chunk {cid!r}"
            raise _fail(shown, f"truncated: {what} declares {size} bytes but only "
                               f"{len(body)} remain")
        if cid == b"MTrk":
            tracks.append(body)
        # Any other chunk type is skipped, as the SMF specification requires.
        off += 8 + size
    if len(tracks) < ntrks:
        raise _fail(shown, f"truncated: the header declares {ntrks} tracks, the file "
                           f"holds {len(tracks)}")
    return _Framed(fmt, division, tuple(tracks))


def _decode_track(body: bytes, division: int, index: int, ntrks: int, shown: str) -> mido.MidiTrack:
    """Decode one MTrk payload with mido (in a one-track SMF of its own)."""
    mini = (b"MThd" + struct.pack(">IHHH", 6, 0, 1, division)
            + b"MTrk" + struct.pack(">I", len(body)) + body)
    where = f"track {index + 1} of {ntrks}"
    try:
        mf = mido.MidiFile(file=io.BytesIO(mini), clip=False)
    except EOFError:
        raise _fail(shown, f"{where}: event data runs past the end of the track "
                           "(corrupt or truncated track)") from None
    except Exception as e:  # mido raises OSError, ValueError, KeyError, ... on bad bytes
        msg = str(e).splitlines()[0] if str(e) else type(e).__name__
        raise _fail(shown, f"{where}: invalid event data ({msg})") from None
    return mf.tracks[0]


# --------------------------------------------------------------------------
# Public API
# --------------------------------------------------------------------------


def _pitch_bend_value(pitch: int) -> float:
    return pitch / 8192.0 if pitch < 0 else pitch / 8191.0


def normalise_message(msg: mido.Message) -> tuple[str, int, int, float] | None:
    """Normalise one channel message, as read from a file or from a live port.

    Parameters
    ----------
    msg : mido.Message
        Any message (meta messages and system messages included).

    Returns
    -------
    tuple (kind, channel, key, value) or None
        ``kind``, ``key`` and ``value`` as in the module docstring's table
        (values in [0, 1], bend in [-1, 1]); None for a message that is
        dropped (SysEx, clock, meta events, ...).  The file
        reader and ``synth play`` both use this function, so a file and a
        keyboard are normalised identically.
    """
    typ = msg.type
    if typ == "note_on":
        if msg.velocity > 0:
            return ("note_on", msg.channel, msg.note, msg.velocity / 127.0)
        return ("note_off", msg.channel, msg.note, _NOTE_OFF_DEFAULT_VELOCITY / 127.0)
    if typ == "note_off":
        return ("note_off", msg.channel, msg.note, msg.velocity / 127.0)
    if typ == "control_change":
        return ("control", msg.channel, msg.control, msg.value / 127.0)
    if typ == "program_change":
        return ("program", msg.channel, msg.program, 0.0)
    if typ == "pitchwheel":
        return ("pitch_bend", msg.channel, -1, _pitch_bend_value(msg.pitch))
    if typ == "aftertouch":
        return ("channel_pressure", msg.channel, -1, msg.value / 127.0)
    if typ == "polytouch":
        return ("poly_pressure", msg.channel, msg.note, msg.value / 127.0)
    return None


#: names of the messages dropped by :func:`normalise_message`, for reports
DROPPED_NAMES = {
    "sysex": "system exclusive",
}


def dropped_name(msg) -> str | None:
    """How a message that :func:`normalise_message` drops is named in the
    list of ignored messages, or None for meta messages (tempo, names, end
    of track: they carry no sound to ignore)."""
    if getattr(msg, "is_meta", False):
        return None
    return DROPPED_NAMES.get(msg.type, msg.type.replace("_", " "))


class MidiEvents(list):
    """A file's :class:`MidiEvent` list, in playing order, with its length.

    Attributes
    ----------
    length_s : float
        The file's length (s): the time of its last message, its trailing
        meta events (the end of track) included, so at least the last
        event's time.
    """

    def __init__(self, events=(), length_s: float = 0.0):
        super().__init__(events)
        self.length_s = float(length_s)


def read_midi_file(path: str | os.PathLike[str], dropped: dict | None = None) -> list[MidiEvent]:
    """Read a Standard MIDI File (format 0 or 1, optionally RIFF RMID-wrapped).

    Parameters
    ----------
    path : str or path-like
        The ``.mid``/``.rmi`` file.
    dropped : dict or None
        If given, the channel and system messages that are not returned are
        counted in it by name (:func:`dropped_name`: ``{"system
        exclusive": 12}``).

    Returns
    -------
    MidiEvents
        Channel events in playing order (see the module docstring), a list
        with the file's length (``length_s``). A file without notes yields
        whatever events it has (possibly none); notes without a note-off are
        kept as they are (the caller releases them).

    Raises
    ------
    MidiFileError
        Unreadable file, not an SMF, SMF format 2, truncated file, undecodable
        event data, or a file longer than :data:`MAX_DURATION_S` (which only
        broken delta times produce). The message is one line naming the file.
    """
    shown = display_path(path)
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError as e:
        raise _fail(shown, f"cannot read MIDI file ({e.strerror or e})") from None
    return read_midi_bytes(data, shown, dropped)


def read_midi_bytes(data: bytes, shown: str = "<memory>",
                    dropped: dict | None = None) -> list[MidiEvent]:
    """:func:`read_midi_file` on the bytes of a file already in memory (a
    ``mido.MidiFile`` saved to a buffer: :func:`synth.render_midi`).

    Parameters
    ----------
    data : bytes
        The whole Standard MIDI File (optionally RIFF RMID-wrapped).
    shown : str
        Its name in error messages.
    dropped : dict or None
        As :func:`read_midi_file`.

    Returns
    -------
    list of MidiEvent

    Raises
    ------
    MidiFileError
        As :func:`read_midi_file`, naming ``shown``.
    """
    framed = _frame(data, shown)
    ntrks = len(framed.tracks)
    tracks = [_decode_track(body, framed.division, i, ntrks, shown)
              for i, body in enumerate(framed.tracks)]
    merged = mido.merge_tracks(tracks, skip_checks=True)

    smpte = bool(framed.division & 0x8000)
    if smpte:
        fps = _SMPTE_FPS[256 - (framed.division >> 8)]
        sec_per_tick = 1.0 / (fps * (framed.division & 0xFF))
    else:
        tpb = framed.division
        sec_per_tick = _DEFAULT_TEMPO_US * 1e-6 / tpb

    events: list[MidiEvent] = []
    tick = 0
    seg_tick = 0  # tick and time at which the current tempo took effect
    seg_s = 0.0
    for msg in merged:
        tick += msg.time
        t = seg_s + (tick - seg_tick) * sec_per_tick
        typ = msg.type
        if typ == "set_tempo":
            if not smpte:
                seg_s, seg_tick = t, tick
                sec_per_tick = msg.tempo * 1e-6 / tpb
            continue
        norm = normalise_message(msg)
        if norm is not None:
            events.append(MidiEvent(t, *norm))
        elif dropped is not None:
            name = dropped_name(msg)
            if name is not None:
                dropped[name] = dropped.get(name, 0) + 1
    length_s = seg_s + (tick - seg_tick) * sec_per_tick  # includes trailing meta events
    if length_s > MAX_DURATION_S:
        raise _fail(shown, f"implausible length {length_s:.1f} s ({length_s / 3600:.1f} h), "
                           f"more than the {MAX_DURATION_S / 3600:g} h limit (broken delta times?)")
    # times are already non-decreasing; simultaneous notes in the engine's order
    return MidiEvents(order_events(events), length_s)


def read_mido_file(midi_file: mido.MidiFile, dropped: dict | None = None) -> tuple[list[MidiEvent], str]:
    """:func:`read_midi_file` on a ``mido.MidiFile`` made or loaded in
    Python (:func:`synth.render_midi`): saved to bytes and read as a file
    is, so that both give the same events.

    Returns
    -------
    (list of MidiEvent, str)
        The events, and the name messages give it (its ``filename``, or
        ``<mido.MidiFile>``).

    Raises
    ------
    MidiFileError
        mido cannot save it (a message out of range), or as :func:`read_midi_file`.
    """
    shown = display_path(midi_file.filename) if midi_file.filename else "<mido.MidiFile>"
    buf = io.BytesIO()
    try:
        midi_file.save(file=buf)
    except (ValueError, TypeError, OSError) as e:
        raise _fail(shown, "cannot be saved as a Standard MIDI File "
                           f"({str(e).splitlines()[0] if str(e) else type(e).__name__})") from None
    return read_midi_bytes(buf.getvalue(), shown, dropped), shown


def is_mido_file(obj) -> bool:
    """Whether ``obj`` is a ``mido.MidiFile``."""
    return isinstance(obj, mido.MidiFile)


def normalise_fields(msg_type: str, **fields) -> tuple[str, int, int, float]:
    """A channel message given by its type and fields (mido's names:
    ``note_on`` with ``channel``, ``note``, ``velocity``; ``control_change``
    with ``control``, ``value``; ``pitchwheel`` with ``pitch``), normalised
    by :func:`normalise_message` as a file's or a keyboard's is
    (:class:`synth.Instrument`'s events).  Values are checked by the
    caller; mido's own check raises ValueError."""
    return normalise_message(mido.Message(msg_type, **fields))


#: General MIDI's percussion channel (channel 10, 0-based 9)
DRUM_CHANNEL = 9


def plays_channel(channel: int, channels=None, drums: bool = False) -> bool:
    """Whether MIDI ``channel`` (0-15) plays: among ``channels`` (None:
    all), and not General MIDI's drum channel unless ``drums``."""
    if channels is not None and channel not in channels:
        return False
    return drums or channel != DRUM_CHANNEL


#: the kinds that become engine events (a program change does not: a
#: render plays one preset, the live player switches it itself)
_PLAYED_KINDS = frozenset(k for k in EVENT_KINDS if k != "program")


def midi_to_events(midi_events, channels=None, drums: bool = False, ignored: dict | None = None):
    """Normalised MIDI events -> engine events (notes, controllers, pitch
    bend, channel and polyphonic key pressure).

    The one place where MIDI becomes the engine's
    :class:`synth.engine.engine.Event` (velocity and controller values
    already in [0, 1] from :func:`normalise_message`), for a file
    (:func:`read_midi_file`) and for the live player alike.  MPE (one
    channel per note) needs nothing here: the engine plays each channel's
    bend, pressure and controllers on that channel's notes, and its MPE
    zones (:mod:`synth.engine.mpe`) combine a zone's manager channel with
    its member channels, for a file and a keyboard alike.

    Parameters
    ----------
    midi_events : iterable of MidiEvent
    channels : collection of int or None
        The MIDI channels (0-15) that play; None: every channel.
    drums : bool
        Play channel 10 (:data:`DRUM_CHANNEL`), General MIDI's percussion
        channel, as pitched notes too; by default its messages are skipped,
        as a General MIDI file means drums there.
    ignored : dict or None
        If given, what is not played is counted in it by name: the skipped
        channels' messages and program changes (a render plays one preset).

    Returns
    -------
    list of Event
    """
    from synth.engine.engine import Event

    def skip(what: str) -> None:
        if ignored is not None:
            ignored[what] = ignored.get(what, 0) + 1

    out = []
    for m in midi_events:
        if channels is not None and m.channel not in channels:
            skip(f"channel {m.channel + 1} messages (not in --channels)")
            continue
        if m.channel == DRUM_CHANNEL and not drums:
            skip("channel 10 messages (General MIDI drums; --drums plays them)")
            continue
        if m.kind in _PLAYED_KINDS:
            out.append(Event(m.time_s, m.kind, m.key, m.value, m.channel))
        elif m.kind == "program":
            skip("program change (a render plays one preset)")
    return out


def midi_file_duration_s(events: list[MidiEvent]) -> float:
    """Time of the last event, s (0.0 for no events). Meta events (end of track) do not count."""
    return max((e.time_s for e in events), default=0.0)
