"""`synth reproduce`: the thesis's results reproduced, as Markdown
(the guide ``synth help reproduction``; synth.apps.reproduce)."""

from __future__ import annotations

import argparse

from .common import fail, require_extra

NAME = "reproduce"
HELP = "reproduce the thesis's numbers and print them as Markdown (synth help reproduction)"

#: the parts and their one-line help
PARTS = {
    "thesis": "Publications I-II: the jawari cases, the biwa's sawari, the A7 hammer (about 20 s)",
    "felt": "chapter 2: deformation waves in hammer felt, with its checks (about 40 s)",
    "felt-study": "the A7 strike with the felt-layer hammer against the lumped law (synth help felt)",
}
#: the options each part takes
OPTIONS = {"thesis": ("--energy",), "felt": ("--png", "--quick"),
           "felt-study": ("--quick", "--repeats")}

EPILOG = ("parts:\n" + "".join(f"  {p:<11} {h}\n" for p, h in PARTS.items())
          + "\nexamples:\n"
          "  synth reproduce                       # the thesis's tables (the part 'thesis')\n"
          "  synth reproduce --energy              # the grid energy, step by step\n"
          "  synth reproduce felt --png figures    # chapter 2, and its figures felt-*.png\n"
          "  synth reproduce felt-study --quick    # the felt layer's checks on coarse settings\n"
          "\nA part whose checks against the thesis fail exits with status 1.")


def add_arguments(parser) -> None:
    parser.add_argument("part", nargs="?", default="thesis", choices=tuple(PARTS),
                        metavar="PART", help=f"what to reproduce: {', '.join(PARTS)} "
                                             "(default thesis)")
    parser.add_argument("--energy", action="store_true",
                        help="thesis: only the grid energy, step by step after the pluck (default: "
                             "off, the whole reproduction)")
    parser.add_argument("--png", metavar="DIR",
                        help="felt: also draw the figures into DIR (felt-*.png; default: none drawn)")
    parser.add_argument("--quick", action="store_true",
                        help="felt: pulses on a grid twice as coarse; felt-study: the checks "
                             "only, on coarse settings (default: off, the full settings)")
    parser.add_argument("--repeats", type=int, default=None,
                        help="felt-study: runs per cost figure, their median (default 3)")


def _given(args) -> list[str]:
    out = []
    if args.energy:
        out.append("--energy")
    if args.png is not None:
        out.append("--png")
    if args.quick:
        out.append("--quick")
    if args.repeats is not None:
        out.append("--repeats")
    return out


def _run_felt(argv) -> int:
    """``synth felt ...`` (``argv[0] == "felt"``) in this process: the
    commands the chapter 2 rows cite, whose JSON they read."""
    from . import felt

    if not argv or argv[0] != "felt":
        raise ValueError(f"argv = {argv!r}: only synth felt commands run here")
    parser = argparse.ArgumentParser(prog="synth felt")
    felt.add_arguments(parser)
    return felt.run(parser.parse_args(argv[1:]))


def run(args: argparse.Namespace) -> int:
    for opt in _given(args):
        if opt not in OPTIONS[args.part]:
            takes = [p for p, o in OPTIONS.items() if opt in o]
            fail(f"{opt}: the part {args.part!r} does not take it (only {', '.join(takes)})")
    if args.part == "thesis":
        from ..apps.reproduce import thesis

        return thesis.run(energy=args.energy)
    if args.part == "felt":
        if args.png is not None:
            require_extra("plots", "synth reproduce felt --png")
        from ..apps.reproduce import felt

        return felt.run(_run_felt, png=args.png, quick=args.quick)
    repeats = 3 if args.repeats is None else args.repeats
    if not 1 <= repeats <= 100:
        fail(f"--repeats = {repeats} is out of range (1 <= value <= 100)")
    from ..apps.reproduce import felt_study

    return felt_study.run(quick=args.quick, repeats=repeats)
