"""The grand piano's voicing report (``tools/voicing_report.py``, issue 11;
``docs/voicing.md``): the parts of it that are not rendering, kept in the
package so that they are tested from it.

* :func:`mono`, :func:`channels`: a render's mono view and channels;
* :func:`law_partials`: the partials a key's stiff-string law checks;
* :class:`Row` and :func:`format_table`: the report's rows and its table;
* :data:`QUICK_KEYS`, :data:`MIDI_FILES`: the keys of ``--quick`` and the
  piano files of ``../shared/midi`` the report plays;
* :class:`Renderer`: single notes of a preset, rendered once and kept
  (the report's, and ``tools/study_partials.py``'s);
* :func:`decay`: a note's T60 and two-stage fit, as the report reads them
  (and ``tools/real_grand.py`` on a recording).

Its loudness and attack-centroid measures are
:func:`synth.analysis.max_momentary_lufs` and
:func:`synth.analysis.attack_centroid_hz`.
"""

from __future__ import annotations

import math
import time
from collections import OrderedDict
from dataclasses import dataclass, field

import numpy as np

from ..analysis import t60_s, two_stage_summary
from ..physics.piano import grand_string

__all__ = ["FS", "QUICK_KEYS", "MIDI_FILES", "mono", "channels", "law_partials", "Row", "format_table",
           "Renderer", "decay"]

#: the report's output rate (Hz): every render and recording is read at it
FS = 48_000
#: a knee is visible when the prompt sound falls at least this much before it
#: and the aftersound at least this much after it (dB)
KNEE_MIN_DROP_DB, KNEE_MIN_LATE_DB = 6.0, 10.0
#: the aftersound's T60 over the prompt sound's for a two-stage decay (the report's limit)
LATE_EARLY_MIN = 3.0


#: the keys of the report's ``--quick`` run
QUICK_KEYS = (21, 33, 41, 48, 59, 60, 61, 72, 84, 96, 97, 100, 104, 108)
#: the five piano files of ../shared/midi (SOURCES.md, section 1)
MIDI_FILES = ("rac_op23_5.mid", "chpn_op25_e11.mid", "deb_clai.mid", "hp956bx4547_exp.mid",
              "kw569bw0899_exp.mid")


def mono(y):
    """Mono view of a render: channels averaged if it is (n, channels)."""
    y = np.asarray(y, dtype=np.float64)
    return y.mean(axis=1) if y.ndim == 2 else y


def channels(y):
    """The render's channels as a list of 1-D arrays."""
    y = np.asarray(y, dtype=np.float64)
    return [y[:, i] for i in range(y.shape[1])] if y.ndim == 2 else [y]


def law_partials(key, f1_hz, f_max_hz=10_000.0, n_max=40):
    """The key's stiff-string law: f0 with partial 1 at ``f1_hz`` and B of
    ``grand_string(key)``; the partial numbers to check (up to ``n_max``,
    or ``f_max_hz``, whichever is fewer)."""
    B = grand_string(key).inharmonicity_b
    f0 = f1_hz / math.sqrt(1.0 + B)
    n = np.arange(1, n_max + 1)
    f = n * f0 * np.sqrt(1.0 + B * n * n)
    return f0, B, int(max(1, np.sum(f <= f_max_hz)))


@dataclass
class Row:
    section: str
    target: str
    measured: str
    limit: str
    status: str          # PASS, FAIL, INFO, SKIP
    value: object = None
    detail: str = ""     # the per-key figures, printed under the table


def format_table(rows, details=True, before=None) -> str:
    """The table (status, target, measured, limit), then the details of
    each row that has any, numbered.  ``before``: {(section, target):
    measured} of an earlier report (``--before``), shown as a column."""
    head = ("", "target", "measured", "limit")
    body = [(r.status, r.target, r.measured, r.limit) for r in rows]
    if before is not None:
        head = ("", "target", "before", "measured", "limit")
        body = [(r.status, r.target, before.get((r.section, r.target), "-"), r.measured, r.limit)
                for r in rows]
    nc = len(head) - 1
    w = [max(len(x[i]) for x in [head] + body) for i in range(nc)]
    lines = []
    for i, x in enumerate([head] + body):
        ref = f"[{i}]" if i and rows[i - 1].detail and details else ""
        lines.append(("  ".join(c.ljust(w[j]) for j, c in enumerate(x[:nc])) + f"  {x[nc]} {ref}").rstrip())
        if i == 0:
            lines.append("  ".join("-" * x for x in w) + "  -----")
    n = {s: sum(r.status == s for r in rows) for s in ("PASS", "FAIL", "INFO", "SKIP")}
    lines.append(f"{n['PASS']} passed, {n['FAIL']} failed, {n['INFO']} for information, "
                 f"{n['SKIP']} skipped")
    if details:
        lines.append("")
        lines += [f"[{i}] {r.detail}" for i, r in enumerate(rows, 1) if r.detail]
    return "\n".join(lines)


@dataclass
class Renderer:
    """Renders single notes of one preset (fresh engine each, the voice's
    key designs shared) and keeps them: a later request for the same note,
    as long or shorter, is served from the cache (a prefix: a render is
    deterministic), up to ``budget_mb`` of audio."""

    preset: str
    overrides: tuple
    budget_mb: float = 200.0
    voice: object = None
    cache: OrderedDict = field(default_factory=OrderedDict)
    render_s: float = 0.0
    audio_s: float = 0.0
    renders: int = 0
    hits: int = 0

    def __post_init__(self):
        from ..io.factory import build_voice

        self.voice = build_voice(self.preset, self.overrides)

    def tuning_hz(self, key):
        return float(self.voice.tuning_hz(key))

    def engine(self, low_key=None):
        from ..io.factory import build_engine

        return build_engine(self.preset, self.overrides, fs_out=FS, extra_low_key=low_key,
                            voice=self.voice)

    def note(self, key, vel, seconds, *, sustain=False, soft=False, off_s=None, exact=False,
             keep_s=None):
        """Mono render of ``key`` at MIDI velocity ``vel`` from t = 0 for
        ``seconds``; sustain pedal / soft pedal fully down from t = 0 if
        asked; key up at ``off_s`` (None: held).

        A render of the same note at least as long is reused (its prefix),
        unless ``exact``: renders of different lengths end in blocks of
        different sizes, and the decimator and soundboard then round
        differently (by ~1e-18 of the signal), so two takes compared sample
        for sample must be rendered alike.  ``keep_s``: keep only the first
        ``keep_s`` in the cache (long decay renders)."""
        n = int(round(seconds * FS))
        tag = (int(key), int(vel), bool(sustain), bool(soft), off_s, n if exact else None)
        y = self.cache.get(tag)
        if y is not None and len(y) >= n:
            self.cache.move_to_end(tag)
            self.hits += 1
            return y[:n]
        from ..engine.engine import Event

        ev = []
        if sustain:
            ev.append(Event(0.0, "control", 64, 1.0))
        if soft:
            ev.append(Event(0.0, "control", 67, 1.0))
        ev.append(Event(0.0, "note_on", int(key), vel / 127.0))
        if off_s is not None:
            ev.append(Event(off_s, "note_off", int(key), 0.0))
        t = time.perf_counter()
        y = mono(self.engine(key).render(ev, duration_s=seconds))
        self.render_s += time.perf_counter() - t
        self.audio_s += seconds
        self.renders += 1
        if keep_s is not None and len(y) > int(keep_s * FS):
            tag = tag[:-1] + (None,)
            self.cache[tag] = y[:int(keep_s * FS)].copy()
        else:
            self.cache[tag] = y
        while sum(v.nbytes for v in self.cache.values()) > self.budget_mb * 1e6 and len(self.cache) > 1:
            self.cache.popitem(last=False)
        return y


def _two_stage(y, f_hz, hop):
    """The two-stage fit (to -50 dB) of the level of ``y`` (the whole note
    for ``f_hz`` None, else its partial at ``f_hz``):
    :func:`synth.analysis.two_stage_summary` with the report's limits."""
    try:
        d = two_stage_summary(y, FS, f_hz=f_hz, stop_db=-50.0, hop_s=hop,
                              min_drop_db=KNEE_MIN_DROP_DB, min_late_db=KNEE_MIN_LATE_DB,
                              min_ratio=LATE_EARLY_MIN)
    except ValueError:
        d = {"t60_early_s": None, "t60_late_s": None, "knee_s": None, "ratio": None,
             "knee_drop_db": None, "late_span_db": None, "visible": False}
    return d


def decay(y, f1_hz):
    """T60 of partial 1 (one line, -5 to -35 dB, or to -25 / -15 dB if it
    does not fall that far), and the two-stage fit (to -50 dB) of the
    note's whole level (what a listener hears fall fast, then slowly: the
    prompt sound and the aftersound) with the knee's drop and the
    aftersound's span; the same fit of partial 1 alone under ``p1_``
    (beats between a unison's detuned strings cut notches of 20-40 dB into
    one partial's level, which a two-line fit takes for a knee).  Level
    frames every 10 ms, or every 1/1000 of a render longer than 10 s (the
    knee search is quadratic in the frames)."""
    hop = max(0.01, len(y) / FS / 1000.0)
    out = {"t60_s": None, "t60_range_db": None}
    for stop in (-35.0, -25.0, -15.0):
        try:
            out["t60_s"] = t60_s(y, FS, f_hz=f1_hz, stop_db=stop, hop_s=hop)
            out["t60_range_db"] = stop
            break
        except ValueError:
            continue
    out.update(_two_stage(y, None, hop))
    out.update({"p1_" + k: v for k, v in _two_stage(y, f1_hz, hop).items()})
    return out
