"""Live play through a real JACK server: ``synth play --jack`` in a
subprocess, played and heard by a JACK client of the test's own.

The server is JACK's dummy backend (no sound card), started here under a
name of its own (``jackd -n ... -d dummy -r 48000 -p 128``) unless
``$SYNTH_TEST_JACK_SERVER`` names a running one.  Skipped, with the reason,
where ``jackd`` or the JACK-Client package is missing (``.ci/run`` installs
both)."""

from __future__ import annotations

import functools
import os
import re
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from synth.io.live.loopback import Loopback, connect, start_dummy_server, wait_ports

FS = 48_000


def _jack_module():
    try:
        import jack
    except (ImportError, OSError) as e:
        return None, f"JACK-Client is not usable ({e})"
    return jack, None


jack, JACK_REASON = _jack_module()


def _start_jackd(name, rate=FS, period=128):
    """``jackd -n NAME -d dummy -r RATE -p PERIOD``, once it answers."""
    try:
        return start_dummy_server(name, rate, period)
    except RuntimeError as e:
        pytest.skip(str(e))


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


def _stop(proc, tester=None):
    """Close the tester's client, Ctrl-C the synth; its (stdout, stderr)."""
    if tester is not None:
        tester.client.close()
    proc.send_signal(signal.SIGINT)
    return proc.communicate(timeout=60)


@pytest.mark.slow  # over 2 s on a quiet 2-core machine
def test_notes_through_jack_sound_as_offline_at_a_constant_latency(server, tmp_path, alone):
    """24 notes sent through JACK MIDI at chosen frames to ``synth play
    --jack --preset grand-piano``, its audio captured through JACK: each
    note the server kept time for (no xrun reported during its capture)
    correlates with the same note rendered offline (at least 0.9 once
    aligned, median 0.99), the latency is the same to the sample for all of
    them; the report names the client's ports and counts the xruns.

    At least 12 notes clear of an xrun are judged.  The VM's noise comes in
    bursts (one capture in five CI runs saw some 430 xruns, 2026-12-02, and
    an idle client right after it none; another, 130 xruns, left 10 notes
    clear, each as offline to 1e-3 and on its sample; a CI run in a slow
    hour, 2026-12-03, some 200 and 190 xruns in two captures, left 1 and 7),
    so captures with fewer are taken again, up to three, and the clear
    notes of all are judged together.  Fewer than 12 in all: the test skips
    if the machine stalled or an idle client sees the server xrun (the
    machine, not the synth), else fails."""
    from synth.io.factory import build_engine

    expected = 128 + build_engine("grand-piano", ()).latency_samples
    untorn, shown = [], []
    for attempt in (1, 2, 3):
        cap = _notes_capture(server, tmp_path / f"live{attempt}.wav", alone)
        clear, text = _judge_notes_capture(cap, expected)
        untorn += clear
        shown.append(f"attempt {attempt}: {text}")
        if len(untorn) >= 12:
            break
    shown = "; ".join(shown)
    if len(untorn) < 12:
        _skip_if_the_machine_stalled(cap["out"], cap["xruns"], 128 / FS, shown)
        _skip_if_the_server_alone_xruns(server, shown)
    assert len(untorn) >= 12 and min(untorn) >= 0.9 and np.median(untorn) >= 0.99, shown


def _judge_notes_capture(cap, expected):
    """One capture of :func:`_notes_capture` judged: the report, the
    messages, every note clear of an xrun at the expected lag (or whole
    periods later, :func:`_assert_constant_lag`), ``--record``'s file;
    returns the clear notes' correlations and a description."""
    n = int(0.1 * FS)
    out, rec, t0, xruns, onsets = cap["out"], cap["rec"], cap["t0"], cap["xruns"], cap["onsets"]
    assert cap["returncode"] == 0, cap["err"]
    assert "JACK client 'synthtest'" in out and "synthtest:out_2" in out
    assert " 0 late events, 0 errors" in out, out
    # every message reaches the synth, but one sent in a cycle the server
    # lost may not (the VM's xruns: 47 of 48 messages, with 5 xruns and no
    # block of the synth's over its budget, twice in the full suite on a
    # 2-vCPU Xeon, 2026-12-01); each message missing must have been sent
    # near an xrun the tester saw (the window of a torn note, below)
    # ... and one sent near an xrun may reach it twice ("25 notes" for 24
    # sent in a storm of 1124 xruns, 2026-12-03): jackd2 1.9.21's dummy
    # backend, two bare JACK-Client clients, the writer one event a cycle,
    # both stalling up to 10 ms in 2 % of their cycles: 150 of 5,297
    # messages read twice in 15 s, with 645 xruns.  So the count may differ
    # by one per message near an xrun either way, and never without one
    def near_xrun(f):
        # an xrun the tester saw from a period before frame f to the end of
        # the window a note's lag and sound are read from (the search's 1024
        # samples and the 0.1 s compared)
        return any(f - 2 * 128 <= x <= f + 1024 + n for _, x, _ in xruns)

    got = int(re.search(r"(\d+) MIDI messages", out).group(1))
    notes = int(re.search(r"MIDI messages, (\d+) notes", out).group(1))
    sent = [f for at in onsets for f in (at, at + cap["hold"])]
    torn = [near_xrun(at) for at in onsets]
    assert abs(got - len(sent)) <= sum(near_xrun(f) for f in sent), (out, xruns)
    assert abs(notes - len(onsets)) <= sum(torn), (out, xruns)
    # each note against the same note offline (the live engine's output, latency included)
    lags, corr = [], []
    for at, k in zip(onsets, cap["keys"]):
        ref = _reference("grand-piano", k, FS)
        seg = rec[at - t0:at - t0 + int(0.2 * FS)].mean(axis=1)
        best = max(range(0, 1024), key=lambda L: float(np.dot(seg[L:L + n], ref[:n])))
        a, b = seg[best:best + n], ref[:n]
        lags.append(best)
        corr.append(float(np.dot(a, b) / np.sqrt(np.dot(a, a) * np.dot(b, b))))
    # a note whose capture an xrun the tester saw fell into is torn (its
    # periods may come shifted by part of one, or be dropped: CI on a busy
    # VM, 2026-11-30; ci31 saw an xrun near most of the 24) and is not
    # judged; every other note sounds as offline and lands to the sample
    # (``torn``, above: an xrun near its onset).
    shown = f"correlations {corr}, lags {lags}, torn {torn}, tester xruns {xruns}"
    checked = [lag for lag, c, t in zip(lags, corr, torn) if c >= 0.9 and not t]
    # the loop through the tester adds one period; the rest is the engine's
    # own delay (the decimator and the grand's limiter, which an offline
    # render removes).  Every note lands at it to the sample, but for a note
    # the server moved by whole periods in an xrun it reported (the dummy
    # backend skips a cycle when the VM loses time; seen once in CI, 2026-11-29)
    _assert_constant_lag(checked, expected, xruns, _xruns_reported(out), shown)
    # --record holds what the client sent: the captured audio, one period earlier
    import soundfile

    y, fs = soundfile.read(str(cap["record"]), dtype="float32")
    assert fs == FS and y.shape[1] == 2 and "recorded " in out
    peak = np.max(np.abs(rec))
    if not xruns and not _xruns_reported(out):
        assert np.max(np.abs(y)) == pytest.approx(peak, rel=1e-6)
    else:
        # a cycle the server lost is in the file but not in the capture (a
        # noisy hour: the file's peak 0.520, the capture's 0.473, 2026-12-03)
        assert np.max(np.abs(y)) >= peak * (1.0 - 1e-6), (np.max(np.abs(y)), peak, shown)
    return [c for c, t in zip(corr, torn) if not t], shown


def _notes_capture(server, record, alone):
    """One run of ``synth play --jack --preset grand-piano --record
    RECORD``: 24 notes (keys 48-83) sent 0.4 s apart at every offset in the
    period, held 0.2 s, its outputs captured.  Returns the synth's stdout,
    stderr and exit code, the capture and its first frame, the tester's
    xruns, the notes' frames and keys, the hold (frames) and ``record``."""
    proc = _synth_play(server, "--preset", "grand-piano", "--jack-name", "synthtest",
                       "--record", str(record))
    tester = None
    try:
        _ports_up(server, "synthtest", 3, proc)
        keys = [48 + (5 * i) % 36 for i in range(24)]
        spacing, hold = int(0.4 * FS), int(0.2 * FS)
        with alone():   # the capture judges the server's clock (conftest)
            tester = Loopback(server, 2, 24 * 0.4 + 1.5 + SETTLE_S)
            tester.client.activate()
            connect(tester.client, [(tester.midi_out, "synthtest:midi_in"),
                                     ("synthtest:out_1", tester.ins[0]),
                                     ("synthtest:out_2", tester.ins[1])])
            _settle(tester, least_s=0.2)
            start = tester.client.last_frame_time + FS // 2
            onsets = []
            for i, k in enumerate(keys):
                at = start + i * spacing + (37 * i) % 128        # every offset in the period
                onsets.append(at)
                tester.events += [(at, bytes([0x90, k, 100])), (at + hold, bytes([0x80, k, 64]))]
            time.sleep(24 * 0.4 + 1.0)
            tester.client.deactivate()
            rec, t0, xruns = tester.rec, tester.t0, list(tester.xruns)
    finally:
        out, err = _stop(proc, tester)
    return {"out": out, "err": err, "returncode": proc.returncode, "rec": rec, "t0": t0,
            "xruns": xruns, "onsets": onsets, "keys": keys, "hold": hold, "record": record}


def _xruns_reported(out: str) -> int:
    """The xruns ``synth play``'s report counted (its "N JACK xruns" line)."""
    import re

    m = re.search(r"\n(\d+) JACK xruns\n", out)
    assert m, out
    return int(m.group(1))


def _assert_constant_lag(lags, expected, tester_xruns, synth_xruns, shown, period=128):
    """Every lag is ``expected`` to the sample; where the server reported an
    xrun (to the tester or to the synth) a lag may be whole periods later:
    the dummy backend then delivers the synth's periods one or more cycles
    late, for one note or from then on (seen on this VM when it is busy:
    lags of 1, 2 and 3 periods more).  A lag off by anything else fails."""
    off = [lag for lag in lags if lag != expected]
    assert all((lag - expected) % period == 0 and lag > expected for lag in off), \
        f"expected {expected}: {shown}"
    assert not off or tester_xruns or synth_xruns, f"expected {expected}, no xrun reported: {shown}"


def test_no_server_is_one_line(server):
    env = dict(os.environ, JACK_DEFAULT_SERVER="synth-no-such-server", JACK_NO_START_SERVER="1")
    p = subprocess.run([sys.executable, "-m", "synth.cli", "play", "--jack", "--preset", "sitar",
                        "--seconds", "1"], env=env, capture_output=True, text=True, timeout=120)
    assert p.returncode != 0
    last = p.stderr.strip().splitlines()[-1]
    assert "no JACK server is running" in last and "Traceback" not in p.stderr, p.stderr


@pytest.mark.slow  # over 2 s on a quiet 2-core machine (2026-11-29: 2.0-6.1 s)
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
        _ports_up(name, "gone", 2, proc)
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


@pytest.mark.slow  # over 2 s on a 2-core machine (2026-12-03: 2.8 s in the fast tier)
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


def _ports_up(server, name, n, proc):
    """Wait for client ``name``'s ``n`` ports on ``server`` (a probe client,
    closed whatever happens: one left to the garbage collector closes itself
    later, perhaps after its server has stopped, which crashes libjack)."""
    probe = jack.Client("waiter", no_start_server=True, servername=server)
    try:
        wait_ports(probe, name, n, proc)
    finally:
        probe.close()


class _Server:
    """A private dummy server (its own name, rate and period), stoppable
    and restartable under the same name."""

    def __init__(self, tag, rate=FS, period=128):
        self.name = f"synth-test-{tag}-{os.getpid()}"
        self.rate, self.period = rate, period
        self.proc = None

    def start(self):
        self.proc = _start_jackd(self.name, self.rate, self.period)
        return self

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


#: the longest wait for the server to settle (s, :func:`_settle`)
SETTLE_S = 6.0


def _settle(lb, least_s=0.5, quiet_s=0.5):
    """Wait for the graph to settle after a loopback's connections (as the
    bench's): at least ``least_s``, then until the server has run
    ``quiet_s`` with no xrun (at most :data:`SETTLE_S` in all; give the
    loopback that much more capture).  On a busy VM the server's xruns
    come in bursts, often right after a client connects: a 44.1 kHz
    capture's first note was torn in both of its attempts (three plays
    each) and the next three clean, in a CI run (2026-12-03) that had
    waited a flat second."""
    t0 = time.monotonic()
    time.sleep(least_s)
    seen, since = len(lb.xruns), time.monotonic()
    while time.monotonic() - t0 < SETTLE_S and time.monotonic() - since < quiet_s:
        time.sleep(0.02)
        if len(lb.xruns) != seen:
            seen, since = len(lb.xruns), time.monotonic()


class _Tester:
    """A :class:`~synth.io.live.loopback.Loopback` attached to a synth
    client, which also tells how a note it played sounded."""

    def __init__(self, server, synth_name, n_in, seconds, rate=FS, name="tester"):
        # ``seconds`` of capture after the settling (:func:`_settle`, at most SETTLE_S)
        self.lb = Loopback(server, n_in, seconds + SETTLE_S, rate=rate,
                           name=name).attach(synth_name)
        self.client, self.rate = self.lb.client, rate
        _settle(self.lb)

    def note(self, key, at_s, hold_s=0.2, velocity=100):
        return self.lb.note(key, at_s, hold_s, velocity)

    def heard(self, at, preset, key, lag, n_s=0.1):
        """Correlation of the capture at frame ``at`` with the same note
        rendered offline at this rate, at the best lag within 3 samples of
        ``lag`` (the loop's period plus the engine's latency: a plucked
        note is periodic, a search over a period would find its echoes),
        and that lag."""
        rate = self.rate
        ref = _reference(preset, key, rate)
        seg = self.lb.rec[at - self.lb.t0:at - self.lb.t0 + int(0.2 * rate)].mean(axis=1)
        n = int(n_s * rate)
        best = max(range(max(lag - 3, 0), lag + 4),
                   key=lambda L: float(np.dot(seg[L:L + n], ref[:n])))
        a, b = seg[best:best + n], ref[:n]
        den = np.sqrt(np.dot(a, a) * np.dot(b, b))
        return (float(np.dot(a, b) / den) if den > 0 else 0.0), best

    def sound(self, key, preset, lag, tries=3):
        """Play ``key`` (held 0.2 s) and judge it (:meth:`heard`); a note
        during which the server reported an xrun (this VM loses cycles now
        and then, whoever runs) is played again, up to ``tries`` times.
        Judge damped notes (the grand's): a plucked note ringing under the
        next one pulls the best lag off by a sample or two.  The first try
        with no xrun is the answer; if every try had one, the best of them
        (the last one, as before, was a torn note in CI on a busy VM,
        2026-11-30: correlation 0.19, 3 samples off)."""
        judged = []
        for _ in range(tries):
            seen = len(self.lb.xruns)
            at = self.note(key, 0.2)
            time.sleep(0.8)
            judged.append(self.heard(at, preset, key, lag))
            if len(self.lb.xruns) == seen:
                return judged[-1]
        return max(judged, key=lambda j: (j[1] == lag, j[0]))


@functools.lru_cache(maxsize=None)
def _reference(preset, key, rate):
    """The note (velocity 100) rendered offline, 0.2 s, mono.  Render the
    references a test needs before its clients are active (``_reference``
    of each): a render in this process holds the GIL for a second, its
    JACK client's callback waits, and the whole server xruns."""
    from synth.engine.engine import Event
    from synth.io.factory import build_engine

    ref = build_engine(preset, (), fs_out=rate).render([Event(0.0, "note_on", key, 100 / 127)],
                                                       duration_s=0.2)
    return ref if ref.ndim == 1 else ref.mean(axis=1)


@functools.lru_cache(maxsize=None)
def _lag(preset, rate=FS, period=128):
    """Frames from a MIDI event written by the loopback to its sound read
    back: one period (the loop) plus the engine's latency."""
    from synth.io.factory import build_engine

    return period + build_engine(preset, (), fs_out=rate).latency_samples


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
        """Wait for the process; (stdout, stderr).  A process that does not
        end within ``timeout`` seconds is killed and the test fails (it
        used to wait on its stderr for ever: a hung close, 2026-12-01)."""
        try:
            self.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
            raise AssertionError(f"the process did not end in {timeout} s: {self.lines}") from None
        err = self.proc.stderr.read()
        self.thread.join(timeout=10)
        return "".join(self.lines), err


@pytest.mark.parametrize("rate,period", [(44_100, 128), (96_000, 256)])
@pytest.mark.slow  # over 2 s on a quiet 2-core machine
def test_other_rates_through_jack(private_server, rate, period, tmp_path, alone):
    """A server at 44.1 or 96 kHz: synth plays at its rate, each note as
    the same note rendered offline at that rate (correlation >= 0.9, each
    at the loop's period plus the engine's latency at that rate), and the
    recording is at that rate.  At 96 kHz the period is 256 frames, the
    same 2.7 ms as 128 at 48 kHz (at 128 frames, 1.3 ms, a grand note-on's
    block overran it on this VM and the server skipped cycles).  A capture
    in which a note missed while the server reported xruns is taken once
    more (the VM's noise comes in bursts: the full suite, 2026-12-02; the
    test passed alone and with the other JACK tests right after); a synth
    that misses a note with no xrun, or twice, fails."""
    import soundfile

    srv = private_server(f"rate{rate}", rate=rate, period=period)
    keys = (50, 57, 62, 69)
    lag = _lag("grand-piano", rate, period)
    for k in keys:
        _reference("grand-piano", k, rate)
    for attempt in (1, 2):
        rec = tmp_path / f"r{attempt}.wav"
        proc = _synth_play(srv.name, "--preset", "grand-piano", "--jack-name", "rated",
                           "--record", str(rec))
        tester = None
        try:
            _ports_up(srv.name, "rated", 3, proc)
            with alone():   # the capture judges the server's clock (conftest)
                tester = _Tester(srv.name, "rated", 2, 12.0, rate=rate)
                time.sleep(0.2)
                heard = [tester.sound(k, "grand-piano", lag) for k in keys]
                xruns = list(tester.lb.xruns)
        finally:
            out, err = _stop(proc, tester)
        good = all(c >= 0.9 for c, _ in heard) and all(L == lag for _, L in heard)
        if good or not xruns:
            break
    assert proc.returncode == 0, err
    assert f"{rate} Hz, period {period}" in out, out
    assert good, (attempt, heard, lag, xruns)
    info = soundfile.info(str(rec))
    assert info.samplerate == rate and info.frames > rate


@pytest.mark.slow  # over 2 s on a quiet 2-core machine
def test_period_change_and_a_midi_source_leaving(private_server, tmp_path):
    """While synth plays: the server's period goes from 128 to 256 frames
    (play goes on, said once), the MIDI source disconnects (a warning) and
    another one connects; every note is heard, before and after, and the
    recording is complete."""
    import soundfile

    srv = private_server("period")
    proc = _synth_play(srv.name, "--preset", "grand-piano", "--jack-name", "faulty",
                       "--record", str(tmp_path / "f.wav"), seconds=60)
    lines = _Lines(proc)
    t1 = t2 = None
    xr = []
    try:
        _ports_up(srv.name, "faulty", 3, proc)
        lines.wait_for("ready in")
        for k in (57, 62, 69):
            _reference("grand-piano", k, FS)
        _lag("grand-piano"), _lag("grand-piano", period=256)
        t1 = _Tester(srv.name, "faulty", 2, 12.0, name="first")
        time.sleep(0.2)
        first = [t1.sound(57, "grand-piano", _lag("grand-piano"))]
        t1.client.blocksize = 256
        lines.wait_for("the JACK period is now 256")
        first.append(t1.sound(62, "grand-piano", _lag("grand-piano", period=256)))
        xr += t1.lb.xruns
        t1.client.deactivate()
        t1.client.close()
        t1 = None
        lines.wait_for("warning: MIDI source 'first:midi_out' disconnected")
        try:
            t2 = _Tester(srv.name, "faulty", 2, 6.0, name="second")
        except jack.JackError as e:
            # (a CI run's second source could not connect for 30 s; say
            # whether the server was still there)
            p = srv.proc
            state = "running" if p is not None and p.poll() is None else \
                f"exited with {None if p is None else p.returncode}"
            raise AssertionError(f"{e}; the private server: {state}") from e
        time.sleep(0.3)
        second = t2.sound(69, "grand-piano", _lag("grand-piano", period=256))
        xr += t2.lb.xruns
        t2.client.deactivate()
    finally:
        for t in (t1, t2):
            if t is not None:
                t.client.close()
        proc.send_signal(signal.SIGINT)
        out, err = lines.rest()
    assert proc.returncode == 0, err
    if not all(cor >= 0.9 for cor, _ in first + [second]):
        _skip_if_the_machine_stalled(out, xr, 128 / FS, str((first, second, xr)))
    # (with the synth's report: a CI run in a slow hour tore the first note,
    # 0.74, with no xrun the tester saw)
    assert all(cor >= 0.9 for cor, _ in first + [second]), (first, second, xr, out[-800:])
    # the loop's delay grows by the one period it gained, nothing else
    assert [lag for _, lag in first + [second]] == [
        _lag("grand-piano"), _lag("grand-piano", period=256), _lag("grand-piano", period=256)]
    assert "the period changed 1 times" in out, out
    y, fs = soundfile.read(str(tmp_path / "f.wav"))
    assert fs == FS and len(y) > 2 * FS and np.max(np.abs(y)) > 0.01


def test_a_loopback_that_cannot_attach_closes_its_client(private_server):
    """A loopback whose connections fail closes its client before the error
    goes on: a client left to the garbage collector closed itself after the
    test had stopped its server, and libjack crashed the test's worker (a
    CI run: the next test of that worker, a segmentation fault)."""
    srv = private_server("attach")
    lb = Loopback(srv.name, 1, 1.0, name="lonely")
    with pytest.raises(jack.JackError):
        lb.attach("nosuch", timeout=0.3)
    assert not lb.client._ptr            # jack.Client.close's mark: closed


def test_a_midi_source_gone_is_said_once_even_if_the_server_did_not():
    """The once-a-second look at the connections says a MIDI source gone
    that the server's notification did not report (on a stalled machine its
    port may be gone before the notification reads its name: CI, 38 xruns,
    no warning), and not one the notification said; the outputs' links are
    not MIDI sources.  (No server: the player's attributes are set by hand.)"""
    from synth.io.live.jack import JackPlayer

    class Port:
        def __init__(self, name):
            self.name, self.shortname = name, name.split(":")[1]

    class Client:
        links = {}

        def get_all_connections(self, port):
            return [Port(n) for n in self.links.get(port.shortname, ())]

    p = object.__new__(JackPlayer)
    p.client, p.midi_in, p.outs = Client(), Port("faulty:midi_in"), [Port("faulty:out_1")]
    p._notes, p._said_gone = [], set()
    Client.links = {"midi_in": ["first:midi_out", "kbd:out"], "out_1": ["system:playback_1"]}
    p._links = set()
    p._note_links()
    assert p._notes == []
    Client.links = {"midi_in": ["kbd:out"]}                     # first gone, unreported; the output unplugged
    p._note_links()
    assert p._notes == ["warning: MIDI source 'first:midi_out' disconnected from faulty:midi_in; "
                        "play goes on"]
    p._notes.clear()
    p._connected(Port("kbd:out"), p.midi_in, False)             # the server said this one
    Client.links = {"midi_in": []}
    p._note_links()
    assert p._notes == ["warning: MIDI source 'kbd:out' disconnected from faulty:midi_in; play goes on"]
    assert p._said_gone == set()


@pytest.mark.slow  # over 2 s on a quiet 2-core machine (2026-11-29: 2.0-6.1 s)
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
        _ports_up(srv.name, "again", 2, proc)
        lines.wait_for("ready in")
        time.sleep(0.5)
        srv.stop()
        lines.wait_for("waiting for it to come back")
        srv.start()
        lines.wait_for("the JACK server is back")
        _reference("biwa", 45, FS), _lag("biwa")
        tester = _Tester(srv.name, "again", 1, 6.0)
        time.sleep(0.2)
        heard = tester.sound(45, "biwa", _lag("biwa"))
        tester.client.deactivate()
    finally:
        if tester is not None:
            tester.client.close()
        proc.send_signal(signal.SIGINT)
        out, err = lines.rest()
    assert proc.returncode == 0, (out, err)
    assert heard[0] >= 0.9 and heard[1] == _lag("biwa"), heard
    assert "the server came back 1 times" in out and "Traceback" not in err, (out, err)
    info = soundfile.info(str(tmp_path / "a.wav"))
    assert info.samplerate == FS and info.frames > FS


@pytest.mark.slow  # over 2 s on a quiet 2-core machine
def test_sigterm_stops_the_play_as_ctrl_c_does(server, tmp_path):
    """SIGTERM (a service manager, ``kill``; the one a job started in the
    background with ``&`` still takes, its SIGINT being ignored) stops
    ``synth play`` as Ctrl-C does: exit status 0, the report, and the
    recording complete (it used to die with no report and no file)."""
    import soundfile

    rec = tmp_path / "t.wav"
    proc = _synth_play(server, "--preset", "biwa", "--jack-name", "termed", "--record", str(rec))
    lines = _Lines(proc)
    try:
        lines.wait_for("ready in")
        time.sleep(0.5)
    finally:
        proc.send_signal(signal.SIGTERM)
        out, err = lines.rest()
    assert proc.returncode == 0, (out, err)
    assert "stopped by SIGTERM" in out and "JACK xruns" in out and "Traceback" not in err, out
    info = soundfile.info(str(rec))
    assert info.samplerate == FS and info.frames >= 0.4 * FS
    assert f"recorded {info.frames / FS:.1f} s to" in out


@pytest.mark.slow  # over 2 s on a quiet 2-core machine
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


@pytest.mark.slow  # over 2 s on a quiet 2-core machine
def test_bench_live_jack_quick_measures_the_loop(server, alone):
    """``tools/bench.py live --jack --quick`` (issue 36's measuring tool, on
    the module's dummy server): every note found, at 241 samples (the
    loop's period and the grand's decimator and limiter), a spread under
    0.1 ms; its xrun count is printed, not judged (this VM's own)."""
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]

    def run():
        with alone():   # the tool judges the server's clock (conftest)
            p = subprocess.run([sys.executable, str(root / "tools" / "bench.py"), "live", "--jack",
                                "--quick", "--server", server], capture_output=True, text=True,
                               timeout=600)
        assert p.returncode == 0, p.stderr
        out = p.stdout
        found = int(re.search(r"notes found: (\d+) of 8", out).group(1))
        xruns = int(re.search(r"(\d+) during play;", out).group(1))
        return out, found, xruns

    # an xrun of the dummy server can tear a note's capture (this VM's own:
    # 9 xruns in 8 s with the synth's worst block at 64 %, CI 2026-11-29;
    # 57 during play with an idle client alone seeing 21 in 4 s, and two
    # notes torn to correlation 0.89, a suite run on a busy VM 2026-11-30):
    # then up to two notes of the eight may be missed, never without one
    # (more misses skip, as the drone's and the notes' captures do, when the
    # tool's own idle client saw an xrun every half second: CI here,
    # 2026-11-30, 3 of 8 found with 171 xruns during play and 11 in 4 s idle)
    out, found, xruns = run()
    if not (found == 8 or (found >= 6 and xruns > 0)) and _preempted(out):
        # the synth's thread was kept from the cores, not slow: its blocks
        # fit the period in CPU time (at most the first note-on's two over)
        # and overran it in wall time many times (a local CI run, 12-03:
        # 5 of 8 found, 182 xruns, 38 blocks over in wall time and 2 in CPU
        # time, with no other test running; the tool alone after it passed
        # three times of three).  Measured once more; the second must pass.
        out, found, xruns = run()
    if not (found == 8 or (found >= 6 and xruns > 0)):
        idle = re.search(r"a client that does nothing saw (\d+) xruns in ([0-9.]+) s", out)
        if idle:
            _skip_if_idle_xruns(int(idle.group(1)), float(idle.group(2)), f"{found} of 8 notes found")
    assert found == 8 or (found >= 6 and xruns > 0), out
    assert "median latency <= 6.5 ms: yes (5.02" in out, out
    # the host's cost of memory left alone, beside the idle client's xruns
    pt = re.search(r"read again \(2000 random pages of 64 MB, us a page\): after 0 s ([0-9.]+), "
                   r"after 0.1 s ([0-9.]+), after 1 s ([0-9.]+)", out)
    assert pt and all(0.0 < float(x) < 1000.0 for x in pt.groups()), out
    ca = re.search(r"a numpy add of 10 floats \(us\): after 0 s ([0-9.]+), after 0.1 s ([0-9.]+), "
                   r"after 0.3 s ([0-9.]+)", out)
    assert ca and all(0.0 < float(x) < 1e6 for x in ca.groups()), out
    # an xrun during play moves the note it falls on a period late (this
    # VM's own, and a first note-on's block may overrun): the spread is
    # judged when the run had none
    assert "xruns during play" in out
    if "0 xruns during play: yes" in out:
        assert "spread <= 0.1 ms: yes" in out, out


@pytest.mark.slow  # over 2 s: a JACK server, synth play and 3.5 s of a drone
def test_the_drone_player_plays_live_through_jack(private_server, tmp_path, monkeypatch, alone):
    """``synth play --jack`` on a preset with a [drone] table: one key sent
    through JACK MIDI starts the drone (a key-up does nothing), the same key
    again stops it; the captured audio is the offline render of those two
    note-ons, sample for sample once aligned (the engine plays the player:
    nothing special in the live path).  The server's period is 1024 frames
    (21 ms): what is judged is the samples, not the latency, and at 128 the
    dummy server on a busy 2-vCPU VM tore every window of the capture (CI,
    2026-11-30: an idle client on it alone saw 21 xruns in 4 s)."""
    from test_drone import NAME, drone_preset_text

    from synth.engine.engine import Event
    from synth.io.factory import build_engine
    from synth.io.presets import ENV_PRESET_PATH

    folder = tmp_path / "presets"
    folder.mkdir()
    (folder / f"{NAME}.toml").write_text(drone_preset_text(), "utf-8")
    monkeypatch.setenv(ENV_PRESET_PATH, str(folder))
    stop_s, seconds = 2.2, 3.5
    eng = build_engine(NAME, ["drone.cycle_s=1"])
    ref = eng.render([Event(0.0, "note_on", 49, 100 / 127),
                      Event(stop_s, "note_on", 49, 90 / 127)], duration_s=seconds)
    # 9 plucks before the key stops it at 2.2 s (the cycles at 0 and 1 s, the
    # first string of the one at 2 s), none after
    assert eng.drone.n_plucks == 9 and not eng.drone.running
    period = 1024
    server = private_server("drone", period=period).name
    expected = period + eng.latency_samples
    # window by window against the offline render at the loop's lag (a
    # period plus the engine's latency), or whole periods later where the
    # server reported an xrun (the dummy backend then delivers a period a
    # cycle late); a window is half a second: one string's period (10 ms)
    # would alias a much shorter one.  A window an xrun reported to the
    # tester falls into (its span in the capture, the lag search included)
    # is torn: the server may have slipped or dropped a period in it.  The
    # others must be the offline samples.  A capture with fewer than 3
    # windows clear of xruns cannot tell, and is played again by a new synth
    # (up to 3 times): CI on a busy VM, 2026-11-30, saw all 7 windows torn.
    win = int(0.5 * FS)
    tries = []
    for _ in range(3):
        rec, at, t0, xruns, out, err, code = _drone_capture(server, NAME, stop_s, seconds, alone)
        assert code == 0, err
        seg = rec[at - t0:]
        lags, corrs, torn = [], [], []
        for w0 in range(0, min(len(ref), len(seg) - expected - 8 * period) - win + 1, win):
            b = ref[w0:w0 + win]
            best = max((expected + period * k for k in range(8)),
                       key=lambda L: float(np.dot(seg[w0 + L:w0 + L + win], b)))
            a = seg[w0 + best:w0 + best + win]
            lags.append(best)
            corrs.append(float(np.dot(a, b) / np.sqrt(np.dot(a, a) * np.dot(b, b))))
            torn.append(any(at + w0 - 2 * period <= f <= at + w0 + win + expected + 8 * period
                            for _, f, _ in xruns))
        tries.append((lags, [round(c, 4) for c in corrs], torn, xruns))
        if len(lags) >= 6 and sum(not t for t in torn) >= 3:
            break
    shown = f"tries (lags, correlations, torn, tester xruns): {tries}"
    if not (len(lags) >= 6 and sum(not t for t in torn) >= 3):
        _skip_if_the_server_alone_xruns(server, shown)
    assert len(lags) >= 6 and sum(not t for t in torn) >= 3, shown
    clean = [(lag, c) for lag, c, t in zip(lags, corrs, torn) if not t]
    assert all(c >= 0.99 for _, c in clean), shown
    _assert_constant_lag([lag for lag, _ in clean], expected, xruns, _xruns_reported(out), shown,
                         period)
    assert "2 notes" in out, out


def _skip_if_the_server_alone_xruns(server, shown, seconds=3.0):
    """Skip, saying why, when the server with only an idle client on it
    (a process callback that does nothing) reports an xrun every half
    second or more often: then the machine, not the synth, is losing
    cycles, and no capture can be judged (seen on this VM: hundreds of
    xruns in 5 s, most of them 13 us late, for a minute).  Otherwise
    return, and the caller's assertion fails on the synth."""
    from synth.apps.bench.live import idle_xruns

    _skip_if_idle_xruns(idle_xruns(server, seconds), seconds, shown)


def _preempted(out):
    """Whether ``tools/bench.py live``'s report says the synth's audio
    thread was kept from the cores rather than slow: at most two blocks over
    the period in its own CPU time (a first note-on's block may overrun)
    and at least ten in wall time."""
    m = re.search(r"([0-9.]+) blocks over budget \(([0-9.]+) in its CPU time", out)
    return bool(m) and float(m.group(2)) <= 2.0 and float(m.group(1)) >= 10.0


def _skip_if_the_machine_stalled(out, xruns, period_s, shown):
    """Skip, saying why, when the server woke a whole period late or more
    (an xrun the tester saw delayed by more than ``period_s``: the dummy
    backend's clock thread was not run) while the synth's audio thread
    never used more CPU time than a period in any block (its report's
    "N in the audio thread's CPU time" is 0): the machine stopped, not the
    synth (CI on this VM, 2026-12-02: 21 of 24 notes torn twice, xruns
    delayed 2.8-4.6 ms, every block within budget in CPU time).  A synth
    that computes too long shows its blocks over budget there and fails;
    this rule would not tell a callback that waits long on a lock from a
    stalled machine (the callback, ``synth.io.live.jack``'s ``_process``,
    takes no lock of its own; the interpreter's is the one it may wait on)."""
    m = re.search(r"blocks over it \((\d+) in the audio thread's CPU time", out)
    late = [x for x in xruns if x[2] > 1e6 * period_s]
    if m and int(m.group(1)) == 0 and late:
        pytest.skip(f"the machine stalled: {len(late)} xruns delayed by more than a period "
                    f"(up to {max(x[2] for x in late):.0f} us), no block of the synth over "
                    f"budget in its CPU time ({shown[:300]})")


def _skip_if_idle_xruns(n, seconds, shown):
    """Skip, saying why, when an idle client saw ``n`` xruns in ``seconds``
    (an xrun every half second or more often): the rule of
    :func:`_skip_if_the_server_alone_xruns`, for a count already measured."""
    if n >= 2 * seconds:
        pytest.skip(f"the JACK server reported {n} xruns in {seconds:g} s with only an "
                    f"idle client on it: this machine is not keeping time now ({shown[:300]})")


def _drone_capture(server, name, stop_s, seconds, alone):
    """``synth play --jack`` on the drone preset ``name``: key 49 through
    JACK MIDI half a second after the capture starts (its key-up 0.1 s
    later), key 49 again ``stop_s`` later; returns the capture (mono), the
    first note's frame, the capture's first frame, the tester's xruns and
    the synth's stdout, stderr and exit code."""
    proc = _synth_play(server, "--preset", name, "--set", "drone.cycle_s=1", "--jack-name",
                       "synthdrone")
    tester = None
    try:
        _ports_up(server, "synthdrone", 2, proc)
        with alone():   # the capture judges the server's clock (conftest)
            tester = Loopback(server, 1, seconds + 1.0).attach("synthdrone")
            time.sleep(0.2)
            at = tester.client.last_frame_time + FS // 2
            tester.events += [(at, bytes([0x90, 49, 100])), (at + FS // 10, bytes([0x80, 49, 64])),
                              (at + int(stop_s * FS), bytes([0x90, 49, 90]))]
            time.sleep(seconds + 1.0)
            tester.client.deactivate()
            rec, t0, xruns = tester.rec[:, 0].copy(), tester.t0, list(tester.xruns)
    finally:
        out, err = _stop(proc, tester)
    return rec, at, t0, xruns, out, err, proc.returncode


_CLOSE_UNDER_CONTENTION = r"""
import sys, threading, time
from synth.io.live.jack import JackPlayer

class Spinner(threading.Thread):
    # stands where the rehearsal stands: a thread of ours that holds the
    # interpreter's lock most of the time, stopped by the player's close()
    def __init__(self):
        super().__init__(daemon=True)
        self.halt = threading.Event()
    def stop(self):
        self.halt.set()
    def tick(self):
        return False
    def run(self):
        while not self.halt.is_set():
            sum(range(2000))

for i in range(int(sys.argv[2])):
    p = JackPlayer("biwa", name=f"gate{i}", server=sys.argv[1], warm_every_ms=0)
    p.start()
    cycle = p._cycle
    def slow_cycle(frames, cycle=cycle):
        # about a millisecond of Python in the process thread, as a loaded
        # machine's cycle: the cycle is in progress when close() comes
        sum(range(20000))
        cycle(frames)
    p._cycle = slow_cycle
    p.rehearsal = Spinner()
    p.rehearsal.start()
    time.sleep(0.2)
    p.close()
    print("closed", i, flush=True)
"""


@pytest.mark.slow  # over 2 s on a quiet 2-core machine
def test_close_while_the_callback_and_another_thread_want_the_lock(server, tmp_path):
    """JACK2's deactivate cancels the process thread; one cancelled inside
    the Python callback (waiting for the interpreter's lock that another
    thread of ours holds) left the process hung for ever (a full-suite run,
    2026-12-01).  The player closes its gate and stops its threads first: four
    closes under contention all return.  Without the order, about four
    closes in five hang (synth.io.live.gate)."""
    script = tmp_path / "close.py"
    script.write_text(_CLOSE_UNDER_CONTENTION)
    proc = subprocess.Popen([sys.executable, str(script), server, "4"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        out, err = proc.communicate(timeout=90)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, err = proc.communicate()
        raise AssertionError(f"a close hung: {out!r}") from None
    assert proc.returncode == 0 and "Exception" not in err, err[-2000:]
    assert [f"closed {i}" in out for i in range(4)] == [True] * 4, out


def test_a_stalled_machine_is_told_from_a_slow_synth():
    """The rule of :func:`_skip_if_the_machine_stalled`: it skips only
    when the server woke more than a period late and the synth's audio
    thread never ran over its budget in CPU time."""
    report = ("100 blocks of 128 at 48000 Hz; block time worst 300.0%, 99th percentile 90.0%, "
              "mean 40.0% of the budget, 3 blocks over it ({} in the audio thread's CPU time, "
              "whose worst is 80.0%); 0 underruns")
    late, early = [("play", 1000, 3000.0)], [("play", 1000, 40.0)]
    with pytest.raises(pytest.skip.Exception):
        _skip_if_the_machine_stalled(report.format(0), late, 128 / FS, "")
    _skip_if_the_machine_stalled(report.format(2), late, 128 / FS, "")      # the synth's own
    _skip_if_the_machine_stalled(report.format(0), early, 128 / FS, "")     # no stall
    _skip_if_the_machine_stalled("no report", late, 128 / FS, "")           # nothing to tell by
