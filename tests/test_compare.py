"""``synth compare`` (synth/apps/compare.py, the page in synth/apps/compare_page.py).

Python side: stimulus syntax, loudness matching (BS.1770 through
synth.analysis.loudness, measured again on the files written), the MUSHRA
anchor's spectrum, the page being self-contained, one-line errors with
nothing left behind, the exact binomial p-value against scipy, the
``--serve`` server.  Browser side: the page in a real headless Chromium
through Selenium and /usr/bin/chromedriver (skipped, saying why, when they
are missing): no console error, every buffer decoded sample-exact, A/B
switching at the same playhead, the loop, a scripted ABX session replayed
from ``?seed=``, MUSHRA, the CSV (on the page, downloaded, and POSTed to the
server).  Notes are 1 s long to keep it quick.
"""

from __future__ import annotations

import base64
import csv
import io
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf

from synth.analysis import loudness
from synth.apps import compare
from synth.apps.compare import (
    ANSWER_COLUMNS,
    CompareRequest,
    binomial_p_value,
    lowpass_anchor,
    make_comparison,
    make_server,
    match_loudness,
    parse_stimulus,
)
from synth.cli import main
from synth.io.errors import SynthError

ROOT = Path(__file__).resolve().parents[1]
FS = 48_000
STIM3 = ("grand-piano", "grand-piano:strings.t60_scale=0.5,tuning.stretch=0", "harpsichord")
CHROMIUM = Path("/usr/bin/chromium")
CHROMEDRIVER = Path("/usr/bin/chromedriver")


# ---------------------------------------------------------------------------
# fixtures: two comparisons, built once
# ---------------------------------------------------------------------------

@pytest.fixture(scope="module")
def cmp3(tmp_path_factory):
    """Three presets, one 1 s note (key 60): A/B, ABX and MUSHRA with the anchor."""
    out = tmp_path_factory.mktemp("cmp3") / "cmp"
    lines = []
    make_comparison(CompareRequest(STIM3, str(out), key=60, velocity=100, seconds=1.0),
                    log=lines.append)
    return out, lines


def _tone(f, seconds, fs, amp, decay=3.0):
    t = np.arange(int(seconds * fs)) / fs
    return amp * np.exp(-decay * t) * (np.sin(2 * np.pi * f * t) + 0.3 * np.sin(2 * np.pi * 3 * f * t))


@pytest.fixture(scope="module")
def cmp2(tmp_path_factory):
    """Two WAV files: a mono 48 kHz tone, and a louder stereo 44.1 kHz one, 0.3 s longer."""
    d = tmp_path_factory.mktemp("cmp2")
    sf.write(d / "one.wav", _tone(220, 1.0, FS, 0.1), FS, subtype="FLOAT")
    st = _tone(220 * 2 ** (1 / 12), 1.3, 44_100, 0.5)
    sf.write(d / "two.wav", np.stack([st, 0.8 * st], axis=1), 44_100, subtype="PCM_16")
    out = d / "cmp"
    lines = []
    make_comparison(CompareRequest((str(d / "one.wav"), str(d / "two.wav")), str(out), key=57,
                                   trials=4), log=lines.append)
    return out, lines


def _data(out: Path) -> dict:
    return json.loads((out / "compare.json").read_text())


def _ids(out: Path) -> list[str]:
    d = _data(out)
    return d["stimuli"] + ([d["anchor"]] if d["anchor"] else [])


# ---------------------------------------------------------------------------
# stimuli
# ---------------------------------------------------------------------------

def test_stimulus_syntax():
    s = parse_stimulus("grand-piano")
    assert (s.kind, s.source, s.overrides) == ("preset", "grand-piano", ())
    s = parse_stimulus("grand-piano:strings.t60_scale=2,tuning.stretch=0")
    assert (s.kind, s.source, s.overrides) == ("preset", "grand-piano",
                                               ("strings.t60_scale=2", "tuning.stretch=0"))
    s = parse_stimulus("sitar:termination.points=[[0, 0], [0.01, 1e-4]], pluck.position=0.7")
    assert s.overrides == ("termination.points=[[0, 0], [0.01, 1e-4]]", "pluck.position=0.7")
    s = parse_stimulus("paper/sitar-case1:termination.profile=\"jawari-case3\"")
    assert (s.source, s.overrides) == ("paper/sitar-case1", ('termination.profile="jawari-case3"',))
    assert parse_stimulus("takes/Take 1.WAV").kind == "wav"
    assert parse_stimulus("my.toml").source == "my.toml"


@pytest.mark.parametrize("text, fragment", [
    ("", "give a preset name"),
    (":strings.t60_scale=2", "no preset name"),
    ("grand-piano:", "nothing after ':'"),
    ("grand-piano:strings.t60_scale=2,,tuning.stretch=0", "an empty override"),
    ("grand-piano:strings.t60_scale=2,", "an empty override"),
    ("grand-piano:strings.nope=1", "unknown key 'strings.nope'"),
    ("grand-piano:t60", "expected PATH=VALUE"),
])
def test_stimulus_syntax_errors(text, fragment):
    with pytest.raises(SynthError) as e:
        parse_stimulus(text)
    msg = str(e.value)
    assert fragment in msg and "\n" not in msg and repr(text) in msg


def test_help_documents_the_syntax(capsys):
    with pytest.raises(SystemExit):
        main(["compare", "--help"])
    out = capsys.readouterr().out
    assert "grand-piano:strings.t60_scale=2,tuning.stretch=0" in out and ".wav" in out


# ---------------------------------------------------------------------------
# statistics
# ---------------------------------------------------------------------------

def test_binomial_p_value_equals_scipy():
    from scipy.stats import binomtest

    for n in range(1, 41):
        for k in range(0, n + 1):
            ref = binomtest(k, n, 0.5, alternative="greater").pvalue
            assert binomial_p_value(k, n) == pytest.approx(ref, rel=1e-12, abs=0), (k, n)
    for k in (500, 530, 560, 600, 700):
        ref = binomtest(k, 1000, 0.5, alternative="greater").pvalue
        assert binomial_p_value(k, 1000) == pytest.approx(ref, rel=1e-9, abs=0)
    assert binomial_p_value(8, 10) == 56 / 1024
    assert binomial_p_value(11, 10) == 0.0


# ---------------------------------------------------------------------------
# loudness, peaks, the anchor
# ---------------------------------------------------------------------------

@pytest.mark.parametrize("which", ["cmp3", "cmp2"])
@pytest.mark.slow  # over 2 s on a quiet 2-core machine
def test_written_files_match_in_loudness_and_do_not_clip(which, request):
    out, _ = request.getfixturevalue(which)
    data = _data(out)
    levels = {}
    for i in _ids(out):
        x, fs = sf.read(out / f"{i}.wav", dtype="float64")
        info = sf.info(out / f"{i}.wav")
        assert (fs, info.subtype, x.ndim) == (FS, "FLOAT", 1)
        assert len(x) == data["samples"]
        ld = loudness(x, fs)
        levels[i] = ld["integrated_lufs"]
        assert ld["peak_dbfs"] <= -1.0, (i, ld["peak_dbfs"])
    spread = max(levels.values()) - min(levels.values())
    assert spread <= 0.1, levels           # the promise
    assert spread <= 0.011, levels         # what make_comparison iterates to
    assert min(levels.values()) == pytest.approx(data["level_lufs"], abs=0.011)


def test_matching_lowers_every_gain_when_one_would_clip():
    fs = FS
    t = np.arange(fs) / fs
    smooth = 0.3 * np.sin(2 * np.pi * 440 * t)                  # crest 3 dB
    spiky = 0.01 * np.sin(2 * np.pi * 440 * t)
    spiky[::4800] = 0.9                                          # crest ~39 dB, quieter
    raw = [loudness(x, fs)["integrated_lufs"] for x in (smooth, spiky)]
    scaled, m = match_loudness([smooth, spiky], fs, target_lufs=-10.0)
    assert m.limited_db > 0 and m.level_lufs < -10.0
    # every gain lowered by the same amount: the gains' difference is the loudness difference
    assert m.gains_db[1] - m.gains_db[0] == pytest.approx(raw[0] - raw[1], abs=0.02)
    got = [loudness(y.astype(np.float64), fs) for y in scaled]
    assert max(g["peak_dbfs"] for g in got) <= -1.0
    assert max(g["peak_dbfs"] for g in got) == pytest.approx(-1.0, abs=0.01)   # no more than needed
    assert abs(got[0]["integrated_lufs"] - got[1]["integrated_lufs"]) <= 0.011
    # no target: the quietest's level, nothing limited here
    _, m = match_loudness([smooth, 0.5 * smooth], fs)
    assert m.limited_db == 0 and m.level_lufs == pytest.approx(raw[0] - 20 * math.log10(2), abs=0.01)


def test_silent_or_short_signals_cannot_be_matched():
    with pytest.raises(SynthError, match="silent"):
        match_loudness([np.ones(FS) * 0.1, np.zeros(FS)], FS, names=["a", "b"])
    with pytest.raises(SynthError, match="shorter than one 400 ms"):
        match_loudness([np.ones(FS) * 0.1, np.ones(100)], FS)


@pytest.mark.slow  # its fixture renders three presets: 9 s
def test_anchor_is_the_reference_low_passed_at_3_5_khz(cmp3):
    out, _ = cmp3
    ref, _ = sf.read(out / "A.wav", dtype="float64")
    anc, _ = sf.read(out / "anchor.wav", dtype="float64")
    w = np.hanning(len(ref))
    f = np.fft.rfftfreq(len(ref), 1 / FS)
    p_ref = np.abs(np.fft.rfft(ref * w)) ** 2
    p_anc = np.abs(np.fft.rfft(anc * w)) ** 2
    hi = f > 3500.0
    lo = (f > 50.0) & (f < 3000.0)
    band_db = 10 * np.log10(p_anc[hi].sum() / p_ref[hi].sum())
    assert band_db <= -40.0, band_db
    # bin by bin too, wherever the reference has anything to remove
    live = hi & (p_ref > p_ref.max() * 1e-12)
    assert np.max(10 * np.log10(p_anc[live] / p_ref[live])) <= -40.0
    # the passband is the reference's (only the matching gain differs)
    assert 10 * np.log10(p_anc[lo].sum() / p_ref[lo].sum()) == pytest.approx(
        data_gain_difference(out), abs=0.2)
    # the filter itself, from its impulse response (which dies out within the 2 s, so the
    # FFT has no leakage): |H|^2 of the forward-backward elliptic filter
    imp = np.zeros(2 * FS)
    imp[FS] = 1.0
    h_db = 20 * np.log10(np.abs(np.fft.rfft(lowpass_anchor(imp, FS))) + 1e-300)
    fn = np.fft.rfftfreq(len(imp), 1 / FS)
    assert np.max(h_db[fn >= 3500.0]) < -110.0
    assert np.all(np.abs(h_db[fn <= 3390.0]) < 0.11)
    f_3db = fn[np.argmax((fn > 3000.0) & (h_db < -3.0))]
    assert 3400.0 < f_3db < 3450.0, f_3db


def data_gain_difference(out: Path) -> float:
    gains = {r["id"]: r["gain_db"] for r in _data(out)["reveal"]}
    return gains["anchor"] - gains["A"]


# ---------------------------------------------------------------------------
# the page and the directory
# ---------------------------------------------------------------------------

class _Attrs(HTMLParser):
    def __init__(self):
        super().__init__()
        self.links: list[tuple[str, str, str]] = []
        self.tags: list[tuple[str, dict]] = []

    def handle_starttag(self, tag, attrs):
        d = dict(attrs)
        self.tags.append((tag, d))
        for k, v in attrs:
            if k in ("src", "href", "srcset", "action", "poster", "data") and v is not None:
                self.links.append((tag, k, v))


@pytest.mark.parametrize("which", [pytest.param("cmp3", marks=pytest.mark.slow), "cmp2"])
def test_page_is_self_contained(which, request):
    out, _ = request.getfixturevalue(which)
    page = (out / "index.html").read_text()
    p = _Attrs()
    p.feed(page)
    for tag, attr, value in p.links:
        assert not value.lower().startswith(("http:", "https:", "//")), (tag, attr, value)
    assert "http://" not in page and "https://" not in page
    assert not [t for t, a in p.tags if t == "script" and "src" in a]
    assert not [t for t, a in p.tags if t == "link" and a.get("rel") == "stylesheet"]
    assert "@import" not in page and "@font-face" not in page and "url(" not in page
    # the audio inside is the files beside it, byte for byte
    for i in _ids(out):
        start = page.index(f'<script type="application/octet-stream" id="audio-{i}">')
        b64 = page[page.index(">", start) + 1:page.index("</script>", start)]
        assert base64.b64decode(b64) == (out / f"{i}.wav").read_bytes()
    assert sorted(os.listdir(out)) == sorted(["index.html", "compare.json"] +
                                             [f"{i}.wav" for i in _ids(out)])


@pytest.mark.slow  # the three-preset fixture
def test_page_data(cmp3, cmp2):
    d3, d2 = _data(cmp3[0]), _data(cmp2[0])
    assert d3["stimuli"] == ["A", "B", "C"] and d3["mushra"] and d3["anchor"] == "anchor"
    assert [r["label"] for r in d3["reveal"]] == list(STIM3) + ["grand-piano low-passed at 3.5 kHz"]
    assert d3["reveal"][1]["overrides"] == ["strings.t60_scale=0.5", "tuning.stretch=0"]
    assert d3["columns"] == list(ANSWER_COLUMNS)
    a = {r["id"]: r["analysis"] for r in d3["reveal"]}
    assert a["A"]["f0_hz"] == pytest.approx(261.6, abs=1.0)       # grand, C4 (stretched)
    assert a["C"]["f0_hz"] == pytest.approx(246.9, abs=1.0)       # harpsichord at A4 = 415 Hz
    assert d2["stimuli"] == ["A", "B"] and not d2["mushra"] and d2["anchor"] is None
    assert d2["trials"] == 4 and d2["duration_s"] == pytest.approx(1.3)
    assert "--trials 4" in d2["command"]


def test_wav_stimuli_are_mixed_down_resampled_and_padded(cmp2):
    out, lines = cmp2
    text = "\n".join(lines)
    assert "2 channels, compared as their mean (mono)" in text
    assert "resampled from 44100 Hz to 48000 Hz" in text
    assert "A (" in text and "padded with 0.30 s of silence" in text
    x, _ = sf.read(out / "A.wav")
    assert len(x) == int(1.3 * FS) and np.all(x[FS:] == 0)
    f0 = {r["id"]: r["analysis"]["f0_hz"] for r in _data(out)["reveal"]}
    assert f0["A"] == pytest.approx(220.0, abs=0.05)
    assert f0["B"] == pytest.approx(220 * 2 ** (1 / 12), abs=0.05)


def test_midi_file_with_two_presets(tmp_path):
    import mido

    mid = mido.MidiFile(ticks_per_beat=480)
    tr = mido.MidiTrack()
    mid.tracks.append(tr)
    tr += [mido.Message("note_on", note=60, velocity=90, time=0),
           mido.Message("note_on", note=64, velocity=90, time=120),
           mido.Message("note_off", note=60, velocity=0, time=240),
           mido.Message("note_off", note=64, velocity=0, time=120)]
    mid.save(tmp_path / "two.mid")
    out = tmp_path / "m"
    lines = []
    make_comparison(CompareRequest(("harpsichord", "grand-piano"), str(out),
                                   midi=str(tmp_path / "two.mid")), log=lines.append)
    d = _data(out)
    assert "--midi" in d["command"] and not d["mushra"]
    assert all(r["analysis"]["f0_hz"] is None for r in d["reveal"])
    lv = [loudness(sf.read(out / f"{i}.wav")[0], FS)["integrated_lufs"] for i in "AB"]
    assert abs(lv[0] - lv[1]) <= 0.011


def run(capsys, *argv):
    rc = main([str(a) for a in argv])
    cap = capsys.readouterr()
    assert "Traceback" not in cap.err, cap.err
    return rc, cap.out, cap.err


@pytest.mark.slow  # over 2 s on a quiet 2-core machine
def test_cli_builds_a_comparison(capsys, tmp_path):
    rc, out, err = run(capsys, "compare", "biwa", "biwa:pluck.position=0.5", "--key", "52",
                       "--seconds", "0.6", "--trials", "3", "--lufs", "-30", "-o", tmp_path / "c")
    assert rc == 0, err
    assert "matched at -30.00 LUFS" in out and "wrote" in out
    assert _data(tmp_path / "c")["trials"] == 3


@pytest.mark.parametrize("argv, fragment", [
    (["nosuch-preset", "grand-piano", "--key", "60"], "nosuch-preset"),
    (["grand-piano:strings.nope=1", "grand-piano", "--key", "60"], "unknown key 'strings.nope'"),
    (["grand-piano:strings.t60_scale=-3", "grand-piano", "--key", "60"], "t60_scale"),
    (["grand-piano", "missing.wav", "--key", "60"], "missing.wav: no such file"),
    (["grand-piano", "notaudio.wav", "--key", "60"], "cannot read it as audio"),
    (["grand-piano", "silent.wav", "--key", "60"], "silent"),
    (["grand-piano", "harpsichord", "--key", "100", "--seconds", "0.5"], "outside the playable range"),
    (["grand-piano", "harpsichord"], "musical preset: give --key"),
    (["grand-piano", "--key", "60"], "give 2 to 12 stimuli"),
    (["grand-piano", "harpsichord", "--key", "60", "--trials", "0"], "--trials"),
    (["grand-piano", "harpsichord", "--key", "60", "--seconds", "0.1"], "--seconds"),
    (["grand-piano", "harpsichord", "--key", "60", "--lufs", "3"], "--lufs"),
    (["grand-piano", "harpsichord", "--key", "60", "--velocity", "0"], "--velocity"),
    (["grand-piano", "harpsichord", "--midi", "x.mid", "--key", "60"], "--midi plays the file"),
    (["grand-piano", "harpsichord", "--midi", "missing.mid"], "missing.mid"),
    (["grand-piano", "harpsichord", "--key", "60", "--port", "9"], "--port is for --serve"),
])
def test_bad_input_is_one_line_exit_2_and_leaves_nothing(argv, fragment, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("SYNTH_PRESET_PATH", raising=False)
    (tmp_path / "notaudio.wav").write_text("not a wav file\n")
    sf.write(tmp_path / "silent.wav", np.zeros(FS), FS)
    before = sorted(os.listdir(tmp_path))
    rc, out, err = run(capsys, "compare", *argv, "-o", "out")
    assert rc == 2, (out, err)
    assert err.startswith("synth: error: ") and err.count("\n") == 1, err
    assert fragment in err, err
    assert sorted(os.listdir(tmp_path)) == before     # no out/, no hidden staging directory


def test_a_directory_that_is_not_empty_is_refused_and_kept(capsys, tmp_path):
    d = tmp_path / "old"
    d.mkdir()
    (d / "answers.csv").write_text("precious\n")
    rc, _, err = run(capsys, "compare", "biwa", "sitar", "--key", "55", "-o", d)
    assert rc == 2 and "not empty" in err and err.count("\n") == 1
    assert os.listdir(d) == ["answers.csv"] and (d / "answers.csv").read_text() == "precious\n"
    # an empty directory is fine, and so is --serve of one that holds no page: an error
    e = tmp_path / "empty"
    e.mkdir()
    rc, _, err = run(capsys, "compare", "-o", e, "--serve", "--port", "0")
    assert rc == 2 and "no index.html" in err


# ---------------------------------------------------------------------------
# the server
# ---------------------------------------------------------------------------

def _post(url, obj, raw=None):
    body = raw if raw is not None else json.dumps(obj).encode()
    req = urllib.request.Request(url, data=body, method="POST",
                                 headers={"Content-Type": "application/json"})
    try:
        with urllib.request.urlopen(req, timeout=10) as r:
            return r.status, json.loads(r.read())
    except urllib.error.HTTPError as e:
        return e.code, json.loads(e.read())


def _read_answers(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_server_serves_the_page_and_appends_answers(cmp2, tmp_path):
    d = tmp_path / "served"
    shutil.copytree(cmp2[0], d)
    posted = []
    srv = make_server(d, 0, log=posted.append)
    host, port = srv.server_address[:2]
    assert host == "127.0.0.1"
    th = threading.Thread(target=srv.serve_forever, daemon=True)
    th.start()
    try:
        base = f"http://127.0.0.1:{port}/"
        with urllib.request.urlopen(base, timeout=10) as r:
            assert r.status == 200 and r.read() == (d / "index.html").read_bytes()
        with urllib.request.urlopen(base + "A.wav", timeout=10) as r:
            assert r.read() == (d / "A.wav").read_bytes()
        row = {"listener": "ann", "time": "2025-01-01T00:00:00Z", "test": "abx", "trial": 1,
               "a": "A", "b": "B", "x": "B", "choice": "B", "correct": True, "score": 1, "n": 1,
               "p_value": 0.5}
        assert _post(base + "answers", row) == (200, {"saved": 1})
        row2 = dict(row, trial=2, choice="A", correct=False, n=2, p_value=0.75)
        rows3 = [{"listener": "ann", "test": "mushra", "trial": k, "stimulus": s, "rating": r}
                 for k, s, r in [(1, "A", 80), (2, "B, \"the other\"", 35)]]
        assert _post(base + "answers", [row2] + rows3) == (200, {"saved": 3})
        assert _post(base + "answers", {"listener": "x", "evil": 1})[0] == 400
        assert _post(base + "answers", None, raw=b"{not json")[0] == 400
        assert _post(base + "answers", {"listener": {"nested": 1}})[0] == 400
        assert _post(base + "elsewhere", row)[0] == 404
    finally:
        srv.shutdown()
        srv.server_close()
    got = _read_answers(d / "answers.csv")
    assert list(got[0]) == ["received"] + list(ANSWER_COLUMNS)
    assert [(r["listener"], r["test"], r["trial"], r["choice"], r["correct"]) for r in got] == [
        ("ann", "abx", "1", "B", "1"), ("ann", "abx", "2", "A", "0"),
        ("ann", "mushra", "1", "", ""), ("ann", "mushra", "2", "", "")]
    assert got[3]["stimulus"] == 'B, "the other"' and got[3]["rating"] == "35"
    assert got[1]["p_value"] == "0.75" and got[0]["time"] == "2025-01-01T00:00:00Z"
    assert len(posted) == 2


def test_serve_from_the_command_line_stops_cleanly_on_ctrl_c(cmp2, tmp_path):
    d = tmp_path / "served"
    shutil.copytree(cmp2[0], d)
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    p = subprocess.Popen([sys.executable, "-m", "synth.cli", "compare", "-o", str(d), "--serve",
                          "--port", "0"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         env=env)
    try:
        line = p.stdout.readline()
        assert "http://127.0.0.1:" in line, line + p.stderr.read()
        url = line.split("http://", 1)[1].split()[0]
        status, _ = _post(f"http://{url}answers", {"listener": "cli", "test": "abx", "trial": 1,
                                                   "choice": "A", "correct": False})
        assert status == 200
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=20)
    finally:
        if p.poll() is None:
            p.kill()
    assert p.returncode == 0, err
    assert "server stopped" in out and "Traceback" not in err
    assert _read_answers(d / "answers.csv")[0]["listener"] == "cli"


# ---------------------------------------------------------------------------
# the page in a real browser
# ---------------------------------------------------------------------------

def mulberry32(seed: int, n: int) -> list[float]:
    """The page's PRNG (mulberry32), in Python: the draws ?seed=N gives."""
    m = 0xFFFFFFFF
    a = seed & m
    out = []
    for _ in range(n):
        a = (a + 0x6D2B79F5) & m
        t = a
        t = ((t ^ (t >> 15)) * (t | 1)) & m
        t ^= (t + (((t ^ (t >> 7)) * (t | 61)) & m)) & m
        out.append(((t ^ (t >> 14)) & m) / 4294967296)
    return out


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    if not (CHROMIUM.exists() and CHROMEDRIVER.exists()):
        pytest.skip("no /usr/bin/chromium and /usr/bin/chromedriver (apt-get install chromium "
                    "chromium-driver)")
    webdriver = pytest.importorskip("selenium.webdriver", reason="selenium is not installed "
                                    "(pip install -e '.[test]')")
    from selenium.webdriver.chrome.service import Service

    downloads = tmp_path_factory.mktemp("downloads")
    o = webdriver.ChromeOptions()
    o.binary_location = str(CHROMIUM)
    for a in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--disable-gpu",
              "--window-size=1100,1400", "--no-first-run", "--disable-extensions"):
        o.add_argument(a)
    o.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    o.add_experimental_option("prefs", {"download.default_directory": str(downloads),
                                        "download.prompt_for_download": False})
    d = webdriver.Chrome(service=Service(str(CHROMEDRIVER)), options=o)
    d.downloads = downloads
    yield d
    d.quit()


def _open(driver, url):
    driver.get_log("browser")        # drop what earlier tests left
    driver.get(url)
    t = time.monotonic()
    while time.monotonic() - t < 20:
        ready = driver.execute_script("return document.documentElement.dataset.ready || ''")
        if ready:
            assert ready == "1", driver.find_element("id", "notice").text
            return
        time.sleep(0.05)
    raise AssertionError("the page did not finish decoding in 20 s")


def _no_console_errors(driver):
    bad = [e for e in driver.get_log("browser")
           if e["level"] == "SEVERE" or "error" in e.get("message", "").lower()]
    assert not bad, bad


def _click(driver, id_):
    driver.find_element("id", id_).click()


def _state(driver):
    return driver.execute_script("return synthCompare.state()")


def _wait(cond, timeout=10.0, what="condition"):
    t = time.monotonic()
    while time.monotonic() - t < timeout:
        v = cond()
        if v:
            return v
        time.sleep(0.02)
    raise AssertionError(f"timed out waiting for {what}")


@pytest.mark.slow  # the three-preset fixture (9 s) and the browser
def test_browser_loads_and_decodes_every_buffer(browser, cmp3):
    out, _ = cmp3
    _open(browser, (out / "index.html").as_uri())
    data = _data(out)
    dec = browser.execute_script("return synthCompare.decoded")
    assert sorted(dec) == sorted(_ids(out))
    for i in _ids(out):
        assert dec[i]["sampleRate"] == FS and dec[i]["channels"] == 1
        assert dec[i]["length"] == data["samples"]
        assert dec[i]["duration"] == pytest.approx(data["duration_s"], abs=1e-9)
        x, _ = sf.read(out / f"{i}.wav", dtype="float32")
        for start in (0, 1000, data["samples"] - 64):
            got = browser.execute_script(f"return synthCompare.samples('{i}', {start}, 64)")
            np.testing.assert_array_equal(np.array(got, np.float32), x[start:start + 64])
    # the JS p-value and PRNG are the Python ones
    for k, n in [(0, 10), (7, 10), (10, 10), (60, 100), (540, 1000)]:
        js = browser.execute_script(f"return synthCompare.binomialPValue({k}, {n})")
        assert js == pytest.approx(binomial_p_value(k, n), rel=1e-15, abs=0)
    assert browser.execute_script("return synthCompare.prng(42, 20)") == mulberry32(42, 20)
    assert not browser.execute_script("return synthCompare.revealed()")
    assert browser.find_element("id", "reveal").get_attribute("hidden") is not None
    _no_console_errors(browser)


@pytest.mark.slow  # over 2 s on a quiet 2-core machine (2026-11-29: 2.0-6.1 s)
def test_browser_ab_switch_keeps_the_playhead_and_loops(browser, cmp3):
    out, _ = cmp3
    _open(browser, (out / "index.html").as_uri())
    _click(browser, "ab-A")
    _wait(lambda: (s := _state(browser))["contextState"] == "running" and s["position"] > 0.25 and s,
          what="playback to reach 0.25 s")
    t1 = time.monotonic()
    s1 = _state(browser)
    assert s1["playing"] and s1["slot"] == "A" and s1["starts"] == 1
    _click(browser, "ab-B")
    t2 = time.monotonic()
    s2 = _state(browser)
    t3 = time.monotonic()
    _click(browser, "ab-C")
    s3 = _state(browser)
    t4 = time.monotonic()
    assert (s2["slot"], s3["slot"]) == ("B", "C")
    # no source restarted: the playhead moved exactly as the audio clock did, forwards, and
    # by no more than the wall time between the two reads (a restart would move it back to
    # 0; a busy machine only makes the clicks slower, so the bound is measured, not fixed).
    # The stimulus loops: on a busy machine the playhead can pass its end between two reads
    # (seen with three test workers on two cores: 0.73 s -> 0.00 s of a 1 s stimulus), so
    # the positions are compared modulo its duration
    assert s2["starts"] == s3["starts"] == 1
    dur = _data(out)["duration_s"]
    for a, b, wall_s in ((s1, s2, t3 - t1), (s2, s3, t4 - t2)):
        clock = b["contextTime"] - a["contextTime"]
        moved = (b["position"] - a["position"]) % dur
        assert moved == pytest.approx(clock % dur, abs=1e-9)
        assert 0 <= clock <= wall_s + 0.02, (clock, wall_s)
    # a loop region: the playhead stays inside it
    for id_, value in (("loop-start", "0.20"), ("loop-end", "0.45")):
        el = browser.find_element("id", id_)
        el.clear()
        el.send_keys(value + "\t")
    _wait(lambda: _state(browser)["loop"] == [0.2, 0.45], what="the loop")
    t0 = time.monotonic()
    positions = []
    while time.monotonic() - t0 < 0.8:
        positions.append(_state(browser)["position"])
        time.sleep(0.03)
    assert all(0.2 <= p < 0.45 for p in positions), positions
    assert any(b < a for a, b in zip(positions, positions[1:])), "never wrapped"
    _click(browser, "stop")
    assert not _state(browser)["playing"]
    _no_console_errors(browser)


def _csv_rows(text: str) -> list[dict]:
    return list(csv.DictReader(io.StringIO(text)))


@pytest.mark.slow  # over 2 s on a quiet 2-core machine (2026-11-29: 2.0-6.1 s)
def test_browser_abx_session_score_p_value_mushra_csv_and_screenshot(browser, cmp3, tmp_path):
    out, _ = cmp3
    seed = 20240611
    _open(browser, (out / "index.html").as_uri() + f"?seed={seed}&listener=tester")
    xs = ["A" if r < 0.5 else "B" for r in mulberry32(seed, 10)]
    right = [True, True, False, True, True, True, False, True, True, True]      # 8 of 10
    answers = [x if ok else ("B" if x == "A" else "A") for x, ok in zip(xs, right)]
    _click(browser, "abx-start")
    _click(browser, "abx-play-x")
    assert _state(browser)["slot"] == "X"
    for i, ans in enumerate(answers):
        _click(browser, "abx-play-a" if i % 2 else "abx-play-b")
        _click(browser, f"abx-answer-{ans.lower()}")
        k = sum(right[:i + 1])
        assert browser.find_element("id", "abx-score").text == f"{k} / {i + 1}"
        js_p = browser.execute_script("return synthCompare.abx().p_value")
        assert js_p == binomial_p_value(k, i + 1)
    from scipy.stats import binomtest

    summary = browser.execute_script("return synthCompare.abx()")
    assert (summary["correct"], summary["answered"], summary["done"]) == (8, 10, True)
    assert summary["p_value"] == pytest.approx(binomtest(8, 10, 0.5, alternative="greater").pvalue,
                                               rel=1e-12)
    assert browser.find_element("id", "abx-p").text == "0.05469"
    assert browser.find_element("id", "abx-answer-a").get_attribute("disabled")
    # MUSHRA still open: no reveal yet
    assert not browser.execute_script("return synthCompare.revealed()")
    items = browser.execute_script("return synthCompare.mushraItems()")
    assert [it["item"] for it in items] == [1, 2, 3, 4, 5]
    ratings = {1: 12, 2: 100, 3: 64, 4: 47, 5: 88}
    for k, v in ratings.items():
        _click(browser, f"mushra-play-{k}")
        browser.execute_script(
            "const r = document.getElementById(arguments[0]); r.value = arguments[1];"
            "r.dispatchEvent(new Event('input'));", f"mushra-slider-{k}", v)
    _click(browser, "mushra-submit")
    assert browser.execute_script("return synthCompare.revealed()")

    text = browser.execute_script("return synthCompare.csv()")
    assert browser.find_element("id", "results-csv").get_attribute("textContent") == text
    rows = _csv_rows(text)
    assert list(rows[0]) == list(ANSWER_COLUMNS)
    abx_rows, mushra_rows = rows[:10], rows[10:]
    k = 0
    for i, r in enumerate(abx_rows):
        k += right[i]
        assert (r["listener"], r["test"], r["trial"], r["a"], r["b"]) == ("tester", "abx", str(i + 1), "A", "B")
        assert (r["x"], r["choice"], r["correct"]) == (xs[i], answers[i], "1" if right[i] else "0")
        assert (int(r["score"]), int(r["n"])) == (k, i + 1)
        assert float(r["p_value"]) == binomial_p_value(k, i + 1)
    assert [(int(r["trial"]), int(r["rating"])) for r in mushra_rows] == sorted(ratings.items())
    assert sorted(r["stimulus"] for r in mushra_rows) == ["A", "B", "C", "anchor", "hidden-reference"]
    res = json.loads(browser.execute_script("return synthCompare.json()"))
    assert res["answers"] == browser.execute_script("return synthCompare.results()")
    assert res["abx"]["correct"] == 8 and res["seed"] == seed and not res["revealed_early"]

    # the reveal names every stimulus, with the loudness and the analysis table
    reveal = browser.find_element("id", "reveal")
    assert reveal.is_displayed()
    for label in STIM3:
        assert label in reveal.text
    assert "f0_hz" in reveal.text and "integrated_lufs" in reveal.text
    imgs = browser.execute_script(
        "return [...document.querySelectorAll('#reveal img')].map(i => [i.naturalWidth, i.complete])")
    assert len(imgs) == 4 and all(w > 100 and ok for w, ok in imgs)

    # the CSV download (Blob + link) is the same text
    _click(browser, "download-csv")
    # (Chromium may show the file under its final name before its bytes are
    # all written: wait for them, then compare)
    got = _wait(lambda: [p for p in browser.downloads.glob("synth-compare-*.csv")
                         if p.stat().st_size >= len(text.encode())], what="the download")
    assert got[0].read_text() == text

    shot = tmp_path / "compare.png"
    browser.execute_script("window.scrollTo(0, 0)")
    assert browser.save_screenshot(str(shot)) and shot.stat().st_size > 10_000
    _no_console_errors(browser)


def test_browser_reveal_now_closes_the_blind_tests(browser, cmp2):
    out, _ = cmp2
    _open(browser, (out / "index.html").as_uri())
    assert browser.find_element("id", "mushra").get_attribute("hidden") is not None
    _click(browser, "abx-start")
    _click(browser, "abx-answer-a")
    _click(browser, "reveal-now")
    assert browser.execute_script("return synthCompare.revealed()")
    assert browser.find_element("id", "abx-answer-a").get_attribute("disabled")
    assert json.loads(browser.execute_script("return synthCompare.json()"))["revealed_early"]
    _no_console_errors(browser)


def test_browser_answers_reach_the_server(browser, cmp2, tmp_path):
    d = tmp_path / "served"
    shutil.copytree(cmp2[0], d)
    srv = make_server(d, 0)
    threading.Thread(target=srv.serve_forever, daemon=True).start()
    try:
        seed = 7
        _open(browser, f"http://127.0.0.1:{srv.server_address[1]}/index.html?seed={seed}&listener=srv")
        xs = ["A" if r < 0.5 else "B" for r in mulberry32(seed, 4)]
        _click(browser, "abx-start")
        for x in xs:
            _click(browser, f"abx-answer-{x.lower()}")        # all right
        _wait(lambda: "4 answer(s) saved" in browser.find_element("id", "server-status").text,
              what="the server to save 4 answers")
    finally:
        srv.shutdown()
        srv.server_close()
    rows = _read_answers(d / "answers.csv")
    assert [(r["listener"], r["trial"], r["x"], r["correct"]) for r in rows] == [
        ("srv", str(i + 1), x, "1") for i, x in enumerate(xs)]
    assert float(rows[-1]["p_value"]) == binomial_p_value(4, 4)
    _no_console_errors(browser)


def test_a_long_midi_file_plays_its_first_minutes(tmp_path, monkeypatch):
    """A --midi file longer than a listening page plays
    (``MAX_MIDI_SECONDS``, 10 min) is cut there, with a note, instead of
    rendering for as long as the file lasts (here the limit is set to 2 s)."""
    import mido

    import synth.apps.compare as C

    monkeypatch.setattr(C, "MAX_MIDI_SECONDS", 2.0)
    mid = mido.MidiFile(ticks_per_beat=480)
    tr = mido.MidiTrack()
    mid.tracks.append(tr)
    tr += [mido.Message("note_on", note=60, velocity=90, time=0),
           mido.Message("note_off", note=60, velocity=0, time=480),
           mido.Message("note_on", note=64, velocity=90, time=480 * 20),
           mido.Message("note_off", note=64, velocity=0, time=480)]
    mid.save(tmp_path / "long.mid")
    out = tmp_path / "m"
    lines = []
    make_comparison(CompareRequest(("biwa", "harpsichord"), str(out),
                                   midi=str(tmp_path / "long.mid")), log=lines.append)
    assert any("rendering its first 2.0 s" in ln and "a listening page plays at most" in ln
               for ln in lines), lines
    for i in "AB":
        x, fs = sf.read(out / f"{i}.wav")
        assert len(x) == 2 * FS
