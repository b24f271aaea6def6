"""Issue 13: the work-precision tool's quick mode (CI): the hammer converges
at second order, the fast and per-sample paths agree to round-off, the
jawari's waveform error falls with the internal rate, and the capo study's
mode energies converge with the thesis's contacts on its grid."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from synth.apps import work_precision as wp

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow  # over 2 s on a quiet 2-core machine: the tool in a subprocess
def test_quick_mode_asserts_the_orders():
    """``python tools/work_precision.py --quick`` (the tool as its users run
    it): exit 0 when its own checks of the orders hold."""
    p = subprocess.run([sys.executable, str(ROOT / "tools" / "work_precision.py"), "--quick"],
                       capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert p.returncode == 0, p.stdout[-3000:] + p.stderr[-3000:]
    out = p.stdout
    assert "Observed orders against the finest grid: g(t)" in out
    assert "the two paths agree to" in out
    assert "## The capo study: mode levels" in out
    assert "## Against the thesis" in out


def test_orders_are_log2_of_successive_error_ratios():
    o = wp.orders([1.0, 0.25, 0.0625])
    assert abs(o[0] - 2) < 1e-12 and abs(o[1] - 2) < 1e-12


def test_capo_summary_leaves_out_the_strikes_node_and_its_neighbours():
    import numpy as np

    d = np.arange(1.0, 41.0)
    d[22] = np.nan                       # mode 23: a node at l = L/23
    d[20:25] += 100.0                    # modes 21-25 swing from grid to grid
    s = wp.capo_summary(d)
    assert s["mode4"] == 4.0 and s["mode1"] == 1.0 and s["low"] == 3.0
    assert s["gain"] == 40.0 and s["gain_mode"] == 40
    far = [m for m in range(6, 41) if not 21 <= m <= 25]
    assert s["median"] == float(np.median(far))
