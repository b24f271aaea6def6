"""The live player: MIDI messages in, the audio stream out.

* :class:`Player`: builds and warms the engine before the stream opens,
  stamps each MIDI message with its arrival time, swaps instruments on a
  program change (built and warmed in a background thread), prints a meter
  and, at Ctrl-C, the real-time report.
* :func:`normalise`: live messages are normalised by the same function as
  the MIDI file reader (:func:`synth.io.midi.normalise_message`).  It lives
  here, not with the ports in :mod:`synth.io.live.devices`, because it is
  the first half of the player's MIDI callback (:meth:`Player.handle`) and
  makes engine events: the device module finds and checks the hardware and
  never touches the engine, the player is where messages become events.

Latency
-------
An event arriving at clock time ``a`` is rendered at stream time
``a - t0 + latency_s`` (``latency_s``: two blocks by default, 5.3 ms for 128
samples at 48 kHz), then waits for the device buffer (PortAudio's output
latency) and the decimator's delay (0.9 ms) before it is heard.
"""

from __future__ import annotations

import contextlib
import math
import gc
import sys
import threading
import time

from synth.io.errors import SynthError
from synth.io.midi import (MidiEvent, dropped_name, midi_to_events, normalise_message,
                           plays_channel)
from synth.io.rates import check_rate
from synth.io.live.devices import (FS_OUT, _one_line, _quiet_c_stderr, check_audio, check_midi,
                                   pick_audio_device, pick_midi_api, pick_midi_port,
                                   port_lister)
from synth.io.live.engines import ready_engine
from synth.io.live.rehearsal import DEFAULT_EVERY_MS, EVERY_MS_RANGE, Rehearsal
from synth.io.live.programs import ProgramMap

__all__ = ["SWITCH_INTERVAL_S", "normalise", "Player"]

#: the interpreter's thread switch interval while streaming (s): the audio
#: callback waits at most about this long for the GIL when another thread
#: (a program change being built) runs Python
SWITCH_INTERVAL_S = 0.0001


# --------------------------------------------------------------------------
# Messages
# --------------------------------------------------------------------------


def normalise(msg, channels=None, drums: bool = False, ignored: dict | None = None):
    """A live mido message as an engine :class:`~synth.engine.engine.Event`.

    The values are those of the MIDI file reader (one shared function,
    :func:`synth.io.midi.normalise_message`): note-on velocity / 127 (a
    note-on with velocity 0 is a note-off), note-off release velocity / 127,
    ``control`` value / 127, ``pitch_bend`` in [-1, 1] (key -1),
    ``channel_pressure`` and ``poly_pressure`` / 127 (the engine lists the
    kinds a preset does not play).  The event's ``time_s`` is 0: the
    player stamps the arrival time.

    Returns
    -------
    Event or None
        None for program changes (the player handles those) and for
        messages that are dropped (clock, SysEx, ...).

    The channels that play (``channels``, 0-based; None: all) and the
    General MIDI drum channel (skipped unless ``drums``) are chosen by the
    same function as a render's (:func:`synth.io.midi.midi_to_events`);
    what is not played is counted in ``ignored``.
    """
    n = normalise_message(msg)
    if n is None:
        if ignored is not None:
            name = dropped_name(msg)
            if name is not None:
                ignored[name] = ignored.get(name, 0) + 1
        return None
    if n[0] == "program":
        return None
    evs = midi_to_events([MidiEvent(0.0, *n)], channels=channels, drums=drums, ignored=ignored)
    return evs[0] if evs else None


# --------------------------------------------------------------------------
# The player
# --------------------------------------------------------------------------


class Player:
    """Play a preset live: MIDI input -> :class:`Realtime` -> audio output.

    The constructor checks everything that can be missing or wrong (the
    sounddevice/PortAudio and rtmidi installs, the ports, the device, the
    presets) before any slow work; :meth:`start` builds and warms the
    engine and opens the stream and the port; :meth:`run` shows the meter
    until Ctrl-C (or ``seconds``), closes, and prints the report.

    Parameters
    ----------
    preset : str
        The preset played first (program 0 unless ``program_map`` says otherwise).
    program_map : ProgramMap or None
        Presets for program changes; default: program 0 -> ``preset``.
    block : int
        Audio block size (samples at the output rate), 16 .. 4096.
    latency_s : float or None
        Constant delay from a message's arrival to its place in the stream
        (s), at least one block; default two blocks.
    audio_device : str or None
        Output device index or name (part); None: the default output.
    midi_port : str or None
        MIDI input port name (part); None: the first real input port.
    midi_api : {"auto", "alsa", "jack"}
        The MIDI system the port is on (``--midi-api``): the ALSA
        sequencer, JACK MIDI, or ``auto``: JACK when a JACK server runs,
        else ALSA.  A port that disappears while playing is reported once
        and play goes on; it is reopened when it comes back.
    midi : bool
        Open a MIDI input port (False: messages only via :meth:`handle`).
    stats : bool
        Print the meter once a second while playing, with the contact
        telemetry of the latest note's strings (its strings then take the
        kernel's per-sample path, which counts contacts).
    out : file
        Where status lines, the meter and the report go (stdout).
    overrides : sequence of str
        ``PATH=VALUE`` overrides (``--set``) of ``preset``, wherever the
        program map plays it (e.g. ``play.polyphony=32``).
    channels : collection of int or None
        MIDI channels that play (0-based); None: every channel.
    drums : bool
        Play channel 10 (General MIDI's drums) too.
    record : str or None
        A WAV file that receives the performance as it goes to the device
        (:class:`synth.io.live.record.Recorder`), complete whatever stops
        the play.
    mpe : tuple of (int, int)
        ``--mpe``: MPE zones set on the engine before the stream opens
        (:func:`synth.engine.mpe.parse_mpe`); a program change keeps the
        zones the engine has then (:meth:`Realtime.swap`).
    warm_every_ms : float
        ``--warm-every-ms``: every so many milliseconds a background
        thread plays a silent note on a small copy of the instrument, so
        that a chord after a quiet moment finds its code and data warm
        (:mod:`synth.io.live.rehearsal`); 0 turns it off, else 2 .. 1000
        (default 20).
    rate : int or None
        Output rate (Hz, ``--rate``), 22050 .. 192000; None: 48 kHz, or
        the device's own rate when it cannot play 48 kHz (a JACK server's
        rate is the server's).  The decimator is designed for this rate
        (:class:`synth.dsp.decimator.Decimator`: 20 kHz flat, 110 dB down
        from the Nyquist frequency).

    Attributes
    ----------
    fs : int
        The output rate (Hz) the stream plays at.
    """

    def __init__(self, preset: str, program_map: ProgramMap | None = None, block: int = 128,
                 latency_s: float | None = None, audio_device: str | None = None,
                 midi_port: str | None = None, midi: bool = True, stats: bool = False,
                 out=None, overrides=(), channels=None, drums: bool = False,
                 record: str | None = None, rate: int | None = None, midi_api: str = "auto",
                 mpe=(), warm_every_ms: float = DEFAULT_EVERY_MS):
        from synth.engine.engine import Engine
        from synth.io.presets import load_preset

        if not (16 <= int(block) <= Engine.MAX_BLOCK_OUT):
            raise SynthError(f"--block = {block} is out of range (16 <= value <= "
                             f"{Engine.MAX_BLOCK_OUT})")
        self.block = int(block)
        w = float(warm_every_ms)
        lo, hi = EVERY_MS_RANGE
        if not (w == 0.0 or lo <= w <= hi):
            raise SynthError(f"--warm-every-ms = {warm_every_ms:g} is out of range (0: off, or "
                             f"{lo:g} <= value <= {hi:g})")
        self.warm_every_ms = w
        #: the silent notes that keep a note's paths warm (None: off)
        self.rehearsal = None
        self._rate = None if rate is None else check_rate(rate)
        self.fs = self._rate
        self.overrides = tuple(overrides)
        self.midi_channels = None if channels is None else frozenset(int(c) for c in channels)
        self.drums = bool(drums)
        self.mpe = tuple(mpe)
        #: messages received and not played, by name (the report lists them)
        self.ignored: dict = {}
        #: why the audio stopped by itself (:meth:`run`), or None
        self.stopped = None
        self.record_path = None
        if record is not None:
            from synth.io.live.record import check_record_path

            self.record_path = check_record_path(record)
        self.recorder = None
        self.record_line = None
        self._first = preset
        load_preset(preset, self.overrides)                  # a bad name or --set fails now
        self.program_map = program_map or ProgramMap({0: preset})
        self.preset_name = preset
        self.stats = stats
        self.out = out if out is not None else sys.stdout
        self.clock = time.monotonic
        self.midi_backend = None
        self.midi_port_name = None
        self.midi_api = midi_api
        self.midi_port_lost = 0        # times the MIDI input port disappeared
        self._lister = None            # the rtmidi client that lists the ports (_port_names)
        self.latency_s = latency_s
        self._check_latency(self._rate or FS_OUT)        # before any device is looked for
        self._check_outside(audio_device, midi_port, midi)
        self._check_latency(self.fs)
        # -- state
        self.rt = None
        self.stream = None
        self.port = None
        self.instruments: dict = {}
        self.ready_s = None            # start(): call to stream running (s)
        self.warm_s = None             # start(): engine built and warmed (s)
        self.n_messages = 0
        self.n_notes = 0
        self.n_program_changes = 0
        self.handler_errors = 0
        self.peak = 0.0                # largest |sample| written to the device
        self.clipped_blocks = 0
        self.max_voices = 0
        self.device_ahead_s = 0.0      # PortAudio: DAC time - callback time, largest seen
        self._lock = threading.Lock()
        self._gen = 0
        self._target = preset
        self._builders: list[threading.Thread] = []
        self._switch = None

    def _check_latency(self, fs: int) -> None:
        lat = self.latency_s
        if lat is not None and not (self.block / fs <= lat <= 1.0):
            raise SynthError(f"--latency-ms = {lat * 1e3:g} is out of range "
                             f"({1e3 * self.block / fs:.2f} <= value <= 1000: at least one block of "
                             f"{self.block} samples at {fs} Hz)")

    def _check_outside(self, audio_device, midi_port, midi: bool) -> None:
        """What the outside world offers, checked before any slow work:
        PortAudio's output device and rtmidi's input port (the JACK player,
        :class:`synth.io.live.jack.JackPlayer`, checks its server instead)."""
        self.sd = check_audio()
        self.device, self.device_name, self.channels, self.fs = pick_audio_device(
            self.sd, audio_device, self._rate)
        if midi:
            check_midi()                            # python-rtmidi installed, else how to
            self.midi_api = pick_midi_api(self.midi_api)
            self.midi_backend = check_midi(self.midi_api)
            self.midi_port_name = pick_midi_port(self.midi_backend, midi_port)

    # -- start and stop -------------------------------------------------------------
    def _overrides_for(self, name: str) -> tuple:
        return self.overrides if name == self._first else ()

    def start(self) -> None:
        """Build and warm the engine, open the audio stream, then the MIDI
        input; prints the latency budget and ``ready in X s``."""
        from synth.engine.realtime import Realtime

        t_call = time.perf_counter()
        try:
            eng = ready_engine(self.preset_name, self.block, self.instruments,
                               self._overrides_for(self.preset_name), fs_out=self.fs)
            self.warm_s = time.perf_counter() - t_call
            eng.telemetry = self.stats      # --stats: the latest note's contacts on the meter
            eng.set_mpe_zones(self.mpe)
            self.rt = Realtime(eng, block=self.block, latency_s=self.latency_s)
            # the audio thread must get the GIL quickly even while a program
            # change is built in the background (default switch interval: 5 ms;
            # tools/bench.py live --program-change measures the difference)
            self._switch = sys.getswitchinterval()
            sys.setswitchinterval(min(self._switch, SWITCH_INTERVAL_S))
            try:
                with _quiet_c_stderr():
                    self.stream = self.sd.OutputStream(
                        samplerate=self.fs, blocksize=self.block, channels=self.channels,
                        dtype="float32", callback=self._callback, device=self.device,
                        latency="low")
            except Exception as e:
                raise SynthError(f"cannot open audio device {self.device_name!r}: "
                                 f"{_one_line(e)}") from None
            self._start_recording(self.channels)
            # the cyclic collector off while playing (Realtime.start), and the
            # stream's sample 0 stamped now
            self.rt.start()
            self._start_rehearsal()
            self.stream.start()
            if self.midi_port_name is not None:
                try:
                    self._open_port()
                except Exception as e:
                    raise SynthError(f"cannot open MIDI input port {self.midi_port_name!r}: "
                                     f"{_one_line(e)}") from None
        except BaseException:
            self.close()
            raise
        self._ready(t_call)

    def _start_rehearsal(self) -> None:
        """Start the silent notes on an understudy engine
        (:class:`synth.io.live.rehearsal.Rehearsal`, ``--warm-every-ms``)."""
        if self.warm_every_ms > 0.0:
            try:
                reh = Rehearsal(self.preset_name, self.instruments[self.preset_name],
                                self.fs, self.block, self.warm_every_ms / 1e3)
            except Exception as e:          # the play goes on without it
                self._say(f"no rehearsal (--warm-every-ms): {_one_line(e)}")
                return
            self.rehearsal = reh
            reh.start()

    def _open_port(self) -> None:
        with _quiet_c_stderr():
            self.port = self.midi_backend.open_input(self.midi_port_name, callback=self.handle)

    def _port_names(self) -> list:
        """The MIDI input ports present now, from one rtmidi client kept
        open for it (:func:`synth.io.live.devices.port_lister`)."""
        try:
            if self._lister is None:
                self._lister = port_lister(self.midi_api)
            return self._lister.get_ports()
        except Exception:
            return []

    def _watch_port(self) -> None:
        """Called about once a second while playing: a MIDI input port that
        has disappeared (a keyboard unplugged, a JACK client gone) is
        reported once and play goes on; when it is back it is reopened."""
        if self.midi_port_name is None or self.midi_backend is None:
            return
        present = self.midi_port_name in self._port_names()
        if self.port is not None and not present:
            self.midi_port_lost += 1
            port, self.port = self.port, None
            with contextlib.suppress(Exception):
                port.close()
            self._say(f"\nwarning: MIDI input {self.midi_port_name!r} is gone; play goes on "
                      "(it is reopened when it comes back)")
        elif self.port is None and present:
            try:
                self._open_port()
            except Exception as e:
                self._say(f"\nMIDI input {self.midi_port_name!r} is back but cannot be opened: "
                          f"{_one_line(e)}")
                return
            self._say(f"\nMIDI input {self.midi_port_name!r} is back")

    def _start_recording(self, channels: int) -> None:
        if self.record_path is not None:
            from synth.io.live.record import Recorder

            self.recorder = Recorder(self.record_path, channels, self.fs)

    def _ready(self, t_call: float) -> None:
        """Say what plays where, with the latency, and ``ready in X s``."""
        self.ready_s = time.perf_counter() - t_call
        self._say(self.describe())
        self._say(f"ready in {self.ready_s:.2f} s (engine built and warmed in {self.warm_s:.2f} s)"
                  "; Ctrl-C stops")

    def latency_budget_s(self) -> dict:
        """The parts of the key-to-sound delay (s) that are known: the
        scheduling latency, the device's output latency (PortAudio's figure),
        the decimator's delay, and their sum."""
        sched = self.rt.latency_s
        dev = float(self.stream.latency) if self.stream is not None else 0.0
        dec = float(self.rt.engine.dec.latency_s)
        return {"schedule_s": sched, "device_s": dev, "decimator_s": dec,
                "total_s": sched + dev + dec}

    def describe(self) -> str:
        lat = self.latency_budget_s()
        midi = (f"MIDI in {self.midi_port_name!r} ({self.midi_api})" if self.midi_port_name
                else "no MIDI input")
        progs = f"; programs {self.program_map}" if len(self.program_map.programs) > 1 else ""
        return (f"{self.preset_name}: {midi} -> audio out {self.device_name!r} "
                f"({self.channels} ch, {self.fs} Hz, block {self.block} = "
                f"{1e3 * self.block / self.fs:.1f} ms){progs}; latency {lat['total_s'] * 1e3:.1f} ms "
                f"= schedule {lat['schedule_s'] * 1e3:.1f} + device {lat['device_s'] * 1e3:.1f} "
                f"+ decimator {lat['decimator_s'] * 1e3:.1f}")

    def close(self) -> None:
        """Close the MIDI port and the stream (idempotent)."""
        lister, self._lister = self._lister, None
        if lister is not None:
            with contextlib.suppress(Exception):
                lister.delete()
        port, self.port = self.port, None
        if port is not None:
            with contextlib.suppress(Exception):
                port.close()
        stream, self.stream = self.stream, None
        if stream is not None:
            with contextlib.suppress(Exception):
                stream.stop()
            with contextlib.suppress(Exception):
                stream.close()
        self._stop_threads()

    def _stop_threads(self) -> None:
        """Drop a program change still being built, restore the switch
        interval and the garbage collector, and finish the recording (once
        the audio has stopped)."""
        reh = self.rehearsal
        if reh is not None:
            reh.stop()
            reh.join(timeout=10.0)
        rec, self.recorder = self.recorder, None
        if rec is not None:
            self.record_line = rec.close()
        with self._lock:
            self._gen += 1                  # a program change still building is dropped
        for th in self._builders:
            th.join(timeout=10.0)
        self._builders = []
        if self._switch is not None:
            sys.setswitchinterval(self._switch)
            self._switch = None
        if self.rt is not None:
            self.rt.stop()

    def run(self, seconds: float | None = None, interval_s: float = 1.0) -> str:
        """Play until Ctrl-C or SIGTERM (or for ``seconds``), then close
        (the recording complete) and print the report, which is returned.
        With ``stats`` the meter is printed once per ``interval_s`` on one
        line.  (A signal ignored when the process started, as for a job
        started in the background with ``&`` or ``nohup``, stays ignored.)"""
        from synth.io.interrupt import interruptible

        if self.stream is None:
            raise RuntimeError("Player.run() before start()")
        t_end = None if seconds is None else time.monotonic() + seconds
        stopped = None
        by = None
        try:
            with interruptible():
                while True:
                    wait = interval_s if t_end is None else min(interval_s, t_end - time.monotonic())
                    if wait > 0:
                        time.sleep(wait)
                    gc.collect(0)          # the young generation only, from this thread
                    self._watch_port()
                    if self.stats:
                        print("\r" + self.rt.meter(), end="", file=self.out, flush=True)
                    stopped = self._stopped()
                    if stopped:
                        break
                    if t_end is not None and time.monotonic() >= t_end:
                        break
        except KeyboardInterrupt as e:
            by = getattr(e, "signal_name", None)
        finally:
            self.close()
        if self.stats:
            print(file=self.out)
        self.stopped = stopped
        rep = self.report()
        if stopped:
            rep += f"\n{stopped}"
        if by == "SIGTERM":
            rep += "\nstopped by SIGTERM"
        self._say(rep)
        return rep

    def _stopped(self) -> str | None:
        """Why the audio stopped by itself, or None while it plays."""
        return None if self.stream.active else "the audio stream stopped (device gone?)"

    def report(self) -> str:
        """:meth:`Realtime.report` and what the player saw."""
        peak = f"{20 * math.log10(self.peak):.1f} dBFS" if self.peak > 0 else "silence"
        clip = f" ({self.clipped_blocks} blocks clipped)" if self.clipped_blocks else ""
        ready = f"ready in {self.ready_s:.2f} s; " if self.ready_s is not None else ""
        ahead = (f"; the device played blocks up to {self.device_ahead_s * 1e3:.1f} ms after "
                 "their callback (PortAudio's timestamps)" if self.device_ahead_s > 0 else "")
        ignored = dict(self.ignored)
        stolen = 0
        for e in self.rt.engines_seen:
            stolen += e.n_stolen
            for what, n in e.ignored.items():
                ignored[what] = ignored.get(what, 0) + n
        rest = "".join(f"\nignored {n} x {what}"
                       for what, n in sorted(ignored.items(), key=lambda kv: (-kv[1], kv[0])))
        if self.record_line:
            rest += f"\n{self.record_line}"
        reh = self.rehearsal
        if reh is not None:
            rest += (f"\nkept warm by {reh.notes} silent notes on an understudy, one every "
                     f"{self.warm_every_ms:g} ms ({reh.cpu_s:.2f} s of CPU time)")
            if reh.error is not None:
                rest += f" (stopped early: {reh.error})"
        return (f"{self.rt.report()}\n{ready}{self.n_messages} MIDI messages, {self.n_notes} notes, "
                f"{self.n_program_changes} program changes, at most {self.max_voices} voices, "
                f"{stolen} voices stolen, peak {peak}{clip}, {self.handler_errors} message "
                f"errors{ahead}{rest}")

    def _say(self, text: str) -> None:
        print(text, file=self.out, flush=True)

    # -- the audio thread -----------------------------------------------------------
    def _after_block(self, block) -> None:
        """After each block sent to the device: the recording, the peak and
        voice meters (scalar reductions, no allocation)."""
        if self.recorder is not None:
            self.recorder.push(block)
        hi = float(block.max())
        lo = -float(block.min())
        p = hi if hi > lo else lo
        if p > self.peak:
            self.peak = p
        if p > 1.0:
            self.clipped_blocks += 1
        n = self.rt.engine.n_voices
        if n > self.max_voices:
            self.max_voices = n
        if self.rehearsal is not None:
            self.rehearsal.tick()

    def _callback(self, outdata, frames, time_info, status) -> None:
        """The stream's callback: the real-time driver, then the peak and
        voice meters (scalar reductions, no allocation)."""
        self.rt.callback(outdata, frames, time_info, status)
        self._after_block(outdata)
        try:
            ahead = time_info.outputBufferDacTime - time_info.currentTime
            if 0.0 < ahead < 1.0 and ahead > self.device_ahead_s:
                self.device_ahead_s = ahead
        except AttributeError:
            pass

    # -- the MIDI thread --------------------------------------------------------------
    def handle(self, msg, arrival_s: float | None = None, at_s: float | None = None) -> None:
        """A MIDI message arrived (the input port's callback): stamp it now
        (or at ``arrival_s``, ``time.monotonic`` seconds) and queue it, or,
        with ``at_s``, queue it for that stream time exactly (a JACK
        message's frame); a program change swaps the instrument.  Never
        raises."""
        t = (self.clock() if arrival_s is None else float(arrival_s)) if at_s is None else 0.0
        try:
            self.n_messages += 1
            if msg.type == "program_change":
                # a channel that does not play switches nothing (--channels,
                # General MIDI's drum channel)
                if not plays_channel(msg.channel, self.midi_channels, self.drums):
                    self.ignored["program change on a channel that does not play"] = (
                        self.ignored.get("program change on a channel that does not play", 0) + 1)
                    return
                self.program_change(msg.program)
                return
            ev = normalise(msg, self.midi_channels, self.drums, self.ignored)
            if ev is None or self.rt is None:
                return
            if ev.kind == "note_on":
                self.n_notes += 1
            if at_s is None:
                self.rt.push(ev, t)
            else:
                self.rt.push_at(ev, at_s)
        except Exception:
            self.handler_errors += 1

    def program_change(self, program: int) -> None:
        """Swap to the preset of ``program``: its engine is built and warmed
        in a background thread, then handed to :meth:`Realtime.swap`.  An
        unmapped program is reported and ignored; the latest request wins."""
        name = self.program_map.preset_for(program)
        if name is None:
            self._say(f"\nprogram {program} is not in the program map ({self.program_map}); "
                      f"keeping {self._target}")
            return
        with self._lock:
            if name == self._target:
                return
            self._target = name
            self._gen += 1
            gen = self._gen
        th = threading.Thread(target=self._build_and_swap, args=(program, name, gen),
                              name=f"synth-program-{program}", daemon=True)
        self._builders = [b for b in self._builders if b.is_alive()] + [th]
        th.start()

    def _build_and_swap(self, program: int, name: str, gen: int) -> None:
        try:
            t = time.perf_counter()
            eng = ready_engine(name, self.block, self.instruments, self._overrides_for(name),
                               fs_out=self.fs)
        except Exception as e:
            self.handler_errors += 1
            self._say(f"\nprogram {program}: {name} failed: {_one_line(e)}")
            return
        eng.telemetry = self.stats
        understudy = None
        if self.rehearsal is not None:
            try:
                understudy = self.rehearsal.understudy(name, self.instruments[name])
            except Exception as e:
                self._say(f"\nprogram {program}: no rehearsal for {name}: {_one_line(e)}")
        with self._lock:
            if gen != self._gen or self.rt is None:
                return
            if understudy is not None:
                self.rehearsal.follow(understudy)
            self.rt.swap(eng)
            self.preset_name = name
            self.n_program_changes += 1
        self._say(f"\nprogram {program}: {name} (ready in {time.perf_counter() - t:.2f} s)")
