"""Sympathetic strings: the undamped strings that ring along through the bridge.

A piano's played strings move the bridge, and every string whose damper is
off (the sustain pedal down, the sostenuto holding it, a key held, the top
keys, which have none) is driven at its end by that motion and answers
where its own partials meet the played ones: the pedal's halo, and the
ring of a held chord's strings under a staccato note.

How it runs.  The voice describes the strings
(:meth:`synth.voices.base.Voice.free_strings`, a ``SympatheticDesign``: one
per key, at the output rate, hanging on an external bridge,
:meth:`StringBank.set_external_bridge`).
Per output block the engine hands this stage the played strings' decimated
bridge force (the dry buses, before the body); the board's bridge follows it
(:func:`synth.kernels.bridge.bridge_follow`: u_b = integral of F / R, with a
slow spring), the free strings render with that displacement at their ends,
and their own bridge force is added to the buses.  The one-way coupling is
the model's simplification: the sympathetic strings do not drive the
bridge back (their force is a thousandth of the played strings' and would
feed the played strings only at second order), and the bridge they see
answers the force summed over the keyboard at one point.

Which strings ring.  A key's string is free when its damper is off
(:meth:`Voice.damper_lift` of the sustain pedal, 1 for a key latched by the
sostenuto or without damper), and it is silent while the key sounds as a
played note (the played strings are those strings: a copy would double
them).  The engine sets these states at the output sample of the event that
changed them (a live stream and an offline render give the same samples);
a free string renders from then on, and strings fall silent and are freed
by the bank's silence scan once nothing is played.
"""

from __future__ import annotations

import math

import numpy as np

from ..dsp.bank import StringBank
from ..kernels.bridge import bridge_follow
from .free_strings import FreeStrings


#: a stop that never comes
_NEVER = np.iinfo(np.int64).max


class Sympathetic(FreeStrings):
    """The sympathetic strings of one engine, on a bank of their own: the
    one-way configuration of :class:`synth.engine.free_strings.FreeStrings`
    (string i in slot i).

    Parameters
    ----------
    design : synth.voices.base.SympatheticDesign
    fs_out : int
        The engine's output rate (Hz): the rate these strings run at.
    buses : int
        Rows of the engine's dry buses (1 or 2); the strings write theirs.
    max_block : int
        Longest block (output samples).
    silence_level : float
        Output level under which a string counts as quiet (the engine's).
    force_per_unit : float
        N of bridge force per unit of the played strings' output (1 / the
        output gain they write with: the engine's
        :class:`~synth.engine.output.OutputStage`).
    """

    #: a muted string's fade (s, 60 dB), and how long after the mute it stops (s)
    MUTE_T60_S = 0.02
    MUTE_HOLD_S = 0.1

    def __init__(self, design, fs_out: int, buses: int, max_block: int, silence_level: float,
                 force_per_unit: float):
        n = len(design.keys)
        super().__init__(design, StringBank(max(n, 1), design.max_cells + 2, 1, max_block), 0,
                         float(fs_out))
        self.keys = tuple(int(k) for k in design.keys)
        self.n = n
        self.buses = int(buses)
        self.slot_of = {k: i for i, k in enumerate(self.keys)}
        for i in range(self.n):
            self.configure(i)
        self._has_damper = np.array(design.has_damper, dtype=bool)
        dt = 1.0 / self.fs
        self.a = math.exp(-2.0 * math.pi * design.return_hz * dt)
        self.b = dt / design.resistance_ns_per_m
        self.force_per_unit = float(force_per_unit)
        self.state = np.zeros(1)
        self.force = np.zeros(max_block)
        self.ub = np.zeros(max_block)
        self.mix = np.zeros((max(self.buses, 1), max_block))
        self.level = float(silence_level)
        self.lift = np.full(self.n, -1.0)      # each string's damper lift now (-1: not set yet)
        self.muted = np.zeros(self.n, dtype=bool)
        self.t = 0                                  # output samples processed
        # the output sample at which a muted string stops rendering
        self._stop_at = np.full(self.n, _NEVER, dtype=np.int64)
        # no muted string stops before this output sample (a lower bound: the
        # block's scan for strings to stop runs only when it is reached)
        self._next_stop = _NEVER
        if self.bank.n_probes or self.mix.shape[1] < max_block or self.ub.shape[0] < max_block:
            raise ValueError("the sympathetic bank's arrays do not fit its blocks")
        self._idx = np.arange(self.n, dtype=np.int64)

    # -- state from the engine -------------------------------------------------
    def set_dampers(self, lift: np.ndarray, muted: np.ndarray) -> None:
        """Every string's damper lift (0 .. 1) and whether its key sounds as
        a played note (muted: its string fades out and stays silent); a
        free string (lifted, not muted) starts rendering now.  Only the
        strings whose state changed are touched (array operations: a chord's
        note-ons each call this in the audio thread)."""
        lift = np.where(self._has_damper, lift, 1.0)
        # (np.array_equal's checks and conversions cost more than these)
        if not (lift != self.lift).any() and not (muted != self.muted).any():
            # nothing changes (each key of a chord let go under the pedal:
            # 32 such calls cost 0.8 ms of a 2.67 ms period)
            return
        new_mute = muted & ~self.muted
        for i in np.flatnonzero(new_mute & self.bank._is_active[:self.n]):
            self.bank.fade(int(i), self.MUTE_T60_S, self.fs)
        self._stop_at[new_mute] = self.t + int(round(self.MUTE_HOLD_S * self.fs))
        back = ~muted & self.muted
        for i in np.flatnonzero(back):
            # the played note has gone: the string starts again from rest
            self.bank.deactivate(int(i))
            self.configure(int(i))
        changed = (~muted) & ((lift != self.lift) | back)
        self.muted = muted.copy()
        self.lift = lift
        self._update_next_stop()
        idx = np.flatnonzero(changed)
        if idx.size:
            self.bank.apply_dampers(idx, lift[idx])
            start = idx[(lift[idx] > 0.0) & ~self.bank._is_active[idx]]
            for i in start:
                # it joins the bridge where the bridge is now, and eases on
                self.bank.join_bridge(int(i), float(self.state[0]))
                self.bank.activate(int(i))

    def rest(self) -> None:
        """After :meth:`fade`, once they are silent: every string starts
        again from rest, and the next :meth:`set_dampers` lifts (and
        starts) those its dampers leave free."""
        for i in np.flatnonzero(self.bank._is_active[:self.n]):
            self.bank.deactivate(int(i))
            self.configure(int(i))
        self.state[:] = 0.0                        # the bridge at rest too
        self.lift = np.full(self.n, -1.0)
        self.muted[:] = False
        self._stop_at[:] = _NEVER
        self._update_next_stop()

    def _update_next_stop(self) -> None:
        st = self._stop_at[self.muted]
        self._next_stop = int(st.min()) if st.size else _NEVER

    def configure(self, i: int) -> None:
        """String ``i`` from its template, at rest, hanging on the external
        bridge, with its damper row."""
        super().configure(i)
        self.bank.set_external_bridge(i)
        self.bank.set_damper(i, self.design.dampers[i])

    # -- per block --------------------------------------------------------------
    def process(self, dry: np.ndarray, o0: int, n: int) -> None:
        """Add the strings' answer to ``dry[:, o0:o0+n]`` (the played
        strings' decimated output, buses x samples, before the body), in
        place; the bridge follows the played strings' force whether or not
        a string renders."""
        if self.n == 0 or n <= 0:
            return
        f = self.force[:n]
        if dry.shape[0] == 2:
            np.add(dry[0, o0:o0 + n], dry[1, o0:o0 + n], out=f)   # (= their sum over axis 0)
        else:
            np.sum(dry[:, o0:o0 + n], axis=0, out=f)
        f *= self.force_per_unit
        bridge_follow(f, n, self.a, self.b, self.state, self.ub)
        t0 = self.t
        self.t += n
        if self.bank.n_active == 0:
            return
        m = self.mix[:, :n]
        m[:] = 0.0
        # a muted string stops at its own output sample (whatever the
        # blocks: a live stream and an offline render agree)
        pos = 0
        while t0 + n > self._next_stop:
            act = self.bank._is_active[:self.n]
            due = np.flatnonzero(self.muted & act & (self._stop_at < t0 + n))
            if due.size == 0:
                # (muted strings that no longer render have nothing to stop)
                self._stop_at[self.muted & ~act] = _NEVER
                self._update_next_stop()
                break
            ts = int(self._stop_at[due].min())
            k = max(ts - t0, pos)
            if k > pos:
                self.bank.render_unchecked(self.mix, pos, k - pos, self.ub)
            pos = k
            for i in due[self._stop_at[due] == ts]:
                self.bank.deactivate(int(i))
                self.configure(int(i))
                self._stop_at[i] = _NEVER
            self._update_next_stop()
            if self.bank.n_active == 0:
                break
        if pos < n and self.bank.n_active:
            self.bank.render_unchecked(self.mix, pos, n - pos, self.ub)
        if dry.shape[0] == m.shape[0]:
            dry[:, o0:o0 + n] += m
        else:
            dry[0, o0:o0 + n] += m.sum(axis=0)

    def reap(self, n: int, idle: bool = True) -> None:
        """The bank's silence scan over the block's ``n`` samples, while
        ``idle`` (nothing is played): free every silent string.  (While
        notes sound a quiet free string stays: the bridge may drive it
        again.  A muted string, whose key sounds as a played note, stops
        ``MUTE_HOLD_S`` after its mute, at that output sample, in
        :meth:`process`: its fade (60 dB in ``MUTE_T60_S``) has taken it
        300 dB down, though the bridge still drives it.  Muted strings used
        to render as long as anything was played: for a pedalled 64-note
        chord, 69 strings where 19 were free, 4 % of real time.)"""
        if self.bank.n_active == 0:
            return
        if idle:
            done = self.bank.reap(n, self.level, int(0.05 * self.fs))
            for s in done.tolist():
                self.bank.deactivate(int(s))
                self.configure(int(s))
                # the next :meth:`set_dampers` starts it again if it is free
                # (it stayed silent for good while its lift did not change:
                # the top keys' undamped strings no longer answered a note
                # played after a pause, and a render depended on whether a
                # block had ended within that pause)
                self.lift[int(s)] = -1.0

    @property
    def n_active(self) -> int:
        """Sympathetic strings rendering now."""
        return self.bank.n_active
