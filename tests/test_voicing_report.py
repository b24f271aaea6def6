"""tools/voicing_report.py: its measures (synth.analysis) and table
(synth.apps.voicing) on closed-form signals, and the quick report end to
end (the tool run as a program)."""

import importlib.util
import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from synth.analysis import attack_centroid_hz, max_momentary_lufs
from synth.apps import voicing as vr

ROOT = Path(__file__).resolve().parents[1]
#: the five piano files' folder the report reads by default (beside the repository)
DEFAULT_MIDI_DIR = ROOT.parent / "shared" / "midi"
FS = 48_000


def test_the_attack_centroid_of_a_sine_is_its_frequency():
    """A sine that starts from silence within 2 ms (as a note does) reads its
    frequency; switched on at once, its onset is a broadband kink and counts
    (the measure keeps the attack at full weight)."""
    t = np.arange(FS) / FS
    fade = np.minimum(1.0, 0.5 - 0.5 * np.cos(np.pi * np.minimum(t / 0.002, 1.0)))
    assert attack_centroid_hz(fade * np.sin(2 * np.pi * 1000 * t), FS) == pytest.approx(1000, rel=0.005)
    # only the first 100 ms count
    y = fade * np.where(t < 0.1, np.sin(2 * np.pi * 500 * t), np.sin(2 * np.pi * 5000 * t))
    assert attack_centroid_hz(y, FS) == pytest.approx(500, rel=0.02)
    assert attack_centroid_hz(np.sin(2 * np.pi * 1000 * t), FS) > 1200


def test_max_momentary_loudness_is_not_gated():
    """A 1 kHz sine of amplitude a reads -3.01 + 20 log10(a) + 0.691 - 0.691
    (K weighting is ~0 dB at 1 kHz) however quiet: the absolute gate of
    BS.1770 would read -inf below -70 LUFS."""
    t = np.arange(FS) / FS
    loud = max_momentary_lufs(0.5 * np.sin(2 * np.pi * 1000 * t), FS)
    quiet = max_momentary_lufs(0.5e-4 * np.sin(2 * np.pi * 1000 * t), FS)
    assert quiet == pytest.approx(loud - 80.0, abs=1e-6)
    assert loud == pytest.approx(20 * np.log10(0.5) - 3.01, abs=0.1)
    assert max_momentary_lufs(np.zeros(FS), FS) == -np.inf


def test_the_law_has_partial_1_at_the_tuning_and_stops_at_40_or_10_khz():
    from synth.physics.piano import grand_string

    f0, B, n = vr.law_partials(21, 27.4)
    assert f0 * np.sqrt(1 + B) == pytest.approx(27.4)
    assert B == grand_string(21).inharmonicity_b and n == 40
    f0, B, n = vr.law_partials(96, 2100.0)
    assert n == 4                                   # the 5th is above 10 kHz
    assert vr.law_partials(108, 4200.0)[2] == 2


def test_a_stereo_render_is_averaged_for_mono_measures():
    y = np.stack([np.ones(4), 3 * np.ones(4)], axis=1)
    assert np.allclose(vr.mono(y), 2.0)
    assert len(vr.channels(y)) == 2 and len(vr.channels(np.ones(4))) == 1


def test_the_table_lists_every_row_and_its_details():
    rows = [vr.Row("dynamics", "C4 range", "22.4 dB", ">= 35 dB", "FAIL", 22.4, "from -40 to -18"),
            vr.Row("pedal", "halo", "bit-identical", "a difference", "INFO")]
    txt = vr.format_table(rows)
    assert "FAIL  C4 range" in txt and ">= 35 dB [1]" in txt and "[1] from -40 to -18" in txt
    assert "0 passed, 1 failed, 1 for information, 0 skipped" in txt


@pytest.mark.slow  # ~15 s on a quiet 2-core machine: ~100 notes and 5 x 4 s of the MIDI files
def test_the_quick_report_runs_and_prints_its_table(tmp_path):
    out = tmp_path / "r.json"
    # the plots need the [plots] extra: without matplotlib the report runs
    # without them (and says so when asked for them, test below)
    plots = importlib.util.find_spec("matplotlib") is not None
    p = subprocess.run([sys.executable, str(ROOT / "tools" / "voicing_report.py"), "--quick", "--silent",
                        "--json", str(out)] + (["--plots", str(tmp_path / "img")] if plots else []),
                       capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert p.returncode == 0, p.stderr
    targets = ["C4 loudness, velocity 1 to 127", "partials 2-8", "adjacent keys", "smooth fit",
               "keys 97-108", "T60 of partial 1, keys 100-108", "two-stage decay", "staccato",
               "halo", "una corda", "partial 1 against the tuning curve", "stiff-string law",
               "bench grand"]
    # the five piano files live beside the repository (../shared/midi), not in
    # it: a checkout without them reports the MIDI rows as skipped
    if all((DEFAULT_MIDI_DIR / f).is_file() for f in vr.MIDI_FILES):
        targets += ["sample peak", "click scan", "stuck notes"]
    else:
        assert re.search(r"SKIP +MIDI files +5 missing", p.stdout), p.stdout
    for target in targets:
        assert target in p.stdout, target
    assert "passed," in p.stdout and "failed," in p.stdout
    r = json.loads(out.read_text())
    assert r["schema"] == 1 and r["quick"] is True
    assert {row["status"] for row in r["rows"]} <= {"PASS", "FAIL", "INFO", "SKIP"}
    assert len(r["data"]["keyboard"]["loudness_lufs"]["80"]) == len(vr.QUICK_KEYS)
    if plots:
        pngs = sorted((tmp_path / "img").glob("*.png"))
        assert len(pngs) == 5 and all(png.stat().st_size < 100_000 for png in pngs)


def test_plots_without_matplotlib_is_one_line_before_any_work(tmp_path):
    """--plots without the [plots] extra stops at once with the install hint
    (a module path whose ``matplotlib`` cannot be found stands in for a
    machine without it)."""
    hide = tmp_path / "hide"
    hide.mkdir()
    (hide / "sitecustomize.py").write_text("import sys\nsys.modules['matplotlib'] = None\n")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(hide), str(ROOT)]))
    t = time.perf_counter()
    p = subprocess.run([sys.executable, str(ROOT / "tools" / "voicing_report.py"), "--quick",
                        "--plots", str(tmp_path / "img")], capture_output=True, text=True,
                       cwd=tmp_path, env=env, timeout=120)
    assert p.returncode == 2
    assert p.stderr.strip().splitlines() == [
        'error: --plots needs the [plots] extra: pip install "synth[plots]"']
    assert time.perf_counter() - t < 60          # no notes were rendered
    assert not (tmp_path / "img").exists()


def test_an_earlier_report_is_a_column():
    rows = [vr.Row("dynamics", "C4 range", "30.1 dB", ">= 35 dB", "FAIL", 30.1),
            vr.Row("pedal", "new row", "x", "", "INFO")]
    txt = vr.format_table(rows, before={("dynamics", "C4 range"): "22.4 dB"})
    head = txt.splitlines()[0]
    assert head.split() == ["target", "before", "measured", "limit"]
    assert "22.4 dB" in txt.splitlines()[2] and "30.1 dB" in txt.splitlines()[2]
    assert txt.splitlines()[3].split()[3] == "-"            # not in the earlier report
