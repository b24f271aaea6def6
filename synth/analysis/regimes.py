"""Aperiodic -> periodic regime transition, and counting contact episodes.

numpy only.

Period deviation
    The signal is cut into whole periods of P samples, period k covering
    samples ``[k P, (k + 1) P)`` (a trailing partial period is ignored). For
    k >= 1, ``rel_dev[k - 1] = rms_k(x[t] - x[t - P]) / rms_k(x[t])``: how much
    period k differs from period k - 1, relative to its own level. On the
    study grid the period is an exact integer (2N samples).

End of the aperiodic regime (definition used in docs/reproduction.md)
    Let K be the last period with ``20 log10(rel_dev) > threshold_db``.
    Period K - 1 is then the last period that still differs from its successor,
    and from ``t_np = K P / fs`` (the end of period K - 1, the start of period
    K) on, ``x(t + P) = x(t)`` holds to within the threshold. ``t_np`` is
    reported; 0 if no period exceeds the threshold. If the wave stops being
    changed at time t0, t0 <= t_np < t0 + P (to the resolution of the
    threshold). Note the deviation also counts the decay over one period
    (about ``1 - exp(-P / (fs tau))`` for an amplitude time constant tau);
    ``fit_gain=True`` removes a per-period gain first, so only changes of
    wave shape count.
"""

from __future__ import annotations

import numpy as np

from synth.analysis.spectrum import _int, _positive, _real, _signal

__all__ = ["period_deviation", "aperiodic_end", "count_episodes", "episode_times"]


def period_deviation(x, period_samples, fit_gain=False):
    """Relative change of each period with respect to the previous one.

    Parameters
    ----------
    x : array_like, shape (n,)
        Signal (any unit), finite, at least 2 periods long.
    period_samples : int
        Period P in samples, >= 1.
    fit_gain : bool
        If True, compare period k with ``g_k`` times period k - 1, where
        ``g_k = <x_k, x_{k-1}> / <x_{k-1}, x_{k-1}>`` is the least-squares gain
        (removes steady decay). Default False: plain difference.

    Returns
    -------
    ndarray, shape (n // P - 1,)
        Entry k - 1 (k = 1 .. n//P - 1) is ``rms(x_k - x_{k-1}) / rms(x_k)``
        (dimensionless, >= 0) for period k = samples ``[k P, (k+1) P)``;
        0 where both rms are 0, inf where only the period itself is silent.
    """
    P = _int("period_samples", period_samples, 1)
    x = _signal("x", x, 1)
    K = x.size // P
    if K < 2:
        raise ValueError(
            f"x has {x.size} samples, fewer than 2 periods of period_samples={P}"
        )
    seg = x[:K * P].reshape(K, P)
    cur, prev = seg[1:], seg[:-1]
    if fit_gain:
        den = np.sum(prev * prev, axis=1)
        g = np.divide(np.sum(cur * prev, axis=1), den, out=np.ones(K - 1), where=den > 0)
        prev = prev * g[:, None]
    d = np.sqrt(np.mean((cur - prev) ** 2, axis=1))
    r = np.sqrt(np.mean(cur * cur, axis=1))
    out = np.zeros(K - 1)
    nz = r > 0
    out[nz] = d[nz] / r[nz]
    out[~nz & (d > 0)] = np.inf
    return out


def aperiodic_end(x, fs, period_samples, threshold_db=-40.0, fit_gain=False):
    """Time at which the signal becomes periodic (end of the aperiodic regime), in s.

    See the module doc for the definition: with K the last period k >= 1
    whose deviation from period k - 1 exceeds ``threshold_db``, returns
    ``K * period_samples / fs`` (end of period K - 1, the last period that
    still differs from its successor); 0.0 if no period exceeds it.

    Parameters
    ----------
    x : array_like, shape (n,)
        Signal (e.g. string displacement or bridge force at the internal
        rate), finite, at least 2 periods long. Analysis starts at x[0].
    fs : float
        Sample rate of x in Hz, > 0.
    period_samples : int
        Period P in samples, >= 1 (exact integer on the study grid, 2N).
    threshold_db : float
        Deviation level ``20 log10(rel_dev)`` above which a period counts
        as still changing, in [-300, 0]; default -40 dB.
    fit_gain : bool
        Passed to :func:`period_deviation` (True ignores steady decay).

    Returns
    -------
    float
        t_np in s, a multiple of P / fs; 0.0 if the signal is periodic from
        the first period on.
    """
    fs = _positive("fs", fs)
    threshold_db = _real("threshold_db", threshold_db, -300.0, 0.0)
    P = _int("period_samples", period_samples, 1)
    dev = period_deviation(x, P, fit_gain)
    with np.errstate(divide="ignore"):
        dev_db = 20.0 * np.log10(dev)
    above = np.flatnonzero(dev_db > threshold_db)
    if above.size == 0:
        return 0.0
    K = int(above[-1]) + 1  # period index k of entry k - 1
    return K * P / fs


def _indicator(indicator):
    a = np.asarray(indicator)
    if a.ndim != 1:
        raise ValueError(f"indicator must be 1-D, got shape {a.shape}")
    if a.dtype != np.bool_:
        if a.size and (not np.issubdtype(a.dtype, np.number) or not np.all((a == 0) | (a == 1))):
            raise ValueError("indicator must be a boolean array (or 0/1 values)")
        a = a.astype(bool)
    return a


def _episodes(indicator, min_gap_samples):
    """(starts, ends) sample indices of merged True runs; ends exclusive."""
    a = _indicator(indicator)
    gap = _int("min_gap_samples", min_gap_samples, 0)
    d = np.diff(np.concatenate(([0], a.astype(np.int8), [0])))
    starts = np.flatnonzero(d == 1)
    ends = np.flatnonzero(d == -1)
    if starts.size > 1:
        # gap before run j (j >= 1) = starts[j] - ends[j - 1]
        keep = np.concatenate(([True], starts[1:] - ends[:-1] >= gap))
        starts = starts[keep]
        ends = np.concatenate((ends[:-1][keep[1:]], ends[-1:]))
    return starts, ends


def count_episodes(indicator, min_gap_samples):
    """Number of episodes (runs of True), merging runs separated by short gaps.

    Used e.g. for "number of contacts with the sawari by 16.4 ms" (pass the
    contact indicator up to that time).

    Parameters
    ----------
    indicator : array_like of bool, shape (n,)
        True while the event (e.g. contact) is on.
    min_gap_samples : int
        Runs separated by fewer than this many False samples are one episode;
        >= 0 (0 or 1: every run counts).

    Returns
    -------
    int
        Number of episodes.
    """
    return int(_episodes(indicator, min_gap_samples)[0].size)


def episode_times(indicator, fs, min_gap_samples):
    """Start times of the episodes counted by :func:`count_episodes`, in s.

    Parameters
    ----------
    indicator : array_like of bool, shape (n,)
        True while the event is on; sample j is at time j / fs.
    fs : float
        Sample rate of the indicator in Hz, > 0.
    min_gap_samples : int
        Merge gap in samples, >= 0 (see :func:`count_episodes`).

    Returns
    -------
    ndarray, shape (n_episodes,)
        Start time of each episode in s (first True sample / fs).
    """
    fs = _positive("fs", fs)
    return _episodes(indicator, min_gap_samples)[0] / fs
