"""Bridges in the bank: strings coupled on a shared bridge (a piano key's
unison, a sitar's taraf with its played strings) and strings hung on an
external bridge (the sympathetic strings).

:class:`Bridges` is the part of :class:`synth.dsp.bank.StringBank` that
forms and leaves these groups (the kernel renders a group together); a
mixin, split from ``bank.py`` to keep one room per job.
"""

from __future__ import annotations

import math

import numpy as np

from ..kernels import strings as K


def bridge_constants(dt_s: float, resistance_ns_per_m: float, return_hz: float,
                     mass_hz: float = 0.0) -> tuple[float, float, float]:
    """A bridge's columns ``F_BRB``, ``F_BRA``, ``F_BRMU`` for its leader's
    time step ``dt_s`` (s), checked as :meth:`Bridges.couple` checks them:
    dt / R, the return spring's pole exp(-2 pi return_hz dt), and
    mu = M / (R dt) with M = R / (2 pi mass_hz), the mass's step against the
    dashpot's (0 without a mass)."""
    if not (resistance_ns_per_m > 0.0) or not math.isfinite(resistance_ns_per_m):
        raise ValueError(f"resistance_ns_per_m = {resistance_ns_per_m!r} is out of range (value > 0)")
    if not (return_hz >= 0.0):
        raise ValueError(f"return_hz = {return_hz!r} is out of range (value >= 0)")
    if not (mass_hz >= 0.0) or not math.isfinite(mass_hz):
        raise ValueError(f"mass_hz = {mass_hz!r} is out of range (value >= 0, finite)")
    return (dt_s / resistance_ns_per_m, math.exp(-2.0 * math.pi * return_hz * dt_s),
            1.0 / (2.0 * math.pi * mass_hz * dt_s) if mass_hz > 0 else 0.0)


def bridge_misfit(name: str, ip, lead: str, ip_lead) -> str | None:
    """Why the string ``name`` (``ipar`` row ``ip``) cannot hang on the
    bridge led by ``lead`` (row ``ip_lead``), as an error's message, or None."""
    if ip[K.I_FILT] != 1 or ip[K.I_OUT] != 1:
        return (f"{name} cannot hang on a bridge (it needs a lossy far end and the "
                f"bridge-force output)")
    if ip[K.I_SUB] != ip_lead[K.I_SUB]:
        return f"{name} runs on another grid than {lead}"
    return None


class Bridges:
    """Coupled and external bridges (a mixin of :class:`synth.dsp.bank.StringBank`)."""

    # -- bridges ----------------------------------------------------------------
    def couple(self, slots, resistance_ns_per_m: float, return_hz: float = 5.0,
               mass_hz: float = 0.0) -> None:
        """Put the strings of ``slots`` (1 .. ``max_group`` distinct slots,
        configured lossy, with the bridge-force output, the same grid) on
        one bridge: a dashpot of resistance ``resistance_ns_per_m`` (N s/m,
        > 0) with a spring that brings it back at ``return_hz`` (Hz, >= 0;
        keeps it from drifting), driven by the strings' summed force, whose
        motion every string's end follows (Weinreich's coupled unison).
        ``mass_hz`` (Hz, >= 0; 0: none) gives the bridge a mass M =
        R / (2 pi mass_hz): its admittance 1 / (R + j w M) is the dashpot's
        below ``mass_hz`` and falls as a mass's above it.
        Every slot must be activated (:meth:`activate`): the group renders
        from its first slot.  The bridge starts at rest.  The group goes as
        a whole (:meth:`reap`)."""
        slots = [int(x) for x in slots]
        G = len(slots)
        if not (1 <= G <= self.max_group) or len(set(slots)) != G:
            raise ValueError(f"slots = {slots!r} is out of range (1 to {self.max_group} "
                             f"distinct slots)")
        self._new_bridge(slots[0], resistance_ns_per_m, return_hz, mass_hz)
        for s in slots[1:]:
            self._check_member(s, slots[0])
        self._members[slots[0]] = slots
        self._chain(slots[0])

    def open_bridge(self, lead: int, resistance_ns_per_m: float, return_hz: float = 5.0) -> None:
        """A bridge (as :meth:`couple`) that strings join and leave while it
        sounds (:meth:`join`, :meth:`leave`; a deactivated member leaves),
        led by slot ``lead``, its first member: a sitar's taraf, chikari and
        played strings on one bridge.  The leader must stay active while
        the group has other members; deactivating it ends the group."""
        self._new_bridge(int(lead), resistance_ns_per_m, return_hz)
        self._members[int(lead)] = [int(lead)]
        self._open.add(int(lead))
        self._chain(int(lead))

    def join(self, lead: int, s: int) -> None:
        """Slot s (configured, lossy, bridge-force output, on the leader's
        grid) joins the open bridge led by ``lead`` from its next sample:
        from then on its end follows the bridge (a string joins at its
        note-on, so the end's step, the bridge's displacement, falls under
        the note's attack), and its force drives it."""
        lead, s = int(lead), int(s)
        if lead not in self._open:
            raise ValueError(f"lead = {lead} is out of range (the leader of an open bridge)")
        mem = self._members[lead]
        if s in mem:
            return
        if len(mem) >= self.max_group:
            raise ValueError(f"the bridge led by slot {lead} holds {len(mem)} strings, the "
                             f"most this bank takes (max_group = {self.max_group})")
        self._check_member(s, lead)
        if self._leader[s] >= 0:
            self.leave(s)
        mem.append(s)
        self._chain(lead)
        # the force of its first sample on the bridge reads the bridge's last
        # step as its own (the lockstep path's reading, :func:`_bridge`)
        self.fst[s, K.S_UBP] = self.fst[lead, K.S_UBM]
        self._take_reading_phase(s, mem)

    def _take_reading_phase(self, s: int, mem) -> None:
        """A string with the tension's modulation that joins a bridge reads
        its tension at the samples another member with it reads (its
        countdown, ``S_TMC``; synth.kernels.tension).  The group renders in
        chunks that end at each member's reading: readings counted from
        each note-on cut a sitar's bridge of 32 notes into chunks of a few
        samples (2x the render's CPU; 128 notes 15x).  The phase is the
        first such member's, from its note-on: a phrase renders the same
        samples whenever it starts and whatever the blocks, and a string off
        any bridge keeps its own."""
        fp = self.fpar
        if fp[s, K.F_TMK] <= 0.0:
            return
        for m in mem:
            if m != s and fp[m, K.F_TMK] > 0.0 and fp[m, K.F_TMM] == fp[s, K.F_TMM]:
                self.fst[s, K.S_TMC] = self.fst[m, K.S_TMC]
                return

    def leave(self, s: int) -> None:
        """Slot s leaves its coupled group (its end on a rigid support from
        its next sample: a string leaves as it is freed or set up anew);
        the leader's leaving ends the group."""
        s = int(s)
        lead = int(self._leader[s])
        if lead < 0:
            return
        mem = self._members[lead]
        if s == lead:
            for m in mem:
                self._unhook(m)
            del self._members[lead]
            self._open.discard(lead)
            return
        mem.remove(s)
        self._unhook(s)
        self._chain(lead)

    def group(self, lead: int) -> tuple:
        """The slots on the bridge led by ``lead`` (empty: no such group)."""
        return tuple(self._members.get(int(lead), ()))

    def _new_bridge(self, lead: int, resistance_ns_per_m: float, return_hz: float,
                    mass_hz: float = 0.0) -> None:
        brb, bra, brmu = bridge_constants(float(self.fpar[lead, K.F_DT]), resistance_ns_per_m,
                                          return_hz, mass_hz)
        if self._leader[lead] >= 0:
            self.leave(lead)
        self._check_member(lead, lead)
        self.fpar[lead, K.F_BRB] = brb
        self.fpar[lead, K.F_BRA] = bra
        self.fpar[lead, K.F_BRMU] = brmu
        self.fst[lead, K.S_UBW] = 0.0
        self.fst[lead, K.S_UBM] = 0.0

    def _check_member(self, s: int, lead: int) -> None:
        why = bridge_misfit(f"slot {s}", self.ipar[s], f"slot {lead}", self.ipar[lead])
        if why is not None:
            raise ValueError(why)

    def _chain(self, lead: int) -> None:
        """Write the group's chain into the kernel's columns."""
        mem = self._members[lead]
        G = len(mem)
        ipar = self.ipar
        if G >= 8:
            # a sitar's bridge (its taraf and every sounding string): one
            # indexed write per column, not a Python step per member (a
            # note-on joins and rewrites the whole chain)
            idx = np.array(mem, dtype=np.int64)
            ipar[idx, K.I_CPL] = lead
            ipar[idx, K.I_CPLN] = G
            ipar[idx[:-1], K.I_CPLNX] = idx[1:]
            ipar[idx[-1], K.I_CPLNX] = -1
            self._leader[idx] = lead
            self.fpar[lead, K.F_BTDX] = float(np.sum(self.fpar[idx, K.F_TDX]))
            self._fit_sub(lead)
            return
        for i, m in enumerate(mem):
            ip = ipar[m]
            ip[K.I_CPL] = lead
            ip[K.I_CPLN] = G
            ip[K.I_CPLNX] = mem[i + 1] if i + 1 < G else -1
            self._leader[m] = lead
        # a key's unison: added in order, as numpy sums fewer than 8 values
        # (the same float), without its call's cost
        fp = self.fpar
        tdx = 0.0
        for m in mem:
            tdx += float(fp[m, K.F_TDX])
        self.fpar[lead, K.F_BTDX] = tdx
        self._fit_sub(lead)

    def set_external_bridge(self, s: int, ease_s: float = 0.02) -> None:
        """Hang slot s (lossy, bridge-force output, no bend line; all such
        slots of a bank on one grid) on an external bridge whose
        displacement comes to :meth:`render` as ``ubx``: a string driven by the rest of the
        instrument (a sympathetic string).  A string that joins the bridge
        while it is displaced (:meth:`join_bridge`) eases onto it with the
        time constant ``ease_s`` (s, > 0) instead of stepping there."""
        ip = self.ipar[s]
        if ip[K.I_FILT] != 1 or ip[K.I_OUT] != 1 or ip[K.I_BLEN] != 0:
            raise ValueError(f"slot {s} cannot hang on an external bridge (it needs a lossy far "
                             f"end, the bridge-force output, no pitch-bend line)")
        M = int(ip[K.I_SUB])
        if self._ext_sub_set and M != self._ext_sub:
            raise ValueError(f"slot {s} runs {M} steps per sample; the bank's other strings on "
                             f"the external bridge run {self._ext_sub} (one ubx serves them all)")
        self._ext_sub, self._ext_sub_set = M, True
        if not (ease_s > 0.0):
            raise ValueError(f"ease_s = {ease_s!r} is out of range (value > 0)")
        ip[K.I_CPL] = K.CPL_EXTERNAL
        ip[K.I_CPLN] = 0
        self.fpar[s, K.F_UBOD] = math.exp(-float(self.fpar[s, K.F_DT]) / ease_s)

    def join_bridge(self, s: int, displacement_m: float) -> None:
        """Slot s (on an external bridge, at rest) starts rendering while
        the bridge is at ``displacement_m`` (m): its end starts there and
        eases onto the bridge's motion (a string whose damper lifts was
        hanging on it all along; without this it would see the bridge's
        displacement as a step, a click)."""
        self.fst[s, K.S_UBOFF] = float(displacement_m)
        self.fst[s, K.S_UBP] = 0.0
