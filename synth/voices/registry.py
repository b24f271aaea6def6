"""Registries: preset ``voice`` names -> voice classes, preset sections -> exciters.

A voice module registers its class with :func:`register_voice`; the
package imports every module of ``synth.voices`` (:mod:`synth.voices`), so
a new voice is one new module here, its preset and its schema rows, and no
list anywhere else to edit.  ``tests/test_registry.py`` checks that every
``voice`` the preset schema allows has a registered class and vice versa.

Exciters (:mod:`synth.voices.exciters`) are registered the same way, under
the name of the preset section that configures them (``pluck``, ``hammer``),
so a string voice takes whichever exciter its preset describes (Faust's
physmodels: any exciter on any string and termination).
"""

from __future__ import annotations

_VOICES: dict[str, type] = {}
_EXCITERS: dict[str, type] = {}


def register_voice(*names: str):
    """Class decorator: the class plays presets whose ``voice`` is one of
    ``names``."""
    def deco(cls):
        for n in names:
            if n in _VOICES and _VOICES[n] is not cls:
                raise ValueError(f"voice {n!r} is registered twice "
                                 f"({_VOICES[n].__name__} and {cls.__name__})")
            _VOICES[n] = cls
        cls.names = tuple(names)
        return cls
    return deco


def register_exciter(section: str):
    """Class decorator: the exciter configured by the preset section
    ``section``."""
    def deco(cls):
        if section in _EXCITERS and _EXCITERS[section] is not cls:
            raise ValueError(f"exciter {section!r} is registered twice")
        _EXCITERS[section] = cls
        cls.section = section
        return cls
    return deco


def voice_names() -> tuple[str, ...]:
    """Every registered voice name."""
    return tuple(_VOICES)


def voice_class(name: str) -> type:
    """The class registered as ``name``."""
    try:
        return _VOICES[name]
    except KeyError:
        raise ValueError(f"voice = {name!r} has no registered voice "
                         f"(registered: {', '.join(_VOICES)})") from None


def exciter_sections() -> tuple[str, ...]:
    """Every preset section that configures a registered exciter."""
    return tuple(_EXCITERS)


def exciter_for(preset, fs: float):
    """The exciter the preset describes, for strings at the internal rate
    ``fs`` (Hz): the registered exciter whose section the preset has
    (exactly one)."""
    found = [name for name in _EXCITERS if getattr(preset, name, None) is not None]
    if len(found) != 1:
        raise ValueError(f"{preset.name}: a string voice needs exactly one exciter section "
                         f"(one of {', '.join(_EXCITERS)}); found {found or 'none'}")
    return _EXCITERS[found[0]](getattr(preset, found[0]), preset, fs)


def voice_for(preset, fs_internal: float | None = None):
    """The voice that plays ``preset`` at the internal rate ``fs_internal``
    (Hz; None: the voice's default)."""
    return voice_class(preset.voice)(preset, fs_internal)
