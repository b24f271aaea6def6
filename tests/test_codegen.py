"""The string kernel's machine code for an AVX2-only and a plain x86-64 CPU.

The termination region's min/max must compile to vector min/max with plain
stores.  Written in place (``a[i] = min(x, a[i])``) LLVM vectorises it as a
compare and a masked store, ``vmaskmovpd`` in AVX2 code, which AMD CPUs
before Zen 4 run as microcode: the jawari strings ran 3-4x slower on a Zen 3
than here (issue 8).  Each target is compiled in a fresh process with its
own numba cache (numba does not show the code of functions loaded from a
cache), through :mod:`synth.apps.cpu_target` (the benchmarks' ``--cpu-name``), as the
benchmarks do.
"""

import subprocess
import sys
import textwrap

import pytest

from synth.apps import cpu_target

RENDER = textwrap.dedent("""
    import numpy as np
    from numba import njit
    from synth.kernels import contact as KC

    # the fast path's termination step: the region's min over its points
    # (_region_pass, four at a time, and its edges), the sub-cell contact
    # and the ring's reads and writes, compiled by itself (render_strings,
    # one string's whole render, took 29-52 s to compile for a target;
    # this 4-5 s).  Its loops are the same functions the renders call.
    P, W = 1000, 200
    ring = np.zeros(2 * P)
    U = np.linspace(1e-4, 1e-3, 12)
    acc, tmp, vw, st = np.zeros(W + 64), np.zeros(W + 64), np.zeros(W + 64), np.zeros(32)
    KC._region_chunk(ring, 0, P, 100, 60, U, 0, 12, 1, acc, tmp, vw, 0.0, st)
    f = KC._region_chunk
    asm = f.inspect_asm(f.signatures[0])
    print("vmaskmov", asm.count("vmaskmov"))
    print("zmm", asm.count("zmm"))
    print("ymm", asm.count("ymm"))
    print("vminpd", asm.count("vminpd"))
    print("minpd", asm.count("minpd"))

    # the control: the same min written in place, which the region avoids
    @njit(cache=False)
    def in_place(a, v, u):
        for i in range(a.shape[0]):
            x = u + v[i]
            if x < a[i]:
                a[i] = x
    a = np.zeros(100)
    in_place(a, a.copy(), 0.1)
    print("control_vmaskmov", in_place.inspect_asm(in_place.signatures[0]).count("vmaskmov"))
""")




def compiled(target, tmp_path):
    env = cpu_target.environ_for(target, tmp_path)
    r = subprocess.run([sys.executable, "-c", RENDER], env=env, capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, r.stderr
    return {k: int(v) for k, v in (line.split() for line in r.stdout.split("\n") if line)}


def host_runs_avx2():
    flags = set(cpu_target.cpuinfo().get("flags", "").split())
    return cpu_target.isa_level_cpu(flags) in ("v3", "v4")


@pytest.mark.slow  # ~5 s: a fresh numba compile of the region step in a subprocess
def test_avx2_build_has_vector_min_and_no_masked_store(tmp_path):
    if not host_runs_avx2():
        pytest.skip("this CPU cannot run AVX2 code")
    c = compiled("haswell", tmp_path)
    assert c["vmaskmov"] == 0
    assert c["zmm"] == 0
    assert c["ymm"] > 0 and c["vminpd"] > 0
    # the count can see a masked store: the in-place min compiles to one
    assert c["control_vmaskmov"] > 0


@pytest.mark.slow  # ~5 s: a fresh numba compile of the region step in a subprocess
def test_plain_x86_64_build_has_sse2_min(tmp_path):
    c = compiled("generic", tmp_path)
    assert c["ymm"] == 0 and c["zmm"] == 0 and c["vmaskmov"] == 0
    assert c["minpd"] > 0
