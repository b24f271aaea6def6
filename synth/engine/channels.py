"""The engine's MIDI channels: pedals, controllers, bend and the mixer.

:class:`ChannelControls` is the part of :class:`synth.engine.engine.Engine`
that plays every control change on its own channel (docs/midi.md is the
chart): the sustain pedal, sostenuto and soft pedal, all notes off, all
sound off (a 5 ms fade, the whole output's when no other channel sounds),
reset all controllers, the bend range (RPN 0), the voice's own controls
(a plucked voice's buzz and pluck point), and volume, expression and pan
through each channel's own rows of the mix (:mod:`synth.engine.mixing`);
MPE zones and per-note pressure come from
:class:`synth.engine.mpe.MpeZones`.  It is a mixin: its methods read and
write the engine's state and are not used alone; the split keeps the
block loop and the voice pool in ``engine.py``.
"""

from __future__ import annotations

import math

import numpy as np

from .mixing import RAMP_S, ChannelGroup, OutputPath
from .mpe import RPN_MPE, MpeZones

CC_SUSTAIN = 64
CC_SOSTENUTO = 66
CC_SOFT = 67
CC_ALL_SOUND_OFF = 120
CC_RESET_ALL = 121
CC_ALL_NOTES_OFF = 123
CC_DATA_MSB = 6
CC_DATA_LSB = 38
CC_RPN_LSB = 100
CC_RPN_MSB = 101
CC_NRPN_LSB = 98
CC_NRPN_MSB = 99
#: the channel-mode messages that also end every note (MIDI 1.0: omni
#: off/on, mono, poly)
CC_MODE = (124, 125, 126, 127)
#: controllers that an MPE zone's manager channel sends to the whole zone
#: (besides the voice's own controls); pan stays the manager's own (a
#: panned channel has its own decimators and body)
ZONE_WIDE = frozenset((64, 66, 67, 120, 121, 123, 7, 11))
CC_VOLUME = 7
CC_PAN = 10
CC_EXPRESSION = 11
#: MIDI channels
CHANNELS = 16
#: the names of the controllers (MIDI 1.0, General MIDI 2), for reports
CC_NAMES = {
    0: "bank select", 1: "modulation", 2: "breath", 4: "foot controller",
    5: "portamento time", 6: "data entry", 7: "volume", 8: "balance", 10: "pan",
    11: "expression", 12: "effect control 1", 13: "effect control 2",
    32: "bank select LSB", 38: "data entry LSB", 64: "sustain pedal",
    65: "portamento", 66: "sostenuto", 67: "soft pedal", 68: "legato footswitch",
    69: "hold 2", 71: "resonance", 72: "release time", 73: "attack time",
    74: "brightness", 75: "decay time", 76: "vibrato rate", 77: "vibrato depth",
    78: "vibrato delay", 84: "portamento control", 91: "reverb send",
    92: "tremolo depth", 93: "chorus send", 94: "detune depth", 95: "phaser depth",
    96: "data increment", 97: "data decrement", 98: "NRPN LSB", 99: "NRPN MSB",
    100: "RPN LSB", 101: "RPN MSB", 120: "all sound off", 121: "reset all controllers",
    122: "local control", 123: "all notes off", 124: "omni off", 125: "omni on",
    126: "mono on", 127: "poly on",
}
#: General MIDI's default channel volume (CC7): the level at which a
#: channel plays the preset's own level
VOLUME_DEFAULT = 100 / 127
#: CC10's centre, 64 / 127
PAN_CENTRE = 64 / 127
#: how long all sound off (CC120) takes to fade the strings out (s): 60 dB
#: in this time, no click
HUSH_T60_S = 0.005


class ChannelControls(MpeZones):
    """The engine's per-channel controls (a mixin of :class:`Engine`; its
    MPE zones and per-note pressure: :class:`synth.engine.mpe.MpeZones`)."""

    def _ignore(self, what: str) -> None:
        """Count a message the engine received and does not play."""
        self.ignored[what] = self.ignored.get(what, 0) + 1

    def _channel_voices(self, channel: int):
        """The sounding (not fading) voices of ``channel``: (index, voice)."""
        return [(v, vo) for v, vo in self.voices.items() if vo.channel == channel and not vo.dying]

    def _bend_value(self, channel: int) -> float:
        """The channel's bend as a share of the preset's range (RPN 0 may
        narrow it); in an MPE zone, its own and its manager's bends in
        semitones, held within the preset's range (:meth:`_zone_bend`)."""
        if self.mpe_manager[channel] >= 0:
            return self._zone_bend(channel)[0]
        return float(self.bend.get(channel, 0.0)) * float(self.bend_range[channel])

    def _voice_controls_for(self, channel: int) -> None:
        """Before a note-on: the instrument's controls for the notes to come
        (a plucked voice's buzz depth) set to this channel's values."""
        for cc, val in self._ctl[channel].items():
            if self._inst_ctl.get(cc) != val:
                self.inst.control_change(self.bank, cc, val, ())
                self._inst_ctl[cc] = val

    def _sustain(self, c: int, value: float) -> None:
        """CC64 on channel c: its released voices' dampers at once (a
        continuous pedal sends many of these; a loop over voices cost ~5 us
        each); the sostenuto keeps its voices' dampers off."""
        self.pedal[c] = value
        idx = np.flatnonzero(self._released & ~self._latched & (self._chan == c))
        if idx.size:
            slots = (idx[:, None] * self.spv + self._spv_range).ravel()
            self.bank.apply_dampers(slots, self.inst.damper_lift(value))

    def _sostenuto(self, c: int, down: bool) -> None:
        if down and not self.sostenuto[c]:
            # the notes held now keep their dampers off until it comes up
            for v, vo in self._channel_voices(c):
                self._latched[v] = not vo.released
                if self._latched[v] and vo.key_arg is not None:
                    self._latched_keys.add((c, int(round(vo.key_arg))))
        elif not down and self.sostenuto[c]:
            held = np.flatnonzero(self._latched & (self._chan == c))
            self._latched[held] = False
            self._latched_keys = {k for k in self._latched_keys if k[0] != c}
            for v in held:
                vo = self.voices.get(int(v))
                if vo is not None and vo.released and not vo.dying:
                    self._damp(vo)     # as far as the sustain pedal lets it
        self.sostenuto[c] = down

    def _all_notes_off(self, c: int) -> None:
        """CC123 (and the mode messages 124-127): channel c's keys up (the
        sustain pedal still holds them, as MIDI 1.0 asks)."""
        for v, _ in self._channel_voices(c):
            self._release(v)

    def _all_sound_off(self, c: int, at: int) -> None:
        """CC120 on channel c: its notes fade out, 60 dB in
        :data:`HUSH_T60_S` (a cut clicks), and are freed once silent.  When
        no other channel's note sounds (a panic sends it on every channel:
        the last one), the whole instrument goes quiet: every string, the
        bridge's own, the sympathetic strings, and the output itself fades
        out in :data:`HUSH_T60_S`, after which the body's ring and the
        limiter are cleared (:meth:`_hush_block`)."""
        if any(vo.channel != c and not vo.dying for vo in self.voices.values()):
            for v, _ in self._channel_voices(c):
                self._fade(v, HUSH_T60_S)
            return
        for v in list(self.voices):
            if not self.voices[v].dying:
                self._fade(v, HUSH_T60_S)
        self._hushed = {v: vo for v, vo in self.voices.items()}
        if self.taraf is not None:
            self.taraf.fade(HUSH_T60_S)
        if self.sym is not None:
            self._sym_hush = True     # at the event's output sample (:meth:`_sympathetic_block`)
        # the output fades with them; once it has, what is left of them (a
        # damper still landing, the body's ring, the limiter's delay line)
        # is cleared (:meth:`_hush_block`); the knocks still to come go
        # (the fade covers their cut)
        j = min(max(self._out_sample(at), 0), self.MAX_BLOCK_OUT - 1)
        self._hush_out = (j, 0)
        self._knock.cut(self.time_out + j + self._knock_lag)

    def _reset_controllers(self, c: int, at: int) -> None:
        """CC121, as General MIDI 2 and RP-015 ask: channel c's pedals up,
        expression full, bend centred, no parameter selected; the voice's
        own controls (a plucked voice's buzz depth, CC1) back to the
        preset's values.  Volume, pan and the bend range stay."""
        self._sustain(c, 0.0)
        self._sostenuto(c, False)
        self.soft[c] = 0.0
        if self.bend.get(c):
            self.bend[c] = 0.0
            self._rebend(c)
        self._rpn[c] = (127, 127)
        self._nrpn[c] = False
        self._set_expression(c, 1.0, at)
        for cc, val in self._ctl_default.items():
            if self._ctl[c].get(cc) != val:
                self._voice_control(c, cc, val)

    def _voice_control(self, c: int, cc: int, value: float) -> None:
        self._ctl[c][cc] = value
        self._inst_ctl[cc] = value
        # the channel's sounding notes as a generator: built only by a voice that uses the CC
        self.inst.control_change(self.bank, cc, value,
                                 ((vo.slots, vo.key_arg, vo.f0_hz)
                                  for _, vo in self._channel_voices(c)))

    def _data_entry(self, c: int, cc: int, value: float) -> None:
        """CC6 / CC38 for the parameter CC101/100 (RPN) or CC99/98 (NRPN)
        selected: RPN 0, the pitch-bend range, is played (up to the preset's
        ``play.pitch_bend_semitones``; in an MPE zone, any range, the bends
        held instead), and RPN 6, the MPE Configuration Message
        (:mod:`synth.engine.mpe`); the others are counted as ignored."""
        raw = int(round(value * 127))
        if self._nrpn[c]:
            self._ignore("NRPN data entry")
            return
        rpn = self._rpn[c]
        if rpn == (127, 127):
            self._ignore("data entry with no parameter selected")
            return
        if rpn == RPN_MPE:
            self._mpe_data_entry(c, cc == CC_DATA_MSB, raw)
            return
        if rpn != (0, 0):
            names = {(0, 1): "fine tuning", (0, 2): "coarse tuning", (0, 5): "modulation depth range"}
            msb, lsb = rpn
            self._ignore(f"RPN {msb * 128 + lsb}" + (f" ({names[rpn]})" if rpn in names else ""))
            return
        top = float(self.play.bend_range_semitones)
        if top <= 0.0:
            self._ignore("RPN 0 (pitch-bend range): the preset does not bend")
            return
        if self.mpe_manager[c] >= 0:
            self._mpe_bend_range(c, cc == CC_DATA_MSB, raw)
            return
        old = self.bend_range[c] * top
        semis, cents = math.floor(old + 1e-9), (old - math.floor(old + 1e-9)) * 100.0
        if cc == CC_DATA_MSB:
            semis, cents = raw, 0.0          # an MSB resets the cents (RP-018)
        else:
            cents = float(raw)
        want = semis + cents / 100.0
        if want > top:
            self._ignore(f"RPN 0 (pitch-bend range) above the preset's {top:g} semitones: held at {top:g}")
            want = top
        self.bend_range[c] = want / top
        if self.bend.get(c) and self.play.bends:
            b = self._bend_value(c)
            for _, vo in self._channel_voices(c):
                self.inst.pitch_bend(self.bank, vo.slots, vo.key_arg, vo.f0_hz, b)

    # -- mixing controls: volume, expression, pan ------------------------------
    def channel_gain(self, c: int) -> float:
        """Channel c's gain from volume (CC7) and expression (CC11), on
        General MIDI 2's curve: (volume / 100)^2 (expression / 127)^2 in
        MIDI values, so the default volume 100 plays the preset's level
        (volume 127: +4.2 dB; 0: silence)."""
        return (self.volume[c] / VOLUME_DEFAULT) ** 2 * self.expression[c] ** 2

    def channel_pan_gains(self, c: int) -> tuple[float, float]:
        """Channel c's (left, right) gains from CC10 on a stereo output:
        General MIDI 2's sine/cosine law, scaled so that the centre (64)
        plays both sides at unity (0: hard left, +3 dB; 127: hard right)."""
        p = self.pan[c]
        if p == PAN_CENTRE:
            return 1.0, 1.0
        th = 0.5 * math.pi * min(max((p * 127.0 - 1.0) / 126.0, 0.0), 1.0)
        return math.sqrt(2.0) * math.cos(th), math.sqrt(2.0) * math.sin(th)

    def _set_volume(self, c: int, value: float, at: int) -> None:
        self.volume[c] = value
        self._mixing_changed(c, at)

    def _set_expression(self, c: int, value: float, at: int) -> None:
        if self.expression[c] != value:
            self.expression[c] = value
            self._mixing_changed(c, at)

    def _set_pan(self, c: int, value: float, at: int) -> None:
        if self.channels != 2:
            self._ignore("CC 10 (pan): the preset's output is mono")
            return
        self.pan[c] = value
        self._mixing_changed(c, at)

    def _control(self, cc: int, value: float, c: int, at: int) -> None:
        """A control change on channel c (every message acts on its own
        channel; docs/midi.md lists them).  On an MPE zone's manager
        channel, the pedals, volume, expression, the voice's controls (the
        buzz, the pluck point) and the notes-off and reset messages act on
        the whole zone (:data:`ZONE_WIDE`): its member channels take them
        as if each had received them."""
        if (cc in ZONE_WIDE or cc in self._ctl_default) and self.mpe_manager[c] == c:
            for ch in self._zone_members(c):
                self._control(cc, value, ch, at)
        if self.drone is not None:
            if cc in (CC_ALL_NOTES_OFF, CC_ALL_SOUND_OFF):
                self.drone.stop()           # a sequencer's stop, a panic (then as below)
            elif cc == CC_RESET_ALL:
                self.drone.reset_controls()
            elif self.drone.control(cc, value):
                return                      # the drone's tempo or pattern
        if cc == CC_SUSTAIN:
            self._sustain(c, value)
        elif cc == CC_SOFT:
            self.soft[c] = value
        elif cc == CC_SOSTENUTO:
            self._sostenuto(c, value >= 0.5)
        elif cc == CC_ALL_NOTES_OFF:
            self._all_notes_off(c)
        elif cc == CC_ALL_SOUND_OFF:
            self._all_sound_off(c, at)
        elif cc == CC_RESET_ALL:
            self._reset_controllers(c, at)
        elif cc in CC_MODE:
            self._all_notes_off(c)
            self._ignore(f"CC {cc} ({CC_NAMES[cc]}): the mode is not changed, its notes end")
        elif cc == CC_VOLUME:
            self._set_volume(c, value, at)
        elif cc == CC_EXPRESSION:
            self._set_expression(c, value, at)
        elif cc == CC_PAN:
            self._set_pan(c, value, at)
        elif cc in (CC_RPN_MSB, CC_RPN_LSB):
            msb, lsb = self._rpn[c]
            raw = int(round(value * 127))
            self._rpn[c] = (raw, lsb) if cc == CC_RPN_MSB else (msb, raw)
            self._nrpn[c] = False
        elif cc in (CC_NRPN_MSB, CC_NRPN_LSB):
            self._nrpn[c] = True               # (its data entries are listed too)
            self._ignore(f"CC {cc} ({CC_NAMES[cc]})")
        elif cc in (CC_DATA_MSB, CC_DATA_LSB):
            self._data_entry(c, cc, value)
        elif cc in self._ctl_default:
            self._voice_control(c, cc, value)
        elif not self.inst.control_change(self.bank, cc, value, ()):
            self._ignore(f"CC {cc}" + (f" ({CC_NAMES[cc]})" if cc in CC_NAMES else ""))

    # -- the mixer: channel volume, expression, pan (synth.engine.mixing) -------
    def _row_of(self, c: int) -> int:
        g = self.groups.get(c)
        return 0 if g is None else g.row

    def _set_rows(self, slots, row: int) -> None:
        bank = self.bank
        for s in slots:
            if bank.output_row(s) != row:
                bank.set_output_row(s, row)

    def _mixing_changed(self, c: int, at: int) -> None:
        """Channel c's volume, expression or pan changed at internal sample
        ``at``: its gain (and pan) ramp to the new values over
        :data:`~synth.engine.mixing.RAMP_S`; a channel leaving its defaults
        the first time gets rows of its own (and, once panned, an output
        path of its own)."""
        gain = self.channel_gain(c)
        pan = self.channel_pan_gains(c)
        grp = self.groups.get(c)
        if grp is None:
            if gain == 1.0 and pan == (1.0, 1.0):
                return
            grp = self._new_group(c)
        # a channel that sounds ramps (no zipper, no click); a silent one
        # takes the new values at once (its next note must not ramp)
        sounding = any(vo.channel == c for vo in self.voices.values()) or (
            self.taraf is not None and self._bridge_channel == c and self.taraf.awake)
        grp.gain.set(at, gain, int(round(RAMP_S * self.fs_in)) if sounding else 0)
        if pan != (1.0, 1.0) and grp.path is None:
            grp.path = OutputPath(self)
        if grp.path is not None:
            j = self.time_out + min(max(self._out_sample(at), 0), self.MAX_BLOCK_OUT)
            n = int(round(RAMP_S * self.fs_out)) if sounding else 0
            grp.path.left.set(j, pan[0], n)
            grp.path.right.set(j, pan[1], n)

    def _new_group(self, c: int) -> ChannelGroup:
        """Rows of the mix for channel c alone; its sounding strings (and the
        bridge's own, when they follow it) move there."""
        row = self.buses * (1 + len(self.groups))
        need = self.buses * (1 + CHANNELS)
        if self.mix.shape[0] < need:
            m = np.zeros((need, self.mix.shape[1]))
            m[:self.mix.shape[0]] = self.mix
            self.mix = m
        grp = ChannelGroup(c, row)
        self.groups[c] = grp
        for vo in self.voices.values():
            if vo.channel == c:
                self._set_rows(vo.slots, row)
        if self.taraf is not None and self._bridge_channel == c:
            self._set_rows(self.taraf.slots, row)
        return grp

    def _mix_groups(self, mix: np.ndarray, start: int, n_in: int) -> list:
        """Each channel's rows times its gain; added to the instrument's
        rows, or left for its own output path.  Returns the groups with a
        path."""
        paths = []
        b = self.buses
        end = start + n_in
        for grp in self.groups.values():        # (made in row order)
            rows = mix[grp.row:grp.row + b]
            g = grp.gain.constant_over(start, end)
            if g is None:
                rows *= grp.gain.envelope(start, n_in)
            elif g != 1.0:
                rows *= g
            grp.gain.forget_before(end)
            if grp.path is None:
                mix[:b] += rows
            else:
                if self.n_dec < b:
                    rows[0] += rows[1]
                paths.append(grp)
        return paths

    def _path_decimate(self, grp: ChannelGroup, mix: np.ndarray, n_out: int) -> None:
        p = grp.path
        d = p.d[:, :n_out]
        for c in range(self.n_dec):
            p.decs[c].process(mix[grp.row + c], d[c])
        if p.knocking:
            p.knocking = p.knock.mix_into(d, self.time_out, n_out)

    def _path_out(self, grp: ChannelGroup, y: np.ndarray, n_out: int) -> None:
        """A panned channel through its body, its pan's gains, into ``y``."""
        p = grp.path
        d = p.d[:, :n_out]
        yp = p.y[:, :n_out]
        if p.body is not None:
            p.body.process(d, out=yp)
        else:
            yp[:] = d
        t0 = self.time_out
        for side, ramp in ((0, p.left), (1, p.right)):
            g = ramp.constant_over(t0, t0 + n_out)
            if g is None:
                y[side] += ramp.envelope(t0, n_out) * yp[side]
            else:
                y[side] += g * yp[side]
            ramp.forget_before(t0 + n_out)

    def _hush_block(self, y: np.ndarray, n_out: int) -> None:
        """All sound off's output fade over this block: a raised cosine from
        the event's output sample, :data:`HUSH_T60_S` long, then silence to
        the block's end; once it is over, the body's ring and the limiter's
        delay line are cleared (nothing of the earlier sound comes out
        again).  A note begun within the fade is heard from the next block."""
        j, done = self._hush_out
        n_f = self._hush_len
        if j >= n_out:                        # (the fade starts in a later block)
            self._hush_out = (j - n_out, done)
            return
        k = min(n_f - done, n_out - j)
        ramp = 0.5 * (1.0 + np.cos(np.pi * (np.arange(done + 1, done + k + 1) / n_f)))
        y[..., j:j + k] *= ramp
        done += k
        if done < n_f:
            self._hush_out = (0, done)
            return
        y[..., j + k:n_out] = 0.0
        for v, vo in self._hushed.items():
            if self.voices.get(v) is vo:
                self._free(v)
        self._hushed = {}
        if self.taraf is not None:
            self.taraf.rest()
        if self.sym is not None:
            self.sym.rest()
            self._sym_dirty = True
        if self.body is not None:
            self.body.reset()
        if self.listener is not None:
            self.listener.reset()
        self.output.reset()
        for d in self.decs:
            d.clear()
        for grp in self.groups.values():
            if grp.path is not None:
                grp.path.reset()
        self._knock.clear()
        self._knocking = False
        self._hush_out = None
