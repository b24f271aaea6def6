"""The ``synth`` command: offline rendering of presets, notes and MIDI files.

    synth demo [-o demo.wav]
    synth presets
    synth note PRESET [--key K | --f0 HZ] [--velocity V] [--seconds S]
               [--internal-rate HZ] [--quality LEVEL | --max-error CENTS,DB]
               [--set PATH=VALUE ...] -o OUT.wav [--probe OUT.npy]
    synth render MIDI_FILE --preset PRESET [--set PATH=VALUE ...] [--max-seconds S]
                 [--quality LEVEL | --max-error CENTS,DB] -o OUT.wav
    synth drone --preset PRESET --sa KEY|NOTE [--pattern "Pa Sa Sa Sa"] [--cycle-s S]
                [--seconds S] [--seed N] [--velocity V] [--set PATH=VALUE ...] -o OUT.wav
    synth check SPEC.toml [...] [--shipped] [--junit OUT.xml]
    synth analyze AUDIO.wav|PRESET [--key K | --f0 HZ] [--velocity V] [--json] [--plot OUT.png]
    synth play --preset PRESET [--midi-api auto|alsa|jack] [--midi-port NAME]
               [--audio-device NAME] [--rate HZ] [--block N] [--latency-ms X]
               [--program-map 0=PRESET,...] [--set PATH=VALUE ...] [--record OUT.wav] [--stats]
    synth play --jack --preset PRESET [--jack-name NAME] [--connect] [--reconnect] [...]
    synth play --list-ports
    synth batch SPEC.toml -o DIR [--scheduler tcp://HOST:8786 | --workers N] [--csv] [--dry-run]
    synth compare STIMULUS STIMULUS [...] [--midi FILE | --key K --velocity V --seconds S]
               [--lufs X] [--trials N] -o DIR [--serve [--port P]]
    synth warmup [--presets LIST]
    synth help [TOPIC]
    synth --version

Audio outputs take their format from the extension: .wav, .flac or .ogg
(anything else is refused before any work); an output that names an input
is refused too.  ``python -m synth`` is the same command (synth/__main__.py).

Each command is a module of synth.commands (its options, checks and
output); this module builds the parser from them, in the order of ``synth
--help``, and dispatches.  MIDI values (0-127) are normalised there, once;
everything below works in SI units and [0, 1].  User errors print one line
(``synth: error: ...``) and exit with status 2; no half-written file is
left behind.  Ctrl-C (and SIGTERM during ``render``) print one line
(``synth: interrupted ...``) and exit with status 130 (143).  Run from the
command line, a command that renders says on stderr, within its first
second, when the kernels are about to compile (a cold numba cache:
:mod:`synth.dsp.compile_notice`).
"""

from __future__ import annotations

import argparse
import gc
import os
import sys

from . import __version__
from .commands import (analyze, batch, check, compare, demo, drone, felt, help as help_cmd, note,
                       play, presets, render, reproduce, warmup)
from .commands.common import arm_compile_notice, os_error_line, parse_channels, parse_mpe_option
from .io.errors import SynthError
from .io.interrupt import Interrupted

__all__ = ["COMMANDS", "build_parser", "main", "parse_channels", "parse_mpe_option"]

#: the command modules, in the order ``synth --help`` lists them
COMMANDS = (demo, presets, note, render, drone, analyze, check, felt, batch, play, compare,
            reproduce, warmup, help_cmd)

EPILOG = """examples:
  synth demo                                         # demo.wav: a phrase on the sitar and biwa
  synth note sitar --key 57 -o a3.wav                # one note (.wav, .flac or .ogg)
  synth render song.mid --preset grand-piano -o song.flac
  synth analyze a3.wav                               # its partials, decays and loudness
  synth COMMAND --help                               # a command's options and examples
  synth help                                         # the user guides shipped with synth"""
#: the commands that render with the kernels: from the command line, they say
#: within a second when the kernels are about to compile (a cold cache)
RENDERING = {"demo", "note", "render", "drone", "analyze", "check", "felt", "batch", "play", "compare",
             "reproduce", "warmup"}


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="synth", description="Physical-modelling string synthesizer "
                                "(waveguide strings against jawari, sawari and capo-bar terminations).",
                                epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--version", action="version", version=f"synth {__version__}",
                   help="print synth's version and exit")
    sub = p.add_subparsers(dest="cmd", required=True, metavar="COMMAND")
    for m in COMMANDS:
        extra = {k.lower(): getattr(m, k) for k in ("DESCRIPTION", "EPILOG", "FORMATTER_CLASS")
                 if hasattr(m, k)}
        extra.setdefault("formatter_class", argparse.RawDescriptionHelpFormatter)
        sp = sub.add_parser(m.NAME, help=m.HELP, **extra)
        m.add_arguments(sp)
        sp.set_defaults(func=m.run, _module=m)
    return p


class _SkipBlasProbe:
    """numba's first kernel load in a process (from its cache too) imports
    its numpy library, ``numba.np.arraymath``, which probes for a BLAS by
    importing ``scipy.linalg.cython_blas``: all of ``scipy.linalg``, 0.18
    of the 1.15 CPU s of a warm ``synth note sitar`` (2-vCPU Xeon,
    docs/benchmarks.md "Start-up").  The kernels call no BLAS (no
    ``np.dot``, ``np.convolve``, ``np.correlate``, ``np.cov``), so the
    command line lets the probe fail: while that one module executes,
    ``sys.modules["scipy.linalg.cython_blas"]`` is None (its import raises
    ImportError before ``scipy.linalg`` is imported), and then the entry is
    gone and scipy imports as usual.  The only effect beyond the time:
    numba code compiled later in the same process computes a float
    ``np.convolve``/``np.correlate``/``np.cov`` with its own loops instead
    of BLAS (``np.dot`` checks for BLAS again when it compiles).  Only the
    ``synth`` command installs it (:func:`main` run from the command line):
    a library user's process is left as it is.  A one-shot finder on
    ``sys.meta_path``: it removes itself at its module's import."""

    MODULE = "numba.np.arraymath"
    PROBE = "scipy.linalg.cython_blas"

    def find_spec(self, name, path=None, target=None):
        if name != self.MODULE:
            return None
        import importlib.util

        sys.meta_path.remove(self)
        spec = importlib.util.find_spec(name)
        if (spec is None or spec.loader is None or "scipy.linalg" in sys.modules
                or self.PROBE in sys.modules):
            return spec
        spec.loader = _ProbeFails(spec.loader, self.PROBE)
        return spec

    @classmethod
    def install(cls) -> None:
        if cls.MODULE not in sys.modules and not any(isinstance(f, cls) for f in sys.meta_path):
            sys.meta_path.insert(0, cls())


class _ProbeFails:
    """A module's loader that executes it with ``probe`` unimportable (None
    in ``sys.modules``), and otherwise is the module's own loader."""

    def __init__(self, loader, probe: str) -> None:
        self._loader, self._probe = loader, probe

    def __getattr__(self, name):
        return getattr(self._loader, name)

    def create_module(self, spec):
        return self._loader.create_module(spec)

    def exec_module(self, module) -> None:
        sys.modules[self._probe] = None
        try:
            self._loader.exec_module(module)
        finally:
            if sys.modules.get(self._probe, 0) is None:
                del sys.modules[self._probe]


def _warn_preset_path() -> None:
    """One line on stderr for each $SYNTH_PRESET_PATH entry that is not a
    folder (a typo is otherwise ignored without a word)."""
    for entry in os.environ.get("SYNTH_PRESET_PATH", "").split(os.pathsep):
        if entry.strip() and not os.path.isdir(os.path.expanduser(entry)):
            what = "is not a folder" if os.path.exists(os.path.expanduser(entry)) \
                else "no such folder"
            print(f"synth: warning: SYNTH_PRESET_PATH entry {entry}: {what} (ignored)",
                  file=sys.stderr)


def main(argv=None) -> int:
    """Run the ``synth`` command with ``argv`` (None: the process's own
    command line, ``sys.argv[1:]``); returns the exit status.

    Run as the process's command (``argv`` None), the objects left when
    the command ends are frozen (:func:`gc.freeze`): the interpreter's
    shutdown then frees them by reference count without first walking the
    whole graph of objects numba and the modules made for cycles.  A warm
    ``synth note sitar --key 57 --seconds 1`` spent about 0.15 s of its
    0.6-0.75 s there (2-vCPU Zen 5; the command below, alternated, in
    docs/benchmarks.md).  Every command has closed its files and streams
    by then; a test calling ``main([...])`` in-process is left as it was.
    """
    try:
        return _run(argv)
    finally:
        if argv is None:
            gc.freeze()


def _run(argv) -> int:
    parser = build_parser()
    args, extras = parser.parse_known_args(argv)
    if extras:
        # an option the command (or felt's mode) does not take: the command
        # may say which one does; else argparse's own error (status 2)
        hook = getattr(getattr(args, "_module", None), "unknown_options", None)
        msg = hook(args, extras) if hook is not None else None
        if msg is None:
            parser.error(f"unrecognized arguments: {' '.join(extras)}")
        print(f"synth: error: {msg}", file=sys.stderr)
        return 2
    if getattr(args, "_module", None) is not felt:
        _warn_preset_path()
    if argv is None and args.cmd in RENDERING:
        arm_compile_notice()
        _SkipBlasProbe.install()
    try:
        if getattr(args, "threads", None) is not None:
            from .io.factory import set_default_threads

            set_default_threads(args.threads)
        return int(args.func(args) or 0)
    except SynthError as e:
        print(f"synth: error: {e}", file=sys.stderr)
        return 2
    except OSError as e:               # one line naming the path, not "[Errno 13] ..."
        print(f"synth: error: {os_error_line(e)}", file=sys.stderr)
        return 2
    except ValueError as e:
        print(f"synth: error: {e}", file=sys.stderr)
        return 2
    except Interrupted as e:                 # SIGINT or SIGTERM (synth.io.interrupt)
        print(f"synth: {e}", file=sys.stderr)
        return e.exit_status
    except KeyboardInterrupt:
        print("synth: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
