"""The piano's soundboard (body) as an output stage on the mono mix.

:class:`Body` filters the engine's mono output (after decimation, once for
the whole mix) through a bank of damped modes that stands for the
soundboard's transfer from bridge to listener, mixed with the direct (dry)
signal. The mode set and its laws are in :mod:`synth.physics.soundboard`
(why modes and not a convolution is argued there); the kernel is
:func:`synth.kernels.body.body_process`.

Level. The modal gains are scaled so that the bank alone has a white-noise
power gain of exactly 1 (sum h^2 = 1). Dry and wet paths are nearly
uncorrelated, so a plain linear crossfade ``(1 - wet) x + wet H x`` would
dip by up to 3 dB at wet = 0.5; instead the two gains are divided by the
exact broadband gain of that mix,

    dry_gain = (1 - wet) / c,  wet_gain = wet / c,
    c^2 = (1 - wet)^2 + wet^2 sum h^2 + 2 wet (1 - wet) h[0],

so the output's power for white noise equals the input's at every ``wet``
and a preset can switch the body on without a level jump. (On a single
sine the gain follows the board's peaks and dips: about +-10 dB.)

Cost (one core, 2.6 GHz Xeon, AVX-512): ~20 ns per output sample for the
default 96 modes at 48 kHz in 1024-sample blocks, i.e. ~0.1 % of one core
(budget: 2 %); the kernel alone ~16 ns, plus ~2 us of validation and
dispatch per ``process`` call (so 64-sample blocks cost ~54 ns per sample).

Streaming: blocks of any length (including 0) give exactly the one-shot
result; no allocation per block when ``out`` is given; zero latency.
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from .signal import as_mono_block, output_block

from synth.kernels.body import body_process as _body_kernel
from synth.physics.soundboard import (
    DEFAULT_N_MODES,
    DEFAULT_SEED,
    resonator_coefs,
    soundboard_modes,
    white_noise_power_gain,
)

__all__ = ["Body", "DEFAULT_WET"]

#: Default wet/dry balance.
DEFAULT_WET = 0.6
#: Longest impulse response :meth:`Body.impulse_response` will make (samples).
MAX_IR_SAMPLES = 1 << 26


class Body:
    """Soundboard modal bank with a dry/wet mix, streaming block by block.

    One input (the decimated mix) and one output (``inputs``, ``outputs``).


    Parameters
    ----------
    fs : int or float
        Sample rate of the signal in Hz (>= 8000), normally the engine's
        output rate (48000).
    n_modes : int
        Number of modes, 1 .. 1024 (default 96).
    seed : int
        Seed of the board's random draws, >= 0 (default 1); fixed seed, same
        board.
    wet : float
        Balance, 0 .. 1: 0 = input unchanged, 1 = body only (default 0.6).
        Power-compensated (see the module docstring). Can be changed between
        blocks by assigning ``body.wet`` (an abrupt change may click).
    size : float
        Board scale, 0.5 .. 2 (default 1): mode frequencies divide by it
        (lowest mode 50 / size Hz), decay times multiply by it.
    brightness : float
        Spectral tilt of the board's response in dB per octave re 1 kHz,
        -12 .. 12 (default 0).

    Attributes
    ----------
    freqs_hz, t60_s, gains : ndarray, shape (K,)
        The mode set (:func:`synth.physics.soundboard.soundboard_modes`).
    coefs : ndarray, shape (3, K)
        Resonator coefficients, rows b0, a1, a2.
    dry_gain, wet_gain : float
        The gains the kernel applies for the current ``wet``.
    """

    inputs = 1
    outputs = 1

    def __init__(self, fs, n_modes=DEFAULT_N_MODES, seed=DEFAULT_SEED, wet=DEFAULT_WET,
                 size=1.0, brightness=0.0):
        self.freqs_hz, self.t60_s, self.gains = soundboard_modes(
            fs, n_modes=n_modes, seed=seed, size=size, brightness=brightness)
        self.fs = float(fs)
        self.n_modes = int(n_modes)
        self.seed = int(seed)
        self.size = float(size)
        self.brightness = float(brightness)
        self.coefs = resonator_coefs(self.fs, self.freqs_hz, self.t60_s, self.gains)
        #: sum_n h[n]^2 of the bank alone (1 up to rounding) and h[0].
        self.ir_energy = white_noise_power_gain(self.coefs)
        self.ir_first = float(self.coefs[0].sum())
        self._state = np.zeros((2, self.n_modes + 1), dtype=np.float64)
        self.wet = wet

    @classmethod
    def from_design(cls, fs, design):
        """The body an instrument describes (a
        :class:`synth.physics.soundboard.BodyDesign`) at the rate ``fs`` (Hz)."""
        return cls(fs, n_modes=design.n_modes, seed=design.seed, wet=design.wet,
                   size=design.size, brightness=design.brightness)

    # -- parameters -------------------------------------------------------------

    @property
    def wet(self):
        """Dry/wet balance, 0 .. 1."""
        return self._wet

    @wet.setter
    def wet(self, value):
        ok = not isinstance(value, bool) and isinstance(value, numbers.Real)
        v = float(value) if ok else math.nan
        if not (math.isfinite(v) and 0.0 <= v <= 1.0):
            raise ValueError(f"wet = {value!r} is out of range (0 <= value <= 1)")
        d = 1.0 - v
        c = math.sqrt(d * d + v * v * self.ir_energy + 2.0 * v * d * self.ir_first)
        self._wet = v
        self.dry_gain = d / c
        self.wet_gain = v / c

    # -- streaming --------------------------------------------------------------

    def reset(self):
        """Forget all history (silence before the next sample)."""
        self._state[:] = 0.0

    def process(self, x, out=None):
        """Filter one block; the state carries over to the next call.

        Parameters
        ----------
        x : array_like of float, 1-D
            Input block at ``fs``, any length (0 .. any), finite values.
        out : ndarray of float64, 1-D, optional
            Where to write the result, length >= len(x); may be ``x`` itself
            (in place). The returned array is ``out[:len(x)]``.

        Returns
        -------
        ndarray of float64, shape (len(x),)
            ``dry_gain x + wet_gain (bank * x)``.
        """
        x = as_mono_block(x)
        n = x.shape[0]
        out = output_block(out, n, "len(x)")
        if n == 0:
            return out[:0]
        target = out if out.flags.c_contiguous else np.empty(n, dtype=np.float64)
        _body_kernel(x, n, self.coefs, self._state, self.dry_gain, self.wet_gain, target)
        if target is not out:
            out[:n] = target[:n]
        return out[:n]

    def impulse_response(self, n):
        """The first ``n`` samples of the response to a unit impulse (current ``wet``).

        Runs on a fresh state; the streaming state is left untouched.

        Parameters
        ----------
        n : int
            Length in samples, 0 .. 2^26.

        Returns
        -------
        ndarray of float64, shape (n,)
            ``dry_gain delta + wet_gain h``, h the bank's impulse response.
        """
        if isinstance(n, bool) or not isinstance(n, numbers.Integral) or not 0 <= n <= MAX_IR_SAMPLES:
            raise ValueError(f"n = {n!r} is out of range (integer, 0 <= value <= {MAX_IR_SAMPLES})")
        n = int(n)
        y = np.zeros(n, dtype=np.float64)
        if n:
            y[0] = 1.0
            state = np.zeros_like(self._state)
            _body_kernel(y, n, self.coefs, state, self.dry_gain, self.wet_gain, y)
        return y
