"""Channel volume, expression and pan: the engine's mixer.

A MIDI channel whose volume (CC7), expression (CC11) or pan (CC10) leaves
its default gets a :class:`ChannelGroup`: its strings write their buses
into rows of the engine's mix of their own (``StringBank.set_output_row``),
where the channel's gain is applied at the internal rate as a ramp
(:class:`Ramp`, :data:`RAMP_S` long from each change: no zipper noise, no
click), before the rows join the instrument's.  The strings' physics is
untouched: the gain scales what they send to the output.

Pan needs a stereo output.  A panned channel's rows then go through a
decimator and a body of their own (an :class:`OutputPath`, the
instrument's design again), whose stereo output is scaled by the pan's
left and right gains, ramped at the output rate, and added to the
instrument's output before the limiter.  The decimator and the body are
linear, so a channel that moves onto its own path at centre pan sounds
exactly as before (the two paths' outputs sum to the one's), and the pan
then ramps from the centre.

Channels at their defaults stay on the instrument's rows and cost nothing.
"""

from __future__ import annotations

import numpy as np

from ..dsp.knock import Knocks

#: how long a gain or pan change takes (s): a linear ramp from the value
#: at the change to the new one
RAMP_S = 0.01

__all__ = ["RAMP_S", "Ramp", "ChannelGroup", "OutputPath"]


class Ramp:
    """A piecewise-linear gain over sample time (any rate): constant at
    ``value`` until :meth:`set` starts a ramp.

    Parameters
    ----------
    value : float
        The gain before any change.
    """

    def __init__(self, value: float = 1.0):
        self._t = [0]
        self._g = [float(value)]

    def at(self, t: int) -> float:
        """The gain at sample ``t``."""
        return float(np.interp(t, self._t, self._g))

    def set(self, t: int, target: float, length: int) -> None:
        """From sample ``t`` on, go linearly to ``target`` over ``length``
        samples; ``length`` 0: ``target`` from sample ``t`` itself (what an
        earlier ramp planned after ``t`` is replaced)."""
        t = int(t)
        if length <= 0:
            g0, t0, t1 = self.at(t - 1), t - 1, t
        else:
            g0, t0, t1 = self.at(t), t, t + int(length)
        keep = [i for i, ti in enumerate(self._t) if ti < t0]
        self._t = [self._t[i] for i in keep] + [t0, t1]
        self._g = [self._g[i] for i in keep] + [g0, float(target)]

    def constant_over(self, t0: int, t1: int) -> float | None:
        """The gain if it is constant over samples [t0, t1), else None."""
        g = self.at(t0)
        for ti, gi in zip(self._t, self._g):
            if t0 < ti < t1 + 1 and gi != g:
                return None
        return g if self.at(t1) == g else None

    def envelope(self, t0: int, n: int) -> np.ndarray:
        """The gain at samples t0 .. t0 + n - 1."""
        return np.interp(np.arange(t0, t0 + n, dtype=np.float64), self._t, self._g)

    def forget_before(self, t: int) -> None:
        """Drop the breakpoints no sample from ``t`` on needs."""
        while len(self._t) > 1 and self._t[1] <= t:
            del self._t[0]
            del self._g[0]


class OutputPath:
    """A panned channel's own decimators, body and knock buffer, with the
    pan's (left, right) gains ramped at the output rate.

    Parameters
    ----------
    engine : synth.engine.engine.Engine
        The engine whose design it repeats.
    """

    def __init__(self, engine):
        # the instrument's decimators' phase (the samples they still need to
        # the next output) with none of their history: the two paths then
        # sum to what the one would give.  Copies of the engine's own
        # designs, not new ones: the first pan controller of a live
        # performance builds this in the audio callback (a new decimator
        # and body took about 25 ms there, tools/bench.py live --quick)
        self.decs = []
        for main in engine.decs:
            d = main.fresh_copy()
            d._state[:] = main._state
            self.decs.append(d)
        self.body = None if engine.body is None else engine.body.fresh_copy()
        if self.body is not None:
            self.body.reset()
        self.d = np.zeros((engine.n_dec, engine.MAX_BLOCK_OUT))
        self.y = np.zeros((engine.channels, engine.MAX_BLOCK_OUT))
        self.knock = Knocks(engine._knock_unit, engine.n_dec, engine.MAX_BLOCK_OUT)
        self.knocking = False
        self.left = Ramp(1.0)
        self.right = Ramp(1.0)

    def reset(self) -> None:
        """All sound off: every stage at rest."""
        for d in self.decs:
            d.clear()
        if self.body is not None:
            self.body.reset()
        self.knock.clear()
        self.knocking = False


class ChannelGroup:
    """One MIDI channel's rows of the mix, its gain ramp (internal rate)
    and, once panned, its :class:`OutputPath`.

    Parameters
    ----------
    channel : int
        The MIDI channel, 0 .. 15.
    row : int
        Its first row of the mix (bus 0; bus 1 the next).
    gain : float
        Its gain now (the ramp's start).
    """

    def __init__(self, channel: int, row: int, gain: float = 1.0):
        self.channel = int(channel)
        self.row = int(row)
        self.gain = Ramp(gain)
        self.path: OutputPath | None = None
