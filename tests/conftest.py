"""Test session set-up shared by every test module."""

import os
import signal

import pytest

# OpenMP's threads (numba's "omp" layer, the renders on several threads) wait
# for the next parallel loop by spinning, by default: in a test run, with a
# second worker (pytest-xdist) and the tests' own subprocesses on the same
# cores, the spinning threads took the cores from the work.  Passive waiting
# (asleep until woken) gives the same samples; measured on 89 render tests
# (2 workers, 2 cores, 2026-11-29): 102.5 s of CPU spinning, 36.7 s passive.
# The tests' subprocesses inherit it; a value set by the user is kept.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

# The tests that interrupt a render or the compare server send SIGINT as a
# user's Ctrl-C would.  A test run started as a background job of a
# non-interactive shell (``cmd &``) inherits SIGINT ignored, the shell's rule
# for background jobs, and keeps it ignored (Python installs its Ctrl-C
# handler only where SIGINT is not ignored at start-up), as would every
# ``synth`` process it starts: those tests then failed, testing the shell
# instead of the program (synth.io.interrupt keeps an ignored signal
# ignored, on purpose).  So the session takes Ctrl-C as an interactive one
# does; its children inherit the default disposition at exec.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


# ---- running in parallel (pytest-xdist) ---------------------------------------------
#
# pyproject's addopts run the suite on every core (``-n auto --dist loadgroup``);
# ``-n 0`` runs it in one process.  Tests go to the workers one by one, except
# the groups below, each run by one worker (pytest.mark.xdist_group):
#
# * "realtime": live play on a real audio server or device, or against the
#   clock: test_jack.py (jackd's dummy backend, its clients' callbacks),
#   test_live.py (PortAudio's null device, ALSA's virtual MIDI ports),
#   test_realtime.py (the live engine's block deadlines) and test_compare.py
#   (its browser tests play the page against its audio clock; its pages are
#   module fixtures): one at a time, so they do not take each other's ports
#   and time.
# * a module whose module-scoped fixture is dear (a LocalCluster of two
#   processes, bisected partials, study renders, the grand's notes against
#   the recording): its tests stay together so
#   the fixture is built once, not once per worker.
#
# Everything else is process-local (tmp_path, port 0, the numba cache's
# writes are atomic) and runs anywhere.
XDIST_GROUPS = {
    "test_jack.py": "realtime",
    "test_live.py": "realtime",
    "test_realtime.py": "realtime",
    "test_compare.py": "realtime",
    "test_batch.py": "batch",
    "test_dispersion.py": "dispersion",
    "test_dispersion_sos.py": "dispersion_sos",
    "test_reproduction.py": "reproduction",
    "test_decimator.py": "decimator",
    "test_real_grand_fit.py": "real_grand_fit",
}


# The marks go on each test as it is collected (pytest_itemcollected), before
# any pytest_collection_modifyitems hook: xdist's hook on each worker reads
# them there and appends the group to the test's node id, which its loadgroup
# scheduler reads.  Set in a plain conftest modifyitems hook, they came after
# xdist's (every group split over the workers: a module fixture built on
# both, the realtime tests on both at once).  pytest 9.2 derives node ids from
# a structured id and ignores xdist 3.8's rewrite, so no group holds there
# (pytest-dev/pytest-xdist#1386): pyproject's test extra keeps pytest < 9.2.
# tests/test_conftest_groups.py checks it.
def pytest_itemcollected(item):
    group = XDIST_GROUPS.get(item.path.name)
    if group is not None:
        item.add_marker(pytest.mark.xdist_group(group))


# ``-n auto`` starts one worker more than the cores the process may use.  The
# realtime group's worker spends much of its time waiting: on the JACK
# server's clock (test_jack.py: 81 s of wall time in a run of the suite), on a
# browser, on a subprocess's audio stream.  A third worker on two cores runs
# other tests meanwhile; the JACK clients' process threads run at real-time
# priority and are not slowed by it.  Measured, the whole suite on the 2-vCPU
# Xeon (warm cache, bytecode written, 2026-11-30): 2 workers 334.5 s wall for
# 573.8 s user; 3 workers 311.8 s for 568.6 s (docs/lab/2026-11-30-ci-time.md).
def pytest_xdist_auto_num_workers(config):
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        cores = os.cpu_count() or 1
    return cores + 1


# ---- the machine to itself, for a capture through a real-time server ---------------
#
# A test that captures a live synth through JACK judges what the server's
# clock did: a cycle the server lost (an xrun) tears the capture.  On two
# cores with three workers, the other workers' renders took the cores from
# the synth's process thread (its callback waits for the GIL, which a thread
# of normal priority in the synth may hold), and CI on a 2-vCPU Zen 1 VM
# failed three JACK tests in one run (4 of 8 notes found with 155 xruns during
# play; 2026-12-01) that pass when the machine is quiet.  So such a test
# takes the machine to itself for its capture: ``with alone(): ...`` waits
# until no other worker runs a test, and keeps them from starting one, until
# it ends.  The rest of the test (starting the synth, its kernels, the
# offline references) shares the machine as every test does.
#
# Two flock(2) files in a directory the controller makes for the run (the
# workers inherit its environment): every test holds "room" shared from its
# set-up to its tear-down; ``alone`` holds "gate" and converts its own
# "room" lock to exclusive.  A test entering passes "gate" first, so a
# waiting ``alone`` is not starved by tests that keep arriving.  A worker that
# dies drops its locks with its file descriptors.
import contextlib
import fcntl
import shutil
import tempfile

_SHARE_ENV = "SYNTH_TEST_SHARE_DIR"


class _Share:
    """This process's hold on the run's machine (see above)."""

    def __init__(self, folder: str):
        self.gate = os.open(os.path.join(folder, "gate"), os.O_RDWR | os.O_CREAT, 0o600)
        self.room = os.open(os.path.join(folder, "room"), os.O_RDWR | os.O_CREAT, 0o600)

    def enter(self):
        fcntl.flock(self.gate, fcntl.LOCK_EX)
        try:
            fcntl.flock(self.room, fcntl.LOCK_SH)
        finally:
            fcntl.flock(self.gate, fcntl.LOCK_UN)

    def leave(self):
        fcntl.flock(self.room, fcntl.LOCK_UN)

    @contextlib.contextmanager
    def alone(self):
        fcntl.flock(self.gate, fcntl.LOCK_EX)
        try:
            fcntl.flock(self.room, fcntl.LOCK_EX)   # waits for the other workers' tests to end
            try:
                yield
            finally:
                fcntl.flock(self.room, fcntl.LOCK_SH)
        finally:
            fcntl.flock(self.gate, fcntl.LOCK_UN)


_share = None


def pytest_configure(config):
    global _share
    if not hasattr(config, "workerinput") and _SHARE_ENV not in os.environ:
        folder = tempfile.mkdtemp(prefix="synth-pytest-share-")
        os.environ[_SHARE_ENV] = folder      # before xdist starts the workers
        config._synth_share_dir = folder
    _share = _Share(os.environ[_SHARE_ENV])


def pytest_unconfigure(config):
    folder = getattr(config, "_synth_share_dir", None)
    if folder is not None:
        os.environ.pop(_SHARE_ENV, None)
        shutil.rmtree(folder, ignore_errors=True)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    _share.enter()
    try:
        yield
    finally:
        _share.leave()


@pytest.fixture
def alone():
    """``with alone(): ...``: the block runs with no other worker's test
    running (see the comment above ``_Share``)."""
    return _share.alone
