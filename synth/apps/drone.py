"""``synth drone``: a preset's drone player (its ``[drone]``, synth.engine.drone)
played from one key for a length of time, into an audio file.

The render is the engine's own: one note-on at Sa at time 0 starts the
cycle, and the engine plucks the strings (each pluck at its internal
sample, humanised from the preset's seed), exactly ``seconds`` long.  The
drone's settings the command takes (``--pattern``, ``--cycle-s``,
``--seed``, ``--velocity``) are ``--set`` overrides of the preset's
``[drone]``, checked as the file is.  The file is written as
``synth render`` writes its own (:func:`synth.apps.render.write_render`:
atomic, the format by extension, the progress bar, Ctrl-C), and the summary
gives its integrated loudness (BS.1770, measured as it is written).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass

from ..io.errors import SynthError
from .render import PreparedRender, RenderPlan, RenderResult, output_interruptible, write_render

__all__ = ["DroneRequest", "drone_overrides", "prepare_drone", "render_drone_file", "note_name"]

_NAMES = ("C", "C#", "D", "D#", "E", "F", "F#", "G", "G#", "A", "A#", "B")


def note_name(key: float) -> str:
    """A MIDI key's name (C4 = 60; sharps)."""
    k = int(round(key))
    return f"{_NAMES[k % 12]}{k // 12 - 1}"


@dataclass(frozen=True)
class DroneRequest:
    """What ``synth drone`` was asked to do (checked by the command and
    :func:`synth.api.drone.check_drone`).

    Attributes
    ----------
    preset : str
        Preset name or ``.toml`` path; it must have a ``[drone]`` table.
    sa : int
        Sa's MIDI key (the first and middle strings' octave; the low Sa is
        12 below).
    seconds : float
        The audio's exact length (s).
    output : str
        The audio file (replaced atomically).
    overrides : tuple of str
        The preset's ``--set`` overrides.
    drone : tuple of str
        The drone's settings as overrides (:func:`drone_overrides`:
        ``--pattern``, ``--cycle-s``, ``--seed``, ``--velocity``), applied
        after the preset is found to have a ``[drone]``.
    rate : int or None
        Output rate (Hz); None: 48 kHz.
    internal_rate : float or None
        The strings' rate (Hz); None: the preset's.
    pcm24 : bool
        WAV: 24-bit PCM instead of 32-bit float.
    fmt : str
        "wav", "flac" or "ogg".
    """

    preset: str
    sa: int
    seconds: float
    output: str
    overrides: tuple = ()
    drone: tuple = ()
    rate: int | None = None
    internal_rate: float | None = None
    pcm24: bool = False
    fmt: str = "wav"


def drone_overrides(pattern: str | None = None, cycle_s: float | None = None,
                    seed: int | None = None, velocity: float | None = None) -> list[str]:
    """The ``--set`` texts of the drone's settings given (None: the
    preset's); ``velocity`` in (0, 1]."""
    out = []
    if pattern is not None:
        out.append(f'drone.pattern="{pattern}"')
    if cycle_s is not None:
        out.append(f"drone.cycle_s={float(cycle_s)!r}")
    if seed is not None:
        out.append(f"drone.seed={int(seed)}")
    if velocity is not None:
        out.append(f"drone.velocity={float(velocity)!r}")
    return out


def prepare_drone(preset, sa: int, seconds: float, overrides=(), drone=(), *,
                  rate: int | None = None, internal_rate: float | None = None) -> PreparedRender:
    """The drone's render made ready: the preset checked for its
    ``[drone]`` (with the user's ``overrides``, before the ``drone``
    settings' own, which would add the table), the engine built, one
    note-on at ``sa`` at time 0 planned for exactly ``seconds``.

    Raises
    ------
    SynthError
        One line: a bad preset or override, a preset without ``[drone]`` or
        with ``drone.player = "off"``.
    """
    from ..engine.engine import NOTE_ON, Event
    from ..io.factory import build_engine
    from ..io.presets import load_preset

    shown = os.fspath(preset)
    p = load_preset(preset, list(overrides))
    if p.drone is None:
        raise SynthError(f"{shown}: the preset has no [drone] table: synth drone plays a preset "
                         "with one (e.g. tanpura; synth help drone)")
    if p.drone.player != "on":
        raise SynthError(f"{shown}: drone.player = {p.drone.player!r}: synth drone needs 'on'")
    eng = build_engine(preset, list(overrides) + list(drone), fs_internal=internal_rate,
                       extra_low_key=max(int(sa) - 12, 0),
                       **({} if rate is None else {"fs_out": int(rate)}))
    events = [Event(0.0, NOTE_ON, int(sa), 1.0)]
    plan = RenderPlan(events=events, keys=[int(sa)], file_length_s=0.0, last_s=0.0,
                      expected_s=float(seconds), duration_s=float(seconds), max_tail_s=0.0,
                      cut=False)
    return PreparedRender(plan, eng, f"drone on {shown}", shown, [], {}, None)


def describe(prep: PreparedRender, sa: int) -> str:
    """The drone as the summary words it, once rendered."""
    eng = prep.engine
    d = eng.drone
    # the plucks within the audio (the render ran on by the decimator's
    # latency, removed from the file)
    end = int(round(prep.plan.duration_s * eng.fs_in_exact))
    n = d.n_plucks - sum(1 for h in d.history if h[0] >= end)
    return (f"a drone on {prep.preset}: Sa {note_name(sa)} (key {sa}), "
            f"{d.spec.pattern.strip()} every {d.spec.cycle_s:g} s, {n} plucks")


def render_drone_file(req: DroneRequest, *, log: Callable[[str], None] | None = None,
                      stream=None) -> RenderResult:
    """Render the drone into ``req.output`` (``synth drone``): the preset
    checked and its engine built, the file written as rendered
    (atomically), SIGINT and SIGTERM leaving no file.  The result's
    summary gives the plucks and the integrated loudness written
    (:attr:`RenderResult.lufs`).

    Raises
    ------
    SynthError
        As :func:`prepare_drone`, and a failed write.
    Interrupted
        A signal: nothing written.
    """
    with output_interruptible(req.output):
        prep = prepare_drone(req.preset, req.sa, req.seconds, req.overrides, req.drone,
                             rate=req.rate, internal_rate=req.internal_rate)
        return write_render(prep, req.output, pcm24=req.pcm24, fmt=req.fmt, log=log,
                            stream=stream, what=lambda: describe(prep, req.sa), loudness=True)
