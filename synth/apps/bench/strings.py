"""Timing of the waveguide string bank kernel, per string-sample.

Usage:  NUMBA_NUM_THREADS=1 python tools/bench.py strings [--runs 7]
            [--banks 1,64,256] [--work 1e7] [--slow-work 2e6] [--seconds-warm 0.01]
            [--cpu-name {host,haswell,generic,all}]

For banks of 1, 64 and 256 identical strings (sitar-like: L = 0.8 m,
N = 812 cells, fs = 324800 Hz; the musical string is tuned to 200 Hz at
325 kHz), plucked (sitar g, A = 1 cm, t0 = 4 ms, at k = 3N/4), the bank is
first rendered for ``--seconds-warm`` (>= 0.01 s, so the pluck has ended and
every string is in its free-vibration state), then timed over ``--runs``
repetitions.  Each repetition renders about ``--work`` string-samples (so
``work / bank`` samples; ``--slow-work`` for the per-sample and naive cases) through :meth:`StringBank.render` in engine-sized
segments (6933 internal samples = one 1024-sample output block at 48 kHz,
split by the bank into pieces of at most ``max_block`` = 4096).  Printed:
the median ns per string-sample (min and max of the repetitions in
brackets).

Cases
-----
lossless           ideal string, rigid ends, no termination region
lossless+J2/25     ideal string + jawari Case 2 (eq. 1.15, continuous), 25 points
lossless+J1/25     ideal string + jawari Case 1 (eq. 1.14), 25 points, 15 finite
musical            tune_loop(200 Hz, 325 kHz, T60 7 s @ 200 Hz, 1.2 s @ 6 kHz):
                   one-pole loss + allpass (+ unit delay) at x = L, bridge-force output
musical+J2/32      the same with a 32-point jawari Case 2 region
per-sample+J2/25   lossless+J2/25 forced through the per-sample reference path
naive+J2/25        Publication II's scheme: two rails shifted by copying every
                   sample (``naive_bank`` below), same string and region
naive/none         the naive scheme without a region

The naive scheme is checked against the bank (same pluck, u at k over
0.02 s) before timing; the largest difference is printed.

Everything runs on one core: NUMBA_NUM_THREADS is set to 1 before numba is
imported and the process is pinned to one CPU.

``--cpu-name`` picks numba's code-generation target (:mod:`synth.apps.bench.harness`:
host, haswell = AVX2 only, generic = SSE2, or all three in turn); the header
names the CPU and the target in effect.
"""

from __future__ import annotations

import os
import sys

if "numba" not in sys.modules:
    # one core; only before numba is imported (imported by a test, after numba
    # started its threads, a changed NUMBA_NUM_THREADS fails the next compile)
    os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import argparse  # noqa: E402
import datetime  # noqa: E402
import shlex  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
from numba import njit  # noqa: E402

from synth.apps.bench import harness  # noqa: E402

from synth.kernels import strings as K  # noqa: E402
from synth.kernels.config import FASTMATH  # noqa: E402
from synth.physics.losses import tune_loop  # noqa: E402
from synth.physics.profiles import Termination, jawari_case1, jawari_case2  # noqa: E402
from synth.dsp import sizing  # noqa: E402
from synth.dsp.bank import StringBank  # noqa: E402

# ---- the string of the benchmark --------------------------------------------
L_M = 0.8                 # string length (m)
N_IDEAL = 812             # cells of the lossless string
FS_IDEAL = 324800.0       # its rate (Hz), dt = 1 / fs: 2N samples per round trip = 200 Hz
K_IDEAL = 609             # 3N/4
PLUCK_A_M = 0.01          # sitar pluck amplitude (m)
PLUCK_T0_S = 0.004        # sitar pluck duration (s)
FS_MUSICAL = 325000.0
TENSION_N = 38.4          # for the bridge-force scale T / dx
SEG = 6933                # internal samples per 1024-sample output block at 48 kHz
MAX_BLOCK = 4096          # as the engine's bank


def jawari2(points: int, dx_m: float) -> np.ndarray:
    """Case 2 profile (k = 0.008, x_b = 10 mm, R = 10 mm) at points 1..points."""
    return Termination(jawari_case2(0.008, 0.010, 0.010), 1, points).sample(dx_m)


def jawari1(points: int, dx_m: float) -> np.ndarray:
    """Case 1 profile (k = 0.008, x_c = 15 mm) at points 1..points."""
    return Termination(jawari_case1(0.008, 0.015), 1, points).sample(dx_m)


# ---- Publication II's naive scheme --------------------------------------------
@njit(nogil=True, fastmath=FASTMATH)
def naive_bank(ur, ul, U, R, k, m0, n, dt, A, t0, out):
    """Render n samples of every string in ur/ul (shape (S, N+1)) with the
    shift-every-array scheme, accumulating u(k) into out[0:n].

    Per sample and string: shift ur right and ul left by copying, reflect
    ul[N] = -ur[N] and ur[0] = -ul[0], add the sitar g(t) (t = (m0 + i) dt)
    at k to both rails, clamp points 1..R (u = ur + ul; if u > U: ur += U - u)
    and output u(k) = ur[k] + ul[k] - g.  Returns the next time index.
    """
    S = ur.shape[0]
    N = ur.shape[1] - 1
    for s in range(S):
        r = ur[s]
        l = ul[s]
        for i in range(n):
            t = (m0 + i) * dt
            if t > t0:
                g = A
            else:
                q = t / t0
                g = A * q * q * np.exp(2.0 * (1.0 - q))
            for j in range(N, 0, -1):
                r[j] = r[j - 1]
            for j in range(N):
                l[j] = l[j + 1]
            l[N] = -r[N]
            r[0] = -l[0]
            r[k] += g
            l[k] += g
            for j in range(1, R + 1):
                u = r[j] + l[j]
                if u > U[j - 1]:
                    r[j] += U[j - 1] - u
            out[i] += r[k] + l[k] - g
    return m0 + n


class Naive:
    """S copies of the naive string, state kept between calls."""

    def __init__(self, S, N, k, dt, U):
        self.ur = np.zeros((S, N + 1))
        self.ul = np.zeros((S, N + 1))
        self.U = np.zeros(1) if U is None else np.ascontiguousarray(U, float)
        self.R = 0 if U is None else len(U)
        self.k, self.dt, self.m = k, dt, 0

    def render(self, out, n):
        self.m = naive_bank(self.ur, self.ul, self.U, self.R, self.k, self.m, n,
                            self.dt, PLUCK_A_M, PLUCK_T0_S, out)


# ---- bank set-ups ---------------------------------------------------------------
def make_bank(S, case):
    """A plucked bank of S identical strings for ``case`` (see module doc)."""
    if case.startswith("musical"):
        tl = tune_loop(200.0, FS_MUSICAL, 7.0, 200.0, 1.2, 6000.0)
        N = tl.cells
        k = int(round(0.75 * N))
        dx = L_M / N
        U = jawari2(32, dx) if case.endswith("J2/32") else None
        b = StringBank(S, N, 64, MAX_BLOCK)
        for s in range(S):
            b.configure(s, cells=N, k=k, dt_s=1.0 / FS_MUSICAL, U=U, lossy=True,
                        b0=tl.b0, a1=tl.a1, eta=tl.eta, extra_delay=tl.extra_delay,
                        out_mode=1, tension_over_dx=TENSION_N / dx, gain=1e-3)
            b.activate(s)
            b.start_pluck(s, 1, PLUCK_A_M, PLUCK_T0_S)
        return b, FS_MUSICAL
    dx = L_M / N_IDEAL
    U = {"lossless": None,
         "lossless+J2/25": jawari2(25, dx),
         "lossless+J1/25": jawari1(25, dx),
         "per-sample+J2/25": jawari2(25, dx)}[case]
    b = StringBank(S, N_IDEAL, 64, MAX_BLOCK)
    for s in range(S):
        b.configure(s, cells=N_IDEAL, k=K_IDEAL, dt_s=1.0 / FS_IDEAL, U=U,
                    force_per_sample=case.startswith("per-sample"))
        b.activate(s)
        b.start_pluck(s, 1, PLUCK_A_M, PLUCK_T0_S)
    return b, FS_IDEAL


def make_naive(S, case):
    dx = L_M / N_IDEAL
    U = jawari2(25, dx) if case == "naive+J2/25" else None
    return Naive(S, N_IDEAL, K_IDEAL, 1.0 / FS_IDEAL, U), FS_IDEAL


def run_segments(obj, mix, n):
    """Render n samples in engine-sized segments (accumulating into mix)."""
    done = 0
    while done < n:
        c = min(SEG, n - done)
        if isinstance(obj, StringBank):
            obj.render(mix, 0, c)
        else:
            obj.render(mix, c)
        done += c


def time_case(S, case, runs, work, slow_work, warm_s):
    """Median, min, max ns per string-sample of ``case`` for a bank of S."""
    naive = case.startswith("naive")
    obj, fs = make_naive(S, case) if naive else make_bank(S, case)
    mix = np.zeros(SEG)
    run_segments(obj, mix, int(np.ceil(warm_s * fs)))
    slow = naive or case.startswith("per-sample")
    n = max(SEG, int(round((slow_work if slow else work) / S)))
    ts = []
    for _ in range(runs):
        t = time.perf_counter()
        run_segments(obj, mix, n)
        ts.append(time.perf_counter() - t)
    if not np.all(np.isfinite(mix)):
        raise RuntimeError(f"case {case}: non-finite output")
    ns = np.array(ts) / (S * n) * 1e9
    return float(np.median(ns)), float(ns.min()), float(ns.max()), n


def check_naive_matches():
    """Largest |u_naive(k) - u_bank(k)| (m) over 0.02 s, jawari Case 2."""
    n = int(0.02 * FS_IDEAL)
    b, _ = make_bank(1, "lossless+J2/25")
    a = np.zeros(n)
    b.render(a, 0, n)
    nv, _ = make_naive(1, "naive+J2/25")
    c = np.zeros(n)
    nv.render(c, n)
    return float(np.max(np.abs(a - c))), float(np.max(np.abs(a)))


def dispatch_overhead_us(reps=2000):
    """Cost (us) of one StringBank.render call that renders nothing."""
    b = StringBank(1, 64, 1, MAX_BLOCK)
    mix = np.zeros(SEG)
    b.render(mix, 0, 64)
    t = time.perf_counter()
    for _ in range(reps):
        b.render(mix, 0, 64)
    return (time.perf_counter() - t) / reps * 1e6


CASES = ["lossless", "lossless+J2/25", "lossless+J1/25", "musical", "musical+J2/32",
         "per-sample+J2/25", "naive+J2/25", "naive/none"]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=7)
    ap.add_argument("--banks", default="1,64,256")
    ap.add_argument("--work", type=float, default=1e7,
                    help="string-samples per timed repetition (fast path)")
    ap.add_argument("--slow-work", type=float, default=2e6,
                    help="string-samples per timed repetition (per-sample path, naive scheme)")
    ap.add_argument("--seconds-warm", type=float, default=0.01)
    harness.add_target_option(ap)
    a = ap.parse_args(argv)
    if a.runs < 1:
        raise ValueError(f"--runs = {a.runs} is out of range (>= 1)")
    if a.seconds_warm < 0.01:
        raise ValueError(f"--seconds-warm = {a.seconds_warm} is out of range (>= 0.01; the pluck lasts 4 ms)")
    rc = harness.dispatch("strings", a.cpu_name, argv)
    if rc is not None:
        return rc
    banks = [int(x) for x in a.banks.split(",")]
    try:
        cpu = sorted(os.sched_getaffinity(0))[0]
        os.sched_setaffinity(0, {cpu})
        pinned = f"pinned to CPU {cpu}"
    except (AttributeError, OSError):
        pinned = "not pinned"
    cmd = (f"NUMBA_NUM_THREADS={os.environ['NUMBA_NUM_THREADS']} "
           + " ".join(shlex.quote(x) for x in [os.path.basename(sys.executable)] + sys.argv))
    print(f"# string bank benchmark  {datetime.datetime.now().isoformat(timespec='seconds')}")
    print(f"# command : {cmd}")
    print(harness.header())
    print(f"# process : {pinned}")
    print(f"# runs={a.runs} (median [min..max] ns per string-sample), work={a.work:g} "
          f"string-samples/rep (per-sample and naive {a.slow_work:g}), warm-up {a.seconds_warm} s, "
          f"segments of {SEG} samples, max_block {MAX_BLOCK}")
    tl = tune_loop(200.0, FS_MUSICAL, 7.0, 200.0, 1.2, 6000.0)
    print(f"# lossless: N={N_IDEAL}, k={K_IDEAL}, fs={FS_IDEAL:g}, fast chunk "
          f"{sizing.max_fast_chunk(N_IDEAL, K_IDEAL, 25, 0)} (R=25) / "
          f"{sizing.max_fast_chunk(N_IDEAL, K_IDEAL, 0, 0)} (R=0); musical: N={tl.cells}, "
          f"k={round(0.75 * tl.cells)}, b0={tl.b0:.4f}, a1={tl.a1:.4f}, eta={tl.eta:.4f}, "
          f"extra_delay={tl.extra_delay}, fast chunk "
          f"{sizing.max_fast_chunk(tl.cells, round(0.75 * tl.cells), 32, 1)} (R=32) "
          "while plucking, "
          f"{sizing.max_free_chunk(tl.cells, round(0.75 * tl.cells), 32, 1)} after")
    t = time.perf_counter()
    err, amp = check_naive_matches()   # also compiles both
    print(f"# naive vs bank, u(k) over 0.02 s with jawari Case 2: max |diff| = {err:.3g} m "
          f"(max |u| = {amp:.3g} m); compile+check {time.perf_counter() - t:.1f} s")
    print(f"# StringBank.render dispatch overhead: {dispatch_overhead_us():.2f} us per call "
          f"(included below; matters only for the 1-string bank)")
    print()
    res = {}
    w = max(len(c) for c in CASES)
    print(f"{'case':<{w}}  " + "  ".join(f"{'bank ' + str(S):>24}" for S in banks))
    for case in CASES:
        cells = []
        for S in banks:
            med, lo, hi, _ = time_case(S, case, a.runs, a.work, a.slow_work, a.seconds_warm)
            res[case, S] = med
            cells.append(f"{med:8.2f} [{lo:6.2f}..{hi:6.2f}]")
        print(f"{case:<{w}}  " + "  ".join(f"{c:>24}" for c in cells), flush=True)
    print()
    print("real-time voices on one core at 325 kHz (1 / (ns * 325000e-9)):")
    for case in ("lossless+J2/25", "lossless+J1/25", "musical+J2/32", "musical", "lossless"):
        print(f"  {case:<{w}}  " + "  ".join(
            f"bank {S}: {1.0 / (res[case, S] * 325000e-9):7.0f}" for S in banks))
    print("naive / fast, same run:")
    for nv, fast in (("naive+J2/25", "lossless+J2/25"), ("naive/none", "lossless"),
                     ("per-sample+J2/25", "lossless+J2/25")):
        print(f"  {nv:<{w}} / {fast:<{w}}  " + "  ".join(
            f"bank {S}: {res[nv, S] / res[fast, S]:6.1f}x" for S in banks))
    print("targets: lossless <= 4 ns, lossless + 25-point jawari <= 10 ns")
    for case, target in (("lossless", 4.0), ("lossless+J2/25", 10.0), ("lossless+J1/25", 10.0)):
        for S in banks:
            ok = "met" if res[case, S] <= target else "MISSED"
            print(f"  {case:<{w}} bank {S:>3}: {res[case, S]:6.2f} ns  {ok}")
    return 0
