"""Warm-up: take an engine through every path a performance uses before a
live stream opens, so the first real note costs no more than the others.

Warming compiles or loads the numba kernels (the first call of each: the
strings', the decimator's, the body's, the listening position's,
:mod:`synth.kernels.listener`, when the preset has a ``[listener]``, and the
limiter's), faults the engine's buffers in and, through
:meth:`synth.voices.base.Voice.warm`, derives every key's physics.  It renders on a throwaway engine, so it
leaves no sound behind.
"""

from __future__ import annotations

from .play import PlayRules
from .engine import CC_SOFT, CC_SUSTAIN, CONTROL, NOTE_OFF, NOTE_ON, PITCH_BEND, Engine, Event


def warm_phrase(voice) -> list[Event]:
    """Events that take an engine through every path a performance uses:
    note-ons across the voice's range (its lowest, middle and highest key;
    a study string's own pitch), a restrike, releases with and without the
    sustain pedal, the soft pedal, a pitch bend."""
    kr = PlayRules.from_preset(voice.preset).key_range
    if kr is not None and not voice.study:
        lo, hi = kr
        keys = sorted({lo, (lo + hi) // 2, hi})
    else:
        keys = [-1]
    ev = [Event(0.0, CONTROL, CC_SOFT, 0.5)]
    ev += [Event(0.001 * i, NOTE_ON, k, 0.8) for i, k in enumerate(keys)]
    ev += [Event(0.012, NOTE_ON, keys[len(keys) // 2], 0.6),
           Event(0.015, CONTROL, CC_SUSTAIN, 1.0)]
    ev += [Event(0.020, NOTE_OFF, k, 0.5) for k in keys]
    ev += [Event(0.025, CONTROL, CC_SUSTAIN, 0.0), Event(0.026, CONTROL, CC_SOFT, 0.0),
           Event(0.030, PITCH_BEND, -1, 0.5)]
    return ev


def warm_up(voice, *, fs_out: int, block: int, **engine_kw) -> None:
    """Design every note of ``voice`` (:meth:`Voice.warm`), then play
    :func:`warm_phrase` block by block (``block`` output samples at
    ``fs_out`` Hz, about 50 ms) on a throwaway :class:`Engine` built with
    ``engine_kw``, measuring the voices as a full pool does (the
    stealing's kernel) and shedding a voice on the way (the overload
    path); then every unit the bank's kernels may call
    (:meth:`~synth.dsp.bank.StringBank.load_units`), so that none loads
    during live play."""
    voice.warm()
    scratch = Engine(voice, fs_out=fs_out, **engine_kw)
    # the units first, but for those another process is compiling (a cold
    # start, synth.apps.cold_start): the phrase waits for them
    scratch.bank.load_units(wait=False)
    scratch.schedule(warm_phrase(voice))
    for _ in range(int(0.05 * fs_out / block) + 1):
        scratch.render_block(block)
    if scratch.voices:
        scratch._quietest(list(scratch.voices))     # the voice stealing's measure
    scratch.shed(1)
    scratch.render_block(block)
    # every unit of the bank, those the phrase did not need too (the
    # engine built next finds them loaded)
    scratch.bank.load_units()
