"""The piano's soundboard (body) as an output stage: 1 or 2 bridge inputs, 1 or 2 outputs.

:class:`Body` filters the engine's bridge signal(s) at the output rate
(after decimation, once for the whole mix) through a bank of damped modes
that stands for the soundboard's transfer from the bridge to the listener,
plus a direct part. With two inputs, input 0 is the bass end of the bridge
and input 1 the treble end (a string is split between them by its
position, :meth:`Body.bridge_split`); with two outputs, output 0 is left
and output 1 right. The mode set, its laws, why the response has no deep
notches and why modes rather than a convolution are in
:mod:`synth.physics.soundboard`; the kernels are in :mod:`synth.kernels.body`.

Level. The modal part and the direct part each have a white-noise power
gain of 1 (averaged over the inputs, summed over the outputs). They are
partly correlated (positive residues: the modal part's real part is
positive), so a plain crossfade ``(1 - wet) dry + wet modes`` would not keep
the level; the two gains are divided by the exact broadband gain of the
mix,

    dry_gain = (1 - wet) / c,  wet_gain = wet / c,
    c^2 = (1 - wet)^2 + wet^2 + 2 wet (1 - wet) X,
    X = mean_b sum_c dry_cb m_cb[0]   (m_cb the modal impulse response),

so the output's white-noise power equals the input's at every ``wet`` and a
preset can switch the body on without a level jump. A stereo body gives the
same loudness (BS.1770 sums the channels' powers) as a mono one.  These
gains are those of the board at 48 kHz
(:data:`synth.physics.soundboard.REFERENCE_FS`) whatever rate it runs at:
its response in Hz, not its white-noise gain up to the rate's Nyquist
frequency, stays the same at 44.1, 88.2 or 96 kHz.

Cost (default 96 modes at 48 kHz in 128-sample blocks, one core of a
2.6 GHz AVX-512 Xeon shared with other jobs): ~36 ns per output sample for
one input and one output (0.17 % of a core; 18 ns of it in the kernel, the
rest the wrapper's ~2 us per call), ~53 ns for two inputs and two outputs
(0.26 %; 1 x 2 and 2 x 1 the same); see
``tests/test_body.py::test_cost_well_under_one_percent_of_a_core``. No
allocation per block when ``out`` is given (views only); blocks of any
length (including 0) give exactly the one-shot result; zero latency.
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from .signal import as_mono_block, output_block
from .board_mass import BoardMass
from .spread import Spread

from synth.kernels.body import body_process as _kernel_mono
from synth.kernels.body import body_process_mimo as _kernel_mimo
from synth.physics.soundboard import (
    DEFAULT_N_MODES,
    DEFAULT_SEED,
    REFERENCE_FS,
    mass_section,
    resonator_coefs,
    section_response,
    soundboard_modes,
    white_noise_cross_energy,
)

__all__ = ["Body", "DEFAULT_WET"]

#: Default balance between the modes and the direct part.
DEFAULT_WET = 0.4
#: Longest impulse response :meth:`Body.impulse_response` will make (samples).
MAX_IR_SAMPLES = 1 << 26
#: Frequencies per chunk in :meth:`Body.response` (memory ~ K x chunk complex).
_RESPONSE_CHUNK = 2048


#: mode sets and their modal Gram matrices, by the board's arguments (:class:`Body`)
_BOARDS: dict = {}
#: the board's mass-law sections by (fs, mass_hz), kept as the modes are (:class:`Body`)
_MASS_SECTIONS: dict = {}


def _path_coefs(m, c, b, coefs) -> np.ndarray:
    """Coefficients (3, K) of the modal path from input b to output c of the
    mode set ``m``: the unit sections ``coefs`` scaled by the pickup and
    the drive."""
    k = coefs.copy()
    k[0] *= m.pickup[c] * m.drive[b]
    return k


def _modal_energy(m) -> np.ndarray:
    """The modal part's white-noise Gram matrix (B, B), summed over the
    outputs, at the reference rate, of the mode set ``m`` (a
    :class:`~synth.physics.soundboard.BoardModes`)."""
    B, C = m.inputs, m.outputs
    ref = resonator_coefs(REFERENCE_FS, m.freqs_hz, m.t60_s, np.ones(m.n_modes))
    banks = [[_path_coefs(m, c, b, ref) for b in range(B)] for c in range(C)]
    gram = np.zeros((B, B))
    for c in range(C):
        for b in range(B):
            for b2 in range(B):
                gram[b, b2] += white_noise_cross_energy(banks[c][b], banks[c][b2])
    return gram


class Body:
    """Soundboard modal bank with a direct part, streaming block by block.

    Parameters
    ----------
    fs : int or float
        Sample rate of the signal in Hz (>= 8000), normally the engine's
        output rate (48000).
    n_modes : int
        Number of modes, 1 .. 1024 (default 96).
    seed : int
        Seed of the board's random draws, >= 0 (default 1); fixed seed, same
        board (for any numbers of inputs and outputs).
    wet : float
        Balance, 0 .. 1: 0 = the direct part only, 1 = the modes only
        (default 0.4). Power-compensated (see the module docstring). Can be
        changed between blocks by assigning ``body.wet`` (an abrupt change
        may click).
    size : float
        Board scale, 0.25 .. 4 (default 1): mode frequencies divide by it
        (lowest mode 50 / size Hz), decay times multiply by it.
    brightness : float
        Spectral tilt of the board's response in dB per octave re 1 kHz,
        -12 .. 12 (default 0).
    inputs : int
        Bridge inputs, 1 or 2 (0: bass end, 1: treble end); default 1.
    outputs : int
        Outputs, 1 or 2 (0: left, 1: right); default 1.
    peaks : sequence of (f_hz, q, level_db), optional
        Named resonances on top of the ``n_modes`` diffuse modes (a gourd's
        air mode, a top plate's first modes), see
        :func:`synth.physics.soundboard.soundboard_modes`; default none.
    spread_ms : float, optional
        The radiation's spread, ms (0 .. 20; 0, the default: none): an
        allpass cascade on the outputs
        (:func:`synth.physics.soundboard.spread_allpasses`).
    mass_hz : float, optional
        The board's mass corner, Hz (0 .. 20000, under fs / 2; 0, the
        default: none): above it the outputs fall 6 dB per octave
        (:func:`synth.physics.soundboard.mass_section`).

    Attributes
    ----------
    modes : synth.physics.soundboard.BoardModes
        The mode set: ``freqs_hz``, ``t60_s`` (K,), ``drive`` (B, K),
        ``pickup`` (C, K), ``dry`` (C, B).
    freqs_hz, t60_s : ndarray, shape (K,)
        Shortcuts to the mode set's.
    coefs : ndarray, shape (3, K)
        Resonator coefficients with unit peak gains, rows b0, a1, a2.
    dry_gain, wet_gain : float
        The gains of the direct and modal parts for the current ``wet``.
    """

    def __init__(self, fs, n_modes=DEFAULT_N_MODES, seed=DEFAULT_SEED, wet=DEFAULT_WET,
                 size=1.0, brightness=0.0, inputs=1, outputs=1, peaks=(), spread_ms=0.0,
                 store=None, mass_hz=0.0):
        def board():
            modes = soundboard_modes(fs, n_modes=n_modes, seed=seed, size=size,
                                     brightness=brightness, inputs=inputs, outputs=outputs,
                                     peaks=peaks)
            return modes, _modal_energy(modes)

        if store is None:
            self.modes, gram = board()
        else:
            # (the modes and their energies: 20-25 ms for the grand's 2 x 2
            # board, kept on disk by ``store``, the engine's
            # synth.voices.design_store, as the listener's calibration)
            key = (float(fs), n_modes, seed, size, brightness, inputs, outputs,
                   tuple(tuple(p) for p in peaks))
            self.modes, gram = store.kept(_BOARDS, "body", key, board,
                                          lambda v: isinstance(v, tuple) and len(v) == 2)
        m = self.modes
        self.fs = float(fs)
        self.n_modes = m.n_modes  # the diffuse modes and the named peaks
        self.seed = int(seed)
        self.size = float(size)
        self.brightness = float(brightness)
        self.inputs = m.inputs
        self.outputs = m.outputs
        self.freqs_hz, self.t60_s = m.freqs_hz, m.t60_s
        self.coefs = resonator_coefs(self.fs, m.freqs_hz, m.t60_s, np.ones(self.n_modes))
        K, B, C = self.n_modes, self.inputs, self.outputs
        # the kernels' arrays
        self._mono = B == 1 and C == 1
        if self._mono:
            self._coefs_mono = self.coefs.copy()
            self._coefs_mono[0] *= m.pickup[0] * m.drive[0]
            self._state = np.zeros((2, K + 1))
        else:
            self._drive2 = np.zeros((2, K))
            self._drive2[:B] = m.drive
            self._gains2 = np.empty((2, K))
            self._gains2[:] = self.coefs[0] * m.pickup  # one output: the row twice
            self._dry_unit = np.zeros((2, 2))
            self._dry_unit[:, :B] = m.dry  # one output: the row twice
            self._dry2 = np.zeros((2, 2))
            self._state = np.zeros((2, K + 2))
        #: energies of the parts (white noise): the modal Gram matrix (B, B)
        #: summed over outputs, and X = mean_b sum_c dry_cb m_cb[0]
        #: both at the reference rate (the board's level and balance do not
        #: depend on the rate it runs at: soundboard.REFERENCE_FS)
        self._gram_modal = gram.copy()
        ref = self.coefs if self.fs == REFERENCE_FS else resonator_coefs(
            REFERENCE_FS, m.freqs_hz, m.t60_s, np.ones(self.n_modes))
        banks = [[self._bank(c, b, ref) for b in range(B)] for c in range(C)]
        self.ir_first = np.array([[banks[c][b][0].sum() for b in range(B)] for c in range(C)])
        self._cross = float((m.dry * self.ir_first).sum() / B)
        self.wet = wet
        #: the radiation's spread on the outputs (:class:`synth.dsp.spread.Spread`), or None
        self.spread = None if float(spread_ms) == 0.0 else Spread(self.fs, spread_ms, C)
        #: the board's mass law on the outputs (:class:`synth.dsp.board_mass.BoardMass`), or None
        self.mass = None
        if float(mass_hz) != 0.0:
            section = None
            if store is not None:
                # (the fit, 3-7 ms and the import of scipy.optimize, 0.3-0.5 s
                # of a warm start, kept on disk with the modes)
                section = store.kept(_MASS_SECTIONS, "board-mass", (self.fs, float(mass_hz)),
                                     lambda: mass_section(self.fs, mass_hz),
                                     lambda v: isinstance(v, tuple) and len(v) == 3)
            self.mass = BoardMass(self.fs, mass_hz, C, section)
        self._post = self._stages()

    @classmethod
    def from_design(cls, fs, design, store=None):
        """The body an instrument describes (a
        :class:`synth.physics.soundboard.BodyDesign`) at the rate ``fs`` (Hz);
        ``store``: where its modes are kept between runs (an object with
        ``kept(memo, kind, key, make, valid)``, as :class:`Body`)."""
        return cls(fs, n_modes=design.n_modes, seed=design.seed, wet=design.wet,
                   size=design.size, brightness=design.brightness,
                   inputs=design.inputs, outputs=design.outputs, peaks=design.peaks,
                   spread_ms=design.spread_ms, store=store, mass_hz=design.mass_hz)

    def _bank(self, c, b, coefs=None):
        """Coefficients (3, K) of the modal path from input b to output c
        (``coefs``: the unit sections, by default the body's own)."""
        return _path_coefs(self.modes, c, b, self.coefs if coefs is None else coefs)

    # -- parameters -------------------------------------------------------------

    @property
    def wet(self):
        """Balance between the modes and the direct part, 0 .. 1."""
        return self._wet

    @wet.setter
    def wet(self, value):
        ok = not isinstance(value, bool) and isinstance(value, numbers.Real)
        v = float(value) if ok else math.nan
        if not (math.isfinite(v) and 0.0 <= v <= 1.0):
            raise ValueError(f"wet = {value!r} is out of range (0 <= value <= 1)")
        d = 1.0 - v
        c = math.sqrt(d * d + v * v + 2.0 * v * d * self._cross)
        self._wet = v
        self.dry_gain = d / c
        self.wet_gain = v / c
        if not self._mono:
            self._dry2[:] = self.dry_gain * self._dry_unit

    # -- stereo bridge --------------------------------------------------------

    def gram(self):
        """White-noise Gram matrix of the inputs (B, B), summed over the outputs.

        ``G[b, b'] = sum_c sum_n h_cb[n] h_cb'[n]`` for the whole body (direct
        and modal parts at the current ``wet``): the output power for white
        noise fed to the inputs with weights w is ``w @ G @ w``.
        """
        m = self.modes
        dg, wg = self.dry_gain, self.wet_gain
        G = dg * dg * (m.dry.T @ m.dry) + wg * wg * self._gram_modal
        X = m.dry.T @ self.ir_first  # X[b, b'] = sum_c dry_cb m_cb'[0]
        return G + dg * wg * (X + X.T)

    def bridge_split(self, t):
        """Weights (w0, w1) that feed a string at bridge position ``t`` to the inputs.

        ``t`` runs from 0 (the bass end, input 0 alone) to 1 (the treble end,
        input 1 alone). The weights are the linear split ``(1 - t, t)`` times
        one gain that keeps the body's output power (white noise, summed over
        the outputs) at the mean of the two ends' for every ``t``: without it a
        string in the middle would come out ~0.1 dB low (the two inputs'
        responses are partly decorrelated). With one input: (1.0,).

        Parameters
        ----------
        t : float
            Position along the bridge, 0 .. 1.

        Returns
        -------
        tuple of float
            ``(w0, w1)`` (or ``(1.0,)`` for a one-input body).
        """
        ok = not isinstance(t, bool) and isinstance(t, numbers.Real)
        v = float(t) if ok else math.nan
        if not (math.isfinite(v) and 0.0 <= v <= 1.0):
            raise ValueError(f"t = {t!r} is out of range (0 <= value <= 1)")
        if self.inputs == 1:
            return (1.0,)
        G = self.gram()
        w = np.array([1.0 - v, v])
        s = math.sqrt(0.5 * (G[0, 0] + G[1, 1]) / float(w @ G @ w))
        return (float(s * w[0]), float(s * w[1]))

    # -- streaming --------------------------------------------------------------

    def fresh_copy(self):
        """A body of the same design and ``wet`` (sharing its read-only
        coefficient arrays) at rest: built in microseconds where a new
        design takes several milliseconds (an output path made in the audio
        callback)."""
        import copy

        b = copy.copy(self)
        b._state = np.zeros_like(self._state)
        b.spread, b.mass = (None if s is None else s.fresh_copy() for s in (self.spread, self.mass))
        b._post = b._stages()
        if not self._mono:
            b._dry2 = self._dry2.copy()       # the wet setter writes it in place
        return b

    def reset(self):
        """Forget all history (silence before the next sample)."""
        self._state[:] = 0.0
        for stage in self._post:
            stage.reset()

    def _stages(self) -> tuple:
        """The stages on the outputs, in order: the spread, then the mass law."""
        return tuple(s for s in (self.spread, self.mass) if s is not None)

    def _inputs(self, x):
        """x as a (B, n) float64 array with contiguous rows (a view when it can be)."""
        if isinstance(x, np.ndarray) and x.ndim == 1 and self.inputs == 1:
            return as_mono_block(x).reshape(1, -1)
        x = np.asarray(x)
        if x.ndim != 2 or x.shape[0] != self.inputs:
            want = "(n,) or (1, n)" if self.inputs == 1 else "(2, n)"
            raise ValueError(f"x has shape {x.shape}; must be {want} (inputs = {self.inputs})")
        if x.dtype.kind not in "fiu":
            raise ValueError(f"x has dtype {x.dtype}; must be real (float or integer)")
        if x.dtype != np.float64 or x.strides[1] != 8:
            x = np.ascontiguousarray(x, dtype=np.float64)
        if not math.isfinite(x.sum()) and not np.isfinite(x).all():
            b, i = (int(v[0]) for v in np.nonzero(~np.isfinite(x)))
            raise ValueError(f"x[{b}, {i}] = {x[b, i]} is not finite; input samples must be finite")
        return x

    def _outputs(self, out, n):
        """(the (C, >= n) array the kernel writes, what process returns)."""
        C = self.outputs
        if out is None:
            out = np.empty((C, n)) if C == 2 else np.empty(n)
        if not isinstance(out, np.ndarray) or out.dtype != np.float64:
            raise ValueError("out must be a float64 ndarray")
        if not out.flags.writeable:
            raise ValueError("out must be writeable")
        if C == 1 and out.ndim == 1:
            if out.shape[0] < n:
                raise ValueError(f"out has length {out.shape[0]}; must be >= {n} (len(x))")
            return out.reshape(1, -1) if out.flags.c_contiguous else out[None, :], out[:n]
        if out.ndim != 2 or out.shape[0] != C or out.shape[1] < n:
            want = f"(>= {n},) or (1, >= {n})" if C == 1 else f"(2, >= {n})"
            raise ValueError(f"out has shape {out.shape}; must be {want} (outputs = {C})")
        return out, out[:, :n]

    def process(self, x, out=None):
        """Filter one block; the state carries over to the next call.

        Parameters
        ----------
        x : array_like of float
            Input block at ``fs``, finite values, any length n >= 0: shape
            (n,) or (1, n) for one input, (2, n) for two (row 0 the bass end,
            row 1 the treble end of the bridge).
        out : ndarray of float64, optional
            Where to write: shape (>= n,) (or (1, >= n)) for one output,
            (2, >= n) for two. May be ``x`` itself (in place). Any strides;
            no allocation when given (with a one-input, one-output body whose
            ``out`` is not contiguous, one temporary block).

        Returns
        -------
        ndarray of float64
            ``out[:n]`` for one output, ``out[:, :n]`` for two: the direct
            part plus the modes, through the radiation's spread and the
            board's mass law if the body has them (:attr:`spread`,
            :attr:`mass`).
        """
        y = self._modes(x, out)
        for stage in self._post:
            stage.process(y)
        return y

    def _modes(self, x, out):
        """:meth:`process` without the spread."""
        if self._mono:
            if isinstance(x, np.ndarray) and x.ndim == 2 and x.shape[0] == 1:
                x = x[0]
            if isinstance(out, np.ndarray) and out.ndim == 2 and out.shape[0] == 1:
                out = out[0]
            x = as_mono_block(x)
            n = x.shape[0]
            out = output_block(out, n, "len(x)")
            if n == 0:
                return out[:0]
            if self._wet == 0.0:
                # the direct part alone (dry gain 1): the modes are not run
                # (a render with body.wet = 0 spends nothing on them; they
                # start from rest if wet is raised later)
                out[:n] = x
                return out[:n]
            target = out if out.flags.c_contiguous else np.empty(n, dtype=np.float64)
            _kernel_mono(x, n, self._coefs_mono, self._state, self.dry_gain, self.wet_gain, target)
            if target is not out:
                out[:n] = target[:n]
            return out[:n]
        x2 = self._inputs(x)
        n = x2.shape[1]
        target, result = self._outputs(out, n)
        if n and self._wet == 0.0:
            # the direct part alone, output c = sum_b dry[c, b] x_b (as the
            # kernel's direct path); the modes are not run
            xb = x2[:, :n]
            if np.shares_memory(target, xb):
                xb = xb.copy()
            B = self.inputs
            for c in range(target.shape[0]):
                row = target[c, :n]
                np.multiply(xb[0], self._dry2[c, 0], out=row)
                for b in range(1, B):
                    row += self._dry2[c, b] * xb[b]
            return result
        if n:
            _kernel_mimo(x2, n, self._drive2, self._gains2, self.coefs, self._state, self._dry2,
                         self.wet_gain, target)
        return result

    # -- analysis ------------------------------------------------------------------

    def impulse_response(self, n):
        """The first ``n`` samples of the response to a unit impulse (current ``wet``).

        Runs on a fresh state; the streaming state is left untouched.

        Parameters
        ----------
        n : int
            Length in samples, 0 .. 2^26.

        Returns
        -------
        ndarray of float64
            Shape (n,) for a one-input, one-output body (``dry_gain delta +
            wet_gain h``); otherwise (C, B, n), the response of output c to
            an impulse at input b.
        """
        if isinstance(n, bool) or not isinstance(n, numbers.Integral) or not 0 <= n <= MAX_IR_SAMPLES:
            raise ValueError(f"n = {n!r} is out of range (integer, 0 <= value <= {MAX_IR_SAMPLES})")
        n = int(n)
        saved = self._state.copy()
        saved_post = [stage.state() for stage in self._post]
        try:
            if self._mono:
                self.reset()
                y = np.zeros(n)
                if n:
                    y[0] = 1.0
                    self.process(y, out=y)
                return y
            C, B = self.outputs, self.inputs
            h = np.zeros((C, B, n))
            for b in range(B):
                self.reset()
                d = np.zeros((B, n))
                if n:
                    d[b, 0] = 1.0
                    self.process(d if B == 2 else d[0], out=h[:, b] if C == 2 else h[0, b])
            return h
        finally:
            self._state[:] = saved
            for stage, st in zip(self._post, saved_post):
                stage.restore(st)

    def response(self, f_hz, weights=None):
        """Complex frequency response of the body (current ``wet``).

        Parameters
        ----------
        f_hz : array_like of float, shape (F,)
            Frequencies in Hz, 0 .. fs / 2.
        weights : sequence of float, optional
            Input weights (B,), e.g. :meth:`bridge_split`; when given the
            response to that mix of the inputs.

        Returns
        -------
        ndarray of complex128
            Shape (C, B, F), or (C, F) with ``weights``: ``dry_gain dry_cb +
            wet_gain sum_k pickup_ck drive_bk H_k(f)``, times the spread's
            response (of magnitude 1) and the mass law's if the body has
            them.
        """
        f = np.atleast_1d(np.asarray(f_hz, dtype=np.float64))
        m = self.modes
        C, B = self.outputs, self.inputs
        H = np.empty((C, B, f.size), dtype=np.complex128)
        for s in range(0, f.size, _RESPONSE_CHUNK):
            R = section_response(self.fs, self.coefs, f[s:s + _RESPONSE_CHUNK])  # (K, F')
            for c in range(C):
                for b in range(B):
                    H[c, b, s:s + _RESPONSE_CHUNK] = (self.wet_gain * (m.pickup[c] * m.drive[b]) @ R
                                                      + self.dry_gain * m.dry[c, b])
        for stage in self._post:
            H *= stage.response(f)
        if weights is None:
            return H
        w = np.asarray(weights, dtype=np.float64)
        if w.shape != (B,):
            raise ValueError(f"weights has shape {w.shape}; must be ({B},)")
        return np.einsum("cbf,b->cf", H, w)
