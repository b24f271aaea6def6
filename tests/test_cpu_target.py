"""synth.apps.cpu_target (the benchmarks' --cpu-name): the numba code-generation
targets of the benchmarks."""

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from synth.apps import cpu_target

ROOT = Path(__file__).resolve().parents[1]


def host_is_x86_64_v3():
    flags = set(cpu_target.cpuinfo().get("flags", "").split())
    return cpu_target.isa_level_cpu(flags) in ("v3", "v4")


def test_haswell_features_are_avx2_only():
    host = cpu_target.host_features()
    s = cpu_target.haswell_features(host)
    f = cpu_target.parse_features(s)
    assert f["avx2"] and f["fma"] and f["bmi2"] and f["sse4.2"]
    assert not any(v for k, v in f.items() if k.startswith("avx512"))
    assert "+avx512" not in s
    # every feature LLVM reports for this host is given, on or off
    assert set(host) <= set(f)
    assert {k for k, v in f.items() if v} == set(cpu_target.HASWELL_FEATURES)
    assert cpu_target.isa_level_llvm(f) == "v3"


def test_haswell_features_turn_off_an_avx512_host():
    host = {"avx512f": True, "avx512bw": True, "avx2": True, "sse2": True, "amx-tile": False}
    f = cpu_target.parse_features(cpu_target.haswell_features(host))
    assert f["avx512f"] is False and f["avx512bw"] is False and f["amx-tile"] is False
    assert f["avx2"] is True and f["fma"] is True      # Haswell's own, even if missing here


def test_target_env(tmp_path):
    g = cpu_target.target_env("generic", tmp_path)
    assert g["NUMBA_CPU_NAME"] == "generic" and g["NUMBA_CPU_FEATURES"] == ""
    assert g["NUMBA_CACHE_DIR"] == str(tmp_path / "generic")
    assert g[cpu_target.ENV_TARGET] == "generic"
    h = cpu_target.target_env("host", tmp_path)
    assert h["NUMBA_CPU_NAME"] is None and h["NUMBA_CPU_FEATURES"] is None
    env = cpu_target.environ_for("host", tmp_path, {"NUMBA_CPU_NAME": "x", "PATH": "/bin"})
    assert "NUMBA_CPU_NAME" not in env and env["PATH"] == "/bin"
    hw = cpu_target.target_env("haswell", tmp_path)
    assert hw["NUMBA_CPU_NAME"] == "haswell" and "+avx2" in hw["NUMBA_CPU_FEATURES"]
    assert hw["NUMBA_CACHE_DIR"] != g["NUMBA_CACHE_DIR"] != h["NUMBA_CACHE_DIR"]
    with pytest.raises(ValueError):
        cpu_target.target_env("skylake", tmp_path)


def test_cache_base_from_numba_cache_dir(monkeypatch, tmp_path):
    monkeypatch.delenv(cpu_target.ENV_CACHE_BASE, raising=False)
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    assert cpu_target.target_env("haswell")["NUMBA_CACHE_DIR"] == str(tmp_path / "haswell")
    monkeypatch.delenv("NUMBA_CACHE_DIR")
    assert cpu_target.cache_base() == Path.home() / ".cache" / "synth-bench-numba"


def test_isa_levels():
    v3 = {"sse4_2", "popcnt", "ssse3", "cx16", "lahf_lm", "avx2", "bmi1", "bmi2", "fma",
          "f16c", "movbe", "abm"}
    assert cpu_target.isa_level_cpu({"sse2"}) == "v1"
    assert cpu_target.isa_level_cpu(v3) == "v3"
    assert cpu_target.isa_level_cpu(v3 | {"avx512f", "avx512bw", "avx512cd", "avx512dq",
                                          "avx512vl"}) == "v4"
    assert cpu_target.isa_level_cpu(v3 - {"avx2"} | {"avx512f"}) == "v2"
    assert cpu_target.code_isa("generic", "") == ("v1", False)
    assert cpu_target.code_isa("haswell", "") == ("v3", False)
    assert cpu_target.code_isa("haswell", "+avx2,+avx512f,+avx512bw,+avx512cd,+avx512dq,"
                               "+avx512vl,+sse4.2,+popcnt,+ssse3,+cx16,+sahf,+bmi,+bmi2,"
                               "+fma,+f16c,+movbe,+lzcnt")[1] is True


def test_strip_cpu_option():
    argv = ["--runs", "3", "--cpu-name", "all", "--quick", "--cpu-name=haswell"]
    assert cpu_target.strip_cpu_option(argv) == ["--runs", "3", "--quick"]


def test_describe_names_cpu_and_target():
    d = cpu_target.describe()
    assert "target host" in d or "target custom" in d
    assert "llvm cpu" in d and "x86-64-v" in d and "numba" in d
    assert all(line.startswith("# ") for line in d.splitlines())


ASM_CHECK = textwrap.dedent("""
    import numpy as np
    from numba import njit
    from synth.apps import cpu_target

    @njit(fastmath=True)
    def f(a, b, out):
        for i in range(a.shape[0]):
            out[i] = a[i] * b[i] + 0.5 * out[i]

    a = np.ones(64)
    f(a, a, a.copy())
    asm = f.inspect_asm(f.signatures[0])
    print(cpu_target.describe())
    print("zmm" in asm, "ymm" in asm)
""")


@pytest.mark.parametrize("target", ["haswell", "generic"])
@pytest.mark.slow  # a compile in a subprocess: 2.1-2.5 s each alone, 2.9-3.5 in the suite
def test_compiled_code_of_target(tmp_path, target):
    """A small float loop compiled for the target (fresh cache directory):
    no zmm registers in the haswell code, no ymm in the generic code."""
    if target == "haswell" and not host_is_x86_64_v3():
        pytest.skip("this CPU cannot run AVX2 code")
    env = cpu_target.environ_for(target, tmp_path)
    env["PYTHONPATH"] = str(ROOT)
    r = subprocess.run([sys.executable, "-c", ASM_CHECK], env=env,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    *head, last = r.stdout.strip().splitlines()
    zmm, ymm = (x == "True" for x in last.split())
    assert f"target {target}: llvm cpu {target}" in "\n".join(head)
    assert not zmm
    if target == "haswell":
        assert ymm                       # it is vectorised, with AVX2
        assert "AVX-512 off, code needs x86-64-v3" in "\n".join(head)
    else:
        assert not ymm
        assert "code needs x86-64-v1" in "\n".join(head)


REGS_CHECK = textwrap.dedent("""
    from synth.kernels import config, strings
    print(config.VECTOR_REGS, strings._HEAD_SOS, strings._LANES_HEAD_SOS, config.LANES,
          strings._LANES_HEAD_SOS2)
""")


@pytest.mark.parametrize("target", ["host", "haswell", "generic"])
def test_vector_registers_of_target(tmp_path, target):
    """The kernels' register count follows numba's code target: 16 for the
    AVX2 and SSE2 builds (the head loops then take fewer biquads), 32 only
    where the target has AVX-512; the lockstep filters run four lanes where
    it has AVX, two in the SSE2 build (whose head then takes no biquad
    after a dispersion section)."""
    if target == "haswell" and not host_is_x86_64_v3():
        pytest.skip("this CPU cannot run AVX2 code")
    env = cpu_target.environ_for(target, tmp_path)
    env["PYTHONPATH"] = str(ROOT)
    r = subprocess.run([sys.executable, "-c", REGS_CHECK], env=env, capture_output=True,
                       text=True, timeout=120, cwd=str(ROOT))
    assert r.returncode == 0, r.stderr
    regs, head, lanes, width, lanes2 = (int(x) for x in r.stdout.split())
    host512 = cpu_target.host_features().get("avx512f", False)
    hostavx = cpu_target.host_features().get("avx", False)
    assert regs == (32 if target == "host" and host512 else 16)
    assert (head, lanes) == ((4, 4) if regs == 32 else (3, 2))
    assert width == (2 if target == "generic" or not hostavx else 4)
    assert lanes2 == (0 if width == 2 else lanes)
