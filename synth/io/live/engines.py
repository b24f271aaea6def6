"""The engine a live stream plays: built and warmed before it is needed.

:func:`ready_engine` builds a preset's engine with the one factory
(:func:`synth.io.factory.build_engine`, ``warm=True``: voice designs, numba
kernels and buffers warmed by :mod:`synth.engine.warm`), so that nothing is
compiled or designed inside the audio callback: the player calls it before
the stream opens and, in a background thread, on a program change.
"""

from __future__ import annotations

from synth.io.live.devices import FS_OUT

__all__ = ["ready_engine"]


def ready_engine(preset_name: str, block: int = 128, instruments: dict | None = None,
                 overrides=(), fs_out: int = FS_OUT):
    """Build the engine for a preset, warmed for live play
    (:func:`synth.io.factory.build_engine` with ``warm=True``: every key
    designed, the kernels compiled or loaded on a throwaway engine, so the
    warm-up leaves no sound behind).

    Parameters
    ----------
    preset_name : str
        Preset name or ``.toml`` path.
    block : int
        Output block size of the stream (samples).
    instruments : dict or None
        Cache of voices by preset name (a program change back to a preset
        reuses its designs).
    overrides : sequence of str
        ``PATH=VALUE`` preset overrides (``--set``), validated like the file.
    fs_out : int
        Output rate (Hz): the card's or the JACK server's.

    Raises
    ------
    SynthError
        The preset does not load or its voice cannot be built.
    """
    from synth.dsp import threads
    from synth.dsp.bank import StringBank
    from synth.io.factory import build_engine, build_voice

    # live: every scene through the one kernel, loaded before the stream
    # opens (a narrower one compiled mid-performance would stall the audio)
    StringBank.whole_kernel = True
    # and each rendering thread's OpenMP team started at its first block,
    # not at the first chord that renders in parallel
    threads.set_priming(True)
    voice = None if instruments is None else instruments.get(preset_name)
    if voice is None:
        voice = build_voice(preset_name, overrides)
        if instruments is not None:
            instruments[preset_name] = voice
    # a keyboard may send any key: size the strings for key 0 (study presets
    # otherwise only hold their own string's length; musical ones already do)
    eng = build_engine(preset_name, voice=voice, fs_out=fs_out, extra_low_key=0, warm=True,
                       block=block)
    # the governor tries the calling thread only for a call that surely fits
    # a fifth of its real-time budget there (a heavy scene stays on the threads)
    threads.Governor.realtime_dt_s = 1.0 / float(eng.fs_in_exact)
    return eng
