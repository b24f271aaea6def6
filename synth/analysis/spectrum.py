"""Spectra, spectrograms, spectral centroid and harmonic partial levels.

numpy only. Every level returned here is in **dB re amplitude 1**: a steady
sinusoid ``A sin(2 pi f t)`` reads ``20 log10(A)`` at its peak (for a peak
lying exactly on an FFT bin, or after the peak refinement of
:func:`partial_peaks`), whatever the window or FFT length. The window's
coherent gain is divided out (``|X| * 2 / sum(w)``; ``|X| / sum(w)`` at DC and
Nyquist) so levels of different analyses can be compared directly. Levels are
floored at :data:`FLOOR_DB` instead of ``-inf``.

Also holds the private helpers shared by the ``synth.analysis`` modules
(argument checks, windows, and the direct-DTFT peak refinement used by
:mod:`synth.analysis.pitch`).
"""

from __future__ import annotations

import math
import numbers

import numpy as np

__all__ = [
    "FLOOR_DB",
    "magnitude_spectrum_db",
    "spectrogram",
    "spectral_centroid_hz",
    "attack_centroid_hz",
    "partial_peaks",
    "partial_levels_db",
]

#: Level (dB) reported for zero amplitude / energy instead of -inf.
FLOOR_DB = -300.0

WINDOWS = ("hann", "hamming", "blackman", "blackmanharris", "nuttall", "rect")


# --------------------------------------------------------------------------
# private helpers shared by the analysis package
# --------------------------------------------------------------------------


def as_mono(x):
    """A signal as one channel: a 1-D array as it is, an (n, channels) array
    (a stereo render or file, soundfile's layout) as the mean of its
    channels.  Raises ValueError for other shapes."""
    a = np.asarray(x, dtype=np.float64)
    if a.ndim == 1:
        return a
    if a.ndim == 2 and 1 <= a.shape[1] <= 16:
        return a.mean(axis=1)
    raise ValueError(f"x has shape {a.shape}; must be (n,) or (n, channels) with 1-16 channels")

def _real(name, value, low=None, high=None, low_open=False, high_open=False):
    """Return ``value`` as a finite float within the bounds, or raise a one-line ValueError."""
    lo_b = "(" if low_open else "["
    hi_b = ")" if high_open else "]"
    rng = f"{lo_b}{'-inf' if low is None else low}, {'inf' if high is None else high}{hi_b}"
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{name}={value!r} must be a real number in {rng}")
    v = float(value)
    bad = not math.isfinite(v)
    if low is not None:
        bad = bad or (v <= low if low_open else v < low)
    if high is not None:
        bad = bad or (v >= high if high_open else v > high)
    if bad:
        raise ValueError(f"{name}={value!r} out of range: must be in {rng}")
    return v


def _positive(name, value):
    """A finite float > 0 (one-line ValueError otherwise)."""
    return _real(name, value, 0.0, None, low_open=True)


def _int(name, value, low, high=None):
    """Return ``value`` as an int in [low, high], or raise a one-line ValueError."""
    rng = f"[{low}, {'inf' if high is None else high}]"
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        if isinstance(value, numbers.Real) and not isinstance(value, bool) \
                and math.isfinite(float(value)) and float(value) == math.floor(float(value)):
            value = int(value)
        else:
            raise ValueError(f"{name}={value!r} must be an integer in {rng}")
    v = int(value)
    if v < low or (high is not None and v > high):
        raise ValueError(f"{name}={v} out of range: must be an integer in {rng}")
    return v


def _signal(name, x, min_len=1):
    """Return ``x`` as a 1-D finite float64 array of length >= min_len (one-line ValueError)."""
    try:
        a = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a 1-D array of real numbers, got {type(x).__name__}") from None
    if a.ndim != 1:
        raise ValueError(f"{name} must be 1-D, got shape {a.shape}")
    if a.size < min_len:
        raise ValueError(f"{name} has {a.size} samples; at least {min_len} required")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} contains NaN or infinite values; all samples must be finite")
    return a


def _window(name, n):
    """Symmetric window ``name`` of ``n`` points (float64); one-line ValueError for unknown names."""
    if not isinstance(name, str) or name not in WINDOWS:
        raise ValueError(f"window={name!r} unknown; allowed: {', '.join(WINDOWS)}")
    if n == 1 or name == "rect":
        return np.ones(n)
    ph = 2.0 * np.pi * np.arange(n) / (n - 1)
    if name == "hann":
        return 0.5 - 0.5 * np.cos(ph)
    if name == "hamming":
        return 0.54 - 0.46 * np.cos(ph)
    if name == "blackman":
        return 0.42 - 0.5 * np.cos(ph) + 0.08 * np.cos(2 * ph)
    if name == "nuttall":
        # Nuttall's minimum 4-term window with continuous first derivative
        # (-93 dB sidelobes decaying 18 dB/octave)
        return (0.355768 - 0.487396 * np.cos(ph) + 0.144232 * np.cos(2 * ph)
                - 0.012604 * np.cos(3 * ph))
    # 4-term Blackman-Harris (-92 dB sidelobes decaying 6 dB/octave)
    return (0.35875 - 0.48829 * np.cos(ph) + 0.14128 * np.cos(2 * ph)
            - 0.01168 * np.cos(3 * ph))


def _next_pow2(n):
    return 1 << max(0, int(n - 1).bit_length())


def _amp_to_db(a):
    """20 log10(a) floored at FLOOR_DB."""
    a = np.asarray(a, dtype=np.float64)
    with np.errstate(divide="ignore"):
        return np.maximum(20.0 * np.log10(a), FLOOR_DB)


def _one_sided_amplitude(spec, n_fft, wsum):
    """Amplitude scale (re 1) of an rfft: 2|X|/sum(w), |X|/sum(w) at DC and Nyquist."""
    amp = np.abs(spec) * (2.0 / wsum)
    amp[..., 0] *= 0.5
    if n_fft % 2 == 0:
        amp[..., -1] *= 0.5
    return amp


class _Dtft:
    """|DTFT|^2 of a windowed, de-meaned segment, evaluated directly at any f.

    ``P(f) = |sum_n xw[n] exp(-2 pi i f t_n)|^2`` with ``t_n`` centred on the
    segment (so the derivatives are well conditioned); also ``P'`` and ``P''``
    for Newton steps. Cost O(len(segment)) per evaluation.
    """

    def __init__(self, xw, fs):
        self.xw = xw
        self.t = (np.arange(xw.size) - 0.5 * (xw.size - 1)) / fs
        self.t2 = self.t * self.t

    def value(self, f):
        ph = (2.0 * np.pi * f) * self.t
        c = np.dot(self.xw, np.cos(ph))
        s = np.dot(self.xw, np.sin(ph))
        return c * c + s * s

    def derivs(self, f):
        # in real arithmetic: e = xw exp(-i ph) = xc - i xs, and the sums
        # x_m = sum e (-2 pi i t)^m from real dot products (2.3x faster than
        # complex arrays on 96000 samples)
        ph = (2.0 * np.pi * f) * self.t
        xc = self.xw * np.cos(ph)
        xs = self.xw * np.sin(ph)
        w = 2.0 * np.pi
        x0 = complex(xc.sum(), -xs.sum())
        x1 = complex(-w * np.dot(xs, self.t), -w * np.dot(xc, self.t))
        x2 = -w * w * complex(np.dot(xc, self.t2), -np.dot(xs, self.t2))
        p = abs(x0) ** 2
        d1 = 2.0 * (x1 * x0.conjugate()).real
        d2 = 2.0 * (x2 * x0.conjugate()).real + 2.0 * abs(x1) ** 2
        return p, d1, d2


def _windowed(x, window):
    """Window ``x`` after removing its window-weighted mean (exactly zero DC)."""
    w = _window(window, x.size)
    wsum = w.sum()
    xw = w * (x - np.dot(w, x) / wsum)
    return xw, wsum


def _refine_peak(dt, f_lo, f_hi, grid_f, grid_p):
    """Frequency (Hz) of the maximum of |DTFT| in [f_lo, f_hi].

    ``grid_f``/``grid_p`` are a coarse sampling of P over the band (sorted,
    including both band edges). The grid maximum and its neighbours bracket
    the peak; P'(f) = 0 is then solved by safeguarded Newton (bisection when a
    Newton step leaves the bracket or P'' >= 0). If the maximum sits on a band
    edge and P still rises outwards, that edge is returned.
    """
    k = int(np.argmax(grid_p))
    a = grid_f[max(k - 1, 0)]
    b = grid_f[min(k + 1, grid_f.size - 1)]
    _, ga, _ = dt.derivs(a)
    _, gb, _ = dt.derivs(b)
    if not (ga > 0.0 and gb < 0.0):
        # No interior stationary point in the bracket: constrained maximum.
        cands = [a, grid_f[k], b]
        return max(cands, key=dt.value)
    f = grid_f[k]
    # 1e-11 of the frequency (1.7e-8 cent): at 1e-13 Newton's steps met the
    # round-off of P' and bisection went on to the tolerance (8.9 DTFT
    # evaluations a peak on average, up to 34, each O(len(segment))); at
    # 1e-11, 3.8 and at most 25, `synth analyze`'s measures of four 1 s
    # notes 2.14 -> 1.00 s, and the partials' frequencies move by at most
    # 1.0e-11 of themselves
    tol = 1e-11 * max(abs(f_hi), 1.0)
    for _ in range(100):
        _, g, h = dt.derivs(f)
        if g > 0.0:
            a = f
        else:
            b = f
        step = -g / h if h < 0.0 else np.inf
        f_new = f + step
        if not (a < f_new < b):
            f_new = 0.5 * (a + b)
        if abs(f_new - f) <= tol or (b - a) <= tol:
            return f_new
        f = f_new
    return f


def _peak_in_band(xw, fs, spec_amp2, n_fft, f_lo, f_hi, dt=None):
    """Refined peak frequency in [f_lo, f_hi] given the zero-padded |rfft|^2 of xw."""
    if dt is None:
        dt = _Dtft(xw, fs)
    df = fs / n_fft
    k0 = int(math.ceil(f_lo / df))
    k1 = int(math.floor(f_hi / df))
    kk = np.arange(max(k0, 0), min(k1, spec_amp2.size - 1) + 1)
    fk = kk * df
    pk = spec_amp2[kk]
    # band edges evaluated directly so narrow bands (< one bin) still work
    grid_f = np.concatenate(([f_lo], fk[(fk > f_lo) & (fk < f_hi)], [f_hi]))
    grid_p = np.concatenate(([dt.value(f_lo)], pk[(fk > f_lo) & (fk < f_hi)], [dt.value(f_hi)]))
    return _refine_peak(dt, f_lo, f_hi, grid_f, grid_p), dt


def _zero_padded_power(xw, pad_factor=4):
    n_fft = _next_pow2(pad_factor * xw.size)
    spec = np.fft.rfft(xw, n_fft)
    return spec.real ** 2 + spec.imag ** 2, n_fft


# --------------------------------------------------------------------------
# public functions
# --------------------------------------------------------------------------

def magnitude_spectrum_db(x, fs, window="hann", n_fft=None):
    """One-sided magnitude spectrum of a whole signal, in dB re amplitude 1.

    Parameters
    ----------
    x : array_like, shape (n,)
        Signal (any unit U, e.g. m or a normalised amplitude); n >= 2, finite.
    fs : float
        Sample rate of ``x`` in Hz, > 0.
    window : {"hann", "hamming", "blackman", "blackmanharris", "nuttall", "rect"}
        Symmetric analysis window spanning the whole signal.
    n_fft : int, optional
        FFT length >= n (zero padding); default the next power of two >= n.

    Returns
    -------
    freqs_hz : ndarray, shape (n_fft // 2 + 1,)
        Bin frequencies in Hz, 0 ... fs/2.
    level_db : ndarray, shape (n_fft // 2 + 1,)
        ``20 log10(|X| * 2 / sum(w))`` (no factor 2 at DC and Nyquist): a
        sinusoid of amplitude A (unit U) centred on a bin reads 20 log10(A)
        dB re 1 U. Floored at :data:`FLOOR_DB`. No mean is removed.
    """
    x = _signal("x", x, 2)
    fs = _positive("fs", fs)
    n_fft = _next_pow2(x.size) if n_fft is None else _int("n_fft", n_fft, x.size)
    w = _window(window, x.size)
    spec = np.fft.rfft(w * x, n_fft)
    amp = _one_sided_amplitude(spec, n_fft, w.sum())
    return np.fft.rfftfreq(n_fft, 1.0 / fs), _amp_to_db(amp)


def spectrogram(x, fs, window_s=0.045, overlap=0.55, n_fft=None, window="hann"):
    """Short-time magnitude spectrum (the thesis's Hann 45 ms, 55 % overlap).

    Frames of ``nperseg = round(window_s * fs)`` samples start at 0, hop,
    2 hop, ... with ``hop = max(1, round(nperseg * (1 - overlap)))``; only
    frames that fit entirely inside ``x`` are analysed (no padding).

    Parameters
    ----------
    x : array_like, shape (n,)
        Signal (unit U), n >= nperseg, finite.
    fs : float
        Sample rate in Hz, > 0.
    window_s : float
        Frame length in s, > 0 (at least 2 samples); default 0.045.
    overlap : float
        Fraction of a frame shared with the next one, in [0, 1); default 0.55.
    n_fft : int, optional
        FFT length >= nperseg; default next power of two >= nperseg.
    window : str
        Window name (see :func:`magnitude_spectrum_db`); default "hann".

    Returns
    -------
    times_s : ndarray, shape (n_frames,)
        Frame centres ``(start + nperseg / 2) / fs`` in s.
    freqs_hz : ndarray, shape (n_fft // 2 + 1,)
        Bin frequencies in Hz.
    level_db : ndarray, shape (n_fft // 2 + 1, n_frames)
        Level in dB re amplitude 1 (same scaling as
        :func:`magnitude_spectrum_db`), frequency along axis 0.
    """
    fs = _positive("fs", fs)
    window_s = _positive("window_s", window_s)
    overlap = _real("overlap", overlap, 0.0, 1.0, high_open=True)
    nperseg = int(round(window_s * fs))
    if nperseg < 2:
        raise ValueError(f"window_s={window_s} s gives {nperseg} samples at fs={fs} Hz; need >= 2")
    x = _signal("x", x, nperseg)
    n_fft = _next_pow2(nperseg) if n_fft is None else _int("n_fft", n_fft, nperseg)
    hop = max(1, int(round(nperseg * (1.0 - overlap))))
    starts = np.arange(0, x.size - nperseg + 1, hop)
    w = _window(window, nperseg)
    frames = np.lib.stride_tricks.sliding_window_view(x, nperseg)[starts] * w
    spec = np.fft.rfft(frames, n_fft, axis=-1)
    amp = _one_sided_amplitude(spec, n_fft, w.sum())
    times = (starts + 0.5 * nperseg) / fs
    return times, np.fft.rfftfreq(n_fft, 1.0 / fs), _amp_to_db(amp).T


def spectral_centroid_hz(x, fs, weighting="magnitude", window="hann"):
    """Spectral centroid of a whole signal, in Hz.

    ``sum_k f_k W_k / sum_k W_k`` over the one-sided, 8x zero-padded spectrum
    of the windowed signal (mean removed first, so DC does not pull the
    centroid down), with ``W_k = |X_k|`` ("magnitude", the usual definition)
    or ``|X_k|^2`` ("power"). The zero padding makes the result insensitive to
    where partials fall relative to the bins (a lone sinusoid at f gives f to
    a small fraction of a bin).

    Parameters
    ----------
    x : array_like, shape (n,)
        Signal, n >= 2, finite, not constant.
    fs : float
        Sample rate in Hz, > 0.
    weighting : {"magnitude", "power"}
    window : str
        Window name (see :func:`magnitude_spectrum_db`); default "hann".

    Returns
    -------
    float
        Centroid in Hz, in [0, fs/2].
    """
    x = _signal("x", x, 2)
    fs = _positive("fs", fs)
    if weighting not in ("magnitude", "power"):
        raise ValueError(f"weighting={weighting!r} unknown; allowed: magnitude, power")
    if np.ptp(x) == 0.0:
        raise ValueError("x is constant; spectral centroid undefined")
    xw, _ = _windowed(x, window)
    n_fft = _next_pow2(8 * x.size)
    a = np.abs(np.fft.rfft(xw, n_fft))
    if weighting == "power":
        a = a * a
    tot = a.sum()
    f = np.fft.rfftfreq(n_fft, 1.0 / fs)
    return float(np.dot(f, a) / tot)


def attack_centroid_hz(x, fs, length_s=0.1, fade_s=0.01):
    """Spectral centroid (Hz) of the first ``length_s`` of a note, flat
    window with a half-Hann fade over its last ``fade_s``, so the attack
    counts in full (the voicing report's brightness of an attack, and the
    una corda's test on it)."""
    n, m = int(round(length_s * fs)), int(round(fade_s * fs))
    seg = np.array(x[:n], dtype=np.float64)
    seg[n - m:] *= 0.5 + 0.5 * np.cos(np.pi * np.arange(m) / m)
    return float(spectral_centroid_hz(seg, fs, window="rect"))


def partial_peaks(x, fs, f0_hz, n_partials, search_cents=50.0, window="nuttall",
                  inharmonicity=0.0):
    """Frequency and level of each partial (peak near n * f0, or a stiff-string guess).

    For n = 1 .. n_partials the maximum of |DTFT| of the windowed, de-meaned
    signal within ``f_n 2^(+-search_cents/1200)``, ``f_n = n f0 sqrt(1 + B n^2)``
    (B = ``inharmonicity``, 0 for harmonic partials), is located (zero-padded FFT,
    then Newton on the DTFT evaluated directly) and its level read there, so
    neither scalloping nor the FFT grid biases frequency or level.

    Parameters
    ----------
    x : array_like, shape (n,)
        Signal (unit U), finite, at least 2 periods of f0 long.
    fs : float
        Sample rate in Hz, > 0.
    f0_hz : float
        Nominal fundamental in Hz, 0 < f0_hz < fs/2.
    n_partials : int
        Number of partials, >= 1.
    search_cents : float
        Half-width of each search band in cents, in (0, 600].
    window : str
        Window name; default "nuttall" (little leakage between neighbouring
        partials, see :mod:`synth.analysis.pitch`).
    inharmonicity : float
        Guess of the stiff-string coefficient B used to centre the search
        bands, in [0, 0.1]; default 0. Iterate with
        :func:`synth.analysis.fit_inharmonicity` for strongly stiff strings.

    Returns
    -------
    freqs_hz : ndarray, shape (n_partials,)
        Peak frequency of each partial in Hz; NaN where the band reaches fs/2.
        Bands wider than half the partial spacing may catch a neighbour.
    levels_db : ndarray, shape (n_partials,)
        Peak level in dB re amplitude 1 U (a steady partial of amplitude A
        reads 20 log10 A; a decaying one its window-weighted mean amplitude);
        NaN where the band reaches fs/2.
    """
    fs = _positive("fs", fs)
    f0_hz = _real("f0_hz", f0_hz, 0.0, fs / 2, low_open=True, high_open=True)
    n_partials = _int("n_partials", n_partials, 1)
    search_cents = _real("search_cents", search_cents, 0.0, 600.0, low_open=True)
    B = _real("inharmonicity", inharmonicity, 0.0, 0.1)
    x = _signal("x", x, max(4, int(math.ceil(2.0 * fs / f0_hz))))
    if np.ptp(x) == 0.0:
        raise ValueError("x is constant; partial peaks undefined")
    xw, wsum = _windowed(x, window)
    p2, n_fft = _zero_padded_power(xw)
    dt = _Dtft(xw, fs)
    r = 2.0 ** (search_cents / 1200.0)
    freqs = np.full(n_partials, np.nan)
    levels = np.full(n_partials, np.nan)
    for i in range(n_partials):
        fc = (i + 1) * f0_hz * math.sqrt(1.0 + B * (i + 1) ** 2)
        lo, hi = fc / r, fc * r
        if hi >= fs / 2:
            break
        f, _ = _peak_in_band(xw, fs, p2, n_fft, lo, hi, dt)
        freqs[i] = f
        levels[i] = _amp_to_db(2.0 * math.sqrt(dt.value(f)) / wsum)
    return freqs, levels


def partial_levels_db(x, fs, f0_hz, n_partials, search_cents=50.0, window="nuttall",
                      inharmonicity=0.0):
    """Level of each harmonic partial in dB re amplitude 1 (peak near n * f0).

    Same as ``partial_peaks(...)[1]``; see :func:`partial_peaks` for the
    parameters. Returns an array of shape (n_partials,), NaN for partials whose
    search band reaches fs/2.
    """
    return partial_peaks(x, fs, f0_hz, n_partials, search_cents, window, inharmonicity)[1]
