"""The voice contract: what the engine may ask of an instrument.

STK's instrument contract is the model (note on, note off, control change,
render a block), with one difference: a voice does not render.  It writes
its physics into string slots of the bank (:class:`synth.dsp.bank.StringBank`)
at note-on and changes them at note-off or on a control; the engine renders
every active slot of every voice with one kernel call per block segment.

A voice class
=============
* subclasses :class:`Voice` and is registered under the preset ``voice``
  names it plays (:func:`synth.voices.registry.register_voice`);
* is built as ``cls(preset, fs_internal)`` from a validated preset (the
  physics is SI; MIDI values arrive normalised to [0, 1]);
* declares what the engine must allocate (:meth:`Voice.sizes`) and, if it
  has one, the body the engine puts on its output (:meth:`Voice.body`);
* implements :meth:`Voice.note_on` and :meth:`Voice.note_off`, and may
  override the other hooks, whose defaults are given here.

The engine owns the voice pool (which slots belong to which sounding note),
the pedals' state and the event timing; a voice is told the slots of one
note and what happened.  Pedals: the engine applies the sustain pedal to the
released notes' slots through :meth:`Voice.damper_lift` and
:meth:`synth.dsp.bank.StringBank.apply_dampers`, and passes the soft pedal
to :meth:`Voice.note_on` (``soft``).  Controllers 120 (all sound off) and
123 (all notes off) are the engine's.

The doc block of each voice (in its module docstring: what it models, which
thesis equations, which preset sections it reads) is what ``synth presets``
users and :doc:`docs/architecture.md` point to.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, NamedTuple

from ..dsp.bank import StringBank
from ..physics.soundboard import BodyDesign, KnockShape
from .quality import quality_level


@dataclass(frozen=True)
class FreeStringsDesign:
    """Strings no key stops, hanging on one bridge with the played strings
    (:class:`synth.engine.free_strings.FreeStrings`): what both of the
    component's configurations share.  A voice returns one of the two
    configurations from :meth:`Voice.free_strings`:

    * :class:`SympatheticDesign`: the strings of a keyboard whose dampers are
      off (a piano's), at the output rate on a bank of their own, driven
      one way by the played strings' force on the board;
    * :class:`TarafDesign`: the sympathetic and drone strings of a sitar,
      at the voice's internal rate in the engine's bank, on one two-way
      bridge with the played strings.

    slots : tuple of SlotTemplate  each string (lossy far end, bridge-force
                                   output, no excitation)
    keys : tuple of int            the MIDI key each is tuned to
    resistance_ns_per_m : float    the bridge they hang on: u_b = integral of
                                   F / R (N s/m)
    return_hz : float              its spring's slow return (Hz)
    max_cells : int                the longest string's cells
    """

    slots: tuple
    keys: tuple
    resistance_ns_per_m: float
    return_hz: float
    max_cells: int


@dataclass(frozen=True)
class SympatheticDesign(FreeStringsDesign):
    """Free strings of a keyboard (a piano's undamped strings, sympathetic
    resonance and the pedal's halo), for the engine to run at its output
    rate: one per key, ringing while its damper is off and its key is not
    itself sounding.

    dampers : tuple of tuple       each string's damper row
                                   (:meth:`StringBank.set_damper`)
    has_damper : tuple of bool     whether the key has a damper at all
    """

    dampers: tuple = ()
    has_damper: tuple = ()


class DronePluck(NamedTuple):
    """How the drones are plucked: the kernel's pluck kind (``K.EXC_*``),
    the amplitude (m) at velocity 1 and the duration (s) per drone, the biwa
    force pluck's rate (1/s) and the velocity exponent."""

    kind: int
    amplitudes_m: tuple
    durations_s: tuple
    alpha_per_s: float
    velocity_exponent: float


@dataclass(frozen=True)
class TarafDesign(FreeStringsDesign):
    """Free strings on an instrument's bridge at the voice's internal rate:
    a sitar's sympathetic strings (taraf, ``slots``), always free, ringing
    with whatever the played strings and the drones put into the bridge,
    and its drone strings (chikari), strummed by a key range or a MIDI
    channel and ringing along too.  The engine runs them in its bank, on
    one bridge with the played strings (:class:`synth.engine.taraf.Taraf`).

    drone_slots : tuple of SlotTemplate  the drone strings (as ``slots``)
    drone_keys : tuple of int       their tunings
    trigger : tuple (lo, hi) or None  MIDI keys that strum the drones
    channel : int or None           MIDI channel (0-15) whose notes strum them
    pluck : DronePluck              how the drones are plucked
    strum_s : float                 delay between successive drones (s)
    max_region : int                the largest termination region (points)
    """

    drone_slots: tuple = ()
    drone_keys: tuple = ()
    trigger: tuple | None = None
    channel: int | None = None
    pluck: DronePluck | None = None
    strum_s: float = 0.0
    max_region: int = 1


@dataclass(frozen=True)
class BankSizes:
    """What one engine must allocate for a voice (per string slot).

    strings_per_voice : int  string slots per sounding note (1 .. 3 for a piano key)
    max_cells : int          largest N (cells) any playable note needs
    max_region : int         largest termination region (grid points), 0: none
    max_gtable : int         longest injected g(t) table (samples), 0: none
    max_bend : int           longest pitch-bend line (samples), 0: none
    """

    strings_per_voice: int
    max_cells: int
    max_region: int = 0
    max_gtable: int = 0
    max_bend: int = 0


class Voice:
    """Base class of every voice (see the module docstring).

    Parameters
    ----------
    preset : synth.io.presets.Preset
        A validated preset whose ``voice`` is one of the class's registered
        names.
    fs_internal : float or None
        Internal rate (Hz); None: the voice's default (``DEFAULT_RATE``)
        times the preset's quality level's factor (``play.quality``,
        :mod:`synth.voices.quality`).

    Attributes
    ----------
    preset : Preset
    fs : float
        The internal rate the voice's strings run at (Hz).
    quality : synth.voices.quality.QualityLevel
        The preset's quality level (its stiffness filters' tolerance; its
        rate unless ``fs_internal`` is given).
    study : bool
        A study preset (the thesis's experiments): the engine then keeps
        its strings until the render ends instead of freeing silent ones.
    """

    #: registered preset ``voice`` names (set by :func:`register_voice`)
    names: ClassVar[tuple[str, ...]] = ()
    #: output buses the voice's strings write (1, or 2: the bass and treble
    #: ends of a bridge, each string split between them by its ``pan``)
    buses: ClassVar[int] = 1
    DEFAULT_RATE: ClassVar[float] = 325_000.0
    study: bool = False
    #: whether a hammer strikes the notes (a hammer speed, the strike's log
    #: and the hammer's contact telemetry apply); plucked voices: False
    struck: bool = False

    def __init__(self, preset, fs_internal: float | None = None):
        if preset.voice not in self.names:
            raise ValueError(f"voice = {preset.voice!r} is not handled by {type(self).__name__} "
                             f"(it plays: {', '.join(self.names)})")
        self.preset = preset
        play = getattr(preset, "play", None)
        self.quality = quality_level(getattr(play, "quality", None))
        self.fs = float(fs_internal or self.DEFAULT_RATE * self.quality.rate_factor)

    # -- what the engine allocates ---------------------------------------------
    def sizes(self, extra_low_key: int | None = None) -> BankSizes:
        """Sizes for the bank; ``extra_low_key``: a MIDI key below the
        voice's own range that must still sound (a keyboard or a file may
        send any key)."""
        raise NotImplementedError(f"{type(self).__name__} must define sizes()")

    def body(self) -> BodyDesign | None:
        """The body (soundboard, gourd, wooden box) the engine applies to the
        voice's mix after decimation: the preset's ``[body]`` table, or None
        when it has none (bare strings).  Bridge inputs and outputs are the
        table's (the grand's) or 1 and 1."""
        b = getattr(self.preset, "body", None)
        if b is None:
            return None
        return BodyDesign(wet=b.wet, n_modes=b.modes, size=b.size, brightness=b.brightness,
                          seed=b.seed, inputs=b.inputs or 1, outputs=b.outputs or 1,
                          peaks=tuple(b.peaks or ()), spread_ms=b.spread_ms,
                          mass_hz=b.mass_hz)

    def warm(self) -> None:
        """Derive every note's physics now, so that no note-on in the audio
        thread has to (called before a live stream opens).  Default: nothing
        to derive."""

    # -- events ---------------------------------------------------------------
    def note_on(self, bank: StringBank, slots: tuple[int, ...], key: float | None,
                velocity: float, *, f0_hz: float | None = None, probe_row: int = -1,
                restrike: bool = False, speed_m_per_s: float | None = None,
                soft: float = 0.0) -> None:
        """Start a note on the bank's ``slots`` (``sizes().strings_per_voice`` of
        them) and activate the slots that sound.

        key : MIDI key (may be fractional), or None with ``f0_hz`` or for a
            study string's own pitch.
        velocity : normalised, 0 < value <= 1.
        f0_hz : explicit pitch (Hz) instead of the key.
        probe_row : probe row for the first string (string j of the note:
            ``probe_row + j``), -1: none (study renders, contact telemetry).
        restrike : the note is sounding on these slots and is played again
            on the same strings (do not reconfigure them).
        rest : (a voice that can: the plucked one, for the drone player)
            configure and activate the strings at rest, excited by nothing;
            the other voices do not take it.
        speed_m_per_s : explicit hammer speed (m/s) for struck voices.
        soft : soft pedal, 0 .. 1.

        Raises ValueError if the pitch cannot be built (the engine then
        drops the note).
        """
        raise NotImplementedError(f"{type(self).__name__} must define note_on()")

    def note_off(self, bank: StringBank, slots: tuple[int, ...], key: float | None,
                 f0_hz: float | None, pedal: float) -> None:
        """The key is up: damp the note's strings as far as the sustain pedal
        (0 .. 1) lets the dampers fall."""
        raise NotImplementedError(f"{type(self).__name__} must define note_off()")

    def damper_lift(self, pedal: float) -> float:
        """How far the sustain pedal (0 .. 1) keeps the dampers off the
        strings, 0 .. 1.  Default: a switch at 0.5 (no half pedal)."""
        return 1.0 if pedal >= 0.5 else 0.0

    def fine_window_s(self, key: float | None) -> float | None:
        """How long (s) a strike of ``key`` keeps its strings on a finer
        grid than the one they go on with (the engine then calls
        :meth:`leave_fine_grid` at that internal sample), or None: the
        strings keep their grid.  Default: None."""
        return None

    def leave_fine_grid(self, bank: StringBank, slots: tuple[int, ...],
                        key: float | None) -> bool:
        """Move a note's sounding strings to their coarser grid; False
        while that cannot be done yet (the engine tries again a millisecond
        later).  Default: nothing to move."""
        return True

    def pitch_bend(self, bank: StringBank, slots: tuple[int, ...], key: float | None,
                   f0_hz: float | None, value: float) -> None:
        """Pitch bend of a sounding note, ``value`` in [-1, 1] of
        ``play.pitch_bend_semitones`` (the engine's
        :class:`synth.engine.play.PlayRules`, which passes bends on only when
        that range is above 0).  Default: the voice does not bend (a piano)."""

    def controls(self) -> dict:
        """The MIDI controllers the voice plays itself (through
        :meth:`control_change`) and their values when the preset loads,
        ``{cc: value in [0, 1]}``: the engine keeps them per MIDI channel,
        sets a note's channel's values before its note-on, and restores
        these at CC121 (reset all controllers).  Default: none."""
        return {}

    @property
    def pressure_cc(self) -> int | None:
        """The control of :meth:`controls` that pressure plays on one note
        (channel pressure on the channel's notes, polyphonic key pressure
        on its key's: the engine calls :meth:`control_change` with those
        notes alone, :mod:`synth.engine.mpe`), or None: the voice plays no
        pressure (the engine lists it).  Default: None."""
        return None

    def control_change(self, bank: StringBank, cc: int, value: float, sounding) -> bool:
        """A MIDI control change the engine does not handle itself (it
        takes the pedals 64, 66, 67 and the channel-mode messages).

        cc : controller number, 0 .. 127.  value : normalised, 0 .. 1.
        sounding : the notes sounding now on the message's channel, an
            iterable of (slots, key, f0_hz) tuples (read it at most once,
            during the call); the value also holds for the notes to come
            (the engine sets each note's channel's value before its note-on).
        Returns True when the voice used the control.  Default: ignored.
        """
        return False

    def pitch_hz(self, key: float | None = None, f0_hz: float | None = None) -> float:
        """The frequency a note sounds at (Hz): ``f0_hz`` if given, else the
        voice's tuning of ``key`` (default: equal temperament, A4 = 440 Hz)."""
        if f0_hz is not None:
            return float(f0_hz)
        if key is None:
            raise ValueError("key or f0_hz is required")
        return 440.0 * 2.0 ** ((float(key) - 69.0) / 12.0)

    def strike_log(self):
        """Probe channels of the last excitation computed apart from the
        bank (the first stage of an injected strike), or None."""
        return None

    def knock_impulse_ns(self, key: float | None, velocity: float,
                         speed_m_per_s: float | None = None) -> float:
        """The impulse (N s) of the action's knock on the board at a note-on
        (the key hitting the keybed, the thump under a struck note): the
        engine adds it to the bridge buses as a short force pulse
        (:func:`synth.physics.soundboard.knock_pulse`) at the note's sample,
        on the key's place along the bridge.  Default 0: no knock."""
        return 0.0

    def knock_shape(self) -> KnockShape:
        """The shape of the knock's force (:meth:`knock_impulse_ns`;
        :class:`synth.physics.soundboard.KnockShape`): default one pulse of
        the piano action's 5 ms."""
        return KnockShape()

    def pan(self, key: int) -> float:
        """Where the key meets the bridge, 0 (bus 0) .. 1 (bus 1): the
        split of its knock.  Default: the middle."""
        return 0.5

    def free_strings(self, fs_out: float) -> FreeStringsDesign | None:
        """The strings on the bridge that no key stops, or None (the
        default: none): a :class:`SympatheticDesign` (a keyboard's undamped
        strings, designed at the engine's output rate ``fs_out`` (Hz): the
        engine runs them on a bank of their own, driven by the played
        strings' force on the bridge, each ringing while its damper is off
        and its key is not itself sounding) or a :class:`TarafDesign`
        (sympathetic and drone strings designed at the voice's internal
        rate: the engine runs them in its bank on one two-way bridge with
        the played strings)."""
        return None
