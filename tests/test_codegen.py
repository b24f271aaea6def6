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
    from synth.kernels import render as KR
    from synth.dsp.bank import StringBank

    # one string with every fast-path stage but the hammer's: a region, loss +
    # dispersion, a bend line.  One string alone renders through
    # render_strings, whose machine code holds the region's min/max as
    # render_sharded's does (render_sharded, every scene in one kernel,
    # took 108-121 s to compile for a target on this machine, 2026-11-29;
    # render_strings 29-33 s)
    b = StringBank(1, 400, 16, 512, max_bend=64)
    U = np.linspace(1e-4, 1e-3, 12)
    b.configure(0, cells=300, k=200, dt_s=1e-5, U=U, lossy=True, b0=0.99, a1=-0.01, eta=0.2,
                out_mode=1, tension_over_dx=1e4, n_disp=6, a_disp=-0.3, bend_len=40,
                bend_delay=10.5)
    b.activate(0)
    b.start_pluck(0, 1, 0.01, 0.002)
    mix = np.zeros(2000)
    b.render(mix, 0, 2000)
    assert KR.render_strings.signatures, "one string did not render through render_strings"
    asm = KR.render_strings.inspect_asm(KR.render_strings.signatures[0])
    print("vmaskmov", asm.count("vmaskmov"))
    print("zmm", asm.count("zmm"))
    print("ymm", asm.count("ymm"))
    print("vminpd", asm.count("vminpd"))
    print("minpd", asm.count("minpd"))
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


@pytest.mark.slow  # ~30 s: a fresh numba compile in a subprocess
def test_avx2_build_has_vector_min_and_no_masked_store(tmp_path):
    if not host_runs_avx2():
        pytest.skip("this CPU cannot run AVX2 code")
    c = compiled("haswell", tmp_path)
    assert c["vmaskmov"] == 0
    assert c["zmm"] == 0
    assert c["ymm"] > 0 and c["vminpd"] > 0


@pytest.mark.slow  # ~30 s: a fresh numba compile in a subprocess
def test_plain_x86_64_build_has_sse2_min(tmp_path):
    c = compiled("generic", tmp_path)
    assert c["ymm"] == 0 and c["zmm"] == 0 and c["vmaskmov"] == 0
    assert c["minpd"] > 0
