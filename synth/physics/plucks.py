"""Plucks as the outgoing wave g(t) (m) at x = l (thesis eq. 1.4: dg/dt = c F / 2T).

Both are kinematic here: g is given in closed form, cumulative (it stays at
its final value once the pluck has ended).  The kernels evaluate the same
formulas inline; these numpy versions are the reference.
"""

from __future__ import annotations

import numpy as np


def sitar_g(t_s, amplitude_m: float, duration_s: float) -> np.ndarray:
    """Sitar pluck, eq. 1.13: g = A (t/t0)^2 exp(2 (1 - t/t0)) for 0 <= t <= t0,
    A after; 0 before t = 0.  A in m, t0 in s."""
    t = np.asarray(t_s, float)
    A, t0 = float(amplitude_m), float(duration_s)
    r = t / t0
    g = np.where(t <= t0, A * r * r * np.exp(2.0 * (1.0 - r)), A)
    return np.where(t < 0, 0.0, g)


def biwa_g(t_s, amplitude_m: float, alpha_per_s: float, duration_s: float) -> np.ndarray:
    """Biwa force pluck, eqs. 1.10-1.11: g = A (1 - (1 + alpha t) exp(-alpha t))
    for t < t0, g(t0) after; 0 before t = 0.  With A = 2 mm, alpha = 2/ms,
    t0 = 2.5 ms, g(t0) = 1.92 mm."""
    t = np.asarray(t_s, float)
    A, a, t0 = float(amplitude_m), float(alpha_per_s), float(duration_s)
    tc = np.minimum(t, t0)
    g = A * (1.0 - (1.0 + a * tc) * np.exp(-a * tc))
    return np.where(t < 0, 0.0, g)


def biwa_force(t_s, amplitude_m: float, alpha_per_s: float, duration_s: float,
               tension_n: float, c_m_per_s: float) -> np.ndarray:
    """The force F(t) = F0 alpha t exp(-alpha t) (N) behind :func:`biwa_g`,
    F0 = 2 T A alpha / c (from dg/dt = c F / 2T)."""
    t = np.asarray(t_s, float)
    a = float(alpha_per_s)
    F0 = 2.0 * tension_n * amplitude_m * a / c_m_per_s
    return np.where((t >= 0) & (t < duration_s), F0 * a * t * np.exp(-a * t), 0.0)
