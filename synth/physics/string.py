"""The ideal flexible string (thesis eq. 1.1) and its waveguide grid.

Wave speed ``c = sqrt(T / mu)``, fundamental ``f0 = c / (2 L)``, wave
impedance ``Z = sqrt(T mu)``.  On the waveguide grid ``c dt = dx`` exactly
(Publication II eq. 8), so the ideal string is exact: no numerical
dispersion, no loss.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


def _check(name: str, value: float, lo: float, hi: float) -> float:
    v = float(value)
    if not (lo <= v <= hi) or math.isnan(v):
        raise ValueError(f"{name} = {value!r} is out of range ({lo} <= value <= {hi})")
    return v


@dataclass(frozen=True)
class IdealString:
    """A lossless flexible string.

    Parameters
    ----------
    length_m : float
        Speaking length L (m), 0.005 .. 10.
    tension_n : float
        Tension T (N), 0.01 .. 1e5.
    linear_density_kg_per_m : float
        Linear mass density mu (kg/m), 1e-6 .. 1.
    """

    length_m: float
    tension_n: float
    linear_density_kg_per_m: float

    def __post_init__(self) -> None:
        _check("length_m", self.length_m, 0.005, 10.0)
        _check("tension_n", self.tension_n, 0.01, 1e5)
        _check("linear_density_kg_per_m", self.linear_density_kg_per_m, 1e-6, 1.0)

    @property
    def c_m_per_s(self) -> float:
        """Transverse wave speed c = sqrt(T / mu) (m/s)."""
        return math.sqrt(self.tension_n / self.linear_density_kg_per_m)

    @property
    def f0_hz(self) -> float:
        """Fundamental f0 = c / (2 L) (Hz) with ideal supports."""
        return self.c_m_per_s / (2.0 * self.length_m)

    @property
    def impedance_kg_per_s(self) -> float:
        """Wave impedance Z = sqrt(T mu) = T / c (kg/s)."""
        return math.sqrt(self.tension_n * self.linear_density_kg_per_m)

    @property
    def mass_kg(self) -> float:
        """Total string mass M = mu L (kg)."""
        return self.linear_density_kg_per_m * self.length_m


@dataclass(frozen=True)
class PaperGrid:
    """The study grid of the thesis: ``cells`` equal cells with c dt = dx.

    The internal rate is ``cells * c / L`` (for the biwa/sitar string with
    812 cells: 324 800 Hz, the thesis's "325 kHz").
    """

    string: IdealString
    cells: int

    def __post_init__(self) -> None:
        if not (2 <= int(self.cells) <= 1_000_000):
            raise ValueError(f"cells = {self.cells!r} is out of range (2 <= value <= 1000000)")

    @property
    def dx_m(self) -> float:
        return self.string.length_m / self.cells

    @property
    def dt_s(self) -> float:
        return self.dx_m / self.string.c_m_per_s

    @property
    def fs_hz(self) -> float:
        """Internal rate 1/dt (Hz), not necessarily an integer."""
        return 1.0 / self.dt_s


def fretted_string(open_string: IdealString, f0_hz: float) -> IdealString:
    """The string that sounds ``f0_hz``: stopped (fretted) above the open
    pitch at constant tension, retuned (lower tension, same length) below it.

    This is what a sitar or biwa player does: frets shorten the speaking
    length; the pegs lower the open pitch.
    """
    f0 = _check("f0_hz", f0_hz, 1.0, 20000.0)
    f_open = open_string.f0_hz
    if f0 >= f_open:
        return IdealString(open_string.c_m_per_s / (2.0 * f0), open_string.tension_n,
                           open_string.linear_density_kg_per_m)
    L = open_string.length_m
    T = open_string.linear_density_kg_per_m * (2.0 * L * f0) ** 2
    return IdealString(L, T, open_string.linear_density_kg_per_m)


def midi_key_to_hz(key: float, a4_hz: float = 440.0) -> float:
    """Equal-temperament frequency of a (possibly fractional) MIDI key (Hz)."""
    return a4_hz * 2.0 ** ((float(key) - 69.0) / 12.0)


def tension_gain(string: IdealString, youngs_modulus_pa: float, diameter_m: float) -> float:
    """dT / T0 per unit of int u_x^2 dx (1/m) of ``string`` (its length L
    and tension T0): E A / (2 L T0), with A = pi d^2 / 4.

    The Kirchhoff-Carrier tension T = T0 + (E A / L) dL of a string whose
    swing u(x) stretches it by dL = 1/2 int u_x^2 dx (Tolonen, Valimaki &
    Karjalainen, IEEE TSAP 8(3), 2000, eq. 4); its wave speed, and every
    partial, follow sqrt(T / T0).  For a triangular pluck of amplitude a at
    the fraction p of L, int u_x^2 dx = a^2 / (p (1 - p) L) at release and
    half that in the time average (the mean tension, which sets the pitch).
    """
    E = _check("youngs_modulus_pa", youngs_modulus_pa, 1e8, 1e12)
    d = _check("diameter_m", diameter_m, 1e-5, 0.01)
    return E * math.pi * d * d / 4.0 / (2.0 * string.length_m * string.tension_n)
