"""Issue 41, items 2-3: the grand fitted to a recorded grand (layer v10 of
the Salamander Yamaha C5) and held out on the other layers.  The recording's
measures are stored as data (tests/data/salamander_issue41.json, with its
source and command), so these run without the npm samples."""

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf

from synth.apps.grand_study import LAYER_VELOCITY, OCTAVES, model_levels_db, octave_model, octave_table
from synth.io.factory import build_voice
from synth.physics import piano as P

ROOT = Path(__file__).resolve().parents[1]
DATA = json.loads((ROOT / "tests" / "data" / "salamander_issue41.json").read_text())


def _real(layer):
    return {int(k): v for k, v in DATA["layers"][str(layer)].items()}


def test_the_stored_recording_has_every_layer_and_key():
    """Layers 4, 10, 14, each C2-C8 every minor third (25 keys), each key
    with the four measures; the recording's own figures of the lab note
    (docs/lab/2026-11-29-fit41.md: C4-B4's centroid 819 Hz, C7-C8's
    partial 1 at 3 s -68 dB on v10)."""
    assert set(DATA["layers"]) == {"4", "10", "14"} and "CC BY 3.0" in DATA["source"]
    for layer in (4, 10, 14):
        real = _real(layer)
        assert sorted(real) == list(range(36, 109, 3))
        assert all(set(m) == {"p1_3s_db", "upper_db", "centroid_hz", "peak_ms"} for m in real.values())
    real = _real(10)
    med = lambda lo, hi, m: float(np.median([real[k][m] for k in real if lo <= k <= hi]))
    assert med(60, 71, "centroid_hz") == pytest.approx(819, abs=1)
    assert med(96, 108, "p1_3s_db") == pytest.approx(-68, abs=1)
    # the centroid over 0-10 kHz (CENTROID_MAX_HZ, the samples' Vorbis
    # bandwidth; docs/lab/2026-11-29-attack41.md): C8's 1863 Hz over 0-24 kHz
    assert med(96, 108, "centroid_hz") == pytest.approx(1851, abs=1)


def test_the_treble_loss_ramps_in_over_half_an_octave():
    """``strings.t60_treble_scale`` (0.65 here): the strings' own T60
    times 1 up to key 78, log-linear to 0.65 at 84, then on by
    ``strings.t60_top_factor`` (0.7 here), log-linear from 1 at 84 to it
    at C8; the defaults (1) change no key; ``bridge_coupling_treble``
    divides the bridge's resistance by its factor over the same ramp (the
    preset's 0.75).  The preset has 0.45 from key 84 on, flat (C6-B6's partial 1 at 3 s 14 dB
    over the recording's with 0.65 and 0.7, 8 with it, 10 with the bridge's 0.75)."""
    shipped = build_voice("grand-piano")
    assert shipped.own_t60_factor(84) == pytest.approx(0.45)
    assert shipped.own_t60_factor(108) == pytest.approx(0.45)
    v = build_voice("grand-piano", ["strings.t60_treble_scale=0.65", "strings.t60_top_factor=0.7"])
    assert v.own_t60_factor(78) == 1.0 and v.own_t60_factor(84) == pytest.approx(0.65)
    assert v.own_t60_factor(81) == pytest.approx(math.sqrt(0.65))
    assert v.own_t60_factor(96) == pytest.approx(0.65 * math.sqrt(0.7))
    assert v.own_t60_factor(108) == pytest.approx(0.65 * 0.7)
    flat = build_voice("grand-piano", ["strings.t60_treble_scale=0.65", "strings.t60_top_factor=1"])
    assert flat.own_t60_factor(108) == pytest.approx(0.65) and flat.own_t60_factor(81) == v.own_t60_factor(81)
    off = build_voice("grand-piano", ["strings.t60_treble_scale=1", "strings.t60_top_factor=1"])
    assert all(off.own_t60_factor(k) == 1.0 for k in range(21, 109))
    assert off._free_string_t60_s(96) == P.single_string_t60_s(96)
    assert v._free_string_t60_s(96) < P.single_string_t60_s(96)
    one = build_voice("grand-piano", ["strings.bridge_coupling_treble=1"])
    c = build_voice("grand-piano", ["strings.bridge_coupling_treble=2"])
    assert c.bridge_resistance_ns_per_m(96) == pytest.approx(one.bridge_resistance_ns_per_m(96) / 2)
    assert c.bridge_resistance_ns_per_m(60) == one.bridge_resistance_ns_per_m(60)
    # the preset's 0.75 (the knees of keys 81, 85 and 87, docs/lab/2026-12-02-board-spread.md):
    # full from key 84, half of it (in log) at 81, none at 78 and below
    R = shipped.bridge_resistance_ns_per_m
    assert R(96) == pytest.approx(one.bridge_resistance_ns_per_m(96) / 0.75)
    assert R(81) == pytest.approx(one.bridge_resistance_ns_per_m(81) / 0.75 ** 0.5)
    assert R(78) == one.bridge_resistance_ns_per_m(78) and R(60) == one.bridge_resistance_ns_per_m(60)


def test_the_treble_unisons_beat_at_most_the_stated_rate():
    """``strings.unison_spread_hz`` (1.8 in the preset, the law's 0.6 Hz
    by default): a unison's outer strings differ by at most 0.6 cent and at
    most that many Hz.  Below about A6 the cent limit holds either way and
    the detuning is the law's exactly (the keys' tuning is unchanged); above
    it (from A6, key 93) the spread widens up to 0.6 cent (C8: 0.25 -> 0.6 cent)."""
    v = build_voice("grand-piano")
    law = build_voice("grand-piano", ["strings.unison_spread_hz=0.6"])
    assert v.unison_spread_hz == 1.8 and law.unison_spread_hz == 0.6
    for k in range(21, 109):
        g = P.grand_string(k)                     # the per-key data: the law's 0.6 Hz
        n = len(g.unison_detune_cents)
        assert P.unison_detune_cents(k, n, law.unison_spread_hz) == g.unison_detune_cents
        if k < 93:
            assert P.unison_detune_cents(k, n, v.unison_spread_hz) == g.unison_detune_cents
    assert P.unison_spread_cents(96) == pytest.approx(1200 / math.log(2) * 0.6 / P.et_f0_hz(96))
    assert P.unison_spread_cents(108) == pytest.approx(0.248, abs=1e-3)
    assert P.unison_spread_cents(108, 1.8) == 0.6
    for k in (96, 108):
        d = P.unison_detune_cents(k, 3, v.unison_spread_hz)
        assert d == pytest.approx((-0.33, 0.0, 0.27))       # 0.6 cent: -0.55 s, 0, +0.45 s
    # the strings the voice designs follow it: key 96's outer strings 0.6
    # cent apart with the preset, 0.496 with the law; key 60's 0.6 either way
    for key, voice, spread in ((96, v, 0.6), (96, law, P.unison_spread_cents(96)),
                               (60, v, 0.6), (60, law, 0.6)):
        f = [su.f1_hz for su in voice.setup(key)]
        assert 1200 * math.log2(max(f) / min(f)) == pytest.approx(spread, abs=1e-9)


@pytest.fixture(scope="module")
def grand_v10():
    """The shipped grand on the recorded keys, close position, v10's matched
    velocity, 4 s: key -> issue 41's measures (tests/conftest.py keeps this
    module on one worker, so it is rendered once)."""
    return octave_model(sorted(_real(10)), "close", LAYER_VELOCITY[10], seconds=4.0)


@pytest.mark.slow  # 25 grand notes of 4 s: about 12 s of CPU
def test_the_fitted_targets_hold_against_the_stored_recording(grand_v10):
    """The per-octave medians against layer v10 (close position, the grand
    at v10's matched velocity, 78) that meet issue 41's targets: partial 1
    at 3 s within 6 dB over C2-B5 (C3-B5 -1.0 to +1.7 dB with the strings'
    second polarization, ``strings.polarization``; -10 to -12 without it,
    docs/lab/2026-11-30-polarization.md) and at most 10 dB above the recording's
    over C7-C8 (+2 dB: the treble's loss and its unisons' spread, fitted
    together; +30 before); partials 2-10 within 6 dB over C3-B3, C4-B4 and
    C6-B6 (C6-B6 -5.4 dB with the board's mass law, ``body.mass_hz``: -6.5
    at 2 kHz); the first 50 ms's centroid within 1.5x on every octave
    (1.06-1.18x with the board's mass law, docs/lab/2026-12-03-board-mass.md;
    1.27-1.39x with the softer felt, docs/lab/2026-11-30-felt41.md; 1.49-2.27x
    at velocity 105 with the felt before; 1.33-1.46x with the board's
    spread); the time
    to the RMS peak within a factor of 2 on every octave (the board's
    spread, ``body.spread_ms``: C5-B5 21 ms against the recording's 19,
    C7-C8 15 against 15; 9 and 6 without it).  What the fits gained without
    meeting the target at first: C6-B6's partial 1 at 3 s +18 -> +14 dB, as
    a stronger loss there took key 87's knee (docs/lab/2026-11-30-treble.md);
    +8 with the treble's loss of 2026-12-01, which took the knees of keys
    81, 85 and 87; +9.8 with the treble unisons' bridge at 0.75
    (``strings.bridge_coupling_treble``), which gives them back
    (docs/lab/2026-12-02-board-spread.md): now within the target's +10."""
    real = _real(10)
    rows = {r["octave"]: r for r in octave_table(grand_v10, real)}
    assert [r for r in rows] == [o for o, _, _ in OCTAVES]
    for o in ("C2-B2", "C3-B3", "C4-B4", "C5-B5"):
        assert abs(rows[o]["p1_3s_db"]) <= 6.0, (o, rows[o]["p1_3s_db"])
    for o in ("C3-B3", "C4-B4", "C6-B6"):
        assert abs(rows[o]["upper_db"]) <= 6.0, (o, rows[o]["upper_db"])
    assert rows["C7-C8"]["p1_3s_db"] <= 10.0 and rows["C6-B6"]["p1_3s_db"] <= 10.0
    for o, r in rows.items():
        assert r["centroid_ratio"] <= 1.5, (o, r["centroid_ratio"])
    for o, r in rows.items():
        assert r["peak_ms_real"] / 2 <= r["peak_ms_model"] <= 2 * r["peak_ms_real"], (o, r)


@pytest.mark.slow  # 40 grand notes of 1 s: about 8 s of CPU
def test_each_layer_is_matched_by_its_step_in_loudness_from_fortissimo():
    """:data:`LAYER_VELOCITY`: the grand at each layer's velocity is as far
    under its velocity 127 as the layer is under the library's loudest (v16),
    within 0.5 dB (maximum momentary loudness, medians over ten keys; the
    recording's steps stored with their command).  The library's own SFZ
    plays v10 at velocities 73-80 and v14 at 105-112."""
    rec = {int(k): v for k, v in DATA["layer_levels"]["re_v16_db"].items()}
    model = model_levels_db(sorted(LAYER_VELOCITY.values()), seconds=1.0)
    for layer, v in LAYER_VELOCITY.items():
        assert model[v] == pytest.approx(rec[layer], abs=0.5), (layer, v, model[v], rec[layer])
    assert 73 <= LAYER_VELOCITY[10] <= 80 and 105 <= LAYER_VELOCITY[14] <= 112


@pytest.mark.slow  # 25 grand notes of 0.6 s (and the targets' 25 of 4 s)
def test_the_knock_sets_the_time_to_the_rms_peak(grand_v10):
    """The time to the RMS peak follows the knock (``action.knock``).  One
    5 ms pulse (the preset's knock before, 3.9, and without the board's
    spread) peaked every octave within 8 ms.  The knock built up over 20 ms (the preset: 2 ms pushes, the
    thump's build-up and its reach to 1 kHz fitted to the recording's)
    peaks C3-B3 and C4-B4 within a factor of 2 of the recording's v10 (30 /
    28 ms against 35 / 26), and its first 50 ms are darker: C7-C8's
    centroid within 1.5x of the recording's (1.20x; 1.65x with the pulse),
    no octave's higher than with the pulse and on average lower.
    docs/lab/2026-11-29-jack-xruns-and-ci.md, "The knock built up".
    Both measures read the first 0.5 s after the onset: notes of 0.6 s give
    the figures of 1 s notes to the last digit (2026-11-30), so the shipped
    knock is read on the targets' 4 s notes (``grand_v10``)."""
    real = _real(10)
    keys = sorted(real)
    # the pulse as it was, before the board's spread too (body.spread_ms)
    pulse = ["action.knock=3.9", "action.knock_s=0.005", "action.knock_build_s=0", "body.spread_ms=0"]
    rows_p = octave_table(octave_model(keys, "close", LAYER_VELOCITY[10], seconds=0.6,
                                       overrides=pulse), real)
    rows_b = octave_table(grand_v10, real)
    for r in rows_p:
        assert r["peak_ms_model"] <= 8.0, ("pulse", r["octave"], r["peak_ms_model"])
    built = {r["octave"]: r for r in rows_b}
    for o in ("C3-B3", "C4-B4"):
        r = built[o]
        assert r["peak_ms_real"] / 2 <= r["peak_ms_model"] <= 2 * r["peak_ms_real"], (o, r)
    assert built["C7-C8"]["centroid_ratio"] <= 1.5
    # (C2-B2 alike within 0.02 % since the board's mass law, body.mass_hz,
    # takes the treble off both knocks)
    for rp in rows_p:
        assert built[rp["octave"]]["centroid_ratio"] < 1.002 * rp["centroid_ratio"], rp["octave"]
    assert np.mean([built[rp["octave"]]["centroid_ratio"] / rp["centroid_ratio"] for rp in rows_p]) < 0.99


def _run(*argv):
    return subprocess.run([sys.executable, str(ROOT / "tools" / "real_grand.py"), *argv],
                          capture_output=True, text=True, cwd=ROOT, timeout=600)


def _c4(folder, layer):
    """A synthetic C4 of ``layer``: partials 1-3, falling 60 dB in 2 s."""
    fs = 44_100
    t = np.arange(int(6.0 * fs)) / fs
    env = np.exp(-math.log(1000.0) * t / 2.0) * np.minimum(t / 0.002, 1.0)
    y = 0.3 * env * sum(a * np.sin(2 * np.pi * n * 261.63 * t) for n, a in ((1, 1.0), (2, 0.5), (3, 0.25)))
    d = folder / f"piano-velocity{layer}" / "audio"
    d.mkdir(parents=True)
    sf.write(str(d / f"C4v{layer}.ogg"), np.c_[y, y], fs)


@pytest.mark.slow  # renders a 6 s grand note
def test_held_out_v4_is_reported_at_its_matched_velocity(tmp_path):
    """``--layer 4``: the table of layer v4, marked held out, the grand at
    v4's matched velocity (52)."""
    _c4(tmp_path, 4)
    out = tmp_path / "t.json"
    p = _run(str(tmp_path), "--octaves", "--layer", "4", "--positions", "body", "--json", str(out))
    assert p.returncode == 0, p.stderr
    assert "layer v4 (held out: the grand was fitted on v10), the grand at velocity 52" in p.stdout
    assert "| C4-B4 |" in p.stdout
    data = json.loads(out.read_text())
    assert data["layer"] == 4 and data["velocity"] == 52 and list(data["body"]["model"]) == ["60"]


@pytest.mark.slow  # three subprocesses
def test_a_bad_velocity_or_change_is_a_one_line_error(tmp_path):
    _c4(tmp_path, 10)
    for argv, words in ((["--velocity", "0"], "--velocity = 0 is out of range (1 <= value <= 127)"),
                        (["--set", "strings.t60_treble_scale=9"],
                         "strings.t60_treble_scale = 9 (from --set) is out of range")):
        p = _run(str(tmp_path), "--octaves", *argv)
        assert p.returncode == 2 and words in p.stderr
        assert len(p.stderr.strip().splitlines()) == 1
