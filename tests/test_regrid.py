"""Issue 13: the re-gridding path. A study string re-gridded with
``--internal-rate`` keeps its obstacle: the termination region keeps its
length in metres (it kept 25 points, and above ~530 kHz jawari Case 1 was
cut short), and a profile edge that falls on a grid point is not dropped
by an ulp of rounding (the sawari's 10 mm at 96 kHz)."""

from __future__ import annotations

import numpy as np
import pytest

from synth.io.factory import build_voice
from synth.io.presets import load_preset
from synth.physics.profiles import EDGE_RTOL, Termination, jawari_case1, sawari

RATES = [96_000, 192_000, 324_800, 530_000, 800_000, 1_300_000]
#: the profiles with an end, and where it is (m)
EDGES = {"paper/sitar-case1": "x_c_m", "paper/biwa-sawari": "extent_m"}


def _setup(name, rate):
    v = build_voice(name, fs_internal=rate)
    su = v.setup(v.preset.play.key_low if v.preset.play is not None else 60)
    return v, su, su.string.c_m_per_s * su.dt_s


@pytest.mark.parametrize("name", ["paper/sitar-case1", "paper/sitar-case2", "paper/sitar-case3",
                                  "paper/biwa-sawari"])
@pytest.mark.parametrize("rate", RATES)
def test_the_region_keeps_its_length_in_metres(name, rate):
    p = load_preset(name)
    L = p.string.length_m
    design_m = p.termination.region_points * L / p.grid.cells
    v, su, dx = _setup(name, rate)
    n = v.termination.points
    # the string's region: those points (within its first third), less the
    # trailing ones out of reach (+inf: past the profile's end)
    full = v.termination.sample(dx)[: max(1, min(n, su.cells // 3))]
    assert su.U is not None and np.array_equal(su.U, full[:len(su.U)])
    assert np.all(np.isinf(full[len(su.U):])) and np.isfinite(su.U[-1])
    # covers the design length, and not more than one cell beyond it
    assert n * dx >= design_m * (1 - 1e-9)
    assert (n - 1) * dx < design_m * (1 + 1e-9)


@pytest.mark.parametrize("name", sorted(EDGES))
@pytest.mark.parametrize("rate", RATES)
def test_the_whole_obstacle_at_every_rate(name, rate):
    """Every grid point up to the profile's end touches (finite U), and at
    1.3 MHz Case 1's 15 mm are all there (6.2 mm before)."""
    p = load_preset(name)
    edge = getattr(p.termination, EDGES[name])
    v, su, dx = _setup(name, rate)
    U = v.termination.sample(dx)
    x = dx * np.arange(1, len(U) + 1)
    inside = x <= edge * (1 + EDGE_RTOL)
    assert x[-1] >= edge - dx            # the region reaches the end
    assert np.all(np.isfinite(U[inside]))
    assert np.all(np.isinf(U[~inside]))


def test_an_edge_on_a_grid_point_is_kept():
    """x = n dx computed as c dt an ulp beyond the edge still touches."""
    s = 0.01
    dx = s / 7 * (1 + 2.2e-16)           # point 7 is an ulp or so beyond 10 mm
    assert 7 * dx > s
    for prof, side in ((sawari(2.0, s), -1), (jawari_case1(0.008, s), 1)):
        U = Termination(prof, side, 10).sample(dx)
        assert np.isfinite(U[6]) and np.isinf(U[7])


def test_the_sawari_edge_at_96_khz():
    """The issue's case: the biwa's sawari (s = 10 mm) re-gridded to 96 kHz,
    240 cells of 3.33 mm: x = 3 dx is the sawari's last point, whichever
    way c dt rounds (here 9.999999999999998 mm; the issue saw an ulp over)."""
    v, su, dx = _setup("paper/biwa-sawari", 96_000)
    s = v.preset.termination.extent_m
    assert abs(3 * dx - s) <= 1e-12 * s
    U = v.termination.sample(dx)
    assert np.isfinite(U[:3]).all() and np.isinf(U[3:]).all()
    # and with dx an ulp larger, as the issue computed it
    U = v.termination.sample(np.nextafter(s / 3, 1.0))
    assert np.isfinite(U[:3]).all()


def test_the_design_rate_is_unchanged():
    """At its own rate a preset's region is its region_points."""
    for name in ("paper/sitar-case1", "paper/biwa-sawari", "sitar", "biwa"):
        v = build_voice(name)
        assert v.termination.points == load_preset(name).termination.region_points


def test_a_musical_preset_scales_from_325_khz():
    v = build_voice("sitar", fs_internal=650_000)
    assert v.termination.points == 2 * load_preset("sitar").termination.region_points


def test_rate_scale_out_of_range_is_one_clear_error():
    with pytest.raises(ValueError, match="rate_scale"):
        Termination(sawari(2.0, 0.01), -1, 10, rate_scale=0.0)


def test_points_out_of_reach_are_trimmed_and_the_samples_do_not_change():
    """``trim_unreachable`` drops a region's trailing +-inf points (past a
    profile's end); the string's samples stay the same to round-off, and
    a region no point of which can be touched is none at all."""
    from synth.dsp.bank import StringBank
    from synth.kernels import strings as K
    from synth.physics.profiles import trim_unreachable

    U = np.array([1e-4, 2e-4, 4e-4, np.inf, np.inf, np.inf, np.inf])
    assert trim_unreachable(U).tolist() == [1e-4, 2e-4, 4e-4]
    assert trim_unreachable(-U)[-1] == -4e-4
    assert trim_unreachable(np.full(5, np.inf)) is None and trim_unreachable(None) is None
    dx, dt = 1e-3, 1e-5
    outs = []
    for region in (U, trim_unreachable(U)):
        b = StringBank(1, 400, 16, 1024)
        b.configure(0, cells=300, k=200, dt_s=dt, U=(region - 3e-4), out_mode=0, lossy=True,
                    b0=0.999, a1=-0.01, eta=0.1)
        b.activate(0)
        b.start_pluck(0, K.EXC_SITAR, 0.002, 0.0008)
        y = np.zeros(6000)
        for o in range(0, 6000, 500):
            b.render(y, o, 500)
        outs.append(y)
        assert b.ipar[0, K.I_REG_N] == len(region)
    assert np.max(np.abs(outs[0] - outs[1])) < 1e-12 * np.max(np.abs(outs[0]))
