"""CPU description and numba code-generation targets for the benchmark tools:
:mod:`synth.apps.cpu_target` (its notes say what each target is), here as
``import cpu_target`` for ``tools/*.py`` (run as ``python tools/x.py``,
tools/ is on ``sys.path``).
"""

from synth.apps.cpu_target import *  # noqa: F401,F403
