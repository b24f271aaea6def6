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
