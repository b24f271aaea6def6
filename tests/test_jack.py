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
