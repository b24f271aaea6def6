"""User-facing jobs beyond play and render, one module each.

* :mod:`synth.apps.check`: spectrum tests of rendered audio against a
  versioned TOML spec (``synth check``).
* :mod:`synth.apps.compare` (with :mod:`synth.apps.compare_page`, the page):
  loudness-matched listening tests in a self-contained web page (``synth
  compare``).
* :mod:`synth.apps.render`: a MIDI file through a preset into a WAV file
  (``synth render``), with the long-render warning, ``--max-seconds``, the
  progress bar and a clean stop on Ctrl-C or SIGTERM.

An app may use the engine (through :func:`synth.io.factory.build_engine`),
the voices, the analysis and ``io``; the CLI only parses arguments and calls
it (``docs/architecture.md``, ``tests/test_layers.py``).
"""
