"""The drone player (synth.engine.drone): a key starts a cycle of plucks of a
tanpura's four strings, the same key stops it, another key moves Sa; the
plucks are humanised from a seeded generator, act at their own internal
sample (the same samples for any block size, live and offline), and every
string is a voice of its own.

The preset is made in a temporary folder from the shipped sitar (its
string, jawari and gourd, without its taraf and chikari) and a ``[drone]``
table, found through ``SYNTH_PRESET_PATH`` as any user's preset is.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from synth.engine import drone as D
from synth.engine.engine import Event
from synth.io.errors import PresetError
from synth.io.factory import build_engine
from synth.io.presets import ENV_PRESET_PATH, load_preset, shipped_preset_dir
from synth.io.presets.sections import DRONE_CYCLE_RANGE_S

NAME = "drone-test"
FS = 48_000
DRONE = '''
[drone]
pattern = "Pa Sa Sa Sa"
cycle_s = 4.0
onsets = [0.0, 0.3, 0.45, 0.6]
velocity = 0.6
timing_jitter_s = 0.02
force_jitter_db = 1.5
seed = 7
tempo_cc = 16
pattern_cc = 17
'''


def drone_preset_text(drone: str = DRONE) -> str:
    """The sitar's file without its taraf and chikari, with a [drone] table."""
    src = (shipped_preset_dir() / "sitar.toml").read_text("utf-8")
    text = src[:src.index("[taraf]")] + src[src.index("[loss]"):]
    text = re.sub(r'(?m)^description = .*$',
                  'description = "Drone test: the sitar string plucked by the drone player"', text)
    return text + drone


@pytest.fixture
def presets(tmp_path, monkeypatch):
    folder = tmp_path / "presets"
    folder.mkdir()
    (folder / f"{NAME}.toml").write_text(drone_preset_text(), "utf-8")
    monkeypatch.setenv(ENV_PRESET_PATH, str(folder))
    return folder


def on(t, key, vel=0.8, ch=0):
    return Event(t, "note_on", key, vel, ch)


def plucks(eng):
    """The engine's plucks: (time s, string, key, velocity)."""
    return [(s / eng.fs_in_exact, i, k, v) for s, i, k, v in eng.drone.history]


# -- the player's pieces --------------------------------------------------------------


def test_pattern_tunings_and_controller_maps():
    assert D.parse_pattern("Pa Sa Sa Sa") == "Pa" and D.parse_pattern(" ma  sa SA sa ") == "Ma"
    assert D.string_keys(49, "Pa") == (44, 49, 49, 37)
    assert D.string_keys(49, "Ma") == (42, 49, 49, 37)
    assert D.string_keys(49, "Ni") == (48, 49, 49, 37)
    assert D.string_keys(49, "Sa") == (49, 49, 49, 37)
    for bad in ("Pa Sa Sa", "Re Sa Sa Sa", "Pa Sa Pa Sa", "Pa Sa Sa Sa Sa"):
        with pytest.raises(ValueError, match="pattern = "):
            D.parse_pattern(bad)
    assert [D.first_from_cc(m / 127) for m in (0, 31, 32, 63, 64, 95, 96, 127)] == \
        ["Pa", "Pa", "Ma", "Ma", "Ni", "Ni", "Sa", "Sa"]
    assert D.cycle_from_cc(0.0) == 16.0 and D.cycle_from_cc(1.0) == pytest.approx(1.0)
    assert D.cycle_from_cc(64 / 127) == pytest.approx(3.96, abs=0.01)
    # the controller sweeps the range the schema allows
    assert D.CYCLE_RANGE_S == DRONE_CYCLE_RANGE_S


def test_a_preset_without_drone_has_no_player_and_player_off_plays_strings(presets):
    assert build_engine("sitar").drone is None
    eng = build_engine(NAME, ["drone.player=off"])
    assert eng.drone is None
    eng.render([on(0.0, 49)], duration_s=0.05)
    assert eng.n_voices == 1                         # one string, the key's


def test_drone_keys_are_checked_when_the_preset_loads(presets):
    for override, words in (("drone.onsets=[0, 0.5, 0.4, 0.6]", "not strictly increasing"),
                            ("drone.onsets=[0, 0.5]", "has 2 values"),
                            ("drone.onsets=[0, 0.3, 0.5, 1.0]", "out of range (0 <= value < 1)"),
                            ("drone.pattern=\"Pa Sa Sa\"", "Pa, Ma, Ni or Sa, then Sa Sa Sa"),
                            ("drone.cycle_s=0.5", "out of range (1 <= value <= 16)"),
                            ("drone.velocity=0", "out of range (0 < value <= 1)")):
        with pytest.raises(PresetError, match=re.escape(words)):
            load_preset(NAME, [override])
    with pytest.raises(Exception, match="drone.tempo_cc = 17 and drone.pattern_cc = 17"):
        build_engine(NAME, ["drone.tempo_cc=17"])
    # a controller the engine or the voice plays is not the drone's
    with pytest.raises(Exception, match=re.escape(
            "drone.tempo_cc = 1 is taken (the voice's own control, modulation): give another "
            "controller (1 <= value <= 119)")):
        build_engine(NAME, ["drone.tempo_cc=1"])
    with pytest.raises(Exception, match=re.escape("drone.pattern_cc = 64 is taken (sustain pedal)")):
        build_engine(NAME, ["drone.pattern_cc=64"])


# -- the cycle ------------------------------------------------------------------------


@pytest.mark.slow   # 20 s of four strings (about 3 s)
def test_plucks_over_20_s_follow_the_pattern_and_onsets_within_the_jitter(presets):
    eng = build_engine(NAME)
    y = eng.render([on(0.0, 49)], duration_s=20.0)
    assert len(y) == 20 * FS
    p = [x for x in plucks(eng) if x[0] < 20.0]
    assert len(p) == 20                              # 5 cycles of 4 strings
    spec = eng.drone.spec
    one = 1.0 / eng.fs_in_exact
    keys = (44, 49, 49, 37)
    for n, (t, i, key, vel) in enumerate(p):
        c = round((t - spec.onsets[i] * spec.cycle_s) / spec.cycle_s)
        want = c * spec.cycle_s + spec.onsets[i] * spec.cycle_s
        assert abs(t - want) <= spec.timing_jitter_s + one, (n, t, want)
        assert t >= c * spec.cycle_s - one           # never before its cycle's start
        assert key == keys[i]
        db = 20.0 * np.log10(vel / spec.velocity)    # velocity_exponent 1
        assert abs(db) <= spec.force_jitter_db + 1e-9
    # in pluck order: first, Sa, Sa, low Sa in every cycle
    assert [x[1] for x in p] == [0, 1, 2, 3] * 5
    # the humanisation is used: the times and forces are not the grid's
    assert np.std([x[3] for x in p]) > 0.01
    # the first string and the first Sa sound: the peak level doubles within
    # 30 ms of their plucks (the second Sa and the low Sa join strings that
    # ring at their pitch and octave: in the mix their onsets rise 1.2-2x,
    # too little to tell apart here; the voices' test shows them)
    env = np.abs(y)
    for t, i, key, vel in p:
        j = int(t * FS)
        if i in (0, 1) and j > 0:
            assert env[j:j + int(0.03 * FS)].max() > 2.0 * env[max(j - 480, 0):j].max(), (t, i)


def _short(presets, **kw):
    """Presets whose cycle is 1 s (quick tests)."""
    return ["drone.cycle_s=1"] + [f"drone.{k}={v}" for k, v in kw.items()]


def test_the_same_seed_gives_the_same_samples_another_seed_others(presets):
    ev = [on(0.0, 49)]
    a = build_engine(NAME, _short(presets)).render(ev, duration_s=2.2)
    b = build_engine(NAME, _short(presets)).render(ev, duration_s=2.2)
    c = build_engine(NAME, _short(presets, seed=8)).render(ev, duration_s=2.2)
    assert np.array_equal(a, b)
    assert np.max(np.abs(a - c)) > 0.05 * np.max(np.abs(a))


def test_the_samples_do_not_depend_on_the_block_size(presets):
    """Plucks, a controller, a key that moves Sa: each at its own internal
    sample, whatever the blocks (live: the same, tests below)."""
    ev = [on(0.0123, 49), Event(0.4, "control", 16, 1.0), on(0.61, 51)]
    ref = None
    for block in (37, 1000):
        eng = build_engine(NAME, _short(presets))
        y = eng.render(ev, duration_s=2.3, block=block)
        if ref is None:
            ref, ref_plucks = y, list(eng.drone.history)
        else:
            assert list(eng.drone.history) == ref_plucks
            assert np.max(np.abs(y - ref)) < 1e-12 * np.max(np.abs(ref))
    assert len(ref_plucks) >= 8


def test_the_two_middle_sa_strings_are_two_voices_sounding_together(presets):
    eng = build_engine(NAME, _short(presets, timing_jitter_s=0))
    eng.render([on(0.0, 49)], duration_s=0.7)        # the four plucks of the first cycle
    assert [h[1:3] for h in eng.drone.history] == [(0, 44), (1, 49), (2, 49), (3, 37)]
    assert eng.n_voices == 4                          # no string cut the one before it
    assert {(0, 49, 1), (0, 49, 2), (0, 44, 0), (0, 37, 3)} <= set(eng.by_key)
    # the second cycle restrikes each string on its own voice
    voices = dict(eng.by_key)
    for _ in range(10):                               # on to 1.5 s
        eng.render_block(4096)
    assert eng.drone.n_plucks >= 5 and eng.n_voices == 4 and dict(eng.by_key) == voices


def test_a_cycle_starts_the_strings_it_plucks_later_at_rest():
    """At a cycle's first sample the player lists, before its plucks and
    with velocity None, every string it plucks later than that sample
    (here strings 1-3: string 0 is plucked at the start); they are not
    plucks (neither counted nor in the history)."""
    spec = load_preset("tanpura", ["drone.timing_jitter_s=0"]).drone
    d = D.Drone(spec, 325_000.0)
    d.press(49, 0, 1000)
    first = d.due(1000)
    assert first == [(1, 49.0, None, 0), (2, 49.0, None, 0), (3, 37.0, None, 0),
                     (0, 44.0, first[3][2], 0)] and first[3][2] > 0
    assert d.n_plucks == 1 and len(d.history) == 1
    nxt = d.due(1000 + int(0.3 * 4.0 * 325_000))
    assert [x[:2] for x in nxt] == [(1, 49.0)] and nxt[0][2] > 0 and d.n_plucks == 2


def test_the_strings_not_yet_plucked_ring_on_the_bridge_from_the_start():
    """The tanpura: from the drone's first sample all four strings are on
    the bridge, and before its own pluck (at 1.2 s) each takes energy from
    Pa through it, the low Sa most (Pa's partial 2 on its partial 3); its
    pluck then excites the string where it is, on the same voice.  A
    resting string's rest does nothing to a sounding one."""
    eng = build_engine("tanpura", ["drone.timing_jitter_s=0"])
    eng.schedule([on(0.0, 49)])

    def energies():
        return {vo.key: float(eng.bank.energy(list(eng._slot_tuples[v])).sum())
                for v, vo in eng.voices.items()}

    eng.render_block(2400)                       # 0.05 s
    early = energies()
    assert sorted(early) == [(0, 37.0, 3), (0, 44.0, 0), (0, 49.0, 1), (0, 49.0, 2)]
    assert eng.drone.n_plucks == 1
    while eng.time_out < int(1.15 * FS):         # to just before the second pluck
        eng.render_block(2400)
    late = energies()
    assert eng.drone.n_plucks == 1
    pa = late[(0, 44.0, 0)]
    for k in ((0, 49.0, 1), (0, 49.0, 2), (0, 37.0, 3)):
        assert 0.0 < late[k] < 1e-3 * pa
    assert late[(0, 37.0, 3)] > 10.0 * early[(0, 37.0, 3)]
    voices = dict(eng.by_key)
    v = voices[(0, 44.0, 0)]
    before = float(eng.bank.energy(list(eng._slot_tuples[v])).sum())
    ev = Event(eng.time_in / eng.fs_in_exact, "note_on", 44, 1.0, 0, string=0)
    eng._note_on(ev, eng.time_in, eng._voice_key(ev), rest=True)
    assert float(eng.bank.energy(list(eng._slot_tuples[v])).sum()) == before
    while eng.time_out < int(1.3 * FS):          # the second pluck, on its resting voice
        eng.render_block(2400)
    assert eng.drone.n_plucks == 2 and dict(eng.by_key) == voices
    assert energies()[(0, 49.0, 1)] > 100.0 * late[(0, 49.0, 1)]


def test_the_same_key_stops_the_drone_and_the_strings_ring_on(presets):
    eng = build_engine(NAME, _short(presets))
    y = eng.render([on(0.0, 49), Event(0.2, "note_off", 49, 0.0), on(1.5, 49)],
                   duration_s=3.5)
    times = [t for t, *_ in plucks(eng)]
    assert len(times) == 7 and max(times) < 1.5      # cycles at 0 and 1 s, none after the key
    tail = y[int(2.5 * FS):]
    assert np.sqrt(np.mean(tail ** 2)) > 1e-3        # ringing out, not cut
    # pressed again it starts again, at its note-on
    eng = build_engine(NAME, _short(presets, timing_jitter_s=0))
    eng.render([on(0.0, 49), on(0.5, 49), on(0.75, 49)], duration_s=1.0)
    assert [round(t, 4) for t, *_ in plucks(eng)] == [0.0, 0.3, 0.45, 0.75]


def test_another_key_moves_sa_from_the_next_cycle(presets):
    eng = build_engine(NAME, _short(presets, timing_jitter_s=0))
    eng.render([on(0.0, 49), on(0.35, 51, ch=0)], duration_s=2.7)
    keys = [k for _, _, k, _ in plucks(eng)]
    assert keys[:4] == [44, 49, 49, 37]              # the cycle under way ends on the old Sa
    assert keys[4:12] == [46, 51, 51, 39] * 2
    assert eng.drone.key == 51
    # the old Sa pressed before the next cycle takes the move back
    eng = build_engine(NAME, _short(presets, timing_jitter_s=0))
    eng.render([on(0.0, 49), on(0.35, 51), on(0.5, 49)], duration_s=1.2)
    assert [k for _, _, k, _ in plucks(eng)][4] == 44 and eng.drone.running


def test_controllers_change_the_cycle_and_the_first_string_from_the_next_cycle(presets):
    eng = build_engine(NAME, _short(presets, timing_jitter_s=0))
    ev = [on(0.0, 49), Event(0.2, "control", 16, 64 / 127), Event(0.25, "control", 17, 40 / 127)]
    eng.render(ev, duration_s=5.5)
    p = plucks(eng)
    starts = [t for t, i, *_ in p if i == 0]
    L = D.cycle_from_cc(64 / 127)
    assert starts[:3] == pytest.approx([0.0, 1.0, 1.0 + L], abs=2 / eng.fs_in_exact)
    assert [k for _, i, k, _ in p if i == 0][:2] == [44, 42]       # Pa, then Ma
    # Reset All Controllers gives back the preset's cycle and first string
    eng.render_block(16)
    eng.schedule([Event(eng.time_out / FS, "control", 121, 0.0)])
    eng.render_block(16)
    assert (eng.drone.cycle_s, eng.drone.first) == (1.0, "Pa")


def test_all_sound_off_stops_the_drone(presets):
    eng = build_engine(NAME, _short(presets))
    eng.render([on(0.0, 49), Event(0.5, "control", 120, 0.0)], duration_s=1.6)
    assert not eng.drone.running and max(t for t, *_ in plucks(eng)) < 0.5


def test_a_restrike_drops_nothing_and_a_pluck_is_a_note_on_of_its_string(presets):
    """A pluck's event plays as any note-on would: restruck on its own voice,
    the other strings untouched (one engine plays the plucks as events, the
    other through the drone: the same samples)."""
    ev = [on(0.0, 49)]
    a_eng = build_engine(NAME, _short(presets, timing_jitter_s=0, force_jitter_db=0))
    a = a_eng.render(ev, duration_s=1.5)
    hist = list(a_eng.drone.history)
    b_eng = build_engine(NAME, _short(presets, timing_jitter_s=0, force_jitter_db=0,
                                      player="off"))
    b = b_eng.render([Event(s / b_eng.fs_in_exact, "note_on", k, v, 0, string=i)
                      for s, i, k, v in hist], duration_s=1.5)
    assert np.max(np.abs(a - b)) < 1e-12 * np.max(np.abs(a))


def test_live_play_gives_the_offline_render_s_samples(presets):
    """Through the live callback (synth play's path: events stamped on
    arrival, played at a constant latency), the drone's key, a controller and
    a move of Sa give the samples of the offline render of those events."""
    from synth.engine.realtime import Realtime

    class Clock:
        t = 0.0

        def __call__(self):
            return self.t

    arrivals = [(0.0131, on(0.0, 49)), (0.3, Event(0.0, "control", 17, 1.0)),
                (0.52, on(0.0, 47)), (0.9, Event(0.0, "note_off", 49, 0.0))]
    clock = Clock()
    eng = build_engine(NAME, _short(presets))
    rt = Realtime(eng, block=128, clock=clock, overload=None)
    rt.start(0.0)
    out, i = [], 0
    for b in range(int(2.2 * FS / 128)):
        clock.t = b * 128 / FS
        while i < len(arrivals) and arrivals[i][0] <= clock.t:
            rt.push(arrivals[i][1], arrivals[i][0])
            i += 1
        buf = np.zeros((128, 1), dtype=np.float32)
        rt.callback(buf, 128, None, None)
        out.append(buf[:, 0].copy())
    rt.stop()
    live = np.concatenate(out)
    off_eng = build_engine(NAME, _short(presets))
    offline = off_eng.render([Event(t + rt.latency_s, ev.kind, ev.key, ev.value)
                              for t, ev in arrivals],
                             duration_s=len(live) / FS, block=1000, compensate_latency=False)
    assert rt.stats.late_events == 0 and rt.stats.errors == 0
    assert list(eng.drone.history) == list(off_eng.drone.history)
    # the first string: Pa of Sa 49, then Sa (CC17 at 127) of Sa 47 from the next cycle
    assert [k for _, i, k, _ in plucks(eng) if i == 0][:2] == [44, 47]
    ref = offline[: len(live)].astype(np.float32)
    assert np.max(np.abs(live - ref)) <= 2 * np.max(np.spacing(np.abs(ref)))


# -- note names -----------------------------------------------------------------------


def test_note_names_parse_with_sharps_flats_and_octave():
    from synth.api.checks import check_key, key_of_name

    assert [key_of_name(n) for n in ("C4", "C#3", "Db3", "A4", "C-1", "G9", "Bb2", "c\u266f3",
                                      "D\u266d3", " e2 ")] == [60, 49, 49, 69, 0, 127, 46, 49,
                                                                49, 40]
    for bad in ("H3", "C", "C#", "3", "C##3", "Cx3", ""):
        assert key_of_name(bad) is None, bad
    assert check_key("--sa", "C#3", 12, 127) == 49
    assert check_key("--sa", "49", 12, 127) == 49 and check_key("--sa", 49, 12, 127) == 49
    for value, message in (
            ("H3", "--sa = 'H3' is not a MIDI key or a note name such as C#3 or Db3 "
                   "(12 <= key <= 127, C4 = 60)"),
            ("C-1", "--sa = C-1 (key 0) is out of range (12 <= key <= 127, C4 = 60)"),
            ("128", "--sa = 128 is out of range (12 <= key <= 127, C4 = 60)"),
            (11, "--sa = 11 is out of range (12 <= key <= 127, C4 = 60)"),
            (49.0, "--sa = 49.0 is not a MIDI key or a note name such as C#3 "
                   "(12 <= key <= 127, C4 = 60)"),
            (True, "--sa = True is not a MIDI key")):
        with pytest.raises(ValueError) as info:
            check_key("--sa", value, 12, 127)
        assert str(info.value).startswith(message), str(info.value)


# -- the loudness of what synth drone writes --------------------------------------------


@pytest.mark.parametrize("channels", [1, 2])
def test_integrated_loudness_block_by_block_is_pyloudnorm_s(channels):
    import pyloudnorm

    from synth.analysis.loudness import IntegratedLoudness

    rng = np.random.default_rng(4)
    for n in (FS * 3 + 1234, 20_000, FS * 2):
        x = rng.standard_normal((n, channels)) * np.linspace(0.01, 0.3, n)[:, None]
        x[: n // 3] *= 1e-3                        # a quiet stretch: the relative gate acts
        m = IntegratedLoudness(FS, channels)
        i = 0
        while i < n:
            b = int(rng.integers(1, 5000))
            m.add(x[i:i + b] if channels > 1 else x[i:i + b, 0])
            i += b
        want = pyloudnorm.Meter(FS).integrated_loudness(x if channels > 1 else x[:, 0])
        assert m.lufs() == pytest.approx(want, abs=1e-9)
    assert IntegratedLoudness(FS).lufs() == -np.inf


# -- synth drone ----------------------------------------------------------------------


@pytest.mark.slow   # a 20-s drone (about 3 s)
def test_synth_drone_writes_exactly_the_seconds_with_its_plucks_and_loudness(presets, tmp_path,
                                                                              capsys):
    import soundfile as sf

    from synth.analysis.loudness import loudness
    from synth.cli import main

    out = tmp_path / "drone.wav"
    rc = main(["drone", "--preset", NAME, "--sa", "C#3", "--pattern", "Pa Sa Sa Sa",
               "--cycle-s", "4", "--seconds", "20", "-o", str(out)])
    summary = capsys.readouterr().out.strip()
    assert rc == 0
    x, fs = sf.read(out)
    assert fs == FS and len(x) == 20 * FS                # 20 s exactly (target: 20 +- 0.5 s)
    plucks_ = int(re.search(r", (\d+) plucks,", summary)[1])
    assert plucks_ == 20 >= 12                            # 5 cycles of 4 strings
    lufs = float(re.search(r"(-?\d+\.\d) LUFS integrated", summary)[1])
    assert lufs == pytest.approx(loudness(x, fs)["integrated_lufs"], abs=0.051)
    assert "Sa C#3 (key 49)" in summary and summary.startswith(f"{out}: 20.0 s, a drone on")
    # the same command and seed: the same file; another seed: another file
    again = tmp_path / "again.wav"
    assert main(["drone", "--preset", NAME, "--sa", "49", "--cycle-s", "4", "--seconds", "20",
                 "-o", str(again)]) == 0
    assert np.array_equal(sf.read(again)[0], x)


@pytest.mark.parametrize("args, words", [
    (["--sa", "H3"], "--sa = 'H3' is not a MIDI key or a note name"),
    (["--sa", "C-1"], "--sa = C-1 (key 0) is out of range (12 <= key <= 127"),
    (["--sa", "49", "--cycle-s", "0.5"], "--cycle-s = 0.5 is out of range (1 <= value <= 16 s)"),
    (["--sa", "49", "--pattern", "Pa Sa"], "--pattern = 'Pa Sa' is not allowed (four tokens"),
    (["--sa", "49", "--seconds", "0"], "--seconds = 0.0 is out of range (0 < value <= 21600 s)"),
    (["--sa", "49", "--velocity", "0"], "--velocity = 0 is out of range (1 <= value <= 127)"),
    (["--sa", "49", "--seed", "-1"], "--seed = -1 is out of range (0 <= value <= 2147483647)"),
    (["--sa", "49", "--set", "drone.timing_jitter_s=1"],
     "drone.timing_jitter_s = 1 (from --set) is out of range (0 <= value <= 0.1)"),
    (["--sa", "49", "--preset", "sitar"], "sitar: the preset has no [drone] table"),
    (["--sa", "49", "--set", "drone.player=off"], "drone.player = 'off': synth drone needs 'on'"),
])
def test_synth_drone_bad_input_is_one_line_exit_2_and_no_file(presets, tmp_path, capsys, args,
                                                              words):
    from synth.cli import main

    out = tmp_path / "drone.wav"
    argv = ["drone", "--preset", NAME, "--seconds", "1", "-o", str(out)] + args
    rc = main(argv)
    err = capsys.readouterr().err
    assert rc == 2 and not out.exists()
    assert err.startswith("synth: error: ") and err.count("\n") == 1 and words in err, err
    # an output file already there is left as it was
    out.write_bytes(b"old")
    assert main(argv) == 2 and out.read_bytes() == b"old"


def test_render_drone_from_python(presets):
    import synth

    a = synth.render_drone(NAME, sa="C#3", seconds=1.2, cycle_s=1, seed=2)
    assert a.samples.shape == (int(1.2 * FS), 1) and a.fs == FS
    b = synth.render_drone(NAME, sa=49, seconds=1.2, cycle_s=1, seed=2)
    assert np.array_equal(a.samples, b.samples)
    with pytest.raises(ValueError, match=r"^cycle_s = 20 is out of range \(1 <= value <= 16 s\)$"):
        synth.render_drone(NAME, sa=49, cycle_s=20)
    with pytest.raises(ValueError, match=r"^sitar: the preset has no \[drone\] table"):
        synth.render_drone("sitar", sa=49)


# -- the end of a rendered file ---------------------------------------------------------


def _drone_file(end_s, key=49):
    """A MIDI file whose one key starts the drone at 0 and whose end of
    track comes at ``end_s`` (120 bpm, 480 ticks a beat)."""
    import mido

    mf = mido.MidiFile(ticks_per_beat=480)
    tr = mido.MidiTrack()
    mf.tracks.append(tr)
    tr.append(mido.Message("note_on", note=key, velocity=90, time=0))
    tr.append(mido.Message("note_off", note=key, velocity=64, time=48))        # at 0.05 s
    tr.append(mido.MetaMessage("end_of_track", time=int(round((end_s - 0.05) / 0.5 * 480))))
    return mf


@pytest.mark.slow  # over 2 s on a quiet 2-core machine (2026-11-29: 2.0-6.1 s)
def test_a_drone_left_running_plays_out_its_cycle_at_the_file_s_end(presets):
    """The drone runs to the file's end (its end of track, after the last
    event), plays out the cycle it is in, and the render ends once the
    strings have rung out, not at the 30 s limit; the engine alone ends it
    at the last event."""
    eng = build_engine(NAME, ["drone.cycle_s=1"])
    y = eng.render([on(0.0, 49)], drone_end_s=3.5)
    times = [t for t, *_ in plucks(eng)]
    # cycles at 0, 1, 2 and 3 s (4 plucks each within 0.6 s + jitter), none from 4 s
    assert eng.drone.n_cycles == 4 and len(times) == 16, times
    assert 3.0 <= max(times) < 3.7 and not eng.drone.running
    assert 4.0 < len(y) / eng.fs_out < 30.0
    # (without a file: the last event ends it, after its first cycle)
    eng = build_engine(NAME, ["drone.cycle_s=1"])
    eng.render([on(0.0, 49)])
    assert eng.drone.n_cycles == 1 and eng.drone.n_plucks == 4

    from synth.io.midi import read_mido_file

    events, _ = read_mido_file(_drone_file(3.5))
    assert events.length_s == pytest.approx(3.5, abs=1e-3) and events[-1].time_s < 0.06
    from synth.api import render_midi

    a = render_midi(_drone_file(3.5), NAME, set={"drone.cycle_s": 1})
    seconds = a.samples.shape[0] / a.fs
    assert 4.0 < seconds < 30.0, seconds
