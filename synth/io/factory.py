"""One factory: preset -> voice -> engine, the same for every caller.

``synth note``, ``synth render``, ``synth play`` (and its program changes),
the tests and the tools all build their engine with :func:`build_engine`,
so an engine is assembled in one place: the preset is loaded and validated
(with ``--set`` overrides), the registered voice is built at the internal
rate, optionally warmed for live play (:mod:`synth.engine.warm`), and the
engine sized for it.

It lives in ``io`` because it loads presets (files); the engine layer below
it never sees a file or a preset name.
"""

from __future__ import annotations

import os
from collections.abc import Sequence

from ..engine.engine import Engine
from ..dsp import threads as threads_mod
from ..engine.warm import fault_in, warm_up
from ..voices import voice_for
from .errors import SynthError
from .presets import Preset, load_preset

__all__ = ["build_engine", "build_voice"]


def build_voice(preset: str | os.PathLike | Preset, overrides: Sequence[str] = (), *,
                fs_internal: float | None = None):
    """The voice a preset (name, ``.toml`` path or loaded :class:`Preset`)
    describes, at the internal rate ``fs_internal`` (Hz; None: the voice's
    default).

    Raises
    ------
    PresetError
        The preset does not load or validate (one line naming the key).
    SynthError
        The voice cannot be built (e.g. a rate out of its range).
    """
    if isinstance(preset, Preset):
        if overrides:
            raise ValueError("overrides apply to a preset name or path, not to a loaded Preset")
        p = preset
    else:
        p = load_preset(preset, overrides)
    try:
        return voice_for(p, fs_internal)
    except ValueError as e:
        raise SynthError(f"{p.name}: {e}") from None


def set_default_threads(threads: int | None) -> None:
    """Make :func:`build_engine` render on ``threads`` threads when it is
    not given ``threads`` (the command line's ``--threads``); None: back to
    ``SYNTH_THREADS``, else every core.  ValueError (naming the value and
    the range) if out of range."""
    threads_mod.set_default(threads)


def build_engine(preset: str | os.PathLike | Preset, overrides: Sequence[str] = (), *,
                 fs_out: int = 48_000, fs_internal: float | None = None,
                 polyphony: int | None = None, probe: bool = False,
                 extra_low_key: int | None = None, warm: bool = False, block: int = 128,
                 voice=None, silence_dbfs: float = -110.0, threads: int | None = None,
                 drone: bool = True) -> Engine:
    """Build the engine that plays ``preset``.

    Parameters
    ----------
    preset : str, path or Preset
        Preset name (``"sitar"``, ``"paper/sitar-case1"``), ``.toml`` path,
        or an already loaded preset.
    overrides : sequence of str
        ``PATH=VALUE`` overrides (``--set``), validated like the file.
    fs_out : int
        Output rate (Hz), 48 000 by default.
    fs_internal : float or None
        Internal rate of the strings (Hz); None: the voice's default
        (325 kHz; a study preset's own grid).
    polyphony : int or None
        Voice pool size; None: the preset's.
    probe : bool
        Record the first voice's probe channels (study renders).
    extra_low_key : int or None
        A MIDI key below the voice's range that must still sound (0 for a
        keyboard, which may send any key).
    warm : bool
        Warm up for live play first (every key designed, kernels compiled
        or loaded, a phrase played block by block on a throwaway engine of
        the same sizes): the first note then costs no more than the others.
    block : int
        Output block size the warm-up plays in (the stream's block).
    voice : Voice or None
        A voice already built for this preset (a program change back to a
        preset reuses its designs); ``preset`` and ``overrides`` are then
        not loaded again.
    silence_dbfs : float
        Level below which a released voice counts as silent and is freed.
    threads : int or None
        Threads the strings render on (the same samples for any number);
        None: ``SYNTH_THREADS``, else every core this process may use
        (:func:`synth.dsp.threads.default_threads`).
    drone : bool
        Whether a preset's drone player (``[drone]``, :mod:`synth.engine.drone`)
        plays: a key then starts and stops the cycle of its strings.  False
        for the renders of single notes (``synth note``, a check's keys, a
        batch's jobs): each key plucks its one string, as on the other
        plucked presets.

    Raises
    ------
    PresetError, SynthError
        One-line errors naming the preset and the problem.
    """
    if voice is None:
        voice = build_voice(preset, overrides, fs_internal=fs_internal)
    try:
        n_threads = threads_mod.resolve(threads)
    except ValueError as e:
        raise SynthError(str(e)) from None
    kw = dict(polyphony=polyphony, probe=probe, extra_low_key=extra_low_key,
              silence_dbfs=silence_dbfs, threads=n_threads)
    try:
        if warm:
            warm_up(voice, fs_out=fs_out, block=block, **kw)
        eng = Engine(voice, fs_out=fs_out, drone=drone, **kw)
        if warm:
            fault_in(eng)               # its buffers mapped before the stream opens
        return eng
    except ValueError as e:
        raise SynthError(f"{voice.preset.name}: {e}") from None
