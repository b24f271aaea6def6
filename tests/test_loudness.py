"""synth.analysis.loudness against BS.1770's calibration: a 997 Hz sine at
-20 dBFS reads -20 LKFS... within the standard's own tolerance, and the
momentary meter agrees with the integrated one on a steady tone."""

import numpy as np
import pytest

from synth.analysis import crest_factor_db, loudness, momentary_lufs, peak_dbfs

FS = 48_000


def _sine(db, seconds=5.0, f=997.0):
    t = np.arange(int(seconds * FS)) / FS
    return 10 ** (db / 20) * np.sin(2 * np.pi * f * t)


def test_a_997_hz_sine_at_minus_20_dbfs_reads_minus_20_lufs_mono():
    """BS.1770-4: a 0 dBFS 997 Hz sine in one channel reads -3.01 LKFS; at
    -20 dBFS peak, -23.01 (mono: the channel weight is 1)."""
    r = loudness(_sine(-20.0), FS)
    assert r["integrated_lufs"] == pytest.approx(-23.01, abs=0.05)
    assert r["max_momentary_lufs"] == pytest.approx(-23.01, abs=0.05)
    assert r["peak_dbfs"] == pytest.approx(-20.0, abs=1e-3)
    assert r["crest_factor_db"] == pytest.approx(20 * np.log10(np.sqrt(2)), abs=1e-3)


def test_momentary_follows_a_step_and_the_gate_ignores_silence():
    x = np.concatenate([_sine(-30.0, 2.0), _sine(-10.0, 2.0), np.zeros(2 * FS)])
    t, m = momentary_lufs(x, FS)
    assert m[t < 1.5] == pytest.approx(-33.01, abs=0.05)
    assert m[(t > 2.5) & (t < 3.5)] == pytest.approx(-13.01, abs=0.05)
    assert np.all(np.isneginf(m[t > 4.5]))
    r = loudness(x, FS)
    # the relative gate (-10 LU) drops the -30 dB part and the absolute one the
    # silence: -13.01 but for the blocks straddling the step (ungated: -16.0)
    assert -14.0 < r["integrated_lufs"] < -13.0


def test_silence_and_bad_input():
    assert np.isneginf(loudness(np.zeros(FS), FS)["integrated_lufs"])
    assert np.isneginf(peak_dbfs(np.zeros(10)))
    assert np.isnan(crest_factor_db(np.zeros(10)))
    with pytest.raises(ValueError, match="fs=-1 out of range"):
        loudness(np.zeros(10), -1)
