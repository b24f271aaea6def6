"""`synth felt`: the felt wave lab's tables and plots (synth.apps.felt)."""

from __future__ import annotations

from .common import check_output, fail

NAME = "felt"
HELP = ("the felt wave lab: dispersion, velocities, attenuation of "
        "deformation waves in hammer felt (thesis chapter 2)")


def add_arguments(parser) -> None:
    parser.add_argument("what", choices=("dispersion", "velocities", "attenuation", "pulse",
                                         "hammer"),
                        help="dispersion: omega and mu against a real wavenumber (initial value "
                             "problem); velocities: phase and group velocity, the negative-group-"
                             "velocity region; attenuation: a harmonic load's wave against its "
                             "frequency (boundary value problem); pulse: a pulse by finite "
                             "differences, linear or nonlinear; hammer: a grand key's hammer on a "
                             "rigid string, the lumped law against its felt solved as a layer")
    parser.add_argument("--preset", "--felt", dest="felt", metavar="NAME|key:N",
                        help="the felt: thesis (eqs. 2.12-2.13, the default), pub3 (Publication "
                             "III's), or key:N, the grand's hammer on MIDI key N (21-108; "
                             "linearised about its strain at 2 m/s for the linear tables); SI "
                             "columns are added; --gamma/--tau0-us set values by hand")
    parser.add_argument("--delta", metavar="D[,D...]",
                        help="the dimensionless model's delta = 1 - gamma alone (0 < value <= 1), "
                             "instead of a felt; a list draws one curve (or pulse) per value")
    parser.add_argument("--gamma", type=float, help="hereditary amplitude of the felt (0 <= value < 1)")
    parser.add_argument("--tau0-us", type=float, help="relaxation time of the felt, microseconds")
    parser.add_argument("--max", type=float, default=6.0,
                        help="largest wavenumber k (dispersion, velocities) or frequency omega "
                             "(attenuation), in the units of eq. 2.11 (default 6)")
    parser.add_argument("--points", type=int, default=25, help="rows (default 25)")
    parser.add_argument("--problem", choices=("bvp", "ivp"), default="bvp",
                        help="pulse: driven into the surface (bvp, eq. 2.28) or released from "
                             "A sech(alpha x) (ivp, eq. 2.29)")
    parser.add_argument("--p", metavar="P[,P...]", help="pulse: the felt's exponent p (1-5; "
                        "default 1, or the --preset's)")
    parser.add_argument("--amplitude", metavar="A[,A...]", default="0.1",
                        help="pulse: A, a strain (default 0.1); one of --delta, --p, --amplitude, "
                             "--t-m may be a list: one pulse per value, drawn together")
    parser.add_argument("--times", default="2,3,4", help="pulse: snapshot times (default 2,3,4; "
                        "0 is the initial state)")
    parser.add_argument("--scheme", choices=("fd", "fv"), default="fd",
                        help="pulse: finite differences (fd, Publication III's; a shock rings) or "
                             "shock-capturing finite volumes (fv; for p > 1 past the steepening)")
    parser.add_argument("--absolute", action="store_true",
                        help="pulse --plot: the strain itself and the crests' fitted exp(-lambda x) "
                             "(thesis Fig. 2.6), instead of each snapshot over its peak")
    parser.add_argument("--dx", type=float, default=0.005, help="pulse: grid step (default 0.005)")
    parser.add_argument("--units", choices=("tau0", "alpha0"), default="tau0",
                        help="pulse: eq. 2.27's units as printed (tau0, Publication III's numbers; "
                             "the default) or eq. 2.11's (alpha0)")
    parser.add_argument("--t-m", metavar="T[,T...]", default="0.5",
                        help="pulse bvp: the load's rise time t_m (default 0.5)")
    parser.add_argument("--alpha", type=float, default=3.0, help="pulse ivp: the sech's alpha")
    parser.add_argument("--velocity", default="2", metavar="V[,V...]",
                        help="hammer: the hammer's speed(s) in m/s (default 2)")
    parser.add_argument("--thickness-mm", type=float,
                        help="hammer: the felt layer's thickness (default: the key's, assumed)")
    parser.add_argument("--area-mm2", type=float,
                        help="hammer: the felt column's cross-section (default 64 mm^2, assumed)")
    parser.add_argument("--cells", type=int, default=32, help="hammer: the layer's grid (default 32)")
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")
    parser.add_argument("--plot", metavar="OUT.png", help="also draw a PNG (needs the [plots] extra)")


def _numbers(text, option: str, example: str) -> tuple | None:
    """A comma-separated list of numbers from the command line (None: not given)."""
    if text is None:
        return None
    try:
        return tuple(float(v) for v in str(text).split(","))
    except ValueError:
        fail(f"{option} = {text!r} is not a list of numbers (e.g. {example})")


def run(args) -> int:
    """The felt wave lab's tables (synth.apps.felt)."""
    import json

    from ..apps.felt import format_table, make_requests, plot_table, table

    if args.plot is not None:
        check_output(args.plot, "--plot")
    deltas = _numbers(args.delta, "--delta", "0.5 or 0.15,0.2,0.5")
    if args.what == "hammer":
        from ..apps.felt import HammerRequest, format_hammer, hammer_table, plot_hammer

        vs = _numbers(args.velocity, "--velocity", "0.5,2,5")
        if deltas is not None:
            fail("hammer takes --preset key:N, not --delta")
        t = hammer_table(HammerRequest(args.felt or "key:60", vs, args.thickness_mm,
                                       args.area_mm2, args.gamma,
                                       None if args.tau0_us is None else args.tau0_us * 1e-6,
                                       args.cells))
        strikes = t.pop("_strikes")
        print(json.dumps(t, indent=1) if args.json else format_hammer(t))
        if args.plot is not None:
            t["_strikes"] = strikes
            plot_hammer(t, args.plot)
        return 0
    if args.what == "pulse":
        from ..apps.felt import (format_pulse, make_pulse_requests, plot_pulse, preset_felt,
                                pulse_table)

        times = _numbers(args.times, "--times", "2,3,4")
        ps = _numbers(args.p, "--p", "1.3,2")
        amps = _numbers(args.amplitude, "--amplitude", "0.2,0.02")
        t_ms = _numbers(args.t_m, "--t-m", "1,0.5")
        if args.gamma is not None or args.tau0_us is not None:
            fail("pulse takes --delta (the dimensionless model) or --preset, not "
                  "--gamma/--tau0-us")
        if args.felt is not None and deltas is not None:
            fail("pulse takes --delta or --preset, not both")
        if args.felt is not None:
            deltas = (preset_felt(args.felt).delta,)   # (a key's: its delta; its p unless --p)
            if ps is None and args.felt.startswith("key:"):
                from ..physics.felt import felt_for_key

                ps = (felt_for_key(int(args.felt[4:])).felt.exponent,)
        ts = [pulse_table(r) for r in make_pulse_requests(
            args.problem, deltas or (0.5,), ps or (1.0,), amps, times, args.dx, args.units,
            t_ms, args.alpha, args.scheme)]
        rs = [t.pop("_result") for t in ts]
        if args.json:
            print(json.dumps(ts[0] if len(ts) == 1 else ts, indent=1))
        else:
            print("\n\n".join(format_pulse(t) for t in ts))
        if args.plot is not None:
            for t, r in zip(ts, rs):
                t["_result"] = r
            plot_pulse(ts, args.plot, absolute=args.absolute)
        return 0
    reqs = make_requests(args.what, args.felt, deltas, args.gamma,
                         None if args.tau0_us is None else args.tau0_us * 1e-6, args.max,
                         args.points)
    ts = [table(r) for r in reqs]
    if args.json:
        print(json.dumps(ts[0] if len(ts) == 1 else ts, indent=1))
    else:
        print("\n\n".join(format_table(t) for t in ts))
    if args.plot is not None:
        from dataclasses import replace

        # the curves finely, whatever the table's rows
        plot_table([table(replace(r, points=1000)) for r in reqs], args.plot)
    return 0
