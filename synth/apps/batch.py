"""``synth batch``: many renders with their parameters and analysis, on every
core of a machine or on a Dask cluster.

A *spec* (versioned TOML, :data:`SPEC_SCHEMA`; ``docs/batch.md`` documents
every key) lists entries: ``[[notes]]`` (single notes, swept over presets,
keys, velocities, lengths, quality levels and any preset value given as a
``--set`` path) and ``[[midi]]`` (Standard MIDI Files played by presets).
:func:`load_spec` validates it and expands it into :class:`Job` objects;
an error is one line naming the file and the key (``spec.toml:
notes[1].velocities = [0] is out of range (1 <= value <= 127)``).

:func:`render_many` renders the jobs with ``dask.distributed`` (the
``[batch]`` extra):

* by default on a ``LocalCluster`` of one single-threaded worker process
  per core (``NUMBA_NUM_THREADS=1`` in each), the numba cache shared and
  warmed once by this process before the workers start;
* or on an existing cluster (``client=`` or ``synth batch --scheduler
  tcp://HOST:8786``), whose workers have ``synth`` installed.

Who writes what.  A worker renders a job in memory and returns the WAV
file's bytes and its manifest row; only the process that called
:func:`render_many` writes files: the WAV (atomically), then the row
(``DIR/.synth-batch/rows/HASH.json``, atomically), then, at the end, the
manifest ``DIR/manifest.parquet`` (and ``manifest.csv`` on request) from
the rows of the spec's jobs in spec order.  So a worker that dies (Dask
reruns its job elsewhere) leaves nothing half-written, a job is in the
manifest at most once (rows are keyed by the job's hash), the workers need
no shared file system, and a run stopped half-way keeps every job it
finished.  MIDI files and preset files given as paths travel with the job,
so a remote worker needs only ``synth``.

Resuming.  A job's hash covers everything that decides its samples: the
entry's name, the kind, the preset's content (:func:`preset_sha256`, the
validated values after ``--set``), key, velocity, lengths, the MIDI file's
bytes, the sample format and the ``synth`` version.  A second run skips a
job whose row exists and whose WAV has the size and SHA-256 its row
records; a missing or broken file is rendered again.

Determinism.  The renders have no randomness (the soundboard's modes are
drawn from a seeded generator), random sweeps draw from
``numpy.random.default_rng(seed)`` in a documented order, and a voice
reused for several jobs in one worker renders the same samples as a fresh
one, so the same spec gives the same WAV bytes on any number of workers
(``tests/test_batch.py``).
"""

from __future__ import annotations

import dataclasses
import glob
import hashlib
import importlib
import io
import json
import math
import os
import re
import sys
import time
import tomllib
from collections import OrderedDict
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..io.errors import PresetError, SynthError, display_path

__all__ = [
    "SPEC_SCHEMA",
    "MANIFEST_FILE",
    "STATE_DIR",
    "BatchError",
    "Job",
    "BatchResult",
    "load_spec",
    "find_spec",
    "preset_sha256",
    "render_job",
    "render_many",
    "local_cluster",
]

#: the spec format's version (``schema = 1`` in the file)
SPEC_SCHEMA = 1
#: the manifest (Parquet) in the output directory
MANIFEST_FILE = "manifest.parquet"
#: the output directory's folder of finished jobs' rows
STATE_DIR = ".synth-batch"
#: a note entry's default velocity (MIDI) and length (s)
DEFAULT_VELOCITY = 100
DEFAULT_SECONDS = 4.0
#: the longest note (s) and MIDI render (s) a job may ask for
MAX_NOTE_S = 600.0
MAX_MIDI_S = 3600.0
#: most jobs one spec may expand to
MAX_JOBS = 1_000_000
#: voices (their designed keys) a worker keeps for later jobs of the same preset
VOICE_CACHE = 4
#: the retries of a job whose worker raised (a worker that dies is rerun by
#: the scheduler itself, up to ``distributed.scheduler.allowed-failures``)
RETRIES = 2
#: the glibc tuning variable Dask's nanny sets (see :func:`local_cluster`)
MALLOC_TRIM = "MALLOC_TRIM_THRESHOLD_"
#: a trim threshold this high (bytes) leaves the renders at their speed
#: (1 GiB: a grand note in 0.53 s, as unset; 65536: 1.12 s)
MALLOC_TRIM_OK = 1 << 30
#: glibc's number of malloc arenas in a worker: 1, the main thread's.  Dask
#: runs a task in a thread of its own, which by default gets an arena of its
#: own, whose heaps glibc unmaps whenever they empty: a 4-s grand note on A0
#: took 23 % more CPU in a thread than in the main thread, with 1.6x the page
#: faults (``tools/bench_batch.py --where``); in a worker with one arena, the same.
MALLOC_ARENAS = "MALLOC_ARENA_MAX"
#: Dask settings for the workers (and the local cluster's scheduler and
#: nannies).  With Dask's defaults (the statistical profiler every 10 ms, the
#: event loop's health tick every 20 ms, the memory monitor every 100 ms, the
#: system monitor every 0.5 s) an idle worker took 33-40 ms of CPU a second and
#: its nanny 20 more, about 6 % of the core it shares with the renders; with
#: these, 3-4 ms.  What is given up: the dashboard's profile page, and memory
#: limits checked once a second (a render holds far less than a worker's limit).
QUIET_DASK = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.worker.memory.monitor-interval": "1s",
    "distributed.admin.system-monitor.interval": "5s",
}
#: partials measured for the analysis summary (partial 1's T60 is the note's)
ANALYSIS_PARTIALS = 4

_NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$")
_TOP_KEYS = ("schema", "description", "format", "notes", "midi")
_NOTE_KEYS = ("name", "preset", "presets", "keys", "velocities", "seconds", "hold_seconds",
              "quality", "set", "sweep", "samples", "seed")
_MIDI_KEYS = ("name", "preset", "presets", "files", "max_seconds", "quality", "set", "sweep",
              "samples", "seed")
_QUALITIES = ("draft", "standard", "reference")
_FORMATS = ("float", "pcm24")


class BatchError(SynthError):
    """A bad spec, or a batch run that could not finish (one line)."""


# --------------------------------------------------------------------------- jobs
@dataclass(frozen=True)
class Job:
    """One render of a batch: a note or a MIDI file on a preset.

    Attributes
    ----------
    name : str
        The spec entry's ``name`` (the WAV's folder).
    index : int
        Position in the expanded spec (the manifest's order).
    kind : {"note", "midi"}
    preset : str
        Preset name, or the file name of a preset given as a path (its
        text is in ``preset_toml``).
    overrides : tuple of str
        ``PATH=VALUE`` overrides, in order (``--set``; the quality level as
        ``play.quality``).
    params : tuple of (str, object)
        The values the entry set or swept, by ``--set`` path, for the
        manifest's ``set.PATH`` columns.
    key : int or None
        MIDI key of a note (None: a study preset's own string).
    velocity : int or None
        MIDI velocity 1-127 of a note.
    seconds : float or None
        A note's length (s); a MIDI job's ``max_seconds`` or None.
    hold_s : float or None
        When a note's key is released (s); None: held to the end.
    quality : str or None
        The quality level asked for (None: the preset's).
    midi_name : str or None
        The MIDI file's name (as given, for the manifest).
    midi_sha256 : str or None
    subtype : {"float", "pcm24"}
        The WAV's sample format.
    preset_sha256 : str
        :func:`preset_sha256` of the preset with the overrides.
    preset_json : str
        The preset's validated values, canonical JSON (the manifest's full
        record of what was rendered).
    hash : str
        SHA-256 of everything that decides the samples (module notes).
    """

    name: str
    index: int
    kind: str
    preset: str
    overrides: tuple
    params: tuple
    key: int | None
    velocity: int | None
    seconds: float | None
    hold_s: float | None
    quality: str | None
    midi_name: str | None
    midi_sha256: str | None
    subtype: str
    preset_sha256: str
    preset_json: str = field(repr=False)
    hash: str = ""
    midi_bytes: bytes | None = field(default=None, repr=False, compare=False)
    preset_toml: bytes | None = field(default=None, repr=False, compare=False)

    @property
    def path(self) -> str:
        """The WAV's path relative to the output directory."""
        flat = self.preset.replace("/", "-").removesuffix(".toml")
        h = self.hash[:12]
        if self.kind == "note":
            k = "k---" if self.key is None else f"k{self.key:03d}"
            return f"{self.name}/{flat}_{k}_v{self.velocity:03d}_{h}.wav"
        stem = Path(self.midi_name or "midi").stem
        return f"{self.name}/{stem}_{flat}_{h}.wav"


def _canonical(obj) -> str:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), allow_nan=True)


def preset_sha256(preset) -> tuple[str, str]:
    """The content hash of a validated preset and its canonical JSON.

    The hash covers every validated value (after ``--set``), not the
    preset's name or file path: the same voice found in a checkout or in a
    wheel hashes alike, and a changed value changes it.

    Returns
    -------
    sha256 : str
        64 hex digits.
    text : str
        The canonical JSON (sorted keys, no spaces).
    """
    d = dataclasses.asdict(preset)
    d.pop("name", None)
    d.pop("path", None)
    text = _canonical(d)
    return hashlib.sha256(text.encode("utf-8")).hexdigest(), text


def _job_hash(j: Job) -> str:
    from .. import __version__

    ident = {"version": __version__, "name": j.name, "kind": j.kind, "preset": j.preset_sha256,
             "key": j.key, "velocity": j.velocity, "seconds": j.seconds, "hold_s": j.hold_s,
             "midi": j.midi_sha256, "subtype": j.subtype}
    return hashlib.sha256(_canonical(ident).encode("utf-8")).hexdigest()


# --------------------------------------------------------------------------- spec
def find_spec(name_or_path: str) -> Path:
    """A spec file: a path (``.toml``), or the name of a shipped spec
    (``synth/presets/batch/NAME.toml``: ``synth batch folk-tunes``).

    Raises
    ------
    BatchError
        Neither exists (the message lists the shipped specs).
    """
    p = Path(name_or_path).expanduser()
    if p.is_file():
        return p
    if str(name_or_path).endswith(".toml") or os.sep in str(name_or_path):
        raise BatchError(f"{display_path(p)}: batch spec not found")
    from ..io.presets import shipped_batch_dir

    d = shipped_batch_dir()
    cand = d / f"{name_or_path}.toml"
    if cand.is_file():
        return cand
    names = sorted(f.stem for f in d.glob("*.toml")) if d.is_dir() else []
    raise BatchError(f"batch spec '{name_or_path}' not found: give a .toml file or a shipped "
                     f"spec ({', '.join(names) or 'none shipped'})")


class _Spec:
    """Validation helpers that name the file and the dotted key."""

    def __init__(self, shown: str) -> None:
        self.shown = shown

    def fail(self, msg: str) -> BatchError:
        return BatchError(f"{self.shown}: {msg}")

    def unknown(self, where: str, table: dict, allowed: Sequence[str]) -> None:
        for k in table:
            if k not in allowed:
                full = f"{where}.{k}" if where else k
                raise self.fail(f"unknown key '{full}' (allowed: {', '.join(allowed)})")

    def number(self, where: str, v, lo: float, hi: float, *, integer: bool = False,
               lo_open: bool = False) -> float | int:
        ok_type = (isinstance(v, int) if integer else isinstance(v, (int, float))) and \
            not isinstance(v, bool)
        kind = "an integer" if integer else "a number"
        if not ok_type:
            raise self.fail(f"{where} = {_show(v)} must be {kind}")
        lo_ok = v > lo if lo_open else v >= lo
        if not (lo_ok and v <= hi):           # also NaN
            op = "<" if lo_open else "<="
            raise self.fail(f"{where} = {_show(v)} is out of range ({_g(lo)} {op} value <= {_g(hi)})")
        return int(v) if integer else float(v)


def _g(x) -> str:
    return f"{x:g}" if isinstance(x, float) else str(x)


def _show(v) -> str:
    if isinstance(v, str):
        return repr(v)
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (list, tuple)):
        inner = ", ".join(_show(x) for x in v[:6])
        return f"[{inner}{', ...' if len(v) > 6 else ''}]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{k} = {_show(x)}" for k, x in v.items()) + "}"
    return repr(v)


def _toml_value(v) -> str:
    """A value as a TOML literal for a ``--set`` override."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        f = float(v)
        if math.isnan(f):
            return "nan"
        if math.isinf(f):
            return "inf" if f > 0 else "-inf"
        return repr(f)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {v!r} as TOML")


class _Axis:
    """One swept quantity: its values (grid) or how to draw them (random).

    Forms: a scalar (one value); a list (each value; random: a uniform
    choice); a table ``{low, high[, steps]}`` (grid: ``steps`` values from
    low to high, ``linspace``; random: uniform in [low, high], integers for
    an integer axis).
    """

    def __init__(self, values=None, low=None, high=None, integer=False, dynamic=None) -> None:
        self.values, self.low, self.high, self.integer = values, low, high, integer
        self.dynamic = dynamic          # keys = "playable": depends on the preset

    def grid(self, ctx=None) -> list:
        if self.dynamic is not None:
            return self.dynamic(ctx)
        return list(self.values)

    def draw(self, rng, ctx=None):
        if self.dynamic is not None:
            vals = self.dynamic(ctx)
            return vals[int(rng.integers(len(vals)))]
        if self.values is not None:
            return self.values[int(rng.integers(len(self.values)))]
        if self.integer:
            return int(rng.integers(self.low, self.high + 1))
        return float(rng.uniform(self.low, self.high))


def _axis(sp: _Spec, where: str, v, *, random: bool, integer: bool, check) -> _Axis:
    """Read one axis (scalar, list or range table) and check every value
    with ``check(where, value) -> value``."""
    if isinstance(v, dict):
        sp.unknown(where, v, ("low", "high", "steps"))
        if "low" not in v or "high" not in v:
            raise sp.fail(f"{where} = {_show(v)}: a range needs low and high")
        lo, hi = check(f"{where}.low", v["low"]), check(f"{where}.high", v["high"])
        if hi < lo:
            raise sp.fail(f"{where}: high = {_g(hi)} is below low = {_g(lo)}")
        if random:
            if "steps" in v:
                raise sp.fail(f"{where}.steps: a random sweep draws from the range; "
                              "steps is for sweep = \"grid\"")
            return _Axis(low=lo, high=hi, integer=integer)
        if integer and "steps" not in v:
            return _Axis(values=list(range(int(lo), int(hi) + 1)))
        if "steps" not in v:
            raise sp.fail(f"{where}: a grid over a range of numbers needs steps (2 <= steps "
                          f"<= 10000), or give a list")
        n = sp.number(f"{where}.steps", v["steps"], 1, 10_000, integer=True)
        vals = np.linspace(lo, hi, n)
        if integer:
            out = sorted({int(round(x)) for x in vals})
        else:
            out = [float(x) for x in vals]
        return _Axis(values=out)
    if isinstance(v, list):
        if not v:
            raise sp.fail(f"{where} = []: give at least one value")
        return _Axis(values=[check(f"{where}[{i}]", x) for i, x in enumerate(v)])
    return _Axis(values=[check(where, v)])


@dataclass
class _Entry:
    kind: str
    name: str
    where: str
    presets: list
    axes: "OrderedDict[str, _Axis]"
    sweep: str
    samples: int | None
    seed: int
    files: list = field(default_factory=list)


def load_spec(path: str | os.PathLike) -> list[Job]:
    """Read, validate and expand a batch spec into jobs.

    Parameters
    ----------
    path : str or path
        The spec (``.toml``), or the name of a shipped spec
        (:func:`find_spec`).

    Returns
    -------
    list of Job
        In spec order: entries as written; within an entry, a grid in the
        order presets, keys, velocities, seconds, hold_seconds, quality,
        then the ``set`` paths as written (the last varies fastest), or the
        random samples as drawn.  A job equal to an earlier one (same hash)
        is left out.

    Raises
    ------
    BatchError
        One line naming the file, the key and what is allowed: unknown or
        missing keys, values out of range, unknown presets, a bad ``--set``
        path or value (as the preset's validation words it), missing MIDI
        files.
    """
    from ..io.presets import load_preset
    from ..io.presets.validate import parse_override

    spec_path = find_spec(str(path))
    shown = display_path(spec_path)
    sp = _Spec(shown)
    try:
        raw = tomllib.loads(spec_path.read_text("utf-8"))
    except (OSError, UnicodeDecodeError) as e:
        raise BatchError(f"{shown}: cannot read ({getattr(e, 'strerror', None) or e})") from None
    except tomllib.TOMLDecodeError as e:
        raise BatchError(f"{shown}: not valid TOML ({e})") from None
    sp.unknown("", raw, _TOP_KEYS)
    if "schema" not in raw:
        raise sp.fail(f"missing key 'schema' (this version reads schema = {SPEC_SCHEMA})")
    if raw["schema"] != SPEC_SCHEMA or isinstance(raw["schema"], bool):
        raise sp.fail(f"schema = {_show(raw['schema'])} is not supported (this version reads "
                      f"schema = {SPEC_SCHEMA})")
    if "description" in raw and not isinstance(raw["description"], str):
        raise sp.fail(f"description = {_show(raw['description'])} must be a string")
    subtype = raw.get("format", "float")
    if subtype not in _FORMATS:
        raise sp.fail(f"format = {_show(subtype)} is not allowed (choices: float, pcm24)")
    entries: list[_Entry] = []
    names: set[str] = set()
    for kind in ("notes", "midi"):
        block = raw.get(kind, [])
        if not isinstance(block, list) or not all(isinstance(t, dict) for t in block):
            raise sp.fail(f"{kind} must be an array of tables ([[{kind}]])")
        for i, t in enumerate(block):
            e = _read_entry(sp, kind, i, t, spec_path.parent, load_preset)
            if e.name in names:
                raise sp.fail(f"{e.where}.name = {e.name!r} is used twice (each entry's name "
                              "is its folder: make them unique)")
            names.add(e.name)
            entries.append(e)
    if not entries:
        raise sp.fail("no jobs: give at least one [[notes]] or [[midi]] entry")

    presets: dict = {}            # (preset, overrides) -> (Preset, sha, json)

    def resolve(e: _Entry, preset: str, overrides: tuple):
        k = (preset, overrides)
        if k not in presets:
            for o in overrides:
                try:
                    parse_override(o)
                except PresetError as err:
                    raise sp.fail(f"{e.where}.set: {err}") from None
            try:
                p = load_preset(preset, overrides)
            except PresetError as err:
                raise sp.fail(f"{e.where} ({e.name}): {err}") from None
            presets[k] = (p, *preset_sha256(p))
        return presets[k]

    midi_cache: dict = {}
    jobs: list[Job] = []
    seen: set[str] = set()
    for e in entries:
        for combo in _combos(sp, e, lambda pr: resolve(e, pr, ())[0]):
            job = _make_job(sp, e, combo, subtype, resolve, midi_cache, len(jobs))
            if job.hash in seen:
                continue
            seen.add(job.hash)
            jobs.append(job)
            if len(jobs) > MAX_JOBS:
                raise sp.fail(f"the spec expands to more than {MAX_JOBS} jobs")
    return jobs


def _read_entry(sp: _Spec, kind: str, i: int, t: dict, base: Path, load_preset) -> _Entry:
    where = f"{kind}[{i}]"
    sp.unknown(where, t, _NOTE_KEYS if kind == "notes" else _MIDI_KEYS)
    name = t.get("name")
    if name is None:
        raise sp.fail(f"missing key '{where}.name' (the entry's folder in the output)")
    if not isinstance(name, str) or not _NAME_RE.match(name):
        raise sp.fail(f"{where}.name = {_show(name)} is not allowed (1-64 letters, digits, "
                      "'_', '-', '.'; starting with a letter or digit)")
    if ("preset" in t) == ("presets" in t):
        raise sp.fail(f"{where}: give one of preset or presets")
    pl = [t["preset"]] if "preset" in t else t["presets"]
    if not isinstance(pl, list) or not pl or not all(isinstance(p, str) and p for p in pl):
        raise sp.fail(f"{where}.presets = {_show(pl)} must be a list of preset names or .toml paths")
    presets = []
    for p in pl:
        if p.endswith(".toml"):
            q = Path(p).expanduser()
            p = str(q if q.is_absolute() else (base / q))
        presets.append(p)
    sweep = t.get("sweep", "grid")
    if sweep not in ("grid", "random"):
        raise sp.fail(f"{where}.sweep = {_show(sweep)} is not allowed (choices: grid, random)")
    random = sweep == "random"
    samples = None
    if random:
        if "samples" not in t:
            raise sp.fail(f"missing key '{where}.samples' (sweep = \"random\" draws that many jobs)")
        samples = sp.number(f"{where}.samples", t["samples"], 1, MAX_JOBS, integer=True)
    elif "samples" in t or "seed" in t:
        bad = "samples" if "samples" in t else "seed"
        raise sp.fail(f"{where}.{bad} is for sweep = \"random\" (this entry's sweep is grid)")
    seed = sp.number(f"{where}.seed", t.get("seed", 0), 0, 2**63 - 1, integer=True)
    axes: OrderedDict[str, _Axis] = OrderedDict()
    axes["preset"] = _Axis(values=presets)
    if kind == "notes":
        if "keys" in t:
            if t["keys"] == "playable":
                def playable(p, _w=where):
                    pr = p
                    if pr.play is None or pr.kind != "musical":
                        raise sp.fail(f"{_w}.keys = 'playable': {pr.name} is not a musical "
                                      "preset (it has no playable keys)")
                    return list(range(pr.play.key_low, pr.play.key_high + 1))
                axes["key"] = _Axis(dynamic=playable)
            else:
                axes["key"] = _axis(sp, f"{where}.keys", t["keys"], random=random, integer=True,
                                    check=lambda w, v: sp.number(w, v, 0, 127, integer=True))
        else:
            axes["key"] = _Axis(values=[None])
        axes["velocity"] = _axis(sp, f"{where}.velocities", t.get("velocities", DEFAULT_VELOCITY),
                                 random=random, integer=True,
                                 check=lambda w, v: sp.number(w, v, 1, 127, integer=True))
        axes["seconds"] = _axis(sp, f"{where}.seconds", t.get("seconds", DEFAULT_SECONDS),
                                random=random, integer=False,
                                check=lambda w, v: sp.number(w, v, 0.0, MAX_NOTE_S, lo_open=True))
        axes["hold_s"] = _Axis(values=[None]) if "hold_seconds" not in t else _axis(
            sp, f"{where}.hold_seconds", t["hold_seconds"], random=random, integer=False,
            check=lambda w, v: sp.number(w, v, 0.0, MAX_NOTE_S, lo_open=True))
        files = []
    else:
        if "files" not in t:
            raise sp.fail(f"missing key '{where}.files' (MIDI files or glob patterns, relative "
                          "to the spec)")
        fl = [t["files"]] if isinstance(t["files"], str) else t["files"]
        if not isinstance(fl, list) or not fl or not all(isinstance(f, str) and f for f in fl):
            raise sp.fail(f"{where}.files = {_show(t['files'])} must be a file name, a glob "
                          "pattern or a list of them")
        files = []
        for pat in fl:
            full = os.path.expanduser(pat)
            full = full if os.path.isabs(full) else str(base / full)
            hits = sorted(glob.glob(full)) if glob.has_magic(full) else (
                [full] if os.path.isfile(full) else [])
            if not hits:
                raise sp.fail(f"{where}.files: {pat!r} matches no file (relative to "
                              f"{display_path(base)})")
            files += [h for h in hits if h not in files]
        axes["midi"] = _Axis(values=files)
        axes["seconds"] = _Axis(values=[None]) if "max_seconds" not in t else _axis(
            sp, f"{where}.max_seconds", t["max_seconds"], random=random, integer=False,
            check=lambda w, v: sp.number(w, v, 0.0, MAX_MIDI_S, lo_open=True))
    if "quality" in t:
        axes["quality"] = _axis(sp, f"{where}.quality", t["quality"], random=random, integer=False,
                                check=lambda w, v: _quality(sp, w, v))
    else:
        axes["quality"] = _Axis(values=[None])
    st = t.get("set", {})
    if not isinstance(st, dict):
        raise sp.fail(f"{where}.set = {_show(st)} must be a table of PATH = value(s)")
    for path, v in st.items():
        if path in ("play.quality",):
            raise sp.fail(f"{where}.set.{path}: give the level as {where}.quality")
        if isinstance(v, dict) and any(isinstance(x, (str, bool)) for x in v.values()):
            raise sp.fail(f"{where}.set.{path} = {_show(v)}: a range has numeric low and high")
        axes["set." + path] = _axis(
            sp, f"{where}.set.{path}", v, random=random, integer=False,
            check=lambda w, x: sp.number(w, x, -math.inf, math.inf)
            if isinstance(x, dict) else _set_value(sp, w, x))
    return _Entry(kind, name, where, presets, axes, sweep, samples, seed, files)


def _quality(sp: _Spec, where: str, v) -> str:
    if v not in _QUALITIES:
        raise sp.fail(f"{where} = {_show(v)} is not allowed (choices: {', '.join(_QUALITIES)})")
    return v


def _set_value(sp: _Spec, where: str, v):
    if isinstance(v, (dict,)):
        raise sp.fail(f"{where} = {_show(v)} must be a value")
    if isinstance(v, float) and not math.isfinite(v):
        raise sp.fail(f"{where} = {_show(v)} must be finite")
    return v


def _combos(sp: _Spec, e: _Entry, preset_of):
    """The entry's parameter combinations, as dicts axis -> value."""
    names = list(e.axes)
    if e.sweep == "grid":
        def rec(i, acc):
            if i == len(names):
                yield dict(acc)
                return
            ax = e.axes[names[i]]
            vals = ax.grid(preset_of(acc["preset"])) if ax.dynamic is not None else ax.grid()
            for v in vals:
                acc[names[i]] = v
                yield from rec(i + 1, acc)
            del acc[names[i]]
        yield from rec(0, {})
        return
    rng = np.random.default_rng(e.seed)
    for _ in range(e.samples):
        acc = {}
        for n in names:
            ax = e.axes[n]
            acc[n] = ax.draw(rng, preset_of(acc["preset"]) if ax.dynamic is not None else None)
        yield acc


def _make_job(sp: _Spec, e: _Entry, c: dict, subtype: str, resolve, midi_cache, index) -> Job:
    overrides = []
    params = []
    for n, v in c.items():
        if n.startswith("set."):
            overrides.append(f"{n[4:]}={_toml_value(v)}")
            params.append((n[4:], v))
    if c["quality"] is not None:
        overrides.append(f"play.quality={c['quality']}")
    overrides = tuple(overrides)
    preset = c["preset"]
    p, sha, pjson = resolve(e, preset, overrides)
    preset_toml = None
    shown_preset = preset
    if preset.endswith(".toml"):
        preset_toml = Path(preset).read_bytes()
        shown_preset = Path(preset).name
    key = c.get("key")
    midi_name = midi_sha = midi_bytes = None
    if e.kind == "notes":
        if p.kind == "musical":
            if key is None:
                raise sp.fail(f"{e.where}: {p.name} is a musical preset: give keys (a list, "
                              "a range {low, high} or \"playable\")")
            lo, hi = p.play.key_low, p.play.key_high
            if not (lo <= key <= hi):
                raise sp.fail(f"{e.where}.keys: key {key} is outside the playable range of "
                              f"{p.name} ({lo} <= key <= {hi})")
        elif key is not None:
            raise sp.fail(f"{e.where}.keys: {p.name} is a study preset (one string at its own "
                          "pitch): leave keys out")
        hold = c["hold_s"]
        if hold is not None and hold >= c["seconds"]:
            hold = None               # released at or after the end: held
        kind = "note"
        vel, secs = int(c["velocity"]), float(c["seconds"])
    else:
        f = c["midi"]
        if f not in midi_cache:
            data = Path(f).read_bytes()
            midi_cache[f] = (data, hashlib.sha256(data).hexdigest())
        midi_bytes, midi_sha = midi_cache[f]
        midi_name = Path(f).name
        kind, vel, hold = "midi", None, None
        secs = None if c["seconds"] is None else float(c["seconds"])
    job = Job(name=e.name, index=index, kind=kind, preset=shown_preset if preset_toml else preset,
              overrides=overrides, params=tuple(params), key=None if key is None else int(key),
              velocity=vel, seconds=secs, hold_s=hold, quality=c["quality"],
              midi_name=midi_name, midi_sha256=midi_sha, subtype=subtype, preset_sha256=sha,
              preset_json=pjson, midi_bytes=midi_bytes, preset_toml=preset_toml)
    return dataclasses.replace(job, hash=_job_hash(job))


# --------------------------------------------------------------------------- worker
_VOICES: "OrderedDict[tuple, Any]" = OrderedDict()


def _preset_source(job: Job, tmp: str) -> str:
    """The preset name, or a copy of the job's preset file in ``tmp``."""
    if job.preset_toml is None:
        return job.preset
    path = os.path.join(tmp, job.preset)
    with open(path, "wb") as f:
        f.write(job.preset_toml)
    return path


def _voice_for(job: Job, source: str):
    from ..io.factory import build_voice

    k = (job.preset, job.preset_sha256)
    v = _VOICES.pop(k, None)
    if v is None:
        v = build_voice(source, job.overrides)
    _VOICES[k] = v
    while len(_VOICES) > VOICE_CACHE:
        _VOICES.popitem(last=False)
    return v


def _analysis(x: np.ndarray, fs: int, job: Job, expected_hz: float | None) -> dict:
    """The analysis summary of ``synth analyze`` for the manifest: pitch,
    loudness, centroid and T60 of a note; loudness and centroid of a MIDI
    render."""
    from ..analysis import as_mono, loudness, spectral_centroid_hz

    mono = as_mono(x)
    out = {"f0_hz": None, "f0_expected_hz": expected_hz, "f0_cents": None,
           "inharmonicity_b": None, "loudness_lufs": None, "max_momentary_lufs": None,
           "centroid_onset_hz": None, "centroid_hz": None, "t60_s": None,
           "t60_early_s": None, "t60_late_s": None, "analysis_error": None}
    if not np.any(mono):
        out["analysis_error"] = "silent"
        return out
    if job.kind == "note":
        from .analyze import analyze_audio

        try:
            r = analyze_audio(mono, fs, key=job.key, f0_hz=expected_hz,
                              n_partials=ANALYSIS_PARTIALS)
        except SynthError as err:
            out["analysis_error"] = str(err)
            return out
        out["f0_hz"] = r["partial1_hz"]
        if expected_hz:
            out["f0_cents"] = 1200.0 * math.log2(r["partial1_hz"] / expected_hz)
        out["inharmonicity_b"] = r["inharmonicity_b"]
        out["loudness_lufs"] = r["loudness"]["integrated_lufs"]
        out["max_momentary_lufs"] = r["loudness"]["max_momentary_lufs"]
        c = r["centroid"]["centroid_hz"]
        if c:
            out["centroid_onset_hz"] = c[0]
            out["centroid_hz"] = float(np.median(c))
        p1 = r["partials"][0]
        out["t60_s"], out["t60_early_s"], out["t60_late_s"] = (
            p1.get("t60_s"), p1.get("t60_early_s"), p1.get("t60_late_s"))
        return out
    ld = loudness(mono, fs)
    out["loudness_lufs"] = _finite(ld["integrated_lufs"])
    out["max_momentary_lufs"] = _finite(ld["max_momentary_lufs"])
    on = int(np.flatnonzero(np.abs(mono) >= 0.01 * np.abs(mono).max())[0])
    out["centroid_onset_hz"] = float(spectral_centroid_hz(mono[on:on + int(0.1 * fs)], fs))
    out["centroid_hz"] = float(spectral_centroid_hz(mono, fs))
    return out


def _finite(v):
    return None if v is None or not math.isfinite(v) else float(v)


def render_job(job: Job) -> dict:
    """Render one job in memory (a worker's task).

    Returns
    -------
    dict
        ``{"wav": bytes, "row": dict}``: the WAV file and the job's
        manifest row (parameters, render facts, analysis summary).

    Raises
    ------
    SynthError
        A preset that no longer validates here, a worker whose preset
        differs from the client's (another ``synth`` version), a render
        that fails.
    """
    import socket
    import tempfile

    import soundfile as sf

    from ..io.wav import wav_bytes

    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="synth-batch-") as tmp:
        source = _preset_source(job, tmp)
        if job.kind == "note":
            from ..engine.engine import NOTE_OFF, NOTE_ON, Event
            from ..io.factory import build_engine

            voice = _voice_for(job, source)
            sha, _ = preset_sha256(voice.preset)
            if sha != job.preset_sha256:
                raise BatchError(f"{job.path}: this worker's preset {job.preset} differs from "
                                 "the client's (is the same synth version installed?)")
            eng = build_engine(voice.preset, voice=voice, extra_low_key=job.key)
            key = -1 if job.key is None else job.key
            ev = [Event(0.0, NOTE_ON, key, job.velocity / 127.0)]
            if job.hold_s is not None:
                ev.append(Event(job.hold_s, NOTE_OFF, key, 0.5))
            y = np.asarray(eng.render(ev, duration_s=job.seconds), dtype=np.float32)
            data, res = wav_bytes(y, eng.fs_out, job.subtype)
            fs = eng.fs_out
            try:
                expected = float(voice.pitch_hz(job.key))
            except ValueError:              # a voice with no pitch of its own
                expected = None
            notes = 1
        else:
            from ..io.presets import load_preset
            from .render import RenderRequest, render_midi_file

            if preset_sha256(load_preset(source, job.overrides))[0] != job.preset_sha256:
                raise BatchError(f"{job.path}: this worker's preset {job.preset} differs from "
                                 "the client's (is the same synth version installed?)")
            mid = os.path.join(tmp, "in.mid")
            with open(mid, "wb") as f:
                f.write(job.midi_bytes)
            out = os.path.join(tmp, "out.wav")
            rr = render_midi_file(RenderRequest(mid, source, out, job.overrides,
                                                pcm24=job.subtype == "pcm24",
                                                max_seconds=job.seconds))
            with open(out, "rb") as f:
                data = f.read()
            y, fs = sf.read(out, dtype="float32", always_2d=True)
            res = None
            expected = None
            notes = rr.notes
    render_s = time.perf_counter() - t0
    t1 = time.perf_counter()
    summary = _analysis(y, fs, job, expected)
    analysis_s = time.perf_counter() - t1
    peak = float(np.max(np.abs(y))) if y.size else 0.0
    row = {
        "job": job.name, "index": job.index, "hash": job.hash, "kind": job.kind,
        "file": job.path, "preset": job.preset, "preset_sha256": job.preset_sha256,
        "key": job.key, "velocity": job.velocity,
        "seconds": job.seconds, "hold_seconds": job.hold_s, "quality": job.quality,
        "midi_file": job.midi_name, "midi_sha256": job.midi_sha256, "format": job.subtype,
        "overrides": "; ".join(job.overrides),
        **{f"set.{k}": v for k, v in job.params},
        "notes": notes,
        "duration_s": y.shape[0] / fs, "channels": int(y.shape[1]) if y.ndim == 2 else 1,
        "fs_hz": int(fs),
        "peak_dbfs": 20.0 * math.log10(peak) if peak > 0 else None,
        "n_clipped": None if res is None else res.n_clipped,
        "wav_bytes": len(data), "wav_sha256": hashlib.sha256(data).hexdigest(),
        "render_s": render_s, "analysis_s": analysis_s,
        "worker": f"{socket.gethostname()}:{os.getpid()}",
        **summary,
        "preset_json": job.preset_json,
    }
    return {"wav": data, "row": row}


_WARMED: set = set()


def warm_worker(presets: Sequence[tuple[str, bytes | None]]) -> float:
    """Compile or load the kernels in this process: 20 ms of each preset
    (name and, for a preset file, its text) at its middle key, once per
    process and preset.  Returns the time it took (s)."""
    import tempfile

    from ..engine.engine import NOTE_ON, Event
    from ..io.factory import build_engine

    t = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="synth-warm-") as tmp:
        for name, text in presets:
            k = (name, None if text is None else hashlib.sha256(text).hexdigest())
            if k in _WARMED:
                continue
            _WARMED.add(k)
            src = name
            if text is not None:
                src = os.path.join(tmp, name)
                with open(src, "wb") as f:
                    f.write(text)
            eng = build_engine(src)
            p = eng.inst.preset
            key = (p.play.key_low + p.play.key_high) // 2 if p.kind == "musical" else -1
            eng.render([Event(0.0, NOTE_ON, key, 0.5)], duration_s=0.02)
    return time.perf_counter() - t


# --------------------------------------------------------------------------- driver
@dataclass
class BatchResult:
    """What :func:`render_many` did.

    Attributes
    ----------
    manifest : pandas.DataFrame
        One row per finished job of the spec, in spec order.
    rendered, skipped : int
        Jobs rendered now; jobs found finished and intact.
    failed : list of (Job, str)
        Jobs that failed, with the one-line reason.
    wall_s : float
        Time of the whole run (s).
    dashboard : str or None
        The Dask dashboard's address, if one ran.
    """

    manifest: Any
    rendered: int
    skipped: int
    failed: list
    wall_s: float
    dashboard: str | None = None


def _need_batch_extra(what: str):
    return BatchError(f'{what} needs the [batch] extra: pip install "synth[batch]"')


def _row_path(out: Path, h: str) -> Path:
    return out / STATE_DIR / "rows" / f"{h}.json"


def _finished(out: Path, job: Job) -> dict | None:
    """The job's row if it is finished and its WAV intact, else None."""
    rp = _row_path(out, job.hash)
    try:
        row = json.loads(rp.read_text("utf-8"))
    except (OSError, ValueError):
        return None
    wav = out / job.path
    try:
        if wav.stat().st_size != row.get("wav_bytes"):
            return None
        h = hashlib.sha256()
        with open(wav, "rb") as f:
            for chunk in iter(lambda: f.read(1 << 20), b""):
                h.update(chunk)
    except OSError:
        return None
    return row if h.hexdigest() == row.get("wav_sha256") else None


def _store(out: Path, job: Job, result: dict) -> dict:
    """Write a finished job: its WAV, then its row (both atomically)."""
    from ..io.wav import write_bytes_atomic, write_text_atomic

    wav = out / job.path
    wav.parent.mkdir(parents=True, exist_ok=True)
    write_bytes_atomic(wav, result["wav"])
    row = result["row"]
    rp = _row_path(out, job.hash)
    rp.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(rp, json.dumps(row, default=_jsonable))
    return row


def _jsonable(v):
    if isinstance(v, np.generic):
        return v.item()
    raise TypeError(f"{v!r} is not JSON")


def _manifest(rows: list[dict]):
    """The rows as a DataFrame with one dtype per column (``set.PATH``
    columns of numbers as float64, of other values as text)."""
    import pandas as pd

    df = pd.DataFrame(rows)
    for c in df.columns:
        if c.startswith("set."):
            vals = [v for v in df[c] if v is not None and not (isinstance(v, float) and math.isnan(v))]
            if vals and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in vals):
                df[c] = df[c].astype("float64")
            elif vals:
                df[c] = [None if v is None else (v if isinstance(v, str) else _toml_value(v))
                         for v in df[c]]
    for c in ("key", "velocity", "n_clipped", "notes"):
        if c in df.columns:
            df[c] = df[c].astype("Int64")
    return df


def _write_manifest(out: Path, df, csv: bool) -> None:
    from ..io.wav import write_bytes_atomic, write_text_atomic

    try:
        importlib.import_module("pyarrow")
    except ImportError:
        raise _need_batch_extra("the Parquet manifest") from None
    buf = io.BytesIO()
    df.to_parquet(buf, index=False)
    write_bytes_atomic(out / MANIFEST_FILE, buf.getvalue())
    if csv:
        write_text_atomic(out / "manifest.csv", df.to_csv(index=False))


def local_cluster(n_workers: int | None = None, *, dashboard: bool = True):
    """A ``LocalCluster`` of single-threaded worker processes, one per core
    by default, each with ``NUMBA_NUM_THREADS=1`` and ``SYNTH_THREADS=1`` (one
    render thread), ``MALLOC_ARENA_MAX=1``
    and this process's numba cache (``NUMBA_CACHE_DIR``, if set), and
    Dask's own threads slowed down (:data:`QUIET_DASK`).  Dask's nanny puts
    ``MALLOC_ARENA_MAX=1`` in this process's ``os.environ`` to spawn the
    workers with it (as it does with its own ``OMP_NUM_THREADS``)."""
    try:
        from dask.distributed import LocalCluster
    except ImportError:
        raise _need_batch_extra("synth batch") from None
    n = n_workers or os.cpu_count() or 1
    # one render thread per worker (synth.dsp.threads): the workers are the cores
    env = {"NUMBA_NUM_THREADS": "1", "SYNTH_THREADS": "1", "OMP_NUM_THREADS": "1",
           "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    if os.environ.get("NUMBA_CACHE_DIR"):
        env["NUMBA_CACHE_DIR"] = os.environ["NUMBA_CACHE_DIR"]
    import dask

    # Dask's nanny sets MALLOC_TRIM_THRESHOLD_=65536 in its workers: glibc
    # then hands freed memory back at once and stops raising its mmap
    # threshold, and the engine's per-block arrays fault their pages in
    # again and again.  A grand note rendered 2.3x slower (0.48 s -> 1.12 s
    # for 4 s, the same with the variable set in one process).  None leaves
    # glibc's own adaptive thresholds.  MALLOC_ARENA_MAX=1 (MALLOC_ARENAS):
    # the task thread allocates from the main arena; glibc reads it when the
    # process starts, so it is set before the spawn, not in `env`.
    # QUIET_DASK: Dask's own threads take 0.4 % of a core instead of 6 % (the
    # nannies pass this configuration on to their workers).
    with dask.config.set({f"distributed.nanny.pre-spawn-environ.{MALLOC_TRIM}": None,
                          f"distributed.nanny.pre-spawn-environ.{MALLOC_ARENAS}": "1",
                          **QUIET_DASK}):
        return LocalCluster(n_workers=n, threads_per_worker=1, processes=True, env=env,
                            dashboard_address=":8787" if dashboard else None, silence_logs=40)


def render_many(jobs: Sequence[Job], out_dir: str | os.PathLike, client=None, *,
                workers: int | None = None, csv: bool = False, progress: bool | None = None,
                dashboard: bool = True, log: Callable[[str], None] | None = None) -> BatchResult:
    """Render jobs into ``out_dir`` and write the manifest.

    Parameters
    ----------
    jobs : sequence of Job
        From :func:`load_spec`.
    out_dir : path
        Output directory (created): ``NAME/...wav``, ``manifest.parquet``,
        ``.synth-batch/rows/``.
    client : dask.distributed.Client or None
        An existing cluster's client; None: a :func:`local_cluster` for
        this run (closed at the end).
    workers : int or None
        Workers of the local cluster (default: one per core).
    csv : bool
        Also write ``manifest.csv``.
    progress : bool or None
        A progress bar (tqdm) on stderr; None: when stderr is a terminal.
    dashboard : bool
        Start the local cluster's dashboard (``http://...:8787/status``).
    log : callable or None
        Receives one-line notes (default: stderr).

    Returns
    -------
    BatchResult
        ``.manifest`` is the DataFrame written to ``manifest.parquet``.

    Raises
    ------
    BatchError
        The ``[batch]`` extra is missing, or the output directory cannot
        be written.  A job that fails is not raised: it is listed in
        ``failed`` and left out of the manifest.
    """
    t_run = time.perf_counter()
    if log is None:
        def log(line):
            print(line, file=sys.stderr, flush=True)
    try:
        importlib.import_module("pandas")
        from dask.distributed import as_completed
    except ImportError:
        raise _need_batch_extra("synth batch") from None
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise BatchError(f"-o {display_path(out)}: is a file, give a directory")
    try:
        (out / STATE_DIR / "rows").mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise BatchError(f"-o {display_path(out)}: cannot create ({e.strerror or e})") from None
    rows: dict[str, dict] = {}
    todo = []
    for j in jobs:
        r = _finished(out, j)
        if r is None:
            todo.append(j)
        else:
            rows[j.hash] = r
    skipped = len(rows)
    failed: list = []
    dash = None
    if todo:
        own = client is None
        cluster = None
        if own:
            from dask.distributed import Client

            # the kernels are compiled (or loaded) here first, into the cache
            # the workers share, so they do not all compile them at once
            warm_worker(_distinct_presets(todo))
            cluster = local_cluster(workers, dashboard=dashboard)
            client = Client(cluster)
        try:
            dash = _dashboard(client)
            if dash:
                log(f"note: Dask dashboard at {dash}")
            try:
                trims = client.run(_malloc_trim)
            except Exception as err:       # a worker with another synth, or none
                raise BatchError(f"the cluster's workers cannot run this synth's batch jobs "
                                 f"({_one_line(err)}); is the same synth version installed "
                                 "on them?") from None
            trimmed = [w for w, v in trims.items() if v is not None and v < MALLOC_TRIM_OK]
            if trimmed:
                log(f"note: {len(trimmed)} of the cluster's {len(trims)} workers have {MALLOC_TRIM} "
                    f"below {MALLOC_TRIM_OK} (Dask's nanny sets 65536), which makes renders "
                    f"about 2x slower; start them with {MALLOC_TRIM}={MALLOC_TRIM_OK} in "
                    f"their environment (docs/batch.md)")
            arenas = [w for w, v in client.run(_malloc_arenas).items() if v != "1"]
            if arenas:
                log(f"note: {len(arenas)} of the cluster's {len(trims)} workers run without "
                    f"{MALLOC_ARENAS}=1, which makes low notes up to 23 % slower; "
                    f"start them with it in their environment (docs/batch.md)")
            loud = client.run(_noisy_dask)
            noisy = {k for v in loud.values() for k in v}
            n_noisy = sum(bool(v) for v in loud.values())
            if noisy:
                log(f"note: {n_noisy} of the cluster's {len(trims)} workers run Dask's own "
                    f"threads more often than synth batch's local cluster does "
                    f"({', '.join(sorted(noisy))}), which takes up to 6 % of each worker's "
                    f"core; docs/batch.md gives the settings")
            client.run(warm_worker, _distinct_presets(todo))
            futures = {}
            for j in todo:
                fut = client.submit(render_job, j, key=f"synth-batch-{j.name}-{j.hash[:20]}",
                                    retries=RETRIES, pure=False)
                futures[fut] = j
            bar = None
            show = progress if progress is not None else _is_terminal(sys.stderr)
            if show:
                from tqdm import tqdm

                bar = tqdm(total=len(todo), file=sys.stderr, unit="job", desc="rendering",
                           mininterval=0.5)
            try:
                for fut in as_completed(list(futures)):
                    j = futures.pop(fut)
                    try:
                        res = fut.result()
                    except Exception as err:          # the job's own failure: reported
                        failed.append((j, _one_line(err)))
                    else:
                        rows[j.hash] = _store(out, j, res)
                    fut.release()
                    if bar is not None:
                        bar.update(1)
            finally:
                if bar is not None:
                    bar.close()
                for fut in futures:
                    fut.cancel()
        finally:
            if own:
                client.close()
                cluster.close()
    # in this spec's order (a row kept from a run of an earlier version of
    # the spec is given its place in this one)
    ordered = [{**rows[j.hash], "index": j.index} for j in jobs if j.hash in rows]
    df = _manifest(ordered)
    _write_manifest(out, df, csv)
    return BatchResult(df, len(todo) - len(failed), skipped, failed,
                       time.perf_counter() - t_run, dash)


def _malloc_trim() -> int | None:
    """This worker's ``MALLOC_TRIM_THRESHOLD_`` (bytes), or None (glibc's
    adaptive default).  A function of this module, so that it runs in the
    worker: ``os.environ.get`` would be pickled with the client's mapping."""
    v = os.environ.get(MALLOC_TRIM)
    try:
        return None if v is None else int(v)
    except ValueError:
        return None


def _malloc_arenas() -> str | None:
    """This worker's ``MALLOC_ARENA_MAX`` (as :func:`_malloc_trim`, run in the worker)."""
    return os.environ.get(MALLOC_ARENAS)


def _noisy_dask() -> list[str]:
    """The settings of :data:`QUIET_DASK` that this worker runs more often
    than they say (or, for the profiler, at all)."""
    import dask
    from dask.utils import parse_timedelta

    out = []
    for k, v in QUIET_DASK.items():
        cur = dask.config.get(k, None)
        if isinstance(v, bool):
            if bool(cur) != v:
                out.append(k)
        elif cur is not None and parse_timedelta(cur) < parse_timedelta(v):
            out.append(k)
    return out


def _distinct_presets(jobs: Sequence[Job]) -> list:
    seen = {}
    for j in jobs:
        seen.setdefault(j.preset, j.preset_toml)
    return list(seen.items())


def _dashboard(client) -> str | None:
    try:
        info = client.scheduler_info()
        if "dashboard" not in info.get("services", {}):
            return None
        return client.dashboard_link
    except Exception:      # a scheduler without the dashboard service
        return None


def _one_line(err: BaseException) -> str:
    text = str(err).strip().splitlines()
    return f"{type(err).__name__}: {text[0]}" if text else type(err).__name__


def _is_terminal(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError, OSError):
        return False
