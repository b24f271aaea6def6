"""The radiation's spread as a streaming stage: the allpass cascade of
:func:`synth.physics.soundboard.spread_allpasses` on 1 or 2 channels.

:class:`Spread` validates and holds the state; the kernel is
:func:`synth.kernels.spread.allpass_cascade`.  Gain 1 at every frequency
(a steady partial keeps its level), zero latency (the first sample of the
response is g^3 of the input), blocks of any length give the one-shot
result, no allocation per block.  :class:`synth.dsp.body.Body` runs one on
its outputs when its design has a ``spread_ms``.
"""

from __future__ import annotations

import numpy as np

from synth.dsp.signal import in_place_rows
from synth.kernels.spread import allpass_cascade as _kernel
from synth.physics.soundboard import spread_allpasses

__all__ = ["Spread"]


class Spread:
    """A cascade of Schroeder allpasses, the same on every channel.

    Parameters
    ----------
    fs : float
        Rate, Hz (>= 8000).
    spread_ms : float
        The longest allpass's delay, ms, 0 < value <= 20
        (:data:`synth.physics.soundboard.SPREAD_RANGE_MS`).
    channels : int
        1 or 2.

    Attributes
    ----------
    delays : ndarray of int64
        The allpasses' delays, samples.
    gains : ndarray of float64
        Their gains.
    """

    def __init__(self, fs, spread_ms, channels=1):
        if isinstance(channels, bool) or channels not in (1, 2):
            raise ValueError(f"channels = {channels!r} is out of range (1 or 2)")
        self.fs = float(fs)
        self.spread_ms = float(spread_ms)
        self.delays, self.gains = spread_allpasses(fs, spread_ms)
        if not len(self.delays):
            raise ValueError(f"spread_ms = {spread_ms!r} ms is out of range (0 < value <= 20 "
                             "ms; 0: no Spread)")
        self.channels = int(channels)
        self._offsets = np.zeros(len(self.delays), dtype=np.int64)
        self._offsets[1:] = np.cumsum(self.delays)[:-1]
        self._lines = np.zeros((self.channels, int(self.delays.sum())))
        self._pos = np.zeros(len(self.delays), dtype=np.int64)

    def reset(self):
        """Silence: every line at rest."""
        self._lines[:] = 0.0
        self._pos[:] = 0

    def fresh_copy(self):
        """The same cascade at rest (its delays and gains shared)."""
        import copy

        s = copy.copy(self)
        s._lines = np.zeros_like(self._lines)
        s._pos = np.zeros_like(self._pos)
        return s

    def state(self):
        """A copy of the state (:meth:`restore` puts it back)."""
        return self._lines.copy(), self._pos.copy()

    def restore(self, state):
        """Put back a state from :meth:`state`."""
        self._lines[:], self._pos[:] = state

    def process(self, y):
        """Filter ``y`` in place: shape (n,) for one channel or (channels, n),
        float64 (rows with a stride cost one temporary block); returns ``y``."""
        return in_place_rows(y, self.channels, self._filter)

    def _filter(self, t, n):
        _kernel(t, n, self.delays, self.gains, self._offsets, self._lines, self._pos)

    def response(self, f_hz):
        """The cascade's complex response at ``f_hz`` (Hz), shape (F,): of
        magnitude 1."""
        f = np.atleast_1d(np.asarray(f_hz, dtype=np.float64))
        z1 = np.exp(-2j * np.pi * f / self.fs)
        H = np.ones(f.shape, dtype=np.complex128)
        for D, g in zip(self.delays, self.gains):
            zd = z1 ** int(D)
            H *= (zd - g) / (1.0 - g * zd)
        return H
