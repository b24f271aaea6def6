"""Dampers of a keyboard instrument: the damped string's decay across the
compass and how far the sustain pedal lifts the dampers (half pedal).

Pure laws on plain numbers, shared by every voice with dampers (the grand,
the harpsichord); the voices read their arguments from the preset's
``[dampers]`` table.
"""

from __future__ import annotations

import math

__all__ = ["damped_t60_s", "damper_lift"]


def damped_t60_s(key: float, key_low: float, key_high: float, t60_bass_s: float,
                 t60_treble_s: float) -> float:
    """T60 (s) of a string under its damper at MIDI ``key``: geometric
    (linear in log T60) from ``t60_bass_s`` at ``key_low`` to
    ``t60_treble_s`` at ``key_high`` (both > 0 s; extrapolated beyond).

    A damper's felt takes hold of a thick bass string more slowly than of a
    thin treble one, so the damped decay shortens up the compass; the
    geometric law keeps equal ratios per octave."""
    x = (key - key_low) / (key_high - key_low)
    return math.exp((1 - x) * math.log(t60_bass_s) + x * math.log(t60_treble_s))


def damper_lift(pedal: float, half_low: float, half_high: float) -> float:
    """How far the sustain pedal lifts the dampers, 0 (resting on the
    strings) .. 1 (off them): 0 with ``pedal`` (0 .. 1, CC64 / 127) below
    ``half_low``, 1 above ``half_high``, linear between (half pedal; 0 <=
    half_low < half_high <= 1)."""
    return min(max((pedal - half_low) / (half_high - half_low), 0.0), 1.0)
