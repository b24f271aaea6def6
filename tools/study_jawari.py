"""Does the sitar's jawari buzz on every key, at every velocity, all note long?

Usage
-----
    python tools/study_jawari.py [--preset sitar] [--set PATH=VALUE ...]
                                 [--keys sweep|all|K1,K2,...] [--velocities 40,80,127]
                                 [--seconds 1.2] [--bands] [--pitch [--fit]]

For every key and velocity the note is rendered twice, ``synth note``'s way
(one note-on at t = 0, 48 kHz output): with the preset (plus the ``--set``
overrides) and with the same overrides and ``termination.profile=none`` (the
ideal rigid end; ``termination.*`` overrides apply to the first only).  The measure is the *high band*: the energy above 1 kHz
(``--f-cut``; one Hann-windowed spectrum of the window) of the render with the jawari
over that of the render without, in dB, in two windows:

* ``early``: 50-500 ms after the pluck;
* ``late``: 0.9-1.1 s.

``end`` is the time of the last contact of the string with the termination
(the kernel's per-sample contact count, engine probe) when it comes before
the last 50 ms of the render (the buzz stopped); ``on`` when the string
still touches the jawari at the end.  ``c@1s`` is the share of the samples
of 0.9-1.1 s in which some region point is in contact (%).

``--keys sweep`` (default) is every third key of 43..74 plus 74; ``all``
is every key 43..74.  The pass criterion (issue 12): every early >= 6 dB and
every late >= 3 dB.  The last lines give the worst cases and the render time
of the jawari notes (the per-sample path with the probe on; ``--bands``
also prints the high-band level of the rigid-end render, dB re 1).

``--pitch`` instead prints, per key and velocity, partial 1 of the preset's
render in cents against the key in several windows: 50 ms - 1.05 s (``synth
check``'s default ``f0`` window), 0.8-1.6 s (``tests/test_pitch.py``'s for the
biwa), the attack and later.  With ``--set termination.pitch_rise_cents=0
--set string.tension_modulation=0`` that is the rise the contact itself
gives (the swing's own glide left out), which the voice tunes out as pitch_rise_cents
(velocity buzz)^0.6 exp(-t / pitch_rise_tau_s); ``--fit`` then fits those
two values (the worst residual over the first two windows).
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from synth.analysis import highband_energy

EARLY = (0.05, 0.5)
LATE = (0.9, 1.1)
F_CUT_HZ = 1000.0


def sweep_keys():
    return list(range(43, 75, 3)) + [74]


def _db(a, b):
    if a <= 0.0 and b <= 0.0:
        return 0.0
    if b <= 0.0:
        return float("inf")
    if a <= 0.0:
        return float("-inf")
    return 10.0 * np.log10(a / b)


def render(preset, overrides, key, velocity, seconds, probe, fs_internal=None):
    """(output at fs_out, fs_out, contact counts per internal sample or None,
    internal rate, render time s)."""
    from synth.engine.engine import Event
    from synth.io.factory import build_engine

    eng = build_engine(preset, list(overrides), probe=probe, extra_low_key=key, fs_internal=fs_internal)
    t = time.perf_counter()
    y = eng.render([Event(0.0, "note_on", key, velocity / 127.0)], duration_s=seconds)
    el = time.perf_counter() - t
    c = None
    if probe:
        from synth.kernels import strings as K

        c = eng.probe_channels(0)[K.P_CONTACT][: int(round(seconds * eng.inst.fs))]
    return np.asarray(y, float), eng.fs_out, c, eng.inst.fs, el


def measure(preset, overrides, key, velocity, seconds=1.2, f_cut=F_CUT_HZ, fs_internal=None,
            above_harmonic=0.0):
    """One cell of the table: dict with early, late (dB above the rigid end),
    end (s, or None while the buzz lasts), c1 (contact share 0.9-1.1 s),
    none_early_db (the rigid end's high band, dB re 1), t_render (s)."""
    y, fs, c, fsi, el = render(preset, overrides, key, velocity, seconds, True, fs_internal)
    # the band's edge above the note's first partials (0: f_cut only)
    f_cut = max(f_cut, above_harmonic * 440.0 * 2.0 ** ((key - 69) / 12.0))
    # the rigid end: the same overrides but those of the termination
    ref = [o for o in overrides if not o.strip().startswith("termination.")]
    y0, _, _, _, _ = render(preset, ref + ["termination.profile=none"], key, velocity, seconds, False,
                            fs_internal)
    on = np.flatnonzero(c)
    end = None
    if len(on) == 0:
        end = 0.0
    elif on[-1] / fsi < seconds - 0.05:
        end = float(on[-1] / fsi)
    w = c[int(LATE[0] * fsi):int(LATE[1] * fsi)]
    return {
        "early": _db(highband_energy(y, fs, f_cut, EARLY[0], EARLY[1] - EARLY[0]), highband_energy(y0, fs, f_cut, EARLY[0], EARLY[1] - EARLY[0])),
        "late": _db(highband_energy(y, fs, f_cut, LATE[0], LATE[1] - LATE[0]), highband_energy(y0, fs, f_cut, LATE[0], LATE[1] - LATE[0])),
        "end": end,
        "c1": 100.0 * float(np.count_nonzero(w)) / max(1, len(w)),
        "none_early_db": 10.0 * np.log10(highband_energy(y0, fs, f_cut, EARLY[0], EARLY[1] - EARLY[0]) + 1e-300),
        "t_render": el,
    }


#: the windows of --pitch (s): synth check's f0 (first), tests/test_pitch.py's,
#: the attack, and later in the note
PITCH_WINDOWS = ((0.05, 1.05), (0.8, 1.6), (0.05, 0.35), (0.35, 0.65), (1.6, 2.4), (2.4, 3.2))


def pitch_table(preset, overrides, keys, vels):
    """Partial 1 against the key (cents) in PITCH_WINDOWS, per key and
    velocity; returns {(key, velocity): [cents per window]}."""
    from synth.analysis import cents, estimate_f0
    from synth.physics.string import midi_key_to_hz

    seconds = max(w[1] for w in PITCH_WINDOWS)
    print(f"preset {preset}, overrides: {' '.join(overrides) or '(none)'}")
    print("partial 1 against the key, cents, in windows (s): "
          + ", ".join(f"{a:g}-{b:g}" for a, b in PITCH_WINDOWS))
    print("key vel | " + " ".join(f"{f'{a:g}-{b:g}':>9s}" for a, b in PITCH_WINDOWS))
    res = {}
    for k in keys:
        for v in vels:
            y, fs, _, _, _ = render(preset, overrides, k, v, seconds, False)
            ref = midi_key_to_hz(k)
            res[(k, v)] = [float(cents(estimate_f0(y[int(a * fs):int(b * fs)], fs, ref,
                                                   search_cents=60.0), ref))
                           for a, b in PITCH_WINDOWS]
            print(f"{k:3d} {v:3d} | " + " ".join(f"{c:+9.2f}" for c in res[(k, v)]), flush=True)
    worst = np.max(np.abs(np.array(list(res.values()))), axis=0)
    print("worst   | " + " ".join(f"{w:9.2f}" for w in worst))
    return res


def fit_rise(res, exponent=0.6, windows=(0, 1)):
    """Fit the voice's tune-out, R (v/127)^exponent exp(-t/tau) cents, to
    the rise ``res`` measured with ``termination.pitch_rise_cents=0``: the
    mean of the model over each window against the measured partial 1,
    minimising the worst residual over ``windows`` (default: synth check's
    and tests/test_pitch.py's).  Prints the best R per tau; returns (R, tau)."""
    def wmean(tau, a, b):
        return tau * (np.exp(-a / tau) - np.exp(-b / tau)) / (b - a)

    print("fit of R (v/127)^%.1f exp(-t/tau): worst residual (cents) per window" % exponent)
    print("tau s    R |  fitted " + " ".join(f"{f'{a:g}-{b:g}':>9s}" for a, b in PITCH_WINDOWS))
    best = None
    for tau in (0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0, 1.2, 1.5):
        cand = None
        for R in np.arange(0.5, 8.0, 0.05):
            r = np.array([[c[i] - R * (v / 127.0) ** exponent * wmean(tau, *PITCH_WINDOWS[i])
                           for i in range(len(PITCH_WINDOWS))] for (k, v), c in res.items()])
            m = float(np.max(np.abs(r[:, list(windows)])))
            if cand is None or m < cand[0]:
                cand = (m, R, np.max(np.abs(r), axis=0))
        m, R, per = cand
        print(f"{tau:5.2f} {R:4.2f} | {m:7.2f} " + " ".join(f"{x:9.2f}" for x in per))
        if best is None or m < best[0]:
            best = (m, R, tau)
    print(f"best: termination.pitch_rise_cents = {best[1]:.2f}, termination.pitch_rise_tau_s = "
          f"{best[2]:g} (worst residual {best[0]:.2f} cent)")
    return best[1], best[2]


def _fmt_end(e):
    return "on" if e is None else f"{e:.3f}"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--preset", default="sitar")
    ap.add_argument("--set", action="append", default=[], metavar="PATH=VALUE",
                    help="override a preset value (repeatable), as synth note --set")
    ap.add_argument("--keys", default="sweep", help="sweep (43..74 step 3, and 74), all, or K1,K2,...")
    ap.add_argument("--velocities", default="40,80,127")
    ap.add_argument("--seconds", type=float, default=1.2)
    ap.add_argument("--f-cut", type=float, default=F_CUT_HZ,
                    help="lower edge of the high band, Hz (issue 12: 1000)")
    ap.add_argument("--above-harmonic", type=float, default=0.0, metavar="H",
                    help="the band starts at max(f_cut, H f0): 2.5 leaves partials 1-2 out on every "
                         "key (default 0: f_cut on every key, as issue 12)")
    ap.add_argument("--internal-rate", type=float, default=None,
                    help="internal rate, Hz (default: the preset's, 325 kHz)")
    ap.add_argument("--bands", action="store_true", help="also print the rigid end's early high band (dB)")
    ap.add_argument("--pitch", action="store_true",
                    help="print partial 1 against the key (cents) per key and velocity instead, "
                         "in several windows")
    ap.add_argument("--fit", action="store_true",
                    help="with --pitch (and --set termination.pitch_rise_cents=0): fit the "
                         "voice's decaying tune-out to the rise")
    a = ap.parse_args(argv)
    if a.keys == "sweep":
        keys = sweep_keys()
    elif a.keys == "all":
        keys = list(range(43, 75))
    else:
        keys = [int(k) for k in a.keys.split(",")]
    vels = [int(v) for v in a.velocities.split(",")]
    if not (LATE[1] + 0.05 <= a.seconds <= 30):
        raise SystemExit(f"--seconds = {a.seconds} is out of range ({LATE[1] + 0.05} <= value <= 30)")
    if a.pitch:
        res = pitch_table(a.preset, a.set, keys, vels)
        if a.fit:
            fit_rise(res)
        return 0
    print(f"preset {a.preset}, overrides: {' '.join(a.set) or '(none)'}"
          + (f", internal rate {a.internal_rate:g} Hz" if a.internal_rate else ""))
    edge = f"> {a.f_cut:g} Hz" + (f" and > {a.above_harmonic:g} f0" if a.above_harmonic else "")
    print(f"dB of the high band ({edge}) above the rigid end (termination.profile=none); "
          "early 50-500 ms, late 0.9-1.1 s; end: last contact (s) or on; c@1s: % of 0.9-1.1 s in contact")
    head = "key " + "".join(f"| v{v:<3d} early  late   end   c@1s " for v in vels)
    if a.bands:
        head += "".join(f"| v{v} none dB " for v in vels)
    print(head)
    res = {}
    t_all = []
    for k in keys:
        row = f"{k:3d} "
        extra = ""
        for v in vels:
            m = measure(a.preset, a.set, k, v, a.seconds, a.f_cut, a.internal_rate, a.above_harmonic)
            res[(k, v)] = m
            t_all.append(m["t_render"])
            row += f"| {m['early']:8.1f} {m['late']:5.1f} {_fmt_end(m['end']):>6s} {m['c1']:5.1f} "
            extra += f"| {m['none_early_db']:10.1f} "
        print(row + (extra if a.bands else ""), flush=True)
    we = min(res, key=lambda kv: res[kv]["early"])
    wl = min(res, key=lambda kv: res[kv]["late"])
    stopped = [kv for kv in res if res[kv]["end"] is not None]
    ok = all(m["early"] >= 6.0 and m["late"] >= 3.0 for m in res.values())
    print(f"worst early: {res[we]['early']:.1f} dB (key {we[0]}, v{we[1]}); "
          f"worst late: {res[wl]['late']:.1f} dB (key {wl[0]}, v{wl[1]}); "
          f"buzz stopped before {a.seconds - 0.05:.2f} s in {len(stopped)} of {len(res)} notes"
          + (f" (earliest {min(res[kv]['end'] for kv in stopped):.3f} s)" if stopped else ""))
    print(f"criterion (early >= 6 dB and late >= 3 dB everywhere): {'PASS' if ok else 'FAIL'}")
    print(f"render time of the jawari notes (probe on, {a.seconds:g} s each): "
          f"median {1e3 * np.median(t_all):.0f} ms, max {1e3 * max(t_all):.0f} ms")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
