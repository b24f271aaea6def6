"""The A7 hammer study (Publication I) with the felt-layer hammer model
against the lumped law: the strike, the mode levels with and without the
capo bar, the cost and the work-precision of the layer's grid (issue 14,
section 6; the tables of docs/felt.md, "The felt layer on the moving string").

    synth reproduce felt-study                 # everything (about 30 s on one core)
    synth reproduce felt-study --quick         # the checks only, on coarse settings (~10 s)
    synth reproduce felt-study --repeats 5     # cost: medians of 5 runs

Both models run through the study presets exactly as `synth note` runs
them: `paper/piano-a7-ideal` and `paper/piano-a7-capo` with
`--set hammer.model=felt-layer` (the layer: the preset's three-parameter
law as its quasi-static limit, felt 10.2 mm x 64 mm^2, 1000 kg/m^3,
tau0 1.8 us, 32 cells; synth.physics.felt.felt_from_law).

Definitions: contact duration, the end of the step-mean force Fm = dg/K
(interpolated to zero as ``synth reproduce`` does) from the strike's
sample 0; peak force, the largest step-mean force; contacts, runs of
samples with F > 0; g(t0), g after the last contact; mode levels,
Publication II eq. 17 from two snapshots (synth.analysis.free_mode_energies),
capo - ideal of the same hammer model; cost, wall time (perf_counter),
median of ``--repeats`` runs after a warm-up, lumped and layer
interleaved in the same run: the strike (the bank alone, from the note-on
to the hammer gone, 4 ms after its last contact) and one second of the
note through the engine.
"""

from __future__ import annotations

import time

import numpy as np

from synth.analysis import episode_times, free_mode_energies
from synth.apps.reproduce import a7_run  # the A7 strike (synth reproduce's)
from synth.dsp.bank import StringBank
from synth.engine.engine import Event
from synth.io.factory import build_engine
from synth.kernels import strings as K

L, T, MU = 0.061, 774.6, 0.0042
LAYER = ("hammer.model=\"felt-layer\"",)
MODELS = {"lumped": (), "felt-layer": LAYER}
TIMES_S = (0.30e-3, 3.86e-3, 6.21e-3)
N_MODES = 40


def strike_summary(ch, fs, K_per):
    """Contact duration (s), peak step-mean force (N), contacts, g after
    the last contact (m) of one strike's probe channels (sample i: t = i dt;
    ``K_per`` = c / 2T)."""
    g = ch[K.P_G]
    Fm = np.diff(g) / (K_per / fs)           # the mean force over each step (N)
    pos = np.flatnonzero(Fm > 1e-9 * np.max(Fm))
    e = int(pos[-1])
    t_end = (e + 0.5 + Fm[e] / (Fm[e - 1] - Fm[e])) / fs if Fm[e - 1] > Fm[e] else (e + 1) / fs
    hit = np.flatnonzero(ch[K.P_F] > 0)
    n_cont = 1 + int(np.sum(np.diff(hit) > 1))
    return t_end, float(Fm.max()), n_cont, float(g[hit[-1] + 1])


def strike_table(speeds=(5.0, 2.0)) -> dict:
    print("### The strike on the ideally supported string (`paper/piano-a7-ideal`)\n")
    print("| V (m/s) | model | contact (ms) | peak force (N) | contacts | g(t0) (mm) "
          "| max abs g difference over g(t0) |")
    print("|---|---|---|---|---|---|---|")
    out = {}
    for v in speeds:
        gs = {}
        for model, sets in MODELS.items():
            inst, su, ch, _ = a7_run("paper/piano-a7-ideal",
                                     sets + (f"hammer.speed_m_per_s={v}",), probe_s=0.0008)
            Kp = su.string.c_m_per_s / (2 * su.string.tension_n)
            tc, pk, nc, g0 = strike_summary(ch, inst.fs, Kp)
            gs[model] = ch[K.P_G]
            d = np.max(np.abs(gs[model] - gs["lumped"])) / abs(g0)
            out[(v, model)] = (tc, pk, nc, g0)
            print(f"| {v:g} | {model} | {tc * 1e3:.4f} | {pk:.1f} | {nc} | {g0 * 1e3:.3f} "
                  f"| {d:.3f} |")
        (tl, pl, _, gl), (tf, pf, _, gf) = out[(v, "lumped")], out[(v, "felt-layer")]
        print(f"| {v:g} | layer - lumped | {100 * (tf / tl - 1):+.1f} % | "
              f"{100 * (pf / pl - 1):+.1f} % | | {100 * (gf / gl - 1):+.2f} % | |")
    print()
    return out


def mode_tables() -> dict:
    """Mode levels: each model's capo - ideal (Publication I's comparison),
    and layer - lumped on each string."""
    print("### Mode levels, capo bar R = 15 mm against ideal supports (dB, capo - ideal of "
          "the same hammer model)\n")
    print("| model | coupling | t (ms) | contacts with the bar | mode 1 | mode 4 | modes 1-5 mean "
          "| largest gain, modes 6-40 (mode) | median, modes 6-40 but 21-25 |")
    print("|---|---|---|---|---|---|---|---|---|")
    modes = np.arange(1, N_MODES + 1)
    live = modes % 23 != 0
    hi = modes >= 6
    far = hi & ((modes < 21) | (modes > 25))
    E = {}
    for model, sets in MODELS.items():
        inst, su, _, snaps_i = a7_run("paper/piano-a7-ideal", sets, times_s=TIMES_S)
        E[(model, "ideal")] = [free_mode_energies(a, b, su.dt_s, L, MU, T, N_MODES)
                               for a, b in snaps_i]
        for cpl in ("injected", "direct"):
            _, _, chc, snaps = a7_run("paper/piano-a7-capo",
                                      sets + (f'hammer.capo_coupling="{cpl}"',), times_s=TIMES_S)
            st = episode_times(chc[K.P_CONTACT] > 0, inst.fs, int(0.02e-3 * inst.fs))
            E[(model, cpl)] = [free_mode_energies(a, b, su.dt_s, L, MU, T, N_MODES)
                               for a, b in snaps]
            for t, Ec, Ei in zip(TIMES_S, E[(model, cpl)], E[(model, "ideal")]):
                d = 10 * np.log10(Ec / Ei)
                j = int(np.argmax(np.where(live & hi, d, -np.inf)))
                print(f"| {model} | {cpl} | {t * 1e3:.2f} | {int(np.sum(st <= t))} | {d[0]:+.1f} "
                      f"| {d[3]:+.1f} | {np.mean(d[:5]):+.1f} | {d[j]:+.1f} ({j + 1}) "
                      f"| {np.median(d[far]):+.1f} |")
    print()
    print(f"### Mode levels, felt layer - lumped law on the same string at "
          f"{TIMES_S[-1] * 1e3:.2f} ms (dB)\n")
    print("| string | mode 1 | mode 2 | mode 3 | mode 4 | mode 5 | modes 1-5 mean | modes 6-20 "
          "mean | modes 24-40 mean | total energy |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for string in ("ideal", "injected", "direct"):
        El, Ef = E[("lumped", string)][-1], E[("felt-layer", string)][-1]
        d = 10 * np.log10(Ef / El)
        name = "ideal supports" if string == "ideal" else f"capo, {string}"
        print(f"| {name} | " + " | ".join(f"{x:+.2f}" for x in d[:5])
              + f" | {np.mean(d[:5]):+.2f} | {np.mean(d[5:20]):+.2f} | {np.mean(d[23:40]):+.2f} "
              f"| {10 * np.log10(Ef.sum() / El.sum()):+.2f} |")
    print()
    print(f"### The layer's grid: felt layer - lumped law on the ideal string at "
          f"{TIMES_S[-1] * 1e3:.2f} ms (dB)\n")
    print("| cells | mode 1 | mode 2 | mode 3 | mode 4 | mode 5 | modes 6-20 mean "
          "| modes 24-40 mean |")
    print("|---|---|---|---|---|---|---|---|")
    for c in (8, 16, 32, 64, 128):
        _, su, _, (snap,) = a7_run("paper/piano-a7-ideal", LAYER + (f"hammer.felt_cells={c}",),
                                   times_s=TIMES_S[-1:])
        d = 10 * np.log10(free_mode_energies(*snap, su.dt_s, L, MU, T, N_MODES)
                          / E[("lumped", "ideal")][-1])
        print(f"| {c} | " + " | ".join(f"{x:+.2f}" for x in d[:5])
              + f" | {np.mean(d[5:20]):+.2f} | {np.mean(d[23:40]):+.2f} |")
    print()
    print(f"### The felt's thickness: the layer against the lumped law on the ideal string "
          f"(5 m/s; mode levels at {TIMES_S[-1] * 1e3:.2f} ms, dB)\n")
    print("| felt (mm) | m_f / m | first step's force (N) | contact | g(t0) | modes 1-5 mean "
          "| modes 6-20 mean | modes 24-40 mean |")
    print("|---|---|---|---|---|---|---|---|")
    inst, su, ch_l, _ = a7_run("paper/piano-a7-ideal", (), probe_s=0.0008)
    Kp = su.string.c_m_per_s / (2 * su.string.tension_n)
    tl, _, _, gl = strike_summary(ch_l, inst.fs, Kp)
    for h in (0.0012, 0.003, 0.0102, 0.02):
        sets = LAYER + (f"hammer.felt_thickness_m={h}",)
        _, _, ch, (snap,) = a7_run("paper/piano-a7-ideal", sets, times_s=TIMES_S[-1:])
        tc, _, _, g0 = strike_summary(ch, inst.fs, Kp)
        d = 10 * np.log10(free_mode_energies(*snap, su.dt_s, L, MU, T, N_MODES)
                          / E[("lumped", "ideal")][-1])
        mf = 1000.0 * 64e-6 * h / 0.0018
        print(f"| {h * 1e3:.1f} | {mf:.3f} | {ch[K.P_F][1]:.1f} | {100 * (tc / tl - 1):+.1f} % "
              f"| {100 * (g0 / gl - 1):+.2f} % | {np.mean(d[:5]):+.2f} | {np.mean(d[5:20]):+.2f} "
              f"| {np.mean(d[23:40]):+.2f} |")
    print()
    return E


def _strike_bank(model_sets, cells=None, substeps=0):
    """A bank with the A7 string and the preset's hammer on it, ready to
    strike (the voice's own exciter and string setup)."""
    e = build_engine("paper/piano-a7-ideal", list(model_sets), probe=False)
    inst = e.inst
    su = inst.setup()
    ex = inst.exciter
    b = StringBank(1, su.cells + 2, 1, 4096, n_probes=1, max_gtable=ex.max_gtable())
    return b, su, ex, inst


def _one_strike(b, su, ex, cells=None, substeps=0, probe=False, n=None):
    """One strike from rest until the hammer is gone (or ``n`` steps);
    returns ((wall s, CPU s), string steps, sub-steps, probe or None)."""
    b.configure(0, cells=su.cells, k=su.k, dt_s=su.dt_s, U=None, probe_row=0 if probe else -1)
    b.activate(0)
    if ex.layer is not None:
        kw = ex.layer_kwargs(su, ex.spec.speed_m_per_s)
        if cells is not None:
            kw["cells"] = cells
        kw["substeps"] = substeps
        b.start_felt_layer(0, **kw)
    else:
        b.start_hammer(0, **ex.hammer_kwargs(su, ex.spec.speed_m_per_s))
    mix = np.zeros(4096)
    steps = 0
    t, tc = time.perf_counter(), time.process_time()
    if n is not None:
        b.render(mix[:n], 0, n)
        steps = n
    else:
        while b.excitation_running(0):
            b.render(mix, 0, 1024)
            steps += 1024
    el = (time.perf_counter() - t, time.process_time() - tc)
    sub = b.felt_layer_substeps(0) if ex.layer is not None else 0
    pr = b.probe[0, :, :steps].copy() if probe else None
    b.deactivate(0)
    return el, steps, sub, pr


def cost_table(repeats: int) -> dict:
    print("### Cost (one core; wall time, in brackets the process's CPU time, median of "
          f"{repeats} runs after a warm-up, lumped and layer interleaved)\n")
    banks = {m: _strike_bank(s) for m, s in MODELS.items()}
    engines = {m: build_engine("paper/piano-a7-ideal", list(s)) for m, s in MODELS.items()}
    for m in MODELS:                                    # warm-up (compiled code, pages)
        _one_strike(*banks[m][:3])
        engines[m].render([Event(0.0, "note_on", -1, 1.0)], duration_s=0.01)
    strike = {m: [] for m in MODELS}
    note = {m: [] for m in MODELS}
    info = {}
    for _ in range(repeats):
        for m in MODELS:
            el, steps, sub, _ = _one_strike(*banks[m][:3])
            strike[m].append(el)
            info[m] = (steps, sub)
            eng = build_engine("paper/piano-a7-ideal", list(MODELS[m]))
            t, tc = time.perf_counter(), time.process_time()
            eng.render([Event(0.0, "note_on", -1, 1.0)], duration_s=1.0)
            note[m].append((time.perf_counter() - t, time.process_time() - tc))
    print("| model | strike (ms) | string steps of the strike | sub-steps | per string step (ns) "
          "| per sub-step (ns) | per cell and sub-step (ns) | 1 s of the note (s) |")
    print("|---|---|---|---|---|---|---|---|")
    res = {}
    cells = banks["felt-layer"][2].spec.felt_cells
    for m in MODELS:
        # wall time (CPU time of this process in brackets: the machine is shared)
        ts, tsc = np.median(np.array(strike[m]), axis=0)
        tn, tnc = np.median(np.array(note[m]), axis=0)
        steps, sub = info[m]
        per = (f"{ts / sub * 1e9:.0f} ({tsc / sub * 1e9:.0f}) | {ts / sub / cells * 1e9:.1f} "
               f"({tsc / sub / cells * 1e9:.1f})") if sub else "- | -"
        print(f"| {m} | {ts * 1e3:.2f} ({tsc * 1e3:.2f}) | {steps} | {sub or '-'} "
              f"| {ts / steps * 1e9:.0f} ({tsc / steps * 1e9:.0f}) | {per} | {tn:.3f} ({tnc:.3f}) |")
        res[m] = (ts, tn, steps, sub)
    print(f"\nThe layer: {res['felt-layer'][0] / res['lumped'][0]:.0f} x the lumped law's strike, "
          f"{res['felt-layer'][1] / res['lumped'][1]:.2f} x its second of the note.  (The strike "
          f"runs until the hammer is gone, 4 ms after its last contact: "
          f"{res['lumped'][2]} string steps rendered in blocks of 1024.)\n")
    return res


def work_precision(cells_list=(8, 16, 32, 64, 128), ref_cells=256, repeats=3, n=620) -> dict:
    """The layer's grid: contact, peak force and g(t) against ``ref_cells``
    cells, run time per strike (the contact's first ``n`` steps)."""
    b, su, ex, inst = _strike_bank(LAYER)
    Kp = su.string.c_m_per_s / (2 * su.string.tension_n)
    _, _, _, pr = _one_strike(b, su, ex, cells=ref_cells, probe=True, n=n)
    tr, pr_, _, gr = strike_summary(pr, inst.fs, Kp)
    g_ref = pr[K.P_G]
    print(f"### Work-precision of the layer's grid (A7, 5 m/s, ideal supports; against "
          f"{ref_cells} cells: contact {tr * 1e3:.5f} ms, peak {pr_:.3f} N; run time of the "
          f"first {n} string steps, the contact, median of {repeats})\n")
    print("| cells | run time per strike (ms; CPU) | sub-steps | contact (ms) | error "
          "| peak force (N) | error | g(t) error |")
    print("|---|---|---|---|---|---|---|---|")
    rows = []
    for c in cells_list:
        els = []
        for _ in range(repeats):
            el, _, sub, p = _one_strike(b, su, ex, cells=c, probe=True, n=n)
            els.append(el)
        tc, pk, _, _ = strike_summary(p, inst.fs, Kp)
        eg = float(np.max(np.abs(p[K.P_G] - g_ref)) / np.max(np.abs(g_ref)))
        el, elc = np.median(np.array(els), axis=0)
        rows.append((c, el, sub, tc, abs(tc / tr - 1), pk, abs(pk / pr_ - 1), eg))
        print(f"| {c} | {el * 1e3:.2f} ({elc * 1e3:.2f}) | {sub} | {tc * 1e3:.5f} | {abs(tc / tr - 1):.1e} "
              f"| {pk:.3f} | {abs(pk / pr_ - 1):.1e} | {eg:.1e} |")
    eg = np.array([r[7] for r in rows])
    orders = np.log2(eg[:-1] / eg[1:])
    print(f"\nObserved order of g(t) per halving of dx: {', '.join(f'{o:.2f}' for o in orders)}.\n")
    return dict(rows=rows, orders=orders)


def quick_checks() -> int:
    """The checks on coarse settings: the layer's strike is shorter than the
    lumped law's and gives the string the same momentum within 1 %, its
    capo-bar contacts are counted, and g(t) converges with the felt's grid."""
    out = strike_table(speeds=(5.0,))
    (tl, pl, _, gl), (tf, pf, _, gf) = out[(5.0, "lumped")], out[(5.0, "felt-layer")]
    wp = work_precision(cells_list=(8, 16, 32), ref_cells=64, repeats=1, n=450)
    ok = (tf < tl and abs(gf / gl - 1) < 0.01 and np.all(wp["orders"] > 0.7))
    print("quick checks:", "passed" if ok else "FAILED")
    return 0 if ok else 1


def run(quick: bool = False, repeats: int = 3) -> int:
    """Print the tables (``quick``: the checks only, coarse; ``repeats``:
    runs per cost figure, their median); 1 if a quick check failed."""
    if quick:
        return quick_checks()
    strike_table()
    mode_tables()
    cost_table(repeats)
    work_precision(repeats=repeats)
    return 0

