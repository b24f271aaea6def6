"""Contact telemetry: synth.analysis.contacts and synth note --contact-log."""

import csv
import subprocess
import sys

import numpy as np
import pytest

from synth.analysis.contacts import contact_frames, contact_summary

FS = 100_000.0


def test_summary_counts_time_episodes_and_peaks():
    c = np.zeros(1000)
    c[100:150] = 2          # 0.5 ms
    c[160:170] = 3          # 10 samples later: merged with a 0.2 ms gap, apart with 0
    c[600:700] = 1
    f = np.zeros(1000)
    f[50:80] = np.hanning(30) * 40.0
    s = contact_summary(c, f, FS, min_gap_s=0.0002)
    t, h = s["termination"], s["hammer"]
    assert t["time_in_contact_s"] == pytest.approx(160 / FS)
    assert t["episodes"] == 2 and t["max_points"] == 3
    assert t["first_contact_s"] == pytest.approx(100 / FS) and t["last_contact_s"] == pytest.approx(699 / FS)
    assert contact_summary(c, f, FS, min_gap_s=0.0)["termination"]["episodes"] == 3
    assert h["episodes"] == 1 and h["peak_force_n"] == pytest.approx(f.max())
    none = contact_summary(np.zeros(10), np.zeros(10), FS)
    assert none["termination"]["first_contact_s"] is None and none["hammer"]["episodes"] == 0
    with pytest.raises(ValueError, match="contacts has 10 samples and force_n 9"):
        contact_summary(np.zeros(10), np.zeros(9), FS)


def test_frames_hold_the_share_and_maxima():
    c = np.zeros(400)
    c[0:50] = 4
    f = np.zeros(400)
    f[250:300] = 7.0
    fr = contact_frames(c, f, FS, frame_s=0.001)           # 100-sample frames
    assert fr.shape == (4, 5)
    assert fr[0].tolist() == [0.0, 0.5, 4.0, 0.0, 0.0]
    assert fr[2, 3] == 0.5 and fr[2, 4] == 7.0


def _note(tmp_path, *args):
    log = tmp_path / "c.csv"
    r = subprocess.run([sys.executable, "-m", "synth.cli", "note", *args, "-o",
                        str(tmp_path / "n.wav"), "--contact-log", str(log)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return r.stdout, list(csv.DictReader(log.open()))


@pytest.mark.slow  # over 2 s on a quiet 2-core machine: ~2.5 s of CPU in its subprocesses
def test_the_biwa_touches_its_sawari_and_a_grand_note_logs_every_string(tmp_path):
    out, rows = _note(tmp_path, "paper/biwa-sawari", "--seconds", "0.0164")
    assert "string 0: termination" in out and "hammer 0.000 ms" in out
    assert max(int(r["termination_points_max"]) for r in rows) > 0
    out, rows = _note(tmp_path, "grand-piano", "--key", "60", "--seconds", "0.05")
    strings = {r["string"] for r in rows}
    assert strings == {"0", "1", "2", "3"}           # C4: three strings, the second polarization
    peak = [float(r["hammer_force_max_n"]) for r in rows]
    assert max(peak) > 1.0 and "termination 0.00 ms" in out   # no capo bar below C#5


# ---- the fast path's region step against its definition ------------------------------
def _region_ref(acc, vw, C, R, U, side):
    """Each element i of the window, slowly: the running minimum ``x if x <
    m else m``, starting from the entry value, over the points n = 1 .. R
    whose windows hold it (R - n <= i < R - n + C), in order, of x = side
    U(n) + vw[i + 2n - R - 1]; a point where side U(n) is +inf (no
    contact) is left out, as the per-sample step leaves it out."""
    out = acc.copy()
    with np.errstate(invalid="ignore"):    # inf - inf: a NaN, which never wins
        for i in range(C + R - 1):
            m = out[i]
            for n in range(1, R + 1):
                u = side * U[n - 1]
                if not (R - n <= i < R - n + C) or u == np.inf:
                    continue
                x = u + vw[i + 2 * n - R - 1]
                m = x if x < m else m
            out[i] = m
    return out


@pytest.mark.parametrize("side", [1, -1])
def test_the_region_step_is_its_definition_bit_for_bit(side):
    """The fast path's region step (``contact._region_chunk``, no sub-cell
    contact: the points four a pass, between two buffers, and their edges)
    against :func:`_region_ref` on a ring of random values: chunks shorter
    and longer than the region, 1-33 points, windows across the ring's
    wrap, profiles with points out of contact (+-inf), values with NaN,
    infinities and signed zeros among them.  The characteristics' slots
    hold the reference's values to the bit (a NaN where it has one), and
    no other slot of the ring changes."""
    from synth.kernels import contact as KC

    rng = np.random.default_rng(7)
    for case in range(300):
        R = int(rng.integers(1, 34))
        C = int(rng.integers(1, 3 * R + 9))
        W = C + R - 1
        P = int(rng.integers(W + R + 4, 2 * W + 64))
        off = int(rng.integers(0, 9))
        ring = rng.normal(0, 1e-5, off + P + 9)
        if case % 5 == 0:
            k = rng.integers(off, off + P, 6)
            ring[k] = rng.choice([np.nan, np.inf, -np.inf, 0.0, -0.0], 6)
        roff = int(rng.integers(0, 4))
        U = np.concatenate([rng.normal(0, 1, roff),
                            np.cumsum(rng.uniform(0, 2e-5, R)) - rng.uniform(0, 2e-5)])
        U[roff:][rng.random(R) < 0.15] = np.inf * rng.choice([1, -1])
        m0 = int(rng.integers(0, P))
        b = (m0 + 1 - R) % P
        slots = off + (b + np.arange(W)) % P
        vslots = off + (m0 + 2 + np.arange(W)) % P
        ref = side * _region_ref(side * ring[slots], side * ring[vslots], C, R, U[roff:], side)
        before = ring.copy()
        acc, tmp, vw = np.zeros(W + 8), np.zeros(W + 8), np.zeros(W + 8)
        KC._region_chunk(ring, off, P, m0, C, U, roff, R, side, acc, tmp, vw, 0.0, np.zeros(32))
        got = ring[slots]
        nan = np.isnan(ref)
        assert np.array_equal(np.isnan(got), nan), (case, C, R)
        assert np.array_equal(got[~nan].view(np.int64), ref[~nan].view(np.int64)), (case, C, R)
        rest = np.ones(ring.shape, bool)
        rest[slots] = False
        assert np.array_equal(ring[rest], before[rest], equal_nan=True), (case, "outside")
