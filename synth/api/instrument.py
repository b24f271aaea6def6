"""A preset played from Python, chunk by chunk: :class:`Instrument`."""

from __future__ import annotations

import numpy as np

from .audio import Audio
from .checks import (KEY_RANGE, MAX_TIME_S, SECONDS_MAX, VELOCITY_RANGE, check_int, check_real,
                     check_set)
from .render import check_preset, check_rate, user_errors

__all__ = ["Instrument", "BEND_RANGE", "RELEASE_VELOCITY"]

#: MIDI's 14-bit pitch bend, centre 0
BEND_RANGE = (-8192, 8191)
#: the release velocity of :meth:`Instrument.note_off` (MIDI's default)
RELEASE_VELOCITY = 64


class Instrument:
    """A preset to play event by event, rendering the audio as it goes.

    Events are given in MIDI units at times in seconds from the start (or
    from the last :meth:`reset`); :meth:`render` returns the next chunk.
    The samples are those of one render of the same events
    (:func:`synth.render_note`, :func:`synth.render_midi`): an event at
    ``t`` sounds at ``t``, whatever the chunks.

    Parameters
    ----------
    preset : str or path-like
        Preset name (:func:`synth.presets`) or ``.toml`` path.
    set : dict or sequence of str, optional
        Preset overrides, as :func:`synth.render_note`.
    rate : int or None
        Output sample rate (Hz), 22050-192000; None: 48000.

    Raises
    ------
    ValueError
        An unknown preset, a bad override or rate (one line naming it).

    Notes
    -----
    Times must not go backwards: each event's time is at or after the
    previous event's, else ValueError.

    The engine renders whole blocks of :attr:`BLOCK` output samples, on
    one grid from the start, so that the chunks never change the samples;
    it has computed up to :attr:`horizon`, a little beyond the audio
    returned (:attr:`time`; at most a block and the decimator's latency,
    about 25 ms at 48 kHz).  An event goes at or after the horizon: one given
    before rendering the chunk that sounds it (a note at 0, a note-off at
    0.5 s, then ``render(1.0)``) is always in time; ``time=None`` is the
    horizon, the earliest time an event can still have; an earlier time
    is refused (ValueError).

    Every MIDI key 0-127 plays: a key outside a musical preset's range is
    played on a string retuned or fretted to its pitch (as ``synth render``
    does).
    """

    #: the engine's blocks (output samples), those of one render
    #: (``Engine.render``): rendered whole, on one grid from the start; what
    #: a chunk does not take is kept for the next
    BLOCK = 1024

    def __init__(self, preset, set=None, *, rate: int | None = None) -> None:
        self._preset = check_preset(preset)
        self._overrides = check_set(set)
        self._fs = check_rate(rate)
        self._build()

    def _build(self) -> None:
        from ..io.factory import build_engine

        with user_errors():
            # every key: a keyboard's engine (synth play) is sized down to key 0 too
            self._engine = build_engine(self._preset, self._overrides, fs_out=self._fs,
                                        extra_low_key=0)
        self._lat = int(self._engine.latency_samples)
        self._done = 0          # output samples the engine has rendered (latency included)
        #: samples rendered and not yet returned (frames, channels)
        self._ahead = np.zeros((0, self._engine.channels), dtype=np.float32)
        self._frames = 0        # frames returned
        self._last = 0.0        # the latest event's time (s)

    # -- facts ----------------------------------------------------------------
    @property
    def preset(self) -> str:
        """The preset's name (as loaded: ``"sitar"``, ``"paper/sitar-case1"``)."""
        return self._engine.inst.preset.name

    @property
    def fs(self) -> int:
        """Output sample rate (Hz)."""
        return self._engine.fs_out

    @property
    def channels(self) -> int:
        """Output channels (1 or 2)."""
        return self._engine.channels

    @property
    def time(self) -> float:
        """The end of the audio rendered so far (s from the start or the last reset)."""
        return self._frames / self.fs

    @property
    def horizon(self) -> float:
        """The time (s) up to which the engine has computed: an event goes
        at or after it (between :attr:`time` and here the sound is already
        made).  At most a block of :attr:`BLOCK` output samples and the
        latency of the decimator (and the limiter, where a preset has one)
        beyond :attr:`time`: about 25 ms at 48 kHz."""
        eng = self._engine
        return eng.time_in / eng.fs_in_exact

    def __repr__(self) -> str:
        return f"Instrument({self.preset!r}, {self.fs} Hz, {self.channels} channels, at {self.time:.3f} s)"

    # -- events ---------------------------------------------------------------
    def _time(self, time) -> float:
        """An event's time (s), checked: at or after the previous event's
        and the horizon; None: the horizon."""
        eng = self._engine
        h = self.horizon
        t = h if time is None else check_real("time", time, 0.0, MAX_TIME_S, unit="s")
        if t < self._last:
            given = f"{time} s" if time is not None else f"None (the horizon, {t:g} s)"
            raise ValueError(f"time = {given} is before the previous event's ({self._last:g} s): "
                             "give events in time order")
        if time is not None and eng.sample_of(t) < eng.time_in:
            now = self.time
            if t < now:
                raise ValueError(f"time = {time} s is before the end of the audio already "
                                 f"rendered (Instrument.time = {now:g} s)")
            raise ValueError(f"time = {time} s is before Instrument.horizon ({h:.6g} s), up to "
                             "which the sound is computed: give an event before rendering the "
                             "chunk that sounds it, or time=None (the horizon)")
        return t

    def _event(self, time, channel, msg_type: str, **fields) -> None:
        """Schedule a message given in MIDI units, normalised as a file's
        or a keyboard's (:func:`synth.io.midi.normalise_fields`)."""
        from ..engine.engine import Event
        from ..io.midi import normalise_fields

        ch = check_int("channel", channel, 1, 16) - 1
        t = self._time(time)
        kind, ch, key, value = normalise_fields(msg_type, channel=ch, **fields)
        self._engine.schedule([Event(t, kind, key, value, ch)])
        self._last = t

    def note_on(self, key: int, velocity: int = 100, time: float | None = None, *,
                channel: int = 1) -> None:
        """Key ``key`` (0-127) down at ``velocity`` (1-127) at ``time`` (s;
        None: :attr:`horizon`) on MIDI ``channel`` (1-16).  A key already
        sounding on the channel is struck again."""
        key = check_int("key", key, *KEY_RANGE)
        velocity = check_int("velocity", velocity, *VELOCITY_RANGE)
        self._event(time, channel, "note_on", note=key, velocity=velocity)

    def note_off(self, key: int, time: float | None = None, *, channel: int = 1) -> None:
        """Key ``key`` (0-127) up at ``time`` (s; None: :attr:`horizon`) on MIDI
        ``channel`` (1-16), release velocity 64; the strings are damped as
        far as the sustain pedal (CC64) lets them be."""
        key = check_int("key", key, *KEY_RANGE)
        self._event(time, channel, "note_off", note=key, velocity=RELEASE_VELOCITY)

    def control(self, cc: int, value: int, time: float | None = None, *, channel: int = 1) -> None:
        """Controller ``cc`` (0-127) to ``value`` (0-127) at ``time`` (s;
        None: :attr:`horizon`) on MIDI ``channel`` (1-16): CC64 sustain pedal,
        CC1 a plucked preset's buzz depth, CC7 volume, CC10 pan, ...
        (docs/midi.md)."""
        cc = check_int("cc", cc, 0, 127)
        value = check_int("value", value, 0, 127)
        self._event(time, channel, "control_change", control=cc, value=value)

    def pitch_bend(self, value: int, time: float | None = None, *, channel: int = 1) -> None:
        """Pitch bend ``value`` (-8192..8191, 0 centre: MIDI's 14 bits) at
        ``time`` (s; None: :attr:`horizon`) on MIDI ``channel`` (1-16); the
        full bend is the preset's ``play.pitch_bend_semitones``."""
        value = check_int("value", value, *BEND_RANGE)
        self._event(time, channel, "pitchwheel", pitch=value)

    # -- audio ----------------------------------------------------------------
    def render(self, seconds: float) -> Audio:
        """The next ``round(seconds * fs)`` frames.

        Parameters
        ----------
        seconds : float
            Length of the chunk (s), 0 < seconds <= 600.

        Returns
        -------
        Audio
            float32, (frames, channels), from :attr:`time` on.
        """
        s = check_real("seconds", seconds, 0.0, SECONDS_MAX, lo_open=True)
        n = int(round(s * self.fs))
        eng = self._engine
        pieces, have = [self._ahead], len(self._ahead)
        while have < n:
            # whole blocks on one grid (Engine.render_blocks'): any chunks, the same samples
            y = eng.render_block(self.BLOCK)
            skip = max(self._lat - self._done, 0)     # the latency's samples, at the start
            self._done += self.BLOCK
            if skip < self.BLOCK:
                y = y[skip:, None] if y.ndim == 1 else y[:, skip:].T
                pieces.append(y.astype(np.float32))
                have += len(y)
        buf = np.concatenate(pieces) if len(pieces) > 1 else self._ahead
        out, self._ahead = buf[:n], buf[n:].copy()
        self._frames += n
        return Audio(out, self.fs)

    def reset(self) -> None:
        """Back to the start: every string silent (no tail of what played
        before), controllers, pedals and bends as the preset loads them,
        the pending events dropped, :attr:`time` 0.  The preset is built
        again (its voice too: a reset instrument sounds as a new one)."""
        self._build()
