"""Issue 41's measures (synth.apps.grand_study) on signals whose answers are known."""

import math

import numpy as np
import pytest

from synth.apps.grand_study import (
    CENTROID_MAX_HZ, OCTAVES, attack_centroid_50ms_hz, octave_table, partial1_at_db, time_to_rms_peak_ms,
    upper_partials_db)
from synth.apps.voicing import FS
from synth.physics.piano import grand_string

T = np.arange(int(4.0 * FS)) / FS


def _note(key, amps, t60s):
    g = grand_string(key)
    y = np.zeros_like(T)
    for j, (a, t60) in enumerate(zip(amps, t60s), start=1):
        y += a * 10 ** (-3 * T / t60) * np.sin(2 * math.pi * g.partial_hz(j) * T)
    return y


def test_partial_1_at_3_s():
    """Partial 1 decaying with T60 = 6 s is 30 dB under its peak at 3 s."""
    y = _note(60, [1.0, 0.5, 0.3], [6.0, 2.0, 1.0])
    assert partial1_at_db(y, 60) == pytest.approx(-30.0, abs=1.0)


def test_partials_2_to_10_re_partial_1():
    amps = [1.0, 0.5, 0.25, 0.1] + [0.0] * 6
    y = _note(48, amps, [50.0] * 10)
    want = 10 * math.log10(sum(a * a for a in amps[1:]) / amps[0] ** 2)
    assert upper_partials_db(y, 48) == pytest.approx(want, abs=0.3)


def test_the_attack_centroid_of_a_tone():
    y = np.sin(2 * math.pi * 1000.0 * T[:FS])
    assert attack_centroid_50ms_hz(y) == pytest.approx(1000.0, rel=0.03)


def test_the_attack_centroid_stops_at_the_recordings_bandwidth():
    """A 1 kHz tone with a 16 kHz one as strong: the centroid counts only
    0 .. CENTROID_MAX_HZ (the samples' encoder keeps nothing above 10.75-16
    kHz), so the 16 kHz tone moves it only with ``max_hz=None``."""
    y = np.sin(2 * math.pi * 1000.0 * T[:FS]) + np.sin(2 * math.pi * 16000.0 * T[:FS])
    assert CENTROID_MAX_HZ == 10_000.0
    assert attack_centroid_50ms_hz(y) == pytest.approx(1000.0, rel=0.03)
    assert attack_centroid_50ms_hz(y, max_hz=None) == pytest.approx(8500.0, rel=0.05)


def test_the_time_to_the_rms_peak():
    """A tone whose envelope rises for 30 ms, then decays."""
    env = np.where(T < 0.03, T / 0.03, np.exp(-(T - 0.03) / 0.2))
    y = env * np.sin(2 * math.pi * 440.0 * T)
    y[0] = 1e-3                       # the onset at t = 0 (within 40 dB of the peak)
    assert time_to_rms_peak_ms(y) == pytest.approx(30.0, abs=3.0)


def test_the_octave_table_takes_medians_per_octave():
    real = {k: {"p1_3s_db": -20.0, "upper_db": 0.0, "centroid_hz": 1000.0, "peak_ms": 30.0}
            for k in (60, 63, 66, 69)}
    model = {k: {"p1_3s_db": -20.0 + d, "upper_db": d, "centroid_hz": 2000.0, "peak_ms": 5.0}
             for k, d in zip((60, 63, 66, 69), (1.0, 2.0, 3.0, 10.0))}
    rows = octave_table(model, real)
    assert [r["octave"] for r in rows] == ["C4-B4"] and OCTAVES[2][0] == "C4-B4"
    assert rows[0]["p1_3s_db"] == pytest.approx(2.5) and rows[0]["upper_db"] == pytest.approx(2.5)
    assert rows[0]["centroid_ratio"] == 2.0 and rows[0]["peak_ms_real"] == 30.0
