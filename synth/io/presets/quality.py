"""Each preset's measured quality errors, from its data: what ``--max-error``
reads.

A musical preset states, in its ``[quality_error]`` table, the error each
quality level was measured to make on it (:class:`.model.QualityErrorSpec`;
``python tools/quality_levels.py notes``, docs/quality.md).  A preset
without the table (a user's own, not measured) is taken at the worst of
the shipped musical presets, level by level.
"""

from __future__ import annotations

from ...voices.quality import LEVELS, QualityLevel, cheapest_within
from ..errors import PresetError
from .loader import list_presets, load_preset
from .model import Preset

__all__ = ["measured_errors", "shipped_worst_errors", "level_within"]


def shipped_worst_errors() -> dict[str, tuple[float, float]]:
    """{level: (cents, dB)}: the worst over the shipped musical presets that
    state their errors (every shipped musical preset does: tests/test_quality.py)."""
    tables = []
    for name, _ in list_presets():
        p = load_preset(name)
        if p.quality_error is not None:
            tables.append(p.quality_error.table())
    if not tables:
        raise ValueError("no shipped preset states its quality errors ([quality_error])")
    return {lv.name: (max(t[lv.name][0] for t in tables), max(t[lv.name][1] for t in tables))
            for lv in LEVELS}


def measured_errors(preset: Preset | str | None) -> tuple[dict[str, tuple[float, float]], str]:
    """The quality levels' errors for ``preset`` (a loaded preset, a name or
    a ``.toml`` path; None: none in particular) and whose they are:
    ``({level: (cents, dB)}, "for NAME")``, or the shipped presets' worst
    with ``"(the worst over the shipped presets)"``."""
    if preset is not None and not isinstance(preset, Preset):
        try:
            preset = load_preset(str(preset))
        except (PresetError, ValueError):
            preset = None
    if preset is not None and preset.quality_error is not None:
        return preset.quality_error.table(), f"for {preset.name}"
    return shipped_worst_errors(), "(the worst over the shipped presets)"


def level_within(max_cents: float, max_db: float, preset: Preset | str | None = None) -> QualityLevel:
    """The cheapest quality level whose measured errors for ``preset`` (see
    :func:`measured_errors`) are within ``max_cents`` (cents, > 0) and
    ``max_db`` (dB, > 0); ValueError naming the levels' errors if none is."""
    table, who = measured_errors(preset)
    return cheapest_within(max_cents, max_db, table, who)
