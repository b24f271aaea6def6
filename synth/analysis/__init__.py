"""Measurement tools (numpy only): spectra, pitch, decay, loudness, modal energies, regimes,
narrow bands and the sympathetic halo, clicks, partials followed upward.

Used by the tests, the reproduction scripts and the analysis commands;
never imports numba or other ``synth`` layers (loudness uses pyloudnorm).
"""

from synth.analysis.bands import band_centroid_hz, band_db, band_levels_db, halo, highband_db, highband_energy, window_energy_db
from synth.analysis.buzz import band_decay, largest_fall_db
from synth.analysis.clicks import click_scan
from synth.analysis.decay import decay_curve_db, t60_s, two_stage_decay, two_stage_summary
from synth.analysis.loudness import (
    crest_factor_db,
    loudness,
    max_momentary_lufs,
    momentary_lufs,
    peak_dbfs,
)
from synth.analysis.modes import (
    free_mode_energies,
    grid_energy,
    mode_energies,
    mode_levels_db,
    string_energy,
    struck_mode_energies,
)
from synth.analysis.partials import track_partials
from synth.analysis.pitch import cents, estimate_f0, f0_track, fit_inharmonicity
from synth.analysis.regimes import (
    aperiodic_end,
    count_episodes,
    episode_times,
    period_deviation,
)
from synth.analysis.spectrum import (
    FLOOR_DB,
    as_mono,
    attack_centroid_hz,
    magnitude_spectrum_db,
    partial_levels_db,
    partial_peaks,
    spectral_centroid_hz,
    spectrogram,
)

__all__ = [
    "band_decay",
    "largest_fall_db",
    "FLOOR_DB",
    "as_mono",
    "magnitude_spectrum_db",
    "spectrogram",
    "spectral_centroid_hz",
    "attack_centroid_hz",
    "partial_peaks",
    "partial_levels_db",
    "estimate_f0",
    "cents",
    "f0_track",
    "fit_inharmonicity",
    "mode_energies",
    "free_mode_energies",
    "struck_mode_energies",
    "string_energy",
    "grid_energy",
    "mode_levels_db",
    "period_deviation",
    "aperiodic_end",
    "count_episodes",
    "episode_times",
    "decay_curve_db",
    "t60_s",
    "two_stage_decay",
    "two_stage_summary",
    "loudness",
    "momentary_lufs",
    "max_momentary_lufs",
    "peak_dbfs",
    "crest_factor_db",
    "band_levels_db",
    "halo",
    "highband_db",
    "highband_energy",
    "window_energy_db",
    "click_scan",
    "track_partials",
]
