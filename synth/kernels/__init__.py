"""The numba kernels: ``@njit(cache=True)`` functions and their constants.

Importing the package (or any module of it) imports every kernel module
with numba's cache in a folder keyed on the bytes of their sources (see
:mod:`synth.kernels.cache`): numba checks a cached function only against
its own file, and the kernels call into each other's files.
"""

from pathlib import Path

from .cache import load_keyed

_CACHE_DIR = load_keyed(__name__, Path(__file__).parent)


def cache_dir() -> Path | None:
    """The folder numba caches the kernels in (``<base>/synth-kernels-<hash
    of their sources>``), or None if no keyed folder could be created and
    numba keeps its default cache (see :mod:`synth.kernels.cache`)."""
    return _CACHE_DIR
