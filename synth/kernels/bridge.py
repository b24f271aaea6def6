"""The instrument's common bridge as a kernel (numba, nogil, no allocation).

:func:`bridge_follow` runs the bridge that a board's sympathetic strings
hang on (:mod:`synth.engine.sympathetic`): a dashpot of resistance R with a
spring that slowly brings it back, driven by the strings' summed force F,

    u[n+1] = a u[n] + b F[n],    b = dt / R,  a = exp(-2 pi f_r dt),

the recurrence of a coupled unison's bridge in :mod:`synth.kernels.coupled`
(:func:`synth.kernels.coupled._bridge`), here over the output rate.
"""

from numba import njit

from .config import SERIAL_OPTS


@njit(**SERIAL_OPTS)
def bridge_follow(force, n, a, b, state, out):
    """out[i] = u[i] for i < n from force[0:n] (N); state[0] holds u of the
    next sample (m) and is updated."""
    u = state[0]
    for i in range(n):
        out[i] = u
        u = a * u + b * force[i]
    state[0] = u
