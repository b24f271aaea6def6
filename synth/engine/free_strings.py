"""Free strings on a bridge: the strings of an instrument that no key stops.

One component, two configurations (the voice's
:meth:`synth.voices.base.Voice.free_strings` picks one by the design it
returns):

* :class:`synth.engine.taraf.Taraf` (a :class:`~synth.voices.base.TarafDesign`):
  a sitar's taraf and chikari, in the engine's own bank at the internal
  rate, on one two-way bridge with every sounding played string (an open
  coupled group of the bank), started by a note or a drone stroke;
* :class:`synth.engine.sympathetic.Sympathetic` (a
  :class:`~synth.voices.base.SympatheticDesign`): a piano's undamped
  strings, in a bank of their own at the output rate, on an external
  bridge that the played strings' decimated force moves (one way), each
  free while its damper is off and its key not sounding.

What they share is here: the strings' slots (one per template, from
``first``), their set-up from the design's templates, the bridge's
constants, all sound off (:meth:`FreeStrings.fade`, then
:meth:`FreeStrings.rest`), membership and the count of sounding strings.

Why two configurations and not one: the bridges differ in what they
answer.  The taraf's two-way bridge lets the played string feel a unison
taraf string take its energy (a one-way coupling let a unison string
build up to a force as large as the note's and opposite to it;
docs/voicing.md, "Taraf and chikari"), which needs the strings in the
played strings' bank, at its rate, stepped by one kernel call.  The
piano's 72 undamped strings are a thousandth of the played strings' force
and run at the output rate on their own bank (6.8 times fewer samples than
at 325 kHz), driven by the force summed over the keyboard; moving them
into the engine's bank would change every render of the grand (the golden
fingerprints) and its cost.
"""

from __future__ import annotations

from ..dsp.bank import StringBank


class FreeStrings:
    """Strings no key stops, in slots ``first`` .. of ``bank``.

    Parameters
    ----------
    design : synth.voices.base.FreeStringsDesign
        The strings (templates at the bank's rate), their keys and bridge.
    bank : synth.dsp.bank.StringBank
        The bank they render in.
    first : int
        Their first slot.
    fs_hz : float
        The bank's rate (Hz).
    templates : tuple of SlotTemplate or None
        Every string's template in slot order (default: ``design.slots``).
    """

    def __init__(self, design, bank: StringBank, first: int, fs_hz: float,
                 templates: tuple | None = None):
        self.design = design
        self.bank = bank
        self.fs = float(fs_hz)
        self.templates = tuple(design.slots) if templates is None else tuple(templates)
        self.first = int(first)
        self.slots = tuple(range(self.first, self.first + len(self.templates)))
        self.R = float(design.resistance_ns_per_m)
        self.return_hz = float(design.return_hz)

    def configure(self, i: int) -> None:
        """Set string ``i`` (an index into :attr:`slots`) up from its
        template, at rest."""
        self.bank.configure_from(self.slots[i], self.templates[i])

    def owns(self, s: int) -> bool:
        """Whether bank slot ``s`` is one of these strings."""
        return self.first <= int(s) < self.first + len(self.slots)

    def fade(self, t60_s: float) -> None:
        """All sound off: every sounding string fades out, 60 dB in
        ``t60_s`` (s); :meth:`rest` then stops them."""
        for s in self.slots:
            if self.bank.is_active(s):
                self.bank.fade(s, t60_s, self.fs)

    def rest(self) -> None:
        """All sound off, once faded: every string stops and rests."""
        raise NotImplementedError

    @property
    def n_active(self) -> int:
        """Strings rendering now."""
        return int(sum(1 for s in self.slots if self.bank.is_active(s)))
