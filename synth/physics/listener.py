"""A listening position: the instrument's sound as radiated to a place in a room (data and laws).

The voice's output is what its body radiates (the soundboard's modes driven
by the bridge force); a listener never hears that as such, but at a place:
close microphones over the strings, as recorded piano libraries are made, the
player's seat, or a seat in a hall.  This module designs that path, as data
for :class:`synth.dsp.listener.Listener` (whose kernel,
:mod:`synth.kernels.listener`, runs it):

* **the direct sound**: the inverse-distance law (-6.02 dB per doubling of
  ``distance_m``), the board's directivity by frequency at this position,
  and the air's absorption over the distance (:func:`air_absorption_db_per_m`,
  ISO 9613-1), as one minimum-phase FIR (:func:`min_phase_fir`);
* **the early reflections**: the image sources of a shoebox room up to the
  second order (Allen and Berkley 1979), each at its own delay and its
  1/r and wall-reflection gain, through one shared filter (the walls'
  absorption by frequency and the air over the reflections' mean path);
* **the late reverberation**: a feedback delay network (Jot and Chaigne
  1991) of :data:`FDN_LINES` lines whose one-pole absorption filters give
  the room's T60 exactly at 500 Hz and 4 kHz (Eyring's formula with the
  air's absorption, :func:`room_t60_s`), its level that of the diffuse
  field, 1 / r_c^2 re the direct sound at 1 m, r_c^2 = A / (16 pi) the
  critical distance's square (A the room's absorption area, m^2), less the
  energy before the network's first output.

Delays are relative to the direct sound, so the stage adds no latency (an
event at t still sounds at t).  Rooms are designed (:data:`ROOMS`) or taken
from a measured impulse response (:func:`measured_room`: its decay per
band, its direct-to-reverberant ratio and its strongest early peaks drive
the same network and taps; the file is not convolved).

Directivity.  ``directivity_db`` is the direct sound's level at high
frequencies re the board's power average (its directivity index at the
position's angle): + on the board's axis (above the strings, or in the
open lid's beam), - off it (the player sees the board's edge, the lid opens
away from him).  Close microphones, 0.5 m over a board some 1.5 m across,
are in its near field, where no far-field directivity has formed: 0 dB
there (with +3 dB the una corda's darkening of keys 90 and 96, -11.6 and
-11.8 % at the body, read -9.6 and -7.9 %, against issue 11's -10 %).
The shape is ``directivity_db f^2 / (f^2 + f_d^2)`` with
``f_d`` = :data:`DIRECTIVITY_HZ`: a board radiates evenly below about
1 kHz and ever more unevenly above (J. Meyer, *Acoustics and the
Performance of Music*, 5th ed., Springer 2009, ch. 4.5, the grand piano's
directivity).  The positions' values are designed, not measured.

Everything is in SI units: m, s, Hz, degrees Celsius, percent relative
humidity.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = [
    "POSITIONS", "ROOMS", "ROOM_NAMES", "LEVELS", "Position", "Room", "ListenerDesign",
    "air_absorption_db_per_m", "room_t60_s", "critical_distance_m", "image_sources",
    "min_phase_fir", "one_pole_for_t60", "design_listener", "measured_room", "SPEED_OF_SOUND_M_PER_S",
    "DISTANCE_RANGE_M", "DIRECTIVITY_RANGE_DB", "TEMPERATURE_RANGE_C", "HUMIDITY_RANGE_PERCENT",
]

#: the speed of sound at 20 degrees C (m/s); :func:`speed_of_sound_m_per_s` for others
SPEED_OF_SOUND_M_PER_S = 343.2
#: the octave bands of the rooms' absorption data (Hz)
BANDS_HZ = np.array([125.0, 250.0, 500.0, 1000.0, 2000.0, 4000.0, 8000.0])
#: the two frequencies at which the late reverberation's T60 is exact (Hz)
T60_HZ = (500.0, 4000.0)
#: lines of the feedback delay network (a power of two: a Hadamard feedback matrix)
FDN_LINES = 8
#: taps of the direct and the early reflections' minimum-phase filters at 48 kHz
#: (scaled with the rate)
FIR_TAPS_48K = 32
#: the frequency where the directivity reaches half its high-frequency value (Hz)
DIRECTIVITY_HZ = 1000.0
#: the latest early reflection kept (s after the direct sound): later ones are the network's
EARLY_MAX_S = 0.1
#: early reflections kept per channel (the strongest)
EARLY_TAPS = 24
#: what the instrument's body takes off a reflection arriving at microphones over
#: the strings from below the board (dB): a designed figure (a rigid screen's
#: shadow at 1 kHz, several wavelengths across, is 15-25 dB)
SHADOW_DB = -20.0
#: the allowed ranges of the [listener] keys (units in the names)
DISTANCE_RANGE_M = (0.1, 50.0)
DIRECTIVITY_RANGE_DB = (-12.0, 12.0)
TEMPERATURE_RANGE_C = (-20.0, 50.0)
HUMIDITY_RANGE_PERCENT = (5.0, 100.0)
#: how the stage's level is set: "matched" (the same mean level over the octaves
#: 125 Hz - 4 kHz at every position: the preset's output.gain holds) or "distance"
#: (the direct sound at 1 m is unity: farther is quieter, as in the room)
LEVELS = ("matched", "distance")


@dataclass(frozen=True)
class Room:
    """A shoebox room: size (m), the walls' mean absorption per octave band
    (:data:`BANDS_HZ`), and where the instrument stands in it (m from the
    corner at the origin; its board's height)."""

    name: str
    size_m: tuple[float, float, float]
    absorption: tuple[float, ...]
    source_m: tuple[float, float, float]
    doc: str

    @property
    def volume_m3(self) -> float:
        x, y, z = self.size_m
        return x * y * z

    @property
    def surface_m2(self) -> float:
        x, y, z = self.size_m
        return 2.0 * (x * y + x * z + y * z)


@dataclass(frozen=True)
class Position:
    """A listening position: its distance from the board's centre (m), the
    height of the ear or microphone above the floor (m), the direct sound's
    directivity re the board's power average (dB, high frequencies), its
    room; a stereo output's two microphones (or ears) are ``pair_m`` apart
    along the room's length, their centre ``pair_shift_m`` from the point
    at the distance (each channel's reflections arrive at their own
    delays).  ``cardioid``: the microphones are cardioids aimed at the
    board's centre (a reflection from angle t to their axis is heard with
    (1 + cos t) / 2, the diffuse field with a third of its power, the
    cardioid's random-energy efficiency); omnidirectional (ears) otherwise.
    ``over_board``: the microphones are over the strings, so that the
    instrument itself (board, rim and case) stands between them and every
    reflection that arrives from below the board: those are heard
    :data:`SHADOW_DB` lower."""

    name: str
    distance_m: float
    height_m: float
    directivity_db: float
    room: str
    doc: str
    pair_m: float = 0.0
    pair_shift_m: float = 0.0
    cardioid: bool = False
    over_board: bool = False


#: the designed rooms (absorption per octave band 125 Hz - 8 kHz; designed for
#: these T60s at 500 Hz / 4 kHz with the air at 20 C, 50 %: ``room_t60_s``)
ROOMS = {
    "studio": Room("studio", (12.0, 9.0, 5.0), (0.22, 0.27, 0.30, 0.30, 0.31, 0.32, 0.33),
                   (4.0, 4.0, 1.0), "a piano recording room, 540 m^3, T60 0.57 s at 500 Hz"),
    "room": Room("room", (6.0, 5.0, 2.8), (0.18, 0.22, 0.26, 0.28, 0.30, 0.32, 0.34),
                 (1.8, 2.2, 1.0), "a living room, 84 m^3, T60 0.37 s at 500 Hz"),
    "hall": Room("hall", (40.0, 26.0, 16.0), (0.24, 0.26, 0.27, 0.28, 0.29, 0.31, 0.33),
                 (8.0, 12.0, 1.2), "a concert hall, 16600 m^3, T60 1.97 s at 500 Hz"),
}
#: the values ``listener.room`` takes besides a WAV file's path ("none": no room, the direct sound alone)
ROOM_NAMES = ("none",) + tuple(ROOMS)

#: the listening positions
POSITIONS = {
    "close": Position("close", 0.5, 1.5, 0.0, "studio",
                      "close microphones 0.5 m over the strings, on the board's axis, as "
                      "recorded piano libraries are made: a bass and a treble microphone "
                      "0.7 m apart, towards the hammers; cardioids aimed at the board",
                      0.7, -0.25, cardioid=True, over_board=True),
    "player": Position("player", 1.0, 1.2, -3.0, "studio",
                       "the player's seat: the board seen from its edge, the lid opening "
                       "away; the ears 0.17 m apart", 0.17, 0.0),
    "hall": Position("hall", 12.0, 1.2, 3.0, "hall",
                     "a seat in a hall, 12 m away, in the open lid's beam; a pair 0.5 m apart",
                     0.5, 0.0),
}


def speed_of_sound_m_per_s(temperature_c: float) -> float:
    """The speed of sound in air (m/s) at ``temperature_c`` (ideal gas, 331.3 m/s at 0 C)."""
    return 331.3 * math.sqrt(1.0 + temperature_c / 273.15)


def air_absorption_db_per_m(f_hz, temperature_c: float = 20.0, humidity_percent: float = 50.0,
                            pressure_kpa: float = 101.325):
    """The air's sound absorption (dB/m) by frequency: ISO 9613-1:1993, eqs. 3-5, B.1.

    Parameters
    ----------
    f_hz : float or array
        Frequencies (Hz).
    temperature_c : float
        Air temperature (degrees C).
    humidity_percent : float
        Relative humidity (%).
    pressure_kpa : float
        Atmospheric pressure (kPa).

    Returns
    -------
    float or ndarray
        Attenuation in dB per metre (ISO 9613-2's table 2, 20 C, 70 %: 5.0,
        22.9, 76.6 dB/km at 1, 4, 8 kHz).
    """
    f = np.asarray(f_hz, dtype=float)
    T = temperature_c + 273.15
    T0, T01, pr = 293.15, 273.16, 101.325
    pa = pressure_kpa / pr
    C = -6.8346 * (T01 / T) ** 1.261 + 4.6151
    h = humidity_percent * 10.0 ** C / pa
    frO = pa * (24.0 + 4.04e4 * h * (0.02 + h) / (0.391 + h))
    frN = pa * (T / T0) ** -0.5 * (9.0 + 280.0 * h * math.exp(-4.170 * ((T / T0) ** (-1.0 / 3.0) - 1.0)))
    a = 8.686 * f * f * (1.84e-11 / pa * (T / T0) ** 0.5 + (T / T0) ** -2.5 * (
        0.01275 * math.exp(-2239.1 / T) / (frO + f * f / frO)
        + 0.1068 * math.exp(-3352.0 / T) / (frN + f * f / frN)))
    return a if a.ndim else float(a)


def _absorption_at(room: Room, f_hz):
    """The walls' mean absorption at ``f_hz``, interpolated over the octave bands in log f."""
    return np.interp(np.log2(np.maximum(np.asarray(f_hz, float), 1.0)), np.log2(BANDS_HZ),
                     room.absorption)


def absorption_area_m2(room: Room, f_hz, temperature_c=20.0, humidity_percent=50.0):
    """The room's equivalent absorption area (m^2): Eyring's walls plus the air's 4 m V."""
    a = _absorption_at(room, f_hz)
    m = np.asarray(air_absorption_db_per_m(f_hz, temperature_c, humidity_percent)) / (10.0 * math.log10(math.e))
    return -room.surface_m2 * np.log(1.0 - a) + 4.0 * m * room.volume_m3


def room_t60_s(room: Room, f_hz, temperature_c=20.0, humidity_percent=50.0):
    """T60 (s) of ``room`` at ``f_hz``: Eyring's formula with the air's absorption,
    T60 = 24 ln(10) V / (c A)."""
    c = speed_of_sound_m_per_s(temperature_c)
    return 24.0 * math.log(10.0) * room.volume_m3 / (c * absorption_area_m2(
        room, f_hz, temperature_c, humidity_percent))


def critical_distance_m(room: Room, f_hz=1000.0, temperature_c=20.0, humidity_percent=50.0):
    """The distance (m) at which the direct sound of an omnidirectional source
    equals the diffuse field: sqrt(A / (16 pi))."""
    return np.sqrt(absorption_area_m2(room, f_hz, temperature_c, humidity_percent) / (16.0 * math.pi))


def image_sources(size_m, source_m, listener_m, order: int = 2, with_positions: bool = False):
    """The image sources of a shoebox room up to ``order`` reflections (Allen
    and Berkley 1979).

    Returns
    -------
    list of (distance_m, reflections) or (distance_m, reflections, position_m)
        Each image's distance to the listener and the number of walls it
        met (and, ``with_positions``, where the image is); the direct sound
        (0 reflections) first.
    """
    out = []
    rng = range(-order, order + 1)
    for kx in rng:
        for ky in rng:
            for kz in rng:
                n = abs(kx) + abs(ky) + abs(kz)
                if n > order:
                    continue
                p = []
                for k, s, L in zip((kx, ky, kz), source_m, size_m):
                    p.append(s + k * L if k % 2 == 0 else -s + (k + 1) * L)
                d = math.dist(p, listener_m)
                out.append((d, n, tuple(p)) if with_positions else (d, n))
    out.sort(key=lambda t: (t[1], t[0]))
    return out


def min_phase_fir(gain_of_hz, fs: float, taps: int, n_fft: int = 4096) -> np.ndarray:
    """A minimum-phase FIR whose magnitude follows ``gain_of_hz`` (a function
    of frequency in Hz giving a linear gain > 0): the real cepstrum folded
    (Oppenheim and Schafer, the homomorphic method), cut to ``taps`` with a
    half-Hann fade over its last quarter."""
    f = np.fft.rfftfreq(n_fft, 1.0 / fs)
    mag = np.maximum(np.asarray(gain_of_hz(f), float), 1e-6)
    c = np.fft.irfft(np.log(mag), n_fft)
    w = np.zeros(n_fft)
    w[0] = 1.0
    w[1:n_fft // 2] = 2.0
    w[n_fft // 2] = 1.0
    h = np.fft.irfft(np.exp(np.fft.rfft(c * w)), n_fft)[:taps]
    q = max(1, taps // 4)
    h[taps - q:] *= 0.5 * (1.0 + np.cos(np.pi * np.arange(1, q + 1) / (q + 1)))
    return h


def one_pole_for_t60(m: int, fs: float, t60_lo_s: float, t60_hi_s: float,
                     f_lo_hz: float = T60_HZ[0], f_hi_hz: float = T60_HZ[1]):
    """The absorption filter a / (1 - b z^-1) of a delay line of ``m`` samples
    that gives T60 = ``t60_lo_s`` at ``f_lo_hz`` and ``t60_hi_s`` at
    ``f_hi_hz`` exactly (Jot and Chaigne 1991: a line's gain per pass is
    10^(-3 m / (T60 fs))).  Returns (a, b), 0 <= b < 1."""
    g1 = 10.0 ** (-3.0 * m / (t60_lo_s * fs))
    g2 = 10.0 ** (-3.0 * m / (t60_hi_s * fs))
    w1, w2 = 2.0 * math.pi * f_lo_hz / fs, 2.0 * math.pi * f_hi_hz / fs
    r = (g1 / g2) ** 2
    if abs(r - 1.0) < 1e-12:
        b = 0.0
    else:
        B = math.cos(w2) - r * math.cos(w1)
        disc = max(B * B - (1.0 - r) ** 2, 0.0)
        roots = [(B + s * math.sqrt(disc)) / (1.0 - r) for s in (1.0, -1.0)]
        b = min(roots, key=abs)
    b = min(max(b, 0.0), 0.999)
    a = g1 * math.sqrt(1.0 - 2.0 * b * math.cos(w1) + b * b)
    return a, b


def _primes_near(targets):
    """Distinct primes, each the first at or above its target."""
    out = []
    for t in targets:
        n = max(int(round(t)), 3)
        while True:
            if n not in out and all(n % p for p in range(2, int(n ** 0.5) + 1)):
                out.append(n)
                break
            n += 1
    return out


@dataclass(frozen=True)
class MeasuredRoom:
    """What :func:`measured_room` reads from an impulse response: T60 at
    :data:`T60_HZ`, the diffuse field's level as a critical distance (m) at
    the given distance, and the early reflections (delay s, gain re the
    direct sound)."""

    path: str
    t60_s: tuple[float, float]
    critical_distance_m: float
    early: tuple[tuple[float, float], ...]


@dataclass(frozen=True)
class ListenerDesign:
    """The stage's design at one output rate (see the module docstring).

    ``direct`` (taps,), ``early_fir`` (taps,): minimum-phase FIRs (the
    direct gain folded in); ``early_lag`` (K,) int samples after the direct
    sound and ``early_gain`` (K,) per channel (C, K); ``pre`` the network's
    input delay (samples); ``fdn_len`` (N,) its lines (samples),
    ``fdn_a``, ``fdn_b`` (N,) their absorption filters, ``fdn_in`` (N,),
    ``fdn_out`` (C, N) its input and output vectors (unscaled: the wrapper
    sets the late level to ``late_energy``, the diffuse field's power in the
    1 kHz octave re the direct sound's at 1 m); ``t60_s`` the design's T60
    at :data:`T60_HZ`; ``level`` as :data:`LEVELS`."""

    fs: float
    channels: int
    direct: np.ndarray
    early_fir: np.ndarray
    early_lag: np.ndarray
    early_gain: np.ndarray
    pre: int
    fdn_len: np.ndarray
    fdn_a: np.ndarray
    fdn_b: np.ndarray
    fdn_in: np.ndarray
    fdn_out: np.ndarray
    late_energy: float
    t60_s: tuple[float, float]
    level: str
    distance_m: float
    room: str


def _hadamard_signs(n: int, row: int) -> np.ndarray:
    """Row ``row`` of the n x n Sylvester-Hadamard matrix (entries +-1)."""
    i = np.arange(n)
    return np.array([1.0 - 2.0 * (bin(row & j).count("1") % 2) for j in i])


def design_listener(fs: float, channels: int, position: str = "close", room: str | None = None,
                    distance_m: float | None = None, directivity_db: float | None = None,
                    temperature_c: float = 20.0, humidity_percent: float = 50.0,
                    level: str = "matched") -> ListenerDesign:
    """Design the listening stage (see the module docstring).

    Parameters
    ----------
    fs : float
        The output rate (Hz).
    channels : int
        1 or 2 (the body's outputs).
    position : str
        A key of :data:`POSITIONS`.
    room : str or None
        A :data:`ROOM_NAMES` value, a WAV file's path, or None (the position's).
    distance_m, directivity_db : float or None
        The position's own values when None.
    temperature_c, humidity_percent : float
        The air (ISO 9613-1).
    level : str
        One of :data:`LEVELS`.
    """
    pos = POSITIONS[position]
    r = float(pos.distance_m if distance_m is None else distance_m)
    di = float(pos.directivity_db if directivity_db is None else directivity_db)
    room_name = pos.room if room is None else room
    c_air = speed_of_sound_m_per_s(temperature_c)
    taps = max(8, int(round(FIR_TAPS_48K * fs / 48_000.0)))
    air = lambda f, d: 10.0 ** (-air_absorption_db_per_m(f, temperature_c, humidity_percent) * d / 20.0)
    dirf = lambda f: 10.0 ** (di * f * f / (f * f + DIRECTIVITY_HZ ** 2) / 20.0)
    direct = min_phase_fir(lambda f: dirf(f) * air(f, r) / r, fs, taps)
    C = int(channels)
    empty = np.zeros((C, 0))
    if room_name == "none":
        return ListenerDesign(fs, C, direct, np.zeros(taps), np.zeros(0, np.int64), empty, 0,
                              np.zeros(0, np.int64), np.zeros(0), np.zeros(0), np.zeros(0),
                              np.zeros((C, 0)), 0.0, (0.0, 0.0), level, r, room_name)
    if room_name in ROOMS:
        rm = ROOMS[room_name]
        t60 = tuple(float(room_t60_s(rm, f, temperature_c, humidity_percent)) for f in T60_HZ)
        rc = float(critical_distance_m(rm, 1000.0, temperature_c, humidity_percent))
        # the listener: at the distance from the board, at its height (or above the board
        # when closer than the height difference), along the room's length
        sx, sy, sz = rm.source_m
        dz = min(pos.height_m - sz, r)
        lx = sx + math.sqrt(max(r * r - dz * dz, 0.0))
        lst = (min(lx, rm.size_m[0] - 0.2), sy, sz + dz)
        beta = lambda f: np.sqrt(1.0 - _absorption_at(rm, f))
        b1k = float(beta(1000.0))
        refl = []
        for ch in range(C):
            # a spaced pair along the room's length (one microphone: at the pair's centre)
            dx = pos.pair_shift_m + (pos.pair_m * (ch - 0.5) if C == 2 else 0.0)
            lc = (min(max(lst[0] + dx, 0.1), rm.size_m[0] - 0.1), lst[1], lst[2])
            d0 = math.dist(rm.source_m, lc)
            axis = np.subtract(rm.source_m, lc) / max(d0, 1e-9)
            imgs = []
            for d, nref, img in image_sources(rm.size_m, rm.source_m, lc, with_positions=True)[1:]:
                g = b1k ** nref / d
                if pos.cardioid:
                    g *= 0.5 * (1.0 + float(np.dot(np.subtract(img, lc) / d, axis)))
                if pos.over_board and img[2] < sz:
                    g *= 10.0 ** (SHADOW_DB / 20.0)
                imgs.append((d - d0, g))
            refl.append([(t, g) for t, g in imgs if 0.0 < t / c_air <= EARLY_MAX_S and g > 0.0])
        mean_path = float(np.mean([r + t for ch in refl for t, _ in ch])) if refl[0] else r
        early_fir = min_phase_fir(lambda f: beta(f) / b1k * air(f, mean_path), fs, taps)
    else:
        mr = measured_room(room_name, r)
        t60 = mr.t60_s
        rc = mr.critical_distance_m
        refl = [[(t * c_air, g / r) for t, g in mr.early] for _ in range(C)]
        early_fir = min_phase_fir(lambda f: air(f, 0.0), fs, taps)
    K = min(EARLY_TAPS, max((len(x) for x in refl), default=0))
    lag = np.zeros((C, K), np.int64)
    gain = np.zeros((C, K))
    for ch in range(C):
        best = sorted(refl[ch], key=lambda t: -t[1])[:K]
        for k, (dd, g) in enumerate(sorted(best)):
            lag[ch, k] = max(1, int(round(dd / c_air * fs)))
            gain[ch, k] = g
    # the network: lines about one to two and a half mean free paths long, at least 10 ms
    if room_name in ROOMS:
        mfp = 4.0 * ROOMS[room_name].volume_m3 / ROOMS[room_name].surface_m2 / c_air
    else:
        mfp = 0.02
    base = max(mfp, 0.01) * fs
    fdn_len = np.array(_primes_near(base * np.geomspace(1.0, 2.5, FDN_LINES)), np.int64)
    ab = [one_pole_for_t60(int(m), fs, t60[0], t60[1]) for m in fdn_len]
    fdn_a = np.array([a for a, _ in ab])
    fdn_b = np.array([b for _, b in ab])
    pre = int(lag.max()) // 2 if K else int(round(0.01 * fs))
    t_late = (pre + int(fdn_len.min())) / fs
    t60_1k = float(np.exp(np.interp(math.log(1000.0), np.log(T60_HZ), np.log(t60))))
    late_energy = (1.0 / 3.0 if pos.cardioid else 1.0) / rc ** 2 * math.exp(-6.0 * math.log(10.0) * t_late / t60_1k)
    fdn_in = _hadamard_signs(FDN_LINES, 3)
    fdn_out = np.array([_hadamard_signs(FDN_LINES, 5 + 2 * ch) for ch in range(C)])
    return ListenerDesign(fs, C, direct, early_fir, lag, gain, pre, fdn_len, fdn_a, fdn_b,
                          fdn_in, fdn_out, late_energy, t60, level, r, room_name)


def measured_room(path: str, distance_m: float) -> MeasuredRoom:
    """Read a measured room impulse response (a WAV file): its T60 at
    :data:`T60_HZ` (Schroeder's backward integral of each octave band, the
    fit from -5 to -25 dB, T20), its diffuse field as a critical distance
    (its direct-to-reverberant energy ratio taken to hold at ``distance_m``)
    and its strongest early peaks (1-100 ms after the direct sound: delay s,
    amplitude re the direct sound).  The file is not convolved: these drive
    the designed network and taps.  Raises ``ValueError`` naming
    ``listener.room`` if the file cannot serve."""
    import soundfile
    from scipy.signal import butter, sosfilt

    p = Path(path)
    if not p.is_file():
        raise ValueError(f"listener.room = {path!r}: no such file (a room: "
                         f"{', '.join(ROOM_NAMES)}, or a WAV file's path)")
    try:
        h, fs = soundfile.read(str(p), dtype="float64", always_2d=True)
    except Exception as e:  # noqa: BLE001 - the library's message, one line
        raise ValueError(f"listener.room = {path!r}: not a readable sound file "
                         f"({str(e).splitlines()[0] if str(e) else type(e).__name__})") from None
    h = h.mean(axis=1)
    if h.size < int(0.2 * fs) or not np.any(h):
        raise ValueError(f"listener.room = {path!r}: an impulse response of at least 0.2 s "
                         f"that is not silent is needed (it has {h.size / fs:.3g} s)")
    i0 = int(np.argmax(np.abs(h)))
    w = max(1, int(0.0025 * fs))
    e_dir = float(np.sum(h[max(0, i0 - w):i0 + w] ** 2))
    e_rev = float(np.sum(h[i0 + w:] ** 2))
    rc = distance_m * math.sqrt(e_dir / max(e_rev, 1e-30))
    t60 = []
    for fc in T60_HZ:
        sos = butter(4, [fc / math.sqrt(2.0), min(fc * math.sqrt(2.0), 0.45 * fs)], "bandpass",
                     fs=fs, output="sos")
        y = sosfilt(sos, h[i0:])
        edc = np.cumsum((y ** 2)[::-1])[::-1]
        edc_db = 10.0 * np.log10(np.maximum(edc / edc[0], 1e-30))
        sel = np.flatnonzero((edc_db <= -5.0) & (edc_db >= -25.0))
        if sel.size < 10:
            raise ValueError(f"listener.room = {path!r}: its decay at {fc:g} Hz does not reach "
                             f"-25 dB (too short or too noisy to give a T60)")
        t = sel / fs
        slope = np.polyfit(t, edc_db[sel], 1)[0]
        t60.append(float(-60.0 / slope))
    a = np.abs(h)
    lo, hi = i0 + max(1, int(0.001 * fs)), min(h.size, i0 + int(EARLY_MAX_S * fs))
    seg = a[lo:hi]
    peaks = [j for j in range(1, seg.size - 1) if seg[j] >= seg[j - 1] and seg[j] > seg[j + 1]]
    peaks = sorted(peaks, key=lambda j: -seg[j])[:EARLY_TAPS]
    early = tuple(sorted(((lo + j - i0) / fs, float(h[lo + j] / h[i0])) for j in peaks))
    return MeasuredRoom(str(p), (t60[0], t60[1]), rc, early)
