"""The listening position (issue 41): design laws, the kernel against a slow
reference, block-size independence, distance, air, reverberation, errors."""

import math

import numpy as np
import pytest
import soundfile

from helpers import engine, note
from synth.cli import main
from synth.dsp.listener import Listener
from synth.physics.listener import (
    ROOMS, T60_HZ, air_absorption_db_per_m, design_listener, image_sources, room_t60_s)

FS = 48_000


def _reference(L: Listener, x: np.ndarray) -> np.ndarray:
    """The module docstring's equations of synth.kernels.listener, sample by
    sample in plain Python over the wrapper's arrays (no ring tricks)."""
    C, n = x.shape
    hd, he, le, ge, pre = L._hd, L._he, L._le, L._ge, L._pre
    lens, fa, fb, fin, fout = L._lens, L._fa, L._fb, L._fin, L._fout
    N = len(lens)
    W = np.array([[(-1) ** bin(i & j).count("1") for j in range(N)] for i in range(N)], float)
    xp = np.concatenate([np.zeros((C, 10_000)), x], axis=1)      # x[n - k] = 0 before the start
    o = 10_000
    e = np.zeros((C, n + o))
    v = {j: [0.0] * (n + o) for j in range(N)}
    z = np.zeros(N)
    y = np.zeros((C, n))
    for i in range(n):
        t = i + o
        u = sum(xp[c, t - pre] for c in range(C)) / C
        s = np.array([v[j][t - lens[j]] for j in range(N)])
        z = fa * s + fb * z
        fb_in = (W @ z) / math.sqrt(N) + fin * u
        for j in range(N):
            v[j][t] = fb_in[j] if abs(fb_in[j]) >= 1e-30 else 0.0
        for c in range(C):
            d = sum(hd[k] * xp[c, t - k] for k in range(len(hd)))
            e[c, t] = sum(ge[c, k] * xp[c, t - le[c, k]] for k in range(le.shape[1]))
            ef = sum(he[k] * e[c, t - k] for k in range(len(he)))
            y[c, i] = d + ef + float(fout[c] @ z)
    return y


def test_the_kernel_is_its_equations():
    """A small room, two channels, noise then silence: the kernel against the
    slow reference, to round-off."""
    L = Listener.design(FS, 2, "player", room="room")
    x = np.zeros((2, 2500))
    x[:, :300] = np.random.default_rng(3).standard_normal((2, 300))
    ref = _reference(L, x)
    y = L.process(x)
    assert np.max(np.abs(y - ref)) < 1e-12 * np.max(np.abs(ref))
    assert np.max(np.abs(y[:, 1500:])) > 1e-3 * np.max(np.abs(y))   # the reverberation is in it



def test_lines_shorter_than_a_segment_keep_the_equations():
    """The kernel takes a block in segments of up to SEGMENT samples and
    the shortest line's length (a line is never read after its write within
    a segment): lines of 37-67 samples, under SEGMENT, in blocks of 1000,
    against the slow reference."""
    from synth.kernels.listener import SEGMENT

    L = Listener.design(FS, 2, "player", room="room")
    lens = np.array([37, 41, 43, 47, 53, 59, 61, 67], dtype=np.int64)
    assert len(lens) == len(L._lens) and lens.max() < SEGMENT
    L._lens = lens
    L._off = np.concatenate([[0], np.cumsum(lens)[:-1]]).astype(np.int64)
    L._lines = np.zeros(int(lens.sum()))
    L.reset()
    x = np.zeros((2, 3000))
    x[:, :200] = np.random.default_rng(5).standard_normal((2, 200))
    ref = _reference(L, x)
    y = np.concatenate([L.process(np.ascontiguousarray(x[:, i:i + 1000])) for i in (0, 1000, 2000)],
                       axis=1)
    assert np.max(np.abs(y - ref)) < 1e-12 * np.max(np.abs(ref))
    assert np.max(np.abs(y[:, 2000:])) > 1e-6 * np.max(np.abs(y))

@pytest.mark.parametrize("position", ["close", "hall"])
def test_blocks_of_any_size_give_the_same_samples(position):
    L = Listener.design(FS, 2, position)
    x = np.random.default_rng(1).standard_normal((2, 20_000))
    one = L.process(x)
    L.reset()
    rng = np.random.default_rng(2)
    out = np.empty_like(x)
    i = 0
    while i < x.shape[1]:
        n = int(rng.integers(1, 700))
        L.process(x[:, i:i + n], out=out[:, i:i + n])
        i += n
    assert np.array_equal(out, one)


def test_an_engine_with_a_listener_renders_the_same_for_any_block_size():
    evs = note(50, 0.0123, 0.9, off=0.2) + note(57, 0.0311, 0.6) + note(62, 0.1507, 1.0)
    ys = [engine("sitar", ["listener.position=hall"]).render(evs, duration_s=0.4, block=b)
          for b in (37, 128, 1000)]
    for y in ys[1:]:
        assert np.max(np.abs(y - ys[0])) < 1e-12 * np.max(np.abs(ys[0]))


def _band_db(h, fc, fs=FS):
    """Mean power (dB) of the impulse response ``h`` in the octave around ``fc``."""
    nfft = 1 << max(16, (len(h) - 1).bit_length())
    p = np.abs(np.fft.rfft(h, nfft)) ** 2
    f = np.fft.rfftfreq(nfft, 1.0 / fs)
    sel = (f >= fc / math.sqrt(2)) & (f < fc * math.sqrt(2))
    return 10 * np.log10(p[sel].mean())


def _direct(distance_m, room="none", **kw):
    L = Listener.design(FS, 1, "close", room=room, distance_m=distance_m, level="distance", **kw)
    return L._ir(4096, late=False, early=False, direct=True)[0, 0]


def test_a_distance_doubled_lowers_the_direct_sound_by_6_db():
    for r in (0.5, 2.0, 8.0):
        a, b = _direct(r), _direct(2 * r)
        drop = _band_db(a, 250) - _band_db(b, 250)
        # the inverse-distance law (6.02 dB) and the air over r more metres (< 0.01 dB at 250 Hz)
        assert drop == pytest.approx(20 * math.log10(2), abs=0.02)


def test_the_airs_high_frequency_loss_grows_with_distance_as_iso_9613_says():
    loss = []
    for r in (1.0, 5.0, 20.0, 40.0):
        h = _direct(r, directivity_db=0.0)
        loss.append(_band_db(h, 500) - _band_db(h, 8000))
    assert all(b > a + 0.3 for a, b in zip(loss, loss[1:]))
    # 40 m against 1 m: 39 m of air at 8 kHz less at 500 Hz (ISO 9613-1, 20 C, 50 %)
    iso = 39 * (air_absorption_db_per_m(8000.0) - air_absorption_db_per_m(500.0))
    assert loss[-1] - loss[0] == pytest.approx(iso, abs=1.0)


def test_the_air_absorption_is_iso_9613s():
    """ISO 9613-2:1996 table 2 (from part 1's formula), 20 C, 70 %: 5.0, 22.9,
    76.6 dB/km at 1, 4, 8 kHz; 10 C, 70 %: 3.7, 32.8, 117."""
    got = air_absorption_db_per_m(np.array([1000.0, 4000.0, 8000.0]), 20.0, 70.0) * 1000
    assert got == pytest.approx([5.0, 22.9, 76.6], rel=0.02)
    got = air_absorption_db_per_m(np.array([1000.0, 4000.0, 8000.0]), 10.0, 70.0) * 1000
    assert got == pytest.approx([3.7, 32.8, 117.0], rel=0.02)


def test_image_sources_of_a_box():
    """The first-order images of a source in a box: six, each at the mirrored
    distance (the floor's: source and listener heights summed)."""
    imgs = image_sources((10.0, 8.0, 4.0), (3.0, 4.0, 1.0), (6.0, 4.0, 1.5), order=1)
    assert imgs[0] == (pytest.approx(math.dist((3, 4, 1), (6, 4, 1.5))), 0)
    first = sorted(d for d, n in imgs if n == 1)
    assert len(first) == 6
    assert min(first) == pytest.approx(math.hypot(3.0, 2.5))        # the floor


def _schroeder_t60(h, fc, fs=FS):
    """T60 (s) of ``h`` in the octave around ``fc``: Schroeder's backward
    integral, the line fitted from -5 to -25 dB (T20)."""
    from scipy.signal import butter, sosfilt

    sos = butter(4, [fc / math.sqrt(2), fc * math.sqrt(2)], "bandpass", fs=fs, output="sos")
    y = sosfilt(sos, h)
    edc = np.cumsum((y ** 2)[::-1])[::-1]
    db = 10 * np.log10(edc / edc.max())
    i = np.flatnonzero((db <= -5) & (db >= -25))
    return -60.0 / np.polyfit(i / fs, db[i], 1)[0]


def _late_t60(L, fc):
    h = L._ir(int((L.tail_s * 1.2 + 0.2) * FS), late=True, early=False, direct=False)[0, 0]
    return _schroeder_t60(h, fc)


@pytest.mark.parametrize("room", ["studio", "hall"])
def test_the_reverberation_decays_as_the_room_is_designed(room):
    """The network's T60 at 500 Hz and 4 kHz (its impulse response, Schroeder's
    integral, -5 to -25 dB) within 10 % of Eyring's for the room."""
    L = Listener.design(FS, 1, "hall", room=room)
    for fc in T60_HZ:
        assert _late_t60(L, fc) == pytest.approx(float(room_t60_s(ROOMS[room], fc)), rel=0.10)


def test_a_measured_room_drives_the_reverberation(tmp_path):
    """A synthetic impulse response (a direct impulse, then noise decaying with
    T60 = 1.4 s): the listener's reverberation decays with the file's T60."""
    rng = np.random.default_rng(5)
    t = np.arange(int(2.5 * FS)) / FS
    h = rng.standard_normal(t.size) * 10 ** (-3 * t / 1.4) * 0.05
    h[:int(0.01 * FS)] = 0.0
    h[0] = 1.0
    p = tmp_path / "ir.wav"
    soundfile.write(str(p), h, FS, subtype="FLOAT")
    import synth.dsp.listener as LM

    n = len(LM._CALIBRATIONS)
    L = Listener.design(FS, 1, "hall", room=str(p))
    assert len(LM._CALIBRATIONS) == n          # a file's calibration is not kept: it may change
    assert L.design.t60_s == pytest.approx((1.4, 1.4), rel=0.1)
    assert _late_t60(L, 1000.0) == pytest.approx(1.4, rel=0.15)


def test_matched_level_holds_across_positions():
    """With level = "matched" every position has the same mean power gain
    over the octaves 125 Hz - 4 kHz (1)."""
    for pos in ("close", "player", "hall"):
        L = Listener.design(FS, 2, pos)
        n = int(L.tail_s * 1.2 * FS) + 4096
        h = L._ir(n, True, True, True)
        p = (np.abs(np.fft.rfft(h, 1 << 19)) ** 2).sum(axis=1).mean(axis=0)
        f = np.fft.rfftfreq(1 << 19, 1 / FS)
        m = np.mean([p[(f >= fc / math.sqrt(2)) & (f < fc * math.sqrt(2))].mean()
                     for fc in (125, 250, 500, 1000, 2000, 4000)])
        assert 10 * np.log10(m) == pytest.approx(0.0, abs=0.05)


def test_the_position_sets_the_direct_to_reverberant_ratio():
    """Farther is more room: the direct sound's share of the 500 Hz octave falls
    from close to hall (at 12 m, beyond the hall's critical distance of 5.4 m,
    the room is the louder)."""
    ratios = []
    for pos in ("close", "player", "hall"):
        L = Listener.design(FS, 1, pos, level="distance")
        d = L._ir(4096, False, False, True)[0, 0]
        r = L._ir(int(L.tail_s * 1.2 * FS), True, True, False)[0, 0]
        ratios.append(_band_db(d, 500) - _band_db(r, 500))
    assert ratios[0] > ratios[1] > ratios[2]
    assert ratios[0] > 3.0 and ratios[2] < -3.0


@pytest.mark.parametrize("setting, words", [
    ("listener.position=stage", ['listener.position = "stage"', '"close", "player", "hall"']),
    ("listener.distance_m=80", ["listener.distance_m = 80", "0.1 <= value <= 50"]),
    ("listener.humidity_percent=2", ["listener.humidity_percent = 2", "5 <= value <= 100"]),
    ("listener.level=loud", ['listener.level = "loud"', '"matched", "distance"']),
    ("listener.room=no-such-room.wav", ["listener.room = 'no-such-room.wav'", "none, studio, room, hall"]),
])
def test_bad_listener_values_are_one_line_errors(tmp_path, capsys, setting, words):
    rc = main(["note", "grand-piano", "--key", "60", "--seconds", "0.05", "--set", setting,
               "-o", str(tmp_path / "x.wav")])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and "\n" not in err and err.startswith("synth: error:")
    for w in words:
        assert w in err


def test_the_wrapper_names_a_bad_value():
    with pytest.raises(ValueError, match=r"^listener.distance_m = 0.01 m is out of range \(0.1 <= value <= 50\)$"):
        Listener.design(FS, 2, "close", distance_m=0.01)
    with pytest.raises(ValueError, match=r"^listener.position = 'far' is not one of close, player, hall$"):
        Listener.design(FS, 2, "far")


def test_without_a_room_the_stage_is_the_direct_sound_alone():
    d = design_listener(FS, 2, "close", room="none")
    assert d.fdn_len.size == 0 and d.early_lag.size == 0
    L = Listener(d)
    assert L.tail_s == 0.0
    h = L._ir(2048, True, True, True)
    assert np.all(h[0, 1] == 0.0) and np.all(h[0, 0, 200:] == 0.0)


def test_a_block_allocates_no_samples():
    """The live callback's rule: with ``out`` given, a block allocates no
    array (a 1024-sample stereo block is 16 kB; the views' headers are not)."""
    import tracemalloc

    L = Listener.design(FS, 2, "hall")
    x = np.random.default_rng(0).standard_normal((2, 1024))
    L.process(x, out=x)
    tracemalloc.start()
    for _ in range(50):
        L.process(x, out=x)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert peak < 4096


def test_an_offline_render_waits_for_the_rooms_reverberation():
    """Rendered until the notes are silent, a render from the hall lasts the
    room's ring longer than one without a listener."""
    evs = note(57, 0.0, 0.8, off=0.1)
    dry = engine("sitar").render(evs, block=1024)
    hall = engine("sitar", ["listener.position=hall"])
    wet = hall.render(evs, block=1024)
    extra = (len(wet) - len(dry)) / FS
    assert extra == pytest.approx(hall.listener.tail_s, abs=1024 / FS + 1e-9)
    assert hall.listener.tail_s > 1.5


def test_a_named_rooms_calibration_is_kept_and_gives_the_same_stage():
    """A second stage of the same design takes the first's calibration (no
    impulse responses rendered again) and is the same stage, sample for
    sample; a measured room (a WAV file, which may change) is not kept."""
    import synth.dsp.listener as L

    L._CALIBRATIONS.clear()
    a = L.Listener.design(48_000, 2, "player")
    assert len(L._CALIBRATIONS) == 1
    calls = []
    orig = L.Listener._ir
    try:
        L.Listener._ir = lambda self, *args, **kw: calls.append(1) or orig(self, *args, **kw)
        b = L.Listener.design(48_000, 2, "player")
    finally:
        L.Listener._ir = orig
    assert calls == [] and (a.late_scale, a.level_scale) == (b.late_scale, b.level_scale)
    x = np.random.default_rng(3).standard_normal((2, 2000))
    assert np.array_equal(a.process(x.copy()), b.process(x.copy()))
    L._CALIBRATIONS.clear()
    c = L.Listener.design(48_000, 2, "player")
    c.reset()
    a.reset()
    assert np.array_equal(a.process(x.copy()), c.process(x.copy()))


def test_a_calibration_is_kept_on_disk_for_the_next_process(tmp_path, monkeypatch):
    """With a store (the engine gives the design store), a stage's scales
    are saved, and a later process (the per-process memo emptied) applies
    them without measuring its impulse responses again: the same stage to
    the bit.  A store holding something else is ignored."""
    from synth.dsp import listener as LM
    from synth.voices import design_store

    monkeypatch.setenv(design_store.ENV, str(tmp_path))
    monkeypatch.setattr(LM, "_CALIBRATIONS", {})
    a = Listener.design(48_000, 2, "player", store=design_store)
    assert list(tmp_path.glob("listener-*.pkl"))
    monkeypatch.setattr(LM, "_CALIBRATIONS", {})

    def no_ir(*args, **kwargs):
        raise AssertionError("measured again")

    monkeypatch.setattr(Listener, "_ir", no_ir)
    b = Listener.design(48_000, 2, "player", store=design_store)
    assert (b.late_scale, b.level_scale) == (a.late_scale, a.level_scale)
    x = np.random.default_rng(3).standard_normal((2, 4801))[:, :4800]
    ya, yb = np.zeros((2, 4801))[:, :4800], np.zeros((2, 4801))[:, :4800]
    a.reset()
    a.process(x, out=ya)
    b.process(x, out=yb)
    assert np.array_equal(ya, yb)
    # something else under that name (another program's pickle): measured anew
    monkeypatch.setattr(LM, "_CALIBRATIONS", {})
    design_store.save("listener", (48000.0, 2, "player", None, None, None, 20.0, 50.0,
                                   "matched"), "not scales")
    with pytest.raises(AssertionError, match="measured again"):
        Listener.design(48_000, 2, "player", store=design_store)
