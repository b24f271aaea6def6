"""Dependencies between the layers of synth point down.

Every ``.py`` under synth/ is parsed with :mod:`ast`; every import counts,
also the lazy ones inside functions, and relative imports are resolved to
absolute module names. A module's layer is the first package under synth
(``synth.engine.body`` -> ``engine``; ``synth/cli.py`` -> ``cli``).

Layers and what each may import from synth (its own layer included)::

    __main__  cli                         (python -m synth)
    cli       commands, io                (the parser from the commands, dispatch)
    commands  anything below: api, apps, testing, io, engine, voices, dsp, physics,
              kernels, analysis           (one module per command; only cli imports them)
    api       as apps, and apps           (synth.render_note ...: the Python API, beside the
                                           commands, which render through it)
    apps, io  engine, voices, dsp, physics, kernels, analysis, io (apps: apps too)
    testing   as apps, and apps (synth.testing: the checks of synth check for pytest)
    engine    voices, dsp, physics, kernels
    voices    dsp, physics, kernels
    dsp       kernels, physics           (python wrappers of the numba kernels)
    physics   -
    kernels   -
    analysis  -                           (numpy/scipy only)

``synth/__init__.py`` and ``synth.presets`` (data) are exempt, as importers
and as targets. A package under synth that is not in the table is reported
until it is given a layer. Third-party imports are free, except that only
cli, io and apps may import mido, sounddevice or rtmidi (the live extras),
and matplotlib may only be imported inside a function, anywhere.
"""

from __future__ import annotations

import ast
from dataclasses import dataclass
from pathlib import Path

import source_trees  # (tests/: the sources parsed once a process)

SYNTH_DIR = Path(__file__).resolve().parents[1] / "synth"

_LOW = {"voices", "dsp", "physics", "kernels"}
ALLOWED: dict[str, set[str]] = {
    # python -m synth: synth/__main__.py runs synth.cli's main
    "__main__": {"cli"},
    # synth.cli builds the parser from synth.commands and dispatches to them
    "cli": {"cli", "commands", "io"},
    # synth.commands: one module per command (options, checks, output); only cli imports them
    "commands": {"commands", "api", "apps", "testing", "io", "engine", "analysis"} | _LOW,
    # synth.api: the Python API (synth.render_note ...); it checks MIDI units at the edge as
    # a command does, and the commands render through it (synth note)
    "api": {"api", "apps", "io", "engine", "analysis"} | _LOW,
    # synth.testing: the checks of synth check (apps) for pytest, beside apps
    "testing": {"testing", "apps", "io", "engine", "analysis"} | _LOW,
    # synth.batch: the Python API of synth batch (apps), beside apps, as testing is
    "batch": {"batch", "apps", "io", "engine", "analysis"} | _LOW,
    "apps": {"apps", "io", "engine", "analysis"} | _LOW,
    "io": {"io", "engine", "analysis"} | _LOW,
    "engine": {"engine"} | _LOW,
    "voices": {"voices", "dsp", "physics", "kernels"},
    "dsp": {"dsp", "physics", "kernels"},
    "physics": {"physics"},
    "kernels": {"kernels"},
    "analysis": {"analysis"},
}
#: the package's own __init__ ("") and the preset data
EXEMPT = {"", "presets"}
#: third-party packages of the live extras: only these layers may import them
LIVE_PACKAGES = {"mido", "sounddevice", "rtmidi"}
LIVE_LAYERS = {"cli", "io", "apps"}
#: third-party packages that may only be imported inside a function
LAZY_ONLY = {"matplotlib"}

# Violations known today, each as "importer imports target". The test fails
# if this set differs from what is found either way: a new violation, or one
# of these gone (then delete it here).
KNOWN_VIOLATIONS: set[str] = set()     # none: keep it that way


@dataclass(frozen=True)
class Violation:
    module: str
    file: str
    line: int
    target: str
    reason: str

    @property
    def key(self) -> str:
        return f"{self.module} imports {self.target}"

    def __str__(self) -> str:
        return f"{self.module} ({self.file}:{self.line}) imports {self.target}: {self.reason}"


@dataclass(frozen=True)
class Import:
    target: str   # absolute module name (for `from a import b`: a.b if that is a module of ours)
    line: int
    lazy: bool    # inside a function


def module_name(path: Path, root: Path) -> str:
    """synth/voices/grand.py -> synth.voices.grand; synth/io/__init__.py -> synth.io."""
    parts = list(path.relative_to(root.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _resolve_relative(module: str, is_package: bool, level: int, name: str | None) -> str:
    package = module.split(".") if is_package else module.split(".")[:-1]
    if level - 1 > len(package) - 1:
        raise ValueError(f"relative import beyond the top-level package in {module}")
    base = package[: len(package) - (level - 1)]
    return ".".join(base + ([name] if name else []))


def imports_of(source: str, module: str, is_package: bool, known_modules: set[str]) -> list[Import]:
    """Every import in `source` (of module `module`) as absolute names."""
    found: list[Import] = []

    def visit(node: ast.AST, lazy: bool) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.Import):
                for a in child.names:
                    found.append(Import(a.name, child.lineno, lazy))
            elif isinstance(child, ast.ImportFrom):
                base = (child.module or "") if child.level == 0 else \
                    _resolve_relative(module, is_package, child.level, child.module)
                for a in child.names:
                    sub = f"{base}.{a.name}" if base else a.name
                    # `from pkg import mod` imports pkg.mod; `from mod import name` imports mod
                    found.append(Import(sub if sub in known_modules else base, child.lineno, lazy))
            elif (isinstance(child, ast.Call) and child.args
                  and isinstance(child.args[0], ast.Constant) and isinstance(child.args[0].value, str)
                  and ((isinstance(child.func, ast.Attribute) and child.func.attr == "import_module")
                       or (isinstance(child.func, ast.Name) and child.func.id in ("import_module", "__import__")))
                  and not child.args[0].value.startswith(".")):
                found.append(Import(child.args[0].value, child.lineno, lazy))
            visit(child, lazy or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)))

    visit(source_trees.parse(source), False)
    return found


def layer_of(module: str, top: str) -> str | None:
    """Layer of a module of package `top` ("" for the package itself), None outside it."""
    parts = module.split(".")
    if parts[0] != top:
        return None
    return parts[1] if len(parts) > 1 else ""


def check_package(root: Path) -> list[Violation]:
    """All layering violations in the package at directory `root`."""
    top = root.name
    files = sorted(root.rglob("*.py"))
    known = {module_name(p, root) for p in files}
    # packages without an __init__.py (namespace packages) are modules too
    known |= {".".join(m.split(".")[:i]) for m in known for i in range(1, m.count(".") + 1)}
    out: list[Violation] = []
    for path in files:
        mod = module_name(path, root)
        src_layer = layer_of(mod, top)
        rel = path.relative_to(root.parent).as_posix()
        for imp in imports_of(path.read_text(encoding="utf-8"), mod, path.name == "__init__.py", known):
            def bad(reason: str) -> None:
                out.append(Violation(mod, rel, imp.line, imp.target, reason))

            first = imp.target.split(".")[0]
            tgt_layer = layer_of(imp.target, top)
            if first in LAZY_ONLY and not imp.lazy:
                bad(f"{first} may only be imported inside a function")
            if first in LIVE_PACKAGES and src_layer not in LIVE_LAYERS:
                bad(f"layer {src_layer or top} may not import {first} "
                    f"(only {', '.join(sorted(LIVE_LAYERS))} may)")
            if src_layer in EXEMPT or tgt_layer is None or tgt_layer in EXEMPT:
                continue
            if src_layer not in ALLOWED:
                bad(f"layer {src_layer} is not assigned a place in the layering "
                    "(add it to ALLOWED in tests/test_layers.py)")
            elif tgt_layer not in ALLOWED[src_layer]:
                bad(f"layer {src_layer} may not import layer {tgt_layer}")
    return out


def test_dependencies_point_down():
    found = check_package(SYNTH_DIR)
    new = [v for v in found if v.key not in KNOWN_VIOLATIONS]
    gone = KNOWN_VIOLATIONS - {v.key for v in found}
    msg = []
    if new:
        msg.append("imports against the layering:\n" + "\n".join(f"  {v}" for v in new))
    if gone:
        msg.append("known violations no longer found (delete them from KNOWN_VIOLATIONS):\n"
                   + "\n".join(f"  {k}" for k in sorted(gone)))
    assert not msg, "\n".join(msg)


def test_every_module_of_synth_is_parsed():
    """The walk sees the real package: its layers and a few known imports."""
    files = list(SYNTH_DIR.rglob("*.py"))
    layers = {layer_of(module_name(p, SYNTH_DIR), "synth") for p in files}
    assert {"", "cli", "commands", "io", "engine", "voices", "dsp", "physics", "kernels",
            "analysis"} <= layers
    grand = SYNTH_DIR / "voices" / "grand.py"
    known = {module_name(p, SYNTH_DIR) for p in files}
    targets = {i.target for i in imports_of(grand.read_text(), "synth.voices.grand", False, known)}
    assert {"synth.kernels.strings", "synth.physics.piano", "synth.dsp.bank"} <= targets


# --------------------------------------------------------------------------
# The checker on a synthetic package
# --------------------------------------------------------------------------


def _package(tmp_path: Path, files: dict[str, str]) -> Path:
    root = tmp_path / "synth"
    for rel, text in files.items():
        p = root / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(text)
    return root


def test_checker_catches_violations(tmp_path):
    root = _package(tmp_path, {
        "__init__.py": "from synth.cli import main\n",                 # exempt
        "cli.py": "import mido\nfrom synth import engine\nimport matplotlib\nfrom .commands import note\n",
        "commands/__init__.py": "",
        "commands/note.py": ("from .common import fail\n"                # own layer
                             "def run(args):\n"
                             "    from ..engine.core import Engine\n"   # commands -> engine, apps
                             "    from synth.apps import render\n"),
        "commands/common.py": "from synth.io.errors import SynthError\nfrom ..cli import main\n",
        "apps/__init__.py": "",
        "apps/render.py": "from synth.commands.common import fail\n",   # apps -> commands
        "engine/__init__.py": "from .core import Engine\n",            # resolves to synth.engine.core
        "engine/core.py": "from ..io import wav\n",                    # engine -> io
        "io/__init__.py": "",
        "io/wav.py": "import mido\ndef plot():\n    import matplotlib.pyplot as plt\n",
        "physics/__init__.py": "",
        "physics/string.py": (
            "import numpy as np\n"
            "from . import losses\n"                                   # own layer
            "from .. import kernels\n"                                 # physics -> kernels
            "def f():\n"
            "    from synth.voices.bank import StringBank\n"           # lazy still counts
            "    import sounddevice\n"
            "class C:\n"
            "    def g(self):\n"
            "        import importlib\n"
            "        return importlib.import_module('synth.engine')\n"
        ),
        "physics/losses.py": "",
        "kernels/__init__.py": "",
        "analysis/spectrum.py": "import scipy.signal\nfrom synth.physics import string\n",
        "presets/__init__.py": "",
        "extras/tool.py": "from synth.kernels import strings\n",     # no layer yet; strings: a name
    })
    found = sorted(str(v) for v in check_package(root))
    assert found == sorted([
        "synth.cli (synth/cli.py:3) imports matplotlib: matplotlib may only be imported inside a function",
        "synth.cli (synth/cli.py:2) imports synth.engine: layer cli may not import layer engine",
        "synth.apps.render (synth/apps/render.py:1) imports synth.commands.common: "
        "layer apps may not import layer commands",
        "synth.commands.common (synth/commands/common.py:2) imports synth.cli: "
        "layer commands may not import layer cli",
        "synth.engine.core (synth/engine/core.py:1) imports synth.io.wav: layer engine may not import layer io",
        "synth.physics.string (synth/physics/string.py:3) imports synth.kernels: "
        "layer physics may not import layer kernels",
        "synth.physics.string (synth/physics/string.py:5) imports synth.voices.bank: "
        "layer physics may not import layer voices",
        "synth.physics.string (synth/physics/string.py:6) imports sounddevice: "
        "layer physics may not import sounddevice (only apps, cli, io may)",
        "synth.physics.string (synth/physics/string.py:10) imports synth.engine: "
        "layer physics may not import layer engine",
        "synth.analysis.spectrum (synth/analysis/spectrum.py:2) imports synth.physics.string: "
        "layer analysis may not import layer physics",
        "synth.extras.tool (synth/extras/tool.py:1) imports synth.kernels: "
        "layer extras is not assigned a place in the layering (add it to ALLOWED in tests/test_layers.py)",
    ]), "\n".join(found)


def test_relative_imports_resolve_to_absolute_names():
    known = {"synth.voices.bank", "synth.engine.body", "synth.engine"}
    src = "from .bank import X\nfrom ..engine.body import Body\nfrom .. import engine\nfrom . import bank\n"
    got = [i.target for i in imports_of(src, "synth.voices.grand", False, known)]
    assert got == ["synth.voices.bank", "synth.engine.body", "synth.engine", "synth.voices.bank"]
    # in a package's __init__ the package itself is the anchor
    got = [i.target for i in imports_of("from .bank import X\n", "synth.voices", True, known)]
    assert got == ["synth.voices.bank"]


#: the most lines a module of synth may have (issue 38: one room per job)
MAX_LINES = 1200


def test_no_module_over_1200_lines():
    """A module that outgrows this holds more than one job: split it along
    its seams (as StringBank's mixins: excitation, bridges, hand_over,
    telemetry)."""
    long = {str(p.relative_to(SYNTH_DIR)): n for p in SYNTH_DIR.rglob("*.py")
            if (n := len(p.read_text("utf-8").splitlines())) > MAX_LINES}
    assert not long, long
