"""Live play (synth/io/live/, ``synth play``): real components as far as
the machine has them.

* The audio path is a real PortAudio stream on ALSA's null device (a
  ``.asoundrc`` with ``pcm.!default { type null }`` in a temporary HOME, in a
  subprocess because PortAudio reads the ALSA configuration once, at
  initialisation).  The null device discards the samples and does not pace
  the stream: blocks are pulled as fast as they render, so stream time runs
  ahead of the clock and events count as late; what is checked is that the
  stream runs, voices sound and nothing fails.
* MIDI comes from a real virtual ALSA port where the ALSA sequencer exists
  (skipped otherwise: containers rarely have /dev/snd/seq); elsewhere the
  messages go into the port callback's own function, ``Player.handle``.
* Missing pieces (PortAudio, sounddevice, python-rtmidi, the port) are
  simulated in subprocesses and must give one line and exit status 2.
"""

from __future__ import annotations

import ctypes.util
import importlib.util
import json
import os
import signal
import subprocess
import sys
import textwrap
import time

import mido
import numpy as np
import pytest

from helpers import engine, note
from synth.cli import main
from synth.engine.engine import Event
from synth.io import live
from synth.io.errors import SynthError
from synth.io.midi import read_midi_file

PORTAUDIO = ctypes.util.find_library("portaudio")
HAVE_SOUNDDEVICE = importlib.util.find_spec("sounddevice") is not None
HAVE_RTMIDI = importlib.util.find_spec("rtmidi") is not None
needs_portaudio = pytest.mark.skipif(
    PORTAUDIO is None or not HAVE_SOUNDDEVICE,
    reason="libportaudio2 is not installed (apt-get install libportaudio2)" if PORTAUDIO is None
    else "sounddevice is not installed (pip install -e '.[test]')")


@pytest.fixture(autouse=True)
def _isolated(tmp_path, monkeypatch):
    monkeypatch.delenv("SYNTH_PRESET_PATH", raising=False)
    monkeypatch.chdir(tmp_path)


@pytest.fixture
def null_home(tmp_path):
    """A HOME whose ALSA configuration sends the default PCM to the null device."""
    home = tmp_path / "home"
    home.mkdir()
    (home / ".asoundrc").write_text("pcm.!default { type null }\n")
    return home


def _env(home=None, pythonpath=None):
    env = dict(os.environ)
    if home is not None:
        env["HOME"] = str(home)
    if pythonpath is not None:
        env["PYTHONPATH"] = os.pathsep.join([str(pythonpath)] + (
            [env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
    env.pop("MIDO_BACKEND", None)
    return env


def _synth(*argv, env, pre="", timeout=120):
    """``synth ARGV`` in a fresh interpreter (after running ``pre``)."""
    code = f"import sys\n{pre}\nfrom synth.cli import main\nsys.exit(main({list(argv)!r}))\n"
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True, timeout=timeout)


def assert_one_line_error(p, *fragments):
    assert p.returncode == 2, (p.returncode, p.stdout, p.stderr)
    assert "Traceback" not in p.stderr, p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("synth: error: "), p.stderr
    for f in fragments:
        assert f in lines[0], (f, lines[0])
    return lines[0]


# ---------------------------------------------------------------------------
# Nothing live is imported for offline work
# ---------------------------------------------------------------------------


@pytest.mark.slow  # over 2 s on a quiet 2-core machine (1.6-2.2 s, 2026-11-30): a fresh process
def test_import_and_offline_render_never_load_sounddevice(tmp_path):
    code = textwrap.dedent(f"""
        import sys
        import synth, synth.cli, synth.io.live
        synth.cli.build_parser()
        assert synth.cli.main(["note", "sitar", "--key", "57", "--seconds", "0.05",
                               "-o", {str(tmp_path / 'a.wav')!r}]) == 0
        bad = [m for m in ("sounddevice", "rtmidi", "mido.backends.rtmidi") if m in sys.modules]
        assert not bad, bad
    """)
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr


# ---------------------------------------------------------------------------
# Normalisation: one function for files and keyboards
# ---------------------------------------------------------------------------


def test_live_messages_normalise_like_the_file_reader(tmp_path):
    msgs = [mido.Message("note_on", channel=3, note=60, velocity=127),
            mido.Message("note_on", channel=3, note=61, velocity=1),
            mido.Message("note_on", channel=3, note=60, velocity=0),
            mido.Message("note_off", channel=2, note=61, velocity=100),
            mido.Message("control_change", channel=0, control=64, value=127),
            mido.Message("control_change", channel=0, control=67, value=0),
            mido.Message("pitchwheel", channel=1, pitch=-8192),
            mido.Message("pitchwheel", channel=1, pitch=8191),
            mido.Message("pitchwheel", channel=1, pitch=0),
            mido.Message("program_change", channel=0, program=5),
            mido.Message("aftertouch", channel=0, value=50)]
    mf = mido.MidiFile(type=0)
    tr = mido.MidiTrack()
    for i, m in enumerate(msgs):
        tr.append(m.copy(time=0 if i == 0 else 10))
    mf.tracks.append(tr)
    mf.save(tmp_path / "m.mid")
    from_file = read_midi_file(tmp_path / "m.mid")
    played = [m for m in msgs if m.type != "program_change"]
    from_live = [live.normalise(m) for m in played]
    assert [live.normalise(m) for m in msgs if m.type == "program_change"] == [None]
    assert [(e.kind, e.channel, e.key, e.value) for e in from_file if e.kind != "program"] == \
        [(e.kind, e.channel, e.key, e.value) for e in from_live]
    assert [e.value for e in from_live[:4]] == [1.0, 1 / 127, 64 / 127, 100 / 127]
    assert [e.value for e in from_live[6:]] == [-1.0, 1.0, 0.0, 50 / 127]
    assert (from_live[-1].kind, from_live[-1].key) == ("channel_pressure", -1)
    assert from_live[2].kind == "note_off"


def test_engine_ignores_kinds_it_does_not_play():
    """Live normalisation forwards every kind it produces; the engine must
    ignore one it does not play (not fail), and accept pitch bend."""
    a = engine("sitar").render(note(57, 0.0, 0.8), duration_s=0.05)
    b = engine("sitar").render(note(57, 0.0, 0.8) + [Event(0.01, "aftertouch", -1, 0.7)],
                               duration_s=0.05)
    # (the event splits the block's render; the sitar's bridge group steps in
    # other chunks then, the same samples to round-off)
    assert np.max(np.abs(a - b)) < 1e-12 * np.max(np.abs(a)) and np.max(np.abs(a)) > 1e-4
    bend = live.normalise(mido.Message("pitchwheel", pitch=4096))
    c = engine("sitar").render(note(57, 0.0, 0.8) + [Event(0.01, bend.kind, bend.key, bend.value)],
                               duration_s=0.05)
    assert np.all(np.isfinite(c)) and np.max(np.abs(c)) > 1e-4


WARM_SCRIPT = r"""
import importlib, json, pkgutil, sys
import numpy as np
from numba.core.registry import CPUDispatcher
import synth.kernels
from synth.engine.engine import Event
from synth.io.live import ready_engine
from synth.io.presets import load_preset

mods = [importlib.import_module(f"synth.kernels.{m.name}")
        for m in pkgutil.iter_modules(synth.kernels.__path__)]
def compiled():
    return {f"{m.__name__}.{n}": len(f.signatures) for m in mods
            for n, f in vars(m).items() if isinstance(f, CPUDispatcher)}
res = {}
for name in sys.argv[1:]:
    eng = ready_engine(name, 128)
    before = compiled()
    play = load_preset(name).play
    lo, hi = (play.key_low, play.key_high) if play else (30, 90)
    rng = np.random.default_rng(3)
    ev = [Event(0.0, "control", 64, 0.5), Event(0.1, "control", 67, 1.0),
          Event(0.15, "pitch_bend", -1, -1.0), Event(0.3, "control", 123, 0.0)]
    for i in range(40):
        k = int(rng.integers(lo - 3, hi + 4))
        ev += [Event(0.008 * i, "note_on", k, float(rng.uniform(0.05, 1.0))),
               Event(0.008 * i + 0.05, "note_off", k, 0.5)]
    eng.schedule(ev)
    for b in range(150):
        eng.render_block(128 if b % 5 else 77)
        if b == 30:
            eng.shed(2)
    after = compiled()
    res[name] = {k: [before[k], v] for k, v in after.items() if v != before[k]}
    assert any(before.values())
print("JSON " + json.dumps(res))
"""


@pytest.mark.slow  # over 2 s on a quiet 2-core machine
def test_warm_up_leaves_no_kernel_to_compile_in_the_callback():
    """A kernel first compiled (or loaded from the cache) inside the audio
    callback would be a dropout of a second or more: after ``ready_engine``'s
    warm-up a varied performance (keys beyond the range, restrikes, pedals,
    bend, stealing, shedding, odd block sizes) must not add one signature.
    In a fresh process, so that nothing else has compiled them."""
    p = subprocess.run([sys.executable, "-c", WARM_SCRIPT, "sitar", "grand-piano",
                        "paper/sitar-case1"], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    res = json.loads(p.stdout.split("JSON ", 1)[1])
    assert res == {"sitar": {}, "grand-piano": {}, "paper/sitar-case1": {}}, res


def _shipped_presets():
    from synth.io.presets import list_presets

    return [n for n, _ in list_presets()]


@pytest.mark.slow  # the grand's engine takes 1-2 s to build and warm
@pytest.mark.parametrize("name", _shipped_presets())
def test_every_shipped_preset_is_ready_for_a_keyboard(name):
    """``synth play --preset NAME`` builds its engine for any key a keyboard
    may send (``ready_engine``: every key designed, sized for key 0), and a
    note-on at either end of MIDI's range plays or is dropped, never an
    error: the hammered sitar's keys 126-127, too short for its jawari's
    sub-cell contact, stopped its warm-up (``synth play`` could not start)."""
    from synth.engine.engine import NOTE_OFF, NOTE_ON, Event
    from synth.io.live.engines import ready_engine

    eng = ready_engine(name, 128, {})
    eng.schedule([Event(0.0, NOTE_ON, k, 0.8) for k in (0, 60, 127)]
                 + [Event(0.01, NOTE_OFF, k, 0.5) for k in (0, 60, 127)])
    y = np.concatenate([eng.render_block(128) for _ in range(8)], axis=-1)
    assert np.isfinite(y).all()
    assert eng.n_voices + eng.n_dropped >= 1


# ---------------------------------------------------------------------------
# Program map
# ---------------------------------------------------------------------------


def test_program_map_parses_and_defaults_to_the_preset():
    pm = live.ProgramMap.parse("0=grand-piano, 1=sitar,24=biwa", "sitar")
    assert pm.programs == {0: "grand-piano", 1: "sitar", 24: "biwa"}
    assert pm.preset_for(24) == "biwa" and pm.preset_for(2) is None
    assert live.ProgramMap.parse(None, "biwa").programs == {0: "biwa"}
    assert live.ProgramMap.parse("5=grand-piano", "biwa").programs == {0: "biwa", 5: "grand-piano"}
    assert str(pm) == "0=grand-piano,1=sitar,24=biwa"


@pytest.mark.parametrize("text, fragments", [
    ("1=sitr", ["1=sitr", "unknown preset 'sitr'", "available:", "grand-piano"]),
    ("128=sitar", ["program = 128 is out of range (0 <= value <= 127)"]),
    ("-1=sitar", ["program = -1 is out of range"]),
    ("one=sitar", ["program 'one' is not an integer"]),
    ("1:sitar", ["'1:sitar' is not PROGRAM=PRESET"]),
    ("1=", ["is not PROGRAM=PRESET"]),
    ("1=sitar,1=biwa", ["program 1 is given twice"]),
    (" , ", ["is empty"]),
])
def test_program_map_errors_are_one_line(text, fragments):
    with pytest.raises(SynthError) as ei:
        live.ProgramMap.parse(text, "sitar")
    msg = str(ei.value)
    assert "\n" not in msg and msg.startswith("--program-map")
    for f in fragments:
        assert f in msg, (f, msg)


def test_play_argument_errors_come_before_any_device(capsys):
    """Bad arguments fail in one line even where no audio or MIDI exists."""
    cases = [(["play"], "--preset"),
             (["play", "--preset", "sitr"], "unknown preset 'sitr'"),
             (["play", "--preset", "sitar", "--program-map", "200=biwa"], "program = 200"),
             (["play", "--preset", "sitar", "--block", "8"], "--block = 8 is out of range"),
             (["play", "--preset", "sitar", "--latency-ms", "1"], "--latency-ms = 1 is out of range"),
             (["play", "--preset", "sitar", "--latency-ms", "-3"], "--latency-ms = -3"),
             (["play", "--preset", "sitar", "--set", "play.polyphony=0"], "play.polyphony"),
             (["play", "--preset", "sitar", "--warm-every-ms", "1"],
              "--warm-every-ms = 1 is out of range (0: off, or 2 <= value <= 1000)"),
             (["play", "--preset", "sitar", "--set", "nosuch.key=1"], "nosuch")]
    for argv, frag in cases:
        rc = main(argv)
        err = capsys.readouterr().err
        assert rc == 2 and "Traceback" not in err, err
        lines = err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("synth: error: ") and frag in lines[0], err


# ---------------------------------------------------------------------------
# Port and device names
# ---------------------------------------------------------------------------


class FakeBackend:
    def __init__(self, names=None, error=None):
        self.names, self.error = names, error

    def get_input_names(self):
        if self.error:
            raise self.error
        return list(self.names)


PORTS = ["Midi Through:Midi Through Port-0 14:0", "Digital Piano:Digital Piano MIDI 1 20:0",
         "nanoKEY2:nanoKEY2 KEYBOARD 24:0"]


def test_midi_port_matching():
    b = FakeBackend(PORTS)
    assert live.pick_midi_port(b, PORTS[2]) == PORTS[2]                     # exact
    assert live.pick_midi_port(b, "digital piano") == PORTS[1]              # part, any case
    assert live.pick_midi_port(b) == PORTS[1]                               # not Midi Through
    assert live.pick_midi_port(FakeBackend(PORTS[:1])) == PORTS[0]
    assert live.pick_midi_port(b, "KEY") == PORTS[2]
    with pytest.raises(SynthError) as ei:
        live.pick_midi_port(b, "roland")
    msg = str(ei.value)
    assert msg.startswith("--midi-port 'roland' matches no MIDI input port (available: ")
    assert all(n in msg for n in PORTS) and "\n" not in msg


def test_midi_port_ambiguous_part():
    b = FakeBackend(["Piano A 20:0", "Piano B 24:0"])
    with pytest.raises(SynthError) as ei:
        live.pick_midi_port(b, "piano")
    assert "matches several MIDI input ports ('Piano A 20:0'; 'Piano B 24:0')" in str(ei.value)
    assert live.pick_midi_port(b, "piano b") == "Piano B 24:0"


def test_no_midi_port_messages():
    with pytest.raises(SynthError) as ei:
        live.pick_midi_port(FakeBackend([]))
    assert str(ei.value) == live.NO_MIDI_PORT
    assert "/dev/snd/seq" in live.NO_MIDI_PORT
    with pytest.raises(SynthError) as ei:
        live.pick_midi_port(FakeBackend(error=RuntimeError("cannot open the sequencer")))
    assert str(ei.value) == f"{live.NO_MIDI_PORT} (cannot open the sequencer)"


def test_match_name_prefers_the_exact_name():
    names = ["USB Audio", "USB Audio Device"]
    assert live.match_name("USB Audio", names, "--audio-device", "audio output device") == "USB Audio"
    assert live.match_name("device", names, "--audio-device", "audio output device") \
        == "USB Audio Device"


# ---------------------------------------------------------------------------
# What is missing, in one line
# ---------------------------------------------------------------------------


def test_missing_portaudio_is_one_line(tmp_path):
    """sounddevice raises OSError('PortAudio library not found') at import
    when libportaudio is absent: simulated by a module of that name first on
    the path."""
    fake = tmp_path / "fake"
    fake.mkdir()
    (fake / "sounddevice.py").write_text("raise OSError('PortAudio library not found')\n")
    env = _env(pythonpath=fake)
    p = _synth("play", "--preset", "sitar", env=env)
    line = assert_one_line_error(p)
    assert line == f"synth: error: {live.PORTAUDIO_MISSING}"
    assert "apt-get install libportaudio2" in line and "brew install portaudio" in line
    p = _synth("play", "--list-ports", env=env)
    assert p.returncode == 0 and "Traceback" not in p.stderr, p.stderr
    assert f"unavailable: {live.PORTAUDIO_MISSING}" in p.stdout
    assert "MIDI input ports" in p.stdout


def test_missing_sounddevice_is_one_line():
    p = _synth("play", "--preset", "sitar", env=_env(), pre="sys.modules['sounddevice'] = None")
    assert_one_line_error(p, "sounddevice is not installed", 'pip install -e ".[live]"')


@needs_portaudio
def test_missing_rtmidi_is_one_line(null_home):
    p = _synth("play", "--preset", "sitar", env=_env(null_home), pre="sys.modules['rtmidi'] = None")
    assert_one_line_error(p, "python-rtmidi is not installed", 'pip install -e ".[live]"')
    p = _synth("play", "--list-ports", env=_env(null_home), pre="sys.modules['rtmidi'] = None")
    assert p.returncode == 0 and "Traceback" not in p.stderr, p.stderr
    assert "unavailable: python-rtmidi is not installed" in p.stdout
    assert "*  0  default" in p.stdout                    # the audio half still listed


@needs_portaudio
@pytest.mark.skipif(not HAVE_RTMIDI, reason="python-rtmidi is not installed")
def test_unknown_midi_port_is_one_line(null_home):
    p = _synth("play", "--preset", "sitar", "--midi-port", "no-such-keyboard-xyz",
               env=_env(null_home))
    line = assert_one_line_error(p)
    # with an ALSA sequencer (or a JACK server) the ports are listed;
    # without either, that is said
    assert ("--midi-port 'no-such-keyboard-xyz' matches no MIDI input port (available: " in line
            or live.NO_MIDI_PORT in line or live.NO_MIDI_SYSTEM in line), line


@needs_portaudio
def test_no_audio_device_is_one_line(tmp_path):
    """PortAudio without any output device (an ALSA configuration with none)."""
    home = tmp_path / "h"
    home.mkdir()
    (home / ".asoundrc").write_text("pcm.!default { type hw card 99 }\nctl.!default { type hw card 99 }\n")
    p = _synth("play", "--preset", "sitar", "--audio-device", "no-such-device-xyz",
               env=_env(home))
    line = assert_one_line_error(p)
    assert ("no audio output device found" in line
            or "--audio-device 'no-such-device-xyz' matches no audio output device" in line), line


@needs_portaudio
def test_list_ports_with_the_null_device(null_home):
    p = _synth("play", "--list-ports", env=_env(null_home))
    assert p.returncode == 0 and "Traceback" not in p.stderr, p.stderr
    assert "Audio output devices" in p.stdout and "*  0  default  (ALSA" in p.stdout
    assert "MIDI input ports" in p.stdout


# ---------------------------------------------------------------------------
# A real stream
# ---------------------------------------------------------------------------

STREAM_SCRIPT = r"""
import json, sys, time
import mido
from synth.io.live import Player, ProgramMap

p = Player("sitar", ProgramMap.parse("1=biwa", "sitar"), block=128, midi=False,
           record=sys.argv[1] if len(sys.argv) > 1 else None)
p.start()
h = p.handle                                     # the MIDI input port's callback
for k in (50, 57, 62):
    h(mido.Message("note_on", note=k, velocity=100))
h(mido.Message("control_change", control=64, value=127))
h(mido.Message("pitchwheel", pitch=3000))
h(mido.Message("clock"))
time.sleep(0.3)
for k in (50, 57, 62):
    h(mido.Message("note_on", note=k, velocity=0))
h(mido.Message("program_change", program=1))
h(mido.Message("program_change", program=7))     # unmapped: ignored
time.sleep(0.3)
h(mido.Message("note_on", note=55, velocity=90))
p.run(seconds=0.5)
st = p.rt.stats
print("JSON " + json.dumps(dict(blocks=st.blocks, errors=st.errors, underruns=st.underruns,
                                max_voices=p.max_voices, peak=p.peak, notes=p.n_notes,
                                messages=p.n_messages, handler_errors=p.handler_errors,
                                preset=p.preset_name, programs=p.n_program_changes,
                                ready_s=p.ready_s, closed=p.stream is None and p.port is None,
                                rehearsed=p.rehearsal.notes, rehearsal_error=p.rehearsal.error,
                                rehearsal_on_biwa=p.rehearsal.engine.inst is p.instruments["biwa"],
                                rehearsal_alive=p.rehearsal.is_alive())))
"""


@needs_portaudio
@pytest.mark.slow  # over 2 s on a quiet 2-core machine: ~3 s of CPU in its subprocess
def test_real_stream_on_the_null_device_plays_messages(null_home, tmp_path):
    import soundfile

    rec = tmp_path / "live.wav"
    p = subprocess.run([sys.executable, "-c", STREAM_SCRIPT, str(rec)], env=_env(null_home),
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    assert "Traceback" not in p.stderr, p.stderr
    out = p.stdout
    assert "ready in " in out and "audio out 'default'" in out
    assert "blocks of 128 at 48000 Hz" in out                 # the report
    assert "program 1: biwa" in out and "program 7 is not in the program map" in out
    r = json.loads(out.split("JSON ", 1)[1])
    assert r["blocks"] > 300                                  # > 0.8 s of audio
    assert r["errors"] == 0 and r["handler_errors"] == 0
    assert r["max_voices"] >= 3 and r["notes"] == 4 and r["messages"] == 12
    assert 1e-3 < r["peak"] < 1.0                             # it sounded, unclipped
    assert r["preset"] == "biwa" and r["programs"] == 1
    assert r["closed"]
    # the silent notes that keep the paths warm: on the program's preset, stopped with the play
    assert r["rehearsed"] > 20 and r["rehearsal_error"] is None
    assert r["rehearsal_on_biwa"] and not r["rehearsal_alive"]
    assert f"kept warm by {r['rehearsed']} silent notes on an understudy, one every 20 ms" in out
    # --record: what went to the device, as a complete WAV file
    info = soundfile.info(str(rec))
    assert info.channels == 2 and info.frames >= r["blocks"] * 128 * 0.9
    assert f"recorded {info.frames / 48000:.1f} s to" in out


def _seq_reason():
    if not os.path.exists("/dev/snd/seq"):
        return "no ALSA sequencer (/dev/snd/seq) on this machine"
    if not HAVE_RTMIDI:
        return "python-rtmidi is not installed"
    try:
        port = mido.Backend("mido.backends.rtmidi").open_output("synth-probe", virtual=True)
        port.close()
    except Exception as e:  # pragma: no cover - depends on the machine
        return f"cannot open a virtual MIDI port ({e})"
    return None


SEQ_REASON = _seq_reason()


@needs_portaudio
@pytest.mark.skipif(SEQ_REASON is not None, reason=str(SEQ_REASON))
def test_virtual_midi_port_into_synth_play(null_home):  # pragma: no cover - needs /dev/snd/seq
    backend = mido.Backend("mido.backends.rtmidi")
    with backend.open_output("synth-test", virtual=True) as out:
        proc = subprocess.Popen([sys.executable, "-c", "import sys\nfrom synth.cli import main\n"
                                 "sys.exit(main(['play', '--preset', 'sitar', '--midi-port', "
                                 "'synth-test', '--stats']))"],
                                env=_env(null_home), stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True)
        lines = []
        t_end = time.monotonic() + 60
        while time.monotonic() < t_end:
            line = proc.stdout.readline()
            lines.append(line)
            if "ready in" in line or not line:
                break
        assert any("ready in" in ln for ln in lines), (lines, proc.poll())
        time.sleep(0.2)
        for k in (50, 57):
            out.send(mido.Message("note_on", note=k, velocity=100))
        time.sleep(0.5)
        for k in (50, 57):
            out.send(mido.Message("note_off", note=k))
        time.sleep(0.3)
        proc.send_signal(signal.SIGINT)
        rest, err = proc.communicate(timeout=30)
    assert proc.returncode == 0, err
    assert "Traceback" not in err
    assert "4 MIDI messages, 2 notes" in rest and "blocks of 128 at 48000 Hz" in rest


@pytest.mark.slow  # over 2 s on a quiet 2-core machine: ~3 s of CPU, two engines readied
def test_set_overrides_the_first_preset_of_live_play():
    """``synth play --set`` reaches the engine the stream plays."""
    from synth.io.live import ready_engine

    assert ready_engine("sitar", overrides=["play.polyphony=7"]).polyphony == 7
    assert ready_engine("sitar").polyphony != 7


def _resident_fraction(a: np.ndarray) -> float:
    """The share of ``a``'s pages that are mapped now (the "present" bit of
    each page's entry in /proc/self/pagemap, which any process may read)."""
    addr = a.__array_interface__["data"][0]
    p0, p1 = addr // 4096, (addr + a.nbytes - 1) // 4096
    with open("/proc/self/pagemap", "rb") as f:
        f.seek(p0 * 8)
        e = np.frombuffer(f.read((p1 - p0 + 1) * 8), dtype=np.uint64)
    return float(np.mean((e >> np.uint64(63)) & np.uint64(1)))


def _fresh(n_bytes: int) -> np.ndarray:
    """A float64 array on pages no one has touched (its own anonymous
    mapping: malloc might hand back pages a freed array had mapped)."""
    import mmap

    return np.frombuffer(mmap.mmap(-1, n_bytes), dtype=np.float64)


@pytest.mark.skipif(not os.path.exists("/proc/self/pagemap"), reason="needs Linux's /proc")
def test_the_audio_threads_buffers_are_mapped_before_play():
    """The recording ring and the loopback's capture are resident when
    made, so the process callback never waits for a page (a fresh 2 MB
    page cost 5 ms on this VM, two periods).  ``np.zeros`` alone is not
    (its pages come on first write): the check tells the two apart."""
    from synth.engine.warm import resident_zeros

    fresh = _fresh(48 << 20)
    assert _resident_fraction(fresh) < 0.01
    fresh[::512] = 0.0
    assert _resident_fraction(fresh) == 1.0
    mapped = resident_zeros((6 << 20, 2))
    # (before anything reads it: a read maps the kernel's zero page, which
    # the check would count, and a write would still fault)
    assert _resident_fraction(mapped) == 1.0
    assert mapped.shape == (6 << 20, 2) and mapped.dtype == np.float32 and not mapped.any()


@pytest.mark.slow  # over 2 s on a quiet 2-core machine
def test_a_live_engine_has_its_buffers_mapped_and_unchanged(monkeypatch):
    """``ready_engine`` maps every page of the engine's large arrays
    (:func:`synth.engine.warm.fault_in`), so that none waits for its first
    use in play (the sitar's hand-over buffer, the mix's rows for longer
    blocks: whether malloc hands out fresh pages depends on what the
    process freed before), and the walk keeps every value."""
    from synth.engine import warm
    from synth.io import factory
    from synth.io.live.engines import ready_engine

    seen = []
    monkeypatch.setattr(factory, "fault_in", lambda e: seen.append(e) or warm.fault_in(e))
    eng = ready_engine("sitar", 128, {}, fs_out=48000)
    assert seen == [eng]
    if os.path.exists("/proc/self/pagemap"):
        assert _resident_fraction(eng.bank.ring) == 1.0
        eng.bank._fresh_for_test = fresh = _fresh(8 << 20)    # an array the bank holds
        assert _resident_fraction(fresh) < 0.01
        assert warm.fault_in(eng) >= eng.bank.ring.nbytes + fresh.nbytes
        assert _resident_fraction(fresh) == 1.0
    ring = eng.bank.ring
    ring[::977] = np.arange(ring[::977].size, dtype=float)
    copy = ring.copy()
    warm.fault_in(eng)
    assert np.array_equal(ring, copy)
