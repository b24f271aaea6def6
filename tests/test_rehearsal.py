"""The live player's rehearsal (synth.io.live.rehearsal): silent notes on an
understudy that keep a note's paths warm, and leave the performance alone."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from synth.engine.engine import CC_SUSTAIN, CONTROL, NOTE_OFF, NOTE_ON, Event
from synth.io.factory import build_engine, build_voice
from synth.io.live.rehearsal import Rehearsal, rehearsal_keys

BLOCK = 128


def _events():
    ev = [Event(0.0, CONTROL, CC_SUSTAIN, 1.0)]
    ev += [Event(0.01 + 0.003 * i, NOTE_ON, k, 0.5 + 0.05 * i) for i, k in enumerate((40, 52, 64, 76, 88))]
    ev += [Event(0.12, NOTE_OFF, k, 0.5) for k in (40, 52, 64, 76, 88)]
    ev += [Event(0.15, CONTROL, CC_SUSTAIN, 0.0), Event(0.16, NOTE_ON, 60, 0.9)]
    return ev


def _tick(r) -> None:
    r.done.clear()
    if r.tick():
        assert r.done.wait(10.0)


def _play(voice, blocks: int, rehearsal=None) -> np.ndarray:
    eng = build_engine("grand-piano", voice=voice, extra_low_key=0, block=BLOCK)
    eng.schedule(_events())
    out = []
    for _ in range(blocks):
        out.append(eng.render_block(BLOCK).copy())
        if rehearsal is not None:
            _tick(rehearsal)               # its part runs between our blocks, as live
    return np.concatenate(out, axis=-1)


@pytest.fixture(scope="module")
def grand():
    voice = build_voice("grand-piano")
    voice.warm()
    return voice


def test_the_performance_is_the_same_to_the_bit_with_a_rehearsal(grand):
    """The understudy shares the live engine's voice; the notes it plays
    (every other block here: a strike, its release, the pedal, a steal on
    its full pool) change none of the live engine's samples."""
    blocks = 90
    ref = _play(grand, blocks)
    r = Rehearsal("grand-piano", grand, 48_000, BLOCK, every_s=2 * BLOCK / 48_000)
    r.start()
    try:
        got = _play(grand, blocks, r)
    finally:
        r.stop()
        r.join(10.0)
    assert not r.is_alive()
    assert r.error is None
    assert r.notes >= blocks // 2 - 2             # it did play, a note every two blocks
    assert r.engine.n_stolen > 0                  # on a full pool
    assert np.abs(ref).max() > 1e-3
    assert np.array_equal(ref, got)


def test_a_part_is_due_after_so_many_blocks():
    """A note every round(every_s fs / block) blocks: its strike, then its
    release at the next block."""
    r = Rehearsal.__new__(Rehearsal)
    threading.Thread.__init__(r)
    r._go, r._count, r._every_blocks = threading.Event(), 0, 3     # every_s = 4 blocks
    fired = []
    for b in range(1, 13):
        fired.append(r.tick())
        assert r._go.is_set() == fired[-1]
        r._go.clear()
    assert [b for b, f in enumerate(fired, 1) if f] == [3, 4, 7, 8, 11, 12]


def test_it_follows_a_program_change_and_stops_on_an_error(grand):
    r = Rehearsal("grand-piano", grand, 48_000, BLOCK, every_s=0.005)
    biwa = build_voice("biwa")
    r.follow(r.understudy("biwa", biwa))
    r.start()
    try:
        for _ in range(8):
            _tick(r)
        assert r.engine.inst is biwa and r.error is None and r.notes >= 2

        class Broken:
            time_out, fs_out = 0, 48_000

            def schedule(self, events):
                raise RuntimeError("no such engine\nsecond line")

        r.follow((Broken(), [60]))
        assert r.tick()                 # the next part is a strike: on the broken engine
        r.join(5.0)
        assert not r.is_alive()
        assert r.error == "RuntimeError: no such engine"
    finally:
        r.stop()
        r.join(5.0)


def test_keys_and_period_range():
    assert rehearsal_keys(build_voice("grand-piano")) == list(range(21, 109))
    assert rehearsal_keys(build_voice("paper/biwa-ideal")) == [-1]
    with pytest.raises(ValueError, match=r"every_s = 0\.001 is out of range \(0\.002 <= value <= 1\)"):
        Rehearsal("biwa", build_voice("biwa"), 48_000, BLOCK, every_s=0.001)


def test_the_command_line_default_is_the_players():
    from synth.cli import build_parser
    from synth.io.live.rehearsal import DEFAULT_EVERY_MS

    args = build_parser().parse_args(["play", "--preset", "sitar"])
    assert args.warm_every_ms == DEFAULT_EVERY_MS
