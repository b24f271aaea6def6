"""The registries and the voice contract: the schema and the code agree, and
the engine drives any voice through the contract alone."""

import ast
import math
from pathlib import Path

import numpy as np
import pytest

import synth
from synth.dsp.bank import StringBank
from synth.engine.engine import Engine, Event
from synth.io import presets as P
from synth.io.factory import build_engine, build_voice
from synth.kernels import strings as K
from synth.physics import profiles
from synth.physics.soundboard import BodyDesign
from synth.voices import BankSizes, Voice, voice_class, voice_names
from synth.voices.registry import exciter_sections

import source_trees  # (tests/: the sources parsed once a process)

SYNTH = Path(synth.__file__).parent


def _rows(section):
    return {s.name: s for s in P.SECTIONS}[section].fields


def test_every_schema_voice_has_a_registered_class_and_back():
    assert set(P.VOICES) == set(voice_names())
    for name in voice_names():
        assert issubclass(voice_class(name), Voice)
        assert name in voice_class(name).names


def test_an_unknown_voice_is_a_one_line_error():
    with pytest.raises(ValueError, match=r"voice = 'harp' has no registered voice \(registered: "):
        voice_class("harp")


def test_every_exciter_is_configured_by_a_schema_section():
    sections = {s.name for s in P.SECTIONS}
    assert set(exciter_sections()) == {"pluck", "hammer"}
    assert set(exciter_sections()) <= sections


def test_class_names_follow_one_pattern():
    """Issue 38: a voice is <Name>Voice, its strings' design <Name>Setup,
    an exciter <Name>Exciter (named for its section)."""
    import inspect

    from synth.voices import exciters
    from synth.voices.registry import _EXCITERS

    for name in voice_names():
        cls = voice_class(name)
        assert cls.__name__.endswith("Voice"), cls
        mod = inspect.getmodule(cls)
        setups = [c for n, c in vars(mod).items() if inspect.isclass(c)
                  and c.__module__ == mod.__name__ and n.endswith("Setup")]
        assert [c.__name__ for c in setups] == [cls.__name__[:-len("Voice")] + "Setup"], cls
    for section, cls in _EXCITERS.items():
        assert cls.__name__ == section.capitalize() + "Exciter", (section, cls)
        assert issubclass(cls, exciters.Exciter)


def test_every_schema_profile_is_registered_with_its_parameters():
    """PROFILES in the schema = the registry plus "none"; each profile's
    parameters are exactly the termination keys the schema requires for it
    (side and region_points are the Termination's own)."""
    assert set(P.PROFILES) == set(profiles.PROFILES) | {"none"}
    rows = _rows("termination")
    for name, kind in profiles.PROFILES.items():
        keys = {f.name for f in rows if f.when is not None and f.when.key == "termination.profile"
                and name in f.when.values}
        # buzz and pitch_rise_* are every profile's (the voice's, not the profile's);
        # contact, the jawari's, is the Termination's (how the kernel treats the
        # first cell: Termination.subcell), not the profile's
        assert set(kind.params) - {"side"} == keys - {"side", "region_points", "buzz",
                                                      "pitch_rise_cents", "pitch_rise_tau_s",
                                                      "contact"}, name


def test_a_new_profile_is_one_registration():
    """A profile registered outside profiles.py builds through the same
    path as the shipped ones (termination_from_spec), with no voice code."""
    name = "test-wedge"
    try:
        @profiles.register_profile(name, "slope")
        def wedge(slope):
            return lambda x: slope * np.asarray(x, float)

        class Spec:
            profile, side, region_points, slope = name, 1, 5, 0.01

        t = profiles.termination_from_spec(Spec)
        assert np.allclose(t.sample(1e-3), 0.01 * 1e-3 * np.arange(1, 6))
        with pytest.raises(ValueError, match="registered twice"):
            profiles.register_profile(name, "slope")(wedge)
    finally:
        profiles.PROFILES.pop(name, None)
    Spec.profile = "no-such-profile"
    with pytest.raises(ValueError, match="'no-such-profile' is not a registered profile"):
        profiles.termination_from_spec(Spec)


@pytest.mark.slow  # over 2 s on a 2-core machine (2026-12-03: 3.4 s in the fast tier)
def test_excitation_kinds_are_named_once():
    """No module but the kernel defines an excitation kind: every kind is a
    distinct ``K.EXC_*`` value (all of them, read from the kernel, so a new
    kind is covered), no other synth module assigns an ``EXC_*`` name, and
    the bank, the voices and the exciters store and compare ``I_EXC`` only
    through them: no bare literal next to ``I_EXC`` or as a hammer ``law``."""
    kinds = {n: getattr(K, n) for n in dir(K) if n.startswith("EXC_")}
    assert {"EXC_ENDED", "EXC_NONE", "EXC_SITAR", "EXC_BIWA", "EXC_GTABLE", "EXC_HAMMER3",
            "EXC_HAMMER4", "EXC_FELT"} <= set(kinds)
    assert len(set(kinds.values())) == len(kinds), f"two kinds share a value: {kinds}"
    for path in sorted(SYNTH.rglob("*.py")):
        rel = path.relative_to(SYNTH).as_posix()
        if rel.startswith("kernels/"):
            continue
        for node in ast.walk(source_trees.parse(path.read_text())):
            if isinstance(node, ast.Assign):
                for t in node.targets:
                    if isinstance(t, ast.Name) and t.id.startswith("EXC_"):
                        pytest.fail(f"{rel}:{node.lineno}: defines {t.id} outside the kernel")
    for path in [SYNTH / "dsp" / "bank.py", SYNTH / "dsp" / "excitation.py",
                 *sorted((SYNTH / "voices").glob("*.py"))]:
        if not path.is_file():
            continue
        tree = source_trees.parse(path.read_text())
        for node in ast.walk(tree):
            # ip[K.I_EXC] = 3, law=4, ip[K.I_EXC] == 4 ... : a literal next to I_EXC or law
            if isinstance(node, ast.Assign) and isinstance(node.value, ast.Constant) \
                    and "I_EXC]" in ast.unparse(node.targets[0]):
                pytest.fail(f"{path.name}:{node.lineno}: a literal excitation kind")
            if isinstance(node, ast.Compare):
                sides = [node.left, *node.comparators]
                if any("I_EXC]" in ast.unparse(x) for x in sides) and any(
                        isinstance(x, ast.Constant) and isinstance(x.value, int) for x in sides):
                    pytest.fail(f"{path.name}:{node.lineno}: I_EXC compared with a literal")
            if isinstance(node, ast.keyword) and node.arg == "law":
                assert not isinstance(node.value, ast.Constant), f"{path.name}:{node.lineno}"


def test_the_engine_uses_no_hasattr_and_indexes_no_kernel_table():
    """Outside the string bank (synth/dsp/bank.py, its mixins
    excitation.py, bridges.py, groups.py, hand_over.py and telemetry.py, and
    templates.py, the slots' validated rows), the kernels and the benchmarks that time
    and inspect them (synth/apps/bench, as the tests of the kernels do), no
    synth module indexes ipar/fpar/fst, and the engine (with its channels'
    mixin) does not probe its instrument."""
    bank = {"dsp/bank.py", "dsp/excitation.py", "dsp/bridges.py", "dsp/groups.py",
            "dsp/hand_over.py", "dsp/telemetry.py", "dsp/templates.py"}
    tables = {"ipar", "fpar", "fst"}
    for path in sorted(SYNTH.rglob("*.py")):
        rel = path.relative_to(SYNTH).as_posix()
        if rel.startswith(("kernels/", "apps/bench/")) or rel in bank:
            continue
        # the code, not its text: any use of a kernel table as an attribute
        # (``bank.ipar[...]``, or ``t = bank.ipar`` then ``t[...]``), and not
        # a comment or docstring that names one
        for node in ast.walk(source_trees.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Attribute) and node.attr in tables:
                pytest.fail(f"{rel}:{node.lineno}: uses the kernel table {node.attr}")
    for name in ("engine.py", "channels.py"):
        for node in ast.walk(source_trees.parse((SYNTH / "engine" / name).read_text())):
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) \
                    and node.func.id in ("hasattr", "getattr"):
                pytest.fail(f"engine/{name}:{node.lineno}: probes its instrument with {node.func.id}")


class _Sine(Voice):
    """A minimal voice for the contract test: one ideal string per note,
    plucked; no body, no pitch bend, no warm-up: the base's defaults."""

    names = ("test-sine",)

    def __init__(self, preset=None, fs_internal=None):
        self.preset = preset
        self.fs = 100_000.0
        self.calls = []

    def sizes(self, extra_low_key=None):
        return BankSizes(strings_per_voice=2, max_cells=200)

    def note_on(self, bank, slots, key, velocity, *, f0_hz=None, probe_row=-1,
                restrike=False, speed_m_per_s=None, soft=0.0):
        self.calls.append(("on", tuple(slots), key, velocity, restrike, soft))
        bank.configure(slots[0], cells=100, k=25, dt_s=1 / self.fs, U=None, lossy=True, b0=0.999)
        bank.start_pluck(slots[0], K.EXC_SITAR, 1e-3 * velocity, 1e-3)
        bank.activate(slots[0])

    def note_off(self, bank, slots, key, f0_hz, pedal):
        self.calls.append(("off", tuple(slots), key, pedal))
        bank.apply_dampers(np.asarray(slots[:1], dtype=np.int64), self.damper_lift(pedal))


def test_the_engine_drives_a_new_voice_through_the_contract_alone():
    v = _Sine()
    # (the pool's size is the engine's: a preset's [play], or this argument)
    e = Engine(v, fs_out=50_000, polyphony=2)
    assert e.body is None and e.spv == 2 and e.polyphony == 2
    evs = [Event(0.0, "control", 67, 0.75), Event(0.01, "note_on", 60, 0.5),
           Event(0.02, "note_on", 64, 1.0), Event(0.03, "pitch_bend", -1, 0.5),
           Event(0.04, "control", 64, 1.0), Event(0.05, "note_off", 60, 0.0),
           Event(0.06, "note_on", 60, 0.25)]
    y = e.render(evs, duration_s=0.1)
    assert np.all(np.isfinite(y)) and np.max(np.abs(y)) > 1e-4
    ons = [c for c in v.calls if c[0] == "on"]
    offs = [c for c in v.calls if c[0] == "off"]
    assert [c[2] for c in ons] == [60, 64, 60]
    assert ons[0][5] == 0.75 and ons[0][3] == 0.5                  # soft pedal, velocity passed on
    assert ons[2][4] is True and ons[2][1] == ons[0][1]            # restrike on the same slots
    assert offs == [("off", ons[0][1], 60, 1.0)]                   # pedal down at the release
    assert len(ons[0][1]) == 2                                     # strings_per_voice slots


def test_voices_describe_their_body_and_the_engine_builds_it():
    g = build_voice("grand-piano")
    d = g.body()
    b = g.preset.body
    assert d == BodyDesign(wet=b.wet, n_modes=b.modes, size=b.size, brightness=b.brightness,
                           seed=b.seed, inputs=b.inputs, outputs=b.outputs, spread_ms=b.spread_ms,
                           peaks=tuple(tuple(p) for p in b.peaks), mass_hz=b.mass_hz)
    assert d.peaks                              # the board's lowest modes (issue 41)
    assert d.mass_hz == 3000.0                  # and its mass law (issue 41)
    e = build_engine("grand-piano", voice=g)
    assert e.body is not None and e.body.n_modes == b.modes + len(b.peaks) and e.body.wet == b.wet
    assert e.body.spread is not None and e.body.spread.spread_ms == b.spread_ms == 3.4
    assert e.body.mass is not None and e.body.mass.mass_hz == b.mass_hz
    # a one-string voice carries its preset's [body] (the sitar's gourd), or none
    s = build_voice("sitar")
    assert s.body().peaks == s.preset.body.peaks and s.body().inputs == 1
    assert build_voice("hammered-sitar").body() is None
    assert build_engine("hammered-sitar").body is None


def test_bank_fade_reaches_its_t60_and_reap_finds_the_silent_slot():
    fs = 100_000.0
    b = StringBank(2, 300)
    for s in (0, 1):
        b.configure(s, cells=200, k=50, dt_s=1 / fs, U=None, lossy=True, b0=1.0)
        b.start_pluck(s, K.EXC_SITAR, 1e-3, 1e-3)
        b.activate(s)
    mix = np.zeros(4096)
    b.render(mix, 0, 1000)
    b.fade(0, t60_s=0.01, fs_hz=fs)
    assert not b.reap(1000, 1e-9, 2000).size            # nothing quiet yet
    y0 = []
    for _ in range(20):                                # 0.2 s in blocks of 1000
        mix[:] = 0.0
        b.render(mix, 0, 1000)
        y0.append(b.last_peak.copy())
        done = b.reap(1000, 1e-9, 2000)
    peaks = np.array(y0)
    # slot 0 lost > 60 dB per 10 ms after the glide; slot 1 rings on
    assert peaks[3, 0] < 1e-3 * peaks[0, 0] and peaks[-1, 1] > 0.5 * peaks[0, 1]
    assert list(done) == [0]
    b.deactivate(0)
    assert b.quiet[0] == 0 and not b.is_active(0)
    assert not b.excitation_running(1)
    b.start_pluck(1, K.EXC_BIWA, 1e-3, 1e-3, 2000.0)
    assert b.excitation_running(1)
    with pytest.raises(ValueError, match=r"model = 3 is not allowed"):
        b.start_pluck(1, K.EXC_GTABLE, 1e-3, 1e-3)


def test_one_string_voice_takes_either_exciter():
    """plucked and piano presets are one class; the exciter comes from the
    preset's section."""
    s, p = build_voice("sitar"), build_voice("paper/piano-a7-ideal")
    assert type(s) is type(p)
    assert type(s.exciter).__name__ == "PluckExciter" and type(p.exciter).__name__ == "HammerExciter"
    assert s.sizes().max_gtable == 0 and p.sizes().max_gtable == int(0.05 * p.fs) + 2
    assert math.isclose(p.excitation_position, p.preset.hammer.position)
