"""Saying so when the numba kernels compile, and how long they took.

The first run on a machine (or after an edit to ``synth/kernels``) compiles
the string kernels for this CPU: a minute or more of silence before the
first sound.  This module

* tells, without importing numba, whether the keyed cache folder of the
  kernels (:mod:`synth.kernels.cache`) holds the bank renderer's index
  (:func:`cache_looks_warm`: a few ``stat`` calls), so that the ``synth``
  command can say what is happening within its first second
  (:func:`arm`);
* listens to numba's ``numba:compile`` event (:func:`listen`, called when
  :mod:`synth.dsp.bank` is imported: numba is loaded then anyway): one
  event per kernel numba compiles, none for one it loads from its cache.
  Once armed, the first compile prints the line if the pre-check did not
  (on a stream that is not a terminal there is no pre-check: the line
  comes with the first compile, and a user error stays the only line),
  and on a terminal a counter of the kernels compiled so far (tqdm);
* adds up the wall time spent compiling (:func:`compile_seconds`), so that
  a command can report its render time without the compile.

Only the ``synth`` command arms it (:func:`synth.cli.main` run from the
command line): the library and the tests in-process print nothing.  On a
stream that is not a terminal (a CI log) it prints the one line and no
progress.  ``SYNTH_COMPILE_NOTICE=0`` keeps it quiet.  On a warm cache it
prints nothing and costs the pre-check (a hash of the kernels' sources and
a few ``stat`` calls, about 2 ms).
"""

from __future__ import annotations

import hashlib
import os
import sys
import threading
import time
from pathlib import Path

#: the kernel whose cache index tells a warm cache (every render compiles or loads it)
PROBE_INDEX = "render.render_bank-*.nbi"
#: the line printed before a cold compile
#: (measured, 2-vCPU Xeons, fresh ``NUMBA_CACHE_DIR``: ``synth note sitar --key 57
#: --seconds 1`` compiled for 29-49 s (model 167) and 52 s (model 207); ``synth demo``,
#: whose phrases of overlapping notes also compile the shards of several strings
#: (``render_sharded``), 104-133 s and 194-219 s, and 50 s (model 207) with its
#: phrases on two processes and the renderers called by address;
#: a note with half its kernels compiled by a second process, model 167: the
#: sitar 19-20 s, the grand 39 s, the biwa 24 s; docs/benchmarks.md,
#: "Start-up")
MESSAGE = ("synth: compiling the string kernels for this CPU, once (on 2 cores 20-40 s "
           "for a note, a minute or more for a phrase; `synth warmup` does it ahead of "
           "time) ...")

_lock = threading.Lock()
_state = {
    "armed": False,       # print the line and the progress (the synth command)
    "said": False,        # the line has been printed
    "stream": None,
    "depth": 0,           # nesting of compile events
    "t0": 0.0,            # wall time the outermost compile started
    "seconds": 0.0,       # wall time in outermost compiles, summed
    "count": 0,           # synth kernels compiled in this process
    "bar": None,
    "ticker": None,       # the Event that stops the bar's refreshing thread
    "listening": False,
}

#: seconds between two refreshes of the progress line while a kernel compiles
#: (tqdm redraws only on an update, and one kernel may compile for 15 s: the
#: elapsed time would stand still)
TICK_S = 0.5


def _kernels_dir() -> Path:
    return Path(__file__).resolve().parents[1] / "kernels"


def _digest(folder: Path) -> str:
    """:func:`synth.kernels.cache.source_digest`, without importing the
    kernels (whose package imports numba and every kernel module)."""
    files = sorted(folder.glob("*.py"), key=lambda p: p.name)
    if not files:
        return ""
    h = hashlib.sha256()
    from importlib import metadata

    def version(dist):
        try:
            return metadata.version(dist)
        except metadata.PackageNotFoundError:      # pragma: no cover
            return "?"

    tc = ("python %d.%d numba %s llvmlite %s numpy %s" % (
        sys.version_info[0], sys.version_info[1], version("numba"), version("llvmlite"),
        version("numpy"))).encode()
    h.update(len(tc).to_bytes(8, "little") + tc)
    for p in files:
        data = p.read_bytes()
        name = p.name.encode()
        h.update(len(name).to_bytes(8, "little") + name)
        h.update(len(data).to_bytes(8, "little") + data)
    return h.hexdigest()[:16]


def keyed_folders() -> list[Path]:
    """Where :mod:`synth.kernels.cache` may put the kernels' keyed folder,
    in its order (``NUMBA_CACHE_DIR``, the kernels' ``__pycache__``, the
    user-wide numba cache)."""
    folder = _kernels_dir()
    d = _digest(folder)
    if not d:
        return []
    bases = []
    if os.environ.get("NUMBA_CACHE_DIR"):
        bases.append(Path(os.environ["NUMBA_CACHE_DIR"]))
    bases.append(folder / "__pycache__")
    xdg = os.environ.get("XDG_CACHE_HOME")
    bases.append(Path(xdg) / "numba" if xdg else Path.home() / ".cache" / "numba")
    return [b / f"synth-kernels-{d}" for b in bases]


def cache_looks_warm(probe: str = PROBE_INDEX) -> bool:
    """True when the first existing keyed folder holds the bank renderer's
    cache index (or the index file pattern ``probe``, such as
    ``"render._block_a-*.nbi"``): the kernels were compiled for these
    sources (for some CPU: a cache shared between different CPUs still
    compiles, and the listener then says so).  No numba import; about 20
    ms, most of it reading the installed versions of numba, llvmlite and
    numpy."""
    folders = keyed_folders()
    if os.environ.get("NUMBA_CACHE_DIR"):
        # numba compiles into that folder (synth.kernels.cache creates it if
        # missing), whatever the others hold
        folders = folders[:1]
    for path in folders:
        if path.is_dir():
            return any(path.glob("*/" + probe)) or any(path.glob(probe))
    return False


def _enabled() -> bool:
    return os.environ.get("SYNTH_COMPILE_NOTICE", "1") not in ("0", "no", "off", "")


def _say(stream) -> None:
    if not _state["said"]:
        _state["said"] = True
        print(MESSAGE, file=stream, flush=True)


def arm(stream=None, precheck: bool | None = None) -> bool:
    """Print the compile line (and, on a terminal, progress) from now on.

    With ``precheck`` (default: when ``stream`` is a terminal), print it at
    once if :func:`cache_looks_warm` says the kernels are not compiled:
    within the command's first 0.1 s, where the first compile starts after
    1.2-1.7 CPU s of imports and preset building.  Without (a log, a pipe),
    the line comes with the first compile, so a command that stops on a
    user error before it prints that error alone.  Returns True if it
    printed now."""
    if not _enabled():
        return False
    stream = sys.stderr if stream is None else stream
    if precheck is None:
        precheck = _is_tty(stream)
    with _lock:
        _state["armed"] = True
        _state["stream"] = stream
        if precheck and not _state["said"] and not cache_looks_warm():
            _say(stream)
            return True
    return False


def disarm() -> None:
    with _lock:
        _state["armed"] = False
        _close_bar()


def _tick(bar, stop: threading.Event) -> None:
    """Redraw ``bar`` (its elapsed time) every :data:`TICK_S` until stopped."""
    while not stop.wait(TICK_S):
        with _lock:
            if _state["bar"] is not bar:
                return
            try:
                bar.refresh()
            except Exception:  # pragma: no cover
                return


def _close_bar() -> None:
    ticker = _state["ticker"]
    if ticker is not None:
        _state["ticker"] = None
        ticker.set()
    bar = _state["bar"]
    if bar is not None:
        _state["bar"] = None
        try:
            bar.close()
        except Exception:  # pragma: no cover
            pass


def _is_tty(stream) -> bool:
    try:
        return stream.isatty()
    except Exception:
        return False


def _ours(data) -> bool:
    try:
        mod = data["dispatcher"].py_func.__module__
    except Exception:  # pragma: no cover
        return False
    return mod.startswith("synth.")


def _on_start(data) -> None:
    with _lock:
        if _state["depth"] == 0:
            _state["t0"] = time.perf_counter()
        _state["depth"] += 1
        if _state["armed"] and _ours(data):
            stream = _state["stream"]
            _say(stream)
            if _state["bar"] is None and _is_tty(stream):
                try:
                    from tqdm import tqdm

                    bar = tqdm(desc="synth: kernels compiled", unit=" kernels",
                               initial=_state["count"], file=stream, leave=False,
                               bar_format="{desc}: {n_fmt} [{elapsed}]")
                except Exception:
                    bar = None
                _state["bar"] = bar
                if bar is not None:
                    stop = _state["ticker"] = threading.Event()
                    threading.Thread(target=_tick, args=(bar, stop), name="synth-compile-bar",
                                     daemon=True).start()


def _on_end(data) -> None:
    with _lock:
        _state["depth"] -= 1
        if _ours(data):
            _state["count"] += 1
            bar = _state["bar"]
            if bar is not None:
                bar.update(1)
        if _state["depth"] == 0:
            _state["seconds"] += time.perf_counter() - _state["t0"]
            _close_bar()


def listen() -> None:
    """Register the listener on numba's compile event (once; imports numba)."""
    if _state["listening"]:
        return
    from numba.core import event as ev

    class _Listener(ev.Listener):
        def on_start(self, event):
            _on_start(event.data)

        def on_end(self, event):
            _on_end(event.data)

    ev.register("numba:compile", _Listener())
    _state["listening"] = True


def add_compile_seconds(seconds: float) -> None:
    """Count ``seconds`` of waiting for another process's compile
    (:mod:`synth.apps.cold_start`) as compiling."""
    with _lock:
        _state["seconds"] += float(seconds)


def compile_seconds() -> float:
    """Wall seconds this process has spent compiling numba functions (since
    :func:`listen`; a compile under way counts up to now)."""
    with _lock:
        s = _state["seconds"]
        if _state["depth"] > 0:
            s += time.perf_counter() - _state["t0"]
        return s


def kernels_compiled() -> int:
    """How many of synth's numba functions this process compiled (and did
    not load from the cache) since :func:`listen`."""
    return _state["count"]


def timing_note(seconds: float) -> str:
    """`` (+ X s compiling the kernels, once)`` for a render that included
    ``seconds`` of compiling, else an empty string."""
    if seconds < 0.05:
        return ""
    return f" (+ {seconds:.1f} s compiling the kernels for this CPU, once)"
