"""tools/study_partials.py: its measures (synth.apps.grand_study), early
T60s and peak and band levels, on synthetic notes whose partials are known
in closed form; its argument checks with the tool run as a program."""

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from synth.apps import grand_study as sp
from synth.physics.piano import et_f0_hz, grand_string

ROOT = Path(__file__).resolve().parents[1]
TOOL = ROOT / "tools" / "study_partials.py"


def _run(*argv):
    """The tool's exit code on ``argv`` (the argument checks stop before any
    rendering)."""
    return subprocess.run([sys.executable, str(TOOL), *argv], capture_output=True, text=True,
                          cwd=ROOT, timeout=300).returncode

FS = 48_000


def _note(key, t60s, amps, seconds=1.6, split_hz=None, split=()):
    """Partials 1..len(t60s) of ``key`` on its stiff-string law, partial n
    decaying with ``t60s[n-1]`` from amplitude ``amps[n-1]``; the partials
    in ``split`` are two lines of half that amplitude ``split_hz`` apart
    (a unison's strings, beating)."""
    g = grand_string(key)
    t = np.arange(int(seconds * FS)) / FS
    y = np.zeros_like(t)
    for n, (T, a) in enumerate(zip(t60s, amps), start=1):
        f = g.partial_hz(n)
        env = a * np.exp(-math.log(1000.0) * t / T)
        if n not in split:
            y += env * np.sin(2 * np.pi * f * t)
        else:
            y += 0.5 * env * (np.sin(2 * np.pi * (f - split_hz / 2) * t)
                              + np.sin(2 * np.pi * (f + split_hz / 2) * t + 0.3))
    return y


def test_early_t60s_of_known_decays():
    t60 = [4.0, 3.0, 2.5, 2.0, 1.5, 1.2, 1.0, 0.8]
    amps = [1.0, 0.5, 0.3, 0.2, 0.1, 0.1, 0.05, 0.05]
    got = sp.early_t60_s(_note(60, t60, amps), 60)
    assert np.allclose(got, t60, rtol=0.03), got


def test_a_steady_partial_reads_99():
    got = sp.early_t60_s(_note(60, [1e9, 2.0], [1.0, 0.3]), 60)
    assert got[0] == 99.0 and abs(got[1] - 2.0) < 0.06


def test_peak_and_band_levels():
    amps = [1.0, 0.5, 0.1, 0.05]
    db = 20 * np.log10(np.array(amps))
    # a steady note: both read the partials' levels
    pk, bd = sp.partial_levels_db(_note(60, [1e9] * 4, amps), 60, 0.05, 1.05, n=4)
    assert np.allclose(pk, db, atol=0.2) and np.allclose(bd, db, atol=0.2)
    # partial 3 split into two lines of half its amplitude 4 Hz apart (they
    # beat between 0 and its amplitude: their mean power is 3 dB under the
    # single line's): in a one-second window they are two peaks, each 6 dB
    # under the single line, which the band level sums
    pk, bd = sp.partial_levels_db(_note(60, [1e9] * 4, amps, split_hz=4.0, split=(3,)), 60,
                                  0.05, 1.05, n=4)
    want = db.copy()
    want[2] -= 10 * np.log10(2)
    assert np.allclose(bd, want, atol=0.3), bd
    assert pk[2] < bd[2] - 2.0 and np.allclose(np.delete(pk, 2), np.delete(db, 2), atol=0.2), pk


def test_keys_are_checked():
    assert _run("una-corda", "--keys", "20") == 2            # argparse's usage error
    assert _run("decay", "--real", "/no/such/folder") == 2


def test_damping_rows_keep_the_band_above_the_floor_and_the_ratio():
    """``damping_rows`` keeps the partials at 3-8 kHz within 50 dB of the
    strongest (key 84, f0 1047 Hz: partials 3-7), and reads each one's T60
    on both notes; ``ratio_summary`` gives the median of model / real."""
    key = 84
    t_real = [2.0, 2.0, 2.0, 1.8, 1.6, 1.4, 1.2, 1.0]
    t_model = [2.0, 2.0, 1.0, 0.9, 0.8, 0.7, 0.6, 0.5]
    amps = [1.0, 0.3, 0.1, 0.05, 0.02, 0.01, 0.005, 0.001]   # partial 8: -60 dB
    rows = sp.damping_rows(key, _note(key, t_real, amps), _note(key, t_model, amps))
    assert [r[0] for r in rows] == [3, 4, 5, 6, 7], rows
    for p, f, lv, t, m in rows:
        assert abs(t - t_real[p - 1]) < 0.05 * t_real[p - 1]
        assert abs(m - t_model[p - 1]) < 0.05 * t_model[p - 1]
    med, lo, hi = sp.ratio_summary(rows)
    assert abs(med - 0.5) < 0.02 and lo <= med <= hi


@pytest.mark.slow  # over 2 s on a quiet 2-core machine (1.5-2.4 s, 2026-11-30)
def test_beat_roughness_ignores_decays_and_knees_and_reads_beats():
    """A partial decaying in one line, or in two with a knee, reads under
    0.2 dB; a partial split into two lines 1 Hz apart (a unison beating)
    reads several dB, the more the closer the lines' amplitudes."""
    key = 60
    t = np.arange(int(3.1 * FS)) / FS
    g = grand_string(key)
    ln = math.log(1000.0)
    f3 = g.partial_hz(3)

    def note(p3):
        """Partials 1-8 decaying with T60 3 s, partial 3 replaced by ``p3``."""
        y = 0.3 * p3
        for n, a in enumerate([1.0, 0.5, 0.3, 0.2, 0.15, 0.1, 0.08, 0.05], start=1):
            if n != 3:
                y = y + a * np.exp(-ln * t / 3.0) * np.sin(2 * np.pi * g.partial_hz(n) * t)
        return y

    line = sp.beat_roughness_db(note(np.exp(-ln * t / 3.0) * np.sin(2 * np.pi * f3 * t)), key)
    # 30 dB in the first 0.8 s, then a T60 of 8 s: a two-stage decay
    knee_db = np.where(t < 0.8, -30.0 * t / 0.8, -30.0 - 60.0 * (t - 0.8) / 8.0)
    kneed = sp.beat_roughness_db(note(10 ** (knee_db / 20) * np.sin(2 * np.pi * f3 * t)), key)
    assert np.nanmax(line) < 0.2 and np.nanmax(kneed) < 0.2, (line, kneed)

    def beating(r):
        """Partial 3 as two lines 1 Hz apart, amplitudes 1 and r."""
        return np.exp(-ln * t / 3.0) * (np.sin(2 * np.pi * (f3 - 0.5) * t)
                                        + r * np.sin(2 * np.pi * (f3 + 0.5) * t)) / (1 + r)

    deep = sp.beat_roughness_db(note(beating(0.9)), key)[2]
    shallow = sp.beat_roughness_db(note(beating(0.3)), key)[2]
    assert deep > shallow > 1.0, (deep, shallow)
    # the envelope of 1 + 0.3 e^(j 2 pi t) swings 20 log10(1.3 / 0.7) = 5.4 dB
    # peak to peak, near a sine in dB: an RMS of about 5.4 / (2 sqrt 2)
    assert abs(shallow - 5.4 / (2 * math.sqrt(2))) < 0.5, shallow
    others = np.delete(sp.beat_roughness_db(note(beating(0.9)), key), 2)
    assert np.nanmax(others) < 0.2


def test_beats_checks_its_arguments():
    assert _run("beats", "--real", "/no/such/folder") == 2
    assert _run("beats", "--real", ".", "--scales", "x") == 2


def test_tail_reads_a_known_decay_and_level():
    """A note falling 30 dB in its first second, then with a T60 of 20 s:
    the tail's T60 reads 20 s and its level over 2.5-4 s the line's
    median there; a note too short or silent reads NaN."""
    t = np.arange(int(11.0 * FS)) / FS
    db = np.where(t < 1.0, -30.0 * t, -30.0 - 60.0 * (t - 1.0) / 20.0)
    y = 10 ** (db / 20) * np.sin(2 * np.pi * 261.6 * t)
    t60, level = sp.tail_t60_and_level(y)
    assert abs(t60 - 20.0) < 0.3, t60
    # the level's median over 2.5-4 s is the line at 3.25 s, re the loudest
    # frame, the first, whose mean power lies 0.75 dB under the start (30
    # dB/s over 50 ms; a sine's frame RMS is its amplitude / sqrt 2 in both)
    assert abs(level - (-30.0 - 60.0 * 2.25 / 20.0 + 0.75)) < 0.1, level
    assert np.isnan(sp.tail_t60_and_level(y[:int(3.0 * FS)])[0])
    steady = np.sin(2 * np.pi * 261.6 * t)
    assert sp.tail_t60_and_level(steady)[0] == float("inf")


def test_level_curve_reads_a_known_decay():
    """``level_curve_db``: 0.1 s frames of a note falling 20 dB a second
    read 2 dB a frame, from the loudest (0 dB) down (250 Hz: whole periods
    in a frame)."""
    t = np.arange(int(2.0 * FS)) / FS
    y = 10 ** (-20.0 * t / 20) * np.sin(2 * np.pi * 250.0 * t)
    c = sp.level_curve_db(y)
    assert len(c) == 20 and c[0] == 0.0
    assert np.allclose(np.diff(c), -2.0, atol=0.01)


def test_tail_checks_its_arguments():
    assert _run("tail", "--real", "/no/such/folder") == 2
    assert _run("tail", "--real", ".", "--keys", "40") == 2        # no sample every minor third
    assert _run("tail", "--real", ".", "--scales", "-1") == 2


def test_thump_reads_the_band_below_the_note_re_c4s_partial_1():
    """``thump_db``: a 100 Hz hum of amplitude a under a note, against a C4
    of amplitude A, reads 20 log10(a / A); the note's own partial 1 and
    anything above 1 kHz or f0 / 2 is left out of the band."""
    t = np.arange(int(0.3 * FS)) / FS
    c4 = 0.5 * np.sin(2 * np.pi * et_f0_hz(60) * t)
    for key in (96, 60):
        note = np.sin(2 * np.pi * et_f0_hz(key) * t + 0.4)
        hum = 0.02 * np.sin(2 * np.pi * 100.0 * t + 1.0)
        assert abs(sp.thump_db(note + hum, key, c4) - 20 * math.log10(0.02 / 0.5)) < 0.1
    # under key 60 a 600 Hz component lies above f0 / 2 (131 Hz): not the thump
    key = 60
    note = np.sin(2 * np.pi * et_f0_hz(key) * t) + 0.02 * np.sin(2 * np.pi * 600.0 * t)
    assert sp.thump_db(note, key, c4) < 20 * math.log10(0.02 / 0.5) - 40


def test_thump_checks_its_arguments():
    assert _run("thump", "--real", "/no/such/folder") == 2
    assert _run("thump", "--real", ".", "--keys", "61") == 2       # no sample every minor third


def test_thump_spectrum_reads_band_densities():
    """``thump_spectrum_db``: tones at 50, 200, 500 and 850 Hz of amplitudes
    1, 1, 0.5, 0.25 read the band powers per Hz: 10 log10(a^2 / width)
    re the 90-360 Hz band's."""
    t = np.arange(int(0.3 * FS)) / FS
    y = (np.sin(2 * np.pi * 50 * t) + np.sin(2 * np.pi * 200 * t)
         + 0.5 * np.sin(2 * np.pi * 500 * t) + 0.25 * np.sin(2 * np.pi * 850 * t))
    got = sp.thump_spectrum_db(y)
    widths = [70.0, 270.0, 360.0, 280.0]
    amps = [1.0, 1.0, 0.5, 0.25]
    want = [10 * math.log10(a * a / w) - 10 * math.log10(1.0 / 270.0) for a, w in zip(amps, widths)]
    assert np.allclose(got, want, atol=0.2), (got, want)
