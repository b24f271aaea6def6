"""Live play: a MIDI keyboard in, the audio device out (``synth play``).

The offline engine plays live through :class:`synth.engine.realtime.Realtime`.
This package adds what touches the outside world, all of it optional
(the ``[live]`` extra: sounddevice and python-rtmidi, imported only when live
play is asked for, never by ``import synth.io.live``):

* :mod:`~synth.io.live.devices`: what is installed (:func:`check_audio`,
  :func:`check_midi`, one line saying how to get what is missing), the MIDI
  input port and audio output device by name, ``--list-ports``.
* :mod:`~synth.io.live.programs`: :class:`ProgramMap`, MIDI program number
  -> preset (``--program-map``).
* :mod:`~synth.io.live.engines`: :func:`ready_engine`, a preset's engine
  built and warmed for live play.
* :mod:`~synth.io.live.player`: :class:`Player` (stream, callback, program
  changes, report) and :func:`normalise` (MIDI message -> engine event).
* :mod:`~synth.io.live.jack`: :class:`~synth.io.live.jack.JackPlayer`, the
  player as a JACK client (``synth play --jack``: each MIDI event on its
  frame); not imported here (it loads JACK-Client when asked for).

The names below are re-exported, so ``synth.io.live.X`` works for all of
them.  To monkeypatch one, patch the module that looks it up (e.g.
``synth.io.live.player.check_audio`` for the player), not the package.
"""

from __future__ import annotations

from synth.io.live.devices import (FS_OUT, INSTALL_LIVE, NO_MIDI_PORT, NO_MIDI_SYSTEM,
                                   PORTAUDIO_MISSING, check_audio, check_midi, list_ports,
                                   match_name, midi_input_names, pick_audio_device, pick_midi_api,
                                   pick_midi_port)
from synth.io.live.engines import ready_engine
from synth.io.live.player import SWITCH_INTERVAL_S, Player, normalise
from synth.io.live.programs import ProgramMap

__all__ = [
    "FS_OUT",
    "SWITCH_INTERVAL_S",
    "INSTALL_LIVE",
    "PORTAUDIO_MISSING",
    "NO_MIDI_PORT",
    "NO_MIDI_SYSTEM",
    "pick_midi_api",
    "check_audio",
    "check_midi",
    "midi_input_names",
    "pick_midi_port",
    "pick_audio_device",
    "match_name",
    "list_ports",
    "normalise",
    "ProgramMap",
    "ready_engine",
    "Player",
]
