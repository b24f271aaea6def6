"""The public, validated face of the numba kernels: one place for every wrapper.

``synth.kernels`` holds only ``@njit`` functions and the constants they read
(numba freezes the globals a kernel reads, and its cache checks a kernel
against its own file only, so a kernel and its column numbers must live in
that package, whose every module's bytes key the cache's folder:
:mod:`synth.kernels.cache`).  This package holds
the Python classes that own the kernels' arrays, validate their parameters
and call them (stumpy's split of a kernel from its public wrapper):

* :mod:`synth.dsp.bank`: :class:`~synth.dsp.bank.StringBank`, the string
  slots of :mod:`synth.kernels.strings`, and the templates a voice builds
  once per key.  It is the only code outside the kernels that indexes
  the kernels' parameter and state tables (``ipar``, ``fpar``, ``fst``,
  columns in :mod:`synth.kernels.layout`):
  voices and the engine use its methods (``configure_from``,
  ``start_pluck``, ``start_hammer_from``, ``apply_dampers``, ``fade``,
  ``reap``...).
* :mod:`synth.dsp.sizing`: what the bank allocates for the string kernels
  and the fast path's chunk limits (plain Python, from the kernels' layout).
* :mod:`synth.dsp.body`: :class:`~synth.dsp.body.Body`, the soundboard's
  modal bank (:mod:`synth.kernels.body`).
* :mod:`synth.dsp.decimator`: :class:`~synth.dsp.decimator.Decimator`,
  325 kHz -> 48 kHz (:mod:`synth.kernels.decimator`).

Why a package of its own and not ``synth/kernels``: the architecture keeps
``kernels/`` to ``@njit`` code only (arrays and scalars in, no objects), and
these wrappers are objects.  They sit in the same layer as the kernels:
``dsp`` imports ``kernels`` and ``physics`` only, and both ``voices`` (which
write a note's strings into the bank) and ``engine`` (which renders the bank
and runs the decimator and the body) import ``dsp``.  Before, the bank lived
in ``voices/`` and the body in ``engine/``, so the grand voice, which
describes its soundboard, imported the engine (a cycle).
"""
