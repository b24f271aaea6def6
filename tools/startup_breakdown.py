"""Where a warm start of ``synth note`` goes: imports, the engine, the
kernels loaded from numba's cache, the render.

    NUMBA_CACHE_DIR=DIR python tools/startup_breakdown.py sitar 57

Run it with a filled cache (a ``synth note`` of the same preset first);
each step's wall and CPU seconds (``time.process_time``, every thread), and
the kernels numba loaded (each ``Dispatcher.compile`` call: from the cache
when warm).
"""

from __future__ import annotations

import sys
import time

T = [("start", time.perf_counter(), time.process_time())]


def mark(what):
    T.append((what, time.perf_counter(), time.process_time()))


def main() -> int:
    import numpy  # noqa: F401
    mark("import numpy")
    import numba  # noqa: F401
    mark("import numba")
    import synth.cli  # noqa: F401
    mark("import synth.cli")
    import numba.core.dispatcher as D

    import synth.io.factory  # noqa: F401
    mark("import synth.io.factory (engine, kernels)")
    from synth.engine.engine import Event
    from synth.io.factory import build_engine

    loads = []
    orig = D.Dispatcher.compile

    def compile_(self, sig):
        t = time.perf_counter()
        r = orig(self, sig)
        loads.append((self.py_func.__qualname__, time.perf_counter() - t))
        return r

    D.Dispatcher.compile = compile_
    preset, key = sys.argv[1], int(sys.argv[2])
    eng = build_engine(preset, (), extra_low_key=key)
    mark("build the engine")
    eng.render([Event(0.0, "note_on", key, 100 / 127.0)], duration_s=1.0)
    mark("first 1 s render (kernels loaded)")
    eng2 = build_engine(preset, (), extra_low_key=key)
    t, c = time.perf_counter(), time.process_time()
    eng2.render([Event(0.0, "note_on", key, 100 / 127.0)], duration_s=1.0)
    for (_, t0, c0), (b, t1, c1) in zip(T, T[1:]):
        print(f"{b:45s} {t1 - t0:7.3f} s wall {c1 - c0:7.3f} CPU s")
    print(f"{'(a second engine, 1 s render)':45s} {time.perf_counter() - t:7.3f} s wall "
          f"{time.process_time() - c:7.3f} CPU s")
    print(f"total {T[-1][1] - T[0][1]:.3f} s wall, {T[-1][2] - T[0][2]:.3f} CPU s; "
          f"{len(loads)} kernels loaded or compiled, {sum(x[1] for x in loads):.3f} s wall:")
    for n, t in sorted(loads, key=lambda x: -x[1]):
        print(f"   {n} {t:.3f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
