"""The schema's building blocks: presence conditions, rows, sections.

:class:`When` (presence condition), :class:`Field` (one key: type, range or
choices, doc, condition), :class:`OrderCheck` (cross-key constraint) and
:class:`Section` (one TOML table mapped onto a dataclass of :mod:`.model`),
plus the helpers that render values and ranges for error messages. The rows
built from them are in :mod:`.sections`; the validator that reads the rows
is in :mod:`.validate`. This module imports neither, so both can import it.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

__all__ = ["When", "Field", "OrderCheck", "Section"]


@dataclass(frozen=True)
class When:
    """Presence condition: the already-validated key ``key`` (dotted) has one of ``values``."""

    key: str
    values: tuple
    also: "When | None" = None    # a second condition that must hold too

    def holds(self, ctx: Mapping[str, Any]) -> bool:
        return (self.key in ctx and ctx[self.key] in self.values
                and (self.also is None or self.also.holds(ctx)))

    def describe(self) -> str:
        vals = [_fmt_value(v) for v in self.values]
        if len(vals) == 1:
            text = f"{self.key} = {vals[0]}"
        else:
            text = f"{self.key} is one of {', '.join(vals)}"
        return text if self.also is None else f"{text} and {self.also.describe()}"


def _when_not(key: str, choices: Sequence, excluded: Sequence) -> When:
    """Condition "key is anything but `excluded`" spelt out over the key's choices."""
    return When(key, tuple(c for c in choices if c not in excluded))


@dataclass(frozen=True)
class Field:
    """One schema row.

    Parameters
    ----------
    name : str
        Key inside its section.
    type : str
        ``"float"`` (int accepted, bool never, must be finite), ``"int"``,
        ``"str"``, ``"line"`` (non-empty single-line string), ``"points"``
        (array of ``[x_m, U_m]`` pairs, at least 2, x >= 0 strictly increasing)
        ``"keys"`` (array of 1 to 24 integers within ``lo``..``hi``: MIDI
        keys, stored as a tuple) or ``"peaks"`` (array of 0 to 32
        ``[f_hz, q, level_db]`` triples, f strictly increasing within
        ``lo``..``hi`` Hz, q 1 .. 500, level -30 .. 30 dB: a body's named
        resonances, stored as a tuple of tuples).
    doc : str
        Meaning and unit, one line.
    lo, hi : float or None
        Range bounds; ``lo_open``/``hi_open`` make them exclusive.
    choices : tuple or None
        Allowed values (for ``str`` and ``int`` keys).
    when : When or None
        Required iff the condition holds, forbidden otherwise; None = always required.
    default : value or None
        With a default the key is optional where its condition holds (absent:
        the default); forbidden elsewhere still.  Keys added after a schema
        version's presets were written take one, so those presets stay valid.
    """

    name: str
    type: str
    doc: str
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    choices: tuple | None = None
    when: When | None = None
    default: Any = None

    def range_text(self) -> str:
        lo_op = "<" if self.lo_open else "<="
        hi_op = "<" if self.hi_open else "<="
        if self.lo is not None and self.hi is not None:
            return f"{_fmt_num(self.lo)} {lo_op} value {hi_op} {_fmt_num(self.hi)}"
        if self.lo is not None:
            return f"value {'>' if self.lo_open else '>='} {_fmt_num(self.lo)}"
        if self.hi is not None:
            return f"value {hi_op} {_fmt_num(self.hi)}"
        return "any value"

    def in_range(self, v: float) -> bool:
        if self.lo is not None and (v <= self.lo if self.lo_open else v < self.lo):
            return False
        if self.hi is not None and (v >= self.hi if self.hi_open else v > self.hi):
            return False
        return True


@dataclass(frozen=True)
class OrderCheck:
    """Cross-key constraint ``section.a <op> section.b`` (op is "<" or "<="), when both present."""

    a: str
    op: str
    b: str


@dataclass(frozen=True)
class Section:
    """One TOML table of the schema, mapped onto the frozen dataclass ``cls``."""

    name: str
    doc: str
    cls: type
    fields: tuple[Field, ...]
    when: When | None = None
    checks: tuple[OrderCheck, ...] = ()
    #: an optional table: where its condition holds it may be absent (its
    #: value is then None) instead of being required
    optional: bool = False
    #: another section this one needs (absent: an error naming it)
    requires: str | None = None



def _unique_names(section: Section) -> list[str]:
    seen: list[str] = []
    for f in section.fields:
        if f.name not in seen:
            seen.append(f.name)
    return seen


# --------------------------------------------------------------------------
# Formatting helpers
# --------------------------------------------------------------------------


def _fmt_num(x: float) -> str:
    if isinstance(x, int):
        return str(x)
    if float(x).is_integer() and abs(x) < 1e6:
        return str(int(x))
    return format(x, "g")


def _fmt_value(v: Any, limit: int = 60) -> str:
    """TOML-like rendering of a value for messages, shortened to about `limit` chars."""
    if isinstance(v, bool):
        s = "true" if v else "false"
    elif isinstance(v, str):
        s = json.dumps(v, ensure_ascii=False)
    elif isinstance(v, (int, float)):
        s = repr(v)
    elif isinstance(v, (list, tuple)):
        s = "[" + ", ".join(_fmt_value(x, limit) for x in v) + "]"
    elif isinstance(v, Mapping):
        s = "{" + ", ".join(f"{k} = {_fmt_value(x, limit)}" for k, x in v.items()) + "}"
    else:
        s = repr(v)
    if len(s) > limit:
        s = s[: limit - 3] + "..."
    return s

