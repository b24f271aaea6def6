"""A note's strings set up in one call (a mixin of :class:`synth.dsp.bank.StringBank`).

A :class:`GroupTemplate` packs the slot templates, damper rows and bridge
of the strings one note-on sets up (a grand key: its unison on a bridge and
its second polarization) into a few arrays, made once per key;
:meth:`Groups.configure_group` writes them with one kernel call
(:func:`synth.kernels.configure.configure_group`): the values
:meth:`~synth.dsp.bank.StringBank.configure_from`,
:meth:`~synth.dsp.bank.StringBank.set_damper` and
:meth:`~synth.dsp.bridges.Bridges.couple` write, to the bit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..kernels import strings as K
from ..kernels.configure import configure_group
from .bridges import bridge_constants, bridge_misfit
from .hand_over import SLOT_COLS, _write_mask


@dataclass(frozen=True, eq=False)
class GroupTemplate:
    """Strings a note-on sets up, packed (:func:`group_template`)."""

    ipar: np.ndarray            # int64 (m, I_NI): their ipar rows
    fpar: np.ndarray            # float64 (m, F_NF)
    U: np.ndarray               # their profiles, one after the other (m)
    uoff: np.ndarray            # int64 (m,): where each profile starts in U
    bend_delay: np.ndarray      # float64 (m,)
    dampers: np.ndarray         # float64 (m, 5): damper rows and their loss factors
    n_coupled: int              # the first n_coupled strings share one bridge (0: none)
    bridge: np.ndarray          # float64 (3,): its F_BRB, F_BRA, F_BRMU
    sizes: tuple                # the largest cells, region, bend line: checked per bank

    @property
    def m(self) -> int:
        return self.ipar.shape[0]


def group_template(templates, damper_rows, n_coupled: int = 0,
                   resistance_ns_per_m: float | None = None, return_hz: float = 5.0,
                   mass_hz: float = 0.0) -> GroupTemplate:
    """Pack ``templates`` (SlotTemplate, one per string) with their damper
    rows ``damper_rows`` ((b0, f1_hz, t60_damped_s, t60_free_s) each,
    :meth:`~synth.dsp.bank.StringBank.set_damper`), the first
    ``n_coupled`` (0, or 1 .. 7) on one bridge of resistance
    ``resistance_ns_per_m`` (N s/m), returning at ``return_hz`` with its
    mass corner at ``mass_hz`` (:meth:`~synth.dsp.bridges.Bridges.couple`'s
    arguments, checked as it checks them)."""
    from .bank import damper_down_factor

    templates = tuple(templates)
    m = len(templates)
    if m == 0 or len(damper_rows) != m:
        raise ValueError(f"damper_rows: {len(damper_rows)} for {m} templates (one each, at least one)")
    n_coupled = int(n_coupled)
    if not (0 <= n_coupled <= min(m, 7)):
        raise ValueError(f"n_coupled = {n_coupled} is out of range (0 <= value <= {min(m, 7)})")
    bridge = np.zeros(3)
    if n_coupled:
        t0 = templates[0]
        for j, t in enumerate(templates[:n_coupled]):
            why = bridge_misfit(f"string {j}", t.ipar, "string 0", t0.ipar)
            if why is not None:
                raise ValueError(why)
        if resistance_ns_per_m is None:
            raise ValueError("resistance_ns_per_m = None is out of range (value > 0)")
        # (Bridges._new_bridge's values: the same floats)
        bridge[:] = bridge_constants(float(t0.fpar[K.F_DT]), resistance_ns_per_m, return_hz,
                                     mass_hz)
    Us = [np.zeros(0) if t.U is None or t.region == 0 else np.asarray(t.U, float)[:t.region]
          for t in templates]
    uoff = np.cumsum([0] + [len(u) for u in Us[:-1]]).astype(np.int64)
    dampers = np.array([tuple(float(v) for v in r[:4]) + (damper_down_factor(r),)
                        for r in damper_rows], dtype=np.float64)
    return GroupTemplate(
        ipar=np.ascontiguousarray(np.stack([t.ipar for t in templates]).astype(np.int64)),
        fpar=np.ascontiguousarray(np.stack([t.fpar for t in templates]).astype(np.float64)),
        U=np.ascontiguousarray(np.concatenate(Us + [np.zeros(1)])), uoff=uoff,
        bend_delay=np.array([float(t.bend_delay) for t in templates]),
        dampers=dampers, n_coupled=n_coupled, bridge=bridge,
        sizes=(max(t.cells for t in templates), max(t.region for t in templates),
               max(t.bend_len for t in templates)))


#: the ``ipar`` columns a template writes (not the slot's own)
_WRITE = _write_mask(SLOT_COLS)


class Groups:
    """Set a note's strings up in one call (a mixin of :class:`synth.dsp.bank.StringBank`)."""

    def configure_group(self, slots, g: GroupTemplate, probe_row: int = -1) -> None:
        """Set up ``slots`` (``g.m`` slots) from ``g``: for slot j,
        :meth:`configure_from` its template (probe row ``probe_row + j``, or
        none for ``probe_row`` -1) and :meth:`set_damper` its damper row;
        then :meth:`couple` the first ``g.n_coupled`` on ``g``'s bridge.  The
        same values to the bit, in one kernel call; a slot still on a
        bridge is first taken off it (:meth:`configure_from` does the same)."""
        arr = self._slot_array(slots)
        if arr.shape[0] != g.m:
            raise ValueError(f"slots = {tuple(arr.tolist())!r}: {g.m} are needed, one per template")
        self._check_sizes(*g.sizes)
        if (self._leader[arr] >= 0).any():
            for s in arr.tolist():
                if self._leader[s] >= 0:
                    self.leave(s)
        if probe_row >= 0:
            probe = np.arange(probe_row, probe_row + g.m, dtype=np.int64)
        else:
            probe = self._no_probe_rows[:g.m]
        configure_group(self.ring, self.ipar, self.fpar, self.fst, self.U, self.damper,
                        self._clean, self._leader, arr, g.m, g.ipar, _WRITE, g.fpar, g.U, g.uoff,
                        g.bend_delay, g.dampers, probe, self.max_block, self.skip_unreachable,
                        g.n_coupled, g.bridge)
        if g.n_coupled:
            lead = int(arr[0])
            self._members[lead] = arr[:g.n_coupled].tolist()
            self._fit_sub(lead)
