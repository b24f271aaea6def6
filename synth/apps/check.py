"""Spectrum tests: state what a preset must sound like, render it, check it.

A *spec* is a versioned TOML file (``schema = 1``) with ``[[render]]``
tables (what to render) and ``[[expect]]`` tables (what must hold, with
tolerances in musical units: cents, dB, LU, seconds).  ``synth check
SPEC.toml ...`` renders, measures, prints a pass/fail table with the
measured values, writes JUnit XML with ``--junit`` and exits 1 if any
expectation fails (2 for a bad spec).  :mod:`synth.testing` gives the same
checks to pytest.  The format is documented in ``docs/check.md``.

Renders
-------
``name`` (unique), and one source: ``preset`` (name or ``.toml`` path; with
``set = ["PATH=VALUE", ...]`` overrides) playing one note per item, or
``preset`` with ``midi = "FILE.mid"``, or ``wav = "FILE.wav"``.  Notes:
``key`` or ``keys`` (a list, or ``"LO..HI/STEP"``), ``velocity`` or
``velocities`` (MIDI 1..127, default 100), ``seconds`` (length rendered,
default 2), ``hold_s`` (key up after, default: held).  A sweep renders every
key at every velocity.  Paths are relative to the spec file.

Expectations
------------
Each names a ``render`` and a ``check``; per-note checks apply to every
item of the render:

============== ================================================ ==================================
check          measures                                         keys
============== ================================================ ==================================
f0             partial 1 against the voice's tuning (or hz)     cents, [hz]
partial        partial n against n x the tuned f0 (or hz)      n, cents, [hz]
partial_level  partial n re the strongest of the first 16 (dB)  n, min_db, max_db
t60            T60 of partial n (default 1), s                  [n], min_s, max_s
loudness       integrated loudness, LUFS (BS.1770)              lufs, lu
peak           sample peak, dBFS                                max_dbfs, [min_dbfs]
evenness       largest step between adjacent keys (per          max_step, [measure]
               velocity) of loudness (LU) or peak (dB)
monotonic      loudness, peak or centroid rising (falling)      measure, over, [direction],
               with velocity or key, allowing a dip             [tolerance]
centroid_ratio centroid(render) / centroid(against), item by    against, min, max
               item
highband_diff  energy above above_hz, render minus against, dB  against, above_hz, min_db, max_db
               over the whole render or a window, s            [start_s], [length_s]
partial_diff   partial n's level, render minus against, item   against, n, min_db, max_db,
               by item, dB (default 0.05-1.05 s)               [start_s], [length_s], [hz]
============== ================================================ ==================================
"""

from __future__ import annotations

import math
import os
import re
import time
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..analysis import (
    as_mono,
    cents,
    estimate_f0,
    fit_inharmonicity,
    halo,
    highband_db,
    loudness,
    momentary_lufs,
    partial_peaks,
    peak_dbfs,
    spectral_centroid_hz,
    t60_s,
    track_partials,
    two_stage_summary,
)
from ..io.errors import SynthError

__all__ = ["SpecError", "Item", "Result", "Spec", "load_spec", "render_note", "run_spec",
           "format_table", "write_junit", "CHECKS", "SPEC_SCHEMA"]

SPEC_SCHEMA = 1
FS_OUT = 48_000


class SpecError(SynthError):
    """A spec file is missing, unreadable or invalid (one line, file and key named)."""


@dataclass
class Item:
    """One rendered sound of a render: a note (key, velocity) or a file."""

    render: str
    audio: np.ndarray
    fs: int
    key: int | None = None
    velocity: int | None = None
    pitch_hz: float | None = None
    pitch_of: object = None        # the voice's pitch of any key (Hz), for a preset's note

    @property
    def label(self) -> str:
        if self.key is None:
            return self.render
        return f"{self.render}[key {self.key}, vel {self.velocity}]"


@dataclass
class Result:
    """One checked expectation on one item (or a sweep, or a pair)."""

    spec: str
    name: str
    measured: str
    expected: str
    passed: bool
    seconds: float = 0.0


@dataclass
class Spec:
    path: str
    description: str
    renders: list = field(default_factory=list)
    expects: list = field(default_factory=list)


# --------------------------------------------------------------------------
# Parsing
# --------------------------------------------------------------------------

_RENDER_KEYS = {"name", "preset", "set", "midi", "wav", "key", "keys", "velocity", "velocities",
                "seconds", "hold_s", "sustain", "soft"}
_KEYS_RANGE = re.compile(r"^\s*(\d+)\s*\.\.\s*(\d+)\s*(?:/\s*(\d+))?\s*$")


def _shown(path) -> str:
    from ..io.errors import display_path

    return display_path(path)


def _num(src, where, key, v, lo, hi, integer=False):
    ok = (isinstance(v, int) if integer else isinstance(v, (int, float))) and not isinstance(v, bool)
    if not ok or not (lo <= v <= hi) or (not integer and not math.isfinite(v)):
        kind = "an integer" if integer else "a number"
        raise SpecError(f"{src}: {where}.{key} = {v!r} is out of range ({kind}, {lo} <= value <= {hi})")
    return int(v) if integer else float(v)


def _keys(src, where, t):
    if "key" in t and "keys" in t:
        raise SpecError(f"{src}: {where}: give key or keys, not both")
    if "key" in t:
        return [_num(src, where, "key", t["key"], 0, 127, True)]
    if "keys" not in t:
        return []
    v = t["keys"]
    if isinstance(v, str):
        m = _KEYS_RANGE.match(v)
        if not m:
            raise SpecError(f"{src}: {where}.keys = {v!r} is not allowed "
                            f"(a list of MIDI keys or \"LO..HI/STEP\")")
        lo, hi, step = int(m[1]), int(m[2]), int(m[3] or 1)
        if not (0 <= lo <= hi <= 127 and step >= 1):
            raise SpecError(f"{src}: {where}.keys = {v!r} is out of range (0 <= LO <= HI <= 127, STEP >= 1)")
        return list(range(lo, hi + 1, step))
    if not isinstance(v, list) or not v:
        raise SpecError(f"{src}: {where}.keys = {v!r} is not allowed (a non-empty list or \"LO..HI/STEP\")")
    return [_num(src, where, "keys", k, 0, 127, True) for k in v]


def _velocities(src, where, t):
    if "velocity" in t and "velocities" in t:
        raise SpecError(f"{src}: {where}: give velocity or velocities, not both")
    if "velocities" in t:
        v = t["velocities"]
        if not isinstance(v, list) or not v:
            raise SpecError(f"{src}: {where}.velocities = {v!r} is not allowed (a non-empty list)")
        return [_num(src, where, "velocities", x, 1, 127, True) for x in v]
    return [_num(src, where, "velocity", t.get("velocity", 100), 1, 127, True)]


def _parse_render(src, base, i, t):
    where = f"render[{i}]"
    if not isinstance(t, dict):
        raise SpecError(f"{src}: {where} must be a table [[render]]")
    unknown = sorted(set(t) - _RENDER_KEYS)
    if unknown:
        raise SpecError(f"{src}: unknown key '{where}.{unknown[0]}' "
                        f"(allowed: {', '.join(sorted(_RENDER_KEYS))})")
    name = t.get("name")
    if not isinstance(name, str) or not name.strip():
        raise SpecError(f"{src}: {where}.name is required (a non-empty string)")
    r = {"name": name, "where": f"render '{name}'"}
    if "wav" in t:
        if set(t) & {"preset", "midi", "set", "key", "keys", "velocity", "velocities"}:
            raise SpecError(f"{src}: render '{name}': wav takes no preset, midi, set, keys or velocities")
        r["wav"] = str((base / str(t["wav"])).resolve())
        return r
    if not isinstance(t.get("preset"), str):
        raise SpecError(f"{src}: render '{name}': preset is required (or wav = \"FILE.wav\")")
    r["preset"] = t["preset"]
    sets = t.get("set", [])
    if not isinstance(sets, list) or not all(isinstance(s, str) for s in sets):
        raise SpecError(f"{src}: render '{name}'.set = {sets!r} is not allowed "
                        f"(a list of \"PATH=VALUE\" strings)")
    r["set"] = list(sets)
    if "midi" in t:
        if set(t) & {"key", "keys", "velocity", "velocities"}:
            raise SpecError(f"{src}: render '{name}': midi takes no keys or velocities")
        r["midi"] = str((base / str(t["midi"])).resolve())
        r["seconds"] = _num(src, r["where"], "seconds", t["seconds"], 0.1, 3600) if "seconds" in t else None
        return r
    r["keys"] = _keys(src, r["where"], t)
    if not r["keys"]:
        raise SpecError(f"{src}: render '{name}': key or keys is required for a preset note")
    r["velocities"] = _velocities(src, r["where"], t)
    r["seconds"] = _num(src, r["where"], "seconds", t.get("seconds", 2.0), 0.1, 60.0)
    r["hold_s"] = (_num(src, r["where"], "hold_s", t["hold_s"], 0.0, r["seconds"])
                   if "hold_s" in t else None)
    # pedals held from the start (CC64 sustain, CC67 soft), 0..1
    r["sustain"] = _num(src, r["where"], "sustain", t.get("sustain", 0.0), 0.0, 1.0)
    r["soft"] = _num(src, r["where"], "soft", t.get("soft", 0.0), 0.0, 1.0)
    return r


def load_spec(path) -> Spec:
    """Read and validate a spec file (see the module docstring).

    Raises
    ------
    SpecError
        One line naming the file, the key, the value and what is allowed.
    """
    p = Path(path)
    src = _shown(p)
    try:
        raw = tomllib.loads(p.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise SpecError(f"{src}: no such spec file") from None
    except (OSError, UnicodeDecodeError) as e:
        raise SpecError(f"{src}: cannot read the spec ({e.__class__.__name__})") from None
    except tomllib.TOMLDecodeError as e:
        raise SpecError(f"{src}: not valid TOML ({e})") from None
    unknown = sorted(set(raw) - {"schema", "description", "render", "expect"})
    if unknown:
        raise SpecError(f"{src}: unknown key '{unknown[0]}' (allowed: description, expect, render, schema)")
    if raw.get("schema") != SPEC_SCHEMA:
        raise SpecError(f"{src}: schema = {raw.get('schema')!r} is not allowed (choose {SPEC_SCHEMA})")
    desc = raw.get("description", "")
    if not isinstance(desc, str):
        raise SpecError(f"{src}: description = {desc!r} is not allowed (a string)")
    renders = raw.get("render", [])
    expects = raw.get("expect", [])
    if not isinstance(renders, list) or not renders:
        raise SpecError(f"{src}: at least one [[render]] table is required")
    if not isinstance(expects, list) or not expects:
        raise SpecError(f"{src}: at least one [[expect]] table is required")
    spec = Spec(str(p), desc)
    names = set()
    for i, t in enumerate(renders):
        r = _parse_render(src, p.parent, i, t)
        if r["name"] in names:
            raise SpecError(f"{src}: render name {r['name']!r} is used twice")
        names.add(r["name"])
        spec.renders.append(r)
    for i, t in enumerate(expects):
        spec.expects.append(_parse_expect(src, i, t, names))
    return spec


def _parse_expect(src, i, t, names):
    where = f"expect[{i}]"
    if not isinstance(t, dict):
        raise SpecError(f"{src}: {where} must be a table [[expect]]")
    chk = t.get("check")
    if chk not in CHECKS:
        raise SpecError(f"{src}: {where}.check = {chk!r} is not allowed "
                        f"(choose one of {', '.join(CHECKS)})")
    c = CHECKS[chk]
    allowed = {"render", "check", "name"} | set(c.required) | set(c.optional)
    unknown = sorted(set(t) - allowed)
    if unknown:
        raise SpecError(f"{src}: unknown key '{where}.{unknown[0]}' for check = {chk!r} "
                        f"(allowed: {', '.join(sorted(allowed))})")
    for k in ("render",) + c.required:
        if k not in t:
            raise SpecError(f"{src}: {where} (check = {chk!r}) is missing key '{k}'")
    for k in ("render", "against"):
        if k in t and t[k] not in names:
            raise SpecError(f"{src}: {where}.{k} = {t[k]!r} names no render "
                            f"(renders: {', '.join(sorted(names))})")
    e = dict(t)
    for k, (lo, hi, integer) in c.ranges.items():
        if k in e:
            e[k] = _num(src, where, k, e[k], lo, hi, integer)
    for k, choices in c.choices.items():
        if k in e and e[k] not in choices:
            raise SpecError(f"{src}: {where}.{k} = {e[k]!r} is not allowed "
                            f"(choose one of {', '.join(choices)})")
    for lo_k, hi_k in (("min_db", "max_db"), ("min_s", "max_s"), ("min", "max"),
                       ("min_dbfs", "max_dbfs")):
        if lo_k in e and hi_k in e and not e[lo_k] <= e[hi_k]:
            raise SpecError(f"{src}: {where}.{lo_k} = {e[lo_k]!r} must be <= {hi_k} = {e[hi_k]!r}")
    return e


# --------------------------------------------------------------------------
# Rendering
# --------------------------------------------------------------------------

def render_note(preset, key: int, velocity: int = 100, seconds: float = 2.0,
                overrides=(), hold_s: float | None = None, engine=None, sustain: float = 0.0,
                soft: float = 0.0):
    """Render one note of ``preset`` (name or path; ``overrides`` as
    ``--set``) at MIDI ``key`` and ``velocity`` (1..127) for ``seconds``,
    key up at ``hold_s`` (None: held), the sustain and soft pedals at
    ``sustain`` and ``soft`` (0..1) from the start.  Returns (audio float64
    at 48 kHz, the mean of a stereo render's channels; fs; the voice's pitch
    for the key in Hz)."""
    from ..engine.engine import Event
    from ..io.factory import build_engine

    eng = engine if engine is not None else build_engine(preset, overrides, fs_out=FS_OUT,
                                                         extra_low_key=key)
    ev = [Event(0.0, "control", cc, v) for cc, v in ((64, sustain), (67, soft)) if v > 0]
    ev.append(Event(0.0, "note_on", key, velocity / 127.0))
    if hold_s is not None:
        ev.append(Event(hold_s, "note_off", key, 0.0))
    y = as_mono(eng.render(ev, duration_s=seconds))      # a stereo render: its mean
    return y, eng.fs_out, eng.inst.pitch_hz(key)


def _render(spec_src: str, r: dict) -> list[Item]:
    if "wav" in r:
        import soundfile as sf

        try:
            x, fs = sf.read(r["wav"], dtype="float64", always_2d=True)
        except (OSError, RuntimeError) as e:
            raise SpecError(f"{spec_src}: render '{r['name']}': cannot read {_shown(r['wav'])} "
                            f"({str(e).splitlines()[0]})") from None
        return [Item(r["name"], x.mean(axis=1), int(fs))]
    if "midi" in r:
        from ..io.factory import build_engine
        from ..io.midi import midi_to_events, read_midi_file

        events = midi_to_events(read_midi_file(r["midi"]))
        keys = [int(e.key) for e in events if e.kind == "note_on" and e.value > 0]
        eng = build_engine(r["preset"], r["set"], fs_out=FS_OUT,
                           extra_low_key=min(keys) if keys else None)
        y = as_mono(eng.render(events, duration_s=r["seconds"], tail_s=0.5))
        return [Item(r["name"], y, eng.fs_out)]
    from ..io.factory import build_engine

    out = []
    eng = None
    for key in r["keys"]:
        for vel in r["velocities"]:
            # one voice per preset; a fresh engine per note (no leftovers)
            eng = build_engine(r["preset"], r["set"], fs_out=FS_OUT, extra_low_key=key,
                               voice=None if eng is None else eng.inst)
            y, fs, f = render_note(None, key, vel, r["seconds"], hold_s=r["hold_s"], engine=eng,
                                   sustain=r["sustain"], soft=r["soft"])
            out.append(Item(r["name"], y, fs, key, vel, f, pitch_of=eng.inst.pitch_hz))
    return out


# --------------------------------------------------------------------------
# Measures and checks
# --------------------------------------------------------------------------

def _segment(item: Item, start_s=0.05, length_s=1.0):
    a = int(start_s * item.fs)
    return item.audio[a:a + int(length_s * item.fs)]


def measure_f0(item: Item, hint_hz: float) -> float:
    """Partial 1 (Hz) of a note, from 50 ms to 1.05 s after its onset."""
    return estimate_f0(_segment(item), item.fs, hint_hz, search_cents=60.0)


def measure_partials(item: Item, f0_hz: float, n: int):
    """(frequencies Hz, levels dB re amplitude 1) of partials 1..n."""
    return partial_peaks(_segment(item), item.fs, f0_hz, n, search_cents=60.0)


def measure(item: Item, what: str) -> float:
    """A scalar of an item: "loudness" (integrated LUFS), "momentary" (the
    maximum 400 ms momentary loudness, LUFS: a note's loudness as a
    listener judges it), "peak" (dBFS) or "centroid" (Hz, over the first
    second)."""
    if what == "loudness":
        return loudness(item.audio, item.fs)["integrated_lufs"]
    if what == "momentary":
        return _max_momentary(item)
    if what == "peak":
        return peak_dbfs(item.audio)
    return spectral_centroid_hz(_segment(item, 0.0, 1.0), item.fs)


def _tuned(item: Item, e: dict) -> float:
    if "hz" in e:
        return float(e["hz"])
    if item.pitch_hz is None:
        raise SpecError(f"check = {e['check']!r} on render '{item.render}' needs hz "
                        f"(a WAV or MIDI render has no tuned pitch)")
    return item.pitch_hz


def _per_item(fn):
    def run(items, e, others):
        return [fn(it, e) for it in items]
    return run


def _c_f0(it, e):
    ref = _tuned(it, e)
    c = cents(measure_f0(it, ref), ref)
    return (it.label, f"{c:+.2f} cent", f"|x| <= {e['cents']:g} cent of {ref:.3f} Hz",
            abs(c) <= e["cents"])


def _c_partial(it, e):
    n = int(e["n"])
    ref = float(e["hz"]) if "hz" in e else n * _tuned(it, e)
    f, _ = measure_partials(it, ref / n, n)
    c = cents(f[-1], ref)
    return (f"{it.label} partial {n}", f"{c:+.2f} cent", f"|x| <= {e['cents']:g} cent of {ref:.2f} Hz",
            bool(abs(c) <= e["cents"]))


def _c_partial_level(it, e):
    n = int(e["n"])
    f0 = _tuned(it, e)
    nmax = max(16, n)
    nyq = int((0.45 * it.fs) // f0)
    seg = _segment(it, e.get("start_s", 0.05), e.get("length_s", 1.0))
    _, lv = partial_peaks(seg, it.fs, f0, max(1, min(nmax, nyq)), search_cents=60.0)
    rel = lv[n - 1] - np.nanmax(lv)
    return (f"{it.label} partial {n}", f"{rel:+.1f} dB",
            f"{e['min_db']:g} .. {e['max_db']:g} dB re strongest "
            f"({e.get('start_s', 0.05):g}-{e.get('start_s', 0.05) + e.get('length_s', 1.0):g} s)",
            bool(e["min_db"] <= rel <= e["max_db"]))


def _c_t60(it, e):
    n = int(e.get("n", 1))
    f0 = _tuned(it, e)
    try:
        t = t60_s(it.audio, it.fs, f_hz=n * f0, stop_db=-25.0)
        shown = f"{t:.2f} s"
    except ValueError:
        t, shown = float("nan"), "no decay to measure"
    return (f"{it.label} partial {n}", shown, f"{e['min_s']:g} .. {e['max_s']:g} s",
            bool(e["min_s"] <= t <= e["max_s"]))


def _c_loudness(it, e):
    v = measure(it, "loudness")
    return (it.label, f"{v:.1f} LUFS", f"{e['lufs']:g} +- {e['lu']:g} LU",
            bool(abs(v - e["lufs"]) <= e["lu"]))


def _c_peak(it, e):
    v = measure(it, "peak")
    lo = e.get("min_dbfs", -math.inf)
    return (it.label, f"{v:.1f} dBFS", f"{lo:g} .. {e['max_dbfs']:g} dBFS",
            bool(lo <= v <= e["max_dbfs"]))


def _groups(items, over):
    """Items grouped by the other sweep variable, sorted along ``over``."""
    g = {}
    for it in items:
        other = it.velocity if over == "key" else it.key
        g.setdefault(other, []).append(it)
    attr = "key" if over == "key" else "velocity"
    return {k: sorted(v, key=lambda it: getattr(it, attr)) for k, v in g.items()}


def _c_evenness(items, e, others):
    what = e.get("measure", "loudness")
    unit = "LU" if what in ("loudness", "momentary") else "dB"
    out = []
    for vel, its in _groups(items, "key").items():
        vals = [measure(it, what) for it in its]
        steps = np.abs(np.diff(vals)) if len(vals) > 1 else np.array([0.0])
        j = int(np.argmax(steps))
        where = f"keys {its[j].key}-{its[j + 1].key}" if len(its) > 1 else "one key"
        out.append((f"{items[0].render}[vel {vel}] {what} evenness",
                    f"{steps[j]:.2f} {unit} ({where})", f"<= {e['max_step']:g} {unit}",
                    bool(steps[j] <= e["max_step"])))
    return out


def _c_monotonic(items, e, others):
    what, over = e["measure"], e["over"]
    sign = 1.0 if e.get("direction", "increasing") == "increasing" else -1.0
    tol = float(e.get("tolerance", 0.0))
    out = []
    for other, its in _groups(items, over).items():
        vals = np.array([measure(it, what) for it in its])
        worst = float(np.min(sign * np.diff(vals))) if len(vals) > 1 else 0.0
        lab = f"vel {other}" if over == "key" else f"key {other}"
        out.append((f"{items[0].render}[{lab}] {what} {e.get('direction', 'increasing')} "
                    f"with {over}", f"worst step {sign * worst:+.2f}",
                    f"no step against it larger than {tol:g}", bool(worst >= -tol)))
    return out


def _pairs(items, e, others):
    b = others[e["against"]]
    if len(b) != len(items):
        raise SpecError(f"check = {e['check']!r}: render '{items[0].render}' has {len(items)} "
                        f"items and '{e['against']}' {len(b)}; they are compared item by item")
    return list(zip(items, b))


def _c_centroid_ratio(items, e, others):
    out = []
    w = e.get("window_s", 1.0)
    for a, b in _pairs(items, e, others):
        r = (spectral_centroid_hz(_segment(a, 0.0, w), a.fs)
             / spectral_centroid_hz(_segment(b, 0.0, w), b.fs))
        out.append((f"centroid {a.label} / {b.label}", f"{r:.3f}", f"{e['min']:g} .. {e['max']:g}",
                    bool(e["min"] <= r <= e["max"])))
    return out


def _c_highband_diff(items, e, others):
    out = []
    for a, b in _pairs(items, e, others):
        w = (e.get("start_s"), e.get("length_s"))
        d = (highband_db(a.audio, a.fs, e["above_hz"], *w)
             - highband_db(b.audio, b.fs, e["above_hz"], *w))
        span = ("" if w == (None, None) else
                f" ({w[0] or 0.0:g}-" + ("end" if w[1] is None else f"{(w[0] or 0.0) + w[1]:g} s") + ")")
        out.append((f"energy above {e['above_hz']:g} Hz{span}, {a.label} - {b.label}", f"{d:+.1f} dB",
                    f"{e['min_db']:g} .. {e['max_db']:g} dB", bool(e["min_db"] <= d <= e["max_db"])))
    return out


def _partial_db(it, e):
    """Partial ``n``'s peak level (dB) over ``length_s`` from ``start_s``
    (default 0.05 and 1 s)."""
    n = int(e["n"])
    seg = _segment(it, e.get("start_s", 0.05), e.get("length_s", 1.0))
    _, lv = partial_peaks(seg, it.fs, _tuned(it, e), n, search_cents=60.0)
    return float(lv[n - 1])


def _c_partial_diff(items, e, others):
    """Partial ``n``'s level, this render minus ``against``, item by item:
    what one part of the instrument does to one partial (the grand's capo
    bar against an ideal support, a body against none)."""
    out = []
    s0 = e.get("start_s", 0.05)
    s1 = s0 + e.get("length_s", 1.0)
    for a, b in _pairs(items, e, others):
        d = _partial_db(a, e) - _partial_db(b, e)
        out.append((f"partial {int(e['n'])} {a.label} - {b.label}", f"{d:+.1f} dB",
                    f"{e['min_db']:g} .. {e['max_db']:g} dB ({s0:g}-{s1:g} s)",
                    bool(e["min_db"] <= d <= e["max_db"])))
    return out


def _c_smooth(items, e, others):
    """Per velocity of a key sweep: the largest distance of a key's
    maximum momentary loudness from a cubic fit over the keys."""
    out = []
    for vel, its in _groups(items, "key").items():
        if len(its) < 5:
            raise SpecError(f"check = 'smooth' needs a sweep of at least 5 keys "
                            f"(render '{items[0].render}' has {len(its)})")
        k = np.array([it.key for it in its], dtype=float)
        v = np.array([_max_momentary(it) for it in its])
        fit = np.polyval(np.polyfit(k, v, 3), k)
        j = int(np.argmax(np.abs(v - fit)))
        out.append((f"{items[0].render}[vel {vel}] loudness against a cubic fit over the keys",
                    f"{v[j] - fit[j]:+.2f} dB (key {its[j].key})", f"|x| <= {e['max_db']:g} dB",
                    bool(abs(v[j] - fit[j]) <= e["max_db"])))
    return out


def _max_momentary(it):
    return float(np.max(momentary_lufs(it.audio, it.fs)[1]))


def _c_dynamic_range(items, e, others):
    """Per key of a sweep: the maximum momentary loudness at its highest
    velocity minus that at its lowest."""
    out = []
    for key, its in _groups(items, "velocity").items():
        if len(its) < 2:
            raise SpecError(f"check = 'dynamic_range': render '{items[0].render}' has one "
                            f"velocity for key {key}; give velocities = [LOW, ..., HIGH]")
        d = _max_momentary(its[-1]) - _max_momentary(its[0])
        lo, hi = e["min_db"], e.get("max_db", math.inf)
        out.append((f"{items[0].render}[key {key}] vel {its[0].velocity}..{its[-1].velocity}",
                    f"{d:.1f} dB", f"{lo:g} .. {hi:g} dB (maximum momentary loudness)",
                    bool(lo <= d <= hi)))
    return out


def _c_two_stage(it, e):
    """The note's level falls fast, then slowly: late / early T60 of the
    two-line fit (:func:`synth.analysis.two_stage_summary`, to ``stop_db``,
    default -50 dB) at least ``min_ratio``, with a visible knee."""
    try:
        d = two_stage_summary(it.audio, it.fs, stop_db=e.get("stop_db", -50.0),
                              min_ratio=e["min_ratio"],
                              min_drop_db=e.get("min_drop_db", 6.0),
                              min_late_db=e.get("min_late_db", 10.0))
    except ValueError:
        return (it.label, "no decay to fit", f"late/early >= {e['min_ratio']:g}, a knee", False)
    if d["ratio"] is None:
        shown = "no knee"
    else:
        shown = (f"late/early {d['ratio']:.2f} (T60 {d['t60_early_s']:.2f} -> "
                 f"{d['t60_late_s']:.2f} s, knee at {d['knee_s']:.2f} s, -{d['knee_drop_db']:.0f} dB)")
    return (it.label, shown, f"late/early >= {e['min_ratio']:g}, a visible knee",
            bool(d["visible"]))


def _c_partials_law(it, e):
    """Partials 1..n (up to ``n``, or ``max_hz``, whichever is fewer; those
    within 60 dB of the strongest) followed upward from the stiff-string
    law f_n = n f0 sqrt(1 + B n^2) fitted to them, within ``cents`` of
    it."""
    f1 = _tuned(it, e)
    nmax = int(e.get("n", 40))
    fmax = float(e.get("max_hz", 10000.0))
    seg = _segment(it)
    B0 = 1e-4
    fa, la = partial_peaks(seg, it.fs, f1, min(8, max(1, int(fmax // f1))), search_cents=60.0)
    ok = np.isfinite(fa)
    if ok.sum() >= 3:
        f0_fit, B0 = fit_inharmonicity(fa[ok], np.arange(1, len(fa) + 1)[ok])
    else:
        f0_fit = f1
    B0 = min(max(B0, 0.0), 0.1)
    n = np.arange(1, nmax + 1)
    law = n * f0_fit * np.sqrt(1 + B0 * n * n)
    K = int(max(1, np.sum(law <= fmax)))
    if K < 3:
        # two partials fix f0 and B exactly: nothing left to judge
        return (f"{it.label} partials 1..{K}", f"{K} partial(s) below {fmax:g} Hz",
                "at least 3 to judge the law", True)
    freqs, levels, _ = track_partials(seg, it.fs, f0_fit, K, inharmonicity=B0)
    good = np.isfinite(freqs) & (levels >= np.nanmax(levels) - 60.0)
    if good.sum() < 3:
        return (f"{it.label} partials 1..{K}", f"{int(good.sum())} partial(s) within 60 dB",
                "at least 3 to judge the law", True)
    f0_fit, B_fit = fit_inharmonicity(freqs[good], np.arange(1, K + 1)[good])
    law = np.arange(1, K + 1) * f0_fit * np.sqrt(1 + B_fit * np.arange(1, K + 1) ** 2)
    c = np.where(good, 1200.0 * np.log2(np.where(good, freqs, 1.0) / law), np.nan)
    j = int(np.nanargmax(np.abs(c)))
    return (f"{it.label} partials 1..{K}", f"{c[j]:+.2f} cent (partial {j + 1}; B {B_fit:.2e}, "
            f"{int(good.sum())} partials)", f"|x| <= {e['cents']:g} cent of the fitted law",
            bool(abs(c[j]) <= e["cents"]))


def _own_partials_hz(item: Item, f1_hz: float) -> np.ndarray:
    """The note's own partials (Hz) below 0.45 fs: the stiff-string law
    f_n = n f0 sqrt(1 + B n^2) fitted to its first 8 partials (B 0 for a
    harmonic note).  A piano's upper partials lie far above n f1 (C4's
    partial 40: +130 cents), where harmonic guesses would leave them in the
    halo's probe bands."""
    fa, _ = partial_peaks(_segment(item), item.fs, f1_hz, min(8, max(1, int(0.45 * item.fs // f1_hz))),
                          search_cents=60.0)
    ok = np.isfinite(fa)
    f0, B = f1_hz, 0.0
    if ok.sum() >= 3:
        f0, B = fit_inharmonicity(fa[ok], np.arange(1, len(fa) + 1)[ok])
        B = min(max(B, 0.0), 0.1)
    n = np.arange(1, 400)
    law = n * f0 * np.sqrt(1.0 + B * n * n)
    return law[law < 0.45 * item.fs]


def _c_halo(items, e, others):
    """Energy at the other keys' partial-1 frequencies (bands of
    ``probe_cents``; those within 40 cents of the note's own partials, on
    the stiff-string law fitted to the note without the halo, left out),
    this render over ``against``, item by item, from ``start_s`` on: the
    halo of strings that ring along (:func:`synth.analysis.halo`)."""
    out = []
    for a, b in _pairs(items, e, others):
        if a.pitch_of is None or a.key is None:
            raise SpecError(f"check = 'halo' needs a preset's notes (render '{a.render}')")
        f1 = a.pitch_hz
        probes = [a.pitch_of(k) for k in range(21, 109) if k != a.key]
        own = _own_partials_hz(b, f1)
        s0 = int(e.get("start_s", 0.5) * a.fs)
        n = min(len(a.audio), len(b.audio))
        h = halo(a.audio[s0:n], b.audio[s0:n], a.fs, probes, own,
                 probe_cents=e.get("probe_cents", 10.0))
        g = h["gain_db"]
        out.append((f"halo {a.label} over {b.label}", f"{g:+.1f} dB",
                    f">= {e['min_db']:g} dB at the other keys' pitches", bool(g >= e["min_db"])))
    return out


@dataclass(frozen=True)
class Check:
    run: object
    required: tuple
    optional: tuple = ()
    ranges: dict = field(default_factory=dict)
    choices: dict = field(default_factory=dict)


_DB = (-200.0, 200.0, False)
CHECKS = {
    "f0": Check(_per_item(_c_f0), ("cents",), ("hz",),
                {"cents": (0.0, 1200.0, False), "hz": (1.0, 20000.0, False)}),
    "partial": Check(_per_item(_c_partial), ("n", "cents"), ("hz",),
                     {"n": (1, 64, True), "cents": (0.0, 1200.0, False), "hz": (1.0, 20000.0, False)}),
    "partial_level": Check(_per_item(_c_partial_level), ("n", "min_db", "max_db"),
                           ("hz", "start_s", "length_s"),
                           {"n": (1, 64, True), "min_db": _DB, "max_db": _DB,
                            "hz": (1.0, 20000.0, False), "start_s": (0.0, 60.0, False),
                            "length_s": (0.01, 60.0, False)}),
    "t60": Check(_per_item(_c_t60), ("min_s", "max_s"), ("n", "hz"),
                 {"n": (1, 64, True), "min_s": (0.0, 1000.0, False), "max_s": (0.0, 1000.0, False),
                  "hz": (1.0, 20000.0, False)}),
    "loudness": Check(_per_item(_c_loudness), ("lufs", "lu"), (),
                      {"lufs": (-100.0, 10.0, False), "lu": (0.0, 100.0, False)}),
    "peak": Check(_per_item(_c_peak), ("max_dbfs",), ("min_dbfs",),
                  {"max_dbfs": _DB, "min_dbfs": _DB}),
    "evenness": Check(_c_evenness, ("max_step",), ("measure",), {"max_step": (0.0, 100.0, False)},
                      {"measure": ("loudness", "momentary", "peak")}),
    "monotonic": Check(_c_monotonic, ("measure", "over"), ("direction", "tolerance"),
                       {"tolerance": (0.0, 1e6, False)},
                       {"measure": ("loudness", "momentary", "peak", "centroid"),
                        "over": ("velocity", "key"),
                        "direction": ("increasing", "decreasing")}),
    "centroid_ratio": Check(_c_centroid_ratio, ("against", "min", "max"), ("window_s",),
                            {"min": (0.0, 1e3, False), "max": (0.0, 1e3, False),
                             "window_s": (0.01, 60.0, False)}),
    "smooth": Check(_c_smooth, ("max_db",), (),
                    {"max_db": (0.0, 100.0, False)}),
    "highband_diff": Check(_c_highband_diff, ("against", "above_hz", "min_db", "max_db"),
                           ("start_s", "length_s"),
                           {"above_hz": (1.0, 24000.0, False), "min_db": _DB, "max_db": _DB,
                            "start_s": (0.0, 60.0, False), "length_s": (0.01, 60.0, False)}),
    "partial_diff": Check(_c_partial_diff, ("against", "n", "min_db", "max_db"),
                          ("hz", "start_s", "length_s"),
                          {"n": (1, 64, True), "min_db": _DB, "max_db": _DB,
                           "hz": (1.0, 20000.0, False), "start_s": (0.0, 60.0, False),
                           "length_s": (0.01, 60.0, False)}),
    "dynamic_range": Check(_c_dynamic_range, ("min_db",), ("max_db",),
                           {"min_db": _DB, "max_db": _DB}),
    "two_stage": Check(_per_item(_c_two_stage), ("min_ratio",),
                       ("min_drop_db", "min_late_db", "stop_db"),
                       {"min_ratio": (0.0, 1e3, False), "min_drop_db": (0.0, 200.0, False),
                        "min_late_db": (0.0, 200.0, False), "stop_db": (-120.0, -10.0, False)}),
    "partials_law": Check(_per_item(_c_partials_law), ("cents",), ("n", "max_hz", "hz"),
                          {"cents": (0.0, 1200.0, False), "n": (2, 64, True),
                           "max_hz": (100.0, 24000.0, False), "hz": (1.0, 20000.0, False)}),
    "halo": Check(_c_halo, ("against", "min_db"), ("start_s", "probe_cents"),
                  {"min_db": _DB, "start_s": (0.0, 60.0, False), "probe_cents": (1.0, 50.0, False)}),
}


# --------------------------------------------------------------------------
# Running and reporting
# --------------------------------------------------------------------------

def run_spec(spec: Spec | str | os.PathLike, progress=None) -> list[Result]:
    """Render everything a spec names and check every expectation.

    ``progress``: called with a line of text as renders finish (or None).
    Returns one :class:`Result` per checked item.  Raises :class:`SpecError`
    (or another one-line :class:`SynthError`: a preset or MIDI file that does
    not load) for a spec that cannot run.
    """
    if not isinstance(spec, Spec):
        spec = load_spec(spec)
    src = _shown(spec.path)
    items = {}
    for r in spec.renders:
        t = time.perf_counter()
        items[r["name"]] = _render(src, r)
        if progress:
            progress(f"{src}: rendered '{r['name']}' ({len(items[r['name']])} items, "
                     f"{time.perf_counter() - t:.1f} s)")
    results = []
    for i, e in enumerate(spec.expects):
        t = time.perf_counter()
        try:
            rows = CHECKS[e["check"]].run(items[e["render"]], e, items)
        except SpecError as err:
            raise SpecError(f"{src}: expect[{i}]: {err}") from None
        dt = (time.perf_counter() - t) / max(1, len(rows))
        prefix = f"{e['name']}: " if "name" in e else ""
        for name, measured, expected, ok in rows:
            results.append(Result(src, f"{prefix}{e['check']} {name}", measured, expected,
                                  bool(ok), dt))
    return results


def format_table(results: list[Result]) -> str:
    """Pass/fail table with the measured values."""
    rows = [("", "check", "measured", "expected")]
    rows += [("PASS" if r.passed else "FAIL", r.name, r.measured, r.expected) for r in results]
    w = [max(len(row[i]) for row in rows) for i in range(4)]
    lines = ["  ".join(c.ljust(w[i]) for i, c in enumerate(row)).rstrip() for row in rows]
    lines.insert(1, "  ".join("-" * x for x in w))
    n_fail = sum(not r.passed for r in results)
    lines.append(f"{len(results) - n_fail} passed, {n_fail} failed")
    return "\n".join(lines)


def write_junit(path, results: list[Result]) -> None:
    """JUnit XML (one testsuite per spec file, one testcase per result),
    written atomically."""
    import xml.etree.ElementTree as ET

    from ..io.wav import write_text_atomic

    root = ET.Element("testsuites", name="synth check")
    by_spec = {}
    for r in results:
        by_spec.setdefault(r.spec, []).append(r)
    for spec, rs in by_spec.items():
        suite = ET.SubElement(root, "testsuite", name=spec, tests=str(len(rs)),
                              failures=str(sum(not r.passed for r in rs)), errors="0",
                              time=f"{sum(r.seconds for r in rs):.3f}")
        for r in rs:
            case = ET.SubElement(suite, "testcase", classname=spec, name=r.name,
                                 time=f"{r.seconds:.3f}")
            ET.SubElement(case, "system-out").text = f"measured {r.measured}; expected {r.expected}"
            if not r.passed:
                ET.SubElement(case, "failure", message=f"measured {r.measured}, expected {r.expected}")
    text = ET.tostring(root, encoding="unicode")
    write_text_atomic(os.fspath(path), '<?xml version="1.0" encoding="UTF-8"?>\n' + text + "\n")
