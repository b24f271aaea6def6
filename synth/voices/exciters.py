"""Exciters: what sets a string moving, independent of the string and its end.

Each exciter is configured by one preset section and registered under that
section's name (:func:`synth.voices.registry.register_exciter`), so a string
voice takes whichever exciter its preset describes, on any string and any
termination (the composition of Faust's physmodels).  An exciter:

* has a ``position``: the excitation point as a fraction of the string's
  length from x = 0;
* says how long an injected g(t) table it may write (``max_gtable``);
* starts itself on a bank slot at note-on (``start``) through the bank's
  methods (:meth:`synth.dsp.bank.StringBank.start_pluck`, ``start_hammer``,
  ``start_gtable``); the kernel's excitation kinds are the named constants
  ``EXC_*`` of :mod:`synth.kernels.layout`.

Both excite through the outgoing wave g(t) at x = l (thesis eq. 1.4:
dg/dt = c F / 2T).
"""

from __future__ import annotations

import numpy as np

from ..dsp.bank import StringBank
from ..kernels import felt_layer as FL
from ..kernels import strings as K
from ..physics import felt as felt_medium
from .registry import register_exciter

#: the preset's ``hammer.law`` names -> the kernel's hammer kinds
HAMMER_LAWS = {"three-parameter": K.EXC_HAMMER3, "four-parameter": K.EXC_HAMMER4}
#: the preset's ``pluck.model`` names -> the kernel's pluck kinds
PLUCK_MODELS = {"sitar": K.EXC_SITAR, "biwa": K.EXC_BIWA}


class Exciter:
    """Base of the exciters (see the module docstring).

    Parameters
    ----------
    spec : the preset section that configures the exciter
    preset : the whole preset (kind and play section)
    fs : float, the voice's internal rate (Hz)
    """

    section: str = ""

    def __init__(self, spec, preset, fs: float):
        self.spec = spec
        self.study = preset.kind == "study"
        self.play = preset.play
        self.fs = float(fs)

    @property
    def position(self) -> float:
        """Excitation point as a fraction of the string length (0 < value < 1)."""
        return self.spec.position

    def max_gtable(self) -> int:
        """Longest g(t) table this exciter injects (samples); 0: none."""
        return 0

    def start(self, bank: StringBank, slot: int, su, velocity: float, *,
              amplitude_scale: float = 1.0, speed_m_per_s: float | None = None,
              length_scale: float = 1.0) -> None:
        """Excite slot ``slot`` from its next sample.

        su : the note's string as configured in the slot: any object with
            ``string`` (:class:`synth.physics.string.IdealString`), ``cells``,
            ``k``, ``dt_s`` and ``U`` (profile or None), such as
            :class:`synth.voices.one_string.OneStringSetup`.
        velocity : normalised, 0 < value <= 1.
        amplitude_scale : factor on the excitation's size for this note
            (a fretted string: its speaking length over the open string's,
            so that it is plucked at the same slope; a keyboard voice: its
            per-key level law), for exciters that scale (the pluck).
        speed_m_per_s : explicit hammer speed (m/s), for hammers.
        length_scale : the note's speaking length over the open string's
            (a fretted string), for exciters whose timing follows it.
        """
        raise NotImplementedError

    strike_log = None


@register_exciter("pluck")
class PluckExciter(Exciter):
    """The thesis's plucks (``[pluck]``): the sitar's kinematic g(t)
    (eq. 1.13) or the biwa's force pluck (eqs. 1.10-1.11).

    Study presets pluck with exactly ``pluck.amplitude_m``; musical presets
    with ``amplitude_m * velocity**velocity_exponent``, scaled with the
    speaking length so that a fretted string is plucked at the same slope
    (the same depth of buzz) as the open one.
    """

    def amplitude_m(self, velocity: float, amplitude_scale: float = 1.0) -> float:
        """Pluck amplitude A (m) for a normalised velocity in (0, 1], times
        the note's ``amplitude_scale`` (musical presets only)."""
        A = self.spec.amplitude_m
        if self.study:
            return A
        return A * amplitude_scale * float(velocity) ** self.play.velocity_exponent

    def duration_s(self, length_scale: float = 1.0) -> float:
        """Pluck duration t0 (s).  The sitar's kinematic g(t) (eq. 1.13) of a
        musical preset lasts ``duration_s`` times the note's speaking length
        over the open string's (``length_scale``, < 1 on a fret):
        the same pluck shape per period on every fret.  Measured
        (``tools/study_jawari.py``, key 74, velocity 40): with the open
        string's 4 ms on the 1.7 ms period the string followed g nearly
        quasi-statically and swung at the bridge 6.7x less (slope 8.6e-4
        against 5.8e-3) than the open string does.  The biwa's force pluck
        is a force in time: it keeps its duration."""
        t0 = self.spec.duration_s
        if self.study or self.spec.model != "sitar":
            return t0
        return t0 * min(1.0, float(length_scale))

    def start(self, bank, slot, su, velocity, *, amplitude_scale=1.0, speed_m_per_s=None,
              length_scale=1.0):
        sp = self.spec
        alpha = sp.alpha_per_s if sp.model == "biwa" else 0.0
        bank.start_pluck(slot, PLUCK_MODELS[sp.model], self.amplitude_m(velocity, amplitude_scale),
                         self.duration_s(length_scale), alpha)


@register_exciter("hammer")
class HammerExciter(Exciter):
    """A felt hammer (``[hammer]``): the hammer-string system of eq. 1.4 at
    x = l with the three-parameter felt (eq. 1.5) or the four-parameter one
    (Publication III eq. 3), integrated by the kernel (implicit, second
    order: ``_hammer_general`` in :mod:`synth.kernels.excite`).

    On a string with a termination, ``hammer.capo_coupling`` chooses the
    physically complete "direct" strike on the terminated string, or
    Publication I's two-stage method, "injected": g(t) is computed on the
    ideally supported string and injected into the string with the bar.

    ``hammer.model = "felt-layer"`` (study presets) replaces the massless
    felt by the felt as a medium: a column of ``felt_thickness_m`` x
    ``felt_area_m2`` of hereditary felt (thesis eqs. 2.1-2.6) on the core,
    whose quasi-static limit is the preset's law
    (:func:`synth.physics.felt.felt_from_law`), pressing the moving string
    (:mod:`synth.kernels.felt_layer`).  It is a kind of the string kernel's
    excitation (``EXC_FELT``), not a study-only path: the string, its
    termination, both capo couplings, the probes (``--hammer-log``) and
    the engine are the lumped hammer's, and any string the kernel runs can
    take it; what keeps it to the study presets is its cost (the felt's
    stable step is 2-200 ns against the string's 0.77 us: docs/felt.md),
    which the kernel pays on its per-sample path while the hammer flies.
    """

    #: longest injected g(t) table (s)
    MAX_FLIGHT_S = 0.05

    def __init__(self, spec, preset, fs):
        super().__init__(spec, preset, fs)
        #: probe channels of the last first-stage (ideal support) strike, if any
        self.strike_log = None
        #: the felt layer (:class:`synth.physics.felt.HammerFelt`) of the
        #: felt-layer model, else None
        self.layer = self._layer() if getattr(spec, "model", None) == "felt-layer" else None

    def _layer(self):
        """The preset's felt layer, its cross-key ranges checked (one-line
        errors naming the preset keys)."""
        h = self.spec
        if h.law == "three-parameter" and not h.felt_tau0_s < h.alpha_s:
            raise ValueError(f"hammer.felt_tau0_s = {h.felt_tau0_s!r} is out of range (< "
                             f"hammer.alpha_s = {h.alpha_s!r}: the felt's gamma = 1 - tau0 / "
                             f"alpha must be > 0)")
        m_felt = h.felt_density_kg_per_m3 * h.felt_area_m2 * h.felt_thickness_m
        if not m_felt < 0.9 * h.mass_kg:
            raise ValueError(f"hammer.felt_thickness_m = {h.felt_thickness_m!r} is out of range "
                             f"(the felt's mass rho A h = {m_felt:.3g} kg must be < 0.9 x "
                             f"hammer.mass_kg = {0.9 * h.mass_kg:.3g} kg: thinner, or a smaller "
                             f"hammer.felt_area_m2 or hammer.felt_density_kg_per_m3)")
        try:
            hf = felt_medium.felt_from_law(
                law=h.law, stiffness_n_per_mm_p=h.stiffness_n_per_mm_p, exponent=h.exponent,
                hammer_mass_kg=h.mass_kg, thickness_m=h.felt_thickness_m,
                alpha_s=h.alpha_s, gamma=h.gamma,
                tau0_s=h.felt_tau0_s if h.law == "three-parameter" else h.tau0_s,
                area_m2=h.felt_area_m2, density_kg_per_m3=h.felt_density_kg_per_m3)
        except ValueError as e:
            raise ValueError(f"hammer.model = \"felt-layer\": the felt of this law and column "
                             f"is out of range: {e}") from None
        self._check_compression(hf, h.speed_m_per_s)
        return hf

    def _check_compression(self, hf, speed: float) -> None:
        """The felt must be at least twice as thick as the lumped law's
        deepest compression on a rigid string at ``speed`` (as
        :func:`synth.physics.felt.strike_layer` asks)."""
        _, w = felt_medium._contact_estimate_s(hf, float(speed))
        if w > 0.5 * hf.thickness_m:
            raise ValueError(f"hammer.felt_thickness_m = {hf.thickness_m!r} is out of range for "
                             f"a strike at {speed:g} m/s (>= {2 * w:.3g}: the law compresses the "
                             f"felt by up to {w * 1e3:.3g} mm)")

    def max_gtable(self) -> int:
        n = int(self.MAX_FLIGHT_S * self.fs) + 2
        if self.layer is not None:
            n = max(n, FL.block_length(self.spec.felt_cells))
        return n

    def layer_kwargs(self, su, speed: float) -> dict:
        """:meth:`StringBank.start_felt_layer` arguments for the note ``su``."""
        hf, h = self.layer, self.spec
        f = hf.felt
        return dict(mass_kg=h.mass_kg, speed_m_per_s=speed, thickness_m=hf.thickness_m,
                    area_m2=hf.area_m2, density_kg_per_m3=f.density_kg_per_m3,
                    e_dynamic_pa=f.e_dynamic_pa, exponent=f.exponent, gamma=f.gamma,
                    tau0_s=f.tau0_s, cells=int(h.felt_cells), tension_n=su.string.tension_n,
                    c_m_per_s=su.string.c_m_per_s, max_flight_s=self.MAX_FLIGHT_S)

    def _strike(self, bank, slot, su, speed: float) -> None:
        """Start this hammer (lumped or felt layer) on ``slot``."""
        if self.layer is not None:
            self._check_compression(self.layer, speed)
            bank.start_felt_layer(slot, **self.layer_kwargs(su, speed))
        else:
            bank.start_hammer(slot, **self.hammer_kwargs(su, speed))

    def speed(self, velocity: float, speed_m_per_s: float | None = None) -> float:
        """Hammer speed V (m/s): explicit, else the preset's (study), else the
        preset's speed times velocity**velocity_exponent (musical)."""
        if speed_m_per_s is not None:
            return float(speed_m_per_s)
        V = self.spec.speed_m_per_s
        if self.study:
            return V
        return V * float(velocity) ** self.play.velocity_exponent

    def hammer_kwargs(self, su, speed: float) -> dict:
        """:meth:`StringBank.start_hammer` arguments for the note ``su``."""
        h = self.spec
        law = HAMMER_LAWS[h.law]
        return dict(law=law, mass_kg=h.mass_kg, speed_m_per_s=speed,
                    stiffness=h.stiffness_n_per_mm_p, exponent=h.exponent,
                    alpha_or_gamma=h.alpha_s if law == K.EXC_HAMMER3 else h.gamma,
                    tau0_s=h.tau0_s if law == K.EXC_HAMMER4 else 0.0,
                    tension_n=su.string.tension_n, c_m_per_s=su.string.c_m_per_s,
                    max_flight_s=self.MAX_FLIGHT_S)

    def ideal_support_g(self, su, speed: float) -> np.ndarray:
        """g(t) (m, per internal sample) of this hammer on the same string with
        ideal supports, up to its final value (Publication I, first stage)."""
        b = StringBank(1, su.cells + 2, 1, 4096, n_probes=1,
                       max_gtable=self.max_gtable() if self.layer is not None else 0)
        b.configure(0, cells=su.cells, k=su.k, dt_s=su.dt_s, U=None, probe_row=0)
        b.activate(0)
        self._strike(b, 0, su, speed)
        n = self.max_gtable() - 1
        mix = np.zeros(n)
        b.render(mix, 0, n)
        # g is constant after the last contact (the probe's g drops to 0 only
        # when the kernel cancels that constant offset: not part of g(t))
        hit = np.flatnonzero(b.probe[0, K.P_F, :n] > 0)
        last = int(hit[-1]) + 2 if len(hit) else 1
        self.strike_log = b.probe[0, :, :last].copy()
        return b.probe[0, K.P_G, :last].copy()

    def start(self, bank, slot, su, velocity, *, amplitude_scale=1.0, speed_m_per_s=None,
              length_scale=1.0):
        V = self.speed(velocity, speed_m_per_s)
        if su.U is not None and self.spec.capo_coupling == "injected":
            bank.start_gtable(slot, self.ideal_support_g(su, V))
        else:
            self._strike(bank, slot, su, V)
