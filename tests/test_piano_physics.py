"""Concert-grand physics data: strings, hammers, stretch tuning (synth.physics.piano)."""

import math
from dataclasses import replace

import numpy as np
import pytest

from synth.physics import piano as P
from synth.physics.piano import (
    GrandString, grand_piano_strings, grand_string, hammer_four_param, hammer_mass_kg,
    hammer_three_param, octave_stretch_cents, string_f0_for_partial1, stretch_curve_cents,
    stretched_f0_hz, thesis_key,
)

MIDIS = np.arange(21, 109)
STR = grand_piano_strings()


def cents(a, b):
    return 1200.0 * np.log2(np.asarray(a, float) / np.asarray(b, float))


def et(m, a4=440.0):
    return a4 * 2.0 ** ((np.asarray(m, float) - 69) / 12)


def col(name):
    return np.array([getattr(s, name) for s in STR], dtype=float)


# ------------------------------------------------------------------ keys

def test_thesis_key_numbering():
    assert thesis_key(21) == 1 and thesis_key(108) == 88 and thesis_key(105) == 85
    for bad in (20, 109, 60.5, "x"):
        with pytest.raises(ValueError, match="midi"):
            thesis_key(bad)


def test_table_has_88_keys_in_order_and_is_cached():
    assert len(STR) == 88
    assert [s.midi for s in STR] == list(MIDIS)
    assert grand_piano_strings() is STR
    assert grand_string(60) is STR[39]


# ------------------------------------------------------------------ strings

def test_string_fundamental_is_equal_tempered():
    f0 = np.array([s.f0_hz for s in STR])
    assert np.max(np.abs(cents(f0, et(MIDIS)))) < 0.01
    # c / 2L recomputed from the raw fields
    c = np.sqrt(col("tension_n") / col("linear_density_kg_per_m"))
    assert np.max(np.abs(cents(c / (2 * col("speaking_length_m")), et(MIDIS)))) < 0.01


def test_a7_matches_the_thesis_study_string():
    s = grand_string(105)
    assert s.f0_hz == pytest.approx(3520.0, rel=1e-9)
    assert s.speaking_length_m == pytest.approx(0.061, rel=1e-3)
    assert s.linear_density_kg_per_m == pytest.approx(4.2e-3, rel=1e-3)
    assert s.tension_n == pytest.approx(774.6, rel=1e-3)
    assert s.mass_kg == pytest.approx(0.26e-3, rel=0.02)
    assert s.strike_distance_m == pytest.approx(2.6e-3, abs=0.01e-3)
    assert s.n_strings == 3 and s.has_capo and not s.has_damper and not s.wound


def test_plain_strings_are_steel_wire_and_wound_strings_heavier_than_core():
    rho = P.STEEL_DENSITY_KG_PER_M3
    core_mu = rho * math.pi * col("core_diameter_m") ** 2 / 4
    mu = col("linear_density_kg_per_m")
    wound = col("wound").astype(bool)
    assert np.allclose(mu[~wound], core_mu[~wound], rtol=1e-12)
    assert np.all(mu[wound] > 1.15 * core_mu[wound])
    assert np.all(col("youngs_modulus_pa") == 2.0e11)


def test_tension_and_wire_stress_are_realistic():
    T = col("tension_n")
    assert np.all((T > 600) & (T < 1400))
    stress = T / (math.pi * col("core_diameter_m") ** 2 / 4)
    # music wire breaks near 2.2..2.7 GPa; working stress 25..65 %
    assert np.all((stress > 0.5e9) & (stress < 1.6e9))


def test_length_and_core_diameter_fall_toward_treble():
    assert np.all(np.diff(col("speaking_length_m")) < 0)
    assert np.all(np.diff(col("core_diameter_m")) < 0)
    L = col("speaking_length_m")
    assert 1.9 < L[0] < 2.1                       # A0 of a 9' grand
    assert 0.60 < L[60 - 21] < 0.70               # middle C
    assert 0.045 < L[-1] < 0.058                  # C8
    # treble octave ratio 1.88 (between a 'just' 2.0 and a flat scale)
    assert L[72 - 21] / L[84 - 21] == pytest.approx(1.88, rel=1e-9)


def test_inharmonicity_formula_and_shape():
    B = np.array([s.inharmonicity_b for s in STR])
    d, T, L = col("core_diameter_m"), col("tension_n"), col("speaking_length_m")
    assert np.allclose(B, math.pi ** 3 * 2e11 * d ** 4 / (64 * T * L ** 2), rtol=1e-12)
    i48 = 48 - 21
    # from the top wound string upward B rises monotonically (the break step
    # C3 wound -> C#3 plain is upward)
    assert np.all(np.diff(B[i48:]) > 0)
    assert B[i48 + 1] / B[i48] > 1.1
    # below: the wound bass, about 1e-4, rising again toward A0
    assert np.all((B[:i48 + 1] > 0.8e-4) & (B[:i48 + 1] < 1.6e-4))
    assert B[0] > 1.3 * B[i48]
    assert np.argmin(B) <= i48
    assert 2.5e-4 < B[60 - 21] < 4.5e-4            # middle C
    assert 1.0e-2 < B[105 - 21] < 2.5e-2           # A7
    # partials follow f_k = k f0 sqrt(1 + B k^2)
    s = grand_string(60)
    assert s.partial_hz(10) == pytest.approx(10 * s.f0_hz * math.sqrt(1 + 100 * B[39]))


def test_string_counts_dampers_and_capo():
    n = col("n_strings").astype(int)
    assert list(np.bincount(n)[1:]) == [10, 18, 60]
    assert np.all(n[MIDIS <= 30] == 1) and np.all(n[(MIDIS >= 31) & (MIDIS <= 48)] == 2)
    assert np.all(n[MIDIS >= 49] == 3)
    assert np.array_equal(col("wound").astype(bool), n < 3)
    damper = col("has_damper").astype(bool)
    capo = col("has_capo").astype(bool)
    assert set(MIDIS[~damper]) == set(range(89, 109))     # top 20 keys undamped
    assert set(MIDIS[capo]) == set(range(73, 109))        # C#5..C8 on the capo bar
    assert np.all(n[capo] == 3)


def test_strike_position():
    a = col("strike_position")
    assert np.all(np.diff(a) <= 0)
    assert np.all(np.abs(a[MIDIS <= 72] - 1 / 8.6) < 0.002)
    assert 1 / 13 < a[84 - 21] < 1 / 10                    # C6
    assert a[105 - 21] == pytest.approx(2.6 / 61, rel=1e-9)
    assert 1 / 30 < a[-1] < 1 / 20


def test_unison_detune():
    for s in STR:
        d = np.array(s.unison_detune_cents)
        assert len(d) == s.n_strings
        assert np.all(np.abs(d) <= 1.0)
        if s.n_strings == 1:
            assert d[0] == 0.0
        else:
            spread = d.max() - d.min()
            # at most 0.6 cent (fitted to a recorded grand's beats), and at
            # most 0.6 Hz of beating between the outer strings
            assert spread == pytest.approx(min(0.6, 1200 / np.log(2) * 0.6 / s.f0_hz), rel=1e-9)
            assert abs(d.mean()) < 0.1


def test_decay_times():
    lo, hi, fh = col("t60_low_s"), col("t60_high_s"), col("f_high_hz")
    f0 = et(MIDIS)
    assert np.all(np.diff(lo) < 0)
    # a string's own decay, the aftersound: fitted to a recorded grand's
    # tails (docs/voicing.md, "The aftersound")
    assert 115 <= lo[0] <= 125                 # A0
    assert 45 <= lo[60 - 21] <= 55             # middle C
    assert 5.5 <= lo[-1] <= 6.5                # C8 (a real grand's top keys: late T60s of 6-47 s)
    pr = col("t60_prompt_s")
    ns = col("n_strings")
    # the in-phase motion: the reference law (A0 40, C4 20, C8 6 s) over the ratio
    ref = np.array([P.t60_prompt_reference_s(f) for f in f0])
    assert ref[0] == pytest.approx(40.0) and ref[60 - 21] == pytest.approx(20.0, rel=1e-3)
    assert np.allclose(ref / pr, [P.prompt_ratio(m) for m in MIDIS])
    assert np.all(pr < lo)
    assert P.prompt_ratio(49) == P.PROMPT_RATIO[3] and P.prompt_ratio(108) == 3.0
    # the middle's trichords as a recorded grand's (the anchors), 4 again from A#5
    for m, r in P.TRICHORD_PROMPT_ANCHORS:
        assert P.prompt_ratio(m) == pytest.approx(r)
    assert P.prompt_ratio(65) == pytest.approx(7.4) and P.prompt_ratio(90) == P.PROMPT_RATIO[3]
    assert all(3.0 <= P.prompt_ratio(m) <= 7.4 for m in range(49, 109))
    assert P.prompt_ratio(40) == P.PROMPT_RATIO[2] and P.prompt_ratio(25) == P.PROMPT_RATIO[1]
    assert np.all(hi < lo)
    assert np.all(fh == np.maximum(5000.0, 2 * f0))
    assert np.all((hi > 0.1) & (hi < 2.0))
    s = grand_string(45)
    assert s.t60_s(s.f0_hz) == pytest.approx(s.t60_low_s, rel=1e-12)
    assert s.t60_s(s.f_high_hz) == pytest.approx(s.t60_high_s, rel=1e-12)
    t = [s.t60_s(f) for f in (200.0, 1000.0, 4000.0, 12000.0)]
    assert np.all(np.diff(t) < 0)


def test_grandstring_validates_its_fields():
    s = grand_string(60)
    with pytest.raises(ValueError, match="n_strings"):
        replace(s, n_strings=4)
    with pytest.raises(ValueError, match="unison_detune_cents"):
        replace(s, unison_detune_cents=(0.0,))
    with pytest.raises(ValueError, match="strike_position"):
        replace(s, strike_position=0.7)
    with pytest.raises(ValueError, match="t60_high_s"):
        replace(s, t60_high_s=2 * s.t60_low_s)
    with pytest.raises(ValueError, match="tension_n"):
        replace(s, tension_n=float("nan"))
    assert isinstance(replace(s, tension_n=800.0), GrandString)


# ------------------------------------------------------------------ hammers

def test_three_parameter_hammer_laws():
    q0, p, alpha = hammer_three_param(105)         # thesis n = 85, A7
    assert q0 == pytest.approx(8387.4, rel=5e-5)
    assert p == pytest.approx(4.975, abs=1e-12)
    assert alpha == pytest.approx(0.630e-3, abs=1e-6)   # the law; the study uses 0.5312 ms
    q0_1, p_1, a_1 = hammer_three_param(21)
    assert q0_1 == pytest.approx(183 * math.exp(0.045), rel=1e-12)
    assert p_1 == pytest.approx(3.715, abs=1e-12)
    assert 250e-6 < a_1 < 270e-6                   # microseconds read as such
    assert np.all(np.diff([hammer_three_param(m).q0_n_per_mm_p for m in MIDIS]) > 0)


def test_concert_voicing_keeps_the_laws_and_changes_their_constants():
    """The grand's voicing: the same forms, softer in the bass and harder in
    the treble (static force at 0.3 mm x0.05 at A0, x0.24 at C4, x2.4 at C8
    of the thesis's); C4's a fifth of Chaigne & Askenfelt's felt (1.47 N
    against 7.0 N at 0.3 mm: issue 41's fit to a recorded grand's attack),
    rising over F#5-C7 (keys 78-96) to their C7 felt (24.4 N against 27 N)
    and to about the thesis's hereditary time (x0.67 at C7)."""
    from synth.physics.piano import CONCERT_VOICING, VOICINGS

    def force(m, v):
        q0, p, _ = hammer_three_param(m, v)
        return q0 * 0.3 ** p

    assert VOICINGS["thesis"] == P.THESIS_VOICING and VOICINGS["concert"] == CONCERT_VOICING
    for m, ratio in ((21, 0.05), (60, 0.236), (96, 1.48), (108, 2.38)):
        assert force(m, CONCERT_VOICING) / force(m, P.THESIS_VOICING) == pytest.approx(ratio, rel=0.1)
    assert force(60, CONCERT_VOICING) == pytest.approx(7.0 / 5, rel=0.06)
    assert force(96, CONCERT_VOICING) == pytest.approx(27.0, rel=0.12)
    assert force(96, CONCERT_VOICING) == pytest.approx(24.4, rel=0.01)
    assert force(78, CONCERT_VOICING) == pytest.approx(24.4 / 5, rel=0.01)
    alpha = [hammer_three_param(m, v).alpha_s for v in (CONCERT_VOICING, P.THESIS_VOICING) for m in (96, 108)]
    assert alpha[0] / alpha[2] == pytest.approx(0.67, abs=0.01) and alpha[1] / alpha[3] == pytest.approx(0.91, abs=0.01)
    # the thesis's own voicing has no treble easing
    assert P.THESIS_VOICING.treble_q == P.THESIS_VOICING.treble_alpha == 1.0
    ps = [hammer_three_param(m, CONCERT_VOICING).p for m in MIDIS]
    assert ps[0] == pytest.approx(3.707, abs=1e-3) and ps[-1] == pytest.approx(4.307, abs=1e-3)
    assert np.all(np.diff([hammer_three_param(m, CONCERT_VOICING).q0_n_per_mm_p for m in MIDIS]) > 0)


def test_four_parameter_hammer_laws_match_printed_ranges():
    h = [hammer_four_param(m) for m in MIDIS]
    F0 = np.array([x.f0_n_per_mm_p for x in h])
    p = np.array([x.p for x in h])
    g = np.array([x.gamma for x in h])
    tau = np.array([x.tau0_s for x in h])
    assert F0[0] == pytest.approx(16440, rel=1e-3) and F0[-1] == pytest.approx(2787300, rel=1e-3)
    assert g[0] == pytest.approx(0.9895, abs=1e-4) and g[-1] == pytest.approx(0.9972, abs=1.5e-4)
    assert tau[0] == pytest.approx(2.70e-6, abs=0.01e-6)
    assert tau[-1] == pytest.approx(1.65e-6, abs=0.01e-6)
    assert np.all(np.diff(tau) < 0) and np.all(np.diff(g) > 0) and np.all(np.diff(F0) > 0)
    assert p[0] == pytest.approx(3.72, abs=0.01)
    assert p[105 - 21] == pytest.approx(4.98, abs=0.01)   # printed upper bound = key 85
    assert p[-1] == pytest.approx(5.02, abs=1e-9)          # the law at key 88


def test_hammer_mass():
    assert hammer_mass_kg(21, 1) == pytest.approx(11.0e-3, abs=0.05e-3)
    assert hammer_mass_kg(108, 1) == pytest.approx(5.3e-3, abs=0.05e-3)
    m85 = hammer_mass_kg(105)                       # three strings by default
    assert m85 == pytest.approx((11.074 - 0.074 * 85 + 1e-4 * 85 ** 2) * 1e-3 / 3, rel=1e-12)
    assert round(m85 * 1e3, 1) == 1.8               # the thesis's "m = 1.8 g"
    assert hammer_mass_kg(21) == hammer_mass_kg(21, 1)
    assert hammer_mass_kg(40) == pytest.approx(hammer_mass_kg(40, 1) / 2)
    with pytest.raises(ValueError, match="n_strings"):
        hammer_mass_kg(60, 4)


def test_stiffness_unit_conversion():
    q0, p, _ = hammer_three_param(105)
    q_si = P.stiffness_per_m_p(q0, p)
    w_mm = 0.37
    assert q_si * (w_mm * 1e-3) ** p == pytest.approx(q0 * w_mm ** p, rel=1e-12)


# ------------------------------------------------------------------ stretch tuning

def partial(f0s, B, k):
    return k * f0s * np.sqrt(1 + B * k * k)


def test_stretch_zero_is_equal_temperament():
    for a4 in (440.0, 442.0, 415.3):
        f = [stretched_f0_hz(m, None, a4, 0.0) for m in MIDIS]
        assert np.max(np.abs(cents(f, et(MIDIS, a4)))) < 1e-9


def test_full_stretch_keeps_a4_and_is_monotone_and_railsback_like():
    f = np.array([stretched_f0_hz(m) for m in MIDIS])
    c = cents(f, et(MIDIS))
    assert abs(c[69 - 21]) < 1e-9
    assert np.all(np.diff(c) > 0)
    assert 10 <= c[-1] <= 40                       # C8 sharp
    assert -5 < c[0] < -0.5                        # A0 slightly flat (low bass B, 2:1 octaves)
    wide = stretch_curve_cents(octave_k_bass=3)
    assert -30 <= wide[0] <= -8                    # 6:3 bass octaves: Railsback-like bass
    assert np.all(np.diff(wide) > 0)
    assert np.allclose(wide[60:], stretch_curve_cents()[60:])   # A5 up: upward octaves only


def test_intermediate_stretch_is_linear_in_cents():
    full = stretch_curve_cents()
    for s in (0.25, 0.5, 1.7):
        f = np.array([stretched_f0_hz(m, stretch=s) for m in MIDIS])
        assert np.max(np.abs(cents(f, et(MIDIS)) - s * full)) < 1e-9


def imposed_pairs():
    return [(a, a + 12) for a in range(21, 105, 12)] + [(94, 106), (95, 107), (96, 108)]


@pytest.mark.parametrize("k_up,k_bass", [(1, 1), (1, 3), (2, 2)])
def test_octave_rule_holds_where_imposed(k_up, k_bass):
    B = np.array([s.inharmonicity_b for s in STR])
    f1 = et(MIDIS) * 2 ** (stretch_curve_cents(None, k_up, k_bass) / 1200)
    f0s = f1 / np.sqrt(1 + B)
    for lo, up in imposed_pairs():
        k = k_up if up > 69 else k_bass
        i, j = lo - 21, up - 21
        assert abs(cents(partial(f0s[i], B[i], 2 * k), partial(f0s[j], B[j], k))) < 0.01


def test_constant_b_gives_uniform_stretch_and_rule_on_every_octave():
    b = 1e-3
    c = stretch_curve_cents(lambda m: b)
    step = octave_stretch_cents(b, b) / 12
    assert np.allclose(np.diff(c), step, atol=1e-9)
    f0s = et(MIDIS) * 2 ** (c / 1200) / math.sqrt(1 + b)
    assert np.max(np.abs(cents(partial(f0s[:-12], b, 2), partial(f0s[12:], b, 1)))) < 0.01
    # a sequence works like the callable
    assert np.allclose(stretch_curve_cents([b] * 88), c)


def test_pchip_matches_scipy():
    interpolate = pytest.importorskip("scipy.interpolate")
    rng = np.random.default_rng(3)
    x = np.arange(0.0, 85.0, 12.0)
    for _ in range(5):
        y = np.cumsum(rng.normal(0, 1, len(x)))
        xe = np.linspace(0, 84, 301)
        ref = interpolate.PchipInterpolator(x, y)(xe)
        assert np.max(np.abs(P._pchip(x, y, xe) - ref)) < 1e-10


def test_string_f0_for_partial1():
    assert string_f0_for_partial1(440.0, 0.0) == 440.0
    B = 7e-4
    f0 = string_f0_for_partial1(440.0, B)
    assert partial(f0, B, 1) == pytest.approx(440.0, rel=1e-14)


def test_stretch_input_validation():
    with pytest.raises(ValueError, match="stretch"):
        stretched_f0_hz(60, stretch=-0.1)
    with pytest.raises(ValueError, match="a4_hz"):
        stretched_f0_hz(60, a4_hz=50.0, stretch=0.0)
    with pytest.raises(ValueError, match="B_of_key"):
        stretch_curve_cents([1e-4] * 87)
    with pytest.raises(ValueError, match=r"B_of_key\(30\)"):
        stretch_curve_cents(lambda m: -1.0 if m == 30 else 1e-4)
    with pytest.raises(ValueError, match="octave_k"):
        stretch_curve_cents(octave_k=0)
    with pytest.raises(ValueError, match="midi"):
        stretched_f0_hz(20)


def test_the_bridge_mass_corner_and_the_resistance_that_keeps_the_prompt_decay():
    """bridge_mass_hz: ratio x f0 on the trichords up to key 72, then twice
    as far every 6 semitones, none on the bass nor at 20 kHz and above;
    bridge_resistance_ns_per_m with a mass keeps the real part of
    the bridge's admittance at f0, 1 / (R (1 + (f0 / f_m)^2)), at the
    dashpot's 1 / R_b, so the prompt T60 at f0 stays."""
    for m in (49, 60, 72):
        assert P.bridge_mass_hz(m, 3.0) == pytest.approx(3.0 * grand_string(m).f0_hz)
    assert P.bridge_mass_hz(33, 3.0) == 0.0 and P.bridge_mass_hz(48, 3.0) == 0.0   # the bass: none
    assert P.bridge_mass_hz(78, 3.0) == pytest.approx(6.0 * grand_string(78).f0_hz)
    assert P.bridge_mass_hz(84, 1.0) == pytest.approx(4.0 * grand_string(84).f0_hz)
    assert P.bridge_mass_hz(87, 3.0) == 0.0 and P.bridge_mass_hz(96, 1.0) == 0.0   # >= 20 kHz: none
    assert P.bridge_mass_hz(60, 0.0) == 0.0
    for m in (49, 60, 84):
        fm = P.bridge_mass_hz(m, 3.0)
        R = P.bridge_resistance_ns_per_m(m, fm)
        f0 = grand_string(m).f0_hz
        re_y = (1.0 / complex(R, 2 * np.pi * f0 * R / (2 * np.pi * fm))).real
        assert re_y == pytest.approx(1.0 / P.bridge_resistance_ns_per_m(m), rel=1e-12)
    with pytest.raises(ValueError, match="ratio"):
        P.bridge_mass_hz(60, -1.0)
