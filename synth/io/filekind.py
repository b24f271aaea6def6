"""What kind of file a path holds, from its first bytes, for error messages.

A user who gives ``synth note notes.txt`` or ``synth check take.wav`` should
hear what the file is and what the command wanted, not "unknown preset" or
a decoder's exception name.  :func:`file_kind` reads at most 64 bytes.
"""

from __future__ import annotations

import os

__all__ = ["file_kind"]

_MAGIC = [
    (b"MThd", "a MIDI file"),
    (b"RIFF", "WAV audio"),
    (b"RIFX", "WAV audio"),
    (b"RF64", "WAV audio"),
    (b"fLaC", "FLAC audio"),
    (b"OggS", "Ogg audio"),
    (b"FORM", "AIFF audio"),
    (b"ID3", "MP3 audio"),
    (b"\xff\xfb", "MP3 audio"),
    (b"%PDF", "a PDF document"),
    (b"PK\x03\x04", "a ZIP archive"),
    (b"\x89PNG", "a PNG image"),
    (b"\x93NUMPY", "a numpy array file"),
]


def file_kind(path: str | os.PathLike) -> str | None:
    """``"a MIDI file"``, ``"WAV audio"``, ..., ``"a text file"`` or
    ``"binary data"`` for an existing regular file; None for anything else
    (missing, a folder, unreadable)."""
    try:
        if not os.path.isfile(path):
            return None
        with open(path, "rb") as f:
            head = f.read(64)
    except OSError:
        return None
    if not head:
        return "an empty file"
    for magic, kind in _MAGIC:
        if head.startswith(magic):
            return kind
    if b"\x00" in head:
        return "binary data"
    try:
        head.decode("utf-8")
    except UnicodeDecodeError:
        # (a multi-byte character cut at byte 64 is still text)
        try:
            head[:-3].decode("utf-8")
        except UnicodeDecodeError:
            return "binary data"
    return "a text file"
