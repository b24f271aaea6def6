"""The measures of ``tools/study_partials.py`` (the studies behind the grand's
fit to a recorded grand, issue 11; ``docs/voicing.md``, "Fitted to a
recorded grand"), on notes at 48 kHz with note-on at t = 0, read against
each key's stiff-string law (:func:`synth.physics.piano.grand_string`):

* :func:`early_t60_s`: the early T60 of partials 1-8;
* :func:`partial_levels_db`: peak and band levels of partials 1..n;
* :func:`thump_db`, :func:`thump_spectrum_db`: the thump under an attack;
* :func:`damping_rows`, :func:`ratio_summary`: the strings' loss at 3-8 kHz;
* :func:`beat_roughness_db`: how much a unison's partials beat;
* :func:`tail_t60_and_level`, :func:`level_curve_db`: the aftersound;
* :func:`midi_of`: the key and layer of a recorded grand's sample from its
  file name (``C4v10.ogg``; ``tools/real_grand.py``).

The tool's studies render the model and read a recording with them; they
live here so that they are tested from the package.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from ..analysis import band_levels_db, estimate_f0, track_partials
from ..physics.piano import et_f0_hz, grand_string
from .voicing import FS  # the rate the measures read: the voicing report's renders and the recordings'

N_PARTIALS = 8


def _f0_law(y, key):
    g = grand_string(key)
    B = g.inharmonicity_b
    f1 = estimate_f0(y[int(0.05 * FS):int(1.05 * FS)], FS, g.partial_hz(1), search_cents=60.0)
    return f1 / math.sqrt(1.0 + B), B


def early_t60_s(y, key, hi_s=1.2, hop_s=0.05, win_s=0.2):
    """Early T60 (s) of partials 1..8 of ``y`` (48 kHz, note-on at 0)."""
    f0, B = _f0_law(y, key)
    ts, levels = [], []
    t = 0.05
    while t + win_s <= hi_s + win_s / 2:
        seg = y[int(t * FS):int((t + win_s) * FS)]
        _, lv, _ = track_partials(seg, FS, f0, N_PARTIALS, inharmonicity=B)
        ts.append(t + win_s / 2)
        levels.append(lv)
        t += hop_s
    ts, levels = np.array(ts), np.array(levels)
    out = []
    for k in range(N_PARTIALS):
        slope = np.polyfit(ts, levels[:, k], 1)[0]
        out.append(-60.0 / slope if slope < -1e-3 else 99.0)
    return np.array(out)


def partial_levels_db(y, key, t0, t1, n=10):
    """(peak levels, band levels) of partials 1..n over t0..t1 s, dB re
    the strongest of each."""
    f0, B = _f0_law(y, key)
    seg = y[int(t0 * FS):int(t1 * FS)]
    _, peak, _ = track_partials(seg, FS, f0, n, inharmonicity=B)
    P = np.abs(np.fft.rfft(seg * np.hanning(len(seg)))) ** 2
    fr = np.fft.rfftfreq(len(seg), 1.0 / FS)
    band = np.array([10 * np.log10(P[np.abs(fr - j * f0 * math.sqrt(1 + B * j * j)) < 0.45 * f0].sum()
                                   + 1e-300) for j in range(1, n + 1)])
    return peak - np.nanmax(peak), band - band.max()


#: the thump's band (Hz): from THUMP_LOW_HZ to THUMP_HIGH_HZ or f0 / 2, whichever is lower
THUMP_LOW_HZ, THUMP_HIGH_HZ = 20.0, 1000.0


#: the attack window the thump is read over (s)
THUMP_WINDOW_S = 0.1


def _band_power_db(y, lo_hz, hi_hz, window_s=THUMP_WINDOW_S):
    """Power (dB) of ``y``'s first ``window_s`` (mean removed) in ``lo_hz``
    < f < ``hi_hz`` (:func:`synth.analysis.band_levels_db`, Hann window)."""
    seg = np.array(y[:int(round(window_s * FS))], dtype=np.float64)
    seg -= seg.mean()
    return float(band_levels_db(seg, FS, 0.5 * (lo_hz + hi_hz), 0.5 * (hi_hz - lo_hz))[0])


def thump_db(y, key, c4):
    """The thump under key ``key``'s attack ``y``: its power below the
    note (20 Hz to 1 kHz or f0 / 2) over the first 100 ms, dB re the power
    of partial 1 of ``c4`` (C4 in the same layer) over the same window."""
    f0 = et_f0_hz(key)
    ref = et_f0_hz(60)
    return (_band_power_db(y, THUMP_LOW_HZ, min(THUMP_HIGH_HZ, 0.5 * f0))
            - _band_power_db(c4, 0.7 * ref, 1.3 * ref))


#: the thump's spectrum: bands (Hz) whose power per Hz is read re the 90-360 Hz band's
THUMP_BANDS_HZ = ((20.0, 90.0), (90.0, 360.0), (360.0, 720.0), (720.0, 1000.0))


def thump_spectrum_db(y):
    """The thump's spectrum over the first 100 ms: the power per Hz in each
    of ``THUMP_BANDS_HZ``, dB re the 90-360 Hz band's (read it on keys
    whose f0 / 2 lies above 1 kHz, where no partial falls in the bands)."""
    lv = [_band_power_db(y, lo, hi) - 10.0 * math.log10(hi - lo) for lo, hi in THUMP_BANDS_HZ]
    return np.array(lv) - lv[1]


#: the band and the level floor of the ``damping`` study
DAMPING_BAND_HZ = (3000.0, 8000.0)


DAMPING_FLOOR_DB = -50.0


def damping_rows(key, real, model):
    """(partial, f (Hz), level (dB), real T60, model T60) of each partial
    1-8 of ``key`` in ``DAMPING_BAND_HZ`` whose level in ``real``'s
    0.05-0.35 s lies within ``-DAMPING_FLOOR_DB`` of its strongest, and
    whose early T60 both notes read (not 99)."""
    g = grand_string(key)
    tr, tm = early_t60_s(real, key), early_t60_s(model, key)
    pk, _ = partial_levels_db(real, key, 0.05, 0.35, n=N_PARTIALS)
    out = []
    for j in range(N_PARTIALS):
        f = g.partial_hz(j + 1)
        if (DAMPING_BAND_HZ[0] <= f <= DAMPING_BAND_HZ[1] and pk[j] > DAMPING_FLOOR_DB
                and tr[j] < 99.0 and tm[j] < 99.0):
            out.append((j + 1, f, float(pk[j]), float(tr[j]), float(tm[j])))
    return out


def ratio_summary(rows):
    """(median, lower quartile, upper quartile) of model / real T60 over
    ``rows`` (geometric: the quantiles of log2 of the ratios)."""
    lr = np.log2([m / t for *_, t, m in rows])
    return tuple(float(2.0 ** np.percentile(lr, q)) for q in (50, 25, 75))


#: the ``beats`` study: frames, span, and the partials it counts
BEAT_WIN_S, BEAT_HOP_S, BEAT_SPAN_S = 0.1, 0.025, (0.1, 3.0)


BEAT_START_DB, BEAT_FLOOR_DB = -40.0, -70.0


def partial_envelopes_db(y, key, span_s=BEAT_SPAN_S, win_s=BEAT_WIN_S, hop_s=BEAT_HOP_S):
    """(frame centres (s), peak levels (dB), shape (frames, 8)) of partials
    1-8 of ``y`` (48 kHz, note-on at 0) in ``win_s`` frames every ``hop_s``
    over ``span_s``."""
    f0, B = _f0_law(y, key)
    ts, levels = [], []
    t = span_s[0]
    while t + win_s <= span_s[1] + 1e-9:
        _, lv, _ = track_partials(y[int(t * FS):int((t + win_s) * FS)], FS, f0, N_PARTIALS,
                                  inharmonicity=B)
        ts.append(t + win_s / 2)
        levels.append(lv)
        t += hop_s
    return np.array(ts), np.array(levels)


def hinge_residual_db(t, level):
    """RMS (dB) of ``level`` about the continuous two-segment line through
    it that fits best (its knee at any frame but the first and last four):
    what is left is the beating, not the decay or its knee."""
    best = np.inf
    for tk in t[4:-4]:
        A = np.stack([np.ones_like(t), t, np.maximum(t - tk, 0.0)], axis=1)
        c, *_ = np.linalg.lstsq(A, level, rcond=None)
        best = min(best, float(np.sqrt(np.mean((level - A @ c) ** 2))))
    return best


def beat_roughness_db(y, key):
    """``hinge_residual_db`` of each partial 1-8 of ``y`` (NaN for those
    whose first frame lies more than ``-BEAT_START_DB`` under the
    strongest; frames more than ``-BEAT_FLOOR_DB`` under it are left out)."""
    ts, L = partial_envelopes_db(y, key)
    top = np.nanmax(L[0])
    out = []
    for k in range(N_PARTIALS):
        e = L[:, k]
        ok = np.isfinite(e) & (e > top + BEAT_FLOOR_DB)
        if not e[0] >= top + BEAT_START_DB or ok.sum() < 12:
            out.append(np.nan)
            continue
        out.append(hinge_residual_db(ts[ok], e[ok]))
    return np.array(out)


#: the ``tail`` study's window (s) and level floor (dB re the loudest frame)
TAIL_SPAN_S, TAIL_LEVEL_S, TAIL_FLOOR_DB = (2.5, 9.0), 1.5, -70.0


def tail_t60_and_level(y, span_s=TAIL_SPAN_S, level_s=TAIL_LEVEL_S, floor_db=TAIL_FLOOR_DB):
    """(T60 (s) of a line through the note's level over ``span_s``, the
    median level (dB re the loudest 50 ms frame) over the first
    ``level_s`` of it) of ``y`` (48 kHz, note-on at 0); the span ends at
    most 1.5 s before ``y`` does.  T60 is inf where the level does not
    fall, and both NaN with fewer than 20 frames above ``floor_db``."""
    lv = level_curve_db(y, 0.05)
    t = (np.arange(len(lv)) + 0.5) * 0.05
    t1 = min(span_s[1], len(y) / FS - 1.5)
    m = (t >= span_s[0]) & (t <= t1) & (lv > floor_db)
    if m.sum() < 20:
        return float("nan"), float("nan")
    slope = np.polyfit(t[m], lv[m], 1)[0]
    level = float(np.median(lv[(t >= span_s[0]) & (t <= span_s[0] + level_s)]))
    return (-60.0 / slope if slope < 0 else float("inf")), level


def level_curve_db(y, frame_s=0.1):
    """The note's level (dB re its loudest frame) in ``frame_s`` frames."""
    fr = int(frame_s * FS)
    n = len(y) // fr
    lv = 10.0 * np.log10(np.mean(np.asarray(y[:n * fr], dtype=np.float64).reshape(n, fr) ** 2, axis=1)
                         + 1e-30)
    return lv - lv.max()


_NOTE = re.compile(r"^([A-G]#?)(\d)v(\d+)\.(ogg|wav|flac)$")


_PITCH = {"C": 0, "C#": 1, "D": 2, "D#": 3, "E": 4, "F": 5, "F#": 6, "G": 7, "G#": 8, "A": 9,
          "A#": 10, "B": 11}


def midi_of(name: str) -> tuple[int, int] | None:
    """(MIDI key, velocity layer) of a sample's file name, or None."""
    m = _NOTE.match(name)
    if not m:
        return None
    return 12 * (int(m.group(2)) + 1) + _PITCH[m.group(1)], int(m.group(3))


def load_recording(path) -> np.ndarray:
    """A recorded note (a file of ``path``) at 48 kHz (:data:`FS`), mono (mean of the channels), from 2 ms before its
    first sample above 1 % of its peak."""
    import soundfile as sf
    from scipy.signal import resample_poly

    y, fs = sf.read(str(path), dtype="float64", always_2d=True)
    y = y.mean(axis=1)
    if fs != FS:
        g = math.gcd(int(fs), FS)
        y = resample_poly(y, FS // g, int(fs) // g)
    i0 = int(np.argmax(np.abs(y) > 0.01 * np.max(np.abs(y))))
    return y[max(0, i0 - int(0.002 * FS)):]


# -- issue 41's measures: a note against a recorded grand, per octave ------------------------

#: the octaves of issue 41's table: (name, lowest key, highest key)
OCTAVES = (("C2-B2", 36, 47), ("C3-B3", 48, 59), ("C4-B4", 60, 71), ("C5-B5", 72, 83),
           ("C6-B6", 84, 95), ("C7-C8", 96, 108))
#: the fitted layer of tools/real_grand.py --octaves (issue 41: fit on v10,
#: report the others without refitting)
FIT_LAYER = 10
#: the model's velocity for each recorded layer: the velocity at which the
#: grand is as much under its velocity 127 as the layer is under the
#: library's loudest, v16 (maximum momentary loudness, median over
#: :data:`ANCHOR_KEYS`; :func:`layer_levels_db`, :func:`model_velocity_for`;
#: ``python tools/real_grand.py DIR --layer-velocities``).  The recording's
#: own level is the library's and the grand's is its calibration's, so
#: only steps in loudness compare: v4 -13.0, v10 -7.1, v14 -2.6 dB re v16
#: give velocities 52, 78 and 106 (the Salamander's own SFZ plays v10 at
#: velocities 73-80 and v14 at 105-112, v4 at 37-43: the grand's soft end
#: is 4 dB quieter re its fortissimo than the library's).  Issue 41 first
#: matched C4's level alone (v10 at velocity 105, 5.6 m/s: near fortissimo
#: where the library has a mezzo-forte).
LAYER_VELOCITY = {4: 52, 10: 78, 14: 106}
#: the keys of the layers' loudness steps (C2-C7 and A2-A5)
ANCHOR_KEYS = (36, 45, 48, 57, 60, 69, 72, 81, 84, 96)
#: the library's loudest layer, played at velocity 127
TOP_LAYER = 16
#: the onset: the first sample within this level of the note's peak (dB)
ONSET_DB = -40.0


def onset_index(y) -> int:
    """The first sample of ``y`` within :data:`ONSET_DB` of its peak."""
    a = np.abs(np.asarray(y, float))
    return int(np.argmax(a >= a.max() * 10.0 ** (ONSET_DB / 20.0)))


def _partial_power(seg, f_hz, half_width_hz):
    """Power of ``seg`` (Hann window, numpy FFT) within ``half_width_hz`` of ``f_hz``."""
    P = np.abs(np.fft.rfft(seg * np.hanning(len(seg)))) ** 2
    fr = np.fft.rfftfreq(len(seg), 1.0 / FS)
    return float(P[np.abs(fr - f_hz) < half_width_hz].sum()) + 1e-300


def partial1_at_db(y, key, t_s=3.0):
    """Partial 1's level at ``t_s`` after the onset, dB re its own peak
    (frames of max(0.1 s, 8 periods), hop a quarter of that; the partial's
    power within 0.3 f0 of it)."""
    f0, B = _f0_law(y, key)
    f1 = f0 * math.sqrt(1.0 + B)
    y = np.asarray(y, float)[onset_index(y):]
    win = max(0.1, 8.0 / f1)
    n = int(win * FS)
    hop = n // 4
    lv = []
    for i in range(0, max(1, len(y) - n), hop):
        lv.append(_partial_power(y[i:i + n], f1, 0.3 * f0))
    lv = 10.0 * np.log10(np.array(lv))
    j = min(int(round((t_s - win / 2) * FS / hop)), len(lv) - 1)
    return float(lv[j] - lv.max())


def upper_partials_db(y, key, t0=0.05, t1=0.5, n=10):
    """Partials 2..``n`` together re partial 1 over ``t0``..``t1`` s after
    the onset: 10 log10(sum P_2..n / P_1), each partial's power within
    0.45 f0 of it on the stiff string's law (numpy FFT, Hann window)."""
    f0, B = _f0_law(y, key)
    y = np.asarray(y, float)[onset_index(y):]
    seg = y[int(t0 * FS):int(t1 * FS)]
    P = [_partial_power(seg, j * f0 * math.sqrt(1.0 + B * j * j), 0.45 * f0) for j in range(1, n + 1)]
    return float(10.0 * np.log10(sum(P[1:]) / P[0]))


#: the attack centroid's upper limit (Hz): below the recording's own
#: bandwidth.  The Salamander samples are Vorbis files whose encoder keeps
#: nothing above 10.75-16 kHz (every 250 Hz band above the cut -125 to
#: -155 dB re the strongest over the first second, digital silence; the
#: lowest cuts on the keys C5 up, whose partials reach them: 10.75 kHz on
#: v4, 11.25 on v10, 11.5 on v14), so a
#: centroid over the whole band counted the model's 10-24 kHz against a
#: recording that cannot hold it (C7 1.91x over 0-24 kHz, 1.53x over 0-12).
CENTROID_MAX_HZ = 10_000.0


def attack_centroid_50ms_hz(y, max_hz=CENTROID_MAX_HZ):
    """The spectral centroid (Hz, magnitude-weighted, numpy FFT, Hann
    window) of the first 50 ms after the onset, over 0 .. ``max_hz``
    (:data:`CENTROID_MAX_HZ`, the recording's bandwidth; None: up to
    Nyquist)."""
    y = np.asarray(y, float)
    seg = y[onset_index(y):][:int(0.05 * FS)]
    m = np.abs(np.fft.rfft(seg * np.hanning(len(seg)), 1 << 13))
    f = np.fft.rfftfreq(1 << 13, 1.0 / FS)
    if max_hz is not None:
        m, f = m[f <= max_hz], f[f <= max_hz]
    return float((f * m).sum() / m.sum())


def time_to_rms_peak_ms(y, frame_s=0.01, hop_s=0.001, within_s=0.5):
    """Time (ms) from the onset to the peak of the RMS level (``frame_s``
    frames every ``hop_s``, centred; searched over the first ``within_s``)."""
    y = np.asarray(y, float)
    y = y[onset_index(y):][:int(within_s * FS)]
    n, h = int(frame_s * FS), int(hop_s * FS)
    y2 = np.concatenate([np.zeros(n // 2), y * y, np.zeros(n)])
    c = np.concatenate([[0.0], np.cumsum(y2)])
    starts = np.arange(0, len(y), h)
    e = c[starts + n] - c[starts]
    return float(starts[int(np.argmax(e))] / FS * 1e3)


def issue41_measures(y, key) -> dict:
    """Issue 41's four measures of one note (48 kHz, mono): partial 1 at
    3 s (dB re its peak), partials 2-10 re partial 1 over 0.05-0.5 s (dB),
    the first 50 ms's centroid (Hz), the time to the RMS peak (ms)."""
    return {"p1_3s_db": partial1_at_db(y, key), "upper_db": upper_partials_db(y, key),
            "centroid_hz": attack_centroid_50ms_hz(y), "peak_ms": time_to_rms_peak_ms(y)}


def octave_table(model: dict, real: dict) -> list[dict]:
    """Per-octave medians of :data:`OCTAVES` from ``model`` and ``real``
    (key -> :func:`issue41_measures`): model minus recording for the levels
    (dB), model / recording for the centroid, and each one's time to peak
    (ms)."""
    rows = []
    for name, lo, hi in OCTAVES:
        ks = [k for k in sorted(real) if lo <= k <= hi and k in model]
        if not ks:
            continue
        med = lambda f: float(np.median([f(k) for k in ks]))
        rows.append({"octave": name, "keys": ks,
                     "p1_3s_db": med(lambda k: model[k]["p1_3s_db"] - real[k]["p1_3s_db"]),
                     "upper_db": med(lambda k: model[k]["upper_db"] - real[k]["upper_db"]),
                     "centroid_ratio": med(lambda k: model[k]["centroid_hz"] / real[k]["centroid_hz"]),
                     "peak_ms_real": med(lambda k: real[k]["peak_ms"]),
                     "peak_ms_model": med(lambda k: model[k]["peak_ms"])})
    return rows


def _grand_notes(keys, position: str, velocity: int, seconds: float, voice=None, overrides=()):
    """Each of ``keys`` played at ``velocity`` for ``seconds`` on a fresh
    engine, heard at ``position`` (``"body"``: without the listening stage;
    ``"close"``, ``"player"``, ``"hall"``: ``[listener] position``): yields
    (key, the mean of its channels at the engine's rate)."""
    from ..dsp.listener import Listener
    from ..engine.engine import NOTE_ON, Event
    from ..io.factory import build_engine, build_voice

    overrides = tuple(overrides)
    voice = voice if voice is not None else build_voice("grand-piano", overrides)
    lst = None
    for k in keys:
        eng = build_engine("grand-piano", overrides, voice=voice, threads=1)
        if position != "body":
            if lst is None:
                lst = Listener.design(eng.fs_out, eng.channels, position)
            lst.reset()
        eng.listener = lst
        y = eng.render([Event(0.0, NOTE_ON, k, velocity / 127.0)], duration_s=seconds)
        yield k, (y.mean(axis=1) if y.ndim == 2 else y)


def octave_model(keys, position: str, velocity: int = 105, seconds: float = 6.0, voice=None,
                 overrides=()) -> dict:
    """The grand's notes for :func:`octave_table`: each of ``keys`` played at
    ``velocity`` for ``seconds`` on a fresh engine, heard at ``position``
    (``"body"``: without the listening stage; ``"close"``, ``"player"``,
    ``"hall"``: ``[listener] position``), the mean of its channels; key ->
    :func:`issue41_measures`.  ``overrides``: the preset's ``PATH=VALUE``
    changes (``synth --set``)."""
    return {k: issue41_measures(y, k)
            for k, y in _grand_notes(keys, position, velocity, seconds, voice, overrides)}


def recording_files(folder) -> dict:
    """The recorded samples under ``folder`` (searched recursively, named
    as :func:`midi_of` reads them): (key, layer) -> path."""
    files = {}
    for p in sorted(Path(folder).rglob("*")):
        km = midi_of(p.name) if p.is_file() else None
        if km is not None:
            files[km] = p
    return files


def layer_levels_db(folder, layers=(1, 4, 10, 14), keys=ANCHOR_KEYS, seconds: float = 4.0) -> dict:
    """Each recorded layer's maximum momentary loudness re the loudest
    layer's (:data:`TOP_LAYER`), dB, the median over ``keys`` of the
    per-key difference; ``folder`` holds the samples
    (:func:`recording_files`: the npm packages' ``piano-velocityN/audio``).
    Raises FileNotFoundError naming a missing sample."""
    from ..analysis.loudness import max_momentary_lufs

    names = recording_files(folder)

    def level(key, layer):
        if (key, layer) not in names:
            raise FileNotFoundError(f"no sample of key {key}, layer v{layer} under {folder}")
        return max_momentary_lufs(load_recording(names[(key, layer)])[:int(seconds * FS)], FS)

    top = {k: level(k, TOP_LAYER) for k in keys}
    return {L: float(np.median([level(k, L) - top[k] for k in keys])) for L in layers}


def model_levels_db(velocities, keys=ANCHOR_KEYS, seconds: float = 2.0, overrides=()) -> dict:
    """The grand's maximum momentary loudness at each of ``velocities`` re
    velocity 127, dB (the close position, the mean of its channels), the
    median over ``keys`` of the per-key difference."""
    from ..analysis.loudness import max_momentary_lufs
    from ..io.factory import build_voice

    voice = build_voice("grand-piano", tuple(overrides))
    lv = {v: np.array([max_momentary_lufs(y, FS) for _, y in
                       _grand_notes(keys, "close", v, seconds, voice, overrides)])
          for v in sorted(set(velocities) | {127})}
    return {v: float(np.median(lv[v] - lv[127])) for v in lv}


def model_velocity_for(level_db: float, model_levels: dict) -> float:
    """The velocity at which the grand is ``level_db`` re its velocity 127,
    interpolated linearly in :func:`model_levels_db`'s table."""
    v = np.array(sorted(model_levels))
    return float(np.interp(level_db, [model_levels[x] for x in v], v))


def octave_markdown(rows) -> str:
    """:func:`octave_table`'s rows as a Markdown table."""
    lines = ["| octave | partial 1 at 3 s, dB | partials 2-10 re 1, dB | centroid 50 ms, model/rec "
             "| time to RMS peak, rec / model ms |", "|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['octave']} | {r['p1_3s_db']:+.0f} | {r['upper_db']:+.0f} | "
                     f"{r['centroid_ratio']:.2f}x | {r['peak_ms_real']:.0f} / {r['peak_ms_model']:.0f} |")
    return "\n".join(lines)
