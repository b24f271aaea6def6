"""User-facing error classes of the synth package.

Every error the command line is expected to report (bad preset, unreadable
MIDI file, impossible output request) is a :class:`SynthError`. Its ``str()``
is a single line that names the file or parameter, the offending value and
what would have been allowed; the CLI prints it as ``synth: error: <msg>``
and exits with status 2. Anything that is not a ``SynthError`` is a bug and
is allowed to show a traceback.
"""

from __future__ import annotations

import os

__all__ = ["SynthError", "PresetError", "MidiFileError", "display_path"]


class SynthError(Exception):
    """Base class of user-facing errors; ``str(err)`` is the one-line message."""


class PresetError(SynthError):
    """A preset could not be found, parsed or validated (or a ``--set`` is bad)."""


class MidiFileError(SynthError):
    """A Standard MIDI File could not be read or is not usable."""


def display_path(path: str | os.PathLike[str]) -> str:
    """A path as error messages show it: relative to the working directory when below it."""
    p = os.fspath(path)
    try:
        rel = os.path.relpath(p)
    except ValueError:  # another drive on Windows
        return p
    return rel if not rel.startswith("..") else os.path.abspath(p)
