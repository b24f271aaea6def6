"""Soundboard (body) of a grand piano as a set of damped modes (numpy only).

What the output stage models
----------------------------
A string drives the bridge; the soundboard moves and radiates. Between the
bridge force and the pressure at a listener the board acts as a linear filter
whose response is a sum of damped modes (Conklin, JASA 100, 1996; Giordano,
JASA 103, 1998; Ege, Boutillon & Rebillat, JSV 332, 2013):

    H(s) = sum_k  g_k  2 pi B_k s / (s^2 + 2 pi B_k s + (2 pi f_k)^2),

one resonance per plate mode: frequency ``f_k``, half-power bandwidth
``B_k = eta_k f_k`` in Hz (loss factor eta), peak gain ``g_k`` at ``f_k``. This module
chooses the set {f_k, T60_k, g_k} (the "mode set": data and the laws that
make it) and the discrete realisation of each mode; the kernel
(:mod:`synth.kernels.body`) runs it and :class:`synth.dsp.body.Body`
wraps it.

Why a modal bank and not a convolution
--------------------------------------
The body runs once, on the mono 48 kHz mix, and must cost well under 2 % of
a core while streaming in blocks of any size without allocating. A measured
board response is 0.3-1 s long (15 000-50 000 taps): direct convolution in
numba costs that many multiply-adds per sample (~100x over budget), and a
partitioned FFT convolution needs FFT scratch per block and adds a block of
latency. A bank of K two-pole resonators costs ~5 K flops per sample, has no
latency, streams trivially (two state values per mode) and its parameters
are physical (mode frequencies, loss factors) and can be scaled (``size``)
or tilted (``brightness``). Measured cost: ~16 ns per sample for K = 96
in the kernel, ~20 ns through the wrapper in 1024-sample blocks (~0.1 % of
one core at 48 kHz; see :mod:`synth.dsp.body`).

The laws
--------
Frequencies. A thin plate has a modal density that is nearly constant in
frequency, n(f) = S sqrt(rho h / D) / 2; a grand piano board has of the order
of one mode per 15-25 Hz at low frequencies, the lowest near 50 Hz. We use
``F_LOW_HZ / size`` for the lowest mode and a mean spacing ``SPACING_HZ /
size`` (a larger board, same thickness, has all frequencies lower by the
same factor; ``size`` therefore divides every frequency, so on a
log-frequency axis it only shifts the response, and it stretches decay
times by ``size``). Above about 1 kHz the modes of a real board overlap (the
modal overlap B / spacing exceeds 1) and individual modes no longer matter
perceptually, so the bank is thinned there: the mode density is
``min(1 / spacing, A / f)`` -- uniform at low frequencies, constant per
octave (geometric spacing) above the crossover ``f_c = A spacing`` -- with
``A`` solved so that ``n_modes`` modes span ``[F_LOW_HZ / size,
min(F_HIGH_HZ / size, NYQUIST_FRACTION fs)]``. The lowest mode sits exactly
at ``F_LOW_HZ / size``; the others are placed by random spacings in the
warped coordinate (cumulated density) drawn from the Wigner surmise
P(s) = (pi s / 2) exp(-pi s^2 / 4) (the level-spacing law of an irregular
plate: level repulsion, no comb), floored at ``MIN_SPACING`` of the mean,
so the modes form no regular comb and no two of them merge into one peak.

Damping. Loss factor eta rises gently with frequency, from ``ETA_LOW`` (2 %)
at the lowest mode to ``ETA_HIGH`` (3 %) from 20x the lowest mode up
(eta = ETA_LOW (f / f_low)^gamma, capped) -- Q falls from 50 to 33, in the
1-3 % range measured on boards. Where the bank is thinned (above f_c) the
bandwidths are widened, if needed, to at least ``OVERLAP`` times the bank's
local mean spacing, so the response there stays a continuum of overlapping
modes (as on the real board, whose modal overlap eta f / spacing passes 1
near 700 Hz) rather than a set of isolated peaks. With the default 96 modes
f_c is near 500 Hz and eta f already exceeds that floor; it matters when
fewer modes are asked for. Q is kept >= 1 (B <= f) for very thin banks.
T60 = ln(1000) / (pi B) (amplitude e^{-pi B t}): 2.2 s for the 50 Hz mode,
~1 s near 100 Hz, ~7 ms at 10 kHz (size 1).

Gains. Each mode of peak gain g and bandwidth B adds about g^2 (pi / 2) B
to the integral of |H|^2, so with g_k ~ 1 / sqrt(B_k rho(f_k)) the smoothed
power response is flat; on that we put a tilt of ``brightness`` dB per
octave (re 1 kHz), a log-normal spread of ``GAIN_SPREAD_DB`` (standard
deviation) and a random sign per mode (the transfer to a listener, not the
driving-point admittance, so residues of both signs: anti-resonances appear
between some pairs of modes, not all). Everything random comes from
``numpy.random.default_rng(seed)``: a fixed seed gives the same board.
Finally the gains are scaled so that the white-noise power gain of the
realised filter, sum_n h[n]^2, is exactly 1 (computed in closed form from
poles and residues, :func:`white_noise_power_gain`).

Realisation (per mode, at ``fs``)
---------------------------------
A two-pole resonator with zeros at DC and Nyquist (Smith & Angell's
constant-peak-gain form), the discrete counterpart of the velocity-type
bandpass above (no DC through the body):

    H_k(z) = b0_k (1 - z^-2) / (1 + a1_k z^-1 + a2_k z^-2),
    r = exp(-pi B_k / fs) = 10^(-3 / (T60_k fs)),  theta = 2 pi f_k / fs,
    a1 = -2 r cos(theta),  a2 = r^2,  b0 = g_k (1 - r^2) / 2,

so the pole angle is exactly ``f_k``, the decay exactly ``T60_k`` and the
peak gain ~ ``g_k``. The coefficient array is laid out (3, K) -- rows b0,
a1, a2 -- so the kernel's loop over modes reads contiguous rows and
vectorises (a (K, 3) layout measured 7x slower).
"""

from __future__ import annotations

from dataclasses import dataclass

import math
import numbers

import numpy as np

__all__ = [
    "DEFAULT_N_MODES",
    "DEFAULT_SEED",
    "soundboard_modes",
    "resonator_coefs",
    "white_noise_power_gain",
    "mode_density_per_hz",
]

#: Default number of modes (cost ~16-20 ns per sample at 48 kHz).
DEFAULT_N_MODES = 96
#: Default seed of the board's random draws.
DEFAULT_SEED = 1
#: Allowed mode counts.
MIN_N_MODES, MAX_N_MODES = 1, 1024
#: Lowest mode of a size-1 board (Hz).
F_LOW_HZ = 50.0
#: Mean mode spacing at low frequencies of a size-1 board (Hz).
SPACING_HZ = 20.0
#: Top of the mode range of a size-1 board (Hz), capped at NYQUIST_FRACTION fs.
F_HIGH_HZ = 10000.0
NYQUIST_FRACTION = 0.45
#: Loss factor at the lowest mode and the ceiling it rises to.
ETA_LOW = 0.02
ETA_HIGH = 0.03
#: eta reaches ETA_HIGH at this multiple of the lowest mode frequency.
ETA_KNEE_RATIO = 20.0
#: Bandwidths are widened to at least OVERLAP x the local mean spacing.
OVERLAP = 0.5
#: Floor of a random spacing, as a fraction of the local mean spacing.
MIN_SPACING = 0.5
#: Standard deviation of the log-normal gain spread (dB).
GAIN_SPREAD_DB = 3.0
#: Allowed ranges of the shape parameters.
SIZE_RANGE = (0.5, 2.0)
BRIGHTNESS_RANGE_DB = (-12.0, 12.0)
MIN_FS = 8000


@dataclass(frozen=True)
class BodyDesign:
    """What an instrument says of its body; the engine builds the filter
    (:meth:`synth.dsp.body.Body.from_design`) on its own output rate.

    wet : float         share of the body in the output, 0 .. 1
    n_modes : int       number of modes, 1 .. 1024
    size : float        board size factor (mode frequencies divide by it)
    brightness : float  spectral tilt, dB per octave re 1 kHz
    seed : int          seed of the mode set's random draws (same seed, same board)
    """

    wet: float
    n_modes: int = DEFAULT_N_MODES
    size: float = 1.0
    brightness: float = 0.0
    seed: int = DEFAULT_SEED


def _int_param(name, value, lo, hi):
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or not lo <= value <= hi:
        raise ValueError(f"{name} = {value!r} is out of range (integer, {lo} <= value <= {hi})")
    return int(value)


def _float_param(name, value, lo, hi, unit=""):
    ok = not isinstance(value, bool) and isinstance(value, numbers.Real)
    v = float(value) if ok else math.nan
    if not (math.isfinite(v) and lo <= v <= hi):
        raise ValueError(f"{name} = {value!r}{unit} is out of range ({lo:g} <= value <= {hi:g})")
    return v


def _fs_param(fs):
    if isinstance(fs, bool) or not isinstance(fs, numbers.Real) or not math.isfinite(float(fs)) \
            or float(fs) < MIN_FS:
        raise ValueError(f"fs = {fs!r} Hz is out of range (value >= {MIN_FS} Hz)")
    return float(fs)


def _layout(fs, n_modes, size):
    """Mode range and density constants: (f_low, f_high, spacing, f_c) in Hz.

    Density rho(f) = 1/spacing below f_c, A/f above (A = f_c/spacing); when
    more modes are asked than a uniform 1/spacing can hold, the whole range is
    uniform with a smaller spacing (f_c = f_high).
    """
    f_low = F_LOW_HZ / size
    f_high = min(F_HIGH_HZ / size, NYQUIST_FRACTION * fs)
    spacing = SPACING_HZ / size
    if f_high <= f_low * 1.5:
        raise ValueError(f"fs = {fs:g} Hz is too low for a board of size {size:g} "
                         f"(needs NYQUIST_FRACTION fs >= {1.5 * f_low:g} Hz)")
    target = float(n_modes - 1)  # intervals between the modes

    def count(f_c):  # modes-intervals in [f_low, f_high] for crossover f_c
        return (f_c - f_low) / spacing + (f_c / spacing) * math.log(f_high / f_c)

    if target >= (f_high - f_low) / spacing:
        spacing = (f_high - f_low) / max(target, 1.0)
        return f_low, f_high, spacing, f_high
    if target <= count(f_low):
        # Sparser than one spacing even at the bottom: geometric everywhere,
        # A = target / ln(f_high / f_low) and f_c = f_low with that A.
        a = max(target, 1.0) / math.log(f_high / f_low)
        return f_low, f_high, f_low / a, f_low
    lo, hi = f_low, f_high
    for _ in range(200):  # count() is increasing in f_c (d/df_c = ln(f_high/f_c)/spacing)
        mid = 0.5 * (lo + hi)
        if count(mid) < target:
            lo = mid
        else:
            hi = mid
    return f_low, f_high, spacing, 0.5 * (lo + hi)


def _density(f, spacing, f_c):
    """Modes per Hz at f (array)."""
    return np.minimum(1.0 / spacing, (f_c / spacing) / f)


def mode_density_per_hz(f_hz, fs, n_modes=DEFAULT_N_MODES, size=1.0):
    """Mean modal density of the bank (modes per Hz) at frequencies ``f_hz``.

    Parameters
    ----------
    f_hz : array_like of float
        Frequencies in Hz (> 0).
    fs : float
        Sample rate in Hz (>= 8000).
    n_modes : int
        Number of modes, 1 .. 1024.
    size : float
        Board scale, 0.5 .. 2 (frequencies divide by it).

    Returns
    -------
    ndarray of float
        Modes per Hz: ``1 / spacing`` below the crossover, ``A / f`` above.
    """
    fs = _fs_param(fs)
    n_modes = _int_param("n_modes", n_modes, MIN_N_MODES, MAX_N_MODES)
    size = _float_param("size", size, *SIZE_RANGE)
    _, _, spacing, f_c = _layout(fs, n_modes, size)
    return _density(np.asarray(f_hz, dtype=np.float64), spacing, f_c)


def soundboard_modes(fs, n_modes=DEFAULT_N_MODES, seed=DEFAULT_SEED, size=1.0, brightness=0.0):
    """The board's modes: frequencies, decay times and signed peak gains.

    Parameters
    ----------
    fs : float
        Sample rate in Hz at which the modes will run (>= 8000); sets the top
        of the mode range (``NYQUIST_FRACTION fs``) and the normalisation.
    n_modes : int
        Number of modes K, 1 .. 1024 (default 96).
    seed : int
        Seed of the random draws (spacings, gain spread, signs), >= 0. The
        same seed gives the same board.
    size : float
        Board scale, 0.5 .. 2 (default 1): every frequency is divided by it
        (lowest mode ``50 / size`` Hz, spacing ``20 / size`` Hz) and decay
        times are multiplied by it.
    brightness : float
        Spectral tilt of the smoothed response in dB per octave re 1 kHz,
        -12 .. 12 (default 0 = flat on average).

    Returns
    -------
    freqs_hz : ndarray of float64, shape (K,)
        Mode (pole-angle) frequencies in Hz, increasing, lowest exactly
        ``50 / size``.
    t60_s : ndarray of float64, shape (K,)
        60 dB amplitude decay time of each mode in s.
    gains : ndarray of float64, shape (K,)
        Signed peak gains, scaled so that the bank realised by
        :func:`resonator_coefs` at ``fs`` has a white-noise power gain of 1.
    """
    fs = _fs_param(fs)
    n_modes = _int_param("n_modes", n_modes, MIN_N_MODES, MAX_N_MODES)
    seed = _int_param("seed", seed, 0, 2**63 - 1)
    size = _float_param("size", size, *SIZE_RANGE)
    brightness = _float_param("brightness", brightness, *BRIGHTNESS_RANGE_DB, unit=" dB/octave")

    f_low, f_high, spacing, f_c = _layout(fs, n_modes, size)
    rng = np.random.default_rng(seed)
    K = n_modes
    # Wigner-surmise spacings (mean 1) in the warped coordinate u = N(f).
    s = np.sqrt(-4.0 / math.pi * np.log1p(-rng.random(K)))
    s = np.maximum(s, MIN_SPACING)
    spread_db = GAIN_SPREAD_DB * rng.standard_normal(K)
    signs = np.where(rng.random(K) < 0.5, -1.0, 1.0)

    a_dens = f_c / spacing
    n_c = (f_c - f_low) / spacing  # u at the crossover
    n_total = n_c + a_dens * math.log(f_high / f_c)
    if K > 1:
        u = np.concatenate(([0.0], np.cumsum(s[1:])))
        u *= n_total / u[-1]
    else:
        u = np.zeros(1)
    freqs = np.where(u <= n_c, f_low + u * spacing, f_c * np.exp((u - n_c) / a_dens))
    freqs[0] = f_low
    freqs = np.minimum(freqs, f_high)

    rho = _density(freqs, spacing, f_c)
    gamma = math.log(ETA_HIGH / ETA_LOW) / math.log(ETA_KNEE_RATIO)
    eta = np.minimum(ETA_LOW * (freqs / f_low) ** gamma, ETA_HIGH)
    bw_hz = eta * freqs
    thinned = freqs > f_c  # fewer modes than the board has: keep them overlapping
    bw_hz[thinned] = np.maximum(bw_hz[thinned], OVERLAP / rho[thinned])
    bw_hz = np.minimum(bw_hz, freqs)  # Q >= 1 even for a very thin bank
    t60 = math.log(1000.0) / (math.pi * bw_hz)

    gains = signs * 10.0 ** ((brightness * np.log2(freqs / 1000.0) + spread_db) / 20.0)
    gains /= np.sqrt(bw_hz * rho)
    p = white_noise_power_gain(resonator_coefs(fs, freqs, t60, gains))
    gains /= math.sqrt(p)
    return freqs, t60, gains


def resonator_coefs(fs, freqs_hz, t60_s, gains):
    """Coefficients of the two-pole, two-zero (1 - z^-2) resonators, layout (3, K).

    Parameters
    ----------
    fs : float
        Sample rate in Hz (>= 8000).
    freqs_hz : array_like of float, shape (K,)
        Pole-angle frequencies in Hz, 0 < f < fs / 2.
    t60_s : array_like of float, shape (K,)
        60 dB decay times in s, > 0.
    gains : array_like of float, shape (K,)
        Peak gains (signed, any finite value).

    Returns
    -------
    ndarray of float64, shape (3, K), C-contiguous
        Rows ``b0, a1, a2`` of ``H_k(z) = b0 (1 - z^-2) / (1 + a1 z^-1 + a2 z^-2)``.
    """
    fs = _fs_param(fs)
    f = np.atleast_1d(np.asarray(freqs_hz, dtype=np.float64))
    t60 = np.atleast_1d(np.asarray(t60_s, dtype=np.float64))
    g = np.atleast_1d(np.asarray(gains, dtype=np.float64))
    if f.ndim != 1 or f.shape != t60.shape or f.shape != g.shape or f.size == 0:
        raise ValueError(f"freqs_hz, t60_s, gains have shapes {f.shape}, {t60.shape}, {g.shape}; "
                         "must be equal 1-D shapes (K,), K >= 1")
    bad = ~(np.isfinite(f) & (f > 0) & (f < fs / 2))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ValueError(f"freqs_hz[{i}] = {f[i]!r} Hz is out of range (0 < value < fs/2 = {fs / 2:g} Hz)")
    bad = ~(np.isfinite(t60) & (t60 > 0))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ValueError(f"t60_s[{i}] = {t60[i]!r} s is out of range (0 < value < inf)")
    bad = ~np.isfinite(g)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ValueError(f"gains[{i}] = {g[i]!r} is out of range (finite)")
    r = 10.0 ** (-3.0 / (t60 * fs))
    theta = 2.0 * math.pi * f / fs
    coefs = np.empty((3, f.size), dtype=np.float64)
    coefs[0] = g * (1.0 - r * r) / 2.0
    coefs[1] = -2.0 * r * np.cos(theta)
    coefs[2] = r * r
    return coefs


def white_noise_power_gain(coefs):
    """Exact sum_n h[n]^2 of the summed bank (the power gain for white noise).

    Each section ``b0 (1 - z^-2) / (1 + a1 z^-1 + a2 z^-2)`` with complex
    poles p, p* is written ``q + c / (1 - p z^-1) + c* / (1 - p* z^-1)``, so
    the bank's response is ``h[n] = Q delta[n] + sum_a C_a P_a^n`` and

        sum_n h^2 = Q^2 + 2 Q sum_a C_a + sum_{a,b} C_a C_b / (1 - P_a P_b).

    Parameters
    ----------
    coefs : ndarray, shape (3, K)
        Rows ``b0, a1, a2`` as from :func:`resonator_coefs`; every section
        must have complex poles inside the unit circle (a1^2 < 4 a2 < 4).

    Returns
    -------
    float
        The energy of the bank's impulse response (dimensionless).
    """
    coefs = np.asarray(coefs, dtype=np.float64)
    if coefs.ndim != 2 or coefs.shape[0] != 3:
        raise ValueError(f"coefs has shape {coefs.shape}; must be (3, K)")
    b0, a1, a2 = coefs
    if not np.all((a1 * a1 < 4.0 * a2) & (a2 < 1.0)):
        raise ValueError("coefs: every section must have complex poles inside the unit circle "
                         "(a1^2 < 4 a2 < 4)")
    r = np.sqrt(a2)
    cos_t = np.clip(-a1 / (2.0 * r), -1.0, 1.0)
    p = r * (cos_t + 1j * np.sqrt(1.0 - cos_t * cos_t))
    # residue at p of N(w)/D(w), w = z^-1: c = N(1/p) / (1 - p*/p)
    w = 1.0 / p
    c = b0 * (1.0 - w * w) / (1.0 - np.conj(p) / p)
    q = b0 - 2.0 * c.real
    P = np.concatenate((p, np.conj(p)))
    C = np.concatenate((c, np.conj(c)))
    Q = q.sum()
    cross = (C[:, None] * C[None, :] / (1.0 - P[:, None] * P[None, :])).sum()
    return float((Q * Q + 2.0 * Q * C.sum() + cross).real)
