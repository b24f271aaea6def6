"""Finding and loading presets: preset directories, listing, reading TOML.

Presets are looked up in the directories of ``$SYNTH_PRESET_PATH``
(:data:`ENV_PRESET_PATH`), then in the shipped ``synth/presets`` folder
(:func:`shipped_preset_dir`, package data found with
:mod:`importlib.resources`). :func:`load_preset` reads the file, applies
``--set`` overrides and validates it with :func:`.validate.validate_dict`.
"""

from __future__ import annotations

import dataclasses
import difflib
import importlib.resources
import os
import tomllib
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from synth.io.errors import PresetError, display_path as _display_path
from synth.io.filekind import file_kind

from .model import Preset
from .validate import _apply_overrides, validate_dict

__all__ = [
    "ENV_PRESET_PATH",
    "shipped_preset_dir",
    "preset_dirs",
    "list_presets",
    "load_preset",
    "find_preset_file",
]

ENV_PRESET_PATH = "SYNTH_PRESET_PATH"


def shipped_preset_dir() -> Path:
    """The presets shipped with the package: ``synth/presets`` (package data).

    Found through :mod:`importlib.resources`, so it is the installed package's
    directory for editable, non-editable and wheel installs alike (see the
    module notes). If the package is not on the file system (a zip import),
    the returned path does not exist and no shipped preset is found.
    """
    res = importlib.resources.files("synth").joinpath("presets")
    if isinstance(res, Path):
        return res
    return Path(str(res))  # not a real directory: callers skip it


def preset_dirs() -> list[Path]:
    """Directories searched for presets, in priority order.

    The entries of ``$SYNTH_PRESET_PATH`` (``os.pathsep``-separated, empty
    entries ignored) come first, then the shipped presets
    (:func:`shipped_preset_dir`). Directories that do not exist are included
    (callers skip them).
    """
    dirs: list[Path] = []
    for entry in os.environ.get(ENV_PRESET_PATH, "").split(os.pathsep):
        if entry.strip():
            dirs.append(Path(entry).expanduser())
    dirs.append(shipped_preset_dir())
    unique: list[Path] = []
    seen: set[Path] = set()
    for d in dirs:
        key = d.resolve()
        if key not in seen:
            seen.add(key)
            unique.append(d)
    return unique


#: a folder of a preset directory that holds spectrum-test specs (``synth check``), not presets
CHECKS_DIR = "checks"


#: a folder of a preset directory that holds batch specs (``synth batch``), not presets
BATCH_DIR = "batch"
#: top-level folders of a preset directory whose TOML files are not presets
NOT_PRESETS = (CHECKS_DIR, BATCH_DIR)


def shipped_checks_dir() -> Path:
    """The shipped spectrum-test specs (``synth/presets/checks``)."""
    return shipped_preset_dir() / CHECKS_DIR


def shipped_batch_dir() -> Path:
    """The shipped batch specs (``synth/presets/batch``, ``synth batch``)."""
    return shipped_preset_dir() / BATCH_DIR


def _scan() -> dict[str, Path]:
    """Map preset name -> file; an earlier directory wins over a later one.
    Files under a top-level ``checks/`` or ``batch/`` folder are specs, not presets."""
    found: dict[str, Path] = {}
    for d in preset_dirs():
        if not d.is_dir():
            continue
        for f in sorted(d.rglob("*.toml")):
            if not f.is_file() or f.relative_to(d).parts[0] in NOT_PRESETS:
                continue
            name = f.relative_to(d).with_suffix("").as_posix()
            found.setdefault(name, f)
    return found


def find_preset_file(name: str) -> Path | None:
    """The file a preset name finds on :func:`preset_dirs` (a path ending in
    ``.toml``: itself if it exists), or None."""
    if str(name).endswith(".toml"):
        p = Path(name)
        return p if p.is_file() else None
    return _scan().get(str(name))


def _read_toml(path: Path, shown: str) -> dict[str, Any]:
    try:
        data = path.read_bytes()
    except OSError as e:
        raise PresetError(f"{shown}: cannot read preset file ({e.strerror or e})") from None
    try:
        return tomllib.loads(data.decode("utf-8"))
    except UnicodeDecodeError as e:
        raise PresetError(f"{shown}: not UTF-8 text (byte {e.start})") from None
    except tomllib.TOMLDecodeError as e:
        raise PresetError(f"{shown}: invalid TOML: {str(e).splitlines()[0]}") from None
    except ValueError as e:
        # tomllib lets Python's int() refuse an integer of more than 4300 digits
        raise PresetError(f"{shown}: invalid TOML: {str(e).splitlines()[0]}") from None
    except RecursionError:
        raise PresetError(f"{shown}: invalid TOML: arrays or tables nested too deeply") from None


def list_presets() -> list[tuple[str, str]]:
    """All presets found in :func:`preset_dirs` as sorted ``(name, description)``.

    A file that cannot be parsed is listed with the description
    ``"(invalid: <reason>)"`` instead of failing the whole listing.
    """
    out: list[tuple[str, str]] = []
    for name, path in sorted(_scan().items()):
        try:
            raw = _read_toml(path, _display_path(path))
            desc = raw.get("description")
            if not isinstance(desc, str) or not desc.strip():
                desc = "(invalid: no description)"
        except PresetError as e:
            desc = f"(invalid: {e})"
        out.append((name, desc.strip()))
    return out


def _name_for_path(path: Path) -> str:
    rp = path.resolve()
    for d in preset_dirs():
        try:
            return rp.relative_to(d.resolve()).with_suffix("").as_posix()
        except ValueError:
            continue
    return path.stem


def override_literal(v) -> str:
    """A Python value as the TOML text of a ``--set PATH=VALUE`` override's
    value (what :func:`load_preset` reads back): a bool, an integer, a real
    (``nan``, ``inf`` included), a string, or a list or tuple of them.

    Raises
    ------
    TypeError
        For any other value."""
    import json
    import math
    from numbers import Integral, Real

    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, Integral):
        return str(int(v))
    if isinstance(v, Real):
        x = float(v)
        if math.isnan(x):
            return "nan"
        if math.isinf(x):
            return "inf" if x > 0 else "-inf"
        return repr(x)
    if isinstance(v, str):
        return json.dumps(v)           # a TOML basic string: JSON's escapes are TOML's
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(override_literal(x) for x in v) + "]"
    raise TypeError(f"cannot write {v!r} as TOML")


def load_preset(name_or_path: str | os.PathLike, overrides: Sequence[str] = ()) -> Preset:
    """Load, override and validate a preset.

    Parameters
    ----------
    name_or_path : str or path
        A preset name (``"sitar"``, ``"paper/sitar-case1"``) looked up in
        :func:`preset_dirs`, or a path to a ``.toml`` file (anything ending in
        ``.toml`` is taken as a path).
    overrides : sequence of str
        ``"PATH=VALUE"`` strings from the CLI's repeatable ``--set`` (see
        :func:`parse_override`), applied in order to the parsed file *before*
        validation, so they are checked exactly like the file; errors about
        such keys say ``(from --set)``. A ``--set`` may add a key the file
        lacks (e.g. ``pluck.alpha_per_s`` when switching ``pluck.model`` to
        ``biwa``, or a whole section when switching ``kind``). When a
        ``--set`` changes a discriminating key (``kind``, ``pluck.model``,
        ``termination.profile``), the keys of the file that the new value
        forbids are dropped (``--set termination.profile=none`` on a jawari
        preset gives the ideal string; ``--set termination.profile=capo
        --set termination.radius_m=0.015`` keeps the file's ``side`` and
        ``region_points`` and drops the jawari parameters); keys the new
        value requires and the file lacks must be given with further
        ``--set``. A forbidden key given by ``--set`` itself is an error.

    Returns
    -------
    Preset

    Raises
    ------
    PresetError
        Unknown name (the message lists the available names), missing or
        unreadable file, invalid TOML, bad ``--set``, or a schema violation.
    """
    text = os.fspath(name_or_path)
    if text.endswith(".toml"):
        path = Path(text)
        shown = _display_path(path)
        if not path.is_file():
            raise PresetError(f"{shown}: preset file not found")
        name = _name_for_path(path)
    else:
        found = _scan()
        if text not in found:
            names = sorted(found)
            kind = file_kind(text)
            if kind is not None:
                raise PresetError(f"{text} is {kind}, not a preset: give a preset's name "
                                  f"({', '.join(names)}) or a preset's .toml file")
            close = difflib.get_close_matches(text, names, n=1)
            hint = f"; did you mean '{close[0]}'?" if close else ""
            avail = ", ".join(names) if names else (
                "none found in " + os.pathsep.join(str(d) for d in preset_dirs()))
            raise PresetError(f"unknown preset '{text}'{hint} (available: {avail})")
        path = found[text]
        shown = _display_path(path)
        name = text
    raw = _read_toml(path, shown)
    file_raw = raw
    raw, keys = _apply_overrides(raw, overrides, shown)
    preset = validate_dict(raw, shown, name=name, overridden=keys, file_raw=file_raw)
    return dataclasses.replace(preset, path=str(path.resolve()))
