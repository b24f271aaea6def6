"""``python -m synth.apps.bench NAME ...`` (as ``python tools/bench.py NAME ...``)."""

import sys

from synth.apps.bench import main

sys.exit(main())
