"""A preset's drone player from Python: :func:`render_drone` (``synth drone``).

The checks of its arguments (:func:`check_drone`) are the command's too,
under the options' names.
"""

from __future__ import annotations

import numpy as np

from .audio import Audio
from .checks import check_int, check_key, check_real, check_set
from .render import check_preset, check_rate, user_errors

__all__ = ["render_drone", "check_drone", "DRONE_API_NAMES", "DRONE_CLI_NAMES", "SA_RANGE",
           "DRONE_SECONDS_MAX"]

#: Sa's MIDI keys: the low Sa, an octave below, must be a key too
SA_RANGE = (12, 127)
#: the longest drone (s): the MIDI reader's longest file, 6 h
DRONE_SECONDS_MAX = 6 * 3600.0
DRONE_API_NAMES = {"sa": "sa", "seconds": "seconds", "pattern": "pattern", "cycle_s": "cycle_s",
                   "seed": "seed", "velocity": "velocity"}
DRONE_CLI_NAMES = {"sa": "--sa", "seconds": "--seconds", "pattern": "--pattern",
                   "cycle_s": "--cycle-s", "seed": "--seed", "velocity": "--velocity"}


def check_drone(sa, seconds, pattern=None, cycle_s=None, seed=None, velocity=None,
                names: dict = DRONE_API_NAMES):
    """The drone's arguments checked.

    Parameters
    ----------
    sa : int or str
        Sa's MIDI key, 12-127, or its note name (``"C#3"``, ``"Db3"``: C4 =
        60).
    seconds : float
        The audio's length (s), 0 < value <= 21600.
    pattern : str or None
        The strings in pluck order, ``"Pa Sa Sa Sa"`` (the first Pa, Ma, Ni
        or Sa, then Sa Sa Sa); None: the preset's.
    cycle_s : float or None
        The cycle's length (s), 1-16; None: the preset's.
    seed : int or None
        The humanisation's seed, 0 .. 2**31 - 1; None: the preset's.
    velocity : int or None
        The plucks' MIDI velocity, 1-127; None: the preset's.
    names : dict
        The parameters' names in messages.

    Returns
    -------
    (sa, seconds, drone overrides)
        Sa's key, the length, and the drone's settings as ``--set`` texts.

    Raises
    ------
    ValueError
        One line naming the parameter, the value and what is allowed.
    """
    from ..apps.drone import drone_overrides
    from ..engine.drone import CYCLE_RANGE_S, parse_pattern

    sa = check_key(names["sa"], sa, *SA_RANGE)
    seconds = check_real(names["seconds"], seconds, 0.0, DRONE_SECONDS_MAX, lo_open=True,
                         unit="s")
    if pattern is not None:
        if not isinstance(pattern, str):
            raise ValueError(f"{names['pattern']} = {pattern!r} is not a text such as "
                             "'Pa Sa Sa Sa'")
        try:
            parse_pattern(pattern)
        except ValueError as e:
            raise ValueError(str(e).replace("pattern = ", f"{names['pattern']} = ", 1)) from None
        pattern = " ".join(pattern.split())
    if cycle_s is not None:
        cycle_s = check_real(names["cycle_s"], cycle_s, *CYCLE_RANGE_S, unit="s")
    if seed is not None:
        seed = check_int(names["seed"], seed, 0, 2 ** 31 - 1)
    if velocity is not None:
        velocity = check_int(names["velocity"], velocity, 1, 127) / 127.0
    return sa, seconds, drone_overrides(pattern, cycle_s, seed, velocity)


def render_drone(preset="tanpura", sa=49, seconds: float = 20.0, *, pattern: str | None = None,
                 cycle_s: float | None = None, seed: int | None = None,
                 velocity: int | None = None, set=None, rate: int | None = None) -> Audio:
    """Play a preset's drone (its ``[drone]`` table: a tanpura's four strings
    plucked in a cycle) from Sa for ``seconds`` (``synth drone``).

    Parameters
    ----------
    preset : str or path-like
        Preset name or ``.toml`` path, with a ``[drone]`` table.
    sa : int or str
        Sa's MIDI key (12-127) or note name (``"C#3"`` = 49; C4 = 60).
    seconds : float
        Length (s), 0 < seconds <= 21600: the audio is exactly this long.
    pattern, cycle_s, seed, velocity
        The drone's settings instead of the preset's: ``"Pa Sa Sa Sa"``
        (Pa, Ma, Ni or Sa first), the cycle (s, 1-16), the humanisation's
        seed, the plucks' MIDI velocity (1-127).
    set : dict or sequence of str, optional
        Preset overrides, as :func:`synth.render_note`.
    rate : int or None
        Output sample rate (Hz), 22050-192000; None: 48000.

    Returns
    -------
    Audio
        ``round(seconds * rate)`` frames, float32, (frames, channels).

    Raises
    ------
    ValueError
        One line naming the parameter (or the preset's key), the value and
        what is allowed; a preset without ``[drone]``.

    Examples
    --------
    >>> a = render_drone("tanpura", sa="C#3", seconds=20, pattern="Pa Sa Sa Sa")  # doctest: +SKIP
    >>> a.seconds                                                                 # doctest: +SKIP
    20.0
    """
    from ..apps.drone import prepare_drone

    sa, seconds, drone = check_drone(sa, seconds, pattern, cycle_s, seed, velocity)
    preset = check_preset(preset)
    overrides = check_set(set)
    fs = check_rate(rate)
    with user_errors():
        prep = prepare_drone(preset, sa, seconds, overrides, drone, rate=fs)
    parts = [np.asarray(b, dtype=np.float32).reshape(len(b), -1) for b in prep.blocks()]
    y = (np.concatenate(parts) if parts
         else np.zeros((0, prep.engine.channels), dtype=np.float32))
    return Audio(y, int(prep.engine.fs_out))

