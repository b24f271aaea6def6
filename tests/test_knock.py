"""The action's knocks mixed block by block (synth.dsp.knock, synth.kernels.knock)
against the buffer the engine kept before: every note-on added its whole
scaled pulse to it, and every block read its head and shifted it on."""

from __future__ import annotations

import numpy as np
import pytest

from synth.dsp.knock import Knocks
from synth.physics.soundboard import knock_pulse


class BufferReference:
    """The engine's knocks as they were (engine.py before 2026-11-30)."""

    def __init__(self, unit, channels, max_block, lag=0):
        self.unit = unit
        self.tail = lag + len(unit)
        self.kb = np.zeros((channels, max_block + self.tail))
        self.w = np.empty_like(unit)
        self.knocking = False

    def add(self, j, gains):
        n = len(self.unit)
        for c, g in enumerate(gains):
            self.kb[c, j:j + n] += np.multiply(self.unit, g, out=self.w)
        self.knocking = True

    def cut(self, j):
        self.kb[:, j:] = 0.0

    def mix_into(self, d, n_out):
        kb, L = self.kb, self.tail
        d += kb[:, :n_out]
        kb[:, :L] = kb[:, n_out:n_out + L]
        kb[:, L:] = 0.0
        self.knocking = bool(kb[:, :L].any())
        return self.knocking


@pytest.mark.parametrize("channels", [1, 2])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_same_samples_as_the_buffer_for_any_blocks(channels, seed):
    rng = np.random.default_rng(seed)
    unit = knock_pulse(48000.0, 1.0, 0.002, 0.02 if seed else 0.0)
    unit[-3:] = 0.0                         # a tail of zeros: the knock ends before it
    MB, LAG = 300, 17
    ref = BufferReference(unit, channels, MB, LAG)
    new = Knocks(unit, channels, MB)
    t = 0
    flag_ref = flag_new = False
    for _ in range(400):
        n_out = int(rng.integers(1, MB + 1))
        # events within the block (as the engine's are: at most its length on,
        # and the decimator's latency): knocks (sometimes several at one
        # sample, some with a zero gain on one channel or on all), now and
        # then a cut
        for _ in range(int(rng.poisson(0.7))):
            j = int(rng.integers(0, n_out)) + LAG
            g = rng.uniform(0.0, 2.0, channels)
            if rng.random() < 0.1:
                g[0] = 0.0
            if rng.random() < 0.05:
                g[:] = 0.0
            ref.add(j, g)
            new.add(t + j, tuple(g))
            flag_ref = flag_new = True
        if rng.random() < 0.02:
            j = int(rng.integers(0, n_out)) + LAG
            ref.cut(j)
            new.cut(t + j)
        d_ref = rng.standard_normal((channels, n_out))
        d_ref[:, :2] = -0.0
        d_new = d_ref.copy()
        if flag_ref:
            flag_ref = ref.mix_into(d_ref, n_out)
        if flag_new:
            flag_new = new.mix_into(d_new, t, n_out)
        assert flag_new == flag_ref
        assert np.array_equal(d_new.view(np.int64), d_ref.view(np.int64))
        t += n_out


def test_a_view_of_wider_buses_and_a_list_that_grows():
    """The engine hands a view of its buses (rows MAX_BLOCK_OUT apart); more
    knocks at once than the list holds make it grow, in order."""
    import synth.dsp.knock as K

    unit = knock_pulse(48000.0, 1.0, 0.002, 0.0)
    ref = BufferReference(unit, 2, 256)
    new = Knocks(unit, 2, 256)
    for k in range(K.CAPACITY + 5):
        g = (1.0 + k * 1e-3, 0.5)
        ref.add(k % 200, g)
        new.add(k % 200, g)
    assert new.n == K.CAPACITY + 5
    wide_ref = np.zeros((2, 512))
    wide_new = np.zeros((2, 512))
    ref.mix_into(wide_ref[:, :200], 200)
    assert new.mix_into(wide_new[:, :200], 0, 200)
    assert np.array_equal(wide_new, wide_ref)


def test_bad_input_is_named():
    with pytest.raises(ValueError, match=r"channels = 3 is out of range"):
        Knocks(np.ones(8), 3, 64)
    with pytest.raises(ValueError, match=r"unit.ndim = 2"):
        Knocks(np.ones((2, 8)), 1, 64)
