"""A JACK loopback for measuring live play: a client that plays MIDI into
``synth play --jack`` at chosen frames and records what comes back.

The measuring harness of ``tests/test_jack.py`` and ``tools/bench.py live
--jack``, and of anyone who wants the MIDI-to-sound latency of their own
set-up: start (or join) a JACK server, wait for the synth's ports, connect
a :class:`Loopback` to them, queue notes at frame times, then read the
recording.  The loop adds one period to every delay it measures (a MIDI
event written in cycle k is read by the synth in cycle k; its sound is
read back by the loopback in cycle k + 1).

Needs the ``JACK-Client`` package (the ``[live]`` extra) and, for
:func:`start_dummy_server`, ``jackd`` (Debian: ``apt-get install jackd2``).
"""

from __future__ import annotations

import subprocess
import time

from synth.engine.warm import resident_zeros
from synth.io.live.gate import ProcessGate

__all__ = ["start_dummy_server", "wait_ports", "connect", "Loopback"]


def _jack():
    import jack

    return jack


def start_dummy_server(name: str, rate: int = 48_000, period: int = 128,
                       tries: int = 100) -> subprocess.Popen:
    """``jackd -n NAME -d dummy -r RATE -p PERIOD``, returned once a client
    can open on it.

    Raises
    ------
    RuntimeError
        The server did not answer within ``tries`` x 0.1 s (it is killed).
    """
    jack = _jack()
    p = subprocess.Popen(["jackd", "-n", name, "-d", "dummy", "-r", str(int(rate)), "-p",
                          str(int(period))], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    for _ in range(tries):
        try:
            jack.Client("probe", no_start_server=True, servername=name).close()
            return p
        except jack.JackOpenError:
            time.sleep(0.1)
    p.kill()
    raise RuntimeError(f"jackd -n {name} -d dummy -r {rate} -p {period} did not start")


def wait_ports(client, prefix: str, n: int, proc=None, timeout: float = 120.0) -> list:
    """The ports of client ``prefix`` once it has at least ``n``.

    Raises
    ------
    RuntimeError
        ``proc`` (the synth's process, if given) exited first (its output
        in the message), or the ports did not appear within ``timeout`` s.
    """
    t_end = time.monotonic() + timeout
    while time.monotonic() < t_end:
        ports = client.get_ports(prefix + ":")
        if len(ports) >= n:
            return ports
        if proc is not None and proc.poll() is not None:
            raise RuntimeError(f"synth play --jack exited: {proc.communicate()}")
        time.sleep(0.1)
    raise RuntimeError(f"{prefix}'s ports did not appear within {timeout:g} s")


def connect(client, pairs, timeout: float = 30.0) -> None:
    """Connect each (source, destination), retrying while a client whose
    ports appear before it is active (the synth while it warms up) is not
    yet active."""
    jack = _jack()
    t_end = time.monotonic() + timeout
    for a, b in pairs:
        while True:
            try:
                client.connect(a, b)
                break
            except jack.JackError:
                if time.monotonic() > t_end:
                    raise
                time.sleep(0.1)


class Loopback:
    """A JACK client that writes MIDI events at given frame times and
    records its audio inputs, each cycle at its frame time; every xrun the
    server reports is stamped with the frame time and the current
    :attr:`phase`.

    Parameters
    ----------
    server : str
        The JACK server's name.
    n_in : int
        Audio inputs (``in_1`` ..), one per output of the synth.
    seconds : float
        Length of the recording (s); cycles past it are not recorded.
    rate : int
        The server's rate (Hz).
    name : str
        The client's name.

    Attributes
    ----------
    midi_out, ins
        Its ports.
    rec : ndarray, shape (n, n_in), float32
        The recording; sample 0 is frame time :attr:`t0`.
    t0 : int or None
        Frame time of the first recorded sample (None before the first cycle).
    events : list of (int, bytes)
        MIDI events (frame time, message bytes), kept sorted by :meth:`note`;
        an event whose frame has passed is written at the cycle's start.
    xruns : list of (str, int, float)
        (phase, frame time, delay in us) of each xrun.
    """

    def __init__(self, server: str, n_in: int, seconds: float, rate: int = 48_000,
                 name: str = "loopback"):
        jack = _jack()
        self.rate = int(rate)
        self.client = jack.Client(name, no_start_server=True, servername=server)
        self.midi_out = self.client.midi_outports.register("midi_out")
        self.ins = [self.client.inports.register(f"in_{i + 1}") for i in range(n_in)]
        # mapped now, not page by page in the process callback: a fresh page
        # there stalled the callback past its period (the server's "client =
        # bench was not finished" xruns, 2 a run of tools/bench.py live --jack)
        self.rec = resident_zeros((int(seconds * self.rate), n_in))
        self.t0 = None
        self.events: list = []
        self.i = 0
        self.phase = "activation"
        self.xruns: list = []
        self._gate = ProcessGate()
        self.client.set_process_callback(self._process)
        self.client.set_xrun_callback(self._xrun)

    def attach(self, synth: str, n_out: int | None = None, timeout: float = 30.0) -> "Loopback":
        """Activate, and connect to client ``synth``: our MIDI out to its
        ``midi_in``, its ``out_1`` .. to our inputs (retried for at most
        ``timeout`` seconds, :func:`connect`).  If that fails, the
        client is closed before the error goes on: a client left to the
        garbage collector closed itself after its server had stopped and
        crashed the process (libjack; a test worker in a CI run)."""
        n = len(self.ins) if n_out is None else n_out
        try:
            self.client.activate()
            connect(self.client, [(self.midi_out, f"{synth}:midi_in")]
                    + [(f"{synth}:out_{i + 1}", self.ins[i]) for i in range(n)], timeout)
        except BaseException:
            try:
                self.client.deactivate()
            except Exception:
                pass
            self.client.close()
            raise
        return self

    def note(self, key: int, at_s: float, hold_s: float = 0.2, velocity: int = 100,
             channel: int = 0) -> int:
        """Queue a note ``at_s`` seconds from now (its note-off ``hold_s``
        later); returns its frame time.  "Now" is the start of the current
        cycle (``last_frame_time``): JACK's ``frame_time`` is an estimate
        from the clock, which on the dummy backend can run ahead of the
        cycles, so that an event meant for a later frame arrives late and is
        written at the start of a cycle."""
        at = self.client.last_frame_time + int(at_s * self.rate)
        self.events += [(at, bytes([0x90 | channel, key, velocity])),
                        (at + int(hold_s * self.rate), bytes([0x80 | channel, key, 64]))]
        self.events.sort()
        return at

    def send(self, data: bytes, at_s: float) -> int:
        """Queue one MIDI message (its bytes) ``at_s`` seconds from the
        start of the current cycle; returns its frame time."""
        at = self.client.last_frame_time + int(at_s * self.rate)
        self.events.append((at, bytes(data)))
        self.events.sort()
        return at

    def _process(self, frames):
        gate = self._gate
        gate.inside = True
        try:
            if gate.closed:
                self.midi_out.clear_buffer()
                return
            self._cycle(frames)
        finally:
            gate.inside = False

    def _cycle(self, frames):
        ft = self.client.last_frame_time
        if self.t0 is None:
            self.t0 = ft
        self.midi_out.clear_buffer()
        ev = self.events
        while self.i < len(ev) and ev[self.i][0] < ft + frames:
            at, data = ev[self.i]
            self.midi_out.write_midi_event(max(at - ft, 0), data)
            self.i += 1
        j = ft - self.t0
        if j + frames <= len(self.rec):
            for c, port in enumerate(self.ins):
                self.rec[j:j + frames, c] = port.get_array()

    def _xrun(self, delay_us):
        try:
            ft = self.client.frame_time
        except Exception:
            ft = -1
        self.xruns.append((self.phase, ft, float(delay_us)))

    def count(self, phase: str) -> int:
        """Xruns stamped with ``phase``."""
        return sum(1 for p, _, _ in self.xruns if p == phase)

    def close(self) -> None:
        """Deactivate and close (idempotent, never raises); the callback is
        let out of Python first (:mod:`synth.io.live.gate`)."""
        self._gate.close()
        for step in (self.client.deactivate, self.client.close):
            try:
                step()
            except Exception:
                pass
