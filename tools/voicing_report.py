"""Voicing report of the grand piano: every target of the voicing issue
(issue 11), measured on rendered audio, in one table.

    python tools/voicing_report.py                    # the full report (keys 21-108)
    python tools/voicing_report.py --quick            # few keys, short notes (CI, development)
    python tools/voicing_report.py --json r.json --plots docs/img/voicing
    python tools/voicing_report.py --set action.speed_max_m_per_s=7 --quick
    python tools/voicing_report.py --bench            # also the cost (tools/bench.py grand)
    python tools/voicing_report.py --before docs/voicing-before.json   # today's figures as a column

Prints one row per target: what was measured, the value(s), the limit and
PASS / FAIL (INFO: reported, no limit; SKIP: not measured in this run).
``docs/voicing.md`` defines every measure and keeps the figures.  Exit 0
when the report was made (whatever the results), 2 on an error.

Loudness is the maximum 400 ms momentary BS.1770 loudness
(``synth.analysis.loudness``); the centroid of the first 100 ms is the
magnitude-weighted spectral centroid of the note's first 100 ms (a flat
window with a 10 ms half-Hann fade at its end, so the attack counts in
full).  Every note is rendered on a fresh engine (note-on at t = 0) and
kept in a cache while the report runs, so a render serves every measure
that needs it.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

if "numba" not in sys.modules:
    # one core; only before numba is imported (imported by a test, after numba
    # started its threads, a changed NUMBA_NUM_THREADS fails the next compile)
    os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from synth.analysis import (  # noqa: E402
    attack_centroid_hz as _attack_centroid_hz,
    cents,
    click_scan,
    estimate_f0,
    halo,
    max_momentary_lufs,
    peak_dbfs,
    track_partials,
)
from synth.apps.voicing import (  # noqa: E402  (the report's pieces, tested there)
    FS,
    KNEE_MIN_DROP_DB,
    KNEE_MIN_LATE_DB,
    LATE_EARLY_MIN,
    Renderer,
    decay,
    MIDI_FILES,
    QUICK_KEYS,
    Row,
    channels,
    format_table,
    law_partials,
)
from synth.engine.engine import Event  # noqa: E402
from synth.io.errors import SynthError  # noqa: E402
from synth.physics.piano import grand_string  # noqa: E402

SCHEMA = 1
#: a voice still sounding this long after a MIDI file's last event is stuck
#: (10 s until 2026-11-27, when the strings' own decay was fitted to a
#: recorded grand's aftersound and the undamped top strings rang past it)
STUCK_AFTER_S = 30.0
ROOT = Path(__file__).resolve().parents[1]
DEFAULT_MIDI_DIR = ROOT.parent / "shared" / "midi"

SWEEP_VELS = (20, 50, 80, 110, 127)
CURVE_KEYS = (33, 48, 60, 72, 84, 96, 105)
PEDAL_KEYS = (36, 48, 60, 72, 84)
HALO_KEYS = (36, 60)
SOFT_KEYS = (33, 48, 60, 72, 84, 96)

#: today's cost (tools/bench.py grand, docs/voicing.md): the limit is 1.5 x
BENCH_BASELINE = {"sustain_ms": 5.80, "chord_pct": 33.1}
BENCH_FACTOR = 1.5

# the limits of the issue
LIM = dict(range_db=35.0, centroid_ratio=2.0, partial_db=-36.0, step_db=3.0, fit_db=5.0,
           treble_db=8.0, t60_treble_s=(0.2, 2.1), late_early=LATE_EARLY_MIN, staccato_db=10.0, soft_change=0.10,
           cents_p1=1.0, cents_law=2.0, peak_dbfs=-1.0, jump_db=30.0, halo_gain_db=6.0)


# --------------------------------------------------------------------------
# rendering, with a cache
# --------------------------------------------------------------------------



# --------------------------------------------------------------------------
# measures of one note
# --------------------------------------------------------------------------

def max_momentary(y):
    """Maximum 400 ms momentary loudness (LUFS) of a note, ungated
    (:func:`synth.analysis.max_momentary_lufs`)."""
    return max_momentary_lufs(y, FS)


def attack_centroid_hz(y, length_s=0.1, fade_s=0.01):
    """Spectral centroid (Hz) of the first ``length_s`` of a note
    (:func:`synth.analysis.attack_centroid_hz`)."""
    return _attack_centroid_hz(y, FS, length_s, fade_s)


def tuning(y, key, f1_hz, seg_s=(0.05, 1.05)):
    """Partial 1 against the tuning curve, and partials 1..N against the
    key's stiff-string law (cents), from ``seg_s`` of the note; partials
    more than 60 dB under the strongest are not judged."""
    a, b = int(seg_s[0] * FS), int(seg_s[1] * FS)
    seg = y[a:b]
    p1 = estimate_f0(seg, FS, f1_hz, search_cents=60.0)
    f0, B, N = law_partials(key, f1_hz)
    freqs, levels, dev = track_partials(seg, FS, f0, N, inharmonicity=B)
    ok = np.isfinite(freqs) & (levels >= np.nanmax(levels) - 60.0)
    c = np.where(ok, dev, np.nan)
    j = int(np.nanargmax(np.abs(c)))
    return {"partial1_cents": float(cents(p1, f1_hz)), "law_cents": c.tolist(),
            "levels_db": (levels - np.nanmax(levels)).tolist(), "n_checked": int(ok.sum()),
            "n_law": N, "worst_n": j + 1, "worst_cents": float(c[j])}


def rms_db(x):
    ms = float(np.mean(np.square(x)))
    return 10.0 * math.log10(ms) if ms > 0 else -math.inf


# --------------------------------------------------------------------------
# the report
# --------------------------------------------------------------------------

class Report:
    def __init__(self, args):
        self.a = args
        self.quick = args.quick
        self.r = Renderer(args.preset, tuple(args.set))
        # tuning: the strings alone (no board), their unison spread (+-0.5 cent by
        # design) taken out: the tuning curve and the stiff-string law are each string's
        self.dry = Renderer(args.preset, tuple(args.set) + ("body.wet=0", "strings.detune_scale=0"))
        self.rows: list[Row] = []
        self.data: dict = {}
        self.timing: dict = {}
        self.keys = list(QUICK_KEYS) if self.quick else list(range(21, 109))
        self.short_s = 1.0                                  # loudness and centroid
        self.c4_vels = [1, 20, 50, 80, 110, 127] if self.quick else list(range(1, 128))
        self.curve_vels = [1, 20, 50, 80, 110, 127] if self.quick else \
            sorted(set([1] + list(range(10, 121, 10)) + [127] + list(SWEEP_VELS)))

    def add(self, section, target, measured, limit, ok, value=None, detail=""):
        status = ok if isinstance(ok, str) else ("PASS" if ok else "FAIL")
        self.rows.append(Row(section, target, measured, limit, status, value, detail))

    def long_s(self, key):
        """Length of the velocity-80 render of a key: long enough for its
        partial 1 to fall 50 dB (the string's own T60 at f0, from
        synth.physics.piano), 3 to 30 s (quick: 1.5 to 4 s)."""
        t = 0.9 * grand_string(key).t60_low_s
        return min(max(t, 1.5), 4.0) if self.quick else min(max(t, 3.0), 30.0)

    def progress(self, msg):
        if not self.a.silent:
            print(msg, file=sys.stderr, flush=True)

    def timed(self, name, fn):
        t = time.perf_counter()
        r0 = self.r.render_s
        fn()
        self.timing[name] = {"total_s": round(time.perf_counter() - t, 2),
                             "render_s": round(self.r.render_s - r0, 2)}
        self.progress(f"  {name}: {self.timing[name]['total_s']:.1f} s "
                      f"(rendering {self.timing[name]['render_s']:.1f} s)")

    # -- keyboard sweep -------------------------------------------------------
    def sweep(self):
        kb = {"keys": self.keys, "velocities": list(SWEEP_VELS), "loudness_lufs": {},
              "centroid100_hz": {}, "key80": {}}
        for vel in SWEEP_VELS:
            L, C = [], []
            for key in self.keys:
                sec = self.long_s(key) if vel == 80 else self.short_s
                y = self.r.note(key, vel, sec, keep_s=4.0)
                L.append(max_momentary(y[:int(self.short_s * FS)]))
                C.append(attack_centroid_hz(y))
                if vel == 80:
                    f1 = self.r.tuning_hz(key)
                    # the tuning from the strings alone (body.wet = 0, as the
                    # test suite measures it): the board's lowest modes (50 Hz,
                    # T60 2 s) pull a bass fundamental's estimate by a cent or two
                    yd = self.dry.note(key, vel, 1.1)
                    seg = (0.05, min(1.05, len(yd) / FS))
                    kb["key80"][key] = {"tuning_hz": f1, "render_s": sec,
                                        **tuning(yd, key, f1, seg), **decay(y, f1)}
            kb["loudness_lufs"][vel] = L
            kb["centroid100_hz"][vel] = C
            self.progress(f"    velocity {vel}: {len(self.keys)} keys")
        self.data["keyboard"] = kb

    def evenness(self):
        kb = self.data["keyboard"]
        keys = np.array(kb["keys"])
        L = np.array(kb["loudness_lufs"][80])
        adj = np.flatnonzero(np.diff(keys) == 1)
        steps = np.diff(L)[adj]
        j = int(np.argmax(np.abs(steps)))
        over = [f"{keys[i]}-{keys[i] + 1}: {st:+.1f}" for i, st in zip(adj, steps)
                if abs(st) > LIM["step_db"]]
        self.add("evenness", "vel 80: loudness step between adjacent keys",
                 f"{steps[j]:+.2f} dB (keys {keys[adj[j]]}-{keys[adj[j]] + 1})",
                 f"|x| <= {LIM['step_db']:g} dB", abs(steps[j]) <= LIM["step_db"], float(steps[j]),
                 f"{len(over)} of {len(steps)} steps over" + (": " + ", ".join(over) if over else ""))
        fits = {}
        for vel in SWEEP_VELS:
            fits[vel] = np.polyfit(keys, np.array(kb["loudness_lufs"][vel]), 3).tolist()
        kb["fit_cubic"] = fits
        dev = L - np.polyval(fits[80], keys)
        j = int(np.argmax(np.abs(dev)))
        over = [f"{k}: {d:+.1f}" for k, d in zip(keys, dev) if abs(d) > LIM["fit_db"]]
        self.add("evenness", "vel 80: key against a smooth fit (cubic in key)",
                 f"{dev[j]:+.2f} dB (key {keys[j]})", f"|x| <= {LIM['fit_db']:g} dB",
                 abs(dev[j]) <= LIM["fit_db"], float(dev[j]),
                 f"RMS {np.sqrt(np.mean(dev ** 2)):.2f} dB; {len(over)} keys over"
                 + (": " + ", ".join(over) if over else ""))
        mid = (keys >= 41) & (keys <= 60)
        top = (keys >= 97) & (keys <= 108)
        ref = float(np.mean(L[mid]))
        d = L[top] - ref
        j = int(np.argmax(np.abs(d)))
        self.add("evenness", "vel 80: keys 97-108 against keys 41-60",
                 f"{d[j]:+.2f} dB (key {keys[top][j]})", f"|x| <= {LIM['treble_db']:g} dB",
                 abs(d[j]) <= LIM["treble_db"], float(d[j]),
                 f"re the mean of keys 41-60 ({ref:.1f} LUFS): "
                 + ", ".join(f"{k}: {v:+.1f}" for k, v in zip(keys[top], d)) + " dB")

    # -- dynamics of C4 -------------------------------------------------------
    def dynamics(self):
        L, C = [], []
        for vel in self.c4_vels:
            y = self.r.note(60, vel, self.short_s)
            L.append(max_momentary(y))
            C.append(attack_centroid_hz(y))
        L, C = np.array(L), np.array(C)
        self.data["c4_dynamics"] = {"velocities": self.c4_vels, "loudness_lufs": L.tolist(),
                                    "centroid100_hz": C.tolist()}
        rng = L[-1] - L[0]
        self.add("dynamics", "C4 loudness, velocity 1 to 127", f"{rng:.1f} dB",
                 f">= {LIM['range_db']:g} dB", rng >= LIM["range_db"], float(rng),
                 f"{L[0]:.1f} LUFS at velocity 1, {L[-1]:.1f} LUFS at 127")
        st = np.diff(L)
        j = int(np.argmin(st))
        self.add("dynamics", "C4 loudness monotonic in velocity",
                 f"smallest step {st[j]:+.3f} dB ({self.c4_vels[j]}-{self.c4_vels[j + 1]})",
                 "every step >= 0", bool(st[j] >= 0.0), float(st[j]),
                 f"{len(L)} velocities: " + ("1 to 127" if len(L) == 127 else
                                             ", ".join(map(str, self.c4_vels))))
        c20 = C[self.c4_vels.index(20)]
        ratio = C[-1] / c20
        self.add("dynamics", "C4 centroid of the first 100 ms, vel 127 / 20", f"{ratio:.2f}",
                 f">= {LIM['centroid_ratio']:g}", ratio >= LIM["centroid_ratio"], float(ratio),
                 f"{c20:.0f} Hz at velocity 20, {C[-1]:.0f} Hz at 127")
        # the other keys' velocity curves (plots; ranges as information)
        curves = {}
        for key in CURVE_KEYS:
            if key == 60:
                vels, Lk, Ck = self.c4_vels, L.tolist(), C.tolist()
            else:
                vels, Lk, Ck = self.curve_vels, [], []
                for vel in vels:
                    y = self.r.note(key, vel, self.short_s)
                    Lk.append(max_momentary(y))
                    Ck.append(attack_centroid_hz(y))
            curves[key] = {"velocities": list(vels), "loudness_lufs": Lk, "centroid100_hz": Ck}
        self.data["velocity_curves"] = curves
        rg = {k: c["loudness_lufs"][-1] - c["loudness_lufs"][0] for k, c in curves.items()}
        cr = {k: c["centroid100_hz"][-1] / c["centroid100_hz"][c["velocities"].index(20)]
              for k, c in curves.items()}
        self.add("dynamics", "other keys: loudness range, vel 1 to 127",
                 f"{min(rg.values()):.1f} to {max(rg.values()):.1f} dB", "(C4's target)", "INFO", None,
                 ", ".join(f"{k}: {v:.1f}" for k, v in rg.items()) + " dB")
        self.add("dynamics", "other keys: centroid 100 ms, vel 127 / 20",
                 f"{min(cr.values()):.2f} to {max(cr.values()):.2f}", "(C4's target)", "INFO", None,
                 ", ".join(f"{k}: {v:.2f}" for k, v in cr.items()))

    def partial_levels(self):
        y = self.r.note(60, 80, min(self.long_s(60), 4.0))
        f1 = self.r.tuning_hz(60)
        f0, B, _ = law_partials(60, f1)
        seg = y[int(0.05 * FS):int(1.05 * FS)]
        _, lv, _ = track_partials(seg, FS, f0, 16, inharmonicity=B)
        rel = lv - np.nanmax(lv)
        worst = int(np.argmin(rel[1:8])) + 2
        self.data["c4_partials_db"] = rel.tolist()
        self.add("spectrum", "C4 vel 80: partials 2-8 re the strongest",
                 f"{rel[worst - 1]:+.1f} dB (partial {worst})", f">= {LIM['partial_db']:g} dB",
                 rel[worst - 1] >= LIM["partial_db"], float(rel[worst - 1]),
                 "partials 1-16 re the strongest (0.05-1.05 s): "
                 + ", ".join(f"{n}: {rel[n - 1]:+.1f}" for n in range(1, 17)) + " dB")

    # -- decay ------------------------------------------------------------------
    def decays(self):
        k80 = self.data["keyboard"]["key80"]
        treble = [k for k in self.keys if 100 <= k <= 108]
        t = {k: k80[k]["t60_s"] for k in treble}
        j = min(treble, key=lambda k: t[k] if t[k] is not None else -1.0)
        lo, hi = LIM["t60_treble_s"]
        out = [k for k in treble if t[k] is None or not lo <= t[k] <= hi]
        if out:
            j = out[0]
        self.add("decay", "T60 of partial 1, keys 100-108 (vel 80)",
                 f"{t[j]:.2f} s (key {j})" if t[j] is not None else f"no decay (key {j})",
                 f"{lo:g} .. {hi:g} s", not out,
                 t[j], ", ".join(f"{k}: {t[k]:.2f}" if t[k] is not None else f"{k}: -" for k in treble)
                 + " s")
        multi = [k for k in self.keys if grand_string(k).n_strings >= 2]
        rat = {k: k80[k]["ratio"] for k in multi}
        vis = [k for k in multi if k80[k]["visible"]]
        finite = [r for r in rat.values() if r is not None]
        med = float(np.median(finite)) if finite else float("nan")
        hi = sum(1 for r in finite if r >= LIM["late_early"])
        self.add("decay", "two-stage decay, keys with 2-3 strings: late/early T60 >= 3, visible knee",
                 f"{len(vis)} of {len(multi)} keys", "all", len(vis) == len(multi), len(vis) / len(multi),
                 f"late/early T60 of the note's level (vel 80): median {med:.2f}, {hi} of {len(multi)} "
                 f"keys >= {LIM['late_early']:g}; a knee is visible when the level falls >= "
                 f"{KNEE_MIN_DROP_DB:g} dB before it and >= {KNEE_MIN_LATE_DB:g} dB after it; below it: "
                 f"the keys that miss")
        miss = [k for k in multi if not k80[k]["visible"]]
        if miss:
            self.rows[-1].detail += ": " + ", ".join(
                f"{k} ({k80[k]['ratio']:.2f})" if k80[k]["ratio"] is not None else f"{k} (-)"
                for k in miss)
        r1 = [k80[k]["p1_ratio"] for k in multi if k80[k]["p1_ratio"] is not None]
        v1 = sum(1 for k in multi if k80[k]["p1_visible"])
        self.add("decay", "two-stage decay of partial 1 alone (its beats cut notches into it)",
                 f"{v1} of {len(multi)} keys", "", "INFO", v1 / len(multi),
                 f"late/early T60 of partial 1: median {float(np.median(r1)) if r1 else float('nan'):.2f}")

    # -- pedals -----------------------------------------------------------------
    def pedal(self):
        off, at = 0.1, 0.6
        res = {}
        for key in PEDAL_KEYS:
            a = int((at - 0.05) * FS), int((at + 0.05) * FS)
            wet = self.r.note(key, 80, 1.0, sustain=True, off_s=off, exact=True)
            dry = self.r.note(key, 80, 1.0, off_s=off, exact=True)
            res[key] = (rms_db(wet[a[0]:a[1]]), rms_db(dry[a[0]:a[1]]))
        diff = {k: w - d for k, (w, d) in res.items()}
        j = min(diff, key=diff.get)
        self.data["pedal_staccato_db"] = {k: list(v) for k, v in res.items()}

        def show(v):
            return "+inf (the take without is silent)" if v == math.inf else f"{v:+.1f}"
        self.add("pedal", "staccato tail 0.5 s after key up, pedal - none", f"{show(diff[j])} dB (key {j})",
                 f">= {LIM['staccato_db']:g} dB", diff[j] >= LIM["staccato_db"], diff[j],
                 f"vel 80, key up at {off:g} s, RMS of 0.55-0.65 s: "
                 + ", ".join(f"{k}: {show(v)}" for k, v in diff.items()) + " dB")
        # the halo of a held note
        hres = {}
        for key in HALO_KEYS:
            wet = self.r.note(key, 80, 4.0, sustain=True, exact=True)
            dry = self.r.note(key, 80, 4.0, exact=True)
            f1 = self.r.tuning_hz(key)
            f0, B, _ = law_partials(key, f1)
            n = np.arange(1, 400)
            own = n * f0 * np.sqrt(1.0 + B * n * n)
            own = own[own < FS / 2]
            probes = [self.r.tuning_hz(k) for k in range(21, 109) if k != key]
            s = slice(int(0.5 * FS), int(4.0 * FS))
            h = halo(wet[s], dry[s], FS, probes, exclude_hz=own, probe_cents=10.0, exclude_cents=40.0)
            whole = halo(wet, dry, FS, probes, exclude_hz=own)["difference_db"]
            hres[key] = {"difference_db": whole, "gain_db": h["gain_db"],
                         "level_with_db": h["level_with_db"], "level_without_db": h["level_without_db"],
                         "n_probes": int(len(h["probes_hz"])), "identical": bool(np.array_equal(wet, dry))}
        self.data["halo"] = hres

        def db(v):
            return "-inf" if v == -math.inf else f"{v:+.1f}"
        same = [k for k, v in hres.items() if v["identical"]]
        dmax = max(v["difference_db"] for v in hres.values())
        self.add("pedal", "halo: held note, pedal down vs up, difference",
                 "bit-identical" if len(same) == len(hres) else f"{db(dmax)} dB re the note",
                 "a difference", "INFO", dmax,
                 ", ".join(f"key {k}: {db(v['difference_db'])} dB" for k, v in hres.items())
                 + " (the whole 4 s take, re the take without)")
        g = {k: v["gain_db"] for k, v in hres.items()}
        j = min(g, key=g.get)
        self.add("pedal", "halo: energy at the other keys' frequencies, pedal - none",
                 f"{db(g[j])} dB (key {j})", f">= {LIM['halo_gain_db']:g} dB (proposed)",
                 g[j] >= LIM["halo_gain_db"], g[j],
                 "held note, vel 80, 0.5-4 s; bands +-10 cents around the other keys' partial-1 "
                 "frequencies, those within 40 cents of the note's own partials left out: "
                 + ", ".join(f"key {k}: {db(v['gain_db'])} dB over {v['n_probes']} keys, "
                             f"{db(v['level_with_db'])} dB re the note with the pedal"
                             for k, v in hres.items()))

    def una_corda(self):
        res = {}
        for key in SOFT_KEYS:
            a = self.r.note(key, 80, self.short_s)
            b = self.r.note(key, 80, self.short_s, soft=True)
            res[key] = {"centroid100_hz": [attack_centroid_hz(a), attack_centroid_hz(b)],
                        "loudness_lufs": [max_momentary(a), max_momentary(b)]}
        ch = {k: v["centroid100_hz"][1] / v["centroid100_hz"][0] - 1.0 for k, v in res.items()}
        j = min(ch, key=lambda k: abs(ch[k]))
        self.data["una_corda"] = res
        self.add("pedal", "una corda: change of the centroid of the first 100 ms",
                 f"{100 * ch[j]:+.1f} % (key {j})", f"|x| >= {100 * LIM['soft_change']:g} %",
                 abs(ch[j]) >= LIM["soft_change"], ch[j],
                 "CC67 down, vel 80: " + ", ".join(f"{k}: {100 * v:+.1f}" for k, v in ch.items()) + " %")
        dl = {k: v["loudness_lufs"][1] - v["loudness_lufs"][0] for k, v in res.items()}
        self.add("pedal", "una corda: loudness change", f"{min(dl.values()):+.1f} to {max(dl.values()):+.1f} dB",
                 "", "INFO", None, ", ".join(f"{k}: {v:+.1f}" for k, v in dl.items()) + " dB")

    # -- tuning -------------------------------------------------------------------
    def tunings(self):
        k80 = self.data["keyboard"]["key80"]
        p1 = {k: k80[k]["partial1_cents"] for k in self.keys}
        j = max(p1, key=lambda k: abs(p1[k]))
        self.add("tuning", "partial 1 against the tuning curve", f"{p1[j]:+.3f} cent (key {j})",
                 f"|x| <= {LIM['cents_p1']:g} cent", abs(p1[j]) <= LIM["cents_p1"], p1[j],
                 f"{len(self.keys)} keys, vel 80, 0.05-1.05 s, strings alone (body.wet = 0), unison spread 0")
        w = {k: k80[k]["worst_cents"] for k in self.keys}
        j = max(w, key=lambda k: abs(w[k]))
        over = [k for k in self.keys if abs(w[k]) > LIM["cents_law"]]
        n_chk = sum(k80[k]["n_checked"] for k in self.keys)
        first = {k: next((n + 1 for n, c in enumerate(k80[k]["law_cents"])
                          if c is not None and not math.isnan(c) and abs(c) > LIM["cents_law"]), None)
                 for k in over}
        self.add("tuning", "partials to 40 / 10 kHz against the stiff-string law",
                 f"{w[j]:+.1f} cent (key {j}, partial {k80[j]['worst_n']})",
                 f"|x| <= {LIM['cents_law']:g} cent", abs(w[j]) <= LIM["cents_law"], w[j],
                 f"{len(over)} of {len(self.keys)} keys over, {n_chk} partials checked (those within 60 dB "
                 f"of the strongest); the first partial over 2 cents: "
                 + (", ".join(f"{k}: {n}" for k, n in first.items()) if first else "none"))

    # -- the MIDI files -----------------------------------------------------------
    def midi(self):
        from synth.io.midi import midi_to_events, read_midi_file

        d = Path(self.a.midi_dir)
        cut = self.a.midi_seconds if self.a.midi_seconds else (4.0 if self.quick else None)
        files = [d / f for f in MIDI_FILES]
        missing = [f.name for f in files if not f.is_file()]
        if missing:
            self.add("midi", "MIDI files", f"{len(missing)} missing", "", "SKIP", None,
                     f"not in {d}: {', '.join(missing)}")
            files = [f for f in files if f.is_file()]
        res = {}
        for f in files:
            ev = midi_to_events(read_midi_file(f))
            if cut is not None:
                # the first `cut` seconds, then every key up and the pedals released
                ev = [e for e in ev if e.time_s < cut]
                chans = sorted({e.channel for e in ev}) or [0]
                ev += [Event(cut, "control", cc, 0.0, ch) for ch in chans for cc in (64, 67)]
                ev += [Event(cut, "control", 123, 0.0, ch) for ch in chans]
            keys = [int(e.key) for e in ev if e.kind == "note_on" and e.value > 0]
            last = max(e.time_s for e in ev)
            eng = self.r.engine(min(keys) if keys else None)
            t = time.perf_counter()
            # up to 30 s after the last event (the engine's own limit, as
            # `synth render` uses): the undamped top strings ring on for 10-15
            # s with a real grand's aftersound; a stuck note never stops
            y = eng.render(ev, tail_s=0.5, max_tail_s=STUCK_AFTER_S)
            el = time.perf_counter() - t
            chs = channels(y)
            pk = [peak_dbfs(c) for c in chs]
            # clicks apart from the notes' attacks (10 ms after each note-on:
            # a hammer's first millisecond is meant to be sharp)
            onsets = [e.time_s for e in ev if e.kind == "note_on" and e.value > 0]
            cl = [click_scan(c, FS, ignore_s=onsets) for c in chs]
            res[f.name] = {"audio_s": len(y) / FS, "notes": len(keys), "render_s": el,
                           "peak_dbfs": pk, "jump_db": [c["worst_jump_db"] for c in cl],
                           "jump_s": [c["worst_jump_s"] for c in cl],
                           "highband_db": [c["worst_highband_db"] for c in cl],
                           "highband_s": [c["worst_highband_s"] for c in cl],
                           "voices_left": eng.n_voices, "silent_after_s": len(y) / FS - 0.5 - last,
                           "cut_s": cut, "finite": bool(np.all(np.isfinite(y)))}
            self.progress(f"    {f.name}: {len(y) / FS:.1f} s in {el:.1f} s")
        self.data["midi"] = res
        if not res:
            return
        what = "MIDI files" + (f" (first {cut:g} s)" if cut else "")

        def short(name):
            return name.split("_")[0] if not name.startswith(("hp", "kw")) else name[:2]
        pk = {k: max(v["peak_dbfs"]) for k, v in res.items()}
        j = max(pk, key=pk.get)
        fin = all(v["finite"] for v in res.values())
        self.add("midi", f"{what}: sample peak", f"{pk[j]:.1f} dBFS ({short(j)})" + ("" if fin else "; NOT FINITE"),
                 f"<= {LIM['peak_dbfs']:g} dBFS", pk[j] <= LIM["peak_dbfs"] and fin, pk[j],
                 ", ".join(f"{k}: {v:.1f}" for k, v in pk.items()) + " dBFS")
        jm = {k: max(v["jump_db"]) for k, v in res.items()}
        j = max(jm, key=jm.get)
        self.add("midi", f"{what}: click scan, largest jump", f"{jm[j]:.1f} dB ({short(j)} "
                 f"{res[j]['jump_s'][0]:.2f} s)", f"<= {LIM['jump_db']:g} dB", jm[j] <= LIM["jump_db"], jm[j],
"largest second difference of a 5 ms frame over its neighbours' RMS (frames within 50 dB "
                 "of the loudest, not the 10 ms after a note-on): " + ", ".join(f"{k}: {v:.1f}" for k, v in jm.items()) + " dB")
        hb = {k: max(v["highband_db"]) for k, v in res.items()}
        j = max(hb, key=hb.get)
        self.add("midi", f"{what}: high-band scan",
                 f"{hb[j]:.1f} dB ({short(j)} {res[j]['highband_s'][0]:.2f} s)", "(a C8 alone: -12 dB)",
                 "INFO", hb[j], "largest share of a 5 ms frame's energy above 14 kHz: "
                 + ", ".join(f"{k}: {v:.1f}" for k, v in hb.items()) + " dB")
        left = sum(v["voices_left"] for v in res.values())
        sil = {k: v["silent_after_s"] for k, v in res.items()}
        self.add("midi", f"{what}: stuck notes (voices {STUCK_AFTER_S:g} s after the end)", f"{left}", "0",
                 left == 0, left,
                 "every voice silent after the last event in: "
                 + ", ".join(f"{k}: {v:.1f} s" for k, v in sil.items()))
        tot = sum(v["render_s"] for v in res.values())
        aud = sum(v["audio_s"] for v in res.values())
        self.add("midi", f"{what}: render time", f"{tot / aud:.3f} x real time", "", "INFO", tot / aud,
                 f"{tot:.1f} s for {aud:.1f} s of audio")

    # -- cost -------------------------------------------------------------------
    def bench(self):
        if not self.a.bench:
            self.add("cost", "bench grand: sustaining note, pedalled chord", "not run (--bench)",
                     f"<= {BENCH_FACTOR:g} x today's", "SKIP")
            return
        p = subprocess.run([sys.executable, str(ROOT / "tools" / "bench.py"), "grand", "--runs", "3"],
                           capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(ROOT)})
        if p.returncode != 0:
            raise SynthError(f"tools/bench.py grand failed: {p.stderr.strip().splitlines()[-1:]}")
        sus = chord = None
        for line in p.stdout.splitlines():
            if line.startswith("Mean over these keys:"):
                sus = float(line.split(":")[1].split("ms")[0])
            if "note chord over the keyboard" in line:
                chord = float(line.split(":")[1].split("%")[0])
        self.data["bench"] = {"sustain_ms": sus, "chord_pct": chord, "output": p.stdout}
        for name, v, unit, base in (("bench grand: sustaining note", sus, "ms/note-s",
                                     BENCH_BASELINE["sustain_ms"]),
                                    ("bench grand: 64-note pedalled chord", chord, "% real time",
                                     BENCH_BASELINE["chord_pct"])):
            self.add("cost", name, f"{v:.2f} {unit} ({v / base:.2f} x)", f"<= {BENCH_FACTOR:g} x {base:g}",
                     v <= BENCH_FACTOR * base, v / base, "tools/bench.py grand --runs 3: "
                     + ("mean CPU per second of a sustaining note over its 10 keys" if unit == "ms/note-s"
                        else "2 s of a 64-note chord over the keyboard, sustain pedal down, whole engine"))

    # -- run ----------------------------------------------------------------------
    def run(self):
        t0 = time.perf_counter()
        self.progress(f"voicing report ({'quick' if self.quick else 'full'}): {len(self.keys)} keys")
        self.timed("keyboard sweep", self.sweep)
        self.timed("dynamics", self.dynamics)
        self.timed("C4 partials", self.partial_levels)
        self.evenness()
        self.decays()
        self.tunings()
        self.timed("pedals", self.pedal)
        self.timed("una corda", self.una_corda)
        self.timed("MIDI files", self.midi)
        self.timed("cost", self.bench)
        order = ["dynamics", "spectrum", "evenness", "decay", "pedal", "tuning", "midi", "cost"]
        self.rows.sort(key=lambda r: order.index(r.section))
        self.timing["total_s"] = round(time.perf_counter() - t0, 1)
        self.timing["notes_rendered"] = self.r.renders
        self.timing["note_audio_s"] = round(self.r.audio_s, 1)
        self.timing["note_render_s"] = round(self.r.render_s, 1)
        self.timing["cache_hits"] = self.r.hits


def git_commit():
    try:
        sha = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
                             capture_output=True, text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True).stdout.strip()
        return sha + ("+dirty" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def _jsonable(o):
    if isinstance(o, dict):
        return {str(k): _jsonable(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_jsonable(v) for v in o]
    if isinstance(o, (np.floating, float)):
        v = float(o)
        if not math.isfinite(v):
            return None if math.isnan(v) else ("inf" if v > 0 else "-inf")
        return float(f"{v:.7g}")
    if isinstance(o, np.integer):
        return int(o)
    if isinstance(o, np.ndarray):
        return _jsonable(o.tolist())
    if isinstance(o, np.bool_):
        return bool(o)
    return o


# --------------------------------------------------------------------------
# plots
# --------------------------------------------------------------------------

def plots(rep: Report, out: Path) -> list[str]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out.mkdir(parents=True, exist_ok=True)
    kb = rep.data["keyboard"]
    keys = np.array(kb["keys"])
    colors = dict(zip(SWEEP_VELS, ("#4575b4", "#74add1", "#1a9850", "#f46d43", "#a50026")))
    written = []

    def save(fig, name):
        import io

        fig.tight_layout()
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=100)            # 800 x 500 pixels
        plt.close(fig)
        p = out / name
        try:    # a 64-colour palette keeps a plot of lines well under 100 KB
            from PIL import Image

            buf.seek(0)
            Image.open(buf).convert("RGB").quantize(64).save(p, optimize=True)
        except ImportError:
            p.write_bytes(buf.getvalue())
        written.append(str(p))

    mk = "o-" if rep.quick else "-"
    fig, ax = plt.subplots(figsize=(8, 5))
    xs = np.linspace(keys.min(), keys.max(), 200)
    for vel in SWEEP_VELS:
        ax.plot(keys, kb["loudness_lufs"][vel], mk, ms=3, lw=1, color=colors[vel], label=f"velocity {vel}")
        ax.plot(xs, np.polyval(kb["fit_cubic"][vel], xs), "--", lw=0.8, color=colors[vel])
    ax.set_xlabel("MIDI key")
    ax.set_ylabel("max momentary loudness, LUFS")
    ax.set_title("Loudness across the keyboard (dashed: cubic fit)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    save(fig, "loudness_keyboard.png")

    fig, ax = plt.subplots(figsize=(8, 5))
    for vel in SWEEP_VELS:
        ax.plot(keys, kb["centroid100_hz"][vel], mk, ms=3, lw=1, color=colors[vel], label=f"velocity {vel}")
    ax.set_yscale("log")
    ax.set_xlabel("MIDI key")
    ax.set_ylabel("centroid of the first 100 ms, Hz")
    ax.set_title("Brightness of the attack across the keyboard")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    save(fig, "centroid_keyboard.png")

    fig, (a1, a2) = plt.subplots(1, 2, figsize=(8, 5))
    cmap = plt.get_cmap("viridis")
    for i, (key, c) in enumerate(rep.data["velocity_curves"].items()):
        col = cmap(i / max(1, len(rep.data["velocity_curves"]) - 1))
        a1.plot(c["velocities"], c["loudness_lufs"], "-", lw=1.2, color=col, label=f"key {key}")
        a2.plot(c["velocities"], c["centroid100_hz"], "-", lw=1.2, color=col, label=f"key {key}")
    a1.set_xlabel("velocity")
    a1.set_ylabel("max momentary loudness, LUFS")
    a2.set_xlabel("velocity")
    a2.set_ylabel("centroid of the first 100 ms, Hz")
    a2.set_yscale("log")
    for a in (a1, a2):
        a.grid(alpha=0.3, which="both")
    a1.legend(fontsize=7)
    fig.suptitle("Velocity response")
    save(fig, "velocity_curves.png")

    fig, ax = plt.subplots(figsize=(8, 5))
    k80 = kb["key80"]

    def col(name):
        return np.array([k80[k][name] if k80[k][name] is not None else np.nan for k in keys], float)
    ax.plot(keys, [grand_string(k).t60_low_s for k in keys], "k:", lw=1,
            label="string table T60 at f0 (synth.physics.piano)")
    ax.plot(keys, col("t60_s"), mk, ms=3, lw=1.2, color="#1a9850", label="T60, one line (-5..-35 dB)")
    ax.plot(keys, col("t60_early_s"), ".", ms=4, color="#f46d43", label="early T60 (two-stage)")
    ax.plot(keys, col("t60_late_s"), ".", ms=4, color="#4575b4", label="late T60 (two-stage)")
    lo, hi = LIM["t60_treble_s"]
    ax.hlines([lo, hi], 100, 108, colors="r", lw=2,
              label=f"target keys 100-108: {lo:g} .. {hi:g} s (the recorded C5's)")
    ax.set_yscale("log")
    ax.set_xlabel("MIDI key")
    ax.set_ylabel("T60 of partial 1, s")
    ax.set_title("Decay across the keyboard (velocity 80)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7)
    save(fig, "t60_keyboard.png")

    fig, ax = plt.subplots(figsize=(8, 5))
    ax.plot(keys, col("partial1_cents"), mk, ms=3, lw=1.2, color="#1a9850",
            label="partial 1 vs the tuning curve")
    ax.plot(keys, col("worst_cents"), "o", ms=3, color="#a50026",
            label="worst partial up to 40 / 10 kHz vs the stiff-string law")
    for lim, st in ((LIM["cents_p1"], ":"), (LIM["cents_law"], "--")):
        ax.axhline(lim, color="k", ls=st, lw=0.8)
        ax.axhline(-lim, color="k", ls=st, lw=0.8)
    ax.set_yscale("symlog", linthresh=3.0, linscale=1.5)
    big = np.nanmax(np.abs(np.concatenate([col("partial1_cents"), col("worst_cents"), [3.0]])))
    ticks = [t for t in (1, 2, 3, 10, 30, 100, 300, 1000) if t <= 1.5 * big]
    ax.set_yticks([-t for t in ticks[::-1]] + [0] + ticks)
    ax.set_yticklabels([f"{-t:g}" for t in ticks[::-1]] + ["0"] + [f"+{t:g}" for t in ticks])
    ax.set_ylim(-1.6 * big, 1.6 * big)
    ax.set_xlabel("MIDI key")
    ax.set_ylabel("cents (linear within ±3, logarithmic beyond)")
    ax.set_title("Tuning and partials (velocity 80; dotted ±1, dashed ±2 cents)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    save(fig, "tuning_cents.png")
    return written


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help=f"keys {','.join(map(str, QUICK_KEYS))}, short "
                    "notes, the MIDI files' first 4 s: for development and CI")
    ap.add_argument("--json", metavar="OUT", help="write the report and every measured value as JSON")
    ap.add_argument("--plots", metavar="DIR", help="write the PNG plots into DIR (needs matplotlib)")
    ap.add_argument("--set", action="append", default=[], metavar="PATH=VALUE",
                    help="override a preset value (repeatable), as synth note --set")
    ap.add_argument("--preset", default="grand-piano", help="preset name or .toml path (a grand voice)")
    ap.add_argument("--midi-dir", default=str(DEFAULT_MIDI_DIR), help="folder of the five piano files")
    ap.add_argument("--midi-seconds", type=float, default=None,
                    help="render only the first S seconds of each file (quick: 4)")
    ap.add_argument("--bench", action="store_true", help="also run tools/bench.py grand (about 10 s)")
    ap.add_argument("--before", metavar="JSON", help="an earlier report's --json (e.g. "
                    "docs/voicing-before.json): its figures as a column")
    ap.add_argument("--silent", action="store_true", help="no progress on stderr")
    a = ap.parse_args(argv)
    if a.plots:
        try:                    # before the work, not after it
            import matplotlib  # noqa: F401
        except ImportError:
            print('error: --plots needs the [plots] extra: pip install "synth[plots]"',
                  file=sys.stderr)
            return 2
    before = None
    if a.before:
        try:
            rows = json.loads(Path(a.before).read_text())["rows"]
            before = {(r["section"], r["target"]): r["measured"] for r in rows}
        except (OSError, ValueError, KeyError, TypeError) as e:
            print(f"error: --before {a.before}: not a voicing report JSON ({e})", file=sys.stderr)
            return 2
    try:
        rep = Report(a)
        rep.run()
    except SynthError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    commit = git_commit()
    cmd = " ".join(["python", "tools/voicing_report.py"] + (argv if argv is not None else sys.argv[1:]))
    t = rep.timing
    print(f"# voicing report, {a.preset}{' ' + ' '.join(a.set) if a.set else ''}, "
          f"{'quick' if a.quick else 'full'} mode, commit {commit}, {time.strftime('%Y-%m-%d %H:%M')}")
    print(f"# {cmd}")
    print(f"# {t['total_s']:.0f} s in all; {t['notes_rendered']} notes rendered ({t['note_audio_s']:.0f} s "
          f"of audio in {t['note_render_s']:.0f} s), {t['cache_hits']} served from the cache")
    print(format_table(rep.rows, before=before))
    written = []
    if a.plots:
        written = plots(rep, Path(a.plots))
        print(f"plots: {', '.join(written)}")
    if a.json:
        doc = {"schema": SCHEMA, "commit": commit, "command": cmd, "preset": a.preset,
               "overrides": a.set, "quick": a.quick, "timing": rep.timing, "limits": LIM,
               "rows": [r.__dict__ for r in rep.rows], "data": rep.data, "plots": written}
        Path(a.json).write_text(json.dumps(_jsonable(doc), indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
