"""The xdist groups of tests/conftest.py reach xdist's scheduler: on a worker
of ``-n N --dist loadgroup`` (pyproject's addopts), every collected test of a
grouped module carries its group in its node id (``...@batch``), which is
what the scheduler reads to keep a group on one worker."""

import pytest

from conftest import XDIST_GROUPS


def test_every_test_of_a_grouped_module_carries_its_group(request):
    cfg = request.config
    if not hasattr(cfg, "workerinput") or not cfg.getvalue("loadgroup"):
        pytest.skip("only an xdist worker under --dist loadgroup names the groups")
    grouped = [it for it in request.session.items if it.path.name in XDIST_GROUPS]
    if not grouped:
        pytest.skip("no test of a grouped module was collected in this run (run the suite)")
    wrong = [it.nodeid for it in grouped if not it.nodeid.endswith("@" + XDIST_GROUPS[it.path.name])]
    assert not wrong, f"{len(wrong)} tests left out of their group, e.g. {wrong[:3]}"
