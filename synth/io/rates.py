"""Output rates: which a card may run at, and the check of a user's rate.

The engine renders at its internal rate and decimates to any output rate
in :data:`RATE_RANGE_HZ` whose ratio to the internal rate the decimator
accepts; the four card rates of :data:`CARD_RATES_HZ` are tested (the
decimator designed for each: 20 kHz flat, 110 dB down from the Nyquist
frequency; the body's response in Hz independent of the rate).
"""

from __future__ import annotations

from .errors import SynthError

__all__ = ["CARD_RATES_HZ", "RATE_RANGE_HZ", "check_rate"]

#: The card rates the output is tested at (Hz).
CARD_RATES_HZ = (44_100, 48_000, 88_200, 96_000)
#: Range of output rates accepted (Hz).
RATE_RANGE_HZ = (22_050, 192_000)


def check_rate(rate, option: str = "--rate") -> int:
    """An output rate (Hz) as an int, or a one-line :class:`SynthError`
    naming the option, the value and the allowed range."""
    try:
        r = float(rate)
    except (TypeError, ValueError):
        r = float("nan")
    lo, hi = RATE_RANGE_HZ
    if not (r == r and r == int(r) and lo <= r <= hi):
        raise SynthError(f"{option} = {rate:g} Hz is out of range (a whole number of Hz, {lo} <= "
                         f"value <= {hi}; cards run at 44100, 48000, 88200 or 96000)"
                         if isinstance(rate, (int, float)) else
                         f"{option} = {rate!r} is out of range (a whole number of Hz, {lo} <= "
                         f"value <= {hi})")
    return int(r)
