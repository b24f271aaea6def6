"""Spectrum tests from Python: the checks of ``synth check``, for pytest.

Run a whole spec file::

    from synth.testing import assert_spec
    def test_my_preset():
        assert_spec("checks/my-preset.toml")     # fails with the table of failures

or check one rendered note::

    from synth.testing import render_note, check_f0, check_peak
    y, fs, f = render_note("grand-piano", key=60, velocity=100, seconds=2.0)
    assert check_f0(y, fs, f, cents=1.0).passed

``render_note`` gives the mean of a stereo preset's channels; with
``mono=False`` every channel, shape (frames, channels).

Every ``check_*`` returns a :class:`~synth.apps.check.Result` (``passed``,
``measured``, ``expected``: the same row ``synth check`` prints).  The
measures are those of :mod:`synth.apps.check`; tolerances are in cents, dB,
LU and seconds.
"""

from __future__ import annotations

from .apps.check import CHECKS, Item, Result, SpecError, format_table, load_spec, render_note, run_spec

__all__ = ["assert_spec", "run_spec", "load_spec", "render_note", "format_table", "SpecError",
           "Result", "check_f0", "check_partial", "check_partial_level", "check_t60",
           "check_loudness", "check_peak"]


def assert_spec(path) -> list[Result]:
    """Run a spec; raise AssertionError with the failing rows if any fails."""
    results = run_spec(path)
    bad = [r for r in results if not r.passed]
    if bad:
        raise AssertionError(f"{len(bad)} of {len(results)} checks failed:\n" + format_table(bad))
    return results


def _one(check, x, fs, pitch_hz=None, **kw) -> Result:
    it = Item("audio", x, int(fs), pitch_hz=pitch_hz)
    kw["check"] = check
    (name, measured, expected, ok), = CHECKS[check].run([it], kw, {})
    return Result("python", f"{check} {name}", measured, expected, bool(ok))


def check_f0(x, fs, pitch_hz, cents, start_s=None, length_s=None):
    """Partial 1 of ``x`` within ``cents`` of ``pitch_hz``, over ``length_s``
    from ``start_s`` (s; default 0.05 and 1.0: the first second after the
    onset)."""
    kw = {"cents": cents} | ({} if start_s is None else {"start_s": start_s}) \
        | ({} if length_s is None else {"length_s": length_s})
    return _one("f0", x, fs, pitch_hz, **kw)


def check_partial(x, fs, pitch_hz, n, cents, hz=None):
    """Partial ``n`` within ``cents`` of ``n * pitch_hz`` (or of ``hz``)."""
    kw = {"n": n, "cents": cents} | ({} if hz is None else {"hz": hz})
    return _one("partial", x, fs, pitch_hz, **kw)


def check_partial_level(x, fs, pitch_hz, n, min_db, max_db):
    """Partial ``n``'s level re the strongest of the first 16 within [min_db, max_db]."""
    return _one("partial_level", x, fs, pitch_hz, n=n, min_db=min_db, max_db=max_db)


def check_t60(x, fs, pitch_hz, min_s, max_s, n=1):
    """T60 of partial ``n`` within [min_s, max_s] (s)."""
    return _one("t60", x, fs, pitch_hz, n=n, min_s=min_s, max_s=max_s)


def check_loudness(x, fs, lufs, lu):
    """Integrated loudness (BS.1770) within ``lufs`` +- ``lu``."""
    return _one("loudness", x, fs, lufs=lufs, lu=lu)


def check_peak(x, fs, max_dbfs, min_dbfs=None):
    """Sample peak at most ``max_dbfs`` (and at least ``min_dbfs``)."""
    kw = {"max_dbfs": max_dbfs} | ({} if min_dbfs is None else {"min_dbfs": min_dbfs})
    return _one("peak", x, fs, **kw)
