"""String configurations validated once: :func:`slot_template` and
:class:`SlotTemplate`, which :meth:`synth.dsp.bank.StringBank.configure_from`
writes into a slot with a few array copies (what a note-on in the audio
thread should cost), and :func:`region_reach`, the termination's reach bound.

These build the rows of the string kernel's parameter tables
(:mod:`synth.kernels.strings`' ``I_*`` and ``F_*`` columns); the bank
(:mod:`synth.dsp.bank`, which re-exports them) and its mixins are the only
other code that indexes those tables.  Moved out of ``bank.py`` unchanged
(issue 38: a module of at most 1200 lines).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..kernels import strings as K
from . import sizing

#: the shortest fast-path chunk a slot is given while its excitation runs
#: (:func:`slot_template`): a shorter one renders per sample
MIN_FAST_CHUNK = 2
def region_reach(U: np.ndarray | None, side: int, subcell: float = 0.0) -> float:
    """The reach bound of a termination region (the kernel's ``F_REACH``):
    min over its points n = 1..R of side U(n) / n (m), over the points
    that can be touched (finite U); 0 when one of them touches the string
    at rest or beyond (side U(n) <= 0: the region always runs); inf when
    none can be touched.

    The fast path skips a chunk's region when every step of two cells on
    the part of the ring that passes it is smaller (so every |u(n)| <
    n B <= side U(n): :func:`synth.kernels.contact._out_of_reach`).
    With the sub-cell contact (``subcell`` > 0, the kernel's ``F_CURV``)
    the bound is over points 2..R: the kernel steps point 1 and the first
    cell in any case (``contact._subcell_ring``), and they only move the
    string away from the obstacle."""
    if U is None:
        return 0.0
    v = float(side) * np.asarray(U, float)
    n = np.arange(1, len(v) + 1, dtype=float)
    if subcell > 0.0:
        v, n = v[1:], n[1:]
    fin = np.isfinite(v)
    if not fin.any():
        return math.inf
    if np.any(v[fin] <= 0.0):
        return 0.0
    return float(np.min(v[fin] / n[fin]))


@dataclass(frozen=True, eq=False)
class SlotTemplate:
    """A validated string configuration (see :meth:`StringBank.configure`),
    written into a slot by :meth:`StringBank.configure_from` with a few array
    copies: what a note-on in the audio thread should cost."""

    ipar: np.ndarray          # int64[I_NI]; per-slot columns filled in by the bank
    fpar: np.ndarray          # float64[F_NF]
    U: np.ndarray | None      # termination profile at points 1..R (m)
    bend_delay: float
    # ipar's sizes as ints, read once (a note-on checks them against the bank)
    cells: int = field(init=False, repr=False)
    region: int = field(init=False, repr=False)
    bend_len: int = field(init=False, repr=False)
    chunk: int = field(init=False, repr=False)
    chunk_free: int = field(init=False, repr=False)

    def __post_init__(self):
        ip = self.ipar
        for name, col in (("cells", K.I_N), ("region", K.I_REG_N), ("bend_len", K.I_BLEN),
                          ("chunk", K.I_CHUNK), ("chunk_free", K.I_CHUNK_FREE)):
            object.__setattr__(self, name, int(ip[col]))



def _index(name: str, v, hi: int) -> int:
    """v as an int in 0 .. hi, else a ValueError naming ``name``."""
    try:
        i = int(v)
        ok = i == v and 0 <= i <= hi
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise ValueError(f"{name} = {v!r} is out of range (integer, 0 <= value <= {hi})")
    return i


def _tension_args(tension, bend_len: int) -> tuple:
    """The four ``F_TM*`` columns of :func:`slot_template`'s ``tension``
    (all 0: off), checked."""
    if tension is None:
        return 0.0, 0.0, 0.0, 0.0
    kappa, loop, every, alpha = (float(v) for v in tension)
    if not (math.isfinite(kappa) and kappa >= 0.0):
        raise ValueError(f"tension kappa = {kappa!r} is out of range (value >= 0)")
    if kappa == 0.0:
        return 0.0, 0.0, 0.0, 0.0
    if not bend_len:
        raise ValueError("tension kappa > 0 needs a bend line (bend_len > 0): the modulation moves it")
    if not (math.isfinite(loop) and loop > 0.0):
        raise ValueError(f"tension loop = {loop!r} is out of range (value > 0 samples)")
    if not (every >= 1.0 and every == int(every) and every <= 1e6):
        raise ValueError(f"tension every = {every!r} is out of range (integer, 1 <= value <= 1000000)")
    if not (0.0 < alpha <= 1.0):
        raise ValueError(f"tension alpha = {alpha!r} is out of range (0 < value <= 1)")
    return kappa, loop, every, alpha


def slot_template(*, cells: int, k: int, dt_s: float, U: np.ndarray | None, side: int = 1,
                  out_mode: int = 0, gain: float = 1.0, tension_over_dx: float = 0.0,
                  b0: float = 1.0, a1: float = 0.0, eta: float = 0.0,
                  extra_delay: int = 0, lossy: bool = False, force_per_sample: bool = False,
                  n_disp: int = 0, a_disp: float = 0.0, bend_len: int = 0,
                  bend_delay: float = 0.0, glide_s: float = 0.002,
                  bend_glide_s: float = 0.02, sos=None,
                  pan: float | None = None, sub: int = 1,
                  subcell: float = 0.0, tension=None) -> SlotTemplate:
    """Validate a string configuration once (parameters as
    :meth:`StringBank.configure`); the bank's own limits (cells, region and
    bend-line sizes) are checked when it is written into a slot.

    ``tension``: None (no tension modulation), or (kappa, loop, every,
    alpha) for :mod:`synth.kernels.tension`: dT / T0 per unit of the ring's
    slope sum (1/m^2, >= 0; 0: off), the loop's delay at T0 (samples, > 0),
    the samples between two readings (an integer >= 1) and a reading's
    weight in the smoothed sum (0 < value <= 1); kappa > 0 needs a bend
    line, which the modulation moves."""
    if not (8 <= cells <= 1_000_000):
        raise ValueError(f"cells = {cells!r} is out of range (8 <= value <= 1000000)")
    if not (1 <= k <= cells - 1):
        raise ValueError(f"k = {k!r} is out of range (1 <= value <= {cells - 1})")
    R = 0 if U is None else len(U)
    if R >= cells - 2:
        raise ValueError(f"region points = {R} must be smaller than cells - 2 = {cells - 2}")
    if not (0 <= n_disp <= K.MAX_DISP):
        raise ValueError(f"n_disp = {n_disp!r} is out of range (0 <= value <= {K.MAX_DISP})")
    if bend_len < 0:
        raise ValueError(f"bend_len = {bend_len!r} is out of range (value >= 0)")
    if bend_len and not (1.0 <= bend_delay <= bend_len - 3):
        raise ValueError(f"bend_delay = {bend_delay!r} is out of range (1 <= value <= {bend_len - 3})")
    sos = np.zeros((0, 2)) if sos is None else np.asarray(sos, dtype=float).reshape(-1, 2)
    if len(sos) > K.MAX_SOS:
        raise ValueError(f"sos sections = {len(sos)} is out of range (0 <= value <= {K.MAX_SOS})")
    for c1, c2 in sos:
        # a stable allpass section: poles inside the unit circle
        if not (np.isfinite(c1) and np.isfinite(c2) and abs(c2) < 1.0 and abs(c1) < 1.0 + c2):
            raise ValueError(f"sos section (c1, c2) = ({float(c1)!r}, {float(c2)!r}) is out of range "
                             f"(|c2| < 1 and |c1| < 1 + c2: a stable section)")
    if pan is not None and not (0.0 <= pan <= 1.0):
        raise ValueError(f"pan = {pan!r} is out of range (0 <= value <= 1)")
    if not (1 <= int(sub) <= K.MAX_SUB) or int(sub) != sub:
        raise ValueError(f"sub = {sub!r} is out of range (integer, 1 <= value <= {K.MAX_SUB})")
    subcell = float(subcell)
    if not (0.0 <= subcell <= 1.0):
        raise ValueError(f"subcell = {subcell!r} is out of range (0 <= value <= 1)")
    if subcell > 0.0 and not (U is not None and len(U) and side * float(U[0]) > 0.0):
        raise ValueError("subcell > 0 needs a region whose first point is off the string at "
                         "rest (side U(1) > 0)")
    if subcell > 0.0 and k < 3:
        raise ValueError(f"k = {k!r} is out of range with subcell > 0 (value >= 3: the sub-cell "
                         f"contact reads points 1 and 2)")
    tm = _tension_args(tension, bend_len)
    ip = np.zeros(K.I_NI, dtype=np.int64)
    ip[K.I_N] = cells
    ip[K.I_K] = k
    ip[K.I_REG_N] = R
    ip[K.I_SIDE] = side
    ip[K.I_FILT] = 1 if (lossy or n_disp or bend_len or len(sos)) else 0
    ip[K.I_NDISP] = int(n_disp)
    ip[K.I_NSOS] = len(sos)
    ip[K.I_BUS] = 0 if pan is None else 1
    ip[K.I_CPL] = K.CPL_NONE
    ip[K.I_CPLNX] = -1
    ip[K.I_SUB] = int(sub)
    ip[K.I_BLEN] = int(bend_len)
    ip[K.I_XDELAY] = int(extra_delay)
    ip[K.I_OUT] = int(out_mode)
    ip[K.I_PROBE] = -1
    chunk = 0 if force_per_sample else sizing.max_fast_chunk(cells, k, R, out_mode)
    # a chunk of one sample does the fast path's per-chunk work at every
    # sample: the per-sample path is then the faster (the same samples to
    # round-off).  The grand's key 97 on its 1.3 MHz strike grid (hammer 1
    # step from the capo region) at velocity 127, in each of the two
    # 128-sample blocks its hammer is on the strings: 2.6-3.5 ms in chunks of
    # one sample, 1.1-1.8 ms per sample (tools/bench.py live --jack)
    ip[K.I_CHUNK] = 0 if chunk < MIN_FAST_CHUNK else chunk
    ip[K.I_CHUNK_FREE] = 0 if force_per_sample else sizing.max_free_chunk(
        cells, k, R, out_mode, bool(ip[K.I_FILT]))
    ip[K.I_HLAST] = -1
    fp = np.zeros(K.F_NF)
    fp[K.F_DT] = dt_s
    fp[K.F_B0] = b0
    fp[K.F_B0T] = b0
    fp[K.F_B0S] = 1.0 - math.exp(-dt_s / glide_s)
    fp[K.F_A1] = a1
    fp[K.F_ETA] = eta
    fp[K.F_GAIN] = gain
    fp[K.F_TDX] = tension_over_dx
    fp[K.F_ADISP] = a_disp
    fp[K.F_SOS:K.F_SOS + 2 * len(sos)] = sos.ravel()
    fp[K.F_PAN] = 0.0 if pan is None else float(pan)
    fp[K.F_BDT] = bend_delay
    fp[K.F_BDS] = 1.0 - math.exp(-dt_s / bend_glide_s)
    fp[K.F_REACH] = region_reach(U, side, subcell)
    fp[K.F_CURV] = subcell
    fp[K.F_TMK], fp[K.F_TML], fp[K.F_TMM], fp[K.F_TMA] = tm
    Uc = None if U is None else np.array(U, dtype=float)
    return SlotTemplate(ip, fp, Uc, float(bend_delay))
