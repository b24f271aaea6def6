"""A look-ahead peak limiter for the engine's output (the last stage).

Why: a preset's level is set so that a reference phrase plays at -20 LUFS
(``tools/calibrate_levels.py``), but a piano's dynamics span more than
that leaves below full scale: the grand's phrase read -24.9 LUFS while a
pedalled fortissimo file already peaked at -1.4 dBFS.  A limiter that
touches only the rare loudest peaks lets the level be right without
clipping them, as commercial piano models do (Pianoteq's output limiter is
on by default).  The preset turns it on (``[output] limiter = "on"``) with
its ceiling (``limit_dbfs``) and release time (``limit_release_s``).

How: :mod:`synth.kernels.limiter` (the equations; a gain common to all
channels so the stereo image does not move).  The look-ahead is
``LOOKAHEAD_S`` (1.5 ms, 72 samples at 48 kHz): the gain ramps down over
that time before a peak instead of stepping, so a limited attack is not a
click; the output is delayed by ``latency_samples`` (71 at 48 kHz), which
:meth:`synth.engine.engine.Engine.render` removes from offline renders and
which live play adds to the stream's latency.  The ceiling is on sample
values (not inter-sample true peaks), and it holds after the engine's
float32 output: the kernel limits to ``ceiling * FLOAT32_MARGIN`` (2.4e-7
under it, 2e-6 dB), so that rounding to float32 (half an ulp, 6e-8
relative) cannot lift a limited peak over it.  Below the ceiling the
output is the input delayed, sample for sample.
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from synth.kernels.limiter import limiter_process as _kernel

from .signal import channel_blocks

__all__ = ["Limiter", "LOOKAHEAD_S", "CEILING_RANGE_DBFS", "RELEASE_RANGE_S", "FLOAT32_MARGIN"]

#: Look-ahead (s): the gain's ramp before a peak, and the latency.
LOOKAHEAD_S = 0.0015
#: Allowed ceilings (dBFS) and release times (s).
CEILING_RANGE_DBFS = (-20.0, 0.0)
RELEASE_RANGE_S = (0.001, 2.0)
#: The kernel's ceiling relative to the nominal one: 4 float32 half-ulps
#: under it, so that the float32 output stays at or below the nominal ceiling.
FLOAT32_MARGIN = 1.0 - 2.0 ** -22


def _float(name, value, lo, hi, unit):
    ok = not isinstance(value, bool) and isinstance(value, numbers.Real)
    v = float(value) if ok else math.nan
    if not (math.isfinite(v) and lo <= v <= hi):
        raise ValueError(f"{name} = {value!r}{unit} is out of range ({lo:g} <= value <= {hi:g})")
    return v


class Limiter:
    """Look-ahead peak limiter, streaming block by block.

    Parameters
    ----------
    fs : float
        Sample rate (Hz), >= 8000.
    ceiling_dbfs : float
        Largest output sample magnitude, dB re full scale, -20 .. 0.
    release_s : float
        Time constant of the gain's return to 1 after a peak (s), 0.001 .. 2.
    channels : int
        1 or 2; the gain is common to both.
    lookahead_s : float
        Look-ahead (s), 0.0001 .. 0.01 (default ``LOOKAHEAD_S``).

    Attributes
    ----------
    latency_samples : int
        Delay of the output behind the input (look-ahead samples - 1).
    """

    def __init__(self, fs, ceiling_dbfs=-1.0, release_s=0.05, channels=1,
                 lookahead_s=LOOKAHEAD_S):
        fs = _float("fs", fs, 8000.0, 1e7, " Hz")
        self.ceiling_dbfs = _float("ceiling_dbfs", ceiling_dbfs, *CEILING_RANGE_DBFS, " dBFS")
        self.release_s = _float("release_s", release_s, *RELEASE_RANGE_S, " s")
        la = _float("lookahead_s", lookahead_s, 1e-4, 0.01, " s")
        if isinstance(channels, bool) or channels not in (1, 2):
            raise ValueError(f"channels = {channels!r} is out of range (1 or 2)")
        self.fs = fs
        self.channels = int(channels)
        self.ceiling = 10.0 ** (self.ceiling_dbfs / 20.0)
        self.release_coef = math.exp(-1.0 / (self.release_s * fs))
        N = max(2, int(round(la * fs)))
        self.lookahead = N
        self.latency_samples = N - 1
        Q = 1 << N.bit_length()  # a power of two > N: the deque holds up to N + 1
        self._delay = np.empty((self.channels, N))
        self._box = np.empty(N)
        self._dq_val = np.empty(Q)
        self._dq_idx = np.empty(Q, dtype=np.int64)
        self._f = np.empty(2)
        self._i = np.empty(4, dtype=np.int64)
        self.reset()

    def reset(self):
        """Silence and unity gain, as new."""
        self._delay[:] = 0.0
        self._box[:] = 1.0
        self._dq_val[:] = 1.0
        self._dq_idx[:] = 0
        self._f[:] = (1.0, float(self.lookahead))
        self._i[:] = 0

    @property
    def gain(self):
        """The gain applied to the latest output sample (1: not limiting)."""
        return min(1.0, float(self._f[1]) / self.lookahead)

    def process(self, x, out=None):
        """Limit one block; the state carries over to the next call.

        Parameters
        ----------
        x : ndarray of float64
            Shape (n,) for one channel, (channels, n) for any; finite.
        out : ndarray of float64, optional
            Same shape as ``x`` (may be ``x``: in place).

        Returns
        -------
        ndarray
            The limited block, delayed by ``latency_samples``.
        """
        x2, out, o2 = channel_blocks(x, out, self.channels)
        _kernel(x2, x2.shape[1], self.ceiling * FLOAT32_MARGIN, self.release_coef, self._delay, self._box,
                self._dq_val, self._dq_idx, self._f, self._i, o2)
        return out
