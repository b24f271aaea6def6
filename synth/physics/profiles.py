"""Termination profiles U(x) (m) of the rigid obstacle near x = 0.

A termination is data: a profile and a ``side``.  ``side = +1``: the
obstacle is above the string (u <= U); ``side = -1``: below it (u >= U).
Where the profile is ``+inf`` (side +1) or ``-inf`` (side -1) there is no
contact.  Cases follow thesis eqs. 1.12, 1.14-1.16 and physics notes
section 2 (Case 2 continuous: ``+ k x_b`` on the parabola).

Every profile function takes ``x`` in metres (array) and returns U in metres.
An edge of a profile (where it ends, or where a piece ends) includes the
points within ``EDGE_RTOL`` of it: a grid point meant to lie on the edge,
x = n dx with dx = c dt, is often an ulp or two beyond it (the sawari's
10 mm at 96 kHz), and must not drop out of the obstacle by rounding.

Registry.  Each profile a preset can name (``termination.profile``) is
registered with :func:`register_profile`: its name, the termination-section
keys it takes (as keyword arguments, in SI units) and the function that
builds it.  :func:`termination_from_spec` builds any registered profile from
a preset's ``[termination]`` section, so a voice never lists profiles.  A new
profile is its function here (or in any module imported by the package) with
``@register_profile(...)``, plus its rows in the preset schema
(``synth/io/presets/sections.py``: the name in ``PROFILES`` and one row per
parameter); ``tests/test_registry.py`` checks the two agree.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

Profile = Callable[[np.ndarray], np.ndarray]

#: Relative tolerance of a profile's edges (see the module docstring): 1e-9
#: of 10 mm is 1e-11 m, thousands of ulps and a hundred-millionth of a cell.
EDGE_RTOL = 1e-9


def _upto(x: np.ndarray, edge: float) -> np.ndarray:
    """x <= edge, with the edge's rounding tolerance (``EDGE_RTOL``)."""
    return x <= edge + EDGE_RTOL * abs(edge)


@dataclass(frozen=True)
class ProfileKind:
    """A registered profile: ``build(**params)`` returns a :data:`Profile`;
    ``params`` are the ``[termination]`` keys it takes (``side`` included
    when the profile needs it)."""

    name: str
    params: tuple[str, ...]
    build: Callable[..., Profile]


#: name -> ProfileKind, in registration order ("none", the ideal rigid end, is not a profile)
PROFILES: dict[str, ProfileKind] = {}


def register_profile(name: str, *params: str):
    """Decorator: register ``build`` as the profile ``name`` taking the
    termination keys ``params``."""
    def deco(build):
        if name in PROFILES or name == "none":
            raise ValueError(f"profile {name!r} is registered twice")
        PROFILES[name] = ProfileKind(name, tuple(params), build)
        return build
    return deco


@register_profile("capo", "radius_m")
def capo(radius_m: float) -> Profile:
    """Capo d'astro bar: U = x^2 / (2R) (side +1)."""
    R = float(radius_m)
    return lambda x: np.asarray(x, float) ** 2 / (2.0 * R)


@register_profile("sawari", "radius_m", "extent_m")
def sawari(radius_m: float, extent_m: float) -> Profile:
    """Biwa sawari, eq. 1.12: U = -x^2/(2R) for x <= s, else -inf (side -1)."""
    R, s = float(radius_m), float(extent_m)

    def U(x):
        x = np.asarray(x, float)
        return np.where(_upto(x, s), -x * x / (2.0 * R), -np.inf)

    # curved from x = 0, level there: the sub-cell contact applies
    # (Termination.subcell; the study preset keeps the thesis's grid)
    U.end_slope = 0.0
    return U


@register_profile("jawari-case1", "slope", "x_c_m")
def jawari_case1(slope: float, x_c_m: float) -> Profile:
    """Jawari Case 1, eq. 1.14: U = k x for x <= x_c, else +inf (side +1)."""
    k, xc = float(slope), float(x_c_m)

    def U(x):
        x = np.asarray(x, float)
        return np.where(_upto(x, xc), k * x, np.inf)

    return U


@register_profile("jawari-case2", "slope", "x_b_m", "radius_m")
def jawari_case2(slope: float, x_b_m: float, radius_m: float) -> Profile:
    """Jawari Case 2, eq. 1.15 made continuous (notes section 2):
    U = k x (x <= x_b), else (x - x_b)^2/(2R) + k x_b (side +1)."""
    k, xb, R = float(slope), float(x_b_m), float(radius_m)

    def U(x):
        x = np.asarray(x, float)
        return np.where(_upto(x, xb), k * x, (x - xb) ** 2 / (2.0 * R) + k * xb)

    return U


@register_profile("jawari-case3", "slope", "x_a_m", "x_b_m", "radius_m", "step_m")
def jawari_case3(slope: float, x_a_m: float, x_b_m: float, radius_m: float,
                 step_m: float) -> Profile:
    """Jawari Case 3, eq. 1.16: k x (x <= x_a); k x + y (x_a < x <= x_b);
    (x - x_b)^2/(2R) + K with K = k x_b + y (side +1)."""
    k, xa, xb, R, y = map(float, (slope, x_a_m, x_b_m, radius_m, step_m))
    K = k * xb + y

    def U(x):
        x = np.asarray(x, float)
        return np.where(_upto(x, xa), k * x,
                        np.where(_upto(x, xb), k * x + y, (x - xb) ** 2 / (2.0 * R) + K))

    return U


@register_profile("jawari", "radius_m", "extent_m", "thread_m")
def jawari(radius_m: float, extent_m: float, thread_m: float) -> Profile:
    """The playable sitar bridge: a curved surface under a grazing string,
    set by its thread (side +1).

    The string leaves the bridge at its far edge (x = 0, the termination)
    and runs over the bridge's top, a surface of radius R (the maker's
    filed *jawari*), to its front edge at x = s (``extent_m``).  A cotton
    thread of diameter d (``thread_m``) lies under the string at the front
    edge.  The surface drops s^2/(2R) below its tangent at x = 0 over the
    bridge, so the thread lifts the string by d - s^2/(2R) above that
    tangent, and the string's rest line leans away from the surface by the
    angle theta = (d - s^2/(2R)) / s.  The gap between the rest string and
    the surface is the profile

        U(x) = theta x + x^2 / (2R)   for 0 < x <= s,  +inf beyond

    (thesis eq. 1.15's ramp and parabola, with the ramp's slope k = theta
    set by the thread and the parabola starting at x = 0).  A thread just
    as thick as the drop (theta = 0) lays the string along the surface's
    tangent: the string grazes the bridge at rest, as a maker's "open"
    jawari does, and touches it whenever it swings towards it, for as long
    as the note sounds.  A thicker thread (theta > 0) "closes" the jawari:
    only a string whose slope at the bridge exceeds theta touches it, and
    the wave soon reshapes itself below that slope (the thesis's periodic
    regime, Publication II section 4): the buzz stops while the note rings.
    The thread itself is cotton, soft next to the bridge; it is not an
    obstacle here.

    The profile carries ``end_slope`` = theta (rad): it is curved from
    x = 0 on, so that a string of any amplitude leaning towards it touches
    it within the first grid cell (:meth:`Termination.subcell`).

    Raises ValueError when the thread is thinner than the drop (the
    string would lie on the surface: theta < 0).
    """
    R, s = float(radius_m), float(extent_m)
    theta = jawari_angle(R, s, thread_m)
    if theta < 0.0:
        raise ValueError(f"termination.thread_m = {float(thread_m):g} is out of range (value >= "
                         f"{s * s / (2.0 * R):g} m, the bridge's drop extent_m^2/(2 radius_m) "
                         f"under its tangent)")

    def U(x):
        x = np.asarray(x, float)
        return np.where(_upto(x, s), theta * x + x * x / (2.0 * R), np.inf)

    # curved from x = 0 with this slope there: the sub-cell contact applies
    # (Termination.subcell)
    U.end_slope = theta
    return U


def jawari_angle(radius_m: float, extent_m: float, thread_m: float) -> float:
    """The rest string's angle over the bridge, theta = (d - s^2/(2R))/s
    (rad), of :func:`jawari`'s geometry."""
    return (float(thread_m) - float(extent_m) ** 2 / (2.0 * float(radius_m))) / float(extent_m)


@register_profile("table", "points", "side")
def table(points, side: int) -> Profile:
    """User profile from (x_m, U_m) points, linearly interpolated; beyond the
    last point there is no contact (+inf for side +1, -inf for side -1)."""
    pts = np.asarray(points, float)
    if pts.ndim != 2 or pts.shape[1] != 2 or pts.shape[0] < 2:
        raise ValueError(f"points has shape {pts.shape}; expected (n >= 2, 2) pairs of (x_m, U_m)")
    xs, us = pts[:, 0], pts[:, 1]
    if np.any(np.diff(xs) <= 0) or xs[0] < 0:
        raise ValueError("points: x_m must start at >= 0 and increase strictly")
    none = np.inf if side > 0 else -np.inf

    def U(x):
        x = np.asarray(x, float)
        inside = (x >= xs[0] - EDGE_RTOL * abs(xs[0])) & _upto(x, xs[-1])
        return np.where(inside, np.interp(x, xs, us), none)

    return U


@dataclass(frozen=True)
class Termination:
    """A rigid obstacle at x = 0: a profile, the side, and the part of the
    string it may touch.

    ``region_points`` grid points (x = dx, 2 dx, ...) on the grid the
    preset was designed on; ``rate_scale`` is the internal rate over that
    grid's (dx_design / dx for the same string).  The region keeps its
    length in metres at any rate: :attr:`points` = ceil(region_points
    rate_scale) grid points (issue 13: a re-gridded study string kept 25
    points, and above 530 kHz jawari Case 1's obstacle was cut short).
    """

    profile: Profile
    side: int
    region_points: int
    rate_scale: float = 1.0
    #: the first cell's sub-cell contact (``termination.contact =
    #: "subcell"``), for a profile that declares its slope at x = 0
    #: (``end_slope``: the jawari's); see :meth:`subcell`
    contact_subcell: bool = False

    def __post_init__(self) -> None:
        if self.side not in (-1, 1):
            raise ValueError(f"side = {self.side!r} is not allowed (choose -1 or +1)")
        if not (1 <= int(self.region_points) <= 100000):
            raise ValueError(f"region_points = {self.region_points!r} is out of range (1 <= value <= 100000)")
        if not (0.01 <= float(self.rate_scale) <= 100.0):
            raise ValueError(f"rate_scale = {self.rate_scale!r} is out of range (0.01 <= value <= 100)")

    @property
    def points(self) -> int:
        """Grid points of the region at this rate: the design grid's
        ``region_points`` over the same length (at least 1)."""
        return max(1, int(np.ceil(int(self.region_points) * float(self.rate_scale) * (1.0 - 1e-12))))

    def sample(self, dx_m: float) -> np.ndarray:
        """U at grid points n = 1..:attr:`points` (x = n dx), metres.

        Returns an array of length :attr:`points`; entries where the
        obstacle cannot be touched are +inf (side +1) or -inf (side -1).
        """
        x = dx_m * np.arange(1, self.points + 1, dtype=float)
        U = np.asarray(self.profile(x), float).copy()
        none = np.inf if self.side > 0 else -np.inf
        U[np.isnan(U)] = none
        # an obstacle on the wrong side of infinity never touches either
        U[np.isinf(U)] = none
        return U

    def subcell(self, dx_m: float) -> float:
        """The first cell's sub-cell contact on a grid of spacing ``dx_m``
        (m): the kernel's ``F_CURV`` (:func:`subcell_share`; 0: off).

        The clamp at grid points sees the obstacle only where points lie:
        on the open jawari the first one's gap U(1) = dx^2 / (2R) (1 um at
        dx = 1 mm, R = 0.5 m) is a threshold, and a string whose swing there
        decays below it leaves the bridge in one step, its buzz with it
        (docs/voicing.md, "The buzz decays with the note").  A string
        under tension on the curved surface wraps it from x = 0 to where
        its tangent leaves it, however small its slope, so the kernel
        solves that contact within the first cell
        (:func:`synth.kernels.contact._subcell_delta`).  On for
        ``contact_subcell`` and a profile with ``end_slope`` (the
        ``jawari``); the thesis's profiles keep the clamp alone."""
        slope = getattr(self.profile, "end_slope", None)
        if not self.contact_subcell or slope is None:
            return 0.0
        U1 = self.sample(dx_m)[0]
        return subcell_share(U1, slope, dx_m, self.side)


def subcell_share(U1: float, end_slope: float, dx_m: float, side: int) -> float:
    """The kernel's ``F_CURV`` for a profile of slope ``end_slope`` (rad)
    at x = 0 and value ``U1`` (m) at the first grid point x = dx: the share
    of U1 due to the profile's curvature, 1 - theta dx / U1 (1 for the
    open jawari, theta = 0), or 0 (no sub-cell contact) when U1 is not
    finite or the profile is not curved towards the string there (side
    (U1 - theta dx) <= 0: a ramp, thesis Cases 1-3, which the clamp at
    point 1 already meets exactly)."""
    U1 = float(U1)
    if not np.isfinite(U1) or side * U1 <= 0.0:
        return 0.0
    G = U1 - float(end_slope) * float(dx_m)
    if side * G <= 0.0:
        return 0.0
    return min(1.0, G / U1)


def trim_unreachable(U: np.ndarray | None) -> np.ndarray | None:
    """The region ``U`` (m, at grid points 1..R) without its trailing
    points where the obstacle cannot be touched (+-inf: past a profile's
    extent), or None when no point can be (the rigid end alone).  The
    string's samples do not change (a point at +-inf never clamps); the
    kernel's region pass and the fast path's chunk limit shrink with it:
    a chikari at C6 sampled the sitar's 2 cm jawari over 48 points of
    1.9 mm (9 cm), 37 of them out of reach."""
    if U is None:
        return None
    fin = np.flatnonzero(np.isfinite(np.asarray(U, float)))
    if fin.size == 0:
        return None
    return U[: int(fin[-1]) + 1]


def buzz_profile(U: np.ndarray, buzz: float, side: int) -> np.ndarray:
    """The profile ``U`` (m, at the region's points) at a buzz depth.

    ``buzz`` in [0, 1] scales the gap between the string at rest and the
    obstacle by 1/buzz: U / buzz.  At 1 the profile is as given; towards 0
    the obstacle withdraws from the string, so that a string of amplitude
    A meets it as one of amplitude A buzz meets the full profile (exactly
    so where U is linear in x: the jawari's ramp, thesis eqs. 1.14-1.16);
    at 0 it is out of reach (+inf for side +1, -inf for side -1): the
    string's contact test never fires and it is the linear string.
    Returns a new array.
    """
    b = float(buzz)
    if not (0.0 <= b <= 1.0):
        raise ValueError(f"buzz = {buzz!r} is out of range (0 <= value <= 1)")
    if b == 0.0:
        return np.full(len(U), np.inf if side > 0 else -np.inf)
    with np.errstate(over="ignore"):      # a tiny depth: U / b overflows to inf, out of reach
        return np.asarray(U, float) / b


def termination_from_spec(spec, rate_scale: float = 1.0) -> Termination | None:
    """The :class:`Termination` a preset's ``[termination]`` section
    describes (any object with its keys as attributes: ``profile``,
    ``side``, ``region_points`` and the profile's parameters), or None for
    the ideal rigid end (``profile = "none"``).  ``rate_scale``: the
    internal rate over the rate the preset's ``region_points`` counts at
    (:class:`Termination`)."""
    name = spec.profile
    if name == "none":
        return None
    kind = PROFILES.get(name)
    if kind is None:
        raise ValueError(f"termination.profile = {name!r} is not a registered profile "
                         f"(registered: {', '.join(PROFILES)})")
    prof = kind.build(**{p: getattr(spec, p) for p in kind.params})
    contact = getattr(spec, "contact", None) or "subcell"
    return Termination(prof, int(spec.side), int(spec.region_points), float(rate_scale),
                       contact == "subcell")
