"""Starting a string's excitation in the bank: plucks, injected g(t)
tables, the felt hammer (lumped law or felt layer), and the validated
hammer templates the voices build once per key.

:class:`Excitations` is the part of :class:`synth.dsp.bank.StringBank`
that writes an excitation into a slot's parameters and state (the kernels
of :mod:`synth.kernels.excite` and :mod:`synth.kernels.felt_layer` then
run it); a mixin, split from ``bank.py`` to keep one room per job.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..kernels import felt_layer as FL
from ..kernels import strings as K
from ..kernels.excite import start_hammers

#: ``fpar`` columns a hammer template sets (speed F_HV and F_HDTV are per strike)
_HAMMER_COLS = np.array([K.F_HQ, K.F_HP, K.F_HA, K.F_HT, K.F_HREL, K.F_HE, K.F_HK, K.F_HMC,
                         K.F_HDZ, K.F_HD, K.F_HKCA, K.F_HKCBY, K.F_HKCBP, K.F_HKCD, K.F_HPE,
                         K.F_HP1, K.F_HP0, K.F_HFA, K.F_HFB, K.F_HFPHI, K.F_HC2, K.F_HC3]
                        + [K.F_HB4 + j for j in range(7)] + [K.F_HTOL, K.F_HTOLG], dtype=np.int64)
#: the felt solver's default tolerance: a correction changing the felt's
#: compression by less than this (relative) ends the step; Halley's
#: iteration is cubic, so the next one would change it by ~1e-15
SOLVER_TOL = 1e-5
#: those proportional to the felt stiffness (scaled by the soft pedal)
_HAMMER_Q_COLS = np.array([K.F_HQ, K.F_HKCA, K.F_HKCBY, K.F_HKCBP, K.F_HKCD, K.F_HFA, K.F_HFB,
                           K.F_HFPHI], dtype=np.int64)


@dataclass(frozen=True, eq=False)
class HammerTemplate:
    """A validated felt hammer (see :meth:`StringBank.start_hammer`) for a
    string of time step ``dt_s``; the speed and a stiffness factor (soft
    pedal) are given per strike to :meth:`StringBank.start_hammer_from`."""

    law: int
    values: np.ndarray        # fpar values at _HAMMER_COLS
    e_end: int                # samples of flight at most
    dt_s: float


def hammer_template(*, law: int, mass_kg: float, stiffness: float, exponent: float,
                    alpha_or_gamma: float, tau0_s: float, tension_n: float, c_m_per_s: float,
                    dt_s: float, max_flight_s: float = 0.05,
                    release_s: float = 0.004, solver_tol: float = SOLVER_TOL) -> HammerTemplate:
    """Validate a felt hammer once (parameters as :meth:`StringBank.start_hammer`).

    ``solver_tol`` (1e-12 .. 0.1): the felt solver stops when a correction
    changes the compression w by at most this, relative, or g by at most
    1e-8 of it (:data:`SOLVER_TOL`, 1e-5: to round-off; a work-precision
    knob, docs/work-precision.md)."""
    if not (1e-12 <= solver_tol <= 0.1):
        raise ValueError(f"solver_tol = {solver_tol!r} is out of range (1e-12 <= value <= 0.1)")
    if law not in (K.EXC_HAMMER3, K.EXC_HAMMER4):
        raise ValueError(f"law = {law!r} is not allowed ({K.EXC_HAMMER3}: three-parameter, "
                         f"{K.EXC_HAMMER4}: four-parameter)")
    if not (mass_kg > 0 and stiffness > 0 and exponent >= 1 and tension_n > 0 and c_m_per_s > 0):
        raise ValueError(f"hammer: mass_kg = {mass_kg!r}, stiffness = {stiffness!r}, "
                         f"exponent = {exponent!r}, tension_n = {tension_n!r}, c_m_per_s = "
                         f"{c_m_per_s!r} are out of range (all > 0, exponent >= 1)")
    if law == K.EXC_HAMMER4 and not tau0_s > 0:
        raise ValueError(f"tau0_s = {tau0_s!r} is out of range (value > 0)")
    tau0 = tau0_s if law == K.EXC_HAMMER4 else 1.0
    dt, Q, p, A = float(dt_s), float(stiffness), float(exponent), float(alpha_or_gamma)
    Kk = c_m_per_s / (2.0 * tension_n)            # g per unit felt impulse (m / (N s))
    mc = 2.0 * tension_n / (c_m_per_s * mass_kg)  # deceleration per unit g (1/s)
    dz = 0.5 * dt * mc
    E = math.exp(-dt / tau0)
    # the felt impulse over a step, K int F dt = K (ca y1 + cby y0 + cbp Phi0),
    # Phi1 = pe Phi0 + p1 y1 + p0 y0 and F1 = fa y1 + fb y0 + fphi Phi1
    # (synth.kernels.excite._hammer_general: eq. 1.5 and Pub. III eq. 3)
    if law == K.EXC_HAMMER3:
        ca, cby, cbp = Q * (0.5 * dt + A), Q * (0.5 * dt - A), 0.0
        pe = p1 = p0 = 0.0
        fa, fb, fphi = Q * (1.0 + A / dt), -Q * A / dt, 0.0
    else:
        h = dt / tau0
        qq = (1.0 - E) / h
        c1, c0 = 1.0 - qq, qq - E
        ca = Q * ((1.0 - A) * 0.5 * dt + A * tau0 * c1)
        cby = Q * ((1.0 - A) * 0.5 * dt + A * tau0 * c0)
        cbp = -Q * A * (1.0 - E)
        pe, p1, p0 = E, tau0 * c1, tau0 * c0
        fa, fb, fphi = Q, 0.0, -Q * A / tau0
    D = 1.0 + dz
    # in the order of _HAMMER_COLS
    v = np.array([Q, p, A, tau0, max(1.0, round(release_s / dt_s)), E, Kk, mc,
                  dz, D, Kk * ca, Kk * cby, Kk * cbp, Kk * ca * D * p, pe, p1, p0, fa, fb, fphi,
                  0.5 * p * (p - 1.0), p * (p - 1.0) * (p - 2.0) / 6.0]
                 + [math.prod(p - i for i in range(j)) / math.factorial(j) for j in range(4, 11)]
                 + [float(solver_tol), 1e-13 if solver_tol == SOLVER_TOL else 1e-8 * solver_tol])
    return HammerTemplate(int(law), v, max(1, int(round(max_flight_s / dt_s))), float(dt_s))


@dataclass(frozen=True, eq=False)
class HammerSet:
    """The hammers of a unison's strings, stacked for
    :meth:`Excitations.start_hammers_from` (one kernel call a strike):
    string j's template values, law, flight and time step, and its share
    of the key's speed (``factors[j]``, 0 < value <= 1)."""

    hvals: np.ndarray         # (n, len(_HAMMER_COLS))
    laws: np.ndarray          # int64 (n,)
    e_ends: np.ndarray        # int64 (n,)
    dts: np.ndarray           # float64 (n,), s
    factors: np.ndarray       # float64 (n,)

    @property
    def n(self) -> int:
        return int(self.laws.shape[0])


def hammer_set(templates, factors) -> HammerSet:
    """Stack ``templates`` (:class:`HammerTemplate`, one per string) with
    each string's share ``factors`` of the strike speed (0 < value <= 1)."""
    templates = tuple(templates)
    f = np.array([float(x) for x in factors], dtype=np.float64)
    if len(templates) == 0 or f.shape != (len(templates),):
        raise ValueError(f"factors: {len(f)} for {len(templates)} hammers (one each, at least one)")
    if not np.all((f > 0.0) & (f <= 1.0)):
        raise ValueError(f"factors = {tuple(f.tolist())!r} are out of range (0 < value <= 1)")
    return HammerSet(np.ascontiguousarray(np.stack([t.values for t in templates])),
                     np.array([t.law for t in templates], dtype=np.int64),
                     np.array([t.e_end for t in templates], dtype=np.int64),
                     np.array([t.dt_s for t in templates], dtype=np.float64), f)


class Excitations:
    """How a slot is excited (a mixin of :class:`synth.dsp.bank.StringBank`)."""

    def start_hammers_from(self, slots, hs: HammerSet, speed_m_per_s: float,
                           stiffness_factor: float = 1.0) -> None:
        """Strike ``slots`` (a sequence of ``hs.n`` slot indices) with the
        hammers of ``hs`` at ``speed_m_per_s`` (m/s, 0 < value <= 20; string
        j's times ``hs.factors[j]``), the felt stiffness scaled by
        ``stiffness_factor`` (0 < value <= 4): :meth:`start_hammer_from` for
        each, in one kernel call (:func:`synth.kernels.excite.start_hammers`),
        the same values to the bit."""
        if not (0.0 < speed_m_per_s <= 20.0):
            raise ValueError(f"speed_m_per_s = {speed_m_per_s!r} is out of range (0 < value <= 20)")
        if not (0.0 < stiffness_factor <= 4.0):
            raise ValueError(f"stiffness_factor = {stiffness_factor!r} is out of range (0 < value <= 4)")
        arr = self._slot_array(slots)
        if arr.shape[0] != hs.n:
            raise ValueError(f"slots = {tuple(arr.tolist())!r}: {hs.n} are needed, one per hammer")
        bad = start_hammers(self.ring, self.ipar, self.fpar, self.fst, self._clean, arr, hs.n,
                            _HAMMER_COLS, hs.hvals, _HAMMER_Q_COLS, hs.laws, hs.e_ends, hs.dts,
                            float(speed_m_per_s), hs.factors, float(stiffness_factor))
        if bad >= 0:
            s = int(arr[bad])
            raise ValueError(f"hammer template dt_s = {float(hs.dts[bad])!r} does not match slot "
                             f"{s}'s time step {self.fpar[s, K.F_DT]!r}")

    def start_pluck(self, s: int, model: int, amplitude_m: float, duration_s: float,
                    alpha_per_s: float = 0.0) -> None:
        """Begin a kinematic pluck on slot s at its next sample: ``model``
        ``K.EXC_SITAR`` (g(t) of eq. 1.13) or ``K.EXC_BIWA`` (force pluck,
        eq. 1.11; ``alpha_per_s``).  A pluck on a sounding string adds to it."""
        if model not in (K.EXC_SITAR, K.EXC_BIWA):
            raise ValueError(f"model = {model!r} is not allowed ({K.EXC_SITAR}: sitar g(t), "
                             f"{K.EXC_BIWA}: biwa force pluck)")
        ip, fp, st = self.ipar[s], self.fpar[s], self.fst[s]
        if ip[K.I_EXC] != K.EXC_NONE:
            self._end_excitation(s)
        dt = float(fp[K.F_DT])
        e_end = int(duration_s / dt)
        while e_end * dt <= duration_s:     # same float test as the kernel's g
            e_end += 1
        while e_end > 0 and (e_end - 1) * dt > duration_s:
            e_end -= 1
        ip[K.I_EXC] = int(model)
        ip[K.I_EXC_M] = 0
        ip[K.I_EXC_END] = e_end
        fp[K.F_A] = amplitude_m
        fp[K.F_T0] = duration_s
        fp[K.F_ALPHA] = alpha_per_s

    def _end_excitation(self, s: int) -> None:
        """Freeze a running excitation at its current g and, as the kernel
        does when one ends, fold that constant g into the ring (add it on the
        loop segment through x = 0; exact for lossy and lossless strings, see
        :mod:`synth.kernels.strings`), so that a new one can start from g = 0."""
        ip, st = self.ipar[s], self.fst[s]
        G = st[K.S_G]
        if G != 0.0:
            N = int(ip[K.I_N])
            P = 2 * N
            k = int(ip[K.I_K])
            q = np.arange(-k, k)
            idx = ip[K.I_OFF] + (int(ip[K.I_POS]) - q) % P
            self.ring[idx] += G
        st[K.S_G] = 0.0
        ip[K.I_EXC] = K.EXC_NONE

    def start_gtable(self, s: int, g: np.ndarray) -> None:
        """Inject a given outgoing wave g (m, one value per internal sample,
        held at its last value afterwards) at slot s's excitation point."""
        g = np.asarray(g, float)
        if not (1 <= len(g) <= self.max_gtable):
            raise ValueError(f"g table length = {len(g)} is out of range (1 <= value <= {self.max_gtable})")
        ip = self.ipar[s]
        if ip[K.I_EXC] != K.EXC_NONE:
            self._end_excitation(s)
        o = ip[K.I_GT_OFF]
        self.U[o: o + len(g)] = g
        ip[K.I_EXC] = K.EXC_GTABLE
        ip[K.I_EXC_M] = 0
        ip[K.I_EXC_END] = len(g)

    def start_hammer(self, s: int, *, law: int, mass_kg: float, speed_m_per_s: float,
                     stiffness: float, exponent: float, alpha_or_gamma: float,
                     tau0_s: float, tension_n: float, c_m_per_s: float,
                     max_flight_s: float = 0.05, release_s: float = 0.004,
                     solver_tol: float = SOLVER_TOL) -> None:
        """Strike slot s with a felt hammer (eq. 1.4) from its next sample.

        law : ``K.EXC_HAMMER3``, three-parameter felt (eq. 1.5; ``stiffness``
            = Q0 in N/mm^p, ``alpha_or_gamma`` = alpha in s), or
            ``K.EXC_HAMMER4``, four-parameter felt (Pub. III
            eq. 3; ``stiffness`` = F0 in N/mm^p, ``alpha_or_gamma`` = gamma,
            ``tau0_s``).
        The hammer starts touching the string where it is now (w = 0) and
        flies until it has been out of contact for ``release_s`` (it may hit
        again before that) or ``max_flight_s`` has passed.  (Voices that
        strike at note-on build a :func:`hammer_template` once and call
        :meth:`start_hammer_from`.)
        """
        t = hammer_template(law=law, mass_kg=mass_kg, stiffness=stiffness, exponent=exponent,
                            alpha_or_gamma=alpha_or_gamma, tau0_s=tau0_s, tension_n=tension_n,
                            c_m_per_s=c_m_per_s, dt_s=float(self.fpar[s, K.F_DT]),
                            max_flight_s=max_flight_s, release_s=release_s,
                            solver_tol=solver_tol)
        self.start_hammer_from(s, t, speed_m_per_s)

    def start_hammer_from(self, s: int, t: HammerTemplate, speed_m_per_s: float,
                          stiffness_factor: float = 1.0) -> None:
        """Strike slot s with the hammer ``t`` at ``speed_m_per_s`` (m/s,
        0 < value <= 20), its felt stiffness scaled by ``stiffness_factor``
        (0 < value <= 4: the soft pedal's softer felt, times the voicing's
        ``action.hardness``)."""
        if not (0.0 < speed_m_per_s <= 20.0):
            raise ValueError(f"speed_m_per_s = {speed_m_per_s!r} is out of range (0 < value <= 20)")
        if not (0.0 < stiffness_factor <= 4.0):
            raise ValueError(f"stiffness_factor = {stiffness_factor!r} is out of range (0 < value <= 4)")
        ip, fp, st = self.ipar[s], self.fpar[s], self.fst[s]
        if fp[K.F_DT] != t.dt_s:
            raise ValueError(f"hammer template dt_s = {t.dt_s!r} does not match slot {s}'s "
                             f"time step {fp[K.F_DT]!r}")
        if ip[K.I_EXC] != K.EXC_NONE:
            self._end_excitation(s)
        # a slot set up anew (clean: its ring and g zero) is at rest
        u_now = 0.0 if self._clean[s] else self.displacement_at_excitation(s)
        fp[_HAMMER_COLS] = t.values
        fp[K.F_HV] = speed_m_per_s
        fp[K.F_HDTV] = t.dt_s * speed_m_per_s
        if stiffness_factor != 1.0:
            fp[_HAMMER_Q_COLS] *= stiffness_factor
        # One time convention for every exciter (issue 13): sample i of the
        # excitation holds t = i dt, as a pluck's g(i dt) does.  A kernel
        # hammer step advances the hammer from t - dt to t, so the hammer
        # starts one step before the string: at sample 0 it arrives (z = u,
        # w = 0, F = 0, g(0) = 0) and its first contact force acts at t = dt.
        # (It started at the string, and sample i held t = (i + 1) dt.)
        st[K.S_HZ] = u_now - fp[K.F_HDTV]
        st[K.S_HY] = 0.0
        st[K.S_HPHI] = 0.0
        st[K.S_HW] = 0.0
        st[K.S_HDG] = 0.0
        st[K.S_HDG2] = 0.0
        st[K.S_HDG3] = 0.0
        st[K.S_HIW] = 0.0
        ip[K.I_EXC] = t.law
        ip[K.I_EXC_M] = 0
        ip[K.I_EXC_END] = t.e_end
        ip[K.I_HLAST] = -1

    def start_felt_layer(self, s: int, *, mass_kg: float, speed_m_per_s: float,
                         thickness_m: float, area_m2: float, density_kg_per_m3: float,
                         e_dynamic_pa: float, exponent: float, gamma: float, tau0_s: float,
                         cells: int, tension_n: float, c_m_per_s: float,
                         max_flight_s: float = 0.05, release_s: float = 0.004,
                         courant: float = 0.5, damping: float = 0.5,
                         substeps: int = 0) -> None:
        """Strike slot s with a hammer whose felt is a medium (the felt-layer
        model, :mod:`synth.kernels.felt_layer`) from its next sample.

        The head (``mass_kg`` on this string, felt included) carries a felt
        column of ``thickness_m`` (m), cross-section ``area_m2`` (m^2) and
        density ``density_kg_per_m3``, with the hereditary power law of
        thesis eqs. 2.1-2.3: ``e_dynamic_pa`` E_d (Pa, the coefficient of
        eps^p), ``exponent`` p, ``gamma``, ``tau0_s`` (s); solved on
        ``cells`` cells (2 .. 1024), sub-stepped inside each string step
        (``courant``: target Courant number, 0 < value <= 0.5; ``damping``:
        the grid-scale damper, 0 <= value <= 0.55; ``substeps``: 0 adapts
        the sub-step to the strain, N > 0 holds N per string step).  The
        string side: ``tension_n`` T and ``c_m_per_s`` c (eq. 1.4).  It
        arrives on the string at sample 0 at ``speed_m_per_s`` and flies
        until out of contact for ``release_s`` or ``max_flight_s`` has
        passed, as :meth:`start_hammer`.  Its state lives in the slot's g
        table (``max_gtable`` >= :func:`synth.kernels.felt_layer.block_length`);
        the string runs on the per-sample path while it does.
        """
        def chk(name, v, lo, hi, lo_open=False):
            v = float(v)
            if not (math.isfinite(v) and (lo < v if lo_open else lo <= v) and v <= hi):
                op = "<" if lo_open else "<="
                raise ValueError(f"{name} = {v!r} is out of range ({lo:g} {op} value <= {hi:g})")
            return v

        if not (isinstance(cells, (int, np.integer)) and 2 <= cells <= 1024):
            raise ValueError(f"cells = {cells!r} is out of range (integer, 2 <= value <= 1024)")
        nc = int(cells)
        need = FL.block_length(nc)
        if need > self.max_gtable:
            raise ValueError(f"cells = {nc} needs a g table of {need} values; the bank holds "
                             f"{self.max_gtable} (max_gtable)")
        m = chk("mass_kg", mass_kg, 0.0, 1.0, True)
        v0 = chk("speed_m_per_s", speed_m_per_s, 0.0, 20.0, True)
        h = chk("thickness_m", thickness_m, 1e-4, 0.1)
        A = chk("area_m2", area_m2, 1e-8, 1e-2)
        rho = chk("density_kg_per_m3", density_kg_per_m3, 10.0, 1e4)
        Ed = chk("e_dynamic_pa", e_dynamic_pa, 0.0, 1e18, True)
        p = chk("exponent", exponent, 1.0, 10.0)
        gm = chk("gamma", gamma, 0.0, 0.999999)
        tau = chk("tau0_s", tau0_s, 1e-9, 1.0)
        T = chk("tension_n", tension_n, 0.0, 1e15, True)
        c = chk("c_m_per_s", c_m_per_s, 0.0, 1e6, True)
        cour = chk("courant", courant, 0.0, 0.5, True)
        damp = chk("damping", damping, 0.0, 0.5 / FL.COURANT_HARD)
        if not (isinstance(substeps, (int, np.integer)) and 0 <= substeps <= FL.MAX_NSUB):
            raise ValueError(f"substeps = {substeps!r} is out of range "
                             f"(integer, 0 <= value <= {FL.MAX_NSUB})")
        m_felt = rho * A * h
        if not m_felt < 0.9 * m:
            raise ValueError(f"felt mass = {m_felt:g} kg is out of range (< 0.9 x mass_kg = "
                             f"{0.9 * m:g}: rho A h of the column against the head)")
        ip, fp, st = self.ipar[s], self.fpar[s], self.fst[s]
        if ip[K.I_EXC] != K.EXC_NONE:
            self._end_excitation(s)
        dt = float(fp[K.F_DT])
        dx = h / nc
        o = int(ip[K.I_GT_OFF])
        b = self.U[o:o + need]
        b[:] = 0.0
        b[FL.L_NC] = nc
        b[FL.L_DX] = dx
        b[FL.L_P] = p
        b[FL.L_ED] = Ed
        b[FL.L_GT] = gm / tau
        b[FL.L_TAU] = tau
        b[FL.L_RHO] = rho
        b[FL.L_AREA] = A
        b[FL.L_M0] = 0.5 * rho * A * dx
        b[FL.L_MC] = m - m_felt + 0.5 * rho * A * dx
        b[FL.L_K] = c / (2.0 * T)
        b[FL.L_DTS] = dt
        b[FL.L_COUR] = cour
        b[FL.L_DAMP] = damp
        b[FL.L_V0] = v0
        # the first touch's shock strain v0 / U, U^(p+1) = E_d v0^(p-1) / rho
        # (synth.physics.felt.first_touch_force_n): the sub-step's floor
        b[FL.L_ETOUCH] = v0 / (Ed * v0 ** (p - 1.0) / rho) ** (1.0 / (p + 1.0))
        b[FL.L_FIXED] = int(substeps)
        b[FL.L_NSUB] = 1.0
        fp[K.F_HV] = v0
        fp[K.F_HREL] = max(1.0, round(release_s / dt))
        ip[K.I_EXC] = K.EXC_FELT
        ip[K.I_EXC_M] = 0
        ip[K.I_EXC_END] = max(1, int(round(max_flight_s / dt)))
        ip[K.I_HLAST] = -1
        st[K.S_HY] = 0.0
        st[K.S_HPHI] = 0.0

    def felt_layer_substeps(self, s: int) -> int:
        """Sub-steps the felt layer of slot s has taken since its strike."""
        return int(self.U[int(self.ipar[s, K.I_GT_OFF]) + FL.L_STEPS])
