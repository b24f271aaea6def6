"""``synth play --record OUT.wav``: the live performance, as it went to the
device, written to a WAV file.

The audio thread copies each block into a ring buffer (no allocation, no
lock: one writer, one reader, each moving its own counter); a thread of its
own drains the ring into :func:`synth.io.wav.write_wav_stream`, which writes
the file atomically.  Whatever stops the performance (Ctrl-C, ``--seconds``,
the server going away), :meth:`Recorder.close` drains what is left and
puts the complete file in place.  If the writer falls more than the ring's
length behind, the blocks that do not fit are dropped and counted (the
report says how many frames).
"""

from __future__ import annotations

import threading

import numpy as np

from synth.engine.warm import resident_zeros
from synth.io.errors import SynthError, display_path

__all__ = ["Recorder", "RING_S", "check_record_path"]

#: the ring buffer's length (s of audio)
RING_S = 10.0


def check_record_path(path) -> str:
    """``--record``'s file: a name ending in .wav, or a one-line error."""
    if not str(path).lower().endswith(".wav"):
        raise SynthError(f"--record = {display_path(path)!r}: the recording is a WAV file "
                         "(give a name ending in .wav)")
    return str(path)


class Recorder:
    """Record the blocks :meth:`push` is given into a WAV file.

    Parameters
    ----------
    path : str
        The WAV file (32-bit float), replaced atomically once closed.
    channels : int
        Channels of every block, 1 .. 64.
    fs : int
        Sample rate, Hz.
    ring_s : float
        The ring buffer's length (s).
    """

    def __init__(self, path: str, channels: int, fs: int, ring_s: float = RING_S):
        self.path = check_record_path(path)
        self.fs = int(fs)
        self.channels = int(channels)
        # (mapped now: the audio thread's first pass over a fresh page would wait for it)
        self._ring = resident_zeros((max(int(ring_s * fs), 4096), self.channels))
        self._w = 0                  # frames pushed (the audio thread's counter)
        self._r = 0                  # frames written (the writer's counter)
        self.dropped = 0             # frames that did not fit in the ring
        self._done = threading.Event()
        self._more = threading.Event()
        self.result = None
        self.error: Exception | None = None
        self._thread = threading.Thread(target=self._run, name="synth-record", daemon=True)
        self._thread.start()

    # -- the audio thread -----------------------------------------------------
    def push(self, block: np.ndarray) -> None:
        """Copy a block ((frames, channels), or (frames,) for one channel)
        into the ring; no allocation."""
        n = block.shape[0]
        ring = self._ring
        cap = ring.shape[0]
        if self._w + n - self._r > cap:
            self.dropped += n
            return
        i = self._w % cap
        k = min(n, cap - i)
        if block.ndim == 1:
            ring[i:i + k, 0] = block[:k]
            ring[:n - k, 0] = block[k:]
        else:
            ring[i:i + k] = block[:k]
            ring[:n - k] = block[k:]
        self._w += n
        self._more.set()

    # -- the writer's thread ----------------------------------------------------
    def _blocks(self):
        cap = self._ring.shape[0]
        while True:
            avail = self._w - self._r
            if avail == 0:
                if self._done.is_set() and self._w == self._r:
                    return
                self._more.wait(0.05)
                self._more.clear()
                continue
            i = self._r % cap
            k = min(avail, cap - i)
            yield self._ring[i:i + k].copy()
            self._r += k

    def _run(self) -> None:
        from synth.io.wav import write_wav_stream

        try:
            self.result = write_wav_stream(self.path, self._blocks(), self.fs, self.channels)
        except Exception as e:             # reported by close()
            self.error = e

    def close(self) -> str:
        """Write what is left and put the file in place; returns the
        report's line."""
        self._done.set()
        self._more.set()
        self._thread.join()
        if self.error is not None:
            return f"the recording failed: {self.error}"
        drop = f", {self.dropped} frames dropped (the writer fell behind)" if self.dropped else ""
        return (f"recorded {self.result.frames / self.fs:.1f} s to {display_path(self.path)}"
                f"{drop}")
