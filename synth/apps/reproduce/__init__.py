"""``synth reproduce``: the thesis's results reproduced and printed as
Markdown (docs/reproduction.md), in three parts:

* :mod:`.thesis` (``synth reproduce``, the default): Publications I-II,
  the plucked strings, the biwa and the A7 hammer;
* :mod:`.felt` (``synth reproduce felt``): chapter 2, deformation waves in
  hammer felt, with its checks against the thesis;
* :mod:`.felt_study` (``synth reproduce felt-study``): the A7 strike with
  the felt-layer hammer against the lumped law (docs/felt.md).

Here: the A7 strike they share (Publication I), a study preset's hammer on
the A7 string, its probe channels and snapshots of the string's shape."""

from __future__ import annotations

import numpy as np

from ...engine.engine import Event
from ...io.factory import build_engine


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
