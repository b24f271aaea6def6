"""Dampers of a keyboard voice, from the preset's ``[dampers]`` table.

One helper for every voice whose keys have dampers (the grand, the
harpsichord): a mixin of :class:`synth.voices.base.Voice` that reads the
table once and gives the voice contract's :meth:`damper_lift` (half
pedal) and the damped string's T60 per key, with the laws of
:mod:`synth.physics.dampers`.  A voice using it lists it before ``Voice``
(``class MyVoice(KeyboardDampers, Voice)``) and has ``KEY_LOW`` and
``KEY_HIGH`` (the compass the damped T60 runs across).
"""

from __future__ import annotations

import numpy as np

from ..dsp.bank import StringBank
from ..physics import dampers as laws

__all__ = ["KeyboardDampers"]


class KeyboardDampers:
    """Mixin: the dampers of ``preset.dampers`` across ``KEY_LOW`` ..
    ``KEY_HIGH``."""

    KEY_LOW: int
    KEY_HIGH: int

    def release_t60_s(self, key: float) -> float:
        """T60 (s) of ``key``'s string under its damper: geometric from
        ``dampers.release_t60_bass_s`` at ``KEY_LOW`` to ``..._treble_s`` at
        ``KEY_HIGH`` (:func:`synth.physics.dampers.damped_t60_s`)."""
        d = self.preset.dampers
        return laws.damped_t60_s(key, self.KEY_LOW, self.KEY_HIGH, d.release_t60_bass_s,
                                 d.release_t60_treble_s)

    def damper_lift(self, pedal: float) -> float:
        """How far the sustain pedal (0 .. 1) lifts the dampers: 0 below
        ``dampers.half_pedal_low``, 1 above ``half_pedal_high``, linear
        between (half pedal; :func:`synth.physics.dampers.damper_lift`)."""
        d = self.preset.dampers
        return laws.damper_lift(pedal, d.half_pedal_low, d.half_pedal_high)

    @property
    def damper_land_s(self) -> float:
        """Time constant (s) over which a damper takes hold of its string or
        lets go (``dampers.land_s``): the loss glide of the strings' slots
        (the bank's ``F_B0S``).  A damper's felt does not stop a string in
        one step, and a pedal let up drops every lifted damper at once: with
        the bank's 5 ms, a MIDI file's pedal-up (a step from 1 to 0) under a
        held chord read as a 30 dB click (docs/voicing.md, "The dampers'
        landing")."""
        return float(self.preset.dampers.land_s)

    def drop_dampers(self, bank: StringBank, slots, pedal: float) -> None:
        """Key up: the dampers fall on ``slots`` as far as the sustain pedal
        lets them (:meth:`synth.dsp.bank.StringBank.apply_dampers`)."""
        bank.apply_dampers(np.asarray(slots, dtype=np.int64), self.damper_lift(pedal))
