"""Live play as a JACK client (``synth play --jack``): frame-accurate MIDI in,
audio out, on any JACK server (``jackd``, or PipeWire's JACK).

The client (named ``synth``, ``--jack-name``) has one MIDI input port,
``midi_in``, and an audio output port per channel of the preset, ``out_1``
(and ``out_2`` for a stereo one).  JACK hands the process callback every
MIDI event of the cycle with its frame offset in the cycle; the event is
queued for exactly that frame (:meth:`synth.engine.realtime.Realtime.push_at`)
and the engine renders the cycle's block with it, so each note lands on its
sample: no clock, no jitter, no scheduling margin.  The delay from a MIDI
event to its sound is the server's output latency (its periods) plus the
decimator's (0.9 ms at 48 kHz) and, for a preset with a limiter, its
look-ahead (1.5 ms); :meth:`JackPlayer.latency_budget_s` says which.

The process callback renders through the same :class:`Realtime` driver as
the PortAudio player (voice shedding under overload, program changes built
in a background thread and swapped in), into preallocated buffers; it waits
on no lock.  JACK's xruns are counted in the report, beside the engine's
figures.  When the server goes away, :meth:`JackPlayer.run` says so in one
line and the command exits non-zero, or, with ``--reconnect``, waits for
it and plays on with the same engine, recording and connections.  The
client plays at the server's rate (the engine's decimator designed for it)
and period, which may change while it plays.  Measured on jackd's dummy
backend (``tools/bench.py live --jack``): a grand note sounds 113 samples
(2.35 ms) after its MIDI event's frame at 48 kHz, the same for every note.

Needs the ``JACK-Client`` package (``[live]`` extra) and the JACK library
(Debian: ``apt-get install jackd2``, or PipeWire's ``pipewire-jack``).
"""

from __future__ import annotations

import sys
import time

import numpy as np

from synth.io.errors import SynthError
from synth.io.live.devices import _one_line, _quiet_c_stderr
from synth.io.live.player import SWITCH_INTERVAL_S, Player
from synth.io.live.gate import ProcessGate
from synth.io.live.rehearsal import DEFAULT_EVERY_MS
from synth.io.rates import check_rate

__all__ = ["JackPlayer", "check_jack", "INSTALL_JACK"]

INSTALL_JACK = ('JACK support needs the JACK-Client package and the JACK library: pip install '
                'JACK-Client (Debian: apt-get install jackd2, or PipeWire\'s pipewire-jack)')


def check_jack():
    """The ``jack`` module (JACK-Client), or a :class:`SynthError` saying
    in one line how to get it."""
    try:
        import jack
    except ImportError:
        raise SynthError(INSTALL_JACK) from None
    except OSError as e:              # JACK-Client without libjack
        raise SynthError(f"{INSTALL_JACK} ({_one_line(e)})") from None
    return jack


class JackPlayer(Player):
    """Play a preset live as a JACK client.

    Parameters
    ----------
    preset, program_map, stats, out, overrides, channels, drums, record, mpe, warm_every_ms
        As :class:`synth.io.live.player.Player`.
    name : str
        The client's name (``--jack-name``; JACK may add a suffix when it is
        taken).
    connect : bool
        Connect the audio outputs to the server's physical playback ports
        and the first physical MIDI capture port to the MIDI input
        (``--connect``).
    server : str or None
        The JACK server's name (None: the default, or ``$JACK_DEFAULT_SERVER``).
    reconnect : bool
        When the server stops, wait for it to come back (polling twice a
        second) and play on, with the same engine, recording and port
        connections (``--reconnect``); without it :meth:`run` stops and the
        command exits non-zero.

    Faults survived: the server's period may change while playing (JACK's
    buffer-size callback; the driver renders any cycle up to 4096 frames);
    a MIDI source that disconnects from ``midi_in`` is reported once and
    play goes on; the server stopping is one line (and, with
    ``reconnect``, a wait).  The ``record`` file is complete after each.
    """

    def __init__(self, preset: str, program_map=None, *, name: str = "synth",
                 connect: bool = False, server: str | None = None, stats: bool = False,
                 out=None, overrides=(), channels=None, drums: bool = False,
                 record: str | None = None, reconnect: bool = False, mpe=(),
                 warm_every_ms: float = DEFAULT_EVERY_MS):
        self._jack_name = str(name)
        self._connect = bool(connect)
        self._server = server
        self._reconnect = bool(reconnect)
        self.client = None
        self.xruns = 0
        self.reconnects = 0             # times the server came back (--reconnect)
        self.period_changes = 0         # buffer-size callbacks after the first cycle
        self._links: set = set()        # (own port's short name, other port's name)
        self._said_gone: set = set()    # MIDI sources the server's notification reported gone
        self._notes: list = []          # messages from the server's threads, said by run()
        self._shutdown = None           # why the server closed us, from its thread
        self._gate = ProcessGate()      # the callback out of Python before deactivate
        super().__init__(preset, program_map, block=128, midi=False, stats=stats, out=out,
                         overrides=overrides, channels=channels, drums=drums, record=record,
                         mpe=mpe, warm_every_ms=warm_every_ms)

    def _check_outside(self, audio_device, midi_port, midi: bool) -> None:
        """The JACK library, and a server to join: the client is opened now
        (inactive until :meth:`start`), so that a missing server is one line
        before any slow work; its rate and period set the block."""
        self.jack = check_jack()
        try:
            self._open_client()
        except self.jack.JackOpenError:
            where = f" {self._server!r}" if self._server else ""
            raise SynthError(f"no JACK server{where} is running: start one (jackd -d alsa, or "
                             "jackd -d dummy -r 48000 -p 128 without a sound card; PipeWire "
                             "runs one as pipewire-jack)") from None
        try:
            self.fs = check_rate(self.client.samplerate, "the JACK server's rate")
        except SynthError:
            self.client.close()
            self.client = None
            raise
        self.block = int(self.client.blocksize)

    def _open_client(self) -> None:
        """Open the (inactive) client; raises ``jack.JackOpenError`` when no
        server answers."""
        with _quiet_c_stderr():
            self.client = self.jack.Client(self._jack_name, no_start_server=True,
                                           servername=self._server)
        self.device_name = f"JACK {self.client.name}"
        self.midi_port_name = f"{self.client.name}:midi_in"

    # -- start and stop -------------------------------------------------------------
    def start(self) -> None:
        """Build and warm the engine for the server's period, register the
        ports, activate the client (and connect it with ``connect``)."""
        from synth.engine.realtime import Realtime
        from synth.io.live.engines import ready_engine

        t_call = time.perf_counter()
        try:
            eng = ready_engine(self.preset_name, self.block, self.instruments,
                               self._overrides_for(self.preset_name), fs_out=self.fs)
            self.warm_s = time.perf_counter() - t_call
            eng.telemetry = self.stats
            eng.set_mpe_zones(self.mpe)
            self.channels = eng.channels
            self.rt = Realtime(eng, block=self.block, latency_s=self.block / self.fs)
            # the process callback must get the GIL at once even while a
            # program change is built in the background (as the PortAudio
            # player: the default switch interval, 5 ms, is two periods at 128)
            self._switch = sys.getswitchinterval()
            sys.setswitchinterval(min(self._switch, SWITCH_INTERVAL_S))
            self._buf = np.zeros((4096, self.channels), dtype=np.float32)
            self._start_recording(self.channels)
            self.rt.start()
            self._start_rehearsal()
            self._attach()
        except BaseException:
            self.close()
            raise
        self._ready(t_call)

    def _attach(self) -> None:
        """Register the ports and callbacks on the open client, activate
        it, and connect it (``connect``: to the physical ports; after a
        reconnect: as it was)."""
        client = self.client
        self.midi_in = client.midi_inports.register("midi_in")
        self.outs = [client.outports.register(f"out_{i + 1}") for i in range(self.channels)]
        client.set_process_callback(self._process)
        client.set_xrun_callback(self._xrun)
        client.set_shutdown_callback(self._closed)
        self._gate.open()
        client.set_blocksize_callback(self._blocksize)
        client.set_port_connect_callback(self._connected)
        self._started = False
        client.activate()
        self.stream = client
        if self._links:
            self._restore_links()
        elif self._connect:
            self._connect_ports()

    def _own_ports(self) -> dict:
        return {p.shortname: p for p in [self.midi_in, *self.outs]}

    def _note_links(self) -> None:
        """Remember the connections of our ports (restored after a reconnect),
        and say a MIDI source gone since the last look that the server's
        notification did not report (a source's client closing on a stalled
        machine: its port may be gone before the notification reads its
        name)."""
        links = set()
        try:
            for short, port in self._own_ports().items():
                for other in self.client.get_all_connections(port):
                    links.add((short, other.name))
            midi = self.midi_in.shortname
        except Exception:
            return
        for short, other in sorted(self._links - links):
            if short != midi:
                continue
            if other in self._said_gone:
                self._said_gone.discard(other)      # the notification said it
            else:
                self._notes.append(self._gone_text(other))
        # (a source the notification said gone that this look never saw
        # linked, or saw gone already, is done with: a later unreported
        # leaving of the same name must still be said)
        self._said_gone &= {other for short, other in links if short == midi}
        self._links = links

    def _restore_links(self) -> None:
        own = self._own_ports()
        for short, other in sorted(self._links):
            port = own.get(short)
            try:
                if port is self.midi_in:
                    self.client.connect(other, port)
                else:
                    self.client.connect(port, other)
            except Exception:
                self._notes.append(f"could not reconnect {port.name} and {other} (gone?)")

    def _connect_ports(self) -> None:
        client = self.client
        play = client.get_ports(is_audio=True, is_input=True, is_physical=True)
        for i, port in enumerate(self.outs):
            if play:
                client.connect(port, play[min(i, len(play) - 1)])
        cap = client.get_ports(is_midi=True, is_output=True, is_physical=True)
        if cap:
            client.connect(cap[0], self.midi_in)

    def close(self) -> None:
        """Silence the callback, stop our threads (the recording complete),
        then deactivate and close the client (idempotent).  In that order:
        JACK2 cancels the process thread on deactivate, and one cancelled
        in Python hangs the process (:mod:`synth.io.live.gate`)."""
        self._gate.close()
        self._stop_threads()
        client, self.client = self.client, None
        self.stream = None
        if client is not None:
            for step in (client.deactivate, client.close):
                try:
                    step()
                except Exception:
                    pass

    def _watch_port(self) -> None:
        """About once a second: say what the server's threads noted (a MIDI
        source gone, the period changed), and remember the connections."""
        if self.client is not None and self._shutdown is None:
            self._note_links()
        notes, self._notes = self._notes, []
        for text in notes:
            self._say(f"\n{text}")

    def _stopped(self) -> str | None:
        if self._shutdown is None:
            return None
        gone = f"the JACK server closed the client ({self._shutdown})"
        if not self._reconnect:
            return gone
        self._say(f"\n{gone}; waiting for it to come back (--reconnect; Ctrl-C stops)")
        # (the callback out of Python, and the rehearsal, which holds the
        # interpreter's lock for long, stopped before deactivate: gate.py)
        self._gate.close()
        reh, self.rehearsal = self.rehearsal, None
        if reh is not None:
            reh.stop()
            reh.join(timeout=10.0)
        old, self.client, self.stream = self.client, None, None
        for step in (old.deactivate, old.close):
            try:
                step()
            except Exception:
                pass
        while True:
            try:
                self._open_client()
                break
            except self.jack.JackOpenError:
                time.sleep(0.5)
        if self.client.samplerate != self.fs or self.client.blocksize > self._buf.shape[0]:
            return (f"the JACK server came back at {self.client.samplerate} Hz, period "
                    f"{self.client.blocksize}; this engine plays at {self.fs} Hz, periods up to "
                    f"{self._buf.shape[0]}: start synth play again")
        self._shutdown = None
        self.block = int(self.client.blocksize)
        if reh is not None:
            self._start_rehearsal()
        self._attach()
        self.reconnects += 1
        self._say(f"the JACK server is back: playing again ({self.fs} Hz, period {self.block}, "
                  f"{len(self._links)} connections restored)")
        return None

    def _playback_latency_frames(self) -> int:
        """The largest playback latency (frames) the server reports for the
        ports our outputs feed (its physical outputs: the periods it
        buffers), 0 when they feed none.  JACK-Client does not wrap
        ``jack_port_get_latency_range``: it is called through ctypes."""
        import ctypes
        import ctypes.util

        class _Range(ctypes.Structure):
            _fields_ = [("min", ctypes.c_uint32), ("max", ctypes.c_uint32)]

        try:
            lib = ctypes.CDLL(ctypes.util.find_library("jack") or "libjack.so.0")
            f = lib.jack_port_get_latency_range
            f.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.POINTER(_Range)]
            worst = 0
            for own in self.outs:
                for port in self.client.get_all_connections(own):
                    r = _Range()
                    f(int(self.jack._ffi.cast("uintptr_t", port._ptr)), 1, ctypes.byref(r))
                    worst = max(worst, int(r.max))        # 1: JackPlaybackLatency
            return worst
        except Exception:
            return 0

    def latency_budget_s(self) -> dict:
        """The delay from a MIDI event to its sound (s): the server's
        playback latency (of the ports the outputs feed), the decimator's,
        the limiter's look-ahead; no scheduling margin (events act at their
        frame)."""
        dev = 0.0
        if self.client is not None and getattr(self, "outs", None):
            dev = self._playback_latency_frames() / self.fs
        eng = self.rt.engine
        dec = float(eng.dec.latency_s)
        lim = (eng.limiter.latency_samples / self.fs) if eng.limiter is not None else 0.0
        return {"schedule_s": 0.0, "device_s": dev, "decimator_s": dec + lim,
                "total_s": dev + dec + lim}

    def describe(self) -> str:
        lat = self.latency_budget_s()
        ports = ", ".join(p.name for p in self.outs)
        return (f"{self.preset_name}: JACK client {self.client.name!r} ({self.midi_in.name} -> "
                f"{ports}; {self.fs} Hz, period {self.block} = {1e3 * self.block / self.fs:.1f} ms); "
                f"latency {lat['total_s'] * 1e3:.1f} ms = server {lat['device_s'] * 1e3:.1f} + "
                f"decimator and limiter {lat['decimator_s'] * 1e3:.1f}")

    def report(self) -> str:
        extra = ""
        if self.reconnects:
            extra += f", the server came back {self.reconnects} times"
        if self.period_changes:
            extra += f", the period changed {self.period_changes} times"
        return super().report() + f"\n{self.xruns} JACK xruns{extra}"

    # -- the server's threads ---------------------------------------------------------
    def _process(self, frames: int) -> None:
        """The process callback: this cycle's MIDI at its frames, then the
        cycle's audio (silence once the gate is closed)."""
        gate = self._gate
        gate.inside = True
        try:
            if gate.closed:
                for port in self.outs:
                    port.get_array()[:] = 0.0
                return
            self._cycle(frames)
        finally:
            gate.inside = False

    def _cycle(self, frames: int) -> None:
        self._started = True
        rt = self.rt
        fs = self.fs
        t0 = rt.n_out / fs
        mido = _mido()
        for offset, data in self.midi_in.incoming_midi_events():
            try:
                msg = mido.Message.from_bytes(bytes(data))
            except Exception:
                self.handler_errors += 1
                continue
            self.handle(msg, at_s=t0 + offset / fs)
        buf = self._buf[:frames]
        rt.render(buf if self.channels > 1 else buf[:, 0], frames)
        for i, port in enumerate(self.outs):
            port.get_array()[:] = buf[:, i]
        self._after_block(buf)

    def _xrun(self, delay_usecs: float) -> None:
        self.xruns += 1

    def _closed(self, status, reason: str) -> None:
        self._shutdown = reason or "shutdown"

    def _blocksize(self, blocksize: int) -> None:
        """The server's period changed: the driver renders whatever the
        callback asks (up to 4096 frames), so play goes on."""
        if self._started:
            self.period_changes += 1
            self._notes.append(f"the JACK period is now {blocksize} frames "
                               f"({1e3 * blocksize / self.fs:.1f} ms); play goes on")
        self.block = int(blocksize)
        if blocksize > self._buf.shape[0]:
            self._notes.append(f"the JACK period {blocksize} is above the {self._buf.shape[0]} "
                               "frames this player renders: stopping")
            raise self.jack.CallbackExit

    def _connected(self, a, b, connect: bool) -> None:
        """A connection made or broken (the server's notification thread):
        a MIDI source leaving ``midi_in`` is reported, play goes on."""
        try:
            if not connect and b.name == self.midi_in.name:
                self._said_gone.add(a.name)
                self._notes.append(self._gone_text(a.name))
        except Exception:
            pass

    def _gone_text(self, source: str) -> str:
        return f"warning: MIDI source {source!r} disconnected from {self.midi_in.name}; play goes on"


_MIDO = None


def _mido():
    global _MIDO
    if _MIDO is None:
        import mido

        _MIDO = mido
    return _MIDO

