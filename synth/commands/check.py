"""`synth check`: spectrum tests of spec files (synth.apps.check)."""

from __future__ import annotations

import sys

from .common import add_threads, check_output, fail

NAME = "check"
HELP = ("spectrum tests: render what SPEC.toml names and check its "
        "expectations (exit 1 if one fails)")


def add_arguments(parser) -> None:
    parser.add_argument("spec", nargs="*", help="spec files (TOML, docs/check.md)")
    parser.add_argument("--shipped", action="store_true",
                        help="also run the specs shipped with the presets (synth/presets/checks)")
    parser.add_argument("--junit", metavar="OUT.xml", help="also write the results as JUnit XML")
    add_threads(parser)


def run(args) -> int:
    from ..apps.check import format_table, run_spec, write_junit
    from ..io.presets import shipped_checks_dir

    specs = list(args.spec)
    if args.shipped:
        specs += sorted(str(p) for p in shipped_checks_dir().glob("*.toml"))
    if not specs:
        fail("check: give one or more SPEC.toml files, or --shipped")
    if args.junit is not None:
        check_output(args.junit, "--junit")
    results = []
    for path in specs:
        results += run_spec(path, progress=lambda line: print(line, file=sys.stderr))
    print(format_table(results))
    if args.junit is not None:
        write_junit(args.junit, results)
        print(f"{args.junit}: JUnit XML, {len(results)} test cases")
    return 1 if any(not r.passed for r in results) else 0
