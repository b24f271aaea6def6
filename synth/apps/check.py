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
f0             partial 1 against the voice's tuning (or hz),    cents, [hz], [start_s],
               over a window (default 0.05-1.05 s)              [length_s]
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
    band_centroid_hz,
    band_db,
    highband_db,
    largest_fall_db,
    loudness,
    max_momentary_lufs,
    partial_peaks,
    peak_dbfs,
    spectral_centroid_hz,
    t60_s,
    track_partials,
    two_stage_summary,
)
from ..io.errors import SynthError
from ..io.filekind import file_kind
from ..io.presets.schema import ABSENT, GIVEN, Field, OrderCheck, Section, When, _fmt_literal
from ..io.presets.validate import check_rows, validate_table

__all__ = ["SpecError", "Item", "Result", "Spec", "load_spec", "render_note", "run_spec",
           "format_table", "write_junit", "CHECKS", "SPEC_SCHEMA", "SPEC_FIELDS", "SPEC_SECTIONS"]

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

def _shown(path) -> str:
    from ..io.errors import display_path

    return display_path(path)


def load_spec(path) -> Spec:
    """Read and validate a spec file (see the module docstring; its keys are
    the rows :data:`SPEC_FIELDS` and :data:`SPEC_SECTIONS`, validated by the
    presets' schema engine).

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
    except UnicodeDecodeError:
        raise SpecError(f"{src}: not a spec: it is {file_kind(p) or 'binary data'}, and a spec is a "
                        "TOML text file (synth help check)") from None
    except OSError as e:
        raise SpecError(f"{src}: cannot read the spec ({e.__class__.__name__})") from None
    except tomllib.TOMLDecodeError as e:
        raise SpecError(f"{src}: not valid TOML ({e})") from None
    v = validate_table(raw, src, SPEC_FIELDS, SPEC_SECTIONS, error=SpecError, show=_fmt_literal,
                       base=p.parent)
    spec = Spec(str(p), v["description"])
    names = set()
    for r in v["render"]:
        if r["name"] in names:
            raise SpecError(f"{src}: render name {r['name']!r} is used twice")
        names.add(r["name"])
        spec.renders.append(_render_dict(r))
    for i, (e, t) in enumerate(zip(v["expect"], raw["expect"])):
        for k in ("render", "against"):
            if e[k] is not None and e[k] not in names:
                raise SpecError(f"{src}: expect[{i}].{k} = {e[k]!r} names no render "
                                f"(renders: {', '.join(sorted(names))})")
        spec.expects.append({k: e[k] for k in t})      # the keys given, in the file's order
    return spec


def _render_dict(v: dict) -> dict:
    """A validated [[render]] table as :func:`run_spec` reads it."""
    r = {"name": v["name"], "where": f"render '{v['name']}'"}
    if v["wav"] is not None:
        r["wav"] = v["wav"]
        return r
    r["preset"], r["set"] = v["preset"], list(v["set"])
    if v["midi"] is not None:
        r["midi"], r["seconds"] = v["midi"], v["seconds"]
        return r
    r["keys"] = [v["key"]] if v["keys"] is None else list(v["keys"])
    r["velocities"] = [v["velocity"]] if v["velocities"] is None else list(v["velocities"])
    for k in ("seconds", "hold_s", "sustain", "soft"):
        r[k] = v[k]
    return r


# --------------------------------------------------------------------------
# Rendering
# --------------------------------------------------------------------------

def render_note(preset, key: int, velocity: int = 100, seconds: float = 2.0,
                overrides=(), hold_s: float | None = None, engine=None, sustain: float = 0.0,
                soft: float = 0.0, mono: bool = True):
    """Render one note of ``preset`` (name or path; ``overrides`` as
    ``--set``) at MIDI ``key`` and ``velocity`` (1..127) for ``seconds``,
    key up at ``hold_s`` (None: held), the sustain and soft pedals at
    ``sustain`` and ``soft`` (0..1) from the start.  Returns (audio float64
    at 48 kHz; fs; the voice's pitch for the key in Hz).  The audio is
    shape (frames,), the mean of a stereo render's channels, with ``mono``
    (the default), else every channel, shape (frames, channels) (1 or 2)."""
    from ..engine.engine import Event
    from ..io.factory import build_engine

    eng = engine if engine is not None else build_engine(preset, overrides, fs_out=FS_OUT,
                                                         extra_low_key=key, drone=False)
    ev = [Event(0.0, "control", cc, v) for cc, v in ((64, sustain), (67, soft)) if v > 0]
    ev.append(Event(0.0, "note_on", key, velocity / 127.0))
    if hold_s is not None:
        ev.append(Event(hold_s, "note_off", key, 0.0))
    y = eng.render(ev, duration_s=seconds)
    # mono: a stereo render's mean; else (frames, channels) for any preset
    y = as_mono(y) if mono else y.reshape(len(y), -1)
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
            # (a drone preset's key plucks its one string: drone=False)
            eng = build_engine(r["preset"], r["set"], fs_out=FS_OUT, extra_low_key=key,
                               voice=None if eng is None else eng.inst, drone=False)
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


def measure_f0(item: Item, hint_hz: float, start_s: float = 0.05, length_s: float = 1.0) -> float:
    """Partial 1 (Hz) of a note over ``length_s`` from ``start_s`` after its
    onset (default 50 ms to 1.05 s)."""
    return estimate_f0(_segment(item, start_s, length_s), item.fs, hint_hz, search_cents=60.0)


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
    t0, n = e.get("start_s", 0.05), e.get("length_s", 1.0)
    if ("start_s" in e or "length_s" in e) and t0 + n > len(it.audio) / it.fs + 1e-9:
        raise SpecError(f"start_s + length_s = {t0 + n:g} is out of range (within the render's "
                        f"{len(it.audio) / it.fs:g} s)")
    c = cents(measure_f0(it, ref, t0, n), ref)
    span = "" if (t0, n) == (0.05, 1.0) else f" ({t0:g}-{t0 + n:g} s)"
    return (f"{it.label}{span}", f"{c:+.2f} cent", f"|x| <= {e['cents']:g} cent of {ref:.3f} Hz",
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
    top = e.get("below_hz")
    for a, b in _pairs(items, e, others):
        w = (e.get("start_s"), e.get("length_s"))
        if top is None:
            d = (highband_db(a.audio, a.fs, e["above_hz"], *w)
                 - highband_db(b.audio, b.fs, e["above_hz"], *w))
        else:
            t0 = w[0] or 0.0
            t1 = min(len(a.audio) / a.fs, len(b.audio) / b.fs) if w[1] is None else t0 + w[1]
            d = (band_db(as_mono(a.audio), a.fs, e["above_hz"], top, t0, t1)
                 - band_db(as_mono(b.audio), b.fs, e["above_hz"], top, t0, t1))
        span = ("" if w == (None, None) else
                f" ({w[0] or 0.0:g}-" + ("end" if w[1] is None else f"{(w[0] or 0.0) + w[1]:g} s") + ")")
        band = f"above {e['above_hz']:g} Hz" if top is None else f"in {e['above_hz']:g}-{top:g} Hz"
        out.append((f"energy {band}{span}, {a.label} - {b.label}", f"{d:+.1f} dB",
                    f"{e['min_db']:g} .. {e['max_db']:g} dB", bool(e["min_db"] <= d <= e["max_db"])))
    return out


def _span(e, name):
    v = tuple(float(x) for x in e[name])
    if len(v) != 2 or not v[0] < v[1]:
        raise SpecError(f"{name} = {list(e[name])!r} is out of range (two times, start < end, s)")
    return v


def _c_centroid_fall(it, e):
    lo, hi = e["above_hz"], e["below_hz"]
    (a0, a1), (b0, b1) = _span(e, "early_s"), _span(e, "late_s")
    y = as_mono(it.audio)
    if b1 > len(y) / it.fs:
        raise SpecError(f"late_s = {list(e['late_s'])!r} is out of range (within the render's "
                        f"{len(y) / it.fs:g} s)")
    c0 = band_centroid_hz(y, it.fs, lo, hi, a0, a1)
    c1 = band_centroid_hz(y, it.fs, lo, hi, b0, b1)
    fall = 100.0 * (1.0 - c1 / c0)
    return (f"centre of {lo:g}-{hi:g} Hz, {a0:g}-{a1:g} s -> {b0:g}-{b1:g} s, {it.label}",
            f"{c0:.0f} -> {c1:.0f} Hz ({fall:.1f} % down)", f">= {e['min_fall_percent']:g} % down",
            bool(fall >= e["min_fall_percent"]))


def _c_band_fall(it, e):
    lo, hi = e["above_hz"], e["below_hz"]
    t0 = e.get("start_s", 0.3)
    t1 = t0 + e.get("length_s", 2.2)
    fall, at = largest_fall_db(it.audio, it.fs, lo, hi, e["span_s"], t0, t1)
    where = "" if fall == 0.0 else f" (into {at:.1f} s)"
    return (f"largest {e['span_s']:g} s fall of {lo:g}-{hi:g} Hz, {t0:g}-{t1:g} s, {it.label}",
            f"{fall:.1f} dB{where}", f"<= {e['max_db']:g} dB", bool(fall <= e["max_db"]))


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
    return max_momentary_lufs(it.audio, it.fs)


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
    """One kind of expectation: ``run(items, e, others)`` gives its rows.
    Its keys, ranges and defaults are rows of :data:`EXPECT`."""

    run: object


CHECKS = {
    "f0": Check(_per_item(_c_f0)),
    "partial": Check(_per_item(_c_partial)),
    "partial_level": Check(_per_item(_c_partial_level)),
    "t60": Check(_per_item(_c_t60)),
    "loudness": Check(_per_item(_c_loudness)),
    "peak": Check(_per_item(_c_peak)),
    "evenness": Check(_c_evenness),
    "monotonic": Check(_c_monotonic),
    "centroid_ratio": Check(_c_centroid_ratio),
    "smooth": Check(_c_smooth),
    "highband_diff": Check(_c_highband_diff),
    "partial_diff": Check(_c_partial_diff),
    "dynamic_range": Check(_c_dynamic_range),
    "two_stage": Check(_per_item(_c_two_stage)),
    "partials_law": Check(_per_item(_c_partials_law)),
    "halo": Check(_c_halo),
    "band_fall": Check(_per_item(_c_band_fall)),
    "centroid_fall": Check(_per_item(_c_centroid_fall)),
}


# --------------------------------------------------------------------------
# The spec's rows (validated by the presets' schema engine, synth.io.presets)
# --------------------------------------------------------------------------

_WAV_MIDI = ("wav", "midi")


def _on(*checks: str) -> When:
    return When("expect.check", checks)


#: A [[render]] table: a WAV file, a preset playing a MIDI file, or a
#: preset's notes (every key at every velocity), as the keys given say.
RENDER = Section("render", "what to render", dict, (
    Field("name", "line", "unique; expectations name it"),
    Field("wav", "path", "a WAV file to check, relative to the spec", optional=True),
    Field("preset", "str", "a preset name or .toml path", excludes=("wav",)),
    Field("set", "str", "--set overrides, PATH=VALUE", many="list0", default=(),
          excludes=("wav",)),
    Field("midi", "path", "a MIDI file the preset plays, relative to the spec", optional=True,
          excludes=("wav",)),
    Field("key", "int", "a MIDI key", 0, 127, optional=True, excludes=_WAV_MIDI),
    Field("keys", "int", "MIDI keys: a list, or \"LO..HI/STEP\" (a sweep)", 0, 127, many="list",
          span=True, excludes=_WAV_MIDI + ("key",)),
    Field("velocities", "int", "MIDI velocities", 1, 127, many="list", optional=True,
          excludes=_WAV_MIDI),
    Field("velocity", "int", "a MIDI velocity", 1, 127, default=100,
          excludes=_WAV_MIDI + ("velocities",)),
    Field("seconds", "float", "length of the MIDI render, s (default: the file's)", 0.1, 3600.0,
          optional=True, when=When("render.midi", (GIVEN,)), excludes=("wav",)),
    Field("seconds", "float", "length rendered, s", 0.1, 60.0, default=2.0,
          when=When("render.midi", (ABSENT,)), excludes=("wav",)),
    Field("hold_s", "float", "key up after, s (default: held)", 0.0, 60.0, optional=True,
          excludes=_WAV_MIDI),
    Field("sustain", "float", "sustain pedal (CC64) held from the start, 0..1", 0.0, 1.0,
          default=0.0, excludes=_WAV_MIDI),
    Field("soft", "float", "soft pedal (CC67, una corda) held from the start, 0..1", 0.0, 1.0,
          default=0.0, excludes=_WAV_MIDI),
), checks=(OrderCheck("hold_s", "<=", "seconds"),), array=True, label="name")

_DB = (-200.0, 200.0)
#: An [[expect]] table: ``check`` selects its keys (required, or optional:
#: ``optional=True``, the check's default applies; elsewhere refused).
EXPECT = Section("expect", "what must hold", dict, (
    Field("name", "str", "a label for the table", optional=True),
    Field("render", "str", "the render checked (its name)"),
    Field("check", "str", "what is measured", choices=tuple(CHECKS)),
    Field("against", "str", "the render compared with, item by item",
          when=_on("centroid_ratio", "highband_diff", "partial_diff", "halo")),
    Field("n", "int", "partial number", 1, 64,
          when=_on("partial", "partial_level", "partial_diff")),
    Field("n", "int", "partial number (default 1)", 1, 64, when=_on("t60"), optional=True),
    Field("n", "int", "partials followed (default 40)", 2, 64, when=_on("partials_law"),
          optional=True),
    Field("cents", "float", "tolerance, cents", 0.0, 1200.0,
          when=_on("f0", "partial", "partials_law")),
    Field("hz", "float", "the tuned pitch, Hz (default: the voice's)", 1.0, 20000.0, optional=True,
          when=_on("f0", "partial", "partial_level", "t60", "partial_diff", "partials_law")),
    Field("min_db", "float", "lowest level, dB", *_DB,
          when=_on("partial_level", "highband_diff", "partial_diff", "dynamic_range", "halo")),
    Field("max_db", "float", "highest level, dB", *_DB,
          when=_on("partial_level", "highband_diff", "partial_diff")),
    Field("max_db", "float", "largest distance from the fit, dB", 0.0, 100.0, when=_on("smooth")),
    Field("max_db", "float", "highest range, dB", *_DB, when=_on("dynamic_range"), optional=True),
    Field("max_db", "float", "largest fall, dB", 0.0, 200.0, when=_on("band_fall")),
    Field("span_s", "float", "the fall's time span, s (a multiple of 0.1)", 0.1, 10.0,
          when=_on("band_fall")),
    Field("below_hz", "float", "the band's upper edge, Hz", 1.0, 24000.0,
          when=_on("band_fall", "centroid_fall")),
    Field("below_hz", "float", "the band's upper edge, Hz (default: none)", 1.0, 24000.0,
          when=_on("highband_diff"), optional=True),
    Field("early_s", "float", "the early span: start and end, s", 0.0, 60.0, many="list",
          when=_on("centroid_fall")),
    Field("late_s", "float", "the late span: start and end, s", 0.0, 60.0, many="list",
          when=_on("centroid_fall")),
    Field("min_fall_percent", "float", "smallest fall of the band's centre, % of the early "
          "centre", -100.0, 100.0, when=_on("centroid_fall")),
    Field("min_s", "float", "shortest T60, s", 0.0, 1000.0, when=_on("t60")),
    Field("max_s", "float", "longest T60, s", 0.0, 1000.0, when=_on("t60")),
    Field("lufs", "float", "target loudness, LUFS", -100.0, 10.0, when=_on("loudness")),
    Field("lu", "float", "tolerance, LU", 0.0, 100.0, when=_on("loudness")),
    Field("max_dbfs", "float", "highest peak, dBFS", *_DB, when=_on("peak")),
    Field("min_dbfs", "float", "lowest peak, dBFS", *_DB, when=_on("peak"), optional=True),
    Field("max_step", "float", "largest step between adjacent keys, LU or dB", 0.0, 100.0,
          when=_on("evenness")),
    Field("measure", "str", "what is measured (default loudness)", when=_on("evenness"),
          optional=True, choices=("loudness", "momentary", "peak")),
    Field("measure", "str", "what is measured", when=_on("monotonic"),
          choices=("loudness", "momentary", "peak", "centroid")),
    Field("over", "str", "along what", when=_on("monotonic"), choices=("velocity", "key")),
    Field("direction", "str", "which way (default increasing)", when=_on("monotonic"),
          optional=True, choices=("increasing", "decreasing")),
    Field("tolerance", "float", "largest step against it (default 0)", 0.0, 1e6,
          when=_on("monotonic"), optional=True),
    Field("min", "float", "lowest ratio", 0.0, 1e3, when=_on("centroid_ratio")),
    Field("max", "float", "highest ratio", 0.0, 1e3, when=_on("centroid_ratio")),
    Field("window_s", "float", "the part read, s (default 1)", 0.01, 60.0,
          when=_on("centroid_ratio"), optional=True),
    Field("above_hz", "float", "the band's lower edge, Hz", 1.0, 24000.0,
          when=_on("highband_diff", "band_fall", "centroid_fall")),
    Field("start_s", "float", "start of the part read, s", 0.0, 60.0, optional=True,
          when=_on("f0", "partial_level", "highband_diff", "partial_diff", "halo", "band_fall")),
    Field("length_s", "float", "length of the part read, s", 0.01, 60.0, optional=True,
          when=_on("f0", "partial_level", "highband_diff", "partial_diff", "band_fall")),
    Field("min_ratio", "float", "lowest late/early T60", 0.0, 1e3, when=_on("two_stage")),
    Field("min_drop_db", "float", "fall before the knee, dB (default 6)", 0.0, 200.0,
          when=_on("two_stage"), optional=True),
    Field("min_late_db", "float", "fall after the knee, dB (default 10)", 0.0, 200.0,
          when=_on("two_stage"), optional=True),
    Field("stop_db", "float", "end of the fit, dB (default -50)", -120.0, -10.0,
          when=_on("two_stage"), optional=True),
    Field("max_hz", "float", "highest partial followed, Hz (default 10000)", 100.0, 24000.0,
          when=_on("partials_law"), optional=True),
    Field("probe_cents", "float", "width of the probe bands, cents (default 10)", 1.0, 50.0,
          when=_on("halo"), optional=True),
), checks=(OrderCheck("min_db", "<=", "max_db"), OrderCheck("min_s", "<=", "max_s"),
           OrderCheck("min", "<=", "max"), OrderCheck("min_dbfs", "<=", "max_dbfs")), array=True)

#: The spec's top-level keys and its arrays of tables.
SPEC_FIELDS = (
    Field("schema", "int", "the spec format's version", choices=(SPEC_SCHEMA,)),
    Field("description", "str", "what the spec checks", default=""),
)
SPEC_SECTIONS = (RENDER, EXPECT)
check_rows(SPEC_FIELDS, SPEC_SECTIONS)


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


def _print_progress(line: str) -> None:
    import sys

    print(line, file=sys.stderr, flush=True)


#: the most specs :func:`run_specs` checks at once
MAX_JOBS = 64


def check_jobs(jobs, name: str = "jobs") -> int:
    """``jobs`` (specs checked at once, :func:`run_specs`) as an int in 1 ..
    :data:`MAX_JOBS`, or ValueError naming ``name``, the value and the range."""
    if isinstance(jobs, bool) or not isinstance(jobs, int) or not 1 <= jobs <= MAX_JOBS:
        raise ValueError(f"{name} = {jobs!r} is out of range (1 <= value <= {MAX_JOBS})")
    return jobs


def _run_spec_job(path: str, threads: int, show: bool) -> list[Result]:
    """One spec in a worker process of :func:`run_specs`, on ``threads``
    threads, its progress lines (with ``show``) on the process's stderr."""
    from ..dsp.threads import set_default

    set_default(threads)
    return run_spec(path, progress=_print_progress if show else None)


def run_specs(paths, jobs: int = 1, threads: int | None = None, progress=None) -> list[Result]:
    """:func:`run_spec` of every spec in ``paths``, the results in their order.

    Every spec is loaded (and so checked) before anything renders.  With
    ``jobs`` > 1 the specs run in that many worker processes at once (the
    renders of one spec stay in one process, in their order), each on
    ``threads // jobs`` threads (at least 1; ``threads`` None: every core,
    :func:`synth.dsp.threads.default_threads`), and, when ``progress`` is
    given, their progress lines go to stderr as they come; the results are
    the same as one after the other (every render is deterministic).
    ``jobs`` is 1 .. :data:`MAX_JOBS` (:func:`check_jobs`).
    """
    from ..dsp.threads import resolve

    check_jobs(jobs)
    specs = [load_spec(p) for p in paths]
    jobs = min(jobs, len(specs))
    if jobs <= 1:
        out = []
        for spec in specs:
            out += run_spec(spec, progress=progress)
        return out
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    each = max(1, resolve(threads) // jobs)
    # spawn, not fork: the parent may hold numba's thread pool and locks
    with ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("spawn")) as ex:
        futures = [ex.submit(_run_spec_job, spec.path, each, progress is not None)
                   for spec in specs]
        out = []
        for f in futures:
            out += f.result()
    return out


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
