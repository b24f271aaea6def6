"""Ctrl-C and SIGTERM during long work: one exception, raised once.

Python turns SIGINT into :class:`KeyboardInterrupt` but leaves SIGTERM to
its default action, which ends the process at once: a temporary file being
written is left behind. Inside :func:`interruptible` both signals raise
:class:`Interrupted` (a :class:`KeyboardInterrupt`) in the main thread, so
every ``finally`` and ``except BaseException`` on the way out runs (the
atomic writers of :mod:`synth.io.wav` delete their temporary file there and
an existing file is never touched). The first signal also ignores further
ones until the block is left, so a second Ctrl-C cannot interrupt that
clean-up. The CLI exits with status 128 + the signal's number (130 for
SIGINT, 143 for SIGTERM), as a shell reports a process killed by it.

Python runs a signal handler in the main thread between two bytecodes,
wherever that is: when it is inside a function that C code called back
(numba compiling a kernel runs llvmlite's object-cache callback through
ctypes), the exception the handler raises is printed ("Exception ignored on
calling ctypes callback function") and lost, and the work would go on to
the end.  So the handler also records the signal, and long loops call
:func:`raise_if_interrupted` between their steps (``synth render`` after
every block): a signal whose exception was lost stops the work there.
"""

from __future__ import annotations

import os
import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["Interrupted", "interruptible", "raise_if_interrupted", "HANDLED_SIGNALS"]

#: the signals :func:`interruptible` turns into :class:`Interrupted`
HANDLED_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Interrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM arrived.

    Parameters
    ----------
    signum : int
        The signal's number.
    detail : str
        What was left undone, for the one-line message (``"out.wav was
        not written"``); empty for none.
    """

    def __init__(self, signum: int, detail: str = "") -> None:
        super().__init__(signum, detail)
        self.signum = int(signum)
        self.detail = detail

    @property
    def signal_name(self) -> str:
        """``"SIGINT"``, ``"SIGTERM"``, ..."""
        try:
            return signal.Signals(self.signum).name
        except ValueError:
            return f"signal {self.signum}"

    @property
    def exit_status(self) -> int:
        """128 + the signal's number, as a shell reports a process it ended."""
        return 128 + self.signum

    def __str__(self) -> str:
        return f"interrupted by {self.signal_name}" + (f": {self.detail}" if self.detail else "")


#: the path part of llvmlite's modules (a frame there is LLVM calling back)
_LLVMLITE = f"{os.sep}llvmlite{os.sep}"

#: signals that arrived inside :func:`interruptible` (its handler appends;
#: entering and leaving the block clears it)
_pending: list[int] = []


def raise_if_interrupted() -> None:
    """Raise :class:`Interrupted` if SIGINT or SIGTERM arrived inside
    :func:`interruptible` and its exception was lost on the way (raised
    inside a ctypes callback); do nothing otherwise.  Cheap: call it once
    per step of a long loop."""
    if _pending:
        raise Interrupted(_pending[0])


@contextmanager
def interruptible(signals=HANDLED_SIGNALS) -> Iterator[None]:
    """Raise :class:`Interrupted` in the main thread on SIGINT or SIGTERM.

    Parameters
    ----------
    signals : sequence of int
        The signals to handle. One that is ignored on entry (``SIG_IGN``, a
        job started with ``nohup`` or in the background) stays ignored.

    Notes
    -----
    Outside the main thread (where Python cannot set handlers) this does
    nothing. The previous handlers are restored on leaving the block.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = {s: signal.getsignal(s) for s in signals}
    mine = [s for s in signals if old[s] != signal.SIG_IGN]

    def handler(signum, frame):
        for s in mine:
            signal.signal(s, signal.SIG_IGN)   # no second interruption of the clean-up
        _pending.append(signum)                # in case the exception below is lost
        if frame is not None and (frame.f_code.co_name == "__del__"
                                  or _LLVMLITE in frame.f_code.co_filename):
            # a finalizer (llvmlite's, numba compiling or loading a kernel)
            # or a callback of LLVM's into llvmlite (its object cache, as a
            # kernel loads) would swallow it and print "Exception ignored
            # ... Traceback" on stderr (the callback's then left LLVM
            # half-way: a segmentation fault): the next
            # raise_if_interrupted raises it instead
            return
        raise Interrupted(signum)

    _pending.clear()
    for s in mine:
        signal.signal(s, handler)
    try:
        yield
    finally:
        _pending.clear()
        for s in mine:
            signal.signal(s, old[s] if old[s] is not None else signal.SIG_DFL)
