"""Stress the real-time callback: per-block render time against the budget.

    NUMBA_NUM_THREADS=1 python tools/bench_live.py [--blocks 64,128,256] [--repeats 3]
                                                   [--seconds S] [--host-seconds S] [--host-only]
    NUMBA_NUM_THREADS=1 python tools/bench_live.py --program-change
    NUMBA_NUM_THREADS=1 python tools/bench_live.py --shedding
    (each also with --cpu-name {host,haswell,generic,all})

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

``--cpu-name`` picks numba's code-generation target (``tools/cpu_target.py``:
host, haswell = AVX2 only, generic = SSE2, or all three in turn); the header
names the CPU and the target in effect.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import cpu_target  # noqa: E402  (tools/, on sys.path when run as a script)
from synth.engine.engine import Event  # noqa: E402
from synth.engine.realtime import Realtime  # noqa: E402
from synth.io.midi import midi_to_events, read_midi_file  # noqa: E402
from synth.io.factory import build_engine  # noqa: E402

SHARED = Path(__file__).resolve().parents[2] / "shared"
if not SHARED.is_dir():
    SHARED = Path("/work/shared")


class Clock:
    t = 0.0

    def __call__(self):
        return self.t


def drive(preset: str, events, seconds: float, block: int, polyphony: int,
          shedding: bool = False, **rt_kw):
    """Play ``events`` through the callback; returns (block times, most
    voices, callback errors, voices shed).  ``shedding``: with the live
    player's default overload rule (``rt_kw`` changing it) instead of none."""
    # warmed as the live player does before the stream opens
    eng = build_engine(preset, polyphony=polyphony, warm=True, block=block)
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
    ap.add_argument("--seconds", type=float, default=None,
                    help="limit each performance to this many seconds (default: whole)")
    cpu_target.add_cpu_option(ap)
    a = ap.parse_args(argv)
    blocks = [int(b) for b in a.blocks.split(",")]
    if a.repeats < 3:
        ap.error(f"--repeats = {a.repeats} is out of range (value >= 3)")
    rc = cpu_target.dispatch(a.cpu_name, argv)
    if rc is not None:
        return rc

    print(f"# {time.strftime('%Y-%m-%d %H:%M')}  one core")
    print(f"# command: python {' '.join(sys.argv)}")
    print(cpu_target.describe())
    # warm-up: compile/load every kernel before timing
    drive("grand-piano", [Event(0.0, "note_on", 60, 0.8)], 0.2, 128, 8)
    drive("sitar", [Event(0.0, "note_on", 60, 0.8)], 0.2, 128, 8)
    over, und, worst, worst_cpu = host_noise(a.host_seconds)
    print(f"# host: a constant loop at 50 % of a 128-sample budget, {a.host_seconds:g} s: {over} "
          f"blocks over budget, {und} underruns, worst {worst:.1f}x its median "
          f"(in the thread's own CPU time: {worst_cpu:.1f}x)")
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
    perfs = [
        ("rac_op23_5.mid x2, grand-piano (64 voices)", "grand-piano", piece("rac_op23_5.mid", 2.0), 64),
        ("hp956bx4547_exp.mid x2, grand-piano (64 voices)", "grand-piano",
         piece("hp956bx4547_exp.mid", 2.0), 64),
        ("8-note chords every 125 ms, pedal down, grand-piano (64 voices)", "grand-piano",
         dense_chords(), 64),
        ("128-note cluster, sitar (128 voices)", "sitar", cluster, 128),
    ]
    if a.shedding:
        print("\n| performance | voices shed, block 128, default overload rule | "
              "the same without the lateness condition (max_late=0) | blocks |")
        print("|---|---|---|---|")
        for label, preset, evs, poly in perfs:
            dur = max(e.time_s for e in evs) + 1.0 if preset != "sitar" else 5.0
            if a.seconds:
                dur = min(dur, a.seconds)
            t, _, _, shed = drive(preset, evs, dur, 128, poly, shedding=True)
            _, _, _, shed0 = drive(preset, evs, dur, 128, poly, shedding=True, max_late=0.0)
            print(f"| {label} | {shed} | {shed0} | {len(t)} |", flush=True)
        return 0
    print(f"\n| performance | block | worst | 99th pct | mean | blocks over budget | "
          f"underruns, 2-period device | per repeat ({a.repeats}) | most voices |")
    print("|---|---|---|---|---|---|---|---|---|")
    for label, preset, evs, poly in perfs:
        dur = max(e.time_s for e in evs) + 1.0 if preset != "sitar" else 5.0
        if a.seconds:
            dur = min(dur, a.seconds)
        for b in blocks:
            runs = [drive(preset, evs, dur, b, poly) for _ in range(a.repeats)]
            budget = b / 48000
            r = stats(np.median([r[0] for r in runs], axis=0), budget)
            each = ",".join(str(stats(r[0], budget)["underruns"]) for r in runs)
            most = max(r[1] for r in runs)
            print(f"| {label} | {b} | {r['worst'] * 100:.0f}% | {r['p99'] * 100:.0f}% | "
                  f"{r['mean'] * 100:.0f}% | {r['over']} of {r['blocks']} | {r['underruns']} | "
                  f"{each} | {most} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
