"""Write the hand-unrolled filter loops of the kernels from one template.

Usage
-----
    python tools/gen_kernels.py            # rewrite the generated regions
    python tools/gen_kernels.py --check    # exit 1 if any region differs

The far end's filter cascades (the loss glide and one-pole loss, the
first-order allpass sections, the biquads) run as one loop per number of
stages, each stage's state in a local variable, so that the compiler keeps
every state in a register and the stages of successive samples overlap (a
loop over the sections with the states in an array runs each recurrence
through memory: docs/benchmarks.md, "One change, one loop").  So each
kernel holds one loop per case, written out: 34 loops in
``synth/kernels/far_end.py`` and ``synth/kernels/coupled.py``.

They are written here, once: a case's loop is the chain of its stages
(:func:`_chain`), and each kernel's dispatch over the cases is generated
between the markers ``# <generated: tools/gen_kernels.py NAME>`` and
``# </generated>`` in its source.  Edit the template, then run this
script; ``tests/test_generated_kernels.py`` fails while a region differs
from what the template gives.  The generated text is plain Python in the
kernel file, so numba compiles and caches it as any other source, and the
keyed cache (:mod:`synth.kernels.cache`) sees an edit.

Exit 0 when the regions are (or are now) current; 1 with ``--check`` and a
region that differs (its name is printed); 2 with a one-line error.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
KERNELS = ROOT / "synth" / "kernels"

IND = "    "


# ---- the stages -------------------------------------------------------------------

def _first_order(j: int, x: str) -> tuple[list[str], str]:
    """First-order allpass j, y = c x + x1 - c y1 (one multiply-add on the
    recurrence, compiled without re-association), on input ``x``."""
    return [f"y{j} = c{j} * {x} + x{j} - c{j} * y{j}", f"x{j} = {x}"], f"y{j}"


def _biquads(cnt: int, x: str, out=None, coef=("ca", "cb")) -> tuple[list[str], str]:
    """``cnt`` biquads in a row, direct form I, y = (c2 (x - y2) + x2 + c1
    x1) - c1 y1, on input ``x``; a biquad's input states are the previous
    one's output states (biquad 0's are x10, x20).  ``out``: the names of
    the outputs (default o0, o1, ...); ``coef``: the names of c1 and c2."""
    out = out or [f"o{j}" for j in range(cnt)]
    a, b = coef
    lines = []
    for j in range(cnt):
        if j == 0:
            lines += [f"{out[0]} = ({b}0 * ({x} - y20) + x20 + {a}0 * x10) - {a}0 * y10",
                      "x20 = x10", f"x10 = {x}"]
        else:
            p = j - 1
            lines += [f"{out[j]} = ({b}{j} * ({out[p]} - y2{j}) + y2{p} + {a}{j} * y1{p})"
                      f" - {a}{j} * y1{j}",
                      f"y2{p} = y1{p}", f"y1{p} = {out[p]}"]
    L = cnt - 1
    lines += [f"y2{L} = y1{L}", f"y1{L} = {out[L]}"]
    return lines, out[L]


def _chain(head: list[str], x: str, n_first: int, n_biquads: int, put: str,
           via_h: bool = True, out=None, coef=("ca", "cb")) -> list[str]:
    """One case's loop body: ``head`` lines giving ``x``, ``n_first``
    first-order sections, ``n_biquads`` biquads (on ``h``, the sections'
    output, when ``via_h``), then ``put`` with ``{}`` the case's output."""
    lines = list(head)
    for j in range(n_first):
        more, x = _first_order(j, x)
        lines += more
    if n_biquads:
        if via_h and x != "h":
            lines.append(f"h = {x}")
            x = "h"
        more, x = _biquads(n_biquads, x, out, coef)
        lines += more
    lines.append(put.format(x))
    return lines


def _loop(body: list[str], depth: int) -> list[str]:
    pad = IND * depth
    return [f"{pad}for i in range(n):"] + [pad + IND + s for s in body]


def _dispatch(cases: list[tuple[str, list[str], list[str], list[str]]]) -> list[str]:
    """``if`` / ``elif`` / ``else`` over (condition, before, body, after):
    the last case is the ``else``."""
    lines = []
    for i, (cond, before, body, after) in enumerate(cases):
        if i == 0:
            lines.append(f"{IND}if {cond}:")
        elif i < len(cases) - 1:
            lines.append(f"{IND}elif {cond}:")
        else:
            lines.append(f"{IND}else:")
        lines += [IND * 2 + s for s in before]
        lines += _loop(body, 2)
        lines += [IND * 2 + s for s in after]
    return lines


def _state_io(j: int) -> tuple[list[str], list[str]]:
    """First-order section j's state (x_j, y_j at st[s_j], st[s_j + 1]):
    its load and its store."""
    return ([f"x{j} = st[s{j}]", f"y{j} = st[s{j} + 1]"],
            [f"st[s{j}] = x{j}", f"st[s{j} + 1] = y{j}"])


# ---- the kernels' regions ---------------------------------------------------------

LOSS = ["b0 = gk * b0 + gc", "lp = b0 * xin[i] - a1 * lp"]
LOSS4 = ["b0 = gk * b0 + gc", "lp = b0 * vec(zt, X0[i], X1[i], X2[i], X3[i]) - a1 * lp"]


def _first_order_cases(head: list[str], x: str, put: str) -> list[str]:
    """cnt (1..4) first-order sections after ``head`` (giving ``x``), each
    case loading and storing the states of sections 1.. (section 0's are
    the caller's)."""
    cases = []
    for cnt in (1, 2, 3, 4):
        before, after = [], []
        for j in range(1, cnt):
            ld, sv = _state_io(j)
            before += ld
            after += sv
        cases.append((f"cnt == {cnt}", before, _chain(head, x, cnt, 0, put), after))
    return _dispatch(cases)


def sections() -> list[str]:
    """far_end._sections: cnt (1..4) first-order sections over v_ in place."""
    return _first_order_cases(["v = v_[i]"], "v", "v_[i] = {}")


def biquads() -> list[str]:
    """far_end._biquads: cnt (1..4) biquads from j0 over v_ in place."""
    names = ["y", "z", "w", "u"]
    cases = []
    for cnt in (1, 2, 3, 4):
        before, after = [], []
        if cnt > 1:
            before += [f"q{j} = q0 + {4 * j}" for j in range(1, cnt)]
            for j in range(1, cnt):
                before += [f"a{j} = fp[F_SOS + 2 * j0 + {2 * j}]",
                           f"b{j} = fp[F_SOS + 2 * j0 + {2 * j + 1}]"]
            for j in range(1, cnt):
                before += [f"y1{j} = st[q{j} + 2]", f"y2{j} = st[q{j} + 3]"]
            for j in range(1, cnt):
                p = j - 1
                after += [f"st[q{j}] = y1{p}", f"st[q{j} + 1] = y2{p}",
                          f"st[q{j} + 2] = y1{j}", f"st[q{j} + 3] = y2{j}"]
        body = _chain(["x = v_[i]"], "x", 0, cnt, "v_[i] = {}", via_h=False,
                      out=names[:cnt], coef=("a", "b"))
        cases.append((f"cnt == {cnt}", before, body, after))
    return _dispatch(cases)


def head() -> list[str]:
    """far_end._head: the loss glide and one-pole loss, then cnt (1..4)
    first-order sections, xin into yo."""
    return _first_order_cases(LOSS, "lp", "yo[i] = {}")


def head_sos() -> list[str]:
    """far_end._head_sos: the loss, ns (1, 2) first-order sections and cnt
    (1..4) biquads, xin into yo."""
    cases = []
    for ns in (1, 2):
        for cnt in (1, 2, 3, 4):
            body = _chain(LOSS, "lp", ns, cnt, "yo[i] = {}")
            cases.append((f"ns == {ns} and cnt == {cnt}", [], body, []))
    # the hand-written form ended on an ``elif`` for the last case, not an
    # ``else`` (cnt outside 1..4 ran no loop): kept
    lines = _dispatch(cases + [("", [], [], [])])
    return lines[:lines.index(f"{IND}else:")]


def lanes_head() -> list[str]:
    """coupled._lanes_head: four strings' loss, ns (1, 2) first-order
    sections and cnt (0..4) biquads, in lanes."""
    cases = []
    for cnt in (0, 1, 2, 3, 4):
        for ns in (1, 2):
            body = _chain(LOSS4, "lp", ns, cnt, "store4(buf, W * i, {})")
            cond = f"ns == {ns}" if cnt == 4 else f"ns == {ns} and cnt == {cnt}"
            cases.append((cond, [], body, []))
    return _dispatch(cases)


def lanes_biquads() -> list[str]:
    """coupled._lanes_biquads: cnt (1..4) biquads of four strings in lanes,
    buf in place."""
    cases = []
    for cnt in (1, 2, 3, 4):
        body = _chain(["h = loadv(zt, buf, W * i)"], "h", 0, cnt, "store4(buf, W * i, {})")
        cases.append((f"cnt == {cnt}", [], body, []))
    return _dispatch(cases)


#: (kernel file, region name, generator)
REGIONS = (
    ("far_end.py", "_sections", sections),
    ("far_end.py", "_biquads", biquads),
    ("far_end.py", "_head", head),
    ("far_end.py", "_head_sos", head_sos),
    ("coupled.py", "_lanes_head", lanes_head),
    ("coupled.py", "_lanes_biquads", lanes_biquads),
)

BEGIN = "    # <generated: tools/gen_kernels.py {}>"
END = "    # </generated>"


def render(text: str, name: str, lines: list[str]) -> str:
    """``text`` with region ``name``'s lines replaced by ``lines``."""
    begin = BEGIN.format(name)
    pat = re.compile(re.escape(begin) + r"\n(.*?)" + re.escape(END) + r"\n", re.S)
    m = pat.search(text)
    if m is None:
        raise ValueError(f"region {name!r}: no '{begin.strip()}' ... '{END.strip()}' markers")
    body = "\n".join(lines) + "\n"
    return text[:m.start(1)] + body + text[m.end(1):]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--check", action="store_true",
                    help="write nothing; exit 1 if a generated region differs from the template's")
    a = ap.parse_args(argv)
    stale, texts = [], {}
    try:
        # every region is rendered before any file is written: an error
        # leaves every file as it was
        for fname in sorted({f for f, _, _ in REGIONS}):
            path = KERNELS / fname
            old = path.read_text("utf-8")
            new = old
            for f, name, gen in REGIONS:
                if f == fname:
                    before = new
                    new = render(new, name, gen())
                    if new != before:
                        stale.append(f"{fname}:{name}")
            if new != old:
                texts[path] = new
        if not a.check:
            for path, new in texts.items():
                path.write_text(new, "utf-8")
    except (OSError, ValueError) as e:
        print(f"gen_kernels: {e}", file=sys.stderr)
        return 2
    if a.check and stale:
        print("not current (run python tools/gen_kernels.py): " + ", ".join(stale))
        return 1
    print(("rewrote: " + ", ".join(stale)) if stale else "every generated region is current")
    return 0


if __name__ == "__main__":
    sys.exit(main())
