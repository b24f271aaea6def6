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
musical preset, kept in the preset's data (its ``[quality_error]``
table).  ``--max-error CENTS,DB`` picks the cheapest level within both for
the preset played (:func:`cheapest_within`; a preset not measured: the
worst over the shipped ones, :func:`synth.io.presets.quality.level_within`).

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


def cheapest_within(max_cents: float, max_db: float, errors: dict, who: str) -> QualityLevel:
    """The cheapest level whose measured errors are within ``max_cents``
    (cents, > 0) and ``max_db`` (dB, > 0).

    errors : {level name: (cents, dB)} for every level (a preset's
        ``[quality_error]``, :meth:`synth.io.presets.model.QualityErrorSpec.table`).
    who : str
        Whose errors they are, for the message (``"for sitar"``).
    """
    if not (max_cents > 0.0) or not (max_db > 0.0):
        raise ValueError(f"max error = {max_cents!r} cents, {max_db!r} dB is out of range "
                         f"(both > 0)")
    for lv in LEVELS:
        c, d = errors[lv.name]
        if c <= max_cents and d <= max_db:
            return lv
    shown = " and ".join(f"{lv.name} {errors[lv.name][0]:g} cents, {errors[lv.name][1]:g} dB"
                         for lv in LEVELS)
    raise ValueError(f"max error = {max_cents:g} cents, {max_db:g} dB is out of range: no level "
                     f"is that accurate {who} ({shown})")
