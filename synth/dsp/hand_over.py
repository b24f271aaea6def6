"""Leaving a finer grid: a sounding string moved to a coarser one without a
click (the grand's top keys leave the capo bar's finer grid once their
hammer has left).

:class:`HandOver` is the part of :class:`synth.dsp.bank.StringBank` that
does it; a mixin, split from ``bank.py`` to keep one room per job (as
:class:`~synth.dsp.bridges.Bridges` and
:class:`~synth.dsp.excitation.Excitations`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..kernels import strings as K

if TYPE_CHECKING:                                # (bank.py imports this module)
    from .bank import SlotTemplate

#: per-slot columns of ``ipar`` that a template does not carry (the output
#: row is the slot's until :meth:`StringBank.set_output_row` changes it)
SLOT_COLS = (K.I_OFF, K.I_REG_OFF, K.I_GT_OFF, K.I_BOFF, K.I_ROW)
#: ``ipar`` columns a template writes, by the columns a slot keeps
#: (:meth:`StringBank._write_template`): one masked copy per write
_WRITE_MASKS: dict[tuple, np.ndarray] = {}


def _write_mask(keep_cols: tuple) -> np.ndarray:
    m = _WRITE_MASKS.get(keep_cols)
    if m is None:
        m = np.ones(K.I_NI, dtype=bool)
        m[list(keep_cols)] = False
        _WRITE_MASKS[keep_cols] = m
    return m


#: ``ipar`` columns a slot keeps when it changes grid (:meth:`StringBank.hand_over`)
_HAND_OVER_KEEP = SLOT_COLS + (K.I_PROBE, K.I_TELEM, K.I_CPL, K.I_CPLN, K.I_CPLNX)
#: ``fst`` columns it keeps as they are: the peak, the bridge, the telemetry's
#: episodes, most points and peak force
_HAND_OVER_ST = (K.S_PEAK, K.S_UBM, K.S_UBW, K.S_UBP, K.S_TC_EP, K.S_TC_PTS, K.S_HC_EP,
                 K.S_HF_PK)


def _chained_state(xdel: int, nd: int, nb: int, n_cols: int) -> np.ndarray:
    """The far-end filter's free state, as columns of an ``fst`` row (one
    per free value): the fast path keeps each stage's input history as the
    previous stage's output history (a first-order section's x1 is the
    stage before's last output, the tuning allpass's S_APX the same, a
    biquad's x1, x2 the stage before's y1, y2) and reads only the free
    values, so a state must be chained: the unit delay's register, the
    loss's output, each first-order section's y1, the tuning allpass's y1,
    the first biquad's x2, each biquad's y1 and y2."""
    cols = []

    def col(*entries):
        v = np.zeros(n_cols)
        for c in entries:
            v[c] = 1.0
        cols.append(v)

    if xdel:
        col(K.S_XD)
    # the loss's output feeds the first first-order section's x1, or the
    # tuning allpass's
    col(K.S_LP, K.S_D0 if nd else K.S_APX)
    for d in range(nd):
        nxt = K.S_D0 + 2 * (d + 1) if d + 1 < nd else K.S_APX
        col(K.S_D0 + 2 * d + 1, nxt)
    # the tuning allpass's output: the first biquad's x1
    col(K.S_APY, *([K.S_SOS] if nb else []))
    if nb:
        col(K.S_SOS + 1)
    for b in range(nb):
        q = K.S_SOS + 4 * b
        nxt = b + 1 < nb
        col(q + 2, *([q + 4] if nxt else []))     # y1: the next biquad's x1
        col(q + 3, *([q + 5] if nxt else []))     # y2: its x2
    return np.array(cols).T


class HandOver:
    """Moving strings between grids (a mixin of :class:`synth.dsp.bank.StringBank`)."""

    #: rows of the least-squares fit of the far-end filter's state (samples
    #: of the coarser grid; at most N - 2, the waves that reach the far end
    #: without passing the termination again)
    HAND_OVER_ROWS = 96

    def hand_over(self, slots, templates, damper_rows) -> bool:
        """Move sounding strings from a finer grid to a coarser one without
        a click: the strings of ``slots`` (one coupled group whole, in any
        order, or single uncoupled strings), each to its template in
        ``templates`` (the same string designed on the coarser grid, whose
        ``I_SUB`` divides the slot's), with its damper row in ``damper_rows``
        (:meth:`set_damper`).  Returns False, changing nothing, while an
        excitation still runs on one of them, or one has a pitch-bend line,
        or the grids do not divide; True when done.

        The string's state is its loop: the ring holds the waves that will
        arrive at the far end in the next 2N steps.  The coarser ring takes
        them at the coarser steps (linear interpolation; a finer grid's
        engine sample is the mean of its r steps, so the coarser step m
        stands at fine step r m + (r - 1) / 2), placed so that the
        termination (x = 0) keeps its place: arrival m of the new ring is
        arrival r m + delta + (r - 1) / 2 of the old, delta = N_fine - r
        N_coarse.  The far-end filter's state does not carry over between
        two designs (its poles differ), so it is fitted: the state whose
        next outputs, with the new ring's arrivals, come nearest (least
        squares over :attr:`HAND_OVER_ROWS` steps) the old filter's, run on
        from its own state on the old ring's arrivals (one call of
        :func:`synth.kernels.hand_over.hand_over_loop` per string, no
        allocation in it: 0.17-0.23 ms for a key's three strings, most of
        it this method's Python; ``tools/study_capo.py cost``).  The bridge keeps its
        displacement, its step w = v dt is scaled by r, its constants are
        the coarser step's; the loss keeps its damper's share (b0 over the
        undamped b0).  ``tools/study_capo.py switch`` measured the scheme
        on the numpy reference string: the wave at the far end within -54
        to -66 dB of the fine string's own continuation (docs/voicing.md,
        "The capo bar")."""
        slots = [int(s) for s in slots]
        if len(templates) != len(slots) or len(damper_rows) != len(slots):
            raise ValueError(f"slots, templates and damper_rows have lengths {len(slots)}, "
                             f"{len(templates)}, {len(damper_rows)} (one each per slot)")
        lead = int(self._leader[slots[0]])
        if lead >= 0 and sorted(self._members[lead]) != sorted(slots):
            raise ValueError(f"slots {slots} are not the whole coupled group led by slot {lead}")
        for s, t in zip(slots, templates):
            ip = self.ipar[s]
            if ip[K.I_EXC] > K.EXC_NONE or ip[K.I_BLEN] != 0:
                return False
            Mf, Mc = int(ip[K.I_SUB]), int(t.ipar[K.I_SUB])
            if Mc > Mf or Mf % Mc:
                return False
            if int(t.ipar[K.I_N]) > self.max_cells or int(t.ipar[K.I_REG_N]) > self.max_region:
                return False
            if int(t.ipar[K.I_BLEN]) != 0:
                return False
        r = int(self.ipar[slots[0], K.I_SUB]) // int(templates[0].ipar[K.I_SUB])
        if r == 1:
            return True
        for s, t, row in zip(slots, templates, damper_rows):
            self._hand_over_slot(s, t, row, r)
        if lead >= 0:
            # the bridge's constants for the coarser step (exp(-w dt), dt / R,
            # M / (R dt)); its step w = v dt scales with dt; F_BTDX anew
            fp = self.fpar[lead]
            fp[K.F_BRA] = fp[K.F_BRA] ** r
            fp[K.F_BRB] = fp[K.F_BRB] * r
            fp[K.F_BRMU] = fp[K.F_BRMU] / r
            self.fst[lead, K.S_UBW] *= r
            self._chain(lead)
        return True

    def _hand_over_slot(self, s: int, t: SlotTemplate, damper_row, r: int) -> None:
        ip = self.ipar[s]
        if ip[K.I_EXC] == K.EXC_ENDED:
            K._fold_offset(self.ring, int(ip[K.I_OFF]), 2 * int(ip[K.I_N]), int(ip[K.I_POS]),
                           int(ip[K.I_K]), float(self.fst[s, K.S_G]))
            self.fst[s, K.S_G] = 0.0
            ip[K.I_EXC] = K.EXC_NONE
        Nf, off, pm = int(ip[K.I_N]), int(ip[K.I_OFF]), int(ip[K.I_POS])
        xdel_f, nd_f, nb_f = int(ip[K.I_XDELAY]), int(ip[K.I_NDISP]), int(ip[K.I_NSOS])
        st_f, fp_f = self._ho_st, self._ho_fp
        st_f[:] = self.fst[s]
        fp_f[:] = self.fpar[s]
        Nc = int(t.ipar[K.I_N])
        pmc = pm % (2 * Nc)
        H = max(1, min(self.HAND_OVER_ROWS, Nc - 2))
        # the slot on the new grid (its group links, probe and telemetry kept)
        self._write_template(s, t, _HAND_OVER_KEEP)
        ip[K.I_EXC] = K.EXC_NONE
        ip[K.I_EXC_M] = 0
        ip[K.I_HLAST] = -1
        ip[K.I_POS] = pmc
        fp = self.fpar[s]
        for c in (K.F_BRA, K.F_BRB, K.F_BRMU):
            fp[c] = fp_f[c]                   # the leader's, converted by the caller
        fp[K.F_TGAP] = round(fp_f[K.F_TGAP] / r)      # telemetry's episode gap, in steps
        share = 1.0 / float(self.damper[s, 0])
        fp[K.F_B0] = float(damper_row[0]) * fp_f[K.F_B0] * share
        fp[K.F_B0T] = float(damper_row[0]) * fp_f[K.F_B0T] * share
        self.set_damper(s, damper_row)
        # the state: what carries over (the bridge, the peak, the telemetry's
        # counts, those in the coarser steps), the filter's to be fitted
        st = self.fst[s]
        st[:] = 0.0
        for c in _HAND_OVER_ST:
            st[c] = st_f[c]
        for c in (K.S_TC_N, K.S_HC_N, K.S_TC_GAP, K.S_HC_GAP):
            st[c] = st_f[c] / r if st_f[c] >= 0.0 else st_f[c]
        st[K.S_BD] = t.bend_delay
        xdel, nd, nb = int(ip[K.I_XDELAY]), int(ip[K.I_NDISP]), int(ip[K.I_NSOS])
        key = (xdel, nd, nb)
        T = self._free_dirs.get(key)
        if T is None:
            T = self._free_dirs[key] = np.ascontiguousarray(_chained_state(xdel, nd, nb, K.S_NS))
        K.hand_over_loop(self.ring, off, Nf, pm, st_f, fp_f, xdel_f, nd_f, nb_f, r, Nc, pmc,
                         st, fp, xdel, nd, nb, T, T.shape[1], H, float(st_f[K.S_UBP]),
                         self._ho_buf, self._ho_At, self._ho_R, self._ho_one)
        self._clean[s] = False
