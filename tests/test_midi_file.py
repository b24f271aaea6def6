"""Tests of synth.io.midi: real files against /work/shared/midi/SOURCES.md, malformed files, synthetic SMFs."""

from __future__ import annotations

import io
import struct
from collections import Counter

import mido
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from synth.io.errors import MidiFileError, SynthError
from synth.io.midi import (
    EVENT_KINDS,
    MAX_DURATION_S,
    MidiEvent,
    midi_file_duration_s,
    read_midi_file,
)

from helpers import shared_dir

MIDI_DIR = shared_dir() / "midi"
MALFORMED = MIDI_DIR / "malformed"

needs_corpus = pytest.mark.skipif(not MIDI_DIR.is_dir(), reason="shared MIDI corpus not present")

# From SOURCES.md: file -> (Dur s, Notes, CC64, (vel min, vel max))
SOURCES_TABLE = {
    "rac_op23_5.mid": (197.1, 3861, 374, (16, 113)),
    "chpn_op25_e11.mid": (187.0, 3172, 271, (18, 121)),
    "deb_clai.mid": (248.6, 1491, 327, (20, 92)),
    "hp956bx4547_exp.mid": (76.8, 1096, 258, (30, 90)),
    "kw569bw0899_exp.mid": (225.8, 2233, 540, (30, 90)),
    "HerGoldenHairWasCurlingDown.mid": (57.0, 220, 0, (80, 105)),
    "ButchersMarchiiThe.mid": (72.0, 350, 0, (80, 105)),
    "PatWardsslide.mid": (64.4, 281, 0, (80, 105)),
}


def _check_invariants(events: list[MidiEvent]) -> None:
    times = [e.time_s for e in events]
    assert times == sorted(times)
    assert all(t >= 0 for t in times)
    for a, b in zip(events, events[1:]):
        if a.time_s == b.time_s and b.kind == "note_off":
            assert a.kind == "note_off", "note-off after another event at the same time"
    for e in events:
        assert e.kind in EVENT_KINDS
        assert 0 <= e.channel <= 15
        if e.kind == "note_on":
            assert 0 < e.value <= 1 and 0 <= e.key <= 127
        elif e.kind == "note_off":
            assert 0 <= e.value <= 1 and 0 <= e.key <= 127
        elif e.kind == "control":
            assert 0 <= e.value <= 1 and 0 <= e.key <= 127
        elif e.kind == "program":
            assert 0 <= e.key <= 127
        elif e.kind == "pitch_bend":
            assert -1 <= e.value <= 1 and e.key == -1


# --------------------------------------------------------------------------
# Real files
# --------------------------------------------------------------------------


@needs_corpus
def test_table_covers_every_real_file():
    assert sorted(p.name for p in MIDI_DIR.glob("*.mid")) == sorted(SOURCES_TABLE)


@needs_corpus
@pytest.mark.parametrize("name", sorted(SOURCES_TABLE))
def test_real_file_agrees_with_sources_table(name):
    dur, notes, cc64, (vmin, vmax) = SOURCES_TABLE[name]
    ev = read_midi_file(MIDI_DIR / name)
    _check_invariants(ev)
    counts = Counter(e.kind for e in ev)
    assert counts["note_on"] == notes
    assert counts["note_off"] == notes  # all these files release every note
    assert abs(midi_file_duration_s(ev) - dur) <= 0.1
    assert sum(1 for e in ev if e.kind == "control" and e.key == 64) == cc64
    vel = np.array([e.value for e in ev if e.kind == "note_on"])
    # normalised once: v/127, so v is recovered exactly
    raw = vel * 127
    assert np.allclose(raw, np.round(raw), atol=1e-9)
    assert round(raw.min()) == vmin and round(raw.max()) == vmax
    pedal = {e.value for e in ev if e.kind == "control" and e.key == 64}
    assert pedal <= {0.0, 1 / 127, 1.0}


@needs_corpus
def test_real_file_times_match_mido_iteration():
    # mido's own iteration (cumulative float seconds) as an independent clock
    path = MIDI_DIR / "deb_clai.mid"  # 733 tempo changes, 8..132 BPM
    t = 0.0
    ref = []
    for msg in mido.MidiFile(path):
        t += msg.time
        if msg.type == "note_on" and msg.velocity > 0:
            ref.append(t)
    ours = [e.time_s for e in read_midi_file(path) if e.kind == "note_on"]
    assert len(ours) == len(ref)
    assert np.max(np.abs(np.sort(ours) - np.sort(ref))) < 1e-6


@needs_corpus
def test_text_meta_in_odd_encoding_is_harmless():
    ev = read_midi_file(MIDI_DIR / "HerGoldenHairWasCurlingDown.mid")
    keys = {e.key for e in ev if e.kind == "note_on"}
    assert min(keys) == 66 and max(keys) == 78


# --------------------------------------------------------------------------
# Malformed and unusual files
# --------------------------------------------------------------------------

MALFORMED_ERRORS = {
    "test-corrupt-file-missing-byte.mid": "truncated",
    "PiDamaged.mid": "truncated",
    "test-2-tracks-type-2.mid": "format 2",
    "test-running-status-sysex.mid": "runs past the end of the track",
    "test-illegal-message-all.mid": "undefined status byte 0xf4",
    "negative_delta.mid": "implausible length 22369622.6 s",
    "midiasm_reference.mid": "data byte must be in range 0..127",
}
MALFORMED_OK = {"notes-with-missing-note-offs.mid", "Beethoven.rmi", "test-non-midi-track.mid"}


@needs_corpus
def test_every_malformed_file_is_covered():
    assert sorted(p.name for p in MALFORMED.iterdir()) == sorted(set(MALFORMED_ERRORS) | MALFORMED_OK)


@needs_corpus
@pytest.mark.parametrize("name", sorted(MALFORMED_ERRORS))
def test_malformed_file_gives_one_line_error(name):
    with pytest.raises(MidiFileError) as ei:
        read_midi_file(MALFORMED / name)
    msg = str(ei.value)
    assert "\n" not in msg
    assert name in msg.split(":")[0]
    assert MALFORMED_ERRORS[name] in msg


@needs_corpus
def test_type2_message_is_clear():
    with pytest.raises(MidiFileError, match=r"format 2 \(independent sequence patterns\) is not supported"):
        read_midi_file(MALFORMED / "test-2-tracks-type-2.mid")


@needs_corpus
def test_pidamaged_names_the_declared_track_count():
    with pytest.raises(MidiFileError, match="of 30"):
        read_midi_file(MALFORMED / "PiDamaged.mid")


@needs_corpus
def test_missing_note_offs_are_kept():
    ev = read_midi_file(MALFORMED / "notes-with-missing-note-offs.mid")
    _check_invariants(ev)
    on = Counter(e.key for e in ev if e.kind == "note_on")
    off = Counter(e.key for e in ev if e.kind == "note_off")
    assert sum(on.values()) == 7 and sum(off.values()) == 6
    assert on[59] >= 1 and off[59] == 0
    assert on[48] == 1 and off[48] == 1  # starts in track 0, ends in track 1
    t_on = next(e.time_s for e in ev if e.kind == "note_on" and e.key == 48)
    t_off = next(e.time_s for e in ev if e.kind == "note_off" and e.key == 48)
    assert t_off > t_on
    assert abs(midi_file_duration_s(ev) - 2.0) <= 0.1


@pytest.mark.slow  # over 2 s on a 2-core machine (2026-12-03: 2.7 s in the fast tier)
@needs_corpus
def test_rmid_wrapper_is_stripped():
    ev = read_midi_file(MALFORMED / "Beethoven.rmi")
    _check_invariants(ev)
    assert abs(midi_file_duration_s(ev) - 379.3) <= 0.1
    data = (MALFORMED / "Beethoven.rmi").read_bytes()
    ref = mido.MidiFile(file=io.BytesIO(data[20:]))
    n_ref = sum(1 for m in ref if m.type == "note_on" and m.velocity > 0)
    assert sum(1 for e in ev if e.kind == "note_on") == n_ref > 1000


@needs_corpus
def test_unknown_chunk_before_track_is_skipped():
    ev = read_midi_file(MALFORMED / "test-non-midi-track.mid")
    assert sum(1 for e in ev if e.kind == "note_on") == 8
    assert midi_file_duration_s(ev) > 0


# --------------------------------------------------------------------------
# Synthetic files
# --------------------------------------------------------------------------


def _smf(tracks: list[list[mido.Message]], tpb: int = 480, fmt: int = 1) -> bytes:
    mf = mido.MidiFile(type=fmt, ticks_per_beat=tpb)
    for msgs in tracks:
        mf.tracks.append(mido.MidiTrack(msgs))
    buf = io.BytesIO()
    mf.save(file=buf)
    return buf.getvalue()


def _chunks(data: bytes) -> list[tuple[bytes, bytes]]:
    out, off = [], 0
    while off < len(data):
        cid, size = data[off:off + 4], struct.unpack(">I", data[off + 4:off + 8])[0]
        out.append((cid, data[off + 8:off + 8 + size]))
        off += 8 + size
    return out


def _join(chunks: list[tuple[bytes, bytes]]) -> bytes:
    return b"".join(cid + struct.pack(">I", len(body)) + body for cid, body in chunks)


def _read_bytes(tmp_path, data: bytes, name: str = "t.mid") -> list[MidiEvent]:
    p = tmp_path / name
    p.write_bytes(data)
    return read_midi_file(p)


M, Meta = mido.Message, mido.MetaMessage


def test_tempo_changes_follow_every_track(tmp_path):
    conductor = [Meta("set_tempo", tempo=500_000, time=0),
                 Meta("set_tempo", tempo=1_000_000, time=480)]  # at 0.5 s: 60 BPM
    t1 = [M("note_on", note=60, velocity=100, time=0),
          M("note_off", note=60, velocity=0, time=960)]  # tick 960: 0.5 + 1.0 = 1.5 s
    t2 = [M("note_on", note=64, velocity=127, channel=3, time=720),  # 0.5 + 0.5 = 1.0 s
          M("note_on", note=64, velocity=0, channel=3, time=1680)]   # tick 2400: 0.5 + 4.0
    ev = _read_bytes(tmp_path, _smf([conductor, t1, t2]))
    got = [(e.kind, e.key, e.channel, round(e.time_s, 12)) for e in ev]
    assert got == [("note_on", 60, 0, 0.0), ("note_on", 64, 3, 1.0), ("note_off", 60, 0, 1.5),
                   ("note_off", 64, 3, 4.5)]
    assert midi_file_duration_s(ev) == pytest.approx(4.5, abs=1e-12)


def test_value_normalisation(tmp_path):
    track = [
        M("note_on", note=60, velocity=1, time=0),
        M("note_on", note=61, velocity=127, time=0),
        M("note_off", note=60, velocity=0, time=10),
        M("note_on", note=61, velocity=0, time=0),  # -> note_off, velocity 64
        M("note_off", note=62, velocity=127, time=0),
        M("control_change", control=64, value=127, time=10),
        M("control_change", control=1, value=0, time=0),
        M("program_change", program=42, channel=9, time=0),
        M("pitchwheel", pitch=-8192, time=10),
        M("pitchwheel", pitch=0, time=0),
        M("pitchwheel", pitch=8191, time=0),
        M("aftertouch", value=50, time=0),
        M("sysex", data=[1, 2, 3], time=0),  # dropped
    ]
    ev = _read_bytes(tmp_path, _smf([track], fmt=0))
    _check_invariants(ev)
    vals = [(e.kind, e.key, e.value) for e in ev]
    assert vals == [
        ("note_on", 60, 1 / 127), ("note_on", 61, 1.0),
        ("note_off", 60, 0.0), ("note_off", 61, 64 / 127), ("note_off", 62, 1.0),
        ("control", 64, 1.0), ("control", 1, 0.0), ("program", 42, 0.0),
        ("pitch_bend", -1, -1.0), ("pitch_bend", -1, 0.0), ("pitch_bend", -1, 1.0),
        ("channel_pressure", -1, 50 / 127),
    ]
    assert ev[7].channel == 9


def test_note_off_first_at_equal_times_otherwise_stable(tmp_path):
    t1 = [M("control_change", control=64, value=127, time=100),
          M("note_on", note=62, velocity=90, time=0),
          M("note_off", note=60, velocity=40, time=0),
          M("control_change", control=7, value=100, time=0)]
    t2 = [M("note_on", note=60, velocity=80, time=0),
          M("note_on", note=60, velocity=0, time=100)]  # same tick as track 1's events
    ev = _read_bytes(tmp_path, _smf([t1, t2]))
    at = [(e.kind, e.key) for e in ev if e.time_s > 0]
    assert at == [("note_off", 60), ("note_off", 60),  # note-offs first, file/track order kept
                  ("control", 64), ("note_on", 62), ("control", 7)]


def test_smpte_division(tmp_path):
    track = [M("note_on", note=60, velocity=100, time=500),
             Meta("set_tempo", tempo=2_000_000, time=0),  # irrelevant under SMPTE
             M("note_off", note=60, velocity=0, time=1000)]
    data = bytearray(_smf([track], fmt=0))
    data[12:14] = struct.pack(">bB", -25, 40)  # 25 fps x 40 ticks = 1000 ticks/s
    ev = _read_bytes(tmp_path, bytes(data))
    assert [round(e.time_s, 12) for e in ev] == [0.5, 1.5]
    data[12:14] = struct.pack(">bB", -29, 100)  # 29.97 drop-frame
    ev = _read_bytes(tmp_path, bytes(data))
    assert ev[0].time_s == pytest.approx(500 / (100 * 30000 / 1001))
    data[12:14] = struct.pack(">bB", -26, 40)
    with pytest.raises(MidiFileError, match="SMPTE"):
        _read_bytes(tmp_path, bytes(data))


def _two_track_file() -> bytes:
    return _smf([[M("note_on", note=60, velocity=100, time=0), M("note_off", note=60, time=480)],
                 [M("note_on", note=67, velocity=100, time=240), M("note_off", note=67, time=480)]])


def test_unknown_chunks_between_and_after_tracks_are_skipped(tmp_path):
    chunks = _chunks(_two_track_file())
    assert [c for c, _ in chunks] == [b"MThd", b"MTrk", b"MTrk"]
    weird = [chunks[0], (b"XFIH", b"\x00" * 7), chunks[1], (b"Junk", b"junk data"),
             chunks[2], (b"Tail", b"x")]
    ev = _read_bytes(tmp_path, _join(weird))
    assert [(e.kind, e.key) for e in ev] == [("note_on", 60), ("note_on", 67),
                                             ("note_off", 60), ("note_off", 67)]


def test_rmid_with_odd_sized_chunk_before_data(tmp_path):
    smf = _two_track_file()
    info = b"LIST" + struct.pack("<I", 3) + b"abc" + b"\x00"  # odd size, padded
    data_chunk = b"data" + struct.pack("<I", len(smf)) + smf
    body = b"RMID" + info + data_chunk
    ev = _read_bytes(tmp_path, b"RIFF" + struct.pack("<I", len(body)) + body, "x.rmi")
    assert len(ev) == 4
    with pytest.raises(MidiFileError, match="not a MIDI file"):
        _read_bytes(tmp_path, b"RIFF" + struct.pack("<I", 4) + b"WAVE", "x.wav")


def test_every_truncation_is_a_midi_file_error(tmp_path):
    data = _two_track_file()
    for n in range(len(data)):
        with pytest.raises(MidiFileError) as ei:
            _read_bytes(tmp_path, data[:n])
        assert "\n" not in str(ei.value)
        if n >= 14:
            assert "truncated" in str(ei.value)
    assert len(_read_bytes(tmp_path, data)) == 4


def test_length_limit(tmp_path):
    # tpb=1 at 120 BPM: 0.5 s per tick
    def file_of_length(seconds: float) -> bytes:
        ticks = int(seconds / 0.5)
        return _smf([[M("note_on", note=60, velocity=100, time=0),
                      M("note_off", note=60, time=ticks)]], tpb=1, fmt=0)

    ev = _read_bytes(tmp_path, file_of_length(MAX_DURATION_S - 60))
    assert midi_file_duration_s(ev) == pytest.approx(MAX_DURATION_S - 60)
    with pytest.raises(MidiFileError, match=r"implausible length 21660\.0 s \(6\.0 h\)"):
        _read_bytes(tmp_path, file_of_length(MAX_DURATION_S + 60))


def test_file_without_notes_is_fine(tmp_path):
    ev = _read_bytes(tmp_path, _smf([[Meta("track_name", name="empty", time=0)]], fmt=0))
    assert ev == [] and midi_file_duration_s(ev) == 0.0
    ev = _read_bytes(tmp_path, _smf([[M("control_change", control=64, value=127, time=5)]]))
    assert [e.kind for e in ev] == ["control"]


@pytest.mark.parametrize("content,fragment", [
    (b"", "empty file"),
    (b"hello world, not midi", "no MThd header"),
    (b"MThd\x00\x00\x00\x06\x00\x01\x00\x00\x01\xe0", "0 tracks"),
    (b"MThd\x00\x00\x00\x06\x00\x03\x00\x01\x01\xe0", "unknown SMF format 3"),
    (b"MThd\x00\x00\x00\x06\x00\x00\x00\x01\x00\x00MTrk\x00\x00\x00\x00", "time division"),
    (b"MThd\x00\x00\x00\x02\x00\x00\x00\x01\x01\xe0", "too short"),
])
def test_bad_headers(tmp_path, content, fragment):
    with pytest.raises(MidiFileError, match=fragment):
        _read_bytes(tmp_path, content)


def test_unreadable_paths(tmp_path):
    with pytest.raises(MidiFileError, match="cannot read MIDI file"):
        read_midi_file(tmp_path / "missing.mid")
    with pytest.raises(MidiFileError, match="cannot read MIDI file"):
        read_midi_file(tmp_path)
    assert issubclass(MidiFileError, SynthError)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.data())
def test_corrupted_bytes_never_raise_anything_else(tmp_path, data):
    base = bytearray(_smf([
        [Meta("set_tempo", tempo=400_000, time=0), Meta("key_signature", key="D", time=0),
         Meta("text", text="abc", time=0)],
        [M("note_on", note=60, velocity=100, time=0), M("pitchwheel", pitch=100, time=10),
         M("sysex", data=[1, 2], time=0), M("note_off", note=60, time=480)],
    ]))
    n = data.draw(st.integers(1, 6))
    for _ in range(n):
        i = data.draw(st.integers(0, len(base) - 1))
        base[i] = data.draw(st.integers(0, 255))
    try:
        ev = _read_bytes(tmp_path, bytes(base))
    except MidiFileError as e:
        assert "\n" not in str(e)
    else:
        _check_invariants(ev)
