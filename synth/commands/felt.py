"""`synth felt`: the felt wave lab's tables and plots (synth.apps.felt)."""

from __future__ import annotations

from .common import check_output, fail, require_extra

NAME = "felt"
HELP = ("the felt wave lab: dispersion, velocities, attenuation of "
        "deformation waves in hammer felt (thesis chapter 2)")


#: the modes and their one-line help
MODES = {
    "dispersion": "omega and mu against a real wavenumber (initial value problem)",
    "velocities": "phase and group velocity, the negative-group-velocity region",
    "attenuation": "a harmonic load's wave against its frequency (boundary value problem)",
    "pulse": "a pulse by finite differences (or finite volumes), linear or nonlinear",
    "hammer": "a grand key's hammer on a rigid string: the lumped law against its felt "
              "solved as a layer",
}
_TABLES = ("dispersion", "velocities", "attenuation")
#: the options of each mode (beyond --json and --plot, which all take)
OPTIONS = {
    **{m: ("--preset", "--delta", "--gamma", "--tau0-us", "--max", "--points") for m in _TABLES},
    "pulse": ("--preset", "--delta", "--problem", "--p", "--amplitude", "--times", "--scheme",
              "--absolute", "--dx", "--units", "--t-m", "--alpha"),
    "hammer": ("--preset", "--velocity", "--gamma", "--tau0-us", "--thickness-mm", "--area-mm2",
               "--cells"),
}
#: every mode's attributes, None (or False) where a mode has no such option
_DESTS = ("felt", "delta", "gamma", "tau0_us", "max", "points", "problem", "p", "amplitude",
          "times", "scheme", "absolute", "dx", "units", "t_m", "alpha", "velocity",
          "thickness_mm", "area_mm2", "cells")

EPILOG = ("modes (each has its own --help: synth felt MODE --help):\n"
          + "".join(f"  {m:<12} {h}\n" for m, h in MODES.items())
          + "\nexamples:\n"
          "  synth felt velocities --delta 0.128 --plot v.png\n"
          "  synth felt attenuation --preset pub3 --max 3 --json\n"
          "  synth felt pulse --delta 0.5 --amplitude 1 --times 4.5,6.75,9\n"
          "  synth felt hammer --preset key:60 --velocity 0.5,2,5\n"
          "\nThe lab's equations and figures: synth help felt.")

_EXAMPLES = {
    "dispersion": ["synth felt dispersion --preset thesis",
                   "synth felt dispersion --delta 0.15,0.2,0.5,0.8 --points 600 --plot d.png"],
    "velocities": ["synth felt velocities --delta 0.128 --plot v.png",
                   "synth felt velocities --preset key:60 --json"],
    "attenuation": ["synth felt attenuation --preset pub3 --max 3 --json",
                    "synth felt attenuation --delta 0.2,0.5,0.8 --max 3 --points 3"],
    "pulse": ["synth felt pulse --delta 0.5 --amplitude 1 --times 4.5,6.75,9",
              "synth felt pulse --problem ivp --delta 0.5 --p 1.3,2 --times 0,3.333,6.667,10 "
              "--scheme fv --plot p.png"],
    "hammer": ["synth felt hammer --preset key:60 --velocity 0.5,2,5 --plot h.png",
               "synth felt hammer --preset key:21 --velocity 5 --thickness-mm 10 --area-mm2 32 "
               "--json"],
}


def _add_felt(p, mode: str) -> None:
    if mode == "hammer":
        p.add_argument("--preset", "--felt", dest="felt", metavar="key:N", default="key:60",
                       help="the grand's hammer on MIDI key N, 21-108 (default %(default)s)")
        return
    if mode == "pulse":
        p.add_argument("--preset", "--felt", dest="felt", metavar="NAME|key:N",
                       help="the felt: thesis (eqs. 2.12-2.13), pub3 (Publication III's), or "
                            "key:N, the grand's hammer on MIDI key N (21-108): its delta, and its "
                            "p unless --p (default: none, --delta, or delta 0.5)")
        return
    p.add_argument("--preset", "--felt", dest="felt", metavar="NAME|key:N",
                   help="the felt: thesis (eqs. 2.12-2.13, the default), pub3 (Publication "
                        "III's), or key:N, the grand's hammer on MIDI key N (21-108; linearised "
                        "about its strain at 2 m/s); SI columns are added; --gamma/--tau0-us set "
                        "values by hand")


def _add_mode(sub, mode: str, formatter) -> None:
    p = sub.add_parser(mode, help=MODES[mode], description=f"synth felt {mode}: {MODES[mode]}.",
                       epilog="examples:\n" + "\n".join(f"  {e}" for e in _EXAMPLES[mode]),
                       formatter_class=formatter)
    _add_felt(p, mode)
    if mode != "hammer":
        p.add_argument("--delta", metavar="D[,D...]",
                       help="the dimensionless model's delta = 1 - gamma alone (0 < value <= 1), "
                            "instead of a felt; a list draws one curve (or pulse) per value "
                            "(default: none)")
    if mode != "pulse":
        p.add_argument("--gamma", type=float,
                       help="hereditary amplitude of the felt, 0 <= value < 1 (default: the "
                            "felt's)")
        p.add_argument("--tau0-us", type=float, metavar="US",
                       help="relaxation time of the felt in microseconds (default: the felt's)")
    if mode in _TABLES:
        p.add_argument("--max", type=float, default=6.0,
                       help="largest wavenumber k (dispersion, velocities) or frequency omega "
                            "(attenuation), in the units of eq. 2.11 (default %(default)g)")
        p.add_argument("--points", type=int, default=25, metavar="N",
                       help="rows of the table, 2 or more (default %(default)s)")
    if mode == "pulse":
        p.add_argument("--problem", choices=("bvp", "ivp"), default="bvp",
                       help="driven into the surface (bvp, eq. 2.28) or released from "
                            "A sech(alpha x) (ivp, eq. 2.29) (default %(default)s)")
        p.add_argument("--p", metavar="P[,P...]",
                       help="the felt's exponent p, 1-5 (default 1, or the --preset's)")
        p.add_argument("--amplitude", metavar="A[,A...]", default="0.1",
                       help="A, a strain (default %(default)s); one of --delta, --p, --amplitude, "
                            "--t-m may be a list: one pulse per value, drawn together")
        p.add_argument("--times", default="2,3,4", metavar="T[,T...]",
                       help="snapshot times in the units of --units (default %(default)s; 0 is the "
                            "initial state)")
        p.add_argument("--scheme", choices=("fd", "fv"), default="fd",
                       help="finite differences (fd, Publication III's; a shock rings) or "
                            "shock-capturing finite volumes (fv; for p > 1 past the steepening) "
                            "(default %(default)s)")
        p.add_argument("--absolute", action="store_true",
                       help="--plot: the strain itself and the crests' fitted exp(-lambda x) "
                            "(thesis Fig. 2.6), instead of each snapshot over its peak (default: "
                            "off)")
        p.add_argument("--dx", type=float, default=0.005,
                       help="grid step, dimensionless (default %(default)g)")
        p.add_argument("--units", choices=("tau0", "alpha0"), default="tau0",
                       help="eq. 2.27's units as printed (tau0, Publication III's numbers) or "
                            "eq. 2.11's (alpha0) (default %(default)s)")
        p.add_argument("--t-m", metavar="T[,T...]", default="0.5",
                       help="bvp: the load's rise time t_m (default %(default)s)")
        p.add_argument("--alpha", type=float, default=3.0,
                       help="ivp: the sech's alpha (default %(default)g)")
    if mode == "hammer":
        p.add_argument("--velocity", default="2", metavar="V[,V...]",
                       help="the hammer's speed(s) in m/s (default %(default)s)")
        p.add_argument("--thickness-mm", type=float, metavar="MM",
                       help="the felt layer's thickness in mm (default: the key's, assumed)")
        p.add_argument("--area-mm2", type=float, metavar="MM2",
                       help="the felt column's cross-section in mm^2 (default 64, assumed)")
        p.add_argument("--cells", type=int, default=32, metavar="N",
                       help="the layer's grid cells (default %(default)s)")
    p.add_argument("--json", action="store_true",
                   help="print JSON instead of a table (default: a table)")
    p.add_argument("--plot", metavar="OUT.png",
                   help="also draw a PNG (needs the [plots] extra; default: none)")


def add_arguments(parser) -> None:
    import argparse

    sub = parser.add_subparsers(dest="what", required=True, metavar="MODE",
                                parser_class=argparse.ArgumentParser)
    for mode in MODES:
        _add_mode(sub, mode, argparse.RawDescriptionHelpFormatter)


def unknown_options(args, extras) -> str | None:
    """The error for an option felt's mode does not take (None: argparse's own)."""
    mode = getattr(args, "what", None)
    if mode not in MODES:
        return None
    opt = next((e for e in extras if e.startswith("-")), extras[0])
    name = opt.split("=", 1)[0]
    users = [m for m, opts in OPTIONS.items() if name in opts or (name == "--felt" and
                                                                   "--preset" in opts)]
    where = f" (it is an option of: {', '.join(users)})" if users else ""
    return (f"felt {mode}: {name} is not an option of this mode{where}; see synth felt {mode} "
            f"--help")


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

    for name in _DESTS:                  # the options another mode has
        if not hasattr(args, name):
            setattr(args, name, None)
    if args.plot is not None:
        check_output(args.plot, "--plot")
        require_extra("plots", "--plot")
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
