"""The kernels' units called by their address (synth.kernels.address), the
bank that loads them (synth.dsp.units, StringBank._units), and a cold
start's second process (synth.apps.cold_start)."""

import os
import subprocess
import sys

import numpy as np
import pytest
from helpers import couple, string_table


def test_groups_need_the_per_sample_path_whenever_a_chunk_could_take_it():
    """The bank leaves the coupled groups' per-sample path (and their
    hammers) unloaded unless groups_need says a group may take it before
    the next event: so on random group states, whenever _coupled_next (the
    render's own choice) would go per sample, groups_need must say so (and
    ask for the hammers whenever a member has one running); and it says no
    for a plain pluck or strike (a note never loads the per-sample path,
    a pluck not the hammers)."""
    from synth.kernels import layout as L
    from synth.kernels import unison as KU
    from synth.kernels.address import A_HAMMERS, A_PER

    PER, HAM = 1 << A_PER, 1 << A_HAMMERS
    rng = np.random.default_rng(7)
    kinds = [L.EXC_NONE, L.EXC_SITAR, L.EXC_BIWA, L.EXC_HAMMER3, L.EXC_HAMMER4, L.EXC_FELT]
    fp = np.zeros((64, L.F_NF))
    fst = np.zeros((64, L.S_NS))
    slow_seen = fast_seen = 0
    for trial in range(400):
        ip = string_table(64)
        ip[:, L.I_CHUNK_FREE] = 8
        size = int(rng.choice([3, 4, 20]))
        couple(ip, 10, size)
        for s in range(10, 10 + size):
            ip[s, L.I_EXC] = kinds[int(rng.choice(len(kinds), p=[.5, .2, .1, .12, .06, .02]))]
            ip[s, L.I_CHUNK] = int(rng.choice([0, 8, 100], p=[.03, .67, .3]))
            ip[s, L.I_CHUNK_FREE] = int(rng.choice([0, 140, 512], p=[.02, .5, .48]))
            ip[s, L.I_EXC_M] = int(rng.integers(0, 50))
            ip[s, L.I_EXC_END] = ip[s, L.I_EXC_M] + int(rng.integers(-1, 50))
            ip[s, L.I_PROBE] = 0 if rng.random() < 0.01 else -1
        active = np.arange(10, 10 + size, dtype=np.int64)
        diag = KU._coupled_diag(10, size, ip)
        _, slow = KU._coupled_next(10, size, ip, fp, fst, 4096, diag)
        need = KU.groups_need(active, size, ip)
        may = bool(need & PER)
        assert may or not slow, (trial, ip[10:10 + size, [L.I_EXC, L.I_CHUNK, L.I_CHUNK_FREE]])
        hammers = bool((ip[10:10 + size, L.I_EXC] >= L.EXC_HAMMER3).any())
        assert bool(need & HAM) == hammers
        slow_seen += slow
        fast_seen += not may
    assert slow_seen > 20 and fast_seen > 20         # both sides were exercised
    # a plucked bridge (one pluck) and a struck unison: no
    ip = string_table(64)
    ip[:, L.I_CHUNK_FREE] = 8
    couple(ip, 0, 20)
    couple(ip, 30, 3)
    ip[5, L.I_EXC] = L.EXC_SITAR
    ip[5, L.I_EXC_END] = 40
    ip[30:33, L.I_EXC] = L.EXC_HAMMER3
    ip[30:33, L.I_EXC_END] = 40
    both = np.r_[np.arange(20), np.arange(30, 33)].astype(np.int64)
    assert KU.groups_need(both, len(both), ip) == HAM
    assert KU.groups_need(both[:20], 20, ip) == 0          # the plucked bridge alone: nothing
    ip[31, L.I_TELEM] = 1                   # telemetry on one string: per sample
    assert KU.groups_need(both, len(both), ip) == PER | HAM
    ip[31, L.I_TELEM] = 0
    ip[0:17, L.I_EXC] = L.EXC_SITAR         # more plucks than a chunk's rows: per sample
    ip[0:17, L.I_EXC_END] = 40
    assert KU.groups_need(both[:20], 20, ip) == PER
    # (a lone string is not a group's: never)
    ip[50, L.I_EXC] = L.EXC_HAMMER3
    assert KU.groups_need(np.array([50], dtype=np.int64), 1, ip) == 0


def test_compile_elsewhere_checks_its_units():
    from synth.dsp.units import compile_elsewhere

    with pytest.raises(ValueError, match=r"units: 9 is not a unit \(0 <= value < 7, or 'bank'\)"):
        compile_elsewhere([9], lambda: None)


def _printed(code: str, script=None) -> list[str]:
    """The lines ``code`` prints in a new process on two threads; run from
    the file ``script`` where given (a process it spawns imports it)."""
    env = dict(os.environ, SYNTH_THREADS="2", SYNTH_COMPILE_NOTICE="0")
    if script is None:
        cmd = [sys.executable, "-c", code]
    else:
        script.write_text(code)
        cmd = [sys.executable, str(script)]
    return subprocess.run(cmd, capture_output=True, text=True, check=True,
                          env=env).stdout.splitlines()


@pytest.mark.slow  # two subprocesses render a note (about 3 s each)
def test_a_note_loads_no_per_sample_path_and_a_probe_does():
    """A sitar note and a grand note never render a coupled group per
    sample: the process neither compiles nor loads _coupled_per_sample (on
    a cold cache, 6 CPU s of a sitar note's 36); with a probe on the
    strings it does, and renders the same note.  The sitar's bridge loads
    no hammers (2.5 CPU s); the grand's unison does."""
    code = (
        "import numpy as np\n"
        "import synth.kernels.unison as KU\n"
        "from synth.api.render import note_engine, play_note\n"
        "for name, key in (('sitar', 57), ('grand-piano', 60)):\n"
        "    e = note_engine(name, [], key, None, probe=PROBE)\n"
        "    y = play_note(e, key, None, 100, 0.3, None)\n"
        "    print(name, len(KU._coupled_per_sample.signatures), int(e.bank._addrs[3] != 0),"
        " int(e.bank._addrs[6] != 0), float(np.abs(y).max()) > 0.01)\n")
    assert _printed(code.replace("PROBE", "False")) == ["sitar 0 0 0 True",
                                                        "grand-piano 0 0 1 True"]
    assert _printed(code.replace("PROBE", "True")) == ["sitar 1 1 0 True",
                                                       "grand-piano 1 1 1 True"]


@pytest.mark.slow  # a subprocess loads a unit (about 2 s)
def test_the_big_unit_loads_first_thing_on_one_thread():
    """The big group's renderer holds its blocks' parallel loops: loaded
    from the cache and called before the process had run any parallel loop
    (numba's threading layer not yet up: live play's warm-up now loads the
    units before its phrase), it crashed (SIGSEGV); the bank starts the
    layer first."""
    code = ("from synth.io.factory import build_engine\n"
            "from synth.kernels import render as KR\n"
            "e = build_engine('sitar', (), threads=1)\n"
            "print(int(e.bank._units(1 << KR.A_BIG)[KR.A_BIG] != 0))\n")
    assert _printed(code) == ["1"]


@pytest.mark.slow  # a subprocess warms two engines (about 4 s)
def test_a_live_engine_has_every_unit_before_it_plays():
    """Live play's warm-up loads every unit the bank may call, those its
    phrase did not need too (the per-sample path: a chord of more plucks
    than a chunk holds would otherwise load it mid-performance), and the
    engine built after it finds them loaded: no block scans for them."""
    code = ("from synth.io.factory import build_engine\n"
            "for name in ('sitar', 'grand-piano'):\n"
            "    e = build_engine(name, (), warm=True, extra_low_key=0)\n"
            "    print(name, e.bank._units_left, int((e.bank._addrs != 0).sum()))\n")
    # (a piano has no big group: neither it nor its blocks' first half)
    assert _printed(code) == ["sitar 0 7", "grand-piano 0 5"]


@pytest.mark.slow  # a second process loads the units, twice (about 8 s)
def test_a_second_process_compiles_units_the_bank_then_waits_for(tmp_path):
    """cold_start.start spawns the second process where the cache lacks
    its units (here: made to look cold); the bank, needing the unit, waits
    for it (once) and loads it, and the note is the same to the bit."""
    code = (
        "import numpy as np\n"
        "import synth.apps.cold_start as CS\n"
        "import synth.dsp.compile_notice as CN\n"
        "import synth.dsp.units as U\n"
        "from synth.api.render import note_engine, play_note\n"
        "def main():\n"
        "    ref = play_note(note_engine('sitar', [], 50, None), 50, None, 90, 0.2, None)\n"
        "    U._ADDR.clear()\n"
        "    CN.cache_looks_warm = lambda probe=None: False\n"
        "    e = note_engine('sitar', [], 50, None)\n"
        "    h = CS.start(e, 'sitar', [], None)\n"
        "    waits = []\n"
        "    w = U._ELSEWHERE[h.units[0]]\n"
        "    U._ELSEWHERE[h.units[0]] = lambda: (waits.append(1), w())\n"
        "    y = play_note(e, 50, None, 90, 0.2, None)\n"
        "    h.close()\n"
        "    print(h.units, len(waits), h.proc.exitcode, np.array_equal(y, ref))\n"
        "if __name__ == '__main__':\n"
        "    main()\n")
    script = tmp_path / "second.py"
    out = _printed(code, script)
    assert out == ["(4,) 1 0 True"], out
    # live play: render_bank and the blocks' first half, before the engine
    # exists; its warm-up waits for them and loads every unit
    code = (
        "import synth.apps.cold_start as CS\n"
        "import synth.dsp.compile_notice as CN\n"
        "import synth.dsp.units as U\n"
        "from synth.io.live import ready_engine\n"
        "def main():\n"
        "    CN.cache_looks_warm = lambda probe=None: False\n"
        "    h = CS.start_live('sitar', [], None)\n"
        "    waits = []\n"
        "    for u in h.units:\n"
        "        w = U._ELSEWHERE[u]\n"
        "        U._ELSEWHERE[u] = lambda w=w: (waits.append(1), w())\n"
        "    e = ready_engine('sitar')\n"
        "    h.close()\n"
        "    print(h.units, len(waits), h.proc.exitcode, e.bank._units_left,"
        " sorted(map(str, U._ADDR)))\n"
        "if __name__ == '__main__':\n"
        "    main()\n")
    out = _printed(code, script)
    assert out == ["('bank', 4) 2 0 0 ['0', '1', '2', '3', '4', '5', '6', 'bank']"], out
    # one thread: no second process
    out = _printed("import synth.apps.cold_start as CS, synth.dsp.compile_notice as CN\n"
                   "from synth.api.render import note_engine\n"
                   "CN.cache_looks_warm = lambda probe=None: False\n"
                   "print(CS.start(note_engine('sitar', [], 50, None), 'sitar', [], 1))\n")
    assert out == ["None"], out
