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
           "PULSE_SCHEMES",
           "attenuation_velocities", "ngv_threshold", "has_ngv", "normal_dispersion_limit",
           "band_gap", "relaxation_kernel", "HammerFelt", "felt_for_key", "felt_thickness_m",
           "Strike", "strike_lumped", "strike_layer", "first_touch_force_n", "GRAND_VOICING",
           "felt_from_law", "STUDY_FELT_TAU0_S", "STUDY_FELT_THICKNESS_M"]


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
    e_static_pa : float         static Young's modulus E_s = E_d (1 - gamma), Pa, 1e3 .. 1e15
                                (for p > 1 the coefficient of sigma = E_s eps^p: a
                                hammer's felt, :func:`felt_for_key`, reaches 1e12)
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
        _check("e_static_pa", self.e_static_pa, 1e3, 1e15)
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

    def linearized(self, strain: float) -> "Felt":
        """The linear felt (p = 1) with this felt's tangent modulus
        p E_s eps^(p-1) at ``strain`` (0 < eps <= 1), the same gamma, tau0
        and density: its small waves about that strain."""
        e = _check("strain", strain, 0.0, 1.0, lo_open=True)
        return Felt(self.density_kg_per_m3,
                    self.exponent * self.e_static_pa * e ** (self.exponent - 1.0),
                    self.gamma, self.tau0_s, 1.0)


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
    om[k == 0.0], mu[k == 0.0] = 0.0, 0.0
    if d == 1.0:
        return k.copy(), np.zeros(k.shape)  # non-dispersive: s = 1 and s = +-i k
    i = np.flatnonzero(k > 0.0)
    if i.size == 0:
        return om, mu
    # the cubic's companion matrices (as numpy.roots builds them), all at once
    k2 = k[i] * k[i]
    C = np.zeros((i.size, 3, 3))
    C[:, 0, 0] = 1.0 / d
    C[:, 0, 1] = -k2 / d
    C[:, 0, 2] = k2 / d
    C[:, 1, 0] = C[:, 2, 1] = 1.0
    r = np.linalg.eigvals(C)
    thr = 1e-12 * np.maximum(1.0, np.max(np.abs(r), axis=1))
    j = np.argmax(r.imag, axis=1)
    s = r[np.arange(i.size), j]
    ok = s.imag > thr                       # else the band gap: three real (relaxing) roots
    om[i[ok]], mu[i[ok]] = np.abs(s.imag[ok]), -s.real[ok]
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
#: :func:`solve_pulse`'s schemes: finite differences (Publication III's) or
#: shock-capturing finite volumes
PULSE_SCHEMES = ("fd", "fv")


@dataclass(frozen=True)
class PulseResult:
    """Strain snapshots of a pulse: ``strain[j]`` at time ``times[j]`` over
    ``x`` (units of ``units``), on a grid of ``dx`` with time step ``dt``
    (the first snapshot after t = 0 a whole number of steps; the others the
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
                courant: float = 0.4, scheme: str = "fd") -> PulseResult:
    """A compression pulse in the felt (eq. 2.11 integrated over time, eq.
    2.27).

    ``scheme="fd"``: finite differences, as Publication III: leapfrog in
    time, central differences in x, the hereditary integral updated exactly
    for its exponential kernel with the trapezoidal rule (I_n = q I_(n-1) +
    dt/2 (f_n + q f_(n-1)), q = exp(-dt / theta)): second order in dx at a
    fixed Courant number, but a front that has steepened into a shock
    (p > 1) rings at the grid scale.  ``scheme="fv"``: finite volumes that
    capture the shock (:func:`_pulse_fv`): eq. 2.27 as the first-order
    system eps_t = v_x, v_t = sigma_x, sigma = c^2 [eps^p - (gamma /
    theta) H], H = int_0^t eps^p(xi) exp((xi - t) / theta) d xi, with
    limited (MC) linear reconstruction, the local Lax-Friedrichs flux and
    Heun's method (second order where the strain is smooth; a shock spread
    over a few cells, without ringing).

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
    times : the snapshots' times (units of ``units``), 0 <= t <= 1000 (t = 0:
        the initial state, as the thesis's Figs. 2.7-2.8 show it).
    dx : grid step, 1e-4 .. 0.5.
    units : ``"tau0"`` (eq. 2.27 as printed; Publication III's numbers) or
        ``"alpha0"`` (eq. 2.11's).
    length : the domain [0, length]; None: far enough that nothing reaches
        its end (eps = 0 there).
    courant : dt = courant dx / (the fastest local speed), 0 < value <= 0.9
        (``"fv"``: <= 0.5).
    scheme : ``"fd"`` or ``"fv"`` (above); ``"fv"`` returns the strain's
        cell averages at the cells' centres (x = (i + 1/2) dx).
    """
    if problem not in ("bvp", "harmonic", "ivp"):
        raise ValueError(f"problem = {problem!r} is not allowed (choose bvp, harmonic, ivp)")
    if scheme not in PULSE_SCHEMES:
        raise ValueError(f"scheme = {scheme!r} is not allowed (choose {', '.join(PULSE_SCHEMES)})")
    A = _check("amplitude", amplitude, 0.0, 1.0, lo_open=True)
    p = _check("exponent", exponent, 1.0, 5.0)
    dx = _check("dx", dx, 1e-4, 0.5)
    courant = _check("courant", courant, 0.0, 0.9 if scheme == "fd" else 0.5, lo_open=True)
    c2, theta, w, vmax = _medium(delta, units)
    ts = np.sort(np.atleast_1d(np.asarray(times, float)))
    if (ts.size == 0 or ts[0] < 0 or ts[-1] <= 0 or ts[-1] > 1000
            or not np.all(np.isfinite(ts))):
        raise ValueError("times must be in [0, 1000], one of them > 0")
    if problem == "bvp":
        _check("t_m", t_m, 1e-3, 100.0)
    elif problem == "harmonic":
        _check("omega", omega, 1e-3, 100.0)
    else:
        _check("alpha", alpha, 1e-3, 100.0)
    # the fastest local speed: sqrt(p eps^(p-1)) times the short-wave speed
    v = vmax * math.sqrt(p * A ** (p - 1.0))
    dt = courant * dx / v
    t1 = float(ts[ts > 0][0])
    dt = t1 / math.ceil(t1 / dt)                # the first snapshot after 0 falls on a step
    if length is None:
        length = 1.3 * v * ts[-1] + (8.0 / alpha + 2.0 if problem == "ivp" else 2.0)
    n_x = int(math.ceil(length / dx)) + 1
    if n_x > 2_000_000:
        raise ValueError(f"length / dx = {length / dx:.0f} grid points is out of range "
                         f"(at most 2000000)")
    x = np.arange(n_x) * dx
    q = math.exp(-dt / theta)
    steps = [int(round(t / dt)) for t in ts]

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

    if scheme == "fv":
        xc = (np.arange(n_x) + 0.5) * dx
        snaps = _pulse_fv(problem, A / np.cosh(alpha * xc) if problem == "ivp" else
                          np.zeros(n_x), surface, p, c2, theta, w, dx, dt, steps)
        return PulseResult(xc, np.array([s * dt for s in steps]), snaps, dx, dt, units,
                           float(delta), p)
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


def _pulse_fv(problem, e0, surface, p, c2, theta, w, dx, dt, steps) -> np.ndarray:
    """:func:`solve_pulse`'s finite volumes: the strain's snapshots at the
    time steps ``steps`` (sorted), from the cell averages ``e0`` at rest.

    Unknowns per cell: the strain eps, the velocity v (eps_t = v_x,
    v_t = sigma_x) and the memory H (H_t = eps^p - H / theta, updated
    exactly for its kernel with the trapezoidal rule, as the finite
    differences' I); sigma = c^2 [eps^p - w H].  Each stage reconstructs
    eps, v and H linearly in each cell with the monotonised-central
    limiter, and takes the local Lax-Friedrichs (Rusanov) flux with the
    frozen speed c sqrt(p eps^(p-1)) of the stiffer side; Heun's method
    (SSP RK2) in time.  Two ghost cells at x = 0: the symmetry plane
    (ivp: eps and H even, v odd) or the driven surface (eps mirrored about
    its imposed value, v and H copied); at the far end copies (outflow)."""
    n = e0.size
    c = math.sqrt(c2)
    q = math.exp(-dt / theta)
    ivp = problem == "ivp"
    E = np.zeros(n + 4)
    V = np.zeros(n + 4)
    Hg = np.zeros(n + 4)

    def power(a):
        return a if p == 1.0 else np.sign(a) * np.abs(a) ** p

    def fill(G, a, odd=False, surf=None):
        G[2:-2] = a
        if surf is not None:
            G[1], G[0] = 2.0 * surf - a[0], 2.0 * surf - a[1]
        elif odd:
            G[1], G[0] = -a[0], -a[1]
        elif ivp:
            G[1], G[0] = a[0], a[1]
        else:
            G[1] = G[0] = a[0]
        G[-2] = G[-1] = a[-1]
        return G

    def faces(G):
        d = np.diff(G)
        dl, dr = d[:-1], d[1:]
        slope = 0.5 * (np.sign(dl) + np.sign(dr)) * np.minimum(
            np.minimum(2.0 * np.abs(dl), 2.0 * np.abs(dr)), 0.5 * np.abs(dl + dr))
        return G[1:-2] + 0.5 * slope[:-1], G[2:-1] - 0.5 * slope[1:]

    def rhs(e, v, H, t):
        eL, eR = faces(fill(E, e, surf=None if ivp else surface(t)))
        vL, vR = faces(fill(V, v, odd=ivp))
        HL, HR = faces(fill(Hg, H))
        sL = c2 * (power(eL) - w * HL)
        sR = c2 * (power(eR) - w * HR)
        if p == 1.0:
            a = c
        else:
            a = c * np.sqrt(p * np.maximum(np.abs(eL), np.abs(eR)) ** (p - 1.0))
        fe = -0.5 * (vL + vR) - 0.5 * a * (eR - eL)       # the flux of eps_t - v_x = 0
        fv = -0.5 * (sL + sR) - 0.5 * a * (vR - vL)       # and of v_t - sigma_x = 0
        return (fe[:-1] - fe[1:]) / dx, (fv[:-1] - fv[1:]) / dx

    e, v, H = e0.astype(float), np.zeros(n), np.zeros(n)
    f = power(e)
    snaps = np.empty((len(steps), n))
    j = k = 0
    while True:
        while j < len(steps) and steps[j] == k:
            snaps[j] = e
            j += 1
        if j == len(steps):
            return snaps
        t = k * dt
        de, dv = rhs(e, v, H, t)
        e1, v1 = e + dt * de, v + dt * dv
        f1 = power(e1)
        H1 = q * H + 0.5 * dt * (q * f + f1)
        de, dv = rhs(e1, v1, H1, t + dt)
        e, v = 0.5 * (e + e1 + dt * de), 0.5 * (v + v1 + dt * dv)
        f_new = power(e)
        H = q * H + 0.5 * dt * (q * f + f_new)
        f = f_new
        k += 1
        if not np.all(np.isfinite(e[:8])):
            raise FloatingPointError(f"the pulse blew up at t = {k * dt:g}")


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
    exp(-lambda x) through its amplitudes at the snapshots after t = 0
    (Publication III section 6; units of the result's length)."""
    x, a = leading_peaks(result)
    keep = (result.times > 0) & (a > 0)
    x, a = x[keep], a[keep]
    if len(x) < 2:
        raise ValueError("pulse_decay needs at least two snapshots after t = 0")
    return float(-np.polyfit(x, np.log(a), 1)[0])


# ---- the bridge to the hammer: a felt layer struck against a rigid string ---------
# (issue 14 section 6; docs/felt.md "The felt layer against the lumped law")

#: the voicing of the shipped grand (``action.voicing`` of
#: synth/presets/grand-piano.toml): the laws of :func:`felt_for_key` default to it
GRAND_VOICING = "concert"
#: the felt over the hammer's core at its crown, A0 and C8 (m), log-linear in
#: between: ASSUMED numbers.  The sources give the shape, not the numbers:
#: a hammer set is pressed from one felt sheet tapered from bass to treble
#: and the heads shrink from bass to treble (piano technicians' accounts,
#: PTG archive, pianotech 2004-07 "How much felt over the core?" and
#: 2007-03 on underfelt; J. Lazzeroni, "Hammers of the piano", 2019); the
#: thesis and its Publications give none.  20 mm at A0 and 8 mm at C8 are
#: the order of a concert grand's bass and treble heads; :func:`felt_for_key`
#: takes any other thickness.
FELT_THICKNESS_A0_M = 0.020
FELT_THICKNESS_C8_M = 0.008
#: the felt column under one string (m^2): the contact patch, ASSUMED 8 mm
#: along the string (worn hammers show string grooves 6-12 mm long) by 8 mm
#: across it; it sets only the felt's mass rho A h against the hammer's
#: (the quasi-static law is Q0 = E A / h^p whatever A is)
FELT_COLUMN_AREA_M2 = 64e-6
#: the felt's density (kg/m^3): the thesis's felt pads (eq. 2.13), assumed
#: for the hammer's pressed felt too
HAMMER_FELT_DENSITY_KG_PER_M3 = 1000.0


def felt_thickness_m(midi: int) -> float:
    """The assumed felt thickness over the core of the grand's key ``midi``
    (21..108): log-linear from :data:`FELT_THICKNESS_A0_M` at A0 to
    :data:`FELT_THICKNESS_C8_M` at C8 (m)."""
    from . import piano as P

    m = P._check_midi(midi)
    s = (m - P.MIDI_LOW) / (P.MIDI_HIGH - P.MIDI_LOW)
    return FELT_THICKNESS_A0_M * (FELT_THICKNESS_C8_M / FELT_THICKNESS_A0_M) ** s


@dataclass(frozen=True)
class HammerFelt:
    """A hammer as a felt layer: a 1-D column of ``felt`` (its exponent p,
    E_s the coefficient of sigma = E_s eps^p at slow loading, gamma, tau0,
    density) of thickness ``thickness_m`` and cross-section ``area_m2``,
    glued to a rigid core; ``hammer_mass_kg`` is the whole head's share per
    string (felt included), as in the lumped law (eq. 1.9).

    Its quasi-static limit (a massless, uniformly strained layer: eps = w / h)
    is the four-parameter law (Publication III eq. 3) with
    F0 = E_d A / h^p, and with tau0 << the contact time the three-parameter
    law of eq. 1.5 (Publication III eqs. 14-15):
    F = Q0 (w^p + alpha d(w^p)/dt), Q0 = E_s A / h^p, alpha = tau0 / delta.
    """

    felt: Felt
    thickness_m: float
    area_m2: float
    hammer_mass_kg: float
    midi: int | None = None

    def __post_init__(self) -> None:
        _check("thickness_m", self.thickness_m, 1e-4, 0.1)
        _check("area_m2", self.area_m2, 1e-8, 1e-2)
        _check("hammer_mass_kg", self.hammer_mass_kg, 1e-5, 1.0)
        if self.felt_mass_kg >= 0.9 * self.hammer_mass_kg:
            raise ValueError(f"felt mass = {self.felt_mass_kg:g} kg is out of range "
                             f"(< 0.9 x hammer_mass_kg = {0.9 * self.hammer_mass_kg:g})")

    @property
    def q0_n_per_m_p(self) -> float:
        """Static stiffness Q0 = E_s A / h^p of eq. 1.5 (N/m^p)."""
        return self.felt.e_static_pa * self.area_m2 / self.thickness_m ** self.felt.exponent

    @property
    def q0_n_per_mm_p(self) -> float:
        """Q0 in the thesis's N/mm^p."""
        return self.q0_n_per_m_p * 1e-3 ** self.felt.exponent

    @property
    def alpha_s(self) -> float:
        """The hereditary time alpha = alpha0 = tau0 / delta of eq. 1.5 (s)."""
        return self.felt.time_scale_s

    @property
    def felt_mass_kg(self) -> float:
        """rho A h: the felt column's mass (kg)."""
        return self.felt.density_kg_per_m3 * self.area_m2 * self.thickness_m

    @property
    def core_mass_kg(self) -> float:
        """The rigid core behind the layer: the head's mass less the felt's (kg)."""
        return self.hammer_mass_kg - self.felt_mass_kg


def felt_for_key(midi: int, voicing: str = GRAND_VOICING, *, thickness_m: float | None = None,
                 area_m2: float = FELT_COLUMN_AREA_M2,
                 density_kg_per_m3: float = HAMMER_FELT_DENSITY_KG_PER_M3) -> HammerFelt:
    """The felt layer whose quasi-static limit is the grand's hammer on key
    ``midi`` (21..108) as the voice plays it.

    From the key's three-parameter law in ``voicing`` (thesis eqs. 1.6-1.8,
    :func:`synth.physics.piano.hammer_three_param`; the shipped grand's is
    ``"concert"``) and its mass per string (eq. 1.9): p the key's; gamma the
    key's four-parameter law's (Publication III eq. 5: 0.9895 .. 0.9972);
    tau0 = alpha delta so that alpha0 = tau0 / delta is the voiced alpha
    exactly (Publication III eq. 15); E_s = Q0 h^p / A (so that
    E_s A (w / h)^p = Q0 w^p).  The thickness h defaults to
    :func:`felt_thickness_m`, the area and density to the module's assumed
    values.  For p > 1, E_s is a power law's coefficient (the stress it
    would give at eps = 1), not a modulus one could measure; the tangent
    modulus at a strain is p E_s eps^(p-1) (:meth:`Felt.linearized`).
    """
    from . import piano as P

    if voicing not in P.VOICINGS:
        raise ValueError(f"voicing = {voicing!r} is not allowed (choose {', '.join(P.VOICINGS)})")
    m = P._check_midi(midi)
    h = felt_thickness_m(m) if thickness_m is None else _check("thickness_m", thickness_m,
                                                                1e-4, 0.1)
    A = _check("area_m2", area_m2, 1e-8, 1e-2)
    q0_mm, p, alpha = P.hammer_three_param(m, P.VOICINGS[voicing])
    tau0 = P.hammer_four_param(m).tau0_s
    q0 = P.stiffness_per_m_p(q0_mm, p)
    felt = Felt(density_kg_per_m3, q0 * h ** p / A, 1.0 - tau0 / alpha, tau0, p)
    return HammerFelt(felt, h, A, P.hammer_mass_kg(m), m)


#: the felt-layer hammer model's relaxation time tau0 for a three-parameter
#: study hammer (s): Publication III eq. 6 at A7 (key 85), the key of the
#: thesis's hammer study (1.80 us); the layer's gamma is 1 - tau0 / alpha
STUDY_FELT_TAU0_S = 1.8e-6
#: the felt-layer hammer model's default thickness for the study (m): the
#: felt lab's assumed thickness at A7 (:func:`felt_thickness_m` of key 85,
#: 10.19 mm)
STUDY_FELT_THICKNESS_M = 0.0102


def felt_from_law(*, law: str, stiffness_n_per_mm_p: float, exponent: float,
                  hammer_mass_kg: float, thickness_m: float, alpha_s: float | None = None,
                  gamma: float | None = None, tau0_s: float | None = None,
                  area_m2: float = FELT_COLUMN_AREA_M2,
                  density_kg_per_m3: float = HAMMER_FELT_DENSITY_KG_PER_M3) -> HammerFelt:
    """The felt layer whose quasi-static limit is a given lumped hammer (a
    study preset's ``[hammer]``), as :func:`felt_for_key` does for a key.

    law : ``"three-parameter"`` (eq. 1.5: ``stiffness_n_per_mm_p`` = Q0,
        ``alpha_s``; the layer's relaxation time ``tau0_s`` and
        gamma = 1 - tau0 / alpha, so that alpha0 = tau0 / delta is alpha
        exactly; E_s = Q0 h^p / A) or ``"four-parameter"`` (Publication
        III eq. 3: ``stiffness_n_per_mm_p`` = F0, ``gamma``, ``tau0_s``;
        E_d = F0 h^p / A, its exact quasi-static limit).
    exponent : p.  hammer_mass_kg : the head's mass on this string, felt
    included (kg).  thickness_m, area_m2, density_kg_per_m3 : the column.
    Errors name the parameter, its value and the range.
    """
    if law not in ("three-parameter", "four-parameter"):
        raise ValueError(f"law = {law!r} is not allowed (choose three-parameter, four-parameter)")
    p = _check("exponent", exponent, 1.0, 10.0)
    h = _check("thickness_m", thickness_m, 1e-4, 0.1)
    A = _check("area_m2", area_m2, 1e-8, 1e-2)
    q = _check("stiffness_n_per_mm_p", stiffness_n_per_mm_p, 0.0, 1e12, lo_open=True)
    q_si = q * 1000.0 ** p
    for name, v in (("tau0_s", tau0_s), ("alpha_s" if law == "three-parameter" else "gamma",
                                          alpha_s if law == "three-parameter" else gamma)):
        if v is None:
            raise ValueError(f"{name} = None is not allowed (the {law} law needs it)")
    tau0 = _check("tau0_s", tau0_s, 1e-9, 1.0)
    if law == "three-parameter":
        a = _check("alpha_s", alpha_s, 0.0, 1.0, lo_open=True)
        if not tau0 < a:
            raise ValueError(f"tau0_s = {tau0!r} is out of range (< alpha_s = {a!r}: "
                             f"gamma = 1 - tau0 / alpha > 0)")
        felt = Felt(density_kg_per_m3, q_si * h ** p / A, 1.0 - tau0 / a, tau0, p)
    else:
        gm = _check("gamma", gamma, 0.0, 0.999999)
        felt = Felt(density_kg_per_m3, q_si * h ** p / A * (1.0 - gm), gm, tau0, p)
    return HammerFelt(felt, h, A, _check("hammer_mass_kg", hammer_mass_kg, 1e-5, 1.0), None)


@dataclass(frozen=True)
class Strike:
    """One strike of a hammer on a rigid string: the contact force
    ``force_n`` (N) against ``time_s`` (s, from first touch) and against the
    felt's compression ``compression_m`` (m: the core's advance less the
    felt surface's), up to the end of contact (the force back to zero);
    ``contact_time_s``, ``peak_force_n``, ``peak_compression_m``; the
    route (``"lumped-kv"``: eq. 1.5; ``"lumped-sls"``: Publication III eq.
    3; ``"layer"``: the felt as a medium), its grid (cells, 0 for lumped)
    and time step (s), and the steps taken.  For the layer,
    ``peak_force_n`` is the pulse's after its first touch's transient
    (t >= min(10 tau0, contact / 5)) and ``touch_force_n`` that
    transient's largest force (the flat face's shock, converging slowly in
    the grid: :func:`first_touch_force_n` gives its jump)."""

    route: str
    time_s: np.ndarray
    force_n: np.ndarray
    compression_m: np.ndarray
    contact_time_s: float
    peak_force_n: float
    peak_compression_m: float
    cells: int
    dt_s: float
    steps: int
    touch_force_n: float = 0.0


def _end_of_contact(t, F, i):
    """The time where F crosses zero between samples i - 1 (F > 0) and i."""
    f0, f1 = F[i - 1], F[i]
    return t[i - 1] + (t[i] - t[i - 1]) * f0 / (f0 - f1) if f0 != f1 else t[i]


def _contact_estimate_s(hf: HammerFelt, v0: float) -> tuple[float, float]:
    """(contact time, peak compression) of the elastic law F = Q0 w^p with
    the hammer's mass at speed v0: w_max from the energy, t ~ 3.3 w_max / v0."""
    p = hf.felt.exponent
    w = ((p + 1.0) * hf.hammer_mass_kg * v0 * v0 / (2.0 * hf.q0_n_per_m_p)) ** (1.0 / (p + 1.0))
    return 3.3 * w / v0, w


def strike_lumped(hf: HammerFelt, v0_m_per_s: float, *, law: str = "kv",
                  steps_per_contact: int = 4000) -> Strike:
    """The lumped hammer (mass m = ``hf.hammer_mass_kg``, felt massless) at
    speed ``v0_m_per_s`` into a rigid string, m w'' = -F, w(0) = 0,
    w'(0) = v0, until F returns to zero.

    law : ``"kv"``: eq. 1.5, F = max(0, Q0 (w^p + alpha d(w^p)/dt)) as the
        voice uses it (physics notes sec. 4), Q0 = ``hf.q0_n_per_m_p``,
        alpha = ``hf.alpha_s``: classical RK4; ``"sls"``: Publication III
        eq. 3, F = F0 (w^p - (gamma / tau0) int_0^t w^p(xi) exp((xi - t) /
        tau0) d xi), F0 = Q0 / delta, the layer's exact quasi-static limit:
        velocity Verlet with the memory integrated exactly for w^p linear
        over a step (stiff-safe for any dt / tau0).
    steps_per_contact : steps per the elastic law's contact time (about);
        the error falls as its fourth (kv) or second (sls) power.
    """
    v0 = _check("v0_m_per_s", v0_m_per_s, 1e-3, 50.0)
    if law not in ("kv", "sls"):
        raise ValueError(f"law = {law!r} is not allowed (choose kv, sls)")
    n = int(_check("steps_per_contact", steps_per_contact, 50, 1e7))
    t_est, _ = _contact_estimate_s(hf, v0)
    dt = t_est / n
    m, p, q0 = hf.hammer_mass_kg, hf.felt.exponent, hf.q0_n_per_m_p
    n_max = 40 * n
    ts = np.empty(n_max + 1)
    Fs = np.empty(n_max + 1)
    ws = np.empty(n_max + 1)
    if law == "kv":
        a = hf.alpha_s

        def force(w, v):
            if w <= 0.0:
                return 0.0
            wp1 = w ** (p - 1.0)
            return max(0.0, q0 * (wp1 * w + a * p * wp1 * v))

        w, v = 0.0, v0
        Fs[0], ws[0], ts[0] = 0.0, 0.0, 0.0
        k = 0
        while k < n_max:
            k1w, k1v = v, -force(w, v) / m
            k2w, k2v = v + 0.5 * dt * k1v, -force(w + 0.5 * dt * k1w, v + 0.5 * dt * k1v) / m
            k3w, k3v = v + 0.5 * dt * k2v, -force(w + 0.5 * dt * k2w, v + 0.5 * dt * k2v) / m
            k4w, k4v = v + dt * k3v, -force(w + dt * k3w, v + dt * k3v) / m
            w += dt / 6.0 * (k1w + 2 * k2w + 2 * k3w + k4w)
            v += dt / 6.0 * (k1v + 2 * k2v + 2 * k3v + k4v)
            k += 1
            ts[k], ws[k] = k * dt, w
            Fs[k] = force(w, v)
            if k > 2 and Fs[k] <= 0.0 and Fs[k - 1] > 0.0:
                break
    else:
        f = hf.felt
        g, tau = f.gamma, f.tau0_s
        F0 = q0 / f.delta
        E = math.exp(-dt / tau)
        r = dt / tau
        c1 = 1.0 - (1.0 - E) / r if r > 1e-6 else 0.5 * r
        c0 = (1.0 - E) / r - E if r > 1e-6 else 0.5 * r
        w, v, y_old, J = 0.0, v0, 0.0, 0.0
        Fs[0], ws[0], ts[0] = 0.0, 0.0, 0.0
        Fn = 0.0
        k = 0
        while k < n_max:
            v_half = v - 0.5 * dt * Fn / m
            w = w + dt * v_half
            y = max(w, 0.0) ** p
            J = E * J + tau * (c1 * y + c0 * y_old)     # int_0^t y(xi) exp((xi - t)/tau) dxi
            y_old = y
            Fn = max(0.0, F0 * (y - g / tau * J))
            v = v_half - 0.5 * dt * Fn / m
            k += 1
            ts[k], ws[k], Fs[k] = k * dt, w, Fn
            if k > 2 and Fn <= 0.0 and Fs[k - 1] > 0.0:
                break
    if k >= n_max:
        raise FloatingPointError(f"the contact did not end within {n_max * dt:g} s")
    tc = _end_of_contact(ts, Fs, k)
    i = int(np.argmax(Fs[:k + 1]))
    return Strike(f"lumped-{law}", ts[:k + 1].copy(), Fs[:k + 1].copy(), ws[:k + 1].copy(), tc,
                  float(Fs[i]), float(np.max(ws[:k + 1])), 0, dt, k)


def strike_layer(hf: HammerFelt, v0_m_per_s: float, *, cells: int = 32,
                 courant: float = 0.5, damping: float = 0.5) -> Strike:
    """The felt layer as a medium, struck against a rigid string.

    The column x in [0, h] (x = 0 the surface on the string, x = h glued to
    the core of mass ``hf.core_mass_kg``), displacement s(x, t) towards
    the string, compressive strain eps = s_x, moves at ``v0_m_per_s`` as a
    whole until its surface touches the string at t = 0.  rho s_tt =
    sigma_x (eq. 2.6) with the hereditary power law (eqs. 2.1-2.3)
    sigma = E_d [eps^p - (gamma / tau0) int_0^t eps^p(xi) exp((xi - t) /
    tau0) d xi] (eps^p as sign(eps) |eps|^p), E_d = E_s / delta: eq. 2.10
    in SI.  The core: m_c Z'' = -A sigma(h).  The surface: s(0, t) <= 0
    (the string does not give); it presses with F = A sigma(0) while in
    contact and leaves when that force would pull.

    Discretisation: ``cells`` cells of dx = h / cells, strains at the
    cells' centres and displacements at their faces (the lumped masses
    rho A dx, half at the surface and at the core); leapfrog (central
    differences) in time; the memory integral updated exactly for eps^p
    linear over a step (I_n = E I_(n-1) + tau0 (c1 f_n + c0 f_(n-1)),
    E = exp(-dt / tau0): stiff-safe, as the voice's law 5).  dt = courant
    dx / c, c the fastest wave, sqrt(p E_d eps^(p-1) / rho) at the largest
    strain (estimated from the lumped law, the run restarted with twice
    the strain bound if a strain outgrows it).

    The first touch stops the surface at once and sends a compression
    front into unstrained felt (for p > 1 a shock: the felt ahead has no
    stiffness, :func:`first_touch_force_n`); a chain of cells carries it
    as a train of grid-scale pulses (a granular chain's), so ``damping``
    adds a grid-scale damper (a hyperviscosity, below) that damps them at
    rho damping c dx eps_t and a smooth strain at O(dx^3): the contact
    time and the peak force converge at second order (docs/felt.md);
    damping x courant <= 0.5 for the explicit damper's stability.  The
    contact ends when the force is back to zero with the core moving back.
    Returns a :class:`Strike` (force and compression at every step).
    """
    v0 = _check("v0_m_per_s", v0_m_per_s, 1e-3, 50.0)
    nc = int(_check("cells", cells, 1, 4096))
    courant = _check("courant", courant, 0.0, 0.9, lo_open=True)
    damping = _check("damping", damping, 0.0, 1.0)
    if damping * courant > 0.5:
        raise ValueError(f"damping x courant = {damping * courant:g} is out of range "
                         f"(<= 0.5: the explicit damper's stability)")
    f = hf.felt
    p, g, tau = f.exponent, f.gamma, f.tau0_s
    rho, A, h = f.density_kg_per_m3, hf.area_m2, hf.thickness_m
    Ed = f.e_dynamic_pa
    dx = h / nc
    t_est, w_est = _contact_estimate_s(hf, v0)
    if w_est > 0.5 * h:
        raise ValueError(f"thickness_m = {h:g} is out of range for this strike (>= "
                         f"{2 * w_est:.3g}: the lumped law compresses the felt by "
                         f"{w_est * 1e3:.3g} mm at {v0:g} m/s)")
    eps_cap = min(1.0, 2.0 * w_est / h)
    for _attempt in range(6):
        c = math.sqrt(max(p * Ed * eps_cap ** (p - 1.0), Ed * 1e-12) / rho)
        dt = courant * dx / c
        res = _layer_run(nc, dx, dt, p, Ed, g, tau, rho, A, hf.core_mass_kg, v0, t_est,
                         eps_cap, damping)
        if res is not None:
            ts, Fs, ws, k = res
            break
        eps_cap = min(1.0, 2.0 * eps_cap)
    else:  # pragma: no cover - the strain cap doubles to 1 within six tries
        raise FloatingPointError("the layer's strain outgrew every time step")
    tc = _end_of_contact(ts, Fs, k)
    # the first touch's transient (the flat face's shock, relaxed within a
    # few tau0) apart from the pulse the law makes
    t_touch = min(10.0 * tau, 0.2 * tc)
    j = int(np.searchsorted(ts[:k + 1], t_touch))
    touch = float(np.max(Fs[:j])) if j > 0 else 0.0
    return Strike("layer", ts[:k + 1], Fs[:k + 1], ws[:k + 1], tc, float(np.max(Fs[j:k + 1])),
                  float(np.max(ws[:k + 1])), nc, dt, k, touch)


def _layer_run(nc, dx, dt, p, Ed, g, tau, rho, A, m_core, v0, t_est, eps_cap, cl=0.0):
    """One run of :func:`strike_layer` at time step ``dt``; None if a strain
    exceeded ``eps_cap`` (the step was too long for the wave it made)."""
    n_max = int(40 * t_est / dt) + 10
    E = math.exp(-dt / tau)
    r = dt / tau
    c1 = 1.0 - (1.0 - E) / r if r > 1e-6 else 0.5 * r
    c0 = (1.0 - E) / r - E if r > 1e-6 else 0.5 * r
    # faces 0..nc: s at t = 0 (all zero: the surface just touches) and at
    # t = -dt (the whole column one step back along its flight)
    s = np.zeros(nc + 1)
    s_old = np.full(nc + 1, -v0 * dt)
    m_face = np.full(nc + 1, rho * A * dx)
    m_face[0] = 0.5 * rho * A * dx
    m_face[-1] = m_core + 0.5 * rho * A * dx
    k_acc = dt * dt * A / m_face
    f_old = np.zeros(nc)
    J = np.zeros(nc)
    pw = p != 1.0
    ts = np.empty(n_max + 1)
    Fs = np.empty(n_max + 1)
    ws = np.empty(n_max + 1)
    sig = np.zeros(nc)
    acc = np.empty(nc + 1)
    gt = g / tau
    eps_prev = np.zeros(nc)
    pEd_rho = p * Ed / rho
    c_lin = math.sqrt(Ed / rho)
    for k in range(1, n_max + 1):
        eps = (s[1:] - s[:-1]) / dx
        if pw:
            fe = np.abs(eps) ** p
            fe = np.copysign(fe, eps)
        else:
            fe = eps
        J *= E
        J += tau * (c1 * fe + c0 * f_old)
        f_old = fe
        np.multiply(fe - gt * J, Ed, out=sig)
        if cl > 0.0:
            # a grid-scale damper (a hyperviscosity): between neighbouring
            # cells the flux d = rho cl c dx (eps_t,i+1 - eps_t,i), c the
            # frozen tangent speed sqrt(p E_d eps^(p-1) / rho) of the
            # faster cell, and q_i = -(d_(i+1/2) - d_(i-1/2)) / 4: it damps
            # the chain's grid-scale pulses at rho cl c dx eps_t and a
            # smooth strain at O(dx^3) (sum q eps_t >= 0: it only dissipates)
            c_loc = np.sqrt(pEd_rho * np.abs(eps) ** (p - 1.0)) if pw else np.full(nc, c_lin)
            cf = np.maximum(c_loc[1:], c_loc[:-1])
            d = cf * np.diff(eps - eps_prev)
            q = np.zeros(nc)
            q[:-1] -= d
            q[1:] += d
            sig += (0.25 * rho * cl * dx / dt) * q
        eps_prev = eps
        # net force on each face (towards the string), per unit area
        acc[0] = sig[0]
        acc[1:-1] = sig[1:] - sig[:-1]
        acc[-1] = -sig[-1]
        s_new = 2.0 * s - s_old + k_acc * acc
        # the surface held on the string (s(0) = 0): it presses with
        # F = A sig_(1/2) (the half cell's momentum balance with s_tt(0) = 0)
        s_new[0] = 0.0
        Fc = A * sig[0]
        ts[k - 1] = (k - 1) * dt
        Fs[k - 1] = max(Fc, 0.0)
        ws[k - 1] = s[-1] - s[0]
        s_old, s = s, s_new
        if eps.max() > eps_cap:
            return None
        # the end: the force back to zero with the core on its way back (a
        # front's ringing at the grid scale can touch zero while the core
        # still advances; the surface is held through it)
        if k > 3 and Fc <= 0.0 and Fs[k - 2] > 0.0 and s[-1] <= s_old[-1]:
            return ts, Fs, ws, k - 1
    raise FloatingPointError(f"the layer's contact did not end within {n_max * dt:g} s")


def first_touch_force_n(hf: HammerFelt, v0_m_per_s: float) -> float:
    """The force at the first touch of a flat felt layer at speed v0 (N):
    the surface stops at once and a shock runs into the unstrained felt at
    its instantaneous (fast-loading, eq. 2.4) law sigma = E_d eps^p; mass
    and momentum across it (eps = v0 / U, sigma = rho U v0) give
    U^(p+1) = E_d v0^(p-1) / rho and F = rho A U v0.  The memory relaxes it
    within a few tau0 (the linear front decays as exp(-gamma t / (2 tau0))),
    to the force of the column being stopped at the relaxed law's speed."""
    v0 = _check("v0_m_per_s", v0_m_per_s, 1e-3, 50.0)
    f = hf.felt
    rho, p = f.density_kg_per_m3, f.exponent
    U = (f.e_dynamic_pa * v0 ** (p - 1.0) / rho) ** (1.0 / (p + 1.0))
    return rho * hf.area_m2 * U * v0
