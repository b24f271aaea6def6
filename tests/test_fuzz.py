"""Fuzzing of the MIDI loader and of preset files (issue 13, "Bad input").

Every case must end in a correct load or a one-line error (a
:class:`~synth.io.errors.SynthError` naming the file), never another
exception, a traceback or a hang.  The corpus is built here, with a fixed
seed, from

* small Standard MIDI Files written by this test with mido (two tracks with
  tempo changes, a chord in format 0, running status, SMPTE time, a RIFF
  RMID wrapper, 3 h of silence before a note) and the repository's own
  ``synth/presets/checks/phrases/*.mid``, mutated byte by byte (flips,
  truncations, insertions, deletions), chunk by chunk (wrong track lengths,
  wrong track counts, formats and time divisions, duplicated and spliced
  chunks) and event by event (huge and over-long variable-length delta
  times, status bytes removed to make running status, huge SysEx and meta
  lengths); plus files generated with random huge delta times;
* the shipped presets ``synth/presets/**/*.toml``, mutated as bytes and as
  TOML (values swapped for out-of-range, huge, non-finite, mistyped ones;
  lines deleted, duplicated, renamed, moved; sections dropped).

Each case has a time budget (:data:`BUDGET_S`, enforced with SIGALRM, so a
hang fails the case instead of the run), and a few mutated files go all the
way through ``synth render`` with ``--max-seconds``.  The counts, the run
time and the slowest case are printed (to the terminal, also without ``-s``).
"""

from __future__ import annotations

import io
import math
import os
import random
import re
import signal
import struct
import time
from contextlib import contextmanager
from pathlib import Path

import mido
import pytest
import soundfile as sf

from synth.apps.render import plan_render
from synth.cli import main
from synth.io.errors import MidiFileError, PresetError, SynthError
from synth.io.midi import EVENT_KINDS, MAX_DURATION_S, midi_to_events, read_midi_file
from synth.io.presets import Preset, load_preset

REPO = Path(__file__).resolve().parents[1]
PHRASES = sorted((REPO / "synth" / "presets" / "checks" / "phrases").glob("*.mid"))
PRESETS = sorted(p for p in (REPO / "synth" / "presets").rglob("*.toml")
                 if p.relative_to(REPO / "synth" / "presets").parts[0] not in ("checks", "batch"))

SEED = 20_131_304                 # fixed: every run tries the same cases
N_MIDI = 4000
N_PRESET = 3000
#: time budget of one load (s): loading a file of a few hundred bytes takes
#: about a millisecond; anything near this is a hang
BUDGET_S = 1.0


@pytest.fixture(autouse=True)
def _in_tmp(tmp_path, monkeypatch):
    """Cases are written to and named from their own directory (messages show "case.mid")."""
    monkeypatch.delenv("SYNTH_PRESET_PATH", raising=False)
    monkeypatch.chdir(tmp_path)


class CaseTimeout(Exception):
    """A fuzz case ran over its budget."""


@contextmanager
def budget(seconds: float, what: str):
    """Raise CaseTimeout if the block runs longer than `seconds` (SIGALRM:
    the main thread, Linux and macOS)."""
    def on_alarm(signum, frame):
        raise CaseTimeout(f"{what}: still running after {seconds:g} s")

    old = signal.signal(signal.SIGALRM, on_alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


# --------------------------------------------------------------------------
# MIDI seed files
# --------------------------------------------------------------------------

M = mido.Message
Meta = mido.MetaMessage


def _smf(tracks, tpb: int = 480, fmt: int = 1) -> bytes:
    mf = mido.MidiFile(type=fmt, ticks_per_beat=tpb)
    for t in tracks:
        mf.tracks.append(mido.MidiTrack(t))
    buf = io.BytesIO()
    mf.save(file=buf)
    return buf.getvalue()


def _chunk(cid: bytes, body: bytes) -> bytes:
    return cid + struct.pack(">I", len(body)) + body


def _header(fmt: int, ntrks: int, division: int) -> bytes:
    return _chunk(b"MThd", struct.pack(">HHH", fmt, ntrks, division))


def _varlen(n: int) -> bytes:
    out = [n & 0x7F]
    n >>= 7
    while n:
        out.append(0x80 | (n & 0x7F))
        n >>= 7
    return bytes(reversed(out))


def midi_seeds() -> dict[str, bytes]:
    """Small valid files of every kind the loader handles, and the repo's phrases."""
    seeds: dict[str, bytes] = {}
    seeds["two_tracks"] = _smf([
        [Meta("set_tempo", tempo=400_000, time=0), Meta("time_signature", numerator=3, denominator=4, time=0),
         Meta("key_signature", key="D", time=0), Meta("text", text="fuzz", time=0),
         Meta("set_tempo", tempo=600_000, time=960), Meta("end_of_track", time=0)],
        [M("program_change", program=5, time=0), M("note_on", note=60, velocity=100, time=0),
         M("control_change", control=64, value=127, time=10), M("pitchwheel", pitch=-3000, time=10),
         M("sysex", data=[1, 2, 3], time=0), M("aftertouch", value=20, time=5),
         M("note_on", note=64, velocity=90, time=100), M("note_off", note=60, velocity=30, time=380),
         M("control_change", control=64, value=0, time=0), M("note_on", note=64, velocity=0, time=480)],
    ])
    seeds["chord_format0"] = _smf([[
        M("note_on", note=n, velocity=70 + n % 40, time=0) for n in (48, 52, 55, 60)] + [
        M("note_off", note=n, time=96 if i == 0 else 0) for i, n in enumerate((48, 52, 55, 60))]],
        tpb=96, fmt=0)
    # running status: one status byte for three note-ons, then note-ons with velocity 0 as offs
    track = (b"\x00\x90\x3c\x64" b"\x00\x40\x64" b"\x00\x43\x64"
             b"\x83\x60\x3c\x00" b"\x00\x40\x00" b"\x00\x43\x00"
             b"\x00\xb0\x40\x7f" b"\x60\x40\x00" b"\x00\xff\x2f\x00")
    seeds["running_status"] = _header(0, 1, 480) + _chunk(b"MTrk", track)
    # SMPTE time: 25 frames of 40 ticks a second (division 0xE728)
    smpte = bytearray(_smf([[M("note_on", note=62, velocity=80, time=0),
                             M("note_off", note=62, time=1000)]], fmt=0))
    smpte[12:14] = struct.pack(">H", 0xE728)
    seeds["smpte"] = bytes(smpte)
    rmid_body = seeds["chord_format0"]
    seeds["rmid"] = b"RIFF" + struct.pack("<I", 4 + 8 + len(rmid_body)) + b"RMID" + \
        b"data" + struct.pack("<I", len(rmid_body)) + rmid_body
    # three hours of silence before one note (tpb 1 at 120 BPM: 0.5 s a tick)
    seeds["three_hours"] = _smf([[M("note_on", note=60, velocity=100, time=0),
                                  M("note_off", note=60, time=1),
                                  M("note_on", note=67, velocity=100, time=21_600),
                                  M("note_off", note=67, time=2)]], tpb=1, fmt=0)
    seeds["unknown_chunk"] = _header(0, 1, 480) + _chunk(b"XFIH", b"\x00" * 5) + \
        _chunk(b"MTrk", b"\x00\x90\x3c\x64\x81\x00\x80\x3c\x40\x00\xff\x2f\x00")
    for p in PHRASES:
        seeds[f"phrase:{p.name}"] = p.read_bytes()
    return seeds


def _tracks(data: bytes) -> list[tuple[int, int]]:
    """(offset of the length field, payload length) of every MTrk chunk found by a plain scan."""
    found = []
    i = data.find(b"MTrk")
    while i >= 0:
        if i + 8 <= len(data):
            found.append((i + 4, struct.unpack(">I", data[i + 4:i + 8])[0]))
        i = data.find(b"MTrk", i + 4)
    return found


def _in_track(rng: random.Random, data: bytes) -> tuple[int, int] | None:
    """A random position inside a track's payload, and the track's length-field offset."""
    tracks = _tracks(data)
    if not tracks:
        return None
    off, n = rng.choice(tracks)
    start = off + 4
    end = min(start + n, len(data))
    if end <= start:
        return None
    return rng.randrange(start, end), off


def _fix_length(data: bytearray, len_off: int, delta: int) -> None:
    (n,) = struct.unpack(">I", data[len_off:len_off + 4])
    data[len_off:len_off + 4] = struct.pack(">I", max(0, min(0xFFFFFFFF, n + delta)))


HUGE_DELTAS = (b"\x8f\xff\xff\x7f",          # 0x0FFFFFFF ticks: the largest legal delta
               b"\xff\xff\xff\xff\x7f",      # five bytes: longer than the SMF allows
               b"\x81\x80\x80\x80\x00",
               b"\xff\xff\xff\xff\xff\xff\xff\xff\x7f",
               b"\x80\x80\x80\x80")          # never ends inside the track


def mutate_midi(rng: random.Random, data: bytes, others: list[bytes]) -> tuple[bytes, str]:
    """One to three mutations of `data`; returns the result and their names."""
    b = bytearray(data)
    names = []
    for _ in range(rng.choice((1, 1, 1, 2, 3))):
        op = rng.randrange(14)
        if not b:
            b = bytearray(rng.choice(others))
        if op == 0:                                    # flip a bit
            i = rng.randrange(len(b))
            b[i] ^= 1 << rng.randrange(8)
            names.append(f"flip@{i}")
        elif op == 1:                                  # set a byte
            i = rng.randrange(len(b))
            b[i] = rng.randrange(256)
            names.append(f"set@{i}")
        elif op == 2:                                  # truncate
            n = rng.randrange(len(b))
            del b[n:]
            names.append(f"truncate@{n}")
        elif op == 3:                                  # insert random bytes
            i = rng.randrange(len(b) + 1)
            b[i:i] = bytes(rng.randrange(256) for _ in range(rng.randint(1, 16)))
            names.append(f"insert@{i}")
        elif op == 4:                                  # delete a span
            i = rng.randrange(len(b))
            del b[i:i + rng.randint(1, 16)]
            names.append(f"delete@{i}")
        elif op in (5, 6):                             # a huge varlen delta time inside a track
            at = _in_track(rng, bytes(b))
            if at is None:
                continue
            i, len_off = at
            v = rng.choice(HUGE_DELTAS) if op == 5 else _varlen(rng.randrange(1 << 28))
            b[i:i] = v
            if rng.random() < 0.7:                     # keep the framing right, usually
                _fix_length(b, len_off, len(v))
            names.append(f"delta{v.hex()}@{i}")
        elif op == 7:                                  # a wrong track length
            tracks = _tracks(bytes(b))
            if not tracks:
                continue
            off, n = rng.choice(tracks)
            new = rng.choice((0, 1, max(n - 1, 0), n + 1, n * 2, 0x7FFFFFFF, 0xFFFFFFFF,
                              rng.randrange(1 << 32))) & 0xFFFFFFFF
            b[off:off + 4] = struct.pack(">I", new)
            names.append(f"tracklen{new}@{off}")
        elif op == 8:                                  # a header field
            j = b.find(b"MThd")
            if j < 0 or j + 14 > len(b):
                continue
            field = rng.choice((8, 10, 12))
            val = rng.choice((0, 1, 2, 3, 0x7FFF, 0x8000, 0xE700, 0xE728, 0xFFFF, rng.randrange(1 << 16)))
            b[j + field:j + field + 2] = struct.pack(">H", val)
            names.append(f"header{field}={val}")
        elif op == 9:                                  # remove a status byte: running status (or garbage)
            at = _in_track(rng, bytes(b))
            if at is None:
                continue
            i, len_off = at
            k = next((x for x in range(i, min(i + 64, len(b))) if 0x80 <= b[x] < 0xF0), None)
            if k is None:
                continue
            del b[k]
            _fix_length(b, len_off, -1)
            names.append(f"drop-status@{k}")
        elif op == 10:                                 # duplicate a chunk
            tracks = _tracks(bytes(b))
            if not tracks:
                continue
            off, n = rng.choice(tracks)
            chunk = bytes(b[off - 4:off + 4 + n])
            b[len(b):] = chunk
            names.append("dup-track")
        elif op == 11:                                 # splice: a track of another file
            other = rng.choice(others)
            tracks = _tracks(other)
            if not tracks:
                continue
            off, n = rng.choice(tracks)
            i = rng.randrange(len(b) + 1)
            b[i:i] = other[off - 4:off + 4 + n]
            names.append(f"splice@{i}")
        elif op == 12:                                 # a SysEx or meta event with a huge length
            at = _in_track(rng, bytes(b))
            if at is None:
                continue
            i, len_off = at
            ev = rng.choice((b"\x00\xf0", b"\x00\xff\x01", b"\x00\xff\x51", b"\x00\xf7")) + \
                rng.choice(HUGE_DELTAS[:3] + (b"\x03",)) + b"\x00\x01\x02"
            b[i:i] = ev
            _fix_length(b, len_off, len(ev))
            names.append(f"long-event@{i}")
        else:                                          # a tempo of 0 or the slowest, early end of track
            at = _in_track(rng, bytes(b))
            if at is None:
                continue
            i, len_off = at
            ev = rng.choice((b"\x00\xff\x51\x03\x00\x00\x00", b"\x00\xff\x51\x03\xff\xff\xff",
                             b"\x00\xff\x2f\x00", b"\x00\xff\x51\x02\x07\xa1"))
            b[i:i] = ev
            _fix_length(b, len_off, len(ev))
            names.append(f"meta{ev[2]:02x}@{i}")
    return bytes(b), "+".join(names) or "none"


def generated_midi(rng: random.Random) -> tuple[bytes, str]:
    """A valid file whose delta times are drawn from small to the largest legal ones."""
    tracks = []
    for _ in range(rng.randint(1, 3)):
        t = []
        for _ in range(rng.randint(1, 12)):
            dt = rng.choice((0, 1, 10, 480, 10_000, 1 << 20, (1 << 28) - 1, rng.randrange(1 << 28)))
            kind = rng.randrange(5)
            if kind == 0:
                t.append(M("note_on", note=rng.randrange(128), velocity=rng.randrange(128), time=dt))
            elif kind == 1:
                t.append(M("note_off", note=rng.randrange(128), velocity=rng.randrange(128), time=dt))
            elif kind == 2:
                t.append(M("control_change", control=rng.randrange(128), value=rng.randrange(128), time=dt))
            elif kind == 3:
                t.append(Meta("set_tempo", tempo=rng.choice((1, 500_000, 0xFFFFFF)), time=dt))
            else:
                t.append(M("pitchwheel", pitch=rng.randrange(-8192, 8192), time=dt))
        tracks.append(t)
    tpb = rng.choice((1, 24, 480, 0x7FFF))
    return _smf(tracks, tpb=tpb, fmt=1 if len(tracks) > 1 else rng.choice((0, 1))), f"generated tpb={tpb}"


def _check_events(events) -> None:
    times = [e.time_s for e in events]
    assert times == sorted(times)
    assert all(math.isfinite(t) and 0 <= t <= MAX_DURATION_S for t in times)
    for e in events:
        assert e.kind in EVENT_KINDS and 0 <= e.channel <= 15
        if e.kind == "pitch_bend":
            assert -1 <= e.value <= 1
        elif e.kind == "channel_pressure":
            assert 0 <= e.value <= 1 and e.key == -1
        else:
            assert 0 <= e.value <= 1 and 0 <= e.key <= 127


def _one_line_error(e: SynthError, shown: str) -> None:
    msg = str(e)
    assert msg and "\n" not in msg and "Traceback" not in msg, msg
    assert msg.startswith(shown), (shown, msg)


def midi_cases(n: int):
    rng = random.Random(SEED)
    seeds = midi_seeds()
    names = sorted(seeds)
    values = [seeds[k] for k in names]
    for i in range(n):
        if i % 8 == 7:
            data, how = generated_midi(rng)
            yield i, "generated", how, data
        else:
            name = names[i % len(names)]
            data, how = mutate_midi(rng, seeds[name], values)
            yield i, name, how, data


def test_midi_seed_files_load(tmp_path):
    """The corpus starts from valid files: each loads, with notes."""
    seeds = midi_seeds()
    assert PHRASES and len(seeds) == 7 + len(PHRASES), "the repo's phrases are part of the corpus"
    for name, data in seeds.items():
        path = tmp_path / "seed.mid"
        path.write_bytes(data)
        ev = read_midi_file(path)
        _check_events(ev)
        assert any(e.kind == "note_on" for e in ev), name
    path.write_bytes(seeds["three_hours"])
    plan = plan_render(midi_to_events(read_midi_file(path)), None, "seed.mid")
    assert plan.file_length_s == pytest.approx(10_801.5)
    assert plan.notes == ["warning: seed.mid lasts 3:00:02 (10802 s): rendering more than 30 min "
                          "of audio; --max-seconds S renders only the first S seconds"]


@pytest.mark.slow  # over 2 s on a quiet 2-core machine
def test_fuzz_midi_loader(tmp_path, capsys):
    path = tmp_path / "case.mid"
    outcome = {"loaded": 0, "error": 0, "long": 0}
    slowest = (0.0, None)
    t_all = time.perf_counter()
    for i, seed, how, data in midi_cases(N_MIDI):
        path.write_bytes(data)
        what = f"MIDI case {i} ({seed}: {how})"
        t = time.perf_counter()
        try:
            with budget(BUDGET_S, what):
                try:
                    midi = read_midi_file(path)
                except MidiFileError as e:
                    _one_line_error(e, "case.mid")
                    outcome["error"] += 1
                    continue
                _check_events(midi)
                events = midi_to_events(midi)
                # what `synth render` decides before any work: the length, the warning, the cap
                for cap in (None, 60.0):
                    try:
                        plan = plan_render(events, cap, "case.mid")
                    except SynthError as e:
                        _one_line_error(e, "case.mid")
                        continue
                    assert plan.events and plan.keys and plan.expected_s > 0
                    if cap is not None:
                        assert plan.expected_s <= cap and all(e.time_s < cap for e in plan.events)
                    elif plan.expected_s > 1800:
                        assert any(line.startswith("warning: case.mid lasts ") for line in plan.notes)
                        outcome["long"] += 1
                outcome["loaded"] += 1
        except CaseTimeout:
            raise
        except Exception as e:                                   # noqa: BLE001 - the point of the test
            raise AssertionError(f"{what}: {type(e).__name__}: {e}") from e
        finally:
            el = time.perf_counter() - t
            if el > slowest[0]:
                slowest = (el, what)
    total = time.perf_counter() - t_all
    assert sum(outcome[k] for k in ("loaded", "error")) == N_MIDI >= 1000
    # the corpus reaches both sides, and long files with their warning
    assert outcome["loaded"] > 100 and outcome["error"] > 100 and outcome["long"] > 0, outcome
    with capsys.disabled():
        print(f"\nMIDI fuzz: {N_MIDI} cases, {outcome}, {total:.1f} s, slowest {slowest[0] * 1e3:.1f} ms "
              f"({slowest[1]})")


#: mutated files rendered end to end (``synth render --max-seconds``), and the budget of each
N_RENDER = 8
RENDER_BUDGET_S = 60.0
RENDER_MAX_S = 2.0


@pytest.mark.slow  # over 2 s on a quiet 2-core machine (2.1-2.3 s, 2026-11-30)
def test_fuzz_render_end_to_end(tmp_path, capsys):
    """A few mutated files through ``synth render --max-seconds 2``: each
    renders at most 2 s or fails with one line, leaving no stray file, within
    its budget (a hang fails instead of blocking the run)."""
    rng = random.Random(SEED + 2)
    seeds = midi_seeds()
    names = sorted(seeds)
    values = [seeds[k] for k in names]
    want = {"rendered": N_RENDER - 3, "error": 3}
    done = {"rendered": 0, "error": 0}
    tried = 0
    while done != want:
        tried += 1
        assert tried < 500, done
        data, how = mutate_midi(rng, seeds[names[tried % len(names)]], values)
        path = tmp_path / "case.mid"
        path.write_bytes(data)
        try:
            events = midi_to_events(read_midi_file(path))
            plan_render(events, RENDER_MAX_S, "case.mid")
            kind = "rendered"
        except SynthError:
            kind = "error"
        if done[kind] == want[kind]:
            continue
        out = tmp_path / "out"
        out.mkdir(exist_ok=True)
        what = f"render case {tried} ({how})"
        with budget(RENDER_BUDGET_S, what):
            rc = main(["render", "case.mid", "--preset", "sitar", "--max-seconds", str(RENDER_MAX_S),
                       "-o", "out/case.wav"])
        cap = capsys.readouterr()
        assert "Traceback" not in cap.err, (what, cap.err)
        if kind == "error":
            assert rc == 2 and os.listdir(out) == [], (what, cap.err)
            lines = cap.err.splitlines()
            assert len(lines) == 1 and lines[0].startswith("synth: error: case.mid"), (what, cap.err)
        else:
            assert rc == 0, (what, cap.err)
            # (notes, and the over-full-scale warning a loud case may earn)
            assert all(line.startswith("note: ")
                       or (line.startswith("warning: ") and "over full scale" in line)
                       for line in cap.err.splitlines()), (what, cap.err)
            info = sf.info(str(out / "case.wav"))
            assert 0 < info.frames <= RENDER_MAX_S * info.samplerate, what
            os.remove(out / "case.wav")
            assert os.listdir(out) == [], what
        done[kind] += 1


# --------------------------------------------------------------------------
# Presets
# --------------------------------------------------------------------------

NASTY_VALUES = (
    "-1", "0", "0.0", "-0.0", "1e-320", "1e308", "1e999", "-1e999", "inf", "-inf", "nan",
    "1" + "0" * 400, "-" + "9" * 30, "0x7fffffff", "9223372036854775807", "true", "false",
    '""', '"text"', '"\\u0000"', "[]", "[1, 2]", "[[1, 2], [3]]", "[[1e999, 0], [0, 1]]",
    "[[0.1, 1" + "0" * 400 + "]]", "{}", "{ a = 1 }", "1979-05-27T07:32:00Z", "07:32:00",
    "1979-05-27", '"jawari"', '"none"', '"plucked"', '"hammered"', '"musical"', '"study"',
    "[60, 62, 300]", "[-1]", "[1.5]", "[[100, 1, 0], [200, 2]]", "[[1e999, 2, 0]]", "0.5", "2", "1e6",
    "1" * 5000,                                    # more digits than Python's int() reads
    "[" * 300 + "]" * 300, "[" * 3000 + "]" * 3000,   # nested deeper than the parser recurses
    "{ a = " * 200 + "1" + " }" * 200,
)
_KV = re.compile(r"^(\s*)([A-Za-z_][A-Za-z0-9_]*)(\s*=\s*)(.*?)(\s*(#.*)?)$")


def mutate_preset(rng: random.Random, text: str) -> tuple[bytes, str]:
    lines = text.splitlines()
    names = []
    for _ in range(rng.choice((1, 1, 2, 3))):
        kv = [i for i, line in enumerate(lines) if _KV.match(line)]
        op = rng.randrange(12)
        if op <= 3 and kv:                               # a nasty value
            i = rng.choice(kv)
            m = _KV.match(lines[i])
            v = rng.choice(NASTY_VALUES)
            lines[i] = f"{m.group(1)}{m.group(2)}{m.group(3)}{v}"
            names.append(f"{m.group(2)}={v[:20]}")
        elif op == 4 and kv:                             # scale a number
            i = rng.choice(kv)
            m = _KV.match(lines[i])
            try:
                x = float(m.group(4))
            except ValueError:
                continue
            x *= rng.choice((-1.0, 0.0, 1e-9, 0.5, 2.0, 1e3, 1e9, 1e300))
            lines[i] = f"{m.group(1)}{m.group(2)}{m.group(3)}{x!r}"
            names.append(f"scale {m.group(2)}")
        elif op == 5 and lines:                          # delete a line
            i = rng.randrange(len(lines))
            names.append(f"del line {i}")
            del lines[i]
        elif op == 6 and lines:                          # duplicate a line (duplicate key or table)
            i = rng.randrange(len(lines))
            lines.insert(rng.randrange(len(lines) + 1), lines[i])
            names.append(f"dup line {i}")
        elif op == 7 and kv:                             # rename a key (a typo)
            i = rng.choice(kv)
            m = _KV.match(lines[i])
            k = m.group(2)
            j = rng.randrange(len(k))
            k2 = k[:j] + rng.choice("abcxyz_") + k[j + 1:]
            lines[i] = f"{m.group(1)}{k2}{m.group(3)}{m.group(4)}"
            names.append(f"rename {k}->{k2}")
        elif op == 8 and kv:                             # move a line elsewhere (another section)
            i = rng.choice(kv)
            line = lines.pop(i)
            lines.insert(rng.randrange(len(lines) + 1), line)
            names.append(f"move line {i}")
        elif op == 9:                                    # a section header dropped or doubled
            hs = [i for i, line in enumerate(lines) if line.lstrip().startswith("[")]
            if not hs:
                continue
            i = rng.choice(hs)
            if rng.random() < 0.5:
                del lines[i]
                names.append(f"drop header {i}")
            else:
                lines.append(lines[i])
                names.append(f"repeat header {i}")
        elif op == 10:                                   # an unknown key or section
            lines.insert(rng.randrange(len(lines) + 1),
                         rng.choice(("bogus = 1", "[bogus]", "schema = 2", "kind = 3", "[[arr]]")))
            names.append("unknown")
        else:                                            # a byte-level mutation
            b = bytearray("\n".join(lines).encode())
            if not b:
                continue
            i = rng.randrange(len(b))
            sub = rng.randrange(4)
            if sub == 0:
                b[i] = rng.randrange(256)
            elif sub == 1:
                del b[i:]
            elif sub == 2:
                b[i:i] = rng.choice((b"\xff\xfe", b"\x00", b"\"", b"[", b"=", b"\r", b"\xef\xbb\xbf",
                                     "é".encode(), b"\xc3"))
            else:
                del b[i:i + rng.randint(1, 8)]
            names.append(f"bytes{sub}@{i}")
            return bytes(b), "+".join(names)
    return ("\n".join(lines) + "\n").encode(), "+".join(names) or "none"


@pytest.mark.slow  # over 2 s on a quiet 2-core machine
def test_fuzz_preset_files(tmp_path, capsys):
    assert len(PRESETS) >= 10, PRESETS
    texts = [(p.relative_to(REPO).as_posix(), p.read_text(encoding="utf-8")) for p in PRESETS]
    rng = random.Random(SEED + 1)
    path = tmp_path / "case.toml"
    outcome = {"loaded": 0, "error": 0}
    slowest = (0.0, None)
    t_all = time.perf_counter()
    for i in range(N_PRESET):
        src, text = texts[i % len(texts)]
        data, how = mutate_preset(rng, text)
        path.write_bytes(data)
        what = f"preset case {i} ({src}: {how})"
        t = time.perf_counter()
        try:
            with budget(BUDGET_S, what):
                try:
                    p = load_preset(str(path))
                except PresetError as e:
                    _one_line_error(e, "case.toml")
                    outcome["error"] += 1
                else:
                    assert isinstance(p, Preset)
                    hash(p)                      # frozen and hashable, as validated presets are
                    outcome["loaded"] += 1
        except CaseTimeout:
            raise
        except Exception as e:                   # noqa: BLE001 - the point of the test
            raise AssertionError(f"{what}: {type(e).__name__}: {e}") from e
        finally:
            el = time.perf_counter() - t
            if el > slowest[0]:
                slowest = (el, what)
    total = time.perf_counter() - t_all
    assert outcome["loaded"] + outcome["error"] == N_PRESET >= 1000
    assert outcome["loaded"] > 50 and outcome["error"] > 300, outcome
    with capsys.disabled():
        print(f"\npreset fuzz: {N_PRESET} cases, {outcome}, {total:.1f} s, slowest "
              f"{slowest[0] * 1e3:.1f} ms ({slowest[1]})")


def test_preset_errors_the_fuzz_found(tmp_path):
    """Found by the fuzz: each was an OverflowError, ValueError or
    RecursionError (a traceback) and is now a one-line PresetError."""
    text = (REPO / "synth" / "presets" / "sitar.toml").read_text(encoding="utf-8")
    cases = {
        "tension_n = 1" + "0" * 400: "string.tension_n = 1000000000",            # > float's range
        "tension_n = " + "1" * 5000: "invalid TOML: Exceeds the limit (4300 digits)",
        "tension_n = " + "[" * 3000 + "]" * 3000: "invalid TOML: arrays or tables nested too deeply",
    }
    for line, fragment in cases.items():
        path = tmp_path / "case.toml"
        path.write_text(re.sub(r"(?m)^tension_n = .*$", lambda m: line, text, count=1), encoding="utf-8")
        with pytest.raises(PresetError) as ei:
            load_preset(str(path))
        msg = str(ei.value)
        assert "\n" not in msg and msg.startswith("case.toml: ") and fragment in msg, msg
        if "1000000000" in fragment:
            assert "is not a finite number" in msg
    # the same through --set
    for value, fragment in (("1" + "0" * 400, "is not a finite number"),
                            ("1" * 5000, "--set string.tension_n=...: the value cannot be read"),
                            ("[" * 3000 + "]" * 3000, "nested too deeply")):
        with pytest.raises(PresetError) as ei:
            load_preset("sitar", [f"string.tension_n={value}"])
        assert "\n" not in str(ei.value) and fragment in str(ei.value), str(ei.value)[:200]
