"""The Python API, for notebooks and scripts (docs/api.md)::

    import synth

    a = synth.render_note("sitar", key=57, velocity=100, seconds=2)
    a.samples.shape, a.fs          # ((96000, 1), 48000)
    a.to_wav("sitar-a3.wav")

* :func:`render_note`: one note of a preset (``synth note``);
* :func:`render_midi`: a MIDI file, by path or as a ``mido.MidiFile``
  (``synth render``);
* :func:`stream_midi`: the same render block by block (a
  :class:`MidiStream`), one block in memory at a time: ``synth render``
  writes its file from it;
* :class:`Instrument`: events given one by one, the audio rendered chunk by
  chunk, :meth:`Instrument.reset`;
* :func:`render_drone`: a preset's drone player (its ``[drone]``: a
  tanpura's four strings plucked in a cycle) from Sa (``synth drone``);
* :func:`presets`: the preset names (``synth presets``);
* :class:`Audio`: what each render returns (float32 samples (frames,
  channels), their rate, ``to_wav``, a player in Jupyter).

``import synth`` loads none of this: ``synth/__init__.py`` imports this
package on the first use of one of its names (PEP 562), so ``synth --help``
still starts without numpy.

Its layer, ``api``, sits beside the command line (tests/test_layers.py):
like a command it takes MIDI units at the edge and checks them
(:mod:`synth.api.checks`, ValueError naming the parameter, the value and
the range) before it reaches ``apps``, ``io`` and the engine below it,
and ``synth note`` and ``synth render`` render through it
(:mod:`synth.api.render`).
"""

from __future__ import annotations

from .audio import Audio
from .drone import render_drone
from .instrument import Instrument
from .render import MidiStream, presets, render_midi, render_note, stream_midi

__all__ = ["Audio", "Instrument", "MidiStream", "presets", "render_drone", "render_midi",
           "render_note", "stream_midi"]
