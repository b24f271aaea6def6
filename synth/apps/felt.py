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
* ``pulse``: a pulse solved by finite differences or by shock-capturing
  finite volumes (:func:`synth.physics.felt.solve_pulse`): driven into the
  felt's surface (eq. 2.28) or released from a sech profile (eq. 2.29),
  linear or nonlinear (p > 1), its leading crest's position and amplitude
  at each snapshot and its attenuation rate; one of delta, p, A, t_m may
  be a list (one pulse per value, drawn together: the thesis's Figs.
  2.6-2.8).

``dispersion``, ``velocities`` and ``attenuation`` take a list of deltas
too (one table and curve per value: Figs. 2.1-2.2).

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

#: named felts of ``--preset`` (``--felt``)
FELTS = {"thesis": F.THESIS_FELT, "pub3": F.PUB3_FELT}
#: a key's felt in the linear subcommands is linearised about the strain of
#: the lumped hammer's deepest compression at this speed (m/s, a mezzo-forte
#: strike: Askenfelt & Jansson 1991 measure ~1 (p) to 5-7 m/s (ff))
KEY_REFERENCE_SPEED_M_PER_S = 2.0
KEY_LOW, KEY_HIGH = 21, 108
#: at most this many curves (values of --delta, or pulses) on one plot
MAX_CURVES = 12


def parse_preset(text: str) -> tuple[str, object]:
    """``--preset``: a named felt (``thesis``, ``pub3``) -> ("named", Felt),
    or a grand key ``key:N`` (MIDI 21..108) -> ("key", N)."""
    t = str(text).strip()
    if t in FELTS:
        return "named", FELTS[t]
    if t.startswith("key:"):
        try:
            n = int(t[4:])
        except ValueError:
            raise SynthError(f"--preset = {text!r} is not a key (key:N, N a MIDI key "
                             f"{KEY_LOW}..{KEY_HIGH})") from None
        if not (KEY_LOW <= n <= KEY_HIGH):
            raise SynthError(f"--preset = {text!r} is out of range (key:{KEY_LOW} <= value <= "
                             f"key:{KEY_HIGH})")
        return "key", n
    raise SynthError(f"--preset = {text!r} is not allowed (choose {', '.join(FELTS)}, or "
                     f"key:N for the grand's key N = {KEY_LOW}..{KEY_HIGH})")


def key_felt_linearized(midi: int) -> tuple[F.Felt, float]:
    """The key's felt (:func:`synth.physics.felt.felt_for_key`) linearised
    (p = 1, the tangent modulus) about the strain of its lumped hammer's
    deepest compression at :data:`KEY_REFERENCE_SPEED_M_PER_S`; returns
    (felt, that strain)."""
    hf = F.felt_for_key(midi)
    w = F.strike_lumped(hf, KEY_REFERENCE_SPEED_M_PER_S).peak_compression_m
    eps = w / hf.thickness_m
    return hf.felt.linearized(eps), eps


def preset_felt(text: str) -> F.Felt:
    """The felt of ``--preset`` for the linear subcommands (a key's felt
    linearised: :func:`key_felt_linearized`)."""
    kind, v = parse_preset(text)
    return v if kind == "named" else key_felt_linearized(v)[0]


@dataclass(frozen=True)
class FeltRequest:
    """What ``synth felt`` was asked.

    what : str                  ``dispersion``, ``velocities`` or ``attenuation``
    felt : Felt or None         the felt (SI columns too; p = 1: a key's is
                                linearised, :func:`key_felt_linearized`), or None
                                (``delta`` alone)
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
    """Validate the command line's choices into a :class:`FeltRequest`;
    ``felt`` is a ``--preset`` (:func:`parse_preset`)."""
    if what not in ("dispersion", "velocities", "attenuation"):
        raise SynthError(f"what = {what!r} is not allowed (choose dispersion, velocities, "
                         f"attenuation)")
    if not (0.0 < x_max <= 1e4) or not math.isfinite(x_max):
        raise SynthError(f"--max = {x_max!r} is out of range (0 < value <= 10000)")
    if not (2 <= points <= 100_000):
        raise SynthError(f"--points = {points!r} is out of range (2 <= value <= 100000)")
    f = None
    if felt is not None:
        f = preset_felt(felt)
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
            raise SynthError("--delta and --preset/--felt are exclusive: a felt has its own delta")
        if not (0.0 < delta <= 1.0):
            raise SynthError(f"--delta = {delta!r} is out of range (0 < value <= 1)")
        d = float(delta)
    else:
        f = f or F.THESIS_FELT
        d = f.delta
    return FeltRequest(what, f, d, float(x_max), int(points))


def make_requests(what: str, felt: str | None, deltas: tuple | None, gamma: float | None,
                  tau0_s: float | None, x_max: float, points: int) -> list[FeltRequest]:
    """:func:`make_request` for each of ``deltas`` (``--delta D1,D2,...``: the
    thesis's Figs. 2.1-2.2 and Publication III's Figs. 2-4 draw several on
    one plot), or once for a felt (``deltas`` None)."""
    if deltas is not None and not (1 <= len(deltas) <= MAX_CURVES):
        raise SynthError(f"--delta has {len(deltas)} values, out of range (1 <= count <= "
                         f"{MAX_CURVES})")
    return [make_request(what, felt, d, gamma, tau0_s, x_max, points)
            for d in (deltas if deltas is not None else (None,))]


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
        if t.get("normal_dispersion_below_k"):
            lines.append(f"# normal dispersion (v_phase > v_group) for k < "
                         f"{t['normal_dispersion_below_k']:.6g}")
        elif t.get("normal_dispersion_below_k") == 0.0:
            lines.append("# normal dispersion: none (k_* = 0, v_phase < v_group at every k)")
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


def _pyplot():
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise SynthError('--plot needs the [plots] extra: pip install "synth[plots]"') from None
    return plt


def _save(fig, path: str, dpi: int = 80) -> None:
    """Write the figure as a PNG of at most 32 colours (line plots: a third
    of the bytes of a full-colour one)."""
    import matplotlib.pyplot as plt

    from ..io.wav import write_bytes_atomic

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    plt.close(fig)
    try:
        from PIL import Image                  # (matplotlib depends on Pillow)

        im = Image.open(io.BytesIO(buf.getvalue())).convert("RGB")
        small = io.BytesIO()
        im.quantize(colors=32).save(small, format="png", optimize=True)
        buf = small
    except ImportError:                        # pragma: no cover
        pass
    write_bytes_atomic(path, buf.getvalue())


def _columns(t: dict) -> dict:
    return {k: np.array([np.nan if v is None else v for v in c], float)
            for k, c in t["columns"].items()}


def plot_table(t, path: str) -> None:
    """A PNG of the table's curves (matplotlib, the ``[plots]`` extra).

    One table: omega and mu (or k and lambda) against k (or omega), and
    the phase and group velocities, with the short-wave limit 1 / sqrt(delta)
    (c_d, dashed: eq. 2.26) and, for the initial value problem, k_* (dotted:
    normal dispersion to its left, thesis Figs. 2.3 and 2.5) and a band gap
    (shaded).  A list of tables (several deltas): one curve per delta,
    omega(k) and mu(k) (thesis Figs. 2.1-2.2), v_ph and v_gr, or k(omega)
    and lambda(omega) (Publication III Fig. 2)."""
    ts = t if isinstance(t, list) else [t]
    plt = _pyplot()
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    ivp = ts[0]["what"] in ("dispersion", "velocities")
    xl = "wavenumber k (1/l0)" if ivp else "frequency omega (1/alpha0)"
    if len(ts) == 1:
        cols = _columns(ts[0])
        d = ts[0]["delta"]
        if ivp:
            x = cols["k"]
            ax[0].plot(x, cols["omega"], label="omega")
            ax[0].plot(x, cols["mu"], label="mu")
            ax[0].set_ylabel("1/alpha0")
        else:
            x = cols["omega"]
            ax[0].plot(x, cols["k"], label="k")
            ax[0].plot(x, cols["lambda"], label="lambda (attenuation)")
            ax[0].set_ylabel("1/l0")
        ax[1].plot(x, cols["v_phase"], label="phase")
        ax[1].plot(x, cols["v_group"], label="group")
        ax[1].axhline(1.0 / math.sqrt(d), color="k", ls="--", lw=0.8,
                      label="1/sqrt(delta) (c_d)")
        ks = ts[0].get("normal_dispersion_below_k")
        if ks:
            for a in ax:
                a.axvline(ks, color="k", ls=":", lw=0.8)
            ax[1].plot([], [], "k:", lw=0.8, label=f"k_* = {ks:.4g}")
        if ts[0].get("band_gap_k"):
            for a in ax:
                a.axvspan(*ts[0]["band_gap_k"], color="0.85")
        # (the group velocity runs off to infinity at a band gap's edges)
        ax[1].set_ylim(min(-1.0, float(np.nanmin(cols["v_group"])) - 0.2),
                       2.0 / math.sqrt(d) + 0.5)
        ax[1].axhline(0.0, color="k", lw=0.5)
        ax[1].set_ylabel("velocity (c_s)")
        title = f"felt {ts[0]['what']}, delta = {d:.4g}"
    else:
        if ts[0]["what"] == "dispersion":
            names, labels = ("omega", "mu"), ("frequency omega (1/alpha0)",
                                              "decay rate mu (1/alpha0)")
        elif ts[0]["what"] == "velocities":
            names, labels = ("v_phase", "v_group"), ("phase velocity (c_s)",
                                                     "group velocity (c_s)")
        else:
            names, labels = ("k", "lambda"), ("wavenumber k (1/l0)", "attenuation lambda (1/l0)")
        top = 0.0
        for j, tj in enumerate(ts):
            cols = _columns(tj)
            x = cols["k"] if ivp else cols["omega"]
            col = plt.cm.viridis(0.9 * j / (len(ts) - 1))       # dark: small delta
            for a, n in zip(ax, names):
                a.plot(x, cols[n], color=col, lw=1.2, label=f"delta = {tj['delta']:.4g}")
            top = max(top, 1.0 / math.sqrt(tj["delta"]))
        if ts[0]["what"] == "dispersion":
            ax[0].plot(x, x, color="k", ls=":", lw=0.8, label="omega = k (delta = 1)")
        if ts[0]["what"] == "velocities":
            vmin = min(float(np.nanmin(_columns(tj)["v_group"])) for tj in ts)
            ax[1].set_ylim(min(-1.0, vmin - 0.2), 2.0 * top + 0.5)
            ax[0].set_ylim(0.0, 1.1 * top)
        for a, lab in zip(ax, labels):
            a.set_ylabel(lab)
        title = f"felt {ts[0]['what']}, {len(ts)} values of delta"
    for a in ax:
        a.set_xlabel(xl)
        a.legend(fontsize=7)
        a.grid(alpha=0.3)
    fig.suptitle(title)
    fig.tight_layout()
    _save(fig, path)


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
    scheme: str = "fd"


#: the pulse parameters a list may vary (``--delta 0.8,0.5,0.2``), one at a time
PULSE_VARIED = {"delta": "--delta", "exponent": "--p", "amplitude": "--amplitude",
                "t_m": "--t-m"}


def make_pulse_requests(problem: str, deltas: tuple, exponents: tuple, amplitudes: tuple,
                        times: tuple, dx: float, units: str, t_ms: tuple,
                        alpha: float, scheme: str = "fd") -> list[PulseRequest]:
    """The pulses ``synth felt pulse`` was asked for: one, or one per value
    of the single parameter given as a list (``--delta``, ``--p``,
    ``--amplitude`` or ``--t-m``; the thesis's Figs. 2.6-2.8 and Publication
    III's Figs. 6-8 each vary one)."""
    lists = {"delta": tuple(deltas), "exponent": tuple(exponents),
             "amplitude": tuple(amplitudes), "t_m": tuple(t_ms)}
    for k, v in lists.items():
        if not v:
            raise SynthError(f"{PULSE_VARIED[k]} needs a value")
    varied = [k for k, v in lists.items() if len(v) > 1]
    if len(varied) > 1:
        raise SynthError(f"{' and '.join(PULSE_VARIED[k] for k in varied)} are lists: vary "
                         f"one parameter at a time")
    if varied and len(lists[varied[0]]) > MAX_CURVES:
        raise SynthError(f"{PULSE_VARIED[varied[0]]} has {len(lists[varied[0]])} values, out "
                         f"of range (1 <= count <= {MAX_CURVES})")
    n = len(lists[varied[0]]) if varied else 1
    pick = {k: (v * n if len(v) == 1 else v) for k, v in lists.items()}
    return [PulseRequest(problem, float(pick["delta"][i]), float(pick["exponent"][i]),
                         float(pick["amplitude"][i]), tuple(times), dx, units,
                         float(pick["t_m"][i]), alpha, scheme) for i in range(n)]


def _front(x: np.ndarray, s: np.ndarray) -> float:
    """The pulse's front: the foremost point where the strain is half its
    peak (interpolated linearly)."""
    m = float(np.max(s))
    if m <= 0.0:
        return 0.0
    i = int(np.flatnonzero(s >= 0.5 * m)[-1])
    if i + 1 >= s.size:
        return float(x[i])
    return float(x[i] + (s[i] - 0.5 * m) / (s[i] - s[i + 1]) * (x[i + 1] - x[i]))


def pulse_table(req: PulseRequest) -> dict:
    """Solve and summarise: per snapshot the leading crest (position,
    amplitude), the strain's least value (a steepened front's undershoot),
    and the crest's attenuation rate over the snapshots after t = 0."""
    try:
        r = F.solve_pulse(req.delta, problem=req.problem, amplitude=req.amplitude,
                          exponent=req.exponent, times=req.times, dx=req.dx, units=req.units,
                          t_m=req.t_m, alpha=req.alpha, scheme=req.scheme)
    except (ValueError, FloatingPointError) as e:
        raise SynthError(str(e)) from None
    xs, amps = F.leading_peaks(r)
    out = {"what": "pulse", "problem": req.problem, "delta": req.delta, "exponent": req.exponent,
           "amplitude": req.amplitude, "units": req.units, "scheme": req.scheme, "dx": r.dx,
           "dt": r.dt,
           "snapshots": [{"t": float(t), "crest_x": float(x), "crest": float(a),
                          "peak_x": float(r.x[int(np.argmax(s))]), "peak": float(np.max(s)),
                          "front_x": _front(r.x, s),
                          "min_strain": float(np.min(s)),
                          # a hump's total variation is twice its height (plus its
                          # foot at the surface); a front that has steepened into a
                          # shock rings at the grid scale and adds much more
                          "rings": bool(np.sum(np.abs(np.diff(s))) > 2.5 * np.max(np.abs(s)))}
                         for t, x, a, s in zip(r.times, xs, amps, r.strain)]}
    if req.problem == "bvp":
        out["t_m"] = req.t_m
    else:
        out["alpha"] = req.alpha
    if int(np.sum((r.times > 0) & (amps > 0))) >= 2:
        out["attenuation_rate"] = F.pulse_decay(r)
    out["_result"] = r
    return out


def format_pulse(t: dict) -> str:
    lines = [f"# felt pulse ({t['problem']}), delta = {t['delta']:g}, p = {t['exponent']:g}, "
             f"A = {t['amplitude']:g}, "
             + (f"t_m = {t['t_m']:g}, " if "t_m" in t else f"alpha = {t['alpha']:g}, ")
             + f"units {t['units']}, scheme {t.get('scheme', 'fd')} (dx {t['dx']:g}, dt "
             f"{t['dt']:.4g})"]
    if "attenuation_rate" in t:
        lines.append(f"# the leading crest decays as exp(-{t['attenuation_rate']:.4f} x)")
    ring = [s["t"] for s in t["snapshots"] if s["rings"]]
    if ring:
        lines.append(f"# from t = {ring[0]:.4g} the front has steepened into a shock and rings "
                     f"at the grid scale: the crest read there is the ringing's ("
                     + ("the central-difference scheme does not capture shocks: --scheme fv "
                        "does" if t.get("scheme", "fd") == "fd" else "the finite volumes "
                        "should not ring: refine --dx") + ")")
    lines.append("# crest: the leading local maximum; peak: the largest strain; front: the "
                 "foremost point at half the peak")
    lines.append(f"{'t':>8}  {'crest x':>10}  {'crest':>10}  {'peak x':>10}  {'peak':>10}  "
                 f"{'front x':>10}  {'min strain':>10}  {'rings':>5}")
    for s in t["snapshots"]:
        lines.append(f"{s['t']:8.4g}  {s['crest_x']:10.5g}  {s['crest']:10.5g}  "
                     f"{s['peak_x']:10.5g}  {s['peak']:10.5g}  {s['front_x']:10.5g}  "
                     f"{s['min_strain']:10.3g}  {'yes' if s['rings'] else 'no':>5}")
    return "\n".join(lines)


def _pulse_label(ts: list, t: dict) -> str:
    """What tells the pulse ``t`` from the others of ``ts`` (the varied
    parameter), or its parameters."""
    for key, name in (("delta", "delta"), ("exponent", "p"), ("amplitude", "A"),
                      ("t_m", "t_m")):
        if len({u.get(key) for u in ts}) > 1:
            return f"{name} = {t[key]:g}"
    return f"delta = {t['delta']:g}, p = {t['exponent']:g}, A = {t['amplitude']:g}"


def plot_pulse(t, path: str, absolute: bool = False) -> None:
    """The snapshots (colour: the time; line style: the pulse when a list
    of pulses varies one parameter), each over its peak (as the thesis's
    Figs. 2.7-2.8 and Publication III's Figs. 7-8), the leading crests
    marked; ``absolute``: the strain itself with the crests' fitted
    exp(-lambda x) dashed (thesis Fig. 2.6).  Two pulses released from a
    sech (ivp) with two values of p are drawn as the thesis's Fig. 2.7: the
    first mirrored to x < 0."""
    ts = t if isinstance(t, list) else [t]
    plt = _pyplot()
    fig, ax = plt.subplots(1, 1, figsize=(10, 4.5))
    styles = ("-", "--", ":", "-.")
    mirror = (len(ts) == 2 and ts[0]["problem"] == "ivp"
              and ts[0]["exponent"] != ts[1]["exponent"])
    # (the runs' time steps differ: colour by the snapshot asked for, not its step's time)
    times = [s["t"] for s in ts[0]["snapshots"]]
    last = 0.0
    for j, u in enumerate(ts):
        r = u["_result"]
        sign = -1.0 if (mirror and j == 0) else 1.0
        ls = styles[j % len(styles)]
        lab = _pulse_label(ts, u)
        for i, (s, snap) in enumerate(zip(u["snapshots"], r.strain)):
            c = f"C{i % 10}"
            scale = 1.0 if absolute else 1.0 / max(s["peak"], 1e-300)
            ax.plot(sign * r.x, snap * scale, ls, color=c, lw=1)
            ax.plot([sign * s["crest_x"]], [s["crest"] * scale], "o", color=c, ms=3)
            last = max(last, s["crest_x"])
        ax.plot([], [], ls, color="k", lw=1, label=lab)
        if absolute and "attenuation_rate" in u:
            pos = [s for s in u["snapshots"] if s["t"] > 0 and s["crest"] > 0]
            b = np.polyfit([s["crest_x"] for s in pos], np.log([s["crest"] for s in pos]), 1)
            xx = np.linspace(0.0, 1.3 * last + 1.0, 200)
            ax.plot(sign * xx, np.exp(np.polyval(b, xx)), "--", color="0.4", lw=0.8)
            xt = 0.97 * xx[-1]
            ax.text(sign * xt, float(np.exp(np.polyval(b, xt))),
                    f"exp(-{u['attenuation_rate']:.3f} x)", fontsize=7, color="0.3",
                    ha="left" if sign < 0 else "right", va="bottom")
    for k, tt in enumerate(times):
        ax.plot([], [], color=f"C{k % 10}", lw=3, label=f"t = {tt:.3g}")
    hi = 1.3 * last + 1.0
    ax.set_xlim(-hi if mirror else 0.0, hi)
    if mirror:
        ax.axvline(0.0, color="k", ls="-.", lw=0.8)
    u0 = ts[0]
    ax.set_xlabel(f"x ({'c_d tau0' if u0['units'] == 'tau0' else 'l0'})"
                  + ("; left: " + _pulse_label(ts, ts[0]) + ", right: " + _pulse_label(ts, ts[1])
                     if mirror else ""))
    ax.set_ylabel("strain" if absolute else "strain / its peak")
    ax.legend(fontsize=7, ncol=2)
    ax.grid(alpha=0.3)
    fixed = [f"{n} = {u0[k]:g}" for k, n in (("delta", "delta"), ("exponent", "p"),
                                              ("amplitude", "A"), ("t_m", "t_m"),
                                              ("alpha", "alpha"))
             if k in u0 and len({u.get(k) for u in ts}) == 1]
    ax.set_title(f"felt pulse ({u0['problem']}), " + ", ".join(fixed))
    fig.tight_layout()
    _save(fig, path)


# ---- synth felt hammer: the felt layer against the lumped law (issue 14 sec. 6) ----

@dataclass(frozen=True)
class HammerRequest:
    """``synth felt hammer``: a grand key's hammer struck on a rigid string
    by the lumped law and as a felt layer.

    preset : str                ``key:N`` (:func:`parse_preset`)
    velocities : tuple          hammer speeds, m/s (0.05 .. 20)
    thickness_mm, area_mm2 : float or None   the layer (None: the key's assumed)
    gamma, tau0_s : float or None            the felt's memory (None: the key's;
                                the lumped law follows, alpha = tau0 / (1 - gamma))
    cells : int                 the layer's grid (2 .. 1024)
    """

    preset: str
    velocities: tuple
    thickness_mm: float | None = None
    area_mm2: float | None = None
    gamma: float | None = None
    tau0_s: float | None = None
    cells: int = 32


def hammer_felt(req: HammerRequest) -> F.HammerFelt:
    """The :class:`synth.physics.felt.HammerFelt` the request names."""
    kind, v = parse_preset(req.preset)
    if kind != "key":
        raise SynthError(f"--preset = {req.preset!r} is not allowed for hammer (a grand key's "
                         f"hammer: key:{KEY_LOW} .. key:{KEY_HIGH})")
    for name, x, lo, hi in (("--thickness-mm", req.thickness_mm, 0.1, 100.0),
                            ("--area-mm2", req.area_mm2, 0.01, 1e4)):
        if x is not None and not (lo <= x <= hi):
            raise SynthError(f"{name} = {x!r} is out of range ({lo:g} <= value <= {hi:g})")
    try:
        hf = F.felt_for_key(v, thickness_m=None if req.thickness_mm is None
                            else req.thickness_mm * 1e-3,
                            area_m2=F.FELT_COLUMN_AREA_M2 if req.area_mm2 is None
                            else req.area_mm2 * 1e-6)
        if req.gamma is not None or req.tau0_s is not None:
            f = hf.felt
            f = F.Felt(f.density_kg_per_m3, f.e_static_pa, f.gamma if req.gamma is None
                       else req.gamma, f.tau0_s if req.tau0_s is None else req.tau0_s, f.exponent)
            hf = F.HammerFelt(f, hf.thickness_m, hf.area_m2, hf.hammer_mass_kg, hf.midi)
    except ValueError as e:
        raise SynthError(str(e)) from None
    return hf


def _rel(a: float, b: float) -> float:
    return a / b - 1.0


def hammer_table(req: HammerRequest) -> dict:
    """Per speed: contact time, peak force (the layer's after its first
    touch's transient) and deepest compression of the
    lumped law as the voice uses it (eq. 1.5, ``lumped_kv``), of its parent
    four-parameter law (Publication III eq. 3, ``lumped_sls``: the layer's
    exact quasi-static limit) and of the layer (``layer``), the layer's
    relative differences to both, the flat face's first-touch force
    (:func:`synth.physics.felt.first_touch_force_n`) and the wall time of
    each solve (s)."""
    import time

    if not (2 <= req.cells <= 1024):
        raise SynthError(f"--cells = {req.cells!r} is out of range (2 <= value <= 1024)")
    if not req.velocities:
        raise SynthError("--velocity needs at least one speed")
    for v in req.velocities:
        if not (0.05 <= v <= 20.0) or not math.isfinite(v):
            raise SynthError(f"--velocity = {v!r} is out of range (0.05 <= value <= 20 m/s)")
    hf = hammer_felt(req)
    f = hf.felt
    out: dict = {"what": "hammer", "key": hf.midi, "felt": {
        "thickness_m": hf.thickness_m, "area_m2": hf.area_m2, "density_kg_per_m3":
        f.density_kg_per_m3, "exponent": f.exponent, "gamma": f.gamma, "tau0_s": f.tau0_s,
        "e_static_pa": f.e_static_pa, "e_dynamic_pa": f.e_dynamic_pa,
        "q0_n_per_mm_p": hf.q0_n_per_mm_p, "alpha_s": hf.alpha_s,
        "hammer_mass_kg": hf.hammer_mass_kg, "felt_mass_kg": hf.felt_mass_kg,
        "core_mass_kg": hf.core_mass_kg}, "cells": req.cells, "rows": [],
        "voice_law": req.gamma is None and req.tau0_s is None}
    strikes = []
    for v in req.velocities:
        try:
            t0 = time.perf_counter()
            kv = F.strike_lumped(hf, v, law="kv")
            t1 = time.perf_counter()
            sls = F.strike_lumped(hf, v, law="sls")
            t2 = time.perf_counter()
            lay = F.strike_layer(hf, v, cells=req.cells)
            t3 = time.perf_counter()
        except (ValueError, FloatingPointError) as e:
            raise SynthError(str(e)) from None
        row = {"v_m_per_s": v}
        for name, r, dt in (("lumped_kv", kv, t1 - t0), ("lumped_sls", sls, t2 - t1),
                            ("layer", lay, t3 - t2)):
            row[name] = {"contact_time_s": r.contact_time_s, "peak_force_n": r.peak_force_n,
                         "peak_compression_m": r.peak_compression_m, "steps": r.steps,
                         "wall_s": dt}
        row["layer_vs_kv"] = {"contact_time": _rel(lay.contact_time_s, kv.contact_time_s),
                              "peak_force": _rel(lay.peak_force_n, kv.peak_force_n)}
        row["layer_vs_sls"] = {"contact_time": _rel(lay.contact_time_s, sls.contact_time_s),
                               "peak_force": _rel(lay.peak_force_n, sls.peak_force_n)}
        row["sls_vs_kv"] = {"contact_time": _rel(sls.contact_time_s, kv.contact_time_s),
                            "peak_force": _rel(sls.peak_force_n, kv.peak_force_n)}
        row["layer"]["touch_force_n"] = lay.touch_force_n
        row["first_touch_force_n"] = F.first_touch_force_n(hf, v)
        out["rows"].append(row)
        strikes.append((v, kv, sls, lay))
    out["_strikes"] = strikes
    return out


def format_hammer(t: dict) -> str:
    """The comparison as text."""
    f = t["felt"]
    lines = [f"# felt hammer, key {t['key']}: felt {f['thickness_m'] * 1e3:.3g} mm x "
             f"{f['area_m2'] * 1e6:.3g} mm^2 ({f['felt_mass_kg'] * 1e3:.3g} g) on a "
             f"{f['core_mass_kg'] * 1e3:.3g} g core (hammer {f['hammer_mass_kg'] * 1e3:.3g} g "
             f"per string), rigid string",
             f"# Q0 {f['q0_n_per_mm_p']:.5g} N/mm^p, p {f['exponent']:.4g}, alpha "
             f"{f['alpha_s'] * 1e6:.4g} us = tau0 {f['tau0_s'] * 1e6:.4g} us / delta "
             f"{1 - f['gamma']:.4g}; E_s {f['e_static_pa']:.4g} Pa (sigma = E_s eps^p), rho "
             f"{f['density_kg_per_m3']:g} kg/m3; layer on {t['cells']} cells",
             "# kv: eq. 1.5 as the voice uses it; sls: Publication III eq. 3 (the layer's "
             "quasi-static limit); layer: the felt as a medium"
             + ("" if t.get("voice_law", True) else " (--gamma/--tau0-us set by hand: kv "
                "has this felt's alpha, not the voice's)"),
             f"{'v m/s':>6} {'route':>10} {'contact ms':>11} {'peak N':>9} {'w_max mm':>9} "
             f"{'d_tc vs kv':>11} {'d_F vs kv':>10} {'wall ms':>8}"]
    for r in t["rows"]:
        for name in ("lumped_kv", "lumped_sls", "layer"):
            x = r[name]
            if name == "lumped_kv":
                d = ("", "")
            else:
                d = (f"{x['contact_time_s'] / r['lumped_kv']['contact_time_s'] - 1:+.2%}",
                     f"{x['peak_force_n'] / r['lumped_kv']['peak_force_n'] - 1:+.2%}")
            lines.append(f"{r['v_m_per_s']:6.3g} {name.replace('lumped_', ''):>10} "
                         f"{x['contact_time_s'] * 1e3:11.4f} {x['peak_force_n']:9.4g} "
                         f"{x['peak_compression_m'] * 1e3:9.4f} {d[0]:>11} {d[1]:>10} "
                         f"{x['wall_s'] * 1e3:8.1f}")
        lines.append(f"{'':6} {'':>10} layer vs sls: contact {r['layer_vs_sls']['contact_time']:+.2%}"
                     f", peak {r['layer_vs_sls']['peak_force']:+.2%}; first touch of the flat "
                     f"face: {r['first_touch_force_n']:.4g} N (its shock), "
                     f"{r['layer']['touch_force_n']:.4g} N on the grid")
    return "\n".join(lines)


def plot_hammer(t: dict, path: str) -> None:
    """Force against compression (and against time) for each route and
    speed (matplotlib, the ``[plots]`` extra)."""
    plt = _pyplot()
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    styles = {"lumped-kv": ("-", "eq. 1.5 (voice)"), "lumped-sls": (":", "Pub. III eq. 3"),
              "layer": ("--", "felt layer")}
    for j, (v, *rs) in enumerate(t["_strikes"]):
        col = f"C{j % 10}"
        for r in rs:
            ls, lab = styles[r.route]
            n = max(1, len(r.time_s) // 1500)            # a light PNG
            ax[0].plot(r.compression_m[::n] * 1e3, r.force_n[::n], ls, color=col, lw=1,
                       label=f"{v:g} m/s, {lab}")
            ax[1].plot(r.time_s[::n] * 1e3, r.force_n[::n], ls, color=col, lw=1)
    ax[0].set_xlabel("felt compression (mm)")
    ax[1].set_xlabel("time (ms)")
    for a in ax:
        a.set_ylabel("force (N)")
        a.grid(alpha=0.3)
    ax[0].legend(fontsize=7)
    f = t["felt"]
    fig.suptitle(f"key {t['key']}: lumped law against a {f['thickness_m'] * 1e3:.3g} mm felt "
                 f"layer, rigid string")
    fig.tight_layout()
    _save(fig, path, dpi=72)
