"""Tests of the ``synth`` command line (synth/cli.py), in-process through
``synth.cli.main([...])`` and once through the installed console script.

Every user error must exit with status 2 and print exactly one line,
``synth: error: ...``, on stderr, never a traceback, and leave nothing
(neither the output file nor a temporary file) in the output directory.
"""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf

from synth.analysis import cents, estimate_f0
from synth.cli import main
from synth.physics.plucks import sitar_g

from helpers import shared_dir

# the checkout's presets (package data, shipped in the wheel)
REPO_PRESETS = Path(__file__).resolve().parents[1] / "synth" / "presets"
MIDI_DIR = shared_dir() / "midi"
SONG = MIDI_DIR / "HerGoldenHairWasCurlingDown.mid"
MALFORMED = sorted(p for p in (MIDI_DIR / "malformed").glob("*") if p.is_file()) \
    if (MIDI_DIR / "malformed").is_dir() else []

FS_OUT = 48_000
# paper/sitar-ideal: 812 cells, c = 320 m/s, L = 0.8 m -> 324.8 kHz; pluck at 3/4 -> cell 609
STUDY_FS = 324_800
STUDY_CELLS = 812
STUDY_K = 609
SITAR_A_M = 0.01
SITAR_T0_S = 0.004
STUDY_GAIN = 50.0


@pytest.fixture(autouse=True)
def _isolated(tmp_path, monkeypatch):
    """Run every test in its own directory with only the shipped presets."""
    monkeypatch.delenv("SYNTH_PRESET_PATH", raising=False)
    monkeypatch.chdir(tmp_path)


def run(capsys, *argv: str) -> tuple[int, str, str]:
    """main(argv) -> (exit status, stdout, stderr); stderr never holds a traceback."""
    rc = main([str(a) for a in argv])
    cap = capsys.readouterr()
    assert "Traceback" not in cap.err, cap.err
    return rc, cap.out, cap.err


def assert_user_error(rc: int, err: str, *fragments: str) -> str:
    """Status 2 and exactly one stderr line ``synth: error: ...`` containing `fragments`."""
    assert rc == 2, err
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("synth: error: "), err
    for f in fragments:
        assert f in lines[0], (f, lines[0])
    return lines[0]


def peak_dbfs(x: np.ndarray) -> float:
    return 20.0 * math.log10(float(np.max(np.abs(x))))


# --------------------------------------------------------------------------
# synth presets
# --------------------------------------------------------------------------


def test_presets_lists_every_preset_with_its_description(capsys):
    files = sorted(f for f in REPO_PRESETS.rglob("*.toml")
                   if f.relative_to(REPO_PRESETS).parts[0] not in ("checks", "batch"))   # specs, not presets
    assert files, "no presets shipped"
    expected = {f.relative_to(REPO_PRESETS).with_suffix("").as_posix():
                tomllib.loads(f.read_text("utf-8"))["description"] for f in files}
    rc, out, err = run(capsys, "presets")
    assert rc == 0 and err == ""
    lines = out.splitlines()
    assert len(lines) == len(files)
    listed = {}
    for line in lines:
        name, desc = line.split(None, 1)
        listed[name] = desc.strip()
    assert listed == expected
    assert "paper/sitar-ideal" in listed and "sitar" in listed and "biwa" in listed


def test_presets_with_none_found_is_an_error(capsys, tmp_path, monkeypatch):
    """An install without its package data must not list nothing and succeed:
    one error line naming every directory searched, status 2."""
    from synth.io.presets import loader

    shipped, extra = tmp_path / "site-packages" / "synth" / "presets", tmp_path / "mine"
    shipped.mkdir(parents=True)
    extra.mkdir()
    monkeypatch.setattr(loader, "shipped_preset_dir", lambda: shipped)
    rc, out, err = run(capsys, "presets")
    assert out == ""
    assert_user_error(rc, err, "no presets found", str(shipped), "SYNTH_PRESET_PATH")
    monkeypatch.setenv("SYNTH_PRESET_PATH", str(extra))
    rc, out, err = run(capsys, "presets")
    assert out == ""
    assert_user_error(rc, err, "no presets found", f"{extra}, {shipped}")
    # ... and the demo says where it looked, too
    rc, out, err = run(capsys, "demo", "-o", str(tmp_path / "demo.wav"))
    assert_user_error(rc, err, "unknown preset", str(shipped))
    assert not (tmp_path / "demo.wav").exists()


# --------------------------------------------------------------------------
# synth note
# --------------------------------------------------------------------------


def test_note_study_preset_writes_wav_and_probe_of_the_pluck(capsys):
    rc, out, err = run(capsys, "note", "paper/sitar-ideal", "--seconds", "0.2",
                       "--probe", "p.npy", "-o", "s.wav")
    assert rc == 0, err
    assert "s.wav" in out and "p.npy" in out
    info = sf.info("s.wav")
    assert (info.samplerate, info.channels, info.subtype) == (FS_OUT, 1, "FLOAT")
    assert info.frames == round(0.2 * FS_OUT)

    u = np.load("p.npy")
    assert u.dtype == np.float64 and u.shape == (round(0.2 * STUDY_FS),)
    # Until the wave reflected at x = L comes back (2 (N - k) samples), u(l, t)
    # is the outgoing pluck g(t) of eq. 1.13 itself.
    n_refl = 2 * (STUDY_CELLS - STUDY_K)
    g = sitar_g(np.arange(n_refl + 200) / STUDY_FS, SITAR_A_M, SITAR_T0_S)
    np.testing.assert_allclose(u[:n_refl], g[:n_refl], rtol=0, atol=1e-9 * SITAR_A_M)
    # ... and not after: the inverted reflection pulls u away from g (by ~ 1.3 mm here)
    assert np.max(np.abs(u[n_refl:n_refl + 200] - g[n_refl:])) > 0.05 * SITAR_A_M
    # The WAV is u times output.gain at 48 kHz: same peak within 0.5 dB.
    audio, fs = sf.read("s.wav", dtype="float64")
    assert fs == FS_OUT
    assert abs(peak_dbfs(audio) - peak_dbfs(STUDY_GAIN * u)) < 0.5


def test_note_pcm24(capsys):
    rc, _, err = run(capsys, "note", "paper/sitar-ideal", "--seconds", "0.05", "--pcm24",
                     "-o", "s24.wav")
    assert rc == 0, err
    info = sf.info("s24.wav")
    assert (info.samplerate, info.subtype, info.frames) == (FS_OUT, "PCM_24", round(0.05 * FS_OUT))


def test_note_musical_preset_with_key(capsys):
    # 1 s: over a shorter window the body's own modes, rung by the pluck,
    # pull a one-peak estimate (a sitar C4 read +1.4 cents over 0.05-0.3 s)
    rc, out, err = run(capsys, "note", "sitar", "--key", "60", "--seconds", "1", "-o", "x.wav")
    assert rc == 0, err
    assert "x.wav" in out
    audio, fs = sf.read("x.wav", dtype="float64")
    assert fs == FS_OUT and audio.shape == (FS_OUT,)
    assert np.all(np.isfinite(audio)) and -40.0 < peak_dbfs(audio) < 0.0
    f_c4 = 440.0 * 2 ** ((60 - 69) / 12)
    f0 = estimate_f0(audio[FS_OUT // 20:], FS_OUT, f_c4)
    assert abs(cents(f0, f_c4)) < 1.0


def test_set_override_changes_the_render(capsys):
    # a bare ".005"-style decimal is accepted; the probe follows the new amplitude
    rc, _, err = run(capsys, "note", "paper/sitar-ideal", "--seconds", "0.02",
                     "--set", "pluck.amplitude_m=.005", "--probe", "p.npy", "-o", "s.wav")
    assert rc == 0, err
    n = 2 * (STUDY_CELLS - STUDY_K)
    u = np.load("p.npy")[:n]
    np.testing.assert_allclose(u, sitar_g(np.arange(n) / STUDY_FS, 0.005, SITAR_T0_S),
                               rtol=0, atol=1e-9 * SITAR_A_M)


def test_set_profile_none_on_a_jawari_preset_is_the_ideal_string(capsys):
    rc, _, err = run(capsys, "note", "paper/sitar-ideal", "--seconds", "0.05",
                     "--probe", "ideal.npy", "-o", "ideal.wav")
    assert rc == 0, err
    rc, _, err = run(capsys, "note", "paper/sitar-case1", "--seconds", "0.05",
                     "--set", "termination.profile=none", "--probe", "none.npy", "-o", "none.wav")
    assert rc == 0, err
    ideal, none = np.load("ideal.npy"), np.load("none.npy")
    assert ideal.shape == none.shape
    assert np.max(np.abs(none - ideal)) <= 1e-9 * SITAR_A_M
    # ... whereas the jawari itself makes a difference within 50 ms
    rc, _, err = run(capsys, "note", "paper/sitar-case1", "--seconds", "0.05",
                     "--probe", "case1.npy", "-o", "case1.wav")
    assert rc == 0, err
    assert np.max(np.abs(np.load("case1.npy") - ideal)) > 0.01 * SITAR_A_M
    # capo from the jawari preset: side/region_points of the file kept, jawari keys dropped
    rc, _, err = run(capsys, "note", "paper/sitar-case1", "--seconds", "0.02",
                     "--set", "termination.profile=capo", "--set", "termination.radius_m=0.015",
                     "-o", "capo.wav")
    assert rc == 0, err
    assert sf.info("capo.wav").frames == round(0.02 * FS_OUT)


@pytest.mark.parametrize("preset,sets,fragments", [
    ("paper/sitar-ideal", ["pluck.position=1.5"], ["pluck.position = 1.5 (from --set)", "0 < value < 1"]),
    ("paper/sitar-ideal", ["pluck.positon=0.5"], ["unknown key 'pluck.positon'"]),
    ("paper/sitar-ideal", ["pluck.position"], ["pluck.position", "PATH=VALUE"]),
    ("paper/sitar-ideal", ["grid.cells=5."], ["grid.cells = 5.0 (from --set)", "wrong type"]),
    ("paper/sitar-case1", ["termination.profile=capo"], ["missing key 'termination.radius_m'"]),
    ("paper/sitar-case1", ["termination.profile=none", "termination.slope=0.01"],
     ["'termination.slope' (from --set) is not allowed"]),
])
def test_bad_set_exits_2_with_one_line(capsys, preset, sets, fragments):
    argv = ["note", preset, "--seconds", "0.05", "-o", "bad.wav"]
    for s in sets:
        argv += ["--set", s]
    rc, out, err = run(capsys, *argv)
    assert_user_error(rc, err, *fragments)
    assert os.listdir(".") == []


def test_musical_preset_needs_a_key(capsys):
    rc, _, err = run(capsys, "note", "sitar", "--seconds", "0.1", "-o", "x.wav")
    assert_user_error(rc, err, "sitar", "--key")
    assert os.listdir(".") == []


@pytest.mark.parametrize("key,fragments", [
    ("100", ["--key = 100", "sitar", "43 <= key <= 74"]),
    ("42", ["--key = 42", "43 <= key <= 74"]),
    ("200", ["--key = 200", "0 <= value <= 127"]),
])
def test_key_outside_the_preset_range(capsys, key, fragments):
    rc, _, err = run(capsys, "note", "sitar", "--key", key, "--seconds", "0.1", "-o", "x.wav")
    assert_user_error(rc, err, *fragments)
    assert os.listdir(".") == []


@pytest.mark.parametrize("preset,key,opt", [
    ("harpsichord", "60", ["--hammer-log", "strike.csv"]),
    ("harpsichord", "60", ["--hammer-speed", "3"]),
    ("sitar", "57", ["--hammer-log", "strike.csv"]),
    ("paper/biwa-ideal", None, ["--hammer-speed", "3"]),
])
def test_hammer_options_on_a_plucked_voice_fail_before_rendering(capsys, preset, key, opt):
    """The voice says whether a hammer strikes its notes (``Voice.struck``),
    not the preset's ``voice`` name: the harpsichord (voice "harpsichord")
    is plucked too, and used to write its WAV and then fail with "the
    hammer never touched the string"."""
    argv = ["note", preset, *(["--key", key] if key else []), "--seconds", "0.1", *opt,
            "-o", "x.wav"]
    rc, _, err = run(capsys, *argv)
    assert_user_error(rc, err, opt[0], preset, "no hammer")
    assert os.listdir(".") == []


def test_struck_voices_say_so():
    from synth.io.factory import build_voice

    assert build_voice("grand-piano", []).struck
    assert build_voice("hammered-sitar", []).struck
    assert build_voice("paper/piano-a7-ideal", []).struck
    assert not build_voice("harpsichord", []).struck
    assert not build_voice("sitar", []).struck
    assert not build_voice("biwa", []).struck


def test_unknown_preset_suggests_a_name(capsys):
    rc, _, err = run(capsys, "note", "sitr", "--key", "60", "--seconds", "0.1", "-o", "x.wav")
    assert_user_error(rc, err, "unknown preset 'sitr'", "did you mean 'sitar'")
    assert os.listdir(".") == []


@pytest.mark.parametrize("argv", [
    ["note", "paper/sitar-ideal", "--seconds", "0.05"],
    ["render", str(SONG), "--preset", "biwa"],
])
def test_output_in_a_missing_directory(capsys, argv):
    rc, _, err = run(capsys, *argv, "-o", "nope/out.wav")
    assert_user_error(rc, err, "nope")
    assert os.listdir(".") == []


# --------------------------------------------------------------------------
# synth render
# --------------------------------------------------------------------------


@pytest.mark.skipif(not SONG.is_file(), reason="shared MIDI files not available")
@pytest.mark.slow  # over 2 s on a quiet 2-core machine
def test_render_a_midi_file(capsys):
    rc, out, err = run(capsys, "render", SONG, "--preset", "biwa", "-o", "out.wav")
    assert rc == 0, err
    assert "out.wav" in out and "220 notes" in out
    info = sf.info("out.wav")
    assert info.samplerate == FS_OUT and info.subtype == "FLOAT"
    # the last event is at 57.0 s; the release tails end well before 30 s later
    assert 57.0 < info.frames / FS_OUT < 87.0
    audio, _ = sf.read("out.wav", dtype="float64")
    assert np.all(np.isfinite(audio)) and -40.0 < peak_dbfs(audio) < 0.0
    assert os.listdir(".") == ["out.wav"]


# What `synth render FILE --preset sitar` does with each file of
# shared/midi/malformed: ("error", a distinctive part of its one-line
# message) or ("renders", None). A file not listed here fails the test until
# its outcome is stated.
MALFORMED_EXPECTED = {
    "Beethoven.rmi": ("renders", None),  # RIFF RMID wrapper around an SMF (380 s)
    "PiDamaged.mid": ("error", "truncated: track 3 of 30 declares 1194067 bytes but only 65461 remain"),
    "midiasm_reference.mid": ("error", "track 2 of 2: invalid event data (data byte must be in range 0..127)"),
    "negative_delta.mid": ("error", "implausible length 22369622.6 s"),
    "notes-with-missing-note-offs.mid": ("renders", None),  # the unreleased notes ring out
    "test-2-tracks-type-2.mid": ("error", "SMF format 2 (independent sequence patterns) is not supported"),
    "test-corrupt-file-missing-byte.mid": ("error", "truncated: track 1 of 1 declares 246 bytes but only 245 remain"),
    "test-illegal-message-all.mid": ("error", "track 1 of 1: invalid event data (undefined status byte 0xf4)"),
    "test-non-midi-track.mid": ("renders", None),  # an unknown chunk before the track is skipped
    "test-running-status-sysex.mid": ("error", "track 1 of 1: event data runs past the end of the track"),
}
#: long files: only their first seconds are rendered (the whole file is still read)
MALFORMED_RENDER_S = {"Beethoven.rmi": 4.0}


@pytest.mark.skipif(not MALFORMED, reason="shared MIDI files not available")
def test_malformed_table_names_only_existing_files():
    assert sorted(MALFORMED_EXPECTED) == [p.name for p in MALFORMED]


@pytest.mark.parametrize("path", MALFORMED, ids=[p.name for p in MALFORMED])
@pytest.mark.slow  # over 2 s on a quiet 2-core machine
def test_render_malformed_file_renders_or_fails_cleanly(capsys, monkeypatch, tmp_path, path):
    assert path.name in MALFORMED_EXPECTED, (
        f"{path.name}: state in MALFORMED_EXPECTED whether it renders or is rejected (and how)")
    outcome, fragment = MALFORMED_EXPECTED[path.name]
    limit = MALFORMED_RENDER_S.get(path.name)
    if limit is not None:
        import synth.io.midi

        read = synth.io.midi.read_midi_file
        seen = []

        def first_seconds(p, dropped=None):
            ev = read(p, dropped=dropped)
            first = [e for e in ev if e.time_s < limit]
            seen.append((sum(1 for e in ev if e.kind == "note_on"),
                         sum(1 for e in first if e.kind == "note_on")))
            return first

        monkeypatch.setattr(synth.io.midi, "read_midi_file", first_seconds)
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    rc, out, err = run(capsys, "render", path, "--preset", "sitar", "-o", out_dir / "song.wav")
    if outcome == "error":
        assert_user_error(rc, err, path.name, fragment)
        assert os.listdir(out_dir) == []
        return
    assert rc == 0, err
    assert os.listdir(out_dir) == ["song.wav"]
    # notes on what was not played, and the one over-full-scale warning a
    # loud file may earn (the sitar reaches +4 dBFS on piano files)
    assert all(line.startswith("note: ") or (line.startswith("warning: ") and "over full scale" in line)
               for line in err.splitlines()), err
    info = sf.info(str(out_dir / "song.wav"))
    assert info.samplerate == FS_OUT and info.frames > 0
    audio, _ = sf.read(str(out_dir / "song.wav"), dtype="float64")
    assert np.all(np.isfinite(audio)) and np.max(np.abs(audio)) > 0
    if limit is not None:
        # the whole file was read and the notes of its first seconds played
        (n_all, n_first), = seen
        assert n_all > 1000 and n_first > 0, seen
        assert "song.wav: " in out and f" {n_first} notes on sitar" in out, out
        assert limit < info.frames / FS_OUT < limit + 31.0


# --------------------------------------------------------------------------
# The installed console script
# --------------------------------------------------------------------------


def _console_script() -> str:
    exe = Path(sys.executable).with_name("synth")
    if exe.is_file():
        return str(exe)
    found = shutil.which("synth")
    if found is None:  # pragma: no cover - the package is pip-installed in the venv
        pytest.fail("the console script 'synth' is not installed")
    return found


def test_console_script(tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "SYNTH_PRESET_PATH"}
    exe = _console_script()
    p = subprocess.run([exe, "note", "sitar", "--key", "60", "--seconds", "0.3", "-o", "x.wav"],
                       cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    assert "Traceback" not in p.stderr
    info = sf.info(str(tmp_path / "x.wav"))
    assert (info.samplerate, info.frames) == (FS_OUT, round(0.3 * FS_OUT))
    # the exit status of a user error reaches the shell
    p = subprocess.run([exe, "note", "sitr", "--key", "60", "-o", "y.wav"],
                       cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)
    assert_user_error(p.returncode, p.stderr, "unknown preset 'sitr'")
    assert not (tmp_path / "y.wav").exists()


def test_the_command_freezes_what_is_left_for_a_quick_exit_and_an_in_process_call_does_not():
    """Run as the process's command (argv None), main() freezes the objects
    left (gc.freeze: the shutdown then skips the cycle walk over numba's
    objects, about 0.15 s of a warm note); called with argv, as tests and
    scripts do, it leaves the collector as it was."""
    import gc

    from synth.cli import main

    before = gc.get_freeze_count()
    assert main(["presets"]) == 0
    assert gc.get_freeze_count() == before
    code = ("import gc, sys; sys.argv = ['synth', 'presets']; from synth.cli import main; "
            "n = main(); print('frozen', gc.get_freeze_count(), 'status', n)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120, check=True).stdout
    last = out.strip().splitlines()[-1].split()
    assert last[0] == "frozen" and int(last[1]) > 1000 and last[3] == "0", out
    # an error exit (argparse's SystemExit) freezes too, and keeps its status
    code = ("import gc, sys; sys.argv = ['synth', 'presets', '--no-such-option']\n"
            "from synth.cli import main\n"
            "try:\n    main()\nexcept SystemExit as e:\n"
            "    print('frozen', gc.get_freeze_count(), 'status', e.code)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert "status 2" in r.stdout and int(r.stdout.split()[1]) > 1000, (r.stdout, r.stderr)
