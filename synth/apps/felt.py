"""``synth felt``: the felt wave lab (issue 14; thesis chapter 2).

Tables (and PNG plots, the ``[plots]`` extra) of the felt's linear waves
(:mod:`synth.physics.felt`):

* ``dispersion``: for real wavenumbers k (the initial value problem), the
  propagating wave's frequency omega and decay rate mu (eq. 2.16);
* ``velocities``: its phase and group velocities, where the group velocity
  turns negative, and the normal-dispersion limit k_*;
* ``attenuation``: for a harmonic load of real frequency omega on the felt's
  surface (the boundary value problem), its wavenumber, attenuation per
  unit length and velocities (Publication III eqs. 31-43);
* ``pulse``: a pulse solved by finite differences (:func:`synth.physics.felt.
  solve_pulse`): driven into the felt's surface (eq. 2.28) or released
  from a sech profile (eq. 2.29), linear or nonlinear (p > 1), its leading
  crest's position and amplitude at each snapshot and its attenuation rate.

Values are in the units of eq. 2.11 (time alpha0 = tau0 / delta, length
l0 = c_s alpha0, velocity c_s) and, for a felt given in SI (``--felt``),
also in SI.  The felt is the thesis's (eqs. 2.12-2.13), Publication III's,
or one set by hand; ``--delta`` alone studies the dimensionless model.
"""

from __future__ import annotations

import io
import math
from dataclasses import dataclass

import numpy as np

from ..io.errors import SynthError
from ..physics import felt as F

#: named felts of ``--felt``
FELTS = {"thesis": F.THESIS_FELT, "pub3": F.PUB3_FELT}


@dataclass(frozen=True)
class FeltRequest:
    """What ``synth felt`` was asked.

    what : str                  ``dispersion``, ``velocities`` or ``attenuation``
    felt : Felt or None         the felt (SI columns too), or None (``delta`` alone)
    delta : float               relaxation parameter 1 - gamma
    x_max : float               largest k (IVP) or omega (BVP), units of eq. 2.11
    points : int                rows
    """

    what: str
    felt: F.Felt | None
    delta: float
    x_max: float
    points: int


def make_request(what: str, felt: str | None, delta: float | None, gamma: float | None,
                 tau0_s: float | None, x_max: float, points: int) -> FeltRequest:
    """Validate the command line's choices into a :class:`FeltRequest`."""
    if what not in ("dispersion", "velocities", "attenuation"):
        raise SynthError(f"what = {what!r} is not allowed (choose dispersion, velocities, "
                         f"attenuation)")
    if not (0.0 < x_max <= 1e4) or not math.isfinite(x_max):
        raise SynthError(f"--max = {x_max!r} is out of range (0 < value <= 10000)")
    if not (2 <= points <= 100_000):
        raise SynthError(f"--points = {points!r} is out of range (2 <= value <= 100000)")
    f = None
    if felt is not None:
        if felt not in FELTS:
            raise SynthError(f"--felt = {felt!r} is not allowed (choose {', '.join(FELTS)})")
        f = FELTS[felt]
    if gamma is not None or tau0_s is not None:
        if delta is not None:
            raise SynthError("--delta and --gamma/--tau0 are exclusive: give one")
        base = f or F.THESIS_FELT
        try:
            f = F.Felt(base.density_kg_per_m3, base.e_static_pa,
                       base.gamma if gamma is None else gamma,
                       base.tau0_s if tau0_s is None else tau0_s, base.exponent)
        except ValueError as e:
            raise SynthError(str(e)) from None
    if delta is not None:
        if f is not None:
            raise SynthError("--delta and --felt are exclusive: a named felt has its own delta")
        if not (0.0 < delta <= 1.0):
            raise SynthError(f"--delta = {delta!r} is out of range (0 < value <= 1)")
        d = float(delta)
    else:
        f = f or F.THESIS_FELT
        d = f.delta
    return FeltRequest(what, f, d, float(x_max), int(points))


def table(req: FeltRequest) -> dict:
    """The rows and the summary of ``req`` as plain data (``--json``)."""
    d = req.delta
    x = np.linspace(req.x_max / req.points, req.x_max, req.points)
    out: dict = {"what": req.what, "delta": d, "units": "eq. 2.11: time alpha0, length l0, "
                 "velocity c_s"}
    if req.felt is not None:
        f = req.felt
        out["felt"] = {"gamma": f.gamma, "tau0_s": f.tau0_s, "e_static_pa": f.e_static_pa,
                       "e_dynamic_pa": f.e_dynamic_pa, "density_kg_per_m3": f.density_kg_per_m3,
                       "c_static_m_per_s": f.c_static_m_per_s,
                       "c_dynamic_m_per_s": f.c_dynamic_m_per_s,
                       "alpha0_s": f.time_scale_s, "l0_m": f.length_scale_m}
    if req.what in ("dispersion", "velocities"):
        om, mu = F.dispersion(x, d)
        vph, vgr = F.velocities(x, d, roots=(om, mu))
        cols = {"k": x, "omega": om, "mu": mu, "v_phase": vph, "v_group": vgr}
        out["ngv"] = F.has_ngv(d)
        out["ngv_threshold_delta"] = F.ngv_threshold()
        if d >= 1.0 / 9.0:
            out["normal_dispersion_below_k"] = F.normal_dispersion_limit(d)
        gap = F.band_gap(d)
        out["band_gap_k"] = list(gap) if gap else None
        # the slowest group velocity on a fine grid (the table's rows may
        # step over a narrow negative region)
        kf = np.linspace(1e-3, max(4.0, req.x_max), 8000)
        vf = F.velocities(kf, d)[1]
        if np.any(np.isfinite(vf)):
            i = int(np.nanargmin(vf))
            out["min_v_group"] = {"k": float(kf[i]), "v": float(vf[i])}
    else:
        k, lam = F.attenuation(x, d)
        vph, vgr = F.attenuation_velocities(x, d)
        cols = {"omega": x, "k": k, "lambda": lam, "v_phase": vph, "v_group": vgr}
        out["lambda_high_frequency"] = (1.0 - d) / (2.0 * math.sqrt(d))
    if req.felt is not None:
        f = req.felt
        a0, l0, cs = f.time_scale_s, f.length_scale_m, f.c_static_m_per_s
        if req.what in ("dispersion", "velocities"):
            cols["wavelength_mm"] = 2e3 * math.pi * l0 / x
            cols["f_hz"] = cols["omega"] / (2 * math.pi * a0)
            cols["decay_per_s"] = -cols["mu"] / a0
        else:
            cols["f_hz"] = x / (2 * math.pi * a0)
            cols["db_per_mm"] = 20.0 / math.log(10.0) * cols["lambda"] / (l0 * 1e3)
        cols["v_phase_m_per_s"] = cols["v_phase"] * cs
        cols["v_group_m_per_s"] = cols["v_group"] * cs
    out["columns"] = {k: [None if not np.isfinite(v) else float(v) for v in np.asarray(c)]
                      for k, c in cols.items()}
    return out


def format_table(t: dict) -> str:
    """The table as text: a header of the felt and the findings, then rows."""
    lines = [f"# felt {t['what']}, delta = {t['delta']:.6g} ({t['units']})"]
    if "felt" in t:
        f = t["felt"]
        lines.append(f"# gamma {f['gamma']:g}, tau0 {f['tau0_s'] * 1e6:g} us, E_s "
                     f"{f['e_static_pa'] / 1e6:g} MPa, E_d {f['e_dynamic_pa'] / 1e6:g} MPa, rho "
                     f"{f['density_kg_per_m3']:g} kg/m3: c_s {f['c_static_m_per_s']:.2f} m/s, c_d "
                     f"{f['c_dynamic_m_per_s']:.2f} m/s, alpha0 {f['alpha0_s'] * 1e3:.4g} ms, "
                     f"l0 {f['l0_m'] * 1e3:.4g} mm")
    if "ngv" in t:
        lines.append(f"# negative group velocity: {'yes' if t['ngv'] else 'no'} (it exists for "
                     f"delta < {t['ngv_threshold_delta']:.10f})")
        if "min_v_group" in t:
            m = t["min_v_group"]
            lines.append(f"# slowest group velocity: {m['v']:+.4f} at k = {m['k']:.4g}")
        if t.get("normal_dispersion_below_k") is not None:
            lines.append(f"# normal dispersion (v_phase > v_group) for k < "
                         f"{t['normal_dispersion_below_k']:.6g}")
        if t.get("band_gap_k"):
            lo, hi = t["band_gap_k"]
            lines.append(f"# band gap: no propagating wave for {lo:.6g} < k < {hi:.6g}")
    if "lambda_high_frequency" in t:
        lines.append(f"# attenuation tends to {t['lambda_high_frequency']:.6g} per l0 at high "
                     f"frequency")
    cols = t["columns"]
    names = list(cols)
    lines.append("  ".join(f"{n:>14}" for n in names))
    for i in range(len(cols[names[0]])):
        lines.append("  ".join(f"{'nan':>14}" if cols[n][i] is None else f"{cols[n][i]:14.6g}"
                               for n in names))
    return "\n".join(lines)


def plot_table(t: dict, path: str) -> None:
    """A PNG of the table's curves (matplotlib, the ``[plots]`` extra)."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise SynthError('--plot needs the [plots] extra: pip install "synth[plots]"') from None
    cols = {k: np.array([np.nan if v is None else v for v in c], float)
            for k, c in t["columns"].items()}
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    if t["what"] in ("dispersion", "velocities"):
        x, xl = cols["k"], "wavenumber k (1/l0)"
        ax[0].plot(x, cols["omega"], label="omega")
        ax[0].plot(x, cols["mu"], label="mu")
        ax[0].set_ylabel("1/alpha0")
    else:
        x, xl = cols["omega"], "frequency omega (1/alpha0)"
        ax[0].plot(x, cols["k"], label="k")
        ax[0].plot(x, cols["lambda"], label="lambda (attenuation)")
        ax[0].set_ylabel("1/l0")
    ax[1].plot(x, cols["v_phase"], label="phase")
    ax[1].plot(x, cols["v_group"], label="group")
    ax[1].axhline(0.0, color="k", lw=0.5)
    ax[1].set_ylabel("velocity (c_s)")
    # (the group velocity runs off to infinity at a band gap's edges)
    ax[1].set_ylim(min(-1.0, float(np.nanmin(cols["v_group"])) - 0.2),
                   2.0 / math.sqrt(t["delta"]) + 0.5)
    for a in ax:
        a.set_xlabel(xl)
        a.legend()
        a.grid(alpha=0.3)
    fig.suptitle(f"felt {t['what']}, delta = {t['delta']:.4g}")
    fig.tight_layout()
    from ..io.wav import write_bytes_atomic

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=80)
    plt.close(fig)
    write_bytes_atomic(path, buf.getvalue())


@dataclass(frozen=True)
class PulseRequest:
    """``synth felt pulse``: the solver's arguments (:func:`F.solve_pulse`)."""

    problem: str
    delta: float
    exponent: float
    amplitude: float
    times: tuple
    dx: float
    units: str
    t_m: float
    alpha: float


def pulse_table(req: PulseRequest) -> dict:
    """Solve and summarise: per snapshot the leading crest (position,
    amplitude), the strain's least value (a steepened front's undershoot),
    and the crest's attenuation rate over the snapshots."""
    try:
        r = F.solve_pulse(req.delta, problem=req.problem, amplitude=req.amplitude,
                          exponent=req.exponent, times=req.times, dx=req.dx, units=req.units,
                          t_m=req.t_m, alpha=req.alpha)
    except (ValueError, FloatingPointError) as e:
        raise SynthError(str(e)) from None
    xs, amps = F.leading_peaks(r)
    out = {"what": "pulse", "problem": req.problem, "delta": req.delta, "exponent": req.exponent,
           "amplitude": req.amplitude, "units": req.units, "dx": r.dx, "dt": r.dt,
           "snapshots": [{"t": float(t), "crest_x": float(x), "crest": float(a),
                          "min_strain": float(np.min(s)),
                          # a hump's total variation is twice its height (plus its
                          # foot at the surface); a front that has steepened into a
                          # shock rings at the grid scale and adds much more
                          "rings": bool(np.sum(np.abs(np.diff(s))) > 2.5 * np.max(np.abs(s)))}
                         for t, x, a, s in zip(r.times, xs, amps, r.strain)]}
    if len(xs) >= 2:
        out["attenuation_rate"] = F.pulse_decay(r)
    out["_result"] = r
    return out


def format_pulse(t: dict) -> str:
    lines = [f"# felt pulse ({t['problem']}), delta = {t['delta']:g}, p = {t['exponent']:g}, "
             f"A = {t['amplitude']:g}, units {t['units']} (dx {t['dx']:g}, dt {t['dt']:.4g})"]
    if "attenuation_rate" in t:
        lines.append(f"# the leading crest decays as exp(-{t['attenuation_rate']:.4f} x)")
    ring = [s["t"] for s in t["snapshots"] if s["rings"]]
    if ring:
        lines.append(f"# from t = {ring[0]:.4g} the front has steepened into a shock and rings "
                     f"at the grid scale: the crest read there is the ringing's (the "
                     f"central-difference scheme does not capture shocks)")
    lines.append(f"{'t':>10}  {'crest x':>12}  {'crest':>12}  {'min strain':>12}  {'rings':>6}")
    for s in t["snapshots"]:
        lines.append(f"{s['t']:10.4g}  {s['crest_x']:12.5g}  {s['crest']:12.5g}  "
                     f"{s['min_strain']:12.4g}  {'yes' if s['rings'] else 'no':>6}")
    return "\n".join(lines)


def plot_pulse(t: dict, path: str) -> None:
    """The snapshots, each normalised to its crest (as the thesis's Figs.
    2.7-2.8), on one axis."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise SynthError('--plot needs the [plots] extra: pip install "synth[plots]"') from None
    r = t["_result"]
    fig, ax = plt.subplots(1, 1, figsize=(9, 4))
    for s, snap in zip(t["snapshots"], r.strain):
        ax.plot(r.x, snap / max(s["crest"], 1e-300), lw=1, label=f"t = {s['t']:.3g}")
    last = max(s["crest_x"] for s in t["snapshots"])
    ax.set_xlim(0, 1.5 * last + 1)
    ax.set_xlabel(f"x ({'c_d tau0' if t['units'] == 'tau0' else 'l0'})")
    ax.set_ylabel("strain / crest")
    ax.legend()
    ax.grid(alpha=0.3)
    ax.set_title(f"felt pulse ({t['problem']}), delta = {t['delta']:g}, p = {t['exponent']:g}, "
                 f"A = {t['amplitude']:g}")
    fig.tight_layout()
    from ..io.wav import write_bytes_atomic

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=80)
    plt.close(fig)
    write_bytes_atomic(path, buf.getvalue())
