"""The wave energy a string stores: the engine's measure of how loud a
sounding note still is when it must give up a voice.

It is read from the strings' state at the event's own sample, so the choice
does not depend on where the audio blocks begin (a live stream and an
offline render choose the same voice).
"""

from numba import njit

from .config import JIT_OPTS


@njit(**JIT_OPTS)
def ring_energy(ring, offs, lens, out):
    """out[i] = sum of ring[offs[i]:offs[i] + lens[i]] ** 2: the squared
    travelling waves of a string's two rails (m^2 for displacement waves),
    for each string i; ``offs``, ``lens`` int64, ``out`` float64, all of one
    length.  No validation (the bank's wrapper gives slices in range)."""
    for i in range(offs.shape[0]):
        a = offs[i]
        acc = 0.0
        for j in range(a, a + lens[i]):
            v = ring[j]
            acc += v * v
        out[i] = acc
