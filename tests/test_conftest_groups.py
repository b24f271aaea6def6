"""The xdist groups of tests/conftest.py reach xdist's scheduler: on a worker
of ``-n N --dist loadgroup`` (pyproject's addopts), every collected test of a
grouped module carries its group in its node id (``...@batch``), which is
what the scheduler reads to keep a group on one worker; and a test that
takes the machine to itself (conftest's ``alone``) waits for the others and
holds off new ones."""

import threading
import time

import pytest

from conftest import XDIST_GROUPS, _Share


def test_every_test_of_a_grouped_module_carries_its_group(request):
    cfg = request.config
    if not hasattr(cfg, "workerinput") or not cfg.getvalue("loadgroup"):
        pytest.skip("only an xdist worker under --dist loadgroup names the groups")
    grouped = [it for it in request.session.items if it.path.name in XDIST_GROUPS]
    if not grouped:
        pytest.skip("no test of a grouped module was collected in this run (run the suite)")
    wrong = [it.nodeid for it in grouped if not it.nodeid.endswith("@" + XDIST_GROUPS[it.path.name])]
    assert not wrong, f"{len(wrong)} tests left out of their group, e.g. {wrong[:3]}"


def test_alone_waits_for_the_running_tests_and_holds_off_new_ones(tmp_path):
    """Three workers' holds on one run's lock files (separate descriptors,
    so they exclude one another as processes do): a test running on worker
    A; worker B's test asks to be alone; a test arriving on C meanwhile.  B
    goes in when A's test ends, and C only after B is done."""
    a, b, c = (_Share(str(tmp_path)) for _ in range(3))
    log = []
    a.enter()
    b.enter()

    def quiet():
        with b.alone():
            log.append("B alone")
            time.sleep(0.3)
            log.append("B done")

    def newcomer():
        c.enter()
        log.append("C in")
        c.leave()

    tb = threading.Thread(target=quiet)
    tb.start()
    time.sleep(0.3)
    assert log == []                     # A's test is still running
    tc = threading.Thread(target=newcomer)
    tc.start()
    time.sleep(0.3)
    assert log == []                     # C waits behind B, not beside A
    a.leave()
    tb.join(10)
    tc.join(10)
    assert log == ["B alone", "B done", "C in"]
    b.leave()
