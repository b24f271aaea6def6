"""Scan rendered audio for clicks: per 5 ms frame, the share of the frame's
energy above 14 kHz (a discontinuity is a broadband burst; felt hammers and
plucks put little energy there).  Frames more than 50 dB below the loudest
are ignored.

    python tools/click_scan.py OUT.wav [...]
"""
import sys, numpy as np, soundfile as sf
for path in sys.argv[1:]:
    y, fs = sf.read(path)
    n = int(0.005 * fs)
    frames = len(y) // n
    Y = np.fft.rfft(y[: frames * n].reshape(frames, n) * np.hanning(n), axis=1)
    P = np.abs(Y) ** 2
    f = np.fft.rfftfreq(n, 1 / fs)
    hi = P[:, f >= 14000].sum(1)
    tot = P.sum(1) + 1e-30
    lvl = 10 * np.log10(tot / n + 1e-30)
    loud = lvl > lvl.max() - 50
    r = 10 * np.log10(hi / tot + 1e-30)
    i = np.argmax(np.where(loud, r, -np.inf))
    print(f"{path}: peak {20*np.log10(np.abs(y).max()):.1f} dBFS; worst 5 ms frame above 14 kHz: "
          f"{r[i]:.1f} dB of the frame (t = {i*0.005:.2f} s, frame level {lvl[i]-lvl.max():.1f} dB re loudest); "
          f"99.9th percentile {np.percentile(r[loud], 99.9):.1f} dB")
