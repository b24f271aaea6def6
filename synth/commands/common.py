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


#: the length of a rendered note when --seconds is not given (note, analyze, compare), s
DEFAULT_SECONDS = 3.0

#: the audio formats the commands write, by file extension (synth.io.wav.FORMATS)
AUDIO_EXTENSIONS = {".wav": "wav", ".flac": "flac", ".ogg": "ogg"}

#: the optional extras and the modules each brings (pyproject.toml's optional-dependencies)
#: ([live] is checked by synth.io.live's players, before any slow work)
EXTRAS = {"plots": ("matplotlib",), "batch": ("distributed", "pandas", "pyarrow")}


def fail(msg: str) -> None:
    raise SynthError(msg)


def arm_compile_notice() -> None:
    """From the command line: say on stderr, within the first second, when
    the kernels are about to compile (a cold numba cache), with progress on
    a terminal (:mod:`synth.dsp.compile_notice`; no numba import here)."""
    from ..dsp import compile_notice

    compile_notice.arm()


def check_output(path: str, option: str) -> None:
    """Fail before any work if `path` cannot be an output file (its directory is missing)."""
    if os.path.isdir(path):
        fail(f"{option} {path}: is a directory, give a file name")
    d = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(d):
        fail(f"{option} {path}: directory {d} does not exist")


def audio_format(path: str, option: str) -> str:
    """The format an audio output's extension chooses ("wav", "flac" or
    "ogg"), or a one-line error before any work: an unknown extension
    (.mp3) or none is not written as WAV data under that name."""
    ext = os.path.splitext(path)[1].lower()
    fmt = AUDIO_EXTENSIONS.get(ext)
    allowed = ", ".join(AUDIO_EXTENSIONS)
    if fmt is None:
        what = f"extension {ext!r} is not an audio format synth writes" if ext \
            else "has no extension to choose the audio format"
        fail(f"{option} {path}: {what} (allowed: {allowed})")
    if fmt != "wav":
        import soundfile as sf

        if fmt.upper() not in sf.available_formats():
            fail(f"{option} {path}: this libsndfile cannot write {fmt.upper()} (allowed here: .wav)")
    return fmt


def _same_file(a: str, b: str) -> bool:
    """`a` and `b` name one file: the same path resolved (a relative path, a
    symlink), or, both existing, the same inode (a hard link)."""
    try:
        if os.path.exists(a) and os.path.exists(b) and os.path.samefile(a, b):
            return True
    except OSError:
        pass
    return os.path.realpath(a) == os.path.realpath(b)


def check_not_inputs(outputs, inputs) -> None:
    """Fail before any work if an output file names an input file, or
    another output: `outputs` and `inputs` are (option, path) pairs, a path
    None when not given.  ``synth render X.mid -o X.mid`` leaves X.mid as
    it was."""
    seen = []
    for opt, path in outputs:
        if path is None:
            continue
        for what, inp in inputs:
            if inp is not None and _same_file(str(path), str(inp)):
                fail(f"{opt} {path}: is the input {what} {inp}; writing it would destroy it "
                     f"(give another output file)")
        for opt2, p2 in seen:
            if _same_file(str(path), str(p2)):
                fail(f"{opt} {path}: is also {opt2} {p2}; give each output its own file")
        seen.append((opt, path))


def preset_file(name) -> str | None:
    """The file a preset argument reads (a .toml path, or the file a name
    finds on the preset path), None if none."""
    if name is None:
        return None
    name = str(name)
    if os.path.isfile(name):
        return name
    from ..io.presets.loader import find_preset_file

    f = find_preset_file(name)
    return None if f is None else str(f)


def require_extra(extra: str, what: str, modules=None) -> None:
    """Fail before any work if an optional extra's packages are missing:
    one line saying how to install them."""
    import importlib.util

    missing = []
    for m in modules or EXTRAS[extra]:
        try:
            if importlib.util.find_spec(m) is None:
                missing.append(m)
        except (ImportError, ValueError):
            missing.append(m)
    if missing:
        fail(f'{what} needs the [{extra}] extra ({", ".join(missing)} not installed): '
             f'pip install "synth[{extra}]"')


def peak_warning(path: str, peak_dbfs: float, gain: float | None, n_clipped: int = 0) -> str | None:
    """The one-line warning for a render over full scale (None under it):
    its peak in dBFS and the gain change, in dB and as ``--set
    output.gain``, that brings it to -1 dBFS."""
    import math

    if not (math.isfinite(peak_dbfs) and peak_dbfs > 0.0):
        return None
    drop = peak_dbfs + 1.0
    clipped = f", {n_clipped} samples clipped" if n_clipped else ""
    fix = f"{-drop:+.1f} dB would peak at -1 dBFS"
    if gain is not None:
        fix += f": --set output.gain={gain * 10.0 ** (-drop / 20.0):.4g} (the preset's is {gain:.4g})"
    return (f"warning: {path} peaks at {peak_dbfs:+.1f} dBFS, over full scale{clipped}; "
            f"{fix}, or --set output.limiter=on")


def os_error_line(e: OSError) -> str:
    """An OSError as one line naming the path: ``out/x.wav: Permission
    denied``, not ``[Errno 13] Permission denied: 'out/x.wav'``."""
    from ..io.errors import display_path

    reason = e.strerror or str(e) or type(e).__name__
    if e.filename is not None:
        where = display_path(os.fsdecode(e.filename))
        if e.filename2 is not None:
            where += f" -> {display_path(os.fsdecode(e.filename2))}"
        return f"{where}: {reason}"
    return reason


def add_quality(p) -> None:
    """--quality and --max-error on a command that builds an engine."""
    p.add_argument("--quality", choices=("draft", "standard", "reference"),
                   help="how finely the strings are computed (default: the preset's "
                        "play.quality, standard); `synth help quality` gives each level's error "
                        "and cost")
    p.add_argument("--max-error", metavar="CENTS,DB",
                   help="the cheapest quality level whose measured error for this preset is "
                        "within CENTS (partial frequencies) and DB (partial levels), e.g. 1,1 "
                        "(default: none, --quality decides; synth help quality)")


def quality_overrides(args) -> list:
    """The ``--set`` overrides for --quality or --max-error (none without)."""
    q = getattr(args, "quality", None)
    me = getattr(args, "max_error", None)
    if q is not None and me is not None:
        fail("--quality and --max-error are exclusive: give one of them")
    if me is not None:
        from ..io.presets.quality import level_within

        try:
            c, d = (float(v) for v in me.split(","))
        except ValueError:
            fail(f"--max-error = {me!r} is not CENTS,DB (two numbers, e.g. 0.5,1)")
        try:
            q = level_within(c, d, getattr(args, "preset", None)).name
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


def write_audio(path: str, audio, fs: int, pcm24: bool, fmt: str = "wav", gain=None) -> str:
    """Write `audio` as a WAV file (32-bit float, or 24-bit PCM), or FLAC or
    Ogg Vorbis (`fmt`); its peak, and clipping if any.  Over full scale, a
    warning on stderr (:func:`peak_warning`; `gain`: the preset's output.gain)."""
    import sys

    import numpy as np

    from ..io.wav import write_wav

    res = write_wav(path, audio.astype(np.float32), fs, "pcm24" if pcm24 else "float", fmt=fmt)
    warn = peak_warning(path, res.peak_dbfs, gain, res.n_clipped)
    if warn:
        print(warn, file=sys.stderr)
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
                        "(default: none, plain MIDI; `synth help midi`, MPE)")


def add_threads(p) -> None:
    p.add_argument("--threads", type=int, metavar="N",
                   help="threads the strings render on (default: every core this process may "
                        "use, or SYNTH_THREADS); the samples are the same for any N")


def add_audio_output(p, default: str | None = None, when: str = "") -> None:
    """An offline command's audio output options: ``--rate``, ``-o/--output``
    (required when ``default`` is None) and ``--pcm24``.  ``when``: what the
    output's help adds before its default, e.g. ``"48 kHz, or --rate; "``."""
    p.add_argument("--rate", type=float, metavar="HZ",
                   help="output sample rate in Hz (default 48000; 44100, 88200, 96000, any "
                        "22050-192000)")
    what = "output audio file, its format by extension: .wav, .flac or .ogg"
    if default is None:
        p.add_argument("-o", "--output", required=True, metavar="OUT.wav",
                       help=f"{what} ({when}required)")
    else:
        p.add_argument("-o", "--output", default=default, metavar="OUT.wav",
                       help=f"{what} ({when}default %(default)s)")
    p.add_argument("--pcm24", action="store_true",
                   help="WAV: write 24-bit PCM instead of 32-bit float (default: float; "
                        "FLAC is always 24-bit)")
