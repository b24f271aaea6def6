"""``synth batch``'s spec: read, validated and expanded into jobs.

A *spec* (versioned TOML, :data:`SPEC_SCHEMA`; ``docs/batch.md`` documents
every key) lists entries: ``[[notes]]`` (single notes, swept over presets,
keys, velocities, lengths, quality levels and any preset value given as a
``--set`` path) and ``[[midi]]`` (Standard MIDI Files played by presets).
:func:`load_spec` validates it against the rows :data:`SPEC_FIELDS` and
:data:`SPEC_SECTIONS` (the presets' schema engine, :mod:`synth.io.presets.validate`)
and expands it into :class:`Job` objects; an error is one line naming the
file and the key (``spec.toml: notes[1].velocities[0] = 0 is out of range
(1 <= value <= 127)``).

A job's hash covers everything that decides its samples: the entry's name,
the kind, the preset's content (:func:`preset_sha256`, the validated values
after ``--set``), key, velocity, lengths, the MIDI file's bytes, the sample
format and the ``synth`` version.  Random sweeps draw from
``numpy.random.default_rng(seed)`` in a documented order.

Needs neither Dask nor pandas.  :mod:`synth.apps.batch_worker` renders a
job, :mod:`synth.apps.batch` runs the jobs (and re-exports this module's
public names).
"""

from __future__ import annotations

import dataclasses
import glob
import hashlib
import json
import os
import tomllib
from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..io.errors import PresetError, SynthError, display_path
from ..io.presets.schema import Field, Range, Section, When, _fmt_literal
from ..io.presets.loader import override_literal
from ..io.presets.validate import check_rows, validate_table

#: the spec format's version (``schema = 1`` in the file)
SPEC_SCHEMA = 1
#: a note entry's default velocity (MIDI) and length (s)
DEFAULT_VELOCITY = 100
DEFAULT_SECONDS = 4.0
#: the longest note (s) and MIDI render (s) a job may ask for
MAX_NOTE_S = 600.0
MAX_MIDI_S = 3600.0
#: most jobs one spec may expand to
MAX_JOBS = 1_000_000

_QUALITIES = ("draft", "standard", "reference")


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
    """Errors that name the file (the keys are checked by the schema engine)."""

    def __init__(self, shown: str) -> None:
        self.shown = shown

    def fail(self, msg: str) -> BatchError:
        return BatchError(f"{self.shown}: {msg}")


# --------------------------------------------------------------------------- rows
def _entry(kind: str, middle: tuple) -> Section:
    """A [[notes]] or [[midi]] entry's rows: name and presets, `middle`, then
    quality, set and the sweep's keys."""
    random = When(f"{kind}.sweep", ("random",))
    return Section(kind, f"entries of {'single notes' if kind == 'notes' else 'MIDI files'}",
                   dict, (
        Field("name", "str", "the entry's folder in the output; unique",
              pattern=(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}",
                       "1-64 letters, digits, '_', '-', '.'; starting with a letter or digit")),
        Field("preset", "line", "a preset name or .toml path (relative to the spec)",
              optional=True),
        Field("presets", "line", "preset names or .toml paths", many="list", excludes=("preset",)),
    ) + middle + (
        Field("quality", "str", "the quality level (default: the preset's)", choices=_QUALITIES,
              many="sweep", optional=True),
        Field("set", "any", "preset values by --set path", many="sweep", mapping=True, default=()),
        Field("sweep", "str", "grid: every combination; random: samples drawn",
              choices=("grid", "random"), default="grid"),
        Field("samples", "int", "jobs drawn", 1, MAX_JOBS, when=random),
        Field("seed", "int", "the generator's seed", 0, 2**63 - 1, when=random, default=0),
    ), array=True, optional=True)


#: The spec's top-level keys and its arrays of tables (values: one, a list
#: or a range table, ``many="sweep"``).
SPEC_FIELDS = (
    Field("schema", "int", "the spec format's version", choices=(SPEC_SCHEMA,)),
    Field("description", "str", "what the spec renders", default=""),
    Field("format", "str", "the WAV's sample format", choices=("float", "pcm24"), default="float"),
)
SPEC_SECTIONS = (
    _entry("notes", (
        Field("keys", "int", "MIDI keys, or \"playable\" (leave out for a study preset)", 0, 127,
              many="sweep", literals=("playable",), optional=True),
        Field("velocities", "int", "MIDI velocities", 1, 127, many="sweep",
              default=(DEFAULT_VELOCITY,)),
        Field("seconds", "float", "the note's length, s", 0.0, MAX_NOTE_S, lo_open=True,
              many="sweep", default=(DEFAULT_SECONDS,)),
        Field("hold_seconds", "float", "when the key is released, s (default: held)", 0.0,
              MAX_NOTE_S, lo_open=True, many="sweep", optional=True),
    )),
    _entry("midi", (
        Field("files", "line", "MIDI files or glob patterns, relative to the spec", many="one+"),
        Field("max_seconds", "float", "render at most this much of each file, s", 0.0,
              MAX_MIDI_S, lo_open=True, many="sweep", optional=True),
    )),
)
check_rows(SPEC_FIELDS, SPEC_SECTIONS)


#: a value as a TOML literal for a ``--set`` override
_toml_value = override_literal


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


def _axis(sp: _Spec, where: str, v, *, random: bool, integer: bool) -> _Axis:
    """An axis from a validated sweep value: a tuple of values or a :class:`Range`."""
    if not isinstance(v, Range):
        return _Axis(values=list(v))
    if random:
        if v.steps is not None:
            raise sp.fail(f"{where}.steps: a random sweep draws from the range; "
                          "steps is for sweep = \"grid\"")
        return _Axis(low=v.low, high=v.high, integer=integer)
    if v.steps is None:
        if integer:
            return _Axis(values=list(range(v.low, v.high + 1)))
        raise sp.fail(f"{where}: a grid over a range of numbers needs steps (2 <= steps "
                      f"<= 10000), or give a list")
    vals = np.linspace(v.low, v.high, v.steps)
    if integer:
        return _Axis(values=sorted({int(round(x)) for x in vals}))
    return _Axis(values=[float(x) for x in vals])


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
    v = validate_table(raw, shown, SPEC_FIELDS, SPEC_SECTIONS, error=BatchError,
                       show=_fmt_literal)
    subtype = v["format"]
    entries: list[_Entry] = []
    names: set[str] = set()
    for kind in ("notes", "midi"):
        for i, t in enumerate(v[kind]):
            e = _read_entry(sp, kind, i, t, spec_path.parent)
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


def _read_entry(sp: _Spec, kind: str, i: int, t: dict, base: Path) -> _Entry:
    """An entry from its validated values: presets found, MIDI files globbed, axes built."""
    where = f"{kind}[{i}]"
    presets = []
    for p in ((t["preset"],) if t["preset"] is not None else t["presets"]):
        if p.endswith(".toml"):
            q = Path(p).expanduser()
            p = str(q if q.is_absolute() else (base / q))
        presets.append(p)
    random = t["sweep"] == "random"
    seed = 0 if t["seed"] is None else t["seed"]
    axes: OrderedDict[str, _Axis] = OrderedDict()
    axes["preset"] = _Axis(values=presets)
    files = []
    if kind == "notes":
        if t["keys"] == "playable":
            def playable(pr, _w=where):
                if pr.play is None or pr.kind != "musical":
                    raise sp.fail(f"{_w}.keys = 'playable': {pr.name} is not a musical "
                                  "preset (it has no playable keys)")
                return list(range(pr.play.key_low, pr.play.key_high + 1))
            axes["key"] = _Axis(dynamic=playable)
        elif t["keys"] is None:
            axes["key"] = _Axis(values=[None])
        else:
            axes["key"] = _axis(sp, f"{where}.keys", t["keys"], random=random, integer=True)
        axes["velocity"] = _axis(sp, f"{where}.velocities", t["velocities"], random=random,
                                 integer=True)
        axes["seconds"] = _axis(sp, f"{where}.seconds", t["seconds"], random=random,
                                integer=False)
        axes["hold_s"] = _Axis(values=[None]) if t["hold_seconds"] is None else _axis(
            sp, f"{where}.hold_seconds", t["hold_seconds"], random=random, integer=False)
    else:
        for pat in t["files"]:
            full = os.path.expanduser(pat)
            full = full if os.path.isabs(full) else str(base / full)
            hits = sorted(glob.glob(full)) if glob.has_magic(full) else (
                [full] if os.path.isfile(full) else [])
            if not hits:
                raise sp.fail(f"{where}.files: {pat!r} matches no file (relative to "
                              f"{display_path(base)})")
            files += [h for h in hits if h not in files]
        axes["midi"] = _Axis(values=files)
        axes["seconds"] = _Axis(values=[None]) if t["max_seconds"] is None else _axis(
            sp, f"{where}.max_seconds", t["max_seconds"], random=random, integer=False)
    axes["quality"] = _Axis(values=[None]) if t["quality"] is None else _axis(
        sp, f"{where}.quality", t["quality"], random=random, integer=False)
    for path, v in t["set"]:
        if path in ("play.quality",):
            raise sp.fail(f"{where}.set.{path}: give the level as {where}.quality")
        axes["set." + path] = _axis(sp, f"{where}.set.{path}", v, random=random, integer=False)
    return _Entry(kind, t["name"], where, presets, axes, t["sweep"], t["samples"], seed, files)


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
