"""A key's strings set up from their templates in one call (numba).

What :meth:`synth.dsp.bank.StringBank.configure_from` and
:meth:`~synth.dsp.bank.StringBank.set_damper` do for one slot, and
:meth:`~synth.dsp.bridges.Bridges.couple` writes for a unison's bridge,
for every string a note-on sets up (a grand key: its unison and its second
polarization), written from packed rows
(:class:`synth.dsp.groups.GroupTemplate`).  The same values to the bit
(copies, and the bridge's sum of T/dx in the members' order, IEEE):
``tests/test_groups.py`` compares every table with the per-slot path.

Why one call: about 15 numpy operations a string become one dispatch, and
a chord's eight fresh note-ons cost 416 us against 732 (warm, in one
process, alternated).  After the
audio thread has been idle on a virtual machine whose host ages memory the
call's own first dispatch dominates and the two paths cost the same.

May import: :mod:`~synth.kernels.config`, :mod:`~synth.kernels.layout`.
"""

from numba import njit

from .config import EXACT_OPTS
from .layout import (
    EXC_NONE, F_BRA, F_BRB, F_BRMU, F_BTDX, F_REACH, F_TDX, F_TMM, I_BLEN, I_BOFF, I_CHUNK,
    I_CHUNK_FREE, I_CPL, I_CPLN, I_CPLNX, I_EXC, I_EXC_M, I_HLAST, I_N, I_OFF, I_POS, I_PROBE,
    I_REG_N, I_REG_OFF, S_BD, S_TMC, S_UBM, S_UBW,
)


@njit(**EXACT_OPTS)
def configure_group(ring, ipar, fpar, fst, U, damper, clean, leader, slots, m, t_ipar, write,
                    t_fpar, t_U, t_uoff, bend_delay, dampers, probe, max_block, keep_reach,
                    n_coupled, bridge):
    """Set up slots ``slots[0:m]`` from template rows ``j`` = 0 .. m-1, and
    couple the first ``n_coupled`` (0: none) on one bridge led by
    ``slots[0]``.

    Per slot (``configure_from``): the ring zeroed unless ``clean`` (its old
    ``I_OFF``, ``I_N``), ``fst`` zeroed, the excitation and position reset;
    ``ipar`` from ``t_ipar[j]`` where ``write`` (the slot's own columns kept),
    chunks capped at ``max_block``; ``fpar`` from ``t_fpar[j]``, ``F_REACH``
    0 unless ``keep_reach``; the profile ``t_U[t_uoff[j]:][:I_REG_N]`` into
    the slot's region, its bend line zeroed; ``I_PROBE`` ``probe[j]``;
    ``S_BD`` ``bend_delay[j]``, ``S_TMC`` its ``F_TMM``; the damper row
    ``dampers[j]`` (5 values, ``set_damper``'s).  Then the bridge
    (``couple``): ``F_BRB``, ``F_BRA``, ``F_BRMU`` of the leader from
    ``bridge`` (computed by the caller as ``_new_bridge`` does), the chain
    columns, ``leader`` and the leader's ``F_BTDX``.  No validation (the
    caller checked the templates against the bank once)."""
    nf = fst.shape[1]
    ni = ipar.shape[1]
    nfp = fpar.shape[1]
    for j in range(m):
        s = slots[j]
        if not clean[s]:
            off = ipar[s, I_OFF]
            n2 = 2 * max(ipar[s, I_N], 0)
            for i in range(off, off + n2):
                ring[i] = 0.0
            clean[s] = True
        for c in range(nf):
            fst[s, c] = 0.0
        ipar[s, I_POS] = 0
        ipar[s, I_EXC] = EXC_NONE
        ipar[s, I_EXC_M] = 0
        ipar[s, I_HLAST] = -1
        for c in range(ni):
            if write[c]:
                ipar[s, c] = t_ipar[j, c]
        if ipar[s, I_CHUNK] > max_block:
            ipar[s, I_CHUNK] = max_block
        if ipar[s, I_CHUNK_FREE] > max_block:
            ipar[s, I_CHUNK_FREE] = max_block
        for c in range(nfp):
            fpar[s, c] = t_fpar[j, c]
        if not keep_reach:
            fpar[s, F_REACH] = 0.0
        R = ipar[s, I_REG_N]
        o = ipar[s, I_REG_OFF]
        u0 = t_uoff[j]
        for i in range(R):
            U[o + i] = t_U[u0 + i]
        ipar[s, I_PROBE] = probe[j]
        blen = ipar[s, I_BLEN]
        b = ipar[s, I_BOFF]
        for i in range(blen):
            U[b + i] = 0.0
        fst[s, S_BD] = bend_delay[j]
        fst[s, S_TMC] = fpar[s, F_TMM]
        for c in range(5):
            damper[s, c] = dampers[j, c]
    if n_coupled > 0:
        lead = slots[0]
        fpar[lead, F_BRB] = bridge[0]
        fpar[lead, F_BRA] = bridge[1]
        fpar[lead, F_BRMU] = bridge[2]
        fst[lead, S_UBW] = 0.0
        fst[lead, S_UBM] = 0.0
        tdx = 0.0
        for i in range(n_coupled):
            s = slots[i]
            ipar[s, I_CPL] = lead
            ipar[s, I_CPLN] = n_coupled
            ipar[s, I_CPLNX] = slots[i + 1] if i + 1 < n_coupled else -1
            leader[s] = lead
            tdx += fpar[s, F_TDX]
        fpar[lead, F_BTDX] = tdx
