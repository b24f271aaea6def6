"""Stiffness dispersion in the loop of a musical (played) string.

A stiff string (piano) has inharmonic partials

    f_n = n f0 sqrt(1 + B n^2),      n = 1, 2, ...

with the inharmonicity coefficient B from ~1e-5 (bass) to ~1e-2 (top
treble).  The loop of a musical string (see :mod:`synth.physics.losses`) is
2N grid samples, a one-pole loss filter, an optional unit delay and a
first-order tuning allpass; a cascade of allpass sections joins them and
stretches the partials.  One module per job:

* :mod:`~synth.physics.dispersion.first_order`: M identical first-order
  sections (:func:`design_dispersion`, :func:`tune_stiff_loop`, the loop's
  resonances :func:`loop_partials`);
* :mod:`~synth.physics.dispersion.biquad`: second-order sections with
  individual poles and at most one first-order section
  (:func:`tune_stiff_loop_sos`, :func:`retune_sos_loop`), falling back to
  the first-order design;
* :mod:`~synth.physics.dispersion.common`: the stiff-string targets
  (:func:`stiff_partials`, :func:`stiff_group_delay`), the phase budget,
  the loss filter, the range checks and the constants both use.

This package re-exports their public names: import them from
``synth.physics.dispersion``.
"""

from __future__ import annotations

from .biquad import (
    MAX_SOS,
    SOS_COST,
    BridgeLag,
    SosStiffLoop,
    retune_sos_loop,
    sos_coefficients,
    sos_poles,
    tune_stiff_loop_sos,
)
from .common import (
    CENTS_PER_LN,
    F_MAX_HZ,
    M_LIMIT,
    MIN_CELLS,
    N_PARTIALS_MAX,
    TOL_CENTS,
    default_n_partials,
    partial_number,
    phase_budget_sections,
    stiff_group_delay,
    stiff_partials,
)
from .first_order import (
    DispersionDesign,
    StiffLoop,
    design_dispersion,
    design_dispersion_detailed,
    loop_partials,
    loop_phase_delay,
    section_phase_delay,
    tune_stiff_loop,
)

__all__ = [
    # common
    "CENTS_PER_LN",
    "F_MAX_HZ",
    "M_LIMIT",
    "MIN_CELLS",
    "N_PARTIALS_MAX",
    "TOL_CENTS",
    "default_n_partials",
    "partial_number",
    "phase_budget_sections",
    "stiff_group_delay",
    "stiff_partials",
    # first_order
    "DispersionDesign",
    "StiffLoop",
    "design_dispersion",
    "design_dispersion_detailed",
    "loop_partials",
    "loop_phase_delay",
    "section_phase_delay",
    "tune_stiff_loop",
    # biquad
    "MAX_SOS",
    "SOS_COST",
    "BridgeLag",
    "SosStiffLoop",
    "retune_sos_loop",
    "sos_coefficients",
    "sos_poles",
    "tune_stiff_loop_sos",
]
