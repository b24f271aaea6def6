"""``synth compare``: compare presets (or WAV files) by ear in one web page.

Each stimulus is rendered (one note, or a MIDI file), all are padded to
the longest and brought to the same BS.1770 integrated loudness with no
sample peak above -1 dBFS, and written as 32-bit float WAV files beside
``index.html``: one self-contained page (script, style, audio and images
inline; it opens from disk) with

* A/B: switching between stimuli at the same playhead (every buffer plays
  in lockstep, switching moves the gains), with a loop region;
* blind ABX: N trials, X drawn at random (``?seed=N`` in the URL makes the
  draw reproducible), running score and exact one-sided binomial p-value;
* MUSHRA (ITU-R BS.1534) with three or more stimuli: a slider 0-100 per
  item in random order, among them a hidden reference (a copy of the first
  stimulus, which is also the open reference) and the 3.5 kHz low-pass
  anchor (:func:`lowpass_anchor`, loudness-matched like the others);
* after the test, the reveal: which stimulus was which, its loudness
  numbers, the analysis table (:func:`reveal_table`) and its spectrogram;
* results as CSV and JSON downloads, and, under ``synth compare --serve``
  (:func:`serve`), each answer POSTed to the local server, which appends it
  to ``DIR/answers.csv``.

The page embeds the audio (base64 of the same WAV bytes as the files
beside it) because a page opened from ``file://`` may not fetch its
neighbours.  Everything the reveal shows is in the page's source: a
listener who reads it is no longer blind.

Stimulus syntax (one command-line argument each)::

    grand-piano                                  a preset (name or .toml path)
    grand-piano:strings.t60_scale=2,tuning.stretch=0
                                                 ... with --set style overrides
    take1.wav                                    a WAV file, used as it is

Overrides are split at commas outside brackets and quotes, so
``sitar:termination.points=[[0,0],[0.01,1e-4]]`` works.
"""

from __future__ import annotations

import base64
import csv
import datetime as _dt
import functools
import io
import json
import math
import os
import shlex
import shutil
import tempfile
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

import numpy as np

from synth.analysis import as_mono, estimate_f0, spectral_centroid_hz, spectrogram
from synth.analysis.loudness import loudness as _loudness
from synth.io.errors import SynthError, display_path

__all__ = [
    "Stimulus", "CompareRequest", "parse_stimulus", "split_overrides", "match_loudness",
    "lowpass_anchor", "reveal_table", "spectrogram_png", "binomial_p_value",
    "make_comparison", "append_answers", "make_server", "serve", "ANSWER_COLUMNS",
    "FS", "CEILING_DBFS", "ANCHOR_HZ", "MAX_STIMULI", "MAX_TRIALS",
]

#: output rate of every stimulus (Hz): the engine's output rate
FS = 48_000
#: highest sample peak of any stimulus after matching (dBFS)
CEILING_DBFS = -1.0
#: the MUSHRA anchor's low-pass cutoff (Hz), ITU-R BS.1534-3
ANCHOR_HZ = 3500.0
#: at most this many stimuli (letters A-L; BS.1534 advises at most 12 items)
MAX_STIMULI = 12
#: ABX trials allowed (the page's exact p-value uses integers up to 2**n)
MAX_TRIALS = 1000
#: matched loudness of every stimulus is within this of the others (LU)
TOLERANCE_LU = 0.1
#: a stimulus must be at least one BS.1770 block long (s)
MIN_SECONDS = 0.4
#: the longest stimulus a page plays from a --midi file (s): a longer file's
#: first 10 minutes (a file of hours rendered for minutes with no sign of
#: life, issue 13)
MAX_MIDI_SECONDS = 600.0
#: columns of an answer row: the page's CSV and the server's answers.csv
ANSWER_COLUMNS = ("listener", "time", "test", "trial", "a", "b", "x", "choice", "correct",
                  "score", "n", "p_value", "stimulus", "rating")
#: answers.csv: the answer's columns plus the server's own clock
SERVER_COLUMNS = ("received",) + ANSWER_COLUMNS
_LETTERS = "ABCDEFGHIJKL"


# ---------------------------------------------------------------------------
# Stimuli
# ---------------------------------------------------------------------------

@dataclass(frozen=True)
class Stimulus:
    """One stimulus as given on the command line.

    ``kind`` is ``"preset"`` (``source`` a preset name or ``.toml`` path,
    ``overrides`` its ``PATH=VALUE`` strings) or ``"wav"`` (``source`` a
    file path)."""

    text: str
    kind: str
    source: str
    overrides: tuple[str, ...] = ()


def split_overrides(text: str) -> list[str]:
    """``"a.b=1,c.d=[1,2]"`` -> ``["a.b=1", "c.d=[1,2]"]``: split at commas
    outside brackets and quotes."""
    out, cur, depth, quote = [], [], 0, ""
    for ch in text:
        if quote:
            if ch == quote:
                quote = ""
        elif ch in "\"'":
            quote = ch
        elif ch in "[{":
            depth += 1
        elif ch in "]}":
            depth -= 1
        elif ch == "," and depth <= 0:
            out.append("".join(cur))
            cur = []
            continue
        cur.append(ch)
    out.append("".join(cur))
    return [s.strip() for s in out]


def parse_stimulus(text: str) -> Stimulus:
    """Parse one stimulus argument (see the module doc).

    Raises
    ------
    SynthError
        Empty text, an empty preset name, ``:`` with nothing after it, an
        empty override or one that is not ``PATH=VALUE`` with PATH a key of
        the preset schema (the message quotes the stimulus).
    """
    from synth.io.presets.validate import parse_override

    raw = text
    text = text.strip()
    if not text:
        raise SynthError("stimulus '': give a preset name, PRESET:PATH=VALUE,... or a .wav file")
    if text.lower().endswith((".wav", ".wave")):
        return Stimulus(raw, "wav", text)
    name, colon, rest = text.partition(":")
    name = name.strip()
    if not name:
        raise SynthError(f"stimulus {raw!r}: no preset name before ':'")
    if not colon:
        return Stimulus(raw, "preset", name)
    if not rest.strip():
        raise SynthError(f"stimulus {raw!r}: nothing after ':' (expected PATH=VALUE,...)")
    overrides = split_overrides(rest)
    for o in overrides:
        if not o:
            raise SynthError(f"stimulus {raw!r}: an empty override (two commas, or one at the end)")
        try:
            parse_override(o)
        except SynthError as e:
            raise SynthError(f"stimulus {raw!r}: {e}") from None
    return Stimulus(raw, "preset", name, tuple(overrides))


@dataclass(frozen=True)
class CompareRequest:
    """What ``synth compare`` was asked to do (validated by :func:`make_comparison`)."""

    stimuli: tuple[str, ...]
    out_dir: str
    midi: str | None = None
    key: int | None = None
    velocity: int = 100
    seconds: float = 3.0
    lufs: float | None = None
    trials: int = 10


@dataclass
class _Rendered:
    stim: Stimulus
    x: np.ndarray
    f0_hint_hz: float | None
    notes: list[str] = field(default_factory=list)


def _read_wav(stim: Stimulus) -> tuple[np.ndarray, list[str]]:
    import soundfile as sf

    path = stim.source
    shown = display_path(path)
    if not os.path.isfile(path):
        raise SynthError(f"stimulus {stim.text!r}: {shown}: no such file")
    try:
        x, fs = sf.read(path, dtype="float64", always_2d=True)
    except (RuntimeError, sf.LibsndfileError) as e:  # LibsndfileError is a RuntimeError
        raise SynthError(f"stimulus {stim.text!r}: {shown}: cannot read it as audio ({e})") from None
    notes = []
    if x.shape[1] > 1:
        notes.append(f"{shown}: {x.shape[1]} channels, compared as their mean (mono)")
    x = x.mean(axis=1)
    if not np.all(np.isfinite(x)):
        raise SynthError(f"stimulus {stim.text!r}: {shown}: has non-finite samples (NaN or inf)")
    if fs != FS:
        from scipy.signal import resample_poly

        g = math.gcd(int(fs), FS)
        x = resample_poly(x, FS // g, int(fs) // g)
        notes.append(f"{shown}: resampled from {fs} Hz to {FS} Hz")
    return x, notes


def _render_preset(stim: Stimulus, req: CompareRequest, events, keys, plan=None) -> _Rendered:
    from synth.engine.engine import Event
    from synth.io.factory import build_engine

    low = min(keys) if keys else req.key
    # one note (no MIDI file): a drone preset's key plucks its one string
    eng = build_engine(stim.source, stim.overrides, extra_low_key=low, drone=events is not None)
    preset, inst = eng.inst.preset, eng.inst
    notes = []
    if events is None:
        if preset.kind == "musical":
            if req.key is None:
                raise SynthError(f"stimulus {stim.text!r}: {stim.source} is a musical preset: give --key")
            lo, hi = preset.play.key_low, preset.play.key_high
            if not lo <= req.key <= hi:
                raise SynthError(f"stimulus {stim.text!r}: --key = {req.key} is outside the playable "
                                 f"range of {stim.source} ({lo} <= key <= {hi})")
        key = req.key if req.key is not None else -1
        x = eng.render([Event(0.0, "note_on", key, req.velocity / 127.0)], duration_s=req.seconds)
        try:
            f0 = float(inst.pitch_hz(req.key, None))
        except (TypeError, ValueError):
            f0 = None
    else:
        if preset.kind == "musical":
            lo, hi = preset.play.key_low, preset.play.key_high
            out_of = sum(1 for k in keys if not lo <= k <= hi)
            if out_of:
                notes.append(f"{stim.text}: {out_of} of {len(keys)} notes are outside the range "
                             f"{lo}..{hi}; they are played on the string retuned or fretted to that pitch")
        if plan is not None and plan.cut:
            x = eng.render(events, duration_s=plan.duration_s)
        else:
            x = eng.render(events, tail_s=0.5)
        f0 = None
    if np.ndim(x) == 2:
        notes.append(f"{stim.text}: stereo, compared as the mean of its channels (mono)")
    return _Rendered(stim, as_mono(x), f0, notes)


def _et_hz(key: int) -> float:
    return 440.0 * 2.0 ** ((key - 69) / 12.0)


# ---------------------------------------------------------------------------
# Loudness matching and the anchor
# ---------------------------------------------------------------------------

@dataclass(frozen=True)
class MatchResult:
    """Gains that bring signals to one integrated loudness.

    ``gains_db`` per signal; ``lufs`` and ``peaks_dbfs`` measured on the
    scaled signals (float32, as written); ``target_lufs`` the level asked
    for and ``level_lufs`` the one reached (lower when the ceiling
    limited it); ``limited_db`` how far every gain was lowered for the
    ceiling (0 when nothing would have clipped)."""

    gains_db: tuple[float, ...]
    lufs: tuple[float, ...]
    peaks_dbfs: tuple[float, ...]
    target_lufs: float
    level_lufs: float
    limited_db: float


def _integrated(x, fs):
    return _loudness(x, fs)["integrated_lufs"]


def _peak_db(x):
    p = float(np.max(np.abs(x)))
    return 20.0 * math.log10(p) if p > 0 else -math.inf


def match_loudness(signals: Sequence[np.ndarray], fs: float, target_lufs: float | None = None,
                   ceiling_dbfs: float = CEILING_DBFS, names: Sequence[str] | None = None,
                   reference_count: int | None = None) -> tuple[list[np.ndarray], MatchResult]:
    """Scale ``signals`` to one BS.1770 integrated loudness, none peaking above the ceiling.

    The level is ``target_lufs``, or the quietest of the first
    ``reference_count`` signals (all by default: the anchor, matched too,
    does not set the level).  If a gain would put a sample peak above
    ``ceiling_dbfs``, every gain is lowered by the same amount.  Gains are
    re-measured and corrected (BS.1770's absolute gate is not
    scale-invariant) until the levels agree within 0.01 LU.

    Returns
    -------
    scaled : list of float32 arrays
    MatchResult

    Raises
    ------
    SynthError
        A signal is silent (below the -70 LUFS gate) or shorter than 400 ms.
    """
    names = list(names) if names is not None else [f"signal {i}" for i in range(len(signals))]
    xs = [np.asarray(s, np.float64) for s in signals]
    lufs0 = []
    for name, x in zip(names, xs):
        if len(x) < int(round(MIN_SECONDS * fs)):
            raise SynthError(f"{name}: {len(x) / fs:.3f} s is shorter than one 400 ms BS.1770 block")
        v = _integrated(x, fs)
        if not math.isfinite(v):
            raise SynthError(f"{name}: silent (below BS.1770's -70 LUFS gate): cannot match its loudness")
        lufs0.append(v)
    n_ref = len(xs) if reference_count is None else reference_count
    target = min(lufs0[:n_ref]) if target_lufs is None else float(target_lufs)
    gains = [target - v for v in lufs0]
    margin = 1e-3  # dB below the ceiling, for float32 rounding
    limited = 0.0
    for _ in range(4):
        over = max(_peak_db(x) + g for x, g in zip(xs, gains)) - (ceiling_dbfs - margin)
        if over > 0:
            gains = [g - over for g in gains]
            limited += over
        scaled = [(x * 10.0 ** (g / 20.0)).astype(np.float32) for x, g in zip(xs, gains)]
        lufs = [_integrated(y.astype(np.float64), fs) for y in scaled]
        level = target - limited
        err = [v - level for v in lufs]
        if max(abs(e) for e in err) <= 0.01:
            break
        gains = [g - e for g, e in zip(gains, err)]
    peaks = [_peak_db(y) for y in scaled]
    return scaled, MatchResult(tuple(gains), tuple(lufs), tuple(peaks), target, target - limited, limited)


def lowpass_anchor(x: np.ndarray, fs: float, cutoff_hz: float = ANCHOR_HZ) -> np.ndarray:
    """The MUSHRA low-pass anchor: ``x`` low-passed at ``cutoff_hz``.

    An elliptic low-pass (passband to 34/35 ``cutoff_hz`` within 0.05 dB,
    stopband from ``cutoff_hz`` at 60 dB; order 12 at 3.5 kHz and 48 kHz)
    run forwards and backwards (``scipy.signal.sosfiltfilt``): zero phase,
    0.1 dB ripple up to 3.4 kHz, -3 dB at about 3.42 kHz, and every
    frequency from ``cutoff_hz`` up at least 120 dB down.
    """
    from scipy import signal

    wp, ws = cutoff_hz * 34.0 / 35.0, cutoff_hz
    order, wn = signal.ellipord(wp, ws, 0.05, 60.0, fs=fs)
    sos = signal.ellip(order, 0.05, 60.0, wn, btype="low", output="sos", fs=fs)
    return signal.sosfiltfilt(sos, np.asarray(x, np.float64))


# ---------------------------------------------------------------------------
# The reveal: analysis table and spectrogram
# ---------------------------------------------------------------------------

def reveal_table(x: np.ndarray, fs: float, key: int | None = None,
                 f0_hz: float | None = None) -> dict[str, float | None]:
    """The numbers the reveal shows for one stimulus (as heard: matched).

    A flat dict of names to numbers: loudness, centroid, f0 and, for a
    single note, the main numbers of :func:`synth.apps.analyze.analyze_audio`
    (B, the first six partials' levels and T60s).  ``f0_hz`` (a hint: the preset's pitch for the note) or
    ``key`` (equal temperament, A4 = 440 Hz) lets f0 be measured
    (:func:`synth.analysis.estimate_f0`, +-100 cents around the hint).
    """
    x = np.asarray(x, np.float64)
    ld = _loudness(x, fs)
    out: dict[str, float | None] = {
        "duration_s": len(x) / fs,
        "integrated_lufs": ld["integrated_lufs"],
        "max_momentary_lufs": ld["max_momentary_lufs"],
        "peak_dbfs": ld["peak_dbfs"],
        "crest_factor_db": ld["crest_factor_db"],
        "spectral_centroid_hz": spectral_centroid_hz(x, fs),
    }
    hint = f0_hz if f0_hz is not None else (_et_hz(key) if key is not None else None)
    f0 = None
    if hint is not None and 20.0 <= hint < 0.4 * fs:
        try:
            f0 = estimate_f0(x, fs, hint)
        except ValueError:
            f0 = None
    out["f0_hz"] = f0
    if hint is not None:
        # a single note: the synth analyze report's main numbers
        from synth.apps.analyze import analyze_audio
        from synth.io.errors import SynthError

        try:
            r = analyze_audio(x, fs, f0_hz=hint, n_partials=6)
        except (SynthError, ValueError):
            r = None
        if r is not None:
            out["inharmonicity_b"] = r["inharmonicity_b"]
            for p in r["partials"]:
                out[f"partial{p['n']}_level_db"] = p["level_db"]
                out[f"partial{p['n']}_t60_s"] = p.get("t60_s")
    return out


def spectrogram_png(x: np.ndarray, fs: float, title: str = "") -> bytes | None:
    """A spectrogram (0-12 kHz, 90 dB range, 30 ms Hann frames) as PNG
    bytes; None without matplotlib."""
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError:
        return None
    t, f, db = spectrogram(np.asarray(x, np.float64), fs, window_s=0.03, overlap=0.75)
    top = min(12_000.0, fs / 2)
    keep = f <= top
    db = db[keep] - np.max(db)
    fig = Figure(figsize=(6.4, 2.4), dpi=100)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    im = ax.imshow(np.clip(db, -90, 0), origin="lower", aspect="auto", cmap="magma",
                   extent=(0.0, len(x) / fs, 0.0, f[keep][-1] / 1e3), vmin=-90, vmax=0,
                   interpolation="nearest")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("kHz")
    if title:
        ax.set_title(title, fontsize=9)
    fig.colorbar(im, ax=ax, label="dB", pad=0.01)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", metadata={"Software": None})
    return buf.getvalue()


# ---------------------------------------------------------------------------
# Statistics
# ---------------------------------------------------------------------------

def binomial_p_value(k: int, n: int) -> float:
    """Exact one-sided p-value of k or more correct of n fair guesses,
    ``P(X >= k | n, 1/2) = sum_{i>=k} C(n, i) / 2^n`` (correctly rounded)."""
    if n < 0 or not 0 <= k <= n + 1:
        raise ValueError(f"k = {k}, n = {n}: need 0 <= n and 0 <= k <= n + 1")
    return float(Fraction(sum(math.comb(n, i) for i in range(k, n + 1)), 2 ** n))


# ---------------------------------------------------------------------------
# The comparison
# ---------------------------------------------------------------------------

def _json_value(v):
    if isinstance(v, dict):
        return {str(k): _json_value(w) for k, w in v.items()}
    if isinstance(v, (list, tuple)):
        return [_json_value(w) for w in v]
    if isinstance(v, (np.floating, float)):
        v = float(v)
        return v if math.isfinite(v) else str(v)   # JSON has no inf: "-inf", "nan"
    if isinstance(v, np.integer):
        return int(v)
    return v


def _check_out_dir(path: str) -> Path:
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise SynthError(f"-o {path}: exists and is not a directory")
    if p.is_dir() and any(p.iterdir()):
        raise SynthError(f"-o {path}: directory is not empty (give a new or empty directory)")
    parent = p.resolve().parent
    if not parent.is_dir():
        raise SynthError(f"-o {path}: directory {parent} does not exist")
    return p


def _validate(req: CompareRequest) -> None:
    if not 2 <= len(req.stimuli) <= MAX_STIMULI:
        raise SynthError(f"give 2 to {MAX_STIMULI} stimuli to compare (got {len(req.stimuli)})")
    if not 1 <= req.trials <= MAX_TRIALS:
        raise SynthError(f"--trials = {req.trials} is out of range (1 <= value <= {MAX_TRIALS})")
    if req.key is not None and not 0 <= req.key <= 127:
        raise SynthError(f"--key = {req.key} is out of range (0 <= value <= 127)")
    if not 1 <= req.velocity <= 127:
        raise SynthError(f"--velocity = {req.velocity} is out of range (1 <= value <= 127)")
    if not (math.isfinite(req.seconds) and MIN_SECONDS <= req.seconds <= 600):
        raise SynthError(f"--seconds = {req.seconds} is out of range ({MIN_SECONDS} <= value <= 600)")
    if req.lufs is not None and not (math.isfinite(req.lufs) and -70 < req.lufs <= 0):
        raise SynthError(f"--lufs = {req.lufs} is out of range (-70 < value <= 0)")


def _command(req: CompareRequest) -> str:
    argv = ["synth", "compare", *req.stimuli]
    if req.midi:
        argv += ["--midi", req.midi]
    else:
        if req.key is not None:
            argv += ["--key", str(req.key)]
        argv += ["--velocity", str(req.velocity), "--seconds", f"{req.seconds:g}"]
    if req.lufs is not None:
        argv += ["--lufs", f"{req.lufs:g}"]
    argv += ["--trials", str(req.trials), "-o", req.out_dir]
    return shlex.join(argv)


def _png_uri(png: bytes | None) -> str | None:
    return None if png is None else "data:image/png;base64," + base64.b64encode(png).decode("ascii")


def make_comparison(req: CompareRequest, log: Callable[[str], None] = print) -> Path:
    """Render, match and write the comparison of ``req`` into ``req.out_dir``.

    Everything is checked, rendered and written into a hidden staging
    directory beside ``out_dir`` first, which is then renamed into place:
    on an error nothing is left in (or as) ``out_dir``.

    Returns the path of ``index.html``.

    Raises
    ------
    SynthError
        Bad arguments, a bad stimulus (unknown preset, bad override,
        unreadable WAV, key outside a preset's range), a silent or too short
        stimulus, an output directory that exists and is not empty.
    """
    from synth.io.midi import midi_to_events, read_midi_file
    from synth.io.presets import load_preset
    from synth.io.wav import write_text_atomic, write_wav

    _validate(req)
    out = _check_out_dir(req.out_dir)
    stims = [parse_stimulus(s) for s in req.stimuli]
    events = keys = None
    plan = None
    if req.midi is not None:
        from synth.apps.render import format_length, plan_render

        events = midi_to_events(read_midi_file(req.midi))
        if not any(e.kind == "note_on" and e.value > 0 for e in events):
            raise SynthError(f"--midi {req.midi}: the file has no notes to play")
        plan = plan_render(events, MAX_MIDI_SECONDS, f"--midi {req.midi}")
        for line in plan.notes:
            log(line.replace(f"(--max-seconds {MAX_MIDI_SECONDS:g})",
                             f"(a listening page plays at most "
                             f"{format_length(MAX_MIDI_SECONDS)})"))
        events, keys = plan.events, plan.keys
    for s in stims:  # every preset and override checked before the first render
        if s.kind == "preset":
            load_preset(s.source, s.overrides)
    rendered = []
    for s in stims:
        if s.kind == "wav":
            x, notes = _read_wav(s)
            hint = _et_hz(req.key) if req.key is not None and req.midi is None else None
            rendered.append(_Rendered(s, x, hint, notes))
        else:
            rendered.append(_render_preset(s, req, events, keys, plan))
    for r in rendered:
        for note in r.notes:
            log(f"note: {note}")

    letters = _LETTERS[:len(stims)]
    n = max(len(r.x) for r in rendered)
    padded = []
    for letter, r in zip(letters, rendered):
        if len(r.x) < n:
            if n - len(r.x) > FS // 100:
                log(f"note: {letter} ({r.stim.text}) padded with {(n - len(r.x)) / FS:.2f} s of "
                    "silence to the longest stimulus")
            padded.append(np.concatenate([r.x, np.zeros(n - len(r.x))]))
        else:
            padded.append(r.x)
    mushra = len(stims) > 2
    names = [f"stimulus {r.stim.text!r}" for r in rendered]
    signals = list(padded)
    if mushra:
        signals.append(lowpass_anchor(padded[0], FS))
        names.append("the anchor")
    scaled, m = match_loudness(signals, FS, req.lufs, names=names, reference_count=len(stims))
    spread = max(m.lufs) - min(m.lufs)
    if spread > TOLERANCE_LU or max(m.peaks_dbfs) > CEILING_DBFS:  # pragma: no cover - a bug
        raise SynthError(f"loudness matching failed: spread {spread:.3f} LU, "
                         f"peak {max(m.peaks_dbfs):.2f} dBFS")

    ids = list(letters) + (["anchor"] if mushra else [])
    files = {i: f"{i}.wav" for i in ids}
    have_mpl = True
    reveal = []
    for idx, i in enumerate(ids):
        r = rendered[idx] if idx < len(rendered) else rendered[0]
        label = r.stim.text if idx < len(rendered) else \
            f"{rendered[0].stim.text} low-passed at {ANCHOR_HZ / 1e3:g} kHz"
        table = reveal_table(scaled[idx].astype(np.float64), FS,
                             key=req.key if req.midi is None else None, f0_hz=r.f0_hint_hz)
        png = spectrogram_png(scaled[idx], FS)
        have_mpl = have_mpl and png is not None
        reveal.append({
            "id": i, "label": label, "file": files[i],
            "source": r.stim.kind if idx < len(rendered) else "anchor",
            "overrides": list(r.stim.overrides),
            "original_lufs": _integrated(signals[idx], FS),
            "original_peak_dbfs": _peak_db(signals[idx]),
            "gain_db": m.gains_db[idx],
            "analysis": table,
            "spectrogram": _png_uri(png),
        })
    now = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
    data = {
        "format": "synth-compare/1",
        "created": now,
        "command": _command(req),
        "fs": FS,
        "samples": n,
        "duration_s": n / FS,
        "trials": req.trials,
        "stimuli": list(letters),
        "mushra": mushra,
        "anchor": "anchor" if mushra else None,
        "files": files,
        "columns": list(ANSWER_COLUMNS),
        "level_lufs": m.level_lufs,
        "target_lufs": m.target_lufs,
        "ceiling_dbfs": CEILING_DBFS,
        "limited_db": m.limited_db,
        "tolerance_lu": TOLERANCE_LU,
        "spectrograms_note": None if have_mpl else
            "spectrograms omitted: matplotlib is not installed (pip install 'synth[plots]')",
        "reveal": reveal,
    }
    data = _json_value(data)

    from synth.apps.compare_page import render_page

    try:
        staging = Path(tempfile.mkdtemp(prefix=f".{out.name or 'compare'}.", suffix=".tmp",
                                        dir=out.resolve().parent))
    except OSError as e:
        raise SynthError(f"-o {display_path(out)}: cannot write in {display_path(out.resolve().parent)} "
                         f"({e.strerror or e})") from None
    try:
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(staging, 0o777 & ~umask)
        audio_b64 = {}
        for idx, i in enumerate(ids):
            write_wav(staging / files[i], scaled[idx], FS, "float")
            audio_b64[i] = base64.b64encode((staging / files[i]).read_bytes()).decode("ascii")
        page = render_page(data, audio_b64)
        write_text_atomic(staging / "index.html", page)
        manifest = dict(data, reveal=[{k: v for k, v in r.items() if k != "spectrogram"}
                                      for r in data["reveal"]])
        write_text_atomic(staging / "compare.json", json.dumps(manifest, indent=1) + "\n")
        if out.is_dir():
            out.rmdir()   # empty (checked above)
        os.rename(staging, out)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    index = out / "index.html"
    for idx, i in enumerate(ids):
        log(f"{i}: {reveal[idx]['label']}: {m.lufs[idx]:.2f} LUFS (gain {m.gains_db[idx]:+.2f} dB), "
            f"peak {m.peaks_dbfs[idx]:.2f} dBFS")
    lim = f", lowered {m.limited_db:.2f} dB so no peak exceeds {CEILING_DBFS:g} dBFS" \
        if m.limited_db > 0 else ""
    size = index.stat().st_size / 1e6
    log(f"matched at {m.level_lufs:.2f} LUFS (spread {spread:.3f} LU{lim}); "
        f"{n / FS:.2f} s each, {req.trials} ABX trials" + (", MUSHRA with hidden reference and "
                                                           "3.5 kHz anchor" if mushra else ""))
    if not have_mpl:
        log("note: spectrograms omitted: matplotlib is not installed (pip install 'synth[plots]')")
    log(f"wrote {display_path(index)} ({size:.1f} MB, audio inline; open it in a browser) "
        f"and {len(ids)} WAV files beside it")
    return index


# ---------------------------------------------------------------------------
# The local server (synth compare --serve)
# ---------------------------------------------------------------------------

_MAX_POST_BYTES = 1 << 20
_MAX_ROWS = 2000
_MAX_CELL = 2000


def _check_rows(obj) -> list[dict]:
    rows = obj if isinstance(obj, list) else [obj]
    if not rows or len(rows) > _MAX_ROWS:
        raise ValueError(f"expected 1 to {_MAX_ROWS} answers, got {len(rows)}")
    for r in rows:
        if not isinstance(r, dict):
            raise ValueError("each answer must be a JSON object")
        unknown = sorted(set(r) - set(ANSWER_COLUMNS))
        if unknown:
            raise ValueError(f"unknown fields {unknown} (allowed: {', '.join(ANSWER_COLUMNS)})")
        for k, v in r.items():
            if not (v is None or isinstance(v, (str, int, float, bool))):
                raise ValueError(f"field {k}: expected a string, number, boolean or null")
            if len(str(v)) > _MAX_CELL:
                raise ValueError(f"field {k}: longer than {_MAX_CELL} characters")
    return rows


#: the first characters that make a spreadsheet read a cell as a formula
#: (OWASP, CSV injection): such a text cell is written with a leading quote
FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r")


def _cell(v) -> str:
    if v is None:
        return ""
    if isinstance(v, bool):
        return "1" if v else "0"
    if isinstance(v, str) and v.startswith(FORMULA_STARTS):
        return "'" + v            # text, not a formula ('=cmd|calc!A1' -> "'=cmd|calc!A1")
    return str(v)


def append_answers(path: str | os.PathLike, rows: Sequence[dict]) -> int:
    """Append answer rows to the CSV at ``path`` (header ``SERVER_COLUMNS``
    first when the file is new); returns the number of rows written."""
    path = Path(path)
    received = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="milliseconds")
    new = not path.exists() or path.stat().st_size == 0
    with open(path, "a", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        if new:
            w.writerow(SERVER_COLUMNS)
        for r in rows:
            w.writerow([received] + [_cell(r.get(c)) for c in ANSWER_COLUMNS])
        f.flush()
        os.fsync(f.fileno())
    return len(rows)


class _Handler(SimpleHTTPRequestHandler):
    """Static files of the comparison's directory; POST /answers appends to answers.csv."""

    lock = threading.Lock()
    log_post: Callable[[str], None] = staticmethod(lambda s: None)

    def log_message(self, format, *args):  # noqa: A002 - the base class's name
        pass   # no line per request

    def end_headers(self):
        self.send_header("Cache-Control", "no-store")
        super().end_headers()

    def _reply(self, status: int, obj) -> None:
        body = (json.dumps(obj) + "\n").encode()
        self.send_response(status)
        self.send_header("Content-Type", "application/json")
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)

    def do_POST(self):  # noqa: N802 - http.server's name
        if self.path.split("?", 1)[0] != "/answers":
            self._reply(404, {"error": "POST answers to /answers"})
            return
        try:
            length = int(self.headers.get("Content-Length", ""))
        except ValueError:
            self._reply(411, {"error": "Content-Length required"})
            return
        if not 0 < length <= _MAX_POST_BYTES:
            self._reply(413, {"error": f"body must be 1 to {_MAX_POST_BYTES} bytes"})
            return
        try:
            rows = _check_rows(json.loads(self.rfile.read(length).decode("utf-8")))
        except (ValueError, UnicodeDecodeError) as e:
            self._reply(400, {"error": str(e).splitlines()[0]})
            return
        with self.lock:
            n = append_answers(Path(self.directory) / "answers.csv", rows)
        r = rows[-1]
        self.log_post(f"answers.csv: +{n} ({r.get('listener') or '?'}: {r.get('test') or '?'} "
                      f"trial {r.get('trial') if r.get('trial') is not None else '?'})")
        self._reply(200, {"saved": n})


def make_server(directory: str | os.PathLike, port: int = 0,
                log: Callable[[str], None] = lambda s: None) -> ThreadingHTTPServer:
    """An HTTP server on 127.0.0.1:``port`` (0: any free port) serving
    ``directory`` and appending POSTed answers to ``directory/answers.csv``.
    Run it with ``serve_forever()``; ``server_address[1]`` is the port."""
    d = Path(directory)
    if not (d / "index.html").is_file():
        raise SynthError(f"-o {directory}: no index.html there (run synth compare with stimuli first)")
    if not 0 <= port <= 65535:
        raise SynthError(f"--port = {port} is out of range (0 <= value <= 65535; 0: any free port)")
    handler = functools.partial(type("Handler", (_Handler,), {"log_post": staticmethod(log)}),
                                directory=str(d.resolve()))
    try:
        return ThreadingHTTPServer(("127.0.0.1", port), handler)
    except OSError as e:
        raise SynthError(f"--port {port}: cannot listen on 127.0.0.1 ({e.strerror or e}); "
                         "give another port (0: any free port)") from None


def serve(directory: str | os.PathLike, port: int = 8765, log: Callable[[str], None] = print) -> int:
    """Serve the comparison until Ctrl-C (then close and return 0)."""
    srv = make_server(directory, port, log)
    host, p = srv.server_address[:2]
    log(f"serving {display_path(directory)} at http://{host}:{p}/  (answers go to "
        f"{display_path(Path(directory) / 'answers.csv')}; Ctrl-C stops)")
    try:
        srv.serve_forever()
    except KeyboardInterrupt:
        pass
    finally:
        srv.server_close()
    log("server stopped")
    return 0
