"""Stress the real-time callback: per-block render time against the budget.

    python tools/bench.py live [--blocks 64,128,256] [--threads 1,2] [--repeats 3]
                               [--perfs rac,roll,chords,cluster]
                               [--seconds S] [--host-seconds S] [--host-only]
    python tools/bench.py live --program-change
    python tools/bench.py live --shedding
    (each also with --cpu-name {host,haswell,generic,all}; --quick: a short run for CI)
    python tools/bench.py live --jack [--server NAME] [--notes 24] [--runs 3] [--idle S] [--quick]
    python tools/bench.py live --jack --voices 32 [--cycles 3] [--runs 3]

Drives :class:`synth.engine.realtime.Realtime` exactly as the audio device
would (``callback(outdata, frames, ...)``), as fast as it can, and times every
block.  A block slower than its budget (block / 48 kHz) would be an underrun
on a live stream.  Shedding is off (``overload=None``), so the numbers are the
full performance's cost.  Performances:

1. the densest piano file in ../shared/midi (Rachmaninoff op. 23/5: 3861
   notes in 197 s, up to 29 keys sounding with the pedal) at double speed on
   ``grand-piano`` (polyphony 64);
2. the Paderewski roll (Chopin op. 25/9, up to 48 keys with the pedal) at
   double speed on ``grand-piano``;
3. 64 piano voices with dense attacks on ``grand-piano`` (polyphony 64):
   sustain pedal down, a chord of 8 random keys (A0+7 .. E7, velocity
   0.5-1) every 125 ms for 12 s, so the pool is full after one second and
   every chord then steals 8 voices;
4. a 128-note cluster on ``sitar``: its 32 playable keys on 4 MIDI channels,
   all struck within 50 ms and held (polyphony 128), i.e. 128 terminated
   plucked voices with their loop filters and pitch-bend lines.

``--shedding`` instead plays each performance once at block 128 with the
live player's default overload rule (``Realtime``'s defaults) and prints
how many voices it shed, and how many the rule sheds without its lateness
condition (``max_late=0``: two slow blocks in a row are enough).

``--program-change`` instead measures a program change while playing: 48
sitar voices sound, paced by the clock as a device would (block 128), and
after 0.27 s a background thread builds ``grand-piano`` from scratch (its
88 key designs, as the live player does on a program change), at Python's
default thread switch interval (5 ms), at 0.5 ms and at the live player's
(``synth.io.live.SWITCH_INTERVAL_S``); 3 plays of 4 s each.

For each and each block size: worst, 99th-percentile and mean block time as
a fraction of the budget, blocks over budget, the underruns a device holding
two periods would have had (a slow block eats into the buffered period, fast
ones refill it), and the most voices sounding.

Each performance is played ``--repeats`` times (at least 3).  The renders
are deterministic, so a block's cost is the *median* of its times over the
repeats; the host's stalls (the line after the header: a constant numba loop
timed the same way stalls at random for up to 10-20x its time on a shared
vCPU) do not come back at the same block in most repeats.  The table gives
the statistics of those per-block medians, and the underruns of every
single repeat beside them ("per repeat").

``--jack`` plays ``synth play --jack --preset grand-piano`` (a subprocess,
launched, waited for and connected as tests/test_jack.py does) through a
JACK server: a dummy ``jackd`` at 48 kHz, period ``--period`` (128),
started here, or a running one (``--server NAME``).  The tool's own JACK
client sends ``--notes`` single notes (spread over the keyboard and the
velocities, 0.45 s apart, at every offset in the period) through JACK MIDI
at known frames and captures the synth's audio; each note's onset is found
by cross-correlation with the same note rendered offline (the engine's
latency removed), as the test does.  It prints the notes found (normalised
correlation >= 0.9), the MIDI-to-sound latency (median, in ms and samples;
the measuring loop's own period, which JACK adds to a client's output fed
back to a client that feeds it, stated separately), the spread (95th minus
5th percentile) and the server's xruns the tool's client saw, by phase:
its activation, its connection to the synth, a settling second, the play;
and the synth's own count (its report, from its activation on).
``--voices 32`` instead plays, with the pedal down, 4 chords of 8 keys
(32 keys spread over C1 .. G7) 0.25 s apart, held 1.5 s (``--cycles``
times), and counts the xruns during play, each with the chord it followed.
``--runs`` plays each in a fresh synth process (default 3).

First, a client that does nothing sits on the server for ``--idle``
seconds (default 20): the xruns it sees are the server's own.  A dummy
``jackd`` on a shared VM reports them with no work to do (its timer wakes
late and every client is then "not finished"; a C client, ``jack_iodelay``,
sees as many), so the xrun count alone cannot tell what the synth caused.
The synth's share is its blocks over budget: a process call that takes
longer than the period it plays for (its report), in wall time and in
the audio thread's CPU time (its own work; the difference is time the
thread did not run), printed beside the targets with the idle client's
count.

``--cpu-name`` picks numba's code-generation target (:mod:`synth.apps.bench.harness`:
host, haswell = AVX2 only, generic = SSE2, or all three in turn); the header
names the CPU and the target in effect.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np  # noqa: E402

from synth.apps.bench import harness  # noqa: E402
from synth.engine.engine import Event  # noqa: E402
from synth.engine.realtime import Realtime  # noqa: E402
from synth.io.midi import midi_to_events, read_midi_file  # noqa: E402
from synth.io.factory import build_engine  # noqa: E402
from synth.io.live.loopback import Loopback  # noqa: E402  (imports jack only when used)

SHARED = Path(__file__).resolve().parents[4] / "shared"
if not SHARED.is_dir():
    SHARED = Path("/work/shared")


class Clock:
    t = 0.0

    def __call__(self):
        return self.t


def drive(preset: str, events, seconds: float, block: int, polyphony: int,
          shedding: bool = False, threads: int = 1, **rt_kw):
    """Play ``events`` through the callback on ``threads`` threads; returns
    (block times, most voices, callback errors, voices shed).
    ``shedding``: with the live player's default overload rule (``rt_kw``
    changing it) instead of none."""
    # warmed as the live player does before the stream opens, its threads
    # governed with the real-time budget (synth.io.live.ready_engine)
    from synth.dsp.threads import Governor

    eng = build_engine(preset, polyphony=polyphony, warm=True, block=block, threads=threads)
    Governor.realtime_dt_s = 1.0 / float(eng.fs_in_exact)
    clock = Clock()
    rt = Realtime(eng, block=block, clock=clock, **rt_kw) if shedding else \
        Realtime(eng, block=block, clock=clock, overload=None)
    rt.start(0.0)
    events = sorted(events, key=lambda e: e.time_s)
    out = np.zeros((block, 1), dtype=np.float32)
    n_blocks = int(seconds * eng.fs_out / block)
    times = np.zeros(n_blocks)
    most = 0
    i = 0
    for b in range(n_blocks):
        clock.t = b * block / eng.fs_out
        while i < len(events) and events[i].time_s <= clock.t:
            rt.push(events[i], events[i].time_s)
            i += 1
        t = time.perf_counter()
        rt.callback(out, block, None, None)
        times[b] = time.perf_counter() - t
        most = max(most, eng.n_voices)
    rt.stop()
    return times, most, rt.stats.errors, rt.stats.shed_voices


def stats(times, budget):
    f = times / budget
    return dict(worst=f.max(), p99=np.percentile(f, 99), mean=f.mean(),
                over=int(np.sum(f > 1.0)), blocks=len(times),
                underruns=device_underruns(times, budget, periods=2))


def host_noise(seconds=10.0, block_s=128 / 48000, load=0.5):
    """The host's own stalls: a constant numba loop calibrated to ``load`` of
    a block's budget, timed ``seconds / block_s`` times like the callback.
    Returns (blocks over budget, underruns of a 2-period device, worst /
    median wall time, worst / median thread CPU time)."""
    from numba import njit

    @njit(nogil=True)
    def spin(n):
        s = 0.0
        for i in range(n):
            s += (i * 1e-9) ** 1.0001
        return s

    spin(10)
    n = 100_000
    t = time.perf_counter()
    spin(n)
    n = max(1, int(n * load * block_s / (time.perf_counter() - t)))
    m = int(seconds / block_s)
    times = np.zeros(m)
    cpu = np.zeros(m)
    for b in range(m):
        t = time.perf_counter()
        c = time.thread_time()
        spin(n)
        cpu[b] = time.thread_time() - c
        times[b] = time.perf_counter() - t
    return (int(np.sum(times > block_s)), device_underruns(times, block_s, 2),
            times.max() / np.median(times), cpu.max() / np.median(times))


def _spin(pause_s: float) -> None:
    """Keep this thread busy for ``pause_s`` seconds touching nothing else
    (a loop reading the clock)."""
    t9 = time.perf_counter()
    while time.perf_counter() - t9 < pause_s:
        pass


def page_touch_us(pauses_s=(0.0, 0.01, 0.1, 1.0), pages: int = 2000, repeats: int = 3,
                  size_mb: int = 64) -> list:
    """What memory left alone costs to read again: ``pages`` pages of a
    ``size_mb`` MB array (random, one byte each) read after the thread
    spun ``pause`` seconds touching nothing else, per pause of
    ``pauses_s`` (median of ``repeats``).  Returns [(pause_s, us per
    page)].  On a machine with no such cost every pause reads a few ns a
    page; where the host ages a guest's pages (a VM) a page left for a
    second can cost microseconds, and a note-on, whose Python touches
    thousands of pages that no block touched since the last note, pays it
    in the audio thread."""
    a = np.ones(size_mb << 20, dtype=np.uint8)
    idx = np.sort(np.random.default_rng(1).choice(a.size // 4096, pages, replace=False)) * 4096
    out = []
    for pause in pauses_s:
        r = []
        for _ in range(repeats):
            int(a[idx].sum())
            _spin(pause)
            t = time.perf_counter()
            int(a[idx].sum())
            r.append(time.perf_counter() - t)
        out.append((float(pause), float(np.median(r)) / pages * 1e6))
    return out


def call_after_us(pauses_s=(0.0, 0.1, 0.3), repeats: int = 3) -> list:
    """What code left alone costs to run again: one ``numpy.add`` of ten
    floats after the thread spun ``pause`` seconds (a loop reading the
    clock), per pause of ``pauses_s`` (median of ``repeats``).  Returns
    [(pause_s, us)].  A few hundred ns where nothing ages the process's
    memory; on this VM a millisecond or more after 0.3 s, which every
    code path a note-on takes pays once."""
    a = np.zeros(10)
    np.add(a, 1.0)
    out = []
    for pause in pauses_s:
        r = []
        for _ in range(repeats):
            _spin(pause)
            t = time.perf_counter()
            np.add(a, 1.0)
            r.append(time.perf_counter() - t)
        out.append((float(pause), float(np.median(r)) * 1e6))
    return out


def page_touch_line(quick: bool = False) -> str:
    """One header line of :func:`page_touch_us` and :func:`call_after_us`
    (``quick``: one of each per pause, 1.5 s in all)."""
    pt = page_touch_us((0.0, 0.1, 1.0), repeats=1) if quick else page_touch_us()
    ca = call_after_us(repeats=1) if quick else call_after_us()
    return ("# memory left alone, read again (2000 random pages of 64 MB, us a page): "
            + ", ".join(f"after {p:g} s {u:.3f}" for p, u in pt)
            + "; a numpy add of 10 floats (us): " + ", ".join(f"after {p:g} s {u:.1f}" for p, u in ca))


def program_change(switch_s: float, seconds: float = 4.0) -> np.ndarray:
    """Block times / budget of a sitar performance, paced in real time, with
    ``grand-piano`` built in a background thread from its 100th block."""
    import threading

    import synth.voices.grand as grand
    from synth.io.live import ready_engine

    old = sys.getswitchinterval()
    sys.setswitchinterval(switch_s)
    try:
        eng = build_engine("sitar", polyphony=64, warm=True)
        clock = Clock()
        rt = Realtime(eng, block=128, clock=clock, overload=None)
        rt.start(0.0)
        for i in range(48):
            rt.push(Event(0.0, "note_on", 43 + i % 32, 0.8, i // 32), 0.0)
        out = np.zeros((128, 1), dtype=np.float32)
        n = int(seconds * 48000 / 128)
        times = np.zeros(n)
        th = None
        t_start = time.perf_counter()
        for b in range(n):
            clock.t = b * 128 / 48000
            if b == 100:
                grand._DESIGNS.clear()           # design every key again
                th = threading.Thread(target=ready_engine, args=("grand-piano",), daemon=True)
                th.start()
            t = time.perf_counter()
            rt.callback(out, 128, None, None)
            times[b] = time.perf_counter() - t
            while time.perf_counter() - t_start < (b + 1) * 128 / 48000:
                time.sleep(0.0002)               # the device's clock
        rt.stop()
        if th is not None:
            th.join()
    finally:
        sys.setswitchinterval(old)
    return times


def dense_chords(seconds=12.0, every_s=0.125, size=8, seed=7):
    """Pedal down, then a chord of ``size`` random keys every ``every_s``."""
    rng = np.random.default_rng(seed)
    evs = [Event(0.0, "control", 64, 1.0)]
    t = 0.01
    while t < seconds:
        for key in rng.choice(np.arange(28, 101), size=size, replace=False):
            evs.append(Event(t, "note_on", int(key), float(rng.uniform(0.5, 1.0))))
            evs.append(Event(t + 0.1, "note_off", int(key), 0.0))
        t += every_s
    return evs


def device_underruns(times, budget, periods=2):
    """Underruns of a device holding ``periods`` blocks, fed by a callback
    that takes ``times[b]`` for block b: a slow block eats into the buffered
    periods, fast ones refill them; the buffer running dry is an underrun
    (the device then plays silence and the backlog is dropped)."""
    backlog = 0.0
    n = 0
    for t in times:
        backlog = max(0.0, backlog + t - budget)
        if backlog > (periods - 1) * budget:
            n += 1
            backlog = 0.0
    return n


def piece(name: str, speed: float):
    evs = midi_to_events(read_midi_file(SHARED / "midi" / name))
    return [Event(e.time_s / speed, e.kind, e.key, e.value, e.channel) for e in evs]


# -- live through a JACK server (--jack) ---------------------------------------------------
FS = 48_000


def _jack():
    import jack

    return jack


def start_jackd(name: str, period: int = 128):
    """``jackd -n NAME -d dummy -r 48000 -p PERIOD``, once a client can open on it."""
    from synth.io.live.loopback import start_dummy_server

    try:
        return start_dummy_server(name, FS, period)
    except RuntimeError as e:
        raise SystemExit(str(e)) from None


def synth_play(server: str, name: str, preset: str, seconds: float = 600.0, extra=()):
    """``synth play --jack`` in a subprocess on ``server`` (as tests/test_jack.py),
    with ``extra`` arguments."""
    import subprocess

    env = dict(os.environ, JACK_DEFAULT_SERVER=server)
    return subprocess.Popen([sys.executable, "-m", "synth.cli", "play", "--jack", "--preset", preset,
                             "--jack-name", name, "--seconds", str(seconds), *extra], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def wait_ports(client, prefix: str, n: int, proc, timeout: float = 180.0):
    from synth.io.live import loopback

    try:
        return loopback.wait_ports(client, prefix, n, proc, timeout)
    except RuntimeError as e:
        raise SystemExit(str(e)) from None


def connect(client, pairs, timeout: float = 30.0):
    from synth.io.live import loopback

    loopback.connect(client, pairs, timeout)


def parse_report(out: str) -> dict:
    """The synth's exit report: its JACK xruns, block times, notes, voices."""
    import re

    r = {}
    for key, pat in (("xruns", r"\n(\d+) JACK xruns"), ("notes", r"(\d+) notes,"),
                     ("voices", r"at most (\d+) voices"), ("worst", r"block time worst ([\d.]+)%"),
                     ("p99", r"99th percentile ([\d.]+)%"), ("mean", r"mean ([\d.]+)% of the budget"),
                     ("over", r"(\d+) blocks over it"),
                     ("over_cpu", r"\((\d+) in the audio thread's CPU time"),
                     ("worst_cpu", r"CPU time, whose worst is ([\d.]+)%"),
                     ("late", r"(\d+) late events"), ("errors", r"(\d+) errors,"),
                     ("shed", r"(\d+) voices shed")):
        m = re.search(pat, out)
        r[key] = None if m is None else float(m.group(1))
    return r


def note_plan(n: int, spacing_s: float = 0.45, hold_s: float = 0.2):
    """``n`` notes spread over the keyboard (C1 .. A#7) and velocities
    (30 .. 127), each ``spacing_s`` after the last (isolated: the one before
    is released ``spacing_s - hold_s`` earlier), at every offset within a
    period; the keys without dampers last.  Returns [(frame from the first note, key, velocity 1..127,
    hold frames)]."""
    from synth.physics.piano import grand_string

    notes = [(24 + (i * 29) % 83, 30 + (i * 41) % 98) for i in range(n)]   # keys 24 .. 106
    # the keys without dampers (89 up) ring on after their note-off: they
    # come last, each louder than the one before, so that no note is heard
    # under a louder one's ringing (a soft A1 after a loud D7 correlated 0.7)
    damped = [kv for kv in notes if grand_string(kv[0]).has_damper]
    free = sorted((kv for kv in notes if not grand_string(kv[0]).has_damper),
                  key=lambda kv: kv[1])
    plan = []
    for i, (key, vel) in enumerate(damped + free):
        at = int(i * spacing_s * FS) + (37 * i) % 128
        plan.append((at, key, vel, int(hold_s * FS)))
    return plan


def chord_plan(voices: int = 32, size: int = 8, every_s: float = 0.25, hold_s: float = 1.5,
               cycles: int = 3, rest_s: float = 1.0, low: int = 24, high: int = 103):
    """Pedal down and ``voices / size`` chords of ``size`` keys (``voices``
    distinct keys spread over ``low`` .. ``high``, interleaved) ``every_s``
    apart, so that ``voices`` voices sound at once; held ``hold_s``, then
    keys and pedal up and ``rest_s`` of rest; ``cycles`` times.  Returns
    ([(frame, bytes)], [(frame, keys)] of the chords, length in frames)."""
    keys = [low + int(round(i * (high - low) / (voices - 1))) for i in range(voices)]
    n_ch = -(-voices // size)
    chords = [keys[i::n_ch] for i in range(n_ch)]
    ev, marks = [], []
    t = 0
    for _ in range(cycles):
        ev.append((t, bytes([0xB0, 64, 127])))
        for c, ch in enumerate(chords):
            at = t + int(c * every_s * FS) + 17 * c
            marks.append((at, ch))
            for j, k in enumerate(ch):
                ev.append((at, bytes([0x90, k, 70 + (7 * j) % 50])))
        t_off = t + int(((n_ch - 1) * every_s + hold_s) * FS)
        ev += [(t_off, bytes([0x80, k, 64])) for k in keys] + [(t_off, bytes([0xB0, 64, 0]))]
        t = t_off + int(rest_s * FS)
    return ev, marks, t


def _pct_ms(x, q):
    return float(np.percentile(x, q)) / FS * 1e3


def jack_run(server: str, mode: str, n_notes: int, voices: int, preset: str, settle_s: float,
             name: str, cycles: int = 3, extra=()) -> dict:
    """One run: ``synth play --jack`` (with ``extra`` arguments) started,
    waited for and connected to the tool's client; then the notes (mode
    "notes") or the chords (mode "voices"), and the synth's report after
    SIGTERM."""
    import signal

    jack = _jack()
    proc = synth_play(server, name, preset, extra=extra)
    probe = None
    t_start = time.perf_counter()
    try:
        waiter = jack.Client("bench-waiter", no_start_server=True, servername=server)
        n_out = len(wait_ports(waiter, name, 2, proc)) - 1
        waiter.close()
        if mode == "notes":
            plan = note_plan(n_notes)
            length_s = plan[-1][0] / FS + 1.5
        else:
            evs, marks, length = chord_plan(voices, cycles=cycles)
            length_s = length / FS + 0.5
        probe = Loopback(server, n_out, length_s + settle_s + 1.5, rate=FS, name="bench")
        probe.client.activate()
        probe.phase = "connection"
        connect(probe.client, [(probe.midi_out, f"{name}:midi_in")]
                + [(f"{name}:out_{c + 1}", probe.ins[c]) for c in range(n_out)])
        probe.phase = "settle"
        time.sleep(settle_s)
        start = probe.client.last_frame_time + FS // 4
        if mode == "notes":
            onsets = []
            for at, key, vel, hold in plan:
                onsets.append((start + at, key, vel))
                probe.events += [(start + at, bytes([0x90, key, vel])),
                                 (start + at + hold, bytes([0x80, key, 64]))]
        else:
            probe.events = sorted(((start + at, b) for at, b in evs), key=lambda e: e[0])
        probe.phase = "play"
        time.sleep(length_s + 0.25)
        probe.phase = "end"
        probe.client.deactivate()
        rec, t0, xr = probe.rec, probe.t0, list(probe.xruns)
    finally:
        if probe is not None:
            probe.close()
        # (SIGTERM: a tool started in the background with & passes its
        # children SIGINT ignored, and synth play keeps it so)
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=120)
    rep = parse_report(out)
    res = {"synth": rep, "returncode": proc.returncode, "wall_s": time.perf_counter() - t_start,
           "xruns": xr, "start": start, "stderr": err.strip().splitlines()[-3:]}
    res["by_phase"] = {p: sum(1 for q, _, _ in xr if q == p)
                       for p in ("activation", "connection", "settle", "play", "end")}
    if mode == "notes":
        res.update(find_onsets(rec, t0, onsets, preset))
    else:
        # which chord each xrun of the play came after (frames after its onset)
        near = []
        for p, ft, _ in xr:
            if p != "play" or ft < 0:
                continue
            after = [(ft - (start + at), tuple(ch)) for at, ch in marks if ft >= start + at]
            near.append(min(after) if after else (ft - start, ()))
        res["near_chords"] = near
    return res


def find_onsets(rec, t0, onsets, preset: str) -> dict:
    """Each note's lag against the same note rendered offline (``synth
    note``'s engine, latency removed), as tests/test_jack.py: the lag (0 ..
    1023 samples after the note's frame) of the best dot product over
    0.1 s; found when the normalised correlation there is at least 0.9.
    The lag is refined to a fraction of a sample by the parabola through
    the correlation's peak."""
    from synth.io.factory import build_engine

    n = int(0.1 * FS)
    lags, corr, found = [], [], []
    refs = {}
    for at, key, vel in onsets:
        if (key, vel) not in refs:
            ref = build_engine(preset, ()).render([Event(0.0, "note_on", key, vel / 127)],
                                                  duration_s=0.15)
            refs[key, vel] = ref.mean(axis=1) if ref.ndim == 2 else ref
        ref = refs[key, vel][:n]
        seg = rec[at - t0:at - t0 + n + 1024].mean(axis=1).astype(np.float64)
        if len(seg) < n + 1024:
            lags.append(np.nan)
            corr.append(0.0)
            found.append(False)
            continue
        c = np.correlate(seg, ref, mode="valid")[:1024]
        L = int(np.argmax(c))
        frac = 0.0
        if 0 < L < len(c) - 1:
            y0, y1, y2 = c[L - 1], c[L], c[L + 1]
            den = y0 - 2 * y1 + y2
            frac = 0.5 * (y0 - y2) / den if den != 0 else 0.0
        a = seg[L:L + n]
        r = float(np.dot(a, ref) / np.sqrt(np.dot(a, a) * np.dot(ref, ref) + 1e-300))
        lags.append(L + frac)
        corr.append(r)
        found.append(r >= 0.9)
    lags, corr, found = np.array(lags), np.array(corr), np.array(found)
    return {"lags": lags, "corr": corr, "found": found, "keys": [k for _, k, _ in onsets],
            "vels": [v for _, _, v in onsets]}


def idle_xruns(server: str, seconds: float) -> int:
    """The xruns a JACK client that does nothing sees on ``server`` in
    ``seconds``: the server's own (a dummy backend on a shared VM reports
    them with no work to do: its timer wakes late, and every client is
    then "not finished"), the floor under any client's count."""
    jack = _jack()
    c = jack.Client("bench-idle", no_start_server=True, servername=server)
    n = [0]

    @c.set_process_callback
    def process(frames):
        pass

    @c.set_xrun_callback
    def xrun(delay_us):
        n[0] += 1

    c.activate()
    try:
        time.sleep(seconds)
    finally:
        c.deactivate()
        c.close()
    return n[0]


def _own_line(runs, idle, idle_s) -> str:
    """The synth's own share: its blocks over budget (a block that takes
    longer than the period it plays for is an xrun the synth caused),
    beside the xruns an idle client saw on the same server."""
    over = [r["synth"]["over"] for r in runs]
    cpu = [r["synth"]["over_cpu"] for r in runs]
    own = all(o is not None and o == 0 for o in cpu)
    floor = ("" if idle is None else
             f"; an idle client on this server: {idle} xruns in {idle_s:g} s")
    return (f"the synth's own work within the period in every block (the audio thread's CPU "
            f"time): {'yes' if own else 'NO'} ({cpu} over); in wall time {over} over{floor}")


def jack_main(a) -> int:
    import shutil

    period = a.period
    own = None
    server = a.server
    if server is None:
        if shutil.which("jackd") is None:
            raise SystemExit("jackd is not installed (Debian: apt-get install jackd2)")
        server = f"bench-live-{os.getpid()}"
        own = start_jackd(server, period)
    try:
        jack = _jack()
        c = jack.Client("bench-info", no_start_server=True, servername=server)
        rate, period = c.samplerate, c.blocksize
        c.close()
        if rate != FS:
            raise SystemExit(f"the JACK server {server!r} runs at {rate} Hz, not {FS}")
        loop_ms = period / FS * 1e3
        mode = "voices" if a.voices else "notes"
        print(f"# {time.strftime('%Y-%m-%d %H:%M')}  JACK server {server!r} "
              f"({'started here, ' if own else ''}{rate} Hz, period {period}); "
              f"command: python {' '.join(sys.argv)}")
        print(f"# {os.cpu_count()} CPUs; load average {' '.join(f'{x:.2f}' for x in os.getloadavg())} "
              "(other processes share them: the xruns are a noisy count)")
        idle_s = a.idle if a.idle is not None else (4.0 if a.quick else 20.0)
        idle = idle_xruns(server, idle_s) if idle_s > 0 else None
        if idle is not None:
            print(f"# the server alone: a client that does nothing saw {idle} xruns in {idle_s:g} s "
                  f"({idle / idle_s * 60:.0f} a minute; the floor under the synth's count)")
        print(page_touch_line(a.quick))
        runs = []
        warms = [None] if a.warm_every_ms is None else a.warm_every_ms
        plan = [(r, w) for r in range(a.runs) for w in warms]
        for i, (r, w) in enumerate(plan):
            name = f"synthbench{i}"
            extra = () if w is None else ("--warm-every-ms", f"{w:g}")
            res = jack_run(server, mode, a.notes, a.voices, a.preset, a.settle, name,
                           cycles=a.cycles, extra=extra)
            res["warm"] = w
            runs.append(res)
            rep, bp = res["synth"], res["by_phase"]
            xr_line = (f"xruns (the server's, seen by the tool's client): {bp['activation']} at its "
                       f"activation, {bp['connection']} at connection, {bp['settle']} in the "
                       f"{a.settle:g} s settle, {bp['play']} during play; the synth counted "
                       f"{rep['xruns']:.0f} in all (from its own activation)"
                       if rep["xruns"] is not None else "the synth's report has no xrun count")
            said = "" if w is None else f" (--warm-every-ms {w:g})"
            head = (f"\nrun {r + 1}/{a.runs}{said}: exit {res['returncode']}, {res['wall_s']:.0f} s; synth "
                    f"block time worst {rep['worst']}%, 99th pct {rep['p99']}%, mean {rep['mean']}%, "
                    f"{rep['over']} blocks over budget ({rep['over_cpu']} in its CPU time, whose "
                    f"worst is {rep['worst_cpu']}%), "
                    f"at most {rep['voices']} voices, {rep['late']} late events, {rep['errors']} "
                    f"errors, {rep['shed']} voices shed")
            print(head)
            print(xr_line)
            if res["returncode"] != 0:
                print("synth stderr: " + " | ".join(res["stderr"]))
            if mode == "notes":
                lags, found = res["lags"], res["found"]
                ok = lags[found]
                print(f"notes found: {int(found.sum())} of {len(found)}")
                if len(ok):
                    med = float(np.median(ok))
                    print(f"MIDI-to-sound latency (the loop's period included): median "
                          f"{med / FS * 1e3:.3f} ms = {med:.2f} samples; spread (95th - 5th pct) "
                          f"{_pct_ms(ok, 95) - _pct_ms(ok, 5):.4f} ms; min {ok.min():.2f}, max "
                          f"{ok.max():.2f} samples")
                    print(f"  of which the measuring loop's own period: {period} samples = "
                          f"{loop_ms:.2f} ms; the synth's own: {(med - period) / FS * 1e3:.3f} ms "
                          f"= {med - period:.2f} samples")
                miss = [(k, v, round(float(c), 3)) for k, v, c, f in
                        zip(res["keys"], res["vels"], res["corr"], found) if not f]
                if miss:
                    print(f"  not found (key, velocity, correlation): {miss}")
                play_x = [(ft - res["start"]) for p, ft, _ in res["xruns"] if p == "play"]
                if play_x:
                    print(f"  play xruns at frames after the first note: {play_x}")
            else:
                if res["near_chords"]:
                    print("  play xruns, (frames after the latest chord's onset, its keys): "
                          + "; ".join(f"({d}, {list(k)})" for d, k in res["near_chords"]))
        if len(warms) > 1:
            print("\n## by --warm-every-ms (runs alternated)")
            for w in warms:
                mine = [x for x in runs if x["warm"] == w]
                print(f"{w:g} ms: xruns during play {[x['by_phase']['play'] for x in mine]}; the "
                      f"synth's blocks over budget in its CPU time "
                      f"{[x['synth']['over_cpu'] for x in mine]}, worst "
                      f"{[x['synth']['worst_cpu'] for x in mine]} %; 99th pct "
                      f"{[x['synth']['p99'] for x in mine]} %")
        if a.runs > 1:
            print(f"\n## over {a.runs} runs")
            play = [r["by_phase"]["play"] for r in runs]
            early = [sum(r["by_phase"][p] for p in ("activation", "connection", "settle"))
                     for r in runs]
            syn = [r["synth"]["xruns"] for r in runs]
            print(f"xruns during play per run: {play} (median {np.median(play):g}); before play "
                  f"(activation, connection, settle): {early}; the synth's count: {syn}")
            if mode == "notes":
                meds = [float(np.median(r["lags"][r["found"]])) for r in runs if r["found"].any()]
                spreads = [_pct_ms(r["lags"][r["found"]], 95) - _pct_ms(r["lags"][r["found"]], 5)
                           for r in runs if r["found"].any()]
                print(f"notes found per run: {[int(r['found'].sum()) for r in runs]} of {a.notes}; "
                      f"median latency per run (ms): {[round(m / FS * 1e3, 3) for m in meds]}; "
                      f"spread per run (ms): {[round(s, 4) for s in spreads]}")
            else:
                print(f"synth worst block per run (% of the period): "
                      f"{[r['synth']['worst'] for r in runs]}; 99th pct: "
                      f"{[r['synth']['p99'] for r in runs]}; most voices: "
                      f"{[r['synth']['voices'] for r in runs]}")
        # the targets
        print("\n## targets")
        if mode == "notes":
            allf = all(bool(r["found"].all()) for r in runs)
            lat = [float(np.median(r["lags"][r["found"]])) / FS * 1e3 for r in runs if r["found"].any()]
            spr = [_pct_ms(r["lags"][r["found"]], 95) - _pct_ms(r["lags"][r["found"]], 5)
                   for r in runs if r["found"].any()]
            xr = [r["by_phase"]["play"] for r in runs]
            print(f"every note found: {'yes' if allf else 'NO'}; median latency <= 6.5 ms: "
                  f"{'yes' if lat and max(lat) <= 6.5 else 'NO'} ({max(lat) if lat else float('nan'):.3f}); "
                  f"spread <= 0.1 ms: {'yes' if spr and max(spr) <= 0.1 else 'NO'}; 0 xruns during play: "
                  f"{'yes' if max(xr) == 0 else 'NO'} ({xr})")
            print(_own_line(runs, idle, idle_s))
        else:
            xr = [r["by_phase"]["play"] for r in runs]
            vv = [r["synth"]["voices"] for r in runs]
            print(f"{a.voices} voices sounding: {'yes' if min(v or 0 for v in vv) >= a.voices else 'NO'} "
                  f"({vv}); 0 xruns at period {period}: {'yes' if max(xr) == 0 else 'NO'} ({xr})")
            print(_own_line(runs, idle, idle_s))
    finally:
        if own is not None:
            own.terminate()
            try:
                own.wait(timeout=10)
            except Exception:
                own.kill()
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--blocks", default="64,128,256")
    ap.add_argument("--repeats", type=int, default=3,
                    help="plays of each performance (>= 3); a block's cost is its median time")
    ap.add_argument("--host-seconds", type=float, default=10.0,
                    help="length of the host-noise probe (s, default 10)")
    ap.add_argument("--host-only", action="store_true",
                    help="run only the host-noise probe")
    ap.add_argument("--shedding", action="store_true",
                    help="count the voices the default overload rule sheds, block 128")
    ap.add_argument("--program-change", action="store_true",
                    help="measure a program change built in the background while playing")
    ap.add_argument("--threads", default=None,
                    help="thread counts to play each performance on, e.g. 1,2 (default: 1 "
                         "up to every core this process may use)")
    ap.add_argument("--perfs", default="rac,roll,chords,cluster",
                    help="performances to play: rac, roll, chords, cluster (default: all)")
    ap.add_argument("--seconds", type=float, default=None,
                    help="limit each performance to this many seconds (default: whole)")
    ap.add_argument("--quick", action="store_true",
                    help="a short run for CI: block 128, 2 s of each performance, 1 s host "
                         "probe; with --jack 8 notes (or one chord cycle) and one run")
    jk = ap.add_argument_group("live through JACK (--jack)")
    jk.add_argument("--jack", action="store_true",
                    help="play synth play --jack through a JACK server: latency, spread, xruns")
    jk.add_argument("--server", default=None,
                    help="a running JACK server's name (default: start a dummy jackd here)")
    jk.add_argument("--period", type=int, default=128,
                    help="the period of the jackd started here (default 128)")
    jk.add_argument("--preset", default="grand-piano")
    jk.add_argument("--notes", type=int, default=24, help="single notes sent (default 24)")
    jk.add_argument("--voices", type=int, default=0,
                    help="instead: chords of 8 so that this many voices sound at once (e.g. 32)")
    jk.add_argument("--cycles", type=int, default=3,
                    help="--voices: chord cycles (pedal down, chords, held, released; default 3)")
    jk.add_argument("--runs", type=int, default=3,
                    help="runs, each a fresh synth process (default 3)")
    jk.add_argument("--idle", type=float, default=None, metavar="S",
                    help="first, seconds of a client that does nothing on the server, whose "
                         "xruns are the server's own (default 20; --quick 4; 0: none)")
    jk.add_argument("--warm-every-ms", default=None, metavar="MS[,MS...]",
                    type=lambda t: [float(x) for x in t.split(",")],
                    help="synth play's --warm-every-ms; a list alternates the runs between its "
                         "values (e.g. 0,10; default: synth play's own)")
    jk.add_argument("--settle", type=float, default=1.0,
                    help="seconds between connecting and the first note (default 1)")
    harness.add_target_option(ap)
    a = ap.parse_args(argv)
    if a.quick:
        a.blocks, a.seconds, a.host_seconds = "128", 2.0, 1.0
        a.notes, a.runs, a.cycles = min(a.notes, 8), 1, 1
    blocks = [int(b) for b in a.blocks.split(",")]
    if a.jack:
        if a.notes < 1 or a.runs < 1 or a.cycles < 1 or a.voices < 0:
            ap.error("--notes, --runs and --cycles must be >= 1, --voices >= 0")
        return jack_main(a)
    if a.repeats < 3:
        ap.error(f"--repeats = {a.repeats} is out of range (value >= 3)")
    rc = harness.dispatch("live", a.cpu_name, argv)
    if rc is not None:
        return rc

    from synth.dsp import threads as threads_mod

    n_max = threads_mod.default_threads()
    try:
        counts = ([int(t) for t in a.threads.split(",")] if a.threads
                  else list(range(1, n_max + 1)))
        for t in counts:
            threads_mod.check_threads(t, "--threads")
    except ValueError as e:
        ap.error(str(e))
    names = [p.strip() for p in a.perfs.split(",")]
    bad = [p for p in names if p not in ("rac", "roll", "chords", "cluster")]
    if bad:
        ap.error(f"--perfs = {bad[0]!r} is not a performance (rac, roll, chords, cluster)")
    print(f"# {time.strftime('%Y-%m-%d %H:%M')}  threads {','.join(map(str, counts))} "
          f"({threads_mod.available_cores()} cores available)")
    print(f"# command: python {' '.join(sys.argv)}")
    print(harness.header())
    # warm-up: compile/load every kernel before timing
    for t in counts:
        drive("grand-piano", [Event(0.0, "note_on", 60, 0.8)], 0.2, 128, 8, threads=t)
        drive("sitar", [Event(0.0, "note_on", 60, 0.8)], 0.2, 128, 8, threads=t)
    over, und, worst, worst_cpu = host_noise(a.host_seconds)
    print(f"# host: a constant loop at 50 % of a 128-sample budget, {a.host_seconds:g} s: {over} "
          f"blocks over budget, {und} underruns, worst {worst:.1f}x its median "
          f"(in the thread's own CPU time: {worst_cpu:.1f}x)")
    print(page_touch_line(a.quick))
    if a.host_only:
        return 0
    if a.program_change:
        from synth.io.live import SWITCH_INTERVAL_S

        budget = 128 / 48000
        print("\n| switch interval | worst | 99th pct | mean | blocks over budget | "
              "underruns, 2-period device | per play (3) |")
        print("|---|---|---|---|---|---|---|")
        for sw in (0.005, 0.0005, SWITCH_INTERVAL_S):
            runs = [program_change(sw) for _ in range(3)]
            r = stats(np.median(runs, axis=0), budget)
            each = ",".join(str(stats(t, budget)["underruns"]) for t in runs)
            print(f"| {sw * 1e3:g} ms | {r['worst'] * 100:.0f}% | {r['p99'] * 100:.0f}% | "
                  f"{r['mean'] * 100:.0f}% | {r['over']} of {r['blocks']} | {r['underruns']} | "
                  f"{each} |", flush=True)
        return 0
    # 128 voices in the sitar's range: its 32 keys (43-74) on 4 MIDI channels
    cluster = [Event(0.0004 * i, "note_on", 43 + i % 32, 0.8, i // 32) for i in range(128)]
    perfs = {
        "rac": ("rac_op23_5.mid x2, grand-piano (64 voices)", "grand-piano",
                lambda: piece("rac_op23_5.mid", 2.0), 64),
        "roll": ("hp956bx4547_exp.mid x2, grand-piano (64 voices)", "grand-piano",
                 lambda: piece("hp956bx4547_exp.mid", 2.0), 64),
        "chords": ("8-note chords every 125 ms, pedal down, grand-piano (64 voices)",
                   "grand-piano", dense_chords, 64),
        "cluster": ("128-note cluster, sitar (128 voices)", "sitar", lambda: cluster, 128),
    }
    perfs = [(lbl, pre, mk(), poly) for lbl, pre, mk, poly in (perfs[n] for n in names)]
    if a.shedding:
        print("\n| performance | voices shed, block 128, default overload rule | "
              "the same without the lateness condition (max_late=0) | blocks |")
        print("|---|---|---|---|")
        for label, preset, evs, poly in perfs:
            dur = max(e.time_s for e in evs) + 1.0 if preset != "sitar" else 5.0
            if a.seconds:
                dur = min(dur, a.seconds)
            t, _, _, shed = drive(preset, evs, dur, 128, poly, shedding=True, threads=counts[-1])
            _, _, _, shed0 = drive(preset, evs, dur, 128, poly, shedding=True, max_late=0.0,
                                   threads=counts[-1])
            print(f"| {label} | {shed} | {shed0} | {len(t)} |", flush=True)
        return 0
    print(f"\n| performance | block | threads | worst | 99th pct | mean | blocks over budget | "
          f"underruns, 2-period device | per repeat ({a.repeats}) | most voices |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for label, preset, evs, poly in perfs:
        dur = max(e.time_s for e in evs) + 1.0 if preset != "sitar" else 5.0
        if a.seconds:
            dur = min(dur, a.seconds)
        for b in blocks:
            # the thread counts alternate within each repeat (a noisy spell
            # of the host then falls on all of them alike)
            runs = {t: [] for t in counts}
            for _ in range(a.repeats):
                for t in counts:
                    runs[t].append(drive(preset, evs, dur, b, poly, threads=t))
            budget = b / 48000
            for t in counts:
                r = stats(np.median([r[0] for r in runs[t]], axis=0), budget)
                each = ",".join(str(stats(r[0], budget)["underruns"]) for r in runs[t])
                most = max(r[1] for r in runs[t])
                print(f"| {label} | {b} | {t} | {r['worst'] * 100:.0f}% | {r['p99'] * 100:.0f}% | "
                      f"{r['mean'] * 100:.0f}% | {r['over']} of {r['blocks']} | {r['underruns']} | "
                      f"{each} | {most} |", flush=True)
    return 0
