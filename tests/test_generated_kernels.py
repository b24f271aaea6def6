"""The kernels' hand-unrolled filter loops are the template's
(``tools/gen_kernels.py``): each dispatch over a cascade's number of stages
is generated between markers in its kernel file, and a region edited by
hand, or a template changed without regenerating, fails here."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TOOL = ROOT / "tools" / "gen_kernels.py"
FILES = ("far_end.py", "coupled.py")
REGIONS = ("_sections", "_biquads", "_head", "_head_sos", "_lanes_head", "_lanes_biquads")


def _run(tool: Path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(tool), *args], capture_output=True, text=True,
                          timeout=60)


def _copy_tree(tmp_path: Path) -> Path:
    """The tool and the two kernel files in a tree of their own."""
    (tmp_path / "tools").mkdir()
    (tmp_path / "synth" / "kernels").mkdir(parents=True)
    shutil.copy(TOOL, tmp_path / "tools" / TOOL.name)
    for f in FILES:
        shutil.copy(ROOT / "synth" / "kernels" / f, tmp_path / "synth" / "kernels" / f)
    return tmp_path / "tools" / TOOL.name


def test_every_generated_region_is_current():
    r = _run(TOOL, "--check")
    assert r.returncode == 0, r.stdout + r.stderr


def test_every_region_is_marked_once():
    text = "".join((ROOT / "synth" / "kernels" / f).read_text("utf-8") for f in FILES)
    for name in REGIONS:
        assert text.count(f"# <generated: tools/gen_kernels.py {name}>") == 1, name
    assert text.count("# </generated>") == len(REGIONS)


def test_a_region_edited_by_hand_is_found_and_rewritten(tmp_path):
    tool = _copy_tree(tmp_path)
    path = tmp_path / "synth" / "kernels" / "far_end.py"
    good = path.read_text("utf-8")
    # one biquad's recurrence with its multiply-add order changed: the same
    # value in exact arithmetic, other samples in floating point
    old = "o3 = (cb3 * (o2 - y23) + y22 + ca3 * y12) - ca3 * y13"
    i = good.index("# <generated: tools/gen_kernels.py _head_sos>")
    j = good.index(old, i)
    path.write_text(good[:j] + "o3 = (cb3 * (o2 - y23) + y22 + ca3 * (y12 - y13))"
                    + good[j + len(old):], "utf-8")
    r = _run(tool, "--check")
    assert r.returncode == 1
    assert "far_end.py:_head_sos" in r.stdout and "_lanes_head" not in r.stdout
    r = _run(tool)
    assert r.returncode == 0 and "far_end.py:_head_sos" in r.stdout
    assert path.read_text("utf-8") == good


def test_missing_markers_are_one_line_exit_2_and_write_nothing(tmp_path):
    tool = _copy_tree(tmp_path)
    kd = tmp_path / "synth" / "kernels"
    # coupled.py (rendered first) has a stale region, far_end.py lost a marker
    cp = kd / "coupled.py"
    stale = cp.read_text("utf-8").replace("h = loadv(zt, buf, W * i)", "h = loadv(zt, buf, i * W)")
    cp.write_text(stale, "utf-8")
    fe = kd / "far_end.py"
    fe.write_text(fe.read_text("utf-8").replace(
        "# <generated: tools/gen_kernels.py _biquads>", "# (marker lost)"), "utf-8")
    r = _run(tool)
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and "_biquads" in r.stderr
    assert cp.read_text("utf-8") == stale        # nothing half-written
