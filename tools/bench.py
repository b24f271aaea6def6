"""Every benchmark, on one harness: ``python tools/bench.py NAME [options]``.

``python tools/bench.py`` lists them; ``NAME --help`` gives a benchmark's
options.  The benchmarks live in :mod:`synth.apps.bench` (the harness:
:mod:`synth.apps.bench.harness`); docs/benchmarks.md gives each command and
its latest figures.
"""

import sys

from synth.apps.bench import main
from synth.cli import main as synth_main  # for `bench.py compile` (argparse-level imports only)

if __name__ == "__main__":
    sys.exit(main(synth_main=synth_main))
