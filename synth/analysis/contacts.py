"""Contact telemetry: how a string touches its termination and its hammer.

From per-sample probe signals of one string (the number of termination
region points in contact, and the hammer's felt force), at the internal rate
``fs``: time in contact, contact episodes (runs of contact, runs closer
than ``min_gap_s`` merged, as :func:`synth.analysis.regimes.count_episodes`
does), first and last contact, peak force; and the same over time in frames
(``frames``) for a log.
"""

from __future__ import annotations

import numpy as np

from .regimes import _episodes
from .spectrum import _positive, _signal

__all__ = ["contact_summary", "contact_frames"]


def _runs(on, fs, min_gap_s):
    starts, ends = _episodes(on, max(0, int(round(min_gap_s * fs))))
    return starts, ends


def contact_summary(contacts, force_n, fs, min_gap_s=0.0002):
    """Summary of one string's contacts.

    Parameters
    ----------
    contacts : array_like, 1-D
        Termination region points in contact, per sample (>= 0).
    force_n : array_like, 1-D, same length
        Hammer felt force (N) per sample (0 out of contact, or no hammer).
    fs : float
        Sample rate of both (Hz), > 0.
    min_gap_s : float
        Contacts separated by less than this (s) are one episode, >= 0.

    Returns
    -------
    dict
        ``termination``: ``time_in_contact_s``, ``episodes``,
        ``first_contact_s``, ``last_contact_s`` (None without contact),
        ``max_points``; ``hammer``: ``time_in_contact_s``, ``episodes``,
        ``first_contact_s``, ``last_contact_s``, ``peak_force_n``.
    """
    fs = _positive("fs", fs)
    c = _signal("contacts", contacts)
    f = _signal("force_n", force_n)
    if len(c) != len(f):
        raise ValueError(f"contacts has {len(c)} samples and force_n {len(f)}; they must match")
    if min_gap_s < 0:
        raise ValueError(f"min_gap_s={min_gap_s!r} out of range: must be in [0, inf)")
    out = {}
    for name, on in (("termination", c > 0), ("hammer", f > 0)):
        starts, ends = _runs(on, fs, min_gap_s)
        hit = np.flatnonzero(on)
        d = {
            "time_in_contact_s": float(np.count_nonzero(on) / fs),
            "episodes": int(starts.size),
            "first_contact_s": float(hit[0] / fs) if hit.size else None,
            "last_contact_s": float(hit[-1] / fs) if hit.size else None,
        }
        if name == "termination":
            d["max_points"] = int(np.max(c)) if len(c) else 0
        else:
            d["peak_force_n"] = float(np.max(f)) if len(f) else 0.0
        out[name] = d
    return out


def contact_frames(contacts, force_n, fs, frame_s=0.001):
    """The same over time, in frames of ``frame_s`` (s): rows of (frame
    start s, share of samples with termination contact, most points in
    contact, share of samples with hammer contact, peak hammer force N)."""
    fs = _positive("fs", fs)
    frame_s = _positive("frame_s", frame_s)
    c = _signal("contacts", contacts)
    f = _signal("force_n", force_n)
    n = max(1, int(round(frame_s * fs)))
    m = len(c) // n
    if m == 0:
        return np.zeros((0, 5))
    cc = c[:m * n].reshape(m, n)
    ff = f[:m * n].reshape(m, n)
    t = np.arange(m) * n / fs
    return np.column_stack([t, np.mean(cc > 0, axis=1), cc.max(axis=1), np.mean(ff > 0, axis=1),
                            ff.max(axis=1)])
