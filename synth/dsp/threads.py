"""How many threads the string bank renders on.

The threads are numba's (its OpenMP threading layer: see
:func:`synth.kernels.config.prefer_openmp`), started once per process and
shared by every bank; the kernels run their ``prange`` loops on them
(:mod:`synth.kernels.render`).  numba's thread count is a per-thread
setting of the *calling* thread (the one that renders: the main thread
offline, the audio server's thread live), so a bank sets it before each
render from that thread (:func:`enter`, a look-up when nothing changes).

The samples do not depend on the thread count (``tests/test_threads.py``).
"""

from __future__ import annotations

import os
import threading
import warnings

#: environment variable giving the default thread count
ENV = "SYNTH_THREADS"
#: environment variable turning the offline and live governor of threads off
GOVERNOR_ENV = "SYNTH_GOVERNOR"

_local = threading.local()
_default: int | None = None
_layer_checked = False
_layer_ok = True
_prime = False


def available_cores() -> int:
    """Cores this process may run on (its CPU affinity; ``os.cpu_count``
    where the platform has no affinity)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def max_threads() -> int:
    """The most threads a bank may use: numba's pool size
    (``NUMBA_NUM_THREADS``, fixed when numba is imported; by default the
    machine's cores)."""
    from numba.core import config as nbconfig

    return max(1, int(nbconfig.NUMBA_NUM_THREADS))


def check_threads(threads, name: str = "threads") -> int:
    """``threads`` as an int in 1 .. :func:`max_threads`, or ValueError
    naming ``name``, the value and the range."""
    hi = max_threads()
    try:
        n = int(threads)
        if n != threads and not isinstance(threads, str):
            raise ValueError
    except (TypeError, ValueError):
        raise ValueError(f"{name} = {threads!r} is not an integer (1 <= value <= {hi})") from None
    if not 1 <= n <= hi:
        extra = "" if hi > 1 else "; NUMBA_NUM_THREADS limits it"
        raise ValueError(f"{name} = {n} is out of range (1 <= value <= {hi}, this machine's "
                         f"threads{extra})")
    return n


def set_default(threads: int | None) -> None:
    """Set the process's default thread count (what :func:`default_threads`
    gives; the command line's ``--threads``), checked; None: back to
    ``SYNTH_THREADS`` or every core."""
    global _default
    _default = None if threads is None else check_threads(threads, "--threads")


def default_threads() -> int:
    """The count :func:`set_default` set, else ``SYNTH_THREADS`` if set
    (checked), else every core this process may use (at most
    :func:`max_threads`)."""
    if _default is not None:
        return _default
    v = os.environ.get(ENV)
    if v is not None and v.strip() != "":
        return check_threads(v.strip(), ENV)
    return min(available_cores(), max_threads())


def resolve(threads: int | None) -> int:
    """``threads`` checked, or :func:`default_threads` for None."""
    return default_threads() if threads is None else check_threads(threads)


def set_priming(on: bool) -> None:
    """Whether :func:`enter` creates a rendering thread's OpenMP team at
    its first call (live play, :func:`synth.io.live.ready_engine`: the
    audio thread's team exists before the first big chord needs it).  Off
    by default: offline, the team starts with the first loop that runs in
    parallel, and a render that never runs one (a note: less work than
    :data:`synth.kernels.render.PAR_MIN_WORK`) neither loads the priming
    kernel nor starts the team."""
    global _prime
    _prime = bool(on)


def enter(n: int, prime: bool | None = None) -> int:
    """Make numba run ``prange`` loops launched from this thread on ``n``
    threads (numba's setting is per calling thread); with ``prime`` (None:
    as :func:`set_priming` says) the first call in a thread also creates
    its team of worker threads (:func:`synth.kernels.render.prime_threads`).
    Returns the count to render with: ``n``, or 1 if numba's threading
    layer turned out to be its workqueue (which costs 130 us a loop and
    aborts when two threads launch loops at once: warned once)."""
    if n <= 1 or not _layer_ok:
        return 1
    prime = _prime if prime is None else prime
    if getattr(_local, "n", 0) != n or (prime and not getattr(_local, "primed", False)):
        import numba

        numba.set_num_threads(n)
        _check_layer()
        if not _layer_ok:
            return 1
        if prime and not getattr(_local, "primed", False):
            # this thread's first loop creates its OpenMP team (~0.1 ms):
            # now, not at the first big chord
            import numpy as np

            from ..kernels.render import prime_threads

            prime_threads(n, np.zeros(n, dtype=np.int64))
            _local.primed = True
        _local.n = n
    return n


def _check_layer() -> None:
    global _layer_checked, _layer_ok
    if _layer_checked:
        return
    _layer_checked = True
    import numba

    try:
        layer = numba.threading_layer()
    except ValueError:
        return
    if layer == "workqueue":
        _layer_ok = False
        warnings.warn("numba found no OpenMP or TBB threading layer (install libgomp1, or "
                      "'pip install tbb'): rendering on one thread", RuntimeWarning, stacklevel=3)


class Governor:
    """Decides, call by call, whether a bank's kernel that could run its
    loops on several threads runs them on ``nt`` or on the calling thread
    alone, by timing both: a render on a machine whose other cores are busy
    (another program, a second render, a CI job) otherwise waits at every
    parallel loop for a worker thread the scheduler has not run yet.

    The samples are the same for any thread count (``tests/test_threads.py``),
    so the choice changes only the time a block takes.  Measured (issue 37,
    2-vCPU Xeon, another job keeping both cores busy): a 10 s tanpura drone
    rendered in 1.16-1.99 s wall on 2 threads against 0.44 s on one.

    How it decides: each timed call gives seconds per unit of work (the
    caller's measure, strings x samples), and the last :attr:`keep` of each
    mode are kept (but the first of each mode in each class: :class:`_Class`).  The bank
    starts on its threads.  After one call, and then at most every
    :attr:`probe_calls` calls and
    :attr:`probe_s` seconds (doubled, up to 8 times, each time a probe keeps
    the mode), :attr:`burst` calls in a row run in the mode not in use (a
    probe).  It leaves its threads when their median
    exceeds :attr:`margin` times the calling thread's, and comes back when
    it falls below 1 / :attr:`margin` times: on a busy machine single timings
    of the threads scatter over a factor of ten, medians do not.  Live play
    (:attr:`realtime_dt_s`) probes the calling thread only where the call
    surely fits there.  Calls are timed and decided by size class
    (:meth:`size_class`: calls within a factor of two of each other in
    internal samples), each class with its own timings, mode and probes.

    Parameters
    ----------
    probe_calls : int
        Least number of calls between probes (>= 1).
    probe_s : float
        Least wall time between probes (s, >= 0): a live stream's 128-sample
        blocks would otherwise probe a stalled mode many times a second.
    margin : float
        Ratio (>= 1) of the medians at which the mode changes.
    clock : callable
        Returns seconds (``time.perf_counter``; tests give their own).
    """

    #: False: every call on the threads (the thread-count tests, which must
    #: run the parallel loops whatever the machine's load; ``SYNTH_GOVERNOR=off``
    #: in the environment, to measure the threads alone)
    auto = os.environ.get(GOVERNOR_ENV, "on").strip().lower() not in ("off", "0", "no")
    #: live play: the real-time budget of one internal sample (s, 1 / the
    #: internal rate; None: offline, no budget).  A probe of the calling
    #: thread is then made only for a call that would surely take at most
    #: :attr:`realtime_share` of its budget there: the threads' median time
    #: per unit times the call's units (:meth:`pick`) times the thread count
    #: (one thread is at most that much slower).  A heavy scene so stays on
    #: the threads; a light one (a drone, a few notes) moves to the calling
    #: thread when the machine's other cores are busy.  (With a half, the
    #: grand's 64-voice chords probed one thread, and on a quiet machine
    #: their live blocks went from 27 % / 102 % to 34 % / 120 % of the
    #: budget, mean / 99th percentile: tools/bench.py live.)
    realtime_dt_s = None
    #: the share of a call's real-time budget that one thread must surely fit
    realtime_share = 0.2
    #: timings kept per mode (the medians' samples)
    keep = 5
    #: calls in a row of a probe
    burst = 3

    def __init__(self, probe_calls: int = 32, probe_s: float = 0.5, margin: float = 1.05,
                 clock=None):
        import time

        if int(probe_calls) != probe_calls or probe_calls < 1:
            raise ValueError(f"probe_calls = {probe_calls!r} is out of range (integer >= 1)")
        if not probe_s >= 0:
            raise ValueError(f"probe_s = {probe_s!r} is out of range (>= 0 s)")
        if not margin >= 1:
            raise ValueError(f"margin = {margin!r} is out of range (>= 1)")
        self.probe_calls = int(probe_calls)
        self.probe_s = float(probe_s)
        self.margin = float(margin)
        self.clock = time.perf_counter if clock is None else clock
        #: the state of each size class of call (:meth:`size_class`)
        self._classes: dict[int, _Class] = {}
        self._cur = None                     # (the first class follows no call's mode)
        self._cur = self._class(0)

    @staticmethod
    def size_class(samples: int) -> int:
        """The class of a call of ``samples`` internal samples: calls within
        a factor of two of each other share one (``samples.bit_length()``;
        0 for a call whose size is not given).  A call's time per unit of
        work includes what it pays once (its parallel loops' launches, the
        bridge's head), so a short call gains less from the threads than a
        long one and may lose: a sitar's 32 note-ons 1 ms apart, calls of
        325 samples, ran faster on one thread, and with one set of timings
        the governor then kept the 4096-sample calls after them on one
        thread too, where the threads were 1.5x faster (a second of a 2 s
        render).  Each class is timed and decided apart."""
        return max(0, int(samples)).bit_length()

    def _class(self, c: int) -> "_Class":
        st = self._classes.get(c)
        if st is None:
            # a new class starts in the mode of the last call's (a machine
            # found busy stays on one thread until the class's probe)
            st = self._classes[c] = _Class(self.probe_calls, self.probe_s)
            if self._cur is not None:
                st.parallel = self._cur.parallel
        return st

    # the current class's state, as one governor's before the classes
    @property
    def parallel(self) -> bool:
        """Whether the threads are the mode in use (the last call's class)."""
        return self._cur.parallel

    @property
    def calls(self) -> list[int]:
        """Calls timed in each mode, every class: [calling thread, threads]."""
        return [sum(st.calls[0] for st in self._classes.values()),
                sum(st.calls[1] for st in self._classes.values())]

    def _fits_one_thread(self, st, nt: int, units: float, samples: int) -> bool:
        """Whether a call of ``units`` over ``samples`` internal samples
        surely fits :attr:`realtime_share` of its real-time budget on one
        thread (always true offline: :attr:`realtime_dt_s` None)."""
        dt = self.realtime_dt_s
        if dt is None:
            return True
        p = st.median(True)
        if p is None or samples <= 0:
            return False
        return p * units * nt <= self.realtime_share * samples * dt

    def pick(self, nt: int, units: float = 0.0, samples: int = 0) -> int:
        """Threads for the next call of a kernel given ``nt``: ``nt`` or 1.
        ``units``, ``samples``: the call's work and internal samples (what
        :meth:`record` will be given; the call's size class and live play's
        budget need them).  With ``nt`` 1 there is nothing to decide (1,
        nothing kept)."""
        if nt <= 1:
            return 1
        st = self._cur = self._class(self.size_class(samples))
        if not self.auto:
            st.mode = True
            return nt
        if st.probing == 0 and st.since >= self.probe_calls:
            now = self.clock()
            if ((st.last_probe is None or now - st.last_probe >= st.wait_s)
                    and (not st.parallel or self._fits_one_thread(st, nt, units, samples))):
                st.probing = self.burst
                st.since = 0
                st.last_probe = now
        par = st.parallel
        if st.probing > 0:
            par = not par
            st.probing -= 1
            st.judge = st.probing == 0
        else:
            st.since += 1
        st.mode = par
        return nt if par else 1

    def record(self, seconds: float, units: float) -> None:
        """Time of the call :meth:`pick` chose threads for (s), and its work
        (units > 0: nothing kept otherwise)."""
        if not units > 0 or not seconds >= 0:
            return
        st = self._cur
        m = int(st.mode)
        if st.fresh[m]:
            st.fresh[m] = False              # cold: not kept (the class's docs)
            return
        kept = st.rates[m]
        kept.append(seconds / units)
        if len(kept) > self.keep:
            del kept[0]
        st.calls[m] += 1
        if st.probing:
            return
        was = st.parallel
        s, p = st.median(False), st.median(True)
        if s is not None and p is not None:
            if st.parallel and p > self.margin * s:
                st.parallel = False
            elif not st.parallel and p * self.margin < s:
                st.parallel = True
        if st.judge:                         # a probe's last call
            st.judge = False
            st.wait_s = (self.probe_s if st.parallel != was
                         else min(2.0 * st.wait_s, 8.0 * self.probe_s))


class _Class:
    """One size class's share of a :class:`Governor`: its timings, its
    mode and its probes.  The first call of each mode in a class is not
    kept: the threads' first call starts them, and a class's first call
    finds its memory cold (a pedalled grand chord's first 2837-sample call
    on the threads took 7.0 ns per unit against 2.8 after, 4.8 on one
    thread; kept, it moved that class to one thread for the rest of a 4 s
    render, whose wall time never reached the next probe)."""

    def __init__(self, probe_calls: int, probe_s: float):
        #: whether the next call of each mode is the class's first: [one, threads]
        self.fresh = [True, True]
        #: whether the threads are the mode in use
        self.parallel = True
        #: the last timings (s per unit): [calling thread, threads]
        self.rates = ([], [])
        #: calls timed in each mode: [calling thread, threads]
        self.calls = [0, 0]
        # (the first probe after one call; a busy machine is found at once,
        # where a sitar chord's call on stalled threads took about 0.28 s
        # against 1.5 ms on one, python tools/bench.py busy)
        self.since = probe_calls - 1
        self.probing = 0
        self.last_probe = None
        self.mode = True
        # the wait between probes: probe_s, doubled (to 8 probe_s) each time a
        # probe keeps the mode (a machine busy for long is probed less)
        self.wait_s = probe_s
        self.judge = False

    def median(self, parallel: bool) -> float | None:
        """Median of the kept timings of a mode (s per unit), None if none."""
        r = sorted(self.rates[int(parallel)])
        if not r:
            return None
        k = len(r) // 2
        return r[k] if len(r) % 2 else 0.5 * (r[k - 1] + r[k])
