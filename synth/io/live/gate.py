"""Let JACK's process thread out of Python before its client is deactivated.

``jack_deactivate`` (and ``jack_client_close``, which calls it) in JACK2
stops the client's process thread with ``pthread_cancel``
(``JackPosixThread::Kill``).  A thread running C code is cancelled at its
next cancellation point; for a Python process callback that can be the
wait for the interpreter's lock (``take_gil``'s ``pthread_cond_timedwait``,
when another thread of ours holds it) or a wait inside the callback.  The
thread then dies holding that lock, and every other thread of the process
waits for it for ever: ``synth play --jack`` hung at Ctrl-C/SIGTERM.

Measured with a JACK-Client client whose callback runs about
1 ms of Python while another thread spins (``jackd -d dummy -r 48000 -p
128``): deactivating it hung 16 runs of 20; with the gate closed first and
the spinning thread stopped, 0 of 20.  The full-suite run that found it
hung ``tests/test_jack.py::test_sigterm_stops_the_play_as_ctrl_c_does``
for 14 minutes, the main thread in ``jack_deactivate``'s return waiting for
a lock last held by the cancelled process thread.

So a client is closed in this order: :meth:`ProcessGate.close` (the
callback, from its next cycle, only writes silence and returns; the call
waits for a cycle in progress to end), then stop every other thread of ours
that may hold the interpreter's lock for long (the rehearsal, the
recorder), then ``deactivate``.  The callback's own cost is two attribute
writes and a ``try``.
"""

from __future__ import annotations

import time

__all__ = ["ProcessGate"]


class ProcessGate:
    """Whether the process callback may run, and whether it is running.

    The callback does::

        gate.inside = True
        try:
            if gate.closed:
                ...  # silence, return
            ...      # the cycle's work
        finally:
            gate.inside = False
    """

    __slots__ = ("closed", "inside")

    def __init__(self) -> None:
        self.closed = False
        self.inside = False

    def open(self) -> None:
        """Let the callback work again (a client opened anew)."""
        self.closed = False

    def close(self, timeout_s: float = 1.0) -> bool:
        """Close the gate and wait, up to ``timeout_s`` seconds, for a cycle
        in progress to end; returns whether it ended (False: the callback is
        stuck, and deactivating may still hang)."""
        self.closed = True
        t_end = time.monotonic() + float(timeout_s)
        while self.inside:
            if time.monotonic() >= t_end:
                return False
            time.sleep(0.0005)
        return True
