"""The strings on a sitar's bridge that no finger stops: taraf and chikari.

A sitar carries, besides its played string, a set of thin sympathetic
strings (*taraf*) under the frets, each on a small jawari bridge of its own,
tuned to the notes of the raga, and a few drone strings (*chikari*) over the
main bridge, struck in rhythm by the player's little finger.  Nothing damps
either: the taraf ring whenever the played string (or a drone) puts one of
their partials into the bridge, the shimmering halo of the instrument.

How it runs.  The voice designs the strings
(:meth:`synth.voices.base.Voice.taraf`: at the engine's output rate times
``grid``, on the kernel's finer-grid path, so that their jawari has points
to touch).  Per output block the engine hands this stage the played
strings' decimated bridge force (the dry buses, before the body), in three
steps:

1. the bridge follows that force (:func:`synth.kernels.bridge.bridge_follow`:
   u_b = integral of F / R with a slow spring), interpolated linearly to
   the strings' grid;
2. the drones render on it (plucked at the samples their strokes fall on);
3. the bridge follows the played strings' force plus the drones', and the
   taraf render on that.

Their bridge forces join the buses.  As for the grand's sympathetic strings
(:mod:`synth.engine.sympathetic`) the coupling is one-way: a taraf string's
impedance is a few hundredths of a N s/m against the bridge's tens, so its
reaction on the bridge (and through it on the played string) is left out;
the drones do not hear the taraf for the same reason.

When they render.  A note-on (of the played string or a stroke) starts every
resting string, joined to the bridge where it is; while nothing is played
the silent ones are freed by the bank's silence scan.  Events act at their
output sample (a live stream and an offline render give the same samples).
"""

from __future__ import annotations

import math

import numpy as np

from ..dsp.bank import StringBank
from ..kernels.bridge import bridge_follow


class _Strings:
    """One bank of strings on one external bridge (taraf or drones)."""

    def __init__(self, templates, max_cells: int, max_region: int, max_block: int):
        self.templates = tuple(templates)
        self.n = len(self.templates)
        self.bank = StringBank(max(self.n, 1), max_cells + 2, max(max_region, 1), max_block)
        for i in range(self.n):
            self._configure(i)

    def _configure(self, i: int) -> None:
        self.bank.configure_from(i, self.templates[i])
        self.bank.set_external_bridge(i)

    def wake(self, ub_now: float) -> None:
        """Start every resting string, its end where the bridge is now."""
        act = self.bank._is_active
        for i in range(self.n):
            if not act[i]:
                self.bank.join_bridge(i, ub_now)
                self.bank.activate(i)

    def rest(self, i: int) -> None:
        """Stop string i and set it up again, at rest, for its next start."""
        self.bank.deactivate(i)
        self._configure(i)

    def reap(self, n: int, level: float, min_quiet: int) -> None:
        if self.bank.n_active == 0:
            return
        for s in self.bank.reap(n, level, min_quiet).tolist():
            self.rest(int(s))


class Taraf:
    """The taraf and chikari of one engine.

    Parameters
    ----------
    design : synth.voices.base.TarafDesign
    fs_out : int
        The engine's output rate (Hz); the strings run at ``fs_out`` x
        ``design.grid``.
    max_block : int
        Longest block (output samples).
    silence_level : float
        Output level under which a string counts as quiet (the engine's).
    """

    def __init__(self, design, fs_out: int, max_block: int, silence_level: float):
        self.design = design
        self.fs = float(fs_out)
        M = self.M = int(design.grid)
        self.taraf = _Strings(design.slots, design.max_cells, design.max_region, max_block)
        self.drones = _Strings(design.drone_slots, design.max_cells, design.max_region, max_block)
        dt = 1.0 / self.fs
        self.a = math.exp(-2.0 * math.pi * design.return_hz * dt)
        self.b = dt / design.resistance_ns_per_m
        self.force_per_unit = float(design.force_per_unit)
        # the bridge under the drones (the played strings' force) and under
        # the taraf (the drones' too): state, displacement per output sample
        # and on the strings' grid, and its value one sample back
        self.state_d = np.zeros(1)
        self.state_t = np.zeros(1)
        self.force = np.zeros(max_block)
        self.ub = np.zeros(max_block)
        self.up_d = np.zeros(max_block * M)
        self.up_t = np.zeros(max_block * M)
        self._prev = np.zeros(2)
        self._diff = np.zeros(max_block)
        self._frac = (np.arange(1, M + 1, dtype=float) / M)[None, :]
        self.mix_d = np.zeros((1, max_block))
        self.mix_t = np.zeros((1, max_block))
        self.level = float(silence_level)
        self.t = 0                                  # output samples processed
        #: pending drone plucks: (output sample, drone, amplitude m)
        self._plucks: list = []
        self.n_strums = 0

    # -- events from the engine ------------------------------------------------
    def is_trigger(self, channel: int, key) -> bool:
        """Whether a note-on on ``channel`` (0-15) at ``key`` strums the drones."""
        if not self.drones.n:
            return False
        d = self.design
        if d.channel is not None and int(channel) == d.channel:
            return True
        return key is not None and d.trigger[0] <= key <= d.trigger[1]

    def strum(self, at: int, velocity: float) -> None:
        """A stroke across the drones at output sample ``at`` (from the
        render's start), normalised ``velocity`` (0 .. 1]: drone i is
        plucked ``i strum_s`` later, with the pluck's amplitude times
        velocity**exponent."""
        d = self.design
        amps = d.pluck.amplitudes_m
        g = max(float(velocity), 0.0) ** d.pluck.velocity_exponent
        step = int(round(d.strum_s * self.fs))
        for i in range(self.drones.n):
            self._plucks.append((int(at) + i * step, i, amps[i] * g))
        self._plucks.sort()
        self.n_strums += 1

    def wake(self) -> None:
        """A note starts: every resting string joins the bridge and renders."""
        self.drones.wake(float(self.state_d[0]))
        self.taraf.wake(float(self.state_t[0]))

    def silence(self) -> None:
        """All sound off: every string stops and rests; pending strokes go."""
        self._plucks.clear()
        for part in (self.drones, self.taraf):
            for i in range(part.n):
                if part.bank._is_active[i]:
                    part.rest(i)

    # -- per block --------------------------------------------------------------
    def _upsample(self, which: int, ub: np.ndarray, n: int, out: np.ndarray) -> None:
        """``out[:n M]``: ``ub[:n]`` on the strings' grid, linear between samples."""
        M = self.M
        if M == 1:
            out[:n] = ub[:n]
            self._prev[which] = ub[n - 1]
            return
        o = out[:n * M].reshape(n, M)
        prev = self._prev[which]
        d = self._diff[:n]
        d[0] = ub[0] - prev
        np.subtract(ub[1:n], ub[:n - 1], out=d[1:])
        np.multiply(d[:, None], self._frac, out=o)
        o[0] += prev
        o[1:] += ub[:n - 1, None]
        self._prev[which] = ub[n - 1]

    def process(self, dry: np.ndarray, o0: int, n: int) -> None:
        """Add the strings' answer to ``dry[0, o0:o0+n]`` (the played
        strings' decimated output, before the body), in place."""
        if n <= 0:
            return
        t0 = self.t
        self.t += n
        fpu = self.force_per_unit
        f = self.force[:n]
        np.sum(dry[:, o0:o0 + n], axis=0, out=f)
        f *= fpu
        ub = self.ub[:n]
        # 1. the bridge under the drones, 2. the drones (plucked on time)
        bridge_follow(f, n, self.a, self.b, self.state_d, ub)
        dm = self.mix_d[:, :n]
        dm[:] = 0.0
        if self.drones.n and (self.drones.bank.n_active or self._plucks):
            self._upsample(0, ub, n, self.up_d)
            bank = self.drones.bank
            pl = self.design.pluck
            pos = 0
            while self._plucks and self._plucks[0][0] < t0 + n:
                ts, i, amp = self._plucks.pop(0)
                k = min(max(ts - t0, pos), n)
                if k > pos and bank.n_active:
                    bank.render(self.mix_d, pos, k - pos, ubx=self.up_d)
                pos = k
                if not bank._is_active[i]:
                    bank.join_bridge(i, float(self.up_d[max(pos * self.M - 1, 0)]))
                    bank.activate(i)
                bank.start_pluck(i, pl.kind, amp, pl.durations_s[i], pl.alpha_per_s)
                bank.reset_quiet(i)
                self.taraf.wake(float(self.state_t[0]))
            if pos < n and bank.n_active:
                bank.render(self.mix_d, pos, n - pos, ubx=self.up_d)
            f += fpu * dm[0]
        else:
            self._prev[0] = ub[n - 1]
        # 3. the bridge under the taraf (the drones' force too), the taraf
        bridge_follow(f, n, self.a, self.b, self.state_t, ub)
        if self.taraf.n and self.taraf.bank.n_active:
            tm = self.mix_t[:, :n]
            tm[:] = 0.0
            self._upsample(1, ub, n, self.up_t)
            self.taraf.bank.render(self.mix_t, 0, n, ubx=self.up_t)
            dry[0, o0:o0 + n] += tm[0]
        else:
            self._prev[1] = ub[n - 1]
        dry[0, o0:o0 + n] += dm[0]

    def reap(self, n: int, idle: bool = True) -> None:
        """The banks' silence scans over the block's ``n`` samples while
        ``idle`` (nothing is played): free every silent string (a note-on
        starts them again, :meth:`wake`)."""
        if idle:
            q = int(0.05 * self.fs)
            self.drones.reap(n, self.level, q)
            self.taraf.reap(n, self.level, q)

    @property
    def n_active(self) -> int:
        """Strings rendering now (taraf and drones)."""
        return self.taraf.bank.n_active + self.drones.bank.n_active
