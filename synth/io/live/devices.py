"""What live play needs from the outside world, and which port and device.

* ``sounddevice`` (PortAudio) for the audio output and ``python-rtmidi``
  (mido's ``rtmidi`` backend) for the MIDI input, imported only here and only
  when live play is asked for: importing :mod:`synth` or rendering offline
  never loads them.  What is missing is reported as one line saying how to
  get it (:func:`check_audio`, :func:`check_midi`).
* Port and device choice by name (exact, else case-insensitive substring):
  :func:`pick_midi_port`, :func:`pick_audio_device`, :func:`list_ports`
  (``synth play --list-ports``).

Turning a MIDI message into an engine event (``normalise``) is not here but
in :mod:`synth.io.live.player`: this module finds the hardware and checks
that it can be used, and never imports the engine; what a message means is
the player's business.
"""

from __future__ import annotations

import contextlib
import os
import sys
import tempfile

from synth.io.errors import SynthError
from synth.io.rates import CARD_RATES_HZ, check_rate

__all__ = [
    "FS_OUT",
    "CARD_RATES_HZ",
    "check_rate",
    "INSTALL_LIVE",
    "PORTAUDIO_MISSING",
    "NO_MIDI_PORT",
    "check_audio",
    "check_midi",
    "pick_midi_api",
    "jack_server_running",
    "port_lister",
    "MIDI_APIS",
    "NO_MIDI_SYSTEM",
    "midi_input_names",
    "pick_midi_port",
    "pick_audio_device",
    "match_name",
    "list_ports",
]

#: Default output rate of the live stream (Hz).
FS_OUT = 48_000

INSTALL_LIVE = 'pip install -e ".[live]"'
PORTAUDIO_MISSING = ("PortAudio library not found: install it (Debian/Ubuntu: apt-get install "
                     "libportaudio2; Fedora: dnf install portaudio; macOS: brew install portaudio)")
NO_MIDI_PORT = ("no MIDI input port found; connect a keyboard, or on Linux check that the ALSA "
                "sequencer (/dev/snd/seq) is available")
NO_MIDI_SYSTEM = ("no MIDI system: neither the ALSA sequencer (/dev/snd/seq) nor a JACK server is "
                  "available; connect a keyboard (ALSA), start a JACK server (jackd, or PipeWire's "
                  "pipewire-jack), or play as a JACK client with --jack")
_RTMIDI_BACKEND = "mido.backends.rtmidi"
#: ``--midi-api`` names and rtmidi's API names (mido's ``rtmidi/API`` backends)
MIDI_APIS = {"alsa": "LINUX_ALSA", "jack": "UNIX_JACK"}
#: the name the MIDI input shows on the ALSA sequencer or the JACK server
MIDI_CLIENT_NAME = "synth"


# --------------------------------------------------------------------------
# What is installed
# --------------------------------------------------------------------------


@contextlib.contextmanager
def _quiet_c_stderr():
    """Silence file descriptor 2 (the C libraries' ``ALSA lib ...: open
    /dev/snd/seq failed`` chatter) for the duration; the Python errors that
    follow carry the same information in one line."""
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, ValueError, AttributeError):
        yield
        return
    try:
        with tempfile.TemporaryFile() as sink:
            os.dup2(sink.fileno(), 2)
            try:
                yield
            finally:
                os.dup2(saved, 2)
    finally:
        os.close(saved)


def check_audio():
    """The ``sounddevice`` module, or a :class:`SynthError` saying what is
    missing and how to install it.

    Returns
    -------
    module
        ``sounddevice`` (PortAudio loaded).

    Raises
    ------
    SynthError
        ``sounddevice`` is not installed (``pip install -e ".[live]"``), or
        the PortAudio library is missing (the system package to install).
    """
    try:
        with _quiet_c_stderr():
            import sounddevice
    except ImportError as e:
        if e.name in ("sounddevice", "cffi", "_cffi_backend"):
            raise SynthError(f"sounddevice is not installed (audio output of synth play): "
                             f"{INSTALL_LIVE} in the synth checkout, or pip install sounddevice"
                             ) from None
        raise SynthError(f"sounddevice cannot be imported ({e}): {INSTALL_LIVE}") from None
    except OSError as e:
        if "portaudio" in str(e).lower():
            raise SynthError(PORTAUDIO_MISSING) from None
        raise SynthError(f"sounddevice cannot load PortAudio ({e}); {PORTAUDIO_MISSING}") from None
    return sounddevice


def check_midi(api: str | None = None):
    """mido's ``rtmidi`` backend (a :class:`mido.Backend`, loaded), or a
    :class:`SynthError` saying how to install python-rtmidi.

    Parameters
    ----------
    api : {"alsa", "jack"} or None
        The MIDI system (``--midi-api``): the ALSA sequencer or JACK MIDI;
        None: rtmidi's default (ALSA on Linux).

    The backend is not made mido's global default; use its
    ``get_input_names()`` and ``open_input()``.
    """
    import mido

    if api is not None and api not in MIDI_APIS:
        raise SynthError(f"--midi-api = {api!r} is not one of {', '.join(MIDI_APIS)} (or auto)")
    name = _RTMIDI_BACKEND if api is None else f"{_RTMIDI_BACKEND}/{MIDI_APIS[api]}"
    try:
        with _quiet_c_stderr():
            return mido.Backend(name, load=True)
    except ImportError as e:
        if e.name == "rtmidi":
            raise SynthError(f"python-rtmidi is not installed (MIDI input of synth play): "
                             f"{INSTALL_LIVE} in the synth checkout, or pip install python-rtmidi"
                             ) from None
        raise SynthError(f"python-rtmidi cannot be loaded ({e}): {INSTALL_LIVE}") from None



# --------------------------------------------------------------------------
# Ports and devices
# --------------------------------------------------------------------------


def port_lister(api: str, name: str = f"{MIDI_CLIENT_NAME}-ports"):
    """An rtmidi input client on ``api`` (``"alsa"`` or ``"jack"``) whose
    ``get_ports()`` lists the MIDI input ports; kept open, a look costs a
    query, not a client registration (mido's ``get_input_names`` opens one
    per call: on JACK tens of ms with the GIL held).

    Raises
    ------
    Exception
        rtmidi's, when the MIDI system does not answer (or ImportError).
    """
    import rtmidi

    with _quiet_c_stderr():
        return rtmidi.MidiIn(getattr(rtmidi, f"API_{MIDI_APIS[api]}"), name=name)


def jack_server_running() -> bool:
    """Whether a JACK server answers (the default one, or
    ``$JACK_DEFAULT_SERVER``), asked through rtmidi's JACK MIDI, without
    starting one."""
    try:
        port_lister("jack", f"{MIDI_CLIENT_NAME}-probe").delete()
    except Exception:            # no rtmidi, no JACK API compiled in, no server
        return False
    return True


def pick_midi_api(api: str | None = "auto") -> str:
    """``--midi-api``: ``"alsa"`` or ``"jack"`` as given, or for ``"auto"``
    (None) JACK MIDI when a JACK server runs, else the ALSA sequencer.

    Raises
    ------
    SynthError
        An unknown name, or ``auto`` with neither system available
        (:data:`NO_MIDI_SYSTEM`).
    """
    if api in (None, "auto"):
        if jack_server_running():
            return "jack"
        if sys.platform.startswith("linux") and not os.path.exists("/dev/snd/seq"):
            raise SynthError(NO_MIDI_SYSTEM)
        return "alsa"
    if api not in MIDI_APIS:
        raise SynthError(f"--midi-api = {api!r} is not one of auto, {', '.join(MIDI_APIS)}")
    return api


def midi_input_names(backend) -> list[str]:
    """Names of the MIDI input ports the backend sees.

    Raises
    ------
    SynthError
        The MIDI system cannot be opened (no ALSA sequencer): the
        no-port message with the backend's reason in parentheses.
    """
    try:
        with _quiet_c_stderr():
            names = backend.get_input_names()
    except Exception as e:  # rtmidi raises its own SystemError subclasses
        raise SynthError(f"{NO_MIDI_PORT} ({_one_line(e)})") from None
    return list(names)


def _one_line(e: BaseException) -> str:
    s = str(e).strip()
    return s.splitlines()[0] if s else type(e).__name__


def match_name(wanted: str, names: list[str], option: str, what: str) -> str:
    """The one name in ``names`` that ``wanted`` designates: an exact match,
    else the only one containing it (case-insensitive).

    Parameters
    ----------
    wanted : str
        What the user gave.
    names : list of str
        The candidates (non-empty).
    option : str
        The option, for the message (``"--midi-port"``).
    what : str
        What the names are, for the message (``"MIDI input port"``).

    Raises
    ------
    SynthError
        No name matches (the message lists them all), or several contain
        ``wanted`` and none equals it (the message lists those).
    """
    if wanted in names:
        return wanted
    low = wanted.lower()
    hits = list(dict.fromkeys(n for n in names if low in n.lower()))
    if len(hits) == 1:
        return hits[0]
    if not hits:
        shown = "; ".join(repr(n) for n in names)
        raise SynthError(f"{option} {wanted!r} matches no {what} (available: {shown})")
    shown = "; ".join(repr(n) for n in hits)
    raise SynthError(f"{option} {wanted!r} matches several {what}s ({shown}): give more of the name")


def pick_midi_port(backend, wanted: str | None = None) -> str:
    """The MIDI input port to play from.

    Parameters
    ----------
    backend : mido.Backend
        From :func:`check_midi`.
    wanted : str or None
        ``--midi-port``: an exact name or a case-insensitive part of one;
        None: the first port that is not ALSA's "Midi Through" (else that).

    Raises
    ------
    SynthError
        No input port at all, or ``wanted`` matches none (all are listed)
        or several.
    """
    names = midi_input_names(backend)
    if not names:
        raise SynthError(NO_MIDI_PORT)
    if wanted is not None:
        return match_name(wanted, names, "--midi-port", "MIDI input port")
    real = [n for n in names if not n.lower().startswith("midi through")]
    return (real or names)[0]


def _output_devices(sd) -> list[dict]:
    return [dict(d, index=i) for i, d in enumerate(sd.query_devices())
            if d["max_output_channels"] > 0]


def _default_output(sd) -> int:
    try:
        return int(sd.default.device[1])
    except Exception:
        return -1


def pick_audio_device(sd, wanted: str | None = None, fs: int | None = None
                      ) -> tuple[int, str, int, int]:
    """The audio output device and its channel count for the live stream.

    Parameters
    ----------
    sd : module
        ``sounddevice`` (from :func:`check_audio`).
    wanted : str or None
        ``--audio-device``: a device index, an exact name or a
        case-insensitive part of one; None: PortAudio's default output.
    fs : int or None
        ``--rate``: the output rate (Hz) asked for; None: 48 kHz, or the
        device's own default rate when it cannot play 48 kHz and that rate
        is one of :data:`CARD_RATES_HZ`.

    Returns
    -------
    (index, name, channels, fs)
        ``channels`` is 2 when the device takes stereo at ``fs`` float32
        (a mono instrument then sounds the same on both), else 1 (left and
        right mixed); ``fs`` the rate (Hz) the stream opens at.

    Raises
    ------
    SynthError
        No output device, no match, or a device that cannot play the rate.
    """
    outs = _output_devices(sd)
    if not outs:
        raise SynthError("no audio output device found (PortAudio lists none); check the "
                         "sound card, or on Linux ALSA (aplay -l), PulseAudio/PipeWire or JACK")
    if wanted is None:
        idx = _default_output(sd)
        dev = next((d for d in outs if d["index"] == idx), outs[0])
    elif wanted.strip().isdigit():
        dev = next((d for d in outs if d["index"] == int(wanted)), None)
        if dev is None:
            shown = "; ".join(f"{d['index']} {d['name']!r}" for d in outs)
            raise SynthError(f"--audio-device {wanted} is not an output device (available: {shown})")
    else:
        name = match_name(wanted, [d["name"] for d in outs], "--audio-device", "audio output device")
        dev = next(d for d in outs if d["name"] == name)
    rates = [int(fs)] if fs is not None else [FS_OUT]
    own = int(round(float(dev.get("default_samplerate") or 0)))
    if fs is None and own in CARD_RATES_HZ and own != FS_OUT:
        rates.append(own)              # a card that cannot play 48 kHz plays its own rate
    errors = []
    for rate in rates:
        for ch in (2, 1):              # stereo (left, right), else the two mixed
            if ch > dev["max_output_channels"]:
                continue
            try:
                with _quiet_c_stderr():
                    sd.check_output_settings(device=dev["index"], channels=ch, dtype="float32",
                                             samplerate=rate)
                return dev["index"], dev["name"], ch, rate
            except Exception as e:
                errors.append(_one_line(e))
    shown = " or ".join(f"{r} Hz" for r in rates)
    raise SynthError(f"audio device {dev['name']!r} cannot play {shown} float32 mono or "
                     f"stereo ({'; '.join(dict.fromkeys(errors)) or 'no output channels'}); "
                     "--rate picks another rate")


def list_ports() -> str:
    """MIDI input ports (ALSA sequencer and JACK MIDI) and audio output
    devices (``synth play --list-ports``).

    Works with any part missing: what cannot be listed says why.
    """
    lines = []
    for api, title in (("alsa", "ALSA sequencer"), ("jack", "JACK MIDI")):
        lines.append(f"MIDI input ports, {title} (--midi-api {api} --midi-port NAME):")
        if api == "jack" and not jack_server_running():
            lines.append("  unavailable: no JACK server is running")
            continue
        try:
            names = midi_input_names(check_midi(api))
        except SynthError as e:
            lines.append(f"  unavailable: {e}")
        else:
            lines += [f"  {n}" for n in names] or ["  none"]
    lines.append("Audio output devices (--audio-device; * = default):")
    try:
        sd = check_audio()
        outs = _output_devices(sd)
        default = _default_output(sd)
        apis = [a["name"] for a in sd.query_hostapis()]
    except SynthError as e:
        lines.append(f"  unavailable: {e}")
    else:
        if not outs:
            lines.append("  none: PortAudio lists no output device")
        for d in outs:
            mark = "*" if d["index"] == default else " "
            api = apis[d["hostapi"]] if 0 <= d["hostapi"] < len(apis) else "?"
            lines.append(f"{mark} {d['index']:2d}  {d['name']}  ({api}, {d['max_output_channels']} "
                         f"channels, {d['default_samplerate']:.0f} Hz)")
    return "\n".join(lines)
