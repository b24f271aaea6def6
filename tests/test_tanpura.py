"""The tanpura (issue 40): the band measures it is judged by, their check
kinds, and what the thread does to the band.  The preset's own targets
(the band's centre falling by 20 % on key 49, the band 6 dB above the
linear string, every string in tune) are its shipped spec,
``synth/presets/checks/tanpura.toml``, which CI runs (``synth check
--shipped``)."""

from __future__ import annotations

import numpy as np
import pytest
import soundfile as sf

import synth
from synth.analysis import as_mono, band_centroid_hz, band_db
from synth.apps.check import SpecError, run_spec
from synth.io.presets.loader import load_preset

FS = 48_000


def _tones(parts, seconds=1.0):
    t = np.arange(int(seconds * FS)) / FS
    return sum(a * np.sin(2 * np.pi * f * t) for f, a in parts)


def test_band_centroid_is_the_power_weighted_mean_frequency():
    # power 1 at 3 kHz, 0.25 at 6 kHz (amplitude 0.5): (3000 + 0.25 * 6000) / 1.25 = 3600 Hz;
    # the 1 kHz and 9 kHz tones lie outside the band
    x = _tones([(1000.0, 3.0), (3000.0, 1.0), (6000.0, 0.5), (9000.0, 2.0)])
    assert band_centroid_hz(x, FS, 2000.0, 8000.0, 0.0, 1.0) == pytest.approx(3600.0, abs=2.0)
    # one tone: its own frequency
    assert band_centroid_hz(x, FS, 5000.0, 7000.0, 0.2, 0.9) == pytest.approx(6000.0, abs=1.0)


def test_band_db_reads_a_halved_tone_6_db_down_and_ignores_the_rest():
    a = _tones([(3000.0, 1.0), (500.0, 5.0)])
    b = _tones([(3000.0, 0.5), (500.0, 0.1)])
    d = band_db(a, FS, 2000.0, 8000.0, 0.1, 0.9) - band_db(b, FS, 2000.0, 8000.0, 0.1, 0.9)
    assert d == pytest.approx(20 * np.log10(2.0), abs=0.01)


@pytest.mark.parametrize("lo, hi, t0, t1, what", [
    (8000.0, 2000.0, 0.0, 1.0, "lo_hz"),
    (2000.0, 30000.0, 0.0, 1.0, "hi_hz"),
    (2000.0, 8000.0, 0.5, 1.5, "end_s"),
    (2000.0, 8000.0, 0.5, 0.5, "end_s"),
])
def test_band_measures_name_the_bad_argument(lo, hi, t0, t1, what):
    x = _tones([(3000.0, 1.0)])
    with pytest.raises(ValueError, match=what):
        band_centroid_hz(x, FS, lo, hi, t0, t1)


def _spec(tmp_path, body: str):
    p = tmp_path / "spec.toml"
    p.write_text('schema = 1\ndescription = "test"\n' + body)
    return p


def _falling_and_rising(tmp_path):
    """Two 4 s WAVs: a band whose weight moves from 6 kHz to 3 kHz (its
    centre falls) and the same backwards (its centre rises)."""
    t = np.arange(4 * FS) / FS
    w = np.clip((t - 0.5) / 3.0, 0.0, 1.0)
    hi, lo = np.sin(2 * np.pi * 6000 * t), np.sin(2 * np.pi * 3000 * t)
    sf.write(tmp_path / "fall.wav", ((1 - w) * hi + w * lo).astype(np.float32) * 0.3, FS,
             subtype="FLOAT")
    sf.write(tmp_path / "rise.wav", ((1 - w) * lo + w * hi).astype(np.float32) * 0.3, FS,
             subtype="FLOAT")


def test_centroid_fall_passes_a_falling_band_and_fails_a_rising_one(tmp_path):
    _falling_and_rising(tmp_path)
    spec = _spec(tmp_path, '''
[[render]]
name = "fall"
wav = "fall.wav"
[[render]]
name = "rise"
wav = "rise.wav"
[[expect]]
render = "fall"
check = "centroid_fall"
above_hz = 2000
below_hz = 8000
early_s = [0.5, 1.0]
late_s = [3.0, 4.0]
min_fall_percent = 20.0
[[expect]]
render = "rise"
check = "centroid_fall"
above_hz = 2000
below_hz = 8000
early_s = [0.5, 1.0]
late_s = [3.0, 4.0]
min_fall_percent = 20.0
''')
    fall, rise = run_spec(spec)
    assert fall.passed and not rise.passed
    # the early span holds mostly 6 kHz, the late one mostly 3 kHz
    assert "down" in fall.measured and float(fall.measured.split("(")[1].split()[0]) > 30.0


def test_centroid_fall_refuses_a_span_beyond_the_render(tmp_path):
    _falling_and_rising(tmp_path)
    spec = _spec(tmp_path, '''
[[render]]
name = "fall"
wav = "fall.wav"
[[expect]]
render = "fall"
check = "centroid_fall"
above_hz = 2000
below_hz = 8000
early_s = [0.5, 1.0]
late_s = [3.0, 5.0]
min_fall_percent = 20.0
''')
    with pytest.raises(SpecError, match="late_s"):
        run_spec(spec)


def test_highband_diff_with_an_upper_edge_reads_the_band_only(tmp_path):
    t = np.arange(FS) / FS
    a = 0.1 * np.sin(2 * np.pi * 3000 * t) + 0.5 * np.sin(2 * np.pi * 12000 * t)
    b = 0.05 * np.sin(2 * np.pi * 3000 * t) + 0.01 * np.sin(2 * np.pi * 12000 * t)
    sf.write(tmp_path / "a.wav", a.astype(np.float32), FS, subtype="FLOAT")
    sf.write(tmp_path / "b.wav", b.astype(np.float32), FS, subtype="FLOAT")
    body = '''
[[render]]
name = "a"
wav = "a.wav"
[[render]]
name = "b"
wav = "b.wav"
[[expect]]
render = "a"
check = "highband_diff"
against = "b"
above_hz = 2000
{edge}min_db = 5.0
max_db = 7.0
'''
    banded, = run_spec(_spec(tmp_path, body.format(edge="below_hz = 8000\n")))
    assert banded.passed, banded.measured              # +6.0 dB: the 3 kHz tone alone
    whole, = run_spec(_spec(tmp_path, body.format(edge="")))
    assert not whole.passed, whole.measured            # the 12 kHz tone's +34 dB dominates


@pytest.mark.slow
def test_raising_the_thread_ends_the_upper_band_sooner():
    """The jiva (thread) lifts the string off the bridge's front edge: the
    higher it is, the sooner the string stops wrapping the bridge as its
    swing decays, and the upper band (4-8 kHz at 3-4 s) goes.  Measured
    (key 49, velocity 90, with the tension's modulation, 2026-11-30):
    +4.8, -9.1, -30.7 and -45.4 dB at 1.0, 1.15, 1.4 and 2 times the open
    jawari's thread; the early band's centre 2593, 2567, 2496 and 2265 Hz."""
    term = load_preset("tanpura").termination
    open_m = term.extent_m ** 2 / (2 * term.radius_m)   # the open jawari's s^2 / (2 R)
    late, early = [], []
    for x in (1.0, 1.4, 2.0):
        a = synth.render_note("tanpura", key=49, velocity=90, seconds=4.2,
                              set=[f"termination.thread_m={x * open_m:.6g}"])
        y = as_mono(np.asarray(a))
        late.append(band_db(y, a.fs, 4000.0, 8000.0, 3.0, 4.0))
        early.append(band_centroid_hz(y, a.fs, 2000.0, 8000.0, 0.5, 1.5))
    assert late[0] - late[1] > 20.0 and late[1] > late[2]
    assert early[0] > early[1] > early[2]


@pytest.mark.slow
def test_the_drone_command_plays_the_tanpura_for_20_s_at_the_presets_level(tmp_path):
    """Issue 40's drone target: ``synth drone --preset tanpura --sa 49
    --seconds 20`` lasts 20 +- 0.5 s with at least 12 plucks, at the
    presets' -20 LUFS (its phrase is the drone: synth.apps.levels)."""
    import re
    import subprocess
    import sys

    import pyloudnorm

    out = tmp_path / "drone.wav"
    p = subprocess.run([sys.executable, "-m", "synth", "drone", "--preset", "tanpura", "--sa", "49",
                        "--seconds", "20", "-o", str(out)], capture_output=True, text=True,
                       timeout=600)
    assert p.returncode == 0, p.stderr
    plucks = int(re.search(r"(\d+) plucks", p.stdout + p.stderr).group(1))
    assert plucks >= 12
    x, fs = sf.read(out)
    assert abs(len(x) / fs - 20.0) <= 0.5
    lufs = pyloudnorm.Meter(fs).integrated_loudness(x)
    assert abs(lufs - (-20.0)) <= 2.0, lufs
