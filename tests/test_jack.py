"""Live play through a real JACK server: ``synth play --jack`` in a
subprocess, played and heard by a JACK client of the test's own.

The server is JACK's dummy backend (no sound card), started here under a
name of its own (``jackd -n ... -d dummy -r 48000 -p 128``) unless
``$SYNTH_TEST_JACK_SERVER`` names a running one.  Skipped, with the reason,
where ``jackd`` or the JACK-Client package is missing (``.ci/run`` installs
both)."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

FS = 48_000


def _jack_module():
    try:
        import jack
    except (ImportError, OSError) as e:
        return None, f"JACK-Client is not usable ({e})"
    return jack, None


jack, JACK_REASON = _jack_module()


def _start_jackd(name):
    """``jackd -n NAME -d dummy`` at 48 kHz, period 128, once it answers."""
    p = subprocess.Popen(["jackd", "-n", name, "-d", "dummy", "-r", str(FS), "-p", "128"],
                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    for _ in range(100):
        try:
            jack.Client("probe", no_start_server=True, servername=name).close()
            return p
        except jack.JackOpenError:
            time.sleep(0.1)
    p.kill()
    pytest.skip("jackd -d dummy did not start")


@pytest.fixture(scope="module")
def server():
    """The name of a running JACK server (dummy backend, 48 kHz, period 128)."""
    if jack is None:
        pytest.skip(JACK_REASON)
    name = os.environ.get("SYNTH_TEST_JACK_SERVER")
    if name:
        yield name
        return
    if shutil.which("jackd") is None:
        pytest.skip("jackd is not installed (Debian: apt-get install jackd2)")
    name = f"synth-test-{os.getpid()}"
    p = _start_jackd(name)
    try:
        yield name
    finally:
        p.terminate()
        try:
            p.wait(timeout=10)
        except subprocess.TimeoutExpired:
            p.kill()


def _synth_play(server, *args, seconds=40.0):
    env = dict(os.environ, JACK_DEFAULT_SERVER=server)
    return subprocess.Popen([sys.executable, "-m", "synth.cli", "play", "--jack", *args,
                             "--seconds", str(seconds)], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def _wait_ports(client, prefix, n, proc, timeout=120.0):
    t_end = time.monotonic() + timeout
    while time.monotonic() < t_end:
        ports = client.get_ports(prefix + ":")
        if len(ports) >= n:
            return ports
        if proc.poll() is not None:
            raise AssertionError(f"synth play --jack exited: {proc.communicate()}")
        time.sleep(0.1)
    raise AssertionError(f"{prefix}'s ports did not appear")


def _connect(client, pairs, timeout=30.0):
    """Connect each (source, destination), retrying while synth's client,
    whose ports appear before it is active, is not yet active."""
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


class _JackProbe:
    """A JACK client that plays MIDI events at given frames and records
    what comes back, with each cycle's frame time."""

    def __init__(self, server, n_in, seconds):
        self.client = jack.Client("tester", no_start_server=True, servername=server)
        self.midi_out = self.client.midi_outports.register("midi_out")
        self.ins = [self.client.inports.register(f"in_{i + 1}") for i in range(n_in)]
        self.rec = np.zeros((int(seconds * FS), n_in), dtype=np.float32)
        self.t0 = None              # frame time of the recording's first sample
        self.events = []            # (frame time, bytes), sorted
        self.i = 0
        self.client.set_process_callback(self._process)

    def _process(self, frames):
        ft = self.client.last_frame_time
        if self.t0 is None:
            self.t0 = ft
        self.midi_out.clear_buffer()
        while self.i < len(self.events) and self.events[self.i][0] < ft + frames:
            at, data = self.events[self.i]
            self.midi_out.write_midi_event(max(at - ft, 0), data)
            self.i += 1
        j = ft - self.t0
        if j + frames <= len(self.rec):
            for c, port in enumerate(self.ins):
                self.rec[j:j + frames, c] = port.get_array()

    def close(self):
        self.client.deactivate()
        self.client.close()


def test_notes_through_jack_sound_as_offline_at_a_constant_latency(server, tmp_path):
    """24 notes sent through JACK MIDI at chosen frames to ``synth play
    --jack --preset grand-piano``, its audio captured through JACK: each
    note correlates with the same note rendered offline (at least 0.9 once
    aligned), the latency is the same to the sample for all of them; the
    report names the client's ports and counts the xruns."""
    from synth.engine.engine import Event
    from synth.io.factory import build_engine

    proc = _synth_play(server, "--preset", "grand-piano", "--jack-name", "synthtest",
                       "--record", str(tmp_path / "live.wav"))
    tester = None
    try:
        probe = jack.Client("waiter", no_start_server=True, servername=server)
        ports = _wait_ports(probe, "synthtest", 3, proc)
        probe.close()
        keys = [48 + (5 * i) % 36 for i in range(24)]
        spacing, hold = int(0.4 * FS), int(0.2 * FS)
        tester = _JackProbe(server, 2, 24 * 0.4 + 1.5)
        tester.client.activate()
        _connect(tester.client, [(tester.midi_out, "synthtest:midi_in"),
                                 ("synthtest:out_1", tester.ins[0]),
                                 ("synthtest:out_2", tester.ins[1])])
        time.sleep(0.2)
        start = tester.client.frame_time + FS // 2
        onsets = []
        for i, k in enumerate(keys):
            at = start + i * spacing + (37 * i) % 128        # every offset in the period
            onsets.append(at)
            tester.events += [(at, bytes([0x90, k, 100])), (at + hold, bytes([0x80, k, 64]))]
        time.sleep(24 * 0.4 + 1.0)
        tester.client.deactivate()
        rec, t0 = tester.rec, tester.t0
    finally:
        if tester is not None:
            tester.client.close()
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    assert "JACK client 'synthtest'" in out and "synthtest:out_2" in out
    assert "24 notes" in out and " 0 late events, 0 errors" in out, out
    # each note against the same note offline (the live engine's output, latency included)
    lags, corr = [], []
    n = int(0.1 * FS)
    for at, k in zip(onsets, keys):
        ref = build_engine("grand-piano", ()).render([Event(0.0, "note_on", k, 100 / 127)],
                                                     duration_s=0.2).mean(axis=1)
        seg = rec[at - t0:at - t0 + int(0.2 * FS)].mean(axis=1)
        best = max(range(0, 1024), key=lambda L: float(np.dot(seg[L:L + n], ref[:n])))
        a, b = seg[best:best + n], ref[:n]
        lags.append(best)
        corr.append(float(np.dot(a, b) / np.sqrt(np.dot(a, a) * np.dot(b, b))))
    # (an xrun of the dummy server can spoil the capture of a note: issue
    # 36's "no xrun" is not yet met, so two of the 24 may miss)
    good = [lag for lag, c in zip(lags, corr) if c >= 0.9]
    assert len(good) >= 22 and np.median(corr) >= 0.99, corr
    assert max(good) - min(good) == 0, lags
    # the loop through the tester adds one period; the rest is the engine's
    # own delay (the decimator and the grand's limiter, which an offline
    # render removes)
    assert good[0] == 128 + build_engine("grand-piano", ()).latency_samples, lags
    # --record holds what the client sent: the captured audio, one period earlier
    import soundfile

    y, fs = soundfile.read(str(tmp_path / "live.wav"), dtype="float32")
    assert fs == FS and y.shape[1] == 2 and "recorded " in out
    peak = np.max(np.abs(rec))
    assert np.max(np.abs(y)) == pytest.approx(peak, rel=1e-6)
    # the report counts the server's xruns (any client's: this test's own
    # activation may make some; issue 36's "no xrun" is not yet met)
    import re

    assert re.search(r"\n\d+ JACK xruns\n", out), out


def test_no_server_is_one_line(server):
    env = dict(os.environ, JACK_DEFAULT_SERVER="synth-no-such-server", JACK_NO_START_SERVER="1")
    p = subprocess.run([sys.executable, "-m", "synth.cli", "play", "--jack", "--preset", "sitar",
                        "--seconds", "1"], env=env, capture_output=True, text=True, timeout=120)
    assert p.returncode != 0
    last = p.stderr.strip().splitlines()[-1]
    assert "no JACK server is running" in last and "Traceback" not in p.stderr, p.stderr


def test_the_server_going_away_is_one_line_and_non_zero(server, tmp_path):
    """The server stops while synth plays: one line, exit 1, and the
    recording of what it played (``--record``) is a complete WAV file."""
    import soundfile

    rec = tmp_path / "gone.wav"
    name = f"synth-test-gone-{os.getpid()}"
    srv = _start_jackd(name)
    try:
        proc = _synth_play(name, "--preset", "biwa", "--jack-name", "gone", "--record",
                           str(rec), seconds=60)
        probe = jack.Client("waiter", no_start_server=True, servername=name)
        _wait_ports(probe, "gone", 2, proc)
        probe.close()
        time.sleep(0.5)
    finally:
        srv.terminate()
        srv.wait(timeout=10)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 1, (out, err)
    assert "the JACK server closed the client" in out and "Traceback" not in err, (out, err)
    info = soundfile.info(str(rec))
    assert info.samplerate == FS and info.channels == 1 and info.frames >= int(0.3 * FS)
    assert f"recorded {info.frames / FS:.1f} s to" in out


def test_connect_needs_jack_and_jack_needs_no_device_options():
    p = subprocess.run([sys.executable, "-m", "synth.cli", "play", "--preset", "sitar",
                        "--connect"], capture_output=True, text=True, timeout=120)
    assert p.returncode != 0 and "--connect needs --jack" in p.stderr
    for opt in (["--midi-port", "x"], ["--audio-device", "1"], ["--latency-ms", "5"]):
        p = subprocess.run([sys.executable, "-m", "synth.cli", "play", "--preset", "sitar",
                            "--jack", *opt], capture_output=True, text=True, timeout=120)
        assert p.returncode != 0 and f"{opt[0]} is not used with --jack" in p.stderr, p.stderr


# --------------------------------------------------------------------------
# Other rates, and faults survived (issue 36, items 3 and 4)
# --------------------------------------------------------------------------


class _Server:
    """A private dummy server (its own name, rate and period), stoppable
    and restartable under the same name."""

    def __init__(self, tag, rate=FS, period=128):
        self.name = f"synth-test-{tag}-{os.getpid()}"
        self.rate, self.period = rate, period
        self.proc = None

    def start(self):
        self.proc = subprocess.Popen(["jackd", "-n", self.name, "-d", "dummy", "-r",
                                      str(self.rate), "-p", str(self.period)],
                                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        for _ in range(100):
            try:
                jack.Client("probe", no_start_server=True, servername=self.name).close()
                return self
            except jack.JackOpenError:
                time.sleep(0.1)
        self.stop()
        pytest.skip("jackd -d dummy did not start")

    def stop(self):
        if self.proc is not None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
            self.proc = None


@pytest.fixture
def private_server():
    if jack is None:
        pytest.skip(JACK_REASON)
    if shutil.which("jackd") is None:
        pytest.skip("jackd is not installed (Debian: apt-get install jackd2)")
    made = []

    def make(tag, rate=FS, period=128):
        s = _Server(tag, rate, period).start()
        made.append(s)
        return s
    yield make
    for s in made:
        s.stop()


class _Tester(_JackProbe):
    """:class:`_JackProbe` at any rate, connected to a synth client, with
    a note played ``at`` seconds from now."""

    def __init__(self, server, synth_name, n_in, seconds, rate=FS, name="tester"):
        self.rate = rate
        self.client = jack.Client(name, no_start_server=True, servername=server)
        self.midi_out = self.client.midi_outports.register("midi_out")
        self.ins = [self.client.inports.register(f"in_{i + 1}") for i in range(n_in)]
        self.rec = np.zeros((int(seconds * rate), n_in), dtype=np.float32)
        self.t0 = None
        self.events = []
        self.i = 0
        self.client.set_process_callback(self._process)
        self.client.activate()
        _connect(self.client, [(self.midi_out, f"{synth_name}:midi_in")]
                 + [(f"{synth_name}:out_{i + 1}", self.ins[i]) for i in range(n_in)])

    def note(self, key, at_s, hold_s=0.2, velocity=100):
        """Queue a note ``at_s`` from now; its frame time."""
        at = self.client.frame_time + int(at_s * self.rate)
        self.events += [(at, bytes([0x90, key, velocity])),
                        (at + int(hold_s * self.rate), bytes([0x80, key, 64]))]
        self.events.sort()
        return at

    def heard(self, at, preset, key, rate, n_s=0.1, near=None):
        """Correlation of the capture at frame ``at`` with the same note
        rendered offline at ``rate`` once their onsets are aligned (or at
        the best lag within 3 samples of ``near``), and the lag."""
        from synth.engine.engine import Event
        from synth.io.factory import build_engine

        ref = build_engine(preset, (), fs_out=rate).render([Event(0.0, "note_on", key, 100 / 127)],
                                                           duration_s=0.2)
        ref = ref if ref.ndim == 1 else ref.mean(axis=1)
        seg = self.rec[at - self.t0:at - self.t0 + int(0.2 * rate)].mean(axis=1)
        n = int(n_s * rate)
        # the lag from the onsets (a plucked note is periodic: the best dot
        # product may be a period off)
        if near is None:
            thr = 1e-3 * np.max(np.abs(ref))
            loud = np.flatnonzero(np.abs(seg) > thr)
            best = int(loud[0]) - int(np.flatnonzero(np.abs(ref) > thr)[0]) if loud.size else 0
            if best < 0:
                return 0.0, best
        else:       # the best lag within 3 samples of ``near`` (a ringing note before)
            best = max(range(max(near - 3, 0), near + 4),
                       key=lambda L: float(np.dot(seg[L:L + n], ref[:n])))
        a, b = seg[best:best + n], ref[:n]
        den = np.sqrt(np.dot(a, a) * np.dot(b, b))
        return (float(np.dot(a, b) / den) if den > 0 else 0.0), best


class _Lines:
    """The lines a process prints, read by a thread of their own (a
    selector in this process, once closed, took a file descriptor number
    libjack still used: the next client saw no ports)."""

    def __init__(self, proc):
        import threading

        self.proc, self.lines = proc, []
        self.thread = threading.Thread(target=self._read, daemon=True)
        self.thread.start()

    def _read(self):
        for line in self.proc.stdout:
            self.lines.append(line)

    def wait_for(self, text, timeout=60.0):
        """Wait until a line contains ``text``."""
        t_end = time.monotonic() + timeout
        while time.monotonic() < t_end:
            if any(text in line for line in self.lines):
                return
            if not self.thread.is_alive():
                break
            time.sleep(0.05)
        raise AssertionError(f"{text!r} not said: {self.lines}")

    def rest(self, timeout=60):
        """Wait for the process; (stdout, stderr)."""
        err = self.proc.stderr.read()
        self.proc.wait(timeout=timeout)
        self.thread.join(timeout=10)
        return "".join(self.lines), err


@pytest.mark.parametrize("rate", [44_100, 96_000])
def test_other_rates_through_jack(private_server, rate, tmp_path):
    """A server at 44.1 or 96 kHz: synth plays at its rate, each note as
    the same note rendered offline at that rate (correlation >= 0.9, one
    latency for all), and the recording is at that rate."""
    import soundfile

    srv = private_server(f"rate{rate}", rate=rate)
    proc = _synth_play(srv.name, "--preset", "sitar", "--jack-name", "rated",
                       "--record", str(tmp_path / "r.wav"))
    tester = None
    try:
        probe = jack.Client("waiter", no_start_server=True, servername=srv.name)
        _wait_ports(probe, "rated", 2, proc)
        probe.close()
        tester = _Tester(srv.name, "rated", 1, 4.0, rate=rate)
        time.sleep(0.2)
        keys = [50, 57, 62, 69]
        ats = [tester.note(k, 0.3 + 0.6 * i) for i, k in enumerate(keys)]
        time.sleep(3.2)
        tester.client.deactivate()
        heard = [tester.heard(ats[0], "sitar", keys[0], rate)]
        heard += [tester.heard(at, "sitar", k, rate, near=heard[0][1])
                  for at, k in zip(ats[1:], keys[1:])]
    finally:
        if tester is not None:
            tester.client.close()
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    assert f"{rate} Hz, period 128" in out and "4 notes" in out, out
    assert all(c >= 0.9 for c, _ in heard), heard
    assert len({lag for _, lag in heard}) == 1, heard
    info = soundfile.info(str(tmp_path / "r.wav"))
    assert info.samplerate == rate and info.frames > rate


def test_period_change_and_a_midi_source_leaving(private_server, tmp_path):
    """While synth plays: the server's period goes from 128 to 256 frames
    (play goes on, said once), the MIDI source disconnects (a warning) and
    another one connects; every note is heard, before and after, and the
    recording is complete."""
    import soundfile

    srv = private_server("period")
    proc = _synth_play(srv.name, "--preset", "sitar", "--jack-name", "faulty",
                       "--record", str(tmp_path / "f.wav"), seconds=60)
    lines = _Lines(proc)
    t1 = t2 = None
    try:
        probe = jack.Client("waiter", no_start_server=True, servername=srv.name)
        _wait_ports(probe, "faulty", 2, proc)
        probe.close()
        lines.wait_for("ready in")
        t1 = _Tester(srv.name, "faulty", 1, 6.0, name="first")
        time.sleep(0.2)
        a = t1.note(57, 0.2)
        time.sleep(0.8)
        t1.client.blocksize = 256
        lines.wait_for("the JACK period is now 256")
        b = t1.note(62, 0.2)
        time.sleep(0.8)
        t1.client.deactivate()
        first = [t1.heard(a, "sitar", 57, FS)]
        first.append(t1.heard(b, "sitar", 62, FS, near=first[0][1] + 128))
        t1.client.close()
        t1 = None
        lines.wait_for("warning: MIDI source 'first:midi_out' disconnected")
        t2 = _Tester(srv.name, "faulty", 1, 3.0, name="second")
        time.sleep(0.3)
        c = t2.note(69, 0.2)
        time.sleep(0.8)
        t2.client.deactivate()
        second = t2.heard(c, "sitar", 69, FS, near=first[1][1])
    finally:
        for t in (t1, t2):
            if t is not None:
                t.client.close()
        proc.send_signal(signal.SIGINT)
        out, err = lines.rest()
    assert proc.returncode == 0, err
    assert all(cor >= 0.9 for cor, _ in first + [second]), (first, second)
    assert "3 notes" in out and "the period changed 1 times" in out, out
    y, fs = soundfile.read(str(tmp_path / "f.wav"))
    assert fs == FS and len(y) > 2 * FS and np.max(np.abs(y)) > 0.01


def test_reconnect_waits_for_the_server_and_plays_on(private_server, tmp_path):
    """--reconnect: the server stops, synth says it waits; the server
    comes back under the same name, synth plays again (a note sent then is
    heard as offline), and the recording spans both."""
    import soundfile

    srv = private_server("again")
    proc = _synth_play(srv.name, "--preset", "biwa", "--jack-name", "again", "--reconnect",
                       "--record", str(tmp_path / "a.wav"), seconds=90)
    lines = _Lines(proc)
    tester = None
    try:
        probe = jack.Client("waiter", no_start_server=True, servername=srv.name)
        _wait_ports(probe, "again", 2, proc)
        probe.close()
        lines.wait_for("ready in")
        time.sleep(0.5)
        srv.stop()
        lines.wait_for("waiting for it to come back")
        srv.start()
        lines.wait_for("the JACK server is back")
        tester = _Tester(srv.name, "again", 1, 2.0)
        time.sleep(0.2)
        at = tester.note(45, 0.2)
        time.sleep(1.0)
        tester.client.deactivate()
        heard = tester.heard(at, "biwa", 45, FS)
    finally:
        if tester is not None:
            tester.client.close()
        proc.send_signal(signal.SIGINT)
        out, err = lines.rest()
    assert proc.returncode == 0, (out, err)
    assert heard[0] >= 0.9, heard
    assert "the server came back 1 times" in out and "Traceback" not in err, (out, err)
    info = soundfile.info(str(tmp_path / "a.wav"))
    assert info.samplerate == FS and info.frames > FS


def test_portaudio_with_jack_midi(private_server, tmp_path):
    """The PortAudio player (no --jack) on a machine whose MIDI is JACK's:
    --midi-api auto takes JACK MIDI, --list-ports shows the keyboard, a
    note is recorded; the keyboard's client going away is a warning, its
    return reopens the port and its next note plays."""
    import soundfile

    pytest.importorskip("rtmidi")
    srv = private_server("pa")
    env = dict(os.environ, JACK_DEFAULT_SERVER=srv.name)
    kbd = {}

    def keyboard():
        c = jack.Client("kbd", no_start_server=True, servername=srv.name)
        port = c.midi_outports.register("keys")
        queue = []

        def process(frames):
            port.clear_buffer()
            while queue:
                port.write_midi_event(0, queue.pop(0))
        c.set_process_callback(process)
        c.activate()
        kbd.update(client=c, queue=queue)

    keyboard()
    lp = subprocess.run([sys.executable, "-m", "synth.cli", "play", "--list-ports"], env=env,
                        capture_output=True, text=True, timeout=120)
    assert "JACK MIDI" in lp.stdout and "  kbd:keys" in lp.stdout, lp.stdout
    proc = subprocess.Popen([sys.executable, "-m", "synth.cli", "play", "--preset", "sitar",
                             "--midi-port", "kbd", "--record", str(tmp_path / "pa.wav"),
                             "--seconds", "60"], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    lines = _Lines(proc)
    try:
        lines.wait_for("ready in", timeout=120)
        kbd["queue"].append(bytes([0x90, 57, 100]))
        time.sleep(1.0)
        kbd["client"].deactivate()
        kbd["client"].close()
        lines.wait_for("warning: MIDI input 'kbd:keys' is gone")
        keyboard()
        lines.wait_for("MIDI input 'kbd:keys' is back")
        time.sleep(0.3)
        kbd["queue"].append(bytes([0x90, 62, 100]))
        time.sleep(1.0)
    finally:
        kbd["client"].close()
        proc.send_signal(signal.SIGINT)
        out, err = lines.rest()
    assert proc.returncode == 0, (out, err)
    assert "2 notes" in out and "(jack)" in out, out
    y, fs = soundfile.read(str(tmp_path / "pa.wav"))
    assert fs == FS and np.max(np.abs(y)) > 0.01
