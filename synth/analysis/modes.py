"""Modal energies of a string snapshot (Publication II eqs. 14-18).

numpy only. The string of length L is sampled on the uniform grid
``x_n = n L / N``, n = 0 .. N (N + 1 samples including both ends). Mode i of
the ideally supported string is ``sin(i pi x / L)`` with angular frequency
``w_i = i pi c / L``, ``c = sqrt(T / mu)``. Given displacement u and velocity
v = u_t at one instant,

    A_i = (2 / L) int_0^L u sin(i pi x / L) dx,
    B_i = (2 / (L w_i)) int_0^L v sin(i pi x / L) dx,
    E_i = M w_i^2 (A_i^2 + B_i^2) / 4,   M = mu L.

The integrals use the trapezoid rule on the grid; the integrand vanishes at
both ends, so it is the exact discrete sine transform (DST-I) of the samples,
computed with an FFT. For a single grid-sampled mode the projection is exact
(discrete orthogonality); for a general shape it equals the projection of the
continuous function only to the accuracy of the rule (fine for a smooth or
finely sampled shape). The sum of E_i then matches :func:`string_energy` to
O((i_max / N)^2) relative (the potential energy uses finite differences, the
modes continuous w_i).
"""

from __future__ import annotations

import numpy as np

from synth.analysis.spectrum import FLOOR_DB, _int, _positive

__all__ = ["mode_energies", "string_energy", "grid_energy", "mode_levels_db", "free_mode_energies",
           "struck_mode_energies"]


def _field(name, a, min_len=3):
    """Float64 array with last axis >= min_len samples, finite (one-line ValueError)."""
    try:
        arr = np.asarray(a, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be an array of real numbers, got {type(a).__name__}") from None
    if arr.ndim < 1 or arr.shape[-1] < min_len:
        raise ValueError(f"{name} has shape {arr.shape}; the last axis needs >= {min_len} samples")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN or infinite values; all samples must be finite")
    return arr


def _dst_sums(u, n_modes):
    """S_i = sum_{n=1}^{N-1} u_n sin(pi i n / N), i = 1..n_modes, along the last axis."""
    N = u.shape[-1] - 1
    y = np.zeros(u.shape[:-1] + (2 * N,))
    y[..., 1:N] = u[..., 1:N]
    y[..., N + 1:] = -u[..., N - 1:0:-1]
    Y = np.fft.rfft(y, axis=-1)
    return -0.5 * Y[..., 1:n_modes + 1].imag


def mode_energies(u, v, length_m, linear_density_kg_per_m, tension_n, n_modes):
    """Energy of each transverse mode of an ideally supported string, in J.

    Parameters
    ----------
    u : array_like, shape (..., N + 1)
        Displacement in m on the grid ``x_n = n length_m / N`` (both ends
        included; their values do not matter as sin vanishes there). N >= 2.
        Leading axes (e.g. time) are allowed.
    v : array_like, same shape as u
        Velocity u_t in m/s on the same grid.
    length_m : float
        String length L in m, > 0.
    linear_density_kg_per_m : float
        Linear mass density mu in kg/m, > 0.
    tension_n : float
        Tension T in N, > 0.
    n_modes : int
        Number of modes, 1 <= n_modes <= N - 1 (higher modes alias on the grid).

    Returns
    -------
    E : ndarray, shape (..., n_modes)
        ``E_i = M w_i^2 (A_i^2 + B_i^2) / 4`` in J for i = 1 .. n_modes,
        M = mu L, w_i = i pi sqrt(T/mu) / L (see the module doc).
    """
    u = _field("u", u)
    v = _field("v", v)
    if u.shape != v.shape:
        raise ValueError(f"v shape {v.shape} must equal u shape {u.shape}")
    L = _positive("length_m", length_m)
    mu = _positive("linear_density_kg_per_m", linear_density_kg_per_m)
    T = _positive("tension_n", tension_n)
    N = u.shape[-1] - 1
    n_modes = _int("n_modes", n_modes, 1, N - 1)
    i = np.arange(1, n_modes + 1)
    w = i * np.pi * np.sqrt(T / mu) / L
    # (2/L) * dx * S = (2/N) * S
    A = (2.0 / N) * _dst_sums(u, n_modes)
    Bw = (2.0 / N) * _dst_sums(v, n_modes)  # = w_i B_i
    M = mu * L
    return 0.25 * M * (w * w * A * A + Bw * Bw)


def string_energy(u, v, dx, tension_n, linear_density_kg_per_m):
    """Total energy of a string snapshot (potential + kinetic), in J.

    Discretisation: potential ``(T/2) sum_{n=0}^{N-1} ((u[n+1] - u[n]) / dx)^2 dx``
    (slope on each of the N intervals between neighbouring samples), kinetic
    ``(mu/2) sum_n c_n v[n]^2 dx`` with trapezoid weights c_n (1/2 at both
    ends, 1 inside; the ends of a supported string do not move).

    Parameters
    ----------
    u : array_like, shape (..., N + 1)
        Displacement in m on a uniform grid including both ends, N >= 1.
    v : array_like, same shape as u
        Velocity in m/s on the same grid.
    dx : float
        Grid spacing in m, > 0 (L / N).
    tension_n : float
        Tension in N, > 0.
    linear_density_kg_per_m : float
        Linear mass density in kg/m, > 0.

    Returns
    -------
    float or ndarray, shape (...)
        Energy in J.
    """
    u = _field("u", u, 2)
    v = _field("v", v, 2)
    if u.shape != v.shape:
        raise ValueError(f"v shape {v.shape} must equal u shape {u.shape}")
    dx = _positive("dx", dx)
    T = _positive("tension_n", tension_n)
    mu = _positive("linear_density_kg_per_m", linear_density_kg_per_m)
    du = np.diff(u, axis=-1)
    pot = 0.5 * T * np.sum(du * du, axis=-1) / dx
    v2 = v * v
    kin = 0.5 * mu * dx * (np.sum(v2, axis=-1) - 0.5 * (v2[..., 0] + v2[..., -1]))
    e = pot + kin
    return float(e) if np.ndim(e) == 0 else e


def grid_energy(u_now, u_prev, tension_n, dx):
    """Energy (J) of a string on the waveguide's grid, from u at two
    successive steps (physics notes: the quantity the contact may only
    lower).

    The waveguide with c dt = dx is the FDTD scheme at CFL 1, whose exactly
    conserved energy is (T / 2dx) [sum du^n du^(n-1) + sum (u^n - u^(n-1))^2]
    (differences du along x; mu dx / dt^2 = T / dx).  The energy of the two
    rails, T/dx sum (d u_r)^2 + (d u_l)^2, is conserved too without contact,
    but a clamp notches one rail and that measure can rise for a few steps
    while the string itself loses energy (measured: up to 0.8 % for jawari
    Case 1), so it is not the quantity to test.

    Parameters
    ----------
    u_now, u_prev : array_like, shape (N + 1,)
        Displacement (m) at grid points 0..N at steps n and n - 1.
    tension_n : float
        Tension in N, > 0.
    dx : float
        Grid spacing in m, > 0.
    """
    u1 = _field("u_now", u_now, 2)
    u0 = _field("u_prev", u_prev, 2)
    if u1.shape != u0.shape:
        raise ValueError(f"u_prev shape {u0.shape} must equal u_now shape {u1.shape}")
    T = _positive("tension_n", tension_n)
    dx = _positive("dx", dx)
    return float(T / (2 * dx) * (np.sum(np.diff(u1) * np.diff(u0)) + np.sum((u1 - u0) ** 2)))


def mode_levels_db(E, E_ref):
    """Mode energies as levels, ``10 log10(E / E_ref)`` dB (energy ratio).

    Parameters
    ----------
    E : array_like
        Energies in J, finite and >= 0.
    E_ref : float
        Reference energy in J, > 0 (e.g. the total input energy or max(E)).

    Returns
    -------
    ndarray (same shape as E)
        Levels in dB re E_ref; zero energy gives :data:`FLOOR_DB`.
    """
    e = np.asarray(E, dtype=np.float64)
    if not np.all(np.isfinite(e) & (e >= 0)):
        raise ValueError("E must be finite and >= 0 J")
    E_ref = _positive("E_ref", E_ref)
    with np.errstate(divide="ignore"):
        return np.maximum(10.0 * np.log10(e / E_ref), FLOOR_DB)


def free_mode_energies(u0, u1, dt_s, length_m, linear_density_kg_per_m, tension_n, n_modes,
                       piecewise_linear=True):
    """Mode energies (J) of a freely vibrating string from two snapshots.

    u0, u1 : displacement on the grid x_n = n L / N (n = 0..N) at t and t + dt.
    Each mode of the ideally supported string evolves as
    q_i(t) = a cos(w_i t) + b sin(w_i t), so from q_i(t) and q_i(t + dt) its
    amplitude is exact: |q|^2 = q0^2 + ((q1 - q0 cos th) / sin th)^2 with
    th = w_i dt, and E_i = M w_i^2 |q|^2 / 4 (Publication II eq. 17).

    piecewise_linear : project the linear interpolant of the samples (exact
        for the waveguide string on a grid with c dt = dx, whose shape is
        piecewise linear between grid points), i.e. the DST-I coefficient
        times sinc^2(i pi / 2N); False: the trapezoid rule on the samples.
    """
    L = _positive("length_m", length_m)
    mu = _positive("linear_density_kg_per_m", linear_density_kg_per_m)
    T = _positive("tension_n", tension_n)
    dt = _positive("dt_s", dt_s)
    n_modes = _int("n_modes", n_modes, 1)
    a0 = _field("u0", u0)
    a1 = _field("u1", u1)
    if a0.shape != a1.shape:
        raise ValueError(f"u0 and u1 must have the same shape, got {a0.shape} and {a1.shape}")
    N = a0.shape[-1] - 1
    if n_modes >= N:
        raise ValueError(f"n_modes = {n_modes} is out of range (1 <= value < N = {N})")
    i = np.arange(1, n_modes + 1)
    q0 = _dst_sums(a0, n_modes) * (2.0 / N)
    q1 = _dst_sums(a1, n_modes) * (2.0 / N)
    if piecewise_linear:
        h = i * np.pi / (2 * N)
        f = (np.sin(h) / h) ** 2
        q0, q1 = q0 * f, q1 * f
    w = i * np.pi * np.sqrt(T / mu) / L
    th = w * dt
    amp2 = q0 ** 2 + ((q1 - q0 * np.cos(th)) / np.sin(th)) ** 2
    return mu * L * w ** 2 * amp2 / 4.0


def struck_mode_energies(g_m, dt_s, strike_fraction, length_m, linear_density_kg_per_m,
                         tension_n, n_modes):
    """Mode energies (J) of an ideally supported string from the force history
    of a point strike (Publication I eqs. 11-13, with the factor 2 the printed
    modal amplitudes lack).

    The force enters through the outgoing wave, F = (2T/c) dg/dt; ``g_m`` are
    its samples at t_m = m dt (piecewise linear between them, so F is
    constant within each step and the integrals are exact).  For a strike at
    a = l/L,

        amp_i = 2 sin(i pi a) / (i pi c mu) | int F(s) exp(j w_i s) ds |,
        E_i = M w_i^2 amp_i^2 / 4.

    The spectrum is stationary once the force has stopped (the hammer has
    left), which is when this route applies.
    """
    L = _positive("length_m", length_m)
    mu = _positive("linear_density_kg_per_m", linear_density_kg_per_m)
    T = _positive("tension_n", tension_n)
    dt = _positive("dt_s", dt_s)
    n_modes = _int("n_modes", n_modes, 1)
    g = _field("g_m", g_m, min_len=2)
    c = np.sqrt(T / mu)
    a = float(strike_fraction)
    if not (0.0 < a < 1.0):
        raise ValueError(f"strike_fraction = {strike_fraction!r} is out of range (0 < value < 1)")
    F = (2.0 * T / c) * np.diff(g) / dt          # constant on [t_(m-1), t_m]
    t_lo = np.arange(len(F)) * dt
    i = np.arange(1, n_modes + 1)[:, None]
    w = i * np.pi * c / L
    # int over each step of exp(j w s) ds = (exp(j w t_hi) - exp(j w t_lo)) / (j w)
    seg = (np.exp(1j * w * (t_lo + dt)) - np.exp(1j * w * t_lo)) / (1j * w)
    I = np.sum(F[None, :] * seg, axis=1)
    amp = 2.0 * np.sin(i[:, 0] * np.pi * a) / (i[:, 0] * np.pi * c * mu) * np.abs(I)
    return mu * L * w[:, 0] ** 2 * amp ** 2 / 4.0
