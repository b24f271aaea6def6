"""tools/real_grand.py: the voicing report's measures on a folder of real
samples, run here (the tool as a program) on synthetic notes whose decay is
known in closed form; its sample names (synth.apps.grand_study.midi_of)."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf

from synth.apps.grand_study import midi_of

ROOT = Path(__file__).resolve().parents[1]


def _run(*argv):
    return subprocess.run([sys.executable, str(ROOT / "tools" / "real_grand.py"), *argv],
                          capture_output=True, text=True, cwd=ROOT, timeout=600)

FS = 48_000


def _note(f1_hz, seconds, early_t60_s, late_t60_s, knee_db, amp=0.5, fs=44_100):
    """Partials 1-3 of a note whose level falls with ``early_t60_s`` to
    ``knee_db`` and then with ``late_t60_s`` (a prompt sound and an
    aftersound: the sum of two decays), after a 2 ms onset ramp."""
    t = np.arange(int(seconds * fs)) / fs
    early = np.exp(-math_ln1000() * t / early_t60_s)
    late = 10 ** (knee_db / 20) * np.exp(-math_ln1000() * t / late_t60_s)
    env = (early + late) * np.minimum(t / 0.002, 1.0)
    y = sum(a * np.sin(2 * np.pi * n * f1_hz * t) for n, a in ((1, 1.0), (2, 0.5), (3, 0.25)))
    return amp * env * y / 1.75, fs


def math_ln1000():
    return np.log(1000.0)


def test_file_names_give_the_key_and_the_layer():
    assert midi_of("C4v10.ogg") == (60, 10)
    assert midi_of("D#1v4.ogg") == (27, 4)
    assert midi_of("A0v14.wav") == (21, 14)
    assert midi_of("C8v1.flac") == (108, 1)
    assert midi_of("notes.txt") is None and midi_of("Cb4v10.ogg") is None


@pytest.mark.slow  # over 2 s on a quiet 2-core machine: ~2.3 s of CPU
def test_the_measures_of_known_notes(tmp_path):
    """A note with a prompt sound (T60 2 s) falling to an aftersound 25 dB
    down (T60 20 s) reads a visible two-stage decay with late/early near 10;
    one straight decay shows no knee; the louder layer's loudness and the
    resampling from 44.1 kHz are taken into account."""
    layer = tmp_path / "piano-velocity10" / "audio"
    layer.mkdir(parents=True)
    y, fs = _note(261.63, 12.0, 2.0, 20.0, -25.0)
    sf.write(str(layer / "C4v10.ogg"), np.c_[y, y], fs)
    y, fs = _note(440.0, 12.0, 6.0, 6.0, -200.0)
    sf.write(str(layer / "A4v10.ogg"), np.c_[y, y], fs)
    soft = tmp_path / "piano-velocity4" / "audio"
    soft.mkdir(parents=True)
    y, fs = _note(261.63, 12.0, 2.0, 20.0, -25.0, amp=0.05)
    sf.write(str(soft / "C4v4.ogg"), np.c_[y, y], fs)
    out = tmp_path / "m.json"
    p = _run(str(tmp_path), "--json", str(out))
    assert p.returncode == 0, p.stderr
    text = p.stdout
    rows = {(r["key"], r["layer"]): r for r in json.loads(out.read_text())}
    c4 = rows[(60, 10)]
    assert c4["visible"] and 6.0 < c4["ratio"] < 14.0
    # the sum of the two decays bends before the knee, so the line through
    # the early frames is a little shallower than the prompt sound's own 2 s
    assert 2.0 <= c4["t60_early_s"] < 3.2
    # one straight decay: no knee a listener hears (the two-line fit may
    # still bend at the onset's first frames; the knee rule sees no drop)
    assert not rows[(69, 10)]["visible"]
    # the layers differ by 20 dB in level
    assert rows[(60, 10)]["loudness_lufs"] - rows[(60, 4)]["loudness_lufs"] == pytest.approx(20.0, abs=0.2)
    # C4's partials: 2 and 3 at -6 and -12 dB re partial 1
    p = rows[(60, 10)]["c4_partials_db"]
    assert p[0] == pytest.approx(0.0) and p[1] == pytest.approx(-6.0, abs=0.5)
    assert p[2] == pytest.approx(-12.0, abs=0.5)
    assert "C4: centroid of the first 100 ms v10 / v4" in text


@pytest.mark.slow  # over 2 s on a 2-core machine (2026-12-03: 3.2 s in the fast tier)
def test_an_empty_folder_is_a_one_line_error(tmp_path):
    p = _run(str(tmp_path))
    assert p.returncode == 2
    assert p.stderr.count("\n") == 1 and "no samples named like C4v10.ogg" in p.stderr
    p = _run(str(tmp_path / "missing"))
    assert p.returncode == 2 and "is not a folder" in p.stderr


def test_octaves_without_the_layer_is_a_one_line_error(tmp_path):
    layer = tmp_path / "piano-velocity4" / "audio"
    layer.mkdir(parents=True)
    y, fs = _note(261.63, 1.0, 2.0, 20.0, -25.0)
    sf.write(str(layer / "C4v4.ogg"), np.c_[y, y], fs)
    p = _run(str(tmp_path), "--octaves")
    assert p.returncode == 2 and p.stderr.count("\n") == 1
    assert "no samples of layer 10" in p.stderr


@pytest.mark.slow  # renders a 6 s grand note
def test_octaves_tables_the_grand_against_the_recording(tmp_path):
    """Issue 41's table (--octaves) from one recorded C4: a row for C4-B4,
    the JSON holding both sides' measures."""
    layer = tmp_path / "piano-velocity10" / "audio"
    layer.mkdir(parents=True)
    y, fs = _note(261.63, 6.0, 2.0, 20.0, -25.0)
    sf.write(str(layer / "C4v10.ogg"), np.c_[y, y], fs)
    out = tmp_path / "t.json"
    p = _run(str(tmp_path), "--octaves", "--positions", "body", "--json", str(out))
    assert p.returncode == 0, p.stderr
    assert "position: body" in p.stdout and "| C4-B4 |" in p.stdout
    data = json.loads(out.read_text())
    assert set(data) == {"real", "body", "layer", "velocity", "set"} and [r["octave"] for r in data["body"]["rows"]] == ["C4-B4"]
    # the synthetic note's partial 1 falls 60 dB in 2 s, then sits 25 dB down with a 20 s T60
    assert -40.0 < data["real"]["60"]["p1_3s_db"] < -25.0


@pytest.mark.slow  # over 2 s on a quiet 2-core machine: the tool in a subprocess, two renders
def test_attacks_draws_the_first_30_ms_with_and_without_the_spread(tmp_path):
    """``--attacks C7 --png``: a synthetic note (4 kHz: four cycles a
    frame, so a frame's RMS follows the envelope) whose onset ramps up
    over 5 ms reads as 1 ms frames rising to 1 within 8 ms; the
    grand's frames with and without the board's spread are printed and
    drawn (30 each, re their largest); without ``--png`` a one-line error."""
    pytest.importorskip("matplotlib")
    layer = tmp_path / "piano-velocity10" / "audio"
    layer.mkdir(parents=True)
    fs = 44_100
    t = np.arange(int(1.0 * fs)) / fs
    y = 0.3 * np.minimum(t / 0.005, 1.0) * np.exp(-t) * np.sin(2 * np.pi * 4000.0 * t)
    sf.write(str(layer / "C7v10.ogg"), np.c_[y, y], fs)
    p = _run(str(tmp_path), "--attacks", "C7")
    assert p.returncode == 2 and "--attacks needs --png" in p.stderr
    png = tmp_path / "a.png"
    p = _run(str(tmp_path), "--attacks", "C7", "--png", str(png))
    assert p.returncode == 0, p.stderr
    assert png.stat().st_size > 1000
    rows = {line.split(":")[0].split(None, 1)[1].strip(): [float(v) for v in line.split(":")[1].split()]
            for line in p.stdout.splitlines() if line.startswith("C7 ")}
    assert set(rows) == {"recording v10", "grand", "no spread"}
    assert all(len(r) == 30 and max(r) == 1.0 for r in rows.values())
    rec = rows["recording v10"]
    assert rec[0] < 0.3 and rec[0] < rec[2] < rec[4] and max(rec[:8]) > 0.95
    # the spread builds the grand's attack up; without it the first ms is near full
    assert rows["grand"][0] < 0.3 < rows["no spread"][0]
