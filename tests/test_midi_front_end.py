"""The MIDI front end as a musician's files exercise it: every test writes
the small MIDI file of one feature, renders it through the file reader and
the engine (or ``synth render``), and measures the sound.

Measures: the level of a note's partial 1 band (Hann window, +-3 % of f0)
over a window, in dB; the render's length; the largest sample step."""

from __future__ import annotations

import mido
import numpy as np
import pytest

from helpers import engine
from synth.engine.engine import Event
from synth.engine.order import order_events
from synth.io.midi import midi_to_events, read_midi_file

FS = 48_000
TPB = 480          # ticks per beat at 120 BPM: 960 ticks per second


def write_midi(path, messages, tpb=TPB):
    """A type-0 file of (time_s, mido.Message) pairs (120 BPM)."""
    mf = mido.MidiFile(type=0, ticks_per_beat=tpb)
    tr = mido.MidiTrack()
    mf.tracks.append(tr)
    tick = 0
    for t, msg in sorted(messages, key=lambda m: m[0]):
        at = int(round(t * 2 * tpb))
        tr.append(msg.copy(time=at - tick))
        tick = at
    mf.save(str(path))
    return path


def on(t, key, vel=100, ch=0):
    return (t, mido.Message("note_on", note=key, velocity=vel, channel=ch))


def off(t, key, ch=0):
    return (t, mido.Message("note_off", note=key, velocity=64, channel=ch))


def cc(t, num, value, ch=0):
    return (t, mido.Message("control_change", control=num, value=value, channel=ch))


def file_events(tmp_path, messages, **kw):
    return midi_to_events(read_midi_file(write_midi(tmp_path / "t.mid", messages)), **kw)


def band_db(y, t0, t1, f_hz, rel=0.03):
    """Power in f_hz +- rel over [t0, t1) s (channels summed), dB."""
    seg = y[int(t0 * FS):int(t1 * FS)]
    if seg.ndim > 1:
        seg = seg.sum(axis=1)
    sp = np.abs(np.fft.rfft(seg * np.hanning(len(seg)))) ** 2
    fr = np.fft.rfftfreq(len(seg), 1.0 / FS)
    m = (fr > f_hz * (1 - rel)) & (fr < f_hz * (1 + rel))
    return 10 * np.log10(sp[m].sum() + 1e-30)


def hz(key):
    return 440.0 * 2.0 ** ((key - 69) / 12.0)


# -- the order of simultaneous events ------------------------------------------
def test_order_rule_zero_length_and_repeated_notes():
    E = Event
    zero = [E(0.5, "note_on", 60, 0.7), E(0.5, "note_off", 60, 0.5)]
    # a zero-length note: its note-off after its note-on (it was put first)
    assert [e.kind for e in order_events(zero)] == ["note_on", "note_off"]
    # a note-off with nothing to release keeps its place in front
    assert [e.kind for e in order_events(zero[::-1])] == ["note_off", "note_on"]
    # a velocity-0 note-on is a note-off
    z0 = [E(0.5, "note_on", 60, 0.7), E(0.5, "note_on", 60, 0.0)]
    assert [e.value for e in order_events(z0)] == [0.7, 0.0]
    # a repeated note: the earlier note's note-off first, both ways round
    rep = [E(0.0, "note_on", 60, 0.7), E(1.0, "note_on", 60, 0.7), E(1.0, "note_off", 60, 0.5)]
    assert [e.kind for e in order_events(rep)] == ["note_on", "note_off", "note_on"]
    rep2 = [rep[0], rep[2], rep[1]]
    assert [e.kind for e in order_events(rep2)] == ["note_on", "note_off", "note_on"]
    # another key's note-off and other events keep their place
    mix = [E(0.0, "note_on", 62, 0.7), E(1.0, "control", 64, 1.0), E(1.0, "note_on", 60, 0.7),
           E(1.0, "note_off", 62, 0.5), E(1.0, "note_off", 60, 0.5)]
    got = [(e.kind, e.key) for e in order_events(mix)]
    assert got == [("note_on", 62), ("note_off", 62), ("control", 64), ("note_on", 60),
                   ("note_off", 60)]
    # channels are apart
    ch = [E(0.0, "note_on", 60, 0.7, 1), E(1.0, "note_on", 60, 0.7, 0), E(1.0, "note_off", 60, 0.5, 0)]
    assert [(e.kind, e.channel) for e in order_events(ch)] == [
        ("note_on", 1), ("note_on", 0), ("note_off", 0)]
    ch2 = [ch[0], ch[2], ch[1]]           # channel 1's note is not the one that ends
    assert [(e.kind, e.channel) for e in order_events(ch2)] == [
        ("note_on", 1), ("note_off", 0), ("note_on", 0)]
    # the engine starts from the keys it holds
    assert [e.kind for e in order_events(zero, sounding={(0, 60)})] == ["note_off", "note_on"]


def test_zero_length_note_sounds_and_stops_in_a_render(tmp_path):
    """Note 60 on and off on one tick, then a short note 62: the grand
    renders about 2 s (it rang undamped for 31 s), and C4 is struck."""
    from synth.apps.render import RenderRequest, render_midi_file

    path = write_midi(tmp_path / "zero.mid", [on(0.5, 60), off(0.5, 60), on(0.75, 62), off(1.0, 62)])
    evs = midi_to_events(read_midi_file(path))
    assert [(e.kind, e.key) for e in evs[:2]] == [("note_on", 60), ("note_off", 60)]
    for preset in ("grand-piano", "harpsichord"):
        res = render_midi_file(RenderRequest(str(path), preset, str(tmp_path / f"{preset}.wav")))
        assert res.seconds <= 8.0, (preset, res.seconds)
    y = engine("grand-piano").render(evs, tail_s=0.5)
    # C4's strike is heard (its partial 1 band over 0.5-0.75 s, against 62's later)
    assert band_db(y, 0.5, 0.75, hz(60)) > band_db(y, 0.5, 0.75, hz(60) * 1.5) + 10


# -- voice allocation -------------------------------------------------------------
@pytest.mark.slow
def test_a_triad_on_the_sitars_full_pool_keeps_every_new_note(tmp_path):
    """Keys 43-58 ring from 0 s on the sitar's 16 voices, a triad comes at
    1 s: each of its notes at least 6 dB above the same band without it
    over 1.1-1.6 s (measured +11.8, +19.8, +7.8 dB; +13.9, +11.6, +8.9
    without the tension's glide, which moves the held notes' partials
    against the triad's; when only the last note sounded: +0, +0, +9 dB)."""
    base = [on(0.0, k) for k in range(43, 59)]
    tri = [on(1.0, k) for k in (62, 66, 69)]
    e0, e1 = engine("sitar"), engine("sitar")
    y0 = e0.render(file_events(tmp_path, base), duration_s=1.7)
    y1 = e1.render(file_events(tmp_path, base + tri), duration_s=1.7)
    for k in (62, 66, 69):
        assert band_db(y1, 1.1, 1.6, hz(k)) - band_db(y0, 1.1, 1.6, hz(k)) >= 6.0, k
    assert e1.n_stolen == 3


@pytest.mark.parametrize("preset", ["biwa", "grand-piano", "harpsichord", "hammered-sitar"])
def test_a_chord_on_a_full_pool_keeps_every_new_note(preset):
    """A 4-note chord on a full pool keeps all four (it kept one): each
    sounds within 6 dB of the chord played alone, and the voices given up
    are held notes."""
    e = engine(preset, polyphony=8)
    lo, hi = e.play.key_range
    held = [Event(0.0, "note_on", lo + i, 0.8) for i in range(8)]
    mid = (lo + hi) // 2
    chord = [Event(0.3, "note_on", mid + d, 0.8) for d in (0, 4, 7, 11)]
    y = e.render(held + chord, duration_s=0.6)
    alone = engine(preset, polyphony=8).render(chord, duration_s=0.6)
    for ev in chord:
        f = e.inst.pitch_hz(ev.key)
        assert band_db(y, 0.35, 0.6, f) >= band_db(alone, 0.35, 0.6, f) - 6.0, (preset, ev.key)
    assert e.n_stolen == 4 and e.n_live == 8
    assert {vo.key[1] for vo in e.voices.values() if not vo.dying} >= {ev.key for ev in chord}


def test_a_repeated_key_restrikes_its_own_voice():
    e = engine("sitar")
    e.render([Event(0.0, "note_on", 50, 0.8), Event(0.1, "note_on", 50, 0.8)], duration_s=0.2)
    assert e.n_voices == 1 and e.n_stolen == 0


def test_steal_oldest_takes_the_oldest_released_note():
    """``play.steal = "oldest"``: the oldest released note goes, else the
    oldest held one (the default takes the quietest)."""
    e = engine("biwa", ["play.steal=oldest"], polyphony=3)
    evs = [Event(0.0, "note_on", 50, 1.0), Event(0.1, "note_on", 52, 0.2),
           Event(0.2, "note_on", 55, 0.2), Event(0.4, "note_on", 59, 0.8)]
    e.render(evs, duration_s=0.45)
    sounding = sorted(vo.key[1] for vo in e.voices.values() if not vo.dying)
    assert sounding == [52, 55, 59]
    e = engine("biwa", ["play.steal=oldest"], polyphony=3)
    e.render(evs[:3] + [Event(0.3, "note_off", 55, 0.5), evs[3]], duration_s=0.45)
    assert sorted(vo.key[1] for vo in e.voices.values() if not vo.dying) == [50, 52, 59]


def test_steals_are_counted_in_the_render_summary(tmp_path):
    from synth.apps.render import RenderRequest, render_midi_file

    path = write_midi(tmp_path / "full.mid", [on(0.0, k) for k in range(43, 59)]
                      + [on(0.5, 62), on(0.5, 66)] + [off(0.8, k) for k in range(43, 67)])
    res = render_midi_file(RenderRequest(str(path), "sitar", str(tmp_path / "o.wav"),
                                         max_seconds=1.0))
    assert res.stolen == 2 and "2 voices stolen (polyphony 16)" in res.summary


# -- channels -------------------------------------------------------------------
def test_a_pedal_on_another_channel_does_not_hold_a_note(tmp_path):
    """CC64 on channel 2 leaves a channel-1 note damped at its note-off;
    on channel 1 it holds it."""
    def level(ch):
        evs = file_events(tmp_path, [cc(0.0, 64, 127, ch), on(0.1, 60), off(0.5, 60)])
        return band_db(engine("grand-piano").render(evs, duration_s=2.0), 1.5, 2.0, hz(60))

    assert level(0) - level(1) > 20.0


@pytest.mark.parametrize("num", [66, 67, 123])
def test_channel_controls_act_on_their_own_channel(num):
    """Sostenuto, soft pedal and all notes off on channel 2 leave a channel-1
    note as it is (the render is the same as without them)."""
    base = [Event(0.0, "note_on", 60, 0.8), Event(0.5, "note_off", 60, 0.5)]
    t = 0.0 if num == 67 else 0.2         # the soft pedal acts at the strike, the others later

    def render(ch):
        ctl = [] if ch is None else [Event(t, "control", num, 1.0, ch)]
        return engine("grand-piano").render(ctl + base, duration_s=1.0)

    y0 = render(None)
    # the same to round-off (any control splits the sympathetic strings' block)
    assert np.max(np.abs(render(1) - y0)) < 1e-10
    assert np.max(np.abs(render(0) - y0)) > 1e-3


def test_channels_and_the_drum_channel_are_chosen(tmp_path):
    msgs = [on(0.0, 60, ch=0), on(0.0, 64, ch=1), on(0.0, 36, ch=9), off(0.5, 60, 0),
            off(0.5, 64, 1), off(0.5, 36, 9)]
    ign = {}
    evs = file_events(tmp_path, msgs, ignored=ign)
    assert {(e.channel, e.key) for e in evs} == {(0, 60), (1, 64)}
    assert ign == {"channel 10 messages (General MIDI drums; --drums plays them)": 2}
    evs = file_events(tmp_path, msgs, drums=True)
    assert {(e.channel, e.key) for e in evs} == {(0, 60), (1, 64), (9, 36)}
    ign = {}
    evs = file_events(tmp_path, msgs, channels={1}, ignored=ign)
    assert {(e.channel, e.key) for e in evs} == {(1, 64)}
    assert ign["channel 1 messages (not in --channels)"] == 2


def test_the_live_player_chooses_channels_as_a_render_does():
    from synth.io.live.player import normalise
    from synth.io.midi import plays_channel

    ign = {}
    assert normalise(mido.Message("note_on", note=36, velocity=90, channel=9), ignored=ign) is None
    assert normalise(mido.Message("note_on", note=36, velocity=90, channel=9), drums=True) is not None
    assert normalise(mido.Message("note_on", note=60, velocity=90, channel=2), channels={0},
                     ignored=ign) is None
    normalise(mido.Message("sysex", data=[3]), ignored=ign)
    assert ign == {"channel 10 messages (General MIDI drums; --drums plays them)": 1,
                   "channel 3 messages (not in --channels)": 1,
                   "system exclusive": 1}
    assert plays_channel(0) and not plays_channel(9) and plays_channel(9, drums=True)
    assert not plays_channel(1, {0, 2}) and plays_channel(2, {0, 2})


def test_channels_option_parses_as_users_number_channels():
    import argparse

    from synth.cli import parse_channels

    assert parse_channels("1,3-4") == (0, 2, 3)
    assert parse_channels("10") == (9,)
    for bad in ("0", "17", "x", "4-2", ""):
        with pytest.raises(argparse.ArgumentTypeError, match="--channels"):
            parse_channels(bad)


# -- controllers ----------------------------------------------------------------
def test_reset_all_controllers_lifts_a_held_pedal(tmp_path):
    """CC121 after a held sustain pedal: the pedal is up, the note is damped,
    and the render ends within 8 s (it ran 31 s)."""
    from synth.apps.render import RenderRequest, render_midi_file

    path = write_midi(tmp_path / "reset.mid", [cc(0.0, 64, 127), on(0.1, 60), off(0.5, 60),
                                               cc(1.0, 121, 0)])
    res = render_midi_file(RenderRequest(str(path), "grand-piano", str(tmp_path / "o.wav")))
    assert res.seconds <= 8.0


def test_rpn_0_sets_the_bend_range(tmp_path):
    """RPN 0 (CC101 0, CC100 0, CC6 1): a full bend plays one semitone on
    the sitar instead of the preset's two; the other RPNs are listed."""
    from synth.analysis.pitch import estimate_f0

    def bent(extra):
        evs = file_events(tmp_path, extra + [
            on(0.1, 57), (0.2, mido.Message("pitchwheel", pitch=8191))])
        y = engine("sitar", ["taraf.coupling=0"]).render(evs, duration_s=1.2)
        return estimate_f0(y[int(0.6 * FS):int(1.2 * FS)], FS, hz(57) * 2 ** (150 / 1200),
                           search_cents=150.0)

    two = bent([])
    one = bent([cc(0.0, 101, 0), cc(0.0, 100, 0), cc(0.0, 6, 1), cc(0.0, 38, 0)])
    assert 1200 * np.log2(two / hz(57)) == pytest.approx(200, abs=8)
    assert 1200 * np.log2(one / hz(57)) == pytest.approx(100, abs=8)
    e = engine("sitar")
    e.render(file_events(tmp_path, [cc(0.0, 101, 0), cc(0.0, 100, 2), cc(0.0, 6, 66),
                                    cc(0.0, 101, 0), cc(0.0, 100, 0), cc(0.0, 6, 24), on(0.0, 57)]),
             duration_s=0.1)
    assert e.ignored == {"RPN 2 (coarse tuning)": 1,
                         "RPN 0 (pitch-bend range) above the preset's 2 semitones: held at 2": 1}


def test_ignored_messages_are_listed_once_with_their_counts(tmp_path):
    from synth.apps.render import RenderRequest, render_midi_file

    msgs = [on(0.0, 60), cc(0.1, 91, 40), cc(0.2, 91, 50), cc(0.2, 5, 10),
            (0.3, mido.Message("aftertouch", value=50)), (0.3, mido.Message("program_change", program=5)),
            off(0.5, 60)]
    path = write_midi(tmp_path / "ign.mid", msgs)
    lines = []
    res = render_midi_file(RenderRequest(str(path), "biwa", str(tmp_path / "o.wav")), log=lines.append)
    # (the biwa plays channel pressure: its note's buzz depth, tests/test_mpe.py)
    assert res.ignored == {"CC 91 (reverb send)": 2, "CC 5 (portamento time)": 1,
                           "program change (a render plays one preset)": 1}
    assert lines[:2] == ["note: ignored 2 x CC 91 (reverb send)",
                         "note: ignored 1 x CC 5 (portamento time)"]


def test_all_sound_off_adds_no_click(tmp_path):
    """CC120 on the grand's sounding C4: no step larger than the note's own
    largest (it stepped by 0.076 against the note's 0.023), then silence."""
    evs = file_events(tmp_path, [on(0.0, 60, 110), cc(0.5, 120, 0)])
    y = engine("grand-piano").render(evs, duration_s=1.0)
    ref = engine("grand-piano").render(evs[:1], duration_s=1.0)
    own = np.max(np.abs(np.diff(ref, axis=0)))
    assert np.max(np.abs(np.diff(y[int(0.45 * FS):], axis=0))) <= own
    assert np.max(np.abs(y[int(0.52 * FS):])) == 0.0


# -- volume, expression, pan --------------------------------------------------------
def _rms_db(y, t0, t1):
    seg = y[int(t0 * FS):int(t1 * FS)]
    return 10 * np.log10(np.mean(seg ** 2) + 1e-300)


def test_volume_zero_silences_the_grand(tmp_path):
    """CC7 = 0 on the grand's C4: at least 40 dB quieter (it measured the
    same as no CC7); 127 is General MIDI 2's +4.2 dB over the default 100."""
    def render(msgs):
        return engine("grand-piano").render(file_events(tmp_path, msgs + [on(0.0, 60)]),
                                            duration_s=1.5)

    y0 = render([])
    assert _rms_db(y0, 0.1, 1.5) - _rms_db(render([cc(0.0, 7, 0)]), 0.1, 1.5) >= 40.0
    assert _rms_db(render([cc(0.0, 7, 127)]), 0.1, 1.5) - _rms_db(y0, 0.1, 1.5) == pytest.approx(
        40 * np.log10(127 / 100), abs=0.05)
    assert np.array_equal(render([cc(0.0, 7, 100)]), y0)     # the default: no change at all
    # expression on top of the volume
    assert _rms_db(y0, 0.1, 1.5) - _rms_db(render([cc(0.0, 11, 64)]), 0.1, 1.5) == pytest.approx(
        -40 * np.log10(64 / 127), abs=0.05)


def test_pan_zero_plays_the_grand_on_the_left(tmp_path):
    """CC10 = 0 on the grand's C4: at least 6 dB more in the left channel
    (it stayed centred, -0.2 dB L-R); the centre is the render without it."""
    def render(msgs):
        return engine("grand-piano").render(file_events(tmp_path, msgs + [on(0.0, 60)]),
                                            duration_s=1.5)

    y0 = render([])
    yl = render([cc(0.0, 10, 0)])
    yr = render([cc(0.0, 10, 127)])
    lr = lambda y: _rms_db(y[:, 0], 0.1, 1.5) - _rms_db(y[:, 1], 0.1, 1.5)   # noqa: E731
    assert lr(yl) - lr(y0) >= 6.0 and lr(yr) - lr(y0) <= -6.0
    assert np.array_equal(render([cc(0.0, 10, 64)]), y0)
    # the mono presets list it
    e = engine("sitar")
    e.render(file_events(tmp_path, [cc(0.0, 10, 0), on(0.0, 57)]), duration_s=0.1)
    assert e.ignored == {"CC 10 (pan): the preset's output is mono": 1}


@pytest.mark.parametrize("num, values", [(7, (127, 0)), (11, (127, 20)), (10, (64, 0))])
def test_volume_and_pan_changes_mid_note_make_no_click(tmp_path, num, values):
    """A change while C4 sounds ramps over 10 ms: no sample step larger than
    the note's own largest."""
    msgs = [cc(0.0, num, values[0]), on(0.0, 60, 110), cc(0.5, num, values[1])]
    y = engine("grand-piano").render(file_events(tmp_path, msgs), duration_s=1.0)
    ref = engine("grand-piano").render(file_events(tmp_path, msgs[:2]), duration_s=1.0)
    own = np.max(np.abs(np.diff(ref, axis=0)))
    assert np.max(np.abs(np.diff(y[int(0.45 * FS):], axis=0))) <= own
    assert not np.allclose(y[int(0.6 * FS):], ref[int(0.6 * FS):])


def test_volume_acts_on_its_own_channel(tmp_path):
    """Channel 2 at volume 0 is silent; channel 1 beside it plays as alone
    (to round-off: the channels' rows are summed)."""
    one = [on(0.0, 60, ch=0), off(0.8, 60, ch=0)]
    two = [cc(0.0, 7, 0, ch=1), on(0.0, 67, ch=1), off(0.8, 67, ch=1)]
    y1 = engine("grand-piano").render(file_events(tmp_path, one), duration_s=1.2)
    y12 = engine("grand-piano").render(file_events(tmp_path, one + two), duration_s=1.2)
    # channel 2's note only reaches the output through the board's shared
    # strings: its sympathetic drive is scaled with it
    assert np.max(np.abs(y12 - y1)) < 1e-6 * np.max(np.abs(y1))


# -- live play and offline rendering ----------------------------------------------
SCENES = {
    "triad on a full pool": ("sitar", [on(0.0, k) for k in range(43, 59)]
                             + [on(0.3, k) for k in (62, 66, 69)]),
    "zero-length note": ("grand-piano", [on(0.05, 60), off(0.05, 60), on(0.2, 62), off(0.35, 62)]),
    "volume and expression": ("grand-piano", [cc(0.0, 7, 60), on(0.02, 60), cc(0.2, 11, 30),
                                              cc(0.3, 7, 0)]),
    "pan": ("grand-piano", [on(0.02, 60), on(0.02, 64, ch=1), cc(0.1, 10, 0), cc(0.2, 10, 127, ch=1)]),
    "reset all controllers": ("grand-piano", [cc(0.0, 64, 127), on(0.02, 60), off(0.1, 60),
                                              cc(0.25, 121, 0)]),
    "buzz down": ("sitar", [on(0.0, 50, 127), cc(0.0, 1, 127), cc(0.2, 1, 0)]),
    "all sound off": ("grand-piano", [on(0.0, 60, 110), on(0.05, 67, 90), cc(0.3, 120, 0)]),
    "channels, bend and RPN": ("sitar", [cc(0.0, 101, 0), cc(0.0, 100, 0), cc(0.0, 6, 1),
                                         on(0.0, 57), on(0.0, 62, ch=1),
                                         (0.1, mido.Message("pitchwheel", pitch=8191)),
                                         cc(0.15, 64, 127, ch=1), off(0.2, 62, ch=1)]),
}


@pytest.mark.parametrize("scene", [pytest.param(s, marks=pytest.mark.slow) if s == "triad on a full pool" else s
                                   for s in sorted(SCENES)])  # (the full pool: over 2 s)
def test_live_play_gives_the_offline_samples(tmp_path, scene):
    """Each scene above played live (the player's message conversion, stamped
    on arrival, pulled in 128-sample blocks) gives the samples of the file
    rendered offline at arrival + latency."""
    from synth.engine.realtime import Realtime
    from synth.io.live.player import normalise

    preset, msgs = SCENES[scene]
    path = write_midi(tmp_path / "scene.mid", msgs)
    seconds = 0.5
    e_live = engine(preset)
    block = 128
    t_now = [0.0]
    rt = Realtime(e_live, block=block, clock=lambda: t_now[0], overload=None)
    rt.start(0.0, quiet_gc=False)
    # the file's own times (tick-exact), as a keyboard would send the messages
    arrivals = [(m.time_s, m) for m in read_midi_file(path)]
    mf = [msg for msg in mido.MidiFile(str(path)) if not msg.is_meta]
    assert len(mf) == len(arrivals)
    out, i = [], 0
    for b in range(int(seconds * FS / block)):
        t_now[0] = b * block / FS
        while i < len(arrivals) and arrivals[i][0] <= t_now[0]:
            ev = normalise(mf[i])
            if ev is not None:
                rt.push(ev, arrivals[i][0])
            i += 1
        buf = np.zeros((block, e_live.channels), dtype=np.float32)
        rt.callback(buf, block, None, None)
        out.append(buf.copy())
    rt.stop()
    live = np.concatenate(out)
    evs = midi_to_events(read_midi_file(path))
    shifted = [Event(e.time_s + rt.latency_s, e.kind, e.key, e.value, e.channel) for e in evs]
    assert rt.stats.late_events == 0 and rt.stats.errors == 0
    assert np.max(np.abs(live)) > 1e-3
    for blk, tol in ((block, 0.0), (1000, 1e-5)):
        offline = engine(preset).render(shifted, duration_s=len(live) / FS, block=blk,
                                        compensate_latency=False).astype(np.float32)
        if offline.ndim == 1:
            offline = offline[:, None]
        # in the same blocks: equal to the float32 output's last place; in
        # other blocks within -100 dBFS (strings freed as silent at a block's
        # end, about -110 dBFS, leave their last whisper at another sample)
        top = 2 * np.spacing(np.float32(np.max(np.abs(offline))))
        assert np.max(np.abs(live - offline)) <= max(top, tol), blk


def test_all_sound_off_on_another_channel_leaves_a_note_sounding(tmp_path):
    """CC120 on channel 2 fades channel 2's note and leaves channel 1's as it
    was; sent on every channel (a panic) it silences everything."""
    base = [on(0.0, 60, ch=0), on(0.0, 67, ch=1)]
    y = engine("grand-piano").render(file_events(tmp_path, base + [cc(0.3, 120, 0, ch=1)]),
                                     duration_s=1.0)
    ref = engine("grand-piano").render(file_events(tmp_path, base), duration_s=1.0)
    assert abs(band_db(y, 0.5, 1.0, hz(60)) - band_db(ref, 0.5, 1.0, hz(60))) < 1.0
    assert band_db(ref, 0.5, 1.0, hz(67)) - band_db(y, 0.5, 1.0, hz(67)) > 30.0
    panic = [cc(0.3, 120, 0, ch=c) for c in range(16)]
    e = engine("grand-piano")
    y = e.render(file_events(tmp_path, base + panic, drums=True), duration_s=1.0)
    assert np.max(np.abs(y[int(0.32 * FS):])) == 0.0 and e.n_voices == 0
