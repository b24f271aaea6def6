"""The board's mass law as a streaming stage: the first-order section of
:func:`synth.physics.soundboard.mass_section` on 1 or 2 channels.

:class:`BoardMass` validates and holds the state; the kernel is
:func:`synth.kernels.board_mass.mass_section`.  Gain 1 at 0 Hz, 6 dB per
octave down above the corner, zero latency, blocks of any length give
the one-shot result, no allocation per block.  :class:`synth.dsp.body.Body`
runs one on its outputs when its design has a ``mass_hz``.
"""

from __future__ import annotations

import numpy as np

from synth.dsp.signal import in_place_rows
from synth.kernels.board_mass import mass_section as _kernel
from synth.physics.soundboard import mass_section, mass_section_check

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
    section : tuple of float, optional
        ``(g, b, a)`` as :func:`~synth.physics.soundboard.mass_section`
        returns it for ``fs`` and ``mass_hz`` (a design kept on disk, so a
        warm start neither fits it again nor imports the fit's
        ``scipy.optimize``, 0.3-0.5 s); None: fitted here.

    Attributes
    ----------
    g, b, a : float
        The section's gain, zero and pole
        (:func:`synth.physics.soundboard.mass_section`).
    """

    def __init__(self, fs, mass_hz, channels=1, section=None):
        if isinstance(channels, bool) or channels not in (1, 2):
            raise ValueError(f"channels = {channels!r} is out of range (1 or 2)")
        self.fs = float(fs)
        if section is None:
            section = mass_section(fs, mass_hz)     # (validates mass_hz)
        else:
            mass_section_check(fs, mass_hz)
            if not (len(section) == 3 and 0.0 < section[2] < 1.0 and abs(section[1]) < 1.0):
                raise ValueError(f"section = {section!r} is out of range ((g, b, a), 0 < a < 1, |b| < 1)")
        self.g, self.b, self.a = (float(x) for x in section)
        self.mass_hz = float(mass_hz)
        if self.mass_hz == 0.0:
            raise ValueError(f"mass_hz = {mass_hz!r} Hz is out of range (0 < value < fs / 2; "
                             "0: no BoardMass)")
        self.channels = int(channels)
        self._state = np.zeros((self.channels, 2))

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
        return in_place_rows(y, self.channels, self._filter)

    def _filter(self, t, n):
        _kernel(t, n, self.g, self.b, self.a, self._state)

    def response(self, f_hz):
        """The filter's complex response at ``f_hz`` (Hz), shape (F,)."""
        f = np.atleast_1d(np.asarray(f_hz, dtype=np.float64))
        z1 = np.exp(-2j * np.pi * f / self.fs)
        return self.g * (1.0 + self.b * z1) / (1.0 - self.a * z1)
