"""Work-precision diagrams: error against run time, one curve per method (issue 13).

Usage
-----
    python tools/work_precision.py                      # every problem, tables and PNGs
    python tools/work_precision.py --out docs/img       # where the PNGs go ([plots] extra)
    python tools/work_precision.py --quick              # CI: a few grids, asserts the orders
    python tools/work_precision.py --only capo,sawari   # some problems (names: PROBLEMS)

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
  the contacts by 16.4 and 201.4 ms;
* **A7 hammer** (Publication I): the contact duration and the peak force of
  the study's three-parameter felt at 5 m/s on ideal supports (second order
  in dt: the error is measured against the Richardson extrapolation of the
  two finest grids);
* **the capo study** (Publication I section 4.1): the A7 strike against
  the capo bar, directly ("direct": the hammer feels the bar) and in
  Publication I's two stages ("injected"); the mode levels capo - ideal at
  3.86 and 6.21 ms and the contacts by then, from 96.6 kHz (14 cells) to
  20.7 MHz (2944 cells; multiples of 23 keep the strike at L/23), errors
  against the finest grid (the order is not known: no Richardson), and
  the bar's region length;
* **the decimator** (325 kHz to 48 kHz): passband ripple and stopband
  rejection of each design against its taps and run time;
* **the grand's stiffness**: the worst partial error (cents, partials up to
  40 or 10 kHz, against the stiff-string law) of a key's loop designed to a
  tolerance, against its dispersion sections and its run time.

Methods: the internal rate (cells = ``BASE`` x 2^j, one run per grid); the
kernel's fast path and its per-sample path (the reference scheme, forced
per string) at each rate.  Run times are medians of ``--repeats`` runs of
the bank alone (one core, ``NUMBA_NUM_THREADS=1`` recommended), the first
run (compilation) discarded; wall time, or the process's CPU time with
``--cpu-time`` (for a machine running other work).

Observed order between two grids: log2(e_j / e_{j+1}).  ``--quick`` runs
the four coarsest grids of each problem and asserts: the hammer's contact
g(t) and peak force converge at order >= 1.8; the two paths agree to
1e-12 of the signal; the jawari's u(l, t) error never grows with the rate
and falls by half or more over the grids; the capo study's mode energies
(46-368 cells) come closer to the finest grid's from 46 to 184 cells, both
strikes touch the bar 13 times by 3.86 ms and 21-22 by 6.21 ms on the
thesis's 184 cells, and 4 mm of bar is all the string touches there.

Each problem states its error against the thesis's number where the thesis
gives one; the last table gathers them ("Against the thesis").
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from synth.apps.work_precision import CAPO_MODES, capo_summary, note_partials, orders, partial_errors

ROOT = Path(__file__).resolve().parents[1]

#: the clock of the run times: wall time, or with ``--cpu-time`` the process's
#: CPU time (on a machine running other work, a short run's wall time can
#: grow tenfold while it waits for a core; its CPU time hardly moves)
CLOCK = time.perf_counter


def clock() -> float:
    return CLOCK()


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
    t0 = clock()
    done = 0
    while done < n:
        m = min(block, n - done)
        b.render(mix, done, m)
        done += m
    dt = clock() - t0
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
    """First contact and contacts by 16.4 and 201.4 ms (per-sample path:
    contact telemetry needs the probe; contacts 0.2 ms apart merged, as
    `synth reproduce` counts them), per grid."""
    from synth.analysis import episode_times

    rows = []
    for j in range(n_grids):
        cells = BASE["sawari"] * 2 ** j
        (u, cont, fs, _), t = timed(lambda: run_study("paper/biwa-sawari", cells, 0.2015, True,
                                                      contacts=True), repeats)
        st = episode_times(cont > 0, fs, int(0.2e-3 * fs))
        rows.append(dict(cells=cells, fs=fs, time_s=t, first_ms=float(st[0]) * 1e3 if len(st) else math.nan,
                         contacts=int(np.sum(st <= 16.4e-3)), contacts_201=int(np.sum(st <= 201.4e-3))))
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
            t0 = clock()
            b.render(mix, 0, n)
            return b.probe[0, :, :n].copy(), clock() - t0

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


#: the capo study (Publication I section 4.1): the A7 string and strike of
#: :func:`hammer` against the capo d'astro bar U = x^2 / (2R), R = 15 mm
CAPO_RADIUS_M = 0.015
#: the region of the study preset (paper/piano-a7-capo: 48 points of 184 cells, 15.9 mm)
CAPO_REGION_M = 48 * 0.061 / 184
#: the snapshot times (s) and the modes the thesis reports on
CAPO_TIMES = (3.86e-3, 6.21e-3)
#: grids: 14 cells (96.6 kHz; the strike on the first point, l = L/14), then
#: multiples of 23 (the strike exactly at l = L/23, as the study preset's
#: 184 cells: 1.295 MHz); the finest is the converged solution
CAPO_CELLS = (14, 23, 46, 92, 184, 368, 736, 1472, 2944)
CAPO_QUICK_CELLS = (46, 92, 184, 368)
#: region lengths (mm) of the capo region problem, on 184 cells
CAPO_REGION_MM = (1.0, 2.0, 4.0, 8.0, 12.0, 15.9, 20.0)
#: the thesis (Publication I section 4.1): mode 4 falls by about 6 dB, high
#: modes gain up to about 15 dB, 13 and 21 contacts with the bar by 3.86 and 6.21 ms
THESIS_CAPO = dict(mode4_db=-6.0, gain_db=15.0, contacts=(13, 21))


def _a7_string():
    L, T, MU = 0.061, 774.6, 0.0042
    C = math.sqrt(T / MU)
    A7 = dict(law=4, mass_kg=0.0018, stiffness=8387.4, exponent=4.975, alpha_or_gamma=0.0005312,
              tau0_s=0.0, tension_n=T, c_m_per_s=C)
    return L, T, MU, C, A7


def capo_run(cells: int, variant: str, *, per_sample: bool = True, region_m: float = CAPO_REGION_M,
             times=CAPO_TIMES):
    """The A7 strike (5 m/s) on ``cells`` cells: ``variant`` "ideal" (no
    bar), "direct" (the hammer strikes the string on the bar and feels it)
    or "injected" (Publication I's two stages: g(t) of the strike on ideal
    supports, injected into the string with the bar).  The bar's region
    covers ``region_m`` (m) in whole grid points.  ``per_sample``: the
    kernel's per-sample path with its probe (contacts counted); else the
    fast path (bridge-force output, no probe: chunks once the excitation
    has ended; the region contains the strike point, so none before).

    Returns the mode energies (J, modes 1..min(CAPO_MODES, cells - 1), from
    u at t and t + dt: :func:`synth.analysis.free_mode_energies`) and the
    contacts with the bar by each of ``times`` (runs less than 0.02 ms apart
    merged, as `synth reproduce` counts them; None on the fast path), the
    internal rate and the render's run time (s)."""
    from synth.analysis import episode_times, free_mode_energies
    from synth.dsp.bank import StringBank
    from synth.kernels import strings as K
    from synth.physics.profiles import capo

    L, T, MU, C, A7 = _a7_string()
    dt = L / (cells * C)
    dx = L / cells
    k = max(1, int(round(cells / 23)))            # l = L/23 (2.65 mm; the thesis: 2.6 mm)
    U = None
    if variant != "ideal":
        R = max(1, int(math.ceil(region_m / dx * (1.0 - 1e-12))))
        U = capo(CAPO_RADIUS_M)(dx * np.arange(1, R + 1))
    g = None
    if variant == "injected":
        b0 = StringBank(1, cells + 2, 1, 4096, n_probes=1)
        b0.configure(0, cells=cells, k=k, dt_s=dt, U=None, probe_row=0)
        b0.activate(0)
        b0.start_hammer(0, speed_m_per_s=5.0, **A7)
        n0 = int(2e-3 / dt)
        b0.render(np.zeros(n0), 0, n0)
        hit = np.flatnonzero(b0.probe[0, K.P_F, :n0] > 0)
        g = b0.probe[0, K.P_G, :int(hit[-1]) + 2].copy()
    b = StringBank(1, cells + 2, max(1, 0 if U is None else len(U)), 4096,
                   n_probes=1 if per_sample else 0, max_gtable=0 if g is None else len(g))
    b.configure(0, cells=cells, k=k, dt_s=dt, U=U, side=1, probe_row=0 if per_sample else -1,
                out_mode=0 if per_sample else 1, tension_over_dx=T / dx)
    b.activate(0)
    if g is None:
        b.start_hammer(0, speed_m_per_s=5.0, **A7)
    else:
        b.start_gtable(0, g)
    n_total = int(round(times[-1] / dt)) + 2
    if per_sample:
        b.ensure_probe_length(n_total + 2)
    mix = np.zeros(n_total + 2)
    nm = min(CAPO_MODES, cells - 1)
    done, E, run = 0, {}, 0.0
    for t in times:
        target = int(round(t / dt)) + 1             # sample i holds t = i dt
        t0 = clock()
        b.render(mix, done, target - done)
        run += clock() - t0
        u0 = b.displacement(0)
        t0 = clock()
        b.render(mix, target, 1)
        run += clock() - t0
        done = target + 1
        E[t] = free_mode_energies(u0, b.displacement(0), dt, L, MU, T, nm)
    contacts = None
    if per_sample and U is not None:
        st = episode_times(b.probe[0, K.P_CONTACT, :done] > 0, 1.0 / dt, int(0.02e-3 / dt))
        contacts = {t: int(np.sum(st <= t)) for t in times}
    return dict(cells=cells, k=k, fs=1.0 / dt, R=0 if U is None else len(U), E=E,
                contacts=contacts, time_s=run)


def _with_time(r):
    """(run, its run time): the shape :func:`timed` takes."""
    return r, r["time_s"]


def _capo_live(n):
    """Modes 1..n but the multiples of 23 (a node at the strike l = L/23)."""
    m = np.arange(1, n + 1)
    return m % 23 != 0


def capo_levels(run, ideal, t):
    """Mode levels capo - ideal (dB) at t, modes 1..n (NaN at the strike's nodes)."""
    Ec, Ei = run["E"][t], ideal["E"][t]
    n = min(len(Ec), len(Ei))
    with np.errstate(divide="ignore", invalid="ignore"):
        d = 10 * np.log10(Ec[:n] / Ei[:n])
    d[~_capo_live(n)] = np.nan
    return d


def capo_study(cells_list, repeats: int, variants=("direct", "injected")):
    """The capo study on each grid: both variants on both kernel paths (the
    per-sample path counts the contacts), the ideal string for the levels;
    errors against the finest grid.  Returns rows, one per (grid, variant,
    path), and the largest difference of the two paths' mode energies."""
    rows, agree = [], 0.0
    ref = {}
    runs = {}
    for cells in cells_list:
        ideal = capo_run(cells, "ideal", per_sample=False)
        for var in variants:
            for path in ("per-sample", "fast"):
                (r, _), tm = timed(lambda: _with_time(capo_run(cells, var,
                                                                per_sample=path == "per-sample")),
                                   repeats)
                r["time_s"] = tm
                runs[(cells, var, path)] = (r, ideal)
            a = runs[(cells, var, "per-sample")][0]["E"]
            f = runs[(cells, var, "fast")][0]["E"]
            for t in CAPO_TIMES:
                agree = max(agree, float(np.max(np.abs(a[t] - f[t]) / np.max(a[t]))))
    J = cells_list[-1]
    for var in variants:
        r, ideal = runs[(J, var, "per-sample")]
        ref[var] = {t: capo_levels(r, ideal, t) for t in CAPO_TIMES}
    for (cells, var, path), (r, ideal) in runs.items():
        row = dict(cells=cells, fs=r["fs"], k=r["k"], R=r["R"], variant=var, path=path,
                   time_s=r["time_s"], contacts=r["contacts"])
        for t in CAPO_TIMES:
            d = capo_levels(r, ideal, t)
            dr = ref[var][t][:len(d)]
            ok = np.isfinite(d) & np.isfinite(dr)
            E, Er = r["E"][t], runs[(J, var, "per-sample")][0]["E"][t][:len(r["E"][t])]
            row[t] = dict(capo_summary(d), levels=d,
                          err_E=float(np.sum(np.abs(E - Er)) / np.sum(Er)),
                          err_rms=float(np.sqrt(np.mean((d[ok] - dr[ok]) ** 2))),
                          err_max=float(np.max(np.abs(d[ok] - dr[ok]))),
                          err_mode4=abs(float(d[3]) - float(dr[3])) if len(d) > 3 else math.nan)
        rows.append(row)
    rows.sort(key=lambda r: (r["variant"], r["path"] != "per-sample", r["cells"]))
    return rows, agree


def capo_region(region_mm, repeats: int, cells: int = 184):
    """The capo study on ``cells`` cells with the bar's region cut to each
    length: the mode levels at 6.21 ms (direct strike, per-sample path)
    against the longest region, and the contacts."""
    t = CAPO_TIMES[-1]
    ideal = capo_run(cells, "ideal", per_sample=False)
    res = []
    for mm in region_mm:
        (r, _), tm = timed(lambda: _with_time(capo_run(cells, "direct", region_m=mm * 1e-3)),
                           repeats)
        res.append((mm, r, tm))
    dr = capo_levels(res[-1][1], ideal, t)
    rows = []
    for mm, r, tm in res:
        d = capo_levels(r, ideal, t)
        ok = np.isfinite(d) & np.isfinite(dr)
        rows.append(dict(mm=mm, R=r["R"], time_s=tm, contacts=r["contacts"][t],
                         mode4=float(d[3]), err_max=float(np.max(np.abs(d[ok] - dr[ok])))))
    return rows


def capo_section(a, reps: int, figs: list, thesis: list) -> bool:
    """The capo study's tables (``--only capo``); False if a quick check fails."""
    ok = True
    cells_list = CAPO_QUICK_CELLS if a.quick else CAPO_CELLS
    rows, agree = capo_study(cells_list, reps)
    t1, t2 = CAPO_TIMES
    J = cells_list[-1]
    print("## The capo study: mode levels (A7, capo bar R = 15 mm, 5 m/s)\n")
    print(f"Levels capo - ideal (dB) at {t2 * 1e3:.2f} ms; errors against the finest grid ({J} cells) "
          f"of the same strike; the two kernel paths agree to {agree:.1e} of the largest mode energy "
          f"on every grid.\n")
    print("| strike | cells | rate (MHz) | l / L | region points | run time, per-sample / fast (ms) "
          "| contacts by 3.86 / 6.21 ms | mode 1 | mode 4 | modes 1-5 | modes 6-40 but 21-25: median "
          "| largest (mode) | energy error, 3.86 / 6.21 ms | mode 4 error (dB) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    by = {(r["variant"], r["path"], r["cells"]): r for r in rows}
    for var in ("direct", "injected"):
        for c in cells_list:
            r, f = by[(var, "per-sample", c)], by[(var, "fast", c)]
            q = r[t2]
            ct = r["contacts"]
            print(f"| {var} | {c} | {r['fs'] / 1e6:.3f} | 1/{c / r['k']:.2f} | {r['R']} "
                  f"| {r['time_s'] * 1e3:.2f} / {f['time_s'] * 1e3:.2f} | {ct[t1]} / {ct[t2]} "
                  f"| {q['mode1']:+.1f} | {q['mode4']:+.1f} | {q['low']:+.1f} | {q['median']:+.1f} "
                  f"| {q['gain']:+.1f} ({q['gain_mode']}) | {r[t1]['err_E']:.3f} / {q['err_E']:.3f} "
                  f"| {q['err_mode4']:.2f} |")
    print()
    curves = []
    for var in ("direct", "injected"):
        dy = [by[(var, "per-sample", c)][t2]["err_E"] for c in cells_list[:-1]]
        dyadic = [c for c in cells_list[:-1] if c >= 46]
        o = orders([by[(var, "per-sample", c)][t2]["err_E"] for c in dyadic])
        print(f"{var}: observed orders of the energy error at {t2 * 1e3:.2f} ms ({', '.join(map(str, dyadic))} "
              f"cells): {', '.join(f'{x:.2f}' for x in o)}.")
        for path in ("per-sample", "fast"):
            rr = [by[(var, path, c)] for c in cells_list[:-1]]
            curves.append((f"{var}, {path}", [r["time_s"] for r in rr], [max(e, 1e-6) for e in dy],
                           [f"{r['fs'] / 1e6:.2g}M" if path == "per-sample" else "" for r in rr]))
    print("\nEnergy error: sum over modes 1..40 (fewer on grids of 40 cells or less) of |E_i - E_i,ref|"
          " over the reference's sum.  Richardson is not applied: no theory gives this problem's "
          "order (the contacts are events on the grid), only the observed orders above.  Run "
          "times: the renders alone, medians.\n")
    fin = {var: by[(var, "per-sample", J)] for var in ("direct", "injected")}
    th = {var: by[(var, "per-sample", 184)] for var in ("direct", "injected") if 184 in cells_list}
    print(f"Against the thesis (mode 4 about {THESIS_CAPO['mode4_db']:+.0f} dB, high modes up to about "
          f"+{THESIS_CAPO['gain_db']:.0f} dB, {THESIS_CAPO['contacts'][0]} and "
          f"{THESIS_CAPO['contacts'][1]} contacts by 3.86 and 6.21 ms):\n")
    print("| strike | grid | mode 4 (dB) | error | largest gain, modes 6-40 but 21-25 (dB) | error "
          "| contacts by 3.86 / 6.21 ms | error |")
    print("|---|---|---|---|---|---|---|---|")
    for var in ("direct", "injected"):
        for label, r in ((f"{J} cells (finest)", fin[var]),) + (((f"184 cells (the thesis's)",
                                                                   th[var]),) if th else ()):
            q = r[t2]
            c = r["contacts"]
            d4 = q["mode4"] - THESIS_CAPO["mode4_db"]
            dg = q["gain"] - THESIS_CAPO["gain_db"]
            print(f"| {var} | {label} | {q['mode4']:+.1f} | {d4:+.1f} | {q['gain']:+.1f} | {dg:+.1f} "
                  f"| {c[t1]} / {c[t2]} | {c[t1] - THESIS_CAPO['contacts'][0]:+d} / "
                  f"{c[t2] - THESIS_CAPO['contacts'][1]:+d} |")
            if label.endswith("(finest)"):
                thesis.append((f"capo study, {var} strike", "mode 4 at 6.21 ms, finest grid",
                               "about -6 dB", f"{q['mode4']:+.1f} dB", f"{d4:+.1f} dB"))
                thesis.append((f"capo study, {var} strike", "largest gain, modes 6-40 but 21-25",
                               "up to about +15 dB", f"{q['gain']:+.1f} dB (mode {q['gain_mode']})",
                               f"{dg:+.1f} dB"))
                thesis.append((f"capo study, {var} strike", "contacts by 3.86 / 6.21 ms", "13 / 21",
                               f"{c[t1]} / {c[t2]}", f"{c[t1] - 13:+d} / {c[t2] - 21:+d}"))
    print()
    figs.append(("wp-capo.png", f"Capo study: mode energies at {t2 * 1e3:.2f} ms (labels: rate)",
                 curves, dict(ylabel="energy error against the finest grid")))

    print(f"The bar's region on 184 cells (direct strike, levels at {t2 * 1e3:.2f} ms):\n")
    rg = capo_region((2.0, 4.0, CAPO_REGION_M * 1e3) if a.quick else CAPO_REGION_MM, reps)
    print("| region (mm) | points | run time (ms) | contacts by 6.21 ms | mode 4 (dB) "
          f"| largest level difference from {rg[-1]['mm']:.1f} mm (dB) |")
    print("|---|---|---|---|---|---|")
    for r in rg:
        print(f"| {r['mm']:.1f} | {r['R']} | {r['time_s'] * 1e3:.2f} | {r['contacts']} | {r['mode4']:+.2f} "
              f"| {r['err_max']:.2e} |")
    print()
    if a.quick:
        if agree > 1e-12:
            print(f"FAIL: capo: the paths differ by {agree:.2e}", file=sys.stderr)
            ok = False
        for var in ("direct", "injected"):
            e0 = by[(var, "per-sample", cells_list[0])][t2]["err_E"]
            e1 = by[(var, "per-sample", cells_list[-2])][t2]["err_E"]
            c = by[(var, "per-sample", 184)]["contacts"]
            if not e1 < e0:
                print(f"FAIL: capo, {var}: the energy error does not fall ({e0:.3f} -> {e1:.3f})",
                      file=sys.stderr)
                ok = False
            if not (c[t1] == 13 and c[t2] in (21, 22)):
                print(f"FAIL: capo, {var}: contacts on 184 cells {c}, not the thesis's 13 and 21-22",
                      file=sys.stderr)
                ok = False
        r4 = [r for r in rg if r["mm"] == 4.0][0]
        if not r4["err_max"] <= 1e-9:
            print(f"FAIL: capo: 4 mm of bar is not all the string touches ({r4['err_max']:.2e} dB)",
                  file=sys.stderr)
            ok = False
    return ok


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
                    t0 = clock()
                    b.render(mix, 0, n)
                    t += clock() - t0
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
            t0 = clock()
            while made < fs_out:
                n = min(128, fs_out - made)
                k = d.inputs_needed(n)
                d.process(x[pos:pos + k], out[:n])
                pos += k
                made += n
            return (clock() - t0,)

        (_,), tm = timed(run, repeats)
        rows.append(dict(passband=pb, atten=att, ripple_db=ripple, rejection_db=rejection,
                         taps=d.taps_per_phase, latency_ms=d.latency_s * 1e3, ns=tm / fs_out * 1e9))
    return rows


#: grand notes: keys and internal rates (the last is the reference)
GRAND_KEYS = (33, 60, 84)
GRAND_RATES = (162_500, 243_750, 325_000, 650_000, 1_300_000)


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
                t0 = clock()
                y = e.render([Event(0.0, "note_on", key, 80 / 127)], duration_s=1.05)
                return as_mono(y), e.fs_out, e.inst.tuning_hz(key), clock() - t0

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
                t0 = clock()
                done = 0
                while done < n:
                    m = min(4096, n - done)
                    b.render(mix, 0, m)
                    done += m
                return (clock() - t0,)

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


#: the problems, in the order they run (``--only``)
PROBLEMS = ("hammer", "tolerance", "jawari", "sawari", "region", "capo", "decimator", "grand",
            "dispersion")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="CI: three grids per problem, assert the orders")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", type=Path, default=None, help="directory for the PNGs (none: no plots)")
    ap.add_argument("--only", default=",".join(PROBLEMS),
                    help=f"comma-separated problems to run (default: all: {','.join(PROBLEMS)})")
    ap.add_argument("--cpu-time", action="store_true",
                    help="time the runs by the process's CPU time (time.process_time), not wall time")
    a = ap.parse_args(argv)
    global CLOCK
    CLOCK = time.process_time if a.cpu_time else time.perf_counter
    only = [x for x in a.only.split(",") if x]
    bad = [x for x in only if x not in PROBLEMS]
    if bad:
        raise SystemExit(f"--only: {', '.join(bad)} not among {', '.join(PROBLEMS)}")
    want = set(only).__contains__
    ng = (lambda p: QUICK_GRIDS) if a.quick else (lambda p: GRIDS[p])
    reps = 1 if a.quick else a.repeats
    ok = True
    figs = []             # (file name, title, curves, keyword arguments of plot)
    thesis = []           # (problem, quantity, thesis, model, error)

    if want("hammer"):
        print("## A7 hammer, ideal supports, 5 m/s (three-parameter felt)\n")
        hr = hammer(ng("hammer"), reps)
        print("| cells | rate (MHz) | run time (ms) | g(t) error | contact (ms) | error | peak force (N) "
              "| error |")
        print("|---|---|---|---|---|---|---|---|")
        for r in hr:
            print(f"| {r['cells']} | {r['fs'] / 1e6:.3f} | {r['time_s'] * 1e3:.3f} | {r['g_err']:.2e} "
                  f"| {r['duration_s'] * 1e3:.5f} | {r['duration_s_err']:.2e} | {r['peak_n']:.3f} "
                  f"| {r['peak_n_err']:.2e} |")
        og = orders([r["g_err"] for r in hr[:-1]])
        op = orders([abs(r["peak_n"] - hr[-1]["peak_n"]) for r in hr[:-1]])
        ext = hr[0]["duration_s_extrapolated"]
        print(f"\ng(t): the largest difference at the coarsest grid's instants from the finest grid, "
              f"over max |g|.  Richardson (order 2) from the two finest grids: contact "
              f"{ext * 1e3:.5f} ms (thesis: about 0.3 ms), peak "
              f"{hr[0]['peak_n_extrapolated']:.3f} N.  Observed orders against the finest grid: g(t) "
              f"{', '.join(f'{x:.2f}' for x in og)}; peak force {', '.join(f'{x:.2f}' for x in op)} "
              f"(the contact's end, read from the step-mean force crossing zero, is not smooth in dt)."
              f"  Against the thesis: the contact {(ext - 0.3e-3) * 1e6:+.2f} us "
              f"({(ext / 0.3e-3 - 1) * 100:+.2f} %) from its 0.3 ms; the peak force is a plot "
              f"there, no number.\n")
        thesis.append(("A7 hammer", "contact duration (Richardson)", "about 0.3 ms",
                       f"{ext * 1e3:.5f} ms", f"{(ext - 0.3e-3) * 1e6:+.2f} us"))
        if a.quick and not (np.all(og > 1.8) and np.all(op > 1.8)):
            print(f"FAIL: the hammer's orders {og}, {op} are under 1.8", file=sys.stderr)
            ok = False
        figs.append(("wp-hammer.png", "A7 strike: g(t), contact duration and peak force",
                     [("g(t), max error", [r["time_s"] for r in hr[:-1]], [r["g_err"] for r in hr[:-1]],
                       ["" for _ in hr[:-1]]),
                      ("contact duration", [r["time_s"] for r in hr[:-1]],
                       [r["duration_s_err"] for r in hr[:-1]], [f"{r['fs'] / 1e6:.1f}M" for r in hr[:-1]]),
                      ("peak force", [r["time_s"] for r in hr[:-1]], [r["peak_n_err"] for r in hr[:-1]],
                       ["" for _ in hr[:-1]])], {}))

    if want("tolerance"):
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
              "(synth.dsp.bank.SOLVER_TOL).  (A numerical setting: the thesis gives no number.)\n")
        if a.quick:
            d = {r["tol"]: r for r in tr}
            if not (d[1e-5]["g_err"] < 1e-9 and d[1e-2]["g_err"] >= d[1e-5]["g_err"]):
                print(f"FAIL: the solver's tolerance: g(t) error {d[1e-5]['g_err']:.1e} at 1e-5, "
                      f"{d[1e-2]['g_err']:.1e} at 1e-2", file=sys.stderr)
                ok = False

    if want("jawari"):
        curves_j = []
        print(f"## Jawari Cases 1-3: u(l, t) over the first {WAVE_S * 1e3:.0f} ms and t_np\n")
        for case in (1, 2, 3):
            rows, tnp, agree = jawari(case, ng("jawari"), reps)
            print(f"Case {case} (error against the finest grid's per-sample run; the two paths agree "
                  f"to {agree:.1e} of the signal on every grid):\n")
            print("| cells | rate (kHz) | path | run time (ms) | u(l, t) error | t_np -40 dB (s) |")
            print("|---|---|---|---|---|---|")
            for r in rows:
                j = int(round(math.log2(r["cells"] / BASE["jawari"])))
                print(f"| {r['cells']} | {r['fs'] / 1e3:.1f} | {r['path']} | {r['time_s'] * 1e3:.1f} "
                      f"| {r['error']:.2e} | {tnp[j]:.3f} |")
            errs = [r["error"] for r in rows if r["path"] == "fast"][:-1]
            d_th = tnp[-1] - THESIS_TNP[case]
            print(f"\nt_np: thesis {THESIS_TNP[case]:.2f} s; the finest grid {d_th:+.3f} s from it "
                  f"({d_th / THESIS_TNP[case] * 100:+.0f} %).  Observed orders of the waveform error: "
                  f"{', '.join(f'{x:.2f}' for x in orders(errs))}.\n")
            thesis.append((f"jawari Case {case}", "t_np (-40 dB), finest grid",
                           f"{THESIS_TNP[case]:.2f} s", f"{tnp[-1]:.3f} s", f"{d_th:+.3f} s"))
            for path in ("fast", "per-sample"):
                rr = [r for r in rows if r["path"] == path][:-1]
                curves_j.append((f"Case {case}, {path}", [r["time_s"] for r in rr],
                                 [r["error"] for r in rr], [f"{r['fs'] / 1e3:.0f}k" for r in rr]))
            if agree > 1e-12:
                print(f"FAIL: Case {case}: the paths differ by {agree:.2e}", file=sys.stderr)
                ok = False
            # the error never grows with the rate, and falls over the grids (203 and
            # 406 cells round the pluck point 3L/4 to the same l = 0.7488 L, and
            # the scheme at c dt = dx then gives the same wave on both)
            falls = (all(e1 <= e0 * (1 + 1e-3) for e0, e1 in zip(errs, errs[1:]))
                     and errs[-1] < 0.5 * errs[0])
            if a.quick and not falls:
                print(f"FAIL: Case {case}: the waveform error does not fall with the rate: {errs}",
                      file=sys.stderr)
                ok = False
        figs.append(("wp-jawari.png", f"Jawari Cases 1-3: u(l, t), first {WAVE_S * 1e3:.0f} ms",
                     curves_j, {}))

    if want("sawari"):
        print("## Biwa sawari: contacts (per-sample path)\n")
        sr = sawari(ng("sawari"), reps)
        print("| cells | rate (kHz) | run time, 201.5 ms (ms) | first contact (ms) | contacts by 16.4 ms "
              "| contacts by 201.4 ms |")
        print("|---|---|---|---|---|---|")
        for r in sr:
            print(f"| {r['cells']} | {r['fs'] / 1e3:.1f} | {r['time_s'] * 1e3:.1f} | {r['first_ms']:.3f} "
                  f"| {r['contacts']} | {r['contacts_201']} |")
        f = sr[-1]
        print(f"\nThesis: first contact after about 3 ms, 3 contacts by 16.4 ms, about 40 by 201.4 ms; "
              f"the finest grid: {f['first_ms'] - 3.0:+.3f} ms, {f['contacts'] - 3:+d} and "
              f"{f['contacts_201'] - 40:+d} from them.\n")
        thesis += [("biwa sawari", "first contact, finest grid", "after about 3 ms",
                    f"{f['first_ms']:.3f} ms", f"{f['first_ms'] - 3.0:+.3f} ms"),
                   ("biwa sawari", "contacts by 16.4 ms", "3", str(f["contacts"]),
                    f"{f['contacts'] - 3:+d}"),
                   ("biwa sawari", "contacts by 201.4 ms", "about 40", str(f["contacts_201"]),
                    f"{f['contacts_201'] - 40:+d}")]

    if want("region"):
        print(f"## The termination region's length: u(l, t) over {WAVE_S * 1e3:.0f} ms, 812 cells\n")
        print("| case | region points | length (mm) | run time (ms) | error against 100 points |")
        print("|---|---|---|---|---|")
        curves_r = []
        for case in (1, 2):
            rr = region(case, (4, 15, 25) if a.quick else REGION_POINTS, reps)
            for r in rr:
                print(f"| {case} | {r['points']} | {r['length_mm']:.1f} | {r['time_s'] * 1e3:.2f} "
                      f"| {r['error']:.2e} |")
            curves_r.append((f"Case {case}", [r["time_s"] for r in rr],
                             [max(r["error"], 1e-17) for r in rr], [str(r["points"]) for r in rr]))
            if a.quick and not rr[-1]["error"] <= 1e-12:
                print(f"FAIL: Case {case}: 25 points are not the whole obstacle ({rr[-1]['error']:.2e})",
                      file=sys.stderr)
                ok = False
        print("\nCase 1's ramp ends at 15 mm (15 points); Case 2's parabola goes on, and the string "
              "reaches it only so far.  (The thesis's region is 25 points, about 25 mm: no error to "
              "state.)\n")
        figs.append(("wp-region.png", "Jawari: region length (labels: points)", curves_r, {}))

    if want("capo"):
        ok &= capo_section(a, reps, figs, thesis)

    if want("decimator"):
        print("## The decimator, 325 kHz to 48 kHz: passband and stopband against cost\n")
        dd = decimator(DEC_DESIGNS[2:5] if a.quick else DEC_DESIGNS, reps)
        print("| passband edge (kHz) | design attenuation (dB) | passband ripple (dB) | rejection above "
              "24 kHz (dB) | taps per output | latency (ms) | ns per output sample |")
        print("|---|---|---|---|---|---|---|")
        for r in dd:
            print(f"| {r['passband'] / 1e3:g} | {r['atten']:g} | {r['ripple_db']:.1e} "
                  f"| {r['rejection_db']:.1f} | {r['taps']} | {r['latency_ms']:.3f} | {r['ns']:.0f} |")
            if a.quick and r["rejection_db"] < r["atten"] - 6:
                print(f"FAIL: the {r['atten']:g} dB design rejects only {r['rejection_db']:.1f} dB",
                      file=sys.stderr)
                ok = False
        print("\n(20 kHz, 110 dB) is the engine's design.  (Not in the thesis.)\n")
        d20 = [r for r in dd if r["passband"] == 20000.0]
        figs.append(("wp-decimator.png", "Decimator 325 -> 48 kHz, 20 kHz passband (labels: dB)",
                     [("stopband leakage (gain above 24 kHz)", [r["ns"] * 1e-9 for r in d20],
                       [10 ** (-r["rejection_db"] / 20) for r in d20], [f"{r['atten']:g}" for r in d20]),
                      ("passband ripple (gain error)", [r["ns"] * 1e-9 for r in d20],
                       [10 ** (r["ripple_db"] / 20) - 1 for r in d20], ["" for _ in d20])],
                     dict(xlabel="run time per output sample (s)")))

    if want("grand"):
        print("## Grand notes against the internal rate: partials over the first second\n")
        gr = grand_notes((60,) if a.quick else GRAND_KEYS,
                         (325_000, 650_000) if a.quick else GRAND_RATES, reps)
        print("| key | internal rate (kHz) | partials compared | worst frequency difference (cents) "
              "| worst level difference (dB) | render time, 1.05 s (s) |")
        print("|---|---|---|---|---|---|")
        for r in gr:
            print(f"| {r['key']} | {r['fs'] / 1e3:g} | {r['partials']} | {r['cents']:.3f} "
                  f"| {r['db']:.2f} | {r['time_s']:.2f} |")
        print(f"\nAgainst the same note at {gr[-1]['fs'] / 1e3:g} kHz: velocity 80, 0.05-1.05 s, "
              "partials 1-16 under 10 kHz within 40 dB of the strongest.  (The thesis has no grand "
              "notes.)\n")

    if want("dispersion"):
        print("## The grand's stiffness: dispersion sections against partial error\n")
        dr = dispersion(DISP_KEYS[::2] if a.quick else DISP_KEYS,
                        (0.5, 2.0, 8.0) if a.quick else DISP_TOLS, reps)
        print("| key | design tolerance (cents) | kind | cost units (biquad = 2) | worst error, partials "
              "1..K (cents) | K | run time, 0.5 s of one string (ms) |")
        print("|---|---|---|---|---|---|---|")
        for r in dr:
            tol = r["tol"] if r["tol"] == "none" else f"{r['tol']:g}"
            print(f"| {r['key']} | {tol} | {r['kind']} | {r['sections']} | {r['worst']:.2f} | {r['K']} "
                  f"| {r['time_s'] * 1e3:.2f} |")
        print("\n'none': the loop with no dispersion filter (a harmonic string), its partials against "
              "the stiff-string law.  The preset designs to 2 cents (`strings.dispersion_sections` = 8 "
              "is the first-order fallback's limit).  (Not in the thesis.)\n")
        for key in sorted({r["key"] for r in dr}):
            rr = [r for r in dr if r["key"] == key and r["tol"] != "none"]
            bad = [r for r in rr if r["kind"] == "sos" and r["worst"] > r["tol"] * 1.0001]
            if bad:
                print(f"FAIL: key {key}: a design misses its tolerance: {bad}", file=sys.stderr)
                ok = False
        curves_d = []
        for key in sorted({r["key"] for r in dr}):
            rr = [r for r in dr if r["key"] == key]
            curves_d.append((f"key {key}", [r["time_s"] for r in rr], [max(r["worst"], 1e-3) for r in rr],
                             [str(r["sections"]) for r in rr]))
        figs.append(("wp-dispersion.png", "Grand: worst partial error (cents) against cost", curves_d,
                     dict(ylabel="worst partial error, cents (labels: cost units)")))

    if thesis:
        print("## Against the thesis\n")
        print("| problem | quantity | thesis | model | error |")
        print("|---|---|---|---|---|")
        for row in thesis:
            print("| " + " | ".join(row) + " |")
        print()

    if a.out is not None and figs:
        a.out.mkdir(parents=True, exist_ok=True)
        for name, title, curves, kw in figs:
            plot(a.out / name, title, curves, **kw)
        print("plots: " + ", ".join(str(a.out / f[0]) for f in figs))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
