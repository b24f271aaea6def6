"""Issue 38, item 7: a toolbox, not a lab bench.

* ``tools/`` holds at most 15 scripts, and every ``tools/X.py`` that the
  README or a user doc cites exists (a retired tool is cited only as
  ``git show COMMIT:tools/X.py``), as does every ``tools/bench.py NAME``;
* no tool imports another tool, nor puts ``tools/`` on ``sys.path``;
* the benchmarks' harness (:mod:`synth.apps.bench.harness`): code targets,
  alternation, medians, the child process of a target;
* ``synth reproduce`` refuses an option its part does not take;
* the measures the tools share, defined once in :mod:`synth.analysis`.
"""

from __future__ import annotations

import ast
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from synth.analysis import highband_db, highband_energy, window_energy_db
from synth.apps import bench, cpu_target
from synth.apps.bench import harness

ROOT = Path(__file__).resolve().parents[1]
TOOLS = ROOT / "tools"
#: the most scripts tools/ may hold (issue 38's target)
MAX_TOOLS = 15


def _user_docs():
    return [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def test_tools_holds_at_most_15_scripts():
    scripts = sorted(p.name for p in TOOLS.glob("*.py"))
    assert 0 < len(scripts) <= MAX_TOOLS, scripts


def test_every_cited_tool_exists():
    """``tools/X.py`` in README.md and docs/*.md names a file of tools/ (a
    ``git show COMMIT:tools/X.py`` of a retired one is not a citation)."""
    missing = []
    for doc in _user_docs():
        for m in re.finditer(r"(?<![:\w/])tools/([A-Za-z0-9_]+\.py)", doc.read_text("utf-8")):
            if not (TOOLS / m.group(1)).is_file():
                missing.append(f"{doc.relative_to(ROOT)}: tools/{m.group(1)}")
    assert not missing, missing


def test_the_citation_check_can_fail(tmp_path):
    """The pattern of the test above finds a plain citation and skips a
    ``git show`` of a retired tool."""
    text = "run `python tools/nope.py`; it was `git show abc123:tools/gone.py`"
    found = re.findall(r"(?<![:\w/])tools/([A-Za-z0-9_]+\.py)", text)
    assert found == ["nope.py"]


def test_every_cited_benchmark_exists():
    names = set()
    for doc in _user_docs():
        names |= set(re.findall(r"tools/bench\.py ([a-z]+)", doc.read_text("utf-8")))
    assert names, "no doc cites a benchmark"
    assert names <= set(bench.BENCHMARKS), names - set(bench.BENCHMARKS)


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text("utf-8"))
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            out.add(node.module.split(".")[0])
    return out


def test_no_tool_imports_another():
    stems = {p.stem for p in TOOLS.glob("*.py")}
    bad = {}
    for p in TOOLS.glob("*.py"):
        hit = _imports(p) & (stems - {p.stem})
        text = p.read_text("utf-8")
        if hit or re.search(r"sys\.path\.insert\([^)]*(__file__\)\.resolve\(\)\.parent\b|\"tools\")",
                            text):
            bad[p.name] = sorted(hit) or ["tools/ on sys.path"]
    assert not bad, bad


def test_bench_lists_and_refuses(capsys):
    assert bench.main([]) == 0
    out = capsys.readouterr().out
    assert all(name in out for name in bench.BENCHMARKS)
    assert bench.main(["nope"]) == 2
    assert "NAME = 'nope' is not a benchmark" in capsys.readouterr().err


def test_every_benchmark_module_has_a_main():
    import importlib

    for name, (mod, what) in bench.BENCHMARKS.items():
        m = importlib.import_module(f"synth.apps.bench.{mod}")
        assert callable(m.main), name
        assert what


def test_parse_targets():
    assert harness.parse_targets("all") == cpu_target.TARGETS
    assert harness.parse_targets("host,generic") == ("host", "generic")
    assert harness.parse_targets(" haswell ") == ("haswell",)
    for bad in ("", "avx9", "host,avx9", ","):
        with pytest.raises(ValueError, match="--cpu-name"):
            harness.parse_targets(bad)


def test_target_option_rejects_an_unknown_target(capsys):
    import argparse

    ap = argparse.ArgumentParser()
    harness.add_target_option(ap)
    assert ap.parse_args(["--cpu-name", "host,haswell"]).cpu_name == "host,haswell"
    with pytest.raises(SystemExit):
        ap.parse_args(["--cpu-name", "pentium"])
    assert "each target must be one of host, haswell, generic" in capsys.readouterr().err


def test_alternate_runs_the_ways_in_turn():
    order = []
    ways = {k: (lambda k=k: order.append(k) or len(order)) for k in ("a", "b", "c")}
    got = harness.alternate(ways, 2, warmup=True)
    assert order == ["a", "b", "c"] * 3
    assert got == {"a": [4.0, 7.0], "b": [5.0, 8.0], "c": [6.0, 9.0]}
    with pytest.raises(ValueError, match="repeats = 0"):
        harness.alternate(ways, 0)


def test_summary_and_ratios():
    assert harness.summary([3.0, 1.0, 2.0, 10.0]) == (2.5, 1.0, 10.0)
    assert harness.ratios([2.0, 3.0], [1.0, 6.0]) == [2.0, 0.5]
    with pytest.raises(ValueError):
        harness.ratios([1.0], [1.0, 2.0])
    with pytest.raises(ValueError):
        harness.summary([])


def test_child_runs_this_checkout():
    cmd = harness.child_command("ab", ["--runs", "1"])
    assert cmd[:4] == [sys.executable, "-m", "synth.apps.bench", "ab"]
    env = harness.child_environ({"PYTHONPATH": f"/elsewhere{os.pathsep}{ROOT}"})
    assert env["PYTHONPATH"].split(os.pathsep) == [str(ROOT), "/elsewhere"]


def test_dispatch_runs_each_target_in_a_child(monkeypatch, tmp_path):
    """--cpu-name host,generic from a process of no target: two children,
    each with that target's NUMBA_CPU_NAME and its own cache folder, the
    benchmark's arguments without --cpu-name, then the target's."""
    calls = []

    def call(cmd, env):
        calls.append((cmd, env))
        return 0

    monkeypatch.delenv(cpu_target.ENV_TARGET, raising=False)
    monkeypatch.delenv("NUMBA_CPU_NAME", raising=False)
    monkeypatch.setenv(cpu_target.ENV_CACHE_BASE, str(tmp_path))
    monkeypatch.setattr(harness.subprocess, "call", call)
    assert harness.dispatch("ab", None, ["--runs", "1"]) is None
    assert harness.dispatch("ab", "host", ["--runs", "1"]) is None      # this process's own
    rc = harness.dispatch("ab", "host,generic", ["--runs", "1", "--cpu-name", "host,generic"])
    assert rc == 0
    assert [c[0][4:] for c in calls] == [["--runs", "1", "--cpu-name", "host"],
                                         ["--runs", "1", "--cpu-name", "generic"]]
    assert "NUMBA_CPU_NAME" not in calls[0][1]
    assert calls[1][1]["NUMBA_CPU_NAME"] == "generic"
    assert calls[0][1]["NUMBA_CACHE_DIR"] == str(tmp_path / "host")
    assert calls[1][1]["NUMBA_CACHE_DIR"] == str(tmp_path / "generic")


def test_cpu_target_keeps_the_targets_only():
    """The re-running of a benchmark per target has one home, the harness."""
    for gone in ("dispatch", "run_for_targets", "add_cpu_option"):
        assert not hasattr(cpu_target, gone), gone


def _synth(*argv):
    return subprocess.run([sys.executable, "-m", "synth.cli", *argv], capture_output=True,
                          text=True, cwd=ROOT, timeout=120)


@pytest.mark.parametrize("argv, msg", [
    (("reproduce", "felt", "--energy"), "--energy: the part 'felt' does not take it (only thesis)"),
    (("reproduce", "--repeats", "2"), "--repeats: the part 'thesis' does not take it (only felt-study)"),
    (("reproduce", "felt-study", "--repeats", "0"), "--repeats = 0 is out of range (1 <= value <= 100)"),
])
def test_reproduce_refuses_an_option_of_another_part(argv, msg):
    p = _synth(*argv)
    assert p.returncode == 2
    assert p.stderr.strip() == f"synth: error: {msg}"
    assert p.stdout == ""


def test_reproduce_lists_its_parts():
    p = _synth("reproduce", "--help")
    assert p.returncode == 0
    for part in ("thesis", "felt", "felt-study"):
        assert f"  {part} " in p.stdout


def test_highband_energy_of_two_sines():
    """A sine below the edge and one above: the band holds the upper one's
    energy only (Hann window: sum |X|^2 = (A N / 4)^2 (1 + 2 / 4^2 ... ) ~
    3 N^2 A^2 / 32 for a sine on a bin), and highband_db is its dB."""
    fs, n = 48000, 4800
    t = np.arange(n) / fs
    lo, hi = 0.5 * np.sin(2 * np.pi * 500.0 * t), 0.1 * np.sin(2 * np.pi * 5000.0 * t)
    e = highband_energy(lo + hi, fs, 1000.0)
    assert e == pytest.approx(3 * n * n * 0.1 ** 2 / 32, rel=1e-3)
    assert highband_db(lo + hi, fs, 1000.0) == pytest.approx(10 * math.log10(e), abs=1e-12)
    assert highband_energy(lo, fs, 1000.0) < 1e-9 * e
    # a window: from 0.05 s for 0.04 s
    assert highband_energy(np.r_[np.zeros(2400), lo + hi], fs, 1000.0, 0.05, 0.1) == \
        pytest.approx(e, rel=1e-12)
    assert highband_db(np.zeros(100), fs, 1000.0) == -math.inf


def test_window_energy_db():
    fs = 1000
    x = np.r_[np.zeros(500), np.full(250, 2.0), np.zeros(250)]
    assert window_energy_db(x, fs, 0.5, 0.75) == pytest.approx(10 * math.log10(250 * 4.0))
    assert window_energy_db(x, fs, 0.6, 0.7) == pytest.approx(10 * math.log10(100 * 4.0))
    assert window_energy_db(x, fs, 0.0, 0.5) == -math.inf


@pytest.mark.parametrize("page", ["benchmarks.md", "voicing.md"])
def test_benchmarks_and_voicing_pages_stay_user_pages(page):
    """docs/benchmarks.md and docs/voicing.md hold the current tables
    (issue 38: at most 400 lines each); the history is in docs/lab/."""
    n = len((ROOT / "docs" / page).read_text("utf-8").splitlines())
    assert n <= 400, n


def test_the_package_cites_no_lab_note():
    """The library and its shipped presets say what they need themselves:
    the lab notes (docs/lab/) are the project's history, not shipped in the
    wheel, and no reader of the code should need them (issue 38)."""
    hits = []
    for path in sorted((ROOT / "synth").rglob("*")):
        if path.suffix in (".py", ".toml", ".md") and "docs/lab" in path.read_text("utf-8"):
            hits.append(str(path.relative_to(ROOT)))
    assert not hits, hits


#: a calendar date as the lab notes write them (2026-11-30)
_DATE = re.compile(r"(?<![\d-])20\d\d-[01]\d-[0-3]\d(?![\d-])")


def _dated_lines(text: str) -> list[str]:
    return [line.strip() for line in text.splitlines() if _DATE.search(line)]


def test_the_package_keeps_no_dated_log():
    """A comment in the library or a shipped preset says why, with the
    command that measures it, not when: "as until 2026-11-30" is the lab's
    history, which git and docs/lab/ keep (issue 38, "library code ... has
    14 dated comments")."""
    hits = []
    for path in sorted((ROOT / "synth").rglob("*")):
        if path.suffix in (".py", ".toml", ".md"):
            hits += [f"{path.relative_to(ROOT)}: {line}"
                     for line in _dated_lines(path.read_text("utf-8"))]
    assert not hits, hits


def test_the_dated_log_check_can_fail():
    text = "x = 1  # 0.41 s without it (2026-12-01, Xeon)\nkeys 21-108, 1-127, 2.0-2.5\n"
    assert _dated_lines(text) == ["x = 1  # 0.41 s without it (2026-12-01, Xeon)"]


CALLGRIND_SYMBOLS = """
import sys
from synth.apps.bench.callgrind import keep_object_code, write_symbols
objs = keep_object_code()
from synth.io.factory import build_engine
e = build_engine("grand-piano", (), polyphony=4)
e.render_block(256)
print(write_symbols(objs, sys.argv[1]))
"""


@pytest.mark.slow  # two processes of the grand (5 s)
@pytest.mark.skipif(not __import__("shutil").which("nm"), reason="needs binutils' nm")
def test_callgrind_names_the_kernels_it_loaded(tmp_path):
    """``bench.py callgrind`` maps callgrind's addresses to the kernels' names
    through the object code numba loaded: with :mod:`synth.kernels`' own
    load in place the map was empty (every kernel ``???:0x...``) until the
    hook wrapped that load.  The engine's stages are named (the cache is
    warmed by a first process)."""
    env = dict(os.environ, NUMBA_NUM_THREADS="1")
    syms = tmp_path / "k.syms"
    for _ in range(2):                     # the first may compile (nothing loaded then)
        r = subprocess.run([sys.executable, "-c", CALLGRIND_SYMBOLS, str(syms)], env=env,
                           capture_output=True, text=True, timeout=600)
        assert r.returncode == 0, r.stderr
    names = [ln.split()[2] for ln in syms.read_text().splitlines()]
    assert int(r.stdout.split()[-1]) == len(names) > 10
    for kernel in ("listener_process", "decimate", "limiter_process"):
        assert any(kernel in n for n in names), kernel


@pytest.mark.slow  # a 32-voice sitar engine and a block of it: 2.3 s
def test_callgrind_scene_holds_the_render_benchmarks_voices():
    """``bench.py callgrind --preset sitar --voices 32`` profiles the scene
    ``bench.py render`` times: 32 distinct keys of the preset's range, its
    overrides (no voice stolen, the strings ringing), every note-on sounding
    after a block; a KEY alone is one note on a polyphony-4 engine, key 0
    none."""
    from synth.apps.bench.callgrind import scene

    e, events = scene("sitar", 0, 32)
    play = e.inst.preset.play
    notes = {(ev.channel, ev.key) for ev in events}
    assert len(events) == len(notes) == 32
    assert all(ev.kind == "note_on" and play.key_low <= ev.key <= play.key_high for ev in events)
    assert play.polyphony == 32 and e.inst.preset.loss.t60_low_s == 120
    e.schedule(events)
    e.render_block(1024)
    assert e.n_voices == e.n_live == 32
    _, ev1 = scene("grand-piano", 60, 0)
    assert [(ev.kind, ev.key) for ev in ev1] == [("note_on", 60)]
    assert scene("grand-piano", 0, 0)[1] == []
