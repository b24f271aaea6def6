"""The per-key designs kept on disk between runs (synth.voices.design_store,
issue 39's warm start): loaded designs give the same samples, anything
that decides a design names another file, and a bad file is designed again."""

from __future__ import annotations

import numpy as np
import pytest

import synth
from synth.io.factory import build_voice
from synth.voices import design_store


@pytest.fixture
def store(tmp_path, monkeypatch):
    d = tmp_path / "designs"
    monkeypatch.setenv(design_store.ENV, str(d))
    return d


def _files(d):
    return sorted(p.name for p in d.glob("*.pkl")) if d.exists() else []


def test_a_warm_voice_saves_its_keys_and_the_next_loads_them_unchanged(store, monkeypatch):
    a = build_voice("biwa", [])
    a.warm()
    assert len(_files(store)) == 1
    b = build_voice("biwa", [])
    calls = []
    orig = type(b).setup

    def counting(self, *args, **kw):
        n = len(self._setups)
        out = orig(self, *args, **kw)
        calls.append(len(self._setups) > n)
        return out

    monkeypatch.setattr(type(b), "setup", counting)
    b.warm()
    assert calls and not any(calls)          # nothing designed: every key loaded
    assert set(b._setups) == set(a._setups)
    for k, su in a._setups.items():
        other = b._setups[k]
        assert other.cells == su.cells and other.eta == su.eta and other.a_disp == su.a_disp
        if su.U is not None:
            assert np.array_equal(other.U, su.U)


@pytest.mark.slow  # over 2 s on a quiet 2-core machine (2026-11-29: 2.0-6.1 s)
def test_loaded_designs_render_the_same_samples(store, monkeypatch):
    synth.render_note("sitar", key=50, seconds=0.2)         # warm nothing: one key
    v = build_voice("sitar", [])
    v.warm()
    v2 = build_voice("sitar", [])
    v2.warm()                                                # from the file
    monkeypatch.setenv(design_store.ENV, "off")
    v3 = build_voice("sitar", [])
    v3.warm()                                                # designed here
    from synth.io.factory import build_engine
    from synth.engine.engine import Event
    out = []
    for voice in (v2, v3):
        eng = build_engine("sitar", voice=voice)
        out.append(eng.render([Event(0.0, "note_on", 57, 0.8)], duration_s=0.3))
    assert np.array_equal(out[0], out[1])


def test_anything_that_decides_a_design_names_another_file(store, monkeypatch):
    build_voice("biwa", []).warm()
    build_voice("biwa", ["termination.radius_m=0.9"]).warm()
    assert len(_files(store)) == 2
    monkeypatch.setattr(design_store, "_digest", "another version of the code")
    build_voice("biwa", []).warm()
    assert len(_files(store)) == 3


def test_a_file_that_does_not_load_is_designed_again(store):
    build_voice("biwa", []).warm()
    (p,) = store.glob("*.pkl")
    p.write_bytes(b"cut sh")
    assert design_store.load("setups", ("x",)) is None
    v = build_voice("biwa", [])
    v.warm()
    assert len(v._setups) >= 100
    (q,) = store.glob("*.pkl")
    assert q.stat().st_size > 1000                            # written whole again


def test_off_neither_reads_nor_writes(tmp_path, monkeypatch):
    monkeypatch.setenv(design_store.ENV, "off")
    assert design_store.folder() is None
    assert design_store.save("setups", ("k",), {1: 2}) is False
    assert design_store.load("setups", ("k",)) is None


def test_an_unwritable_folder_is_not_an_error(tmp_path, monkeypatch):
    f = tmp_path / "a-file"
    f.write_text("not a folder")
    monkeypatch.setenv(design_store.ENV, str(f / "designs"))
    assert design_store.save("setups", ("k",), {1: 2}) is False
    build_voice("biwa", []).warm()


def test_the_folder_keeps_the_newest(store, monkeypatch):
    monkeypatch.setattr(design_store, "KEEP", 3)
    for i in range(5):
        assert design_store.save("t", ("key", i), i)
    assert len(_files(store)) == 3
    assert design_store.load("t", ("key", 4)) == 4


@pytest.mark.slow  # over 2 s on a quiet 2-core machine (1.5-2.1 s, 2026-11-30): the grand designed twice
def test_the_grand_keeps_its_keys_and_its_sympathetic_strings(store, monkeypatch):
    from synth.voices import grand

    # a fresh process's caches: another test of this process (any grand
    # engine) may have designed the keys (and read another store's file:
    # then warm() designs nothing new and saves nothing here) and the
    # sympathetic strings already
    monkeypatch.setattr(grand, "_DESIGNS", {})
    grand._SYMPATHETIC.clear()
    v = build_voice("grand-piano", [])
    v.warm()
    v.free_strings(48_000.0)
    names = _files(store)
    assert any(n.startswith("grand-keys-") for n in names)
    assert any(n.startswith("grand-sympathetic-") for n in names)
    # a new process: the in-process caches are empty
    before = v.free_strings(48_000.0)
    grand._SYMPATHETIC.clear()
    w = build_voice("grand-piano", [])
    after = w.free_strings(48_000.0)
    assert after is not before                                # loaded, not the same object
    assert after.keys == before.keys and after.dampers == before.dampers
    assert after.resistance_ns_per_m == before.resistance_ns_per_m
    assert len(after.slots) == len(before.slots)
    for a, b in zip(after.slots, before.slots):               # every template, value for value
        for name in ("ipar", "fpar", "U", "bend_delay", "cells", "region", "bend_len"):
            x, y = getattr(a, name), getattr(b, name)
            assert np.array_equal(x, y) if isinstance(x, np.ndarray) else x == y, name


def test_a_grand_key_designed_for_one_note_is_kept_for_the_next_process(store, monkeypatch):
    """A key that a single note designs (no :meth:`warm`) is saved at once,
    in the one file :meth:`warm` fills: the next process (its designs
    emptied) loads it and designs nothing for it, the same strings; a key
    not designed before is designed and joins the file."""
    from synth.voices import grand
    from synth.voices.grand import GrandVoice

    monkeypatch.setattr(grand, "_DESIGNS", {})
    v = build_voice("grand-piano", [])
    a = v.setup(60)
    assert [n for n in _files(store) if n.startswith("grand-keys-")]
    kept = design_store.load("grand-keys", v._store_key())
    assert 60 in kept and 61 not in kept

    designed = []
    plain = GrandVoice._design
    monkeypatch.setattr(GrandVoice, "_design",
                        lambda self, key, M: (designed.append(key), plain(self, key, M))[1])
    monkeypatch.setattr(grand, "_DESIGNS", {})              # a new process
    w = build_voice("grand-piano", [])
    b = w.setup(60)
    assert designed == [] and b is not a
    assert len(a) == len(b) == 3
    for x, y in zip(a, b):
        assert (x.f1_hz, x.sub, x.cells, x.b0, x.a1, x.n_disp) == (y.f1_hz, y.sub, y.cells, y.b0,
                                                                   y.a1, y.n_disp)
        assert np.array_equal(x.sos, y.sos)
    w.setup(61)
    assert designed == [61]
    assert 61 in design_store.load("grand-keys", w._store_key())


def test_the_sitar_keeps_its_taraf_and_chikari(store):
    """The sitar's free strings (13 strings designed at every engine's
    build: 0.1 s) are saved by the first voice and loaded by the next,
    template for template; with the store off they are designed anew, the
    same values."""
    from synth.voices import one_string

    # a fresh process's cache: another test of this process may have
    # designed the sitar's free strings already
    one_string._FREE_STRINGS.clear()
    v = build_voice("sitar", [])
    before = v.free_strings(48_000.0)
    assert any(n.startswith("free-strings-") for n in _files(store))
    one_string._FREE_STRINGS.clear()                          # a new process
    after = build_voice("sitar", []).free_strings(48_000.0)
    assert after is not before and after.keys == before.keys and after.drone_keys == before.drone_keys
    for a, b in zip(after.slots + after.drone_slots, before.slots + before.drone_slots):
        for name in ("ipar", "fpar", "U", "bend_delay", "cells", "region", "bend_len"):
            x, y = getattr(a, name), getattr(b, name)
            assert np.array_equal(x, y) if isinstance(x, np.ndarray) else x == y, name
    assert build_voice("tanpura", []).free_strings(48_000.0).slots == ()   # the bridge alone, kept too
    assert build_voice("tanpura", []).free_strings(48_000.0).resistance_ns_per_m == 500.0
