"""The engine a live stream plays: built and warmed before it is needed.

:func:`ready_engine` builds a preset's engine and warms it (instrument
designs, numba kernels, buffers) with :func:`_warm_phrase`, so that nothing
is compiled or designed inside the audio callback: the player calls it
before the stream opens and, in a background thread, on a program change.
"""

from __future__ import annotations

from synth.io.errors import SynthError
from synth.io.live.devices import FS_OUT

__all__ = ["ready_engine"]


def _warm_phrase(preset) -> list:
    """Events that take the engine through every path a performance uses:
    note-ons across the range, a restrike, releases with and without the
    sustain pedal, the soft pedal."""
    from synth.engine.engine import Event

    if preset.kind == "musical" and preset.play is not None:
        lo, hi = preset.play.key_low, preset.play.key_high
        keys = sorted({lo, (lo + hi) // 2, hi})
    else:
        keys = [-1]
    ev = [Event(0.0, "control", 67, 0.5)]
    ev += [Event(0.001 * i, "note_on", k, 0.8) for i, k in enumerate(keys)]
    ev += [Event(0.012, "note_on", keys[len(keys) // 2], 0.6),
           Event(0.015, "control", 64, 1.0)]
    ev += [Event(0.020, "note_off", k, 0.5) for k in keys]
    ev += [Event(0.025, "control", 64, 0.0), Event(0.026, "control", 67, 0.0),
           Event(0.030, "pitch_bend", -1, 0.5)]
    return ev


def ready_engine(preset_name: str, block: int = 128, instruments: dict | None = None,
                 overrides=()):
    """Build the engine for a preset, warmed for live play.

    The instrument designs every key now (its ``warm()``), then a throwaway
    engine renders a short phrase block by block (compiling or loading the
    numba kernels, faulting the buffers in), and a fresh engine on the same
    instrument is returned, so the warm-up leaves no sound behind.

    Parameters
    ----------
    preset_name : str
        Preset name or ``.toml`` path.
    block : int
        Output block size of the stream (samples).
    instruments : dict or None
        Cache of instruments by preset name (a program change back to a
        preset reuses its designs).
    overrides : sequence of str
        ``PATH=VALUE`` preset overrides (``--set``), validated like the file.

    Raises
    ------
    SynthError
        The preset does not load or its instrument cannot be built.
    """
    from synth.engine.engine import Engine
    from synth.io.presets import load_preset
    from synth.voices import instrument_for

    inst = None if instruments is None else instruments.get(preset_name)
    if inst is None:
        preset = load_preset(preset_name, overrides)
        try:
            inst = instrument_for(preset)
        except ValueError as e:
            raise SynthError(f"{preset_name}: {e}") from None
        warm = getattr(inst, "warm", None)
        if warm is not None:
            warm()
        if instruments is not None:
            instruments[preset_name] = inst
    else:
        preset = inst.preset
    # a keyboard may send any key: size the strings for key 0 (study presets
    # otherwise only hold their own string's length; musical ones already do)
    try:
        scratch = Engine(inst, fs_out=FS_OUT, extra_low_key=0)
    except ValueError as e:
        raise SynthError(f"{preset_name}: {e}") from None
    scratch.schedule(_warm_phrase(preset))
    for _ in range(int(0.05 * FS_OUT / block) + 1):
        scratch.render_block(block)
    scratch.shed(1)
    scratch.render_block(block)
    return Engine(inst, fs_out=FS_OUT, extra_low_key=0)
