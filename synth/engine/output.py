"""The engine's output policy: the preset's ``[output]`` table as one stage.

The voice's strings write their signal (bridge force in N, or displacement
in m) times ``output.gain`` into the bank's buses (the gain is part of each
string's slot, so the kernel scales as it writes); what happens to the
output after that is the engine's, and it lives here:

* the gain the engine puts on what it adds to the buses itself (the
  action's knock, a force in N: :meth:`OutputStage.force_to_output`);
* the look-ahead peak limiter (``output.limiter = "on"``,
  ``limit_dbfs``, ``limit_release_s``: :class:`synth.dsp.limiter.Limiter`),
  the last stage of every block, whose latency offline renders remove as
  they remove the decimator's.

A voice no longer says how its output is limited; the engine builds this
stage from the preset (:meth:`OutputStage.from_preset`).
"""

from __future__ import annotations

import numpy as np

from ..dsp.limiter import Limiter

__all__ = ["OutputStage"]


class OutputStage:
    """The output gain and the optional peak limiter of one engine.

    Parameters
    ----------
    gain : float
        Output units (full scale = 1) per unit of the strings' signal (N of
        bridge force, or m): the preset's ``output.gain``.
    fs_out : int
        The engine's output rate (Hz).
    channels : int
        Output channels (1 or 2).
    limit : tuple (ceiling_dbfs, release_s) or None
        The peak limiter's ceiling (dBFS) and release (s), or None: off.

    Attributes
    ----------
    gain : float
    limiter : synth.dsp.limiter.Limiter or None
    """

    def __init__(self, gain: float, fs_out: int, channels: int,
                 limit: tuple[float, float] | None = None):
        self.gain = float(gain)
        self.limiter = None if limit is None else Limiter(fs_out, *limit, channels=channels)

    @classmethod
    def from_preset(cls, preset, fs_out: int, channels: int) -> "OutputStage":
        """The stage of ``preset``'s ``[output]`` table (a preset without
        one: gain 1, no limiter)."""
        o = getattr(preset, "output", None)
        if o is None:
            return cls(1.0, fs_out, channels)
        limit = None
        if getattr(o, "limiter", "off") == "on":
            limit = (float(o.limit_dbfs), float(o.limit_release_s))
        return cls(o.gain, fs_out, channels, limit)

    @property
    def latency_samples(self) -> int:
        """Output samples the stage delays its input by (the limiter's
        look-ahead; 0 without)."""
        return self.limiter.latency_samples if self.limiter is not None else 0

    def force_to_output(self, force_n: float) -> float:
        """A force (N, or N s of an impulse) the engine adds to the buses,
        in the buses' units: times the gain the strings write with."""
        return force_n * self.gain

    def process(self, y: np.ndarray) -> None:
        """The block's last stage, in place on ``y`` (channels x samples)."""
        if self.limiter is not None:
            self.limiter.process(y, out=y)

    def reset(self) -> None:
        """All sound off: the limiter's state and delay line cleared."""
        if self.limiter is not None:
            self.limiter.reset()
