"""What the commands share: the one-line user error, output-path checks, the
engine and WAV helpers, and the options several commands take (--quality and
--max-error, --threads, --channels and --drums, --mpe, --rate).

Imported when the parser is built, so only argparse-level things at the top;
the engine, numpy and the rest are imported inside the functions that use
them.
"""

from __future__ import annotations

import argparse
import os

from ..io.errors import SynthError


def fail(msg: str) -> None:
    raise SynthError(msg)


def check_output(path: str, option: str) -> None:
    """Fail before any work if `path` cannot be an output file (its directory is missing)."""
    if os.path.isdir(path):
        fail(f"{option} {path}: is a directory, give a file name")
    d = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(d):
        fail(f"{option} {path}: directory {d} does not exist")


def add_quality(p) -> None:
    """--quality and --max-error on a command that builds an engine."""
    p.add_argument("--quality", choices=("draft", "standard", "reference"),
                   help="how finely the strings are computed (default: the preset's "
                        "play.quality, standard); docs/quality.md gives each level's error "
                        "and cost")
    p.add_argument("--max-error", metavar="CENTS,DB",
                   help="the cheapest quality level whose measured error for this preset is "
                        "within CENTS (partial frequencies) and DB (partial levels), e.g. 1,1 "
                        "(docs/quality.md)")


def quality_overrides(args) -> list:
    """The ``--set`` overrides for --quality or --max-error (none without)."""
    q = getattr(args, "quality", None)
    me = getattr(args, "max_error", None)
    if q is not None and me is not None:
        fail("--quality and --max-error are exclusive: give one of them")
    if me is not None:
        from ..voices.quality import cheapest_within

        try:
            c, d = (float(v) for v in me.split(","))
        except ValueError:
            fail(f"--max-error = {me!r} is not CENTS,DB (two numbers, e.g. 0.5,1)")
        name = getattr(args, "preset", None)
        if name is not None and str(name).endswith(".toml"):
            name = os.path.splitext(os.path.basename(str(name)))[0]
        try:
            q = cheapest_within(c, d, name).name
        except ValueError as e:
            fail(f"--max-error: {e}")
    return [] if q is None else [f"play.quality={q}"]


def engine_for(preset_name: str, overrides, internal_rate=None, probe=False, low_key=None,
               rate=None):
    """A preset's engine, with its --set overrides: (preset, instrument, engine)."""
    from ..io.factory import build_engine

    kw = {} if rate is None else {"fs_out": rate}
    eng = build_engine(preset_name, overrides, fs_internal=internal_rate, probe=probe,
                       extra_low_key=low_key, **kw)
    return eng.inst.preset, eng.inst, eng


def write_audio(path: str, audio, fs: int, pcm24: bool) -> str:
    """Write `audio` as a WAV file (32-bit float, or 24-bit PCM); its peak, and clipping if any."""
    import numpy as np

    from ..io.wav import write_wav

    res = write_wav(path, audio.astype(np.float32), fs, "pcm24" if pcm24 else "float")
    clip = f", {res.n_clipped} samples clipped" if res.n_clipped else ""
    return f"peak {res.peak_dbfs:.1f} dBFS{clip}"




def parse_channels(text: str) -> tuple[int, ...]:
    """``--channels``: MIDI channels as users number them, 1-16, with
    ranges (``1,3-4``) -> 0-based channels (0, 2, 3)."""
    out = set()
    for part in text.split(","):
        part = part.strip()
        try:
            lo, _, hi = part.partition("-")
            a, b = int(lo), int(hi or lo)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"--channels = {text!r}: {part!r} is not a channel or a range (e.g. 1,3-4)") from None
        if not (1 <= a <= b <= 16):
            raise argparse.ArgumentTypeError(
                f"--channels = {text!r}: {part!r} is out of range (channels 1 <= value <= 16)")
        out.update(range(a - 1, b))
    return tuple(sorted(out))


def add_channels(p) -> None:
    p.add_argument("--channels", type=parse_channels, metavar="LIST",
                   help="MIDI channels that play, 1-16, e.g. 1,3-4 (default: every channel; "
                        "the others' messages are skipped and counted)")
    p.add_argument("--drums", action="store_true",
                   help="play channel 10 too: General MIDI keeps it for drums, so by default "
                        "its notes are skipped (and counted)")


def output_rate(args):
    """``--rate`` checked (None when not given)."""
    if args.rate is None:
        return None
    from ..io.rates import check_rate

    try:
        return check_rate(args.rate)
    except SynthError as e:
        fail(str(e))


def parse_mpe_option(text: str) -> tuple[tuple[int, int], ...]:
    """``--mpe``: MPE zones (:func:`synth.engine.mpe.parse_mpe`)."""
    from ..engine.mpe import parse_mpe

    try:
        return parse_mpe(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def add_mpe(p) -> None:
    p.add_argument("--mpe", type=parse_mpe_option, default=(), metavar="ZONE",
                   help="MPE zones, as if the MPE configuration message (RPN 6) had been "
                        "received: lower (manager channel 1, notes on 2-16), upper (manager "
                        "16, notes on 1-15), lower:N or upper:N (N member channels), or "
                        "lower:7,upper:7; each note's channel bends (48 semitones, plus the "
                        "manager's 2; held within the preset's range), presses (its buzz) "
                        "and sets its pluck point (CC74) for that note alone "
                        "(docs/midi.md, MPE)")


def add_threads(p) -> None:
    p.add_argument("--threads", type=int, metavar="N",
                   help="threads the strings render on (default: every core this process may "
                        "use, or SYNTH_THREADS); the samples are the same for any N")
