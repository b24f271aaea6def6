"""User-facing jobs beyond playing and rendering, one module each
(``compare``: listening tests in a web page).

Apps may import engine, voices, dsp, physics, kernels, analysis, io and
apps (tests/test_layers.py); the command line (``synth.cli``) parses the
arguments and calls them.
"""
