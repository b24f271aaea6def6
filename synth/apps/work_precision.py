"""The summaries of ``tools/work_precision.py`` (issue 13; docs/benchmarks.md,
"Work and precision"), kept in the package so that they are tested from it:

* :func:`orders`: observed orders of convergence from successive errors;
* :func:`capo_summary`: the capo study's quantities of a mode-level vector.
"""

from __future__ import annotations

import math

import numpy as np


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
