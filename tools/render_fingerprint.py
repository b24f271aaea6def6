"""Record and compare render fingerprints: check that a refactor changed no sound.

A refactor that claims "behaviour is unchanged" is held to this: every shipped
study preset's probe u(l, t) is bit-identical before and after, and the piano
(and plucked phrase) renders give the same float32 output, or differ by at
most the last place.  This tool renders a fixed set of outputs through the
``synth`` command line only (``python -m synth.cli ...`` in a subprocess, never
an import of synth's internals), so the same tool runs unchanged on the code
before and after the refactor.

    python tools/render_fingerprint.py record OUTDIR [--quick] [--midi-dir DIR]
    python tools/render_fingerprint.py compare DIR_A DIR_B [--max-ulp N]

Run it from the checkout under test, with that checkout on ``PYTHONPATH``
(the interpreter is ``sys.executable``; ``NUMBA_NUM_THREADS`` defaults to 1
for the subprocesses).  For example, on the old code and then on the new::

    PYTHONPATH=$PWD python tools/render_fingerprint.py record /tmp/fp/base
    PYTHONPATH=$PWD python tools/render_fingerprint.py record /tmp/fp/new
    python tools/render_fingerprint.py compare /tmp/fp/base /tmp/fp/new

``record`` renders into OUTDIR (which must be empty or absent, unless
``--force``):

* every study preset (``synth presets``, the names under ``paper/``):
  ``synth note PRESET --seconds 0.5 -o OUTDIR/PRESET.wav --probe
  OUTDIR/PRESET.probe.npy``, plus ``--hammer-log OUTDIR/PRESET.hammer.csv``
  for hammered ones (tried first; a plucked preset refuses it, and is then
  rendered without it);
* the five piano files of the MIDI directory with ``--preset grand-piano``
  (``synth render FILE --preset grand-piano -o OUTDIR/NAME.wav``, 32-bit float
  WAV, the default);
* one folk melody on ``--preset sitar`` and one on ``--preset biwa``
  (``OUTDIR/sitar-NAME.wav``, ``OUTDIR/biwa-NAME.wav``).

``--quick`` renders only the study presets and the Paderewski roll
(hp956bx4547_exp.mid).  OUTDIR/manifest.json records every command, its exit
status, wall time and output, the git commit of the synth checkout, the
environment (Python, numpy, numba, CPU, NUMBA_* variables), the MIDI inputs'
sha256, and for each output its sha256, shape, dtype, peak and duration.

``compare`` prints one line per output present in both directories, then a
summary line.  Its verdicts and thresholds:

* probes (``*.probe.npy``, float64 u(l, t)) must be bitwise identical (same
  shape, dtype and bytes of data); a difference is reported with its max abs
  difference and always fails;
* hammer logs (``*.hammer.csv``) must be identical text (they print float64
  values to 10 significant digits, so they follow the probe); a difference is
  reported with the max abs numeric difference and fails;
* WAVs: "identical" if bitwise equal; otherwise the max abs difference, as dB
  re full scale (1.0) and dB re the signal's own peak, the RMS difference
  (dBFS), and, for float32 WAVs, the max distance in ULPs:
  |a - b| / np.spacing(np.float32(max(|a|, |b|))) per sample, i.e. how many
  float32 steps apart the two samples are at their magnitude.  (PCM WAVs
  count steps of the PCM LSB instead.)  A WAV fails if its max ULP distance
  exceeds ``--max-ulp`` (default 1: "the same float32 output or within its
  last place"), or if its shape, sample rate or format differ;
* an output listed by one side's manifest but missing from the other fails;
  an output that a ``--quick`` run does not record is only noted as skipped.

The exit status is 0 if everything passes, 1 if anything fails, 2 on usage
errors (e.g. a directory without outputs).
"""

from __future__ import annotations

import argparse
import csv
import datetime
import hashlib
import json
import math
import os
import platform
import shlex
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import soundfile as sf

NOTE_SECONDS = 0.5
STUDY_PREFIX = "paper/"
PIANO_PRESET = "grand-piano"
PIANO_FILES = ["rac_op23_5.mid", "chpn_op25_e11.mid", "deb_clai.mid",
               "hp956bx4547_exp.mid", "kw569bw0899_exp.mid"]
QUICK_PIANO = ["hp956bx4547_exp.mid"]          # the Paderewski roll
PHRASES = [("sitar", "HerGoldenHairWasCurlingDown.mid"),  # 57 s, 220 notes, keys 66-78
           ("biwa", "PatWardsslide.mid")]                 # 64 s, 281 notes, keys 62-79
DEFAULT_MIDI_DIR = "/work/shared/midi"
MANIFEST = "manifest.json"
KINDS = (".probe.npy", ".hammer.csv", ".wav")


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _kind(name: str) -> str | None:
    for k in KINDS:
        if name.endswith(k):
            return k
    return None


# ---------------------------------------------------------------- record ---
def _env() -> dict:
    env = dict(os.environ)
    env.setdefault("NUMBA_NUM_THREADS", "1")
    env.setdefault("PYTHONHASHSEED", "0")
    return env


def _synth(args: list[str], env: dict) -> dict:
    """Run ``python -m synth.cli ARGS``; return the command, status, output and wall time."""
    cmd = [sys.executable, "-m", "synth.cli", *args]
    t = time.perf_counter()
    p = subprocess.run(cmd, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t
    return {"argv": cmd, "command": shlex.join(["synth", *args]), "returncode": p.returncode,
            "wall_s": round(wall, 3), "stdout": p.stdout.strip(), "stderr": p.stderr.strip()}


def _describe(path: Path) -> dict:
    """sha256, shape, dtype, peak (and rate, duration) of one output file."""
    d = {"sha256": _sha256(path), "bytes": path.stat().st_size}
    k = _kind(path.name)
    if k == ".probe.npy":
        a = np.load(path, allow_pickle=False)
        d.update(shape=list(a.shape), dtype=str(a.dtype),
                 peak=float(np.max(np.abs(a))) if a.size else 0.0,
                 finite=bool(np.isfinite(a).all()))
    elif k == ".wav":
        info = sf.info(str(path))
        a, fs = _read_wav(path)
        d.update(shape=list(a.shape), dtype=str(a.dtype), subtype=info.subtype, samplerate=fs,
                 duration_s=round(info.frames / fs, 6),
                 peak=float(np.max(np.abs(a.astype(np.float64)))) if a.size else 0.0,
                 finite=bool(np.isfinite(a).all()) if a.dtype.kind == "f" else True)
        if a.dtype.kind == "i":
            d["peak"] /= 2.0 ** 31
    elif k == ".hammer.csv":
        rows = _read_csv(path)
        d.update(shape=[len(rows[1]), len(rows[0])], dtype="text (float64 printed %.9e)",
                 peak=float(np.max(np.abs(rows[1]))) if rows[1].size else 0.0)
    return d


def _read_wav(path: Path):
    """Samples exactly as stored: float32/float64 for float WAVs, int32 for PCM."""
    info = sf.info(str(path))
    dtype = {"FLOAT": "float32", "DOUBLE": "float64"}.get(info.subtype, "int32")
    a, fs = sf.read(str(path), dtype=dtype, always_2d=False)
    return a, fs


def _read_csv(path: Path):
    with open(path, newline="") as f:
        r = list(csv.reader(f))
    header, body = r[0], r[1:]
    return header, np.array([[float(x) for x in row] for row in body], dtype=np.float64)


def _git_commit(env: dict) -> dict:
    """The git commit of the synth checkout the subprocesses import (found
    without importing synth, by the same sys.path the subprocess uses)."""
    code = ("import importlib.util, os; s = importlib.util.find_spec('synth'); "
            "print(os.path.dirname(os.path.dirname(s.origin)) if s and s.origin else '')")
    root = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True).stdout.strip()
    out = {"synth_root": root or None, "commit": None, "dirty": None}
    if root:
        def git(*a):
            p = subprocess.run(["git", "-C", root, *a], capture_output=True, text=True)
            return p.stdout.strip() if p.returncode == 0 else None
        out["commit"] = git("rev-parse", "HEAD")
        out["branch"] = git("rev-parse", "--abbrev-ref", "HEAD")
        out["synth_tree"] = git("rev-parse", "HEAD:synth")   # the package's own tree
        st = git("status", "--porcelain", "--untracked-files=no")
        out["dirty"] = None if st is None else bool(st)
    return out


def _platform(env: dict) -> dict:
    code = "import numpy, numba; print(numpy.__version__, numba.__version__)"
    p = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    vers = p.stdout.split() if p.returncode == 0 else [None, None]
    cpu = None
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        cpu = platform.processor() or None
    return {"python": sys.version.split()[0], "executable": sys.executable,
            "numpy": vers[0], "numba": vers[1] if len(vers) > 1 else None,
            "soundfile": sf.__version__, "machine": platform.machine(), "cpu": cpu,
            "env": {k: v for k, v in sorted(env.items())
                    if k.startswith(("NUMBA_", "SYNTH_")) or k in ("PYTHONPATH", "PYTHONHASHSEED")}}


def _study_presets(env: dict) -> list[str]:
    r = _synth(["presets"], env)
    if r["returncode"] != 0:
        sys.exit(f"render_fingerprint: `synth presets` failed: {r['stderr']}")
    names = [line.split()[0] for line in r["stdout"].splitlines() if line.strip()]
    study = [n for n in names if n.startswith(STUDY_PREFIX)]
    if not study:
        sys.exit(f"render_fingerprint: `synth presets` lists no {STUDY_PREFIX}* presets")
    return study


def cmd_record(a) -> int:
    out = Path(a.outdir).resolve()
    if out.exists() and any(out.iterdir()) and not a.force:
        print(f"render_fingerprint: {out} is not empty (use --force to write into it)",
              file=sys.stderr)
        return 2
    out.mkdir(parents=True, exist_ok=True)
    midi_dir = Path(a.midi_dir)
    env = _env()
    piano = QUICK_PIANO if a.quick else PIANO_FILES
    phrases = [] if a.quick else PHRASES
    for f in piano + [m for _, m in phrases]:
        if not (midi_dir / f).is_file():
            print(f"render_fingerprint: {midi_dir / f} does not exist", file=sys.stderr)
            return 2

    t_all = time.perf_counter()
    manifest = {"tool": "tools/render_fingerprint.py", "mode": "quick" if a.quick else "full",
                "created": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
                "cwd": os.getcwd(), "git": _git_commit(env), "platform": _platform(env),
                "note_seconds": NOTE_SECONDS, "midi_dir": str(midi_dir), "midi_inputs": {},
                "runs": [], "outputs": {}}
    failed = 0

    def run(args, produces, label, r=None):
        nonlocal failed
        r = r or _synth(args, env)
        r["outputs"] = produces
        manifest["runs"].append(r)
        ok = r["returncode"] == 0
        failed += not ok
        print(f"{'ok  ' if ok else 'FAIL'} {r['wall_s']:7.2f} s  {label}"
              + ("" if ok else f"\n     {r['stderr']}"), flush=True)
        if ok:
            for rel in produces:
                manifest["outputs"][rel] = _describe(out / rel)

    for preset in _study_presets(env):
        (out / preset).parent.mkdir(parents=True, exist_ok=True)
        wav, probe, log = f"{preset}.wav", f"{preset}.probe.npy", f"{preset}.hammer.csv"
        base = ["note", preset, "--seconds", f"{NOTE_SECONDS:g}", "-o", str(out / wav),
                "--probe", str(out / probe)]
        # hammered presets take --hammer-log; a plucked one refuses it (before rendering)
        r = _synth(base + ["--hammer-log", str(out / log)], env)
        if r["returncode"] != 0 and "no hammer" in r["stderr"]:
            manifest["runs"].append({**r, "outputs": [], "expected_failure":
                                     "plucked preset: no --hammer-log; rendered without it"})
            run(base, [wav, probe], preset)
        else:
            run(None, [wav, probe, log], f"{preset} (+ hammer log)", r)

    jobs = [(PIANO_PRESET, f, f"{Path(f).stem}.wav") for f in piano]
    jobs += [(p, f, f"{p}-{Path(f).stem}.wav") for p, f in phrases]
    for preset, f, wav in jobs:
        src = midi_dir / f
        manifest["midi_inputs"][f] = _sha256(src)
        run(["render", str(src), "--preset", preset, "-o", str(out / wav)], [wav],
            f"{f} on {preset}")

    manifest["total_wall_s"] = round(time.perf_counter() - t_all, 1)
    manifest["failed_runs"] = failed
    (out / MANIFEST).write_text(json.dumps(manifest, indent=1) + "\n")
    print(f"{len(manifest['outputs'])} outputs, {failed} failed runs, "
          f"{manifest['total_wall_s']:.1f} s; manifest {out / MANIFEST}")
    return 1 if failed else 0


# --------------------------------------------------------------- compare ---
def _db(x: float) -> str:
    return "-inf" if x <= 0 else f"{20 * math.log10(x):.1f}"


def _outputs(d: Path) -> set[str]:
    return {p.relative_to(d).as_posix() for p in d.rglob("*") if p.is_file() and _kind(p.name)}


def _cmp_probe(pa: Path, pb: Path) -> tuple[bool, str]:
    a, b = np.load(pa, allow_pickle=False), np.load(pb, allow_pickle=False)
    if a.shape != b.shape or a.dtype != b.dtype:
        return False, f"DIFFERENT shape/dtype {a.shape} {a.dtype} vs {b.shape} {b.dtype}"
    if np.ascontiguousarray(a).tobytes() == np.ascontiguousarray(b).tobytes():
        note = "" if _sha256(pa) == _sha256(pb) else " (data; the .npy headers differ)"
        return True, "identical" + note
    d = np.abs(a.astype(np.float64) - b.astype(np.float64))
    peak = float(np.max(np.abs(a))) or 1.0
    ab = np.ascontiguousarray(a).reshape(a.size, 1).view(np.uint8)
    bb = np.ascontiguousarray(b).reshape(b.size, 1).view(np.uint8)
    n = int(np.count_nonzero(np.any(ab != bb, axis=1)))
    return False, (f"DIFFERENT (must be bit-identical): max abs diff {np.nanmax(d):.3e} m "
                   f"({_db(float(np.nanmax(d)) / peak)} dB re peak), {n} of {a.size} samples differ")


def _cmp_csv(pa: Path, pb: Path) -> tuple[bool, str]:
    if pa.read_bytes() == pb.read_bytes():
        return True, "identical"
    (ha, a), (hb, b) = _read_csv(pa), _read_csv(pb)
    if ha != hb or a.shape != b.shape:
        return False, f"DIFFERENT header/shape {ha} {a.shape} vs {hb} {b.shape}"
    d = np.abs(a - b).max(axis=0)
    cols = ", ".join(f"{h} {x:.3e}" for h, x in zip(ha, d))
    return False, f"DIFFERENT: max abs diff per column: {cols}"


def _cmp_wav(pa: Path, pb: Path, max_ulp: float) -> tuple[bool, str]:
    ia, ib = sf.info(str(pa)), sf.info(str(pb))
    a, fa = _read_wav(pa)
    b, fb = _read_wav(pb)
    if (fa, ia.subtype, a.shape) != (fb, ib.subtype, b.shape):
        return False, (f"DIFFERENT format: {a.shape} {ia.subtype} {fa} Hz vs "
                       f"{b.shape} {ib.subtype} {fb} Hz")
    if a.tobytes() == b.tobytes():
        return True, "identical"
    if a.dtype.kind == "f":
        af, bf = a.astype(np.float64), b.astype(np.float64)
        scale = 1.0
        mag = np.maximum(np.abs(a), np.abs(b))
        ulp = np.abs(af - bf) / np.spacing(mag).astype(np.float64)   # spacing in a's dtype
        unit = "ULP"
    else:
        bits = {"PCM_16": 16, "PCM_24": 24, "PCM_32": 32}.get(ia.subtype, 32)
        scale = 2.0 ** 31
        af, bf = a.astype(np.float64) / scale, b.astype(np.float64) / scale
        ulp = np.abs(a.astype(np.float64) - b.astype(np.float64)) / 2.0 ** (32 - bits)
        unit = "LSB"
    d = np.abs(af - bf)
    both_nan = np.isnan(af) & np.isnan(bf)
    d[both_nan] = 0.0
    ulp[both_nan] = 0.0
    mx = float(np.max(d)) if np.all(np.isfinite(d)) else math.inf
    peak = float(np.max(np.abs(af))) or 1.0
    rms = float(np.sqrt(np.mean(np.square(d)))) if d.size else 0.0
    mu = float(np.max(ulp)) if np.all(np.isfinite(ulp)) else math.inf
    n = int(np.count_nonzero(d))
    ok = mu <= max_ulp
    verdict = "within" if ok else "DIFFERENT: over"
    return ok, (f"max abs diff {mx:.3e} ({_db(mx)} dBFS, {_db(mx / peak)} dB re peak), "
                f"rms diff {rms:.3e} ({_db(rms)} dBFS), max {mu:.3g} {unit}, "
                f"{n} of {d.size} samples differ; {verdict} --max-ulp {max_ulp:g}")


def _manifest(d: Path) -> dict:
    try:
        return json.loads((d / MANIFEST).read_text())
    except (OSError, ValueError):
        return {}


def cmd_compare(a) -> int:
    da, db = Path(a.dir_a), Path(a.dir_b)
    for d in (da, db):
        if not d.is_dir():
            print(f"render_fingerprint: {d} is not a directory", file=sys.stderr)
            return 2
    ma, mb = _manifest(da), _manifest(db)
    for tag, d, m in (("A", da, ma), ("B", db, mb)):
        g = m.get("git", {})
        print(f"{tag}: {d}  commit {g.get('commit')}{' (dirty)' if g.get('dirty') else ''}, "
              f"{m.get('mode', 'no manifest')}, {m.get('created', '')}")
    fa, fb = _outputs(da), _outputs(db)
    if not fa and not fb:
        print("render_fingerprint: no outputs in either directory", file=sys.stderr)
        return 2
    names = sorted(fa | fb)
    w = max(len(n) for n in names)
    fails = skipped = identical = within = 0
    for n in names:
        if n not in fa or n not in fb:
            missing_in, m, present = ("A", ma, fb) if n not in fa else ("B", mb, fa)
            listed = n in m.get("outputs", {}) or any(n in r.get("outputs", ())
                                                      for r in m.get("runs", ()))
            if m.get("mode") == "quick" and not listed:
                skipped += 1
                print(f"{n:<{w}}  skipped: not recorded by the --quick run {missing_in}")
            else:
                fails += 1
                print(f"{n:<{w}}  MISSING in {missing_in}")
            continue
        k = _kind(n)
        try:
            if k == ".probe.npy":
                ok, msg = _cmp_probe(da / n, db / n)
            elif k == ".hammer.csv":
                ok, msg = _cmp_csv(da / n, db / n)
            else:
                ok, msg = _cmp_wav(da / n, db / n, a.max_ulp)
        except Exception as e:    # unreadable file: a failure, not a crash
            ok, msg = False, f"ERROR reading: {type(e).__name__}: {e}"
        fails += not ok
        identical += msg.startswith("identical")
        within += ok and not msg.startswith("identical")
        print(f"{n:<{w}}  {msg}")
    compared = sum(1 for n in names if n in fa and n in fb)
    print(f"summary: {compared} compared, {identical} identical, {within} within "
          f"{a.max_ulp:g} ULP, {fails} failing, {skipped} skipped (quick run) -> "
          f"{'PASS' if fails == 0 else 'FAIL'}")
    return 0 if fails == 0 else 1


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="render_fingerprint",
                                description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("record", help="render the fingerprint set into OUTDIR")
    r.add_argument("outdir")
    r.add_argument("--quick", action="store_true",
                   help="study presets and the Paderewski roll only")
    r.add_argument("--midi-dir", default=DEFAULT_MIDI_DIR,
                   help=f"directory of the MIDI files (default {DEFAULT_MIDI_DIR})")
    r.add_argument("--force", action="store_true", help="write into a non-empty OUTDIR")
    r.set_defaults(func=cmd_record)
    c = sub.add_parser("compare", help="compare two recorded directories")
    c.add_argument("dir_a")
    c.add_argument("dir_b")
    c.add_argument("--max-ulp", type=float, default=1.0,
                   help="largest float32 ULP distance a WAV sample may have (default 1)")
    c.set_defaults(func=cmd_compare)
    a = p.parse_args(argv)
    return a.func(a)


if __name__ == "__main__":
    sys.exit(main())
