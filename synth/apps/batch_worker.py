"""``synth batch``'s worker: one job rendered in memory.

:func:`render_job` renders a :class:`~synth.apps.batch_spec.Job` and
returns the WAV file's bytes and the job's manifest row (parameters, render
facts and the analysis summary of ``synth analyze``); it writes no file of
the output, the process that called :func:`synth.apps.batch.render_many`
does.  A worker keeps the voices of its last :data:`VOICE_CACHE` presets
for later jobs (a reused voice renders the same samples as a fresh one),
and :func:`warm_worker` compiles or loads the kernels once per process and
preset.  Dask runs these functions in its workers; this module does not
import Dask.
"""

from __future__ import annotations

import hashlib
import math
import os
import time
from collections import OrderedDict
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..io.errors import SynthError
from .batch_spec import BatchError, Job, preset_sha256

#: voices (their designed keys) a worker keeps for later jobs of the same preset
VOICE_CACHE = 4
#: partials measured for the analysis summary (partial 1's T60 is the note's)
ANALYSIS_PARTIALS = 4


# --------------------------------------------------------------------------- worker
_VOICES: "OrderedDict[tuple, Any]" = OrderedDict()


def _preset_source(job: Job, tmp: str) -> str:
    """The preset name, or a copy of the job's preset file in ``tmp``."""
    if job.preset_toml is None:
        return job.preset
    path = os.path.join(tmp, job.preset)
    with open(path, "wb") as f:
        f.write(job.preset_toml)
    return path


def _voice_for(job: Job, source: str):
    from ..io.factory import build_voice

    k = (job.preset, job.preset_sha256)
    v = _VOICES.pop(k, None)
    if v is None:
        v = build_voice(source, job.overrides)
    _VOICES[k] = v
    while len(_VOICES) > VOICE_CACHE:
        _VOICES.popitem(last=False)
    return v


def _analysis(x: np.ndarray, fs: int, job: Job, expected_hz: float | None) -> dict:
    """The analysis summary of ``synth analyze`` for the manifest: pitch,
    loudness, centroid and T60 of a note; loudness and centroid of a MIDI
    render."""
    from ..analysis import as_mono, loudness, spectral_centroid_hz

    mono = as_mono(x)
    out = {"f0_hz": None, "f0_expected_hz": expected_hz, "f0_cents": None,
           "inharmonicity_b": None, "loudness_lufs": None, "max_momentary_lufs": None,
           "centroid_onset_hz": None, "centroid_hz": None, "t60_s": None,
           "t60_early_s": None, "t60_late_s": None, "analysis_error": None}
    if not np.any(mono):
        out["analysis_error"] = "silent"
        return out
    if job.kind == "note":
        from .analyze import analyze_audio

        try:
            r = analyze_audio(mono, fs, key=job.key, f0_hz=expected_hz,
                              n_partials=ANALYSIS_PARTIALS)
        except SynthError as err:
            out["analysis_error"] = str(err)
            return out
        out["f0_hz"] = r["partial1_hz"]
        if expected_hz:
            out["f0_cents"] = 1200.0 * math.log2(r["partial1_hz"] / expected_hz)
        out["inharmonicity_b"] = r["inharmonicity_b"]
        out["loudness_lufs"] = r["loudness"]["integrated_lufs"]
        out["max_momentary_lufs"] = r["loudness"]["max_momentary_lufs"]
        c = r["centroid"]["centroid_hz"]
        if c:
            out["centroid_onset_hz"] = c[0]
            out["centroid_hz"] = float(np.median(c))
        p1 = r["partials"][0]
        out["t60_s"], out["t60_early_s"], out["t60_late_s"] = (
            p1.get("t60_s"), p1.get("t60_early_s"), p1.get("t60_late_s"))
        return out
    ld = loudness(mono, fs)
    out["loudness_lufs"] = _finite(ld["integrated_lufs"])
    out["max_momentary_lufs"] = _finite(ld["max_momentary_lufs"])
    on = int(np.flatnonzero(np.abs(mono) >= 0.01 * np.abs(mono).max())[0])
    out["centroid_onset_hz"] = float(spectral_centroid_hz(mono[on:on + int(0.1 * fs)], fs))
    out["centroid_hz"] = float(spectral_centroid_hz(mono, fs))
    return out


def _finite(v):
    return None if v is None or not math.isfinite(v) else float(v)


def render_job(job: Job) -> dict:
    """Render one job in memory (a worker's task).

    Returns
    -------
    dict
        ``{"wav": bytes, "row": dict}``: the WAV file and the job's
        manifest row (parameters, render facts, analysis summary).

    Raises
    ------
    SynthError
        A preset that no longer validates here, a worker whose preset
        differs from the client's (another ``synth`` version), a render
        that fails.
    """
    import socket
    import tempfile

    import soundfile as sf

    from ..io.wav import wav_bytes

    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="synth-batch-") as tmp:
        source = _preset_source(job, tmp)
        if job.kind == "note":
            from ..engine.engine import NOTE_OFF, NOTE_ON, Event
            from ..io.factory import build_engine

            voice = _voice_for(job, source)
            sha, _ = preset_sha256(voice.preset)
            if sha != job.preset_sha256:
                raise BatchError(f"{job.path}: this worker's preset {job.preset} differs from "
                                 "the client's (is the same synth version installed?)")
            eng = build_engine(voice.preset, voice=voice, extra_low_key=job.key, drone=False)
            key = -1 if job.key is None else job.key
            ev = [Event(0.0, NOTE_ON, key, job.velocity / 127.0)]
            if job.hold_s is not None:
                ev.append(Event(job.hold_s, NOTE_OFF, key, 0.5))
            y = np.asarray(eng.render(ev, duration_s=job.seconds), dtype=np.float32)
            data, res = wav_bytes(y, eng.fs_out, job.subtype)
            fs = eng.fs_out
            try:
                expected = float(voice.pitch_hz(job.key))
            except ValueError:              # a voice with no pitch of its own
                expected = None
            notes = 1
        else:
            from ..io.presets import load_preset
            from .render import RenderRequest, render_midi_file

            if preset_sha256(load_preset(source, job.overrides))[0] != job.preset_sha256:
                raise BatchError(f"{job.path}: this worker's preset {job.preset} differs from "
                                 "the client's (is the same synth version installed?)")
            mid = os.path.join(tmp, "in.mid")
            with open(mid, "wb") as f:
                f.write(job.midi_bytes)
            out = os.path.join(tmp, "out.wav")
            rr = render_midi_file(RenderRequest(mid, source, out, job.overrides,
                                                pcm24=job.subtype == "pcm24",
                                                max_seconds=job.seconds))
            with open(out, "rb") as f:
                data = f.read()
            y, fs = sf.read(out, dtype="float32", always_2d=True)
            res = None
            expected = None
            notes = rr.notes
    render_s = time.perf_counter() - t0
    t1 = time.perf_counter()
    summary = _analysis(y, fs, job, expected)
    analysis_s = time.perf_counter() - t1
    peak = float(np.max(np.abs(y))) if y.size else 0.0
    row = {
        "job": job.name, "index": job.index, "hash": job.hash, "kind": job.kind,
        "file": job.path, "preset": job.preset, "preset_sha256": job.preset_sha256,
        "key": job.key, "velocity": job.velocity,
        "seconds": job.seconds, "hold_seconds": job.hold_s, "quality": job.quality,
        "midi_file": job.midi_name, "midi_sha256": job.midi_sha256, "format": job.subtype,
        "overrides": "; ".join(job.overrides),
        **{f"set.{k}": v for k, v in job.params},
        "notes": notes,
        "duration_s": y.shape[0] / fs, "channels": int(y.shape[1]) if y.ndim == 2 else 1,
        "fs_hz": int(fs),
        "peak_dbfs": 20.0 * math.log10(peak) if peak > 0 else None,
        "n_clipped": None if res is None else res.n_clipped,
        "wav_bytes": len(data), "wav_sha256": hashlib.sha256(data).hexdigest(),
        "render_s": render_s, "analysis_s": analysis_s,
        "worker": f"{socket.gethostname()}:{os.getpid()}",
        **summary,
        "preset_json": job.preset_json,
    }
    return {"wav": data, "row": row}


_ANALYSIS_WARM = False
_WARMED: set = set()


def _warm_analysis() -> None:
    """Run the manifest's analysis once in this process on a made-up 1 s
    note (a 220 Hz tone with four partials, decaying): its first call
    imports SciPy's filters, pyloudnorm and the measures (0.87 s on a Zen 5
    VM, against 0.10 s for each call after it), which would
    otherwise fall on a worker's first job."""
    global _ANALYSIS_WARM
    if _ANALYSIS_WARM:
        return
    _ANALYSIS_WARM = True
    from types import SimpleNamespace

    fs = 48000
    t = np.arange(fs) / fs
    tone = np.exp(-3.0 * t) * sum(np.sin(2 * np.pi * 220.0 * n * t) / n for n in range(1, 5))
    _analysis(0.3 * tone, fs, SimpleNamespace(kind="note", key=57), 220.0)


def warm_worker(presets: Sequence[tuple[str, bytes | None]]) -> float:
    """Compile or load the kernels in this process: 20 ms of each preset
    (name and, for a preset file, its text) at its middle key, once per
    process and preset; and run the analysis once (:func:`_warm_analysis`).
    Returns the time it took (s)."""
    import tempfile

    from ..engine.engine import NOTE_ON, Event
    from ..io.factory import build_engine

    t = time.perf_counter()
    _warm_analysis()
    with tempfile.TemporaryDirectory(prefix="synth-warm-") as tmp:
        for name, text in presets:
            k = (name, None if text is None else hashlib.sha256(text).hexdigest())
            if k in _WARMED:
                continue
            _WARMED.add(k)
            src = name
            if text is not None:
                src = os.path.join(tmp, name)
                with open(src, "wb") as f:
                    f.write(text)
            eng = build_engine(src)
            p = eng.inst.preset
            key = (p.play.key_low + p.play.key_high) // 2 if p.kind == "musical" else -1
            eng.render([Event(0.0, NOTE_ON, key, 0.5)], duration_s=0.02)
    return time.perf_counter() - t
