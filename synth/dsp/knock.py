"""The action's knocks still sounding: a list mixed block by block.

:class:`Knocks` keeps each note-on's knock as (first output sample, end,
gain per channel) and adds the next block of all of them to the buses in
one kernel call (:func:`synth.kernels.knock.knock_mix`), in the order of
their note-ons: the samples of a buffer that each note-on added its whole
scaled pulse to, bit for bit, for a fraction of the work on the audio
thread.
"""

from __future__ import annotations

import numpy as np

from synth.kernels.knock import knock_mix

#: knocks held at once before the list grows (allocating: a knock lasts
#: about 0.17 s, so 4096 at once is 24,000 note-ons a second)
CAPACITY = 4096


class Knocks:
    """The knocks of one set of buses.

    Parameters
    ----------
    unit : ndarray of float64, 1-D
        The pulse shape (force per unit of gain), at the output rate.
    channels : int
        Buses (1 or 2).
    max_block : int
        The longest block :meth:`mix_into` is given (output samples).
    """

    def __init__(self, unit: np.ndarray, channels: int, max_block: int):
        unit = np.ascontiguousarray(unit, dtype=np.float64)
        if unit.ndim != 1:
            raise ValueError(f"unit.ndim = {unit.ndim} is out of range (1 <= value <= 1)")
        if channels not in (1, 2):
            raise ValueError(f"channels = {channels!r} is out of range (1 <= value <= 2)")
        self.unit = unit
        nz = np.flatnonzero(unit)
        #: samples from a knock's start to the sample after its last non-zero one
        self.length = int(nz[-1]) + 1 if nz.size else 0
        self.channels = channels
        self.starts = np.zeros(CAPACITY, dtype=np.int64)
        self.ends = np.zeros(CAPACITY, dtype=np.int64)
        self.gains = np.zeros((CAPACITY, channels))
        self.n = 0
        self._acc = np.zeros((channels, int(max_block)))

    def add(self, start: int, gains) -> None:
        """A knock from output sample ``start`` on, with ``gains`` (one per
        channel) times the unit pulse.  One whose gains are all zero adds
        nothing and is not kept."""
        if self.length == 0 or not any(gains):
            return
        if self.n == len(self.starts):
            grow = len(self.starts)
            self.starts = np.concatenate([self.starts, np.zeros(grow, dtype=np.int64)])
            self.ends = np.concatenate([self.ends, np.zeros(grow, dtype=np.int64)])
            self.gains = np.concatenate([self.gains, np.zeros((grow, self.channels))])
        k = self.n
        self.starts[k] = start
        self.ends[k] = start + self.length
        self.gains[k, :] = gains
        self.n = k + 1

    def mix_into(self, d: np.ndarray, t0: int, n_out: int) -> bool:
        """Add output samples ``t0`` .. ``t0 + n_out - 1`` of every knock to
        ``d`` (channels x at least n_out); returns whether knocks remain."""
        # (with none left it still adds its zeros, as the buffer did: -0.0 + 0.0)
        self.n = int(knock_mix(self.unit, self.starts, self.ends, self.gains, self.n,
                               t0, n_out, self._acc, d))
        return self.n > 0

    def cut(self, at: int) -> None:
        """Nothing of the knocks held now sounds from output sample ``at`` on."""
        e = self.ends[:self.n]
        np.minimum(e, at, out=e)

    def clear(self) -> None:
        """No knock."""
        self.n = 0
