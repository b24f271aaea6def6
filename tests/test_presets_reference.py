"""docs/presets.md is the schema's own reference (``synth presets --reference``)."""

import dataclasses
import subprocess
import sys
from pathlib import Path

from synth.io.presets import reference as R
from synth.io.presets import sections as S

DOC = Path(__file__).resolve().parents[1] / "docs" / "presets.md"


def test_docs_presets_md_is_current():
    """The shipped reference is what the schema writes now: regenerate it with
    ``synth presets --reference > docs/presets.md`` after editing a row."""
    assert DOC.read_text(encoding="utf-8") == R.reference_markdown(), (
        "docs/presets.md is stale: run `synth presets --reference > docs/presets.md`")


def test_every_key_has_its_row_with_range_default_and_condition():
    text = R.reference_markdown()
    rows = [ln for ln in text.splitlines() if ln.startswith("| `")]
    n_fields = len(S.SCHEMA_FIELDS) + sum(len(s.fields) for s in S.SECTIONS)
    assert len(rows) == n_fields
    for sec in S.SECTIONS:
        assert f"## `[{sec.name}]`" in text
        for f in sec.fields:
            mine = [r for r in rows if r.startswith(f"| `{sec.name}.{f.name}` |")]
            assert mine, f"{sec.name}.{f.name} missing"
            # a key with several rows (disjoint conditions) has one per condition
            assert any((f.when is None and r.endswith("| always |"))
                       or (f.when is not None and f.when.describe() in r) for r in mine)
            if f.choices is None and f.lo is not None and f.type == "float":
                assert any(f.range_text() in r for r in mine), (sec.name, f.name)
            if f.default is None:
                want = "| optional |" if f.optional else "| required |"
                assert any(want in r for r in mine)


def test_a_changed_row_changes_the_reference(monkeypatch):
    """The text follows the rows (it is not a copy that could go stale)."""
    before = R.reference_markdown()
    sec = S.SECTIONS[0]
    f0 = dataclasses.replace(sec.fields[0], hi=2.5, doc="a changed meaning, m")
    changed = dataclasses.replace(sec, fields=(f0,) + sec.fields[1:])
    monkeypatch.setattr(R, "SECTIONS", (changed,) + S.SECTIONS[1:])
    after = R.reference_markdown()
    assert after != before
    assert "a changed meaning, m" in after and "<= 2.5" in after


def test_the_command_prints_it():
    out = subprocess.run([sys.executable, "-m", "synth.cli", "presets", "--reference"],
                         capture_output=True, text=True, check=True).stdout
    assert out == R.reference_markdown()
