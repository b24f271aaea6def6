"""Partials followed upward, for series that stray from their law.

Written with recipe 3 of ``docs/architecture.md`` (numpy only, explicit
``fs``, arrays in).

:func:`synth.analysis.partial_peaks` looks for partial n within a fixed
band around ``n f0 sqrt(1 + B n^2)``.  When the real series strays from
that law by more than half the distance to the next partial (a dispersion
filter that follows the stiff-string law only up to some frequency, a
wrong B), the band holds the neighbour, or nothing, and the partial's
identity is lost: the deviation reads at most the band's half width, and
then the next partial's.  :func:`track_partials` follows the series
instead: partial n is searched around the law's frequency *moved by the
deviation of the partials found so far* (in cents, extrapolated linearly
from the last two strong ones), so a deviation that grows smoothly with n
is followed however large it gets.

Each peak is the vertex of a parabola through the log power of the three
bins around the largest bin in the band of the 8x zero-padded spectrum of
the Nuttall-windowed signal (whose main lobe is close to a Gaussian, whose
log is a parabola): on a clean series the frequencies come out within
~0.005 cent and the levels within ~0.01 dB (tests/test_partials.py), at a
small fraction of the cost of the DTFT-Newton refinement of
:func:`partial_peaks`, which matters for 40 partials of 88 keys.
"""

from __future__ import annotations

import math

import numpy as np

from .spectrum import _int, _positive, _real, _signal, _windowed, _zero_padded_power

__all__ = ["track_partials"]


def track_partials(x, fs, f0_hz, n_partials, inharmonicity=0.0, search=0.45, window="nuttall",
                   strong_db=-40.0):
    """Frequency and level of partials 1..N, followed upward from the law
    ``f_n = n f0 sqrt(1 + B n^2)``.

    Parameters
    ----------
    x : array_like, 1-D
        Signal, finite, at least 2 periods of ``f0_hz`` long.
    fs : float
        Sample rate (Hz), > 0.
    f0_hz : float
        f0 of the law (Hz), 0 < f0_hz < fs/2 (for partial 1 at f1:
        ``f0 = f1 / sqrt(1 + B)``).
    n_partials : int
        Partials to follow, >= 1; those whose band reaches fs/2 read NaN.
    inharmonicity : float
        B of the law, in [0, 0.1].
    search : float
        Half width of each search band as a fraction of the distance (in
        cents) to the next partial of the law, in (0, 0.5]: partial n is
        searched within ``+- search * 1200 log2(f_(n+1) / f_n)`` cents of its
        predicted frequency.
    window : str
        Analysis window (see :func:`synth.analysis.partial_peaks`).
    strong_db : float
        Only partials within this of the strongest found so far (dB, < 0)
        steer the prediction; weaker ones are still measured.

    Returns
    -------
    freqs_hz : ndarray, shape (n_partials,)
        Peak frequency of each partial (Hz); NaN where the band reaches fs/2.
    levels_db : ndarray, shape (n_partials,)
        Peak level (dB re amplitude 1, as :func:`partial_peaks`); NaN there too.
    deviation_cents : ndarray, shape (n_partials,)
        ``1200 log2(freq / law)``: the measured series against the law.
    """
    fs = _positive("fs", fs)
    f0_hz = _real("f0_hz", f0_hz, 0.0, fs / 2, low_open=True, high_open=True)
    n_partials = _int("n_partials", n_partials, 1)
    B = _real("inharmonicity", inharmonicity, 0.0, 0.1)
    search = _real("search", search, 0.0, 0.5, low_open=True)
    strong_db = _real("strong_db", strong_db, -200.0, 0.0, high_open=True)
    x = _signal("x", x, max(4, int(math.ceil(2.0 * fs / f0_hz))))
    if np.ptp(x) == 0.0:
        raise ValueError("x is constant; partials undefined")
    xw, wsum = _windowed(x, window)
    p2, n_fft = _zero_padded_power(xw, pad_factor=8)
    df = fs / n_fft
    with np.errstate(divide="ignore"):
        lp = np.log(np.maximum(p2, 1e-300))

    def peak(lo, hi):
        k0, k1 = int(math.ceil(lo / df)), int(math.floor(hi / df))
        if k1 < k0:
            k1 = k0
        k = k0 + int(np.argmax(p2[k0:k1 + 1]))
        if k0 < k < k1:
            a, b, c = lp[k - 1], lp[k], lp[k + 1]
            den = a - 2.0 * b + c
            d = 0.5 * (a - c) / den if den < 0 else 0.0
            return (k + d) * df, b - 0.25 * (a - c) * d, False
        return k * df, lp[k], True
    n = np.arange(1, n_partials + 2)
    law = n * f0_hz * np.sqrt(1.0 + B * n * n)
    freqs = np.full(n_partials, np.nan)
    levels = np.full(n_partials, np.nan)
    dev = np.full(n_partials, np.nan)
    steer: list[int] = []                     # indices of the strong partials so far
    top = -np.inf
    for i in range(n_partials):
        if len(steer) >= 2:
            a, b = steer[-2], steer[-1]
            pred = dev[b] + (dev[b] - dev[a]) * (i - b) / (b - a)
        elif steer:
            pred = dev[steer[-1]]
        else:
            pred = 0.0
        half = search * 1200.0 * math.log2(law[i + 1] / law[i])
        fc = law[i] * 2.0 ** (pred / 1200.0)
        lo, hi = fc * 2.0 ** (-half / 1200.0), fc * 2.0 ** (half / 1200.0)
        if hi >= fs / 2:
            break
        f, logp, on_edge = peak(lo, hi)
        lv = float(10.0 * logp / math.log(10.0) + 20.0 * math.log10(2.0 / wsum))
        freqs[i], levels[i] = f, lv
        dev[i] = 1200.0 * math.log2(f / law[i])
        top = max(top, lv)
        # a peak on the band's edge is no partial found: it does not steer
        if lv >= top + strong_db and not on_edge:
            steer.append(i)
    return freqs, levels, dev
