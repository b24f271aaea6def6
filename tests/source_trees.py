"""The package's sources parsed once per test process, for the structural
tests (layers, the kernels' numba sites, the registry's rules): parsing
all of ``synth`` takes about 2.4 s here, and five tests read every file.
The trees are shared: a test reads them and never changes them."""

from __future__ import annotations

import ast

_TREES: dict[str, ast.Module] = {}


def parse(text: str, filename: str = "<unknown>") -> ast.Module:
    """``ast.parse(text, filename)``, once for each text (``filename`` only
    names the file in a syntax error)."""
    tree = _TREES.get(text)
    if tree is None:
        tree = _TREES[text] = ast.parse(text, filename)
    return tree
