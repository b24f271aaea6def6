"""Whole-pipeline benchmark: the cost of ``synth render`` per voice per internal sample.

    python tools/bench.py render [--voices 1,8,32,128] [--presets sitar,biwa,grand-piano]
                                 [--long-s 12] [--short-s 2] [--runs 3] [--window-s 1]
                                 [--quick] [--cpu-name {host,haswell,generic,all}]

For each preset and each number N of held voices, a MIDI file is written
(mido) in which N notes start at t = 0 and are held to t = T, where they are
released and all sound is cut (CC 120 on every channel, so the render ends
0.5 s later, as ``synth render`` adds a 0.5 s tail).  The notes are N distinct
playable keys spread evenly over the preset's ``play.key_low .. key_high``;
N above the number of keys uses several MIDI channels (the engine tells
voices apart by (channel, key)), the keys divided evenly between them.  The
presets are overridden so that every voice sounds to the end and none is
stolen: ``play.polyphony=N``; for presets with a ``loss`` section (sitar,
biwa) ``loss.t60_low_s=120`` and ``loss.t60_high_s=60``; for the grand
``strings.t60_scale=5`` (the largest allowed: five times the per-key decay
times; the keys are held, so the dampers are off and the sustain pedal
would change nothing).  Even so the grand's top keys fall below the
engine's silence level during a long render (at t60_scale 5, keys above
about 84 within 12 s), and their strings are freed: the figures are per
voice and string *sounding*, counted in the engine (see "sounding (a)").

Two measurements:

a. ``synth render CASE.mid --preset P --set ... -o OUT.wav`` in a subprocess
   (``NUMBA_NUM_THREADS=1``; the numba cache already warm from an untimed
   render), for T = ``--long-s`` and T = ``--short-s``, ``--runs`` times
   each, alternating.  The difference of the medians cancels start-up
   (imports, cache loading, preset, key designs, note-ons, attacks, tail);
   what remains is the render of the interval from ``--short-s`` to
   ``--long-s``.
b. In this process, the same preset, overrides and note-ons (not the
   release at T), with the engine built by ``synth.io.factory.build_engine`` as
   ``synth render`` builds it, rendered in 1024-sample output blocks (as
   ``Engine.render``): untimed to t = ``--short-s``; then timed to t =
   ``--long-s``, counting the voices and strings sounding in every block
   (the renders are deterministic, so these are the child's too); then,
   ``--runs`` times: the engine for ``--window-s`` of output, the kernel
   alone on the same bank (``engine.bank.render`` on the bank's active
   strings, for exactly the internal samples of the engine's blocks), and
   an engine of the same preset with no voice for as many blocks.  Medians.

Columns of the table (one table per preset)
-------------------------------------------
voices : int
    N, the held notes in the MIDI file (and ``play.polyphony``).
ch : int
    MIDI channels the notes use.
sounding (a) : str
    Voices / strings sounding (``engine.n_voices`` / ``engine.bank.n_active``)
    at the start and the end of (a)'s interval, "v/s..v/s" if they changed
    (grand: strings and then voices of the top keys fall silent).
render wall : float, ns per voice-sample
    (a): median wall-clock time of the long render minus that of the short
    one, divided by the internal samples between them (the difference of
    the WAV lengths times fs_in / fs_out) and by the mean number of voices
    sounding over the interval (from b).
± : float, ns per voice-sample
    Spread of the render wall figure: half the sum of the ranges (max - min)
    of the long and the short wall times, on the same scale (empty with one
    run).  Start-up varies by ~0.1-0.3 s on a busy machine, so with few
    voices or a short interval the figure is mostly noise.
render cpu : float, ns per voice-sample
    (a): the same from the child's user + system CPU time
    (``resource.getrusage(RUSAGE_CHILDREN)`` differences).
engine (a) : float, ns per voice-sample
    (b): the in-process engine's time over (a)'s interval, on the same
    scale: the render without start-up, WAV writing or noise from it.
sounding (b) : str
    Voices / strings sounding at the end of the (b) windows.
engine : float, ns per voice-sample
    (b): the engine's block loop (``Engine.render_block``: bank, decimator,
    body, voice bookkeeping, silence scan) per voice sounding and internal
    sample.
kernel : float, ns per voice-sample
    (b): ``StringBank.render`` alone on the same strings, same samples.
engine/str, kernel/str : float, ns per string-sample
    The same two per string sounding and internal sample; equal to the
    per-voice figures for the one-string voices of the plucked presets.
idle : float, ns per internal sample
    (b): the engine with no voice (decimator, body, bookkeeping): the fixed
    cost per internal sample, shared by all voices.
engine/kernel : float
    engine time / kernel time in the same windows (dimensionless).
render/kernel : float
    render wall (a) / kernel (b), both per string-sample (the grand's mix of
    strings per voice differs between (a)'s interval and the later (b)
    windows; dimensionless).

The issue's target: 32 held sitar voices within 1.3x of the kernel figure
(checked on both ratios when the case is run).

``--quick``: N = 1, 8, T = 1.5 s and 0.5 s, 1 run, 0.2 s window: a smoke
test of the tool.  Its (a) figures are start-up noise (one second of a few
voices costs less than the start-up varies) and may even be negative; its
(b) figures are short but sound.  ``--cpu-name`` picks numba's code-generation
target for this process and the renders (:mod:`synth.apps.cpu_target`).
"""

from __future__ import annotations

import os
import sys

if "numba" not in sys.modules:
    # one core; only before numba is imported (imported by a test, after numba
    # started its threads, a changed NUMBA_NUM_THREADS fails the next compile)
    os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import argparse  # noqa: E402
import datetime  # noqa: E402
import math  # noqa: E402
import resource  # noqa: E402
import shlex  # noqa: E402
import subprocess  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import mido  # noqa: E402
import numpy as np  # noqa: E402
import soundfile  # noqa: E402

from synth.apps.bench import harness  # noqa: E402
from synth.io.factory import build_engine  # noqa: E402
from synth.io.midi import midi_to_events, read_midi_file  # noqa: E402
from synth.io.presets import load_preset  # noqa: E402

BLOCK = 1024                  # output samples per engine block, as Engine.render
VELOCITY = 100
TICKS_PER_BEAT = 960
TEMPO_US = 500_000            # 120 bpm: one beat = 0.5 s
TAIL_S = 0.5                  # synth render's tail after the last sound


# ---- the cases ----------------------------------------------------------------------------------
def spread_keys(lo: int, hi: int, n: int) -> list[tuple[int, int]]:
    """``n`` notes as (channel, key): distinct keys spread evenly over
    lo..hi on as few channels as hold them, divided evenly between them."""
    n_keys = hi - lo + 1
    n_ch = max(1, math.ceil(n / n_keys))
    if n_ch > 16:
        raise ValueError(f"{n} voices need {n_ch} MIDI channels (at most 16)")
    out = []
    for c in range(n_ch):
        m = n // n_ch + (1 if c < n % n_ch else 0)
        keys = np.linspace(lo, hi, m).round().astype(int) if m > 1 else [round((lo + hi) / 2)]
        out += [(c, int(k)) for k in keys]
    assert len(set(out)) == n
    return out


def overrides_for(preset_name: str, n: int) -> list[str]:
    """``--set`` values that keep N held voices sounding, none stolen
    (checked by loading the preset with them)."""
    base = load_preset(preset_name)
    ov = [f"play.polyphony={max(n, 1)}"]
    if getattr(base, "loss", None) is not None:
        ov += ["loss.t60_low_s=120", "loss.t60_high_s=60"]
    elif getattr(base, "strings", None) is not None:
        ov += ["strings.t60_scale=5"]
    load_preset(preset_name, ov)          # every path exists and every value is valid
    return ov


def write_midi(path: Path, notes, hold_s: float) -> None:
    """Note-ons at 0 for every (channel, key), note-offs and CC 120 (all
    sound off) on every channel at ``hold_s``."""
    mf = mido.MidiFile(type=0, ticks_per_beat=TICKS_PER_BEAT)
    tr = mido.MidiTrack()
    mf.tracks.append(tr)
    tr.append(mido.MetaMessage("set_tempo", tempo=TEMPO_US, time=0))
    for ch, key in notes:
        tr.append(mido.Message("note_on", channel=ch, note=key, velocity=VELOCITY, time=0))
    dt = int(round(hold_s * 1e6 / TEMPO_US * TICKS_PER_BEAT))
    for i, (ch, key) in enumerate(notes):
        tr.append(mido.Message("note_off", channel=ch, note=key, velocity=64,
                               time=dt if i == 0 else 0))
    for ch in sorted({c for c, _ in notes}):
        tr.append(mido.Message("control_change", channel=ch, control=120, value=0, time=0))
    tr.append(mido.MetaMessage("end_of_track", time=0))
    mf.save(str(path))


def synth_command() -> list[str]:
    """The ``synth`` command of this environment."""
    exe = Path(sys.executable).parent / "synth"
    if exe.is_file():
        return [str(exe)]
    return [sys.executable, "-m", "synth.cli"]


# ---- (a) synth render in a subprocess ----------------------------------------------------------
def render_once(cmd: list[str], env: dict, wav: Path) -> tuple[float, float, int]:
    """(wall s, child CPU s, output frames) of one ``synth render``."""
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run(cmd, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode != 0:
        raise RuntimeError(f"{shlex.join(cmd)} failed ({p.returncode}):\n{p.stderr}")
    cpu = (r1.ru_utime + r1.ru_stime) - (r0.ru_utime + r0.ru_stime)
    return wall, cpu, soundfile.info(str(wav)).frames


def subprocess_case(cmds: dict, env: dict, wav: Path, runs: int):
    """Median (wall, cpu) of the long and short renders, their frames, and
    the spread of the wall times (half the sum of the two ranges, s)."""
    res = {"long": [], "short": []}
    frames = {}
    for _ in range(runs):
        for which in ("long", "short"):
            w, c, f = render_once(cmds[which], env, wav)
            res[which].append((w, c))
            frames[which] = f
    med = {k: np.median(np.array(v), axis=0) for k, v in res.items()}
    spread = sum(float(np.ptp([w for w, _ in v])) for v in res.values()) / 2 if runs > 1 else None
    return med, frames, spread


def source_stamp() -> float:
    """Latest modification time of synth's sources: a change while a case
    runs means a render may have compiled its kernels again."""
    import synth

    return max(p.stat().st_mtime for p in Path(synth.__file__).parent.rglob("*.py"))


# ---- (b) in process ---------------------------------------------------------------------------
def in_process_case(preset_name: str, overrides: list[str], midi_path: Path, hold_s: float,
                    short_s: float, long_s: float, window_s: float, runs: int):
    """The in-process measurements of a case (see the module doc): the voices
    and strings sounding over (a)'s interval, the engine's time over it, then
    engine, kernel and no-voice engine over the same windows."""
    events = [e for e in midi_to_events(read_midi_file(midi_path)) if e.time_s < hold_s]
    keys = [int(e.key) for e in events if e.kind == "note_on"]
    eng = build_engine(preset_name, overrides, extra_low_key=min(keys))
    idle = build_engine(preset_name, overrides, extra_low_key=min(keys))
    eng.schedule(events)
    bank = eng.bank
    # to the start of (a)'s interval, untimed
    for _ in range(max(1, int(round(short_s * eng.fs_out / BLOCK)))):
        eng.render_block(BLOCK)
    at_short = (eng.n_voices, bank.n_active)
    # (a)'s interval: what sounds in it (the renders are deterministic) and
    # the engine's time for it (the reads of two counters per block included)
    n_a = max(1, int(round(long_s * eng.fs_out / BLOCK)) - int(round(short_s * eng.fs_out / BLOCK)))
    samples_a = voice_a = string_a = 0
    t = time.perf_counter()
    for _ in range(n_a):
        t0 = eng.time_in
        eng.render_block(BLOCK)
        n = eng.time_in - t0
        samples_a += n
        voice_a += eng.n_voices * n
        string_a += bank.n_active * n
    t_a = time.perf_counter() - t
    at_long = (eng.n_voices, bank.n_active)
    for _ in range(20):
        idle.render_block(BLOCK)
    # (b): engine, then kernel alone on the same strings, then the empty engine
    n_blocks = max(1, int(round(window_s * eng.fs_out / BLOCK)))
    t_eng, t_ker, t_idle = [], [], []
    samples = string_samples = voice_samples = 0
    mix = np.zeros_like(eng.mix)
    for _ in range(runs):
        n_in = np.zeros(n_blocks, dtype=np.int64)
        t = time.perf_counter()
        for b in range(n_blocks):
            t0 = eng.time_in
            eng.render_block(BLOCK)
            n_in[b] = eng.time_in - t0
        t_eng.append(time.perf_counter() - t)
        # voices and strings: read after the timed loop, the window being
        # short against the decay
        string_samples += bank.n_active * int(n_in.sum())
        voice_samples += eng.n_voices * int(n_in.sum())
        samples += int(n_in.sum())
        t = time.perf_counter()
        for n in n_in.tolist():
            bank.render(mix, 0, n)
        t_ker.append(time.perf_counter() - t)
        t = time.perf_counter()
        for _ in range(n_blocks):
            idle.render_block(BLOCK)
        t_idle.append(time.perf_counter() - t)
    if not np.all(np.isfinite(mix)):
        raise RuntimeError(f"{preset_name}: non-finite kernel output")
    return dict(t_eng=float(np.median(t_eng)), t_ker=float(np.median(t_ker)),
                t_idle=float(np.median(t_idle)), samples=samples / runs,
                strings=string_samples / samples, voices=voice_samples / samples,
                window=(eng.n_voices, bank.n_active),
                t_a=t_a, samples_a=samples_a, voices_a=voice_a / samples_a,
                strings_a=string_a / samples_a, at_short=at_short, at_long=at_long,
                fs_in=eng.fs_in, fs_out=eng.fs_out, stolen=eng.n_stolen + eng.n_dropped)


# ---- output -------------------------------------------------------------------------------------
def fmt_sounding(before, after) -> str:
    a = f"{before[0]}/{before[1]}"
    b = f"{after[0]}/{after[1]}"
    return a if a == b else f"{a}..{b}"


def per_ns(t_s: float, count: float, samples: float) -> float:
    """ns per (count x samples); nan if nothing sounded."""
    return t_s / (count * samples) * 1e9 if count > 0 and samples > 0 else float("nan")


def scaling(presets, voices, counts, long_s, short_s, runs) -> int:
    """The scaling table: ``synth render --threads T`` of the held-voice
    cases in a subprocess for each T (numba's pool not capped: no
    ``NUMBA_NUM_THREADS``), the long and short renders of every T
    alternated within each run; the wall-time difference per voice-sample
    and per string-sample (the strings counted in process at the long
    render's start), the speed-up against the first T, and whether every
    T wrote the same bytes.  From the speed-up S at T threads, the share
    of the work that stayed serial, s = (T / S - 1) / (T - 1) (Amdahl),
    and what that predicts for 4 and 8 threads, 1 / (s + (1 - s) / n)."""
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_NUM_THREADS", "SYNTH_THREADS")}
    synth = synth_command()
    print(f"# synth render scaling  {datetime.datetime.now().isoformat(timespec='seconds')}")
    print(f"# command : {shlex.join([os.path.basename(sys.executable)] + sys.argv)}")
    print(harness.header())
    print(f"# holds {long_s:g} s and {short_s:g} s (+{TAIL_S:g} s tail), {runs} run(s), "
          f"medians; wall-time differences, ns per voice-sample and per string-sample")
    with tempfile.TemporaryDirectory(prefix="bench_render_") as tmp:
        tmp = Path(tmp)
        for p in presets:
            pre = load_preset(p)
            for n in voices:
                notes = spread_keys(pre.play.key_low, pre.play.key_high, n)
                ov = overrides_for(p, n)
                sets = [x for o in ov for x in ("--set", o)]
                mids = {}
                for which, hold in (("long", long_s), ("short", short_s)):
                    mids[which] = tmp / f"{p}-{n}-{which}.mid"
                    write_midi(mids[which], notes, hold)
                wavs = {t: tmp / f"out-{t}.wav" for t in counts}
                cmds = {(t, k): synth + ["render", str(m), "--preset", p, *sets, "--threads",
                                         str(t), "-o", str(wavs[t])]
                        for t in counts for k, m in mids.items()}
                print(f"\n## {p}, {n} held voices: "
                      + shlex.join(["synth", "render", "CASE.mid", "--preset", p, *sets,
                                    "--threads", "T", "-o", "OUT.wav"]))
                eng = build_engine(p, ov, threads=1)
                eng.render(midi_to_events(read_midi_file(mids["short"])), duration_s=0.3)
                strings = eng.bank.n_active + (0 if eng.sym is None else eng.sym.bank.n_active)
                for t in counts:                       # fill numba's cache, untimed
                    render_once(cmds[t, "short"], env, wavs[t])
                res = {t: {"long": [], "short": []} for t in counts}
                frames = {}
                for _ in range(runs):
                    for t in counts:
                        for which in ("long", "short"):
                            w, _, f = render_once(cmds[t, which], env, wavs[t])
                            res[t][which].append(w)
                            frames[which] = f
                same = len({wavs[t].read_bytes() for t in counts}) == 1
                d_in = (frames["long"] - frames["short"]) * eng.fs_in / eng.fs_out
                print("\n| threads | render wall, ns/voice-sample | ± | ns/string-sample | "
                      "speed-up | long render, s | serial share | predicted 4 / 8 threads |")
                print("|---:|---:|---:|---:|---:|---:|---:|---|")
                base = None
                for t in counts:
                    lo, sh = np.array(res[t]["long"]), np.array(res[t]["short"])
                    dw = float(np.median(lo) - np.median(sh))
                    pm = (float(np.ptp(lo)) + float(np.ptp(sh))) / 2 if runs > 1 else float("nan")
                    base = dw if base is None else base
                    S = base / dw
                    ser = (t / S - 1) / (t - 1) if t > 1 else float("nan")
                    pred = "" if t == 1 else (f"{1 / (ser + (1 - ser) / 4):.2f} / "
                                              f"{1 / (ser + (1 - ser) / 8):.2f}")
                    print(f"| {t} | {per_ns(dw, n, d_in):.2f} | {per_ns(pm, n, d_in):.2f} | "
                          f"{per_ns(dw, strings, d_in):.2f} | {S:.2f} | {np.median(lo):.2f} | "
                          f"{'' if t == 1 else f'{ser:.3f}'} | {pred} |", flush=True)
                print(f"same bytes for every thread count: {'yes' if same else 'NO'}")
                if not same:
                    return 1
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--voices", default=None, help="held voices per case (default 1,8,32,128)")
    ap.add_argument("--presets", default="sitar,biwa,grand-piano")
    ap.add_argument("--long-s", type=float, default=None, help="long render's hold time (s, 12)")
    ap.add_argument("--short-s", type=float, default=None, help="short render's hold time (s, 2)")
    ap.add_argument("--runs", type=int, default=None, help="renders of each length (3)")
    ap.add_argument("--window-s", type=float, default=None,
                    help="in-process timed window per run (s of output, 1)")
    ap.add_argument("--quick", action="store_true",
                    help="smoke test: voices 1,8, holds 1.5 and 0.5 s, 1 run, 0.2 s window")
    ap.add_argument("--threads", default=None,
                    help="instead: the scaling table, synth render --threads T for each T of "
                         "this list (e.g. 1,2; 'all': 1 up to every core), voices default 32")
    harness.add_target_option(ap)
    a = ap.parse_args(argv)
    q = a.quick
    voices = [int(x) for x in (a.voices or ("1,8" if q else "32" if a.threads
                                            else "1,8,32,128")).split(",")]
    long_s = a.long_s if a.long_s is not None else (1.5 if q else 12.0)
    short_s = a.short_s if a.short_s is not None else (0.5 if q else 2.0)
    runs = a.runs if a.runs is not None else (1 if q else 3)
    window_s = a.window_s if a.window_s is not None else (0.2 if q else 1.0)
    presets = [p for p in a.presets.split(",") if p]
    if not (0 < short_s < long_s):
        ap.error(f"--short-s = {short_s} and --long-s = {long_s}: need 0 < short < long")
    if runs < 1 or window_s <= 0 or any(n < 1 for n in voices):
        ap.error("--runs, --window-s and --voices must be positive")
    for p in presets:
        load_preset(p)                        # unknown name: fail before anything runs
    if a.threads is not None:
        from synth.dsp import threads as threads_mod

        cores = threads_mod.available_cores()
        try:
            counts = (list(range(1, cores + 1)) if a.threads == "all"
                      else [int(t) for t in a.threads.split(",")])
        except ValueError:
            ap.error(f"--threads = {a.threads!r} is not a list of counts (e.g. 1,2 or all)")
        if any(not 1 <= t <= cores for t in counts):
            ap.error(f"--threads = {a.threads!r} is out of range (1 <= each <= {cores}, the "
                     f"cores this process may use)")
        rc = harness.dispatch("render", a.cpu_name, argv)
        if rc is not None:
            return rc
        return scaling(presets, voices, counts, long_s, short_s, runs)
    rc = harness.dispatch("render", a.cpu_name, argv)
    if rc is not None:
        return rc

    cmd = (f"NUMBA_NUM_THREADS={os.environ['NUMBA_NUM_THREADS']} "
           + shlex.join([os.path.basename(sys.executable)] + sys.argv))
    print(f"# synth render benchmark  {datetime.datetime.now().isoformat(timespec='seconds')}")
    print(f"# command : {cmd}")
    print(harness.header())
    print(f"# voices {','.join(map(str, voices))}; holds {long_s:g} s and {short_s:g} s "
          f"(+{TAIL_S:g} s tail), {runs} run(s) each, medians; in process: {window_s:g} s "
          f"windows from t = {long_s:g} s, {BLOCK}-sample blocks; ns per voice-sample "
          f"unless marked /str (per string-sample), idle per internal sample; see the "
          f"module docstring for the columns")
    synth = synth_command()
    env = dict(os.environ, NUMBA_NUM_THREADS="1")
    results = {}
    with tempfile.TemporaryDirectory(prefix="bench_render_") as tmp:
        tmp = Path(tmp)
        wav = tmp / "out.wav"
        for p in presets:
            pre = load_preset(p)
            lo, hi = pre.play.key_low, pre.play.key_high
            print(f"\n## {p}  (keys {lo}..{hi}, {pre.description})")
            shown = None
            rows = []
            warmed = None
            for n in voices:
                notes = spread_keys(lo, hi, n)
                ov = overrides_for(p, n)
                mids = {}
                for which, hold in (("long", long_s), ("short", short_s)):
                    mids[which] = tmp / f"{p}-{n}-{which}.mid"
                    write_midi(mids[which], notes, hold)
                sets = [x for o in ov for x in ("--set", o)]
                cmds = {k: synth + ["render", str(m), "--preset", p, *sets, "-o", str(wav)]
                        for k, m in mids.items()}
                if shown is None:
                    shown = shlex.join(["NUMBA_NUM_THREADS=1", *synth[:-1],
                                        os.path.basename(synth[-1]), "render", "CASE.mid",
                                        "--preset", p, *sets, "-o", "OUT.wav"])
                    shown = shown.replace(f"play.polyphony={n}", "play.polyphony=N")
                    print(f"# render  : {shown}  (N held voices)")
                stamp = source_stamp()
                ip = in_process_case(p, ov, mids["long"], long_s, short_s, long_s, window_s, runs)
                if warmed != source_stamp():   # fill numba's cache for the children, untimed
                    warmed = source_stamp()
                    render_once(cmds["short"], env, wav)
                med, frames, spread = subprocess_case(cmds, env, wav, runs)
                changed = source_stamp() != stamp
                d_in = (frames["long"] - frames["short"]) * ip["fs_in"] / ip["fs_out"]
                dw, dc = med["long"] - med["short"]
                S = ip["samples"]
                r = dict(
                    n=n, ch=len({c for c, _ in notes}), changed=changed, stolen=ip["stolen"],
                    sound_a=fmt_sounding(ip["at_short"], ip["at_long"]),
                    wall=per_ns(dw, ip["voices_a"], d_in), cpu=per_ns(dc, ip["voices_a"], d_in),
                    pm="" if spread is None else f"{per_ns(spread, ip['voices_a'], d_in):.2f}",
                    eng_a=per_ns(ip["t_a"], ip["voices_a"], ip["samples_a"]),
                    sound_b=f"{ip['window'][0]}/{ip['window'][1]}",
                    eng_v=per_ns(ip["t_eng"], ip["voices"], S),
                    ker_v=per_ns(ip["t_ker"], ip["voices"], S),
                    eng_s=per_ns(ip["t_eng"], ip["strings"], S),
                    ker_s=per_ns(ip["t_ker"], ip["strings"], S),
                    idle=per_ns(ip["t_idle"], 1, S),
                    ek=ip["t_eng"] / ip["t_ker"] if ip["strings"] > 0 else float("nan"))
                r["rk"] = per_ns(dw, ip["strings_a"], d_in) / r["ker_s"]
                rows.append(r)
                results[p, n] = r
            print("\n| voices | ch | sounding (a) | render wall | ± | render cpu | engine (a) "
                  "| sounding (b) | engine | kernel | engine/str | kernel/str | idle "
                  "| engine/kernel | render/kernel |")
            print("|---:|---:|---|---:|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|")
            for r in rows:
                print(f"| {r['n']} | {r['ch']} | {r['sound_a']} | {r['wall']:.2f} | {r['pm']} | "
                      f"{r['cpu']:.2f} | {r['eng_a']:.2f} | {r['sound_b']} | {r['eng_v']:.2f} | "
                      f"{r['ker_v']:.2f} | {r['eng_s']:.2f} | {r['ker_s']:.2f} | {r['idle']:.2f} | "
                      f"{r['ek']:.2f} | {r['rk']:.2f} |", flush=True)
            for r in rows:
                if r["stolen"]:
                    print(f"note: {p}, {r['n']} voices: {r['stolen']} voices stolen or dropped")
                if r["changed"]:
                    print(f"note: {p}, {r['n']} voices: synth's sources changed while the case "
                          f"ran; a render may have compiled its kernels (times include it)")
    if ("sitar", 32) in results:
        r = results["sitar", 32]
        print(f"\ntarget: 32 held sitar voices within 1.3x of the kernel: engine/kernel "
              f"{r['ek']:.2f} ({'met' if r['ek'] <= 1.3 else 'MISSED'}), render/kernel "
              f"{r['rk']:.2f} ({'met' if r['rk'] <= 1.3 else 'MISSED'})")
    return 0
