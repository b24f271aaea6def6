"""`synth presets`: the presets found, one line each, or (--reference) every key
a preset file may hold, as Markdown."""

from __future__ import annotations

import sys

from .common import fail

NAME = "presets"
HELP = "list presets with a one-line description"
EPILOG = ("examples:\n"
          "  synth presets                          # name and description of each preset found\n"
          "  synth presets --reference > keys.md    # every key a preset file may hold\n"
          "\n"
          "Presets are looked for in the folders of $SYNTH_PRESET_PATH (separated by\n"
          "the system's path separator), then among the shipped ones.")


def add_arguments(parser) -> None:
    parser.add_argument("--reference", action="store_true",
                        help="instead: print every key a preset file may hold (meaning, unit, type, "
                             "range, default, when it applies) as Markdown, the text of `synth help "
                             "presets` (default: off, the list)")


def run(args) -> int:
    from ..io.presets import ENV_PRESET_PATH, list_presets, preset_dirs

    if getattr(args, "reference", False):
        from ..io.presets.reference import reference_markdown

        sys.stdout.write(reference_markdown())
        return 0
    items = list_presets()
    if not items:
        # an install without its package data, or an empty SYNTH_PRESET_PATH
        # directory and no shipped presets: say so, do not list nothing and succeed
        where = ", ".join(str(d) for d in preset_dirs())
        fail(f"no presets found (looked in: {where}; add directories with ${ENV_PRESET_PATH})")
    w = max((len(n) for n, _ in items), default=0)
    for name, desc in items:
        print(f"{name:<{w}}  {desc}")
    return 0
