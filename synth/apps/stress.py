"""Numerical stability under stress: random presets, scenes, rates and block sizes (issue 13).

Usage
-----
    python tools/stress.py --cases 5000               # property cases, a table of counts
    python tools/stress.py --cases 2000 --seed 7      # reproducible
    python tools/stress.py --perf                     # also: denormals and a one-hour pedalled chord

Property-based (hypothesis): each case is drawn by :func:`cases` and
checked by :func:`check`, which returns the problems it found (none: the
case passed) or raises :class:`Rejected` when the preset rejects the drawn
values with its one-line error (an allowed outcome, counted apart).  The
kinds:

``preset``
    a shipped one-string or harpsichord preset with 1-4 of its numeric
    values drawn across their whole allowed range (log-uniform where the
    range spans more than a decade), played with 1-3 notes at any velocity
    for 30-120 ms;
``scene``
    a shipped musical preset (the grand's keys designed once) and a random
    scene: a dense cluster, every velocity, a pitch-bend sweep, a pedal storm
    (sustain, sostenuto and soft pedals toggled every few ms), restrikes of
    one key during its contact; rendered in blocks of a random size and in
    blocks of 1024;
``rate``
    a study preset re-gridded to a random internal rate from 96 kHz to 1.3
    MHz, at a random pluck amplitude or hammer speed;
``energy``
    a lossless study string (ideal, jawari Cases 1-3, sawari) at a random
    rate and pluck: the grid energy (the conserved energy of the equivalent
    FDTD scheme) after the pluck, sampled every 64 steps;
``silence``
    controllers, pitch bends and velocity-0 note-ons only.

What each case must show: no NaN or Inf; an output bounded by ``BOUND``
(+60 dBFS: the presets keep their calibrated gain); a scene's samples do
not depend on the block size (1e-9 of its peak); the lossless and contact
strings' grid energy stays at or below its value after the pluck E0 (within
``ENERGY_RTOL``: the contacts can add a little energy for a while, counted
and reported apart); silence in, exact zeros out.

``tools/stress.py --perf`` adds two measurements (medians of repeated runs): a sounding
string's cost per sample at full level and with every signal it holds
scaled 100 dB, 300 dB and 1e-306 down (the last in subnormal arithmetic,
which the engine never reaches: it frees a string 110 dB down, and the body
flushes its modes), and one simulated hour of a held, pedalled 6-note grand
chord (bounded, and the cost per simulated minute flat).
``tests/test_stress.py`` runs 2,000 cases in CI.  ``tools/stress.py`` is
the command line (:func:`run` and the table, and ``--perf``); the cases need
hypothesis (the ``[test]`` extra).
"""

from __future__ import annotations

import math
import sys
import time
import tomllib
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

#: largest output sample allowed (full scale = 1): +60 dBFS
BOUND = 1e3
#: the grid energy after the pluck, sampled every 64 steps, may never exceed
#: its value E0 just after the pluck by more than this (relative).  Not 0:
#: the thesis's clamp is not energy-stable on the grid.  Where a profile
#: kinks or steps (Cases 2-3) on a grid finer than the study's, a contact can
#: add a little energy for a while (largest seen: 1.9e-4 of E0 over 64 steps,
#: Case 3 on 1776 cells; the same on the per-sample path), while the
#: contacts together remove energy; every such rise is counted in RISES and
#: reported by main().  An instability would pass E0 by orders of magnitude.
ENERGY_RTOL = 1e-3
#: (largest rise over 64 steps / E0, case) of every energy case checked
RISES: list = []
#: presets drawn by the "preset" kind (cheap to build), "scene" kind and "energy" kind
PRESET_KIND = ("sitar", "biwa", "hammered-sitar", "harpsichord", "paper/sitar-case1",
               "paper/sitar-case2", "paper/sitar-case3", "paper/biwa-sawari", "paper/piano-a7-capo")
SCENE_KIND = ("sitar", "biwa", "hammered-sitar", "harpsichord", "grand-piano")
RATE_KIND = ("paper/sitar-ideal", "paper/sitar-case1", "paper/sitar-case2", "paper/sitar-case3",
             "paper/biwa-ideal", "paper/biwa-sawari", "paper/piano-a7-ideal", "paper/piano-a7-capo")
ENERGY_KIND = {"ideal": None, "case1": ("jawari_case1", (0.008, 0.015)),
               "case2": ("jawari_case2", (0.008, 0.010, 0.010)),
               "case3": ("jawari_case3", (0.008, 0.004, 0.010, 0.010, 0.00011)),
               "sawari": ("sawari", (2.0, 0.01))}
#: the listening positions a scene is heard from (none: the body's output)
LISTENERS = ((), ("listener.position=close",), ("listener.position=player",),
             ("listener.position=hall",))
#: preset keys never drawn: the calibrated level, and what a render cannot show
FROZEN = {"output.gain", "output.limit_dbfs", "output.limit_release_s", "play.polyphony",
          "play.key_low", "play.key_high", "body.seed", "grid.cells"}

#: preset tables never drawn: data about the preset, not its sound (the
#: quality levels' measured errors)
FROZEN_SECTIONS = {"quality_error"}


class Rejected(Exception):
    """The preset (or its physics) refused the drawn values with a one-line error."""


@dataclass
class Case:
    kind: str
    preset: str
    sets: tuple = ()
    events: tuple = ()            # (time_s, kind, key, value, channel)
    seconds: float = 0.05
    block: int = 1024
    rate_hz: float | None = None
    extra: dict = field(default_factory=dict)

    def describe(self) -> str:
        s = f"{self.kind} {self.preset}"
        if self.sets:
            s += " --set " + " --set ".join(self.sets)
        if self.rate_hz:
            s += f" at {self.rate_hz:.0f} Hz"
        if self.events:
            s += f", {len(self.events)} events over {self.seconds:.3f} s, block {self.block}"
        if self.extra:
            s += f", {self.extra}"
        return s


# ---- drawing cases ------------------------------------------------------------------
_FIELDS: dict = {}


def numeric_fields(preset: str):
    """(dotted key, Field) of the numeric keys present in the preset's file."""
    if preset in _FIELDS:
        return _FIELDS[preset]
    from synth.io.presets.loader import _scan
    from synth.io.presets.sections import SECTIONS

    raw = tomllib.loads(_scan()[preset].read_text("utf-8"))
    out = []
    for sec in SECTIONS:
        table = raw.get(sec.name)
        if not isinstance(table, dict) or sec.name in FROZEN_SECTIONS:
            continue
        seen = set()
        for f in sec.fields:
            key = f"{sec.name}.{f.name}"
            if (f.type in ("float", "int") and f.name in table and f.choices is None
                    and key not in FROZEN and f.lo is not None and f.hi is not None
                    and key not in seen):
                # a key with several rows (per profile): the row whose range holds the file's value
                if f.in_range(float(table[f.name])):
                    out.append((key, f))
                    seen.add(key)
    _FIELDS[preset] = out
    return out


def _value(st, f):
    lo, hi = float(f.lo), float(f.hi)
    if f.type == "int":
        return st.integers(int(math.ceil(lo)), int(math.floor(hi)))
    if lo > 0 and hi / lo > 10:
        return st.floats(math.log(lo), math.log(hi)).map(math.exp).filter(f.in_range)
    return st.floats(lo, hi, allow_nan=False, allow_infinity=False).filter(f.in_range)


def cases():
    """The hypothesis strategy of one :class:`Case`."""
    from hypothesis import strategies as st

    @st.composite
    def preset_case(draw):
        name = draw(st.sampled_from(PRESET_KIND))
        fields = numeric_fields(name)
        chosen = draw(st.lists(st.sampled_from(fields), min_size=1, max_size=4,
                               unique_by=lambda kf: kf[0]))
        sets = tuple(f"{k}={draw(_value(st, f))!r}" for k, f in chosen)
        n = draw(st.integers(1, 3))
        study = name.startswith("paper/")
        evs = tuple((draw(st.floats(0.0, 0.02)), "note_on",
                     -1 if study else draw(st.integers(43, 74)),
                     draw(st.floats(0.01, 1.0)), 0) for _ in range(n))
        return Case("preset", name, sets, evs, draw(st.floats(0.03, 0.12)))

    @st.composite
    def scene_case(draw):
        name = draw(st.sampled_from(SCENE_KIND))
        lo, hi = (21, 108) if name == "grand-piano" else (43, 74)
        if name == "harpsichord":
            lo, hi = 29, 89
        style = draw(st.sampled_from(("cluster", "velocities", "bend", "pedals", "restrike")))
        T = draw(st.floats(0.05, 0.25))
        ev = []
        if style == "cluster":
            base = draw(st.integers(lo, hi - 12))
            for k in range(base, base + draw(st.integers(3, 12))):
                ev.append((draw(st.floats(0.0, 0.01)), "note_on", k, draw(st.floats(0.05, 1.0)), 0))
        elif style == "velocities":
            for i in range(draw(st.integers(4, 16))):
                ev.append((i * T / 20, "note_on", draw(st.integers(lo, hi)),
                           draw(st.sampled_from((1 / 127, 0.25, 0.5, 0.75, 1.0))), 0))
        elif style == "bend":
            k = draw(st.integers(lo, hi))
            ev.append((0.0, "note_on", k, draw(st.floats(0.1, 1.0)), 0))
            for i in range(draw(st.integers(5, 40))):
                ev.append((0.002 + i * 0.003, "pitch_bend", -1, draw(st.floats(-1.0, 1.0)), 0))
        elif style == "pedals":
            for k in draw(st.lists(st.integers(lo, hi), min_size=1, max_size=6, unique=True)):
                ev.append((draw(st.floats(0.0, 0.03)), "note_on", k, draw(st.floats(0.1, 1.0)), 0))
                ev.append((draw(st.floats(0.03, 0.1)), "note_off", k, 0.5, 0))
            for i in range(draw(st.integers(5, 40))):
                ev.append((i * 0.004, "control", draw(st.sampled_from((64, 66, 67))),
                           draw(st.sampled_from((0.0, 0.3, 0.5, 1.0))), 0))
        else:  # restrike: the same key again while its hammer or pluck is on the string
            k = draw(st.integers(lo, hi))
            for i in range(draw(st.integers(2, 8))):
                ev.append((i * draw(st.floats(0.0002, 0.004)), "note_on", k, draw(st.floats(0.1, 1.0)), 0))
        block = draw(st.integers(7, 1024))
        # heard from a listening position (the grand has its own, close): its
        # room's reverberation must not depend on the blocks either
        # (from the block size, not a draw of its own: the cases drawn after
        # this one stay those drawn before the listener existed)
        sets = () if name == "grand-piano" else LISTENERS[block % len(LISTENERS)]
        return Case("scene", name, sets, tuple(sorted(ev, key=lambda e: e[0])), T, block,
                    extra={"style": style})

    @st.composite
    def rate_case(draw):
        name = draw(st.sampled_from(RATE_KIND))
        rate = draw(st.floats(math.log(96_000), math.log(1_300_000)).map(math.exp))
        sets = ()
        if "piano" in name:
            sets = (f"hammer.speed_m_per_s={draw(st.floats(0.1, 10.0))!r}",)
        else:
            sets = (f"pluck.amplitude_m={draw(st.floats(1e-5, 0.01))!r}",)
        return Case("rate", name, sets, ((0.0, "note_on", -1, 1.0, 0),), 0.03, rate_hz=rate)

    @st.composite
    def energy_case(draw):
        prof = draw(st.sampled_from(sorted(ENERGY_KIND)))
        cells = draw(st.integers(240, 4000))
        amp = draw(st.floats(1e-4, 0.01)) if prof != "sawari" else draw(st.floats(1e-5, 0.002))
        pos = draw(st.floats(0.2, 0.9))
        return Case("energy", prof, extra={"cells": cells, "amplitude_m": amp, "position": pos})

    @st.composite
    def silence_case(draw):
        name = draw(st.sampled_from(SCENE_KIND))
        ev = []
        for i in range(draw(st.integers(0, 20))):
            kind = draw(st.sampled_from(("control", "pitch_bend", "note_on0", "note_off")))
            t = draw(st.floats(0.0, 0.05))
            if kind == "control":
                ev.append((t, "control", draw(st.sampled_from((1, 64, 66, 67, 7, 11, 120, 121, 123))),
                           draw(st.floats(0.0, 1.0)), 0))
            elif kind == "pitch_bend":
                ev.append((t, "pitch_bend", -1, draw(st.floats(-1.0, 1.0)), 0))
            elif kind == "note_on0":
                ev.append((t, "note_on", draw(st.integers(21, 108)), 0.0, 0))
            else:
                ev.append((t, "note_off", draw(st.integers(21, 108)), 0.5, 0))
        return Case("silence", name, (), tuple(sorted(ev, key=lambda e: e[0])), 0.06,
                    draw(st.integers(7, 1024)))

    return st.one_of(preset_case(), scene_case(), rate_case(), energy_case(), silence_case())


# ---- checking cases -----------------------------------------------------------------
_VOICES: dict = {}


def _voice(name, sets=()):
    from synth.io.factory import build_voice

    if (name, sets) not in _VOICES:
        _VOICES[(name, sets)] = build_voice(name, sets)
    return _VOICES[(name, sets)]


def _events(case):
    from synth.engine.engine import Event

    return [Event(t, k, key, v, ch) for t, k, key, v, ch in case.events]


def _bounded(y, label):
    out = []
    if not np.all(np.isfinite(y)):
        out.append(f"{label}: {int(np.sum(~np.isfinite(y)))} samples not finite")
    elif y.size and np.max(np.abs(y)) > BOUND:
        out.append(f"{label}: peak {np.max(np.abs(y)):.3g} over {BOUND:g}")
    return out


def _engine(case, block=1024, voice=None):
    from synth.io.errors import SynthError
    from synth.io.factory import build_engine

    try:
        return build_engine(case.preset, case.sets, fs_internal=case.rate_hz, block=block,
                            voice=voice, extra_low_key=min([int(e[2]) for e in case.events
                                                            if e[1] == "note_on" and e[2] >= 0],
                                                           default=None))
    except (SynthError, ValueError) as e:
        msg = str(e)
        if "\n" in msg.strip() or not msg:
            raise AssertionError(f"a rejection that is not one line: {msg!r}")
        raise Rejected(msg) from None


def check(case: Case) -> list[str]:
    """The problems of one case (empty: it passed); :class:`Rejected` when
    the preset refused its values."""
    if case.kind == "energy":
        return _check_energy(case)
    if case.kind == "scene":
        v = _voice(case.preset, case.sets)
        y1 = _engine(case, case.block, v).render(_events(case), duration_s=case.seconds, block=case.block)
        y2 = _engine(case, 1024, v).render(_events(case), duration_s=case.seconds, block=1024)
        out = _bounded(y1, "output")
        if not out:
            d = float(np.max(np.abs(y1 - y2))) if y1.size else 0.0
            if d > 1e-9 * max(float(np.max(np.abs(y2))), 1e-30):
                out.append(f"blocks of {case.block} and 1024 differ by {d:.3g}")
        return out
    if case.kind == "silence":
        y = _engine(case, case.block, _voice(case.preset)).render(_events(case), duration_s=case.seconds,
                                                                  block=case.block)
        return [] if not np.any(y) else [f"silence in, {np.max(np.abs(y)):.3g} out"]
    y = _engine(case).render(_events(case), duration_s=case.seconds)
    return _bounded(y, "output")


def _check_energy(case: Case) -> list[str]:
    from synth.analysis import grid_energy
    from synth.dsp.bank import StringBank
    from synth.kernels import strings as K
    from synth.physics import profiles as P

    L, T, mu = 0.8, 38.4, 0.000375
    c = math.sqrt(T / mu)
    N = int(case.extra["cells"])
    dx = L / N
    dt = dx / c
    k = min(max(int(round(case.extra["position"] * N)), 2), N - 2)
    spec = ENERGY_KIND[case.preset]
    side, model, t0, alpha = 1, K.EXC_SITAR, 0.004, 0.0
    U = None
    if spec is not None:
        prof = getattr(P, spec[0])(*spec[1])
        if case.preset == "sawari":
            side, model, t0, alpha = -1, K.EXC_BIWA, 0.0025, 2000.0
        U = P.Termination(prof, side, 25, rate_scale=N / 812).sample(dx)
    R = 1 if U is None else len(U)
    b = StringBank(1, N + 2, R, 4096)
    b.configure(0, cells=N, k=k, dt_s=dt, U=U, side=side)
    b.activate(0)
    b.start_pluck(0, model, case.extra["amplitude_m"], t0, alpha)
    n0 = int(t0 / dt) + 4
    mix = np.zeros(max(4096, n0))
    b.render(mix, 0, n0)

    def energy():
        u1 = b.displacement(0)
        b.render(mix, 0, 1)
        return grid_energy(b.displacement(0), u1, T, dx)

    E = [energy()]
    for _ in range(int(0.03 / dt) // 64):
        b.render(mix, 0, 63)
        E.append(energy())
    E = np.array(E)
    out = []
    if not np.all(np.isfinite(E)):
        out.append("energy not finite")
    elif E[0] <= 0:
        out.append(f"energy after the pluck {E[0]:.3g} J")
    else:
        rise = float(np.max(np.diff(E))) / E[0]
        RISES.append((rise, case))
        top = float(np.max(E)) / E[0] - 1.0
        if top > ENERGY_RTOL:
            out.append(f"energy {top:.3g} of E0 above its value after the pluck")
    return out


# ---- running many -------------------------------------------------------------------
def run(n_cases: int, seed: int, verbose: bool = False, trace: bool = False):
    """Draw and check ``n_cases`` cases; (counts per kind and outcome,
    failures as (case, problems), seconds)."""
    from hypothesis import HealthCheck, given, settings, seed as hseed

    counts: Counter = Counter()
    failures = []
    t0 = time.perf_counter()
    if n_cases <= 0:
        return counts, failures, 0.0

    @hseed(seed)
    @settings(max_examples=n_cases, deadline=None, database=None, derandomize=False,
              suppress_health_check=list(HealthCheck))
    @given(cases())
    def one(case):
        if trace:
            print("CASE", case.describe(), file=sys.stderr, flush=True)
        try:
            probs = check(case)
        except Rejected:
            counts[(case.kind, "rejected")] += 1
            return
        except Exception as e:       # a crash is a failure too: count it, keep going
            probs = [f"{type(e).__name__}: {e}"]
        if probs:
            counts[(case.kind, "failed")] += 1
            failures.append((case, probs))
            if verbose:
                print("FAIL", case.describe(), probs, file=sys.stderr)
        else:
            counts[(case.kind, "passed")] += 1

    one()
    return counts, failures, time.perf_counter() - t0


# ---- performance checks (--perf) ----------------------------------------------------
