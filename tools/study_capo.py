"""Studies of the capo bar in the grand's free vibration (issue 11, item 5).

    python tools/study_capo.py grid   [--keys 84,90,96,102] [--grids 4,6,8] [--velocity 98]
    python tools/study_capo.py window [--keys 84,90,96,102] [--ms 5,20,50,100] [--grid 4]
    python tools/study_capo.py switch [--keys 84,90,96] [--ms 20]
    python tools/study_capo.py cost   [--keys 84,90,96,102,108]
    python tools/study_capo.py hash   [--keys 84,96,102] [--png OUT.png]

``grid``: is the thesis's grid (1.3 MHz at the bar, ``strings.capo_grid=4``)
converged?  For each key and grid, the change of the audible partials
(within 60 dB of partial 1 on the ideal support) of the free vibration
(0.05-0.55 s, the preset's output at 48 kHz) with the bar against an
ideal support on the same grid, at MIDI velocity ``--velocity`` (98: the
thesis's V = 5 m/s), as ``tests/test_grand.py``'s capo test measures it.

``window``: how soon is the bar's colour made?  The same change when the
bar acts only for the first T ms of the note on the fine grid and the
string's end is an ideal support after it (the bank's rows of the key's
strings set to no termination region, ``I_REG_N`` = 0, at the first block
boundary after T, blocks of 5 ms), and, in the last column, the preset as
it plays (its strike on the finer grid for ``strings.capo_window_s``, then
the engine's grid, :meth:`synth.dsp.bank.StringBank.hand_over`).

``switch``: can a string leave the fine grid without a click?  On the
slow numpy scheme of the tests (``tests/reference.naive_lossy_string``,
here with its state kept: one string of the key, the preset's loop
filters at each rate, no bridge coupling, the hammer's wave at the fine
grid taken from the engine's probe), the fine string with the bar runs T
ms; then a string at the engine's rate takes over as
:meth:`~synth.dsp.bank.StringBank.hand_over` does it: its ring holds the
fine ring's arrivals at its own steps, the bar's end in place, and its
far-end filter state is zero, or fitted by least squares so that its
next outputs continue the fine filter's (``fit_state``).  Printed: the
error of the coarse string's wave arriving at the far end against the
fine string's (run on with the bar lifted at T, at the same places), RMS
over the first 2 ms and over 2-50 ms after the switch, in dB re that
wave's RMS.

``hash``: what the hand-over takes away.  On the fine grid the string
goes on touching the bar through the note, and its contacts leave a
faint noise between the partials; on the engine's grid they stop.
Printed: the median level of the bins between the partials (500 Hz-20
kHz, more than 400 Hz from each; 256-sample frames every 32 samples) over
8-18 ms and 40-100 ms, dB re the loudest bin, on the fine grid through the
whole note and on the preset; ``--png`` draws both spectrograms (the
hand-over's 20 ms marked).

``cost``: the time one hand-over takes (a key's strings, 20 ms after a
strike at velocity 0.8, the preset's grids; median of 20 from the same
state, after one untimed call): what a live block pays once per treble
strike.

Exit 0 after printing; 2 with a one-line error on stderr.
"""

from __future__ import annotations

import argparse
import copy
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

from reference import _step  # noqa: E402  (the tests' naive scheme, one step)

from synth.analysis import as_mono, partial_peaks  # noqa: E402
from synth.engine.engine import Event  # noqa: E402
from synth.io.factory import build_engine  # noqa: E402
from synth.kernels import strings as K  # noqa: E402
from synth.physics import piano as P  # noqa: E402

FS = 48_000
BLOCK = 240


def _fine(grid: int, key_from: int = 73) -> tuple:
    """The finer grid at the bar through the whole note (no hand-over)."""
    return (f"strings.capo_grid={grid}", f"strings.capo_grid_from_key={key_from}",
            "strings.capo_window_s=0")


def render_note(key: int, velocity: int, sets=(), seconds: float = 0.6,
                lift_after_s: float | None = None) -> tuple:
    """The preset's output (mono, 48 kHz) of one note, and its engine; with
    ``lift_after_s`` the key's strings lose their termination region (the
    bar: an ideal support from then on) at the first block boundary after
    that time.  The strings through the board, not a room: the listening
    position (``[listener]``) is taken off, as its reverberation would fill
    the gaps between the partials that the ``hash`` study reads."""
    e = build_engine("grand-piano", tuple(sets))
    e.listener = None
    e.schedule([Event(0.0, "note_on", key, velocity / 127)])
    out, n, lifted = [], 0, lift_after_s is None
    while n < int(seconds * FS):
        out.append(np.array(e.render_block(BLOCK), copy=True))
        n += BLOCK
        if not lifted and n >= lift_after_s * FS:
            for vo in e.voices.values():
                for s in vo.slots:
                    e.bank.ipar[s, K.I_REG_N] = 0
            lifted = True
    y = np.concatenate(out, axis=-1)
    return as_mono(y.T if y.ndim == 2 else y), e


def partial_levels_db(y: np.ndarray, key: int, e) -> np.ndarray:
    """Peak levels (dB) of the partials below 20 kHz (at most 12) over
    0.05-0.55 s, on the key's stiff-string law."""
    B = P.grand_string(key).inharmonicity_b
    f1 = e.inst.tuning_hz(key)
    n = int(min(12, 20000.0 // (f1 * np.sqrt(1 + B * 144))))
    _, lv = partial_peaks(y[int(0.05 * FS):int(0.55 * FS)], FS, f1 / np.sqrt(1 + B), n,
                          search_cents=40, inharmonicity=B)
    return np.asarray(lv)


def capo_change_db(key: int, velocity: int, sets=(), lift_after_s=None) -> tuple:
    """(change of the audible partials with the bar minus the ideal support,
    dB; the mask of audible partials: within 60 dB of partial 1 on the
    ideal support)."""
    y0, e0 = render_note(key, velocity, tuple(sets) + ("strings.capo_region_m=0",))
    ideal = partial_levels_db(y0, key, e0)
    y1, e1 = render_note(key, velocity, sets, lift_after_s=lift_after_s)
    bar = partial_levels_db(y1, key, e1)
    aud = ideal - ideal[0] > -60.0
    return (bar - ideal)[aud], aud


def _fmt(values) -> str:
    return " ".join(f"{v:+.1f}" for v in values)


def grid(args) -> None:
    print(f"Audible partials, the bar minus an ideal support on the same grid, dB "
          f"(velocity {args.velocity}, 0.05-0.55 s)")
    print("| key | " + " | ".join(f"grid {g}" for g in args.grids) + " |")
    print("|---|" + "---|" * len(args.grids))
    for key in args.keys:
        cells = [_fmt(capo_change_db(key, args.velocity, _fine(g, min(args.keys)))[0])
                 for g in args.grids]
        print(f"| {key} | " + " | ".join(cells) + " |", flush=True)


def window(args) -> None:
    sets = _fine(args.grid, min(args.keys))
    print(f"Audible partials, the bar for the first T ms then an ideal support, minus an "
          f"ideal support throughout, grid {args.grid}, velocity {args.velocity}, dB")
    cols = [f"{t:g} ms" for t in args.ms] + ["whole note", "the preset"]
    print("| key | " + " | ".join(cols) + " |")
    print("|---|" + "---|" * len(cols))
    for key in args.keys:
        cells = [_fmt(capo_change_db(key, args.velocity, sets, t / 1e3)[0]) for t in args.ms]
        cells.append(_fmt(capo_change_db(key, args.velocity, sets)[0]))
        cells.append(_fmt(capo_change_db(key, args.velocity)[0]))
        print(f"| {key} | " + " | ".join(cells) + " |", flush=True)


# -- the switch, on the naive scheme -------------------------------------------------------

class NaiveString:
    """``tests/reference.naive_lossy_string``'s scheme (its ``_step``; no
    pitch bend, no sub-cell contact) with its state kept between calls, so that it can be
    copied, cut short and handed over: the rails ``ur``, ``ul`` (N + 1
    points), the termination region ``U`` (points 1..R, ``side`` +1) and
    the far end's filter state ``xd, lp, dx1, dy1, apx, apy, bq``."""

    def __init__(self, su, U=None):
        self.N, self.k = int(su.cells), int(su.k)
        self.b0, self.a1, self.eta = float(su.b0), float(su.a1), float(su.eta)
        self.xdel = int(su.extra_delay)
        self.nd, self.ad = int(su.n_disp), float(su.a_disp)
        self.sos = [tuple(map(float, c)) for c in su.sos]
        self.U = None if U is None else np.asarray(U, float)
        self.ur = np.zeros(self.N + 1)
        self.ul = np.zeros(self.N + 1)
        self.set_state(np.zeros(self.n_state))

    @property
    def n_state(self) -> int:
        return 4 + 2 * self.nd + 4 * len(self.sos)

    def state(self) -> np.ndarray:
        return np.concatenate([[self.xd, self.lp, self.apx, self.apy], self.dx1, self.dy1,
                               np.ravel(self.bq) if self.sos else []])

    def set_state(self, v) -> None:
        v = np.asarray(v, float)
        self.xd, self.lp, self.apx, self.apy = v[:4]
        nd = self.nd
        self.dx1 = v[4:4 + nd].copy()
        self.dy1 = v[4 + nd:4 + 2 * nd].copy()
        self.bq = v[4 + 2 * nd:].reshape(len(self.sos), 4).copy()

    def far_end(self, x: float) -> float:
        """The far end's filter chain on one arriving sample: its output y
        (the wave leaves as -y)."""
        if self.xdel:
            x, self.xd = self.xd, x
        self.lp = self.b0 * x - self.a1 * self.lp
        y = self.lp
        for d in range(self.nd):
            yd = self.ad * y + self.dx1[d] - self.ad * self.dy1[d]
            self.dx1[d], self.dy1[d] = y, yd
            y = yd
        yo = self.eta * y + self.apx - self.eta * self.apy
        self.apx, self.apy = y, yo
        for j, (c1, c2) in enumerate(self.sos):
            h = self.bq[j]
            yb = c2 * yo + c1 * h[0] + h[1] - c1 * h[2] - c2 * h[3]
            h[1], h[0], h[3], h[2] = h[0], yo, h[2], yb
            yo = yb
        return yo

    def run(self, n: int, g=None) -> tuple:
        """``n`` steps (``g``: the injected wave per step, else none); returns
        the wave arriving at the far end and the far end's output per step."""
        ur, ul, k, N = self.ur, self.ul, self.k, self.N
        R = 0 if self.U is None else len(self.U)
        xs, ys = np.empty(n), np.empty(n)
        for m in range(n):
            gm = 0.0 if g is None or m >= len(g) else g[m]
            _step(ur, ul, k, gm, self.U, 1, R)
            xs[m] = ur[N]
            ys[m] = self.far_end(ur[N])
            ul[N] = -ys[m]
        return xs, ys


def arrivals(string: NaiveString) -> np.ndarray:
    """The waves that will reach the far end in the next 2N steps, in
    order (the ring of the kernel, :meth:`synth.dsp.bank.StringBank.
    hand_over`): u_r from N-1 down to 0, then the reflection of u_l
    from 1 to N (the last of them the far end's last output)."""
    return np.concatenate([string.ur[string.N - 1::-1], -string.ul[1:string.N + 1]])


def fit_state(coarse: NaiveString, target: np.ndarray) -> np.ndarray:
    """The far-end filter state of ``coarse`` (its rails set) whose next
    ``len(target)`` outputs come nearest ``target`` (least squares): the
    outputs are the zero-state response to the arriving waves, which the
    rails fix, plus the zero-input response, linear in the state."""
    H = len(target)
    base = copy.deepcopy(coarse)
    base.set_state(np.zeros(base.n_state))
    _, s0 = base.run(H)
    A = np.empty((H, coarse.n_state))
    for i in range(coarse.n_state):
        probe = copy.deepcopy(coarse)
        probe.ur[:] = 0.0
        probe.ul[:] = 0.0
        e = np.zeros(coarse.n_state)
        e[i] = 1.0
        probe.set_state(e)
        _, A[:, i] = probe.run(H)
    sol, *_ = np.linalg.lstsq(A, target - s0, rcond=None)
    return sol


def switch_errors(key: int, velocity: int, window_ms: float, grid_m: int = 4,
                  after_ms: float = 50.0, horizon: int = 96) -> dict:
    """The switch study of one string of ``key`` on the naive scheme, as
    :meth:`synth.dsp.bank.StringBank.hand_over` does it: the coarse ring's
    arrival m is the fine ring's arrival M m + delta + (M - 1) / 2 (linear
    interpolation; delta = N_fine - M N_coarse keeps the bar's end in
    place), and the far-end filter's state is zero or fitted to the fine
    filter's next outputs.  Returns, per mode, the error of the coarse
    string's arriving wave against the fine string's at the same places
    (bar lifted at the switch), dB re its RMS, over the first 2 ms and over
    2 ms to ``after_ms``."""
    sets = _fine(grid_m, 73)
    e = build_engine("grand-piano", sets, probe=True)
    e.render([Event(0.0, "note_on", key, velocity / 127)], duration_s=0.006,
             compensate_latency=False)
    g_eng = e.probe_channels(0)[K.P_G]
    fine_su = e.inst.setup(key)[0]
    M = fine_su.sub
    if M != grid_m:
        raise ValueError(f"key {key} is not on the {grid_m}-step grid")
    # the hammer's wave per fine step (the probe holds one step per engine sample)
    g = np.interp(np.arange(len(g_eng) * M) / M, np.arange(len(g_eng)), g_eng)
    coarse_su = e.inst.coarse_setup(key)[0]
    fine = NaiveString(fine_su, fine_su.U)
    fine.run(int(round(window_ms * 1e-3 * e.fs_in)) * M, g)
    fine.U = None                                  # the bar lifted at the switch
    Nf, Nc = fine.N, int(coarse_su.cells)
    delta, phase = Nf - M * Nc, 0.5 * (M - 1)
    n_after = int(after_ms * 1e-3 * e.fs_in)
    ref = copy.deepcopy(fine)
    xf, yf = ref.run(M * (n_after + 4))
    A = arrivals(fine)
    X = np.concatenate([A, yf])                    # the arrivals, then the outputs to come
    Y = np.concatenate([A, yf])                    # the outputs: Y[i] = y(i - 2 Nf)
    grid = np.arange(len(X))
    res = {}
    for mode in ("zero", "fit"):
        c = NaiveString(coarse_su, None)
        Ac = np.interp(M * np.arange(2 * Nc) + delta + phase, grid, X)
        c.ur[Nc - 1::-1] = Ac[:Nc]
        c.ul[1:Nc + 1] = -Ac[Nc:]
        if mode == "fit":
            H = min(horizon, Nc - 2)
            target = np.interp(M * np.arange(H) - delta + phase + 2 * Nf, grid, Y)
            c.set_state(fit_state(c, target))
        xc, _ = c.run(n_after)
        want = np.interp(M * np.arange(n_after) + delta + phase, np.arange(len(xf)), xf)
        err = xc - want
        rms = np.sqrt(np.mean(want ** 2))
        n2 = int(0.002 * e.fs_in)
        res[mode] = (20 * np.log10(np.sqrt(np.mean(err[:n2] ** 2)) / rms + 1e-300),
                     20 * np.log10(np.sqrt(np.mean(err[n2:] ** 2)) / rms + 1e-300))
    return res


def switch(args) -> None:
    print(f"Switch from grid {args.grid} to the engine's grid after {args.ms[0]:g} ms "
          f"(one string, velocity {args.velocity}): error of the wave at the far end, "
          f"dB re its RMS")
    print("| key | zero state: 0-2 ms | 2-50 ms | fitted state: 0-2 ms | 2-50 ms |")
    print("|---|---|---|---|---|")
    for key in args.keys:
        r = switch_errors(key, args.velocity, args.ms[0], args.grid)
        print(f"| {key} | {r['zero'][0]:.1f} | {r['zero'][1]:.1f} | {r['fit'][0]:.1f} | "
              f"{r['fit'][1]:.1f} |", flush=True)


def hand_over_cost_ms(key: int, repeats: int = 20) -> float:
    """Median time (ms) of one hand-over of ``key``'s strings 20 ms after
    a strike (velocity 0.8; :meth:`GrandVoice.leave_fine_grid`,
    warm: after one untimed call, each from the same bank state)."""
    import time

    e = build_engine("grand-piano", ("strings.capo_window_s=0",))
    e.schedule([Event(0.0, "note_on", key, 0.8)])
    for _ in range(int(0.02 * FS) // BLOCK):
        e.render_block(BLOCK)
    slots = list(next(iter(e.voices.values())).slots)
    b = e.bank
    saved = [a.copy() for a in (b.ring, b.ipar, b.fpar, b.fst, b.U, b.damper)]
    times = []
    for i in range(repeats + 1):
        for a, v in zip((b.ring, b.ipar, b.fpar, b.fst, b.U, b.damper), saved):
            a[...] = v
        t = time.perf_counter()
        if not e.inst.leave_fine_grid(b, slots, key):
            raise ValueError(f"key {key}: a hammer is still on the strings after 20 ms")
        if i:
            times.append(time.perf_counter() - t)
    return 1e3 * float(np.median(times))


def cost(args) -> None:
    print("Hand-over of a key's strings from the finer grid, ms (median of 20, warm)")
    print("| key | ms |")
    print("|---|---|")
    for key in args.keys:
        print(f"| {key} | {hand_over_cost_ms(key):.3f} |", flush=True)


def _spectrogram_db(y: np.ndarray, nfft: int = 256, hop: int = 32):
    """Power (dB) of Hann-windowed frames of ``y`` (``nfft`` samples every
    ``hop``), their frequencies (Hz) and centre times (s)."""
    w = np.hanning(nfft)
    starts = np.arange(0, len(y) - nfft, hop)
    frames = np.stack([y[i:i + nfft] * w for i in starts])
    P = np.abs(np.fft.rfft(frames, axis=1)) ** 2
    return (10 * np.log10(P.T + 1e-300), np.fft.rfftfreq(nfft, 1.0 / FS),
            (starts + nfft / 2) / FS)


def contact_hash(key: int, velocity: int) -> tuple:
    """The bar's contact noise between the partials: the median level (dB re
    the loudest bin) of the 256-sample spectrogram's bins 500 Hz-20 kHz
    more than 400 Hz from every partial, over 8-18 ms and 40-100 ms, on the
    fine grid through the whole note and on the preset (hand-over at 20 ms);
    and the two renders."""
    B = P.grand_string(key).inharmonicity_b
    out, ys = [], []
    for sets in (("strings.capo_window_s=0",), ()):
        y, e = render_note(key, velocity, sets, seconds=0.12)
        f0 = e.inst.tuning_hz(key) / np.sqrt(1 + B)
        L, f, t = _spectrogram_db(y)
        mask = (f > 500) & (f < 20000)
        for m in range(1, 60):
            mask &= np.abs(f - m * f0 * np.sqrt(1 + B * m * m)) > 400
        ref = L.max()
        out.append([float(np.median(L[mask][:, (t > a) & (t < b)]) - ref)
                    for a, b in ((0.008, 0.018), (0.04, 0.1))])
        ys.append(y)
    return out, ys


def hash_(args) -> None:
    print(f"Between the partials (median, dB re the loudest bin), velocity {args.velocity}")
    print("| key | fine grid, 8-18 ms | 40-100 ms | the preset, 8-18 ms | 40-100 ms |")
    print("|---|---|---|---|---|")
    panels = []
    for key in args.keys:
        (fine, pre), ys = contact_hash(key, args.velocity)
        print(f"| {key} | {fine[0]:.1f} | {fine[1]:.1f} | {pre[0]:.1f} | {pre[1]:.1f} |", flush=True)
        panels.append((key, ys))
    if args.png:
        try:
            import matplotlib
        except ImportError:
            raise ValueError("--png needs matplotlib: pip install 'synth[plots]'") from None
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, axs = plt.subplots(2, len(panels), figsize=(3.0 * len(panels), 4.2), sharey=True,
                                squeeze=False)
        for j, (key, ys) in enumerate(panels):
            for i, (y, name) in enumerate(zip(ys, ("thesis's grid, whole note",
                                                   "preset: 325 kHz after 20 ms"))):
                L, f, t = _spectrogram_db(y)
                ax = axs[i, j]
                ax.pcolormesh(t, f, L - L.max(), vmin=-110, vmax=0, cmap=plt.get_cmap("magma", 12),
                              shading="auto")
                ax.axvline(0.02, color="c", lw=0.8)
                ax.set_ylim(0, 20000)
                ax.set_title(f"key {key}: {name}", fontsize=8)
                ax.tick_params(labelsize=7)
        axs[1, 0].set_xlabel("s", fontsize=8)
        axs[1, 0].set_ylabel("Hz", fontsize=8)
        fig.tight_layout()
        fig.savefig(args.png, dpi=50)
        print(f"plot: {args.png}")


def _ints(text: str, lo: int, hi: int, name: str) -> list:
    try:
        v = [int(t) for t in text.split(",") if t.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{name} {text!r}: comma-separated integers") from None
    if not v or any(not lo <= x <= hi for x in v):
        raise argparse.ArgumentTypeError(f"{name} {text!r}: comma-separated integers {lo}-{hi}")
    return v


def _floats(text: str) -> list:
    try:
        v = [float(t) for t in text.split(",") if t.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"--ms {text!r}: comma-separated times (ms)") from None
    if not v or any(not 0 < x <= 500 for x in v):
        raise argparse.ArgumentTypeError(f"--ms {text!r}: comma-separated times in (0, 500] ms")
    return v


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="study_capo.py", description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="study", required=True)
    for name, helptext in (("grid", "is the thesis's grid converged"),
                           ("window", "the bar for the first T ms only"),
                           ("switch", "leaving the fine grid: the error of the hand-over"),
                           ("cost", "the time of one hand-over, per key"),
                           ("hash", "the bar's contact noise between the partials")):
        p = sub.add_parser(name, help=helptext)
        p.add_argument("--keys", type=lambda t: _ints(t, P.CAPO_FIRST_MIDI, 108, "--keys"),
                       default=[84, 90, 96, 102])
        p.add_argument("--velocity", type=lambda t: _ints(t, 1, 127, "--velocity")[0],
                       default=98)
        if name == "grid":
            p.add_argument("--grids", type=lambda t: _ints(t, 1, K.MAX_SUB, "--grids"),
                           default=[4, 6, 8])
        elif name == "hash":
            p.add_argument("--png", metavar="OUT.png", help="also draw the spectrograms "
                           "(needs matplotlib, the [plots] extra)")
        elif name != "cost":
            p.add_argument("--grid", type=lambda t: _ints(t, 2, K.MAX_SUB, "--grid")[0],
                           default=4)
            p.add_argument("--ms", type=_floats, default=[5, 20, 50, 100] if name == "window"
                           else [20])
    args = ap.parse_args(argv)
    try:
        {"grid": grid, "window": window, "switch": switch, "cost": cost,
         "hash": hash_}[args.study](args)
    except ValueError as exc:
        print(f"study_capo: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
