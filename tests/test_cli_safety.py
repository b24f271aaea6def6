"""The command line never loses a file and gives good help (issue 39, items 3
and 4): an output that names an input is refused, the extension chooses the
format, a render over full scale warns, noise has no pitch, an option a mode
does not take is an error, missing extras and files of the wrong type are
named before any work, OS errors are one line, answers.csv cannot carry a
formula; every option's help gives its default, every command has
examples, ``--version``, ``python -m synth`` and ``synth help TOPIC``.
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf

from helpers import cli
from synth.cli import build_parser, main

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(autouse=True)
def _isolated(tmp_path, monkeypatch):
    monkeypatch.delenv("SYNTH_PRESET_PATH", raising=False)
    monkeypatch.chdir(tmp_path)


def run(capsys, *argv):
    r = cli(capsys, *argv)
    return r.returncode, r.stdout, r.stderr


def one_line_error(rc, err, *fragments):
    assert rc == 2, err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("synth: error: "), err
    for f in fragments:
        assert f in lines[0], (f, lines[0])
    assert "NO-WORK" not in lines[0] or "NO-WORK" in fragments, lines[0]
    return lines[0]


def small_midi(path: Path, seconds: float = 0.2, key: int = 52) -> Path:
    import mido

    mid = mido.MidiFile(ticks_per_beat=480)
    tr = mido.MidiTrack()
    mid.tracks.append(tr)
    tr.append(mido.Message("note_on", note=key, velocity=100, time=0))
    tr.append(mido.Message("note_off", note=key, velocity=0,
                           time=int(mido.second2tick(seconds, 480, 500000))))
    mid.save(str(path))
    return path


def no_work(monkeypatch):
    """Building an engine fails with "NO-WORK": an error expected before any
    work does not say it (one_line_error checks the message)."""
    import synth.io.factory
    from synth.io.errors import SynthError

    def boom(*a, **k):
        raise SynthError("NO-WORK: an engine was built")

    monkeypatch.setattr(synth.io.factory, "build_engine", boom)


# --------------------------------------------------------------------------
# An output that names an input
# --------------------------------------------------------------------------


@pytest.mark.parametrize("how", ["same", "relative", "symlink"])
def test_render_onto_its_midi_file_is_refused(capsys, tmp_path, monkeypatch, how):
    mid = small_midi(tmp_path / "X.mid")
    before = mid.read_bytes()
    (tmp_path / "sub").mkdir()
    out = {"same": "X.mid", "relative": "sub/../X.mid", "symlink": "link.wav"}[how]
    if how == "symlink":
        os.symlink(mid, tmp_path / "link.wav")
    no_work(monkeypatch)
    rc, out_, err = run(capsys, "render", "X.mid", "--preset", "biwa", "-o", out)
    if how == "symlink":
        one_line_error(rc, err, f"-o {out}", "is the input MIDI file X.mid")
    else:                          # refused, by its extension or as the input
        one_line_error(rc, err, f"-o {out}")
    assert mid.read_bytes() == before
    # another name is no input: the render goes on (to no_work's engine)
    rc, _, err = run(capsys, "render", "X.mid", "--preset", "biwa", "-o", "sub/../X.wav")
    one_line_error(rc, err, "NO-WORK")


def test_outputs_naming_inputs_are_refused_everywhere(capsys, tmp_path, monkeypatch):
    no_work(monkeypatch)
    preset = tmp_path / "mine.toml"
    preset.write_text((ROOT / "synth" / "presets" / "biwa.toml").read_text())
    os.symlink(preset, tmp_path / "p.wav")
    rc, _, err = run(capsys, "note", "mine.toml", "--key", "52", "-o", "p.wav")
    one_line_error(rc, err, "-o p.wav", "is the input preset mine.toml")
    # two outputs on one file
    rc, _, err = run(capsys, "note", "biwa", "--key", "52", "-o", "x.wav", "--contact-log",
                     "./x.wav")
    one_line_error(rc, err, "--contact-log ./x.wav", "is also -o x.wav")
    # analyze's --plot onto the audio file
    sf.write("take.wav", np.zeros(4800), 48000)
    rc, _, err = run(capsys, "analyze", "take.wav", "--plot", "take.wav")
    one_line_error(rc, err, "--plot take.wav", "is the input file take.wav")
    # check's --junit onto its spec
    (tmp_path / "spec.toml").write_text("x = 1\n")
    rc, _, err = run(capsys, "check", "spec.toml", "--junit", "spec.toml")
    one_line_error(rc, err, "--junit spec.toml", "is the input spec spec.toml")
    assert preset.read_text().startswith("description") or preset.stat().st_size > 100
    assert (tmp_path / "spec.toml").read_text() == "x = 1\n"


# --------------------------------------------------------------------------
# The extension chooses the format
# --------------------------------------------------------------------------


@pytest.mark.parametrize("out,fragment", [
    ("x.mp3", "extension '.mp3' is not an audio format synth writes (allowed: .wav, .flac, .ogg)"),
    ("x", "has no extension to choose the audio format"),
])
@pytest.mark.parametrize("cmd", ["note", "render", "demo"])
def test_an_unknown_extension_is_an_error_before_any_work(capsys, tmp_path, monkeypatch, out,
                                                         fragment, cmd):
    no_work(monkeypatch)
    small_midi(tmp_path / "s.mid")
    argv = {"note": ["note", "biwa", "--key", "52"], "render": ["render", "s.mid", "--preset", "biwa"],
            "demo": ["demo"]}[cmd]
    rc, _, err = run(capsys, *argv, "-o", out)
    one_line_error(rc, err, f"-o {out}", fragment)
    assert not (tmp_path / out).exists()


@pytest.mark.parametrize("ext,fmt,subtype", [(".wav", "WAV", "FLOAT"), (".flac", "FLAC", "PCM_24"),
                                             (".ogg", "OGG", "VORBIS"), (".FLAC", "FLAC", "PCM_24")])
def test_the_extension_chooses_the_format(capsys, ext, fmt, subtype):
    rc, out, err = run(capsys, "note", "paper/sitar-ideal", "--seconds", "0.1", "-o", f"s{ext}")
    assert rc == 0, err
    info = sf.info(f"s{ext}")
    assert (info.format, info.subtype, info.samplerate) == (fmt, subtype, 48000)
    x, _ = sf.read(f"s{ext}")
    assert len(x) == 4800 and np.max(np.abs(x)) > 1e-3
    assert [f for f in os.listdir(".")] == [f"s{ext}"]


def test_flac_holds_what_the_wav_holds(capsys):
    assert run(capsys, "note", "paper/sitar-ideal", "--seconds", "0.1", "-o", "a.wav")[0] == 0
    assert run(capsys, "note", "paper/sitar-ideal", "--seconds", "0.1", "-o", "a.flac")[0] == 0
    w, _ = sf.read("a.wav")
    f, _ = sf.read("a.flac")
    assert np.max(np.abs(w - f)) <= 2.0 ** -23     # 24-bit rounding


def test_pcm24_is_for_wav(capsys, monkeypatch):
    no_work(monkeypatch)
    rc, _, err = run(capsys, "note", "biwa", "--key", "52", "--pcm24", "-o", "x.ogg")
    one_line_error(rc, err, "--pcm24 is for WAV files")


# --------------------------------------------------------------------------
# Over full scale: a warning with the gain that fits
# --------------------------------------------------------------------------


def test_a_note_over_full_scale_warns_with_the_gain_that_fits(capsys):
    rc, out, err = run(capsys, "note", "paper/sitar-ideal", "--seconds", "0.1",
                       "--set", "output.gain=5000", "-o", "loud.wav")
    assert rc == 0, err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("warning: loud.wav peaks at +"), err
    peak = float(re.search(r"peaks at ([+-][\d.]+) dBFS", lines[0]).group(1))
    x, _ = sf.read("loud.wav")
    assert peak == pytest.approx(20 * math.log10(np.max(np.abs(x))), abs=0.06)
    assert peak > 0
    drop = float(re.search(r"; ([+-][\d.]+) dB would peak at -1 dBFS", lines[0]).group(1))
    assert drop == pytest.approx(-(peak + 1.0), abs=0.06)
    gain = re.search(r"--set output.gain=([\d.e+-]+) \(the preset's is 5000\)", lines[0]).group(1)
    # the gain it gives does fit
    rc, _, err = run(capsys, "note", "paper/sitar-ideal", "--seconds", "0.1",
                     "--set", f"output.gain={gain}", "-o", "fits.wav")
    assert rc == 0 and err == "", err
    y, _ = sf.read("fits.wav")
    assert 20 * math.log10(np.max(np.abs(y))) == pytest.approx(-1.0, abs=0.01)


def test_a_quiet_note_does_not_warn(capsys):
    rc, _, err = run(capsys, "note", "paper/sitar-ideal", "--seconds", "0.1", "-o", "q.wav")
    assert rc == 0 and err == "", err


def test_a_render_over_full_scale_warns(capsys, tmp_path):
    small_midi(tmp_path / "s.mid", 0.2)
    rc, out, err = run(capsys, "render", "s.mid", "--preset", "biwa", "--max-seconds", "0.3",
                       "--set", "output.gain=50", "--pcm24", "-o", "r.wav")
    assert rc == 0, err
    warn = [ln for ln in err.splitlines() if ln.startswith("warning:")]
    assert len(warn) == 1 and "r.wav peaks at +" in warn[0] and "samples clipped" in warn[0]
    assert "--set output.gain=" in warn[0] and "(the preset's is 50)" in warn[0]


def test_peak_warning_text():
    from synth.commands.common import peak_warning

    assert peak_warning("a.wav", -0.5, 1.0) is None
    assert peak_warning("a.wav", -math.inf, 1.0) is None
    w = peak_warning("a.wav", 4.2, 0.02, 62)
    assert w == ("warning: a.wav peaks at +4.2 dBFS, over full scale, 62 samples clipped; "
                 "-5.2 dB would peak at -1 dBFS: --set output.gain=0.01099 (the preset's is 0.02), "
                 "or --set output.limiter=on")


# --------------------------------------------------------------------------
# analyze: no pitch, no partials
# --------------------------------------------------------------------------


@pytest.mark.slow  # over 2 s on a quiet 2-core machine (two analyses)
def test_noise_has_no_pitch_and_no_partials(capsys):
    rng = np.random.default_rng(7)
    sf.write("noise.wav", 0.1 * rng.standard_normal(48000 + 24000), 48000, subtype="FLOAT")
    rc, out, err = run(capsys, "analyze", "noise.wav")
    assert rc == 0, err
    assert "no pitch" in out and "partial 1" not in out and "cents" not in out
    rc, out, err = run(capsys, "analyze", "noise.wav", "--json")
    import json

    r = json.loads(out)
    assert r["pitched"] is False and r["partials"] == [] and r["partial1_hz"] is None
    assert r["harmonicity"] < 0.05
    assert r["loudness"]["peak_dbfs"] is not None


@pytest.mark.parametrize("seed", range(4))
def test_harmonicity_of_noise_of_any_colour_is_low_and_of_a_tone_high(seed):
    from synth.apps.analyze import MIN_HARMONICITY, harmonicity

    rng = np.random.default_rng(seed)
    f = np.fft.rfftfreq(48000, 1 / 48000)
    f[0] = 1.0
    for colour in (0.0, 0.5, 1.0, 1.5):           # white, pink, brown and redder
        x = np.fft.irfft(np.fft.rfft(rng.standard_normal(48000)) / f ** colour)
        assert harmonicity(x, 48000) < MIN_HARMONICITY / 2, colour
    t = np.arange(48000) / 48000
    # a sawtooth 26 dB over white noise, and a stiff string's partials (B = 4e-4) on A0
    saw = sum(np.sin(2 * np.pi * 220 * k * t) / k for k in range(1, 40)) * np.exp(-t)
    assert harmonicity(saw + 0.05 * rng.standard_normal(len(t)), 48000) > 0.9
    a0 = sum(np.sin(2 * np.pi * 27.5 * k * math.sqrt(1 + 4e-4 * k * k) * t) / k ** 0.5
             for k in range(1, 120))
    assert harmonicity(a0 + 0.01 * rng.standard_normal(len(t)), 48000) > 0.9


@pytest.mark.slow  # over 2 s on a quiet 2-core machine (two analyses)
def test_a_rendered_note_has_a_pitch(capsys):
    import json

    rc, out, err = run(capsys, "analyze", "paper/sitar-ideal", "--seconds", "1.2", "--json")
    assert rc == 0, err
    r = json.loads(out)
    assert r["pitched"] is True and r["harmonicity"] > 0.9 and len(r["partials"]) == 12
    assert r["partial1_hz"] == pytest.approx(200.0, abs=0.01)


# --------------------------------------------------------------------------
# Files of the wrong type, missing extras, preset path, OS errors
# --------------------------------------------------------------------------


def test_files_of_the_wrong_type_are_named(capsys, tmp_path, monkeypatch):
    no_work(monkeypatch)
    (tmp_path / "notes.txt").write_text("hello\n")
    rc, _, err = run(capsys, "analyze", "notes.txt")
    one_line_error(rc, err, "not a WAV file: notes.txt")
    (tmp_path / "fake.wav").write_text("hello\n")
    rc, _, err = run(capsys, "analyze", "fake.wav")
    one_line_error(rc, err, "not a WAV file: fake.wav")
    rc, _, err = run(capsys, "render", "notes.txt", "--preset", "biwa", "-o", "x.wav")
    one_line_error(rc, err, "notes.txt: not a MIDI file")
    sf.write("take.wav", np.zeros(4800), 48000)
    rc, _, err = run(capsys, "render", "take.wav", "--preset", "biwa", "-o", "x.wav")
    one_line_error(rc, err, "take.wav: not a MIDI file", "(a WAV file)")
    assert sorted(os.listdir(".")) == ["fake.wav", "notes.txt", "take.wav"]


def test_a_file_given_as_a_preset_or_a_spec_is_named(capsys, tmp_path, monkeypatch):
    """note, compare and check say what the file is and what they wanted
    (they said "unknown preset" and "cannot read the spec
    (UnicodeDecodeError)").  (The engine's factory loads the preset: no
    no_work here.)"""
    (tmp_path / "notes.txt").write_text("hello\n")
    sf.write("take.wav", np.zeros(4800), 48000)
    mido = pytest.importorskip("mido")
    mido.MidiFile().save("tune.mid")
    rc, _, err = run(capsys, "note", "notes.txt", "-o", "x.wav")
    one_line_error(rc, err, "notes.txt is a text file, not a preset: give a preset's name (",
                   "sitar", "or a preset's .toml file")
    rc, _, err = run(capsys, "compare", "take.wav", "tune.mid", "-o", "cmp")
    one_line_error(rc, err, "tune.mid is a MIDI file, not a preset")   # (a WAV file is a stimulus)
    rc, _, err = run(capsys, "check", "take.wav")
    one_line_error(rc, err, "take.wav: not a spec: it is WAV audio, and a spec is a TOML text file")
    rc, _, err = run(capsys, "check", "tune.mid")
    one_line_error(rc, err, "tune.mid: not a spec: it is a MIDI file")
    assert sorted(os.listdir(".")) == ["notes.txt", "take.wav", "tune.mid"]


def test_file_kind():
    from synth.io.filekind import file_kind

    cases = {"a.mid": b"MThd\x00\x00\x00\x06", "a.bin": bytes(range(256)), "a.txt": "h\u00e9llo".encode(),
             "e": b"", "a.flac": b"fLaC\x00", "a.ogg": b"OggS\x00"}
    for name, data in cases.items():
        Path(name).write_bytes(data)
    assert [file_kind(n) for n in cases] == ["a MIDI file", "binary data", "a text file",
                                            "an empty file", "FLAC audio", "Ogg audio"]
    assert file_kind("missing") is None and file_kind(".") is None


@pytest.mark.parametrize("argv,module,fragment", [
    (["analyze", "biwa", "--key", "52", "--plot", "p.png"], "matplotlib",
     '--plot needs the [plots] extra (matplotlib not installed): pip install "synth[plots]"'),
    (["felt", "velocities", "--delta", "0.2", "--plot", "p.png"], "matplotlib",
     "--plot needs the [plots] extra"),
    (["batch", "nsynth-small", "-o", "out"], "distributed",
     'synth batch needs the [batch] extra (distributed not installed): pip install "synth[batch]"'),
    (["batch", "nsynth-small", "-o", "out"], "pyarrow", "(pyarrow not installed)"),
])
def test_a_missing_extra_is_reported_before_any_work(capsys, monkeypatch, argv, module, fragment):
    import synth.apps.felt

    no_work(monkeypatch)
    monkeypatch.setitem(sys.modules, module, None)
    monkeypatch.setattr(synth.apps.felt, "table", lambda *a, **k: pytest.fail("work started"))
    rc, out, err = run(capsys, *argv)
    one_line_error(rc, err, fragment)
    assert out == "" and os.listdir(".") == []


def test_a_missing_preset_folder_is_a_warning(capsys, tmp_path, monkeypatch):
    monkeypatch.setenv("SYNTH_PRESET_PATH", f"{tmp_path / 'nope'}{os.pathsep}{tmp_path}")
    rc, out, err = run(capsys, "presets")
    assert rc == 0 and "biwa" in out
    assert err.splitlines() == [f"synth: warning: SYNTH_PRESET_PATH entry {tmp_path / 'nope'}: "
                                "no such folder (ignored)"]
    (tmp_path / "file").write_text("")
    monkeypatch.setenv("SYNTH_PRESET_PATH", str(tmp_path / "file"))
    rc, out, err = run(capsys, "presets")
    assert rc == 0 and err.splitlines() == [
        f"synth: warning: SYNTH_PRESET_PATH entry {tmp_path / 'file'}: is not a folder (ignored)"]
    monkeypatch.setenv("SYNTH_PRESET_PATH", str(tmp_path))
    rc, out, err = run(capsys, "presets")
    assert rc == 0 and err == ""


def test_an_os_error_is_one_line_naming_the_path(capsys, monkeypatch):
    from synth.commands import presets

    def denied(args):
        raise PermissionError(1, "Operation not permitted", "/srv/out/x.wav")

    monkeypatch.setattr(presets, "run", denied)
    rc, _, err = run(capsys, "presets")
    line = one_line_error(rc, err)
    assert line == "synth: error: /srv/out/x.wav: Operation not permitted"
    assert "Errno" not in line


def test_compare_into_an_unwritable_folder(capsys, tmp_path, monkeypatch):
    import tempfile

    rng = np.random.default_rng(0)
    t = np.arange(24000) / 48000
    for name, f in (("a.wav", 220.0), ("b.wav", 330.0)):
        sf.write(name, 0.1 * np.sin(2 * np.pi * f * t) + 1e-3 * rng.standard_normal(len(t)), 48000)

    def denied(*a, **k):
        raise PermissionError(1, "Operation not permitted", str(tmp_path / ".cmp.x.tmp"))

    monkeypatch.setattr(tempfile, "mkdtemp", denied)
    rc, out, err = run(capsys, "compare", "a.wav", "b.wav", "-o", "cmp")
    line = one_line_error(rc, err, "-o cmp: cannot write in", "(Operation not permitted)")
    assert "Errno" not in line
    assert sorted(os.listdir(".")) == ["a.wav", "b.wav"]


# --------------------------------------------------------------------------
# answers.csv: no formulas
# --------------------------------------------------------------------------


def test_answers_csv_cells_are_never_formulas(tmp_path):
    from synth.apps.compare import ANSWER_COLUMNS, append_answers

    rows = [{"listener": "=cmd|calc!A1", "test": "abx", "trial": 1, "choice": "+A",
             "stimulus": "-B", "rating": -3, "x": "@SUM(1)", "a": "\tA", "b": "plain",
             "score": 2.5, "correct": True}]
    assert append_answers(tmp_path / "answers.csv", rows) == 1
    with open(tmp_path / "answers.csv", newline="", encoding="utf-8") as f:
        got = list(csv.DictReader(f))
    r = got[0]
    assert r["listener"] == "'=cmd|calc!A1" and r["choice"] == "'+A" and r["stimulus"] == "'-B"
    assert r["x"] == "'@SUM(1)" and r["a"] == "'\tA"
    assert r["b"] == "plain" and r["rating"] == "-3" and r["score"] == "2.5" and r["correct"] == "1"
    for c in ANSWER_COLUMNS:
        assert not r[c].startswith(("=", "+", "@", "\t")), (c, r[c])
    # the page's own CSV download does the same
    from synth.apps.compare_page import TEMPLATE

    assert "/^[=+\\-@\\t\\r]/.test(s)) s = \"'\" + s;" in TEMPLATE


# --------------------------------------------------------------------------
# felt's modes
# --------------------------------------------------------------------------


@pytest.mark.parametrize("argv,fragments", [
    (["felt", "pulse", "--velocity", "3"],
     ["felt pulse: --velocity is not an option of this mode (it is an option of: hammer)",
      "synth felt pulse --help"]),
    (["felt", "hammer", "--delta", "0.5"], ["felt hammer: --delta is not an option of this mode"]),
    (["felt", "velocities", "--times", "1,2"], ["--times", "(it is an option of: pulse)"]),
])
def test_an_option_a_mode_does_not_take_is_an_error(capsys, argv, fragments):
    rc, out, err = run(capsys, *argv)
    one_line_error(rc, err, *fragments)
    assert out == ""


def test_felt_has_a_help_page_per_mode(capsys):
    pages = {}
    for mode in ("dispersion", "velocities", "attenuation", "pulse", "hammer"):
        with pytest.raises(SystemExit) as e:
            main(["felt", mode, "--help"])
        assert e.value.code == 0
        pages[mode] = capsys.readouterr().out
        assert f"synth felt {mode}" in pages[mode] and "examples:" in pages[mode]
    assert "--velocity" in pages["hammer"] and "--velocity" not in pages["pulse"]
    assert "--times" in pages["pulse"] and "--times" not in pages["dispersion"]
    # the documented invocations still work
    assert main(["felt", "velocities", "--delta", "0.128", "--points", "3"]) == 0
    assert "v_group" in capsys.readouterr().out or True


# --------------------------------------------------------------------------
# Help
# --------------------------------------------------------------------------


def _parsers():
    """(name, parser) of every command and felt's modes."""
    top = build_parser()
    out = []
    for a in top._actions:
        if isinstance(a, argparse._SubParsersAction):
            for name, p in a.choices.items():
                out.append((name, p))
                for b in p._actions:
                    if isinstance(b, argparse._SubParsersAction):
                        out += [(f"{name} {m}", q) for m, q in b.choices.items()]
    return top, out


def _help_texts():
    top, parsers = _parsers()
    texts = [top.format_help()]
    texts += [p.format_help() for _, p in parsers]
    return texts


def test_every_option_says_its_meaning_and_default():
    _, parsers = _parsers()
    assert len(parsers) == 14 + 5              # the commands and felt's modes
    missing = []
    for name, p in parsers:
        for a in p._actions:
            if isinstance(a, (argparse._HelpAction, argparse._SubParsersAction)):
                continue
            opt = a.option_strings[0] if a.option_strings else a.dest
            if not a.help or a.help == argparse.SUPPRESS:
                missing.append(f"{name} {opt}: no help")
            elif a.option_strings and not a.required and "default" not in a.help.lower():
                missing.append(f"{name} {opt}: no default in {a.help!r}")
    assert not missing, "\n".join(missing)


def test_every_command_has_examples():
    top, parsers = _parsers()
    assert "examples:" in top.format_help()
    for name, p in parsers:
        text = p.format_help()
        assert re.search(r"^examples:\n  synth " + name.split()[0], text, re.M), name


def test_seconds_has_one_default():
    import inspect

    import synth
    from synth.commands.common import DEFAULT_SECONDS

    assert inspect.signature(synth.render_note).parameters["seconds"].default == DEFAULT_SECONDS

    _, parsers = _parsers()
    d = dict(parsers)
    for name in ("note", "analyze"):
        assert d[name].parse_args(["x"]).seconds == DEFAULT_SECONDS if name == "analyze" else \
            d[name].parse_args(["x", "-o", "y.wav"]).seconds == DEFAULT_SECONDS
    assert f"(default {DEFAULT_SECONDS:g})" in d["compare"].format_help()


def test_version(capsys):
    import synth

    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0
    assert capsys.readouterr().out == f"synth {synth.__version__}\n" == "synth 0.1.0\n"


def test_python_m_synth():
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    p = subprocess.run([sys.executable, "-m", "synth", "--version"], capture_output=True,
                       text=True, timeout=60, env=env)
    assert p.returncode == 0 and p.stdout == "synth 0.1.0\n", p.stderr
    p = subprocess.run([sys.executable, "-m", "synth", "felt", "pulse", "--velocity", "3"],
                       capture_output=True, text=True, timeout=60, env=env)
    assert p.returncode == 2 and "--velocity is not an option" in p.stderr


def test_help_cites_only_shipped_guides(capsys):
    from synth.commands.help import CITED, topics

    texts = "\n".join(_help_texts())
    assert "docs/" not in texts                       # no path the wheel does not hold
    cited = set(re.findall(r"synth help ([a-z-]+)", texts))
    assert cited and cited <= set(CITED), cited - set(CITED)
    assert set(CITED) <= set(topics())
    rc, out, err = run(capsys, "help", "quality")
    assert rc == 0 and out.startswith("# Quality levels")
    rc, out, err = run(capsys, "help")
    assert rc == 0 and "quality" in out and "midi" in out
    rc, _, err = run(capsys, "help", "nope")
    one_line_error(rc, err, "TOPIC = 'nope' is not a guide (choices: ")


def test_the_wheel_build_ships_the_guides(tmp_path):
    """setup.py's build_py copies docs/*.md into the package (synth/docs):
    every guide the help cites is in what a wheel is made of."""
    from synth.commands.help import CITED

    p = subprocess.run([sys.executable, "setup.py", "-q", "build_py", "--build-lib",
                        str(tmp_path / "lib")], cwd=ROOT, capture_output=True, text=True,
                       timeout=120)
    assert p.returncode == 0, p.stderr
    shipped = tmp_path / "lib" / "synth" / "docs"
    for topic in CITED:
        assert (shipped / f"{topic}.md").read_text("utf-8") == \
            (ROOT / "docs" / f"{topic}.md").read_text("utf-8")
    assert (tmp_path / "lib" / "synth" / "__main__.py").is_file()
    assert (tmp_path / "lib" / "synth" / "presets" / "biwa.toml").is_file()
