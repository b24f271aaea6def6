"""The board's mass law as a streaming stage: the one-pole low-pass of
:func:`synth.physics.soundboard.mass_pole` on 1 or 2 channels.

:class:`BoardMass` validates and holds the state; the kernel is
:func:`synth.kernels.board_mass.one_pole_lowpass`.  Gain 1 at 0 Hz, 6 dB
per octave down above the corner, zero latency, blocks of any length give
the one-shot result, no allocation per block.  :class:`synth.dsp.body.Body`
runs one on its outputs when its design has a ``mass_hz``.
"""

from __future__ import annotations

import numpy as np

from synth.kernels.board_mass import one_pole_lowpass as _kernel
from synth.physics.soundboard import mass_pole

__all__ = ["BoardMass"]


class BoardMass:
    """The board's mass law, the same on every channel.

    Parameters
    ----------
    fs : float
        Rate, Hz (>= 8000).
    mass_hz : float
        The corner, Hz, 0 < value < fs / 2 (within
        :data:`synth.physics.soundboard.MASS_RANGE_HZ`).
    channels : int
        1 or 2.

    Attributes
    ----------
    a : float
        The pole (:func:`synth.physics.soundboard.mass_pole`).
    """

    def __init__(self, fs, mass_hz, channels=1):
        if isinstance(channels, bool) or channels not in (1, 2):
            raise ValueError(f"channels = {channels!r} is out of range (1 or 2)")
        self.fs = float(fs)
        self.a = mass_pole(fs, mass_hz)
        if self.a == 0.0:
            raise ValueError(f"mass_hz = {mass_hz!r} Hz is out of range (0 < value < fs / 2; "
                             "0: no BoardMass)")
        self.mass_hz = float(mass_hz)
        self.channels = int(channels)
        self._state = np.zeros(self.channels)

    def reset(self):
        """Silence: the state at rest."""
        self._state[:] = 0.0

    def fresh_copy(self):
        """The same filter at rest."""
        import copy

        m = copy.copy(self)
        m._state = np.zeros_like(self._state)
        return m

    def state(self):
        """A copy of the state (:meth:`restore` puts it back)."""
        return self._state.copy()

    def restore(self, state):
        """Put back a state from :meth:`state`."""
        self._state[:] = state

    def process(self, y):
        """Filter ``y`` in place: shape (n,) for one channel or (channels, n),
        float64 (rows with a stride cost one temporary block); returns ``y``."""
        if not isinstance(y, np.ndarray) or y.dtype != np.float64 or not y.flags.writeable:
            raise ValueError("y must be a writeable float64 ndarray")
        y2 = y[None, :] if y.ndim == 1 else y
        if y2.ndim != 2 or y2.shape[0] != self.channels:
            raise ValueError(f"y has shape {y.shape}; must be ({self.channels}, n)"
                             + (" or (n,)" if self.channels == 1 else ""))
        n = y2.shape[1]
        if n:
            t = y2 if n == 1 or y2.strides[1] == 8 else np.ascontiguousarray(y2)
            _kernel(t, n, self.a, self._state)
            if t is not y2:
                y2[:] = t
        return y

    def response(self, f_hz):
        """The filter's complex response at ``f_hz`` (Hz), shape (F,)."""
        f = np.atleast_1d(np.asarray(f_hz, dtype=np.float64))
        z1 = np.exp(-2j * np.pi * f / self.fs)
        return (1.0 - self.a) / (1.0 - self.a * z1)
