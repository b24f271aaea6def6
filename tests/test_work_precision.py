"""Issue 13: the work-precision tool's quick mode (CI): the hammer converges
at second order, the fast and per-sample paths agree to round-off, and the
jawari's waveform error falls with the internal rate."""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))

import work_precision as wp  # noqa: E402


def test_quick_mode_asserts_the_orders(capsys):
    assert wp.main(["--quick"]) == 0
    out = capsys.readouterr().out
    assert "Observed orders against the finest grid: g(t)" in out
    assert "the two paths agree to" in out


def test_orders_are_log2_of_successive_error_ratios():
    o = wp.orders([1.0, 0.25, 0.0625])
    assert abs(o[0] - 2) < 1e-12 and abs(o[1] - 2) < 1e-12
