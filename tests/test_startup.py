"""First sound in seconds (issue 39): the line a cold start prints before the
kernels compile, ``synth warmup``, and render times reported without the
compile (synth.dsp.compile_notice)."""

from __future__ import annotations

import io
import time
import json
import os
import re
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from helpers import couple, string_table

from synth.dsp import compile_notice as CN

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def notice_state():
    """compile_notice's module state, restored after the test."""
    saved = dict(CN._state)
    CN._state.update(armed=False, said=False, stream=None, bar=None)
    yield CN._state
    CN._state.clear()
    CN._state.update(saved)


class _Tty(io.StringIO):
    def isatty(self):
        return True


def _event(module="synth.kernels.render"):
    return {"dispatcher": SimpleNamespace(py_func=SimpleNamespace(__module__=module))}


def _keyed(base: Path) -> Path:
    (folder,) = [p for p in CN.keyed_folders() if p.parent == base]
    return folder


def test_cache_looks_warm_reads_the_keyed_folder(tmp_path, monkeypatch):
    """Cold while the keyed folder (NUMBA_CACHE_DIR first) lacks the bank
    renderer's index, warm once it holds one; the folder's name is
    synth.kernels.cache's for these sources."""
    from synth.kernels import cache as C

    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    folder = _keyed(tmp_path)
    assert folder.name == C.folder_name(C.NAME, C.source_digest(ROOT / "synth" / "kernels"))
    assert not CN.cache_looks_warm()
    (folder / "kernels_0123").mkdir(parents=True)
    assert not CN.cache_looks_warm()
    (folder / "kernels_0123" / "render.render_bank-603.py311.nbi").write_bytes(b"")
    assert CN.cache_looks_warm()


def test_the_line_comes_with_the_first_compile_in_a_log(tmp_path, monkeypatch, notice_state):
    """Not a terminal: nothing at arm(), the line once at the first compile
    of a synth kernel (not another library's), no progress; the compile's
    time is added up."""
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    log = io.StringIO()
    assert CN.arm(log) is False and log.getvalue() == ""
    c0, n0 = CN.compile_seconds(), CN.kernels_compiled()
    CN._on_start(_event("other.library"))
    CN._on_end(_event("other.library"))
    assert log.getvalue() == ""
    CN._on_start(_event())
    CN._on_start(_event("synth.kernels.strings"))
    CN._on_end(_event("synth.kernels.strings"))
    CN._on_end(_event())
    CN._on_start(_event())
    CN._on_end(_event())
    assert log.getvalue() == CN.MESSAGE + "\n"
    assert CN.kernels_compiled() == n0 + 3
    assert CN.compile_seconds() >= c0


def test_a_terminal_hears_it_at_once_on_a_cold_cache(tmp_path, monkeypatch, notice_state):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    tty = _Tty()
    assert CN.arm(tty) is True
    assert tty.getvalue() == CN.MESSAGE + "\n"
    CN._on_start(_event())
    CN._on_end(_event())
    assert tty.getvalue().count(CN.MESSAGE) == 1


def test_nothing_on_a_warm_cache_or_when_turned_off(tmp_path, monkeypatch, notice_state):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    folder = _keyed(tmp_path)
    (folder / "k").mkdir(parents=True)
    (folder / "k" / "render.render_bank-603.py311.nbi").write_bytes(b"")
    tty = _Tty()
    assert CN.arm(tty) is False and tty.getvalue() == ""
    CN.disarm()
    monkeypatch.setenv("SYNTH_COMPILE_NOTICE", "0")
    (folder / "k" / "render.render_bank-603.py311.nbi").unlink()
    assert CN.arm(tty) is False
    CN._on_start(_event())
    CN._on_end(_event())
    assert tty.getvalue() == ""


def test_the_progress_line_moves_while_a_kernel_compiles(tmp_path, monkeypatch, notice_state):
    """On a terminal the elapsed time is redrawn every TICK_S during one
    long compile (tqdm redraws only when a kernel finishes, and one may take
    15 s), and no more once the compiles are over."""
    import re

    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(CN, "TICK_S", 0.05)
    tty = _Tty()
    CN.arm(tty)
    CN._on_start(_event())
    time.sleep(1.2)
    shown = re.findall(r"kernels compiled: \d+ \[(\d\d:\d\d)\]", tty.getvalue())
    assert len(shown) >= 5 and shown[-1] == "00:01", shown
    CN._on_end(_event())
    n = len(tty.getvalue())
    time.sleep(0.3)
    assert len(tty.getvalue()) == n and CN._state["ticker"] is None


def test_timing_note():
    assert CN.timing_note(0.0) == ""
    assert CN.timing_note(41.26) == " (+ 41.3 s compiling the kernels for this CPU, once)"


def test_in_process_main_never_arms(tmp_path, notice_state):
    """synth.cli.main(argv) (the tests, a program using the package) says
    nothing; only the command line arms the notice."""
    from synth.cli import main

    assert main(["presets"]) == 0
    assert CN._state["armed"] is False


def test_warmup_is_a_command():
    from synth.cli import COMMANDS, build_parser

    assert "warmup" in [m.NAME for m in COMMANDS]
    a = build_parser().parse_args(["warmup", "--presets", "biwa"])
    assert a.presets == "biwa"


def _synth(args, cache, cwd):
    """``synth ARGS`` in a subprocess in ``cwd`` with numba's cache in
    ``cache`` (None: the suite's own); (stdout, stderr), exit status 0."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    if cache is not None:
        env["NUMBA_CACHE_DIR"] = str(cache)
    env.pop("SYNTH_COMPILE_NOTICE", None)
    r = subprocess.run([sys.executable, "-m", "synth.cli", *args], env=env, cwd=str(cwd),
                       capture_output=True, text=True, timeout=1800)
    assert r.returncode == 0, r.stderr
    return r.stdout, r.stderr


def _seeded(cache: Path, missing: str) -> None:
    """Fill the keyed folder of numba cache ``cache`` with the suite's own
    compiled kernels (its keyed folder, where numba put them for these
    sources), except the files of module ``missing`` (e.g. "decimator.");
    nothing if the suite's cache is empty (a note then compiles every
    kernel)."""
    import shutil

    suite = next((p for p in CN.keyed_folders() if p.is_dir()), None)
    if suite is not None:
        shutil.copytree(suite, cache / suite.name, ignore=shutil.ignore_patterns(missing + "*"))


@pytest.mark.slow  # a subprocess compiles what its cache lacks (the decimator: 5-10 s)
def test_cold_start_says_so_then_nothing(tmp_path):
    """With a numba cache that lacks a kernel the note needs (the
    decimator; the suite's cache gives the others): `synth note` prints the
    one line on stderr (not a terminal: no progress) and reports its
    render time without the compile; the same note again prints nothing on
    stderr and compiles nothing.  (A cache that lacks every kernel is
    CI's: its Quick start's `synth demo` compiles them all, on a fresh
    install, and prints the same line; here that took 54 s of the suite.)"""
    cache = tmp_path / "numba"
    _seeded(cache, "decimator.")
    note = ["note", "biwa", "--key", "52", "--seconds", "0.05", "-o", "a.wav"]
    out, err = _synth(note, cache, tmp_path)
    assert err.splitlines() == [CN.MESSAGE]
    assert re.search(r"rendered in [0-9.]+ s \(\+ [0-9.]+ s compiling the kernels", out), out
    assert any(p.name.startswith("decimator.decimate") for p in cache.rglob("*.nbi"))
    out, err = _synth(note, cache, tmp_path)
    assert err == "" and "compiling" not in out


@pytest.mark.slow  # what the suite's cache lacks of the biwa's paths, compiled once
def test_warmup_compiles_then_says_it_compiled_nothing(tmp_path):
    """`synth warmup` compiles what a phrase of several notes and live play
    add (or finds them compiled already), then, run again, compiles
    nothing, says so and prints no compile notice.  It runs on the suite's
    own numba cache (``NUMBA_CACHE_DIR`` as the suite has it, else numba's
    default): a fresh one would compile the whole tree again, which
    :func:`test_cold_start_says_so_then_nothing` and CI's fresh install
    already do, and the other tests load what it compiles."""
    runs = [_synth(["warmup", "--presets", "biwa"], None, tmp_path) for _ in range(2)]
    assert "warmup: compiled" in runs[0][0] or "already compiled" in runs[0][0]
    assert "already compiled" in runs[1][0] and CN.MESSAGE not in runs[1][1]


def test_warmup_order_and_bad_input():
    """The presets whose kernels differ most go first; a bad --jobs, an
    unknown preset are refused before any work."""
    from synth.apps.warmup import ORDER, ordered, warm_presets

    assert ordered(["harpsichord", "sitar", "grand-piano", "sitar"]) == \
        ["grand-piano", "sitar", "harpsichord"]
    assert ordered(["biwa"]) == ["biwa"] and ORDER[0] == "grand-piano"
    for jobs in (0, 65, 1.5, True):
        with pytest.raises(ValueError, match=r"jobs = .* is out of range \(1 <= value <= 64\)"):
            warm_presets(["biwa"], jobs)
    from synth.io.errors import PresetError

    with pytest.raises(PresetError, match="no-such-preset"):
        warm_presets(["biwa", "no-such-preset"], 2)
    from synth.cli import main

    assert main(["warmup", "--presets", "biwa", "--jobs", "0"]) == 2
    from synth.io.factory import build_engine

    with pytest.raises(ValueError, match=r"only = \('sharded', 'all'\): each must be one of sharded, "):
        build_engine("biwa", ()).bank.load_kernels(("sharded", "all"))


@pytest.mark.slow  # two spawned processes load the kernels: 5-15 s on 2 cores
def test_warmup_in_two_processes_reports_each_preset(tmp_path):
    """``warm_presets(..., jobs=2)`` warms the presets in worker processes
    (on the suite's own cache, where they compile what it lacks or load
    it), in two rounds: the bank's renderers and one note of each, then
    each phrase; it reports every part as it ends and returns each preset,
    in the given order, its parts added up; run again they compile
    nothing."""
    from synth.apps.warmup import n_tasks, warm_presets

    seen = []
    first = warm_presets(["biwa", "harpsichord"], jobs=2, threads=2, done=seen.append)
    assert [w.preset for w in first] == ["biwa", "harpsichord"]
    assert sorted((w.part, w.preset) for w in seen) == [
        ("note", "biwa"), ("note", "harpsichord"), ("phrase", "biwa"),
        ("phrase", "harpsichord"), ("sharded", "biwa")]
    assert n_tasks(["biwa", "harpsichord"], 2) == 5 and n_tasks(["biwa", "harpsichord"], 1) == 2
    for w in first:
        parts = [x for x in seen if x.preset == w.preset]
        assert w.part == "all" and w.seconds == pytest.approx(sum(x.seconds for x in parts))
        assert w.compiled == sum(x.compiled for x in parts) >= 0
    again = warm_presets(["biwa", "harpsichord"], jobs=2, threads=2)
    assert [w.compiled for w in again] == [0, 0] and [w.compile_s for w in again] == [0.0, 0.0]


def test_bank_kind_picks_the_renderer_render_sharded_would_run():
    """The bank's choice of kernel (synth.kernels.render.bank_kind): one
    shard of big groups, one small group, one plain string, anything else
    in one shard (a hammer stepped with others, a finer grid), several
    units (shards), nothing."""
    from synth.kernels import layout as L
    from synth.kernels import render as KR

    def kind(ip, active, n=4096):
        a = np.array(active, dtype=np.int64)
        return KR.bank_kind(a, len(active), ip, fp, n)

    ip = string_table(40)
    fp = np.zeros((40, L.F_NF))
    assert kind(ip, []) == KR.KIND_NONE
    couple(ip, 0, 14)                      # a sitar's bridge
    couple(ip, 20, 3)                      # a piano key
    # chunks of 8 samples: never the work for a second thread
    assert kind(ip, list(range(14))) == KR.KIND_BIG_GROUPS_ONE
    # chunks of up to 512 samples (GROUP_CHUNK) of 14 strings of cost
    # 6 + 20: 186k > PAR_MIN_WORK ...
    ip[0:14, L.I_CHUNK] = 4096
    ip[0:14, L.I_REG_N] = 20
    assert KR.unit_cost(ip, fp, 0) * KR.GROUP_CHUNK >= KR.PAR_MIN_WORK
    assert kind(ip, list(range(14))) == KR.KIND_BIG_GROUPS
    # ... unless the call renders fewer samples, or a member's chunks are short
    assert kind(ip, list(range(14)), n=64) == KR.KIND_BIG_GROUPS_ONE
    ip[5, L.I_CHUNK] = 100
    assert kind(ip, list(range(14))) == KR.KIND_BIG_GROUPS_ONE
    ip[5, L.I_CHUNK_FREE] = 4096           # (the longer of a member's two limits)
    assert kind(ip, list(range(14))) == KR.KIND_BIG_GROUPS
    assert kind(ip, [20, 21, 22]) == KR.KIND_SMALL_GROUP
    assert kind(ip, [30]) == KR.KIND_STRINGS
    assert kind(ip, [30, 31]) == KR.KIND_SHARDS
    assert kind(ip, list(range(14)) + [30]) == KR.KIND_SHARDS
    assert kind(ip, [20, 21, 22, 30]) == KR.KIND_SHARDS
    ip[31, L.I_EXC] = L.EXC_HAMMER3        # a hammer render_bank steps with others
    assert kind(ip, [31]) == KR.KIND_BANK
    ip[31, L.I_PROBE] = 0                  # ... unless it has a probe: by itself
    assert kind(ip, [31]) == KR.KIND_STRINGS
    ip[20, L.I_SUB] = 2                    # a key on a finer grid
    assert kind(ip, [20, 21, 22]) == KR.KIND_BANK


@pytest.mark.slow
def test_a_sitar_note_compiles_no_parallel_loop():
    """A single sitar note on two threads never has the work for a second
    thread in a chunk of its bridge (bank_kind: KIND_BIG_GROUPS_ONE), so
    it runs render_big_groups typed with ``nt`` None, and the blocks'
    parallel loops are neither compiled nor loaded (issue 39: 10 of a cold
    note's CPU seconds); a chord with the work for them runs the threaded
    kind (test_threads checks that both give the same samples)."""
    out = _printed_on_two_threads(
        "synth.render_note('sitar', key=57, velocity=100, seconds=0.2)\n"
        "print(len(KR._tasks_a_par.signatures), len(KR._tasks_c_par.signatures),"
        " [str(s[-2]) for s in KR.render_big_groups.signatures])\n")
    assert out[-1:] == ["0 0 ['none']"], out


def _printed_on_two_threads(code: str) -> list[str]:
    """The lines ``code`` prints in a new process on two threads (with
    ``synth`` and ``KR``, synth.kernels.render, imported): which kernels a
    scene compiles or loads, seen from a process that ran nothing else."""
    env = dict(os.environ, SYNTH_THREADS="2", SYNTH_COMPILE_NOTICE="0")
    code = "import synth, synth.kernels.render as KR\n" + code
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True, env=env).stdout.splitlines()


@pytest.mark.slow  # a subprocess renders a chord (about 4 s)
def test_a_piano_chord_compiles_no_big_group_renderer():
    """A piano's chord runs the shards' renderer (render_sharded, which
    calls render_bank by its address), and render_bank calls the renderer
    of each unit by its address too: a piano key's unison
    (render_coupled_small, the one a single note runs too).  A piano has no
    coupled group of more than BLOCK members, so render_coupled_big (a
    sitar bridge's blocks and their parallel loops) is neither compiled
    nor loaded; a sitar's bank, with room for one, loads it."""
    out = _printed_on_two_threads(
        "from synth.io.factory import build_engine\n"
        "from synth.engine.engine import Event\n"
        "e = build_engine('grand-piano', (), threads=2)\n"
        "e.render([Event(0.0, 'note_on', k, 0.8) for k in (48, 55, 60, 64)], duration_s=0.1)\n"
        "print(len(KR.render_sharded.signatures), len(KR.render_bank.signatures),"
        " len(KR.render_coupled_small.signatures), len(KR.render_coupled_big.signatures))\n"
        "e = build_engine('sitar', (), threads=2)\n"
        "e.bank.load_kernels(('sharded',))\n"
        "print(len(KR.render_coupled_big.signatures))\n")
    assert out[-2:] == ["1 1 1 0", "1"], out


LEAN_SCRIPT = r"""
import json, sys
import synth.cli
sys.argv = ["synth", *sys.argv[1:]]
rc = synth.cli.main()
import synth.kernels.render as KR
print("JSON " + json.dumps({
    "rc": rc,
    "scipy.linalg": "scipy.linalg" in sys.modules,
    "mido": "mido" in sys.modules,
    "prime_threads": len(KR.prime_threads.signatures),
}))
from synth.io.live import ready_engine
ready_engine("biwa")
print("JSON " + json.dumps({"primed for live": len(KR.prime_threads.signatures)}))
"""


@pytest.mark.slow  # a one-note render and a live engine's warm-up in a subprocess
def test_a_one_note_command_starts_no_thread_team_and_no_scipy(tmp_path):
    """A warm start does only what the note needs (issue 39): on 2 threads,
    a one-note ``synth note`` run from the command line renders without a
    parallel loop (less work than PAR_MIN_WORK), so it neither loads the
    priming kernel nor starts OpenMP's team (synth.dsp.threads.set_priming,
    off offline), numba's BLAS probe does not import scipy.linalg
    (synth.cli._SkipBlasProbe), and no MIDI reader (mido: 40 ms) is
    imported.  Live play still primes before the stream
    opens (ready_engine).  (prime_threads is only ever called from Python:
    a cold cache compiles it for no caller, so the test holds cold or warm.)"""
    env = dict(os.environ, PYTHONPATH=str(ROOT), SYNTH_THREADS="2", NUMBA_NUM_THREADS="2",
               SYNTH_COMPILE_NOTICE="0")
    p = subprocess.run([sys.executable, "-c", LEAN_SCRIPT, "note", "sitar", "--key", "57",
                        "--seconds", "0.2", "-o", "a.wav"], env=env, cwd=str(tmp_path),
                       capture_output=True, text=True, timeout=1800)
    assert p.returncode == 0, p.stderr
    note, live = (json.loads(x.split("\n", 1)[0]) for x in p.stdout.split("JSON ")[1:])
    assert note == {"rc": 0, "scipy.linalg": False, "mido": False, "prime_threads": 0}
    assert live == {"primed for live": 1}


def test_priming_is_for_live_play_only():
    """threads.enter primes a thread's team only when asked (set_priming,
    or prime=True): a new thread's first enter does not, a later one that
    is asked to does, once.  (Off by default in a fresh process: the
    subprocess test above; ready_engine turns it on for the process.)"""
    import threading

    from synth.dsp import threads as TH

    if TH.max_threads() < 2:
        pytest.skip("numba has one thread (NUMBA_NUM_THREADS)")
    seen = []

    def run():
        seen.append((TH.enter(2, prime=False), getattr(TH._local, "primed", False)))
        seen.append((TH.enter(2, prime=True), getattr(TH._local, "primed", False)))
        seen.append((TH.enter(2), getattr(TH._local, "primed", False)))

    t = threading.Thread(target=run)
    t.start()
    t.join()
    assert seen == [(2, False), (2, True), (2, True)]


@pytest.mark.slow  # a spawned worker imports synth and renders a phrase (about 4 s)
def test_the_demo_renders_a_phrase_in_a_second_process_only_when_cold(monkeypatch):
    """On a cold cache and two cores or more, ``synth demo`` renders its
    second phrase in a spawned worker while it renders the first, so that
    their kernels compile on two cores: the worker's samples are the ones
    this process renders (on half the threads: the same samples for any
    count).  On a warm cache, or on one thread, it renders both here."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    from synth.commands import demo

    monkeypatch.setattr(CN, "cache_looks_warm", lambda: True)
    assert not demo._other_process(2)
    monkeypatch.setattr(CN, "cache_looks_warm", lambda: False)
    assert not demo._other_process(1)      # --threads 1: one core
    assert demo._other_process(2)
    here = demo._render("biwa")
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as ex:
        there = ex.submit(demo._render, "biwa", 1).result()
    assert here[1] == there[1] == 48_000
    assert here[0].shape == there[0].shape and here[0].shape[0] > 5 * 48_000
    np.testing.assert_array_equal(here[0], there[0])
