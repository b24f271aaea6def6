"""tools/study_capo.py: the switch study on the numpy reference string
(the scheme of StringBank.hand_over) and its command line."""

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))

import study_capo as sc  # noqa: E402


def test_the_fitted_state_hands_over_where_a_zero_state_clicks():
    """Key 96 after 20 ms on the 1.3 MHz grid: with the far-end filter's
    state fitted, the coarse string's wave follows the fine one's within
    -55 dB over the first 2 ms, where a click would show (measured -61.6
    dB), and within -45 dB over 2-50 ms, where the two grids' own loop
    designs drift apart (-49.8 dB since the strings' own decay was fitted
    to a recorded grand's tails on 2026-11-27, -53.9 before; keys 84, 90
    and 105: -65 to -78 dB); with it zeroed, the filter's memory is lost
    and the wave is off by -6 dB."""
    r = sc.switch_errors(96, 98, 20.0)
    assert r["fit"][0] < -55.0 and r["fit"][1] < -45.0, r
    assert min(r["zero"]) > -20.0, r


@pytest.mark.parametrize("argv", [["switch", "--keys", "60"], ["window", "--ms", "0"],
                                  ["grid", "--grids", "9"], ["switch", "--velocity", "x"],
                                  ["cost", "--keys", "72"]])
def test_bad_arguments_exit_2_with_one_line(argv, capsys):
    with pytest.raises(SystemExit) as ex:
        sc.main(argv)
    assert ex.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err and "study_capo.py" in err[-1]


def test_the_hand_over_stops_the_bars_faint_contact_noise():
    """Key 96 at V = 5 m/s: before the hand-over the two renders are one
    (the same median between the partials over 8-18 ms); after it the
    fine grid's contacts go on leaving noise between the partials some 77
    dB under the loudest bin, the preset's strings, off the bar, 84 dB."""
    (fine, pre), _ = sc.contact_hash(96, 98)
    assert abs(fine[0] - pre[0]) < 0.5, (fine, pre)
    assert fine[1] < -70.0 and pre[1] < fine[1] - 3.0, (fine, pre)
