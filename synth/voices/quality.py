"""Quality levels: how finely a musical voice is computed, for a stated error.

A level is a documented choice of what the strings cost:

* the internal rate (the grid every string runs on, hence the time and
  space steps of the waveguide, the jawari's and the capo bar's grid
  points, the hammer's time step): a factor on the voice's default rate
  (325 kHz);
* the stiffness filters' design tolerance (the grand's second-order
  dispersion cascade: each string's partials up to 40, or 10 kHz, within
  this many cents of the stiff-string law);

and, the same at every level, for these reasons:

* the termination region: it covers, in metres, every point the obstacle
  can touch at any rate (:class:`synth.physics.profiles.Termination`), and
  points out of reach are dropped (:func:`~synth.physics.profiles.
  trim_unreachable`): shortening it further changes the wave by 7e-2 to
  0.28 (docs/work-precision.md, "termination region"), lengthening it
  changes nothing;
* the hammer's felt solver: Halley's iteration until a correction changes
  the felt's compression by less than 1e-5, relative (round-off: the next
  would be ~1e-15).  Looser saves at most a fifth of a strike's 12 us at
  325 kHz (1e-3: 1.2e-10 of g(t)), nothing at 1.3 MHz, and a strike is a
  few microseconds of a note (docs/work-precision.md, "the hammer's felt
  solver").

Each level's error is measured against the same notes at 1.3 MHz with
0.5-cent stiffness filters, the finest setting of the work-precision
study (``python tools/quality_levels.py notes``, docs/quality.md): the
worst partial-frequency error (cents) and partial-level error (dB) over
the first second of a low, a middle and a high note of each shipped
musical preset (:data:`ERRORS`).  ``--max-error CENTS,DB`` picks the
cheapest level within both for the preset played (a preset not measured
here: the worst over the shipped ones).

The names are the schema's ``play.quality`` choices
(:data:`synth.io.presets.QUALITIES`); a study preset keeps the thesis's
grid and takes no level.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class QualityLevel:
    """One quality level.

    name : str                   ``draft``, ``standard`` or ``reference``
    rate_factor : float          internal rate over the voice's default (325 kHz)
    dispersion_tol_cents : float the grand's stiffness filters' design tolerance
    cost : float                 run time over ``standard``'s, measured on the
                                 five piano files (``tools/quality_levels.py
                                 files``; docs/quality.md)
    """

    name: str
    rate_factor: float
    dispersion_tol_cents: float
    cost: float


#: the levels, cheapest first
LEVELS: tuple[QualityLevel, ...] = (
    QualityLevel("draft", 0.5, 1.2, cost=0.66),
    QualityLevel("standard", 1.0, 1.2, cost=1.0),   # 1.2: why, synth.voices.grand
    QualityLevel("reference", 2.0, 0.5, cost=1.72),
)

#: measured errors (cents, dB) per shipped musical preset and level: the worst
#: over keys low, middle and high (``python tools/quality_levels.py notes``,
#: 2026-11-25; docs/quality.md)
ERRORS: dict[str, dict[str, tuple[float, float]]] = {
    "grand-piano": {"draft": (1.96, 5.65), "standard": (1.93, 5.23), "reference": (0.02, 0.82)},
    "harpsichord": {"draft": (1.11, 3.15), "standard": (0.62, 2.50), "reference": (0.62, 3.18)},
    "sitar": {"draft": (7.14, 5.65), "standard": (2.40, 1.32), "reference": (0.26, 0.79)},
    "hammered-sitar": {"draft": (7.04, 3.72), "standard": (5.84, 3.53),
                       "reference": (5.10, 3.58)},
    # the biwa's with the sawari's sub-cell contact (2026-11-29, issue 40)
    "biwa": {"draft": (0.07, 0.30), "standard": (0.05, 0.87), "reference": (0.02, 0.14)},
}

BY_NAME = {lv.name: lv for lv in LEVELS}

#: the level a preset without ``play.quality`` plays at
DEFAULT = "standard"


def quality_level(name: str | None) -> QualityLevel:
    """The level called ``name`` (None: :data:`DEFAULT`)."""
    if name is None:
        name = DEFAULT
    lv = BY_NAME.get(str(name))
    if lv is None:
        raise ValueError(f"quality = {name!r} is not allowed (choose {', '.join(BY_NAME)})")
    return lv


def errors(level: str, preset: str | None = None) -> tuple[float, float]:
    """The measured error (cents, dB) of ``level`` for ``preset`` (a
    shipped preset's name), or the worst over the shipped presets."""
    table = ERRORS.get(str(preset)) if preset is not None else None
    if table is not None:
        return table[level]
    return (max(t[level][0] for t in ERRORS.values()),
            max(t[level][1] for t in ERRORS.values()))


def cheapest_within(max_cents: float, max_db: float, preset: str | None = None) -> QualityLevel:
    """The cheapest level whose measured errors for ``preset`` (see
    :func:`errors`) are within ``max_cents`` (cents, > 0) and ``max_db``
    (dB, > 0)."""
    if not (max_cents > 0.0) or not (max_db > 0.0):
        raise ValueError(f"max error = {max_cents!r} cents, {max_db!r} dB is out of range "
                         f"(both > 0)")
    for lv in LEVELS:
        c, d = errors(lv.name, preset)
        if c <= max_cents and d <= max_db:
            return lv
    shown = " and ".join(f"{lv.name} {errors(lv.name, preset)[0]:g} cents, "
                         f"{errors(lv.name, preset)[1]:g} dB" for lv in LEVELS)
    who = f"for {preset}" if preset in ERRORS else "(the worst over the shipped presets)"
    raise ValueError(f"max error = {max_cents:g} cents, {max_db:g} dB is out of range: no level "
                     f"is that accurate {who} ({shown})")
