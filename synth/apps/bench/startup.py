"""Start-up time of live play: import, build and warm the engine
(:func:`synth.io.live.ready_engine`, what ``synth play`` does before the
stream opens), in a fresh process, with a cold and then a warm numba cache.

    python tools/bench.py startup [--presets sitar,grand-piano]

The cold run uses an empty ``NUMBA_CACHE_DIR`` (every kernel compiles); the
warm run repeats it with that cache filled.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time

CHILD = """
import sys, time
t = time.perf_counter()
from synth.io.live import ready_engine
ready_engine(sys.argv[1])
print(f"{time.perf_counter() - t:.3f}")
"""


def run(preset: str, cache_dir: str) -> float:
    env = dict(os.environ, NUMBA_CACHE_DIR=cache_dir)
    p = subprocess.run([sys.executable, "-c", CHILD, preset], env=env, capture_output=True,
                       text=True, check=True)
    return float(p.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--presets", default="sitar,grand-piano")
    a = ap.parse_args(argv)
    print(f"# {time.strftime('%Y-%m-%d %H:%M')}  python {' '.join(sys.argv)}")
    print("| preset | cold numba cache (s) | warm (s) |")
    print("|---|---|---|")
    for preset in a.presets.split(","):
        with tempfile.TemporaryDirectory() as d:
            cold = run(preset, d)
            warm = run(preset, d)
        print(f"| {preset} | {cold:.2f} | {warm:.2f} |", flush=True)
    return 0
