"""The preset file reference, written from the schema rows (``synth presets --reference``).

Every key a preset file may hold, with its meaning and unit, its type, its
allowed range or choices, its default and the condition under which it
applies, is read from :data:`~.sections.SCHEMA_FIELDS` and
:data:`~.sections.SECTIONS`: the same rows that validate a file when it
loads. ``docs/presets.md`` is this module's output
(``tests/test_presets_reference.py`` checks that it is current), so the
reference cannot drift from what the loader accepts.
"""

from __future__ import annotations

from .schema import Field, Section, When, _fmt_num, _fmt_value
from .sections import SCHEMA_FIELDS, SCHEMA_VERSION, SECTIONS

__all__ = ["reference_markdown"]

#: what each schema type accepts, for the reference's type column
TYPE_TEXT = {
    "float": "number",
    "int": "integer",
    "str": "string",
    "line": "one-line text",
    "points": "[[x_m, U_m], ...]",
    "keys": "[key, ...]",
    "ascending": "[number, ...], increasing",
    "peaks": "[[f_hz, q, level_db], ...]",
}


def _cell(text: str) -> str:
    """Text safe inside a Markdown table cell (no pipe, no line break)."""
    return " ".join(str(text).split()).replace("|", "\\|")


def _allowed(f: Field) -> str:
    if f.choices is not None:
        return ", ".join(f"`{_fmt_value(c)}`" for c in f.choices)
    if f.type in ("float", "int", "keys", "peaks", "ascending") and (f.lo is not None
                                                                     or f.hi is not None):
        text = f.range_text()
        return text if f.count is None else f"{f.count} values, each {text}"
    return ""


def _default(f: Field) -> str:
    if f.default is None:
        return "optional" if f.optional else "required"
    v = f.default
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        return f"`{_fmt_num(v)}`"
    return f"`{_fmt_value(v)}`"


def _when(w: When | None) -> str:
    return "always" if w is None else w.describe()


def _table(fields: tuple[Field, ...], prefix: str) -> list[str]:
    out = ["| key | meaning, unit | type | allowed | default | applies when |",
           "|---|---|---|---|---|---|"]
    for f in fields:
        out.append("| " + " | ".join((
            f"`{prefix}{f.name}`",
            _cell(f.doc),
            _cell(TYPE_TEXT.get(f.type, f.type)),
            _cell(_allowed(f)),
            _cell(_default(f)),
            _cell(_when(f.when)),
        )) + " |")
    return out


def _section(sec: Section) -> list[str]:
    out = [f"## `[{sec.name}]`", "", _cell(sec.doc[:1].upper() + sec.doc[1:]) + "."]
    cond = []
    if sec.when is not None:
        cond.append(f"The table applies when {sec.when.describe()}")
    else:
        cond.append("Every preset has this table")
    if sec.optional:
        cond[-1] += "; it may be left out"
    if sec.requires:
        cond[-1] += f"; it needs `[{sec.requires}]`"
    out += ["", cond[0] + ".", ""]
    out += _table(sec.fields, f"{sec.name}.")
    if sec.checks:
        out += [""] + [f"Also: `{sec.name}.{c.a}` {c.op} `{sec.name}.{c.b}` when both are given."
                       for c in sec.checks]
    return out + [""]


def reference_markdown() -> str:
    """The preset file reference as Markdown (the text of ``docs/presets.md``).

    Returns
    -------
    str
        A title, how to read the tables, the top-level keys, then one
        section per TOML table in validation order, each a table of its
        keys: meaning and unit, type, allowed range or choices, default
        ("required" where none; "optional" for a key that may be left out
        without one, its value then None) and the condition under which the key
        applies (elsewhere it is refused).
    """
    lines = [
        "# Preset files: every key",
        "",
        "<!-- Written by `synth presets --reference` from the schema rows in",
        "     synth/io/presets/sections.py; do not edit by hand (a test checks it is current). -->",
        "",
        f"A preset is a TOML file (schema {SCHEMA_VERSION}).  Each key below is checked when a preset",
        "loads, and each `--set PATH=VALUE` too: a value out of range, a key given where",
        "its condition does not hold, or a required key left out stops the load with",
        "one line naming the file, the key, the value and the allowed range.",
        "\"Applies when\" names the condition under which a key is read; elsewhere it is",
        "refused.  A key with a default may be left out where it applies.",
        "Units are SI unless the key's name or meaning says otherwise.",
        "",
        "## Top-level keys",
        "",
    ]
    lines += _table(SCHEMA_FIELDS, "")
    lines.append("")
    for sec in SECTIONS:
        lines += _section(sec)
    return "\n".join(lines).rstrip("\n") + "\n"
