"""The Python API (synth.render_note, render_midi, Instrument, presets, Audio;
docs/api.md): shapes, rate and dtype, tuning, the checks of its inputs, the
streaming instrument (chunks and one render give the same samples; reset
leaves no tail), the WAV and notebook outputs, and the command line built on
it."""

from __future__ import annotations

import base64
import io
import re
import shutil
import subprocess
import sys
import wave
from pathlib import Path

import mido
import numpy as np
import pytest
import soundfile as sf

import synth
from synth.cli import main
from synth.testing import SpecError, check_f0

SITAR_A3_HZ = 220.0          # key 57, equal temperament


@pytest.fixture(scope="module")
def sitar():
    """Sitar, key 57, velocity 100, 0.5 s."""
    return synth.render_note("sitar", key=57, velocity=100, seconds=0.5)


def _phrase(path=None) -> mido.MidiFile:
    """Two sitar notes: 57 at 0 for 0.25 s, 60 at 0.125 s for 0.25 s (120 bpm, 480 ticks)."""
    mf = mido.MidiFile(type=0, ticks_per_beat=480)
    tr = mido.MidiTrack()
    mf.tracks.append(tr)
    tr += [mido.Message("note_on", note=57, velocity=100, time=0),
           mido.Message("note_on", note=60, velocity=80, time=120),
           mido.Message("note_off", note=57, velocity=64, time=120),
           mido.Message("note_off", note=60, velocity=64, time=120)]
    if path is not None:
        mf.save(str(path))
    return mf


# --------------------------------------------------------------------------
# import synth stays light
# --------------------------------------------------------------------------


def test_import_synth_and_help_load_no_numpy_until_the_api_is_used():
    code = (
        "import sys, synth, synth.cli\n"
        "try:\n"
        "    synth.cli.main(['--help'])\n"
        "except SystemExit:\n"
        "    pass\n"
        "assert 'numpy' not in sys.modules, 'numpy imported by import synth / --help'\n"
        "assert 'synth.api' not in sys.modules\n"
        "f = synth.render_note\n"
        "assert 'synth.api' in sys.modules and f is sys.modules['synth.api'].render_note\n"
        "print(sorted(synth.__all__))\n")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    assert ("['Audio', 'Instrument', 'MidiStream', 'presets', 'render_drone', 'render_midi', "
            "'render_note', 'stream_midi']") in p.stdout


def test_the_package_names_the_api_and_nothing_else():
    assert set(synth.__all__) <= set(dir(synth))
    assert synth.Instrument is synth.api.Instrument
    with pytest.raises(AttributeError, match="no attribute 'render_notes'"):
        synth.render_notes      # noqa: B018


# --------------------------------------------------------------------------
# render_note: shape, dtype, rate, tuning
# --------------------------------------------------------------------------


def test_render_note_shape_dtype_rate(sitar):
    assert isinstance(sitar, synth.Audio)
    assert sitar.fs == 48_000 and isinstance(sitar.fs, int)
    assert sitar.samples.dtype == np.float32
    assert sitar.samples.shape in ((24_000, 1), (24_000, 2))
    assert sitar.frames == 24_000 and sitar.seconds == 0.5
    assert sitar.channels == sitar.samples.shape[1]
    assert np.all(np.isfinite(sitar.samples)) and 0.01 < np.abs(sitar.samples).max() <= 1.0


@pytest.mark.slow  # over 2 s: a 2 s render
def test_the_issues_example_is_in_tune_within_one_cent():
    a = synth.render_note("sitar", key=57, velocity=100, seconds=2)
    assert a.samples.shape in ((96_000, 1), (96_000, 2)) and a.fs == 48_000
    r = check_f0(a.samples.mean(axis=1), a.fs, SITAR_A3_HZ, cents=1.0)
    assert r.passed, (r.measured, r.expected)


def test_a_short_note_is_in_tune_within_two_cents_while_it_glides(sitar):
    """0.05-0.5 s of a strong pluck: the string's tension follows its swing
    (measured +1.12 cents); the note that rings on is within 1 cent
    (test_the_issues_example_is_in_tune_within_one_cent, tests/test_pitch.py)."""
    r = check_f0(sitar.samples.mean(axis=1), sitar.fs, SITAR_A3_HZ, cents=2.0)
    assert r.passed, (r.measured, r.expected)
    late = check_f0(sitar.samples.mean(axis=1), sitar.fs, SITAR_A3_HZ, cents=1.0, start_s=0.3,
                    length_s=0.2)
    assert late.passed, (late.measured, late.expected)
    with pytest.raises(SpecError, match=r"start_s \+ length_s = 1\.05 is out of range"):
        check_f0(sitar.samples.mean(axis=1), sitar.fs, SITAR_A3_HZ, cents=1.0, start_s=0.05)


def test_render_note_gives_the_samples_synth_note_writes(sitar, tmp_path):
    """The command line renders through the API: the WAV file holds the same float32 samples."""
    out = tmp_path / "n.wav"
    assert main(["note", "sitar", "--key", "57", "--velocity", "100", "--seconds", "0.5",
                 "-o", str(out)]) == 0
    y, fs = sf.read(str(out), dtype="float32", always_2d=True)
    assert fs == sitar.fs
    assert np.array_equal(y, sitar.samples)


def test_numpy_asarray_gives_the_samples(sitar):
    a = np.asarray(sitar)
    assert a is sitar.samples or np.shares_memory(a, sitar.samples)
    assert np.asarray(sitar, dtype=np.float64).dtype == np.float64
    assert np.array_equal(np.asarray(sitar, dtype=np.float64), sitar.samples)
    assert len(sitar) == sitar.frames


def test_render_note_at_another_rate_and_f0():
    a = synth.render_note("sitar", f0=220.0, seconds=0.2, rate=44_100)
    assert a.fs == 44_100 and a.frames == round(0.2 * 44_100)


def test_set_as_a_dict_or_as_strings_gives_the_same_note():
    a = synth.render_note("sitar", key=57, seconds=0.3, set={"pluck.position": 0.3})
    b = synth.render_note("sitar", key=57, seconds=0.3, set=["pluck.position=0.3"])
    c = synth.render_note("sitar", key=57, seconds=0.3)
    assert np.array_equal(a.samples, b.samples)
    assert not np.array_equal(a.samples, c.samples)


def test_testing_render_note_gives_every_channel_on_request():
    y, fs, f = synth.testing.render_note("sitar", 57, seconds=0.2)
    y2, fs2, f2 = synth.testing.render_note("sitar", 57, seconds=0.2, mono=False)
    assert y.ndim == 1 and y2.ndim == 2 and len(y2) == len(y) and (fs, f) == (fs2, f2)
    assert np.array_equal(y2.mean(axis=1), y)
    a = synth.render_note("sitar", key=57, seconds=0.2)
    assert y2.shape == a.samples.shape
    assert np.array_equal(y2.astype(np.float32), a.samples)


# --------------------------------------------------------------------------
# Inputs are checked as the command line checks them
# --------------------------------------------------------------------------


@pytest.mark.parametrize("kw, message", [
    (dict(key=200), "key = 200 is out of range (0 <= value <= 127)"),
    (dict(key=-1), "key = -1 is out of range (0 <= value <= 127)"),
    (dict(key=57.0), "key = 57.0 is not an integer (0 <= value <= 127)"),
    (dict(key="57"), "key = '57' is not an integer (0 <= value <= 127)"),
    (dict(key=57, velocity=0), "velocity = 0 is out of range (1 <= value <= 127)"),
    (dict(key=57, velocity=128), "velocity = 128 is out of range (1 <= value <= 127)"),
    (dict(key=57, velocity=0.5), "velocity = 0.5 is not an integer (1 <= value <= 127)"),
    (dict(key=57, velocity=1.0), "velocity = 1.0 is not an integer (1 <= value <= 127)"),
    (dict(key=57, velocity=True), "velocity = True is not an integer (1 <= value <= 127)"),
    (dict(key=57, seconds=-1), "seconds = -1 is out of range (0 < value <= 600)"),
    (dict(key=57, seconds=0), "seconds = 0 is out of range (0 < value <= 600)"),
    (dict(key=57, seconds=float("nan")), "seconds = nan is out of range (0 < value <= 600)"),
    (dict(key=57, seconds="2"), "seconds = '2' is not a number (0 < value <= 600)"),
    (dict(key=57, f0=220.0), "key and f0 are exclusive: give one of them"),
    (dict(f0=10.0), "f0 = 10.0 is out of range (20 <= value <= 5000 Hz)"),
    (dict(key=57, rate=1000), "rate = 1000 Hz is out of range"),
    (dict(key=57, set="pluck.position=0.7"), "set = 'pluck.position=0.7' is not a dict"),
    (dict(key=57, set={"pluck.position": None}), "set['pluck.position'] = None is not a preset value"),
])
def test_bad_arguments_raise_one_line_value_errors(kw, message):
    with pytest.raises(ValueError) as e:
        synth.render_note("sitar", **kw)
    assert str(e.value).startswith(message), str(e.value)
    assert "\n" not in str(e.value)


@pytest.mark.parametrize("preset, kw, fragments", [
    ("sitr", dict(key=57), ["unknown preset 'sitr'", "did you mean 'sitar'"]),
    ("", dict(key=57), ["preset = '' is not a preset name"]),
    (None, dict(key=57), ["preset = None is not a preset name"]),
    ("sitar", dict(key=57, set={"pluck.positon": 0.5}), ["unknown key 'pluck.positon'"]),
    ("sitar", dict(key=57, set={"pluck.position": 1.5}),
     ["pluck.position = 1.5 (from --set)", "0 < value < 1"]),
    ("sitar", dict(key=57, set={"play.quality": "best"}), ["play.quality", "best"]),
    ("sitar", dict(key=100), ["key = 100 is outside the playable range of sitar (43 <= key <= 74)"]),
    ("sitar", dict(), ["sitar is a musical preset: give key or f0"]),
])
def test_bad_presets_and_overrides_raise_value_errors(preset, kw, fragments):
    with pytest.raises(ValueError) as e:
        synth.render_note(preset, seconds=0.1, **kw)
    for f in fragments:
        assert f in str(e.value), str(e.value)
    assert "\n" not in str(e.value)


@pytest.mark.parametrize("argv, message", [
    (["--key", "200"], "--key = 200 is out of range (0 <= value <= 127)"),
    (["--key", "57", "--velocity", "0"], "--velocity = 0 is out of range (1 <= value <= 127)"),
    (["--key", "57", "--seconds", "-1"], "--seconds = -1.0 is out of range (0 < value <= 600)"),
    (["--f0", "10"], "--f0 = 10.0 is out of range (20 <= value <= 5000 Hz)"),
    (["--key", "100"], "--key = 100 is outside the playable range of sitar (43 <= key <= 74)"),
    ([], "sitar is a musical preset: give --key or --f0"),
])
def test_the_command_line_says_the_same_under_its_option_names(capsys, tmp_path, argv, message):
    assert main(["note", "sitar", *argv, "-o", str(tmp_path / "x.wav")]) == 2
    assert capsys.readouterr().err == f"synth: error: {message}\n"
    assert not (tmp_path / "x.wav").exists()


# --------------------------------------------------------------------------
# Audio: WAV, notebook player
# --------------------------------------------------------------------------


def test_to_wav_round_trip(sitar, tmp_path):
    p = tmp_path / "a.wav"
    assert sitar.to_wav(p) is None
    y, fs = sf.read(str(p), dtype="float32", always_2d=True)
    assert fs == sitar.fs and np.array_equal(y, sitar.samples)
    sitar.to_wav(str(tmp_path / "b.wav"), subtype="pcm24")
    info = sf.info(str(tmp_path / "b.wav"))
    assert info.subtype == "PCM_24" and info.frames == sitar.frames


def test_to_wav_writes_the_format_its_extension_names(sitar, tmp_path):
    sitar.to_wav(tmp_path / "a.flac")
    sitar.to_wav(tmp_path / "a.OGG")
    assert sf.info(str(tmp_path / "a.flac")).format == "FLAC"
    assert sf.info(str(tmp_path / "a.OGG")).format == "OGG"
    with pytest.raises(ValueError, match=r"a\.mp3'?: the extension must choose an audio format "
                                         r"\(\.wav, \.flac, \.ogg\)"):
        sitar.to_wav(tmp_path / "a.mp3")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.OGG", "a.flac"]


def test_to_wav_errors(sitar, tmp_path):
    with pytest.raises(ValueError, match=r"subtype = 'pcm16' is not allowed \(choices: 'float', 'pcm24'\)"):
        sitar.to_wav(tmp_path / "a.wav", subtype="pcm16")
    with pytest.raises(OSError, match="nope"):
        sitar.to_wav(tmp_path / "nope" / "a.wav")
    assert list(tmp_path.iterdir()) == []


def _player_wav(html: str):
    m = re.search(r'<audio controls[^>]* src="data:audio/wav;base64,([A-Za-z0-9+/=]+)"', html)
    assert m, html[:300]
    with wave.open(io.BytesIO(base64.b64decode(m.group(1)))) as w:
        return w.getnchannels(), w.getsampwidth(), w.getframerate(), w.getnframes()


def test_repr_html_is_an_audio_player(sitar):
    html = sitar._repr_html_()
    assert "<audio" in html and "</audio>" in html
    assert _player_wav(html) == (sitar.channels, 2, 48_000, sitar.frames)     # 16-bit
    assert "0.50 s" in html and "48000 Hz" in html
    assert repr(sitar) == f"Audio(0.500 s, {sitar.channels} channel{'s' * (sitar.channels > 1)}, 48000 Hz)"


def test_the_player_is_bounded():
    from synth.api.audio import PLAYER_MAX_S

    fs = 48_000
    long = synth.Audio(np.full((int((PLAYER_MAX_S + 10) * fs), 2), 2.0), fs)   # over full scale
    html = long._repr_html_()
    assert _player_wav(html) == (2, 2, fs, int(PLAYER_MAX_S * fs))
    assert "first 30 s" in html and "clipped" in html
    # the clipped 16-bit samples are full scale, not wrapped round
    pcm = np.frombuffer(long.wav16(0.001)[44:], dtype="<i2")
    assert np.all(pcm == 32767)


def test_audio_checks_its_arguments():
    with pytest.raises(ValueError, match="fs = 0"):
        synth.Audio(np.zeros(10), 0)
    with pytest.raises(ValueError, match="shape"):
        synth.Audio(np.zeros((2, 3, 4)), 48_000)
    a = synth.Audio(np.zeros(10, dtype=np.float64), 48_000)
    assert a.samples.shape == (10, 1) and a.samples.dtype == np.float32
    assert a.peak_dbfs == -np.inf


# --------------------------------------------------------------------------
# presets()
# --------------------------------------------------------------------------


def test_presets_lists_the_shipped_and_the_users(tmp_path, monkeypatch):
    names = synth.presets()
    assert {"sitar", "biwa", "grand-piano", "harpsichord", "paper/sitar-case1"} <= set(names)
    assert names == sorted(names)
    shutil.copy(Path(synth.__file__).parent / "presets" / "sitar.toml", tmp_path / "my-sitar.toml")
    monkeypatch.setenv("SYNTH_PRESET_PATH", str(tmp_path))
    assert "my-sitar" in synth.presets()


# --------------------------------------------------------------------------
# render_midi
# --------------------------------------------------------------------------


def test_render_midi_from_a_path_or_a_mido_file_gives_synth_renders_samples(tmp_path):
    path = tmp_path / "phrase.mid"
    mf = _phrase(path)
    a = synth.render_midi(path, preset="sitar", max_seconds=0.6)
    b = synth.render_midi(mf, preset="sitar", max_seconds=0.6)
    assert a.fs == 48_000 and a.samples.dtype == np.float32 and a.samples.ndim == 2
    assert a.frames == round(0.6 * 48_000)
    assert np.array_equal(a.samples, b.samples)
    assert main(["render", str(path), "--preset", "sitar", "--max-seconds", "0.6",
                 "-o", str(tmp_path / "r.wav")]) == 0
    y, fs = sf.read(str(tmp_path / "r.wav"), dtype="float32", always_2d=True)
    assert fs == a.fs and np.array_equal(y, a.samples)


@pytest.mark.slow  # over 2 s: two renders until the notes have died away
def test_render_midi_plays_the_release_tails_as_synth_render_does(tmp_path):
    path = tmp_path / "phrase.mid"
    _phrase(path)
    a = synth.render_midi(path, preset="sitar")
    # the last event at 0.5 s, then the release tails and 0.5 s of silence
    assert 1.0 <= a.seconds < 31.0
    assert main(["render", str(path), "--preset", "sitar", "-o", str(tmp_path / "r.wav")]) == 0
    y, fs = sf.read(str(tmp_path / "r.wav"), dtype="float32", always_2d=True)
    assert fs == a.fs and np.array_equal(y, a.samples)


def test_render_midi_max_seconds_cuts_with_a_fade():
    a = synth.render_midi(_phrase(), preset="sitar", max_seconds=0.3)
    assert a.frames == round(0.3 * 48_000)
    assert not np.any(a.samples[-1])                    # the fade's end
    assert np.abs(a.samples[-580:-480]).max() > 1e-3      # sounding before its 10 ms


@pytest.mark.parametrize("kw, fragment, cls", [
    (dict(preset="sitr"), "unknown preset 'sitr'", ValueError),
    (dict(preset="sitar", max_seconds=0), "max_seconds = 0 is out of range (0 < value <= 21600 s)",
     ValueError),
    (dict(preset="sitar", channels=[17]), "channels = 17 is out of range (1 <= value <= 16)",
     ValueError),
    (dict(preset="sitar", channels=[2]), "the file has no notes to play", ValueError),
    (dict(preset="sitar", set={"pluck.position": 2}), "pluck.position = 2", ValueError),
])
def test_render_midi_errors(kw, fragment, cls):
    with pytest.raises(cls) as e:
        synth.render_midi(_phrase(), **kw)
    assert fragment in str(e.value), str(e.value)


def test_render_midi_refuses_a_broken_file(tmp_path):
    bad = tmp_path / "bad.mid"
    bad.write_bytes(b"RIFF nonsense")
    with pytest.raises(ValueError, match="bad.mid"):
        synth.render_midi(bad, preset="sitar")
    with pytest.raises(ValueError, match="missing.mid"):
        synth.render_midi(tmp_path / "missing.mid", preset="sitar")
    with pytest.raises(ValueError, match="is not a MIDI file's path or a mido.MidiFile"):
        synth.render_midi(b"MThd", preset="sitar")


def test_stream_midi_gives_render_midi_s_samples_block_by_block(tmp_path):
    """The blocks (float64, (frames, channels)) are render_midi's samples;
    the stream runs once; its notes are said to log as they come."""
    lines = []
    s = synth.stream_midi(_phrase(), "sitar", max_seconds=0.3, log=lines.append)
    assert isinstance(s, synth.MidiStream)
    assert (s.fs, s.channels, s.seconds) == (48_000, 1, 0.3)
    assert lines == s.notes and "rendering its first 0.3 s (--max-seconds 0.3)" in lines[0]
    blocks = list(s)
    assert len(blocks) > 1 and all(b.dtype == np.float64 and b.shape[1] == 1 for b in blocks)
    y = np.concatenate(blocks)
    assert s.cut and len(y) == round(0.3 * 48_000)
    assert np.array_equal(y.astype(np.float32),
                          synth.render_midi(_phrase(), "sitar", max_seconds=0.3).samples)
    with pytest.raises(RuntimeError, match="already run"):
        next(iter(s))


@pytest.mark.parametrize("kw, fragment", [
    (dict(internal_rate=1000), "internal_rate = 1000 is out of range (20000 <= value <= 2e+06 Hz)"),
    (dict(mpe="middle"), "mpe = 'middle': 'middle' is not a zone"),
    (dict(mpe=7), "mpe = 7 is not a text of MPE zones"),
    (dict(log="stderr"), "log = 'stderr' is not callable"),
])
def test_stream_midi_errors_name_the_parameter(kw, fragment):
    with pytest.raises(ValueError) as e:
        synth.stream_midi(_phrase(), "sitar", **kw)
    assert fragment in str(e.value), str(e.value)


def test_synth_render_renders_through_the_api(tmp_path, monkeypatch):
    """The command line is built on the API (issue 39): ``synth render``
    takes its blocks from synth.api.stream_midi, with its options as the
    API's arguments (channels numbered 1-16, MPE zones as text)."""
    import synth.api.render as AR

    calls = []
    real = AR.stream_midi

    def spy(*a, **kw):
        calls.append((a, kw))
        return real(*a, **kw)

    monkeypatch.setattr(AR, "stream_midi", spy)
    path = tmp_path / "phrase.mid"
    _phrase(path)
    assert main(["render", str(path), "--preset", "sitar", "--max-seconds", "0.3",
                 "--channels", "1,3", "--mpe", "lower:7", "-o", str(tmp_path / "r.wav")]) == 0
    (a, kw), = calls
    assert a[:2] == (str(path), "sitar")
    assert kw["channels"] == [1, 3] and kw["mpe"] == "lower:7" and kw["max_seconds"] == 0.3


# --------------------------------------------------------------------------
# Instrument: streaming
# --------------------------------------------------------------------------


@pytest.fixture(scope="module")
def inst():
    return synth.Instrument("sitar")


def test_chunks_give_the_samples_of_one_render(inst):
    """A note at a fixed time: one render of 0.6 s and chunks of 0.1, 0.25,
    0.05 and 0.2 s (not on the engine's blocks) give the same samples."""
    inst.reset()
    inst.note_on(57, 100, time=0.05)
    inst.note_off(57, time=0.4)
    whole = inst.render(0.6)
    inst.reset()
    inst.note_on(57, 100, time=0.05)
    inst.note_off(57, time=0.4)
    parts = [inst.render(s) for s in (0.1, 0.25, 0.05, 0.2)]
    assert inst.time == pytest.approx(0.6)
    joined = np.concatenate([p.samples for p in parts])
    assert joined.shape == whole.samples.shape == (28_800, inst.channels)
    assert np.array_equal(joined, whole.samples)
    assert np.abs(whole.samples).max() > 0.01


def test_an_instrument_plays_render_notes_samples(inst):
    inst.reset()
    inst.note_on(57, 100, time=0.0)
    a = inst.render(0.5)
    b = synth.render_note("sitar", key=57, velocity=100, seconds=0.5)
    assert np.array_equal(a.samples, b.samples)


def test_reset_leaves_no_tail_and_sounds_as_new(inst):
    inst.reset()
    inst.note_on(57, 100, time=0.0)
    first = inst.render(0.3)
    inst.control(1, 0)                        # the buzz off: the voice's own state
    inst.pitch_bend(8191)
    inst.note_on(62, 100)
    inst.render(0.2)
    inst.reset()
    assert inst.time == 0.0
    assert not np.any(inst.render(0.3).samples)          # silence: no tail of the notes before
    inst.reset()
    inst.note_on(57, 100, time=0.0)
    assert np.array_equal(inst.render(0.3).samples, first.samples)


def test_events_are_played(inst):
    """A note-off damps, a bend bends, CC7 (volume) 0 silences."""
    inst.reset()
    inst.note_on(57, 100, time=0.0)
    held = inst.render(0.6).samples
    inst.reset()
    inst.note_on(57, 100, time=0.0)
    inst.note_off(57, time=0.2)
    damped = inst.render(0.6).samples
    tail = slice(int(0.45 * 48_000), None)
    assert np.sqrt(np.mean(damped[tail] ** 2)) < 0.1 * np.sqrt(np.mean(held[tail] ** 2))
    inst.reset()
    inst.control(7, 0, time=0.0)
    inst.note_on(57, 100, time=0.0)
    assert np.abs(inst.render(0.3).samples).max() < 1e-4 * np.abs(held).max()


@pytest.mark.slow  # over 2 s: two 1.5 s renders
def test_pitch_bend_bends_by_the_presets_range():
    inst = synth.Instrument("sitar")
    inst.pitch_bend(8191, time=0.0)               # +2 semitones (play.pitch_bend_semitones)
    inst.note_on(57, 100, time=0.0)
    a = inst.render(1.5)
    r = check_f0(a.samples.mean(axis=1), a.fs, SITAR_A3_HZ * 2 ** (2 / 12), cents=3.0)
    assert r.passed, (r.measured, r.expected)


@pytest.mark.parametrize("call, message", [
    (lambda i: i.note_on(200), "key = 200 is out of range (0 <= value <= 127)"),
    (lambda i: i.note_on(57, 0), "velocity = 0 is out of range (1 <= value <= 127)"),
    (lambda i: i.note_on(57, 128), "velocity = 128 is out of range (1 <= value <= 127)"),
    (lambda i: i.note_on(57, 0.5), "velocity = 0.5 is not an integer (1 <= value <= 127)"),
    (lambda i: i.note_on(57, 100, channel=17), "channel = 17 is out of range (1 <= value <= 16)"),
    (lambda i: i.note_on(57, 100, time=-1), "time = -1 is out of range (0 <= value <= 21600 s)"),
    (lambda i: i.note_off(128), "key = 128 is out of range (0 <= value <= 127)"),
    (lambda i: i.control(128, 0), "cc = 128 is out of range (0 <= value <= 127)"),
    (lambda i: i.control(64, 0.5), "value = 0.5 is not an integer (0 <= value <= 127)"),
    (lambda i: i.pitch_bend(8192), "value = 8192 is out of range (-8192 <= value <= 8191)"),
    (lambda i: i.render(-1), "seconds = -1 is out of range (0 < value <= 600)"),
    (lambda i: i.render(0), "seconds = 0 is out of range (0 < value <= 600)"),
])
def test_instrument_checks_its_events(inst, call, message):
    inst.reset()
    with pytest.raises(ValueError) as e:
        call(inst)
    assert str(e.value) == message


def test_time_must_not_go_backwards(inst):
    inst.reset()
    inst.note_on(57, 100, time=0.5)
    with pytest.raises(ValueError, match=r"^time = 0.2 s is before the previous event's \(0.5 s\): "
                                         r"give events in time order$"):
        inst.note_off(57, time=0.2)
    inst.note_off(57, time=0.5)                   # the same time is in order
    inst.render(0.75)
    assert inst.time == 0.75 and 0.75 < inst.horizon <= 0.75 + (1024 + 42 + 16) / 48_000
    with pytest.raises(ValueError, match=r"^time = 0.6 s is before the end of the audio already "
                                         r"rendered \(Instrument.time = 0.75 s\)$"):
        inst.control(64, 127, time=0.6)
    with pytest.raises(ValueError, match=r"^time = 0.751 s is before Instrument.horizon \(0.76"):
        inst.control(64, 127, time=0.751)         # rendered already, not yet returned
    inst.control(64, 127)                         # None: at the horizon
    inst.control(64, 0, time=inst.horizon)
    inst.note_on(57, 100, time=1.0)
    with pytest.raises(ValueError, match=r"^time = None \(the horizon, 0.76\d* s\) is before the previous event's \(1 s\)"):
        inst.note_off(57)


def test_an_event_given_late_is_at_the_horizon_as_a_note_on_there_is(inst):
    """time=None after a render: the sound of an event at the horizon given before the render."""
    inst.reset()
    inst.note_on(57, 100, time=0.0)
    inst.render(0.3)
    h = inst.horizon
    inst.note_off(57)
    late = inst.render(0.5).samples
    inst.reset()
    inst.note_on(57, 100, time=0.0)
    inst.note_off(57, time=h)
    inst.render(0.3)
    assert np.array_equal(inst.render(0.5).samples, late)


def test_an_instrument_at_another_rate():
    i = synth.Instrument("biwa", rate=44_100)
    assert (i.fs, i.preset, i.channels) == (44_100, "biwa", 1)
    i.note_on(57, 100, time=0.0)
    a = i.render(0.1)
    assert a.fs == 44_100 and a.frames == 4410 and np.abs(a.samples).max() > 0.01
    with pytest.raises(ValueError, match=r"^rate = 1000 Hz is out of range"):
        synth.Instrument("biwa", rate=1000)


def test_instrument_errors_name_the_preset_and_the_override():
    with pytest.raises(ValueError, match="unknown preset 'sitr'; did you mean 'sitar'"):
        synth.Instrument("sitr")
    with pytest.raises(ValueError, match=r"unknown key 'pluck.positon'"):
        synth.Instrument("sitar", set={"pluck.positon": 0.5})

