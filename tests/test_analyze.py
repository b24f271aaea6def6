"""synth analyze: the report against signals whose answer is known, and the CLI."""

import json
import subprocess
import sys

import numpy as np
import pytest
import soundfile as sf

from helpers import cli
from synth.analysis import two_stage_decay
from synth.apps.analyze import analyze_audio, format_report

FS = 48_000


def _stiff(f0=220.0, B=1e-3, n=10, seconds=2.0, t60=(3.0, 1.0)):
    """Partials n f0 sqrt(1 + B n^2), levels -3 dB per partial, T60 from
    t60[0] (partial 1) falling linearly to t60[1] (partial n)."""
    t = np.arange(int(seconds * FS)) / FS
    x = np.zeros_like(t)
    for k in range(1, n + 1):
        T = t60[0] + (t60[1] - t60[0]) * (k - 1) / (n - 1)
        a = 0.1 * 10 ** (-3 * (k - 1) / 20)
        x += a * np.exp(-np.log(1000) * t / T) * np.sin(2 * np.pi * k * f0 * np.sqrt(1 + B * k * k) * t)
    return np.concatenate([np.zeros(480), x])


def test_two_stage_decay_finds_the_knee_and_both_slopes():
    t = np.arange(4 * FS) / FS
    lvl = np.where(t < 0.5, -60 * t / 1.0, -30 - 60 * (t - 0.5) / 6.0)
    d = two_stage_decay(10 ** (lvl / 20) * np.sin(2 * np.pi * 200 * t), FS, f_hz=200.0)
    assert d["t60_early_s"] == pytest.approx(1.0, rel=0.02)
    assert d["t60_late_s"] == pytest.approx(6.0, rel=0.02)
    assert d["knee_s"] == pytest.approx(0.5, abs=0.02)
    assert 1.0 < d["t60_s"] < 6.0


@pytest.mark.slow  # over 2 s on a quiet 2-core machine: ~5 s of CPU, two analyses of a 2 s tone
def test_the_report_of_a_stiff_string_tone():
    r = analyze_audio(_stiff(), FS, f0_hz=220.0 * np.sqrt(1.001), n_partials=10)
    assert r["schema"] == 2 and r["onset_s"] == pytest.approx(0.01, abs=1e-4)
    assert r["inharmonicity_b"] == pytest.approx(1e-3, rel=0.01)
    assert r["f0_fit_hz"] == pytest.approx(220.0, rel=1e-5)
    p = r["partials"]
    assert [q["n"] for q in p] == list(range(1, 11))
    for k, q in enumerate(p, start=1):
        assert abs(q["cents_stiff"]) < 0.05
        T = 3.0 + (1.0 - 3.0) * (k - 1) / 9
        assert q["t60_s"] == pytest.approx(T, rel=0.05)
    # levels: with one T60 for all partials they read exactly -3 dB apart
    flat = analyze_audio(_stiff(t60=(2.0, 2.0)), FS, n_partials=10)["partials"]
    for k, q in enumerate(flat, start=1):
        assert q["level_db"] == pytest.approx(-3.0 * (k - 1), abs=0.1)
    # partial 10 of a stiff string is sharp of 10 x partial 1 (the harmonic)
    assert p[9]["cents_harmonic"] > 50
    lo = r["loudness"]
    assert lo["peak_dbfs"] < 0 and lo["integrated_lufs"] < lo["max_momentary_lufs"] + 1e-9
    text = format_report(r, "tone")
    assert text.splitlines()[0] == "tone" and "B = 0.001" in text
    json.dumps(r)                                    # JSON-able as documented


def _cli(*args):
    """``synth analyze ARGS`` as a program: a fresh interpreter, its exit
    status and streams (the command's contract; a cold start costs 1-2 s
    of imports, so most tests call :func:`_run` instead)."""
    return subprocess.run([sys.executable, "-m", "synth.cli", "analyze", *map(str, args)],
                          capture_output=True, text=True)


def _run(capsys, *args):
    """``synth analyze ARGS`` through :func:`synth.cli.main` in this process:
    the same parsing, errors and exit status as the program, without a cold
    start.  Returns what :func:`_cli` does (returncode, stdout, stderr)."""
    return cli(capsys, "analyze", *args)


@pytest.mark.slow  # over 2 s on a quiet 2-core machine: ~9 s of CPU, the program with its plot and an analysis
def test_cli_on_a_wav_file_table_json_and_plot(tmp_path, capsys):
    pytest.importorskip("matplotlib", reason="--plot needs the [plots] extra")
    wav = tmp_path / "tone.wav"
    sf.write(wav, np.column_stack([_stiff(), _stiff()]).astype(np.float32), FS, subtype="FLOAT")
    r = _cli(wav, "--f0", 220.11, "--partials", 6, "--plot", tmp_path / "a.png")
    assert r.returncode == 0, r.stderr
    assert "2 channels; analysing their mean" in r.stderr
    assert "n  freq Hz  level dB" in r.stdout and (tmp_path / "a.png").read_bytes()[:4] == b"\x89PNG"
    r = _run(capsys, wav, "--json")
    assert r.returncode == 0, r.stderr
    j = json.loads(r.stdout)
    assert j["schema"] == 2 and len(j["partials"]) == 12
    # found without a hint, and partials 11-12 (none there) do not spoil the fit
    assert j["partials"][0]["freq_hz"] == pytest.approx(220 * np.sqrt(1.001), abs=0.01)
    assert j["inharmonicity_b"] == pytest.approx(1e-3, rel=0.01)


@pytest.mark.slow  # over 2 s on a quiet 2-core machine: ~4 s of CPU, 2 s of the grand and its analysis
def test_cli_renders_a_preset_note_and_measures_the_piano_string(capsys):
    """C4 on the grand: partial 1 is the voice's tuning; the fitted B is the
    string's (synth.physics.piano: 3.16e-4; measured 3.07e-4, the dispersion
    allpasses fit the law over the lowest partials only: within 10 %)."""
    from synth.physics import piano as P

    r = _run(capsys, "grand-piano", "--key", 60, "--seconds", 2, "--json")
    assert r.returncode == 0, r.stderr
    j = json.loads(r.stdout)
    assert abs(1200 * np.log2(j["partial1_hz"] / j["expected_hz"])) < 0.1
    assert j["inharmonicity_b"] == pytest.approx(P.grand_string(60).inharmonicity_b, rel=0.1)


@pytest.mark.parametrize("args, fragment", [
    (["nothere.wav"], "nothere.wav: no such audio file"),
    (["grand-piano", "--key", "60", "--f0", "200"], "--key and --f0 are exclusive"),
    (["grand-piano"], "grand-piano is a musical preset: give --key or --f0"),
    (["grand-piano", "--key", "60", "--plot", "/no/such/dir/a.png"], "directory /no/such/dir does not exist"),
    (["grand-piano", "--key", "60", "--partials", "0"], "--partials = 0 is out of range"),
])
def test_bad_input_is_one_line_exit_2(args, fragment, capsys):
    r = _run(capsys, *args)
    assert r.returncode == 2 and r.stderr.startswith("synth: error: ") and fragment in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1


def test_a_file_that_is_not_audio(tmp_path):
    p = tmp_path / "fake.wav"
    p.write_text("not audio")
    r = _cli(p)                  # the program: exit 2, one line on stderr
    assert r.returncode == 2 and f"not a WAV file: {p}" in r.stderr
    assert r.stderr.startswith("synth: error: ") and len(r.stderr.strip().splitlines()) == 1


def test_contacts_are_summarised_per_string_and_over_time(capsys):
    """The sitar of Publication II Case 2 keeps touching its jawari; C4 of the
    grand has three strings and its second polarization, struck by the
    hammer, and no capo bar."""
    j = json.loads(_run(capsys, "paper/sitar-case2", "--seconds", 0.3, "--partials", 3, "--contacts",
                        "--json").stdout)
    (c,) = j["contacts"]
    assert c["termination"]["episodes"] > 10 and c["termination"]["max_points"] > 0
    assert c["hammer"]["episodes"] == 0
    assert len(c["frames"]["time_s"]) == 30 and max(c["frames"]["termination_contact_share"]) > 0
    r = _run(capsys, "grand-piano", "--key", 60, "--seconds", 0.5, "--partials", 3, "--contacts")
    lines = [ln for ln in r.stdout.splitlines() if ln.startswith("contacts, string")]
    assert len(lines) == 4 and all("termination 0.00 ms" in ln and "peak" in ln for ln in lines)
    r = _run(capsys, "x.wav", "--contacts")
    assert r.returncode == 2
