"""Constants repeated across synth's layers stay equal.

The physics layer may not import the kernels (tests/test_layers.py), so the
dispersion designs (synth.physics.dispersion) repeat the sizes the string
kernel (synth.kernels.layout) holds state for.  A design larger than the
kernel's state would be refused by the bank (synth.dsp.bank) at run time;
one smaller would leave the kernel's room unused.  These tests make a change
on one side fail until the other follows.
"""

from synth.io.presets.sections import SECTIONS
from synth.kernels import strings as K
from synth.physics import dispersion as D


def test_first_order_cascade_limit_is_the_kernel_s():
    """dispersion.M_LIMIT (most identical first-order sections a design may
    use) is the kernel's MAX_DISP (the sections it holds state for)."""
    assert D.M_LIMIT == K.MAX_DISP


def test_biquad_limit_is_the_kernel_s():
    """dispersion.MAX_SOS (most biquads a design may use) is the kernel's
    MAX_SOS (the biquads it holds state for)."""
    assert D.MAX_SOS == K.MAX_SOS


def test_preset_dispersion_sections_range_is_the_design_s():
    """A preset's strings.dispersion_sections (m_max of the first-order
    design) may go up to M_LIMIT and no further."""
    (strings,) = [s for s in SECTIONS if s.name == "strings"]
    (field,) = [f for f in strings.fields if f.name == "dispersion_sections"]
    assert (field.lo, field.hi) == (0, D.M_LIMIT)
