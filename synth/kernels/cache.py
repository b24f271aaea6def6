"""numba's on-disk cache of the kernels, in a folder keyed on their sources.

The kernels are ``@njit(cache=True)`` and call each other across files
(:mod:`~synth.kernels.render` calls and inlines the string kernels,
:mod:`~synth.kernels.strings` and the modules of its steps, which call one
another, :mod:`~synth.kernels.felt_layer` and the intrinsics of
:mod:`~synth.kernels.lanes`, and read the columns of
:mod:`~synth.kernels.layout`; all read the flags and target constants of
:mod:`~synth.kernels.config`).  numba checks a cached function against the
one file that defines it (its modification time and size in older numba,
a hash of its bytes in 0.68), never against the files it calls into: an
edit to ``strings.py`` left ``render.py``'s entries valid in numba's eyes,
and they went on running the old ``strings`` code.  So the whole cache of
the package goes into a folder named from a hash of the bytes (and names)
of every module in it, ``synth-kernels-<16 hex digits of sha256>``: any edit
to any kernel module gives a fresh folder, and no entry compiled from other
sources can be found.  Only ``synth/kernels`` is hashed: no other module of
``synth`` has numba code (``tests/test_kernel_cache.py`` checks that), and
``tests/test_layers.py`` keeps the kernels from importing other layers.

Where the folder goes, in numba's own order of cache locations:

1. ``$NUMBA_CACHE_DIR/synth-kernels-<hash>`` when the user set
   ``NUMBA_CACHE_DIR`` (or ``numba.config.CACHE_DIR``) before importing the
   kernels: the CI and ``tools/bench.py --cpu-name`` (one base per numba code
   target) rely on it, and each gets its keyed folder under its own base.
2. Else ``synth/kernels/__pycache__/synth-kernels-<hash>``, next to the
   sources, where numba put the kernels' cache before: a checkout (or
   worktree, or virtual environment) keeps its compiled kernels to itself,
   they go when it is deleted, and pruning only sees that checkout's old
   folders (in one user-wide folder, several checkouts in use would evict
   each other's and recompile in turn, and deleted checkouts would leave
   theirs behind).
3. Else, when the package's folder is not writable (a system-wide install),
   numba's user-wide cache folder (``~/.cache/numba`` on Linux, honouring
   ``XDG_CACHE_HOME``; the platform's equivalent elsewhere), where numba
   itself falls back.

The first of these that can be created and written is used (numba's test: a
temporary file in it).  If none can, or the sources are not on disk, nothing
is changed and numba keeps its default, unkeyed, cache.

How it is applied: numba builds a function's cache locator when the
``@njit(cache=True)`` decorator runs, reading ``numba.config.CACHE_DIR``
then; setting it later, even before the first compile, changes nothing for
functions already decorated.  And numba re-reads its ``NUMBA_*``
environment variables before each compile when one of them changed, which
would reset a ``CACHE_DIR`` set in code.  So :func:`load_keyed` sets
``numba.config.CACHE_DIR`` to the keyed folder, imports every module of the
package at once (every decorator runs within that window), and puts the
user's value back: code outside the kernels, and other libraries' numba
functions, keep their own cache location.  Within that window the kernels'
entries go straight into the keyed folder, under ``kernels/``, where
numba's own locator for ``NUMBA_CACHE_DIR`` would add a hash of the
sources' absolute path: the same sources installed elsewhere (a wheel in a
new virtual environment, a second checkout) find the kernels compiled
already.  The folder's hash covers the sources and the versions of Python,
numba, llvmlite and numpy (:func:`toolchain`), which is everything that
decides the compiled code but the CPU, which numba's index keys itself.  ``synth/kernels/__init__.py``
calls it, so importing any kernel module imports them all (about 15 ms
beyond ``strings``, which every user of the kernels imports anyway).

Loading: a kernel loaded from the keyed folder skips numba's refresh of
its target context, which imports every lowering registry numba has and
cost a warm note a third of its time (:func:`install_light_load`), and
reads the symbols it defines from its object code, parsing its linking
bitcode only if a compile links it in (:func:`_install_lazy_linking`); a
compile still refreshes.

Saving and compiling between processes: a save takes a lock on the folder
and writes the data before the index (:func:`install_save_lock`), and two
processes that need one kernel compile it once, the second waiting for
the first (:func:`install_compile_lock`).

Old folders: each load marks its folder as used (its modification time) and
deletes the siblings of the same name pattern beyond the :data:`KEEP` most
recently used, never the current one and never anything else in the base
folder; a failure to delete is ignored (numba recreates a folder deleted
under a running process and only recompiles).  A cache of the kernels
takes a few tens of MB (17 MB after one sitar note).
"""

from __future__ import annotations

import hashlib
import importlib
import os
import pkgutil
import re
import shutil
import tempfile
import threading
from pathlib import Path

#: name of the keyed folder of ``synth.kernels``: ``synth-kernels-<hash>``
NAME = "synth-kernels"
#: hex digits of the sha256 of the sources kept in the folder's name
DIGEST_CHARS = 16
#: keyed folders kept in one base folder, the current one included
KEEP = 3


def source_files(folder: str | os.PathLike) -> list[Path]:
    """The modules hashed for ``folder``: its ``*.py`` files (one level, as
    :func:`load_keyed` imports them), sorted by name."""
    return sorted(Path(folder).glob("*.py"), key=lambda p: p.name)


def toolchain() -> bytes:
    """What compiled code also depends on besides the sources: the versions
    of Python, numba, llvmlite and numpy (hashed into the keyed folder's
    name, so that venvs on other versions never share a folder; numba's
    own index checks only its own version).  Read from the installed
    distributions, without importing them (``synth.dsp.compile_notice``
    computes the same name before numba is imported)."""
    import sys
    from importlib import metadata

    def version(dist):
        try:
            return metadata.version(dist)
        except metadata.PackageNotFoundError:      # pragma: no cover
            return "?"

    return ("python %d.%d numba %s llvmlite %s numpy %s" % (
        sys.version_info[0], sys.version_info[1], version("numba"), version("llvmlite"),
        version("numpy"))).encode()


def source_digest(folder: str | os.PathLike) -> str:
    """First :data:`DIGEST_CHARS` hex digits of the sha256 of the names and
    bytes of :func:`source_files` of ``folder`` and of :func:`toolchain`; an
    empty string if it has no sources."""
    files = source_files(folder)
    if not files:
        return ""
    h = hashlib.sha256()
    tc = toolchain()
    h.update(len(tc).to_bytes(8, "little") + tc)
    for p in files:
        data = p.read_bytes()
        name = p.name.encode()
        h.update(len(name).to_bytes(8, "little") + name)
        h.update(len(data).to_bytes(8, "little") + data)
    return h.hexdigest()[:DIGEST_CHARS]


def folder_name(name: str, digest: str) -> str:
    """The keyed folder's name, ``<name>-<digest>``."""
    return f"{name}-{digest}"


def user_cache_base() -> Path:
    """numba's user-wide cache folder (where numba falls back when a
    module's ``__pycache__`` is not writable)."""
    try:
        from numba.misc.appdirs import AppDirs

        return Path(AppDirs(appname="numba", appauthor=False).user_cache_dir)
    except Exception:  # pragma: no cover - numba without its appdirs copy
        xdg = os.environ.get("XDG_CACHE_HOME")
        return Path(xdg) / "numba" if xdg else Path.home() / ".cache" / "numba"


def candidate_bases(folder: str | os.PathLike, user_base: str | os.PathLike | None) -> list[Path]:
    """Base folders to try, in order: ``user_base`` (``NUMBA_CACHE_DIR``) if
    set, ``folder/__pycache__``, :func:`user_cache_base`."""
    bases = [Path(user_base)] if user_base else []
    return bases + [Path(folder) / "__pycache__", user_cache_base()]


def _writable(path: Path) -> bool:
    """Create ``path`` and write a temporary file in it (numba's test)."""
    try:
        path.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=path).close()
    except OSError:
        return False
    return True


def choose_dir(folder: str | os.PathLike, name: str = NAME,
               user_base: str | os.PathLike | None = None) -> Path | None:
    """The keyed cache folder for the sources in ``folder``: the first of
    :func:`candidate_bases` ``/ <name>-<digest>`` that can be created and
    written (it is created), or None if none can or ``folder`` has no
    sources.

    Raises
    ------
    ValueError
        If ``name`` is empty or holds a path separator.
    """
    if not name or os.sep in name or "/" in name:
        raise ValueError(f"name = {name!r} must be a non-empty folder name (no path separator)")
    digest = source_digest(folder)
    if not digest:
        return None
    for base in candidate_bases(folder, user_base):
        path = base / folder_name(name, digest)
        if _writable(path):
            return path
    return None


def prune(current: str | os.PathLike, name: str = NAME, keep: int = KEEP) -> list[Path]:
    """Delete the siblings of ``current`` named ``<name>-<digest>`` beyond the
    ``keep`` most recently used (modification time), counting ``current``,
    which is never deleted.  Other entries of the parent folder are left
    alone.  Never raises for a file-system error: what cannot be listed or
    deleted stays.

    Returns
    -------
    list of Path
        The folders deleted.

    Raises
    ------
    ValueError
        If ``keep`` < 1.
    """
    if keep < 1:
        raise ValueError(f"keep = {keep!r} must be >= 1 (the current folder is always kept)")
    current = Path(current)
    pattern = re.compile(re.escape(name) + "-[0-9a-f]{%d}" % DIGEST_CHARS)
    try:
        siblings = []
        for entry in os.scandir(current.parent):
            if (entry.name != current.name and pattern.fullmatch(entry.name)
                    and entry.is_dir(follow_symlinks=False)):
                siblings.append((entry.stat(follow_symlinks=False).st_mtime, entry.path))
    except OSError:
        return []
    siblings.sort(reverse=True)
    deleted = []
    for _, path in siblings[keep - 1:]:
        try:
            shutil.rmtree(path)
        except OSError:
            continue
        deleted.append(Path(path))
    return deleted


def load_keyed(package: str, folder: str | os.PathLike, name: str = NAME,
               keep: int = KEEP) -> Path | None:
    """Import every module of ``package`` (its files in ``folder``) with
    numba's cache in the folder keyed on their sources (:func:`choose_dir`,
    the user's ``numba.config.CACHE_DIR`` as first base), then restore
    ``numba.config.CACHE_DIR``, mark the folder used and :func:`prune` its
    old siblings.  Call it from the package's ``__init__``, before any of
    its modules is imported.

    Returns
    -------
    Path or None
        The keyed folder, or None if none could be used (the modules are
        imported all the same, with numba's default cache).
    """
    from numba.core import config as nbconfig

    # numba re-reads its NUMBA_* variables before a compile when one changed
    # since it last read them; reading them now keeps that from resetting
    # CACHE_DIR while the modules are decorated
    nbconfig.reload_config()
    user_base = nbconfig.CACHE_DIR
    path = choose_dir(folder, name, user_base)
    if path is not None:
        nbconfig.CACHE_DIR = str(path)
        _KeyedLocator.folder = os.path.abspath(os.fspath(folder))
    try:
        for mod in pkgutil.iter_modules([str(folder)]):
            importlib.import_module(f"{package}.{mod.name}")
    finally:
        nbconfig.CACHE_DIR = user_base
        _KeyedLocator.folder = None
        _KeyedLocator.checked = None
    if path is not None:
        try:
            os.utime(path)
        except OSError:
            pass
        prune(path, name, keep)
        install_save_lock(path)
        install_light_load(path)
        install_compile_lock(path)
    return path


def _keyed_locator_class():
    """numba's locator for a cache folder given by the user, without the
    path of the sources in it (see :class:`_KeyedLocator`); None for a numba
    without it."""
    try:
        from numba.core import caching
    except ImportError:                      # pragma: no cover
        return None
    base = getattr(caching, "UserProvidedCacheLocator", None)
    impl = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl", None)
    if base is None or impl is None or not isinstance(
            getattr(impl, "_locator_classes", None), list):
        return None                          # pragma: no cover - another numba

    class KeyedLocator(base):
        """Entries of the modules in :attr:`folder`, while :func:`load_keyed`
        decorates them, go straight into the keyed folder
        (``numba.config.CACHE_DIR`` then) under the package folder's name:
        numba's own locator adds a sha1 of the sources' absolute path, so
        the same sources installed elsewhere (a wheel in a new venv, another
        checkout) compiled everything again into a folder of their own,
        though the keyed folder's name already holds a hash of every
        kernel's bytes and the versions that compiled them (the path adds
        nothing to what decides the code)."""

        folder: str | None = None

        def __init__(self, py_func, py_file):
            super().__init__(py_func, py_file)
            from numba.core import config as nbconfig

            self._cache_path = os.path.join(nbconfig.CACHE_DIR,
                                            os.path.basename(os.path.dirname(py_file)))

        #: the folder whose existence and writability this process checked
        #: while :func:`load_keyed` decorated the kernels
        checked: str | None = None

        @classmethod
        def from_function(cls, py_func, py_file):
            if cls.folder is None or os.path.dirname(os.path.abspath(py_file)) != cls.folder:
                return None
            return super().from_function(py_func, py_file)

        def ensure_cache_path(self):
            """numba's check (the folder made, a temporary file written in
            it and removed) once per folder while the kernels are
            decorated, not once per function: 136 functions made and
            removed 136 files at every start (12 ms); numba's check before
            each save stays as it is."""
            path = self.get_cache_path()
            if type(self).folder is not None and type(self).checked == path:
                return
            super().ensure_cache_path()
            if type(self).folder is not None:
                type(self).checked = path

    impl._locator_classes.insert(0, KeyedLocator)
    return KeyedLocator


class _NoLocator:
    folder: str | None = None
    checked: str | None = None


_KeyedLocator = _keyed_locator_class() or _NoLocator


#: name of the lock file in a keyed folder (:func:`install_save_lock`)
LOCK_NAME = ".save.lock"
_LOCKED_ROOTS: set[str] = set()


def install_save_lock(root: str | os.PathLike) -> bool:
    """Make numba's saves of cache entries under ``root`` safe between
    processes; returns whether the guard is in place.

    numba 0.68 saves an entry (``IndexDataCacheFile.save``) by reading the
    function's index, naming the data file by the first number that no
    signature in it uses, writing the index and then the data, with no
    lock.  Two processes that compile two signatures of one function at
    once (two test workers, two Dask workers, ``render_big_groups`` typed
    with ``nt`` None in one and int64 in the other) can both take number 1:
    the index then names one signature and the data file holds the other's
    code, and every later process that loads that signature runs code
    compiled for other types (a grand note crashed with signal 11 on such a
    cache, and rendered on a fresh one).  The guard takes an exclusive lock
    on ``root/.save.lock`` (``fcntl.flock``) around the whole save and writes
    the data before the index, so an index never names data that is not
    there or not its own.  Loads take no lock: both files are replaced
    atomically (numba writes a temporary file and renames it).  Without
    ``fcntl`` (Windows) only the order is changed."""
    try:
        from numba.core import caching
    except ImportError:                      # pragma: no cover
        return False

    def make(plain):
        def save(self, key, data):
            root = _root_of(self, _LOCKED_ROOTS)
            if root is None:
                return plain(self, key, data)
            with _flocked(os.path.join(root, LOCK_NAME)):
                _save_in_order(self, key, data)
        return save

    return _patch(getattr(caching, "IndexDataCacheFile", None), "save",
                  ("_load_index", "_save_index", "_save_data", "_data_name"),
                  _LOCKED_ROOTS, root, make)


#: the folder, in a keyed folder, of the kernels' compile locks (:func:`install_compile_lock`)
COMPILE_LOCKS = ".compile"
#: the longest a process waits for another's compile of a kernel before it
#: compiles the kernel itself (s): a compile that is stuck or very slow only
#: costs the waiter what the lock would have saved
COMPILE_WAIT_S = 900.0
_COMPILE_ROOTS: set[str] = set()


def install_compile_lock(root: str | os.PathLike) -> bool:
    """Make two processes that need one kernel of ``root`` compile it once:
    returns whether the guard is in place.

    numba compiles a function that its cache lacks in every process that
    calls it, each on its own, and saves it from each.  Two processes
    started together on a cold cache (``synth demo``'s phrases, ``synth
    warmup --jobs 2``, two test workers, Dask workers) therefore compile
    the kernels they share twice: ``synth warmup --jobs 2`` spent 378 CPU
    s compiling against 248 on one process (``docs/benchmarks.md``,
    "Start-up").  Here ``Dispatcher.compile`` of a function cached under
    ``root`` takes an exclusive lock named after the function
    (``root/.compile/<module>.<name>.lock``, ``fcntl.flock``) around
    numba's own load-or-compile: a second process waits for the first and
    then loads what it saved.  Locks are per function and taken from caller
    to callee (numba compiles a callee while typing its caller), and the
    kernels call each other without cycles, so two processes never wait
    for each other (within a process, numba's compiler lock is taken
    first, so one thread at a time holds any); a wait longer than
    :data:`COMPILE_WAIT_S` gives up and compiles.  A function already in this process takes no lock.  Without
    ``fcntl`` (Windows) nothing changes."""
    try:
        import fcntl
        from numba.core import dispatcher, sigutils
        from numba.core.compiler_lock import global_compiler_lock
    except ImportError:                      # pragma: no cover - Windows, another numba
        return False
    del fcntl                                # (only whether there is one: _flocked takes it)
    cls = getattr(dispatcher, "Dispatcher", None)
    if cls is None or not hasattr(cls, "compile"):
        return False                         # pragma: no cover - another numba
    _COMPILE_ROOTS.add(os.path.abspath(os.fspath(root)))
    plain = cls.compile
    if hasattr(plain, "__wrapped_plain__"):
        return True

    def compile(self, sig):
        root = _root_of(getattr(self, "_cache", None), _COMPILE_ROOTS)
        if root is None or not hasattr(self, "overloads") or not hasattr(self, "py_func"):
            return plain(self, sig)
        try:
            args, _ = sigutils.normalize_signature(sig)
            if tuple(args) in self.overloads:
                return plain(self, sig)
        except Exception:                    # (numba's compile says what is wrong)
            return plain(self, sig)
        f = self.py_func
        name = re.sub(r"[^A-Za-z0-9_.-]", "_", f"{f.__module__}.{f.__qualname__}")
        # numba's own lock first (re-entrant: numba's compile takes it
        # again): one thread of a process at a time holds compile locks, so
        # two threads never hold one each and wait for the other's
        with global_compiler_lock, _flocked(os.path.join(root, COMPILE_LOCKS, name + ".lock"),
                                            COMPILE_WAIT_S):
            return plain(self, sig)

    compile.__wrapped_plain__ = plain
    cls.compile = compile
    return True


def _save_in_order(cache_file, key, data) -> None:
    """numba's ``IndexDataCacheFile.save`` of ``cache_file`` with the data
    written before the index (:func:`install_save_lock`)."""
    overloads = cache_file._load_index()
    data_name = overloads.get(key)
    if data_name is None:
        used = set(overloads.values())
        i = 1
        while cache_file._data_name(i) in used:
            i += 1
        data_name = cache_file._data_name(i)
    cache_file._save_data(data_name, data)
    overloads[key] = data_name
    cache_file._save_index(overloads)


def _patch(cls, name: str, need, roots: set, root, make) -> bool:
    """Replace numba's ``cls.<name>`` by ``make(the plain method)`` (once
    per process), for the cache folders of ``roots``, to which ``root`` is
    added; False (nothing changed) for a numba whose ``cls`` lacks the
    method or any of the attributes ``need`` the replacement relies on."""
    if cls is None or not all(hasattr(cls, a) for a in (name, *need)):
        return False                         # another numba: leave it as it is
    roots.add(os.path.abspath(os.fspath(root)))
    plain = getattr(cls, name)
    if hasattr(plain, "__wrapped_plain__"):
        return True
    new = make(plain)
    new.__wrapped_plain__ = plain
    setattr(cls, name, new)
    return True


def _root_of(cache, roots) -> str | None:
    """The folder of ``roots`` that holds the entries of ``cache`` (a numba
    cache object: its ``_cache_path``), or None."""
    path = getattr(cache, "_cache_path", None)
    if not path:                             # (a function without a cache: numba's NullCache)
        return None
    path = os.path.abspath(path)
    for r in roots:
        if path == r or path.startswith(r + os.sep):
            return r
    return None


_LIGHT_ROOTS: set[str] = set()


def install_light_load(root: str | os.PathLike) -> bool:
    """Load cached entries under ``root`` without numba's refresh of the
    target context; returns whether the change is in place.

    numba 0.68's ``Cache.load_overload`` calls ``target_context.refresh()``
    before it reads an entry.  The first refresh of a process imports and
    installs every lowering registry numba has (its linalg, random, typed
    containers, datetime, the CPython builtins) and refreshes the typing
    context: what a *compile* needs.  Loading compiled code needs none of
    it: ``CompileResult._rebuild`` unserializes the library, links it
    (which needs the runtime's symbols, :func:`rtsys.initialize`, the first
    thing refresh does) and runs the parallel loops' re-initialisers.  A
    compile still refreshes the contexts itself (``CompilerBase``), so a
    cache miss later in the process is unaffected.  A warm ``synth note
    sitar`` spent 0.24 s of its 0.63 s after start-up in that refresh (a
    2-vCPU Xeon: 0.41 s without it, the same bytes; ``tools/bench.py
    startup``).  Entries of other folders (other libraries' numba
    functions) keep numba's own load."""
    try:
        from numba.core import caching
        from numba.core.runtime import rtsys
    except ImportError:                      # pragma: no cover
        return False
    if not hasattr(rtsys, "initialize"):
        return False                         # pragma: no cover - another numba

    # (and without parsing each library's module for linking: _install_lazy_linking)
    lazy = _install_lazy_linking()

    def make(plain):
        def load_overload(self, sig, target_context):
            if _root_of(self, _LIGHT_ROOTS) is None:
                return plain(self, sig, target_context)
            rtsys.initialize(target_context)
            with self._guard_against_spurious_io_errors():
                if not lazy:
                    return self._load_overload(sig, target_context)
                _LAZY.on = True
                try:
                    return self._load_overload(sig, target_context)
                finally:
                    _LAZY.on = False
        return load_overload

    return _patch(getattr(caching, "Cache", None), "load_overload",
                  ("_load_overload", "_guard_against_spurious_io_errors"), _LIGHT_ROOTS, root, make)


class _Flag(threading.local):
    on = False


#: on while install_light_load's load of a keyed-folder entry runs
_LAZY = _Flag()


def _install_lazy_linking() -> bool:
    """Let a library unserialized from object code while :data:`_LAZY` is
    on skip parsing its module for linking; returns whether in place.

    numba 0.68 (``CPUCodeLibrary._unserialize``) parses an entry's bitcode
    (the whole call tree's IR, kept for inlining into later compiles) and
    walks it through ctypes to list the symbols the library defines: 0.16
    of the grand note's 0.24 s of loads (a 2-vCPU Zen 3).  Here
    the names come from the object code's ELF symbol table (the same
    names, less the internal ``.const.`` strings, which numba never looks
    up by name) and the bitcode is parsed
    only when a compile links the library in.  The machine code is
    numba's own: the same samples.  Non-ELF objects keep numba's path."""
    try:
        import llvmlite.binding as ll
        from numba.core import codegen
    except ImportError:                      # pragma: no cover
        return False
    cls = getattr(codegen, "CPUCodeLibrary", None)
    unser = None if cls is None else cls.__dict__.get("_unserialize")
    link = None if cls is None else cls.__dict__.get("_get_module_for_linking")
    if not isinstance(unser, classmethod) or link is None:
        return False                         # pragma: no cover - another numba
    if hasattr(unser.__func__, "__wrapped_plain__"):
        return True
    plain = unser.__func__

    def _unserialize(klass, cg, state):
        name, kind, data = state
        engine = getattr(cg, "_engine", None)
        if (_LAZY.on and kind == "object"
                and isinstance(getattr(engine, "_defined_symbols", None), set)):
            names = elf_defined_symbols(data[0])
            if names:
                self = cg.create_library(name)
                self.enable_object_caching()
                self._set_compiled_object(data[0])
                self._synth_linking_bitcode = data[1]
                self._finalize_final_module()
                engine._defined_symbols |= names
                return self
        return plain(klass, cg, state)

    def _get_module_for_linking(self):
        bitcode = self.__dict__.pop("_synth_linking_bitcode", None)
        if bitcode is not None:
            self._shared_module = ll.parse_bitcode(bitcode)
        return link(self)

    _unserialize.__wrapped_plain__ = plain
    cls._unserialize = classmethod(_unserialize)
    cls._get_module_for_linking = _get_module_for_linking
    return True


def elf_defined_symbols(obj: bytes) -> set[str] | None:
    """The global and weak symbols an ELF64 little-endian object defines
    (its ``.symtab``); None if ``obj`` is not one or has no symbol table."""
    import struct

    if len(obj) < 64 or obj[:4] != b"\x7fELF" or obj[4] != 2 or obj[5] != 1:
        return None
    try:
        shoff, = struct.unpack_from("<Q", obj, 0x28)
        shentsize, shnum = struct.unpack_from("<HH", obj, 0x3A)
        sections = [struct.unpack_from("<IIQQQQIIQQ", obj, shoff + i * shentsize)
                    for i in range(shnum)]
        tables = [sh for sh in sections if sh[1] == 2]          # SHT_SYMTAB
        names: set[str] = set()
        for _, _, _, _, off, size, link, _, _, entsize in tables:
            strtab = sections[link][4]
            for j in range(size // entsize if entsize else 0):
                st_name, info, _, shndx, _, _ = struct.unpack_from("<IBBHQQ", obj, off + j * entsize)
                if st_name and shndx != 0 and (info >> 4) in (1, 2, 10):   # GLOBAL, WEAK, UNIQUE
                    end = obj.index(b"\0", strtab + st_name)
                    names.add(obj[strtab + st_name:end].decode())
    except (struct.error, ValueError, IndexError, UnicodeDecodeError):
        return None
    return names if tables else None


class _flocked:
    """An exclusive ``fcntl.flock`` on ``path`` (created, and its folder) for
    a ``with`` block; nothing where ``fcntl`` or the file is not available.
    ``wait_s``: the longest to wait for it (None: as long as it takes); then
    the block runs without it."""

    def __init__(self, path: str, wait_s: float | None = None):
        self.path = path
        self.wait_s = wait_s
        self.fd = None

    def __enter__(self):
        try:
            import fcntl
        except ImportError:                  # pragma: no cover (Windows)
            return self
        try:
            try:
                self.fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o666)
            except FileNotFoundError:
                os.makedirs(os.path.dirname(self.path), exist_ok=True)
                self.fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o666)
            if self.wait_s is None:
                fcntl.flock(self.fd, fcntl.LOCK_EX)
            else:
                import time

                end = time.monotonic() + self.wait_s
                while True:
                    try:
                        fcntl.flock(self.fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                        break
                    except BlockingIOError:
                        if time.monotonic() >= end:
                            raise
                        time.sleep(0.05)
        except OSError:
            if self.fd is not None:
                os.close(self.fd)
            self.fd = None
        return self

    def __exit__(self, *exc):
        if self.fd is not None:
            import fcntl

            try:
                fcntl.flock(self.fd, fcntl.LOCK_UN)
            finally:
                os.close(self.fd)
        return False
