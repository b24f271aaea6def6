"""The addresses of the kernels' units in this process, and the units
another process is compiling (a cold start on several cores).

The renderers call some kernels by their address
(:mod:`synth.kernels.address`): each such unit compiles, or loads from
numba's cache, on its own, the first time a bank needs it
(:meth:`synth.dsp.bank.StringBank._units`), and its address is kept here
for every bank of the process.  On a cold cache a command may start a
second process that compiles some units into the cache meanwhile
(:mod:`synth.apps.cold_start`); :func:`compile_elsewhere` says which, and
a bank that needs one of them loads everything else it can first, then
waits for that process and loads the unit from the cache.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from ..kernels import address as KA
from .compile_notice import add_compile_seconds

#: the units' addresses, once per process: a unit index of
#: :mod:`synth.kernels.address`, or "bank" (render_bank, for render_sharded)
_ADDR: dict[object, int] = {}
#: units another process is compiling into numba's cache: a unit index (or
#: "bank") -> a callable that returns once that process is done
_ELSEWHERE: dict[object, Callable[[], None]] = {}


def compile_elsewhere(units, wait: Callable[[], None]) -> None:
    """Say that another process compiles ``units`` (unit indices of
    :mod:`synth.kernels.address`, or ``"bank"``) into numba's cache, and
    that ``wait`` returns when it is done: a bank that needs one of them
    first loads what it can compile itself, then calls ``wait`` (once) and
    loads the unit from the cache (or compiles it, if that process failed).
    A unit this process has already loaded is left alone."""
    units = list(units)
    for u in units:
        if u != "bank" and not (isinstance(u, int) and 0 <= u < KA.N_ADDRS):
            raise ValueError(f"units: {u!r} is not a unit (0 <= value < {KA.N_ADDRS}, or 'bank')")
    for u in units:
        if u not in _ADDR:
            _ELSEWHERE[u] = wait


def elsewhere(u) -> bool:
    """Whether another process is compiling unit ``u`` (not waited for yet)."""
    return u in _ELSEWHERE


def _wait_elsewhere(u) -> None:
    """Wait for the process compiling unit ``u``, if one is.  An error of
    that process is its own: this one then compiles the unit itself."""
    wait = _ELSEWHERE.pop(u, None)
    if wait is not None:
        t0 = time.perf_counter()
        try:
            wait()
        except Exception:
            pass
        # (the wait is the compile's: a command reports its render without it)
        add_compile_seconds(time.perf_counter() - t0)


def preloaded(addrs, mask: int) -> int:
    """Put in ``addrs`` the address of every unit of ``mask`` (bits 1 <<
    unit) that this process has loaded already; returns the bits of those
    still to load."""
    for k in range(KA.N_ADDRS):
        if (mask >> k) & 1 and k in _ADDR:
            addrs[k] = _ADDR[k]
            mask &= ~(1 << k)
    return mask


def _with_needs(mask: int) -> int:
    """``mask`` (bits 1 << unit) with the units its units call
    (:data:`synth.kernels.address.NEEDS`)."""
    for k in range(KA.N_ADDRS):
        if (mask >> k) & 1:
            mask |= KA.NEEDS[k]
    return mask
