"""Voices: physics at note-on, kernels per block (through the string bank).

Every voice follows the contract of :mod:`synth.voices.base` and registers
itself (:mod:`synth.voices.registry`).  Importing this package imports each
of its modules, so a new voice module is found without editing any list;
:func:`voice_for` builds the voice a preset names.
"""

import importlib
import pkgutil

from .base import BankSizes, Voice
from .registry import exciter_for, voice_class, voice_for, voice_names

for _m in pkgutil.iter_modules(__path__):
    importlib.import_module(f"{__name__}.{_m.name}")
del _m

__all__ = ["BankSizes", "Voice", "exciter_for", "voice_class", "voice_for", "voice_names"]
