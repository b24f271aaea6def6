"""`synth check`: spectrum tests of spec files (synth.apps.check)."""

from __future__ import annotations

import sys

from .common import add_threads, check_not_inputs, check_output, fail

NAME = "check"
HELP = ("spectrum tests: render what SPEC.toml names and check its "
        "expectations (exit 1 if one fails)")
EPILOG = ("examples:\n"
          "  synth check mine.toml                   # the tests of one spec file\n"
          "  synth check --shipped --junit out.xml   # the shipped specs, and JUnit XML for CI\n"
          "\n"
          "The spec format: synth help check.")


def add_arguments(parser) -> None:
    parser.add_argument("spec", nargs="*", metavar="SPEC.toml",
                        help="spec files (TOML; the format: synth help check)")
    parser.add_argument("--shipped", action="store_true",
                        help="also run the specs shipped with the presets (synth/presets/checks; "
                             "default: off)")
    parser.add_argument("--junit", metavar="OUT.xml",
                        help="also write the results as JUnit XML (default: none)")
    parser.add_argument("--jobs", type=int, metavar="N",
                        help="specs checked at once, each in its own process on its share of "
                             "the threads (default: one per core, at most one per spec); the "
                             "results are the same for any N")
    add_threads(parser)


def run(args) -> int:
    from ..apps.check import check_jobs, format_table, run_specs, write_junit
    from ..io.presets import shipped_checks_dir

    specs = list(args.spec)
    if args.shipped:
        specs += sorted(str(p) for p in shipped_checks_dir().glob("*.toml"))
    if not specs:
        fail("check: give one or more SPEC.toml files, or --shipped")
    if args.junit is not None:
        check_output(args.junit, "--junit")
        check_not_inputs([("--junit", args.junit)], [("spec", p) for p in specs])
    from ..dsp.threads import available_cores

    if args.jobs is None:
        jobs = min(available_cores(), len(specs))
    else:
        try:
            jobs = check_jobs(args.jobs, "--jobs")
        except ValueError as e:
            fail(f"check: {e}")
    results = run_specs(specs, jobs, args.threads,
                        progress=lambda line: print(line, file=sys.stderr))
    print(format_table(results))
    if args.junit is not None:
        write_junit(args.junit, results)
        print(f"{args.junit}: JUnit XML, {len(results)} test cases")
    return 1 if any(not r.passed for r in results) else 0
