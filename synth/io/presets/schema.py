"""The schema's building blocks: presence conditions, rows, sections.

:class:`When` (presence condition), :class:`Field` (one key: type, shape,
range or choices, doc, condition), :class:`OrderCheck` (cross-key
constraint) and :class:`Section` (one TOML table, or an array of tables
``[[name]]``, mapped onto a dataclass of :mod:`.model` or a dict), plus the
helpers that render values and ranges for error messages. The preset rows
built from them are in :mod:`.sections`; the validator that reads rows is in
:mod:`.validate`. This module imports neither, so both can import it.

The same engine validates three kinds of file, each from its own rows:
presets (:mod:`.sections`), spectrum-test specs (``synth.apps.check``) and
batch specs (``synth.apps.batch_spec``). What the specs need beyond the
presets' rows: arrays of tables (``Section(array=True)``, items named in
messages by ``label``), keys that may be left out without a default
(``Field(optional=True)``, conditions on them with :data:`ABSENT` and
:data:`GIVEN`), keys that exclude one another (``Field(excludes=...)``),
value shapes (``Field(many=...)``: arrays, one value or an array, a sweep
with range tables :class:`Range`; ``span`` for ``"LO..HI/STEP"``,
``literals``, ``mapping`` for a table of free keys), the types ``"path"``
and ``"any"`` and a ``pattern`` for strings.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

__all__ = ["When", "Field", "OrderCheck", "Section", "Range", "ABSENT", "GIVEN"]


class _Mark:
    """A named marker value (:data:`ABSENT`, :data:`GIVEN`)."""

    def __init__(self, text: str) -> None:
        self.text = text

    def __repr__(self) -> str:
        return self.text


#: The value a validated key has in the context when it applies but was left
#: out and has no default (an ``optional`` row); in ``When.values``: "left out".
ABSENT: Any = _Mark("absent")
#: In ``When.values``: "given, whatever its value".
GIVEN: Any = _Mark("given")


@dataclass(frozen=True)
class When:
    """Presence condition: the already-validated key ``key`` (dotted) has one of ``values``.

    ``values`` may hold :data:`ABSENT` (the key applies but was left out) or
    :data:`GIVEN` (the key was given). A key that does not apply (its own
    condition fails, or a key it excludes was given) satisfies no condition.
    """

    key: str
    values: tuple
    also: "When | None" = None    # a second condition that must hold too

    def holds(self, ctx: Mapping[str, Any]) -> bool:
        if self.key not in ctx:
            return False
        v = ctx[self.key]
        hit = v in self.values or (v is not ABSENT and any(x is GIVEN for x in self.values))
        return hit and (self.also is None or self.also.holds(ctx))

    def describe(self, show=None, name=None) -> str:
        """The condition in words; ``show`` renders values (default
        :func:`_fmt_value`), ``name`` the keys (default: as they are)."""
        show = show or _fmt_value
        key = self.key if name is None else name(self.key)
        if self.values in ((ABSENT,), (GIVEN,)):
            text = f"{key} is {self.values[0]!r}"
        else:
            vals = [show(v) for v in self.values]
            if len(vals) == 1:
                text = f"{key} = {vals[0]}"
            else:
                text = f"{key} is one of {', '.join(vals)}"
        return text if self.also is None else f"{text} and {self.also.describe(show, name)}"


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
        keys, stored as a tuple), ``"ascending"`` (array of 1 to 24 numbers
        within ``lo``..``hi``, strictly increasing, exactly ``count`` of them
        when ``count`` is set: times within a cycle, stored as a tuple) or
        ``"peaks"`` (array of 0 to 32
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
    optional : bool
        The key may be left out where its condition holds, without a default:
        its value is then None (:data:`ABSENT` in conditions on it).
    many : str or None
        The value's shape around ``type``: None one value; ``"list"`` a
        non-empty array; ``"list0"`` an array, maybe empty; ``"one+"`` one
        value or a non-empty array; ``"sweep"`` one value, a non-empty array
        or (for ``int``, ``float``, ``any``) a range table ``{low, high[,
        steps]}`` (a :class:`Range`, low <= high, steps 1 .. 10000). Each
        value is checked against the row (``key[i]``, ``key.low``). Arrays
        come out as tuples, one value of ``"one+"``/``"sweep"`` too.
    span : bool
        With ``many`` and ``type="int"``: a string ``"LO..HI/STEP"`` (``/STEP``
        optional) is taken for the integers LO, LO + STEP, ... <= HI.
    literals : tuple of str
        With ``many``: strings taken as they are (``"playable"``).
    pattern : (regex, text) or None
        A ``str``/``line`` value must match the regex whole; ``text`` says
        what is allowed.
    mapping : bool
        The value is a table of free keys (e.g. ``--set`` paths), each holding
        a value shaped as above; it comes out as a tuple of (key, value).
    count : int or None
        Type ``"ascending"``: the array's exact length (None: 1 to 24).
    excludes : tuple of str
        Earlier keys of the same table this key may not be given with: when
        one of them is given, this key does not apply (and is not required);
        when none is, it is as its condition says (a missing required key
        names them as the alternatives).

    Types beyond the presets': ``"path"`` (a non-empty string naming a file
    relative to the document's folder; its absolute path) and ``"any"`` (any
    TOML value but a table; a float must be finite).
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
    optional: bool = False
    many: str | None = None
    span: bool = False
    literals: tuple = ()
    pattern: tuple[str, str] | None = None
    mapping: bool = False
    excludes: tuple[str, ...] = ()
    count: int | None = None

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
class Range:
    """A range table ``{low, high[, steps]}`` of a ``many="sweep"`` key (steps: None if absent)."""

    low: Any
    high: Any
    steps: int | None = None


@dataclass(frozen=True)
class Section:
    """One TOML table of the schema, mapped onto ``cls`` (a frozen dataclass, or
    ``dict``) built from its keys' values.

    ``array=True``: an array of tables ``[[name]]``, a tuple of ``cls``; required
    (no ``when``, not ``optional``) it needs at least one table, optional it
    may be absent (an empty tuple). Items are named ``name[i]`` in messages,
    or ``name VALUE`` once the key ``label`` (validated first) is known. Rows
    name their own table's keys as ``name.key`` in conditions.
    """

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
    array: bool = False
    label: str | None = None



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


def _fmt_value(v: Any, limit: int = 60, literal: bool = False) -> str:
    """TOML-like rendering of a value for messages, shortened to about `limit` chars.

    Strings are basic strings (``"sitar"``), or with ``literal`` Python's
    repr, which reads as a TOML literal string (``'sitar'``)."""
    if isinstance(v, bool):
        s = "true" if v else "false"
    elif isinstance(v, str):
        s = repr(v) if literal else json.dumps(v, ensure_ascii=False)
    elif isinstance(v, (int, float)):
        s = repr(v)
    elif isinstance(v, (list, tuple)):
        s = "[" + ", ".join(_fmt_value(x, limit, literal) for x in v) + "]"
    elif isinstance(v, Mapping):
        s = "{" + ", ".join(f"{k} = {_fmt_value(x, limit, literal)}" for k, x in v.items()) + "}"
    else:
        s = repr(v)
    if len(s) > limit:
        s = s[: limit - 3] + "..."
    return s



def _fmt_literal(v: Any) -> str:
    """:func:`_fmt_value` with strings as literal strings (``'a'``): the specs' messages."""
    return _fmt_value(v, literal=True)
