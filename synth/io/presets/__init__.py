"""Presets: TOML files describing one instrument voice (schema version 1).

A preset is a TOML file in a directory listed in ``$SYNTH_PRESET_PATH`` or
in the shipped ``synth/presets/`` folder; its *name* is its path relative to
that directory without ``.toml``, e.g. ``"sitar"`` or ``"paper/sitar-case1"``.

The package is split by role; every public name is re-exported here, so
``from synth.io.presets import load_preset`` is the way to use it:

* :mod:`.model` -- the frozen result dataclasses (``StringSpec`` ...
  ``PlaySpec``, :class:`Preset`).
* :mod:`.schema` -- the building blocks of the schema (:class:`When`,
  :class:`Field`, :class:`OrderCheck`, :class:`Section`) and the helpers
  that format values and ranges in messages.
* :mod:`.sections` -- the schema rows, as data: :data:`SCHEMA_FIELDS`,
  :data:`SECTIONS` and the choice lists (:data:`VOICES`, :data:`PROFILES`,
  ...). This is the file to edit to add a voice, a profile or a key.
* :mod:`.validate` -- the validator (:func:`validate_dict`), the import-time
  consistency check of the rows, and ``--set`` overrides
  (:func:`parse_override`). Its engine validates the specs of ``synth
  check`` and ``synth batch`` too, each against its own rows
  (:func:`~.validate.validate_table`, :func:`~.validate.check_rows`).
* :mod:`.loader` -- finding, listing, reading and loading presets
  (:func:`preset_dirs`, :func:`list_presets`, :func:`load_preset`).

Imports go one way, without cycles: ``model`` and ``schema`` import nothing
of the package; ``sections`` imports both; ``validate`` imports ``model``,
``schema`` and ``sections``; ``loader`` imports ``model`` and ``validate``.

The shipped presets are package data so a wheel carries them: they live
inside the ``synth`` package, are declared in ``pyproject.toml``
(``[tool.setuptools.package-data]``) and are found with
``importlib.resources.files("synth") / "presets"``, which names the package's
own directory whether it was installed editable (the checkout's
``synth/presets``), from a wheel or by a plain ``pip install .`` (the copy in
``site-packages/synth/presets``). A folder beside the package (the old
``presets/`` at the top of the checkout, found by ``__file__`` arithmetic)
exists only in a checkout, so an installed wheel had no presets. The folder
is not a Python package (no ``__init__.py``); pip always unpacks wheels onto
the file system, so the resource is a real directory and presets keep real
paths (for error messages and ``Preset.path``); an import from a zip file,
where it would not be one, is not supported and finds no shipped presets.

The schema is declared once, as data, in :data:`SCHEMA_FIELDS` and
:data:`SECTIONS`: every key has a type, a range or a set of choices, a short
doc string with its unit, and a presence condition (:class:`When`). A key
with a condition is required when the condition holds and forbidden
otherwise; a key without one is always required. The same key may appear in
several rows with disjoint conditions and different ranges (e.g.
``termination.radius_m`` for ``capo`` and for ``sawari``). Adding a voice
(``"piano"``) or a termination profile is adding rows in :mod:`.sections`
and, if it brings a new section, one frozen dataclass in :mod:`.model`.

Validation raises :class:`~synth.io.errors.PresetError` whose message is a
single line naming the file, the dotted key, the value and what is allowed::

    synth/presets/sitar.toml: pluck.position = 1.5 is out of range (0 < value < 1)
    synth/presets/sitar.toml: unknown key 'pluck.positon' (allowed: model, ...)
    synth/presets/sitar.toml: missing key 'string.tension_n'

The validated result is an immutable, hashable :class:`Preset` built from
plain ``int``/``float``/``str``/``tuple`` fields (keys that are absent for
the preset's variant are ``None``). All quantities are SI (m, N, kg/m, s,
Hz), as the key names say.
"""

from __future__ import annotations

from .loader import (
    ENV_PRESET_PATH,
    list_presets,
    load_preset,
    preset_dirs,
    shipped_preset_dir,
    shipped_checks_dir,
    shipped_batch_dir,
)
from .model import (
    ActionSpec,
    BodySpec,
    DampersSpec,
    GridSpec,
    HammerSpec,
    LossSpec,
    OutputSpec,
    PlaySpec,
    PluckSpec,
    Preset,
    StringSpec,
    StringsSpec,
    TerminationSpec,
    TuningSpec,
)
from .schema import Field, OrderCheck, Section, When
from .sections import (
    CAPO_COUPLINGS,
    HAMMER_LAWS,
    HAMMER_MODELS,
    KINDS,
    PLUCK_MODELS,
    QUALITIES,
    PROFILES,
    SCHEMA_FIELDS,
    SCHEMA_VERSION,
    SECTIONS,
    SIGNALS,
    VOICES,
)
from .validate import parse_override, validate_dict

__all__ = [
    # result objects (model)
    "StringSpec",
    "GridSpec",
    "PluckSpec",
    "HammerSpec",
    "TuningSpec",
    "ActionSpec",
    "StringsSpec",
    "DampersSpec",
    "BodySpec",
    "TerminationSpec",
    "LossSpec",
    "OutputSpec",
    "PlaySpec",
    "Preset",
    # schema building blocks (schema)
    "When",
    "Field",
    "Section",
    "OrderCheck",
    # schema rows (sections)
    "SCHEMA_VERSION",
    "KINDS",
    "VOICES",
    "HAMMER_LAWS",
    "HAMMER_MODELS",
    "CAPO_COUPLINGS",
    "PLUCK_MODELS",
    "QUALITIES",
    "PROFILES",
    "SIGNALS",
    "SCHEMA_FIELDS",
    "SECTIONS",
    # validation and --set (validate)
    "validate_dict",
    "parse_override",
    # finding and loading (loader)
    "ENV_PRESET_PATH",
    "preset_dirs",
    "shipped_preset_dir",
    "shipped_checks_dir",
    "shipped_batch_dir",
    "list_presets",
    "load_preset",
]
