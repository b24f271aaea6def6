"""The A7 strike of the reproduction scripts (``tools/reproduce.py``,
``tools/felt_study.py``; docs/reproduction.md, Publication I): a study
preset's hammer on the A7 string, its probe channels and snapshots of the
string's shape, kept in the package so that they are tested from it."""

from __future__ import annotations

import numpy as np

from ..engine.engine import Event
from ..io.factory import build_engine


def a7_run(name, sets=(), times_s=(), probe_s=0.0065, fs_internal=None):
    """A7 strike: probe channels over ``probe_s`` and two snapshots (u at t
    and t + dt) at each of ``times_s`` (``fs_internal``: re-grid the study
    string to that rate)."""
    e = build_engine(name, sets, probe=True, fs_internal=fs_internal)
    inst = e.inst
    e.schedule([Event(0.0, "note_on", -1, 1.0)])
    e.render_block(1)
    b, s = e.bank, int(e.bank.active[0])
    su = inst.setup()
    n_total = int(round(probe_s * inst.fs))
    b.ensure_probe_length(n_total + 2)
    b.probe[:] = 0.0
    mix = np.zeros(n_total + 2)
    done, snaps = 0, []
    # the study voice probes its string into probe row 0 (``probe=True``)
    # the note started at the engine's first internal sample (already rendered)
    done = e.time_in
    for t in times_s:
        target = int(round(t * inst.fs))
        b.render(mix, done, target - done)
        done = target
        u0 = b.displacement(s)
        b.render(mix, done, 1)
        done += 1
        snaps.append((u0, b.displacement(s)))
    if done < n_total:
        b.render(mix, done, n_total - done)
    return inst, su, b.probe[0, :, :n_total].copy(), snaps
