"""Tests of synth.io.wav: formats, clipping report, validation and atomic writes."""

from __future__ import annotations

import math
import os

import numpy as np
import pytest
import soundfile as sf

from synth.io import wav as W
from synth.io.errors import SynthError
from synth.io.wav import WavWriteResult, write_npy_atomic, write_wav

LSB24 = 2.0 ** -23


def _sine(n=4800, fs=48000, f=1000.0, amp=0.5):
    t = np.arange(n) / fs
    return amp * np.sin(2 * np.pi * f * t)


def test_float_mono_roundtrip_is_exact_float32(tmp_path):
    x = _sine() * 3.0  # 1.5 peak: float keeps values beyond full scale
    p = tmp_path / "a.wav"
    r = write_wav(p, x, 48000)
    info = sf.info(str(p))
    assert (info.format, info.subtype, info.samplerate, info.channels, info.frames) == \
        ("WAV", "FLOAT", 48000, 1, len(x))
    y, fs = sf.read(str(p), dtype="float32")
    assert fs == 48000 and np.array_equal(y, x.astype(np.float32))
    assert r == WavWriteResult(frames=len(x), channels=1,
                               peak_dbfs=pytest.approx(20 * math.log10(np.max(np.abs(x)))),
                               n_clipped=0)
    assert r.peak_dbfs == pytest.approx(3.52, abs=0.01)


def test_float_stereo_keeps_channel_order(tmp_path):
    x = np.stack([_sine(amp=0.25), -_sine(amp=0.125)], axis=1)
    p = tmp_path / "s.wav"
    r = write_wav(p, x, 44100)
    y, fs = sf.read(str(p), dtype="float32", always_2d=True)
    assert fs == 44100 and y.shape == x.shape and np.array_equal(y, x.astype(np.float32))
    assert r.channels == 2 and r.peak_dbfs == pytest.approx(-12.04, abs=0.01)


def test_pcm24_quantisation_within_half_lsb(tmp_path):
    rng = np.random.default_rng(1)
    x = rng.uniform(-0.999, 0.999, size=(5000, 2))
    p = tmp_path / "p.wav"
    r = write_wav(p, x, 96000, subtype="pcm24")
    assert sf.info(str(p)).subtype == "PCM_24" and r.n_clipped == 0
    y, _ = sf.read(str(p), dtype="int32", always_2d=True)
    assert np.all(y & 0xFF == 0)  # 24 significant bits
    err = (y >> 8) * LSB24 - x
    assert np.max(np.abs(err)) <= 0.5 * LSB24 * (1 + 1e-9)


def test_pcm24_clips_to_range_and_reports(tmp_path):
    x = np.array([0.0, 0.5, 1.0, 1.5, -1.0, -2.0, 1 - LSB24, -0.25])
    p = tmp_path / "c.wav"
    r = write_wav(p, x, 48000, subtype="pcm24")
    y, _ = sf.read(str(p), dtype="int32")
    q = y >> 8
    assert q.tolist() == [0, 1 << 22, (1 << 23) - 1, (1 << 23) - 1, -(1 << 23), -(1 << 23),
                          (1 << 23) - 1, -(1 << 21)]
    assert r.n_clipped == 3  # 1.0, 1.5 (above 1 - 2**-23) and -2.0
    assert r.peak_dbfs == pytest.approx(20 * math.log10(2.0))


def test_silence_and_empty(tmp_path):
    r = write_wav(tmp_path / "z.wav", np.zeros(100), 48000)
    assert r.peak_dbfs == -math.inf and r.n_clipped == 0
    r = write_wav(tmp_path / "e.wav", np.zeros(0), 48000, subtype="pcm24")
    assert r.frames == 0 and sf.info(str(tmp_path / "e.wav")).frames == 0


@pytest.mark.parametrize("fs", [7999, 384001, 0, -48000])
def test_fs_out_of_range(tmp_path, fs):
    with pytest.raises(SynthError, match=rf"fs = {fs} Hz is out of range \(8000 <= fs <= 384000\)"):
        write_wav(tmp_path / "x.wav", np.zeros(10), fs)
    assert not os.listdir(tmp_path)


@pytest.mark.parametrize("fs", [48000.0, True, "48000"])
def test_fs_must_be_int(tmp_path, fs):
    with pytest.raises(SynthError, match="fs = "):
        write_wav(tmp_path / "x.wav", np.zeros(10), fs)


@pytest.mark.parametrize("fs", [8000, 384000, np.int64(22050)])
def test_fs_bounds_accepted(tmp_path, fs):
    write_wav(tmp_path / "x.wav", np.zeros(10), fs)
    assert sf.info(str(tmp_path / "x.wav")).samplerate == int(fs)


def test_non_finite_samples_are_counted_and_nothing_is_written(tmp_path):
    x = _sine()
    x[[3, 10, 99]] = [np.nan, np.inf, -np.inf]
    p = tmp_path / "n.wav"
    p.write_bytes(b"previous take")
    with pytest.raises(SynthError) as ei:
        write_wav(p, x, 48000)
    assert "3 non-finite samples" in str(ei.value) and "\n" not in str(ei.value)
    assert p.read_bytes() == b"previous take"
    assert os.listdir(tmp_path) == ["n.wav"]


@pytest.mark.parametrize("audio,fragment", [
    (np.zeros((10, 2, 2)), "shape"),
    (np.zeros((10, 0)), "shape"),
    (np.zeros(10, dtype=complex), "dtype"),
    (np.array(["a", "b"]), "dtype"),
])
def test_bad_audio(tmp_path, audio, fragment):
    with pytest.raises(SynthError, match=fragment):
        write_wav(tmp_path / "x.wav", audio, 48000)


def test_bad_subtype(tmp_path):
    with pytest.raises(SynthError, match="subtype = 'pcm16'"):
        write_wav(tmp_path / "x.wav", np.zeros(10), 48000, subtype="pcm16")


def test_missing_directory_is_a_synth_error(tmp_path):
    with pytest.raises(SynthError, match="cannot write"):
        write_wav(tmp_path / "no" / "such" / "x.wav", np.zeros(10), 48000)
    with pytest.raises(SynthError, match="is a directory"):
        write_wav(tmp_path, np.zeros(10), 48000)


def _failing_write(exc):
    real_write = sf.SoundFile.write

    def write(self, data):
        real_write(self, data[: len(data) // 2])  # half the samples reach the disk ...
        raise exc  # ... then the disk fills up / the process is interrupted

    return write


@pytest.mark.parametrize("subtype", ["float", "pcm24"])
def test_failure_mid_write_leaves_no_file(tmp_path, monkeypatch, subtype):
    monkeypatch.setattr(sf.SoundFile, "write", _failing_write(OSError(28, "No space left on device")))
    p = tmp_path / "out.wav"
    with pytest.raises(SynthError, match="No space left on device"):
        write_wav(p, _sine(), 48000, subtype=subtype)
    assert os.listdir(tmp_path) == []


def test_failure_mid_write_keeps_the_previous_file(tmp_path, monkeypatch):
    p = tmp_path / "out.wav"
    write_wav(p, _sine(amp=0.1), 48000)
    before = p.read_bytes()
    monkeypatch.setattr(sf.SoundFile, "write", _failing_write(KeyboardInterrupt()))
    with pytest.raises(KeyboardInterrupt):  # not an I/O error: re-raised unchanged
        write_wav(p, _sine(amp=0.9), 48000)
    assert p.read_bytes() == before
    assert os.listdir(tmp_path) == ["out.wav"]


def test_overwrite_replaces_and_respects_umask(tmp_path):
    p = tmp_path / "o.wav"
    write_wav(p, np.zeros(10), 48000)
    write_wav(p, _sine(), 48000)
    assert sf.info(str(p)).frames == len(_sine())
    old = os.umask(0o027)
    try:
        write_wav(tmp_path / "m.wav", np.zeros(10), 48000)
    finally:
        os.umask(old)
    assert (os.stat(tmp_path / "m.wav").st_mode & 0o777) == 0o640
    assert sorted(os.listdir(tmp_path)) == ["m.wav", "o.wav"]


def test_npy_roundtrip_exact_path(tmp_path):
    a = np.arange(12, dtype=np.float64).reshape(3, 4) / 7
    p = tmp_path / "state.bin"  # no .npy suffix is added
    write_npy_atomic(p, a)
    assert os.listdir(tmp_path) == ["state.bin"]
    b = np.load(p)
    assert b.dtype == a.dtype and np.array_equal(a, b)


def test_npy_failure_leaves_previous_file(tmp_path, monkeypatch):
    p = tmp_path / "x.npy"
    write_npy_atomic(p, np.ones(3))
    real_save = np.save

    def failing_save(f, arr, allow_pickle=False):
        real_save(f, arr, allow_pickle=allow_pickle)
        raise OSError(5, "Input/output error")

    monkeypatch.setattr(W.np, "save", failing_save)
    with pytest.raises(SynthError, match="Input/output error"):
        write_npy_atomic(p, np.zeros(1000))
    assert np.array_equal(np.load(p), np.ones(3))
    assert os.listdir(tmp_path) == ["x.npy"]


@pytest.mark.parametrize("subtype", ["float", "pcm24"])
def test_a_streamed_wav_is_the_same_file(tmp_path, subtype):
    """write_wav_stream, fed blocks, writes what write_wav writes of their
    concatenation (samples, peak, clipped count)."""
    from synth.io.wav import write_wav_stream

    rng = np.random.default_rng(4)
    a = rng.uniform(-1.2, 1.2, (10_001, 2))
    r1 = write_wav(tmp_path / "a.wav", a, 48_000, subtype)
    r2 = write_wav_stream(tmp_path / "b.wav", (a[i:i + 997] for i in range(0, len(a), 997)),
                          48_000, 2, subtype)
    assert r1 == r2
    assert np.array_equal(sf.read(tmp_path / "a.wav")[0], sf.read(tmp_path / "b.wav")[0])


def test_a_bad_block_leaves_no_streamed_file(tmp_path):
    from synth.io.errors import SynthError
    from synth.io.wav import write_wav_stream

    out = tmp_path / "x.wav"
    out.write_bytes(b"old")

    def blocks(bad):
        yield np.zeros(100)
        yield bad

    for bad, msg in [(np.array([0.0, np.nan]), "1 non-finite samples .* at frame 100"),
                     (np.zeros((5, 2)), r"shape \(5, 2\)")]:
        with pytest.raises(SynthError, match=msg):
            write_wav_stream(out, blocks(bad), 48_000, 1)
        assert out.read_bytes() == b"old" and len(list(tmp_path.iterdir())) == 1


def test_same_samples_give_the_same_bytes_later(tmp_path):
    """No PEAK chunk (libsndfile writes the time into it): a batch run must
    give the same bytes for the same spec, whenever it runs."""
    import time

    from synth.io.wav import wav_bytes

    x = (np.random.default_rng(0).standard_normal((2000, 2)) * 0.1).astype(np.float32)
    a, res = wav_bytes(x, 48000)
    time.sleep(1.05)
    b, _ = wav_bytes(x, 48000)
    assert a == b and b"PEAK" not in a and res.frames == 2000
    write_wav(tmp_path / "x.wav", x, 48000)
    assert (tmp_path / "x.wav").read_bytes() == a      # the same encoder as the files
    y, fs = sf.read(tmp_path / "x.wav", dtype="float32")
    assert fs == 48000 and np.array_equal(y, x)
