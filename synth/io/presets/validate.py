"""Validation of a parsed preset against the rows of :mod:`.sections`, and ``--set``.

:func:`validate_dict` builds a :class:`~.model.Preset` or raises a one-line
:class:`~synth.io.errors.PresetError`; :func:`parse_override` and
``_apply_overrides`` handle the CLI's ``--set PATH=VALUE``. Importing this
module runs ``_check_schema``, a consistency check of the rows against the
dataclasses of :mod:`.model` (programming errors only).
"""

from __future__ import annotations

import copy
import math
import re
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import fields as dc_fields
from pathlib import Path
from typing import Any

from synth.io.errors import PresetError
from synth.physics.soundboard import MAX_PEAKS, PEAK_DB_RANGE, PEAK_Q_RANGE

from .model import Preset
from .schema import Field, When, _fmt_value, _unique_names
from .sections import SCHEMA_FIELDS, SECTIONS

__all__ = ["validate_dict", "parse_override"]

_SECTION_BY_NAME = {s.name: s for s in SECTIONS}
_TOP_BY_NAME = {f.name: f for f in SCHEMA_FIELDS}
_TOP_KEYS = tuple(f.name for f in SCHEMA_FIELDS) + tuple(s.name for s in SECTIONS)


def _check_schema() -> None:
    """Import-time consistency check of the schema table (programming errors only)."""
    known: list[str] = [f.name for f in SCHEMA_FIELDS]
    for sec in SECTIONS:
        if sec.when is not None and sec.when.key not in known:
            raise AssertionError(f"section {sec.name}: condition on later/unknown key {sec.when.key}")
        names = _unique_names(sec)
        cls_names = [f.name for f in dc_fields(sec.cls)]
        if sorted(names) != sorted(cls_names):
            raise AssertionError(f"section {sec.name}: schema keys {names} != {sec.cls.__name__} {cls_names}")
        for name in names:
            rows = [f for f in sec.fields if f.name == name]
            if len(rows) > 1:
                # Several rows: all conditional on the same key with disjoint values.
                if any(r.when is None for r in rows) or len({r.when.key for r in rows}) != 1:
                    raise AssertionError(f"{sec.name}.{name}: ambiguous rows")
                vals = [v for r in rows for v in r.when.values]
                if len(vals) != len(set(vals)):
                    raise AssertionError(f"{sec.name}.{name}: overlapping conditions")
            for r in rows:
                if r.when is not None and r.when.key not in known:
                    raise AssertionError(f"{sec.name}.{name}: condition on later/unknown key {r.when.key}")
            known.append(f"{sec.name}.{name}")
        for chk in sec.checks:
            if chk.a not in names or chk.b not in names or chk.op not in ("<", "<="):
                raise AssertionError(f"section {sec.name}: bad check {chk}")
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


_TYPE_TEXT = {
    "float": "a number",
    "int": "an integer",
    "str": "a string",
    "line": "a string",
    "points": "an array of [x_m, U_m] pairs",
    "keys": "an array of MIDI keys",
    "peaks": "an array of [f_hz, q, level_db] triples",
}


# --------------------------------------------------------------------------
# Validation
# --------------------------------------------------------------------------


class _Validator:
    def __init__(self, source: str, overridden: frozenset[str],
                 file_raw: Mapping[str, Any] | None = None):
        self.src = source
        self.overridden = overridden
        self.file_raw = file_raw
        self.ctx: dict[str, Any] = {}
        self.dropped: list[str] = []

    # -- messages ---------------------------------------------------------
    def _origin(self, key: str) -> str:
        return " (from --set)" if key in self.overridden else ""

    def fail(self, msg: str) -> PresetError:
        return PresetError(f"{self.src}: {msg}")

    def _when_text(self, when: When) -> str:
        set_by = ", set by --set" if when.key in self.overridden else ""
        return f"{when.describe()}{set_by}"

    # -- scalar values ----------------------------------------------------
    def value(self, key: str, row: Field, v: Any) -> Any:
        shown = f"{key} = {_fmt_value(v)}{self._origin(key)}"
        t = row.type
        if t == "float":
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise self.fail(f"{shown} has the wrong type (expected {_TYPE_TEXT[t]})")
            v = _float(v)
            if not math.isfinite(v):
                raise self.fail(f"{shown} is not a finite number ({row.range_text()})")
        elif t == "int":
            if isinstance(v, bool) or not isinstance(v, int):
                raise self.fail(f"{shown} has the wrong type (expected {_TYPE_TEXT[t]})")
        elif t in ("str", "line"):
            if not isinstance(v, str):
                raise self.fail(f"{shown} has the wrong type (expected {_TYPE_TEXT[t]})")
            if t == "line" and (not v.strip() or "\n" in v or "\r" in v):
                raise self.fail(f"{shown} must be a non-empty single line")
        elif t == "points":
            return self.points(key, v)
        elif t == "keys":
            return self.keys(key, row, v)
        elif t == "peaks":
            return self.peaks(key, row, v)
        else:  # pragma: no cover - schema error
            raise AssertionError(f"unknown field type {t!r}")
        if row.choices is not None:
            if v not in row.choices:
                allowed = ", ".join(_fmt_value(c) for c in row.choices)
                raise self.fail(f"{shown} is not allowed (choices: {allowed})")
        elif t in ("float", "int") and not row.in_range(v):
            raise self.fail(f"{shown} is out of range ({row.range_text()})")
        return v

    def points(self, key: str, v: Any) -> tuple[tuple[float, float], ...]:
        o = self._origin(key)
        if not isinstance(v, list):
            raise self.fail(f"{key} = {_fmt_value(v)}{o} has the wrong type "
                            f"(expected {_TYPE_TEXT['points']})")
        if len(v) < 2:
            raise self.fail(f"{key} = {_fmt_value(v)}{o} needs at least 2 [x_m, U_m] points")
        out: list[tuple[float, float]] = []
        for i, p in enumerate(v):
            item = f"{key}[{i}] = {_fmt_value(p)}{o}"
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
                                f"(previous x_m = {_fmt_value(out[-1][0])})")
            out.append((x, u))
        return tuple(out)

    def keys(self, key: str, row: Field, v: Any) -> tuple[int, ...]:
        o = self._origin(key)
        if not isinstance(v, list) or not v:
            raise self.fail(f"{key} = {_fmt_value(v)}{o} has the wrong type "
                            f"(expected {_TYPE_TEXT['keys']}, at least one)")
        if len(v) > 24:
            raise self.fail(f"{key} = {_fmt_value(v)}{o} has {len(v)} keys (at most 24)")
        for i, k in enumerate(v):
            if isinstance(k, bool) or not isinstance(k, int) or not row.in_range(k):
                raise self.fail(f"{key}[{i}] = {_fmt_value(k)}{o} is not a MIDI key "
                                f"(an integer, {row.range_text()})")
        return tuple(int(k) for k in v)

    def peaks(self, key: str, row: Field, v: Any) -> tuple[tuple[float, float, float], ...]:
        o = self._origin(key)
        if not isinstance(v, list):
            raise self.fail(f"{key} = {_fmt_value(v)}{o} has the wrong type "
                            f"(expected {_TYPE_TEXT['peaks']})")
        if len(v) > MAX_PEAKS:
            raise self.fail(f"{key} = {_fmt_value(v)}{o} has {len(v)} peaks (at most {MAX_PEAKS})")
        out: list[tuple[float, float, float]] = []
        for i, p in enumerate(v):
            item = f"{key}[{i}] = {_fmt_value(p)}{o}"
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
                                f"(previous f_hz = {_fmt_value(out[-1][0])})")
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

    def presence(self, key: str, present: bool, whens: Sequence[When | None]) -> When | None:
        """Check presence of `key` whose schema rows have conditions `whens`.

        Returns the condition of the active row (None if unconditional) when
        the key is required and present; raises if it is missing but required
        or present but forbidden; returns the sentinel ``_ABSENT`` when it is
        (correctly) absent, or when it is a key of the file that a --set of
        its discriminator made forbidden (it is then dropped, see
        :meth:`_droppable`, and recorded in ``self.dropped``).
        """
        active = [w for w in whens if w is None or w.holds(self.ctx)]
        if active:
            if not present:
                w = active[0]
                cond = "" if w is None else f" (required when {self._when_text(w)})"
                raise self.fail(f"missing key '{key}'{cond}")
            return active[0]
        if present:
            if self._droppable(key, whens):
                self.dropped.append(key)
                return _ABSENT
            disc = whens[0].key  # rows of one key share their discriminator (_check_schema)
            if len(whens) == 1 and whens[0].also is not None:
                allowed = whens[0].describe()
            else:
                allowed = When(disc, tuple(v for w in whens for v in w.values)).describe()
            actual = _fmt_value(self.ctx[disc]) if disc in self.ctx else "(absent)"
            shown = self._overridden_under(key) or key  # name the --set key inside a section
            raise self.fail(f"key '{shown}'{self._origin(shown)} is not allowed when "
                            f"{disc} = {actual}{self._origin(disc)}, only when {allowed}")
        return _ABSENT

    def _optional(self, rows: Sequence[Field]) -> Field | None:
        """The active row of an absent key when it has a default (the key
        is then optional), else None."""
        for r in rows:
            if r.default is not None and (r.when is None or r.when.holds(self.ctx)):
                return r
        return None

    def run(self, raw: Mapping[str, Any]) -> dict[str, Any]:
        if not isinstance(raw, Mapping):
            raise self.fail("a preset must be a TOML table")
        self.unknown_keys("", raw, _TOP_KEYS)
        out: dict[str, Any] = {}
        for row in SCHEMA_FIELDS:
            if self.presence(row.name, row.name in raw, [row.when]) is not _ABSENT:
                out[row.name] = self.ctx[row.name] = self.value(row.name, row, raw[row.name])
        for sec in SECTIONS:
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
                raise self.fail(f"{sec.name} = {_fmt_value(table)}{self._origin(sec.name)} "
                                f"has the wrong type (expected a table [{sec.name}])")
            names = _unique_names(sec)
            self.unknown_keys(f"{sec.name}.", table, names)
            values: dict[str, Any] = {}
            for name in names:
                dotted = f"{sec.name}.{name}"
                rows = [f for f in sec.fields if f.name == name]
                opt = self._optional(rows) if name not in table else None
                if opt is not None:
                    values[name] = self.ctx[dotted] = opt.default
                    continue
                when = self.presence(dotted, name in table, [r.when for r in rows])
                if when is _ABSENT:
                    values[name] = None
                    continue
                row = next(r for r in rows if r.when is when)
                values[name] = self.ctx[dotted] = self.value(dotted, row, table[name])
            for chk in sec.checks:
                a, b = values.get(chk.a), values.get(chk.b)
                if a is None or b is None:
                    continue
                if not (a < b if chk.op == "<" else a <= b):
                    ka, kb = f"{sec.name}.{chk.a}", f"{sec.name}.{chk.b}"
                    word = "less than" if chk.op == "<" else "less than or equal to"
                    raise self.fail(f"{ka} = {_fmt_value(a)}{self._origin(ka)} must be {word} "
                                    f"{kb} = {_fmt_value(b)}{self._origin(kb)}")
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
    out = v.run(raw)
    if name is None:
        name = Path(source).stem
    return Preset(name=name, path=source, **out)


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
