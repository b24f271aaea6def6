"""CPU description and numba code-generation targets for the benchmark tools.

The benchmarks say which CPU they ran on and can be run for several numba
code-generation targets (``--cpu-name``):

host
    numba's default: LLVM's name for this CPU and this CPU's own feature
    list (``NUMBA_CPU_NAME`` and ``NUMBA_CPU_FEATURES`` unset).
haswell
    an AVX2-only build, as on any x86-64-v3 machine: ``NUMBA_CPU_NAME=haswell``
    *and* ``NUMBA_CPU_FEATURES`` = the host's feature list with every feature
    Haswell lacks turned off and Haswell's own turned on.  ``NUMBA_CPU_NAME``
    alone is not enough: numba then still passes the host's feature string
    to LLVM (``numba.core.codegen.JITCPUCodegen._customize_tm_features``), so
    on an AVX-512 host the "haswell" code uses zmm registers.
generic
    plain x86-64 (SSE2): ``NUMBA_CPU_NAME=generic`` (numba then defaults the
    features to "").

Each target compiles into its own ``NUMBA_CACHE_DIR`` (``<base>/<target>``,
the base being ``$NUMBA_CACHE_DIR`` if set, else
``~/.cache/synth-bench-numba``): numba's cache index keys on the CPU name and
features too, but separate directories keep runs honest.  The kernels'
cache is a folder keyed on their sources within it
(:mod:`synth.kernels.cache`).

A benchmark runs for another target by re-executing itself in a subprocess
with that target's environment (:func:`synth.apps.bench.harness.dispatch`);
numba reads these variables once, when it is imported.

The benchmarks use it through their harness (:mod:`synth.apps.bench.harness`,
``python tools/bench.py NAME --cpu-name host,haswell,generic``).
"""

from __future__ import annotations

import os
import platform
from pathlib import Path

#: code-generation targets ``--cpu-name`` accepts (besides "all")
TARGETS = ("host", "haswell", "generic")

#: environment variable naming the target a child process was started for
ENV_TARGET = "SYNTH_BENCH_TARGET"
#: environment variable holding the base cache directory of the targets
ENV_CACHE_BASE = "SYNTH_BENCH_CACHE_BASE"

#: LLVM feature names of the Haswell micro-architecture (x86-64-v3 plus a few)
HASWELL_FEATURES = frozenset(
    "64bit cmov cx8 cx16 fxsr mmx sse sse2 sse3 ssse3 sse4.1 sse4.2 popcnt sahf avx avx2 "
    "bmi bmi2 f16c fma lzcnt movbe pclmul rdrnd xsave xsaveopt fsgsbase invpcid crc32 aes".split())

# x86-64 micro-architecture levels (psABI), in /proc/cpuinfo flag names ...
_LEVELS_CPUINFO = (
    ("v2", ("sse4_2", "popcnt", "ssse3", "cx16", "lahf_lm")),
    ("v3", ("avx2", "bmi1", "bmi2", "fma", "f16c", "movbe", "abm")),
    ("v4", ("avx512f", "avx512bw", "avx512cd", "avx512dq", "avx512vl")),
)
# ... and in LLVM feature names
_LEVELS_LLVM = (
    ("v2", ("sse4.2", "popcnt", "ssse3", "cx16", "sahf")),
    ("v3", ("avx2", "bmi", "bmi2", "fma", "f16c", "movbe", "lzcnt")),
    ("v4", ("avx512f", "avx512bw", "avx512cd", "avx512dq", "avx512vl")),
)
# the level of an LLVM CPU name's own feature set (used when the features
# string is empty and LLVM takes the CPU's defaults); others: unknown
_LEVEL_OF_CPU = {
    "generic": "v1", "x86-64": "v1", "x86-64-v2": "v2", "x86-64-v3": "v3", "x86-64-v4": "v4",
    "nehalem": "v2", "westmere": "v2", "sandybridge": "v2", "ivybridge": "v2",
    "haswell": "v3", "broadwell": "v3", "skylake": "v3", "alderlake": "v3", "znver1": "v3",
    "znver2": "v3", "znver3": "v3", "skylake-avx512": "v4", "cascadelake": "v4",
    "cooperlake": "v4", "icelake-server": "v4", "icelake-client": "v4",
    "sapphirerapids": "v4", "znver4": "v4", "znver5": "v4",
}


# ---- features -------------------------------------------------------------------------------
def parse_features(s: str) -> dict[str, bool]:
    """'+a,-b,...' -> {'a': True, 'b': False, ...}."""
    out = {}
    for item in s.split(","):
        item = item.strip()
        if len(item) > 1 and item[0] in "+-":
            out[item[1:]] = item[0] == "+"
    return out


def host_features() -> dict[str, bool]:
    """LLVM's feature map of this CPU ({} if LLVM cannot tell)."""
    import llvmlite.binding as ll

    try:
        return parse_features(ll.get_host_cpu_features().flatten())
    except RuntimeError:
        return {}


def haswell_features(host: dict[str, bool] | None = None) -> str:
    """The feature string of an AVX2-only (Haswell) build on this host: every
    feature LLVM knows here, '+' if Haswell has it and '-' otherwise."""
    host = host_features() if host is None else host
    names = sorted(set(host) | HASWELL_FEATURES)
    return ",".join(("+" if n in HASWELL_FEATURES else "-") + n for n in names)


def isa_level_llvm(features: dict[str, bool]) -> str:
    """x86-64 level ('v1'..'v4') that code built with these LLVM features needs."""
    level = "v1"
    for name, need in _LEVELS_LLVM:
        if all(features.get(f, False) for f in need):
            level = name
        else:
            break
    return level


def cpuinfo() -> dict[str, str]:
    """The first processor's fields of /proc/cpuinfo ({} if unreadable)."""
    get: dict[str, str] = {}
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if not line.strip():
                    if get:
                        break
                    continue
                if ":" in line:
                    key, val = (x.strip() for x in line.split(":", 1))
                    get.setdefault(key, val)
    except OSError:
        pass
    return get


def isa_level_cpu(flags: set[str]) -> str:
    """x86-64 level ('v1'..'v4') of a CPU with these /proc/cpuinfo flags."""
    level = "v1"
    for name, need in _LEVELS_CPUINFO:
        if all(f in flags for f in need):
            level = name
        else:
            break
    return level


def runnable(target: str, flags: set[str] | None = None) -> str | None:
    """None if this CPU can run ``target``'s code, else why not."""
    if target != "haswell":
        return None
    if flags is None:
        flags = set(cpuinfo().get("flags", "").split())
    if not flags:
        return None                     # no /proc/cpuinfo: let it try
    if isa_level_cpu(flags) in ("v3", "v4"):
        return None
    return f"this CPU is x86-64-{isa_level_cpu(flags)}: it cannot run AVX2 (x86-64-v3) code"


# ---- targets --------------------------------------------------------------------------------
def cache_base() -> Path:
    """Base directory of the per-target numba caches."""
    if os.environ.get(ENV_CACHE_BASE):
        return Path(os.environ[ENV_CACHE_BASE])
    if os.environ.get("NUMBA_CACHE_DIR"):
        return Path(os.environ["NUMBA_CACHE_DIR"])
    return Path.home() / ".cache" / "synth-bench-numba"


def target_env(target: str, base: str | os.PathLike | None = None) -> dict[str, str | None]:
    """Environment variables for ``target`` (None: the variable is removed).

    NUMBA_CPU_NAME, NUMBA_CPU_FEATURES (both removed for "host"),
    NUMBA_CACHE_DIR = ``<base>/<target>`` (``base`` default
    :func:`cache_base`), and the target's name in ``SYNTH_BENCH_TARGET``.
    """
    if target not in TARGETS:
        raise ValueError(f"target = {target!r} is not one of {', '.join(TARGETS)}")
    base = Path(base) if base is not None else cache_base()
    env: dict[str, str | None] = {
        "NUMBA_CACHE_DIR": str(base / target),
        ENV_CACHE_BASE: str(base),
        ENV_TARGET: target,
    }
    if target == "host":
        env["NUMBA_CPU_NAME"] = None
        env["NUMBA_CPU_FEATURES"] = None
    elif target == "haswell":
        env["NUMBA_CPU_NAME"] = "haswell"
        env["NUMBA_CPU_FEATURES"] = haswell_features()
    else:
        env["NUMBA_CPU_NAME"] = "generic"
        env["NUMBA_CPU_FEATURES"] = ""
    return env


def environ_for(target: str, base=None, environ=None) -> dict[str, str]:
    """A full environment (``environ`` default os.environ) for ``target``."""
    env = dict(os.environ if environ is None else environ)
    for k, v in target_env(target, base).items():
        if v is None:
            env.pop(k, None)
        else:
            env[k] = v
    return env


def current_target() -> str:
    """The target this process was started for: SYNTH_BENCH_TARGET, else
    "host" if no NUMBA_CPU_NAME is set, else "custom"."""
    t = os.environ.get(ENV_TARGET)
    if t:
        return t
    return "host" if not os.environ.get("NUMBA_CPU_NAME") else "custom"


# ---- what numba actually does ------------------------------------------------------------------
def codegen_in_effect() -> tuple[str, str]:
    """(LLVM CPU name, feature string) numba's JIT compiles with in this process."""
    import numba  # noqa: F401  (config read at import)
    from numba.core import config

    try:
        from numba.core.registry import cpu_target

        cg = cpu_target.target_context.codegen()
        return cg._get_host_cpu_name(), cg._tm_features
    except Exception:                                # private API moved: read the config
        import llvmlite.binding as ll
        from numba.core.codegen import get_host_cpu_features

        name = config.CPU_NAME or ll.get_host_cpu_name()
        feats = config.CPU_FEATURES if config.CPU_FEATURES is not None else get_host_cpu_features()
        return name, feats


def code_isa(cpu_name: str, features: str) -> tuple[str, bool | None]:
    """(x86-64 level the generated code needs, AVX-512 enabled?) for a CPU
    name and feature string ('': the CPU's own defaults)."""
    f = parse_features(features)
    if f:
        return isa_level_llvm(f), bool(f.get("avx512f", False))
    level = _LEVEL_OF_CPU.get(cpu_name.lower())
    if level is None:
        return "?", None
    return level, level == "v4"


def describe(prefix: str = "# ") -> str:
    """A benchmark header: the CPU, numba's code-generation target in effect,
    and the software, one item per line (each starting with ``prefix``)."""
    import llvmlite
    import numba
    import numpy as np

    info = cpuinfo()
    flags = set(info.get("flags", "").split())
    model = info.get("model name") or platform.processor() or "unknown"
    cpu_level = isa_level_cpu(flags) if flags else "?"
    avx512 = "yes" if "avx512f" in flags else ("no" if flags else "?")
    n_cpu = os.cpu_count()
    try:
        n_aff = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        n_aff = n_cpu
    cpus = f"{n_cpu} CPUs" + (f" ({n_aff} usable by this process)" if n_aff != n_cpu else "")
    cpu = (f"{model} (family {info.get('cpu family', '?')}, model {info.get('model', '?')}, "
           f"{info.get('cpu MHz', '?')} MHz, cache {info.get('cache size', '?')}), "
           f"{cpus}; x86-64-{cpu_level}, AVX-512 {avx512}")
    name, feats = codegen_in_effect()
    level, code512 = code_isa(name, feats)
    from numba.core import config

    how = []
    how.append(f"NUMBA_CPU_NAME={config.CPU_NAME}" if config.CPU_NAME else "host CPU name")
    if config.CPU_FEATURES is None:
        how.append("host features")
    else:
        how.append(f"NUMBA_CPU_FEATURES {'empty' if not config.CPU_FEATURES else 'given'}")
    code = (f"target {current_target()}: llvm cpu {name} ({', '.join(how)}), AVX-512 "
            f"{'on' if code512 else ('off' if code512 is not None else '?')}, code needs "
            f"x86-64-{level}; NUMBA_CACHE_DIR={os.environ.get('NUMBA_CACHE_DIR', '(default)')}")
    sw = (f"python {platform.python_version()}, numpy {np.__version__}, numba {numba.__version__}, "
          f"llvmlite {llvmlite.__version__}, NUMBA_NUM_THREADS={config.NUMBA_NUM_THREADS}")
    return "\n".join(f"{prefix}{k:<9}: {v}" for k, v in
                     (("cpu", cpu), ("codegen", code), ("software", sw)))


# ---- the harness's --cpu-name ---------------------------------------------------------------
def strip_cpu_option(argv) -> list[str]:
    """``argv`` without ``--cpu-name X`` / ``--cpu-name=X``."""
    out, skip = [], False
    for a in argv:
        if skip:
            skip = False
            continue
        if a == "--cpu-name":
            skip = True
            continue
        if a.startswith("--cpu-name="):
            continue
        out.append(a)
    return out
