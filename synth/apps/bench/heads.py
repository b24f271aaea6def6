"""The far end's loop filter of a string with second-order dispersion, split
into the head loop and passes of biquads, timed alone (CPU time, one core).

    NUMBA_NUM_THREADS=1 python tools/bench.py heads [--cpu-name {host,haswell,generic,all}]
                                                    [--n 600] [--reps 600] [--rounds 7]

For 1-8 biquads (after the loss filter and two first-order sections, as a
grand's string with one dispersion section), ns per sample of

* the lockstep form (``_lanes_head`` + ``_lanes_biquads``, four strings as
  the lanes of a vector: ns per four-lane sample) and the scalar form
  (``_head_sos`` + ``_biquads``);
* split the plain way (the head takes up to four biquads, the rest
  in passes of four), and as the kernels split them now (the head takes
  them all up to ``_LANES_HEAD_SOS`` / ``_HEAD_SOS``, else one, or with
  32 vector registers what passes of four leave; the rest
  in even passes of two to four: ``strings._far_lanes``,
  ``strings._far_filter``).

Each split computes the same operations in the same order; only the time
differs.  The minimum over ``--rounds`` interleaved rounds is printed (the
machine's other load only adds time).
"""

from __future__ import annotations

import argparse
import os
import sys
import time

if "numba" not in sys.modules:
    # one core; only before numba is imported (imported by a test, after numba
    # started its threads, a changed NUMBA_NUM_THREADS fails the next compile)
    os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from numba import njit  # noqa: E402

from synth.apps.bench import harness  # noqa: E402
from synth.kernels import strings as K  # noqa: E402
from synth.kernels.config import SERIAL_OPTS  # noqa: E402
from synth.kernels.lanes import splat4  # noqa: E402

_OPTS = dict(SERIAL_OPTS, cache=False)


@njit(**_OPTS)
def _passes(nb, j, even):
    left = nb - j
    if not even:
        return left if left < 4 else 4
    p = (left + 3) // 4
    return (left + p - 1) // p


@njit(**_OPTS)
def _lanes(h, nb, even, reps, X0, X1, X2, X3, buf, n, fpar, fst):
    for _ in range(reps):
        K._lanes_head(X0, X1, X2, X3, buf, n, fpar, fst, 0, 1, 2, 3, 3, 2, h, splat4(0.0))
        j = h
        while j < nb:
            c = _passes(nb, j, even)
            K._lanes_biquads(buf, n, fpar, fst, 0, 1, 2, 3, 3, j, c, splat4(0.0))
            j += c


@njit(**_OPTS)
def _scalar(h, nb, even, reps, xin, yo, n, st, fp):
    for _ in range(reps):
        K._head_sos(xin, yo, n, st, fp, 2, K.S_D0, K.S_APX, -0.3, 0.2, h)
        j = h
        while j < nb:
            c = _passes(nb, j, even)
            K._biquads(yo, n, st, fp, j, c)
            j += c


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--n", type=int, default=600, help="samples per chunk")
    ap.add_argument("--reps", type=int, default=600, help="chunks per timing")
    ap.add_argument("--rounds", type=int, default=7)
    harness.add_target_option(ap)
    a = ap.parse_args(argv)
    rc = harness.dispatch("heads", a.cpu_name, argv)
    if rc is not None:
        return rc
    print(harness.header())
    n, reps = a.n, a.reps
    rng = np.random.default_rng(1)
    X = [rng.standard_normal(n) * 1e-3 for _ in range(4)]
    buf = np.zeros(4 * n)
    fpar = np.zeros((4, K.F_NF))
    fst = np.zeros((4, K.S_NS))
    for f in (fpar,):
        f[:, K.F_B0] = f[:, K.F_B0T] = 0.999
        f[:, K.F_B0S] = 1 / 650
        f[:, K.F_A1] = -0.001
        f[:, K.F_ADISP] = -0.3
        f[:, K.F_ETA] = 0.2
        f[:, K.F_SOS:K.F_SOS + 2 * K.MAX_SOS:2] = -1.5     # stable allpass biquads
        f[:, K.F_SOS + 1:K.F_SOS + 2 * K.MAX_SOS:2] = 0.6
    xin, yo, st, fp = X[0], np.zeros(n), np.zeros(K.S_NS), fpar[0].copy()

    def run(kind, h, nb, even, r):
        if kind == "lanes":
            _lanes(h, nb, even, r, X[0], X[1], X[2], X[3], buf, n, fpar, fst)
        else:
            _scalar(h, nb, even, r, xin, yo, n, st, fp)

    print(f"\nns per sample (lockstep: per four-lane sample), min of {a.rounds} rounds, "
          f"chunks of {n}")
    print("| biquads | lockstep before | lockstep now | now / before | scalar before | "
          "scalar now | now / before |")
    print("|---|---|---|---|---|---|---|")
    for nb in range(1, 9):
        plans = {
            ("lanes", 0): (min(nb, 4), False),
            ("lanes", 1): (nb if nb <= K._LANES_HEAD_SOS else
                           ((nb - 1) % 4 + 1 if K.VECTOR_REGS >= 32 else 1), True),
            ("scalar", 0): (min(nb, 4), False),
            ("scalar", 1): (nb if nb <= K._HEAD_SOS else
                            ((nb - 1) % 4 + 1 if K.VECTOR_REGS >= 32 else 1), True),
        }
        for (kind, _), (h, even) in plans.items():
            run(kind, h, nb, even, 1)                       # compile
        res = {k: [] for k in plans}
        for _ in range(a.rounds):
            for k, (h, even) in plans.items():
                t = time.process_time()
                run(k[0], h, nb, even, reps)
                res[k].append((time.process_time() - t) / (reps * n) * 1e9)
        m = {k: min(v) for k, v in res.items()}
        print(f"| {nb} | {m['lanes', 0]:.2f} | {m['lanes', 1]:.2f} | "
              f"{m['lanes', 1] / m['lanes', 0]:.2f} | {m['scalar', 0]:.2f} | "
              f"{m['scalar', 1]:.2f} | {m['scalar', 1] / m['scalar', 0]:.2f} |")
    return 0
