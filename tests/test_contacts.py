"""Contact telemetry: synth.analysis.contacts and synth note --contact-log."""

import csv
import subprocess
import sys

import numpy as np
import pytest

from synth.analysis.contacts import contact_frames, contact_summary

FS = 100_000.0


def test_summary_counts_time_episodes_and_peaks():
    c = np.zeros(1000)
    c[100:150] = 2          # 0.5 ms
    c[160:170] = 3          # 10 samples later: merged with a 0.2 ms gap, apart with 0
    c[600:700] = 1
    f = np.zeros(1000)
    f[50:80] = np.hanning(30) * 40.0
    s = contact_summary(c, f, FS, min_gap_s=0.0002)
    t, h = s["termination"], s["hammer"]
    assert t["time_in_contact_s"] == pytest.approx(160 / FS)
    assert t["episodes"] == 2 and t["max_points"] == 3
    assert t["first_contact_s"] == pytest.approx(100 / FS) and t["last_contact_s"] == pytest.approx(699 / FS)
    assert contact_summary(c, f, FS, min_gap_s=0.0)["termination"]["episodes"] == 3
    assert h["episodes"] == 1 and h["peak_force_n"] == pytest.approx(f.max())
    none = contact_summary(np.zeros(10), np.zeros(10), FS)
    assert none["termination"]["first_contact_s"] is None and none["hammer"]["episodes"] == 0
    with pytest.raises(ValueError, match="contacts has 10 samples and force_n 9"):
        contact_summary(np.zeros(10), np.zeros(9), FS)


def test_frames_hold_the_share_and_maxima():
    c = np.zeros(400)
    c[0:50] = 4
    f = np.zeros(400)
    f[250:300] = 7.0
    fr = contact_frames(c, f, FS, frame_s=0.001)           # 100-sample frames
    assert fr.shape == (4, 5)
    assert fr[0].tolist() == [0.0, 0.5, 4.0, 0.0, 0.0]
    assert fr[2, 3] == 0.5 and fr[2, 4] == 7.0


def _note(tmp_path, *args):
    log = tmp_path / "c.csv"
    r = subprocess.run([sys.executable, "-m", "synth.cli", "note", *args, "-o",
                        str(tmp_path / "n.wav"), "--contact-log", str(log)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return r.stdout, list(csv.DictReader(log.open()))


@pytest.mark.slow  # over 2 s on a quiet 2-core machine: ~2.5 s of CPU in its subprocesses
def test_the_biwa_touches_its_sawari_and_a_grand_note_logs_every_string(tmp_path):
    out, rows = _note(tmp_path, "paper/biwa-sawari", "--seconds", "0.0164")
    assert "string 0: termination" in out and "hammer 0.000 ms" in out
    assert max(int(r["termination_points_max"]) for r in rows) > 0
    out, rows = _note(tmp_path, "grand-piano", "--key", "60", "--seconds", "0.05")
    strings = {r["string"] for r in rows}
    assert strings == {"0", "1", "2", "3"}           # C4: three strings, the second polarization
    peak = [float(r["hammer_force_max_n"]) for r in rows]
    assert max(peak) > 1.0 and "termination 0.00 ms" in out   # no capo bar below C#5
