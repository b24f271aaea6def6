"""Per-key string designs kept on disk between runs (issue 39: a warm start).

Designing every key of a preset is pure arithmetic on the preset's data
(the loop filters, the dispersion cascade, the contact's profile), and it
is most of a warm start: the sitar's 128 keys took 0.94 CPU s of its
1.9 s to ``synth play``'s first sound, the grand's keys and sympathetic
strings 0.75 s.  A voice that has designed its keys (:meth:`Voice.warm`)
saves them here; the next process with the same designs loads them in a
few milliseconds instead.

A stored design can never be stale, because the file's name is a digest
of everything that decides it:

* the source of every module of the ``synth`` package (any edit of the
  code, or another version installed, gives other names);
* numpy's and Python's versions;
* the key the voice gives: its preset (the validated dataclass, every
  value of the file and of ``--set``), its internal rate and its tolerances.

A file that does not load (cut short, another pickle protocol) is ignored
and designed again.  Writes go to a temporary file renamed into place, so
two processes saving at once leave one whole file.  The folder keeps the
:data:`KEEP` newest files.

``SYNTH_DESIGN_CACHE``: the folder (default ``$XDG_CACHE_HOME/synth/designs``,
else ``~/.cache/synth/designs``), or ``off`` to neither read nor write.
"""

from __future__ import annotations

import hashlib
import os
import pickle
import sys
import tempfile
from pathlib import Path

__all__ = ["ENV", "KEEP", "folder", "kept", "load", "save", "source_digest"]

#: the environment variable naming the folder (or ``off``)
ENV = "SYNTH_DESIGN_CACHE"
#: files kept in the folder (the newest by modification time).  Every preset
#: variant (each ``--set``) and rate has its own files, a few per preset
#: (keys 50-600 kB, free strings and sympathetic strings under 100 kB): 32
#: were evicted by one test run's variants, and the next warm start designed
#: everything again; 128 hold a few dozen variants in some 10-30 MB
KEEP = 128
_OFF = ("off", "0", "no", "false")
_digest: str | None = None


def folder() -> Path | None:
    """The folder designs are stored in, or None when ``SYNTH_DESIGN_CACHE=off``."""
    v = os.environ.get(ENV, "").strip()
    if v.lower() in _OFF:
        return None
    if v:
        return Path(v).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "synth" / "designs"


def source_digest() -> str:
    """SHA-256 over the ``synth`` package's Python sources (paths and
    bytes, in sorted order), numpy's version and Python's: computed once
    per process (about 10 ms)."""
    global _digest
    if _digest is None:
        import numpy as np

        root = Path(__file__).resolve().parents[1]
        h = hashlib.sha256()
        for p in sorted(root.rglob("*.py")):
            h.update(p.relative_to(root).as_posix().encode())
            h.update(b"\0")
            h.update(p.read_bytes())
            h.update(b"\0")
        h.update(f"numpy {np.__version__} python {sys.version}".encode())
        _digest = h.hexdigest()
    return _digest


def _path(kind: str, key) -> Path | None:
    d = folder()
    if d is None:
        return None
    h = hashlib.sha256(source_digest().encode())
    h.update(kind.encode())
    h.update(repr(key).encode())
    return d / f"{kind}-{h.hexdigest()[:32]}.pkl"


def load(kind: str, key):
    """The designs saved under ``kind`` and ``key`` (a value whose repr
    names everything they depend on besides the code), or None."""
    p = _path(kind, key)
    if p is None:
        return None
    try:
        with open(p, "rb") as f:
            return pickle.load(f)
    except (OSError, EOFError, pickle.UnpicklingError, AttributeError, ImportError,
            IndexError, TypeError, ValueError):
        return None


def save(kind: str, key, value) -> bool:
    """Store ``value`` under ``kind`` and ``key``; True if written.  A
    folder that cannot be written is not an error (the designs are then
    made again next time)."""
    p = _path(kind, key)
    if p is None:
        return False
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=".design-", dir=p.parent)
        try:
            with os.fdopen(fd, "wb") as f:
                pickle.dump(value, f, protocol=pickle.HIGHEST_PROTOCOL)
            os.replace(tmp, p)
        except BaseException:
            try:
                os.unlink(tmp)
            except OSError:
                pass
            raise
        _prune(p.parent)
        return True
    except OSError:
        return False


def kept(memo: dict, kind: str, key, make, valid=lambda value: True):
    """The design of ``kind`` and ``key`` for this process: ``memo[key]`` if
    this process has it, else the stored one (when ``valid(value)``), else
    ``make()``, saved; kept in ``memo`` (a module's dict: every engine built
    in the process shares it; ``key`` must be hashable)."""
    if key not in memo:
        value = load(kind, key)
        if value is None or not valid(value):
            value = make()
            save(kind, key, value)
        memo[key] = value
    return memo[key]


def _prune(d: Path) -> None:
    try:
        files = sorted(d.glob("*.pkl"), key=lambda q: q.stat().st_mtime, reverse=True)
        for q in files[KEEP:]:
            q.unlink()
    except OSError:
        pass
