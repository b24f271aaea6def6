"""Soundboard (body) of a grand piano as a set of damped modes (numpy only).

What the output stage models
----------------------------
The strings drive the board at the bridges; the board moves and radiates.
Between the bridge forces and the sound at a listener the board acts as a
linear filter whose response is a sum of damped modes (Conklin, JASA 100,
1996; Giordano, JASA 103, 1998; Ege, Boutillon & Rebillat, JSV 332, 2013):

    H_cb(s) = dry_cb + sum_k  p_ck d_bk  2 pi B_k s / (s^2 + 2 pi B_k s + (2 pi f_k)^2),

one resonance per plate mode -- frequency ``f_k``, half-power bandwidth
``B_k = eta_k f_k`` in Hz (loss factor eta) -- driven from bridge input
``b`` with gain ``d_bk`` (the mode's shape where that bridge end sits) and
heard at output ``c`` with gain ``p_ck`` (how the mode radiates towards that
pickup). There are B = 1 or 2 inputs (0: the bass end of the bridge, 1:
the treble end) and C = 1 or 2 outputs (two pickups, left and right). This
module chooses the mode set {f_k, T60_k, d_bk, p_ck}, the direct part
``dry_cb`` and the discrete realisation of each mode; the kernels
(:mod:`synth.kernels.body`) run it and :class:`synth.dsp.body.Body` wraps
it. :func:`knock_pulse` is the force pulse of the hammer knock.

Why a modal bank and not a convolution
--------------------------------------
The body runs once, on the 48 kHz bridge buses, and must cost well under
1 % of a core while streaming in blocks of any size without allocating. A
measured board response is 0.3-1 s long (15 000-50 000 taps) per input and
output: direct convolution costs that many multiply-adds per sample and
path (~100x over budget), and a partitioned FFT convolution needs FFT
scratch per block and adds a block of latency. A bank of K two-pole
resonators costs ~6 K flops per sample for two inputs and two outputs
(measured: 0.26 % of a core for the default 96 modes, 0.17 % for one input
and one output, :mod:`synth.dsp.body`), has no latency, streams trivially (two state values per mode) and its
parameters are physical (mode frequencies, loss factors) and can be scaled
(``size``) or tilted (``brightness``).

Evenness by design
------------------
A piano tone is a set of nearly sinusoidal partials, so the body's gain at
each partial's frequency sets that partial's level directly: a notch or a
peak of the response on one key's partial is a quiet or a loud key. The
earlier board had two sources of deep notches:

* random residue signs: between two modes whose residues have the same sign
  the tails of the two resonances are in antiphase and cancel (an
  anti-resonance); with random signs in the overlapping mid range the
  response is a random-phase sum with Rayleigh statistics, ~10 % of all
  frequencies more than 10 dB below the mean (Schroeder's statistics of
  dense modal responses); measured on the old board: notches to -55 dB
  re the 1/3-octave smoothed response, C4's partial 3 22 dB down;
* the dry + wet sum: a direct path and a modal path of random phase cancel
  wherever they have equal magnitude and opposite phase.

A real board's *driving-point* response has no sign changes: its residues
are the squared mode shapes at the drive point, all positive, and the
power a string gives the board is the real part of that admittance, a sum
of positive resonance curves (Skudrzyk's mean-value theory: its average is
the infinite-plate admittance, flat and real; Ege & Boutillon, ISMA 2010,
"Synthetic description of the piano soundboard mechanical mobility", after
Skudrzyk 1980 and Langley 1994). What a listener in a room hears of a
partial follows that radiated power (the reverberant field, two ears and a
moving head average the point-to-point sign changes away); one fixed linear
filter cannot average incoherently, so this board keeps what the power
says and leaves out the point-to-point signs:

* every ``d_bk`` and ``p_ck`` is positive. Each discrete section below is
  the bilinear image of a positive-real analog band-pass, so its real part
  is >= 0 at every frequency; a sum of such sections plus a positive direct
  gain ``g`` therefore has ``|H| >= Re H >= g`` everywhere: **the response
  can never fall below the direct part** -- no notch deeper than the
  direct level, by construction, for any seed;
* the direct part (``dry``) is the drive point's local, infinite-plate
  response -- the part of the board's motion that is there before the
  reflections from the rim come back -- real and flat, as in Skudrzyk's
  mean-value picture; the modes are the board's resonant build-up on top
  of it. The balance between the two is the preset's ``wet``;
* peaks stand above the smoothed level by about ``2 / (pi M)`` in power
  for a modal overlap ``M`` (an isolated mode of bandwidth B in a spacing
  1/n), less the share of the direct part in the smoothed level. With the
  grand preset's ``wet = 0.4`` the response stays within -4.5 .. +6 dB of
  its 1/3-octave smoothed value (:func:`smoothed_db`) from 150 Hz to 13 kHz
  and within -6.5 .. +8.5 dB from 25 to 150 Hz, where the lowest modes
  stand alone (overlap < 0.15) -- for every seed tested (1-8), one or two
  inputs and outputs (tests/test_body.py); the old board reached -55 dB.
  Measured on the instrument (a retired study, git show dbf4294:tools/study_body_evenness.py, velocity 80,
  keys 21-108), the median loudness step between adjacent keys is 1.2 dB
  (mono) / 1.4 dB (stereo) with the body against 0.45 dB for the bare
  strings and 2.7 dB with the old board; at partials 1-3 of every key the
  body's gain is within -3.1 .. +4.5 dB of its smoothed gain (old board:
  -21 .. +5).

The laws
--------
Frequencies (Ege, Boutillon & Rebillat 2013; Ege & Boutillon 2010;
Berthaut, Ichchou & Jezequel, Appl. Acoust. 64, 2003). Below about
1.1 kHz a piano board behaves as a homogeneous plate: its modal density is
nearly constant, ~0.05 modes per Hz (one mode per 20 Hz), the lowest mode
near 50 Hz for a grand (Conklin 1996; Suzuki, JASA 80, 1986). Above
1.1 kHz the ribs confine the waves between them and the measured modal
density falls, to ~0.01 modes per Hz at 2.5 kHz. The bank follows this: a
uniform density ``1 / SPACING_HZ`` from ``F_LOW_HZ`` up to ``F_RIB_HZ``,
then a density ``A / f`` (constant per octave) up to ``F_HIGH_HZ`` (capped
at ``NYQUIST_FRACTION fs``), with ``A`` set by the number of modes asked;
for the default 96 modes A = 19 per e-fold (13 per octave), i.e. 0.008
modes per Hz at 2.5 kHz, near the measured 0.01. With too few modes for at
least ``MIN_PER_OCTAVE`` per octave above the ribs' frequency, the uniform
part ends lower, where the density of the geometric part meets it; with
more modes than a uniform bank to ``F_HIGH_HZ`` needs, the bank is uniform
with a smaller spacing. ``size`` divides every frequency (a larger board,
same thickness: all frequencies lower by that factor). The lowest mode
sits exactly at ``F_LOW_HZ / size``; the others are placed by random
spacings in the warped coordinate (cumulated density) drawn from the
Wigner surmise P(s) = (pi s / 2) exp(-pi s^2 / 4) (the level-spacing law
of an irregular plate: level repulsion, no comb), floored at
``MIN_SPACING`` of the mean.

Damping. Loss factor eta = ETA_LOW (f / f_low)^gamma, from ``ETA_LOW``
(2 %) at the lowest mode to ``ETA_HIGH`` (3 %) from 20x the lowest mode up
-- Ege et al. measured a mean of about 2 % on a board in playing
condition, "close to that of wood", with a slight rise with frequency.
The board's modal overlap M = eta f n(f) then passes 1 near 700 Hz (0.05 at
the lowest mode, 0.7 at 500 Hz, 1.5 at 1.1 kHz) -- Ege et al.'s mean 2 %
with 0.05 modes per Hz puts it at 1 kHz. Above ``F_RIB_HZ`` the bank
holds fewer modes than the board, so there each bandwidth is widened, if
needed, to ``OVERLAP`` (1) times the bank's local mean spacing: the
response stays a continuum of overlapping modes (overlap >= 1) as on the
real board, not a set of isolated peaks. Q is kept >= 1 (B <= f).
T60 = ln(1000) / (pi B): 2.2 s for the 50 Hz mode, ~1 s near 100 Hz,
~12 ms at 2 kHz (size 1; ``size`` multiplies decay times).

Gains. A mode of peak gain g and bandwidth B adds about g^2 (pi / 2) B to
the integral of |H|^2, so with g_k ~ 1 / sqrt(B_k n(f_k)) the smoothed
power response is flat; on that goes a tilt of ``brightness`` dB per
octave (re 1 kHz). Each mode's drive gain at each bridge end is that times
a log-normal factor of ``DRIVE_SPREAD_DB`` (standard deviation; where a
bridge end sits on a mode's shape), independently per input, so the two
inputs excite the same modes differently (a key's timbre depends on where
it drives the board) while the smoothed responses are the same. With two
outputs each mode is panned by a random angle theta_k, uniform on
[0, pi/2]: pickup gains (cos theta_k, sin theta_k), so every mode gives the
left and right outputs together the same power and the two outputs differ
in their fine structure (decorrelated) but not on average. Everything
random comes from ``numpy.random.default_rng(seed)`` in a fixed order (the
spacings, then the spreads of both inputs, then the angles), so a fixed
seed gives the same board whatever the numbers of inputs and outputs: the
one-input board's modes are the two-input board's input 0.

The direct part and stereo. With one input and one output ``dry = 1``;
one input, two outputs: the input to both outputs; two inputs, one output:
their sum. With two of each: ``dry = [[1, r], [r, 1]]`` (output 0 =
left = mostly the bass end, output 1 = right = mostly the treble end, as
the pianist hears), with ``r`` chosen so that the direct part's 2 x 2
input Gram matrix has the same correlation coefficient as the modal part's
(the drives of the two inputs are correlated through their common mean).
Then, for a string split linearly between the inputs by its position,
both parts change by the same factor along the keyboard and one gain per
string (:meth:`synth.dsp.body.Body.bridge_split`) makes the loudness
independent of the position; without it the middle of the keyboard is
~0.1 dB low (the drives are correlated through their common mean, so
``r`` comes out near 0.7 for the default spread: a narrow direct image, the
width comes from the modes' pan angles). The
direct and modal parts are each scaled to a white-noise power gain of 1
(averaged over the inputs, summed over the outputs), computed in closed
form from poles and residues (:func:`white_noise_cross_energy`).

Realisation (per mode, at ``fs``)
---------------------------------
A two-pole resonator with zeros at DC and Nyquist (Smith & Angell's
constant-peak-gain form), the discrete counterpart of the velocity-type
band-pass above (no DC through the body):

    H_k(z) = b0_k (1 - z^-2) / (1 + a1_k z^-1 + a2_k z^-2),
    r = exp(-pi B_k / fs) = 10^(-3 / (T60_k fs)),  theta = 2 pi f_k / fs,
    a1 = -2 r cos(theta),  a2 = r^2,  b0 = g_k (1 - r^2) / 2,

so the pole angle is exactly ``f_k``, the decay exactly ``T60_k`` and the
peak gain ~ ``g_k``. It is the bilinear transform of an analog
c s / (s^2 + alpha s + beta) with c, alpha > 0, a positive-real function:
``Re H_k >= 0`` on the unit circle whenever ``b0_k > 0`` (tested). The
coefficient array is laid out (3, K) -- rows b0, a1, a2 -- so the kernel's
loop over modes reads contiguous rows and vectorises.

The radiation's spread
----------------------
The modal bank keeps what a partial's steady level needs and drops the
transfer's phases (positive residues), so its response to a tone is there
at once: a sum of positive band-passes starts every mode in phase at the
strike.  A listener near a board some 1.5 m across hears more than that:
each part of the board starts to move when the bending wave from the
bridge reaches it (about 300-550 m/s from 1 to 3.5 kHz, a few ms across
the board, then the rim's reflections) and is heard at its own distance
(0.5 m over the strings: path differences up to about 1.2 m, 3.5 ms).  So
a note's sound arrives spread over some milliseconds and builds up: on
the recorded Yamaha C5 (Salamander V3, v10, close microphones; 1 ms RMS
frames re their largest, in each channel alike) C6 starts at 0.21 and
reaches 1 at 9 ms, C7 starts at 0.08 and reaches 1 at 12 ms, A7 starts at
0.16 and reaches 1 at 11 ms, where the modal bank was at 0.8-0.9 in its
first millisecond (``tools/real_grand.py --attacks``).
:func:`spread_allpasses` restores that spread without changing the steady
spectrum: ``spread_ms`` sets a cascade of three Schroeder allpasses
(Schroeder, JAES 10, 1962),

    A_s(z) = (-g + z^-D_s) / (1 - g z^-D_s),   D_s = spread_ms (0.382, 0.618, 1),  g = 0.5,

each of gain 1 at every frequency, so a partial's level, the key-to-key
evenness and the loudness are the bank's, while the first arrival is
g^3 = 0.125 of the input and the rest follows in echoes whose energy
builds with time constants of the delays.  Delays in the golden ratio
keep the three echo series from coinciding.  The same cascade runs on
every output, so the channels' sum (a mono mix) stays flat.  ``spread_ms
= 0`` (the default): none.  The grand's 3.4 ms is fitted to the
recording's time to the RMS peak (``tools/real_grand.py --octaves``).

The board's mass
----------------
The modal bank's response is flat on average at every frequency (a tilt
aside, ``brightness``), and its direct part is flat.  A board is not: from
some frequency up its bridge and ribs move as a mass under the strings'
force, so the velocity per unit force, and the sound, fall 6 dB per
octave: |1 / (1 + j f / mass_hz)|.  ``mass_hz`` sets that corner, one
first-order section of unit gain at 0 Hz on every output
(:func:`mass_section`),

    H(z) = g (1 + b z^-1) / (1 - a z^-1),   g = (1 - a) / (1 + b),

whose a and b are fitted at the rate to the mass's magnitude (least
squares in dB on 64 frequencies from 20 Hz to 20 kHz or 0.45 fs, ten times
the weight below 5 kHz): with a 3 kHz corner it is within 0.022 dB of
it below 5 kHz and 0.31 dB up to 19 kHz at 44.1 kHz, 0.015 and 0.18 at 48
kHz, 0.001 and 0.011 at 88.2 kHz, so the board sounds the same at every
card rate (the matched-z pole alone, b = 0, fell 0.2 dB below 5 kHz and
2.8 dB by 19 kHz at 44.1 kHz).  ``mass_hz = 0`` (the default): none.  The
grand's 3 kHz is fitted to the recorded Yamaha C5, not measured on a
board: without it the grand's partials over 3 kHz stood 7-16 dB over the
recording's re partial 1 on every octave from C2 (0.05-0.5 s, medians by
octave and band) and its attack centroid 1.33-1.46x the recording's; a 2
kHz corner brought the centroids to 0.97-1.11x but took C4's partial 7
under the recording's (-26.8 dB over its first second against -26.0) and
the knee of key 96; 3 kHz keeps both (the grand's section of
``docs/voicing.md``).

The knock
---------
:func:`knock_pulse` and :func:`knock_impulse_ns`: when the key hits the
keybed and the hammer hits the strings, the action and the case receive an
impulsive force that reaches the board besides the strings' own wave
(Askenfelt & Jansson, "From touch to string vibrations", in *Five lectures
on the acoustics of the piano*, 1990; Askenfelt, "Observations on the
transient components of the piano tone", SMAC 93, 1993: the key-bottom
"thump" comes within a few ms of the hammer-string contact and is most
audible in the treble, where the tone itself has little low-frequency
energy). It is modelled as a raised-cosine force pulse of a few ms added
to the bridge inputs: short against the period of the board's low modes,
so it excites them with a flat spectrum up to ~1 / duration (the "low
thump"), see :func:`knock_impulse_ns` for its level.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import math
import numbers

import numpy as np

__all__ = [
    "DEFAULT_N_MODES",
    "DEFAULT_SEED",
    "BodyDesign",
    "BoardModes",
    "soundboard_modes",
    "resonator_coefs",
    "section_response",
    "white_noise_cross_energy",
    "white_noise_power_gain",
    "mode_density_per_hz",
    "smoothed_db",
    "knock_pulse",
    "knock_impulse_ns",
    "spread_allpasses",
    "mass_section",
    "mass_section_check",
]

#: Default number of modes.
DEFAULT_N_MODES = 96
#: Default seed of the board's random draws.
DEFAULT_SEED = 1
#: Allowed mode counts.
MIN_N_MODES, MAX_N_MODES = 1, 1024
#: Lowest mode of a size-1 board (Hz).
F_LOW_HZ = 50.0
#: Mean mode spacing below F_RIB_HZ of a size-1 board (Hz): 0.05 modes per Hz.
SPACING_HZ = 20.0
#: Above this the ribs confine the waves and the density falls (Hz, size 1).
F_RIB_HZ = 1100.0
#: Top of the mode range of a size-1 board (Hz), capped at NYQUIST_FRACTION fs.
F_HIGH_HZ = 10000.0
NYQUIST_FRACTION = 0.45
#: Rate (Hz) at which a board is laid out and its level normalised,
#: whatever rate it runs at: the mode range is capped at
#: ``NYQUIST_FRACTION REFERENCE_FS`` (at ``NYQUIST_FRACTION fs`` below
#: 44.1 kHz) and the white-noise gains are
#: those of the modes realised at this rate, so a board run at 44.1, 88.2 or
#: 96 kHz has the response in Hz (modes, levels, dry/wet balance) of the
#: same board at 48 kHz.  (Normalised at its own rate, a board at 96 kHz
#: came out 1.5-2 dB louder in every band: a resonator's white-noise power
#: gain is its bandwidth over the rate.)
REFERENCE_FS = 48000.0
#: Fewest modes per octave above F_RIB_HZ before the uniform part is shortened.
MIN_PER_OCTAVE = 6.0
#: Loss factor at the lowest mode and the ceiling it rises to.
ETA_LOW = 0.02
ETA_HIGH = 0.03
#: eta reaches ETA_HIGH at this multiple of the lowest mode frequency.
ETA_KNEE_RATIO = 20.0
#: Above the uniform part, bandwidths are widened to at least OVERLAP x the local mean spacing.
OVERLAP = 1.0
#: Floor of a random spacing, as a fraction of the local mean spacing.
MIN_SPACING = 0.5
#: Standard deviation of the log-normal drive spread of each mode at each input (dB).
DRIVE_SPREAD_DB = 3.0
#: Allowed ranges of the shape parameters.
#: (size: 0.25 for a lute's or a sitar's small body, lowest diffuse mode
#: 200 Hz, to 4 for a concert grand's board stretched to 12.5 Hz; the
#: preset schema allows the same range)
SIZE_RANGE = (0.25, 4.0)
BRIGHTNESS_RANGE_DB = (-12.0, 12.0)
MIN_FS = 8000
#: Named resonances (``peaks``): at most this many, and their allowed
#: frequency (Hz; also below ``NYQUIST_FRACTION fs``), quality factor and
#: level re the diffuse bank's smoothed level (dB).
MAX_PEAKS = 32
PEAK_HZ_RANGE = (20.0, 20000.0)
PEAK_Q_RANGE = (1.0, 500.0)
PEAK_DB_RANGE = (-30.0, 30.0)
#: Allowed numbers of bridge inputs and of outputs.
MAX_INPUTS = MAX_OUTPUTS = 2
#: Knock: default pulse duration (s) and impulse re the hammer's momentum.
#: 5 ms: the key's stop on the keybed felt, a low thump (flat to ~80 Hz,
#: first zero at 400 Hz); at 2 ms the pulse reached the board's modes above
#: 1 kHz and sounded as a click (C4's pp attack centroid 674 -> 1303 Hz)
KNOCK_DURATION_S = 0.005
KNOCK_DURATION_RANGE_S = (0.0002, 0.02)
#: Knock built up over time (``action.knock_build_s``, :func:`knock_pulse`):
#: the allowed time constants (s), the pushes per second of its train, the
#: span of its envelope in time constants (8: the last push at -43 dB) and the
#: seed of its pushes' places and signs (the same train on every run)
KNOCK_BUILD_RANGE_S = (0.0, 0.05)
KNOCK_TRAIN_HZ = 2000.0
KNOCK_BUILD_SPAN = 8.0
KNOCK_SEED = 41
KNOCK_IMPULSE_RATIO = 0.1
#: the largest knock ratio allowed (the grand's fitted 3.9, with room)
KNOCK_RATIO_MAX = 10.0
#: The radiation's spread (:func:`spread_allpasses`): the allpasses' delays
#: as fractions of ``spread_ms``, their common gain, the allowed range (ms)
SPREAD_RATIOS = (0.382, 0.618, 1.0)
SPREAD_GAIN = 0.5
SPREAD_RANGE_MS = (0.0, 20.0)
#: the board's mass corner's allowed range (Hz; 0: none)
MASS_RANGE_HZ = (0.0, 20000.0)


@dataclass(frozen=True)
class BodyDesign:
    """What an instrument says of its body; the engine builds the filter
    (:meth:`synth.dsp.body.Body.from_design`) on its own output rate.

    wet : float         share of the modes in the output, 0 .. 1 (the rest: the direct part)
    n_modes : int       number of modes, 1 .. 1024
    size : float        board size factor (mode frequencies divide by it)
    brightness : float  spectral tilt, dB per octave re 1 kHz
    seed : int          seed of the mode set's random draws (same seed, same board)
    inputs : int        bridge inputs, 1 (the whole bridge) or 2 (0: bass end, 1: treble end)
    outputs : int       outputs, 1 (mono) or 2 (0: left, 1: right)
    peaks : tuple       named resonances ((f_hz, q, level_db), ...) on top of the
                        diffuse modes (:func:`soundboard_modes`); () = none
    spread_ms : float   the radiation's spread (:func:`spread_allpasses`), ms; 0 = none
    mass_hz : float     the board's mass corner (:func:`mass_section`), Hz; 0 = none
    """

    wet: float
    n_modes: int = DEFAULT_N_MODES
    size: float = 1.0
    brightness: float = 0.0
    seed: int = DEFAULT_SEED
    inputs: int = 1
    outputs: int = 1
    peaks: tuple = ()
    spread_ms: float = 0.0
    mass_hz: float = 0.0


@dataclass(frozen=True)
class BoardModes:
    """A board's mode set (:func:`soundboard_modes`); K modes, B inputs, C outputs.

    freqs_hz : ndarray (K,)    mode (pole-angle) frequencies, Hz, increasing
    t60_s : ndarray (K,)       60 dB decay time of each mode, s
    drive : ndarray (B, K)     drive gain of each mode at each input, > 0
    pickup : ndarray (C, K)    peak gain of each mode at each output, >= 0; the
                               mode's peak gain from input b to output c is
                               ``pickup[c, k] * drive[b, k]``
    dry : ndarray (C, B)       direct part, >= 0
    """

    freqs_hz: np.ndarray
    t60_s: np.ndarray
    drive: np.ndarray
    pickup: np.ndarray
    dry: np.ndarray

    @property
    def n_modes(self):
        return int(self.freqs_hz.shape[0])

    @property
    def inputs(self):
        return int(self.drive.shape[0])

    @property
    def outputs(self):
        return int(self.pickup.shape[0])


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


def _layout_fs(fs):
    """The rate whose Nyquist frequency caps the modes: :data:`REFERENCE_FS`
    at every card rate from 44.1 kHz up (a mode at up to 0.45 x 48 kHz =
    21.6 kHz is still below 44.1 kHz's Nyquist frequency), else ``fs``."""
    return REFERENCE_FS if fs >= 44100.0 else fs


def _layout(fs, n_modes, size):
    """Mode range and density: (f_low, f_high, spacing, f_c, a) in Hz (a per e-fold).

    Density n(f) = 1 / spacing for f <= f_c, a / f above (see the module
    docstring, "The laws").
    """
    f_low = F_LOW_HZ / size
    f_high = min(F_HIGH_HZ / size, NYQUIST_FRACTION * _layout_fs(fs))
    spacing = SPACING_HZ / size
    if f_high <= f_low * 1.5:
        raise ValueError(f"fs = {fs:g} Hz is too low for a board of size {size:g} "
                         f"(needs NYQUIST_FRACTION fs >= {1.5 * f_low:g} Hz)")
    target = float(n_modes - 1)  # intervals between the modes

    def uniform(f_c):  # intervals of the uniform part
        return (f_c - f_low) / spacing

    def count(f_c):  # intervals with a density continuous at f_c (a = f_c / spacing)
        return uniform(f_c) + (f_c / spacing) * math.log(f_high / f_c)

    def solve(lo, hi):  # count() is increasing in f_c (d/df_c = ln(f_high / f_c) / spacing)
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            if count(mid) < target:
                lo = mid
            else:
                hi = mid
        return 0.5 * (lo + hi)

    if target >= uniform(f_high):  # uniform everywhere, spacing shrunk to fit
        spacing = (f_high - f_low) / max(target, 1.0)
        return f_low, f_high, spacing, f_high, f_high / spacing
    f_rib = min(F_RIB_HZ / size, f_high)
    if target >= count(f_rib):  # more than the board's density: continuous above f_rib
        f_c = solve(f_rib, f_high)
        return f_low, f_high, spacing, f_c, f_c / spacing
    span = math.log(f_high / f_rib)
    a = (target - uniform(f_rib)) / span if span > 0 else 0.0
    if span > 0 and a >= MIN_PER_OCTAVE / math.log(2.0):  # the board's law
        return f_low, f_high, spacing, f_rib, a
    if target <= count(f_low):  # very few modes: geometric everywhere
        a = max(target, 1.0) / math.log(f_high / f_low)
        return f_low, f_high, f_low / a, f_low, a
    f_c = solve(f_low, f_rib)
    return f_low, f_high, spacing, f_c, f_c / spacing


def _density(f, spacing, f_c, a):
    """Modes per Hz at f (array)."""
    return np.where(f <= f_c, 1.0 / spacing, a / np.maximum(f, 1e-300))


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
        Board scale, 0.25 .. 4 (frequencies divide by it).

    Returns
    -------
    ndarray of float
        Modes per Hz: ``1 / spacing`` up to the end of the uniform part
        (``F_RIB_HZ / size`` for the default count), ``A / f`` above.
    """
    fs = _fs_param(fs)
    n_modes = _int_param("n_modes", n_modes, MIN_N_MODES, MAX_N_MODES)
    size = _float_param("size", size, *SIZE_RANGE)
    _, _, spacing, f_c, a = _layout(fs, n_modes, size)
    return _density(np.asarray(f_hz, dtype=np.float64), spacing, f_c, a)


def soundboard_modes(fs, n_modes=DEFAULT_N_MODES, seed=DEFAULT_SEED, size=1.0, brightness=0.0,
                     inputs=1, outputs=1, peaks=()):
    """The board's modes, their drive and pickup gains and the direct part.

    Parameters
    ----------
    fs : float
        Sample rate in Hz at which the modes will run (>= 8000); below
        44.1 kHz it caps the mode range at ``NYQUIST_FRACTION fs``.  The
        layout at and above 44.1 kHz and the normalisation are those of
        :data:`REFERENCE_FS` (48 kHz), so the board's response in Hz does
        not depend on the rate it runs at.
    n_modes : int
        Number of modes K, 1 .. 1024 (default 96).
    seed : int
        Seed of the random draws (spacings, drive spreads, pan angles), >= 0.
        The same seed gives the same board for any ``inputs``, ``outputs``.
    size : float
        Board scale, 0.25 .. 4 (default 1): every frequency is divided by it
        (lowest mode ``50 / size`` Hz, spacing ``20 / size`` Hz) and decay
        times are multiplied by it.
    brightness : float
        Spectral tilt of the smoothed response in dB per octave re 1 kHz,
        -12 .. 12 (default 0 = flat on average).
    inputs : int
        Bridge inputs B, 1 or 2 (0: bass end, 1: treble end).
    outputs : int
        Outputs C, 1 or 2 (0: left, 1: right).
    peaks : sequence of (f_hz, q, level_db), optional
        Named resonances added to the K diffuse modes (at most 32): the
        body's own low modes that give an instrument its identity -- a
        gourd's or a box's air (Helmholtz) mode, the top plate's first
        bending modes -- at frequency ``f_hz`` (20 .. 20000 Hz, below
        ``NYQUIST_FRACTION fs``), quality factor ``q`` = f / bandwidth
        (1 .. 500; T60 = 2.2 q / f) and peak ``level_db`` above the diffuse
        bank's smoothed level at that frequency (-30 .. 30 dB). The smoothed
        power level of modes of peak gain g, bandwidth B and density n is
        ``(pi / 2) g^2 B n``, which the diffuse bank holds at ``(pi / 2)
        tilt(f)^2`` (g = tilt / sqrt(B n)); a peak of level L gets
        ``g = 10^(L / 20) sqrt(pi / 2) tilt(f)``. Its drive is 1 at every
        input and its pickup centred (equal at both outputs), so it keeps
        the positive-real sum: no notch below the direct part.

    Returns
    -------
    BoardModes
        The K diffuse modes and the P peaks sorted by frequency (without
        peaks the lowest is exactly ``50 / size`` Hz), decay times, drive
        (B, K) > 0, pickup (C, K) >= 0 and dry (C, B) >= 0, scaled so that the
        modal part realised by :func:`resonator_coefs` at
        :data:`REFERENCE_FS` and the direct part each have a white-noise
        power gain of 1 at that rate, averaged over the inputs and summed
        over the outputs.
    """
    fs = _fs_param(fs)
    n_modes = _int_param("n_modes", n_modes, MIN_N_MODES, MAX_N_MODES)
    seed = _int_param("seed", seed, 0, 2**63 - 1)
    size = _float_param("size", size, *SIZE_RANGE)
    brightness = _float_param("brightness", brightness, *BRIGHTNESS_RANGE_DB, unit=" dB/octave")
    B = _int_param("inputs", inputs, 1, MAX_INPUTS)
    C = _int_param("outputs", outputs, 1, MAX_OUTPUTS)
    pk = _peaks_param(peaks, fs)

    f_low, f_high, spacing, f_c, a_dens = _layout(fs, n_modes, size)
    rng = np.random.default_rng(seed)
    K = n_modes
    # Wigner-surmise spacings (mean 1) in the warped coordinate u = N(f).
    s = np.sqrt(-4.0 / math.pi * np.log1p(-rng.random(K)))
    s = np.maximum(s, MIN_SPACING)
    spread_db = DRIVE_SPREAD_DB * rng.standard_normal((MAX_INPUTS, K))
    theta = 0.5 * math.pi * rng.random(K)

    n_c = (f_c - f_low) / spacing  # u at the end of the uniform part
    n_total = n_c + a_dens * math.log(f_high / f_c)
    if K > 1:
        u = np.concatenate(([0.0], np.cumsum(s[1:])))
        u *= n_total / u[-1]
    else:
        u = np.zeros(1)
    freqs = np.where(u <= n_c, f_low + u * spacing,
                     f_c * np.exp((u - n_c) / max(a_dens, 1e-300)))
    freqs[0] = f_low
    freqs = np.minimum(freqs, f_high)

    rho = _density(freqs, spacing, f_c, a_dens)
    gamma = math.log(ETA_HIGH / ETA_LOW) / math.log(ETA_KNEE_RATIO)
    eta = np.minimum(ETA_LOW * (freqs / f_low) ** gamma, ETA_HIGH)
    bw_hz = eta * freqs
    thinned = freqs > f_c  # fewer modes than the board has: keep them overlapping
    bw_hz[thinned] = np.maximum(bw_hz[thinned], OVERLAP / rho[thinned])
    bw_hz = np.minimum(bw_hz, freqs)  # Q >= 1 even for a very thin bank
    t60 = math.log(1000.0) / (math.pi * bw_hz)

    g = 10.0 ** (brightness * np.log2(freqs / 1000.0) / 20.0) / np.sqrt(bw_hz * rho)
    drive = 10.0 ** (spread_db[:B] / 20.0)
    pickup = np.vstack((np.cos(theta), np.sin(theta))) if C == 2 else np.ones((1, K))
    if pk.shape[0]:
        fp, qp, lp = pk.T
        gp = 10.0 ** ((brightness * np.log2(fp / 1000.0) + lp) / 20.0) * math.sqrt(0.5 * math.pi)
        freqs = np.concatenate((freqs, fp))
        t60 = np.concatenate((t60, math.log(1000.0) * qp / (math.pi * fp)))
        g = np.concatenate((g, gp))
        drive = np.hstack((drive, np.ones((B, fp.size))))
        centre = np.full((C, fp.size), math.sqrt(0.5) if C == 2 else 1.0)
        pickup = np.hstack((pickup, centre))
        order = np.argsort(freqs, kind="stable")
        freqs, t60, g = freqs[order], t60[order], g[order]
        drive, pickup = drive[:, order], pickup[:, order]
        K = freqs.size
    pickup = pickup * g
    unit = resonator_coefs(REFERENCE_FS, freqs, t60, np.ones(K))
    gram = _modal_gram(unit, drive, pickup)
    scale = 1.0 / math.sqrt(np.trace(gram) / B)
    pickup = pickup * scale
    gram = gram * scale * scale
    dry = _dry_matrix(B, C, gram)
    return BoardModes(freqs, t60, np.ascontiguousarray(drive), np.ascontiguousarray(pickup), dry)


def _peaks_param(peaks, fs):
    """``peaks`` as a (P, 3) float array of (f_hz, q, level_db) rows, validated."""
    try:
        a = np.asarray(peaks if peaks is not None else (), dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"peaks = {peaks!r} must be a sequence of (f_hz, q, level_db) triples") \
            from None
    if a.size == 0:
        return np.zeros((0, 3))
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"peaks has shape {a.shape}; must be (P, 3) rows of (f_hz, q, level_db)")
    if a.shape[0] > MAX_PEAKS:
        raise ValueError(f"peaks has {a.shape[0]} rows; at most {MAX_PEAKS}")
    f_hi = min(PEAK_HZ_RANGE[1], NYQUIST_FRACTION * _layout_fs(fs))
    for i, (f, q, level) in enumerate(a):
        if not (math.isfinite(f) and PEAK_HZ_RANGE[0] <= f <= f_hi):
            raise ValueError(f"peaks[{i}] f_hz = {f:g} Hz is out of range "
                             f"({PEAK_HZ_RANGE[0]:g} <= value <= {f_hi:g})")
        if not (math.isfinite(q) and PEAK_Q_RANGE[0] <= q <= PEAK_Q_RANGE[1]):
            raise ValueError(f"peaks[{i}] q = {q:g} is out of range "
                             f"({PEAK_Q_RANGE[0]:g} <= value <= {PEAK_Q_RANGE[1]:g})")
        if not (math.isfinite(level) and PEAK_DB_RANGE[0] <= level <= PEAK_DB_RANGE[1]):
            raise ValueError(f"peaks[{i}] level_db = {level:g} dB is out of range "
                             f"({PEAK_DB_RANGE[0]:g} <= value <= {PEAK_DB_RANGE[1]:g})")
    return a


def _modal_gram(unit_coefs, drive, pickup):
    """(B, B) white-noise Gram matrix of the modal part, summed over outputs:
    G[b, b'] = sum_c sum_n m_cb[n] m_cb'[n], m_cb the bank with peak gains
    pickup[c] * drive[b] (``unit_coefs``: the sections with unit gains)."""
    B, C = drive.shape[0], pickup.shape[0]
    G = np.zeros((B, B))
    for c in range(C):
        banks = [_scaled(unit_coefs, pickup[c] * drive[b]) for b in range(B)]
        for b in range(B):
            for b2 in range(b, B):
                G[b, b2] += white_noise_cross_energy(banks[b], banks[b2])
    return np.triu(G) + np.triu(G, 1).T


def _scaled(unit_coefs, gains):
    c = unit_coefs.copy()
    c[0] *= gains
    return c


def _dry_matrix(B, C, gram):
    """The direct part (C, B), >= 0, white-noise power 1 averaged over the inputs."""
    if B == 1:
        d = np.ones((C, 1))
    elif C == 1:
        d = np.ones((1, 2))
    else:
        rho = gram[0, 1] / math.sqrt(gram[0, 0] * gram[1, 1])
        rho = min(max(rho, 0.0), 1.0)
        r = (1.0 - math.sqrt(1.0 - rho * rho)) / rho if rho > 0 else 0.0  # 2 r / (1 + r^2) = rho
        d = np.array([[1.0, r], [r, 1.0]])
    return d / math.sqrt((d * d).sum() / B)


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
        Peak gains (any finite value; the board uses positive ones).

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


def _poles_residues(coefs, name):
    """(Q, P, C): the bank's response as h[n] = Q delta[n] + sum_a C_a P_a^n
    (P, C over both poles of every section)."""
    coefs = np.asarray(coefs, dtype=np.float64)
    if coefs.ndim != 2 or coefs.shape[0] != 3:
        raise ValueError(f"{name} has shape {coefs.shape}; must be (3, K)")
    b0, a1, a2 = coefs
    if not np.all((a1 * a1 < 4.0 * a2) & (a2 < 1.0)):
        raise ValueError(f"{name}: every section must have complex poles inside the unit circle "
                         "(a1^2 < 4 a2 < 4)")
    r = np.sqrt(a2)
    cos_t = np.clip(-a1 / (2.0 * r), -1.0, 1.0)
    p = r * (cos_t + 1j * np.sqrt(1.0 - cos_t * cos_t))
    # residue at p of N(w)/D(w), w = z^-1: c = N(1/p) / (1 - p*/p)
    w = 1.0 / p
    c = b0 * (1.0 - w * w) / (1.0 - np.conj(p) / p)
    q = b0 - 2.0 * c.real
    return q.sum(), np.concatenate((p, np.conj(p))), np.concatenate((c, np.conj(c)))


def white_noise_cross_energy(coefs1, coefs2):
    """Exact sum_n h1[n] h2[n] of two banks (the cross power for white noise).

    Each section ``b0 (1 - z^-2) / (1 + a1 z^-1 + a2 z^-2)`` with complex
    poles p, p* is written ``q + c / (1 - p z^-1) + c* / (1 - p* z^-1)``, so
    a bank's response is ``h[n] = Q delta[n] + sum_a C_a P_a^n`` and

        sum_n h1 h2 = Q1 Q2 + Q1 sum_a C2_a + Q2 sum_a C1_a
                      + sum_{a,b} C1_a C2_b / (1 - P1_a P2_b).

    Parameters
    ----------
    coefs1, coefs2 : ndarray, shape (3, K1) and (3, K2)
        Rows ``b0, a1, a2`` as from :func:`resonator_coefs`; every section
        must have complex poles inside the unit circle (a1^2 < 4 a2 < 4).

    Returns
    -------
    float
        The cross energy of the two impulse responses (dimensionless).
    """
    Q1, P1, C1 = _poles_residues(coefs1, "coefs1")
    Q2, P2, C2 = _poles_residues(coefs2, "coefs2")
    cross = (C1[:, None] * C2[None, :] / (1.0 - P1[:, None] * P2[None, :])).sum()
    return float((Q1 * Q2 + Q1 * C2.sum() + Q2 * C1.sum() + cross).real)


def white_noise_power_gain(coefs):
    """Exact sum_n h[n]^2 of the summed bank (the power gain for white noise).

    Parameters
    ----------
    coefs : ndarray, shape (3, K)
        Rows ``b0, a1, a2`` as from :func:`resonator_coefs`; every section
        must have complex poles inside the unit circle (a1^2 < 4 a2 < 4).

    Returns
    -------
    float
        The energy of the bank's impulse response (dimensionless), see
        :func:`white_noise_cross_energy`.
    """
    Q, P, C = _poles_residues(coefs, "coefs")
    cross = (C[:, None] * C[None, :] / (1.0 - P[:, None] * P[None, :])).sum()
    return float((Q * Q + 2.0 * Q * C.sum() + cross).real)


def section_response(fs, coefs, f_hz):
    """Complex frequency response of each section, shape (K, F).

    Parameters
    ----------
    fs : float
        Sample rate in Hz (>= 8000).
    coefs : ndarray, shape (3, K)
        Rows ``b0, a1, a2`` as from :func:`resonator_coefs`.
    f_hz : array_like of float, shape (F,)
        Frequencies in Hz, 0 <= f <= fs / 2.

    Returns
    -------
    ndarray of complex128, shape (K, F)
        ``b0 (1 - z^-2) / (1 + a1 z^-1 + a2 z^-2)`` at ``z = exp(2 pi j f / fs)``.
    """
    fs = _fs_param(fs)
    coefs = np.asarray(coefs, dtype=np.float64)
    if coefs.ndim != 2 or coefs.shape[0] != 3:
        raise ValueError(f"coefs has shape {coefs.shape}; must be (3, K)")
    f = np.atleast_1d(np.asarray(f_hz, dtype=np.float64))
    if f.ndim != 1 or not np.all(np.isfinite(f) & (f >= 0) & (f <= fs / 2)):
        raise ValueError(f"f_hz must be a 1-D array of frequencies in [0, fs/2 = {fs / 2:g}] Hz")
    w = np.exp(-2j * math.pi * f / fs)
    b0, a1, a2 = (row[:, None] for row in coefs)
    return b0 * (1.0 - w * w) / (1.0 + a1 * w + a2 * w * w)


def smoothed_db(f_hz, power, fraction=1.0 / 3.0):
    """Fractional-octave smoothing of a power response, in dB.

    The mean of ``power`` over the points of a log-spaced grid within
    ``fraction`` of an octave centred on each point (a rectangular window
    in log frequency; the band is cut at the ends of the grid).

    Parameters
    ----------
    f_hz : array_like of float, shape (F,)
        Increasing, log-spaced frequencies in Hz (> 0).
    power : array_like of float, shape (F,)
        Power response (|H|^2) at ``f_hz``, >= 0.
    fraction : float
        Band width in octaves, 0 < fraction <= 2 (default 1/3).

    Returns
    -------
    ndarray of float, shape (F,)
        ``10 log10`` of the band means.
    """
    f = np.asarray(f_hz, dtype=np.float64)
    p = np.asarray(power, dtype=np.float64)
    if f.ndim != 1 or p.shape != f.shape or f.size < 2 or not np.all(f > 0) \
            or not np.all(np.diff(f) > 0):
        raise ValueError("f_hz must be increasing positive frequencies and power the same shape")
    fraction = _float_param("fraction", fraction, 1e-6, 2.0, unit=" octave")
    lf = np.log2(f)
    cs = np.concatenate(([0.0], np.cumsum(p)))
    lo = np.searchsorted(lf, lf - fraction / 2.0)
    hi = np.searchsorted(lf, lf + fraction / 2.0, side="right")
    with np.errstate(divide="ignore"):
        return 10.0 * np.log10((cs[hi] - cs[lo]) / (hi - lo))


def knock_impulse_ns(hammer_mass_kg, hammer_speed_m_per_s, ratio=KNOCK_IMPULSE_RATIO):
    """Impulse of the knock as an equivalent bridge force (N s).

    ``J = ratio * m_h * v_h``: a multiple of the hammer's momentum. Why this
    scale: the key stops on the keybed within a few ms of the hammer-string
    contact (Askenfelt & Jansson 1990), carrying a momentum m_k v_k; with the
    grand action's hammer-to-key speed ratio of about 5 and an effective
    key mass at the front of ~0.05 kg, m_k v_k ~ 0.01 v_h, about the
    hammer's own momentum (5-11 g, :func:`synth.physics.piano.hammer_mass_kg`
    with one string). It reaches the air through the keybed, the case, the
    rim and the board, and the hammer's blow also pushes the whole
    string-frame-board system; J is the force on the bridge that radiates
    the same thump, not a transferred momentum, so ``ratio`` may exceed 1.
    ``KNOCK_IMPULSE_RATIO`` = 0.1 is an estimate (the sources give the
    mechanism, timing and spectrum of the thump, not its force); the grand
    preset's ``action.knock`` = 3.9 is fitted to a recorded grand's thump
    (``python tools/study_partials.py thump``: 20 Hz to 1 kHz or f0/2
    over the first 100 ms, re C4's partial 1; docs/voicing.md, "The thump under the attack").
    For comparison, the hammer gives the string about m_h v_h, which reaches
    the bridge as the string's own wave. Linear in the hammer speed, so the
    knock keeps its level relative to the tone at every velocity
    (:func:`knock_pulse` makes the force signal), as the recording's does
    (its thump re C4's partial 1 moves by under 3 dB between layers).

    Parameters
    ----------
    hammer_mass_kg : float
        Mass of the whole hammer, 0.001 .. 0.05 kg.
    hammer_speed_m_per_s : float
        Hammer speed at the strings, 0 .. 20 m/s.
    ratio : float
        Impulse re the hammer's momentum, 0 .. 10 (default 0.1).

    Returns
    -------
    float
        The knock's impulse in N s.
    """
    m = _float_param("hammer_mass_kg", hammer_mass_kg, 0.001, 0.05, unit=" kg")
    v = _float_param("hammer_speed_m_per_s", hammer_speed_m_per_s, 0.0, 20.0, unit=" m/s")
    ratio = _float_param("ratio", ratio, 0.0, KNOCK_RATIO_MAX)
    return ratio * m * v


class KnockShape(NamedTuple):
    """The shape of a voice's knock (:func:`knock_pulse`): the duration (s)
    of its force pulse, and the time constant (s) over which its pushes
    build up (0: one pulse)."""

    duration_s: float = KNOCK_DURATION_S
    build_s: float = 0.0


def knock_pulse(fs, impulse_ns, duration_s=KNOCK_DURATION_S, build_s=0.0):
    """The knock's force: one raised-cosine pulse, or a train of them built up.

    ``build_s`` = 0: ``F(t) = (J / T) (1 - cos(2 pi t / T))`` for 0 <= t < T,
    sampled at ``t = (i + 1/2) / fs``, i = 0 .. N-1, N = max(1, round(T
    fs)), and scaled so that ``sum F / fs = J`` exactly. Its spectrum is flat
    (|F(f)| = J) to within 1 dB up to about 0.4 / T (80 Hz for the default
    5 ms), falls by 6 dB at 1 / T and has its first zero at 2 / T: a short
    push that excites the board's low modes evenly (the thump) and little
    else.

    ``build_s`` = tau > 0: the same pulses, :data:`KNOCK_TRAIN_HZ` a second
    at random places (one in each 1 / KNOCK_TRAIN_HZ s) with random signs
    (a sparse "velvet" train, seeded: :data:`KNOCK_SEED`), weighted by
    ``(t / tau) exp(1 - t / tau)`` over ``KNOCK_BUILD_SPAN tau``, and scaled
    to the single pulse's energy (``sum F^2 / fs`` equal).  The thump then
    builds up over about tau, in pushes of both signs: the action's impacts
    (the key on the keybed and its rebound, the hammer's reaction) reaching
    the board through the keyframe and the case by paths of many lengths.  Why: a recorded grand's thump (20 Hz to
    1 kHz or f0 / 2) builds up to its peak 10-35 ms after the onset and
    reaches 1 kHz (docs/voicing.md, "The thump under the attack"); one pulse
    peaks at once.  The places and signs are drawn in seconds, so the train
    is the same at every rate.

    Parameters
    ----------
    fs : float
        Sample rate in Hz (>= 8000).
    impulse_ns : float
        The single pulse's area J in N s, 0 .. 10 (see :func:`knock_impulse_ns`);
        a train has that pulse's energy.
    duration_s : float
        Duration T of each pulse in s, 0.0002 .. 0.02 (default 0.005).
    build_s : float
        Time constant tau of the train's build-up in s, 0 .. 0.05 (0: one
        pulse).

    Returns
    -------
    ndarray of float64, shape (N,)
        Force samples in N: one pulse (>= 0, peak 2 J / T), or the train
        (about ``KNOCK_BUILD_SPAN tau + T`` long).
    """
    fs = _fs_param(fs)
    j = _float_param("impulse_ns", impulse_ns, 0.0, 10.0, unit=" N s")
    t = _float_param("duration_s", duration_s, *KNOCK_DURATION_RANGE_S, unit=" s")
    tau = _float_param("build_s", build_s, *KNOCK_BUILD_RANGE_S, unit=" s")
    n = max(1, int(round(t * fs)))
    shape = 1.0 - np.cos(2.0 * math.pi * (np.arange(n) + 0.5) / n)
    pulse = shape * (j * fs / shape.sum())
    if tau == 0.0:
        return pulse
    span = KNOCK_BUILD_SPAN * tau
    m = int(math.ceil(span * KNOCK_TRAIN_HZ))
    rng = np.random.default_rng(KNOCK_SEED)
    at = (np.arange(m) + rng.random(m)) / KNOCK_TRAIN_HZ          # s
    sign = np.where(rng.random(m) < 0.5, -1.0, 1.0)
    weight = sign * (at / tau) * np.exp(1.0 - at / tau)
    out = np.zeros(int(math.ceil((span + t) * fs)) + 1)
    for a, w in zip(at, weight):
        # the pulse starting at a, sampled at (i + 1/2) / fs
        i0 = int(math.ceil(a * fs - 0.5))
        i1 = min(int(math.ceil((a + t) * fs - 0.5)), out.shape[0])
        x = ((np.arange(i0, i1) + 0.5) / fs - a) / t
        out[i0:i1] += w * (1.0 - np.cos(2.0 * math.pi * x))
    e1 = float(np.dot(pulse, pulse))
    e = float(np.dot(out, out))
    return out * math.sqrt(e1 / e) if e > 0.0 else out


def spread_allpasses(fs, spread_ms):
    """The radiation's spread as allpasses (see the module docstring).

    Parameters
    ----------
    fs : float
        Rate the cascade runs at, Hz (>= 8000).
    spread_ms : float
        The longest allpass's delay, ms, within :data:`SPREAD_RANGE_MS`;
        0: no spread.

    Returns
    -------
    delays : ndarray of int64, shape (S,)
        Each allpass's delay in samples at ``fs`` (``spread_ms`` times
        :data:`SPREAD_RATIOS`, rounded, each at least one more than the
        last); empty when ``spread_ms`` is 0.
    gains : ndarray of float64, shape (S,)
        Each allpass's gain, :data:`SPREAD_GAIN`.
    """
    fs = _fs_param(fs)
    v = _float_param("spread_ms", spread_ms, *SPREAD_RANGE_MS, " ms")
    if v == 0.0:
        return np.zeros(0, dtype=np.int64), np.zeros(0)
    delays, last = [], 0
    for r in SPREAD_RATIOS:
        d = max(int(round(v * 1e-3 * r * fs)), last + 1)
        delays.append(d)
        last = d
    return np.array(delays, dtype=np.int64), np.full(len(delays), SPREAD_GAIN)


#: the mass law's fitted sections, by (fs, mass_hz)
_MASS_SECTIONS: dict = {}
#: its fit: frequencies, the top one's limit as a fraction of fs, the weight below MASS_FIT_SPLIT_HZ
MASS_FIT_POINTS = 64
MASS_FIT_TOP = 0.45
MASS_FIT_SPLIT_HZ = 5000.0
MASS_FIT_WEIGHT = 10.0


def mass_section_check(fs, mass_hz):
    """``(fs, mass_hz)`` as floats, checked as :func:`mass_section` checks
    them (a ValueError naming the one out of range)."""
    fs = _fs_param(fs)
    v = _float_param("mass_hz", mass_hz, *MASS_RANGE_HZ, " Hz")
    if v >= 0.5 * fs:
        raise ValueError(f"mass_hz = {mass_hz!r} Hz is out of range (0 <= value < fs / 2 = {0.5 * fs:g})")
    return fs, v


def mass_section(fs, mass_hz):
    """The board's mass law at the rate ``fs`` (see the module docstring):
    the first-order section g (1 + b z^-1) / (1 - a z^-1), g = (1 - a) /
    (1 + b), of unit gain at 0 Hz, fitted to |1 / (1 + j f / mass_hz)|.

    Parameters
    ----------
    fs : float
        Rate, Hz (>= 8000).
    mass_hz : float
        The corner, Hz, within :data:`MASS_RANGE_HZ` and under fs / 2;
        0: no mass law.

    Returns
    -------
    tuple of float
        ``(g, b, a)``, 0 < a < 1, |b| < 1; ``(1.0, 0.0, 0.0)`` when
        ``mass_hz`` is 0 (the section passes its input unchanged).
    """
    fs, v = mass_section_check(fs, mass_hz)
    if v == 0.0:
        return (1.0, 0.0, 0.0)
    key = (fs, v)
    got = _MASS_SECTIONS.get(key)
    if got is None:
        from scipy.optimize import least_squares

        f = np.geomspace(20.0, min(20000.0, MASS_FIT_TOP * fs), MASS_FIT_POINTS)
        w = np.where(f < MASS_FIT_SPLIT_HZ, MASS_FIT_WEIGHT, 1.0)
        want = -10.0 * np.log10(1.0 + (f / v) ** 2)
        z1 = np.exp(-2j * np.pi * f / fs)

        def residual(p):
            a, b = p
            return w * (20.0 * np.log10(np.abs((1.0 - a) / (1.0 + b) * (1.0 + b * z1) / (1.0 - a * z1)))
                        - want)

        a0 = math.exp(-2.0 * math.pi * v / fs)
        r = least_squares(residual, [a0, 0.0], bounds=([0.0, -0.99], [0.9999, 0.99]),
                          xtol=1e-14, ftol=1e-14)
        a, b = (float(x) for x in r.x)
        got = _MASS_SECTIONS[key] = ((1.0 - a) / (1.0 + b), b, a)
    return got
