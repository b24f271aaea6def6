"""One note, a MIDI file, the preset names: :func:`render_note`,
:func:`render_midi`, :func:`presets`.

``synth note`` renders through :func:`note_engine`, :func:`check_playable`
and :func:`play_note`, the pieces :func:`render_note` is made of: one path,
the same samples (tests/test_golden.py pins them).
"""

from __future__ import annotations

import math
import os
from contextlib import contextmanager

import numpy as np

from ..apps.render import PreparedRender
from ..io.errors import SynthError
from .audio import Audio
from .checks import API_NAMES, check_note, check_real, check_set

__all__ = ["render_note", "render_midi", "stream_midi", "MidiStream", "presets", "note_engine",
           "check_playable", "play_note",
           "user_errors", "check_preset", "check_rate"]


@contextmanager
def user_errors():
    """The package's one-line user errors (:class:`~synth.io.errors.SynthError`:
    a bad preset name, a bad override, an unreadable MIDI file) raised as
    :class:`ValueError` with the same message."""
    try:
        yield
    except SynthError as e:
        raise ValueError(str(e)) from None


def check_preset(preset) -> str | os.PathLike:
    """A preset name (``"sitar"``, ``"paper/sitar-case1"``) or a ``.toml``
    path; ValueError for anything else (it is looked up when it loads)."""
    if isinstance(preset, os.PathLike) or (isinstance(preset, str) and preset.strip()):
        return preset
    raise ValueError(f"preset = {preset!r} is not a preset name or a .toml path "
                     "(synth.presets() lists the names)")


def check_rate(rate) -> int:
    """An output rate (Hz), 22050-192000, as an int; None: 48000."""
    if rate is None:
        return 48_000
    from ..io.rates import check_rate as _check

    with user_errors():
        return _check(rate, "rate")


def note_engine(preset, overrides, key: int | None, f0: float | None, *,
                internal_rate: float | None = None, rate: int | None = None, probe: bool = False):
    """The engine of one note: ``preset`` with its ``--set`` overrides,
    sized down to ``key`` (or to the key below ``f0``), at the output
    ``rate`` (Hz; None: 48000) and the ``internal_rate`` (Hz; None: the
    preset's).

    Raises
    ------
    SynthError
        The preset or an override is bad (one line naming them).
    """
    from ..io.factory import build_engine

    low = key
    if f0 is not None:
        low = int(math.floor(69 + 12 * math.log2(f0 / 440.0)))
    kw = {} if rate is None else {"fs_out": rate}
    # one note: a drone preset's key plucks its one string (no drone cycle)
    return build_engine(preset, overrides, fs_internal=internal_rate, probe=probe,
                        extra_low_key=low, drone=False, **kw)


def check_playable(eng, shown: str, key: int | None, f0: float | None,
                   names: dict = API_NAMES) -> None:
    """A musical preset plays a key of its range, or an explicit f0; a study
    preset plays its own string.  ValueError naming the preset ``shown`` and
    the range."""
    preset = eng.inst.preset
    if preset.kind != "musical":
        return
    if key is None and f0 is None:
        raise ValueError(f"{shown} is a musical preset: give {names['key']} or {names['f0']}")
    if key is not None:
        lo, hi = preset.play.key_low, preset.play.key_high
        if not (lo <= key <= hi):
            raise ValueError(f"{names['key']} = {key} is outside the playable range of {shown} "
                             f"({lo} <= key <= {hi})")


def play_note(eng, key: int | None, f0: float | None, velocity: int, seconds: float,
              speed_m_per_s: float | None = None) -> np.ndarray:
    """One note from time 0, held, for ``seconds``: float64 at the engine's
    output rate, shape (frames,) (mono) or (frames, channels).  ``velocity``
    is MIDI (1-127); ``speed_m_per_s`` a hammer speed instead of it."""
    from ..engine.engine import Event

    ev = Event(0.0, "note_on", key if key is not None else -1, velocity / 127.0,
               f0_hz=f0, speed_m_per_s=speed_m_per_s)
    return eng.render([ev], duration_s=seconds)


def render_note(preset, key: int | None = None, velocity: int = 100, seconds: float = 3.0,
                set=None, *, f0: float | None = None, rate: int | None = None) -> Audio:
    """Render one note of a preset, held for ``seconds`` (``synth note``).

    Parameters
    ----------
    preset : str or path-like
        Preset name (:func:`presets`) or ``.toml`` path.
    key : int or None
        MIDI key, 0-127 (69 = A4 = 440 Hz); a musical preset plays the keys
        of its range (``sitar``: 43-74).  None with ``f0``, or for a study
        preset (``paper/...``: its own string).
    velocity : int
        MIDI velocity, 1-127 (an integer: 0.5 or 1.0 is refused).
    seconds : float
        Length (s), 0 < seconds <= 600; 3 as ``synth note``.
    set : dict or sequence of str, optional
        Preset overrides, ``{"pluck.position": 0.7, "play.quality":
        "draft"}`` or ``["pluck.position=0.7"]`` (``synth note --set``),
        checked like the preset file.
    f0 : float or None
        Fundamental frequency (Hz), 20-5000, instead of ``key``.
    rate : int or None
        Output sample rate (Hz), 22050-192000; None: 48000.

    Returns
    -------
    Audio
        ``round(seconds * rate)`` frames, float32, (frames, 1) or
        (frames, 2); the note starts at frame 0.

    Raises
    ------
    ValueError
        One line naming the parameter, the value and what is allowed: a key
        or velocity out of range or not an integer, a bad length, an unknown
        preset (with the closest name), an unknown or out-of-range override,
        a key outside a musical preset's range.

    Examples
    --------
    >>> a = render_note("sitar", key=57, velocity=100, seconds=0.5)   # doctest: +SKIP
    >>> a.samples.shape, a.fs                                         # doctest: +SKIP
    ((24000, 1), 48000)
    """
    key, f0, velocity, seconds = check_note(key, f0, velocity, seconds)
    preset = check_preset(preset)
    overrides = check_set(set)
    fs = check_rate(rate)
    with user_errors():
        eng = note_engine(preset, overrides, key, f0, rate=fs)
    check_playable(eng, os.fspath(preset), key, f0)
    return Audio(play_note(eng, key, f0, velocity, seconds), eng.fs_out)


def _midi_events(midi, ignored: dict):
    """The normalised events of a path or a ``mido.MidiFile`` and the name
    messages give it."""
    from ..io.errors import display_path
    from ..io.midi import is_mido_file, read_midi_file, read_mido_file

    if is_mido_file(midi):
        return read_mido_file(midi, dropped=ignored)
    if isinstance(midi, (str, os.PathLike)):
        return read_midi_file(midi, dropped=ignored), display_path(midi)
    raise ValueError(f"midi = {midi!r} is not a MIDI file's path or a mido.MidiFile")


def _check_channels(channels):
    """MIDI channels as users number them (1-16) -> the reader's 0-based set."""
    if channels is None:
        return None
    from .checks import check_int

    if isinstance(channels, (int, str, bytes)):
        raise ValueError(f"channels = {channels!r} is not a collection of MIDI channels "
                         "(e.g. [1, 3]; 1 <= value <= 16)")
    out = {check_int("channels", c, 1, 16) - 1 for c in channels}
    if not out:
        raise ValueError("channels = [] leaves no channel to play (1 <= value <= 16)")
    return out


def _check_mpe(mpe):
    """MPE zones as ``--mpe`` writes them (``"lower"``, ``"lower:7,upper:7"``)
    -> the engine's ((manager channel, members), ...); None: none."""
    if mpe is None:
        return ()
    if not isinstance(mpe, str):
        raise ValueError(f"mpe = {mpe!r} is not a text of MPE zones (lower, upper, lower:N, "
                         "upper:N, e.g. 'lower:7,upper:7')")
    from ..engine.mpe import parse_mpe

    try:
        return parse_mpe(mpe)
    except ValueError as e:
        raise ValueError(str(e).replace("--mpe = ", "mpe = ", 1)) from None


def _check_internal_rate(internal_rate):
    if internal_rate is None:
        return None
    return check_real("internal_rate", internal_rate, 20_000.0, 2_000_000.0, unit="Hz")


class MidiStream(PreparedRender):
    """A MIDI file's render, block by block (:func:`stream_midi`): iterate
    it once for the blocks, float64 arrays of shape (frames, channels) at
    :attr:`fs`, the samples :func:`render_midi` returns (as float32) and
    ``synth render`` writes, a block at a time (about 50 ms each).

    Attributes
    ----------
    fs : int
        Output sample rate (Hz).
    channels : int
        1 or 2.
    seconds : float
        The least audio the render gives (s): up to the last event plus
        0.5 s of tail, or ``max_seconds`` when the file is cut there (the
        release tail may add up to 30 s).
    notes : list of str
        What ``synth render`` says on stderr before rendering
        (``warning: ...`` of a file of more than 30 min, ``note: ...`` of a
        cut file or of keys outside the preset's range).
    cut : bool
        After the iteration: whether the sound was cut at ``max_seconds``.
    ignored : dict
        Messages of the file not played, by name, with their counts (after
        the iteration: with those the engine ignored).
    """

    def __init__(self, prep: PreparedRender) -> None:
        super().__init__(prep.plan, prep.engine, prep.shown, prep.preset, prep.notes,
                         prep.ignored, prep.max_seconds)

    @property
    def fs(self) -> int:
        return int(self.engine.fs_out)

    @property
    def channels(self) -> int:
        return int(self.engine.channels)

    @property
    def seconds(self) -> float:
        return float(self.plan.expected_s)

    def __iter__(self):
        for b in self.blocks():
            yield b.reshape(len(b), -1)


def stream_midi(midi, preset, set=None, *, max_seconds: float | None = None, channels=None,
                drums: bool = False, rate: int | None = None,
                internal_rate: float | None = None, mpe: str | None = None,
                log=None) -> MidiStream:
    """Render a Standard MIDI File with a preset block by block, holding
    one block in memory at a time (``synth render`` writes its file from
    it): :func:`render_midi`'s arguments, and

    Parameters
    ----------
    internal_rate : float or None
        Internal sample rate of the strings (Hz), 20000-2000000; None: the
        preset's (``--internal-rate``).
    mpe : str or None
        MPE zones, as ``--mpe`` takes them: ``"lower"``, ``"upper"``,
        ``"lower:N"``, ``"upper:N"`` or ``"lower:7,upper:7"``; None: plain
        MIDI.
    log : callable or None
        Called with each line of :attr:`MidiStream.notes` as soon as it is
        known (the file's length before the engine is built).

    Returns
    -------
    MidiStream
        Iterate it once: float64 blocks of shape (frames, channels).

    Raises
    ------
    ValueError
        As :func:`render_midi`, before any rendering.

    Examples
    --------
    >>> s = stream_midi("song.mid", "sitar", max_seconds=10)        # doctest: +SKIP
    >>> peak = max(abs(b).max() for b in s)                         # doctest: +SKIP
    """
    from ..apps.render import prepare_render

    preset = check_preset(preset)
    overrides = check_set(set)
    if max_seconds is not None:
        from ..io.midi import MAX_DURATION_S

        max_seconds = check_real("max_seconds", max_seconds, 0.0, MAX_DURATION_S, lo_open=True,
                                 unit="s")
    chans = _check_channels(channels)
    fs = check_rate(rate)
    internal_rate = _check_internal_rate(internal_rate)
    zones = _check_mpe(mpe)
    if log is not None and not callable(log):
        raise ValueError(f"log = {log!r} is not callable (a function of one line of text)")
    ignored: dict = {}
    with user_errors():
        raw, shown = _midi_events(midi, ignored)
        prep = prepare_render(raw, shown, preset, overrides, ignored=ignored,
                              internal_rate=internal_rate, rate=fs, max_seconds=max_seconds,
                              channels=chans, drums=bool(drums), mpe=zones, log=log)
    return MidiStream(prep)


def render_midi(midi, preset, set=None, *, max_seconds: float | None = None, channels=None,
                drums: bool = False, rate: int | None = None, internal_rate: float | None = None,
                mpe: str | None = None) -> Audio:
    """Render a Standard MIDI File with a preset (``synth render``).

    Parameters
    ----------
    midi : str, path-like or mido.MidiFile
        The file, or a ``mido.MidiFile`` made or loaded in Python.
    preset : str or path-like
        Preset name (:func:`presets`) or ``.toml`` path.
    set : dict or sequence of str, optional
        Preset overrides, as :func:`render_note`.
    max_seconds : float or None
        Render at most this much (s), 0 < value <= 21600: later notes are
        left out and a sound still going is cut with a 10 ms fade-out (as
        ``--max-seconds``); None: the whole file and its release tails.
    channels : collection of int or None
        MIDI channels that play, 1-16 (``--channels``); None: every one.
    drums : bool
        Play channel 10 (General MIDI's drums) as pitched notes too; by
        default its messages are skipped (``--drums``).
    rate : int or None
        Output sample rate (Hz), 22050-192000; None: 48000.
    internal_rate, mpe
        As :func:`stream_midi` (``--internal-rate``, ``--mpe``).

    Returns
    -------
    Audio
        float32, (frames, 1) or (frames, 2): up to the last event, then
        until the notes have died away plus 0.5 s (at most 30 s after the
        last event), the samples ``synth render`` writes.

    Raises
    ------
    ValueError
        An unreadable or broken file, a file without notes, a bad preset
        or override, an argument out of range: one line naming it.
    """
    s = stream_midi(midi, preset, set, max_seconds=max_seconds, channels=channels, drums=drums,
                    rate=rate, internal_rate=internal_rate, mpe=mpe)
    parts = [np.asarray(b, dtype=np.float32) for b in s]
    y = np.concatenate(parts) if parts else np.zeros((0, s.channels), dtype=np.float32)
    return Audio(y, s.fs)


def presets() -> list[str]:
    """The names of the presets found: the shipped ones and those in the
    directories of ``$SYNTH_PRESET_PATH`` (``synth presets``), sorted.

    Returns
    -------
    list of str
        Names to give :func:`render_note`, :func:`render_midi` and
        :class:`Instrument` (``"sitar"``, ``"paper/sitar-case1"``, ...).
    """
    from ..io.presets import list_presets

    return [name for name, _ in list_presets()]
