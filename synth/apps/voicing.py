"""The grand piano's voicing report (``tools/voicing_report.py``, issue 11;
``docs/voicing.md``): the parts of it that are not rendering, kept in the
package so that they are tested from it.

* :func:`mono`, :func:`channels`: a render's mono view and channels;
* :func:`law_partials`: the partials a key's stiff-string law checks;
* :class:`Row` and :func:`format_table`: the report's rows and its table;
* :data:`QUICK_KEYS`, :data:`MIDI_FILES`: the keys of ``--quick`` and the
  piano files of ``../shared/midi`` the report plays.

Its loudness and attack-centroid measures are
:func:`synth.analysis.max_momentary_lufs` and
:func:`synth.analysis.attack_centroid_hz`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..physics.piano import grand_string

__all__ = ["QUICK_KEYS", "MIDI_FILES", "mono", "channels", "law_partials", "Row", "format_table"]

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
