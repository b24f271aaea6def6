"""The board's mass law: a one-pole low-pass on C channels, in place (numba kernel; no validation).

:func:`one_pole_lowpass` runs each row of ``y`` through

    s[n] = (1 - a) x[n] + a s[n - 1],   y[n] = s[n]

(the design is :func:`synth.physics.soundboard.mass_pole`).  The state
``state[c]`` is channel c's last output; a state under ``TINY`` (1e-30,
-600 dB) is written as 0 at the end of a block, so a silent output ends
in exact zeros and never in subnormal arithmetic.  Blocks of any length
give the one-shot result.  The wrapper is
:class:`synth.dsp.board_mass.BoardMass`; the slow reference
(scipy.signal.lfilter) is in ``tests/test_board_mass.py``.
"""

from numba import njit

from synth.kernels.config import JIT_OPTS

#: a state smaller than this in magnitude is written as 0
TINY = 1e-30


@njit(**JIT_OPTS)
def one_pole_lowpass(y, n, a, state):
    """Filter ``y[:, :n]`` in place.

    Parameters
    ----------
    y : float64[:, :]
        (C, >= n): the channels, each row contiguous; overwritten.
    n : int
        Samples to process.
    a : float
        The pole, 0 <= a < 1 (0: the input passes unchanged).
    state : float64[:]
        (C,): each channel's last output; updated.
    """
    b = 1.0 - a
    for c in range(y.shape[0]):
        row = y[c]
        s = state[c]
        for i in range(n):
            s = b * row[i] + a * s
            row[i] = s
        state[c] = s if abs(s) > TINY else 0.0
