"""The buzz depth as a live control (``play.buzz_cc``, CC1): lowered on a
sounding note, its buzz goes at once; raised, it comes; nothing else moves.

The issue: CC1 127 -> 0 at 1.0 s left the sitar's band above 4 kHz 2-4
dB *louder* for over a second, the biwa's 2 dB lower.  Measured before
the fix (velocity 100, band against the note's own render without the
change, over 1.0-1.2 s / 1.1-1.2 s): the sitar's keys 43, 50, 55, 62, 67,
74 at +0.0/-0.0, -3.7/-5.6, -3.4/-3.4, -8.3/-7.0, -0.4/+0.9, +1.0/+3.3
(key 74 +1.7 over 1.2-2.2 s); the hammered sitar's 67 and 74 at +3.6 and
+4.0 over 1.0-1.2 s; the biwa's 43-55 at -3.8 to -5.1, its 62-74 at 0.0
(their string no longer reaches the sawari at 1 s).  Not the causes: 0 is
not clamped to a minimum (the obstacle goes to +-inf, no contact after
the change), the taraf never touch their own jawari (below), the tune-out
glides.  The cause: the buzz's energy sits in the string's upper
partials, which the linear string keeps, ringing at the loop's own loss
(T60 1.2 s at 6 kHz on the sitar: the band falls 30 dB/s, as the note
at buzz 0 from the start does), about as slowly as the buzzing note's
band falls by itself, while on the top keys the contact had been taking
some of the band's energy.  Now a fall of the depth drains it
(:meth:`synth.voices.one_string.OneStringVoice.set_buzz`).  The step
withdrawal itself was a click on some keys (below): the obstacle now
glides, over 1 ms.

The renders here: a note (two in one test) at velocity 100, 1.85 s at most."""

from __future__ import annotations

import math

import numpy as np
import pytest

from helpers import engine
from synth.analysis.bands import highband_db
from synth.analysis.clicks import click_scan
from synth.dsp.bank import StringBank
from synth.engine.engine import Event
from synth.kernels import strings as K

PRESETS = ["sitar", "biwa", "hammered-sitar"]
KEY, VEL = 50, 100 / 127
T_CC = 1.0


def _render(preset, cc=None, start=None, key=KEY, duration_s=1.25, overrides=(), block=1024,
            more=()):
    """One note (and CC1 to ``cc`` at T_CC, to ``start`` before the note)."""
    ev = [] if start is None else [Event(0.0, "control", 1, start)]
    ev += [Event(0.0, "note_on", key, VEL)]
    if cc is not None:
        ev.append(Event(T_CC, "control", 1, cc))
    e = engine(preset, list(overrides))
    y = np.asarray(e.render(ev + list(more), duration_s=duration_s, block=block), float)
    return (y.mean(axis=1) if y.ndim == 2 else y), e


def _band(y, fs, t0, t1, above_hz=4000.0):
    """Energy above ``above_hz`` over t0-t1 (s), dB (Hann window)."""
    return highband_db(y, fs, above_hz, t0, t1 - t0)


def _below(y, fs, t0, t1, hz):
    """Energy from 1 Hz up to ``hz`` over t0-t1 (s), dB (Hann window)."""
    x = y[int(round(t0 * fs)):int(round(t1 * fs))]
    spec = np.abs(np.fft.rfft(x * np.hanning(len(x)))) ** 2
    f = np.fft.rfftfreq(len(x), 1.0 / fs)
    return 10.0 * np.log10(np.sum(spec[(f >= 1.0) & (f < hz)]))


@pytest.mark.parametrize("preset", PRESETS)
def test_lowering_the_buzz_takes_the_band_above_4_khz_down_at_once(preset):
    """CC1 127 -> 0 at 1.0 s: the band above 4 kHz at least 6 dB under the
    note's own render without the change, over 1.0-1.2 s and over 1.1-1.2
    s (measured -19.4 / -28.0 dB on the sitar, -17.5 / -27.7 on the biwa,
    -18.3 / -23.1 on the hammered sitar; before the drain -3.7 / -5.6,
    -5.1 / -8.1, -3.1 / -4.6; on keys 43-74 of the three now -7.2 to
    -22.0 over 1.0-1.2 s).  The note itself stays: below 500 Hz within 2
    dB over 1.0-1.2 s (measured within 0.1)."""
    y0, e = _render(preset)
    y, _ = _render(preset, cc=0.0)
    fs = e.fs_out
    for t0 in (1.0, 1.1):
        drop = _band(y, fs, t0, 1.2) - _band(y0, fs, t0, 1.2)
        assert drop <= -6.0, f"{preset}: {drop:+.1f} dB over {t0}-1.2 s"
    low = _below(y, fs, 1.0, 1.2, 500.0) - _below(y0, fs, 1.0, 1.2, 500.0)
    assert abs(low) <= 2.0, f"{preset}: {low:+.1f} dB below 500 Hz"


@pytest.mark.parametrize("preset", PRESETS)
def test_raising_the_buzz_brings_the_band_up(preset):
    """CC1 0 (before the note) -> 127 at 1.0 s: the band above 4 kHz over
    1.0-1.2 s at least 6 dB over the same note left at 0 (measured +9.0
    dB on the sitar, +20.7 without its tension's modulation, whose steps
    leave the linear note 17 dB more there, 60 dB under its partial 1; +80.7
    on the biwa, +8.2 on the hammered sitar)."""
    y0, e = _render(preset, start=0.0)
    y, _ = _render(preset, cc=1.0, start=0.0)
    rise = _band(y, e.fs_out, 1.0, 1.2) - _band(y0, e.fs_out, 1.0, 1.2)
    assert rise >= 6.0, f"{preset}: {rise:+.1f} dB"


def test_withdrawing_the_jawari_is_no_click():
    """The hammered sitar's key 43, CC1 127 -> 0: the obstacle moved in one
    step let go of the string within a sample, a jump of 24.9 dB on the
    click scan in the 5 ms after the change (16.2 dB at most in the note's
    own 0.9-1.3 s); gliding over 1 ms (``BUZZ_GLIDE_S``), the scan's worst
    over 0.9-1.3 s is the note's own 16.2, before the change."""
    y, e = _render("hammered-sitar", cc=0.0, key=43, duration_s=1.3)
    fs = e.fs_out
    r = click_scan(y[int(0.9 * fs):], fs)
    assert r["worst_jump_db"] <= 20.0, (r["worst_jump_db"], r["worst_jump_s"])


@pytest.mark.parametrize("preset", PRESETS)
def test_renders_without_a_buzz_change_are_untouched(preset):
    """No fall or rise of the depth, nothing moves: CC1 mid-note at the
    depth the note already has renders as another controller there (CC74,
    which the voice ignores), bit for bit; CC1 at 0 before the note is the
    preset at ``termination.buzz = 0``, bit for bit.  (Any event splits
    the render at its sample; the sitar's bridge, shared with the taraf,
    then rounds differently: CC74 alone moves its samples by 2.7e-14, as
    blocks of 64 instead of 1000 do by 5.3e-14.  The same renders without
    CC1 are bit for bit those before the drain: their sha256 unchanged.)"""
    other, _ = _render(preset, duration_s=0.7, more=[Event(0.3, "control", 74, 0.0)])
    same, _ = _render(preset, duration_s=0.7, more=[Event(0.3, "control", 1, 1.0)])
    assert np.array_equal(same, other)
    y, _ = _render(preset, start=0.0, duration_s=0.7)
    zero, _ = _render(preset, duration_s=0.7, overrides=["termination.buzz=0"])
    assert np.array_equal(y, zero)


@pytest.mark.parametrize("preset", ["sitar", "biwa"])
def test_the_drain_is_the_same_in_any_blocks(preset):
    """The drain's and the glide's steps act at their own internal sample
    (:meth:`StringBank.after`): blocks of 64 and of 1000 output samples
    give the same render.  (The sitar without its taraf, whose bridge
    rounds differently in other blocks whatever the controls; so does the
    hammered sitar's strike, by 7.6e-13 from 25 ms on.)"""
    over = ["taraf.coupling=0"] if preset == "sitar" else []
    a, _ = _render(preset, cc=0.0, duration_s=1.2, block=64, overrides=over)
    b, _ = _render(preset, cc=0.0, duration_s=1.2, block=1000, overrides=over)
    assert np.array_equal(a, b)


def _slot(e):
    (vo,) = e.voices.values()
    return vo.slots[0], e.inst.setup(vo.key_arg, vo.f0_hz)


def test_the_drain_ends_on_the_notes_own_loss_and_a_rise_ends_it():
    """After the drain (CC1 0 at 1.0 s) the note's loss filter is its own
    again, exactly, and so is its pitch-bend line's delay; a rise 20 ms
    after a fall ends the drain within it."""
    for extra, dur in (((), 1.25 + 0.6), ((Event(T_CC + 0.02, "control", 1, 1.0),), 1.25)):
        _, e = _render("sitar", cc=0.0, duration_s=dur, more=extra)
        s, su = _slot(e)
        assert not e.inst._drains
        assert e.bank.fpar[s, K.F_A1] == su.a1 and e.bank.damper[s, 0] == su.b0
        assert e.bank.fpar[s, K.F_B0T] == su.b0          # the key is down: undamped
        assert e.bank.fpar[s, K.F_BDT] == su.bend_delay


def test_a_depth_sent_for_some_notes_moves_those_alone():
    """An engine that keeps CC1 per MIDI channel passes a channel's notes
    alone (and sends a channel's value again before its note-ons): two
    notes, CC1 0 for the first, then 1 (its own value) for the second: the
    first is withdrawn and drained, the second neither."""
    e = engine("sitar")
    e.render([Event(0.0, "note_on", KEY, VEL), Event(0.0, "note_on", 62, VEL)], duration_s=0.3)
    notes = sorted(e.voices.values(), key=lambda vo: vo.key_arg)
    (a, sa), (b, sb) = ((vo.slots[0], e.inst.setup(vo.key_arg, vo.f0_hz)) for vo in notes)
    e.inst.set_buzz(e.bank, 0.0, [(notes[0].slots, notes[0].key_arg, notes[0].f0_hz)])
    e.inst.set_buzz(e.bank, 1.0, [(notes[1].slots, notes[1].key_arg, notes[1].f0_hz)])
    e.render([], duration_s=0.01)

    def region(s, su):
        return e.bank.U[e.bank.ipar[s, K.I_REG_OFF]:][:len(su.U)]

    assert np.all(region(a, sa) == np.inf) and np.array_equal(region(b, sb), sb.U)
    assert a in e.inst._drains and b not in e.inst._drains
    assert e.bank.fpar[b, K.F_A1] == sb.a1 and e.bank.fpar[a, K.F_A1] < sa.a1


def test_a_voice_played_by_another_engine_mid_drain_starts_afresh():
    """A cached voice (a program change back in ``synth play``) left
    mid-drain on one engine: on the next engine its notes have their own
    loss and bend line, and its drains step and end there."""
    first = engine("sitar")
    first.render([Event(0.0, "note_on", KEY, VEL), Event(T_CC, "control", 1, 0.0)],
                 duration_s=T_CC + 0.05)             # the drain under way
    assert first.inst._drains
    e = engine("sitar", voice=first.inst)
    e.render([Event(0.0, "note_on", KEY, VEL)], duration_s=0.3)
    s, su = _slot(e)
    assert e.bank.fpar[s, K.F_A1] == su.a1 and e.bank.fpar[s, K.F_BDT] == su.bend_delay
    e.render([Event(0.3, "control", 1, 1.0), Event(0.4, "control", 1, 0.0)], duration_s=1.0)
    assert not e.inst._drains and e.bank.fpar[s, K.F_A1] == su.a1


def test_the_taraf_never_reach_their_jawari():
    """Why the taraf take no buzz control: on the played note their swing
    stays under their jawari's first gap, so lifting their jawari (a 5 mm
    thread) leaves the render bit for bit."""
    y, _ = _render("sitar", duration_s=0.8)
    lifted, _ = _render("sitar", duration_s=0.8, overrides=["taraf.thread_m=0.005"])
    assert np.array_equal(y, lifted)


# -- the bank's pieces ---------------------------------------------------------------

def _string(bank, s=0):
    bank.configure(s, cells=64, k=40, dt_s=1.0 / 48000, U=None, lossy=True, b0=0.4, a1=-0.59,
                   out_mode=1, tension_over_dx=1.0)
    bank.set_damper(s, (0.4, 375.0, 0.3, math.inf))
    bank.start_pluck(s, K.EXC_SITAR, 1e-3, 1e-3)
    bank.activate(s)


def test_after_calls_at_its_sample_whatever_the_render_calls():
    bank = StringBank(1, 64)
    _string(bank)
    seen = []
    bank.after(100, lambda: seen.append(bank.time))
    bank.after(100, lambda: seen.append(-bank.time))     # same sample: in order
    bank.after(1, lambda: bank.after(250, lambda: seen.append(bank.time)))
    mix = np.zeros((1, 400))
    for o0, n in ((0, 37), (37, 63), (100, 300)):
        bank.render(mix, o0, n)
    assert seen == [100, -100, 251] and bank.time == 400
    for n in (0, 1.5, -3):
        with pytest.raises(ValueError, match=rf"n = {n!r} is out of range \(integer, 1 <= "
                                             r"value <= 2\*\*40 samples\)"):
            bank.after(n, lambda: None)
    with pytest.raises(ValueError, match=r"fn = 3 is not callable"):
        bank.after(1, 3)


def test_set_loss_filter_keeps_the_dampers_share():
    bank = StringBank(1, 64)
    _string(bank)
    bank.apply_dampers(np.array([0]), 0.0)               # the damper down
    share = bank.fpar[0, K.F_B0T] / 0.4
    bank.set_loss_filter(0, 0.2, -0.795)                 # the same gain at DC
    assert bank.fpar[0, K.F_A1] == -0.795 and bank.damper[0, 0] == 0.2
    assert bank.fpar[0, K.F_B0T] / 0.2 == pytest.approx(share)
    bank.apply_dampers(np.array([0]), 1.0)               # lifted: the new gain undamped
    assert bank.fpar[0, K.F_B0T] == 0.2
    with pytest.raises(ValueError, match=r"a1 = -1.0 is out of range \(-1 < value < 1\)"):
        bank.set_loss_filter(0, 0.2, -1.0)
    with pytest.raises(ValueError, match=r"b0 = 0.5 is out of range \(0 < value < 1 - \|a1\| "
                                         r"= 0.41: a loop gain below 1 at every frequency\)"):
        bank.set_loss_filter(0, 0.5, -0.59)
