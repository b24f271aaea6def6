"""`synth help`: the user guides (the repository's docs/*.md), which a wheel
carries as package data in synth/docs (copied there by setup.py's build
step); in a source checkout (an editable install) they are read from docs/."""

from __future__ import annotations

import os
import sys
from pathlib import Path

from .common import fail

NAME = "help"
HELP = "print a user guide shipped with synth (e.g. quality, midi, presets); without TOPIC, list them"
EPILOG = ("examples:\n"
          "  synth help                 # the guides and their titles\n"
          "  synth help quality         # the quality levels: each one's error and cost\n"
          "  synth help midi | less     # what synth render and synth play do with MIDI")

#: the guides the commands' --help texts cite as ``synth help TOPIC``
#: (tests/test_cli_safety.py checks each is shipped)
CITED = ("analyze", "batch", "check", "drone", "felt", "midi", "presets", "quality",
         "reproduction")


def docs_dir() -> Path:
    """Where the guides are: the installed package's synth/docs (a wheel),
    else the checkout's docs/ beside the package (an editable install)."""
    import importlib.resources

    res = importlib.resources.files("synth").joinpath("docs")
    if res.is_dir():
        return Path(str(res))
    return Path(__file__).resolve().parents[2] / "docs"


def topics() -> dict[str, Path]:
    """Guide name -> its Markdown file."""
    d = docs_dir()
    return {p.stem: p for p in sorted(d.glob("*.md"))} if d.is_dir() else {}


def add_arguments(parser) -> None:
    parser.add_argument("topic", nargs="?", metavar="TOPIC",
                        help="the guide to print, e.g. quality (default: list the guides)")


def run(args) -> int:
    found = topics()
    if not found:
        fail(f"no user guides found (looked in {docs_dir()}): this install lacks synth/docs")
    if args.topic is None:
        w = max(len(n) for n in found)
        for name, path in found.items():
            title = path.read_text("utf-8").splitlines()[0].lstrip("# ").strip()
            print(f"{name:<{w}}  {title}")
        return 0
    topic = args.topic.removesuffix(".md").removeprefix("docs" + os.sep).removeprefix("docs/")
    if topic not in found:
        fail(f"TOPIC = {args.topic!r} is not a guide (choices: {', '.join(found)})")
    sys.stdout.write(found[topic].read_text("utf-8"))
    return 0
