"""What every render of the Python API returns: :class:`Audio`."""

from __future__ import annotations

import base64
import html
import io
import math
import os
import wave
from numbers import Integral

import numpy as np

from ..io.errors import SynthError

__all__ = ["Audio", "PLAYER_MAX_S"]

#: the longest audio a notebook's player embeds (s): beyond it, the first
#: PLAYER_MAX_S are embedded and the caption says so (a data URI of 16-bit
#: stereo at 48 kHz is 256 kB a second)
PLAYER_MAX_S = 30.0


class Audio:
    """Rendered audio: samples and their rate.

    Parameters
    ----------
    samples : array_like
        Samples, full scale 1.0, shape (frames, channels) or (frames,)
        (one channel); kept as float32, (frames, channels).
    fs : int
        Sample rate (Hz).

    Attributes
    ----------
    samples : numpy.ndarray
        float32, shape (frames, channels): 1 channel (mono presets) or 2
        (the stereo ones: the bridge's two ends, or a body with two outputs).
    fs : int
        Sample rate (Hz), 48000 unless another rate was asked for.

    Notes
    -----
    ``numpy.asarray(audio)`` gives :attr:`samples`; :meth:`to_wav` writes
    them as ``synth note`` does; in Jupyter an :class:`Audio` shows as an
    HTML5 player (16-bit, the first :data:`PLAYER_MAX_S` seconds).
    """

    __slots__ = ("samples", "fs")

    def __init__(self, samples, fs: int) -> None:
        a = np.asarray(samples, dtype=np.float32)
        if a.ndim == 1:
            a = a[:, None]
        if a.ndim != 2 or a.shape[1] < 1:
            raise ValueError(f"samples has shape {np.shape(samples)}: must be (frames,) or "
                             "(frames, channels)")
        if isinstance(fs, bool) or not isinstance(fs, Integral) or fs <= 0:
            raise ValueError(f"fs = {fs!r} is not a sample rate (a positive whole number of Hz)")
        self.samples = np.ascontiguousarray(a)
        self.fs = int(fs)

    # -- facts ----------------------------------------------------------------
    @property
    def frames(self) -> int:
        """Number of sample frames."""
        return int(self.samples.shape[0])

    @property
    def channels(self) -> int:
        """Number of channels (1 or 2)."""
        return int(self.samples.shape[1])

    @property
    def seconds(self) -> float:
        """Length (s)."""
        return self.frames / self.fs

    @property
    def peak_dbfs(self) -> float:
        """Sample peak (dB re full scale 1.0); -inf for silence."""
        p = float(np.max(np.abs(self.samples))) if self.samples.size else 0.0
        return 20.0 * math.log10(p) if p > 0.0 else -math.inf

    def __len__(self) -> int:
        return self.frames

    def __array__(self, dtype=None, copy=None):
        a = self.samples
        if dtype is not None and np.dtype(dtype) != a.dtype:
            return a.astype(dtype)
        return a.copy() if copy else a

    def __repr__(self) -> str:
        return (f"Audio({self.seconds:.3f} s, {self.channels} channel"
                f"{'s' if self.channels != 1 else ''}, {self.fs} Hz)")

    # -- output ---------------------------------------------------------------
    def to_wav(self, path, subtype: str = "float") -> None:
        """Write the samples to an audio file (atomically, as ``synth note``
        does: :func:`synth.io.wav.write_wav`), its format chosen by the
        extension as for ``synth note -o``.

        Parameters
        ----------
        path : str or path-like
            The file, ending in ``.wav``, ``.flac`` (24-bit PCM) or ``.ogg``
            (Ogg Vorbis, clipped to full scale); replaced if it exists, never
            left half-written.
        subtype : {"float", "pcm24"}
            For ``.wav``: 32-bit float (the default; values beyond full
            scale kept) or 24-bit PCM (clipped to full scale).

        Raises
        ------
        ValueError
            Another ``subtype``, or an extension of no format written here
            (``.mp3``: nothing is written).
        OSError
            The file cannot be written (a missing directory, a full disk):
            one line naming it.
        """
        from ..io.wav import FORMATS, SUBTYPES, write_wav

        if subtype not in SUBTYPES:
            raise ValueError(f"subtype = {subtype!r} is not allowed (choices: "
                             f"{', '.join(repr(s) for s in SUBTYPES)})")
        # the extension chooses the container, as for synth note -o: never
        # WAV data under another format's name
        ext = os.path.splitext(os.fspath(path))[1].lower()
        fmt = {e: f for f, e in FORMATS.items()}.get(ext)
        if fmt is None:
            raise ValueError(f"path = {os.fspath(path)!r}: the extension must choose an audio "
                             f"format ({', '.join(FORMATS.values())})")
        try:
            write_wav(os.fspath(path), self.samples, self.fs, subtype, fmt)
        except SynthError as e:
            raise OSError(str(e)) from None

    def wav16(self, max_seconds: float | None = PLAYER_MAX_S) -> bytes:
        """The first ``max_seconds`` (None: all) as a 16-bit PCM WAV file's
        bytes, clipped to full scale (what the notebook player plays)."""
        n = self.frames if max_seconds is None else min(self.frames,
                                                         int(round(max_seconds * self.fs)))
        x = np.clip(self.samples[:n].astype(np.float64), -1.0, 1.0)
        pcm = np.round(x * 32767.0).astype("<i2")
        buf = io.BytesIO()
        with wave.open(buf, "wb") as w:
            w.setnchannels(self.channels)
            w.setsampwidth(2)
            w.setframerate(self.fs)
            w.writeframes(pcm.tobytes())
        return buf.getvalue()

    def _repr_html_(self) -> str:
        """An HTML5 audio player (a base64 16-bit WAV data URI of at most
        :data:`PLAYER_MAX_S` seconds) with a caption."""
        data = base64.b64encode(self.wav16()).decode("ascii")
        kind = {1: "mono", 2: "stereo"}.get(self.channels, f"{self.channels} channels")
        peak = self.peak_dbfs
        cap = f"{self.seconds:.2f} s, {kind}, {self.fs} Hz, peak {peak:.1f} dBFS"
        if peak > 0.0:
            cap += " (clipped in the player)"
        if self.seconds > PLAYER_MAX_S:
            cap += f"; the player holds the first {PLAYER_MAX_S:g} s (to_wav writes all)"
        return (f'<div><audio controls preload="metadata" src="data:audio/wav;base64,{data}">'
                f"</audio><br><small>{html.escape(cap)}</small></div>")
