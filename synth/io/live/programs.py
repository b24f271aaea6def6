"""Program changes: MIDI program number -> preset (``--program-map``).

:class:`ProgramMap` parses ``synth play --program-map 0=grand-piano,1=sitar``
and checks every preset before any device is opened; the player asks it
which preset a program change plays.
"""

from __future__ import annotations

from synth.io.errors import SynthError

__all__ = ["ProgramMap"]


class ProgramMap:
    """MIDI program number (0-127, as sent in the message) -> preset name.

    Parameters
    ----------
    programs : mapping of int to str
        Program -> preset name (or ``.toml`` path).
    """

    def __init__(self, programs: dict[int, str]):
        self.programs = dict(sorted(programs.items()))

    @classmethod
    def parse(cls, text: str | None, default_preset: str, check: bool = True) -> ProgramMap:
        """Parse ``--program-map 0=grand-piano,1=sitar,24=biwa``.

        Program 0 plays ``default_preset`` unless the text maps it.  With
        ``check``, every preset is loaded and validated.

        Raises
        ------
        SynthError
            A malformed entry, a program outside 0..127, a program given
            twice, or a preset that does not load (the message lists the
            available presets).
        """
        from synth.io.presets import load_preset

        progs: dict[int, str] = {0: default_preset}
        given: set[int] = set()
        if text is not None:
            entries = [e.strip() for e in text.split(",")]
            if not any(entries):
                raise SynthError(f"--program-map = {text!r} is empty (e.g. 0=grand-piano,1=sitar)")
            for entry in entries:
                if not entry:
                    continue
                prog_s, sep, name = (s.strip() for s in entry.partition("="))
                if not sep or not name or not prog_s:
                    raise SynthError(f"--program-map entry {entry!r} is not PROGRAM=PRESET "
                                     "(e.g. 0=grand-piano,1=sitar)")
                try:
                    prog = int(prog_s)
                except ValueError:
                    raise SynthError(f"--program-map entry {entry!r}: program {prog_s!r} is not an "
                                     "integer (0 <= value <= 127)") from None
                if not (0 <= prog <= 127):
                    raise SynthError(f"--program-map entry {entry!r}: program = {prog} is out of "
                                     "range (0 <= value <= 127)")
                if prog in given:
                    raise SynthError(f"--program-map: program {prog} is given twice")
                given.add(prog)
                progs[prog] = name
        if check:
            for prog, name in progs.items():
                try:
                    load_preset(name)
                except SynthError as e:
                    if prog in given:
                        raise SynthError(f"--program-map entry {prog}={name}: {e}") from None
                    raise
        return cls(progs)

    def preset_for(self, program: int) -> str | None:
        """The preset of ``program``, or None if it is not mapped."""
        return self.programs.get(int(program))

    def __str__(self) -> str:
        return ",".join(f"{p}={n}" for p, n in self.programs.items())

    def __repr__(self) -> str:
        return f"ProgramMap({self.programs!r})"
