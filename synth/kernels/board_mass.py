"""The board's mass law: a first-order section on C channels, in place (numba kernel; no validation).

:func:`mass_section` runs each row of ``y`` through

    y[n] = g (x[n] + b x[n - 1]) + a y[n - 1]

(the design is :func:`synth.physics.soundboard.mass_section`).  The state
``state[c]`` is channel c's last input and last output; a state under
``TINY`` (1e-30, -600 dB) is written as 0 at the end of a block, so a
silent output ends in exact zeros and never in subnormal arithmetic.
Blocks of any length give the one-shot result.  The wrapper is
:class:`synth.dsp.board_mass.BoardMass`; the slow reference
(scipy.signal.lfilter) is in ``tests/test_board_mass.py``.
"""

from numba import njit

from synth.kernels.config import JIT_OPTS

#: a state smaller than this in magnitude is written as 0
TINY = 1e-30


@njit(**JIT_OPTS)
def mass_section(y, n, g, b, a, state):
    """Filter ``y[:, :n]`` in place.

    Parameters
    ----------
    y : float64[:, :]
        (C, >= n): the channels, each row contiguous; overwritten.
    n : int
        Samples to process.
    g, b, a : float
        The section's gain, zero and pole (|b| < 1, 0 <= a < 1).
    state : float64[:, :]
        (C, 2): each channel's last input and last output; updated.
    """
    for c in range(y.shape[0]):
        row = y[c]
        x1 = state[c, 0]
        s = state[c, 1]
        for i in range(n):
            x = row[i]
            s = g * (x + b * x1) + a * s
            x1 = x
            row[i] = s
        state[c, 0] = x1 if abs(x1) > TINY else 0.0
        state[c, 1] = s if abs(s) > TINY else 0.0
