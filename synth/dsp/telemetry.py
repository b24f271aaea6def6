"""Contact telemetry (live play's ``--stats``): a slot's contacts with its
termination and its hammer, counted by the kernel.

:class:`Telemetry` is the part of :class:`synth.dsp.bank.StringBank` that
turns it on and reads it; a mixin, split from ``bank.py`` to keep one room
per job.
"""

from __future__ import annotations

from ..kernels import strings as K


class Telemetry:
    """Contact counts per slot (a mixin of :class:`synth.dsp.bank.StringBank`)."""

    TELEMETRY_GAP_S = 0.0002

    def set_telemetry(self, s: int, on: bool, min_gap_s: float = TELEMETRY_GAP_S) -> None:
        """Count slot s's contacts from its next sample (``on``), restarting
        the counts, or stop counting.  A counted slot takes the kernel's
        per-sample path (the reference of the fast path: the same samples to
        round-off), which counts, per sample, the termination points in
        contact and the hammer's felt force; contacts fewer than
        ``min_gap_s`` (s, >= 0) apart are one episode, as in
        :func:`synth.analysis.contacts.contact_summary`."""
        if not (min_gap_s >= 0.0):
            raise ValueError(f"min_gap_s = {min_gap_s!r} is out of range (value >= 0)")
        self.ipar[s, K.I_TELEM] = 1 if on else 0
        if on:
            st = self.fst[s]
            st[K.S_TC_N:K.S_HF_PK + 1] = 0.0
            st[K.S_TC_GAP] = -1.0
            st[K.S_HC_GAP] = -1.0
            dt = float(self.fpar[s, K.F_DT])
            self.fpar[s, K.F_TGAP] = max(0, int(round(min_gap_s / dt))) if dt > 0 else 0

    def telemetry(self, s: int) -> dict:
        """Slot s's contact counts since :meth:`set_telemetry` (the keys of
        :func:`synth.analysis.contacts.contact_summary`, without the first
        and last contact times): ``termination`` (``time_in_contact_s``,
        ``episodes``, ``max_points``) and ``hammer`` (``time_in_contact_s``,
        ``episodes``, ``peak_force_n``).  Read from any thread: the values
        are the kernel's running counts (a meter may see a block in flight)."""
        st = self.fst[s]
        dt = float(self.fpar[s, K.F_DT])
        return {"termination": {"time_in_contact_s": float(st[K.S_TC_N]) * dt,
                                "episodes": int(st[K.S_TC_EP]),
                                "max_points": int(st[K.S_TC_PTS])},
                "hammer": {"time_in_contact_s": float(st[K.S_HC_N]) * dt,
                           "episodes": int(st[K.S_HC_EP]),
                           "peak_force_n": float(st[K.S_HF_PK])}}
