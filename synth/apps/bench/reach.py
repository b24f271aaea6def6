"""What skipping a termination out of the string's reach saves (issue 13).

Usage
-----
    NUMBA_NUM_THREADS=1 python tools/bench.py reach [--runs 7] [--seconds 30]
    NUMBA_NUM_THREADS=1 python tools/bench.py reach --callgrind [--seconds 30]
    python tools/bench.py reach --onset          # when the skip starts, per treble key,
                                                 # and what the energy bound would skip;
                                                 # which sitar strings it skips

The kernel's fast path skips a chunk's termination region when no point of
it can touch the obstacle (``synth.kernels.strings._out_of_reach``); with
``StringBank.skip_unreachable = False`` every region runs.  Both give the
same samples (checked here on every scene: the two renders' outputs must
be identical, else the tool fails).

Scenes (each rendered as ``synth render`` / ``synth note`` render them):

* ``treble``: the grand's capo-bar keys 73, 79, 85, 91, 97, 103 and 108,
  one note each (a fresh engine per note, velocity 80), ``--seconds`` /
  5 of each;
* ``chopin``: the first ``--seconds`` of ../shared/midi/chpn_op25_e11.mid on
  ``grand-piano`` (the etude's right hand runs in the treble);
* ``sitar-buzz-0.2`` and ``sitar``: the first ``--seconds`` of
  ButchersMarchiiThe.mid on ``sitar`` at ``termination.buzz`` = 0.2 and as
  shipped (1: the played strings graze their jawari and reach it; what is
  skipped there is the taraf's and the chikari's);
* ``sitar-alone``: the same without taraf and chikari
  (``taraf.coupling = 0``): the played strings alone;
* ``biwa``: the same tune on ``biwa`` (the sawari);
* ``case1``: the thesis's jawari Case 1 string (``paper/sitar-case1``,
  lossless, 812 cells) for ``--seconds`` / 10: the bound lets almost none
  of its chunks off (``--onset`` counts them), so the test's cost is all
  there is to see.

Timing: each run renders a scene with the skip, then without it, in one
process, timed by the process's CPU time (``time.process_time``: on a
machine running other work a render's wall time grows while it waits for
a core, its CPU time hardly does); the figure is the median over
``--runs`` of the ratio of the two times (skip / run), with its range.
``--callgrind`` counts instructions instead (load-independent): each
scene under ``valgrind
--tool=callgrind``, with the skip and without it, counting the render
alone (the instrumentation switched on and off around it with
``callgrind_control``), in the AVX2 ("haswell") build of
:mod:`synth.apps.cpu_target` (valgrind runs no AVX-512) compiled outside
valgrind first.
"""

from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from synth.apps import cpu_target  # noqa: E402
from synth.apps.bench import harness  # noqa: E402

ROOT = Path(__file__).resolve().parents[3]  # the checkout
TREBLE_KEYS = (73, 79, 85, 91, 97, 103, 108)
SCENES = ("treble", "chopin", "sitar-buzz-0.2", "sitar", "sitar-alone", "biwa", "case1")


def shared_midi() -> Path:
    for d in (ROOT.parent / "shared" / "midi", Path("/work/shared/midi")):
        if d.is_dir():
            return d
    raise SystemExit("../shared/midi: not found (the workplace's MIDI files)")


def audio_s(scene: str, seconds: float) -> float:
    """The audio (s) a scene renders for ``--seconds``."""
    return seconds / 10 if scene == "case1" else seconds


def render_scene(scene: str, seconds: float, skip: bool):
    """(output samples, render time in s) of ``scene`` with or without the skip."""
    from synth.dsp.bank import StringBank

    StringBank.skip_unreachable = skip
    try:
        if scene == "case1":
            from synth.engine.engine import Event
            from synth.io.factory import build_engine

            e = build_engine("paper/sitar-case1")
            t0 = time.process_time()
            y = e.render([Event(0.0, "note_on", -1, 1.0)], duration_s=seconds / 10)
            return np.ravel(y), time.process_time() - t0
        if scene == "treble":
            from synth.engine.engine import Event
            from synth.io.factory import build_engine

            out, t = [], 0.0
            for k in TREBLE_KEYS:
                e = build_engine("grand-piano")
                t0 = time.process_time()
                out.append(e.render([Event(0.0, "note_on", k, 80 / 127)], duration_s=seconds / 5))
                t += time.process_time() - t0
            return np.concatenate([np.ravel(y) for y in out]), t
        import soundfile as sf

        from synth.apps.render import RenderRequest, render_midi

        f, preset, sets = {"chopin": ("chpn_op25_e11.mid", "grand-piano", ()),
                           "sitar-buzz-0.2": ("ButchersMarchiiThe.mid", "sitar",
                                              ("termination.buzz=0.2",)),
                           "sitar": ("ButchersMarchiiThe.mid", "sitar", ()),
                           "sitar-alone": ("ButchersMarchiiThe.mid", "sitar",
                                           ("taraf.coupling=0",)),
                           "biwa": ("ButchersMarchiiThe.mid", "biwa", ())}[scene]
        with tempfile.TemporaryDirectory() as tmp:
            out = os.path.join(tmp, "x.wav")
            t0 = time.process_time()
            render_midi(RenderRequest(midi_file=str(shared_midi() / f), preset=preset,
                                      output=out, overrides=sets, max_seconds=seconds))
            t = time.process_time() - t0
            y, _ = sf.read(out, dtype="float32")
        return np.ravel(y), t
    finally:
        StringBank.skip_unreachable = True


def timing(scenes, seconds: float, runs: int) -> bool:
    print(f"| scene | audio (s) | render with the skip (CPU s, median) | without (CPU s, median) "
          f"| ratio skip / run, median (range) | identical |")
    print("|---|---:|---:|---:|---|---|")
    ok = True
    for sc in scenes:
        render_scene(sc, 0.5, True)               # compile / warm
        render_scene(sc, 0.5, False)
        ta, tb, same = [], [], True
        for _ in range(runs):
            ya, a = render_scene(sc, seconds, True)
            yb, b = render_scene(sc, seconds, False)
            ta.append(a)
            tb.append(b)
            same &= bool(np.array_equal(ya, yb))
        r = np.array(ta) / np.array(tb)
        print(f"| {sc} | {audio_s(sc, seconds):g} | {statistics.median(ta):.3f} | {statistics.median(tb):.3f} "
              f"| {np.median(r):.3f} ({r.min():.3f}-{r.max():.3f}) | {'yes' if same else 'NO'} |",
              flush=True)
        ok &= same
    return ok


# ---- instruction counts ------------------------------------------------------------------
def _child_cmd(scene, seconds, skip):
    return harness.child_command("reach", ["--child", scene, "--seconds", str(seconds),
                                           "--skip", "1" if skip else "0"])


def _ir(path: Path) -> int:
    """The instructions a callgrind output counted ("totals:"; its
    "summary:" is 0 when the instrumentation started off)."""
    for line in path.read_text(errors="replace").splitlines():
        m = re.match(r"totals:\s+(\d+)", line)
        if m:
            return int(m.group(1))
    raise SystemExit(f"{path}: no instruction total")


def callgrind_window(cmd, out: Path, env, what: str, **popen_kw) -> str:
    """Run ``cmd`` under callgrind, counting only the window the child opens:
    valgrind starts with the instrumentation off; the child loads and warms
    up, says "ready" and waits; ``callgrind_control -i on`` and a line on
    its stdin start the measured work; it prints one line and waits again
    while the instrumentation goes off.  Returns that line (``what`` names
    the child in the error if it fails).  Also used by
    tools/bench.py callgrind."""
    p = subprocess.Popen(["valgrind", "--tool=callgrind", "--instr-atstart=no",
                          f"--callgrind-out-file={out}", *cmd, "--wait"],
                         env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                         **popen_kw)
    try:
        assert p.stdout.readline().strip() == "ready"
        subprocess.run(["callgrind_control", "-i", "on", str(p.pid)], check=True,
                       stdout=subprocess.DEVNULL)
        p.stdin.write("go\n")
        p.stdin.flush()
        reply = p.stdout.readline().strip()
        subprocess.run(["callgrind_control", "-i", "off", str(p.pid)], check=True,
                       stdout=subprocess.DEVNULL)
        p.stdin.write("end\n")
        p.stdin.flush()
        if p.wait(timeout=3600) != 0:
            raise SystemExit(f"the callgrind child of {what} failed")
    finally:
        if p.poll() is None:
            p.kill()
    return reply


def _callgrind_render(scene, seconds, skip, env, out: Path):
    """One render under callgrind, counted from its start to its end only
    (:func:`callgrind_window`; the child's line is the output's digest).
    Returns (instructions, digest)."""
    digest = callgrind_window(_child_cmd(scene, seconds, skip), out, env, scene)
    return _ir(out), digest


def callgrind(scenes, seconds: float) -> bool:
    env = harness.child_environ(cpu_target.environ_for("haswell"))
    env["NUMBA_NUM_THREADS"] = "1"
    env["PYTHONHASHSEED"] = "0"
    print(f"| scene | audio (s) | render instructions with the skip | without | ratio | saved "
          f"| identical |")
    print("|---|---:|---:|---:|---:|---:|---|")
    ok = True
    with tempfile.TemporaryDirectory() as tmp:
        for sc in scenes:
            # compile (or load) the AVX2 build outside valgrind
            subprocess.run(_child_cmd(sc, 0.5, True), env=env, check=True, stdout=subprocess.DEVNULL)
            a, da = _callgrind_render(sc, seconds, True, env, Path(tmp) / f"{sc}-skip.out")
            b, db = _callgrind_render(sc, seconds, False, env, Path(tmp) / f"{sc}-run.out")
            same = da == db
            ok &= same
            print(f"| {sc} | {audio_s(sc, seconds):g} | {a / 1e9:.3f} G | {b / 1e9:.3f} G | {a / b:.4f} "
                  f"| {100 * (1 - a / b):.2f} % | {'yes' if same else 'NO'} |", flush=True)
    return ok


def child(scene: str, seconds: float, skip: bool, wait: bool = False) -> int:
    """One render (``--callgrind``'s unit): prints a digest of the output
    (``wait``: "ready" first, then the render after a line on stdin, then
    a line more before leaving)."""
    import hashlib

    render_scene(scene, 0.05, skip)               # load the compiled kernels
    if wait:
        print("ready", flush=True)
        sys.stdin.readline()
    y, _ = render_scene(scene, seconds, skip)
    print(hashlib.sha256(np.ascontiguousarray(y).tobytes()).hexdigest(), flush=True)
    if wait:
        sys.stdin.readline()
    return 0


# ---- when the skip starts ------------------------------------------------------------------
def energy_bound_skips(ring: np.ndarray, U: np.ndarray, side: int) -> bool:
    """Whether the string's energy, now, keeps it off the obstacle: with D
    the sum of the squared steps around the ring (the waveguide string's
    energy is (T / dx) D), u(n) is a sum of the 2n steps from vl(n) through
    x = 0 to u_r(n), so u(n)^2 <= 2 n D (Cauchy-Schwarz): out of reach when
    2 n D < (side U(n))^2 at every point.  An instant only: D is no bound
    over a block (the hammer, the unison's bridge, the loop filter's
    allpasses and a bend line put energy into the ring)."""
    D = float(np.sum((ring - np.roll(ring, 1)) ** 2))
    v = side * np.asarray(U, float)
    fin = np.isfinite(v)
    n = np.arange(1, len(v) + 1)
    return bool(np.all(v[fin] > 0) and np.all(2 * n[fin] * D < v[fin] ** 2))


def onset(keys, velocities, seconds: float = 2.0, step_s: float = 0.005) -> None:
    """For each key and velocity, a note alone: every ``step_s`` the played
    strings' next free chunk is tested (:func:`strings._out_of_reach` on the
    bank's state); the time from which every test skips, and the share of
    tests that skip over the note's first ``seconds``; beside it, the share
    the string's energy would allow at the same instants
    (:func:`energy_bound_skips`)."""
    from synth.engine.engine import Event
    from synth.io.factory import build_engine
    from synth.kernels import strings as K

    print("| key | velocity | regions tested | skipped | always skipped from (ms) "
          "| the energy bound would skip |")
    print("|---|---:|---:|---:|---:|---:|")
    for key in keys:
        for vel in velocities:
            e = build_engine("grand-piano")
            e.schedule([Event(0.0, "note_on", key, vel / 127)])
            n_block = max(1, int(round(step_s * e.fs_out)))
            t_all, n_t, n_s, n_e, t = None, 0, 0, 0, 0.0
            while t < seconds:
                e.render_block(n_block)
                t += n_block / e.fs_out
                b = e.bank
                hit = []
                for s in b.active[: b.n_active]:
                    s = int(s)
                    R = int(b.ipar[s, K.I_REG_N])
                    C = int(b.ipar[s, K.I_CHUNK_FREE])
                    if R == 0 or C <= 0:
                        continue
                    off, P = int(b.ipar[s, K.I_OFF]), 2 * int(b.ipar[s, K.I_N])
                    hit.append(K._out_of_reach(b.ring, off, P, int(b.ipar[s, K.I_POS]),
                                               C, R, float(b.fpar[s, K.F_REACH])))
                    ro = int(b.ipar[s, K.I_REG_OFF])
                    n_e += energy_bound_skips(b.ring[off:off + P], b.U[ro:ro + R],
                                              int(b.ipar[s, K.I_SIDE]))
                n_t += len(hit)
                n_s += sum(hit)
                if hit and all(hit):
                    t_all = t if t_all is None else t_all
                else:
                    t_all = None
            print(f"| {key} | {vel} | {n_t} | {100 * n_s / max(n_t, 1):.1f} % | "
                  f"{'never' if t_all is None else f'{t_all * 1e3:.0f}'} "
                  f"| {100 * n_e / max(n_t, 1):.0f} % |", flush=True)


def _skips(b, s, K) -> bool:
    """Whether slot s's next free chunk would skip its region (False: no region)."""
    R = int(b.ipar[s, K.I_REG_N])
    C = int(b.ipar[s, K.I_CHUNK_FREE])
    return R > 0 and C > 0 and K._out_of_reach(b.ring, int(b.ipar[s, K.I_OFF]),
                                               2 * int(b.ipar[s, K.I_N]), int(b.ipar[s, K.I_POS]),
                                               C, R, float(b.fpar[s, K.F_REACH]))


def case1_share(seconds: float = 3.0, step_s: float = 0.025) -> None:
    """The ``case1`` scene's string tested every ``step_s`` over ``seconds``."""
    from synth.engine.engine import Event
    from synth.io.factory import build_engine
    from synth.kernels import strings as K

    e = build_engine("paper/sitar-case1")
    e.schedule([Event(0.0, "note_on", -1, 1.0)])
    v, t = [], 0.0
    while t < seconds:
        n = max(1, int(round(step_s * e.fs_out)))
        e.render_block(n)
        t += n / e.fs_out
        v += [_skips(e.bank, int(s), K) for s in e.bank.active[: e.bank.n_active]]
    print(f"The jawari Case 1 string (scene case1), tested every {step_s * 1e3:g} ms over "
          f"{seconds:g} s: {sum(v)} of {len(v)} tests skipped.")


def sitar_share(seconds: float = 1.0, step_s: float = 0.025) -> None:
    """The sitar (two notes, keys 62 and 67 at 0 and 0.5 s) at buzz 1 and
    0.2: every ``step_s`` each string with a region is tested as in
    :func:`onset`; the share skipped, for the played strings and for
    those ringing along on the bridge (taraf and chikari)."""
    from synth.engine.engine import Event
    from synth.io.factory import build_engine
    from synth.kernels import strings as K

    print("| buzz | strings | regions tested | skipped |")
    print("|---|---|---:|---:|")
    for buzz in (1.0, 0.2):
        e = build_engine("sitar", (f"termination.buzz={buzz}",))
        e.schedule([Event(0.0, "note_on", 62, 0.8), Event(0.5, "note_on", 67, 0.6)])
        played, res, t = set(), {}, 0.0
        while t < seconds:
            n = max(1, int(round(step_s * e.fs_out)))
            e.render_block(n)
            t += n / e.fs_out
            b = e.bank
            for vo in e.voices.values():          # the notes' own strings
                played.update(int(x) for x in vo.slots)
            for s in b.active[: b.n_active]:
                s = int(s)
                R = int(b.ipar[s, K.I_REG_N])
                C = int(b.ipar[s, K.I_CHUNK_FREE])
                if R == 0:
                    continue
                ok = C > 0 and K._out_of_reach(b.ring, int(b.ipar[s, K.I_OFF]),
                                               2 * int(b.ipar[s, K.I_N]), int(b.ipar[s, K.I_POS]),
                                               C, R, float(b.fpar[s, K.F_REACH]))
                res.setdefault(s, []).append(ok)
        for label, pick in (("played", lambda s: s in played),
                            ("ringing along (taraf, chikari)", lambda s: s not in played)):
            v = [x for s, xs in res.items() if pick(s) for x in xs]
            print(f"| {buzz:g} | {label} | {len(v)} | {100 * sum(v) / max(len(v), 1):.1f} % |")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=7)
    ap.add_argument("--seconds", type=float, default=30.0)
    ap.add_argument("--scenes", default=",".join(SCENES))
    ap.add_argument("--callgrind", action="store_true", help="count instructions under valgrind")
    ap.add_argument("--onset", action="store_true", help="when the skip starts, per treble key")
    ap.add_argument("--child", default=None, help=argparse.SUPPRESS)
    ap.add_argument("--skip", type=int, default=1, help=argparse.SUPPRESS)
    ap.add_argument("--wait", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.child:
        return child(a.child, a.seconds, bool(a.skip), a.wait)
    scenes = [s for s in a.scenes.split(",") if s]
    bad = [s for s in scenes if s not in SCENES]
    if bad:
        raise SystemExit(f"--scenes: {bad} not in {SCENES}")
    print(f"# {time.strftime('%Y-%m-%d %H:%M')}  NUMBA_NUM_THREADS={os.environ.get('NUMBA_NUM_THREADS')}")
    print(harness.header())
    if a.onset:
        onset(TREBLE_KEYS, (20, 80, 127))
        print()
        sitar_share()
        print()
        case1_share()
        return 0
    ok = callgrind(scenes, a.seconds) if a.callgrind else timing(scenes, a.seconds, a.runs)
    if not ok:
        print("FAIL: the skip changed a render's samples", file=sys.stderr)
    return 0 if ok else 1
