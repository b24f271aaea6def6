"""Work-precision diagrams: error against run time, one curve per method (issue 13).

Usage
-----
    python tools/work_precision.py                      # every problem, tables and PNGs
    python tools/work_precision.py --out docs/img       # where the PNGs go ([plots] extra)
    python tools/work_precision.py --quick              # CI: a few grids, asserts the orders

In the style of the SciMLBenchmarks work-precision diagrams: for each
problem, the error of a quantity against its converged value (the finest
setting, or its Richardson extrapolation where the order is known) is
plotted against the run time, one curve per method.  The problems are the
thesis's studies on its own string models, re-gridded with the internal
rate (a study preset's ``cells``; c dt = dx on every grid):

* **jawari Cases 1-3** (Publication II): u(l, t) at the pluck point over
  the first ``WAVE_S`` (relative L2 error at the coarsest grid's instants),
  and the end of the aperiodic regime t_np (-40 dB; the thesis's figures
  beside it);
* **biwa sawari** (Publication I section 4.2): the first contact time and
  the contacts by 16.4 ms;
* **A7 hammer** (Publication I): the contact duration and the peak force of
  the study's three-parameter felt at 5 m/s on ideal supports (second order
  in dt: the error is measured against the Richardson extrapolation of the
  two finest grids);
* **the decimator** (325 kHz to 48 kHz): passband ripple and stopband
  rejection of each design against its taps and run time;
* **the grand's stiffness**: the worst partial error (cents, partials up to
  40 or 10 kHz, against the stiff-string law) of a key's loop designed to a
  tolerance, against its dispersion sections and its run time.

Methods: the internal rate (cells = ``BASE`` x 2^j, one run per grid); the
kernel's fast path and its per-sample path (the reference scheme, forced
per string) at each rate.  Run times are medians of ``--repeats`` runs of
the bank alone (one core, ``NUMBA_NUM_THREADS=1`` recommended), the first
run (compilation) discarded.

Observed order between two grids: log2(e_j / e_{j+1}).  ``--quick`` runs
the four coarsest grids of each problem and asserts: the hammer's contact
g(t) and peak force converge at order >= 1.8; the two paths agree to
1e-12 of the signal; the jawari's u(l, t) error never grows with the rate
and falls by half or more over the grids.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

#: the waveform window (s) for the jawari's u(l, t) error
WAVE_S = 0.05
#: the study string's cells on the coarsest grid, and grids per problem
BASE = {"jawari": 203, "sawari": 203, "hammer": 46}
GRIDS = {"jawari": 5, "sawari": 5, "hammer": 6}
QUICK_GRIDS = 4
THESIS_TNP = {1: 0.13, 2: 0.16, 3: 0.30}


# ---- running one study string -------------------------------------------------------
def _bank_for(voice, n_block):
    from synth.dsp.bank import StringBank

    sz = voice.sizes()
    return StringBank(1, sz.max_cells, max_region=max(sz.max_region, 1), max_block=n_block,
                      n_probes=1, max_gtable=sz.max_gtable, max_bend=sz.max_bend)


def run_study(name: str, cells: int, seconds: float, per_sample: bool, *, contacts: bool = False,
              sets=()):
    """The study preset ``name`` re-gridded to ``cells`` cells: u(l, t) per
    internal sample over ``seconds`` (m), the contact flag per sample (with
    ``contacts``, per-sample path only), the internal rate and the run time
    (s) of the bank's render."""
    from synth.io.factory import build_voice
    from synth.io.presets import load_preset
    from synth.kernels import strings as K

    p = load_preset(name, sets)
    c = math.sqrt(p.string.tension_n / p.string.linear_density_kg_per_m)
    fs = cells * c / p.string.length_m
    v = build_voice(name, sets, fs_internal=fs)
    n = int(round(seconds * v.fs))
    block = 4096
    b = _bank_for(v, block)
    v.note_on(b, [0], None, 1.0, probe_row=0 if contacts else -1)
    if per_sample:
        b.ipar[0, K.I_CHUNK] = 0
        b.ipar[0, K.I_CHUNK_FREE] = 0
    if contacts:
        b.ensure_probe_length(n + 2)
    gain = float(b.fpar[0, K.F_GAIN])
    mix = np.zeros(n)
    t0 = time.perf_counter()
    done = 0
    while done < n:
        m = min(block, n - done)
        b.render(mix, done, m)
        done += m
    dt = time.perf_counter() - t0
    u = mix / gain
    cont = b.probe[0, K.P_CONTACT, :n].copy() if contacts else None
    return u, cont, v.fs, dt


def timed(fn, repeats):
    """fn() repeated; (last result, median run time)."""
    fn()                                      # compile / warm
    times, res = [], None
    for _ in range(max(1, repeats)):
        res = fn()
        times.append(res[-1])
    return res, statistics.median(times)


def orders(errors):
    e = np.asarray(errors, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.log2(e[:-1] / e[1:])


# ---- problems ----------------------------------------------------------------------
def jawari(case: int, n_grids: int, repeats: int):
    """u(l, t) over WAVE_S and t_np at -40 dB, per grid and path."""
    from synth.analysis import aperiodic_end

    name = f"paper/sitar-case{case}"
    rows = []
    runs = {}
    for j in range(n_grids):
        cells = BASE["jawari"] * 2 ** j
        for path in ("fast", "per-sample"):
            (u, _, fs, _), t = timed(lambda: run_study(name, cells, WAVE_S, path == "per-sample"),
                                     repeats)
            runs[(j, path)] = (u, fs, t)
    J = n_grids - 1
    ref = runs[(J, "per-sample")][0]
    n0 = len(runs[(0, "fast")][0])
    for j in range(n_grids):
        idx = np.arange(n0) * 2 ** j
        idx_ref = np.arange(n0) * 2 ** J
        for path in ("fast", "per-sample"):
            u, fs, t = runs[(j, path)]
            m = min(len(idx), int(np.sum(idx_ref < len(ref))), int(np.sum(idx < len(u))))
            err = float(np.linalg.norm(u[idx[:m]] - ref[idx_ref[:m]]) / np.linalg.norm(ref[idx_ref[:m]]))
            rows.append(dict(cells=BASE["jawari"] * 2 ** j, fs=fs, path=path, time_s=t,
                             error=err if j < J else float("nan")))
    # t_np: a longer run per grid (fast path), its period exact on every grid
    tnp = []
    for j in range(n_grids):
        cells = BASE["jawari"] * 2 ** j
        u, _, fs, _ = run_study(name, cells, 0.6 if case < 3 else 0.9, False)
        tnp.append(aperiodic_end(u, fs, 2 * cells, -40))
    paths_agree = max(float(np.max(np.abs(runs[(j, "fast")][0] - runs[(j, "per-sample")][0])))
                      / float(np.max(np.abs(runs[(j, "per-sample")][0]))) for j in range(n_grids))
    return rows, tnp, paths_agree


def sawari(n_grids: int, repeats: int):
    """First contact and contacts by 16.4 ms (per-sample path: contact
    telemetry needs the probe), per grid."""
    from synth.analysis import episode_times

    rows = []
    for j in range(n_grids):
        cells = BASE["sawari"] * 2 ** j
        (u, cont, fs, _), t = timed(lambda: run_study("paper/biwa-sawari", cells, 0.0175, True,
                                                      contacts=True), repeats)
        st = episode_times(cont > 0, fs, int(0.2e-3 * fs))
        rows.append(dict(cells=cells, fs=fs, time_s=t, first_ms=float(st[0]) * 1e3 if len(st) else math.nan,
                         contacts=int(np.sum(st <= 16.4e-3))))
    return rows


def hammer(n_grids: int, repeats: int):
    """The A7 study's strike on ideal supports at 5 m/s (the bank alone,
    as tests/test_hammer.py): contact duration and peak force per grid."""
    from synth.dsp.bank import StringBank
    from synth.kernels import strings as K

    L, T, MU = 0.061, 774.6, 0.0042
    C = math.sqrt(T / MU)
    A7 = dict(law=4, mass_kg=0.0018, stiffness=8387.4, exponent=4.975, alpha_or_gamma=0.0005312,
              tau0_s=0.0, tension_n=T, c_m_per_s=C)
    rows = []
    for j in range(n_grids):
        cells, k = 46 * 2 ** j, 2 * 2 ** j
        dt = L / (cells * C)
        n = int(0.4e-3 / dt)

        def strike():
            b = StringBank(1, cells + 2, 1, 4096, n_probes=1)
            b.configure(0, cells=cells, k=k, dt_s=dt, U=None, side=1, probe_row=0)
            b.activate(0)
            b.start_hammer(0, speed_m_per_s=5.0, **A7)
            mix = np.zeros(n)
            t0 = time.perf_counter()
            b.render(mix, 0, n)
            return b.probe[0, :, :n].copy(), time.perf_counter() - t0

        (ch, _), t = timed(strike, repeats)
        g = ch[K.P_G]
        Fm = np.diff(g) / (C / (2 * T) * dt)          # step-mean force, at mid-step
        e = int(np.flatnonzero(Fm > 0)[-1])
        dur = (e + 0.5 + Fm[e] / (Fm[e - 1] - Fm[e])) * dt
        # the peak force: a parabola through the step-mean forces around their maximum
        i = int(np.argmax(Fm))
        y0, y1, y2 = Fm[i - 1], Fm[i], Fm[i + 1]
        peak = y1 + 0.125 * (y0 - y2) ** 2 / (2 * y1 - y0 - y2)
        rows.append(dict(cells=cells, fs=1 / dt, time_s=t, duration_s=dur, peak_n=float(peak), g=g))
    # g(t) at the coarsest grid's instants t = i dt_0 against the finest grid
    J = len(rows) - 1
    n0 = len(rows[0]["g"])
    gJ = rows[J]["g"][np.arange(n0) * 2 ** J]
    for j, r in enumerate(rows):
        r["g_err"] = float(np.max(np.abs(r["g"][np.arange(n0) * 2 ** j] - gJ)) / np.max(np.abs(gJ)))
    # Richardson (order 2) from the two finest grids
    for q in ("duration_s", "peak_n"):
        a, b = rows[-2][q], rows[-1][q]
        ext = b + (b - a) / 3.0
        for r in rows:
            r[q + "_err"] = abs(r[q] - ext) / abs(ext)
        rows[0][q + "_extrapolated"] = ext
    return rows


#: the felt solver's tolerances of the hammer-tolerance problem (the last the reference)
SOLVER_TOLS = (1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-7, 1e-10)


def hammer_tolerance(tols, cells_list, repeats: int):
    """The A7 strike of :func:`hammer` at a fixed grid, its felt solver
    stopped at each tolerance (``StringBank.start_hammer(solver_tol=)``):
    g(t), peak force and contact duration against the tightest tolerance on
    the same grid (the grid's error is another problem's), and the run time
    of the strike (0.4 ms) rendered 200 times, median of ``repeats``."""
    from synth.dsp.bank import StringBank
    from synth.kernels import strings as K

    L, T, MU = 0.061, 774.6, 0.0042
    C = math.sqrt(T / MU)
    A7 = dict(law=4, mass_kg=0.0018, stiffness=8387.4, exponent=4.975, alpha_or_gamma=0.0005312,
              tau0_s=0.0, tension_n=T, c_m_per_s=C)
    rows = []
    for cells in cells_list:
        k = max(1, int(round(2 * cells / 46)))
        dt = L / (cells * C)
        n = int(0.4e-3 / dt)
        b = StringBank(1, cells + 2, 1, 4096, n_probes=1)
        mix = np.zeros(n)
        res = {}
        for tol in tols:
            def strike(times=1):
                t = 0.0
                for _ in range(times):
                    b.configure(0, cells=cells, k=k, dt_s=dt, U=None, side=1, probe_row=0)
                    b.activate(0)
                    b.start_hammer(0, speed_m_per_s=5.0, solver_tol=tol, **A7)
                    t0 = time.perf_counter()
                    b.render(mix, 0, n)
                    t += time.perf_counter() - t0
                return b.probe[0, :, :n].copy(), t

            strike()                                     # compile / warm
            ts = [strike(200)[1] for _ in range(max(1, repeats))]
            ch, _ = strike()
            g = ch[K.P_G]
            F = ch[K.P_F]
            res[tol] = (g, F, statistics.median(ts) / 200)
        g_ref, F_ref, _ = res[tols[-1]]
        for tol in tols:
            g, F, t = res[tol]
            on = np.flatnonzero(F > 0)
            on_ref = np.flatnonzero(F_ref > 0)
            rows.append(dict(cells=cells, fs=1 / dt, tol=tol, time_s=t,
                             g_err=float(np.max(np.abs(g - g_ref)) / np.max(np.abs(g_ref))),
                             peak_err=abs(F.max() - F_ref.max()) / F_ref.max(),
                             steps_diff=int(abs(len(on) - len(on_ref)))))
    return rows


#: region lengths (points on the study's 812-cell grid, 0.985 mm each) of the region problem
REGION_POINTS = (2, 4, 6, 8, 10, 12, 15, 20, 25, 40)


def region(case: int, points, repeats: int):
    """u(l, t) over WAVE_S on the study grid with the termination region
    cut to ``points`` grid points, against the region of 100 points (98.5
    mm: more than the string ever reaches), and its run time (fast path)."""
    name = f"paper/sitar-case{case}"
    ref = run_study(name, 812, WAVE_S, False, sets=("termination.region_points=100",))[0]
    rows = []
    for R in points:
        (u, _, fs, _), t = timed(lambda: run_study(name, 812, WAVE_S, False,
                                                   sets=(f"termination.region_points={R}",)), repeats)
        rows.append(dict(points=R, length_mm=R * 0.8 / 812 * 1e3, time_s=t,
                         error=float(np.linalg.norm(u - ref) / np.linalg.norm(ref))))
    return rows


#: decimator designs: (passband edge Hz, design stopband attenuation dB); (20 kHz, 110 dB) ships
DEC_DESIGNS = ((20000.0, 60.0), (20000.0, 80.0), (20000.0, 100.0), (20000.0, 110.0),
               (20000.0, 140.0), (18000.0, 110.0), (22000.0, 110.0))


def decimator(designs, repeats: int, fs_in: int = 325_000, fs_out: int = 48_000):
    """The 325 kHz -> 48 kHz decimator per design: its measured passband
    ripple (largest |gain| error in dB up to the passband edge), stopband
    rejection (smallest attenuation from the stopband edge, fs_out / 2, up
    to fs_in / 2: what aliases into the audio band), taps per output sample,
    latency, and run time (ns per output sample, 1 s of noise in 128-sample
    blocks)."""
    from synth.dsp.decimator import Decimator

    rows = []
    rng = np.random.default_rng(0)
    for pb, att in designs:
        d = Decimator(fs_in, fs_out, passband_hz=pb, atten_db=att)
        fs_proto = float(d.L) * fs_in
        nfft = 1 << int(math.ceil(math.log2(fs_proto / 5.0)))       # 5 Hz bins
        H = np.abs(np.fft.rfft(d.h / d.L, nfft))
        f = np.fft.rfftfreq(nfft, 1.0 / fs_proto)
        with np.errstate(divide="ignore"):
            db = 20 * np.log10(np.maximum(H, 1e-300))
        ripple = float(np.max(np.abs(db[f <= pb])))
        rejection = float(-np.max(db[(f >= d.stopband_hz) & (f <= fs_in / 2)]))
        x = rng.standard_normal(d.inputs_needed(fs_out) + 1)

        def run():
            d.reset()
            out = np.empty(128)
            pos = made = 0
            t0 = time.perf_counter()
            while made < fs_out:
                n = min(128, fs_out - made)
                k = d.inputs_needed(n)
                d.process(x[pos:pos + k], out[:n])
                pos += k
                made += n
            return (time.perf_counter() - t0,)

        (_,), tm = timed(run, repeats)
        rows.append(dict(passband=pb, atten=att, ripple_db=ripple, rejection_db=rejection,
                         taps=d.taps_per_phase, latency_ms=d.latency_s * 1e3, ns=tm / fs_out * 1e9))
    return rows


#: grand notes: keys and internal rates (the last is the reference)
GRAND_KEYS = (33, 60, 84)
GRAND_RATES = (162_500, 243_750, 325_000, 650_000, 1_300_000)


def note_partials(y, fs, f1, B):
    """Partials 1..16 (those under 10 kHz) of a note over 0.05 s on:
    frequencies and levels (:func:`synth.analysis.track_partials`)."""
    from synth.analysis.partials import track_partials

    seg = y[int(0.05 * fs):]
    n = max(1, min(16, int(10_000 / f1)))
    f, lv, _ = track_partials(seg, fs, f1 / math.sqrt(1 + B), n, inharmonicity=B)
    return f, lv


def partial_errors(f, lv, fr, lr):
    """(partials compared, worst frequency error in cents, worst level
    error in dB) of partials (f, lv) against the reference's (fr, lr), over
    the reference's partials within 40 dB of its strongest."""
    keep = np.isfinite(fr) & np.isfinite(lr) & (lr >= np.nanmax(lr) - 40)
    ok = keep & np.isfinite(f) & np.isfinite(lv)
    if not ok.any():
        return 0, math.nan, math.nan
    return (int(ok.sum()), float(np.max(np.abs(1200 * np.log2(f[ok] / fr[ok])))),
            float(np.max(np.abs(lv[ok] - lr[ok]))))


def grand_notes(keys, rates, repeats: int):
    """A grand note (velocity 80, 1.05 s, mono mean) rendered at each
    internal rate: partials 1..16 (those under 10 kHz and within 40 dB of the
    strongest) over 0.05-1.05 s (:func:`synth.analysis.track_partials`),
    their frequencies (cents) and levels (dB) against the same note at the
    highest rate, and the render's run time."""
    from synth.analysis.spectrum import as_mono
    from synth.engine.engine import Event
    from synth.io.factory import build_engine
    from synth.physics import piano as PI

    rows = []
    for key in keys:
        B = PI.grand_string(key).inharmonicity_b
        res = {}
        for fs in rates:
            def render():
                e = build_engine("grand-piano", fs_internal=fs)
                t0 = time.perf_counter()
                y = e.render([Event(0.0, "note_on", key, 80 / 127)], duration_s=1.05)
                return as_mono(y), e.fs_out, e.inst.tuning_hz(key), time.perf_counter() - t0

            (y, fo, f1, _), tm = timed(render, repeats)
            res[fs] = (*note_partials(y, fo, f1, B), tm)
        fr, lr, _ = res[rates[-1]]
        for fs in rates:
            f, lv, tm = res[fs]
            n, cents, db = partial_errors(f, lv, fr, lr)
            rows.append(dict(key=key, fs=fs, partials=n, cents=cents, db=db, time_s=tm))
    return rows


#: grand keys and design tolerances (cents) of the dispersion problem
DISP_KEYS = (33, 48, 60, 72, 84)
DISP_TOLS = (0.5, 1.0, 2.0, 4.0, 8.0, 16.0)


def dispersion(keys, tols, repeats: int):
    """The grand's stiffness: for each key and design tolerance, the loop of
    :func:`synth.physics.dispersion.tune_stiff_loop_sos` as the voice
    designs it (the key's loss at 325 kHz; 2 cents is the preset's), its
    exact partials' worst error against n f0 sqrt(1 + B n^2) over partials
    1 .. K (up to 40 or 10 kHz), its sections, and the run time of one
    such string for 0.5 s on the fast path; plus the loop with no
    dispersion filter at all (the harmonic string)."""
    from synth.dsp.bank import StringBank
    from synth.io.factory import build_voice
    from synth.physics import piano as PI
    from synth.physics.dispersion import stiff_partials, tune_stiff_loop, tune_stiff_loop_sos

    v = build_voice("grand-piano")
    fs = v.fs
    rows = []
    for key in keys:
        gs = PI.grand_string(key)
        f1 = v.tuning_hz(key)
        B = gs.inharmonicity_b
        t_lo = gs.t60_low_s
        t_hi = min(gs.t60_s(gs.f_high_hz), t_lo)
        fh = max(gs.f_high_hz, 1.5 * f1)
        loops = [("none", tune_stiff_loop(f1, 0.0, fs, t_lo, f1, t_hi, fh, m_max=0))]
        loops += [(tol, tune_stiff_loop_sos(f1, B, fs, t_lo, f1, t_hi, fh, tol_cents=tol, m_max=16))
                  for tol in tols]
        K = loops[-1][1].n_partials
        target = stiff_partials(f1 / math.sqrt(1 + B), B, np.arange(1, K + 1))
        for tol, loop in loops:
            if tol == "none":
                # the harmonic loop's partials are n f1: their error against the stiff law
                worst = float(np.max(np.abs(1200 * np.log2(f1 * np.arange(1, K + 1) / target))))
                sections, sos, n_fo, a_fo = 0, None, 0, 0.0
            else:
                worst = float(loop.worst_cents)
                sos = loop.sos if len(loop.sos) else None
                n_fo, a_fo = int(loop.n_fo), float(loop.a_fo)
                sections = 2 * len(loop.sos) + n_fo       # cost units: a biquad = 2 first-order

            def render():
                b = StringBank(1, loop.cells + 2, 1, 4096)
                b.configure(0, cells=loop.cells, k=max(2, loop.cells // 8), dt_s=1.0 / fs, U=None,
                            out_mode=1, tension_over_dx=1.0, b0=loop.b0, a1=loop.a1, eta=loop.eta,
                            extra_delay=loop.extra_delay, lossy=True, n_disp=n_fo, a_disp=a_fo,
                            sos=sos)
                b.activate(0)
                b.start_pluck(0, 1, 1e-3, 1e-3, 0.0)
                mix = np.zeros(4096)
                n = int(0.5 * fs)
                t0 = time.perf_counter()
                done = 0
                while done < n:
                    m = min(4096, n - done)
                    b.render(mix, 0, m)
                    done += m
                return (time.perf_counter() - t0,)

            (_,), tm = timed(render, repeats)
            rows.append(dict(key=key, tol=tol, sections=sections, kind=getattr(loop, "kind", "-"),
                             worst=worst, K=K, time_s=tm))
    return rows


# ---- output ------------------------------------------------------------------------
def plot(path: Path, title: str, curves, xlabel="run time (s)", ylabel="relative error"):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise SystemExit("tools/work_precision.py: the plots need matplotlib: pip install -e '.[plots]'")
    fig, ax = plt.subplots(figsize=(5.2, 3.6), dpi=110)
    for label, xs, ys, ann in curves:
        ax.loglog(xs, ys, "o-", ms=4, lw=1.2, label=label)
        for x, y, a in zip(xs, ys, ann):
            ax.annotate(a, (x, y), fontsize=6, xytext=(3, 3), textcoords="offset points")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=9)
    ax.grid(True, which="both", lw=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="CI: three grids per problem, assert the orders")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", type=Path, default=None, help="directory for the PNGs (none: no plots)")
    a = ap.parse_args(argv)
    ng = (lambda p: QUICK_GRIDS) if a.quick else (lambda p: GRIDS[p])
    reps = 1 if a.quick else a.repeats
    ok = True

    print("## A7 hammer, ideal supports, 5 m/s (three-parameter felt)\n")
    hr = hammer(ng("hammer"), reps)
    print("| cells | rate (MHz) | run time (ms) | g(t) error | contact (ms) | error | peak force (N) | error |")
    print("|---|---|---|---|---|---|---|---|")
    for r in hr:
        print(f"| {r['cells']} | {r['fs'] / 1e6:.3f} | {r['time_s'] * 1e3:.3f} | {r['g_err']:.2e} "
              f"| {r['duration_s'] * 1e3:.5f} | {r['duration_s_err']:.2e} | {r['peak_n']:.3f} "
              f"| {r['peak_n_err']:.2e} |")
    og = orders([r["g_err"] for r in hr[:-1]])
    op = orders([abs(r["peak_n"] - hr[-1]["peak_n"]) for r in hr[:-1]])
    print(f"\ng(t): the largest difference at the coarsest grid's instants from the finest grid, over "
          f"max |g|.  Richardson (order 2) from the two finest grids: contact "
          f"{hr[0]['duration_s_extrapolated'] * 1e3:.5f} ms (thesis: about 0.3 ms), peak "
          f"{hr[0]['peak_n_extrapolated']:.3f} N.  Observed orders against the finest grid: g(t) "
          f"{', '.join(f'{x:.2f}' for x in og)}; peak force {', '.join(f'{x:.2f}' for x in op)} (the "
          f"contact's end, read from the step-mean force crossing zero, is not smooth in dt).\n")
    if a.quick and not (np.all(og > 1.8) and np.all(op > 1.8)):
        print(f"FAIL: the hammer's orders {og}, {op} are under 1.8", file=sys.stderr)
        ok = False

    print("## The hammer's felt solver: its tolerance\n")
    tols = (1e-2, 1e-5, 1e-10) if a.quick else SOLVER_TOLS
    tr = hammer_tolerance(tols, (46,) if a.quick else (46, 184), reps)
    print("| cells | rate (MHz) | tolerance | strike run time (us) | g(t) error | peak force error "
          "| contact steps off |")
    print("|---|---|---|---|---|---|---|")
    for r in tr:
        print(f"| {r['cells']} | {r['fs'] / 1e6:.3f} | {r['tol']:.0e} | {r['time_s'] * 1e6:.1f} "
              f"| {r['g_err']:.2e} | {r['peak_err']:.2e} | {r['steps_diff']} |")
    print("\nThe A7 strike above (0.4 ms), its felt solver (Halley's iteration, "
          "synth.kernels.strings._hammer_general) stopped when a correction changes the felt's "
          "compression by less than the tolerance (relative); errors against 1e-10 on the same "
          "grid; run time per strike, median.  The shipped tolerance is 1e-5 "
          "(synth.dsp.bank.SOLVER_TOL).\n")
    if a.quick:
        d = {r["tol"]: r for r in tr}
        if not (d[1e-5]["g_err"] < 1e-9 and d[1e-2]["g_err"] >= d[1e-5]["g_err"]):
            print(f"FAIL: the solver's tolerance: g(t) error {d[1e-5]['g_err']:.1e} at 1e-5, "
                  f"{d[1e-2]['g_err']:.1e} at 1e-2", file=sys.stderr)
            ok = False

    curves_j = []
    print(f"## Jawari Cases 1-3: u(l, t) over the first {WAVE_S * 1e3:.0f} ms and t_np\n")
    for case in (1, 2, 3):
        rows, tnp, agree = jawari(case, ng("jawari"), reps)
        print(f"Case {case} (error against the finest grid's per-sample run; the two paths agree to "
              f"{agree:.1e} of the signal on every grid):\n")
        print("| cells | rate (kHz) | path | run time (ms) | u(l, t) error | t_np -40 dB (s) |")
        print("|---|---|---|---|---|---|")
        for r in rows:
            j = int(round(math.log2(r["cells"] / BASE["jawari"])))
            print(f"| {r['cells']} | {r['fs'] / 1e3:.1f} | {r['path']} | {r['time_s'] * 1e3:.1f} "
                  f"| {r['error']:.2e} | {tnp[j]:.3f} |")
        errs = [r["error"] for r in rows if r["path"] == "fast"][:-1]
        print(f"\nt_np: thesis {THESIS_TNP[case]:.2f} s.  Observed orders of the waveform error: "
              f"{', '.join(f'{x:.2f}' for x in orders(errs))}.\n")
        for path in ("fast", "per-sample"):
            rr = [r for r in rows if r["path"] == path][:-1]
            curves_j.append((f"Case {case}, {path}", [r["time_s"] for r in rr], [r["error"] for r in rr],
                             [f"{r['fs'] / 1e3:.0f}k" for r in rr]))
        if agree > 1e-12:
            print(f"FAIL: Case {case}: the paths differ by {agree:.2e}", file=sys.stderr)
            ok = False
        # the error never grows with the rate, and falls over the grids (203 and
        # 406 cells round the pluck point 3L/4 to the same l = 0.7488 L, and
        # the scheme at c dt = dx then gives the same wave on both)
        falls = all(e1 <= e0 * (1 + 1e-3) for e0, e1 in zip(errs, errs[1:])) and errs[-1] < 0.5 * errs[0]
        if a.quick and not falls:
            print(f"FAIL: Case {case}: the waveform error does not fall with the rate: {errs}",
                  file=sys.stderr)
            ok = False

    print("## Biwa sawari: contacts (per-sample path)\n")
    sr = sawari(ng("sawari"), reps)
    print("| cells | rate (kHz) | run time (ms) | first contact (ms) | contacts by 16.4 ms |")
    print("|---|---|---|---|---|")
    for r in sr:
        print(f"| {r['cells']} | {r['fs'] / 1e3:.1f} | {r['time_s'] * 1e3:.1f} | {r['first_ms']:.3f} | {r['contacts']} |")
    print("\nThesis: first contact after about 3 ms, 3 contacts by 16.4 ms.\n")

    print(f"## The termination region's length: u(l, t) over {WAVE_S * 1e3:.0f} ms, 812 cells\n")
    print("| case | region points | length (mm) | run time (ms) | error against 100 points |")
    print("|---|---|---|---|---|")
    curves_r = []
    for case in (1, 2):
        rr = region(case, (4, 15, 25) if a.quick else REGION_POINTS, reps)
        for r in rr:
            print(f"| {case} | {r['points']} | {r['length_mm']:.1f} | {r['time_s'] * 1e3:.2f} | {r['error']:.2e} |")
        curves_r.append((f"Case {case}", [r["time_s"] for r in rr], [max(r["error"], 1e-17) for r in rr],
                         [str(r["points"]) for r in rr]))
        if a.quick and not rr[-1]["error"] <= 1e-12:
            print(f"FAIL: Case {case}: 25 points are not the whole obstacle ({rr[-1]['error']:.2e})",
                  file=sys.stderr)
            ok = False
    print("\nCase 1's ramp ends at 15 mm (15 points); Case 2's parabola goes on, and the string reaches "
          "it only so far.\n")

    print("## The decimator, 325 kHz to 48 kHz: passband and stopband against cost\n")
    dd = decimator(DEC_DESIGNS[2:5] if a.quick else DEC_DESIGNS, reps)
    print("| passband edge (kHz) | design attenuation (dB) | passband ripple (dB) | rejection above "
          "24 kHz (dB) | taps per output | latency (ms) | ns per output sample |")
    print("|---|---|---|---|---|---|---|")
    for r in dd:
        print(f"| {r['passband'] / 1e3:g} | {r['atten']:g} | {r['ripple_db']:.1e} | {r['rejection_db']:.1f} "
              f"| {r['taps']} | {r['latency_ms']:.3f} | {r['ns']:.0f} |")
        if a.quick and r["rejection_db"] < r["atten"] - 6:
            print(f"FAIL: the {r['atten']:g} dB design rejects only {r['rejection_db']:.1f} dB",
                  file=sys.stderr)
            ok = False
    print("\n(20 kHz, 110 dB) is the engine's design.\n")

    print("## Grand notes against the internal rate: partials over the first second\n")
    gr = grand_notes((60,) if a.quick else GRAND_KEYS,
                     (325_000, 650_000) if a.quick else GRAND_RATES, reps)
    print("| key | internal rate (kHz) | partials compared | worst frequency difference (cents) "
          "| worst level difference (dB) | render time, 1.05 s (s) |")
    print("|---|---|---|---|---|---|")
    for r in gr:
        print(f"| {r['key']} | {r['fs'] / 1e3:g} | {r['partials']} | {r['cents']:.3f} | {r['db']:.2f} "
              f"| {r['time_s']:.2f} |")
    print(f"\nAgainst the same note at {gr[-1]['fs'] / 1e3:g} kHz: velocity 80, 0.05-1.05 s, partials "
          "1-16 under 10 kHz within 40 dB of the strongest.\n")

    print("## The grand's stiffness: dispersion sections against partial error\n")
    dr = dispersion(DISP_KEYS[::2] if a.quick else DISP_KEYS, (0.5, 2.0, 8.0) if a.quick else DISP_TOLS,
                    reps)
    print("| key | design tolerance (cents) | kind | cost units (biquad = 2) | worst error, partials "
          "1..K (cents) | K | run time, 0.5 s of one string (ms) |")
    print("|---|---|---|---|---|---|---|")
    for r in dr:
        tol = r["tol"] if r["tol"] == "none" else f"{r['tol']:g}"
        print(f"| {r['key']} | {tol} | {r['kind']} | {r['sections']} | {r['worst']:.2f} | {r['K']} "
              f"| {r['time_s'] * 1e3:.2f} |")
    print("\n'none': the loop with no dispersion filter (a harmonic string), its partials against the "
          "stiff-string law.  The preset designs to 2 cents (`strings.dispersion_sections` = 8 is the "
          "first-order fallback's limit).\n")
    for key in sorted({r["key"] for r in dr}):
        rr = [r for r in dr if r["key"] == key and r["tol"] != "none"]
        bad = [r for r in rr if r["kind"] == "sos" and r["worst"] > r["tol"] * 1.0001]
        if bad:
            print(f"FAIL: key {key}: a design misses its tolerance: {bad}", file=sys.stderr)
            ok = False

    if a.out is not None:
        a.out.mkdir(parents=True, exist_ok=True)
        plot(a.out / "wp-hammer.png", "A7 strike: g(t), contact duration and peak force",
             [("g(t), max error", [r["time_s"] for r in hr[:-1]], [r["g_err"] for r in hr[:-1]],
               ["" for _ in hr[:-1]]),
              ("contact duration", [r["time_s"] for r in hr[:-1]], [r["duration_s_err"] for r in hr[:-1]],
               [f"{r['fs'] / 1e6:.1f}M" for r in hr[:-1]]),
              ("peak force", [r["time_s"] for r in hr[:-1]], [r["peak_n_err"] for r in hr[:-1]],
               ["" for _ in hr[:-1]])])
        plot(a.out / "wp-jawari.png", f"Jawari Cases 1-3: u(l, t), first {WAVE_S * 1e3:.0f} ms", curves_j)
        curves_d = []
        for key in sorted({r["key"] for r in dr}):
            rr = [r for r in dr if r["key"] == key]
            curves_d.append((f"key {key}", [r["time_s"] for r in rr], [max(r["worst"], 1e-3) for r in rr],
                             [str(r["sections"]) for r in rr]))
        plot(a.out / "wp-region.png", "Jawari: region length (labels: points)", curves_r)
        d20 = [r for r in dd if r["passband"] == 20000.0]
        plot(a.out / "wp-decimator.png", "Decimator 325 -> 48 kHz, 20 kHz passband (labels: dB)",
             [("stopband leakage (gain above 24 kHz)", [r["ns"] * 1e-9 for r in d20],
               [10 ** (-r["rejection_db"] / 20) for r in d20], [f"{r['atten']:g}" for r in d20]),
              ("passband ripple (gain error)", [r["ns"] * 1e-9 for r in d20],
               [10 ** (r["ripple_db"] / 20) - 1 for r in d20], ["" for _ in d20])],
             xlabel="run time per output sample (s)")
        plot(a.out / "wp-dispersion.png", "Grand: worst partial error (cents) against cost",
             curves_d, ylabel="worst partial error, cents (labels: cost units)")
        print(f"plots: {a.out / 'wp-hammer.png'}, {a.out / 'wp-jawari.png'}, {a.out / 'wp-region.png'}, "
              f"{a.out / 'wp-decimator.png'}, {a.out / 'wp-dispersion.png'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
