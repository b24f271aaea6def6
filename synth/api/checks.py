"""The checks of the Python API's inputs, shared with the command line.

MIDI units are checked here, at the edge, before anything is built: a key
0-127 and a velocity 1-127 (integers: a velocity of 0.5 or 1.0, meant as
the engine's [0, 1], is refused, not played at 1/127), controller values
0-127, a 14-bit bend -8192..8191, times and lengths in seconds.  Every
check raises :class:`ValueError` with one line naming the parameter, the
value and what is allowed::

    key = 200 is out of range (0 <= value <= 127)
    velocity = 0.5 is not an integer (1 <= value <= 127)

``synth note`` runs the same checks under its option names (``--key = 200
is out of range (0 <= value <= 127)``): the messages are one text.
"""

from __future__ import annotations

import re
from numbers import Integral, Real

__all__ = ["check_int", "check_real", "check_note", "check_set", "check_key", "key_of_name",
           "API_NAMES", "CLI_NAMES",
           "KEY_RANGE", "VELOCITY_RANGE", "SECONDS_MAX", "F0_RANGE_HZ", "MAX_TIME_S"]

#: MIDI keys
KEY_RANGE = (0, 127)
#: MIDI note-on velocities (0 is a note-off in MIDI: not a note)
VELOCITY_RANGE = (1, 127)
#: the longest note (s) ``synth note`` and :func:`synth.render_note` render
SECONDS_MAX = 600.0
#: an explicit fundamental (Hz) instead of a key
F0_RANGE_HZ = (20.0, 5000.0)
#: the latest event time (s) an :class:`synth.Instrument` takes (the MIDI
#: reader's longest file, 6 h)
MAX_TIME_S = 6 * 3600.0

#: the parameters' names in messages, for the Python API and for ``synth note``
API_NAMES = {"key": "key", "f0": "f0", "velocity": "velocity", "seconds": "seconds"}
CLI_NAMES = {"key": "--key", "f0": "--f0", "velocity": "--velocity", "seconds": "--seconds"}


def _g(x) -> str:
    """A range limit as messages show it (600.0 -> 600, 0.01 -> 0.01)."""
    return f"{x:g}" if isinstance(x, float) else str(x)


def check_int(name: str, value, lo: int, hi: int) -> int:
    """``value`` as an int in [lo, hi], or ValueError naming ``name``.

    Floats are refused even when whole (``velocity = 1.0``: MIDI units are
    integers; a value meant in [0, 1] must not play at 1/127), as are
    bools; numpy integers are taken.
    """
    if isinstance(value, bool) or not isinstance(value, Integral):
        raise ValueError(f"{name} = {value!r} is not an integer ({lo} <= value <= {hi})")
    if not lo <= value <= hi:
        raise ValueError(f"{name} = {value} is out of range ({lo} <= value <= {hi})")
    return int(value)


def check_real(name: str, value, lo: float, hi: float, *, lo_open: bool = False,
               unit: str = "") -> float:
    """``value`` as a float in [lo, hi] ((lo, hi] with ``lo_open``), or
    ValueError naming ``name``, the value and the range (NaN is out of
    range; a bool or a string is not a number)."""
    rng = f"{_g(lo)} {'<' if lo_open else '<='} value <= {_g(hi)}{' ' + unit if unit else ''}"
    if isinstance(value, bool) or not isinstance(value, Real):
        raise ValueError(f"{name} = {value!r} is not a number ({rng})")
    v = float(value)
    ok = (lo < v if lo_open else lo <= v) and v <= hi
    if not ok:                                  # (NaN fails both)
        raise ValueError(f"{name} = {value} is out of range ({rng})")
    return v


#: pitch classes of the note names (C4 = 60)
_PITCH_CLASS = {"c": 0, "d": 2, "e": 4, "f": 5, "g": 7, "a": 9, "b": 11}
_ACCIDENTAL = {"": 0, "#": 1, "\u266f": 1, "b": -1, "\u266d": -1}
_NOTE_NAME = re.compile(r"([A-Ga-g])(#|b|\u266f|\u266d)?(-?\d+)")


def key_of_name(text: str) -> int | None:
    """The MIDI key of a note name: a letter A-G, an optional sharp (``#``,
    U+266F) or flat (``b``, U+266D) and an octave, scientific pitch (C4 =
    60, A4 = 69, C#3 = Db3 = 49, C-1 = 0); None if ``text`` is not one."""
    m = _NOTE_NAME.fullmatch(text.strip())
    if m is None:
        return None
    return 12 * (int(m[3]) + 1) + _PITCH_CLASS[m[1].lower()] + _ACCIDENTAL[m[2] or ""]


def check_key(name: str, value, lo: int = 0, hi: int = 127) -> int:
    """A MIDI key given as an integer, a string of digits or a note name
    (:func:`key_of_name`: ``"C#3"``, ``"Db3"``, ``"A4"``), within [lo, hi];
    ValueError naming ``name``, the value and the range otherwise."""
    rng = f"{lo} <= key <= {hi}, C4 = 60"
    if isinstance(value, str):
        text = value.strip()
        if re.fullmatch(r"[+-]?\d+", text):
            key = int(text)
        else:
            key = key_of_name(text)
            if key is None:
                raise ValueError(f"{name} = {value!r} is not a MIDI key or a note name such as "
                                 f"C#3 or Db3 ({rng})")
        if not lo <= key <= hi:
            shown = value if str(key) == text else f"{value} (key {key})"
            raise ValueError(f"{name} = {shown} is out of range ({rng})")
        return key
    if isinstance(value, bool) or not isinstance(value, Integral):
        raise ValueError(f"{name} = {value!r} is not a MIDI key or a note name such as C#3 "
                         f"({rng})")
    if not lo <= value <= hi:
        raise ValueError(f"{name} = {value} is out of range ({rng})")
    return int(value)


def check_note(key, f0, velocity, seconds, names: dict = API_NAMES):
    """The arguments of one note (:func:`synth.render_note`, ``synth note``).

    Parameters
    ----------
    key : int or None
        MIDI key, 0-127.
    f0 : float or None
        Fundamental frequency (Hz), 20-5000, instead of ``key``.
    velocity : int
        MIDI velocity, 1-127.
    seconds : float
        Length rendered (s), 0 < value <= 600.
    names : dict
        The parameters' names in messages (:data:`API_NAMES`,
        :data:`CLI_NAMES`).

    Returns
    -------
    (key, f0, velocity, seconds)
        Checked: int or None, float or None, int, float.

    Raises
    ------
    ValueError
        One line naming the parameter, the value and the allowed range.
    """
    nk, nf = names["key"], names["f0"]
    if key is not None and f0 is not None:
        raise ValueError(f"{nk} and {nf} are exclusive: give one of them")
    if key is not None:
        key = check_int(nk, key, *KEY_RANGE)
    if f0 is not None:
        f0 = check_real(nf, f0, *F0_RANGE_HZ, unit="Hz")
    velocity = check_int(names["velocity"], velocity, *VELOCITY_RANGE)
    seconds = check_real(names["seconds"], seconds, 0.0, SECONDS_MAX, lo_open=True)
    return key, f0, velocity, seconds


def _toml_value(path: str, v) -> str:
    """A Python value as the TOML text of a ``--set`` value
    (:func:`synth.io.presets.loader.override_literal`), or ValueError naming
    the override."""
    from ..io.presets.loader import override_literal

    try:
        return override_literal(v)
    except TypeError:
        raise ValueError(f"set[{path!r}] = {v!r} is not a preset value (a number, a string, a bool "
                         f"or a list of them)") from None


def check_set(overrides) -> list[str]:
    """Preset overrides as ``--set`` texts (``"PATH=VALUE"``).

    Parameters
    ----------
    overrides : dict, sequence of str, or None
        ``{"pluck.position": 0.7, "play.quality": "draft"}`` (values as
        Python numbers, strings, bools or lists), or the command line's
        ``["pluck.position=0.7", ...]``; None: none.

    Returns
    -------
    list of str
        Validated by the preset loader when the preset loads (an unknown
        key, a value out of range: one line naming them).

    Raises
    ------
    ValueError
        Not a dict or a sequence of strings, a key that is not a string, a
        value that is not a preset value.
    """
    if overrides is None:
        return []
    if isinstance(overrides, dict):
        out = []
        for path, v in overrides.items():
            if not isinstance(path, str) or not path.strip():
                raise ValueError(f"set: key {path!r} is not a preset path (e.g. 'pluck.position')")
            out.append(f"{path}={_toml_value(path, v)}")
        return out
    bad = ValueError(f"set = {overrides!r} is not a dict of preset values or a list of "
                     "'PATH=VALUE' strings")
    if isinstance(overrides, (str, bytes)):
        raise bad
    try:
        items = list(overrides)
    except TypeError:
        raise bad from None
    if not all(isinstance(s, str) for s in items):
        raise bad
    return items
