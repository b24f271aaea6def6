"""Hammered string voice: a hereditary felt hammer striking one string.

Hammered string
===============
The hammer-string system of thesis eq. 1.4 at x = l: the hammer (mass m,
speed V at first contact) compresses the felt by w = z - u(l, t); the felt
force F (three-parameter law eq. 1.5, or the four-parameter law of
Publication III eq. 3 by recursive convolution) sends the outgoing wave g
(dg/dt = c F / 2T) into both directions, every internal sample, and the felt
reads the string's u(l, t) back.  The integrator (kernel ``_hammer_general``)
is implicit and second order: see :mod:`synth.kernels.strings`.

With a termination (the capo d'astro bar), ``hammer.capo_coupling`` chooses
between the physically complete "direct" strike on the terminated string and
Publication I's two-stage method, "injected": g(t) is computed on the
ideally supported string and injected into the string with the bar.

This voice serves the A7 study (``paper/piano-a7-*``); the playable 88-key
instrument is the grand piano voice.
"""

from __future__ import annotations

import numpy as np

from ..kernels import strings as K
from .bank import StringBank
from .plucked import PluckedInstrument

LAWS = {"three-parameter": 4, "four-parameter": 5}


class HammeredStringInstrument(PluckedInstrument):
    """One string struck by a felt hammer (voice ``piano``)."""

    VOICES = ("piano",)
    #: longest injected g(t) table (s)
    MAX_FLIGHT_S = 0.05
    #: probe channels of the last first-stage (ideal support) strike, if any
    last_strike_log = None

    @property
    def excitation_position(self) -> float:
        return self.preset.hammer.position

    def hammer_speed(self, velocity: float, speed_m_per_s: float | None = None) -> float:
        """Hammer speed V (m/s): explicit, else the preset's (study), else the
        preset's speed times velocity**velocity_exponent (musical)."""
        if speed_m_per_s is not None:
            return float(speed_m_per_s)
        V = self.preset.hammer.speed_m_per_s
        if self.study:
            return V
        return V * float(velocity) ** self.preset.play.velocity_exponent

    def hammer_kwargs(self, su, speed: float) -> dict:
        h = self.preset.hammer
        law = LAWS[h.law]
        return dict(law=law, mass_kg=h.mass_kg, speed_m_per_s=speed,
                    stiffness=h.stiffness_n_per_mm_p, exponent=h.exponent,
                    alpha_or_gamma=h.alpha_s if law == 4 else h.gamma,
                    tau0_s=h.tau0_s if law == 5 else 0.0,
                    tension_n=su.string.tension_n, c_m_per_s=su.string.c_m_per_s,
                    max_flight_s=self.MAX_FLIGHT_S)

    def gtable_length(self) -> int:
        return int(self.MAX_FLIGHT_S * self.fs) + 2

    def ideal_support_g(self, su, speed: float) -> np.ndarray:
        """g(t) (m, per internal sample) of this hammer on the same string with
        ideal supports, up to its final value (Publication I, first stage)."""
        b = StringBank(1, su.cells + 2, 1, 4096, n_probes=1)
        b.configure(0, cells=su.cells, k=su.k, dt_s=su.dt_s, U=None, probe_row=0)
        b.activate(0)
        b.start_hammer(0, **self.hammer_kwargs(su, speed))
        n = self.gtable_length() - 1
        mix = np.zeros(n)
        b.render(mix, 0, n)
        # g is constant after the last contact (the probe's g drops to 0 only
        # when the kernel cancels that constant offset: not part of g(t))
        hit = np.flatnonzero(b.probe[0, K.P_F, :n] > 0)
        last = int(hit[-1]) + 2 if len(hit) else 1
        self.last_strike_log = b.probe[0, :, :last].copy()
        return b.probe[0, K.P_G, :last].copy()

    def note_on(self, bank: StringBank, slots, key, velocity: float, f0_hz=None,
                probe_row: int = -1, restrike: bool = False, speed_m_per_s: float | None = None,
                soft: float = 0.0) -> None:
        slot = slots[0]
        su = self.setup(key, f0_hz)
        if restrike:
            bank.set_loss(slot, su.b0)
        else:
            self._configure(bank, slot, su, probe_row)
        V = self.hammer_speed(velocity, speed_m_per_s)
        if su.U is not None and self.preset.hammer.capo_coupling == "injected":
            bank.start_gtable(slot, self.ideal_support_g(su, V))
        else:
            bank.start_hammer(slot, **self.hammer_kwargs(su, V))
        bank.activate(slot)
