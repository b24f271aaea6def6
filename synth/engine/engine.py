"""Block engine: sample-accurate events, voice pool, mixing, decimation.

The engine knows nothing of MIDI or files: it receives :class:`Event` s whose
values are already normalised (velocity and controllers in [0, 1]) and time
stamped in seconds, and produces output blocks at ``fs_out``.

Per output block of ``n_out`` samples it renders exactly the number of
internal samples the decimator needs, split at the internal sample of each
event (an event at time t acts at internal sample round(t fs_in), not at a
block boundary), mixes every active string at the internal rate, decimates
once, and frees voices that have fallen silent (they then cost nothing).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..dsp.bank import StringBank
from ..dsp.body import Body
from ..dsp.decimator import Decimator
from ..dsp.knock import Knocks
from ..dsp.listener import Listener
from ..kernels import strings as K
from ..physics.soundboard import knock_pulse
from ..voices import design_store
from ..voices.base import SympatheticDesign, TarafDesign
from .channels import (  # noqa: F401  (re-exported: the engine's controller numbers)
    CC_ALL_NOTES_OFF, CC_ALL_SOUND_OFF, CC_DATA_LSB, CC_DATA_MSB, CC_EXPRESSION, CC_MODE,
    CC_NAMES, CC_NRPN_LSB, CC_NRPN_MSB, CC_PAN, CC_RESET_ALL, CC_RPN_LSB, CC_RPN_MSB,
    CC_SOFT, CC_SOSTENUTO, CC_SUSTAIN, CC_VOLUME, CHANNELS, HUSH_T60_S, PAN_CENTRE,
    VOLUME_DEFAULT, ChannelControls)
from .mixing import ChannelGroup
from .drone import Drone
from .order import note_identity, order_events
from .output import OutputStage
from .play import STEAL_RULES, PlayRules  # noqa: F401  (STEAL_RULES re-exported)
from .sympathetic import Sympathetic
from .taraf import Taraf

NOTE_ON = "note_on"
NOTE_OFF = "note_off"
CONTROL = "control"
PITCH_BEND = "pitch_bend"
CHANNEL_PRESSURE = "channel_pressure"
POLY_PRESSURE = "poly_pressure"
#: a note struck less than this long ago (s) is not given up to a new one
#: while older ones sound (a chord's notes, a fast run's last notes)
STEAL_MIN_AGE_S = 0.02


@dataclass(frozen=True)
class Event:
    """A normalised performance event.

    time_s : float        time from the start of the render (s), >= 0
    kind : str            "note_on" | "note_off" | "control" | "pitch_bend" |
                          "channel_pressure" | "poly_pressure" (others ignored)
    key : float           MIDI key (may be fractional; poly_pressure's too) or
                          controller number (-1: pitch_bend, channel_pressure)
    value : float         velocity in (0, 1], controller value or pressure in
                          [0, 1], or bend in [-1, 1]
    channel : int         0..15
    f0_hz : float | None  explicit pitch instead of the key (note_on only)
    speed_m_per_s : float | None  hammer speed instead of the velocity's
    string : int | None   which of the key's own strings (a tanpura's two
                          middle Sa strings share a key): part of the
                          note's identity when set, so that each string is
                          a voice of its own (:mod:`synth.engine.drone`
                          plucks with it); None: the key's one voice
    """

    time_s: float
    kind: str
    key: float = -1
    value: float = 0.0
    channel: int = 0
    f0_hz: float | None = None
    speed_m_per_s: float | None = None
    string: int | None = None


@dataclass
class _Voice:
    key: object            # (channel, key) identity (+ string, Event.string)
    start: int             # internal sample of the (last) note-on
    slots: tuple           # bank slots of its strings
    key_arg: object        # MIDI key for the instrument, or None
    f0_hz: float | None
    released: bool = False
    dying: bool = False    # stolen or shed: fading out, no longer counted

    @property
    def channel(self) -> int:
        return self.key[0]


class Engine(ChannelControls):
    """Offline/online renderer for one instrument.

    Parameters
    ----------
    instrument : synth.voices.base.Voice
        The voice: it writes its notes into the engine's string bank
        (the contract of :mod:`synth.voices.base`).
    fs_out : int
        Output rate (Hz), 48 000 by default.
    polyphony : int or None
        Voice pool size (default: the preset's).
    probe : bool
        Record the probe channels (u at the excitation point, region points
        in contact, hammer force, ...) per internal sample for every string
        of the first voice (study renders, contact telemetry).
    silence_dbfs : float
        A released/decayed voice whose output stays below this level for two
        periods (and at least 20 ms) is freed.
    drone : bool
        Whether the preset's drone player plays (its ``[drone]`` with
        ``player = "on"``): False for single notes, each key plucking its
        own string.
    """

    MAX_BLOCK_OUT = 4096

    def __init__(self, instrument, fs_out: int = 48_000, polyphony: int | None = None,
                 probe: bool = False, silence_dbfs: float = -110.0, extra_low_key: int | None = None,
                 threads: int = 1, drone: bool = True):
        self.inst = instrument
        self.fs_in_exact = float(instrument.fs)
        # the decimator needs an integer rate with a small ratio; the physics
        # keeps its exact dt (study grids), the audio is off by < 0.3 cent
        fs_int = int(round(self.fs_in_exact))
        if abs(fs_int - self.fs_in_exact) > 1e-6 or math.gcd(fs_int, int(fs_out)) < 100:
            fs_int = int(round(self.fs_in_exact / 100.0)) * 100
        self.fs_in = fs_int
        self.fs_out = int(fs_out)
        self.dec = Decimator(self.fs_in, self.fs_out)
        #: the playing rules (the preset's ``[play]``: the pool's size, the
        #: steal rule, the key range, the bend range)
        self.play = PlayRules.from_preset(instrument.preset)
        self.polyphony = int(polyphony or self.play.polyphony)
        #: voices fading out after being stolen or shed use spare indices
        self.n_spare = max(4, self.polyphony // 4)
        self.n_index = self.polyphony + self.n_spare
        sizes = instrument.sizes(extra_low_key)
        #: strings per voice (a grand piano note has up to three)
        self.spv = int(sizes.strings_per_voice)
        #: output buses the strings write (the bridge's bass and treble ends)
        self.buses = int(instrument.buses)
        max_in = self.dec.inputs_needed(self.MAX_BLOCK_OUT) + 16
        #: the strings on the bridge that no key stops (one component, two
        #: configurations, :mod:`synth.engine.free_strings`; the voice's
        #: design picks one): a sitar's taraf and chikari in the bank after
        #: the voices' slots, on one bridge with every sounding played string
        #: (:mod:`synth.engine.taraf`), or a piano's undamped strings at the
        #: output rate (:mod:`synth.engine.sympathetic`, below)
        fd = instrument.free_strings(self.fs_out)
        td = fd if isinstance(fd, TarafDesign) else None
        sd = fd if isinstance(fd, SympatheticDesign) else None
        n_voice_slots = self.n_index * self.spv
        n_taraf = 0 if td is None else len(td.slots) + len(td.drone_slots)
        max_cells, max_region, max_group = sizes.max_cells, sizes.max_region, K.MAX_CPL
        if td is not None:
            max_cells = max(max_cells, td.max_cells)
            max_region = max(max_region, td.max_region)
            max_group = max(max_group, n_taraf + n_voice_slots)
        self.bank = StringBank(n_voice_slots + n_taraf, max_cells,
                               max_region=max(max_region, 1), max_block=4096,
                               n_probes=self.spv if probe else 0, max_gtable=sizes.max_gtable,
                               max_bend=sizes.max_bend, max_group=max_group)
        self.taraf = None if td is None else Taraf(td, self.bank, n_voice_slots,
                                                   self.fs_in_exact)
        #: the drone player (the preset's ``[drone]``: a key starts and stops
        #: a cycle of plucks of its strings, :mod:`synth.engine.drone`), or None
        self.drone = Drone.from_preset(instrument.preset, self.fs_in_exact) if drone else None
        #: the body (soundboard) stage after decimation, if the instrument has one
        design = instrument.body()
        self.body = None if design is None else Body.from_design(fs_out, design,
                                                                 store=design_store)
        #: decimated channels: the body's inputs (buses beyond them are summed
        #: into the first before decimation), or one per bus without a body
        self.n_dec = min(self.buses, self.body.inputs) if self.body is not None else self.buses
        #: output channels (1: mono, 2: stereo)
        self.channels = self.body.outputs if self.body is not None else self.n_dec
        self.decs = [self.dec] + [Decimator(self.fs_in, self.fs_out) for _ in range(self.n_dec - 1)]
        #: the output policy (the preset's ``[output]``: the gain of what the
        #: engine adds to the buses, the peak limiter), the last stage
        self.output = OutputStage.from_preset(instrument.preset, self.fs_out, self.channels)
        #: its peak limiter (``[output] limiter = "on"``), or None
        self.limiter = self.output.limiter
        #: the listening position (the preset's ``[listener]``: distance,
        #: directivity, air, the room's reflections and reverberation), a
        #: stage after the body, before the output stage; None: the body's
        #: output as it is
        self.listener = Listener.from_preset(instrument.preset, self.fs_out, self.channels,
                                             store=design_store)
        self.mix = np.zeros((self.buses, max_in))
        self.probe = probe
        self._probe: list[np.ndarray] = []
        self.time_in = 0                     # internal samples rendered so far
        self.voices: dict[int, _Voice] = {}  # voice index -> voice
        self.by_key: dict[object, int] = {}  # (channel, key) -> voice index
        # -- per MIDI channel: pedals, controllers and bend act on their own
        # channel's notes (index: channel 0 .. 15)
        self.pedal = np.zeros(CHANNELS)      # sustain pedal CC64, 0..1 (half pedal between)
        self.soft = np.zeros(CHANNELS)       # soft pedal CC67, 0..1
        self.sostenuto = np.zeros(CHANNELS, dtype=bool)   # CC66 (down at 0.5 and above)
        # voice indices whose dampers the sostenuto holds off (held when it went down)
        self._latched = np.zeros(self.n_index, dtype=bool)
        self._latched_keys: set = set()      # their (channel, key) (the strings stay free while it is down)
        self.bend = {}                       # pitch bend per channel, -1..1 of its range
        #: pitch-bend range per channel as a share of the preset's
        #: ``play.pitch_bend_semitones`` (RPN 0 sets it; 1: the preset's)
        self.bend_range = np.ones(CHANNELS)
        #: the registered parameter selected by CC101/100 per channel
        #: ((msb, lsb); (127, 127): none) and whether it is an NRPN
        self._rpn = [(127, 127)] * CHANNELS
        self._nrpn = [False] * CHANNELS
        #: MPE zones (none until the configuration message or --mpe)
        self._init_mpe()
        #: the channel of each voice index (its notes' channel)
        self._chan = np.zeros(self.n_index, dtype=np.int64)
        #: volume (CC7), expression (CC11) and pan (CC10) per channel, MIDI
        #: values / 127 (:meth:`channel_gain`, :meth:`channel_pan_gains`)
        self.volume = np.full(CHANNELS, VOLUME_DEFAULT)
        self.expression = np.ones(CHANNELS)
        self.pan = np.full(CHANNELS, PAN_CENTRE)
        #: the voice's own controls (CC -> value at load) and each channel's
        #: values of them; the instrument holds one value per control for the
        #: notes to come (``_inst_ctl``), set to a note's channel's value at
        #: its note-on
        self._ctl_default = dict(instrument.controls())
        if self.drone is not None:
            self._check_drone_controls()
        self._ctl = [dict(self._ctl_default) for _ in range(CHANNELS)]
        self._inst_ctl = dict(self._ctl_default)
        #: how a new note finds a voice when all are sounding (``play.steal``)
        self.steal = self.play.steal
        #: messages the engine received and did not play, by description
        #: (``"CC 5 (portamento time)"``: count), for the render summary and
        #: the live report
        self.ignored: dict[str, int] = {}
        #: the channels whose volume, expression or pan left their defaults:
        #: rows of the mix of their own (:mod:`synth.engine.mixing`)
        self.groups: dict[int, ChannelGroup] = {}
        #: the channel whose rows the bridge's own strings (taraf) and whose
        #: sustain pedal the undamped strings (sympathetic) follow: the
        #: latest note's
        self._bridge_channel = 0
        #: all sound off: the voices it fades, freed once the output has faded
        self._hushed: dict = {}
        #: all sound off's output fade: (its first output sample in the
        #: next block rendered, samples of it done), or None
        self._hush_out = None
        self._hush_len = max(1, int(round(HUSH_T60_S * self.fs_out)))
        # voice indices whose key is up and which are not fading out: the
        # sustain pedal damps exactly these (one array operation per CC64)
        self._released = np.zeros(self.n_index, dtype=bool)
        #: voices whose strings leave a finer grid after a window (the
        #: instrument's ``fine_window_s``): voice index -> (internal sample
        #: due, the note-on's sample); done at the first block start after it
        self._hand_over: dict[int, tuple[int, int]] = {}
        self._spv_range = np.arange(self.spv)
        #: each voice index's slots (a tuple per index, made once)
        self._slot_tuples = tuple(tuple(range(v * self.spv, (v + 1) * self.spv))
                                  for v in range(self.n_index))
        #: the wave energy of voices (index -> the sum of its strings' squared
        #: travelling waves, m^2: the stealing's measure, :meth:`_quietest`) at internal sample
        #: ``_energy_time`` of the bank: a chord's steals at one sample
        #: measure each candidate once (a voice's entry goes when its
        #: strings are touched: struck, freed, moved to another grid)
        self._energy: dict[int, float] = {}
        self._energy_time = -1
        self._out = np.zeros((self.channels, self.MAX_BLOCK_OUT))
        self._dout = np.zeros((self.n_dec, self.MAX_BLOCK_OUT))
        self.n_stolen = 0                    # voices faded out to make room
        self.n_shed = 0                      # voices faded out under CPU overload
        self.n_dropped = 0                   # note-ons the instrument could not play
        self.silence_level = 10.0 ** (silence_dbfs / 20.0)
        #: the strings that ring along through the bridge (the voice's
        #: sympathetic strings, at the output rate), or None
        self.sym = None if sd is None else Sympathetic(sd, self.fs_out, self.n_dec,
                                                       self.MAX_BLOCK_OUT, self.silence_level,
                                                       1.0 / self.output.gain)
        self._sym_dirty = True
        #: threads the strings render on (:meth:`set_threads`)
        self.threads = 1
        self.set_threads(threads)
        #: per voice index: its key's sympathetic string (-1: none, or the
        #: voice is free or fading out) and whether its key is up
        #: (``_Voice.released``): :meth:`_sympathetic_state` in array operations
        self._vsym = np.full(self.n_index, -1, dtype=np.int64)
        self._vrel = np.zeros(self.n_index, dtype=bool)
        self._sym_events: list = []          # (output sample, lift, muted, hush) within this block
        self._sym_hush = False               # all sound off: fade them at the next such event
        #: (output sample, hush) of the latest events' new state, not yet read
        #: (:meth:`_sym_event`), or None
        self._sym_wait: tuple | None = None
        self._n_out = 0                      # the block's output samples (:meth:`render_block`)
        #: the action's knocks: a unit pulse (its shape), and the force still
        #: to add to the buses (output samples from the block's start)
        self._knock_unit = knock_pulse(self.fs_out, 1.0, *instrument.knock_shape())
        #: the knocks join the bridge after decimation: they wait the
        #: decimator's latency so that they meet the note they belong to
        self._knock_lag = int(round(self.dec.latency_samples))
        self._knock = Knocks(self._knock_unit, self.n_dec, self.MAX_BLOCK_OUT)
        self._knocking = False
        self.time_out = 0                    # output samples rendered so far
        self._pending: list[tuple[int, int, Event]] = []
        self._seq = 0
        #: count the contacts of the latest note's strings (live ``--stats``;
        #: :meth:`contact_telemetry`)
        self.telemetry = False
        self._telem: tuple | None = None     # (voice index, key) of the counted note

    def _check_drone_controls(self) -> None:
        """The drone's controllers must be free: not the engine's own (the
        pedals, volume, expression, pan, parameter selection and data entry)
        nor the voice's (the buzz, the pluck point).  ValueError naming it."""
        engine_ccs = (CC_SUSTAIN, CC_SOSTENUTO, CC_SOFT, CC_VOLUME, CC_EXPRESSION, CC_PAN,
                      CC_DATA_MSB, CC_DATA_LSB, CC_RPN_MSB, CC_RPN_LSB, CC_NRPN_MSB, CC_NRPN_LSB)
        for name, cc in (("tempo_cc", self.drone.tempo_cc), ("pattern_cc", self.drone.pattern_cc)):
            if cc in engine_ccs or cc in self._ctl_default:
                what = CC_NAMES.get(cc, "the voice's own control")
                if cc in self._ctl_default:
                    what = "the voice's own control" + (f", {what}" if cc in CC_NAMES else "")
                raise ValueError(f"drone.{name} = {cc} is taken ({what}): give another "
                                 "controller (1 <= value <= 119)")

    # -- events -----------------------------------------------------------------
    def sample_of(self, time_s: float) -> int:
        """Internal sample index at which an event at ``time_s`` acts."""
        return int(round(time_s * self.fs_in_exact))

    def schedule(self, events) -> None:
        """Queue events (any order); they act at their own internal sample,
        simultaneous ones in the order of :func:`synth.engine.order.order_events`
        (the file reader's and the live player's: a note-on before the
        note-off of a zero-length note, the note-off of an earlier note
        before a new note-on of its key)."""
        new = list(events)
        if not new:
            return
        items = [ev for _, _, ev in self._pending] + new
        held = {vo.key for vo in self.voices.values() if not vo.released and not vo.dying}
        ordered = order_events(items, time_of=lambda ev: self.sample_of(ev.time_s), sounding=held)
        self._pending = [(self.sample_of(ev.time_s), self._seq + i, ev)
                         for i, ev in enumerate(ordered)]
        self._seq += len(ordered)

    def _alloc(self, at: int) -> int:
        """A free voice index for a note-on at internal sample ``at``.  With
        ``polyphony`` voices sounding, one of them is faded out in about 10
        ms (never cut: that clicks) and keeps its index until silent; the
        new note takes a spare index.  The voice given up is one struck at
        least :data:`STEAL_MIN_AGE_S` before (a chord on a full pool must
        not steal its own notes), released ones first, then by
        ``play.steal``: the quietest (the least wave energy in its strings
        at this sample, :meth:`StringBank.energy`: the same choice whatever
        the block size, live or offline) or the oldest note.  Only when
        every sounding voice is younger (a chord larger than the pool) is
        the oldest of them given up."""
        live = [v for v, vo in self.voices.items() if not vo.dying]
        if len(live) >= self.polyphony:
            age = int(STEAL_MIN_AGE_S * self.fs_in)
            before = [v for v in live if at - self.voices[v].start >= age]
            if before:
                rel = [v for v in before if self.voices[v].released]
                pool = rel or before
                if self.steal == "oldest":
                    victim = min(pool, key=lambda v: (self.voices[v].start, v))
                else:
                    victim = self._quietest(pool)
            else:
                victim = min(live, key=lambda v: (self.voices[v].start, v))
            self._fade(victim)
            self.n_stolen += 1
        for v in range(self.n_index):
            if v not in self.voices:
                return v
        # every index busy (fading voices too): cut the quietest fading one
        v = self._quietest([v for v, vo in self.voices.items() if vo.dying])
        self._free(v)
        return v

    def _quietest(self, candidates: list) -> int:
        """The candidate voice whose strings store the least wave energy.
        The energies are those at the bank's current sample; a voice's is
        measured once per sample (a chord's notes stealing in turn at one
        sample measured every sounding voice for each: 0.3 ms a note)."""
        cache = self._energy
        if self._energy_time != self.bank.time:
            cache.clear()
            self._energy_time = self.bank.time
        need = [v for v in candidates if v not in cache]
        if need:
            slots = [s for v in need for s in self._slot_tuples[v]]
            e = self.bank.energy(slots).reshape(len(need), self.spv).sum(axis=1)
            cache.update(zip(need, e.tolist()))
        return candidates[int(np.argmin(np.array([cache[v] for v in candidates])))]

    def _touched(self, v: int) -> None:
        """Voice v's strings change other than by rendering (struck,
        freed, moved to another grid): its measured energy goes."""
        self._energy.pop(v, None)

    def _levels(self) -> np.ndarray:
        """Last block's peak output of every voice index (the loudest of its
        strings), in one array operation (a note-on with the pool full must
        not cost Python work per voice)."""
        return self.bank.last_peak[:self.n_index * self.spv].reshape(self.n_index, self.spv).max(axis=1)

    def _fade(self, v: int, t60_s: float = 0.01) -> None:
        """Fade voice v out (its strings' loss rises to T60 = ``t60_s``)."""
        vo = self.voices[v]
        vo.dying = vo.released = True
        self._released[v] = False       # the pedal no longer touches it
        self._latched[v] = False
        self._vsym[v] = -1
        self._vrel[v] = True
        self._sym_dirty = True
        if self.by_key.get(vo.key) == v:
            del self.by_key[vo.key]
        for s in vo.slots:
            self.bank.fade(s, t60_s, self.fs_in_exact)

    def shed(self, n: int) -> int:
        """Fade out the ``n`` quietest sounding voices (CPU overload); returns
        how many were shed."""
        lv = self._levels()
        live = sorted((v for v, vo in self.voices.items() if not vo.dying), key=lv.__getitem__)
        for v in live[:n]:
            self._fade(v)
        self.n_shed += len(live[:n])
        return len(live[:n])

    def _slots(self, v: int) -> tuple:
        return self._slot_tuples[v]

    def _free(self, v: int) -> None:
        self._released[v] = False
        self._latched[v] = False
        self._vsym[v] = -1
        self._touched(v)
        self._sym_dirty = True
        vo = self.voices.pop(v, None)
        if vo is not None and self.by_key.get(vo.key) == v:
            del self.by_key[vo.key]
        for s in self._slots(v):
            self.bank.deactivate(s)

    @staticmethod
    def _voice_key(ev: Event):
        """Identity of a sounding note: channel and key (or explicit f0),
        and the string when the event names one
        (:func:`synth.engine.order.note_identity`)."""
        return note_identity(ev)

    def _extra(self, ev: Event) -> dict:
        x = {"soft": float(self.soft[ev.channel])}
        if ev.speed_m_per_s is not None:
            x["speed_m_per_s"] = ev.speed_m_per_s
        return x

    def _note_on(self, ev: Event, at: int, vk, rest: bool = False) -> None:
        """Start (or strike again) the note of ``ev`` at internal sample
        ``at``; with ``rest``, start its strings at rest (configured, on
        their bridge, excited by nothing: the drone's strings before their
        pluck), or nothing if the note sounds."""
        key = None if ev.key is None or ev.key < 0 else ev.key
        if self.taraf is not None:
            if ev.string is None and self.taraf.is_trigger(ev.channel, key):
                # a stroke across the drones (no played note)
                self.taraf.strum(at, float(ev.value))
                return
            self.taraf.wake()
        if self._bridge_channel != ev.channel:
            # the strings no key holds (taraf, undamped strings) follow the
            # latest note's channel: its volume, its sustain pedal
            self._bridge_channel = ev.channel
            if self.taraf is not None:
                self._set_rows(self.taraf.slots, self._row_of(ev.channel))
        if self._ctl_default:
            self._voice_controls_for(ev.channel)
        v = self.by_key.get(vk)
        sounding = v is not None and any(self.bank.is_active(s) for s in self._slot_tuples[v])
        if rest and sounding:
            return
        if sounding:
            # a sounding key is struck again on the same strings
            vo = self.voices[v]
            self._touched(v)
            self.inst.note_on(self.bank, vo.slots, key, ev.value, f0_hz=ev.f0_hz,
                              restrike=True, **self._extra(ev))
            if self.taraf is not None:
                self.taraf.join(vo.slots)
            vo.start, vo.released = at, False
            self._released[v] = False
            self._vrel[v] = False
        else:
            v = self._alloc(at)
            slots = self._slot_tuples[v]
            self._touched(v)
            extra = self._extra(ev)
            if rest:
                extra["rest"] = True
            try:
                self.inst.note_on(self.bank, slots, key, ev.value, f0_hz=ev.f0_hz,
                                  probe_row=0 if (self.probe and not self.voices) else -1,
                                  **extra)
            except ValueError:
                # a pitch this instrument cannot build (a study string far
                # off its own pitch, say): the note is dropped, not the block
                self.n_dropped += 1
                for s in slots:
                    self.bank.deactivate(s)
                return
            self.voices[v] = _Voice(vk, at, slots, key, ev.f0_hz)
            self._vrel[v] = False
            if self.sym is not None and key is not None:
                self._vsym[v] = self.sym.slot_of.get(int(round(key)), -1)
            self._chan[v] = ev.channel
            self._set_rows(slots, self._row_of(ev.channel))
            if self.taraf is not None:
                self.taraf.join(slots)
            self._released[v] = False
            self.by_key[vk] = v
            b = self._bend_value(ev.channel)
            if b:
                self.inst.pitch_bend(self.bank, slots, key, ev.f0_hz, b)
        if not rest:
            self._add_knock(key, ev, at)
        self._schedule_hand_over(v, key, at)
        # the block's samples before the note are not its silence
        before = max(at - self.time_in, 0)
        for s in self._slot_tuples[v]:
            self.bank.reset_quiet(s, before)
        if self.telemetry:
            self._track(v, ev.key if ev.f0_hz is None else None)

    def _apply(self, ev: Event, at: int) -> None:
        if self._sym_wait is not None and self._sym_wait[0] != self._sym_sample(at):
            self._sym_read()                   # the state the earlier events left
        if self.drone is not None and ev.string is None and ev.f0_hz is None \
                and ev.kind in (NOTE_ON, NOTE_OFF) and ev.key is not None and ev.key >= 0:
            # the drone player's keys: a note-on starts, stops or moves the
            # drone (its plucks come back here with their string); a
            # note-off does nothing
            if ev.kind == NOTE_ON and ev.value > 0:
                self.drone.press(ev.key, ev.channel, at)
            return
        vk = self._voice_key(ev)
        if ev.kind in (NOTE_ON, NOTE_OFF, CONTROL):
            self._sym_dirty = True
        if ev.kind == NOTE_ON and ev.value > 0:
            self._note_on(ev, at, vk)
        elif ev.kind in (NOTE_OFF, NOTE_ON):
            v = self.by_key.get(vk)
            if v is not None:
                self._release(v)
        elif ev.kind == PITCH_BEND:
            self._pitch_bend(int(ev.channel), float(ev.value))
        elif ev.kind in (CHANNEL_PRESSURE, POLY_PRESSURE):
            self._pressure(int(ev.channel), None if ev.kind == CHANNEL_PRESSURE else ev.key,
                           float(ev.value))
        elif ev.kind == CONTROL:
            self._control(int(ev.key), float(ev.value), int(ev.channel), at)
        else:
            self._ignore(str(ev.kind))

    @property
    def latency_samples(self) -> int:
        """Output samples between an event and its sound: the decimator's
        integer latency plus the limiter's look-ahead (when it is on)."""
        return int(self.dec.latency_samples) + self.output.latency_samples

    def _out_sample(self, at: int) -> int:
        """The output sample of internal sample ``at``, counted from the
        current block's start (the stages after decimation act there): the
        first output sample at or after it, ceil(at fs_out / fs_in).  (With
        the floor, an event in a block's first internal samples could map
        to the previous block's last output sample, and the knock, the
        taraf and the sympathetic strings then acted one sample later than
        in a render with other block sizes: found by tools/stress.py.)"""
        return -((-at * self.fs_out) // self.fs_in) - self.time_out

    def _add_knock(self, key, ev: Event, at: int) -> None:
        """The action's knock of a note-on at internal sample ``at``: its
        force pulse (N, times the output gain of the voice's strings) from
        the event's output sample (and the decimator's latency) on, split
        along the bridge by the key's place (:class:`synth.dsp.knock.Knocks`)."""
        J = self.inst.knock_impulse_ns(key, ev.value, ev.speed_m_per_s)
        if J <= 0.0:
            return
        j = self._out_sample(at)
        j = min(max(int(j), 0), self.MAX_BLOCK_OUT - 1) + self._knock_lag
        g = self.output.force_to_output(J)
        grp = self.groups.get(ev.channel)
        kb = self._knock
        if grp is not None:
            g *= grp.gain.at(at)               # the channel's volume
            if grp.path is not None:
                kb = grp.path.knock
                grp.path.knocking = True
        p = self.inst.pan(int(round(key)))
        kb.add(self.time_out + j, ((1.0 - p) * g, p * g) if self.n_dec == 2 else (g,))
        if kb is self._knock:
            self._knocking = True

    def _track(self, v: int, key) -> None:
        """Count the contacts of voice v's strings from now on (and stop
        counting the previous note's)."""
        if self._telem is not None and self._telem[0] != v:
            for s in self._slots(self._telem[0]):
                self.bank.set_telemetry(s, False)
        for s in self._slots(v):
            self.bank.set_telemetry(s, True)
        self._telem = (v, key)

    def contact_telemetry(self) -> dict | None:
        """Contacts of the latest note's strings since its note-on (with
        :attr:`telemetry` on; None before the first note): ``key`` and
        ``strings``, one :meth:`StringBank.telemetry` dict per sounding
        string (termination: time in contact, episodes, most points;
        hammer: time in contact, episodes, peak force)."""
        if self._telem is None:
            return None
        v, key = self._telem
        strings = [self.bank.telemetry(s) for s in self._slots(v) if self.bank.is_active(s)]
        return {"key": key, "strings": strings}

    def _damp(self, vo: _Voice) -> None:
        self.inst.note_off(self.bank, vo.slots, vo.key_arg, vo.f0_hz, float(self.pedal[vo.channel]))

    def _release(self, v: int) -> None:
        """Key up: the instrument damps the strings as far as the sustain
        pedal lets it (fully up: the player's or the damper's full damping)."""
        vo = self.voices[v]
        if vo.released:
            return
        vo.released = True
        self._released[v] = True
        self._vrel[v] = True
        if not self._latched[v]:
            self._damp(vo)                 # (the sostenuto holds a latched one's dampers off)

    # -- rendering ----------------------------------------------------------------
    def render_block(self, n_out: int, out: np.ndarray | None = None) -> np.ndarray:
        """Render the next ``n_out`` output samples (float64), into ``out``
        or the engine's own buffer (valid until the next call): shape
        (n_out,) for a mono engine, (channels, n_out) for a stereo one."""
        if not (1 <= n_out <= self.MAX_BLOCK_OUT):
            raise ValueError(f"n_out = {n_out!r} is out of range (1 <= value <= {self.MAX_BLOCK_OUT})")
        n_in = self.dec.inputs_needed(n_out)
        mix = self.mix[:, :n_in]
        mix[:] = 0.0
        self._n_out = n_out
        start = self.time_in
        end = start + n_in
        bank = self.bank
        if self.probe:
            bank.ensure_probe_length(n_in)
            bank.probe[:, :, :n_in] = 0.0
        cursor = 0
        pend = self._pending
        taraf = self.taraf
        drone = self.drone
        while True:
            if self._hand_over:
                # strings leaving a finer grid, at their own sample (block
                # boundaries do not move them: live and offline agree)
                th = min(d for d, _ in self._hand_over.values())
                if th < end and (not pend or th < pend[0][0]):
                    off = max(th - start, 0)
                    if off > cursor:
                        bank.render(self.mix, cursor, off - cursor)
                        cursor = off
                    self._hand_overs_due(start + off)
                    continue
            dp = None if drone is None else drone.next_due()
            if dp is not None and dp < end and (not pend or dp < pend[0][0]):
                # the drone's plucks (and the start of its next cycle) at
                # their own internal sample; an event at the same sample
                # comes first (a key that stops the drone there)
                off = max(dp - start, 0)
                if off > cursor:
                    bank.render(self.mix, cursor, off - cursor)
                    cursor = off
                for i, key, vel, ch in drone.due(start + off):
                    if vel is None:
                        # a string of the cycle, at rest on the bridge until its pluck
                        ev = Event((start + off) / self.fs_in_exact, NOTE_ON, key, 1.0, ch, string=i)
                        self._note_on(ev, start + off, self._voice_key(ev), rest=True)
                        continue
                    self._apply(Event((start + off) / self.fs_in_exact, NOTE_ON, key, vel, ch,
                                      string=i), start + off)
                    self._sym_event(start + off)
                continue
            tp = None if taraf is None else taraf.next_pluck()
            if tp is not None and tp < end and (not pend or tp < pend[0][0]):
                # a drone of a stroke is plucked (a stroke's later strings
                # come after their event)
                off = max(tp - start, 0)
                if off > cursor:
                    bank.render(self.mix, cursor, off - cursor)
                    cursor = off
                taraf.pluck_due(start + off, off)
                continue
            if not (pend and pend[0][0] < end):
                break
            at, _, ev = pend.pop(0)
            off = max(at - start, 0)
            if off > cursor and not self._inert(ev.kind):
                bank.render(self.mix, cursor, off - cursor)
                cursor = off
            self._apply(ev, start + off)
            self._sym_event(start + off)
        if self._sym_wait is not None:
            self._sym_read()
        if cursor < n_in:
            bank.render(self.mix, cursor, n_in - cursor)
        self.time_in = end
        if self.probe:
            self._probe.append(bank.probe[:, :, :n_in].copy())
        mix = self.mix[:, :n_in]              # (a channel's own rows may have been added)
        paths = self._mix_groups(mix, start, n_in) if self.groups else ()
        if self.n_dec < self.buses:
            mix[0] += mix[1]                  # a mono body: the bridge's two ends summed
        if self.sym is not None or self._knocking or self.n_dec > self.channels or paths:
            d = self._dout[:, :n_out]
            for c in range(self.n_dec):
                self.decs[c].process(mix[c], d[c])
            if self._knocking:
                # the knocks' force joins the bridge (it drives the board,
                # and the sympathetic strings hear it)
                self._knocking = self._knock.mix_into(d, self.time_out, n_out)
            for g in paths:
                self._path_decimate(g, mix, n_out)
            if self.sym is not None:
                # the panned channels' strings drive the sympathetic strings too
                for g in paths:
                    d += g.path.d[:, :n_out]
                self._sympathetic_block(d, n_out)
                for g in paths:
                    d -= g.path.d[:, :n_out]
            y = self._finish(d, n_out, out)
            for g in paths:
                self._path_out(g, y, n_out)
        elif self.channels == 1:
            y = self.dec.process(mix[0], self._out[0] if out is None else out)
            if self.body is not None:
                self.body.process(y, out=y)
        else:
            y = (self._out if out is None else out)[:, :n_out]
            if self.body is None:
                for c in range(self.n_dec):
                    self.decs[c].process(mix[c], y[c])
            else:
                d = self._dout[:, :n_out]
                for c in range(self.n_dec):
                    self.decs[c].process(mix[c], d[c])
                self.body.process(d, out=y)
        if self.listener is not None:
            self.listener.process(y, out=y)
        self.output.process(y)
        if self._hush_out is not None:
            self._hush_block(y, n_out)
        self._reap(n_in)
        self.time_out += n_out
        return y

    def _sym_sample(self, at: int) -> int:
        """The output sample in this block at which the sympathetic strings
        take the state an event at internal sample ``at`` leaves."""
        return min(max(self._out_sample(at), 0), self._n_out)

    def _sym_event(self, at: int) -> None:
        """After an event at internal sample ``at``: the sympathetic strings
        take their new state from the output sample of that internal sample
        (block-size independent).  The state is read once for all the
        events that act at one output sample (:meth:`_sym_read`, before the
        next event at another sample, or at the end of the events): a
        chord's eight note-ons read and set it once, not eight times (each
        read and set cost 20-30 us of the audio thread's block)."""
        if self.sym is not None and self._sym_dirty:
            j = self._sym_sample(at)
            w = self._sym_wait
            hush = self._sym_hush or (w is not None and w[0] == j and w[1])
            self._sym_wait = (j, hush)
            self._sym_dirty = False
            self._sym_hush = False

    def _sym_read(self) -> None:
        """The state the events at the waiting output sample left, to the
        block's list (:meth:`_sympathetic_block` applies it there)."""
        j, hush = self._sym_wait
        self._sym_wait = None
        self._sym_events.append((j, *self._sympathetic_state(), hush))

    def _schedule_hand_over(self, v: int, key, at: int) -> None:
        """After a strike: if the instrument plays this key's strike on a
        finer grid for a window (``fine_window_s``), its strings go on at
        the coarser one from the internal sample that ends it."""
        w = None if key is None else self.inst.fine_window_s(key)
        if w is not None:
            self._hand_over[v] = (at + int(math.ceil(w * self.fs_in)), at)

    def _hand_overs_due(self, now: int) -> None:
        for v, (due, at) in list(self._hand_over.items()):
            if due > now:
                continue
            vo = self.voices.get(v)
            if vo is None or vo.dying or vo.start != at:
                del self._hand_over[v]          # gone, or struck again since
                continue
            self._touched(v)
            if self.inst.leave_fine_grid(self.bank, vo.slots, vo.key_arg):
                del self._hand_over[v]
            else:
                # a hammer still on the strings: look again a millisecond on
                self._hand_over[v] = (now + max(1, int(0.001 * self.fs_in)), at)

    def _sympathetic_block(self, d: np.ndarray, n_out: int) -> None:
        """The strings that ring along, driven by the played strings' force
        in ``d`` (the decimated buses), added to it; their dampers and mutes
        change at the events' output samples."""
        sym = self.sym
        c0 = 0
        for j, lift, muted, hush in self._sym_events:
            sym.process(d, c0, j - c0)
            if hush:
                sym.fade(HUSH_T60_S)       # all sound off
            sym.set_dampers(lift, muted)
            c0 = j
        self._sym_events.clear()
        if self._sym_dirty:                 # a voice freed since: from here on
            sym.set_dampers(*self._sympathetic_state())
            self._sym_dirty = False
        sym.process(d, c0, n_out - c0)
        sym.reap(n_out, idle=self.bank.n_active == 0)

    def _finish(self, d: np.ndarray, n_out: int, out) -> np.ndarray:
        """The output block from the decimated buses ``d``: through the body,
        or as they are; shape (n_out,) or (channels, n_out)."""
        y = self._out if out is None else out
        if self.channels == 1:
            y = (y[0] if y.ndim == 2 else y)[:n_out]
            if self.body is not None:
                # a board with two bridges and one output takes both buses
                self.body.process(d if self.n_dec > 1 else d[0], out=y)
            else:
                y[:] = d[0]
            return y
        y = y[:, :n_out]
        if self.body is not None:
            self.body.process(d, out=y)
        else:
            y[:] = d
        return y

    def _sympathetic_state(self):
        """The sympathetic strings' dampers after a pedal or a note: each
        key's lift by the sustain pedal (1 for a key the sostenuto holds or
        a key held down), its string silent while the key sounds as a
        played note.  Returns (lift, muted), one value per string."""
        sym = self.sym
        # the strings no key holds share the instrument's dampers: the pedal
        # of the channel that played last lifts them
        lift = np.full(sym.n, self.inst.damper_lift(float(self.pedal[self._bridge_channel])))
        for _, k in self._latched_keys:
            i = sym.slot_of.get(k)
            if i is not None:
                lift[i] = 1.0
        muted = np.zeros(sym.n, dtype=bool)
        # the sounding voices' strings (``_vsym``: -1 for none), held by the
        # key or the sostenuto (a loop over the voices cost ~1 us each, per
        # event: 64 us a note-on with the pool full)
        vs = self._vsym
        on = vs >= 0
        muted[vs[on]] = True
        lift[vs[on & (self._latched | ~self._vrel)]] = 1.0
        return lift, muted

    def _reap(self, n_in: int) -> None:
        """Free silent strings (output below the silence level for four
        periods and 20 ms, excitation over) and the voices left with none;
        the scan itself is a kernel (no allocation per block)."""
        bank = self.bank
        if bank.n_active == 0:
            if self.voices and not self.inst.study:
                for v in list(self.voices):
                    self._free(v)
            return
        done = bank.reap(n_in, self.silence_level, int(0.02 * self.fs_in))
        if len(done) == 0 or self.inst.study:
            return
        done = done.tolist()
        if self.taraf is not None:
            # the bridge's own strings go only while nothing is played
            self.taraf.reap(done, idle=not self.voices)
            done = [s for s in done if not self.taraf.owns(s)]
        for s in done:
            bank.deactivate(s)
            self._touched(s // self.spv)
        for v in {s // self.spv for s in done}:
            if v in self.voices and not any(bank.is_active(s) for s in self._slots(v)):
                self._free(v)

    @property
    def n_voices(self) -> int:
        """Sounding voices (fading-out ones included)."""
        return len(self.voices)

    @property
    def n_live(self) -> int:
        """Voices that count against the polyphony (not fading out)."""
        return sum(1 for vo in self.voices.values() if not vo.dying)

    def probe_channels(self, string: int = 0) -> np.ndarray:
        """All probe channels (kernel ``P_*``) of the first voice's string
        ``string`` (0 .. strings per voice - 1) per internal sample, shape
        (channels, samples): u at the excitation point (m), region points in
        contact, hammer force (N), felt compression (m), hammer position (m),
        outgoing wave g (m).  A string the note does not use reads zeros."""
        if not self.probe:
            raise ValueError("probe = False: this engine records no probe")
        if not (0 <= string < self.spv):
            raise ValueError(f"string = {string!r} is out of range (0 <= value <= {self.spv - 1})")
        return np.concatenate([b[string] for b in self._probe], axis=1)

    def probe_signals(self):
        """(u at the excitation point (m), contact counts) per internal sample."""
        ch = self.probe_channels()
        return ch[K.P_U], ch[K.P_CONTACT]

    def set_threads(self, n: int) -> None:
        """Render the strings on ``n`` threads (1 .. the machine's,
        :func:`synth.dsp.threads.max_threads`), the same samples for any
        ``n``.  Call it between blocks, from any thread."""
        self.bank.set_threads(n)
        if self.sym is not None:
            self.sym.bank.set_threads(n)
        self.threads = self.bank.threads

    def render(self, events, duration_s: float | None = None, tail_s: float = 1.0,
               max_tail_s: float = 30.0, block: int = 1024, compensate_latency: bool = True,
               progress=None, drone_end_s: float | None = None) -> np.ndarray:
        """Render events offline.

        duration_s : exact length of the result (s); None: until the last
            event plus the release tails (voices silent, and the taraf's
            halo: its strings freed as silent), plus ``tail_s``,
            at most ``max_tail_s`` after the last event.
        progress : callable or None
            Called after every block with the number of output samples
            rendered so far (the latency compensation's included); None
            (the default) calls nothing.  The rendered samples are the same
            either way.
        drone_end_s : float or None
            With ``duration_s`` None: a drone player still running at this
            time (s; None: the last event's) plays out the cycle it is in and
            stops, and the render ends when its strings have rung out (a MIDI
            file's end: :attr:`synth.apps.render.RenderPlan.file_end_s`).
        Returns float64 audio at ``fs_out``, shape (n,) (mono) or (n,
        channels), aligned so that an event at t sounds at t (the
        decimator's integer latency and the limiter's are removed).
        (:meth:`render_blocks` gives the same samples a block at a time.)
        """
        chunks = list(self.render_blocks(events, duration_s, tail_s, max_tail_s, block,
                                         compensate_latency, progress, drone_end_s))
        if chunks:
            return np.concatenate(chunks)
        return np.zeros(0) if self.channels == 1 else np.zeros((0, self.channels))

    def render_blocks(self, events, duration_s: float | None = None, tail_s: float = 1.0,
                      max_tail_s: float = 30.0, block: int = 1024,
                      compensate_latency: bool = True, progress=None,
                      drone_end_s: float | None = None):
        """:meth:`render`'s samples as a generator of blocks (each a new
        array, (frames,) mono or (frames, channels)), rendered as they are
        asked for: a long render is written out without being held
        (``synth render``, :func:`synth.io.wav.write_wav_stream`)."""
        events = list(events)
        self.schedule(events)
        lat = self.latency_samples if compensate_latency else 0
        last = max((e.time_s for e in events), default=0.0)
        n_done = 0
        skip = lat                         # output samples still to drop (the latency)

        def emit(y):
            nonlocal skip
            if skip >= y.shape[-1]:
                skip -= y.shape[-1]
                return None
            y = y[..., skip:]
            skip = 0
            return y.copy() if self.channels == 1 else np.array(y.T, order="C")

        if duration_s is not None:
            total = int(round(duration_s * self.fs_out)) + lat
            while n_done < total:
                n = min(block, total - n_done)
                y = emit(self.render_block(n))
                n_done += n
                if progress is not None:
                    progress(n_done)
                if y is not None:
                    yield y
        else:
            drone = self.drone
            drone_end = (last if drone_end_s is None or drone is None
                         else max(last, float(drone_end_s)))
            hard = int((drone_end + max_tail_s) * self.fs_out) + lat
            quiet_after = None
            while n_done < hard:
                y = emit(self.render_block(block))
                n_done += block
                if progress is not None:
                    progress(n_done)
                if y is not None:
                    yield y
                t = n_done / self.fs_out
                if drone is not None and drone.running and t > drone_end:
                    drone.finish()
                if (t > last and not self._pending and not self.voices
                        and (self.taraf is None or self.taraf.n_active == 0)
                        and (drone is None or (not drone.running
                                               and drone.next_due() is None))):
                    if quiet_after is None:
                        # (and the room's reverberation dies away)
                        ring = 0.0 if self.listener is None else self.listener.tail_s
                        quiet_after = n_done + int((tail_s + ring) * self.fs_out) + lat
                    if n_done >= quiet_after:
                        break
