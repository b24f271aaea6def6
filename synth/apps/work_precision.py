"""The summaries of ``tools/work_precision.py`` (issue 13; docs/benchmarks.md,
"Work and precision"), kept in the package so that they are tested from it:

* :func:`orders`: observed orders of convergence from successive errors;
* :func:`capo_summary`: the capo study's quantities of a mode-level vector;
* :func:`note_partials`, :func:`partial_errors`: a note's partials, and
  their errors against a reference render's (also ``tools/quality_levels.py``'s).
"""

from __future__ import annotations

import math

import numpy as np

from ..analysis import track_partials


def orders(errors):
    """log2 of each error over the next (errors on grids refined by 2 each
    time): the observed order of convergence between successive grids."""
    e = np.asarray(errors, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.log2(e[:-1] / e[1:])


#: the modes the capo study reports on (the thesis's)
CAPO_MODES = 40


def capo_summary(d):
    """The thesis's quantities of a level vector: modes 1 and 4, the mean
    of modes 1-5, and over modes 6-40 but 21-25 (the missing mode 23 and
    its neighbours, weakest on the ideal string, whose levels swing by
    tens of dB from grid to grid) the median and the largest gain (with
    its mode)."""
    m = np.arange(1, len(d) + 1)
    far = (m >= 6) & (m <= CAPO_MODES) & ((m < 21) | (m > 25)) & np.isfinite(d)
    j = int(m[far][np.argmax(d[far])]) if far.any() else 0
    return dict(mode1=float(d[0]), mode4=float(d[3]) if len(d) > 3 else math.nan,
                low=float(np.nanmean(d[:5])),
                median=float(np.median(d[far])) if far.any() else math.nan,
                gain=float(d[j - 1]) if j else math.nan, gain_mode=j)


def note_partials(y, fs, f1, B):
    """Partials 1..16 (those under 10 kHz) of a note over 0.05 s on:
    frequencies and levels (:func:`synth.analysis.track_partials`)."""
    seg = y[int(0.05 * fs):]
    n = max(1, min(16, int(10_000 / f1)))
    f, lv, _ = track_partials(seg, fs, f1 / math.sqrt(1 + B), n, inharmonicity=B)
    return f, lv


def partial_errors(f, lv, fr, lr):
    """(partials compared, worst frequency error in cents, worst level
    error in dB) of partials (f, lv) against the reference's (fr, lr), over
    the reference's partials within 40 dB of its strongest."""
    keep = np.isfinite(fr) & np.isfinite(lr) & (lr >= np.nanmax(lr) - 40)
    ok = keep & np.isfinite(f) & np.isfinite(lv)
    if not ok.any():
        return 0, math.nan, math.nan
    return (int(ok.sum()), float(np.max(np.abs(1200 * np.log2(f[ok] / fr[ok])))),
            float(np.max(np.abs(lv[ok] - lr[ok]))))
