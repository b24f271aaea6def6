"""User-facing jobs beyond play and render, one module each.

* :mod:`synth.apps.check`: spectrum tests of rendered audio against a
  versioned TOML spec (``synth check``).
* :mod:`synth.apps.compare` (with :mod:`synth.apps.compare_page`, the page):
  loudness-matched listening tests in a self-contained web page (``synth
  compare``).
* :mod:`synth.apps.render`: a MIDI file through a preset into a WAV file
  (``synth render``), with the long-render warning, ``--max-seconds``, the
  progress bar and a clean stop on Ctrl-C or SIGTERM.

What the scripts of ``tools/`` run and the tests test is here too (no test
imports ``tools/``): :mod:`~synth.apps.stress` (the stability stress cases),
:mod:`~synth.apps.cpu_target` (the benchmarks' numba code targets),
:mod:`~synth.apps.voicing` and :mod:`~synth.apps.grand_study` (the voicing
report's table and the grand's studies' measures), :mod:`~synth.apps.levels`
(the presets' reference phrases), :mod:`~synth.apps.reproduce` (the A7
strike) and :mod:`~synth.apps.work_precision` (its summaries).

An app may use the engine (through :func:`synth.io.factory.build_engine`),
the voices, the analysis and ``io``; the CLI only parses arguments and calls
it (``docs/architecture.md``, ``tests/test_layers.py``).
"""
