"""Shared test helpers: build instruments and engines from presets."""

from synth.engine.engine import Engine, Event
from synth.io.presets import load_preset
from synth.voices import instrument_for


def engine(name, overrides=(), probe=False, **kw):
    inst = instrument_for(load_preset(name, overrides))
    return Engine(inst, probe=probe, **kw)


def note(key, t=0.0, vel=0.8, off=None):
    ev = [Event(t, "note_on", key, vel)]
    if off is not None:
        ev.append(Event(off, "note_off", key, 0.0))
    return ev


def shared_dir():
    """The workplace's shared/ folder: beside the checkout (as in CI), else
    /work/shared."""
    from pathlib import Path

    here = Path(__file__).resolve().parents[2] / "shared"
    return here if here.is_dir() else Path("/work/shared")
