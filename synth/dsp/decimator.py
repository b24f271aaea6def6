"""Polyphase rational decimator from the internal rate down to the output rate.

The engine renders its mix at a high internal rate (325 kHz by default, also
e.g. 336 kHz = 7 x 48 kHz, or 324.8 kHz for the thesis's grid) and hands it,
block by block, to a :class:`Decimator` that resamples it to ``fs_out``
(48 kHz) by the fixed ratio ``L / M = fs_out / fs_in`` (reduced by the gcd:
48/325, 1/7, 30/203).

The anti-aliasing prototype is a Kaiser-windowed sinc designed with numpy
only, at the rate ``L * fs_in``: flat (ripple far below 0.01 dB) up to
``passband_hz``, at least ``atten_db`` minus a few dB down from
``stopband_hz`` up to ``L * fs_in / 2``, linear phase. Its group delay is the
decimator's latency (under 1 ms at the default rates and bands).

Streaming: push any number of input samples at a time; the outputs come out
exactly as if the whole signal had been pushed at once, and equal
``np.convolve(zero_stuff(x, L), h)[::M]`` (the first output is aligned with
the first input; history starts at zero).
"""

import math
import numbers

import numpy as np

from synth.kernels.decimator import decimate as _decimate_kernel

from .signal import as_mono_block, output_block

__all__ = ["Decimator", "design_prototype", "default_passband_hz", "AUDIO_BAND_HZ"]

#: Largest interpolation factor L = fs_out / gcd(fs_in, fs_out) accepted.
MAX_L = 4096
#: Largest prototype length accepted (taps at the rate L * fs_in).
MAX_PROTOTYPE_TAPS = 1 << 23


def _as_rate_hz(name, value, low):
    """Return ``value`` as an int Hz rate >= ``low``, or raise a one-line ValueError."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{name}={value!r} must be an integer rate in Hz >= {low}")
    if isinstance(value, numbers.Integral):
        iv = int(value)
    else:
        fv = float(value)
        if not math.isfinite(fv) or fv != math.floor(fv):
            raise ValueError(f"{name}={value!r} Hz must be a whole number of Hz >= {low}")
        iv = int(fv)
    if iv < low:
        raise ValueError(f"{name}={iv} Hz out of range: must be an integer >= {low} Hz")
    return iv


def _ratio(fs_in, fs_out):
    """Validate the rates and return (fs_in, fs_out, L, M) as ints."""
    fs_out = _as_rate_hz("fs_out", fs_out, 8000)
    fs_in = _as_rate_hz("fs_in", fs_in, fs_out + 1)
    g = math.gcd(fs_in, fs_out)
    L, M = fs_out // g, fs_in // g
    if L > MAX_L:
        raise ValueError(
            f"fs_in={fs_in} Hz with fs_out={fs_out} Hz gives interpolation factor "
            f"L={L}; allowed L <= {MAX_L} (pick rates with a larger common divisor)"
        )
    return fs_in, fs_out, L, M


def _kaiser_beta(atten_db):
    """Kaiser's beta for a stopband attenuation in dB (Kaiser 1974)."""
    if atten_db > 50.0:
        return 0.1102 * (atten_db - 8.7)
    return 0.5842 * (atten_db - 21.0) ** 0.4 + 0.07886 * (atten_db - 21.0)


def design_prototype(fs_in, fs_out=48000, passband_hz=20000.0, stopband_hz=24000.0,
                     atten_db=110.0):
    """Design the linear-phase anti-aliasing prototype of an L/M decimator.

    A Kaiser-windowed sinc at the prototype rate ``L * fs_in``, cutoff halfway
    between the band edges, length from Kaiser's formula for ``atten_db`` and
    the transition width, rounded up to a whole number of polyphase rows
    (``len(h) = L * taps_per_phase``). Scaled by L, so that zero-stuffing by
    L, filtering and keeping every M-th sample has unit passband gain (the DC
    gain of ``h / L`` is exactly 1).

    Parameters
    ----------
    fs_in : int
        Input (internal) rate in Hz, a whole number > fs_out.
    fs_out : int
        Output rate in Hz, a whole number >= 8000.
    passband_hz : float
        Upper edge of the flat band in Hz, 0 < passband_hz < stopband_hz.
    stopband_hz : float
        Lower edge of the stopband in Hz, passband_hz < stopband_hz <= fs_out / 2
        (everything above it would alias into 0 .. fs_out - stopband_hz).
    atten_db : float
        Design stopband attenuation in dB, 21 .. 200 (the Kaiser formula
        lands within a few dB of it; 110 keeps margin over 100 dB).

    Returns
    -------
    h : ndarray of float64, shape (L * taps_per_phase,)
        Prototype impulse response, symmetric, at the rate ``L * fs_in``,
        scaled by L. Group delay ``(len(h) - 1) / 2`` samples at that rate.
    L : int
        Interpolation factor, ``fs_out / gcd(fs_in, fs_out)``.
    M : int
        Decimation factor, ``fs_in / gcd(fs_in, fs_out)``.
    """
    fs_in, fs_out, L, M = _ratio(fs_in, fs_out)
    passband_hz = float(passband_hz)
    stopband_hz = float(stopband_hz)
    atten_db = float(atten_db)
    if not (math.isfinite(stopband_hz) and 0.0 < stopband_hz <= fs_out / 2):
        raise ValueError(
            f"stopband_hz={stopband_hz} Hz out of range: must be in (0, fs_out/2 = {fs_out / 2}] Hz"
        )
    if not (math.isfinite(passband_hz) and 0.0 < passband_hz < stopband_hz):
        raise ValueError(
            f"passband_hz={passband_hz} Hz out of range: must be in (0, stopband_hz = {stopband_hz}) Hz"
        )
    if not (math.isfinite(atten_db) and 21.0 <= atten_db <= 200.0):
        raise ValueError(f"atten_db={atten_db} dB out of range: must be in [21, 200] dB")

    fs_proto = float(L) * fs_in
    d_omega = 2.0 * math.pi * (stopband_hz - passband_hz) / fs_proto
    n_kaiser = int(math.ceil((atten_db - 7.95) / (2.285 * d_omega))) + 1
    taps_per_phase = -(-n_kaiser // L)
    n = L * taps_per_phase
    if n > MAX_PROTOTYPE_TAPS:
        raise ValueError(
            f"fs_in={fs_in} Hz with fs_out={fs_out} Hz and a {stopband_hz - passband_hz} Hz "
            f"transition needs a {n}-tap prototype; allowed <= {MAX_PROTOTYPE_TAPS} taps"
        )
    fc = 0.5 * (passband_hz + stopband_hz) / fs_proto  # cycles per prototype sample
    t = np.arange(n, dtype=np.float64) - 0.5 * (n - 1)
    h = 2.0 * fc * np.sinc(2.0 * fc * t) * np.kaiser(n, _kaiser_beta(atten_db))
    h *= L / h.sum()
    return h, L, M


#: The audio band kept flat at every output rate of 44.1 kHz and above (Hz).
AUDIO_BAND_HZ = 20000.0


def default_passband_hz(stopband_hz):
    """The decimator's default flat band edge (Hz) for a stopband edge (Hz).

    20 kHz (:data:`AUDIO_BAND_HZ`) whenever the stopband starts at 22.05 kHz
    or above (a 44.1 kHz card's Nyquist frequency: the prototype is then
    about twice as long as at 48 kHz, 1130 taps per output instead of 578),
    else 5/6 of the stopband edge.
    """
    sb = float(stopband_hz)
    return AUDIO_BAND_HZ if sb >= 22050.0 else min(AUDIO_BAND_HZ, sb * 5.0 / 6.0)


class Decimator:
    """Streaming polyphase resampler from ``fs_in`` down to ``fs_out``.

    Parameters
    ----------
    fs_in : int
        Internal (input) rate in Hz, a whole number > fs_out
        (e.g. 325000, 336000, 324800).
    fs_out : int
        Output rate in Hz, a whole number >= 8000 (default 48000).
    passband_hz : float or None
        Flat band edge in Hz; None means :func:`default_passband_hz`:
        20 kHz at every card rate from 44.1 kHz up (44.1, 48, 88.2, 96 kHz),
        5/6 of the stopband edge below.
    stopband_hz : float or None
        Stopband edge in Hz, <= fs_out / 2; None means fs_out / 2.
    atten_db : float
        Design stopband attenuation in dB, 21 .. 200 (default 110).

    Attributes
    ----------
    fs_in, fs_out : int
        The rates in Hz.
    L, M : int
        Reduced ratio ``L / M = fs_out / fs_in``.
    h : ndarray
        Prototype at rate ``L * fs_in`` (scaled by L).
    taps_per_phase : int
        Multiply-adds per output sample.
    latency_s : float
        Group delay of the prototype in seconds: an input event at time t
        (internal clock) appears in the output at t + latency_s.
    """

    def __init__(self, fs_in, fs_out=48000, passband_hz=None, stopband_hz=None,
                 atten_db=110.0):
        fs_in, fs_out, _, _ = _ratio(fs_in, fs_out)
        if stopband_hz is None:
            stopband_hz = fs_out / 2.0
        if passband_hz is None:
            passband_hz = default_passband_hz(stopband_hz)
        h, L, M = design_prototype(fs_in, fs_out, passband_hz, stopband_hz, atten_db)
        self.fs_in = fs_in
        self.fs_out = fs_out
        self.L = L
        self.M = M
        self.passband_hz = float(passband_hz)
        self.stopband_hz = float(stopband_hz)
        self.atten_db = float(atten_db)
        self.h = h
        T = len(h) // L
        self.taps_per_phase = T
        # E[p, j] = h[p + j L]; rows reversed for the kernel's forward dot product.
        self.phases = np.ascontiguousarray(h.reshape(T, L).T[:, ::-1], dtype=np.float64)
        self.latency_s = 0.5 * (len(h) - 1) / (float(L) * fs_in)
        self._hist = np.zeros(2 * T, dtype=np.float64)
        self._state = np.zeros(3, dtype=np.int64)
        self.reset()

    def fresh_copy(self):
        """A decimator of the same design (sharing its read-only prototype
        and phase matrix) with empty history, at rest: built in
        microseconds where a new design takes milliseconds (an output path
        made in the audio callback)."""
        import copy

        d = copy.copy(self)
        d._hist = np.zeros_like(self._hist)
        d._state = np.zeros_like(self._state)
        d.reset()
        return d

    def reset(self):
        """Forget all history: the next input is treated as the first one."""
        self._hist[:] = 0.0
        self._state[0] = 0  # phase p of the next output
        self._state[1] = 1  # the first output needs one input
        self._state[2] = self.taps_per_phase - 1  # first input goes to slot 0

    def clear(self):
        """Forget the input history but keep the phase: the next outputs
        come at the same input samples as they would have (the engine's
        all sound off: its clock runs on)."""
        self._hist[:] = 0.0

    @property
    def latency_samples(self):
        """Group delay in output samples (float)."""
        return self.latency_s * self.fs_out

    def inputs_needed(self, n_out):
        """Exactly how many inputs to push next so that exactly ``n_out`` outputs come out.

        Parameters
        ----------
        n_out : int
            Number of outputs wanted, >= 0.

        Returns
        -------
        int
            Number of input samples; pushing them yields ``n_out`` outputs and
            leaves no completed-but-unemitted output (the next output needs at
            least one more input).
        """
        n_out = self._count("n_out", n_out)
        if n_out == 0:
            return 0
        p, d = int(self._state[0]), int(self._state[1])
        return d + (p + (n_out - 1) * self.M) // self.L

    def outputs_for(self, n_in):
        """How many outputs pushing ``n_in`` more inputs will produce (state unchanged).

        Parameters
        ----------
        n_in : int
            Number of input samples, >= 0.
        """
        n_in = self._count("n_in", n_in)
        p, d = int(self._state[0]), int(self._state[1])
        if n_in < d:
            return 0
        return ((n_in - d + 1) * self.L - 1 - p) // self.M + 1

    @staticmethod
    def _count(name, value):
        if type(value) is int and value >= 0:  # fast path
            return value
        if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 0:
            raise ValueError(f"{name}={value!r} out of range: must be an integer >= 0")
        return int(value)

    def process(self, x, out=None):
        """Push a block of input samples; return the outputs that became available.

        Parameters
        ----------
        x : array_like of float, 1-D
            Input block at ``fs_in``, any length (0 .. any); finite values.
        out : ndarray of float64, 1-D, optional
            Where to write the outputs; must hold at least
            ``outputs_for(len(x))`` samples. The returned array is
            ``out[:n]``.

        Returns
        -------
        ndarray of float64
            The ``outputs_for(len(x))`` new output samples at ``fs_out``.
        """
        x = as_mono_block(x)
        n_in = x.shape[0]
        p, d = int(self._state[0]), int(self._state[1])
        n = 0 if n_in < d else ((n_in - d + 1) * self.L - 1 - p) // self.M + 1
        out = output_block(out, n, "outputs_for(len(x))")
        if n_in == 0:
            return out[:0]
        target = out if out.flags.c_contiguous else np.empty(n, dtype=np.float64)
        got = _decimate_kernel(x, n_in, self.phases, self.L, self.M,
                               self._hist, self._state, target)
        assert got == n, (got, n)
        if target is not out:
            out[:n] = target[:n]
        return out[:n]
