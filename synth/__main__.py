"""``python -m synth``: the ``synth`` command (synth.cli)."""

import sys

from .cli import main

if __name__ == "__main__":
    sys.exit(main())
