"""Voices: physics at note-on, kernels per block (via the string bank)."""

from .grand import GrandPianoInstrument
from .hammered import HammeredStringInstrument
from .plucked import PluckedInstrument


def instrument_for(preset, fs_internal=None):
    """The instrument that plays ``preset``'s voice at the internal rate
    ``fs_internal`` (Hz; None: the voice's default)."""
    if preset.voice == "plucked":
        return PluckedInstrument(preset, fs_internal)
    if preset.voice == "piano":
        return HammeredStringInstrument(preset, fs_internal)
    if preset.voice == "grand":
        return GrandPianoInstrument(preset, fs_internal)
    raise ValueError(f"voice = {preset.voice!r} has no instrument")
