"""The felt layer against the lumped law: a sweep over the grand's keys (issue 14 sec. 6).

Usage
-----
    python tools/felt_hammer.py                         # tables (markdown) on stdout
    python tools/felt_hammer.py --json out.json         # and the data
    python tools/felt_hammer.py --png docs/img          # felt-hammer.png, felt-hammer-wp.png ([plots])
    python tools/felt_hammer.py --quick                 # fewer keys, grids and repeats

For each key x speed, a grand hammer on a rigid string three ways
(:mod:`synth.physics.felt`): the lumped law as the voice uses it (eq. 1.5,
``kv``), its parent four-parameter law (Publication III eq. 3, ``sls``: the
layer's quasi-static limit) and the felt solved as a layer (``layer``, 32
cells): contact time, peak force, their relative differences, and the cost
of one strike (median wall time of ``--repeats`` runs, one core).

Then where they agree: key 60 with thinner felts (the felt's mass over the
hammer's -> 0, the layer -> the sls law), and the work-precision data of the
layer solver (cells 8 .. 256 against 1024: error of the contact time and of
the peak force against the run time; observed order log2(e_j / e_(j+1))).
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from synth.physics import felt as F  # noqa: E402

KEYS = (21, 40, 60, 80, 100, 108)
SPEEDS = (0.5, 2.0, 5.0)
CELLS = 32
WP_CASES = ((21, 5.0), (60, 2.0), (108, 0.5))
WP_CELLS = (8, 16, 32, 64, 128, 256)
WP_REF = 1024
THIN_MM = (0.5, 1.0, 2.0, 4.0, 8.0)


def _timed(fn, repeats):
    ts, r = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        r = fn()
        ts.append(time.perf_counter() - t0)
    return r, statistics.median(ts)


def sweep(keys, speeds, repeats):
    rows = []
    for k in keys:
        hf = F.felt_for_key(k)
        for v in speeds:
            kv, t_kv = _timed(lambda: F.strike_lumped(hf, v), repeats)
            sls, t_sls = _timed(lambda: F.strike_lumped(hf, v, law="sls"), repeats)
            lay, t_lay = _timed(lambda: F.strike_layer(hf, v, cells=CELLS), repeats)
            rows.append(dict(
                key=k, v=v, h_mm=hf.thickness_m * 1e3, mf_over_m=hf.felt_mass_kg / hf.hammer_mass_kg,
                tc_kv_ms=kv.contact_time_s * 1e3, tc_sls_ms=sls.contact_time_s * 1e3,
                tc_layer_ms=lay.contact_time_s * 1e3, F_kv=kv.peak_force_n, F_sls=sls.peak_force_n,
                F_layer=lay.peak_force_n, F_touch=F.first_touch_force_n(hf, v),
                F_touch_grid=lay.touch_force_n,
                d_tc=lay.contact_time_s / kv.contact_time_s - 1,
                d_F=lay.peak_force_n / kv.peak_force_n - 1,
                d_tc_sls=lay.contact_time_s / sls.contact_time_s - 1,
                d_F_sls=lay.peak_force_n / sls.peak_force_n - 1,
                d_tc_sls_kv=sls.contact_time_s / kv.contact_time_s - 1,
                d_F_sls_kv=sls.peak_force_n / kv.peak_force_n - 1,
                wall_kv_ms=t_kv * 1e3, wall_sls_ms=t_sls * 1e3, wall_layer_ms=t_lay * 1e3,
                steps_kv=kv.steps, steps_layer=lay.steps))
            print(f"  key {k} v {v}: done", file=sys.stderr)
    return rows


def thin(speeds=(0.5, 2.0)):
    rows = []
    for v in speeds:
        for h in THIN_MM + (None,):
            hf = F.felt_for_key(60, thickness_m=None if h is None else h * 1e-3)
            if F._contact_estimate_s(hf, v)[1] > 0.5 * hf.thickness_m:
                continue                        # thinner than the strike compresses it
            sls = F.strike_lumped(hf, v, law="sls")
            kv = F.strike_lumped(hf, v)
            lay = F.strike_layer(hf, v, cells=CELLS)
            rows.append(dict(v=v, h_mm=hf.thickness_m * 1e3,
                             mf_over_m=hf.felt_mass_kg / hf.hammer_mass_kg,
                             d_tc_sls=lay.contact_time_s / sls.contact_time_s - 1,
                             d_F_sls=lay.peak_force_n / sls.peak_force_n - 1,
                             d_tc_kv=lay.contact_time_s / kv.contact_time_s - 1,
                             d_F_kv=lay.peak_force_n / kv.peak_force_n - 1))
    return rows


def work_precision(cases, cells, ref_cells, repeats):
    out = []
    for k, v in cases:
        hf = F.felt_for_key(k)
        ref = F.strike_layer(hf, v, cells=ref_cells)
        pts = []
        for n in cells:
            r, t = _timed(lambda: F.strike_layer(hf, v, cells=n), repeats)
            pts.append(dict(cells=n, wall_s=t,
                            e_tc=abs(r.contact_time_s / ref.contact_time_s - 1),
                            e_F=abs(r.peak_force_n / ref.peak_force_n - 1)))
        for a, b in zip(pts[:-1], pts[1:]):
            b["order_tc"] = math.log2(a["e_tc"] / b["e_tc"]) if b["e_tc"] > 0 else None
            b["order_F"] = math.log2(a["e_F"] / b["e_F"]) if b["e_F"] > 0 else None
        out.append(dict(key=k, v=v, ref_cells=ref_cells, tc_ref_ms=ref.contact_time_s * 1e3,
                        F_ref=ref.peak_force_n, points=pts))
        print(f"  work-precision key {k} v {v}: done", file=sys.stderr)
    return out


def markdown(rows, thin_rows, wp):
    L = ["| key | h mm | m_f/m | v m/s | contact kv ms | sls ms | layer ms | layer vs kv | "
         "peak kv N | sls N | layer N | layer vs kv | layer vs sls (tc, F) | first touch N "
         "(shock, grid) | cost kv / layer ms |", "|" + "---|" * 15]
    for r in rows:
        L.append(f"| {r['key']} | {r['h_mm']:.1f} | {r['mf_over_m']:.2f} | {r['v']:g} | "
                 f"{r['tc_kv_ms']:.3f} | {r['tc_sls_ms']:.3f} | {r['tc_layer_ms']:.3f} | "
                 f"{r['d_tc']:+.1%} | {r['F_kv']:.3g} | {r['F_sls']:.3g} | {r['F_layer']:.3g} | "
                 f"{r['d_F']:+.1%} | {r['d_tc_sls']:+.1%}, {r['d_F_sls']:+.1%} | "
                 f"{r['F_touch']:.3g}, {r['F_touch_grid']:.3g} | {r['wall_kv_ms']:.1f} / "
                 f"{r['wall_layer_ms']:.0f} |")
    L += ["", "| v m/s | h mm | m_f/m | layer vs sls: contact | peak | layer vs kv: contact | peak |",
          "|" + "---|" * 7]
    for r in thin_rows:
        L.append(f"| {r['v']:g} | {r['h_mm']:.2f} | {r['mf_over_m']:.3f} | {r['d_tc_sls']:+.2%} | "
                 f"{r['d_F_sls']:+.2%} | {r['d_tc_kv']:+.2%} | {r['d_F_kv']:+.2%} |")
    for c in wp:
        L += ["", f"key {c['key']}, {c['v']:g} m/s (reference: {c['ref_cells']} cells, contact "
              f"{c['tc_ref_ms']:.4f} ms, peak {c['F_ref']:.4g} N)", "",
              "| cells | wall ms | error contact | order | error peak | order |", "|" + "---|" * 6]
        for p in c["points"]:
            o1 = p.get("order_tc")
            o2 = p.get("order_F")
            L.append(f"| {p['cells']} | {p['wall_s'] * 1e3:.0f} | {p['e_tc']:.2e} | "
                     f"{'' if o1 is None else f'{o1:.2f}'} | {p['e_F']:.2e} | "
                     f"{'' if o2 is None else f'{o2:.2f}'} |")
    return "\n".join(L)


def plots(outdir, wp):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    outdir = Path(outdir)
    fig, ax = plt.subplots(1, 2, figsize=(9, 3.6))
    for a, k in zip(ax, (21, 108)):
        hf = F.felt_for_key(k)
        for j, v in enumerate((0.5, 2.0, 5.0)):
            for r, ls in ((F.strike_lumped(hf, v), "-"), (F.strike_layer(hf, v, cells=CELLS), "--")):
                n = max(1, len(r.time_s) // 600)
                a.plot(r.compression_m[::n] * 1e3, r.force_n[::n], ls, color=f"C{j}", lw=1,
                       label=f"{v:g} m/s {'eq. 1.5' if ls == '-' else 'layer'}")
        a.set_title(f"key {k} (felt {hf.thickness_m * 1e3:.0f} mm)", fontsize=9)
        a.set_xlabel("compression (mm)")
        a.set_ylabel("force (N)")
        a.set_yscale("log")
        a.set_ylim(0.05, None)
        a.grid(alpha=0.3)
    ax[0].legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(outdir / "felt-hammer.png", dpi=64)
    plt.close(fig)
    fig, ax = plt.subplots(1, 2, figsize=(9, 3.4))
    for j, c in enumerate(wp):
        t = [p["wall_s"] for p in c["points"]]
        ax[0].loglog(t, [p["e_tc"] for p in c["points"]], "o-", color=f"C{j}", ms=3,
                     label=f"key {c['key']}, {c['v']:g} m/s")
        ax[1].loglog(t, [p["e_F"] for p in c["points"]], "o-", color=f"C{j}", ms=3)
    ax[0].set_ylabel("contact time: relative error")
    ax[1].set_ylabel("peak force: relative error")
    for a in ax:
        a.set_xlabel("run time per strike (s)")
        a.grid(alpha=0.3, which="both")
    ax[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(outdir / "felt-hammer-wp.png", dpi=64)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--json", metavar="OUT.json", help="also write the data")
    ap.add_argument("--png", metavar="DIR", help="write felt-hammer.png and felt-hammer-wp.png")
    ap.add_argument("--repeats", type=int, default=3, help="runs per timing (median; default 3)")
    ap.add_argument("--quick", action="store_true", help="keys 21, 60, 108; grids to 64 against 256")
    a = ap.parse_args(argv)
    keys, cells, ref, rep = KEYS, WP_CELLS, WP_REF, a.repeats
    if a.quick:
        keys, cells, ref, rep = (21, 60, 108), WP_CELLS[:4], 256, 1
    rows = sweep(keys, SPEEDS, rep)
    thin_rows = thin()
    wp = work_precision(WP_CASES, cells, ref, rep)
    print(markdown(rows, thin_rows, wp))
    if a.json:
        Path(a.json).write_text(json.dumps(dict(sweep=rows, thin=thin_rows, work_precision=wp),
                                           indent=1))
    if a.png:
        plots(a.png, wp)
    return 0


if __name__ == "__main__":
    sys.exit(main())
