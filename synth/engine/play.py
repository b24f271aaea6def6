"""The engine's playing rules: the preset's ``[play]`` table as one component.

What a keyboard or a MIDI file may ask of an instrument, and how the engine
answers when it asks too much, is the engine's business, not the voice's:

* the voice pool's size (``play.polyphony``) and which sounding note gives
  its voice up when a note finds the pool full (``play.steal``);
* the keys that play (``play.key_low`` .. ``key_high``; the warm-up's keys);
* the widest pitch bend (``play.pitch_bend_semitones``), the value 1 of a
  voice's :meth:`synth.voices.base.Voice.pitch_bend`, and whether the
  engine passes bends on at all.

A voice used to answer these itself (five members of
:class:`synth.voices.base.Voice` that only read ``[play]``); the engine now
builds this component from the preset (:meth:`PlayRules.from_preset`), as it
builds its output stage from ``[output]`` (:mod:`synth.engine.output`).
A study preset has no ``[play]``: a pool of 8, the quietest stolen, no key
range (the string plays its own pitch), no bend.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["PlayRules", "STEAL_RULES", "DEFAULT_POLYPHONY"]

#: the rules a full pool may steal by (``play.steal``)
STEAL_RULES = ("quietest", "oldest")

#: the pool's size when the preset has no ``[play]`` (a study string)
DEFAULT_POLYPHONY = 8


@dataclass(frozen=True)
class PlayRules:
    """The playing rules of one engine.

    Attributes
    ----------
    polyphony : int
        Default size of the voice pool (``play.polyphony``), 1 .. 512.
    steal : str
        Which sounding voice a note takes when the pool is full
        (``play.steal``): ``"quietest"`` (the least wave energy in its
        strings) or ``"oldest"``.
    key_range : tuple (lowest, highest) or None
        Playable MIDI keys, or None (a study string that plays its own pitch).
    bend_range_semitones : float
        The widest pitch bend (semitones), a voice's pitch-bend value 1;
        0: the instrument does not bend.
    """

    polyphony: int = DEFAULT_POLYPHONY
    steal: str = "quietest"
    key_range: tuple[int, int] | None = None
    bend_range_semitones: float = 0.0

    def __post_init__(self):
        if self.steal not in STEAL_RULES:
            raise ValueError(f"play.steal = {self.steal!r} is not one of {', '.join(STEAL_RULES)}")
        if not (1 <= int(self.polyphony) <= 512):
            raise ValueError(f"play.polyphony = {self.polyphony!r} is out of range (1 to 512)")

    @property
    def bends(self) -> bool:
        """Whether the instrument plays pitch bend at all."""
        return self.bend_range_semitones > 0.0

    @classmethod
    def from_preset(cls, preset) -> "PlayRules":
        """The rules of ``preset``'s ``[play]`` table (the defaults above
        for a preset without one)."""
        play = getattr(preset, "play", None)
        if play is None:
            return cls()
        return cls(polyphony=int(play.polyphony),
                   steal=getattr(play, "steal", None) or "quietest",
                   key_range=(int(play.key_low), int(play.key_high)),
                   bend_range_semitones=float(getattr(play, "pitch_bend_semitones", 0.0) or 0.0))
