"""synth.analysis.band_levels_db and halo against closed-form signals."""

import numpy as np
import pytest

from synth.analysis import band_levels_db, halo

FS = 48_000


def _sine(f, amp, seconds=2.0, phase=0.7):
    t = np.arange(int(seconds * FS)) / FS
    return amp * np.sin(2 * np.pi * f * t + phase)


@pytest.mark.parametrize("f", [27.5, 261.63, 3001.7])
def test_a_sine_in_its_band_reads_its_mean_square(f):
    x = _sine(f, 0.3)
    lv = band_levels_db(x, FS, [f, 1.5 * f], 0.05 * f)
    assert lv[0] == pytest.approx(10 * np.log10(0.3 ** 2 / 2), abs=0.02)
    assert lv[1] < lv[0] - 90                              # nothing at 1.5 f


def test_white_noise_reads_its_share_of_the_variance():
    rng = np.random.default_rng(7)
    x = 0.2 * rng.standard_normal(4 * FS)
    lv = band_levels_db(x, FS, [6000.0], 1000.0)
    assert lv[0] == pytest.approx(10 * np.log10(0.04 * 2000 / 24000), abs=0.1)


def test_the_band_is_never_narrower_than_the_main_lobe():
    x = _sine(100.0, 1.0, seconds=0.5)                     # main lobe +-4 Hz
    assert band_levels_db(x, FS, [100.0], 0.01)[0] == pytest.approx(10 * np.log10(0.5), abs=0.05)


def test_identical_takes_have_no_halo():
    x = _sine(261.63, 0.5)
    h = halo(x, x.copy(), FS, probe_hz=[196.0, 220.0], exclude_hz=[261.63])
    assert h["difference_db"] == -np.inf
    assert h["gain_db"] == pytest.approx(0.0, abs=1e-12)


def test_a_string_ringing_along_is_the_halo():
    """The note (261.63 Hz, amplitude 0.5) with and without a sympathetic
    string at 196 Hz (amplitude a): the difference is 20 log10(a / 0.5), the
    probe band's energy rises from the note's leakage to a^2 / 2, and the
    halo reads 20 log10(a / 0.5) re the take (plus the note's share)."""
    a = 0.005
    note = _sine(261.63, 0.5)
    ring = _sine(196.0, a, phase=0.1)
    probes = [196.0, 220.0, 261.63 * 2 ** (5 / 1200), 523.25]
    h = halo(note + ring, note, FS, probes, exclude_hz=[261.63, 523.26])
    assert h["difference_db"] == pytest.approx(20 * np.log10(a / 0.5), abs=0.01)
    assert h["gain_db"] > 60                               # only leakage there without it
    assert h["level_with_db"] == pytest.approx(10 * np.log10(a ** 2 / (0.5 ** 2 + a ** 2)), abs=0.05)
    # the probes near the note's partials were left out
    assert np.allclose(h["probes_hz"], [196.0, 220.0])


def test_bad_arguments_are_one_line_errors():
    x = _sine(100.0, 0.1)
    with pytest.raises(ValueError, match="must be equal"):
        halo(x, x[:-1], FS, [200.0])
    with pytest.raises(ValueError, match="every probe lies within"):
        halo(x, x, FS, [100.0], exclude_hz=[100.5])
    with pytest.raises(ValueError, match=r"centres_hz must be frequencies in \(0, fs/2"):
        band_levels_db(x, FS, [30000.0], 10.0)
