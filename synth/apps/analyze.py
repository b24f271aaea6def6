"""``synth analyze``: what a note is made of, from a WAV file or a render.

:func:`analyze_audio` measures a mono signal with :mod:`synth.analysis`:
the partials (frequency, level re the strongest, cents against the harmonic
series of partial 1 and against the fitted stiff-string law
f_n = n f0 sqrt(1 + B n^2), with B), each partial's decay (one T60, and the
two-stage fit: early and late T60 and the knee), the spectral centroid over
time, and loudness (BS.1770 integrated and maximum momentary through
pyloudnorm, sample peak, crest factor).  The result is a JSON-able dict
whose format is documented in ``docs/analyze.md`` (``schema`` 1);
:func:`format_report` prints it as a table and :func:`plot_report` draws
the PNG (matplotlib, the ``[plots]`` extra).
"""

from __future__ import annotations

import math

import numpy as np

from ..analysis import (
    cents,
    estimate_f0,
    fit_inharmonicity,
    loudness,
    magnitude_spectrum_db,
    partial_peaks,
    spectral_centroid_hz,
    two_stage_decay,
)
from ..analysis.decay import decay_curve_db
from ..io.errors import SynthError

__all__ = ["REPORT_SCHEMA", "analyze_audio", "format_report", "plot_report"]

REPORT_SCHEMA = 2
#: a spectral peak stands out of its neighbourhood's median power by this
#: much (dB) to count as a partial: white noise's highest bins read 10-13 dB
#: over the median (an exponential's tail), a plucked or struck note's
#: partials 25-60 dB
PROMINENCE_DB = 15.0
#: a sound has a pitch when at least this share of its power (20 Hz-0.45 fs,
#: over the measured window) is in prominent partials: white, pink and brown
#: noise read 0 (once 0.07 in 24 draws of 2 s), the shipped presets' notes
#: (sitar, biwa, harpsichord, hammered sitar, grand A0, C4, E7) 0.99-1
MIN_HARMONICITY = 0.3
#: partials fitted to the stiff-string law: those within this of the strongest (dB)
FIT_RANGE_DB = 60.0
#: the partials are measured over this window after the onset (s)
WINDOW_START_S, WINDOW_S = 0.05, 1.0


def _onset(x, fs):
    """First sample within 40 dB of the peak."""
    a = np.abs(x)
    return int(np.flatnonzero(a >= 0.01 * a.max())[0])


def _guess_f1(seg, fs):
    """Without a key: the strongest spectral peak between 20 Hz and 5 kHz,
    refined, taken as partial 1."""
    f, db = magnitude_spectrum_db(seg, fs)
    band = (f >= 20.0) & (f <= 5000.0)
    return float(f[band][np.argmax(db[band])])


def harmonicity(seg, fs):
    """The share of the power of ``seg`` (Hann window, 20 Hz to 0.45 fs) in
    prominent peaks: bins that stand :data:`PROMINENCE_DB` over the median
    power within 100 Hz either side (a running median), with the 3 bins
    either side of each.  It needs no pitch to be guessed right (a guess at
    partial 2 or 3 does not halve it), and inharmonic partials count as
    harmonic ones: 0 for noise, whatever its colour (no bin stands 15 dB out
    of its neighbours), near 1 for a plucked or struck note."""
    from scipy.ndimage import maximum_filter1d, median_filter

    seg = np.asarray(seg, float)
    n = len(seg)
    p = np.abs(np.fft.rfft(np.hanning(n) * (seg - seg.mean()))) ** 2
    df = fs / n
    f = np.arange(len(p)) * df
    band = (f >= 20.0) & (f <= 0.45 * fs)
    total = float(p[band].sum())
    if not total > 0.0:
        return 0.0
    w = 2 * max(int(round(100.0 / df)), 8) + 1
    floor = median_filter(p, size=w, mode="nearest")
    peak = (p > 10.0 ** (PROMINENCE_DB / 10.0) * np.maximum(floor, 1e-300)) & band
    tonal = maximum_filter1d(peak.astype(np.uint8), size=7) > 0
    return min(float(p[tonal & band].sum()) / total, 1.0)


def _num(v):
    return None if v is None or not math.isfinite(v) else float(v)


def analyze_audio(x, fs, key=None, f0_hz=None, n_partials=12):
    """Analyse one note.

    Parameters
    ----------
    x : array_like, 1-D
        The note (full scale 1), starting before or at its onset.
    fs : float
        Sample rate (Hz).
    key, f0_hz : float or None
        Expected pitch: a MIDI key (A4 = 440 Hz) or a frequency (Hz), used
        as the search hint for partial 1 (and ``expected_hz``); with neither, the strongest
        spectral peak between 20 Hz and 5 kHz is taken as partial 1.
    n_partials : int
        Partials to measure, 1 .. 64 (fewer if they reach 0.45 fs).

    Returns
    -------
    dict
        See ``docs/analyze.md``.

    Raises
    ------
    SynthError
        Silence, or a note too short to measure (one line).

    A sound without a pitch (noise: under :data:`MIN_HARMONICITY` of its
    power in prominent partials, :func:`harmonicity`) has ``pitched``
    false, no ``partials`` and null ``partial1_hz``, ``f0_fit_hz`` and
    ``inharmonicity_b``.
    """
    x = np.asarray(x, dtype=np.float64)
    fs = float(fs)
    if x.ndim != 1 or len(x) < int(0.1 * fs):
        raise SynthError(f"the audio is {len(x) / fs:.3f} s long; at least 0.1 s is needed")
    if not np.any(x):
        raise SynthError("the audio is silent: nothing to analyse")
    if not (1 <= int(n_partials) <= 64):
        raise SynthError(f"--partials = {n_partials} is out of range (1 <= value <= 64)")
    on = _onset(x, fs)
    a = on + int(WINDOW_START_S * fs)
    seg = x[a:a + int(WINDOW_S * fs)]
    if len(seg) < int(0.05 * fs):
        seg = x[on:]
    hint = f0_hz if f0_hz is not None else (440.0 * 2.0 ** ((key - 69) / 12.0) if key is not None
                                            else _guess_f1(seg, fs))
    f1 = estimate_f0(seg, fs, hint, search_cents=60.0)
    n = max(1, min(int(n_partials), int(0.45 * fs // f1)))
    freqs, levels = partial_peaks(seg, fs, f1, n, search_cents=40.0)
    B, f0_fit = 0.0, f1

    def fitted():
        # partials more than 60 dB under the strongest are noise, not partials
        return np.flatnonzero(np.isfinite(freqs) & (levels >= np.nanmax(levels) - FIT_RANGE_DB))

    ok = fitted()
    if ok.size >= 3:
        f0_fit, B = fit_inharmonicity(freqs[ok], ok + 1)
        if 0.0 < B <= 0.1:      # search again around the stiff-string law
            freqs, levels = partial_peaks(seg, fs, f0_fit, n, search_cents=40.0, inharmonicity=B)
            ok = fitted()
            f0_fit, B = fit_inharmonicity(freqs[ok], ok + 1)
    harm = harmonicity(seg, fs)
    ld = loudness(x, fs)
    common = {
        "schema": REPORT_SCHEMA,
        "fs_hz": fs,
        "duration_s": len(x) / fs,
        "onset_s": on / fs,
        "loudness": {k: _num(v) for k, v in ld.items()},
        "pitched": bool(harm >= MIN_HARMONICITY),
        "harmonicity": float(harm),
    }
    if harm < MIN_HARMONICITY:
        # noise: the peaks found near n f1 are no partials; none are reported
        return {**common, "partial1_hz": None, "f0_fit_hz": None, "inharmonicity_b": None,
                "expected_hz": None if key is None and f0_hz is None else float(hint),
                "partials": [], "centroid": _centroid(x, fs, on)}
    top = np.nanmax(levels)
    partials = []
    for i in range(n):
        k = i + 1
        f = freqs[i]
        row = {"n": k, "freq_hz": _num(f), "level_db": _num(levels[i] - top)}
        if math.isfinite(f):
            row["cents_harmonic"] = float(cents(f, k * freqs[0]))
            row["cents_stiff"] = float(cents(f, k * f0_fit * math.sqrt(1.0 + B * k * k)))
            try:
                d = two_stage_decay(x[on:], fs, f_hz=f)
            except ValueError:
                d = {"t60_s": None, "t60_early_s": None, "t60_late_s": None, "knee_s": None}
            for name, v in d.items():
                row[name] = _num(v)
        partials.append(row)
    return {
        **common,
        "partial1_hz": float(freqs[0]) if math.isfinite(freqs[0]) else float(f1),
        "f0_fit_hz": float(f0_fit),
        "inharmonicity_b": float(B),
        "expected_hz": None if hint is None or (key is None and f0_hz is None) else float(hint),
        "partials": partials,
        "centroid": _centroid(x, fs, on),
    }


def _centroid(x, fs, on) -> dict:
    """The spectral centroid over time: 50 ms frames from the onset, frames
    60 dB under the loudest skipped."""
    hop = int(0.05 * fs)
    frames = [(s, x[s:s + hop]) for s in range(on, len(x) - hop + 1, hop)]
    rms = np.array([np.sqrt(np.mean(w * w)) for _, w in frames]) if frames else np.zeros(0)
    times, cents_hz = [], []
    for (s, w), r in zip(frames, rms):
        if r > 1e-3 * rms.max() and np.ptp(w) > 0:
            times.append(round((s - on) / fs, 6))
            cents_hz.append(float(spectral_centroid_hz(w, fs)))
    return {"time_s": times, "centroid_hz": cents_hz}


def _f(v, fmt, none="-"):
    return none if v is None else format(v, fmt)


def format_report(r: dict, title: str = "") -> str:
    """The report as a readable table."""
    ld = r["loudness"]
    lines = []
    if title:
        lines.append(title)
    lines.append(f"peak {_f(ld['peak_dbfs'], '.1f')} dBFS, crest {_f(ld['crest_factor_db'], '.1f')} dB, "
                 f"loudness {_f(ld['integrated_lufs'], '.1f')} LUFS integrated, "
                 f"{_f(ld['max_momentary_lufs'], '.1f')} LUFS max momentary")
    exp = r["expected_hz"]
    if not r.get("pitched", True):
        lines.append(f"no pitch: only {100 * r['harmonicity']:.0f} % of the power is in partials "
                     f"(a note has over {100 * MIN_HARMONICITY:.0f} %); noise, not a note: no "
                     f"partials measured")
    else:
        dev = f" ({cents(r['partial1_hz'], exp):+.2f} cent from {exp:.3f} Hz)" if exp else ""
        lines.append(f"partial 1 {r['partial1_hz']:.3f} Hz{dev}; stiff-string fit f0 "
                     f"{r['f0_fit_hz']:.3f} Hz, B = {r['inharmonicity_b']:.3g}")
    c = r["centroid"]["centroid_hz"]
    if c:
        lines.append(f"spectral centroid {c[0]:.0f} Hz at the onset, {c[len(c) // 2]:.0f} Hz at "
                     f"{r['centroid']['time_s'][len(c) // 2]:.2f} s, {c[-1]:.0f} Hz at "
                     f"{r['centroid']['time_s'][-1]:.2f} s")
    if not r["partials"]:
        return "\n".join(lines)
    lines.append("")
    head = ("n", "freq Hz", "level dB", "cents harm", "cents stiff", "T60 s", "early s", "late s",
            "knee s")
    rows = [head]
    for p in r["partials"]:
        rows.append((str(p["n"]), _f(p["freq_hz"], ".2f"), _f(p["level_db"], ".1f"),
                     _f(p.get("cents_harmonic"), "+.2f"), _f(p.get("cents_stiff"), "+.2f"),
                     _f(p.get("t60_s"), ".2f"), _f(p.get("t60_early_s"), ".2f"),
                     _f(p.get("t60_late_s"), ".2f"), _f(p.get("knee_s"), ".2f")))
    w = [max(len(row[i]) for row in rows) for i in range(len(head))]
    for row in rows:
        lines.append("  ".join(c.rjust(w[i]) for i, c in enumerate(row)))
    return "\n".join(lines)


def plot_report(x, fs, r: dict, path: str, title: str = "") -> None:
    """One PNG: log-frequency spectrogram with the partials marked, the
    partials' decay curves, and the centroid over time (needs matplotlib,
    the ``[plots]`` extra)."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise SynthError('--plot needs the [plots] extra: pip install "synth[plots]"') from None
    x = np.asarray(x, float)
    fig, ax = plt.subplots(3, 1, figsize=(10, 10), height_ratios=(3, 2, 1.3))
    n_fft = 4096
    ax[0].specgram(x, NFFT=n_fft, Fs=fs, noverlap=n_fft * 3 // 4, cmap="magma", vmin=-150)
    ax[0].set_yscale("log")
    ax[0].set_ylim(max(20.0, 0.5 * (r["partial1_hz"] or 40.0)), fs / 2)
    for p in r["partials"]:
        if p["freq_hz"]:
            ax[0].axhline(p["freq_hz"], color="c", lw=0.5, ls="--")
    ax[0].set_ylabel("Hz")
    ax[0].set_title(title or "spectrogram (dashed: the measured partials)")
    on = int(r["onset_s"] * fs)
    for p in r["partials"][:8]:
        if p["freq_hz"]:
            t, db = decay_curve_db(x[on:], fs, f_hz=p["freq_hz"])
            ax[1].plot(t, db, lw=0.8, label=f"{p['n']}")
    ax[1].set_ylabel("partial level, dB")
    ax[1].set_ylim(-140, 0)
    ax[1].legend(title="partial", ncol=8, fontsize=7)
    ax[2].plot(r["centroid"]["time_s"], r["centroid"]["centroid_hz"])
    ax[2].set_ylabel("centroid, Hz")
    ax[2].set_xlabel("time after the onset, s")
    fig.tight_layout()
    import io

    from ..io.wav import write_bytes_atomic

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=80)
    plt.close(fig)
    write_bytes_atomic(path, buf.getvalue())
