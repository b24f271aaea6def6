"""Atomic writing of WAV files and ``.npy`` arrays.

Both writers write to a temporary file in the destination directory and
then ``os.replace`` it onto the destination, so a failure (a full disk, an
exception, a kill between the two steps) never leaves a half-written file
under the requested name, and an existing file is either fully replaced or
left untouched.

libsndfile writes a WAV file through the temporary file's descriptor (its own
C I/O), not through soundfile's virtual I/O, whose Python write callback runs
inside a cffi callback: an exception there (``OSError`` from a full disk, or
``KeyboardInterrupt`` from Ctrl-C) is printed as a traceback and swallowed by
cffi, and the write goes on.  A failing write is reported by libsndfile and
raised here as an ``OSError`` naming the system's reason (``No space left on
device``).
"""

from __future__ import annotations

import errno
import math
import os
import secrets
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import BinaryIO

import numpy as np
import soundfile as sf

from synth.io.errors import SynthError, display_path

__all__ = ["WavWriteResult", "write_wav", "FORMATS", "write_wav_stream", "write_npy_atomic", "write_text_atomic", "write_bytes_atomic",
           "wav_bytes", "wav_max_frames", "FS_MIN_HZ", "FS_MAX_HZ", "SUBTYPES"]

FS_MIN_HZ = 8000
FS_MAX_HZ = 384000
MAX_CHANNELS = 64
SUBTYPES = ("float", "pcm24")
#: the audio formats written, by file extension: WAV (32-bit float or 24-bit
#: PCM), FLAC (24-bit PCM, lossless) and Ogg Vorbis (lossy), through libsndfile
FORMATS = {"wav": ".wav", "flac": ".flac", "ogg": ".ogg"}
_PCM24_SCALE = float(1 << 23)
_PCM24_MAX = 1.0 - 1.0 / _PCM24_SCALE  # largest representable sample, full scale is [-1, 1)
_WAV_MAX_DATA_BYTES = 0xFFFFFFFF - 1024  # RIFF sizes are 32-bit
#: frames per libsndfile write call: an interruption (a signal's handler
#: runs between calls) is noticed at least this often
_WRITE_FRAMES = 1 << 20


def wav_max_frames(channels: int, subtype: str = "float") -> int:
    """The most frames a WAV file of `channels` channels and `subtype`
    (``"float"``: 4 bytes a sample, ``"pcm24"``: 3) can hold (RIFF sizes are
    32-bit: about 4 GiB of samples)."""
    return _WAV_MAX_DATA_BYTES // (channels * (4 if subtype == "float" else 3))


def _libsndfile_failure(snd: sf.SoundFile, e: sf.LibsndfileError) -> OSError:
    """The OSError behind a libsndfile write error, with the system's
    reason when libsndfile kept it (``System error : No space left on
    device.`` -> ``OSError(ENOSPC, 'No space left on device')``)."""
    text = str(e)
    try:
        from soundfile import _ffi, _snd  # the handle's own message holds strerror(errno)

        handle = getattr(snd, "_file", None)
        text = _ffi.string(_snd.sf_strerror(handle if handle is not None else _ffi.NULL)).decode(
            "utf-8", "replace") or text
    except (ImportError, AttributeError, TypeError):
        pass
    for code in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EIO, errno.EROFS):
        if os.strerror(code) in text:
            return OSError(code, os.strerror(code))
    return OSError(text.removeprefix("System error : ").rstrip(".") or "libsndfile write error")


@dataclass(frozen=True)
class WavWriteResult:
    """What :func:`write_wav` wrote.

    Attributes
    ----------
    frames : int
        Number of sample frames.
    channels : int
        Number of channels.
    peak_dbfs : float
        Peak |sample| of the input in dB re full scale (1.0), before any
        clipping; ``-inf`` for silence or no frames. Above 0 means over full scale.
    n_clipped : int
        Samples changed by clipping to the PCM range [-1, 1 - 2**-23]
        (always 0 for ``"float"``, which stores values beyond full scale as they are).
    """

    frames: int
    channels: int
    peak_dbfs: float
    n_clipped: int


def _atomic_write(path: str | os.PathLike[str], write: Callable[[BinaryIO], None]) -> None:
    """Call ``write(f)`` on a fresh temporary file next to `path`, then rename it onto `path`."""
    path = os.fspath(path)
    shown = display_path(path)
    directory, base = os.path.split(os.path.abspath(path))
    if os.path.isdir(path):
        raise SynthError(f"{shown}: is a directory, cannot write a file there")
    tmp = os.path.join(directory, f".{base}.{secrets.token_hex(6)}.tmp")
    try:
        # 0o666 & ~umask, like a normally created file (mkstemp would force 0o600).
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0), 0o666)
    except OSError as e:
        raise SynthError(f"{shown}: cannot write ({e.strerror or e})") from None
    try:
        with os.fdopen(fd, "wb") as f:
            write(f)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException as e:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if isinstance(e, (OSError, sf.SoundFileError)):
            raise SynthError(f"{shown}: writing failed ({getattr(e, 'strerror', None) or e})") from e
        raise


def write_wav(path: str | os.PathLike[str], audio: np.ndarray, fs: int,
              subtype: str = "float", fmt: str = "wav") -> WavWriteResult:
    """Write audio to a WAV file atomically.

    Parameters
    ----------
    path : str or path-like
        Destination file; replaced atomically if it exists.
    audio : numpy.ndarray
        Real samples, shape ``(frames,)`` (mono) or ``(frames, channels)``,
        full scale = 1.0. Must be finite.
    fs : int
        Sample rate, Hz, 8000..384000.
    subtype : {"float", "pcm24"}
        ``"float"``: 32-bit IEEE float, values beyond +-1 kept as they are.
        ``"pcm24"``: 24-bit PCM, samples rounded to the nearest step of
        2**-23 and clipped to [-1, 1 - 2**-23] (the count is reported).
    fmt : {"wav", "flac", "ogg"}
        The container (:data:`FORMATS`): ``"wav"`` as `subtype` says;
        ``"flac"`` is 24-bit PCM whatever `subtype` (rounded and clipped as
        ``"pcm24"``), ``"ogg"`` Ogg Vorbis (samples clipped to [-1, 1]).

    Returns
    -------
    WavWriteResult
        frames, channels, input peak in dBFS and number of clipped samples.

    Raises
    ------
    SynthError
        Bad fs, subtype, shape, dtype, non-finite samples (the message says how
        many), a file too long for WAV, or an I/O failure. Nothing is left at
        `path` (an existing file is kept unchanged) when an error occurs.
    """
    shown = display_path(path)
    if isinstance(fs, bool) or not isinstance(fs, (int, np.integer)):
        raise SynthError(f"{shown}: fs = {fs!r} must be an integer sample rate in Hz "
                         f"({FS_MIN_HZ} <= fs <= {FS_MAX_HZ})")
    fs = int(fs)
    if not FS_MIN_HZ <= fs <= FS_MAX_HZ:
        raise SynthError(f"{shown}: fs = {fs} Hz is out of range ({FS_MIN_HZ} <= fs <= {FS_MAX_HZ})")
    if subtype not in SUBTYPES:
        raise SynthError(f"{shown}: subtype = {subtype!r} is not allowed (choices: 'float', 'pcm24')")
    a = np.asarray(audio)
    if a.dtype.kind not in "fiu" or a.dtype == np.bool_:
        raise SynthError(f"{shown}: audio has dtype {a.dtype}, expected real floating-point samples")
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2 or not 1 <= a.shape[1] <= MAX_CHANNELS:
        raise SynthError(f"{shown}: audio has shape {np.shape(audio)}, expected (frames,) or "
                         f"(frames, channels) with 1 <= channels <= {MAX_CHANNELS}")
    frames, channels = a.shape
    if a.dtype not in (np.float32, np.float64):
        a = a.astype(np.float64)       # (float32 is kept: no float64 copy of a long render)
    n_bad = int(a.size - np.count_nonzero(np.isfinite(a)))
    if n_bad:
        raise SynthError(f"{shown}: audio has {n_bad} non-finite samples (NaN or inf) of {a.size}; "
                         "nothing written")
    _check_fmt(shown, fmt)
    if fmt == "wav" and frames > wav_max_frames(channels, subtype):
        raise SynthError(f"{shown}: {frames} frames x {channels} channels is too long for a WAV "
                         f"file (4 GiB limit)")
    # (checked whole above: the stream writer need not look again)
    return _write_blocks(path, (a[i:i + _WRITE_FRAMES] for i in range(0, frames, _WRITE_FRAMES)),
                         fs, channels, subtype, checked=True, fmt=fmt)


def _check_fmt(shown: str, fmt: str) -> None:
    if fmt not in FORMATS:
        raise SynthError(f"{shown}: fmt = {fmt!r} is not allowed (choices: "
                         f"{', '.join(repr(f) for f in FORMATS)})")


def write_wav_stream(path: str | os.PathLike[str], blocks: Iterable[np.ndarray], fs: int,
                     channels: int, subtype: str = "float", fmt: str = "wav") -> WavWriteResult:
    """Write audio to a WAV file atomically, block by block as ``blocks``
    yields them: a render of hours holds one block in memory, not the
    whole of it (at 48 kHz a 3-hour stereo render is 8.3 GB of float64).

    Parameters
    ----------
    path : str or path-like
        Destination file; replaced atomically if it exists, once the last
        block is written.
    blocks : iterable of numpy.ndarray
        Real samples, each ``(frames,)`` (mono) or ``(frames, channels)``,
        full scale = 1.0, finite; consumed while the file is written (an
        exception it raises, a signal's among them, leaves no file).
    fs : int
        Sample rate, Hz, 8000..384000.
    channels : int
        Channels of every block, 1..64.
    subtype : {"float", "pcm24"}
        As :func:`write_wav`.
    fmt : {"wav", "flac", "ogg"}
        As :func:`write_wav`.

    Returns
    -------
    WavWriteResult
        As :func:`write_wav`, over all the blocks.

    Raises
    ------
    SynthError
        As :func:`write_wav`; a block with non-finite samples or of the
        wrong shape, or more frames than a WAV file holds, stops the write
        and leaves nothing at `path`.
    """
    shown = display_path(path)
    if isinstance(fs, bool) or not isinstance(fs, (int, np.integer)) or not (
            FS_MIN_HZ <= int(fs) <= FS_MAX_HZ):
        raise SynthError(f"{shown}: fs = {fs!r} is out of range (an integer sample rate, "
                         f"{FS_MIN_HZ} <= fs <= {FS_MAX_HZ} Hz)")
    fs = int(fs)
    if subtype not in SUBTYPES:
        raise SynthError(f"{shown}: subtype = {subtype!r} is not allowed (choices: 'float', 'pcm24')")
    if not (1 <= int(channels) <= MAX_CHANNELS):
        raise SynthError(f"{shown}: channels = {channels!r} is out of range "
                         f"(1 <= value <= {MAX_CHANNELS})")
    _check_fmt(shown, fmt)
    return _write_blocks(path, blocks, fs, int(channels), subtype, checked=False, fmt=fmt)


def _write_blocks(path, blocks, fs: int, channels: int, subtype: str,
                  checked: bool, fmt: str = "wav") -> WavWriteResult:
    """Encode and write ``blocks`` (validated fs, channels and subtype)
    atomically; each block is checked for its shape and finite samples
    unless the caller ``checked`` the whole of them (:func:`write_wav`)."""
    write, result = _encoder(display_path(path), blocks, fs, channels, subtype, checked, fmt)
    _atomic_write(path, write)
    return result()


def wav_bytes(audio: np.ndarray, fs: int, subtype: str = "float") -> tuple[bytes, WavWriteResult]:
    """The bytes of the WAV file :func:`write_wav` would write, in memory
    (a batch worker returns them; the one process that writes files writes
    them atomically with :func:`write_bytes_atomic`).

    Parameters and errors as :func:`write_wav` (the file is named
    ``<memory>`` in messages).

    Returns
    -------
    data : bytes
        The whole file, header included.
    result : WavWriteResult
    """
    import tempfile

    a = np.asarray(audio)
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2 or a.dtype.kind != "f" or not (1 <= a.shape[1] <= MAX_CHANNELS):
        raise SynthError(f"<memory>: audio has shape {np.shape(audio)} and dtype {a.dtype}, "
                         f"expected real samples (frames,) or (frames, channels)")
    if isinstance(fs, bool) or not isinstance(fs, (int, np.integer)) or not (
            FS_MIN_HZ <= int(fs) <= FS_MAX_HZ):
        raise SynthError(f"<memory>: fs = {fs!r} is out of range (an integer sample rate, "
                         f"{FS_MIN_HZ} <= fs <= {FS_MAX_HZ} Hz)")
    if subtype not in SUBTYPES:
        raise SynthError(f"<memory>: subtype = {subtype!r} is not allowed (choices: 'float', 'pcm24')")
    blocks = (a[i:i + _WRITE_FRAMES] for i in range(0, a.shape[0], _WRITE_FRAMES))
    write, result = _encoder("<memory>", blocks, int(fs), a.shape[1], subtype, False)
    with tempfile.TemporaryFile() as f:
        write(f)
        f.seek(0)
        return f.read(), result()


#: libsndfile's command that turns the PEAK chunk of a float file on or off
_SFC_SET_ADD_PEAK_CHUNK = 0x1050


def _no_peak_chunk(snd: sf.SoundFile) -> None:
    """Leave out the PEAK chunk libsndfile adds to float WAV files: it holds
    the time of writing, so the same samples gave different bytes a second
    later (a batch run must give the same bytes for the same spec).  The
    chunk is optional; readers take the peak from the samples."""
    lib = getattr(sf, "_snd", None)
    if lib is None:                     # another soundfile layout: keep the chunk
        return
    lib.sf_command(snd._file, _SFC_SET_ADD_PEAK_CHUNK, sf._ffi.NULL, 0)


def _encoder(shown: str, blocks, fs: int, channels: int, subtype: str, checked: bool,
             fmt: str = "wav"):
    """``write(f)``, which encodes ``blocks`` into the open binary file
    ``f``, and ``result()``, the :class:`WavWriteResult` once it has."""
    if fmt == "flac":
        subtype = "pcm24"                 # FLAC holds integers: 24-bit, as --pcm24
    limit = wav_max_frames(channels, subtype) if fmt == "wav" else 1 << 62
    sf_subtype = {"wav": "FLOAT" if subtype == "float" else "PCM_24", "flac": "PCM_24",
                  "ogg": "VORBIS"}[fmt]
    tally = {"frames": 0, "peak": 0.0, "clipped": 0}

    def write(f: BinaryIO) -> None:
        f.flush()
        snd = sf.SoundFile(f.fileno(), mode="w", samplerate=fs, channels=channels,
                           subtype=sf_subtype, format=fmt.upper(), closefd=False)
        if fmt == "wav":
            _no_peak_chunk(snd)
        try:
            for block in blocks:
                a = np.asarray(block)
                if a.ndim == 1:
                    a = a[:, None]
                if a.ndim != 2 or a.shape[1] != channels or a.dtype.kind != "f":
                    raise SynthError(f"{shown}: a block has shape {np.shape(block)} and dtype "
                                     f"{a.dtype}, expected real samples (frames, {channels})")
                n_bad = 0 if checked else int(a.size - np.count_nonzero(np.isfinite(a)))
                if n_bad:
                    raise SynthError(f"{shown}: audio has {n_bad} non-finite samples (NaN or "
                                     f"inf) in a block at frame {tally['frames']}; nothing written")
                tally["frames"] += a.shape[0]
                if tally["frames"] > limit:
                    raise SynthError(f"{shown}: more than {limit} frames x {channels} channels "
                                     f"is too long for a WAV file (4 GiB limit); nothing written")
                if a.size:
                    tally["peak"] = max(tally["peak"], float(a.max()), float(-a.min()))
                if fmt == "ogg":
                    tally["clipped"] += int(np.count_nonzero(np.abs(a) > 1.0))
                    data = np.ascontiguousarray(np.clip(a, -1.0, 1.0), dtype=np.float32)
                elif subtype == "float":
                    data = np.ascontiguousarray(a, dtype=np.float32)
                else:
                    tally["clipped"] += int(np.count_nonzero((a > _PCM24_MAX) | (a < -1.0)))
                    q = np.clip(np.rint(a * _PCM24_SCALE), -_PCM24_SCALE, _PCM24_SCALE - 1.0)
                    data = np.ascontiguousarray(q.astype(np.int32) << 8)
                snd.write(data)
            snd.close()                   # the header's sizes
        except sf.LibsndfileError as e:
            raise _libsndfile_failure(snd, e) from None
        finally:
            if not snd.closed:
                try:
                    snd.close()
                except sf.SoundFileError:
                    pass                  # the first error is the one to report

    def result() -> WavWriteResult:
        peak = tally["peak"]
        return WavWriteResult(frames=tally["frames"], channels=channels,
                              peak_dbfs=20.0 * math.log10(peak) if peak > 0 else -math.inf,
                              n_clipped=tally["clipped"])

    return write, result


def write_npy_atomic(path: str | os.PathLike[str], array: np.ndarray) -> None:
    """Save `array` in ``.npy`` format at exactly `path` (no suffix added), atomically.

    Raises
    ------
    SynthError
        On I/O failure; nothing is left at `path` (an existing file is kept).
    """
    arr = np.asanyarray(array)

    def write(f: BinaryIO) -> None:
        np.save(f, arr, allow_pickle=False)

    _atomic_write(path, write)


def write_text_atomic(path: str | os.PathLike[str], text: str) -> None:
    """Write UTF-8 text (a CSV log, say) at `path` atomically, like
    :func:`write_npy_atomic`."""
    data = text.encode("utf-8")

    def write(f: BinaryIO) -> None:
        f.write(data)

    _atomic_write(path, write)


def write_bytes_atomic(path: str | os.PathLike[str], data: bytes) -> None:
    """Write bytes (a PNG, say) at `path` atomically, like :func:`write_npy_atomic`."""

    def write(f: BinaryIO) -> None:
        f.write(data)

    _atomic_write(path, write)
