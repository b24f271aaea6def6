"""A note's strings set up in one kernel call (StringBank.configure_group)
write what the per-slot path writes (configure_from, set_damper, couple),
to the bit, from any state the slots were left in."""

import numpy as np
import pytest

from synth.dsp.groups import group_template
from synth.engine.engine import Event
from synth.io.factory import build_engine
from synth.voices.grand import BRIDGE_RETURN_HZ

TABLES = ("ring", "ipar", "fpar", "fst", "U", "damper", "_clean", "_leader", "_is_active")


def _per_slot(bank, slots, sus, pol, probe_row):
    """The reference: the slot-by-slot calls the grand's note-on made."""
    n = len(sus)
    for j, (slot, su) in enumerate(zip(slots, sus)):
        bank.configure_from(slot, su.slot, probe_row + j if probe_row >= 0 else -1)
        bank.set_damper(slot, su.damper)
    if sus[0].bridge is not None:
        bank.couple(slots[:n], sus[0].bridge[0], BRIDGE_RETURN_HZ, sus[0].bridge[1])
    if pol is not None:
        bank.configure_from(slots[n], pol.slot, probe_row + n if probe_row >= 0 else -1)
        bank.set_damper(slots[n], pol.damper)


def _dirty(key_before, probe):
    """A grand engine whose first voice played ``key_before`` for 20 ms
    (its slots sounding, on a bridge, their rings full)."""
    e = build_engine("grand-piano", (), threads=1, probe=probe)
    e.schedule([Event(0.0, "note_on", key_before, 0.8)])
    for _ in range(8):
        e.render_block(128)
    return e


@pytest.mark.parametrize("key_before,key,probe", [
    (60, 72, False),      # a trichord over a trichord, both with the second polarization
    (40, 60, False),      # over a bichord (its polarization slot never set up)
    (60, 30, False),      # a bichord without it over a trichord with it
    (96, 100, False),     # the capo keys on the finer grid
    (50, 64, True),       # with probes
])
def test_one_call_writes_what_the_per_slot_path_writes(key_before, key, probe):
    ref, got = _dirty(key_before, probe), _dirty(key_before, probe)
    inst = ref.inst
    sus, pol = inst.setup(key), inst.polar_setup(key)
    slots = tuple(range(len(sus) + (pol is not None)))
    probe_row = 0 if probe else -1
    _per_slot(ref.bank, slots, sus, pol, probe_row)
    got.bank.configure_group(slots, inst._group_of(key, sus, pol), probe_row)
    for name in TABLES:
        a, b = getattr(ref.bank, name), getattr(got.bank, name)
        assert a.dtype == b.dtype and np.array_equal(a, b, equal_nan=True), name
    assert ref.bank._members == got.bank._members
    assert ref.bank._open == got.bank._open


def test_a_bad_group_is_a_one_line_error():
    e = build_engine("grand-piano", (), threads=1)
    inst = e.inst
    sus = inst.setup(60)
    t = [su.slot for su in sus]
    with pytest.raises(ValueError, match="damper_rows: 2 for 3 templates"):
        group_template(t, [su.damper for su in sus][:2])
    with pytest.raises(ValueError, match="n_coupled = 4 is out of range"):
        group_template(t, [su.damper for su in sus], n_coupled=4)
    with pytest.raises(ValueError, match="resistance_ns_per_m = -1.0 is out of range"):
        group_template(t, [su.damper for su in sus], n_coupled=3, resistance_ns_per_m=-1.0)
    g = group_template(t, [su.damper for su in sus])
    with pytest.raises(ValueError, match="3 are needed, one per template"):
        e.bank.configure_group((0, 1), g)
    with pytest.raises(ValueError, match="slots = .* are out of range"):
        e.bank.configure_group((0, 0, 1), g)
