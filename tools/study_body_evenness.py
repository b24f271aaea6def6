"""How even is the keyboard's loudness through the soundboard body?

Usage
-----
    python tools/study_body_evenness.py render  [--cache PATH] [--velocity 80] [--duration 2.0]
    python tools/study_body_evenness.py compare [--cache PATH] [--wet 0.4]

``render`` plays every key 21..108 once at ``velocity`` with the body off
(``body.wet=0``), one engine per key, and keeps the dry 48 kHz renders in
``--cache`` (an .npz, ~70 MB; default /tmp/body_study/dry_v80.npz). It takes
a few minutes; the other command reuses the renders.

``compare`` applies body variants offline to the same dry renders (cheap:
one body filtering per key and variant) and prints, per variant:

* loudness: the maximum 400 ms momentary BS.1770 loudness of each key
  (:func:`synth.analysis.loudness.momentary_lufs`, 50 ms hop; a stereo body
  is measured as BS.1770 does, the channel powers summed); adjacent-key
  steps (median, 90th percentile, max, in dB) and the deviation from a
  smooth fit across the keyboard (a degree-4 polynomial in the key number:
  standard deviation and largest |residual|);
* partials 1-3: the body's own gain at the partial frequencies of each key
  (:func:`synth.dsp.body.Body.response` at the measured partial
  frequencies, power summed over the outputs) relative to the body's
  1/3-octave smoothed gain there (:func:`synth.physics.soundboard.smoothed_gain_db`),
  worst value below and above;
* the same adjacent-step statistics for the level of partials 1-3 in the
  rendered output (dB re each key's dry level, so only the body's part of
  the key-to-key change shows).

Variants: ``dry`` (no body), ``old`` (the body as it was before the
two-bridge redesign, random residue signs, mono, wet 0.5: its module is
read from git at ``OLD_COMMIT``; skipped without the history), ``new-mono``
(this body, 1 in, 1 out, wet ``--wet``, default the grand preset's 0.4) and ``new-stereo``
(2 in, 2 out; the dry render of each key split between the bridge ends by
its position t = (key - 21) / 87 with :meth:`Body.bridge_split`).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time

import numpy as np

DEFAULT_CACHE = "/tmp/body_study/dry_v80.npz"
KEYS = np.arange(21, 109)


def render(cache, velocity, duration_s):
    from synth.engine.engine import Event
    from synth.io.factory import build_engine

    os.makedirs(os.path.dirname(cache) or ".", exist_ok=True)
    ys = []
    t0 = time.time()
    for k in KEYS:
        e = build_engine("grand-piano", ["body.wet=0"])
        ys.append(e.render([Event(0.0, "note_on", int(k), velocity / 127)], duration_s=duration_s))
        print(f"key {k}: {time.time() - t0:.0f} s", file=sys.stderr, flush=True)
    f1 = np.array([e.inst.tuning_hz(int(k)) for k in KEYS])
    np.savez(cache, y=np.array(ys), keys=KEYS, f1=f1, fs=e.fs_out, velocity=velocity)


OLD_COMMIT = "0854ef6"  # the body before the two-bridge redesign
OLD_WET = 0.5           # its preset value


def _old_body(fs, wet):
    """The old mono body (random residue signs) from its own source at
    OLD_COMMIT: returns filter(x) -> y and response(f) -> complex, or None."""
    import subprocess
    import types

    try:
        src = subprocess.run(["git", "show", f"{OLD_COMMIT}:synth/physics/soundboard.py"],
                             capture_output=True, text=True, check=True,
                             cwd=os.path.dirname(os.path.abspath(__file__))).stdout
    except (OSError, subprocess.CalledProcessError):
        return None
    old = types.ModuleType("old_soundboard")
    sys.modules["old_soundboard"] = old  # dataclasses look their module up
    exec(compile(src, "old_soundboard.py", "exec"), old.__dict__)
    f, t60, g = old.soundboard_modes(fs, n_modes=96, seed=1, size=1.0, brightness=0.0)
    coefs = old.resonator_coefs(fs, f, t60, g)
    e, h0 = old.white_noise_power_gain(coefs), coefs[0].sum()
    d = 1.0 - wet
    c = math.sqrt(d * d + wet * wet * e + 2.0 * wet * d * h0)
    dg, wg = d / c, wet / c

    from scipy.signal import lfilter

    def run(x):
        y = dg * x
        for b0, a1, a2 in coefs.T:
            y = y + wg * lfilter([b0, 0.0, -b0], [1.0, a1, a2], x)
        return y[None, :]

    def response(fr):
        from synth.physics.soundboard import section_response
        return (dg + wg * section_response(fs, coefs, fr).sum(axis=0))[None, :]

    return run, response


def _max_momentary_lufs(y, fs, hop_s=0.05):
    """Largest 400 ms momentary loudness (BS.1770, channel powers summed), y (C, n).

    The K-weighting (pyloudnorm's filters) runs once over the whole signal
    and the 400 ms mean squares are taken every ``hop_s`` -- the same as
    :func:`synth.analysis.loudness.momentary_lufs` without its per-window
    filter start-up (a few hundredths of a LU).
    """
    import pyloudnorm

    meter = pyloudnorm.Meter(int(fs), block_size=0.4)
    z = 0.0
    n = int(round(0.4 * fs))
    hop = int(round(hop_s * fs))
    for ch in np.atleast_2d(y):
        v = ch.copy()
        for stage in meter._filters.values():
            v = stage.apply_filter(v)
        c = np.concatenate(([0.0], np.cumsum(v * v)))
        s = np.arange(0, len(v) - n + 1, hop)
        z = z + (c[s + n] - c[s]) / n
    with np.errstate(divide="ignore"):
        return float(-0.691 + 10.0 * np.log10(np.max(z)))


def _partials_hz(keys, f1, n=3):
    from synth.physics.piano import grand_string

    out = np.empty((len(keys), n))
    for i, (k, f) in enumerate(zip(keys, f1)):
        b = grand_string(int(k)).inharmonicity_b
        m = np.arange(1, n + 1)
        out[i] = f * m * np.sqrt((1.0 + b * m * m) / (1.0 + b))
    return out


def _steps(v):
    d = np.abs(np.diff(v))
    return np.median(d), np.percentile(d, 90), d.max(), int(np.argmax(d))


def _smooth_fit(keys, v, deg=4):
    c = np.polyfit(keys - 64.5, v, deg)
    r = v - np.polyval(c, keys - 64.5)
    return r.std(), np.abs(r).max()


def _rendered_partials_db(y, fs, f1, keys):
    """Levels (dB) of partials 1-3 in 50-550 ms of each render (power summed over outputs)."""
    from synth.analysis.spectrum import partial_levels_db
    from synth.physics.piano import grand_string

    a, b = int(0.05 * fs), int(0.55 * fs)
    out = np.full((len(keys), 3), np.nan)
    for i, k in enumerate(keys):
        p = 0.0
        for ch in y[i]:
            lv = partial_levels_db(ch[a:b], fs, f1[i], 3,
                                   inharmonicity=grand_string(int(k)).inharmonicity_b)
            p = p + 10.0 ** (lv / 10.0)
        out[i] = 10.0 * np.log10(p)
    return out


def _knock_report(body, ys, keys, fs, velocity):
    """Loudness of the knock alone through the body re the key's tone, for a few keys."""
    from synth.io.factory import build_voice
    from synth.physics.piano import hammer_mass_kg
    from synth.physics.soundboard import knock_impulse_ns, knock_pulse

    voice = build_voice("grand-piano")
    gain = voice.preset.output.gain  # bridge force (N) to full scale
    v = voice.hammer_speed(velocity / 127.0)
    print(f"\nknock (KNOCK_IMPULSE_RATIO impulse, 2 ms) through the mono body, re the tone's "
          f"max momentary loudness, velocity {velocity:g} (hammer {v:.2f} m/s):")
    cells = []
    for k in (28, 48, 60, 72, 84, 96, 105):
        i = int(np.flatnonzero(keys == k)[0])
        j = knock_impulse_ns(hammer_mass_kg(k, 1), v)
        x = np.zeros(len(ys[i]))
        p = knock_pulse(fs, j, 0.002) * gain
        x[:len(p)] = p
        body.reset()
        lk = _max_momentary_lufs(body.process(x)[None, :], fs)
        body.reset()
        lt = _max_momentary_lufs(body.process(ys[i])[None, :], fs)
        cells.append(f"key {k}: {lk - lt:+.1f} LU")
    print("  " + ", ".join(cells))


def compare(cache, wet=None):
    from synth.dsp.body import Body
    from synth.physics.soundboard import smoothed_db

    d = np.load(cache)
    ys, keys, f1, fs = d["y"], d["keys"], d["f1"], float(d["fs"])
    from synth.dsp.body import DEFAULT_WET

    wet = DEFAULT_WET if wet is None else wet
    t_of_key = (keys - keys[0]) / (keys[-1] - keys[0])
    grid = np.geomspace(20.0, 0.45 * fs, 12000)
    fp = _partials_hz(keys, f1)

    variants = {}
    variants["dry"] = (lambda i: ys[i][None, :], None)
    old = _old_body(fs, OLD_WET)
    if old is not None:
        old_run, old_resp = old
        variants["old"] = (lambda i: old_run(ys[i]), lambda i, fr: old_resp(fr))
    else:
        print("(old body: git history not available, skipped)")
    mono = Body(fs, wet=wet)
    stereo = Body(fs, wet=wet, inputs=2, outputs=2)

    def run_mono(i):
        mono.reset()
        return mono.process(ys[i])[None, :].copy()

    def run_stereo(i):
        stereo.reset()
        w = stereo.bridge_split(float(t_of_key[i]))
        return stereo.process(np.vstack((w[0] * ys[i], w[1] * ys[i]))).copy()

    variants["new-mono"] = (run_mono, lambda i, fr: mono.response(fr, (1.0,)))
    variants["new-stereo"] = (run_stereo,
                              lambda i, fr: stereo.response(fr, stereo.bridge_split(float(t_of_key[i]))))
    results = {}
    for name, (run, resp) in variants.items():
        t0 = time.time()
        outs = [run(i) for i in range(len(keys))]
        lufs = np.array([_max_momentary_lufs(y, fs) for y in outs])
        parts = _rendered_partials_db(outs, fs, f1, keys)
        fine = None
        if resp is not None:
            fine = np.empty_like(fp)
            cache_sm = {}
            for i in range(len(keys)):
                # smoothed response: per key for the stereo body (its split depends on t)
                tk = round(float(t_of_key[i]), 6) if name == "new-stereo" else 0.0
                if tk not in cache_sm:
                    sm = smoothed_db(grid, (np.abs(resp(i, grid)) ** 2).sum(axis=0))
                    cache_sm[tk] = sm
                sm = np.interp(np.log(fp[i]), np.log(grid), cache_sm[tk])
                lv = 10.0 * np.log10((np.abs(resp(i, fp[i])) ** 2).sum(axis=0))
                fine[i] = lv - sm
        results[name] = (lufs, parts, fine)
        print(f"[{name}: {time.time() - t0:.0f} s]", file=sys.stderr, flush=True)

    print(f"velocity {float(d['velocity']):g}, keys {keys[0]}..{keys[-1]}, wet {wet:g} "
          f"(old body: wet {OLD_WET:g})")
    print("\nloudness (max momentary LUFS per key):")
    print(f"{'variant':12s} {'step med':>9s} {'p90':>6s} {'max':>6s} {'at key':>7s} "
          f"{'fit sd':>7s} {'fit max':>8s} {'mean':>7s}")
    for name, (lufs, parts, fine) in results.items():
        med, p90, mx, at = _steps(lufs)
        sd, fmx = _smooth_fit(keys, lufs)
        print(f"{name:12s} {med:9.2f} {p90:6.2f} {mx:6.2f} {keys[at]:>3d}-{keys[at + 1]:<3d} "
              f"{sd:7.2f} {fmx:8.2f} {lufs.mean():7.1f}")
    mid = (keys >= 48) & (keys <= 84)
    print("  (keys 48-84, fit sd: " + ", ".join(
        f"{n} {_smooth_fit(keys[mid], r[0][mid])[0]:.2f}" for n, r in results.items()) + ")")
    print("\npartials 1-3 in the renders (dB, power over outputs): adjacent-key steps, fit residual")
    for name, (lufs, parts, fine) in results.items():
        cells = []
        for j in range(3):
            v = parts[:, j]
            ok = np.isfinite(v)
            med, p90, mx, _ = _steps(v[ok])
            sd, fmx = _smooth_fit(keys[ok], v[ok])
            cells.append(f"p{j + 1}: {med:4.1f}/{mx:5.1f} sd {sd:4.1f}")
        print(f"{name:12s} " + "   ".join(cells) + "   (step median/max, fit sd)")
    print("\nbody gain at partials 1-3 re its 1/3-octave smoothed gain (dB): min, max, share beyond -6/+6")
    for name, (lufs, parts, fine) in results.items():
        if fine is None:
            continue
        for j in range(3):
            v = fine[:, j]
            lo, hi = int(np.argmin(v)), int(np.argmax(v))
            print(f"{name:12s} p{j + 1}: min {v[lo]:6.1f} (key {keys[lo]}), max {v[hi]:5.1f} "
                  f"(key {keys[hi]}), beyond: {np.mean(np.abs(v) > 6.0) * 100:4.1f} %")
    _knock_report(mono, ys, keys, fs, float(d["velocity"]))
    c4 = int(np.flatnonzero(keys == 60)[0])
    print("\nC4 partial 3 in the render re dry (dB): " + ", ".join(
        f"{n} {r[1][c4, 2] - results['dry'][1][c4, 2]:+.1f}" for n, r in results.items()))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("what", choices=("render", "compare"))
    ap.add_argument("--cache", default=DEFAULT_CACHE)
    ap.add_argument("--velocity", type=float, default=80.0)
    ap.add_argument("--duration", type=float, default=2.0)
    ap.add_argument("--wet", type=float, default=None, help="body wet for compare (default 0.5)")
    a = ap.parse_args(argv)
    if a.what == "render":
        render(a.cache, a.velocity, a.duration)
    else:
        compare(a.cache, a.wet)


if __name__ == "__main__":
    main()
