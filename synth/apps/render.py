"""``synth render``: a Standard MIDI File played by a preset into a WAV file.

Long work shows itself and can be stopped:

* On a terminal, a render that runs longer than :data:`PROGRESS_DELAY_S`
  (2 s) shows a progress bar (tqdm) on stderr: seconds of audio done, the
  time elapsed and the time left. Not on a terminal (a pipe, a file, CI) or
  for a shorter render, nothing is shown.
* A file whose audio lasts more than :data:`LONG_RENDER_S` (30 min) is
  announced before any work with one line on stderr (``warning: FILE lasts
  3:00:00 (10800 s): rendering more than 30 min of audio; --max-seconds S
  renders only the first S seconds``); the render then goes on. A
  mutated file with huge delta times, or three hours of silence before one
  note, no longer renders for minutes without a word.
* ``--max-seconds S`` caps the audio at S seconds: notes starting at S or
  later are left out and, when the music goes on past S, the result is
  exactly S seconds long, ending in a :data:`CUT_FADE_S` (10 ms) fade-out (a
  note line on stderr says so). With ``--max-seconds`` the user has chosen
  the length: no 30-minute warning.
* A length no WAV file can hold (4 GiB of samples: 3 h 6 min of stereo
  32-bit float) is refused before rendering, naming the limit.
* Ctrl-C (SIGINT) and SIGTERM stop the render (:mod:`synth.io.interrupt`):
  no output file and no temporary file is left, an existing output file is
  kept as it was, and the exit status is 130 or 143.
* The file is written atomically (:mod:`synth.io.wav`): a full disk gives a
  one-line error (``out.wav: writing failed (No space left on device)``)
  and no partial file.
"""

from __future__ import annotations

import math
import os
import sys
import time
from collections.abc import Callable, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np

from ..io.errors import SynthError, display_path
from ..io.interrupt import Interrupted, interruptible, raise_if_interrupted

__all__ = [
    "RenderRequest",
    "RenderPlan",
    "RenderResult",
    "plan_render",
    "render_midi",
    "render_midi_file",
    "PreparedRender",
    "prepare_render",
    "write_render",
    "output_interruptible",
    "check_max_seconds",
    "log_stderr",
    "ignored_lines",
    "format_length",
    "LONG_RENDER_S",
    "PROGRESS_DELAY_S",
    "TAIL_S",
    "MAX_TAIL_S",
    "CUT_FADE_S",
]

#: renders longer than this (s of audio) are announced with a warning
LONG_RENDER_S = 30 * 60.0
#: the progress bar appears only once a render has run this long (s), on a terminal
PROGRESS_DELAY_S = 2.0
#: silence kept after the last voice has died away (s)
TAIL_S = 0.5
#: the longest release tail after the last event (s)
MAX_TAIL_S = 30.0
#: the fade-out where --max-seconds cuts a sounding render (s)
CUT_FADE_S = 0.010


@dataclass(frozen=True)
class RenderRequest:
    """What ``synth render`` was asked to do (validated by :func:`render_midi`).

    Attributes
    ----------
    midi_file : str
        The Standard MIDI File.
    preset : str
        Preset name or ``.toml`` path.
    output : str
        The WAV file to write (replaced atomically if it exists).
    overrides : tuple of str
        ``--set PATH=VALUE`` overrides of the preset.
    internal_rate : float or None
        Internal rate of the strings (Hz); None: the preset's.
    rate : int or None
        Output sample rate of the WAV file (Hz, ``--rate``); None: 48 kHz.
    pcm24 : bool
        24-bit PCM instead of 32-bit float.
    max_seconds : float or None
        ``--max-seconds``: the longest audio to render (s), 0 < value <=
        :data:`~synth.io.midi.MAX_DURATION_S`; None: the whole file.
    channels : tuple of int or None
        ``--channels``: the MIDI channels that play, 0-based (0 .. 15);
        None: every channel.
    drums : bool
        ``--drums``: play channel 10 (General MIDI's drums) as pitched
        notes too; by default it is skipped.
    mpe : tuple of (int, int)
        ``--mpe``: MPE zones set before the first event, as if the MPE
        Configuration Message had been received: (manager channel 0 or
        15, member channels 1 .. 15) each
        (:func:`synth.engine.mpe.parse_mpe`); () none.
    """

    midi_file: str
    preset: str
    output: str
    overrides: tuple[str, ...] = ()
    internal_rate: float | None = None
    pcm24: bool = False
    max_seconds: float | None = None
    channels: tuple[int, ...] | None = None
    drums: bool = False
    rate: int | None = None
    mpe: tuple[tuple[int, int], ...] = ()
    #: the container: "wav", "flac" or "ogg" (synth.io.wav.FORMATS)
    fmt: str = "wav"


@dataclass(frozen=True)
class RenderPlan:
    """What will be rendered, decided from the file's events alone (no engine).

    Attributes
    ----------
    events : list of synth.engine.engine.Event
        The events to play (those before ``--max-seconds``).
    keys : list of int
        The keys of their note-ons.
    file_length_s : float
        Time of the file's last event (s).
    last_s : float
        Time of the last event played (s).
    expected_s : float
        The least audio the render gives (s): up to the last event plus
        :data:`TAIL_S`, or exactly ``max_seconds`` when the file is cut.
    duration_s : float or None
        Exact length to render (the file cut at ``max_seconds``), or None:
        until the sound has died away, at most ``max_tail_s`` after the last
        event.
    max_tail_s : float
        The longest release tail after the last event (s).
    cut : bool
        ``max_seconds`` leaves events of the file out.
    notes : list of str
        Lines for stderr (``warning: ...``, ``note: ...``), printed before
        rendering.
    """

    events: list
    keys: list
    file_length_s: float
    last_s: float
    expected_s: float
    duration_s: float | None
    max_tail_s: float
    cut: bool
    notes: list = field(default_factory=list)
    #: the MIDI file's length (s, its end of track), or None (not a file's):
    #: a drone player still running then plays out its cycle and stops
    file_end_s: float | None = None


@dataclass(frozen=True)
class RenderResult:
    """What :func:`render_midi` wrote.

    Attributes
    ----------
    seconds : float
        Length of the audio written (s).
    notes : int
        Note-ons played.
    elapsed_s : float
        Time the render took (s), without reading and writing.
    summary : str
        The one-line report for stdout.
    stolen : int
        Voices given up to new notes (the pool was full).
    ignored : dict
        Messages the file holds and the render did not play, by name, with
        their counts (:func:`ignored_lines` prints them).
    """

    seconds: float
    notes: int
    elapsed_s: float
    summary: str
    stolen: int = 0
    ignored: dict = field(default_factory=dict)
    #: the peak sample (dBFS; over 0: over full scale), samples clipped
    #: (24-bit PCM, FLAC, Ogg), and the preset's output.gain
    peak_dbfs: float = -math.inf
    n_clipped: int = 0
    output_gain: float | None = None
    #: the integrated loudness written (LUFS), when measured (write_render's ``loudness``)
    lufs: float | None = None


def ignored_lines(ignored: dict) -> list[str]:
    """``note: ignored ...`` lines for the messages a render did not play,
    one per kind with its count, in order of count (most first)."""
    return [f"note: ignored {n} x {what}"
            for what, n in sorted(ignored.items(), key=lambda kv: (-kv[1], kv[0]))]


def format_length(seconds: float) -> str:
    """A length for messages: ``"42.0 s"`` below a minute, else ``"3:00:05
    (10805 s)"`` or ``"31:00 (1860 s)"``."""
    if seconds < 60.0:
        return f"{seconds:.1f} s"
    s = int(round(seconds))
    h, rest = divmod(s, 3600)
    m, sec = divmod(rest, 60)
    hms = f"{h}:{m:02d}:{sec:02d}" if h else f"{m}:{sec:02d}"
    return f"{hms} ({s} s)"


def check_max_seconds(max_seconds: float | None) -> None:
    """``--max-seconds``: None, or 0 < value <= MAX_DURATION_S (SynthError naming it)."""
    if max_seconds is None:
        return
    # (the MIDI reader, and mido with it, only when a file is read: a note
    # command imports this module and reads none, 40 ms)
    from ..io.midi import MAX_DURATION_S

    if not (0.0 < max_seconds <= MAX_DURATION_S):     # also NaN
        raise SynthError(f"--max-seconds = {max_seconds:g} is out of range "
                         f"(0 < value <= {MAX_DURATION_S:g} s)")


def plan_render(events: Sequence, max_seconds: float | None = None, shown: str = "MIDI file",
                file_end_s: float | None = None) -> RenderPlan:
    """Decide what to render: the events kept, the expected length, the warnings.

    Parameters
    ----------
    events : sequence of synth.engine.engine.Event
        The file's events (:func:`synth.io.midi.midi_to_events`).
    max_seconds : float or None
        ``--max-seconds`` (validated here), or None.
    shown : str
        The file's name in messages.
    file_end_s : float or None
        The file's length (:attr:`synth.io.midi.MidiEvents.length_s`), kept
        as :attr:`RenderPlan.file_end_s`.

    Returns
    -------
    RenderPlan

    Raises
    ------
    SynthError
        ``--max-seconds`` out of range, a file without notes, or no note
        starting before ``--max-seconds``.
    """
    check_max_seconds(max_seconds)
    events = list(events)
    notes = [e for e in events if e.kind == "note_on" and e.value > 0]
    if not notes:
        raise SynthError(f"{shown}: the file has no notes to play")
    file_len = max(e.time_s for e in events)
    lines = []
    if max_seconds is not None and file_len >= max_seconds:
        kept = [e for e in events if e.time_s < max_seconds]
        kept_notes = [e for e in kept if e.kind == "note_on" and e.value > 0]
        if not kept_notes:
            raise SynthError(f"{shown}: no note starts in the first {max_seconds:g} s "
                             f"(--max-seconds); the first starts at {format_length(notes[0].time_s)}")
        lines.append(f"note: {shown} lasts {format_length(file_len)}; rendering its first "
                     f"{format_length(max_seconds)} (--max-seconds {max_seconds:g})")
        last = max(e.time_s for e in kept)
        return RenderPlan(kept, [int(e.key) for e in kept_notes], file_len, last,
                          float(max_seconds), float(max_seconds), 0.0, True, lines)
    max_tail = MAX_TAIL_S if max_seconds is None else min(MAX_TAIL_S, max_seconds - file_len)
    expected = file_len + TAIL_S if max_seconds is None else min(file_len + TAIL_S, max_seconds)
    if max_seconds is None and expected > LONG_RENDER_S:
        lines.append(f"warning: {shown} lasts {format_length(file_len)}: rendering more than "
                     f"{LONG_RENDER_S / 60:g} min of audio; --max-seconds S renders only the "
                     f"first S seconds")
    return RenderPlan(events, [int(e.key) for e in notes], file_len, file_len, expected, None,
                      max_tail, False, lines, file_end_s)


def _is_terminal(stream) -> bool:
    try:
        return bool(stream is not None and stream.isatty())
    except (AttributeError, ValueError, OSError):    # no isatty, or a closed stream
        return False


class _Progress:
    """The render's progress bar on a terminal (tqdm, shown after
    :data:`PROGRESS_DELAY_S`), fed output samples by ``Engine.render``."""

    BAR_FORMAT = ("{desc}: {percentage:3.0f}%|{bar}| {n:.0f}/{total:.0f} s of audio "
                  "[{elapsed} elapsed, {remaining} left]")

    def __init__(self, total_s: float, fs: int, stream, desc: str) -> None:
        from tqdm import tqdm

        self.fs = fs
        # nrows given: tqdm hides a bar below the screen's last row, and a
        # terminal that reports no size (0 x 0: a bare pty) would hide it
        self.bar = tqdm(total=max(total_s, 1e-3), file=stream, delay=PROGRESS_DELAY_S, leave=False,
                        desc=desc, unit="s", bar_format=self.BAR_FORMAT, mininterval=0.25,
                        nrows=24)

    def __call__(self, n_out: int) -> None:
        s = n_out / self.fs
        bar = self.bar
        if s > bar.total:           # the release tail beyond the expected length
            bar.total = s
        bar.update(s - bar.n)

    def close(self) -> None:
        self.bar.close()


def _checked(blocks):
    """The blocks, stopping with :class:`Interrupted` once a signal has
    arrived whose exception was lost (:func:`synth.io.interrupt.
    raise_if_interrupted`): checked before each block and after the last,
    so before the output file is put in place."""
    for b in blocks:
        raise_if_interrupted()
        yield b
    raise_if_interrupted()


class _Cut:
    """The render's blocks cut at ``n_max`` samples (None: not cut), the
    last ``n_fade`` of them held back until the render ends: when it is cut
    (``cut`` known beforehand: the file was cut at --max-seconds; or found
    now: the release tail ran past it) they fade out (:func:`_fade_out`),
    as they did on the whole render in memory.  After the iteration,
    :attr:`cut` says whether it was."""

    def __init__(self, blocks, n_max: int | None, n_fade: int, cut: bool) -> None:
        self.blocks, self.n_max, self.n_fade, self.cut = blocks, n_max, int(n_fade), bool(cut)

    def __iter__(self):
        if self.n_max is None:
            yield from self.blocks            # nothing to cut, nothing to fade
            return
        held = None
        total = 0
        for b in self.blocks:
            if total + len(b) > self.n_max:
                b = b[: self.n_max - total]
                self.cut = True
            total += len(b)
            held = b if held is None else np.concatenate([held, b])
            if len(held) > self.n_fade:
                yield held[: len(held) - self.n_fade]
                held = held[len(held) - self.n_fade:]
            if total >= self.n_max:
                self.cut = self.cut or self._more()
                break
        if held is not None and len(held):
            if self.cut:
                held = held.copy()
                _fade_out(held, self.n_fade)
            yield held

    def _more(self) -> bool:
        """Whether the render goes on past ``n_max`` (one more block)."""
        return next(iter(self.blocks), None) is not None


def _fade_out(y: np.ndarray, n: int) -> None:
    """A raised-cosine fade over the last `n` samples of `y` ((frames,) or (frames, channels)), in place."""
    n = min(n, len(y))
    if n <= 0:
        return
    ramp = 0.5 * (1.0 + np.cos(np.pi * (np.arange(1, n + 1) / n)))
    y[-n:] *= ramp if y.ndim == 1 else ramp[:, None]


def render_midi(req: RenderRequest, *, log: Callable[[str], None] | None = None,
                stream=None) -> RenderResult:
    """Render a MIDI file with a preset into a WAV file (``synth render``).

    Parameters
    ----------
    req : RenderRequest
        The file, the preset and the options.
    log : callable or None
        Receives the ``note:``/``warning:`` lines (default: print to stderr).
    stream : file or None
        Where the progress bar goes (default ``sys.stderr``); it is shown
        only if this is a terminal.

    Returns
    -------
    RenderResult

    Raises
    ------
    SynthError
        One line: bad ``--max-seconds``, an unreadable or broken MIDI file,
        no notes, a bad preset, a length beyond what a WAV file holds, a
        failed write (a full disk). Nothing is left at ``req.output``.
    Interrupted
        SIGINT or SIGTERM: nothing written, an existing output file kept,
        no temporary file left; its ``detail`` says so.
    """
    if log is None:
        log = log_stderr
    if stream is None:
        stream = sys.stderr
    check_max_seconds(req.max_seconds)
    with output_interruptible(req.output):
        return _render(req, log, stream)


def log_stderr(line: str) -> None:
    """A ``note:``/``warning:`` line on stderr, at once."""
    print(line, file=sys.stderr, flush=True)


@contextmanager
def output_interruptible(output: str):
    """SIGINT and SIGTERM stop the work within (:func:`synth.io.interrupt.
    interruptible`) with an :class:`Interrupted` whose ``detail`` says what
    became of ``output``: "was not written", or "was left as it was" when it
    existed before."""
    shown_out = display_path(output)
    existed = os.path.lexists(output)
    with interruptible():
        try:
            yield
        except Interrupted as e:
            kept = "was left as it was" if existed else "was not written"
            raise Interrupted(e.signum, f"{shown_out} {kept}") from None


def render_midi_file(req: RenderRequest, *, log: Callable[[str], None] | None = None,
                     stream=None) -> RenderResult:
    """:func:`render_midi` without taking over SIGINT and SIGTERM, for code
    that does not own the process's signals: a thread, or a batch worker
    (:mod:`synth.apps.batch_worker`), whose process its nanny stops.  The write is
    atomic all the same.  ``log`` defaults to nothing; ``stream`` to none
    (no progress bar)."""
    check_max_seconds(req.max_seconds)
    return _render(req, log or (lambda line: None), stream)


def _render(req: RenderRequest, log, stream) -> RenderResult:
    from ..io.midi import read_midi_file     # looked up now: tests patch it

    ignored: dict = {}
    raw = read_midi_file(req.midi_file, dropped=ignored)
    prep = prepare_render(raw, display_path(req.midi_file), req.preset, req.overrides,
                          ignored=ignored, internal_rate=req.internal_rate, rate=req.rate,
                          max_seconds=req.max_seconds,
                          channels=None if req.channels is None else set(req.channels),
                          drums=req.drums, mpe=req.mpe, log=log)
    return write_render(prep, req.output, pcm24=req.pcm24, fmt=req.fmt, log=log, stream=stream)


class PreparedRender:
    """A MIDI file's render made ready: its events planned
    (:func:`plan_render`), the engine built, nothing rendered yet
    (:func:`prepare_render`).  :meth:`blocks` runs it once;
    :func:`write_render` writes it to a file.  The Python API's
    :class:`synth.api.MidiStream` is one.

    Attributes
    ----------
    plan : RenderPlan
    engine : synth.engine.engine.Engine
    shown : str
        The file's name in messages.
    preset : str
        The preset as given (messages).
    notes : list of str
        The ``note:``/``warning:`` lines of the plan and the preset's range,
        said before rendering.
    ignored : dict
        Messages of the file not played, by name, with their counts; after
        the render, with those the engine ignored.
    max_seconds : float or None
        The cap (s), or None.
    cut : bool
        After :meth:`blocks`: whether the sound was cut at ``max_seconds``.
    """

    def __init__(self, plan: RenderPlan, engine, shown: str, preset: str, notes: list,
                 ignored: dict, max_seconds: float | None) -> None:
        self.plan, self.engine, self.shown, self.preset = plan, engine, shown, preset
        self.notes, self.ignored, self.max_seconds = notes, ignored, max_seconds
        self.cut = plan.cut
        self._started = False

    def blocks(self, progress=None, *, interruptible: bool = False):
        """The render's blocks as the engine gives them (float64,
        ``(frames,)`` mono or ``(frames, channels)``), cut at
        ``max_seconds`` with the fade-out; ``progress`` is called with the
        output samples done (``Engine.render_blocks``); with
        ``interruptible`` it stops with :class:`Interrupted` between
        blocks once a signal has arrived (:func:`_checked`).  Runs once:
        an engine renders from time 0 only once."""
        if self._started:
            raise RuntimeError("this render has already run (prepare it again to render again)")
        self._started = True
        eng, plan = self.engine, self.plan
        if plan.duration_s is not None:
            blocks = eng.render_blocks(plan.events, duration_s=plan.duration_s, progress=progress)
        else:
            blocks = eng.render_blocks(plan.events, tail_s=TAIL_S, max_tail_s=plan.max_tail_s,
                                       progress=progress, drone_end_s=plan.file_end_s)
        if interruptible:
            blocks = _checked(blocks)
        fs = eng.fs_out
        n_max = None if self.max_seconds is None else int(round(self.max_seconds * fs))
        cut = _Cut(blocks, n_max, int(round(CUT_FADE_S * fs)), plan.cut)
        yield from cut
        self.cut = cut.cut
        for what, n in eng.ignored.items():
            self.ignored[what] = self.ignored.get(what, 0) + n


def prepare_render(raw, shown: str, preset, overrides=(), *, ignored: dict | None = None,
                   internal_rate: float | None = None, rate: int | None = None,
                   max_seconds: float | None = None, channels=None, drums: bool = False,
                   mpe=(), log: Callable[[str], None] | None = None) -> PreparedRender:
    """Plan a MIDI file's events and build the engine that plays them.

    Parameters
    ----------
    raw : list of synth.io.midi.MidiEvent
        The file's messages (:func:`synth.io.midi.read_midi_file`).
    shown : str
        The file's name in messages.
    preset, overrides
        Preset name or ``.toml`` path, and its ``--set`` texts.
    ignored : dict or None
        Messages the reader dropped, by name (added to, with those of
        ``channels`` and ``drums``).
    internal_rate, rate : float or None
        The strings' rate and the output rate (Hz); None: the preset's and
        48 kHz.
    max_seconds : float or None
        ``--max-seconds`` (checked here).
    channels : set of int or None
        The 0-based MIDI channels that play; None: all.
    drums : bool
        Play channel 10 too.
    mpe : tuple of (int, int)
        MPE zones (:attr:`RenderRequest.mpe`).
    log : callable or None
        Receives the ``note:``/``warning:`` lines as soon as they are known
        (they are kept in :attr:`PreparedRender.notes` too).

    Raises
    ------
    SynthError
        One line: bad ``--max-seconds``, no notes, a bad preset or override.
    """
    from ..io.factory import build_engine
    from ..io.midi import midi_to_events     # looked up now: tests patch it

    check_max_seconds(max_seconds)
    ignored = {} if ignored is None else ignored
    events = midi_to_events(raw, channels=channels, drums=drums, ignored=ignored)
    plan = plan_render(events, max_seconds, shown, file_end_s=getattr(raw, "length_s", None))
    notes = list(plan.notes)
    for line in notes:
        if log is not None:
            log(line)
    eng = build_engine(preset, overrides, fs_internal=internal_rate,
                       extra_low_key=min(plan.keys),
                       **({} if rate is None else {"fs_out": int(rate)}))
    eng.set_mpe_zones(mpe)
    p = eng.inst.preset
    if p.kind == "musical":
        lo, hi = p.play.key_low, p.play.key_high
        out_of = sum(1 for k in plan.keys if not (lo <= k <= hi))
        if out_of:
            line = (f"note: {out_of} of {len(plan.keys)} notes are outside {os.fspath(preset)}'s "
                    f"range {lo}..{hi}; they are played on the string retuned or fretted to "
                    "that pitch")
            notes.append(line)
            if log is not None:
                log(line)
    return PreparedRender(plan, eng, shown, os.fspath(preset), notes, ignored, max_seconds)


def _metered(blocks, meter):
    """The blocks, each given to ``meter.add`` on the way."""
    for b in blocks:
        meter.add(b)
        yield b


def write_render(prep: PreparedRender, output: str, *, pcm24: bool = False, fmt: str = "wav",
                 log: Callable[[str], None] | None = None, stream=None,
                 what=None, loudness: bool = False) -> RenderResult:
    """Render ``prep`` into the audio file ``output``, written as rendered
    (atomically: :func:`synth.io.wav.write_wav_stream`), with the progress
    bar on ``stream`` if it is a terminal, stopping between blocks once
    SIGINT or SIGTERM has arrived (run it within
    :func:`synth.io.interrupt.interruptible`, as :func:`render_midi` does).
    ``what`` words the render in the summary (a text, or a function
    giving it once rendered; default: "N notes on PRESET"); with ``loudness`` the summary gives the integrated loudness
    of the samples written (BS.1770, measured as they are written:
    :class:`synth.analysis.loudness.IntegratedLoudness`), also in
    :attr:`RenderResult.lufs`.

    Raises
    ------
    SynthError
        A length beyond what a WAV file holds, a failed write.
    Interrupted
        A signal: nothing written.
    """
    from ..io.wav import wav_max_frames, write_wav_stream

    log = log or (lambda line: None)
    eng, plan, shown = prep.engine, prep.plan, prep.shown
    fs = eng.fs_out
    subtype = "pcm24" if pcm24 else "float"
    limit_s = wav_max_frames(eng.channels, subtype) / fs
    if fmt == "wav" and plan.expected_s > limit_s:
        kind = {1: "mono", 2: "stereo"}.get(eng.channels, f"{eng.channels}-channel")
        raise SynthError(f"{shown}: {format_length(plan.expected_s)} of {kind} "
                         f"{'24-bit PCM' if pcm24 else '32-bit float'} audio is more than a WAV "
                         f"file holds ({format_length(limit_s)}); give --max-seconds "
                         f"(0 < value <= {math.floor(limit_s)} s)")
    bar = (_Progress(plan.expected_s, fs, stream, f"rendering {shown}")
           if stream is not None and _is_terminal(stream) else None)
    blocks = prep.blocks(bar, interruptible=True)
    meter = None
    if loudness:
        from ..analysis.loudness import IntegratedLoudness

        meter = IntegratedLoudness(fs, eng.channels)
        blocks = _metered(blocks, meter)
    from ..dsp.compile_notice import compile_seconds, timing_note

    c0 = compile_seconds()
    t = time.perf_counter()
    try:
        # written as rendered: the whole render is never in memory
        res = write_wav_stream(output, blocks, fs, eng.channels, subtype, fmt=fmt)
    finally:
        if bar is not None:
            bar.close()
    comp = compile_seconds() - c0
    el = time.perf_counter() - t - comp
    if prep.cut and not plan.cut:
        log(f"note: the sound is cut at {format_length(prep.max_seconds)} "
            f"(--max-seconds {prep.max_seconds:g}), before it has died away")
    clip = f", {res.n_clipped} samples clipped" if res.n_clipped else ""
    dur = res.frames / fs
    for line in ignored_lines(prep.ignored):
        log(line)
    stolen = f", {eng.n_stolen} voices stolen (polyphony {eng.polyphony})" if eng.n_stolen else ""
    lufs = None if meter is None else meter.lufs()
    level = "" if lufs is None else f"{lufs:.1f} LUFS integrated, "
    if what is None:
        what = f"{len(plan.keys)} notes on {prep.preset}"
    elif callable(what):
        what = what()
    summary = (f"{output}: {dur:.1f} s, {what}{stolen}, "
               f"{level}peak {res.peak_dbfs:.1f} dBFS{clip}, "
               f"rendered in {el:.1f} s ({el / max(dur, 1e-9):.2f} x real time)"
               f"{timing_note(comp)}")
    return RenderResult(dur, len(plan.keys), el, summary, eng.n_stolen, dict(prep.ignored),
                        res.peak_dbfs, res.n_clipped, float(eng.inst.preset.output.gain), lufs)
