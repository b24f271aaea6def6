"""The hammer's wool felt as a medium: thesis chapter 2 (Publications III, IV).

The felt's stress follows the hereditary power law (eqs. 2.1-2.3)

    sigma = E_d [eps^p - R * eps^p],   R(t) = (gamma / tau0) exp(-t / tau0),

with dynamic modulus E_d (fast loading, eq. 2.4) and static modulus
E_s = E_d (1 - gamma) (slow loading, eq. 2.5); the relaxation parameter is
delta = 1 - gamma.  With rho u_tt = sigma_x (eq. 2.6) the deformation waves
obey eq. 2.7; in the units of eqs. 2.8-2.9 (time alpha0 = tau0 / delta,
length l0 = c_s alpha0, velocity c_s = sqrt(E_s / rho); c_d = sqrt(E_d /
rho) = c_s / sqrt(delta)) the strain eps = u_x obeys eq. 2.11

    (eps^p)_xx - eps_tt + (eps^p)_xxt - delta eps_ttt = 0.

Linear waves (p = 1), eps ~ exp(i k x - i Omega t), satisfy eq. 2.16

    k^2 (1 - i Omega) = Omega^2 (1 - i delta Omega),

read two ways: the initial value problem (real wavenumber k, complex
frequency Omega = omega + i mu: :func:`dispersion`, :func:`velocities`;
thesis section 2.2) and the boundary value problem (real frequency omega,
complex wavenumber kappa = k + i lambda, lambda the attenuation per unit
distance: :func:`attenuation`; Publication III eqs. 31-43, thesis
section 2.3).

Closed forms found here (not in the thesis, which gives the thresholds
numerically; derivation in docs/felt.md): with Omega = -i s, eq. 2.16 is the
real cubic delta s^3 - s^2 + k^2 s - k^2 = 0, whose complex pair is the
propagating wave.  Writing C = gamma / delta, its branch is
mu = -(C - e) / 2, omega^2 = (C - e) [(e + 1) / e - (C - e) / 4],
k^2 = delta (C - e) (e + 1)^2 / e for e in (0, C); from it

* negative group velocity exists iff 2 (C - 2)^3 > 27 C, i.e. for
  delta < 0.1346427873 (:func:`ngv_threshold`; thesis "0.1345",
  Publication IV "0.135");
* normal dispersion (v_ph > v_gr) for k < k_* with
  k_*^2 = 4 (C - 4) (C + 1)^2 / ((C - 2)^2 (C + 4)), which is sqrt 3 at
  delta = 1/9 and 0 from delta = 1/5 on (:func:`normal_dispersion_limit`;
  the thesis: "0 <= k_* < sqrt 3", "k_* = 0 for delta >= 0.2");
* for delta < 1/9 a band of k has no propagating wave (the band gap of
  Publication V): where 4 delta k^4 - (1 + 18 delta - 27 delta^2) k^2 + 4 < 0.

Everything here is numpy, dimensionless unless a name carries a unit;
:class:`Felt` converts to SI.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Felt", "THESIS_FELT", "PUB3_FELT", "dispersion", "velocities", "attenuation",
           "solve_pulse", "PulseResult", "leading_peaks", "pulse_decay", "PULSE_UNITS",
           "attenuation_velocities", "ngv_threshold", "has_ngv", "normal_dispersion_limit",
           "band_gap", "relaxation_kernel"]


def _check(name: str, value, lo: float, hi: float, lo_open: bool = False) -> float:
    v = float(value)
    ok = (lo < v if lo_open else lo <= v) and v <= hi and math.isfinite(v)
    if not ok:
        op = "<" if lo_open else "<="
        raise ValueError(f"{name} = {value!r} is out of range ({lo:g} {op} value <= {hi:g})")
    return v


@dataclass(frozen=True)
class Felt:
    """A felt as a hereditary medium (thesis eqs. 2.1-2.5).

    density_kg_per_m3 : float   rho, 10 .. 10^4
    e_static_pa : float         static Young's modulus E_s = E_d (1 - gamma), Pa, 1e3 .. 1e10
    gamma : float               hereditary amplitude, 0 <= gamma < 1
    tau0_s : float              relaxation time, s, 1e-9 .. 1
    exponent : float            nonlinearity p (eq. 2.1), 1 .. 10 (1: linear)
    """

    density_kg_per_m3: float
    e_static_pa: float
    gamma: float
    tau0_s: float
    exponent: float = 1.0

    def __post_init__(self) -> None:
        _check("density_kg_per_m3", self.density_kg_per_m3, 10.0, 1e4)
        _check("e_static_pa", self.e_static_pa, 1e3, 1e10)
        _check("gamma", self.gamma, 0.0, 0.999999)
        _check("tau0_s", self.tau0_s, 1e-9, 1.0)
        _check("exponent", self.exponent, 1.0, 10.0)

    @property
    def delta(self) -> float:
        """Relaxation parameter delta = 1 - gamma (eq. 2.9)."""
        return 1.0 - self.gamma

    @property
    def e_dynamic_pa(self) -> float:
        """Dynamic modulus E_d = E_s / delta (eqs. 2.4-2.5), Pa."""
        return self.e_static_pa / self.delta

    @property
    def c_static_m_per_s(self) -> float:
        """c_s = sqrt(E_s / rho): long waves (m/s)."""
        return math.sqrt(self.e_static_pa / self.density_kg_per_m3)

    @property
    def c_dynamic_m_per_s(self) -> float:
        """c_d = sqrt(E_d / rho) = c_s / sqrt(delta): short waves (m/s)."""
        return math.sqrt(self.e_dynamic_pa / self.density_kg_per_m3)

    @property
    def time_scale_s(self) -> float:
        """alpha0 = tau0 / delta, the unit of time of eq. 2.11 (s)."""
        return self.tau0_s / self.delta

    @property
    def length_scale_m(self) -> float:
        """l0 = c_s alpha0, the unit of length of eq. 2.11 (m)."""
        return self.c_static_m_per_s * self.time_scale_s


#: the thesis's felt (eqs. 2.12-2.13): E_s = 0.6 MPa and rho = 10^3 kg/m^3
#: from static tests on felt pads, gamma = 0.96, tau0 = 10 us (delta 0.04,
#: E_d 15 MPa, c_s 24.5 m/s, c_d 122 m/s, alpha0 0.25 ms, l0 6.1 mm)
THESIS_FELT = Felt(1000.0, 0.6e6, 0.96, 10e-6)
#: Publication III's (eqs. 20-21): gamma = 0.99, tau0 = 20 us (delta 0.01,
#: E_d 60 MPa, c_d 245 m/s, alpha0 2 ms, l0 49 mm)
PUB3_FELT = Felt(1000.0, 0.6e6, 0.99, 20e-6)


def relaxation_kernel(t_s, gamma: float, tau0_s: float) -> np.ndarray:
    """Rabotnov's kernel R(t) = (gamma / tau0) exp(-t / tau0) (eq. 2.2), 1/s,
    at times ``t_s`` >= 0 (s)."""
    _check("gamma", gamma, 0.0, 0.999999)
    _check("tau0_s", tau0_s, 1e-9, 1.0)
    t = np.asarray(t_s, float)
    if np.any(t < 0) or not np.all(np.isfinite(t)):
        raise ValueError("t_s must be finite and >= 0")
    return (gamma / tau0_s) * np.exp(-t / tau0_s)


def _delta(delta: float) -> float:
    return _check("delta", delta, 0.0, 1.0, lo_open=True)


def _wavenumbers(k) -> np.ndarray:
    k = np.atleast_1d(np.asarray(k, float))
    if k.ndim != 1 or np.any(k < 0) or not np.all(np.isfinite(k)):
        raise ValueError("k must be finite and >= 0 (a number or a 1-D array)")
    return k


def dispersion(k, delta: float) -> tuple[np.ndarray, np.ndarray]:
    """The propagating wave of eq. 2.16 for real wavenumbers ``k`` (the
    initial value problem, in the units of eq. 2.11): its frequency omega
    (> 0) and its growth rate mu (<= 0: it decays as exp(mu t)).

    The roots come from the real cubic delta s^3 - s^2 + k^2 s - k^2 = 0
    (Omega = -i s) solved by numpy's eigenvalue method, which stays
    accurate where the thesis's closed form (eqs. 2.21-2.23) meets its
    branch points; where the cubic has no complex pair (delta < 1/9,
    inside the band gap) omega and mu are NaN.

    Returns (omega, mu), arrays shaped like ``k``.
    """
    d = _delta(delta)
    k = _wavenumbers(k)
    om = np.full(k.shape, np.nan)
    mu = np.full(k.shape, np.nan)
    for i, kk in enumerate(k):
        if kk == 0.0:
            om[i], mu[i] = 0.0, 0.0
            continue
        if d == 1.0:
            om[i], mu[i] = kk, 0.0          # non-dispersive: s = 1 and s = +-i k
            continue
        r = np.roots([d, -1.0, kk * kk, -kk * kk])
        pair = r[np.abs(r.imag) > 1e-12 * max(1.0, float(np.max(np.abs(r))))]
        if len(pair) == 0:
            continue                        # the band gap: three real (relaxing) roots
        s = pair[np.argmax(pair.imag)]
        om[i], mu[i] = abs(s.imag), -s.real
    return om, mu


def velocities(k, delta: float, roots=None) -> tuple[np.ndarray, np.ndarray]:
    """Phase velocity omega / k and group velocity d omega / d k of the
    propagating wave at wavenumbers ``k`` > 0 (units of c_s): the group
    velocity from eq. 2.16 by implicit differentiation,
    dOmega/dk = 2 k (1 - i Omega) / (2 Omega - 3 i delta Omega^2 + i k^2),
    its real part.  Both tend to 1 (c_s) for long waves and to 1/sqrt(delta)
    (c_d) for short ones (eq. 2.26).  ``roots``: :func:`dispersion`'s
    (omega, mu) for these k, if the caller has them (else solved here)."""
    k = _wavenumbers(k)
    if np.any(k <= 0):
        raise ValueError("k must be > 0 for the velocities")
    om, mu = dispersion(k, delta) if roots is None else roots
    O = om + 1j * mu
    d = float(delta)
    with np.errstate(invalid="ignore"):           # NaN in a band gap stays NaN
        dO = 2.0 * k * (1.0 - 1j * O) / (2.0 * O - 3j * d * O * O + 1j * k * k)
    return om / k, dO.real


def ngv_threshold() -> float:
    """The largest delta with a negative group velocity somewhere:
    1 / (1 + C*), C* the real root of 2 (C - 2)^3 = 27 C (0.1346427873)."""
    lo, hi = 2.0, 50.0                       # f(C) = 2 (C-2)^3 - 27 C: f(2) < 0 < f(50)
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if 2.0 * (mid - 2.0) ** 3 - 27.0 * mid > 0.0:
            hi = mid
        else:
            lo = mid
    return 1.0 / (1.0 + 0.5 * (lo + hi))


def has_ngv(delta: float) -> bool:
    """Whether some wavenumber travels with a negative group velocity
    (initial value problem): 2 (C - 2)^3 > 27 C, C = (1 - delta) / delta."""
    d = _delta(delta)
    C = (1.0 - d) / d
    return C > 2.0 and 2.0 * (C - 2.0) ** 3 > 27.0 * C


def normal_dispersion_limit(delta: float) -> float:
    """k_*: the dispersion is normal (v_ph > v_gr) for k < k_*, anomalous
    above; 0 from delta = 1/5 on, sqrt 3 at delta = 1/9 (thesis section
    2.2.2); defined for delta >= 1/9."""
    d = _check("delta", delta, 1.0 / 9.0 - 1e-15, 1.0)
    C = (1.0 - d) / d
    if C <= 4.0:
        return 0.0
    return math.sqrt(4.0 * (C - 4.0) * (C + 1.0) ** 2 / ((C - 2.0) ** 2 * (C + 4.0)))


def band_gap(delta: float) -> tuple[float, float] | None:
    """The wavenumbers (k_lo, k_hi) with no propagating wave, for delta < 1/9
    (where 4 delta k^4 - (1 + 18 delta - 27 delta^2) k^2 + 4 < 0), else None."""
    d = _delta(delta)
    P = 1.0 + 18.0 * d - 27.0 * d * d
    disc = P * P - 64.0 * d
    if d >= 1.0 / 9.0 or disc <= 0.0:
        return None
    r = math.sqrt(disc)
    return math.sqrt((P - r) / (8.0 * d)), math.sqrt((P + r) / (8.0 * d))


def attenuation(omega, delta: float, units: str = "alpha0") -> tuple[np.ndarray, np.ndarray]:
    """The boundary value problem (Publication III eqs. 31-36): a harmonic
    load of real frequency ``omega`` (> 0, units of 1/alpha0) on the felt's
    surface makes the wave exp(i kappa x - i omega t) with
    kappa = omega sqrt(1 - i delta omega) / sqrt(1 - i omega) = k + i lambda:
    returns (k, lambda), lambda >= 0 its attenuation per unit length l0
    (tending to (1 - delta) / (2 sqrt delta) at high frequency, eq. 38).
    ``units="tau0"``: frequency and attenuation in the units of eq. 2.27 as
    printed (time tau0, length c_d tau0; :data:`PULSE_UNITS`), where
    kappa(omega) = sqrt(delta) kappa_alpha0(omega / delta)."""
    d = _delta(delta)
    w = np.atleast_1d(np.asarray(omega, float))
    if np.any(w <= 0) or not np.all(np.isfinite(w)):
        raise ValueError("omega must be finite and > 0")
    if units not in ("alpha0", "tau0"):
        raise ValueError(f"units = {units!r} is not allowed (choose alpha0, tau0)")
    s = 1.0
    if units == "tau0":
        w, s = w / d, math.sqrt(d)
    kap = s * w * np.sqrt(1.0 - 1j * d * w) / np.sqrt(1.0 - 1j * w)
    return kap.real, kap.imag


def attenuation_velocities(omega, delta: float) -> tuple[np.ndarray, np.ndarray]:
    """Phase velocity omega / k and group velocity 1 / (dk / d omega) of the
    boundary value problem's wave (Publication III eqs. 39-43), units of
    c_s; dk/domega from kappa by differentiation,
    dkappa/domega = kappa [1/omega - i delta / (2 (1 - i delta omega)) + i / (2 (1 - i omega))]."""
    d = _delta(delta)
    w = np.atleast_1d(np.asarray(omega, float))
    k, lam = attenuation(w, d)
    kap = k + 1j * lam
    dk = kap * (1.0 / w - 0.5j * d / (1.0 - 1j * d * w) + 0.5j / (1.0 - 1j * w))
    return w / k, 1.0 / dk.real


# ---- pulses: the finite-difference solver (thesis sections 2.3-2.4) ---------------
#: the unit systems the pulse solver takes: eq. 2.11's (time alpha0 = tau0 /
#: delta, length l0 = c_s alpha0) or those of eq. 2.27 as printed (time tau0,
#: length c_d tau0), in which Publication III's numerical results are
#: (docs/felt.md)
PULSE_UNITS = ("alpha0", "tau0")


@dataclass(frozen=True)
class PulseResult:
    """Strain snapshots of a pulse: ``strain[j]`` at time ``times[j]`` over
    ``x`` (units of ``units``), on a grid of ``dx`` with time step ``dt``
    (the first snapshot's time a whole number of steps; the others the
    nearest step to the time asked)."""

    x: np.ndarray
    times: np.ndarray
    strain: np.ndarray
    dx: float
    dt: float
    units: str
    delta: float
    exponent: float


def _medium(delta: float, units: str):
    """(c^2, theta, the memory's weight) of eps_tt = c^2 [f - (gamma / theta)
    int_0^t f(xi) exp((xi - t) / theta) d xi], f = (eps^p)_xx, and the
    short-wave speed."""
    d = _delta(delta)
    g = 1.0 - d
    if units == "tau0":
        return 1.0, 1.0, g, 1.0                 # eq. 2.27 as printed
    if units == "alpha0":
        return 1.0 / d, d, g / d, 1.0 / math.sqrt(d)
    raise ValueError(f"units = {units!r} is not allowed (choose {', '.join(PULSE_UNITS)})")


def solve_pulse(delta: float, *, problem: str, amplitude: float, exponent: float = 1.0,
                times=(1.0,), dx: float = 0.005, units: str = "tau0", t_m: float = 0.5,
                alpha: float = 3.0, omega: float = 1.0, length: float | None = None,
                courant: float = 0.4) -> PulseResult:
    """A compression pulse in the felt (eq. 2.11 integrated over time, eq.
    2.27), by finite differences: leapfrog in time, central differences in
    x, the hereditary integral updated exactly for its exponential kernel
    with the trapezoidal rule (I_n = q I_(n-1) + dt/2 (f_n + q f_(n-1)),
    q = exp(-dt / theta)): second order in dx at a fixed Courant number.

    problem : ``"bvp"``: the felt at rest, its surface x = 0 driven by
        eps(0, t) = A (t / t_m)^3 exp(3 (1 - t / t_m)) (eq. 2.28; section
        2.3); ``"harmonic"``: driven by A sin(omega t), faded in over two
        periods (1 - exp(-(t / 2T)^2)), the boundary value problem of
        :func:`attenuation`; ``"ivp"``: eps(x, 0) = A sech(alpha x), eps_t(x, 0) = 0,
        symmetric about x = 0 (eqs. 2.29-2.30, read as eps_x(0, t) = 0;
        section 2.4), computed on x >= 0.
    amplitude : A, strain, 0 < A <= 1.
    exponent : p (eq. 2.1), 1 .. 5; eps^p is taken as sign(eps) |eps|^p (a
        steepening front undershoots a little).
    times : the snapshots' times (units of ``units``), 0 < t <= 1000.
    dx : grid step, 1e-4 .. 0.5.
    units : ``"tau0"`` (eq. 2.27 as printed; Publication III's numbers) or
        ``"alpha0"`` (eq. 2.11's).
    length : the domain [0, length]; None: far enough that nothing reaches
        its end (eps = 0 there).
    courant : dt = courant dx / (the fastest local speed), 0 < value <= 0.9.
    """
    if problem not in ("bvp", "harmonic", "ivp"):
        raise ValueError(f"problem = {problem!r} is not allowed (choose bvp, harmonic, ivp)")
    A = _check("amplitude", amplitude, 0.0, 1.0, lo_open=True)
    p = _check("exponent", exponent, 1.0, 5.0)
    dx = _check("dx", dx, 1e-4, 0.5)
    courant = _check("courant", courant, 0.0, 0.9, lo_open=True)
    c2, theta, w, vmax = _medium(delta, units)
    ts = np.sort(np.atleast_1d(np.asarray(times, float)))
    if ts.size == 0 or ts[0] <= 0 or ts[-1] > 1000 or not np.all(np.isfinite(ts)):
        raise ValueError("times must be in (0, 1000]")
    if problem == "bvp":
        _check("t_m", t_m, 1e-3, 100.0)
    elif problem == "harmonic":
        _check("omega", omega, 1e-3, 100.0)
    else:
        _check("alpha", alpha, 1e-3, 100.0)
    # the fastest local speed: sqrt(p eps^(p-1)) times the short-wave speed
    v = vmax * math.sqrt(p * A ** (p - 1.0))
    dt = courant * dx / v
    dt = ts[0] / math.ceil(ts[0] / dt)          # the first snapshot falls on a step
    if length is None:
        length = 1.3 * v * ts[-1] + (8.0 / alpha + 2.0 if problem == "ivp" else 2.0)
    n_x = int(math.ceil(length / dx)) + 1
    if n_x > 2_000_000:
        raise ValueError(f"length / dx = {length / dx:.0f} grid points is out of range "
                         f"(at most 2000000)")
    x = np.arange(n_x) * dx
    q = math.exp(-dt / theta)

    def power(e):
        return np.sign(e) * np.abs(e) ** p if p != 1.0 else e

    def lap(e):
        ep = power(e)
        f = np.empty_like(e)
        f[1:-1] = (ep[2:] - 2.0 * ep[1:-1] + ep[:-2]) / (dx * dx)
        f[-1] = 0.0
        # x = 0: a driven surface (bvp, its value imposed) or the symmetry
        # plane (ivp: the ghost point mirrors the first)
        f[0] = 2.0 * (ep[1] - ep[0]) / (dx * dx) if problem == "ivp" else 0.0
        # (bvp, harmonic: eps(0, t) is imposed)
        return f

    T2 = 2.0 * (2.0 * math.pi / omega)

    def surface(t):
        if t <= 0:
            return 0.0
        if problem == "harmonic":
            return A * math.sin(omega * t) * (1.0 - math.exp(-(t / T2) ** 2))
        s = t / t_m
        return A * s ** 3 * math.exp(3.0 * (1.0 - s))

    if problem == "ivp":
        e = A / np.cosh(alpha * x)
    else:
        e = np.zeros(n_x)
    f = lap(e)
    I = np.zeros(n_x)
    # first step from rest (eps_t = 0): eps_1 = eps_0 + dt^2/2 c^2 f_0
    e_new = e + 0.5 * dt * dt * c2 * f
    if problem != "ivp":
        e_new[0] = surface(dt)
    e_new[-1] = 0.0
    e_old, e = e, e_new
    f_old = f
    n = 1
    snaps = np.empty((ts.size, n_x))
    j = 0
    steps = [int(round(t / dt)) for t in ts]
    while j < ts.size and steps[j] <= 0:
        snaps[j] = e_old
        j += 1
    while j < ts.size:
        if n == steps[j]:
            snaps[j] = e
            j += 1
            continue
        f = lap(e)
        I = q * I + 0.5 * dt * (f + q * f_old)
        e_new = 2.0 * e - e_old + dt * dt * c2 * (f - w * I)
        if problem != "ivp":
            e_new[0] = surface((n + 1) * dt)
        e_new[-1] = 0.0
        e_old, e, f_old = e, e_new, f
        n += 1
        if not np.all(np.isfinite(e[:8])):
            raise FloatingPointError(f"the pulse blew up at t = {n * dt:g} (courant = {courant})")
    return PulseResult(x, np.array([s * dt for s in steps]), snaps, dx, dt, units,
                       float(delta), p)


def leading_peaks(result: PulseResult, floor: float = 0.2) -> tuple[np.ndarray, np.ndarray]:
    """Position and amplitude of each snapshot's leading crest: the local
    maximum furthest from the surface among those above ``floor`` of the
    snapshot's largest (the pulse's front; a slow hump of the hereditary
    tail can outgrow it, Publication III)."""
    xs, amps = [], []
    for s in result.strain:
        top = float(np.max(s))
        m = (s[1:-1] >= s[:-2]) & (s[1:-1] > s[2:]) & (s[1:-1] >= floor * top)
        if not m.any():
            # the crest on the surface (a pulse released there, or not yet in)
            i = int(np.argmax(s))
            xs.append(result.x[i])
            amps.append(float(s[i]))
            continue
        i = int(np.flatnonzero(m)[-1]) + 1
        # a parabola through the crest and its neighbours
        y0, y1, y2 = s[i - 1], s[i], s[i + 1]
        den = y0 - 2.0 * y1 + y2
        off = 0.5 * (y0 - y2) / den if den != 0 else 0.0
        xs.append(result.x[i] + off * result.dx)
        amps.append(y1 - 0.25 * (y0 - y2) * off)
    return np.array(xs), np.array(amps)


def pulse_decay(result: PulseResult) -> float:
    """The attenuation rate lambda of the pulse's leading crest: the fit of
    exp(-lambda x) through its amplitudes at the snapshots (Publication III
    section 6; units of the result's length)."""
    x, a = leading_peaks(result)
    if len(x) < 2:
        raise ValueError("pulse_decay needs at least two snapshots")
    return float(-np.polyfit(x, np.log(a), 1)[0])
