"""Output rows (``I_ROW``, :meth:`StringBank.set_output_row`): a slot adds its
buses to the rows of a taller mix from its own row on, the same samples as
in rows 0 and 1."""

import numpy as np
import pytest

from synth.dsp.bank import StringBank
from synth.io.factory import build_engine
from synth.kernels import strings as K
from synth.physics import profiles as P

BLOCK = 997          # segments of a render (not a divisor of anything)


def _render(bank, rows, n, mix=None, o0=0):
    """n samples of ``bank`` into a new mix of ``rows`` rows (or into
    ``mix`` from o0), in segments of BLOCK."""
    if mix is None:
        mix = np.zeros((rows, n))
    for o in range(o0, o0 + n, BLOCK):
        bank.render(mix, o, min(BLOCK, o0 + n - o))
    return mix


def _assert_moved(ref, got, r):
    """``got`` holds ``ref`` (its 1 or 2 rows) bitwise from row r on and
    nothing in its other rows."""
    assert np.any(ref)
    np.testing.assert_array_equal(got[r:r + ref.shape[0]], ref)
    rest = np.ones(got.shape[0], dtype=bool)
    rest[r:r + ref.shape[0]] = False
    assert not np.any(got[rest])


def _set_rows(bank, r):
    for s in bank.active[:bank.n_active]:
        bank.set_output_row(int(s), r)


# ---- strings set up on a bank of their own -------------------------------------

def _jawari(per_sample, pan=None):
    """A sitar-like lossless string (N = 812 at 324.8 kHz) plucked against
    a 25-point jawari Case 2 termination."""
    dx = 0.8 / 812
    U = P.Termination(P.jawari_case2(0.008, 0.010, 0.010), 1, 25).sample(dx)
    b = StringBank(1, 814, 25, 1024)
    b.configure(0, cells=812, k=609, dt_s=1.0 / 324800.0, U=U, side=1,
                force_per_sample=per_sample, pan=pan)
    b.activate(0)
    b.start_pluck(0, K.EXC_SITAR, 0.01, 0.004)
    return b


def _hammered(per_sample, pan=0.3):
    """A lossy, dispersive string struck by a felt hammer, bridge-force
    output split between two buses by ``pan``."""
    b = StringBank(1, 302, 1, 1024)
    b.configure(0, cells=300, k=40, dt_s=1e-5, U=None, lossy=True, b0=0.99, a1=-0.01,
                eta=0.2, out_mode=1, tension_over_dx=1e4, n_disp=4, a_disp=-0.3, pan=pan,
                force_per_sample=per_sample)
    b.activate(0)
    b.start_hammer(0, law=4, mass_kg=0.008, speed_m_per_s=2.0, stiffness=1e4, exponent=2.5,
                   alpha_or_gamma=1e-5, tau0_s=0.0, tension_n=700.0, c_m_per_s=300.0)
    return b


@pytest.mark.parametrize("per_sample", [False, True], ids=["fast", "per-sample"])
@pytest.mark.parametrize("r,rows", [(3, 5), (4, 5)])
def test_plucked_jawari_string_on_its_row(per_sample, r, rows):
    n = 4000                         # the pluck (4 ms = 1300 samples) and the contacts after it
    ref = _render(_jawari(per_sample), 1, n)
    b = _jawari(per_sample)
    b.set_output_row(0, r)
    _assert_moved(ref, _render(b, rows, n), r)


@pytest.mark.parametrize("per_sample", [False, True], ids=["fast", "per-sample"])
@pytest.mark.parametrize("make", [_hammered, lambda ps: _jawari(ps, pan=0.3)],
                         ids=["hammered", "plucked"])
def test_two_buses_on_their_rows(per_sample, make):
    """Bus 0 to row r, bus 1 to row r + 1; a mix whose last row is r takes
    all of it there, as a one-row mix takes it in row 0."""
    n = 3000
    ref2 = _render(make(per_sample), 2, n)
    ref1 = _render(make(per_sample), 1, n)
    assert np.any(ref2[1])
    b = make(per_sample)
    b.set_output_row(0, 2)
    _assert_moved(ref2, _render(b, 6, n), 2)
    b = make(per_sample)
    b.set_output_row(0, 5)
    _assert_moved(ref1, _render(b, 6, n), 5)


def test_two_strings_on_two_rows_sum_to_one_row():
    """Two slots on rows 1 and 3 hold, summed, what they give together on
    row 0 (to round-off: the order of the sums differs)."""
    dx = 0.8 / 812
    U = P.Termination(P.jawari_case2(0.008, 0.010, 0.010), 1, 25).sample(dx)

    def bank():
        b = StringBank(2, 814, 25, 1024)
        b.configure(0, cells=812, k=609, dt_s=1.0 / 324800.0, U=U, side=1)
        b.configure(1, cells=700, k=500, dt_s=1.0 / 324800.0, U=U, side=1, lossy=True,
                    b0=0.999, out_mode=1, tension_over_dx=1e4)
        for s in (0, 1):
            b.activate(s)
        b.start_pluck(0, K.EXC_SITAR, 0.01, 0.004)
        b.start_pluck(1, K.EXC_SITAR, 0.004, 0.002)
        return b

    n = 4000
    ref = _render(bank(), 1, n)
    b = bank()
    b.set_output_row(0, 1)
    b.set_output_row(1, 3)
    got = _render(b, 4, n)
    assert np.any(got[1]) and np.any(got[3]) and not np.any(got[[0, 2]])
    np.testing.assert_allclose(got[1] + got[3], ref[0], rtol=0, atol=1e-15 * np.max(np.abs(ref)))


# ---- voices of the shipped instruments, through their own code ----------------

def _voice(preset, key, vel=0.8, telemetry=False):
    """An engine with ``key`` struck on its first voice's slots (as
    Engine._apply does, the taraf's bridge joined where it has one);
    ``telemetry`` on its first slot puts its coupled group on the
    per-sample path (:func:`strings._coupled_per_sample`)."""
    eng = build_engine(preset, ())
    slots = tuple(range(eng.spv))          # voice 0's slots (Engine._slots)
    if eng.taraf is not None:
        eng.taraf.wake()
    eng.inst.note_on(eng.bank, slots, key, vel)
    if eng.taraf is not None:
        eng.taraf.join(slots)
    if telemetry:
        eng.bank.set_telemetry(slots[0], True)
    # the strings the note sounds (a grand key outside the second
    # polarization's range leaves its slot unused)
    return eng, tuple(s for s in slots if eng.bank.is_active(s))


PATHS = pytest.mark.parametrize("telemetry", [False, True], ids=["chunks", "per-sample"])


@PATHS
def test_grand_unison_on_its_rows(telemetry):
    """A mid key's coupled unison, two buses (lockstep chunks with the
    hammers stepped together, then the lanes' loop filters; or per
    sample)."""
    n = 6000
    eng, slots = _voice("grand-piano", 60, telemetry=telemetry)
    assert len(eng.bank.group(slots[0])) > 1 and eng.bank.ipar[slots[0], K.I_BUS] == 1
    ref = _render(eng.bank, 2, n)
    assert np.any(ref[1])
    eng, _ = _voice("grand-piano", 60, telemetry=telemetry)
    _set_rows(eng.bank, 5)
    _assert_moved(ref, _render(eng.bank, 8, n), 5)


@PATHS
def test_grand_treble_on_a_finer_grid_and_after_its_hand_over(telemetry):
    """A treble key struck on its finer grid (staged in ``bank.sub``), then
    handed over to the engine's grid: its row stays, the same samples."""
    key = 88
    eng, slots = _voice("grand-piano", key, telemetry=telemetry)
    assert eng.bank.grid_of(slots[0]) > 1

    def run(eng, rows):
        n0 = int(0.022 * 325000)            # past the 20 ms window
        mix = np.zeros((rows, n0 + 3000))
        _render(eng.bank, rows, n0, mix)
        o = n0
        while not eng.inst.leave_fine_grid(eng.bank, slots, key):
            _render(eng.bank, rows, 100, mix, o)
            o += 100
        assert eng.bank.grid_of(slots[0]) == 1
        _render(eng.bank, rows, mix.shape[1] - o, mix, o)
        return mix

    ref = run(eng, 2)
    eng, _ = _voice("grand-piano", key, telemetry=telemetry)
    _set_rows(eng.bank, 3)
    got = run(eng, 7)
    assert all(eng.bank.output_row(s) == 3 for s in slots)
    _assert_moved(ref, got, 3)


@PATHS
def test_finer_grid_group_across_rows_sums_to_one_row(telemetry):
    """The members of one coupled group on a finer grid on rows 1, 3 and 5
    (buses 0 there, buses 1 on rows 2, 4 and 6; the staging mix grows to
    the group's span of rows)."""
    n = 3000
    eng, slots = _voice("grand-piano", 88, telemetry=telemetry)
    ref = _render(eng.bank, 2, n)
    eng, slots = _voice("grand-piano", 88, telemetry=telemetry)
    assert len(slots) == 3 and eng.bank.grid_of(slots[0]) > 1
    for s, r in zip(slots, (1, 3, 5)):
        eng.bank.set_output_row(s, r)
    assert eng.bank.sub.shape[0] >= 6
    got = _render(eng.bank, 7, n)
    assert not np.any(got[0])
    for r in range(1, 7):
        assert np.any(got[r])
    tol = 1e-14 * np.max(np.abs(ref))
    np.testing.assert_allclose(got[1] + got[3] + got[5], ref[0], rtol=0, atol=tol)
    np.testing.assert_allclose(got[2] + got[4] + got[6], ref[1], rtol=0, atol=tol)


@PATHS
def test_sitar_voice_and_taraf_on_their_rows(telemetry):
    """The sitar's played string (jawari, sub-cell contact) and its taraf on
    one open bridge: all on row 2 gives row 0's samples bitwise; the
    played string on row 1 and the taraf on row 3 sum to them."""
    n = 6000
    eng, slots = _voice("sitar", 62, telemetry=telemetry)
    taraf = [s for s in eng.taraf.slots if eng.bank.is_active(s)]
    assert len(eng.bank.group(eng.taraf.lead)) == len(taraf) + len(slots)
    ref = _render(eng.bank, 1, n)
    eng, _ = _voice("sitar", 62, telemetry=telemetry)
    _set_rows(eng.bank, 2)
    _assert_moved(ref, _render(eng.bank, 4, n), 2)
    eng, _ = _voice("sitar", 62, telemetry=telemetry)
    for s in slots:
        eng.bank.set_output_row(s, 1)
    for s in taraf:
        eng.bank.set_output_row(s, 3)
    got = _render(eng.bank, 4, n)
    assert np.any(got[1]) and np.any(got[3]) and not np.any(got[[0, 2]])
    np.testing.assert_allclose(got[1] + got[3], ref[0], rtol=0,
                               atol=1e-14 * np.max(np.abs(ref)))


# ---- the row as the slot's, and the checks --------------------------------------

def test_row_stays_with_the_slot():
    b = StringBank(3, 102, 1, 256)
    assert b.output_row(1) == 0 and b.mix_rows == 1
    b.set_output_row(1, 4)
    b.set_output_row(2, 2)
    assert b.mix_rows == 5
    b.configure(1, cells=100, k=25, dt_s=1e-5, U=None, pan=0.5)
    b.activate(1)
    b.deactivate(1)
    b.configure(1, cells=90, k=20, dt_s=1e-5, U=None)
    assert b.output_row(1) == 4
    b.set_output_row(1, 0)
    assert b.mix_rows == 3                 # slot 2's row is the highest now
    b.set_output_row(2, 0)
    assert b.mix_rows == 1


@pytest.mark.parametrize("row", [-1, 1.5, StringBank.MAX_ROW + 1, "2", None])
def test_bad_row_is_refused(row):
    b = StringBank(2, 102, 1, 256)
    with pytest.raises(ValueError,
                       match=r"^row = .* is out of range \(integer, 0 <= value <= 255\)$"):
        b.set_output_row(0, row)
    assert b.output_row(0) == 0 and b.mix_rows == 1


def test_bad_slot_is_refused():
    b = StringBank(2, 102, 1, 256)
    with pytest.raises(ValueError, match=r"^s = 2 is out of range \(integer, 0 <= value <= 1\)$"):
        b.set_output_row(2, 1)


def test_render_refuses_a_mix_without_the_slots_rows():
    """The kernel does not check bounds: a mix without some slot's row is
    refused, whether or not that slot is active."""
    b = StringBank(2, 102, 1, 256)
    b.configure(0, cells=100, k=25, dt_s=1e-5, U=None)
    b.activate(0)
    b.start_pluck(0, K.EXC_SITAR, 1e-3, 1e-3)
    b.set_output_row(1, 2)
    with pytest.raises(ValueError, match=r"^mix rows = 2 is out of range \(value >= 3"):
        b.render(np.zeros((2, 100)), 0, 100)
    with pytest.raises(ValueError, match=r"^mix rows = 1 is out of range \(value >= 3"):
        b.render(np.zeros(100), 0, 100)
    mix = np.zeros((3, 100))
    b.render(mix, 0, 100)
    assert np.any(mix[0]) and not np.any(mix[1:])


def test_a_panned_channels_path_is_a_fresh_copy_of_the_engines_design():
    """The output path a pan controller makes in the audio callback copies
    the engine's decimators and body (sharing their read-only designs, with
    fresh state) instead of designing new ones, which took about 25 ms in
    the callback: the copies give the samples new designs give, and touch
    nothing of the engine's own."""
    from synth.dsp.body import Body
    from synth.dsp.decimator import Decimator
    from synth.engine.mixing import OutputPath
    from synth.io.factory import build_engine

    eng = build_engine("grand-piano")
    x = np.random.default_rng(3).standard_normal((2, 3250))
    eng.decs[0].process(x[0])                          # the engine's own state moves on
    path = OutputPath(eng)
    new_dec = Decimator(eng.fs_in, eng.fs_out)
    new_dec._state[:] = eng.decs[0]._state
    np.testing.assert_array_equal(path.decs[0].process(x[1]), new_dec.process(x[1]))
    assert path.decs[0].phases is eng.decs[0].phases and path.decs[0]._hist is not eng.decs[0]._hist
    new_body = Body.from_design(eng.fs_out, eng.inst.body())
    y = np.random.default_rng(4).standard_normal((eng.body.inputs, 480))
    y1 = y[0] if eng.body.inputs == 1 else y
    np.testing.assert_array_equal(path.body.process(y1.copy()), new_body.process(y1.copy()))
    assert not np.any(eng.body._state) and path.body._state is not eng.body._state
