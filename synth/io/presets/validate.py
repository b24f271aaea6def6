"""The schema engine: validation of a parsed TOML document against rows, and ``--set``.

:func:`validate_dict` validates a preset against the rows of :mod:`.sections`
and builds a :class:`~.model.Preset` or raises a one-line
:class:`~synth.io.errors.PresetError`; :func:`validate_table` validates any
document against its own rows (the spectrum-test specs of ``synth check``
and the batch specs of ``synth batch`` use it) and raises the caller's error
class; :func:`parse_override` and ``_apply_overrides`` handle the CLI's
``--set PATH=VALUE``. :func:`check_rows` is the consistency check of a set
of rows (programming errors only); importing this module runs it on the
presets' rows, with ``_check_schema`` checking them against the
dataclasses of :mod:`.model`.
"""

from __future__ import annotations

import copy
import math
import re
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import fields as dc_fields
from dataclasses import is_dataclass
from pathlib import Path
from typing import Any

from synth.io.errors import PresetError
from synth.physics.soundboard import MAX_PEAKS, PEAK_DB_RANGE, PEAK_Q_RANGE

from .model import Preset
from .schema import ABSENT, Field, Range, Section, When, _fmt_num, _fmt_value, _unique_names
from .sections import SCHEMA_FIELDS, SECTIONS

__all__ = ["validate_dict", "validate_table", "check_rows", "parse_override"]

_SECTION_BY_NAME = {s.name: s for s in SECTIONS}
_TOP_BY_NAME = {f.name: f for f in SCHEMA_FIELDS}
_TOP_KEYS = tuple(f.name for f in SCHEMA_FIELDS) + tuple(s.name for s in SECTIONS)

_TYPE_TEXT = {
    "float": "a number",
    "int": "an integer",
    "str": "a string",
    "line": "a string",
    "points": "an array of [x_m, U_m] pairs",
    "keys": "an array of MIDI keys",
    "ascending": "an array of numbers, strictly increasing",
    "peaks": "an array of [f_hz, q, level_db] triples",
    "path": "a file name",
    "any": "a value (not a table)",
}
_MANY = (None, "list", "list0", "one+", "sweep")
#: types whose ``many="sweep"`` values may be range tables {low, high[, steps]}
_RANGED = ("int", "float", "any")
#: a range table's bounds for type "any", and its steps
_ANY_BOUND = Field("low", "float", "a bound of a range")
_STEPS = Field("steps", "int", "values of a grid over the range", 1, 10_000)
#: "LO..HI/STEP" (a ``span`` row)
_SPAN = re.compile(r"\s*(\d+)\s*\.\.\s*(\d+)\s*(?:/\s*(\d+))?\s*")


def _check_when(where: str, when: When | None, known: Sequence[str]) -> None:
    while when is not None:
        if when.key not in known:
            raise AssertionError(f"{where}: condition on later/unknown key {when.key}")
        when = when.also


def _check_fields(prefix: str, fields: Sequence[Field], known: list[str]) -> list[str]:
    """Check one table's rows; append their dotted names to `known`; return the names."""
    names = _unique_names(Section(prefix, "", dict, tuple(fields)))
    for i, name in enumerate(names):
        where = f"{prefix}.{name}" if prefix else name
        rows = [f for f in fields if f.name == name]
        if len(rows) > 1:
            # Several rows: all conditional on the same key with disjoint values.
            if any(r.when is None for r in rows) or len({r.when.key for r in rows}) != 1:
                raise AssertionError(f"{where}: ambiguous rows")
            vals = [v for r in rows for v in r.when.values]
            if len(vals) != len(set(vals)):
                raise AssertionError(f"{where}: overlapping conditions")
            if len({r.excludes for r in rows}) != 1:
                raise AssertionError(f"{where}: rows with different excludes")
        for r in rows:
            _check_when(where, r.when, known)
            if r.type not in _TYPE_TEXT or r.many not in _MANY:
                raise AssertionError(f"{where}: unknown type {r.type!r} or shape {r.many!r}")
            if (r.span and (r.type != "int" or r.many is None or r.lo is None or r.hi is None)
                    or (r.literals and r.many is None)
                    or (r.pattern and r.type not in ("str", "line"))
                    or (r.count is not None and (r.type != "ascending" or not 1 <= r.count <= 24))):
                raise AssertionError(f"{where}: span, literals or pattern do not fit the row")
            for other in r.excludes:
                if other not in names[:i]:
                    raise AssertionError(f"{where}: excludes a later/unknown key {other}")
                if any(o.default is not None for o in fields if o.name == other):
                    raise AssertionError(f"{where}: excludes {other}, which has a default")
        known.append(where)
    return names


def check_rows(fields: Sequence[Field], sections: Sequence[Section]) -> None:
    """Consistency check of a document's rows (programming errors only).

    Conditions name earlier keys; several rows of one key are conditional on
    one key with disjoint values; excluded keys are earlier keys of the same
    table without a default; a section's keys are its dataclass's fields;
    checks and labels name keys of their table.

    Raises
    ------
    AssertionError
        Naming the row.
    """
    known: list[str] = [f.name for f in fields]
    _check_fields("", fields, [])
    for sec in sections:
        _check_when(f"section {sec.name}", sec.when, known)
        if sec.array and (sec.when is not None or sec.requires is not None):
            raise AssertionError(f"section {sec.name}: an array takes no when or requires")
        names = _check_fields(sec.name, sec.fields, known)
        if is_dataclass(sec.cls):
            cls_names = [f.name for f in dc_fields(sec.cls)]
            if sorted(names) != sorted(cls_names):
                raise AssertionError(f"section {sec.name}: schema keys {names} != "
                                     f"{sec.cls.__name__} {cls_names}")
        for chk in sec.checks:
            if chk.a not in names or chk.b not in names or chk.op not in ("<", "<="):
                raise AssertionError(f"section {sec.name}: bad check {chk}")
        if sec.label is not None and (not sec.array or names[:1] != [sec.label]):
            raise AssertionError(f"section {sec.name}: the label must be its first key")


def _check_schema() -> None:
    """Import-time consistency check of the preset rows (programming errors only)."""
    check_rows(SCHEMA_FIELDS, SECTIONS)
    preset_names = [f.name for f in dc_fields(Preset)]
    if preset_names != ["name", "path"] + list(_TOP_KEYS):
        raise AssertionError(f"Preset fields {preset_names} do not follow the schema {_TOP_KEYS}")


_check_schema()



_ABSENT: Any = When("<absent>", ())  # sentinel returned by _Validator.presence


def _float(v: int | float) -> float:
    """A TOML number as a float; an integer too large for one (TOML has
    them: ``1`` and 400 zeros) is +-inf, which the callers reject as not
    finite, instead of raising OverflowError."""
    try:
        return float(v)
    except OverflowError:
        return math.inf if v > 0 else -math.inf


# --------------------------------------------------------------------------
# Validation
# --------------------------------------------------------------------------


class _Validator:
    """Reads rows and validates a document against them.

    ``error`` is the exception class raised (one line: ``source: message``),
    ``show`` renders values in messages, ``base`` is the folder ``"path"``
    values are relative to. ``overridden`` and ``file_raw`` are the presets'
    ``--set`` (see :func:`validate_dict`).
    """

    def __init__(self, source: str, overridden: frozenset[str] = frozenset(),
                 file_raw: Mapping[str, Any] | None = None, *, error: type = PresetError,
                 show=_fmt_value, base: str | Path | None = None):
        self.src = source
        self.overridden = overridden
        self.file_raw = file_raw
        self.error = error
        self.show = show
        self.base = Path(base) if base is not None else Path(".")
        self.ctx: dict[str, Any] = {}
        self.dropped: list[str] = []
        #: (section, its label in messages): an array's item is named by its
        #: label ("render 'a'"), its keys stay "render.KEY" in the context
        self.scope: tuple[str, str] = ("", "")

    # -- messages ---------------------------------------------------------
    def _origin(self, key: str) -> str:
        return " (from --set)" if key in self.overridden else ""

    def fail(self, msg: str) -> Exception:
        return self.error(f"{self.src}: {msg}")

    def _name(self, key: str) -> str:
        """A context key as messages name it (an array item's keys by its label)."""
        sec, label = self.scope
        if sec and label != sec and key.startswith(sec + "."):
            return label + key[len(sec):]
        return key

    def _when_text(self, when: When) -> str:
        set_by = ", set by --set" if when.key in self.overridden else ""
        return f"{when.describe(self.show, self._name)}{set_by}"

    def _expect(self, row: Field) -> str:
        """What a row's key accepts, for a wrong type."""
        one = _TYPE_TEXT[row.type]
        text = {None: one, "list": f"a non-empty array ({one} each)",
                "list0": f"an array ({one} each)", "one+": f"{one} or an array of them",
                "sweep": f"{one} or an array of them"}[row.many]
        if row.many == "sweep" and row.type in _RANGED:
            text = f"{one}, an array of them or a range {{low, high[, steps]}}"
        if row.span:
            text += ' or "LO..HI/STEP"'
        if row.literals:
            text += ", or " + " or ".join(self.show(x) for x in row.literals)
        return f"a table of keys, each {text}" if row.mapping else text

    # -- values -----------------------------------------------------------
    def value(self, key: str, row: Field, v: Any) -> Any:
        """The validated value of `key` (as messages name it) for `row`."""
        if row.mapping:
            if not isinstance(v, Mapping):
                raise self.fail(f"{key} = {self.show(v)} has the wrong type "
                                f"(expected {self._expect(row)})")
            return tuple((k, self.shaped(f"{key}.{k}", row, x)) for k, x in v.items())
        return self.shaped(key, row, v)

    def shaped(self, key: str, row: Field, v: Any) -> Any:
        """One value of the row's shape (``many``): arrays and one value of
        "one+"/"sweep" as tuples, a range table as a :class:`Range`."""
        m = row.many
        if m is None:
            return self.scalar(key, row, v)
        if isinstance(v, str) and v in row.literals:
            return v
        if isinstance(v, list):
            if not v and m != "list0":
                raise self.fail(f"{key} = [] needs at least one value")
            return tuple(self.scalar(f"{key}[{i}]", row, x) for i, x in enumerate(v))
        if row.span and isinstance(v, str):
            return self.span(key, row, v)
        if m == "sweep" and isinstance(v, Mapping) and row.type in _RANGED:
            return self.range_table(key, row, v)
        if m in ("one+", "sweep") and not isinstance(v, Mapping):
            return (self.scalar(key, row, v, self._expect(row)),)
        raise self.fail(f"{key} = {self.show(v)} has the wrong type (expected {self._expect(row)})")

    def span(self, key: str, row: Field, v: str) -> tuple[int, ...]:
        m = _SPAN.fullmatch(v)
        shown = f"{key} = {self.show(v)}"
        if not m:
            raise self.fail(f"{shown} has the wrong type (expected {self._expect(row)})")
        lo, hi, step = int(m[1]), int(m[2]), int(m[3] or 1)
        if not (row.in_range(lo) and lo <= hi and row.in_range(hi) and step >= 1):
            raise self.fail(f"{shown} is out of range ({_fmt_num(row.lo)} <= LO <= HI <= "
                            f"{_fmt_num(row.hi)}, STEP >= 1)")
        return tuple(range(lo, hi + 1, step))

    def range_table(self, key: str, row: Field, v: Mapping[str, Any]) -> Range:
        self.unknown_keys(f"{key}.", v, ("low", "high", "steps"))
        for k in ("low", "high"):
            if k not in v:
                raise self.fail(f"missing key '{key}.{k}' (a range {{low, high[, steps]}})")
        bound = _ANY_BOUND if row.type == "any" else row
        lo = self.scalar(f"{key}.low", bound, v["low"])
        hi = self.scalar(f"{key}.high", bound, v["high"])
        if not lo <= hi:
            raise self.fail(f"{key}.low = {self.show(lo)} must be less than or equal to "
                            f"{key}.high = {self.show(hi)}")
        steps = self.scalar(f"{key}.steps", _STEPS, v["steps"]) if "steps" in v else None
        return Range(lo, hi, steps)

    def scalar(self, key: str, row: Field, v: Any, expected: str | None = None) -> Any:
        """One value of the row's type; `expected` words a wrong type (default: the type's)."""
        shown = f"{key} = {self.show(v)}{self._origin(key)}"
        t = row.type
        wrong = f"{shown} has the wrong type (expected {expected or _TYPE_TEXT[t]})"
        if t == "float":
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise self.fail(wrong)
            v = _float(v)
            if not math.isfinite(v):
                bounds = "" if row.lo is None and row.hi is None else f" ({row.range_text()})"
                raise self.fail(f"{shown} is not a finite number{bounds}")
        elif t == "int":
            if isinstance(v, bool) or not isinstance(v, int):
                raise self.fail(wrong)
        elif t in ("str", "line"):
            if not isinstance(v, str):
                raise self.fail(wrong)
            if t == "line" and (not v.strip() or "\n" in v or "\r" in v):
                raise self.fail(f"{shown} must be a non-empty single line")
            if row.pattern is not None and not re.fullmatch(row.pattern[0], v):
                raise self.fail(f"{shown} is not allowed ({row.pattern[1]})")
        elif t == "path":
            if not isinstance(v, str) or not v:
                raise self.fail(wrong)
            return str((self.base / v).resolve())
        elif t == "any":
            if isinstance(v, Mapping):
                raise self.fail(wrong)
            if isinstance(v, float) and not math.isfinite(v):
                raise self.fail(f"{shown} is not a finite number")
            return v
        elif t == "points":
            return self.points(key, v)
        elif t == "keys":
            return self.keys(key, row, v)
        elif t == "ascending":
            return self.ascending(key, row, v)
        elif t == "peaks":
            return self.peaks(key, row, v)
        else:  # pragma: no cover - schema error
            raise AssertionError(f"unknown field type {t!r}")
        if row.choices is not None:
            if v not in row.choices:
                allowed = ", ".join(self.show(c) for c in row.choices)
                raise self.fail(f"{shown} is not allowed (choices: {allowed})")
        elif t in ("float", "int") and not row.in_range(v):
            raise self.fail(f"{shown} is out of range ({row.range_text()})")
        return v

    def points(self, key: str, v: Any) -> tuple[tuple[float, float], ...]:
        o = self._origin(key)
        if not isinstance(v, list):
            raise self.fail(f"{key} = {self.show(v)}{o} has the wrong type "
                            f"(expected {_TYPE_TEXT['points']})")
        if len(v) < 2:
            raise self.fail(f"{key} = {self.show(v)}{o} needs at least 2 [x_m, U_m] points")
        out: list[tuple[float, float]] = []
        for i, p in enumerate(v):
            item = f"{key}[{i}] = {self.show(p)}{o}"
            if (not isinstance(p, list) or len(p) != 2
                    or any(isinstance(c, bool) or not isinstance(c, (int, float)) for c in p)):
                raise self.fail(f"{item} is not an [x_m, U_m] pair of numbers")
            x, u = _float(p[0]), _float(p[1])
            if not (math.isfinite(x) and math.isfinite(u)):
                raise self.fail(f"{item} is not finite")
            if x < 0:
                raise self.fail(f"{item} has x_m < 0 (x_m >= 0 required)")
            if out and x <= out[-1][0]:
                raise self.fail(f"{item} has x_m not strictly increasing "
                                f"(previous x_m = {self.show(out[-1][0])})")
            out.append((x, u))
        return tuple(out)

    def keys(self, key: str, row: Field, v: Any) -> tuple[int, ...]:
        o = self._origin(key)
        if not isinstance(v, list) or not v:
            raise self.fail(f"{key} = {self.show(v)}{o} has the wrong type "
                            f"(expected {_TYPE_TEXT['keys']}, at least one)")
        if len(v) > 24:
            raise self.fail(f"{key} = {self.show(v)}{o} has {len(v)} keys (at most 24)")
        for i, k in enumerate(v):
            if isinstance(k, bool) or not isinstance(k, int) or not row.in_range(k):
                raise self.fail(f"{key}[{i}] = {self.show(k)}{o} is not a MIDI key "
                                f"(an integer, {row.range_text()})")
        return tuple(int(k) for k in v)

    def ascending(self, key: str, row: Field, v: Any) -> tuple[float, ...]:
        o = self._origin(key)
        n = row.count
        many = f"{n} numbers" if n is not None else "1 to 24 numbers"
        if (not isinstance(v, list) or not v
                or any(isinstance(x, bool) or not isinstance(x, (int, float)) for x in v)):
            raise self.fail(f"{key} = {self.show(v)}{o} has the wrong type "
                            f"(expected an array of {many}, strictly increasing)")
        if (n is not None and len(v) != n) or len(v) > 24:
            raise self.fail(f"{key} = {self.show(v)}{o} has {len(v)} values (expected {many})")
        out: list[float] = []
        for i, x in enumerate(v):
            x = _float(x)
            if not (math.isfinite(x) and row.in_range(x)):
                raise self.fail(f"{key}[{i}] = {self.show(v[i])}{o} is out of range "
                                f"({row.range_text()})")
            if out and x <= out[-1]:
                raise self.fail(f"{key}[{i}] = {self.show(v[i])}{o} is not strictly increasing "
                                f"(previous value {self.show(out[-1])})")
            out.append(x)
        return tuple(out)

    def peaks(self, key: str, row: Field, v: Any) -> tuple[tuple[float, float, float], ...]:
        o = self._origin(key)
        if not isinstance(v, list):
            raise self.fail(f"{key} = {self.show(v)}{o} has the wrong type "
                            f"(expected {_TYPE_TEXT['peaks']})")
        if len(v) > MAX_PEAKS:
            raise self.fail(f"{key} = {self.show(v)}{o} has {len(v)} peaks (at most {MAX_PEAKS})")
        out: list[tuple[float, float, float]] = []
        for i, p in enumerate(v):
            item = f"{key}[{i}] = {self.show(p)}{o}"
            if (not isinstance(p, list) or len(p) != 3
                    or any(isinstance(c, bool) or not isinstance(c, (int, float)) for c in p)):
                raise self.fail(f"{item} is not an [f_hz, q, level_db] triple of numbers")
            f, q, level = (_float(c) for c in p)
            if not (math.isfinite(f) and row.in_range(f)):
                raise self.fail(f"{item} has f_hz out of range ({row.range_text()})")
            (q_lo, q_hi), (l_lo, l_hi) = PEAK_Q_RANGE, PEAK_DB_RANGE
            if not (math.isfinite(q) and q_lo <= q <= q_hi):
                raise self.fail(f"{item} has q out of range ({q_lo:g} <= value <= {q_hi:g})")
            if not (math.isfinite(level) and l_lo <= level <= l_hi):
                raise self.fail(f"{item} has level_db out of range "
                                f"({l_lo:g} <= value <= {l_hi:g})")
            if out and f <= out[-1][0]:
                raise self.fail(f"{item} has f_hz not strictly increasing "
                                f"(previous f_hz = {self.show(out[-1][0])})")
            out.append((f, q, level))
        return tuple(out)

    # -- tables -----------------------------------------------------------
    def unknown_keys(self, prefix: str, table: Mapping[str, Any], allowed: Sequence[str]) -> None:
        for k in table:
            if k not in allowed:
                dotted = f"{prefix}{k}"
                raise self.fail(f"unknown key '{dotted}'{self._origin(dotted)} "
                                f"(allowed: {', '.join(allowed)})")

    def _overridden_under(self, key: str) -> str | None:
        """The first dotted key given by --set that is `key` itself or inside section `key`."""
        if key in self.overridden:
            return key
        return next((k for k in sorted(self.overridden) if k.startswith(key + ".")), None)

    def _file_value(self, dotted: str) -> Any:
        """Value of `dotted` in the file before the overrides (``_ABSENT`` if not there)."""
        node: Any = self.file_raw
        for part in dotted.split("."):
            if not isinstance(node, Mapping) or part not in node:
                return _ABSENT
            node = node[part]
        return node

    def _droppable(self, key: str, whens: Sequence[When]) -> bool:
        """Whether the forbidden, present `key` is a key of the file left over by a
        --set that changed its discriminator (it is then dropped, not an error).

        True when the discriminator was given by --set, neither `key` nor
        (for a section) any key inside it was, and the file's own value of
        the discriminator allowed `key` (a key the file could not have is
        still the file's error). Without the file (``file_raw`` None) every
        such key counts as coming from the file.
        """
        disc = whens[0].key
        if disc not in self.overridden or self._overridden_under(key) is not None:
            return False
        if self.file_raw is None:
            return True
        fv = self._file_value(disc)
        return fv is not _ABSENT and any(fv in w.values for w in whens)

    def presence(self, key: str, present: bool, whens: Sequence[When | None],
                 alternatives: Sequence[str] = ()) -> When | None:
        """Check presence of `key` whose schema rows have conditions `whens`.

        Returns the condition of the active row (None if unconditional) when
        the key is required and present; raises if it is missing but required
        or present but forbidden; returns the sentinel ``_ABSENT`` when it is
        (correctly) absent, or when it is a key of the file that a --set of
        its discriminator made forbidden (it is then dropped, see
        :meth:`_droppable`, and recorded in ``self.dropped``).
        `alternatives` (the keys it excludes) are named when it is missing.
        """
        active = [w for w in whens if w is None or w.holds(self.ctx)]
        if active:
            if not present:
                w = active[0]
                cond = "" if w is None else f" (required when {self._when_text(w)})"
                alt = f" (or {' or '.join(alternatives)})" if alternatives else ""
                raise self.fail(f"missing key '{key}'{cond}{alt}")
            return active[0]
        if present:
            if self._droppable(key, whens):
                self.dropped.append(key)
                return _ABSENT
            disc = whens[0].key  # rows of one key share their discriminator (check_rows)
            if len(whens) == 1 and whens[0].also is not None:
                allowed = whens[0].describe(self.show, self._name)
            else:
                allowed = When(disc, tuple(v for w in whens for v in w.values)).describe(
                    self.show, self._name)
            dv = self.ctx.get(disc, ABSENT)
            actual = "(absent)" if dv is ABSENT else self.show(dv)
            shown = self._overridden_under(key) or key  # name the --set key inside a section
            raise self.fail(f"key '{shown}'{self._origin(shown)} is not allowed when "
                            f"{self._name(disc)} = {actual}{self._origin(disc)}, "
                            f"only when {allowed}")
        return _ABSENT

    def _optional(self, rows: Sequence[Field]) -> Field | None:
        """The active row of an absent key when it has a default or is
        optional (the key may then be left out), else None."""
        for r in rows:
            if ((r.default is not None or r.optional)
                    and (r.when is None or r.when.holds(self.ctx))):
                return r
        return None

    def _excluded(self, prefix: str, name: str, rows: Sequence[Field],
                  table: Mapping[str, Any]) -> bool:
        """Whether a key `name` excludes was given (then `name` does not
        apply); raises if `name` is given too."""
        for other in rows[0].excludes:
            if self.ctx.get(f"{prefix}{other}", ABSENT) is ABSENT:
                continue
            if name in table:
                label = self.scope[1]
                key, okey = (f"{label}.{n}" if label else n for n in (name, other))
                raise self.fail(f"{key} = {self.show(table[name])} is not allowed with "
                                f"{okey} = {self.show(table[other])} (give one of them)")
            return True
        return False

    def rows(self, sec: str, fields: Sequence[Field], table: Mapping[str, Any],
             label_key: str | None = None) -> dict[str, Any]:
        """The values of `table`'s keys by the rows `fields` of section `sec`
        ("" for the top level), in row order; absent keys are None (or their
        default). Validated values go into the context as ``sec.key``."""
        prefix = f"{sec}." if sec else ""
        values: dict[str, Any] = {}
        for name in _unique_names(Section(sec, "", dict, tuple(fields))):
            dotted = f"{prefix}{name}"
            shown = f"{self.scope[1]}.{name}" if sec else name
            rows = [f for f in fields if f.name == name]
            if self._excluded(prefix, name, rows, table):
                values[name] = None
                continue
            opt = self._optional(rows) if name not in table else None
            if opt is not None:
                values[name] = opt.default
                self.ctx[dotted] = ABSENT if opt.default is None else opt.default
                continue
            when = self.presence(shown, name in table, [r.when for r in rows], rows[0].excludes)
            if when is _ABSENT:
                values[name] = None
                continue
            row = next(r for r in rows if r.when is when)
            values[name] = self.ctx[dotted] = self.value(shown, row, table[name])
            if name == label_key:
                self.scope = (sec, f"{sec} {self.show(table[name])}")
        return values

    def order_checks(self, sec: Section, values: Mapping[str, Any]) -> None:
        for chk in sec.checks:
            a, b = values.get(chk.a), values.get(chk.b)
            if a is None or b is None:
                continue
            if not (a < b if chk.op == "<" else a <= b):
                ka, kb = f"{self.scope[1]}.{chk.a}", f"{self.scope[1]}.{chk.b}"
                word = "less than" if chk.op == "<" else "less than or equal to"
                raise self.fail(f"{ka} = {self.show(a)}{self._origin(ka)} must be {word} "
                                f"{kb} = {self.show(b)}{self._origin(kb)}")

    def array(self, sec: Section, raw: Mapping[str, Any]) -> tuple:
        """An array of tables ``[[name]]``: a tuple of ``sec.cls``."""
        items = raw.get(sec.name, [])
        if not isinstance(items, list):
            raise self.fail(f"{sec.name} = {self.show(items)} has the wrong type "
                            f"(expected an array of tables [[{sec.name}]])")
        if not items and not sec.optional:
            raise self.fail(f"at least one [[{sec.name}]] table is required")
        names = _unique_names(sec)
        out = []
        for i, t in enumerate(items):
            label = f"{sec.name}[{i}]"
            if not isinstance(t, Mapping):
                raise self.fail(f"{label} = {self.show(t)} has the wrong type "
                                f"(expected a table [[{sec.name}]])")
            for k in [k for k in self.ctx if k.startswith(sec.name + ".")]:
                del self.ctx[k]             # the previous item's keys
            self.scope = (sec.name, label)
            self.unknown_keys(f"{label}.", t, names)
            values = self.rows(sec.name, sec.fields, t, sec.label)
            self.order_checks(sec, values)
            out.append(sec.cls(**values))
        self.scope = ("", "")
        return tuple(out)

    def run(self, raw: Mapping[str, Any], fields: Sequence[Field],
            sections: Sequence[Section]) -> dict[str, Any]:
        self.unknown_keys("", raw, tuple(dict.fromkeys(f.name for f in fields))
                          + tuple(s.name for s in sections))
        out = self.rows("", fields, raw)
        for sec in sections:
            if sec.array:
                out[sec.name] = self.array(sec, raw)
                continue
            if sec.optional and sec.name not in raw:
                out[sec.name] = None
                continue
            if self.presence(sec.name, sec.name in raw, [sec.when]) is _ABSENT:
                out[sec.name] = None
                continue
            if sec.requires is not None and out.get(sec.requires) is None:
                raise self.fail(f"[{sec.name}] needs a [{sec.requires}] table "
                                f"({sec.name}: {sec.doc})")
            table = raw[sec.name]
            if not isinstance(table, Mapping):
                raise self.fail(f"{sec.name} = {self.show(table)}{self._origin(sec.name)} "
                                f"has the wrong type (expected a table [{sec.name}])")
            self.unknown_keys(f"{sec.name}.", table, _unique_names(sec))
            self.scope = (sec.name, sec.name)
            values = self.rows(sec.name, sec.fields, table)
            self.order_checks(sec, values)
            self.scope = ("", "")
            out[sec.name] = sec.cls(**values)
        return out


def validate_dict(raw: Mapping[str, Any], source: str, *, name: str | None = None,
                  overridden: Sequence[str] = (),
                  file_raw: Mapping[str, Any] | None = None) -> Preset:
    """Validate a parsed preset table and build the :class:`Preset`.

    Parameters
    ----------
    raw : mapping
        The TOML document as parsed by :mod:`tomllib` (overrides already applied).
    source : str
        File name (or any label) used at the start of every error message and
        stored as ``Preset.path``.
    name : str, optional
        Preset name; defaults to the stem of ``source``.
    overridden : sequence of str
        Dotted keys whose values came from ``--set``; errors about them say so.
        When one of them is a discriminating key (``kind``, ``pluck.model``,
        ``termination.profile``, ...), the keys and sections *not* given by
        ``--set`` that its new value forbids are dropped instead of being an
        error; forbidden keys given by ``--set`` stay an error.
    file_raw : mapping, optional
        The document before the overrides. With it, only keys the file's own
        value of the discriminator allowed are dropped (a key the file could
        not have had is still reported). None: every key not in `overridden`
        counts as the file's.

    Raises
    ------
    PresetError
        One line: source, dotted key, value and the allowed range or choices.
    """
    v = _Validator(source, frozenset(overridden), file_raw)
    if not isinstance(raw, Mapping):
        raise v.fail("a preset must be a TOML table")
    out = v.run(raw, SCHEMA_FIELDS, SECTIONS)
    if name is None:
        name = Path(source).stem
    return Preset(name=name, path=source, **out)


def validate_table(raw: Mapping[str, Any], source: str, fields: Sequence[Field],
                   sections: Sequence[Section] = (), *, error: type, show=_fmt_value,
                   base: str | Path | None = None) -> dict[str, Any]:
    """Validate a parsed TOML document against its own rows (the engine of
    :func:`validate_dict`, for documents other than presets).

    Parameters
    ----------
    raw : mapping
        The document as parsed by :mod:`tomllib`.
    source : str
        File name (or any label) at the start of every error message.
    fields, sections : sequences of Field and Section
        The document's rows: its top-level keys, then its tables (arrays
        of tables with ``array=True``), validated in this order
        (:func:`check_rows` them once, at import).
    error : exception class
        Raised with the one-line message.
    show : callable
        Renders values in messages (:func:`~.schema._fmt_literal`: strings
        as ``'a'``).
    base : path, optional
        The folder ``"path"`` values are relative to (the document's).

    Returns
    -------
    dict
        Every top-level key's value (None, or its default, when absent) and
        every section's object (an array: a tuple of them).

    Raises
    ------
    error
        One line: source, key, value and what is allowed.
    """
    return _Validator(source, error=error, show=show, base=base).run(raw, fields, sections)


# --------------------------------------------------------------------------
# Overrides (--set PATH=VALUE)
# --------------------------------------------------------------------------


#: A decimal with a point that TOML rejects (".5", "5.", "-.5e-3", "01.5"); parsed as float.
_LOOSE_FLOAT = re.compile(r"[+-]?(?:\d+\.\d*|\.\d+)(?:[eE][+-]?\d+)?")


def _known_path(path: str) -> bool:
    if path in _TOP_BY_NAME:
        return True
    sec, dot, key = path.partition(".")
    return bool(dot) and sec in _SECTION_BY_NAME and key in _unique_names(_SECTION_BY_NAME[sec])


def parse_override(text: str) -> tuple[str, Any]:
    """Parse one ``--set`` argument ``"PATH=VALUE"`` into ``(dotted_path, value)``.

    VALUE is read as a TOML value (``0.7``, ``3``, ``"capo"``, ``[[0, 0], [0.01, 1e-4]]``,
    ``true``); a decimal TOML rejects but Python reads (``.5``, ``-.5``,
    ``5.``, ``007.5``) is a float; other text that is not valid TOML is
    taken as a plain string, so ``termination.profile=capo`` works without
    quotes. PATH must be a key of
    the schema (``kind``, ``pluck.position``, ...).

    Raises
    ------
    PresetError
        Missing ``=`` or a PATH that is not a key of the schema.
    """
    path, eq, value_text = text.partition("=")
    path = path.strip()
    if not eq or not path:
        raise PresetError(f"--set {text!r}: expected PATH=VALUE, e.g. pluck.position=0.7")
    if not _known_path(path):
        if path in _SECTION_BY_NAME:
            keys = ", ".join(f"{path}.{k}" for k in _unique_names(_SECTION_BY_NAME[path]))
            raise PresetError(f"--set {text!r}: '{path}' is a section; set one of its keys ({keys})")
        sec, dot, _ = path.partition(".")
        if dot and sec in _SECTION_BY_NAME:
            allowed = ", ".join(_unique_names(_SECTION_BY_NAME[sec]))
        else:
            allowed = ", ".join(_TOP_KEYS)
        raise PresetError(f"--set {text!r}: unknown key '{path}' (allowed: {allowed})")
    try:
        value = tomllib.loads(f"v = {value_text}")["v"]
    except tomllib.TOMLDecodeError:
        value = value_text.strip()
        if _LOOSE_FLOAT.fullmatch(value):
            value = float(value)  # ".5", "-.5", "5.", "1.e-3": decimals TOML rejects
    except (ValueError, RecursionError) as e:
        # an integer of more than 4300 digits (Python's limit), or arrays
        # nested too deeply for the parser
        why = "nested too deeply" if isinstance(e, RecursionError) else str(e).splitlines()[0]
        raise PresetError(f"--set {path}=...: the value cannot be read ({why})") from None
    return path, value


def _apply_overrides(raw: dict[str, Any], overrides: Sequence[str], source: str
                     ) -> tuple[dict[str, Any], list[str]]:
    raw = copy.deepcopy(raw)
    keys: list[str] = []
    for text in overrides:
        path, value = parse_override(text)
        if "." in path:
            sec, _, key = path.partition(".")
            table = raw.setdefault(sec, {})
            if not isinstance(table, dict):
                raise PresetError(f"{source}: --set {text!r}: '{sec}' in the file is not a table")
            table[key] = value
        else:
            raw[path] = value
        keys.append(path)
    return raw, keys
