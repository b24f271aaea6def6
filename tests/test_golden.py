"""Golden fingerprints: what the instrument renders today, pinned, so that a
refactor that changes the sound is caught.

Each case is rendered through the command line (``synth note``, ``synth
render`` in this process) and fingerprinted twice:

* exactly: the sha256 of its samples (and of the probe u(l, t) for the
  study presets), per numba code target (the host CPU's name, or
  ``$NUMBA_CPU_NAME``): a refactor keeps them bit-identical;
* numerically, for any target: the sum, the sum of squares and 16 samples
  spread over the render, within 1e-9 relative (other targets vectorise
  the sums differently, far below that).

The pinned values are in ``tests/golden/fingerprints.json``.  A change that
means to change the sound records them anew, and says why in its commit:
``SYNTH_GOLDEN_RECORD=1 python -m pytest tests/test_golden.py`` (for this
machine's target; the numeric values are kept from the first target that
recorded them unless ``SYNTH_GOLDEN_RECORD=all``).
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import mido
import numpy as np
import pytest
import soundfile

from synth.cli import main
from synth.dsp import compile_notice as CN

GOLDEN = Path(__file__).resolve().parent / "golden" / "fingerprints.json"
RECORD = os.environ.get("SYNTH_GOLDEN_RECORD", "")

STUDY = ["paper/sitar-ideal", "paper/sitar-case1", "paper/sitar-case2", "paper/sitar-case3",
         "paper/biwa-ideal", "paper/biwa-sawari", "paper/piano-a7-ideal", "paper/piano-a7-capo"]
NOTES = [("sitar", 50), ("biwa", 52), ("grand-piano", 60), ("grand-piano", 96),
         ("harpsichord", 60), ("hammered-sitar", 57)]


def _target() -> str:
    name = os.environ.get("NUMBA_CPU_NAME")
    if name:
        return name
    import llvmlite.binding as llvm

    return llvm.get_host_cpu_name()


def _phrase(path: Path) -> Path:
    """A grand-piano phrase on two channels: pedal, volume, expression,
    pan and a chord on a full pool's worth of notes (the MIDI front end)."""
    mf = mido.MidiFile(type=0, ticks_per_beat=480)
    tr = mido.MidiTrack()
    mf.tracks.append(tr)
    msgs = [(0.0, mido.Message("control_change", control=10, value=30, channel=1)),
            (0.0, mido.Message("control_change", control=64, value=127)),
            (0.0, mido.Message("note_on", note=48, velocity=90)),
            (0.05, mido.Message("note_on", note=67, velocity=70, channel=1)),
            (0.2, mido.Message("control_change", control=11, value=60)),
            (0.3, mido.Message("note_on", note=72, velocity=100)),
            (0.3, mido.Message("note_off", note=48, velocity=64)),
            (0.45, mido.Message("control_change", control=7, value=80, channel=1)),
            (0.6, mido.Message("control_change", control=64, value=0))]
    tick = 0
    for t, m in msgs:
        at = int(round(t * 960))
        tr.append(m.copy(time=at - tick))
        tick = at
    mf.save(str(path))
    return path


def _cases():
    out = [(f"study {p}", ["note", p, "--seconds", "0.05"], True) for p in STUDY]
    out += [(f"note {p} {k}", ["note", p, "--key", str(k), "--velocity", "100",
                               "--seconds", "0.3"], False) for p, k in NOTES]
    # the biwa with its tension modulation off: the fingerprint of its note
    # before the modulation (on by default since) -- off is bit for bit
    out.append(("note biwa 52 off", ["note", "biwa", "--key", "52", "--velocity", "100",
                                     "--seconds", "0.3", "--set", "string.tension_modulation=0"],
                False))
    out.append(("render phrase grand-piano", None, False))
    return out


def _sha(a: np.ndarray) -> str:
    return hashlib.sha256(np.ascontiguousarray(a).tobytes()).hexdigest()


def _numbers(a: np.ndarray) -> list:
    x = np.asarray(a, dtype=np.float64).ravel()
    idx = np.linspace(0, x.size - 1, 16).astype(int)
    return [float(x.sum()), float(np.dot(x, x))] + [float(v) for v in x[idx]]


def _render(tmp_path, name, argv, probe, fresh=False):
    """The case's parts (``wav``, and ``probe`` for a study preset),
    rendered in this process, or with ``fresh`` in a new one."""
    wav = tmp_path / "out.wav"
    if argv is None:
        argv = ["render", str(_phrase(tmp_path / "phrase.mid")), "--preset", "grand-piano"]
    extra = ["--probe", str(tmp_path / "p.npy")] if probe else []
    if fresh:
        env = dict(os.environ, SYNTH_COMPILE_NOTICE="0")
        subprocess.run([sys.executable, "-m", "synth", *argv, "-o", str(wav), *extra], check=True,
                       capture_output=True, env=env)
    else:
        assert main(argv + ["-o", str(wav)] + extra) == 0
    y, _ = soundfile.read(str(wav), dtype="float32")
    parts = {"wav": y}
    if probe:
        parts["probe"] = np.load(tmp_path / "p.npy")
    return parts


def _load():
    return json.loads(GOLDEN.read_text()) if GOLDEN.exists() else {"exact": {}, "numbers": {}}


#: cases over 2 s on a quiet 2-core machine (the fast tier leaves them to the full run)
SLOW = {"render phrase grand-piano": "3.2 s, 2026-11-29"}


@pytest.mark.parametrize("name, argv, probe", [
    pytest.param(*c, id=c[0], marks=[pytest.mark.slow] if c[0] in SLOW else []) for c in _cases()])
def test_the_sound_is_pinned(tmp_path, name, argv, probe):
    parts = _render(tmp_path, name, argv, probe)
    target = _target()
    data = _load()
    if RECORD:
        data["exact"].setdefault(target, {})
        for part, a in parts.items():
            data["exact"][target][f"{name} {part}"] = _sha(a)
            if RECORD == "all" or f"{name} {part}" not in data["numbers"]:
                data["numbers"][f"{name} {part}"] = _numbers(a)
        GOLDEN.parent.mkdir(exist_ok=True)
        GOLDEN.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")
        return
    for part, a in parts.items():
        key = f"{name} {part}"
        assert key in data["numbers"], f"{key}: no fingerprint pinned (SYNTH_GOLDEN_RECORD=1)"
        np.testing.assert_allclose(_numbers(a), data["numbers"][key], rtol=1e-9, atol=1e-12,
                                   err_msg=key)
        exact = data["exact"].get(target)
        if exact is not None and key in exact:
            sha = _sha(a)
            if sha != exact[key] and CN.kernels_compiled() > 0:
                # (a process that compiled the grand's renderer together with
                # the unison's chunk functions runs code that rounds a few
                # samples otherwise than the code it saves to numba's cache,
                # which every later process loads: what is pinned is that
                # code, so a process that compiled renders the case again in
                # a new process; docs/lab/2026-11-30-compile-and-ci.md)
                sha = _sha(_render(tmp_path, name, argv, probe, fresh=True)[part])
            assert sha == exact[key], f"{key}: not bit-identical on {target}"
