"""The commands of ``synth``, one module each.

Each module has ``NAME`` (the command), ``HELP`` (its line in ``synth
--help``), ``add_arguments(parser)``, ``run(args) -> int`` (the exit status)
and optionally ``DESCRIPTION``, ``EPILOG`` and ``FORMATTER_CLASS`` for its
own ``--help``. synth.cli builds the parser from them and dispatches; what
they share is in :mod:`synth.commands.common`. Their top level imports
argparse-level things only: the engine, numba's kernels and numpy are
imported inside ``run``, so ``synth --help`` and ``synth presets`` stay fast.
"""
