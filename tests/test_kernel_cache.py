"""numba's cache of the kernels sits in a folder keyed on their sources
(:mod:`synth.kernels.cache`), so an edit to a callee's file cannot leave a
caller's stale machine code in use."""

import ast
import os
import re
import shutil
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from synth.kernels import cache as C

import source_trees  # (tests/: the sources parsed once a process)

ROOT = Path(__file__).resolve().parents[1]
KERNELS = ROOT / "synth" / "kernels"
KEYED = re.compile(r"synth-kernels-[0-9a-f]{16}")


def _env(tmp_path, cache=None, **extra):
    """This process's environment with the checkout and ``tmp_path`` on the
    path and ``NUMBA_CACHE_DIR`` = ``cache`` (removed if None)."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), str(tmp_path)]), **extra)
    env.pop("NUMBA_CACHE_DIR", None)
    if cache is not None:
        env["NUMBA_CACHE_DIR"] = str(cache)
    return env


def _run(code, env, cwd):
    r = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], env=env, cwd=str(cwd),
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    return r.stdout.strip().splitlines()


# ---- the key ------------------------------------------------------------------------------
def test_digest_changes_with_any_kernel_source(tmp_path):
    """A copy of the sources has the real digest; a one-byte edit of any one
    module, a new module or a renamed one each give another; touching a file
    (a new mtime, the same bytes) does not."""
    copy = tmp_path / "kernels"
    copy.mkdir()
    files = C.source_files(KERNELS)
    assert {"strings.py", "render.py", "config.py", "lanes.py", "felt_layer.py",
            "cache.py", "__init__.py"} <= {p.name for p in files}
    for p in files:
        shutil.copyfile(p, copy / p.name)
    base = C.source_digest(copy)
    assert base == C.source_digest(KERNELS)
    assert re.fullmatch(r"[0-9a-f]{16}", base)
    seen = {base}
    for p in files:
        q = copy / p.name
        data = q.read_bytes()
        q.write_bytes(data.replace(b"def ", b"def  ", 1) if b"def " in data else data + b"\n")
        d = C.source_digest(copy)
        assert d not in seen, p.name
        seen.add(d)
        q.write_bytes(data)
    assert C.source_digest(copy) == base
    os.utime(copy / "strings.py", (1, 1))
    assert C.source_digest(copy) == base
    (copy / "extra.py").write_text("X = 1\n")
    assert C.source_digest(copy) != base
    (copy / "extra.py").rename(copy / "extra2.py")
    assert C.source_digest(copy) not in (base, C.source_digest(KERNELS))
    (copy / "notes.txt").write_text("not a module\n")         # only modules count
    (copy / "extra2.py").unlink()
    assert C.source_digest(copy) == base


COMPILERS = {"njit", "jit", "vectorize", "guvectorize", "cfunc", "stencil", "generated_jit",
             "overload", "intrinsic"}


def _numba_sites(path):
    """Lines of ``path`` that call or decorate with a numba compiler."""
    def name(node):
        return node.attr if isinstance(node, ast.Attribute) else getattr(node, "id", None)

    sites = []
    for node in ast.walk(source_trees.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Call) and name(node.func) in COMPILERS or (
                isinstance(node, (ast.FunctionDef, ast.ClassDef))
                and any(name(d.func if isinstance(d, ast.Call) else d) in COMPILERS
                        for d in node.decorator_list)):
            sites.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    return sites


def test_no_numba_code_outside_kernels():
    """Only ``synth/kernels`` is hashed: no other module of ``synth`` may
    compile numba functions (they could be cached, or call a kernel), but
    the benchmarks' own timing loops and naive references
    (``synth/apps/bench``), which are never cached: compiled afresh in
    each run, they cannot keep a stale kernel."""
    assert _numba_sites(KERNELS / "energy.py")            # the check sees a kernel
    assert _numba_sites(KERNELS / "lanes.py")             # and an intrinsic
    bench = ROOT / "synth" / "apps" / "bench"
    outside = [site for p in (ROOT / "synth").rglob("*.py")
               if KERNELS not in p.parents and bench not in p.parents
               for site in _numba_sites(p)]
    assert outside == []
    for p in bench.glob("*.py"):
        if _numba_sites(p):
            text = p.read_text(encoding="utf-8")
            assert "cache=True" not in text, p.name
            if re.search(r"\b(JIT|SERIAL|PAR)_OPTS\b", text):
                assert "cache=False" in text, p.name    # the kernels' options, uncached


def test_every_kernel_is_cached_in_the_keyed_folder():
    """Every cached dispatcher of every kernel module (the lazily imported
    ones too) has its locator in :func:`synth.kernels.cache_dir`."""
    import synth.kernels as K
    from numba.core.registry import CPUDispatcher

    folder = K.cache_dir()
    assert folder is not None and KEYED.fullmatch(folder.name)
    assert folder.name.endswith(C.source_digest(KERNELS))
    n = 0
    for mod in [m for name, m in sys.modules.items() if name.startswith("synth.kernels.")]:
        for obj in vars(mod).values():
            if isinstance(obj, CPUDispatcher) and obj.__module__ == mod.__name__:
                if obj._cache.__class__.__name__ == "NullCache":
                    continue
                assert Path(obj._cache.cache_path).parent == folder, (mod.__name__, obj)
                n += 1
    assert n > 50


# ---- where it goes ------------------------------------------------------------------------
PRINT_DIR = """
    import numba, synth.kernels as K
    from synth.kernels import strings
    print(K.cache_dir())
    print(strings.felt_layer_step._cache.cache_path)
    print(numba.config.CACHE_DIR)
"""


@pytest.mark.slow  # over 2 s on a quiet 2-core machine (2.2 s, 2026-11-30): three processes
def test_folder_stable_across_processes_and_under_numba_cache_dir(tmp_path):
    """Two fresh processes with the same sources pick the same folder, named
    from the sources' digest, under ``NUMBA_CACHE_DIR``; numba's setting is
    the user's again once the kernels are imported."""
    base = tmp_path / "nc"
    a = _run(PRINT_DIR, _env(tmp_path, base), tmp_path)
    b = _run(PRINT_DIR, _env(tmp_path, base), tmp_path)
    assert a == b
    folder = Path(a[0])
    assert folder == base / f"synth-kernels-{C.source_digest(KERNELS)}"
    assert folder.is_dir()
    assert Path(a[1]).parent == folder
    assert a[2] == str(base)
    # a target of synth.apps.cpu_target (its own NUMBA_CACHE_DIR) gets its own folder
    c = _run(PRINT_DIR, _env(tmp_path, base / "haswell"), tmp_path)
    assert Path(c[0]) == base / "haswell" / folder.name


COUNT_CHECKS = """
    import tempfile
    made = []
    real = tempfile.TemporaryFile
    def counting(*a, **k):
        made.append(k.get("dir"))
        return real(*a, **k)
    tempfile.TemporaryFile = counting
    import synth.kernels as K
    from synth.kernels import strings
    numba_checks = lambda: [str(d) for d in made if str(d) != str(K.cache_dir())]
    print(len(numba_checks()), len(set(numba_checks())), numba_checks()[0])
    strings.felt_layer_step._cache._impl.locator.ensure_cache_path()   # as before a save
    print(len(numba_checks()))
"""


def test_the_keyed_folder_is_checked_once_while_the_kernels_are_decorated(tmp_path):
    """numba checks that a function's cache folder is writable (a temporary
    file made and removed) for each function it decorates: the kernels'
    folder in the keyed folder is checked once for the whole package, not
    once for each of its 136 functions (12 ms of every start), and numba's
    check before a save still runs.  (The keyed folder's own check, by
    :func:`synth.kernels.cache.choose_dir`, is not counted.)"""
    out = _run(COUNT_CHECKS, _env(tmp_path, tmp_path / "nc"), tmp_path)
    n, distinct, where = out[0].split()
    assert (int(n), int(distinct)) == (1, 1)
    assert Path(where).name == "kernels" and KEYED.fullmatch(Path(where).parent.name)
    assert int(out[1]) == 2

def test_default_folder_chain(tmp_path, monkeypatch):
    """Without NUMBA_CACHE_DIR: the package's ``__pycache__``, else numba's
    user-wide folder; NUMBA_CACHE_DIR first when set; None when nothing is
    writable or there are no sources."""
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "m.py").write_text("X = 1\n")
    name = "synth-kernels-" + C.source_digest(pkg)
    user = tmp_path / "user"
    monkeypatch.setattr(C, "user_cache_base", lambda: user)
    assert C.choose_dir(pkg) == pkg / "__pycache__" / name
    assert C.choose_dir(pkg, user_base=tmp_path / "nc") == tmp_path / "nc" / name
    shutil.rmtree(pkg / "__pycache__")
    (pkg / "__pycache__").write_text("")          # not a folder: in-tree cannot be used
    assert C.choose_dir(pkg) == user / name
    (tmp_path / "blocked").write_text("")
    monkeypatch.setattr(C, "user_cache_base", lambda: tmp_path / "blocked")
    assert C.choose_dir(pkg) is None
    assert C.choose_dir(tmp_path / "empty") is None
    with pytest.raises(ValueError, match="name = 'a/b'"):
        C.choose_dir(pkg, name="a/b")


# ---- pruning ------------------------------------------------------------------------------
def test_prune_keeps_the_newest_and_the_current(tmp_path):
    names = [f"synth-kernels-{i:016x}" for i in range(6)]
    for i, n in enumerate(names):
        (tmp_path / n).mkdir()
        (tmp_path / n / "f.nbi").write_text("x")
        os.utime(tmp_path / n, (1000 + i, 1000 + i))
    others = ["synth-kernels-old", "kernels_0123", "synth-kernels-0000000000000000x"]
    for n in others:
        (tmp_path / n).mkdir()
        os.utime(tmp_path / n, (1, 1))
    (tmp_path / "synth-kernels-00000000000000ff").write_text("a file, not ours")
    os.utime(tmp_path / "synth-kernels-00000000000000ff", (1, 1))
    current = tmp_path / names[0]                 # the oldest: still never deleted
    deleted = C.prune(current, keep=3)
    assert sorted(p.name for p in deleted) == sorted(names[1:4])
    left = sorted(p.name for p in tmp_path.iterdir())
    assert left == sorted([names[0], names[4], names[5], *others, "synth-kernels-00000000000000ff"])
    assert C.prune(current, keep=1) == [tmp_path / names[5], tmp_path / names[4]]
    assert C.prune(tmp_path / "missing" / names[0]) == []    # no parent: no error
    with pytest.raises(ValueError, match="keep = 0"):
        C.prune(current, keep=0)


def test_prune_ignores_what_it_cannot_delete(tmp_path, monkeypatch):
    for i in range(3):
        (tmp_path / f"synth-kernels-{i:016x}").mkdir()
        os.utime(tmp_path / f"synth-kernels-{i:016x}", (1000 + i, 1000 + i))

    def refuse(path):
        raise PermissionError(path)

    monkeypatch.setattr(C.shutil, "rmtree", refuse)
    assert C.prune(tmp_path / f"synth-kernels-{2:016x}", keep=1) == []
    assert len(list(tmp_path.iterdir())) == 3


# ---- end to end: a caller in one file, its callee in another -------------------------------
CALLER = """
    from numba import njit
    from .callee import k


    @njit(cache=True)
    def f():
        return k() + 0.5
"""
CALLEE = """
    from numba import njit


    @njit(cache=True)
    def k():
        return {value}
"""
KEYED_INIT = """
    from pathlib import Path
    from synth.kernels.cache import load_keyed

    DIR = load_keyed(__name__, Path(__file__).parent, name="toy")
"""
RUN = """
    import keyed.caller, plain.caller
    for c in (keyed.caller, plain.caller):
        print(c.f(), sum(c.f.stats.cache_hits.values()), c.f._cache.cache_path)
"""


def _toy(root, pkg, init, value):
    d = root / pkg
    d.mkdir(exist_ok=True)
    (d / "__init__.py").write_text(textwrap.dedent(init))
    (d / "caller.py").write_text(textwrap.dedent(CALLER))
    (d / "callee.py").write_text(textwrap.dedent(CALLEE).format(value=value))


@pytest.mark.parametrize("numba_cache_dir", [True, False], ids=["NUMBA_CACHE_DIR", "default"])
@pytest.mark.slow  # over 2 s on a quiet 2-core machine: ~3 s of CPU, a compile in a subprocess
def test_callee_edit_gives_fresh_code(tmp_path, numba_cache_dir):
    """The toy package ``keyed`` loads its modules with :func:`load_keyed`;
    ``plain`` (the control) is the same without it.  After the callee's
    value changes from 1.0 to 2.0, ``plain``'s caller still returns 1.5 from
    numba's cache (the bug), ``keyed``'s compiles afresh and returns 2.5;
    both load from the cache when nothing changed."""
    nc = tmp_path / "nc" if numba_cache_dir else None
    env = _env(tmp_path, nc)
    for pkg, init in (("keyed", KEYED_INIT), ("plain", "")):
        _toy(tmp_path, pkg, init, "1.0")

    def run():
        out = []
        for line in _run(RUN, env, tmp_path):
            value, hits, path = line.split()
            out.append((float(value), int(hits), Path(path)))
        return out

    (k1, p1), (k2, p2) = run(), run()
    assert k1[:2] == p1[:2] == (1.5, 0)                  # compiled
    assert k2[:2] == p2[:2] == (1.5, 1)                  # loaded from the cache
    folder = k1[2].parent
    assert re.fullmatch(r"toy-[0-9a-f]{16}", folder.name)
    assert folder.parent == (nc if nc else tmp_path / "keyed" / "__pycache__")
    assert "toy-" not in str(p1[2])                      # the user's setting is back

    for pkg in ("keyed", "plain"):
        (tmp_path / pkg / "callee.py").write_text(textwrap.dedent(CALLEE).format(value="2.0"))
    k3, p3 = run()
    assert p3[:2] == (1.5, 1)                            # numba alone: stale
    assert k3[:2] == (2.5, 0)                            # a fresh folder, compiled
    assert k3[2].parent != folder and k3[2].parent.parent == folder.parent
    k4, _ = run()
    assert k4[:2] == (2.5, 1)
    assert folder.is_dir()                               # kept: within KEEP


@pytest.mark.slow  # two subprocesses, one compile
def test_the_same_sources_elsewhere_load_what_was_compiled(tmp_path):
    """Two copies of the toy package at two paths (a checkout and an
    installed wheel, say) with one ``NUMBA_CACHE_DIR``: the second loads the
    first's compiled code from the keyed folder (numba alone would key the
    entries on the sources' path too and compile again), and both name the
    same entry."""
    nc = tmp_path / "nc"
    out = []
    for where in ("a", "b"):
        root = tmp_path / where
        root.mkdir()
        _toy(root, "keyed", KEYED_INIT, "1.0")
        env = dict(_env(root, nc), PYTHONPATH=os.pathsep.join([str(ROOT), str(root)]))
        (line,) = _run("""
            import keyed.caller as c
            print(c.f(), sum(c.f.stats.cache_hits.values()), c.f._cache.cache_path)
        """, env, root)
        value, hits, path = line.split()
        out.append((float(value), int(hits), Path(path)))
    assert out[0][:2] == (1.5, 0) and out[1][:2] == (1.5, 1), out
    assert out[0][2] == out[1][2] and out[0][2].parent.parent == nc, out


def _racing_saves(root, guarded):
    """Two processes' saves of two signatures of one function, interleaved
    as numba's unlocked save lets them be: A reads the empty index, B reads
    it too, A writes its index, B writes its index and its data, A writes its
    data last.  Threads stand for the processes; hooks on the two
    ``IndexDataCacheFile`` objects order them (each wait gives up after
    0.3 s, as it must when the guard's lock keeps B out until A is done).
    Returns what a later process finds: {key: data} through the index."""
    import threading

    from numba.core import caching

    cls = caching.IndexDataCacheFile
    path = str(root / "kernels_x")
    os.makedirs(path, exist_ok=True)
    a = cls(path, "f-1.py311", "stamp")
    b = cls(path, "f-1.py311", "stamp")
    a_read, b_read, a_index, b_done = (threading.Event() for _ in range(4))

    def hook(obj, name, before=None, after=None):
        plain = getattr(obj, name)

        def run(*args):
            if before:
                before()
            out = plain(*args)
            if after:
                after()
            return out
        setattr(obj, name, run)

    hook(a, "_load_index", after=lambda: (a_read.set(), b_read.wait(0.3)))
    hook(b, "_load_index", before=lambda: a_read.wait(0.3), after=b_read.set)
    hook(a, "_save_index", after=a_index.set)
    hook(b, "_save_index", before=lambda: a_index.wait(0.3))
    hook(a, "_save_data", before=lambda: (a_index.set(), b_done.wait(0.3)))
    save = cls.save if guarded else getattr(cls.save, "__wrapped_plain__", None)
    assert save is not None
    tb = threading.Thread(target=lambda: (save(b, "key-int64", "code for int64"), b_done.set()))
    ta = threading.Thread(target=lambda: save(a, "key-none", "code for none"))
    ta.start()
    tb.start()
    ta.join(10)
    tb.join(10)
    c = cls(path, "f-1.py311", "stamp")
    return {k: c.load(k) for k in ("key-none", "key-int64")}


@pytest.mark.parametrize("guarded", [False, True])
def test_two_processes_saving_two_signatures_never_swap_their_code(tmp_path, guarded):
    """numba's own save, so interleaved, leaves the index naming int64's
    signature and the data file holding None's code (a later process runs
    code compiled for other types: a grand note crashed with signal 11 on
    such a cache).  With synth.kernels.cache's guard (a lock around the
    save, the data written before the index) each signature found loads its
    own code.  The guard covers only the keyed folder's saves."""
    C.install_save_lock(tmp_path)
    got = _racing_saves(tmp_path, guarded)
    if guarded:
        for key, code in (("key-none", "code for none"), ("key-int64", "code for int64")):
            assert got[key] in (None, code), got
        assert any(v is not None for v in got.values())
    else:
        assert got["key-int64"] == "code for none", got     # the race the guard closes


LIGHT_RUN = """
    import sys
    import numba
    from numba.core import caching
    refreshes = []
    ctx = numba.core.registry.cpu_target.target_context
    plain_refresh = type(ctx).refresh
    type(ctx).refresh = lambda self: (refreshes.append(1), plain_refresh(self))[1]
    import llvmlite.binding as ll
    parses = []
    plain_parse = ll.parse_bitcode
    ll.parse_bitcode = lambda b, *a: (parses.append(1), plain_parse(b, *a))[1]
    import synth.kernels.cache as K
    objs = []
    plain_elf = K.elf_defined_symbols
    K.elf_defined_symbols = lambda o: (objs.append(o), plain_elf(o))[1]
    import {pkg}.caller as c
    v = c.f()
    print(v, sum(c.f.stats.cache_hits.values()), len(refreshes), "numba.np.linalg" in sys.modules,
          len(parses))
    ll.parse_bitcode = plain_parse

    @numba.njit
    def g(x):                       # not cached: a compile after the load
        return x * 2.0

    @numba.njit
    def h():                        # links the loaded library into its own
        return c.f() + 1.0

    print(g(c.f()), "numba.np.linalg" in sys.modules, h())
    mod = c.f.overloads[c.f.signatures[0]].library._get_module_for_linking()
    names = {{v.name for vs in (mod.functions, mod.global_variables) for v in vs
              if not v.is_declaration and v.linkage.name not in ("private", "internal")}}
    print([plain_elf(o) == names for o in objs])     # the entries loaded lazily
"""


@pytest.mark.slow  # three subprocesses, two compiles
def test_a_warm_load_skips_numbas_refresh_and_a_later_compile_still_works(tmp_path):
    """Loading the keyed folder's compiled code does not refresh numba's
    target context (the lowering registries, 0.24 s of a warm ``synth
    note``) nor parse the library's bitcode for linking (0.13 s of a warm
    grand note): the second run of the toy ``keyed`` package loads its
    caller with no refresh, no bitcode parsed and without importing numba's
    linalg lowering; a function compiled afterwards in the same process
    (numba's compiler refreshes the contexts itself) still compiles and
    runs, and one that calls the loaded function links it in; the symbols
    read from the object code are the names the bitcode defines.  The control
    ``plain``, another library's cached functions, keeps numba's load,
    which refreshes."""
    env = _env(tmp_path, tmp_path / "nc")
    for pkg, init in (("keyed", KEYED_INIT), ("plain", "")):
        _toy(tmp_path, pkg, init, "1.0")
    _run(LIGHT_RUN.format(pkg="keyed"), env, tmp_path)          # compiles
    _run(LIGHT_RUN.format(pkg="plain"), env, tmp_path)
    first, second, names = _run(LIGHT_RUN.format(pkg="keyed"), env, tmp_path)
    assert first.split() == ["1.5", "1", "0", "False", "0"], first     # no bitcode parsed
    assert second.split() == ["3.0", "True", "2.5"], second
    assert names == "[True]"    # the object's symbols: the bitcode's names (less the internal .const. strings)
    first, _, _ = _run("import keyed\n" + textwrap.dedent(LIGHT_RUN.format(pkg="plain")), env,
                       tmp_path)
    value, hits, refreshes, _, parses = first.split()
    assert (value, hits) == ("1.5", "1") and int(refreshes) >= 1 and int(parses) >= 1, first


# ---- two processes, one compile ------------------------------------------------------------
BIG = """
    from numba import njit


    @njit(cache=True)
    def big(x):
        y = x
{body}
        return y
"""
RACE = """
    import os, sys, time
    import {pkg}.big as b
    open({ready!r}, "w").close()          # imported: numba and the package
    start = {start!r}
    while not os.path.exists(start):      # both processes call at once
        time.sleep(0.001)
    v = b.big(1.0)
    print(v, sum(b.big.stats.cache_misses.values()), sum(b.big.stats.cache_hits.values()))
"""


@pytest.mark.slow  # two races of two processes compiling a long function
def test_two_processes_that_need_one_kernel_compile_it_once(tmp_path):
    """Two processes call one cached function of a keyed folder at the same
    moment on a cold cache: one compiles it, the other waits for that
    compile and loads its code (``install_compile_lock``).  The function is
    long enough (150 statements: about a second to compile) that without
    the lock both would compile it."""
    body = "\n".join(f"        y = y * 1.0000001 + {i % 7}.0 / (y + {i + 1}.0)" for i in range(150))
    env = _env(tmp_path, tmp_path / "nc")
    for pkg, init in (("raced", KEYED_INIT), ("plain", "")):
        d = tmp_path / pkg
        d.mkdir()
        (d / "__init__.py").write_text(textwrap.dedent(init))
        (d / "big.py").write_text(textwrap.dedent(BIG.format(body=body)))

    def race(pkg):
        start = tmp_path / f"go-{pkg}"
        ready = [tmp_path / f"ready-{pkg}-{i}" for i in range(2)]
        procs = [subprocess.Popen([sys.executable, "-c", textwrap.dedent(RACE.format(
                     pkg=pkg, start=str(start), ready=str(r)))], env=env, cwd=str(tmp_path),
                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for r in ready]
        t_end = time.time() + 120
        while not all(r.exists() for r in ready):     # both have imported numba and the package
            assert time.time() < t_end and all(p.poll() is None for p in procs), \
                [p.communicate() for p in procs if p.poll() is not None]
            time.sleep(0.01)
        start.write_text("")
        outs = []
        for p in procs:
            out, err = p.communicate(timeout=300)
            assert p.returncode == 0, err
            outs.append(out.split())
        assert len({o[0] for o in outs}) == 1, outs
        return sorted((int(o[1]), int(o[2])) for o in outs)

    assert race("plain") == [(1, 0), (1, 0)]          # numba alone: compiled twice
    assert race("raced") == [(0, 1), (1, 0)]          # once, and loaded by the other
    locks = list((tmp_path / "nc").rglob(".compile/*.lock"))
    assert [q.name for q in locks] == ["raced.big.big.lock"], locks
