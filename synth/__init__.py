"""synth: a physical-modelling string synthesizer.

Digital-waveguide strings at a high internal rate (325 kHz by default) with
pluggable nonlinear contact terminations (capo d'astro, sawari, jawari, or any
user profile), the plucks of Kartofelev's thesis, a block engine with
sample-accurate events and a polyphase decimator to 48 kHz.

The Python API (docs/api.md) is loaded on first use (PEP 562), so that
``import synth`` and ``synth --help`` stay light (no numpy)::

    import synth
    audio = synth.render_note("sitar", key=57, velocity=100, seconds=2)

Layers (dependencies point down):
    cli -> commands -> api, apps and io -> engine -> voices -> dsp ->
    physics, kernels;  analysis -> numpy only.
"""

__version__ = "0.1.0"

#: the names of :mod:`synth.api`, imported from it when first used
__all__ = ["Audio", "Instrument", "MidiStream", "presets", "render_drone", "render_midi",
           "render_note", "stream_midi"]


def __getattr__(name: str):
    if name in __all__:
        from . import api

        return getattr(api, name)
    raise AttributeError(f"module 'synth' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))
