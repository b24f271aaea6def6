"""Quality levels (issue 13 section 2): draft, standard and reference, as a
preset key (``play.quality``) and as ``--quality`` / ``--max-error`` on
``note``, ``render`` and ``play``; each level's error is measured by
tools/quality_levels.py (docs/quality.md)."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from helpers import cli
from synth.io.factory import build_voice
from synth.io.presets import QUALITIES, load_preset
from synth.voices import quality as Q

ROOT = Path(__file__).resolve().parents[1]


def _synth(*args):
    return subprocess.run([sys.executable, "-m", "synth.cli", *args], capture_output=True,
                          text=True, cwd=ROOT, timeout=600)


def test_the_levels_are_the_schemas_choices_cheapest_first():
    assert QUALITIES == tuple(lv.name for lv in Q.LEVELS)
    assert load_preset("biwa").play.quality == Q.DEFAULT == "standard"
    rates = [lv.rate_factor for lv in Q.LEVELS]
    assert rates == sorted(rates) and Q.BY_NAME["standard"].rate_factor == 1.0
    costs = [lv.cost for lv in Q.LEVELS]
    assert costs == sorted(costs) and Q.BY_NAME["standard"].cost == 1.0
    # measured for every shipped musical preset, in its own data; over them
    # all, the finer the level the smaller its worst error
    from synth.io.presets import list_presets
    from synth.io.presets.quality import shipped_worst_errors

    musical = [load_preset(n) for n, _ in list_presets() if load_preset(n).kind == "musical"]
    assert musical and all(p.quality_error is not None for p in musical), \
        [p.name for p in musical if p.quality_error is None]
    worst = shipped_worst_errors()
    assert all(math.isfinite(v) for lv in Q.LEVELS for v in worst[lv.name])
    for a, b in zip(Q.LEVELS, Q.LEVELS[1:]):
        assert worst[b.name][0] < worst[a.name][0] and worst[b.name][1] < worst[a.name][1]


def test_a_level_sets_the_rate_and_the_stiffness_filters():
    assert build_voice("sitar", ["play.quality=draft"]).fs == 162_500.0
    assert build_voice("sitar").fs == 325_000.0
    assert build_voice("sitar", ["play.quality=reference"]).fs == 650_000.0
    # an explicit internal rate wins over the level's
    assert build_voice("biwa", ["play.quality=draft"], fs_internal=400_000.0).fs == 400_000.0
    g = build_voice("grand-piano", ["play.quality=reference"])
    assert g.quality.dispersion_tol_cents == 0.5
    std = build_voice("grand-piano")
    from synth.voices.grand import DISPERSION_TOL_CENTS

    assert std.quality.dispersion_tol_cents == DISPERSION_TOL_CENTS
    # the finer tolerance takes more sections somewhere in the bass
    n_ref = sum(len(s.sos) for k in (24, 30, 36) for s in build_voice(
        "grand-piano", ["play.quality=reference"], fs_internal=325_000.0).setup(k))
    n_std = sum(len(s.sos) for k in (24, 30, 36) for s in std.setup(k))
    assert n_ref > n_std


def test_max_error_picks_the_cheapest_level_within_the_budget(tmp_path):
    from synth.io.presets.quality import level_within, measured_errors, shipped_worst_errors

    d, s, r = Q.LEVELS
    assert level_within(1e3, 1e3) is d
    # per preset, from its [quality_error]: the grand needs the reference's
    # finer stiffness filters for 1 cent
    grand = load_preset("grand-piano")
    assert measured_errors("grand-piano") == (grand.quality_error.table(), "for grand-piano")
    assert grand.quality_error.of("standard") == (grand.quality_error.standard_cents,
                                                  grand.quality_error.standard_db)
    assert level_within(1.0, 1.0, "grand-piano") is r
    assert level_within(*load_preset("sitar").quality_error.of("standard"), "sitar") is s
    # a preset not measured (or not found): the worst over the shipped ones
    worst = shipped_worst_errors()
    assert measured_errors("my-own") == (worst, "(the worst over the shipped presets)")
    own = tmp_path / "own.toml"
    own.write_text("\n".join(line for line in
                             (ROOT / "synth/presets/biwa.toml").read_text().splitlines()
                             if not line.startswith(("draft_", "standard_", "reference_",
                                                     "[quality_error]"))))
    assert load_preset(str(own)).quality_error is None
    assert measured_errors(str(own))[0] == worst
    # a .toml path is read as it is (its own table), not by its stem
    assert measured_errors(str(ROOT / "synth/presets/biwa.toml"))[1] == "for biwa"
    with pytest.raises(ValueError, match="no level is that accurate for sitar"):
        level_within(0.01, 0.01, "sitar")
    with pytest.raises(ValueError, match="is out of range"):
        level_within(0.0, 1.0)
    with pytest.raises(ValueError, match="is out of range"):
        Q.cheapest_within(1.0, -1.0, worst, "for x")
    with pytest.raises(ValueError, match="quality = 'fast' is not allowed"):
        Q.quality_level("fast")


def test_the_command_line_options(tmp_path, capsys):
    """In this process (synth.cli.main, as the console script calls it): 16
    commands as subprocesses took 11 s, each importing numba and loading the
    kernels again."""
    def _synth(*args):
        return cli(capsys, *args)

    out = tmp_path / "n.wav"
    p = _synth("note", "biwa", "--key", "50", "--seconds", "0.2", "--quality", "draft",
               "-o", str(out))
    assert p.returncode == 0, p.stderr
    assert "internal rate 162500.0 Hz (draft)" in p.stdout
    p = _synth("note", "biwa", "--key", "50", "--seconds", "0.2", "--max-error", "1000,1000",
               "-o", str(out))
    assert p.returncode == 0 and "(draft)" in p.stdout
    # the biwa's [quality_error]: draft 0.07 cents / 0.30 dB, standard 0.05 / 0.87,
    # reference 0.02 / 0.14: the cheapest level within both
    p = _synth("note", "biwa", "--key", "50", "--seconds", "0.2", "--max-error", "0.06,1",
               "-o", str(out))
    assert p.returncode == 0 and "(standard)" in p.stdout
    p = _synth("note", "biwa", "--key", "50", "--seconds", "0.2", "--max-error", "0.03,0.2",
               "-o", str(out))
    assert p.returncode == 0 and "(reference)" in p.stdout
    for args, msg in [
        (["--quality", "draft", "--max-error", "1,1"], "--quality and --max-error are exclusive"),
        (["--max-error", "1"], "--max-error = '1' is not CENTS,DB"),
        (["--max-error", "0.00001,0.00001"], "no level is that accurate"),
        (["--quality", "fast"], "invalid choice: 'fast'"),
    ]:
        p = _synth("note", "biwa", "--key", "50", "--seconds", "0.2", *args, "-o", str(out))
        assert p.returncode == 2 and msg in p.stderr.strip().splitlines()[-1], (args, p.stderr)
        if "invalid choice" not in msg:                      # (argparse prints its usage first)
            assert len(p.stderr.strip().splitlines()) == 1
    # a study preset runs on the thesis's grid
    p = _synth("note", "paper/sitar-case1", "--quality", "draft", "-o", str(out))
    assert p.returncode == 2 and "play.quality" in p.stderr and "study" in p.stderr
    for cmd in (["render", "x.mid", "--preset", "sitar", "-o", "y.wav"], ["play"]):
        assert "--max-error" in _synth(*cmd, "--help").stdout


@pytest.mark.slow  # over 2 s on a quiet 2-core machine
def test_the_levels_study_runs_in_its_quick_mode():
    """tools/quality_levels.py notes --quick (docs/quality.md): the
    reference level is the closest to the converged note."""
    p = subprocess.run([sys.executable, str(ROOT / "tools" / "quality_levels.py"), "notes",
                        "--quick"], capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert p.returncode == 0, p.stderr
    rows = {}
    for line in p.stdout.splitlines():
        f = [c.strip() for c in line.strip("|").split("|")]
        if len(f) == 8 and f[0] == "sitar":
            rows[f[2]] = (float(f[4]), float(f[5]))
    assert set(rows) == {"draft", "standard", "reference"}
    assert rows["reference"][0] < rows["standard"][0] and rows["reference"][1] < rows["standard"][1]
    assert np.all(np.isfinite(list(rows.values())))
