"""docs/api.md's examples run as doctests: the user page of the Python API
says what the code does."""

from __future__ import annotations

import doctest
from pathlib import Path

import pytest

API_MD = Path(__file__).resolve().parents[1] / "docs" / "api.md"


@pytest.mark.slow  # over 2 s: a dozen short renders
def test_docs_api_md_examples_run(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)                  # the examples write WAV and MIDI files
    monkeypatch.delenv("SYNTH_PRESET_PATH", raising=False)
    res = doctest.testfile(str(API_MD), module_relative=False, report=True,
                           optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert res.attempted > 30, res
    assert res.failed == 0, f"{res.failed} of {res.attempted} examples of docs/api.md failed (above)"
    assert (tmp_path / "sitar-a3.wav").is_file()
