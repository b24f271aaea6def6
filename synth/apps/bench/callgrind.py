"""Instructions of a note's or a scene's sustain, per numba function (callgrind).

    NUMBA_NUM_THREADS=1 python tools/bench.py callgrind KEY [KEY ...] [--out DIR] [--top 40]
    NUMBA_NUM_THREADS=1 python tools/bench.py callgrind --preset sitar --voices 32 --block 1024

For each key (0: the engine with no note), in the AVX2 ("haswell") build
of :mod:`synth.apps.cpu_target` (``--cpu-name generic``: the SSE2 build;
valgrind cannot run the host's AVX-512 one): a warm-up run outside valgrind (compiles or
loads the kernels), then a child under ``valgrind --tool=callgrind
--instr-atstart=no``: an engine of the preset (``--preset``, default the
grand, polyphony 4) plays the key (velocity 0.8), renders 0.06 s of
blocks of ``--block`` output samples (default 256: 11 blocks), and the
instrumentation is on (``callgrind_control -i on/off``) for the next 0.1 s
of blocks (18 of 256, 31,200 engine samples; 4 of 1024).  Prints the total
and the functions' self and inclusive instructions and call counts.

``--voices N`` instead plays the scene of ``tools/bench.py render``: N
distinct keys spread over the preset's range, held, on an engine of
polyphony N with the render benchmark's overrides (the sitar's and biwa's
strings ring for 120 s, the grand's t60 x 5), so that none is stolen and
each sounds throughout (the sitar's one-thread cost by function, issue 37).

Numba's JIT code has no symbols in callgrind (``???:0x...``): the child
keeps the object code numba loads from its cache
(``CPUCodeLibrary._unserialize``, wrapped after :mod:`synth.kernels` has
installed its own load, which never calls an earlier wrapper), lists its symbols with ``nm -S`` and
writes each function's load address (that of a global symbol less its
offset) to ``DIR/NAME.out.syms``; the report maps callgrind's addresses
through it.  (So the cache must be warm: the warm-up run does that.)
"""

from __future__ import annotations

import argparse
import bisect
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path


from synth.apps import cpu_target
from synth.apps.bench import harness
from synth.apps.bench.reach import callgrind_window


def keep_object_code() -> dict:
    """From now on, the object code of every library numba loads from its
    cache, by the library's id (``CPUCodeLibrary._unserialize`` wrapped
    after :mod:`synth.kernels` has installed its own load, which never calls
    a wrapper installed before it)."""
    import importlib

    from numba.core import codegen as cg

    importlib.import_module("synth.kernels")
    objs = {}
    orig = cg.CPUCodeLibrary._unserialize.__func__

    def unser(cls, codegen, state):
        lib = orig(cls, codegen, state)
        if state[1] == "object":
            objs[id(lib)] = state[2][0]
        return lib

    cg.CPUCodeLibrary._unserialize = classmethod(unser)
    return objs


def write_symbols(objs: dict, syms: str) -> int:
    """Each loaded synth kernel's functions as ``address size name`` lines
    into ``syms`` (``nm -S`` of its object code, moved to where it was
    loaded); returns the lines written."""
    from numba.core.registry import CPUDispatcher

    seen = set()
    n = 0
    with open(syms, "w") as f:
        for mn, m in list(sys.modules.items()):
            if not mn.startswith("synth"):
                continue
            for o in list(vars(m).values()):
                if not isinstance(o, CPUDispatcher) or id(o) in seen:
                    continue
                seen.add(id(o))
                for cres in o.overloads.values():
                    obj = objs.get(id(cres.library))
                    if obj is None:
                        continue
                    with tempfile.NamedTemporaryFile(suffix=".o") as t:
                        t.write(obj)
                        t.flush()
                        nm = subprocess.run(["nm", "-S", "--defined-only", t.name],
                                            capture_output=True, text=True).stdout
                    rows = [p for p in (ln.split() for ln in nm.splitlines())
                            if len(p) == 4 and p[2] in "tTwW"]
                    base = None
                    for p in rows:
                        if p[2] == "T":
                            try:
                                base = cres.library.get_pointer_to_function(p[3]) - int(p[0], 16)
                                break
                            except Exception:
                                pass
                    if base is None:
                        continue
                    for p in rows:
                        f.write(f"{base + int(p[0], 16):x} {int(p[1], 16)} {p[3]}\n")
                        n += 1
    return n


def scene(preset: str, key: int, voices: int):
    """The engine and its note-ons: ``key`` on a polyphony-4 engine of
    ``preset`` (none for key 0), or ``voices`` > 0 held keys spread over
    the preset's range, as ``tools/bench.py render`` holds them
    (:func:`synth.apps.bench.render.spread_keys`, ``overrides_for``)."""
    from synth.engine.engine import Event
    from synth.io.factory import build_engine

    if voices <= 0:
        e = build_engine(preset, (), polyphony=4)
        return e, [Event(0.0, "note_on", key, 0.8)] if key else []
    from synth.apps.bench.render import overrides_for, spread_keys

    e = build_engine(preset, overrides_for(preset, voices))
    play = e.inst.preset.play
    notes = spread_keys(play.key_low, play.key_high, voices)
    return e, [Event(0.0, "note_on", k, 0.8, channel=c) for c, k in notes]


def child(key: int, wait: bool, syms: str, preset: str = "grand-piano", voices: int = 0,
          block: int = 256) -> None:
    objs = keep_object_code()
    e, events = scene(preset, key, voices)
    if events:
        e.schedule(events)
    for _ in range(max(1, int(0.06 * e.fs_out / block))):
        e.render_block(block)
    if wait:
        print("ready", flush=True)
        sys.stdin.readline()
    for _ in range(max(1, int(0.1 * e.fs_out / block))):
        e.render_block(block)
    if not wait:
        return
    print("done", flush=True)
    sys.stdin.readline()
    write_symbols(objs, syms)


def run(key: int, out: Path, env: dict, preset: str = "grand-piano", voices: int = 0,
        block: int = 256) -> int:
    what = f"{voices} voices of {preset}" if voices > 0 else f"key {key}"
    cmd = harness.child_command("callgrind", ["--child", str(key), "--preset", preset,
                                              "--voices", str(voices), "--block", str(block)])
    env = harness.child_environ(env)
    subprocess.run(cmd, env=env, check=True)
    env = dict(env, SYMS=str(out) + ".syms")
    reply = callgrind_window(cmd, out, env, what, stderr=subprocess.DEVNULL)
    if reply != "done":
        raise SystemExit(f"the callgrind child of {what} said {reply!r}, not 'done'")
    for line in out.read_text(errors="replace").splitlines():
        if line.startswith("totals:"):
            return int(line.split()[1])
    raise SystemExit(f"{out}: no total")


def report(out: Path, top: int) -> None:
    syms = sorted((int(a, 16), int(s), n) for a, s, n in
                  (ln.split() for ln in open(str(out) + ".syms")))
    starts = [s[0] for s in syms]
    names = {}

    def name(text):
        m = re.match(r"(?:\?\?\?:)?0x([0-9a-f]+)", text)
        if not m:
            return text[:70]
        a = int(m.group(1), 16)
        i = bisect.bisect_right(starts, a) - 1
        if i < 0 or a >= syms[i][0] + max(syms[i][1], 1):
            return text[:70]
        raw = syms[i][2]
        if raw not in names:
            n = subprocess.run(["c++filt", raw], capture_output=True, text=True).stdout.strip()
            names[raw] = re.sub(r"\[abi:[^\]]*\]", "", n).split("(")[0].replace("synth::kernels::", "")
        return names[raw]

    cost = {}
    for col, incl in ((0, "no"), (1, "yes")):
        txt = subprocess.run(["callgrind_annotate", f"--inclusive={incl}", "--threshold=100",
                              str(out)], capture_output=True, text=True).stdout
        for ln in txt.splitlines():
            m = re.match(r"\s*([\d,]+) \(\s*[\d.]+%\)\s+(.*)", ln)
            if m:
                c = cost.setdefault(name(m.group(2)), [0, 0])
                c[col] += int(m.group(1).replace(",", ""))
    # call counts from the raw file (name compression: "(id) name" the first time)
    ids, calls, cfn = {}, {}, None
    for ln in open(out, errors="replace"):
        if ln.startswith(("fn=", "cfn=")):
            m = re.match(r"c?fn=\((\d+)\)(?: (.*))?", ln.strip())
            if m.group(2):
                ids[m.group(1)] = m.group(2)
            if ln.startswith("cfn="):
                cfn = m.group(1)
        elif ln.startswith("calls="):
            n = name(ids.get(cfn, ""))
            calls[n] = calls.get(n, 0) + int(ln.split()[0][6:])
    print(f"{'self':>12} {'inclusive':>12} {'calls':>8}  function")
    for n, (s, i) in sorted(cost.items(), key=lambda kv: -kv[1][0])[:top]:
        print(f"{s:>12,} {i:>12,} {calls.get(n, ''):>8}  {n}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("keys", nargs="*", type=int)
    ap.add_argument("--out", default=None, help="directory for the callgrind outputs")
    ap.add_argument("--top", type=int, default=40)
    ap.add_argument("--cpu-name", default="haswell", choices=("haswell", "generic"),
                    help="numba code target (synth.apps.cpu_target; default haswell)")
    ap.add_argument("--preset", default="grand-piano",
                    help="the engine's preset (default grand-piano)")
    ap.add_argument("--voices", type=int, default=0,
                    help="N > 0: N held keys spread over the preset's range, as tools/bench.py "
                         "render holds them (instead of KEY)")
    ap.add_argument("--block", type=int, default=256,
                    help="output samples per engine block (default 256; 1-4096, the engine's "
                         "largest block)")
    ap.add_argument("--child", type=int, default=None, help=argparse.SUPPRESS)
    ap.add_argument("--wait", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    from synth.engine.engine import Engine

    if not 1 <= a.block <= Engine.MAX_BLOCK_OUT:
        ap.error(f"--block {a.block} is out of range (1-{Engine.MAX_BLOCK_OUT} samples)")
    if not 0 <= a.voices <= 512:
        ap.error(f"--voices {a.voices} is out of range (0-512)")
    if a.child is not None:
        child(a.child, a.wait, os.environ.get("SYMS", os.devnull), a.preset, a.voices, a.block)
        return 0
    if a.voices <= 0 and not a.keys:
        ap.error("give a KEY (0: the engine with no note) or --voices N")
    from synth.io.presets import load_preset

    try:
        load_preset(a.preset)
    except Exception as e:
        ap.error(f"--preset {a.preset!r}: {e}")
    env = cpu_target.environ_for(a.cpu_name)
    env.update(NUMBA_NUM_THREADS="1", PYTHONHASHSEED="0")
    if os.environ.get("NUMBA_CACHE_DIR"):           # one's own cache, if given
        env["NUMBA_CACHE_DIR"] = os.environ["NUMBA_CACHE_DIR"]
    out = Path(a.out or tempfile.mkdtemp(prefix="callgrind-note-"))
    out.mkdir(parents=True, exist_ok=True)
    if a.voices > 0:
        f = out / f"{a.preset.replace('/', '-')}-v{a.voices}.out"
        n = run(0, f, env, a.preset, a.voices, a.block)
        print(f"{a.voices} voices of {a.preset}, blocks of {a.block}: {n:,} instructions ({f})",
              flush=True)
        report(f, a.top)
        return 0
    for k in a.keys:
        f = out / f"k{k}.out"
        n = run(k, f, env, a.preset, 0, a.block)
        print(f"key {k}: {n:,} instructions ({f})", flush=True)
        report(f, a.top)
    return 0
