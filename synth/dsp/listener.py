"""The listening position as a stage of the engine's output (after the body).

Why: the voice's output is the sound its body radiates, heard nowhere in
particular; a recorded piano is heard through microphones in a room (issue
41).  The preset's ``[listener]`` table puts the listener at a position
(close microphones over the strings, the player's seat, a seat in a hall)
in a room (designed, a measured impulse response's, or none).

How: :func:`synth.physics.listener.design_listener` designs the path (the
direct sound's distance, directivity and air absorption as one FIR, the
early reflections as taps through one FIR, the late reverberation as a
feedback delay network); :mod:`synth.kernels.listener` runs it (its sums as
vector loops over segments of up to ``SEGMENT`` samples, the network's
lines side by side), the same samples for any block sizes, with no allocation.  This
wrapper owns the state, sets the levels and validates.

Levels.  The late reverberation is scaled so that its mean power in the
1 kHz octave is the design's ``late_energy`` (the diffuse field re the
direct sound at 1 m): measured at set-up on the network's impulse response.
With ``level = "matched"`` (the default) the whole stage is then scaled so
that its mean power gain over the octaves 125 Hz - 4 kHz (averaged over the
inputs, summed over the outputs, as :class:`synth.dsp.body.Body`) is 1: the
preset's ``output.gain`` holds at every position.  With ``"distance"`` the
direct sound at 1 m is unity (farther is quieter).

Cost: see docs/benchmarks.md, "The listener".  Zero latency (the delays are
relative to the direct sound).
"""

from __future__ import annotations

import math

import numpy as np

from synth.kernels.listener import SEGMENT, listener_process as _kernel
from synth.physics.listener import (
    DIRECTIVITY_RANGE_DB, DISTANCE_RANGE_M, HUMIDITY_RANGE_PERCENT, LEVELS, POSITIONS, ROOM_NAMES,
    TEMPERATURE_RANGE_C, ListenerDesign, design_listener)

from .signal import channel_blocks

__all__ = ["Listener", "LEVEL_BANDS_HZ"]

#: the octave bands whose mean power gain ``level = "matched"`` holds at 1
LEVEL_BANDS_HZ = (125.0, 250.0, 500.0, 1000.0, 2000.0, 4000.0)
#: the longest impulse response measured at set-up (s)
MAX_IR_S = 12.0


def _band_mean(power: np.ndarray, fs: float, fc: float) -> float:
    f = np.linspace(0.0, fs / 2.0, power.shape[-1])
    sel = (f >= fc / math.sqrt(2.0)) & (f < fc * math.sqrt(2.0))
    return float(power[..., sel].mean())



#: calibrations kept for the process (:meth:`Listener._calibrate`): the
#: design's arguments -> (late scale, level scale); a few positions and
#: rates in use, cleared past :data:`_MAX_CALIBRATIONS`
_CALIBRATIONS: dict = {}
_MAX_CALIBRATIONS = 64


def _scales_ok(value) -> bool:
    """Whether a stored value is a calibration (two floats or None)."""
    return (isinstance(value, tuple) and len(value) == 2
            and all(v is None or isinstance(v, float) for v in value))

class Listener:
    """The listening stage, streaming block by block.

    Parameters
    ----------
    design : synth.physics.listener.ListenerDesign
        From :func:`synth.physics.listener.design_listener`.

    Attributes
    ----------
    design : ListenerDesign
    channels : int
    tail_s : float
        How long the stage rings on after its input stops (the network's
        longest T60, at low frequencies; 0 without a room).
    late_scale, level_scale : float
        The late reverberation's scale and the stage's (``"matched"``).
    """

    def __init__(self, design: ListenerDesign, calibration_key=None, store=None):
        self.design = d = design
        C = self.channels = int(d.channels)
        L = d.direct.shape[0]
        self._hd = np.ascontiguousarray(d.direct, dtype=np.float64)
        self._he = np.ascontiguousarray(d.early_fir, dtype=np.float64)
        self._le = np.ascontiguousarray(d.early_lag, dtype=np.int64).reshape(C, -1)
        self._ge = np.ascontiguousarray(d.early_gain, dtype=np.float64).reshape(C, -1)
        self._pre = int(d.pre)
        self._lens = np.ascontiguousarray(d.fdn_len, dtype=np.int64)
        self._off = np.zeros(len(self._lens), dtype=np.int64)
        if len(self._lens):
            self._off[1:] = np.cumsum(self._lens)[:-1]
        self._fa = np.ascontiguousarray(d.fdn_a, dtype=np.float64)
        self._fb = np.ascontiguousarray(d.fdn_b, dtype=np.float64)
        self._fin = np.ascontiguousarray(d.fdn_in, dtype=np.float64)
        self._fout = np.ascontiguousarray(d.fdn_out, dtype=np.float64).reshape(C, -1).copy()
        lag_max = int(self._le.max()) if self._le.size else 0
        # the histories hold a segment more than the longest lag (the kernel
        # writes a segment's samples before its sums read them)
        self._span = max(L, lag_max + 1, self._pre + 1, 2)
        H = self._span + SEGMENT
        self._hist = np.zeros((C, 2 * H))
        self._ehist = np.zeros((C, 2 * (L + SEGMENT)))
        self._sc = np.zeros((len(self._lens) + 2, SEGMENT))
        self._lines = np.zeros(int(self._lens.sum()))
        self._lpos = np.zeros(len(self._lens), dtype=np.int64)
        self._z = np.zeros(len(self._lens))
        self._i = np.zeros(2, dtype=np.int64)
        g_dc = self._fa / (1.0 - self._fb) if len(self._lens) else np.zeros(0)
        t60 = [-3.0 * m / (d.fs * math.log10(g)) for m, g in zip(self._lens, g_dc) if 0 < g < 1]
        self.tail_s = float(max(t60, default=0.0))
        self.late_scale = 1.0
        self.level_scale = 1.0
        self._calibrate(calibration_key, store)
        self.reset()

    @classmethod
    def from_preset(cls, preset, fs_out: int, channels: int, store=None) -> "Listener | None":
        """The stage of ``preset``'s ``[listener]`` table, or None (no table,
        or ``position`` left out): the output as the body radiates it.
        ``store``: where calibrations are kept between processes
        (:meth:`_calibrate`)."""
        spec = getattr(preset, "listener", None)
        if spec is None:
            return None
        return cls.design(fs_out, channels, spec.position, spec.room, spec.distance_m,
                          spec.directivity_db, spec.temperature_c, spec.humidity_percent,
                          spec.level, store=store)

    @classmethod
    def design(cls, fs, channels, position="close", room=None, distance_m=None, directivity_db=None,
               temperature_c=20.0, humidity_percent=50.0, level="matched",
               store=None) -> "Listener":
        """Validate, design and build (the arguments of
        :func:`synth.physics.listener.design_listener`); a bad value is a
        one-line ``ValueError`` naming ``listener.<key>``, the value and
        the range."""
        if position not in POSITIONS:
            raise ValueError(f"listener.position = {position!r} is not one of "
                             f"{', '.join(POSITIONS)}")
        if level not in LEVELS:
            raise ValueError(f"listener.level = {level!r} is not one of {', '.join(LEVELS)}")
        if room is not None and (not isinstance(room, str) or not room):
            raise ValueError(f"listener.room = {room!r}: give one of {', '.join(ROOM_NAMES)} "
                             f"or a WAV file's path")
        for name, v, (lo, hi), unit in (("distance_m", distance_m, DISTANCE_RANGE_M, " m"),
                                        ("directivity_db", directivity_db, DIRECTIVITY_RANGE_DB, " dB"),
                                        ("temperature_c", temperature_c, TEMPERATURE_RANGE_C, " C"),
                                        ("humidity_percent", humidity_percent,
                                         HUMIDITY_RANGE_PERCENT, " %")):
            if v is None:
                continue
            ok = not isinstance(v, bool) and isinstance(v, (int, float)) and math.isfinite(v)
            if not ok or not lo <= v <= hi:
                raise ValueError(f"listener.{name} = {v!r}{unit if ok else ''} is out of range "
                                 f"({lo:g} <= value <= {hi:g})")
        if isinstance(channels, bool) or channels not in (1, 2):
            raise ValueError(f"channels = {channels!r} is out of range (1 or 2)")
        # a named room (or none) is designed from these values alone: its
        # calibration can be kept for the next engine (a WAV file's cannot:
        # the file may change)
        key = None
        if room is None or room in ROOM_NAMES:
            key = (float(fs), int(channels), position, room, distance_m, directivity_db,
                   float(temperature_c), float(humidity_percent), level)
        return cls(design_listener(float(fs), int(channels), position, room, distance_m,
                                   directivity_db, float(temperature_c), float(humidity_percent),
                                   level), calibration_key=key, store=store)

    # -- levels ------------------------------------------------------------------------
    def _ir(self, n: int, late: bool, early: bool, direct: bool) -> np.ndarray:
        """The impulse responses (inputs, outputs, n) of the chosen parts, from silence."""
        C = self.channels
        saved = (self._hd, self._ge, self._fout)
        if not direct:
            self._hd = np.zeros_like(self._hd)
        if not early:
            self._ge = np.zeros_like(self._ge)
        if not late:
            self._fout = np.zeros_like(self._fout)
        h = np.zeros((C, C, n))
        # views of wider arrays, as the engine's blocks are: the kernel is
        # compiled for one array layout, not two
        x = np.zeros((C, n + 1))[:, :n]
        o = np.zeros((C, n + 1))[:, :n]
        try:
            for b in range(C):
                self.reset()
                x[:] = 0.0
                x[b, 0] = 1.0
                self.process(x, out=o)
                h[b] = o
        finally:
            self._hd, self._ge, self._fout = saved
        self.reset()
        return h

    def _calibrate(self, key=None, store=None) -> None:
        """Scale the late reverberation to the design's energy and (level
        "matched") the whole stage to unit mean power in ``LEVEL_BANDS_HZ``,
        from the stage's own impulse responses (the grand's close position:
        25 ms in a warm process, 1.3 ms loaded from the store, medians of 7,
        2-vCPU Zen 5).  With ``key`` (the design's arguments), the scales found
        are kept for the process and applied again, the same operations in
        the same order, to a stage built with the same key; with ``store``
        too (an object with ``kept(memo, kind, key, make, valid)``: the
        engine gives :mod:`synth.voices.design_store`, whose files are named
        by the code as well), they are kept on disk for the next process."""
        if key is None:
            scales = self._measure_scales()
        else:
            if key not in _CALIBRATIONS and len(_CALIBRATIONS) >= _MAX_CALIBRATIONS:
                _CALIBRATIONS.clear()
            if store is not None:
                scales = store.kept(_CALIBRATIONS, "listener", key, self._measure_scales,
                                    _scales_ok)
            else:
                if key not in _CALIBRATIONS:
                    _CALIBRATIONS[key] = self._measure_scales()
                scales = _CALIBRATIONS[key]
        self._apply_scales(*scales)

    def _measure_scales(self) -> tuple:
        """(late scale, level scale) from the unscaled stage's impulse
        responses (None where not scaled): :meth:`_calibrate`'s measure."""
        d = self.design
        fs = d.fs
        n_short = 2 * self._span + 2 * self._hd.shape[0]
        n = n_short
        if len(self._lens):
            n = int(min(MAX_IR_S, self.tail_s * 1.1) * fs) + self._pre + int(self._lens.max()) + n_short
        nfft = 1 << max(10, (n - 1).bit_length())
        de = self._ir(n, late=False, early=True, direct=True)
        late_scale = level_scale = None
        if len(self._lens):
            late = self._ir(n, late=True, early=False, direct=False)
            pw = (np.abs(np.fft.rfft(late, nfft)) ** 2).sum(axis=1).mean(axis=0)
            e = _band_mean(pw, fs, 1000.0)
            late_scale = math.sqrt(d.late_energy / e) if e > 0 else 0.0
            de = de + late_scale * late
        if d.level == "matched":
            pw = (np.abs(np.fft.rfft(de, nfft)) ** 2).sum(axis=1).mean(axis=0)
            m = float(np.mean([_band_mean(pw, fs, fc) for fc in LEVEL_BANDS_HZ]))
            level_scale = 1.0 / math.sqrt(m)
        return late_scale, level_scale

    def _apply_scales(self, late_scale, level_scale) -> None:
        """The late reverberation times ``late_scale`` (None: not scaled),
        then the whole stage times ``level_scale`` (None: not scaled)."""
        if late_scale is not None:
            self.late_scale = late_scale
            self._fout *= self.late_scale
        if level_scale is not None:
            self.level_scale = level_scale
            self._hd = self._hd * self.level_scale
            self._ge = self._ge * self.level_scale
            self._fout *= self.level_scale

    # -- streaming ---------------------------------------------------------------------
    def reset(self) -> None:
        """Silence, as new."""
        self._hist[:] = 0.0
        self._ehist[:] = 0.0
        self._lines[:] = 0.0
        self._lpos[:] = 0
        self._z[:] = 0.0
        self._i[:] = 0

    def process(self, x: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """One block; the state carries over to the next call.

        Parameters
        ----------
        x : ndarray of float64
            Shape (n,) for one channel, (channels, n) for any; finite.
        out : ndarray of float64, optional
            Same shape as ``x`` (may be ``x``: in place).
        """
        x2, out, o2 = channel_blocks(x, out, self.channels)
        _kernel(x2, x2.shape[1], self._hd, self._le, self._ge, self._he, self._pre, self._lens,
                self._off, self._fa, self._fb, self._fin, self._fout, self._hist, self._ehist,
                self._lines, self._lpos, self._z, self._i, self._sc, o2)
        return out
