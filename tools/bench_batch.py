"""Batch rendering's throughput and Dask's overhead (issue 15).

The same jobs rendered three ways, in one run:

* **one process**: :func:`synth.apps.batch.render_job` and the writes of
  the WAV and its row, in a loop in this process (no Dask);
* **Dask, 1 worker**: :func:`synth.apps.batch.render_many` on a
  LocalCluster of one single-threaded worker;
* **Dask, 2 workers** (or ``--workers N``).

Dask's overhead per job is (Dask with 1 worker - one process) / jobs,
also given as a share of a job's time in one process.  Each way is run
``--runs`` times into a fresh directory and the median is reported; the
cluster's start (and its workers' warm-up) is timed apart, as it is paid
once per run of ``synth batch``, not per job.

Usage
-----
    python tools/bench_batch.py [--preset grand-piano] [--jobs 16] [--seconds 4]
                                [--workers 2] [--runs 3] [--quick]

``--quick`` (a few 1-s biwa notes, one run) checks that the tool works.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

# as in the workers (synth.apps.batch.local_cluster), before numpy is imported
os.environ.setdefault("NUMBA_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def _spec(preset: str, n: int, seconds: float) -> str:
    from synth.io.presets import load_preset

    p = load_preset(preset)
    lo, hi = p.play.key_low, p.play.key_high
    keys = sorted({lo + round(i * (hi - lo) / max(n - 1, 1)) for i in range(n)})
    hold = min(3.0, 0.75 * seconds)
    return (f'schema = 1\n[[notes]]\nname = "bench"\npreset = "{preset}"\n'
            f"keys = {keys}\nvelocities = [90]\nseconds = {seconds}\nhold_seconds = {hold}\n")


def _busy(seconds: float, nbytes: int) -> dict:
    """A stand-in job: busy for `seconds` (as a render is), returning a
    WAV-sized result, for Dask's own cost per job."""
    t = time.perf_counter()
    while time.perf_counter() - t < seconds:
        pass
    return {"wav": os.urandom(nbytes), "row": {}}


def _machinery(client, n: int, seconds: float, nbytes: int) -> float:
    """Dask's cost per job (s): n stand-in jobs through one worker, less their work."""
    from dask.distributed import as_completed

    t = time.perf_counter()
    futs = [client.submit(_busy, seconds, nbytes, pure=False) for _ in range(n)]
    for f in as_completed(futs):
        f.result()
        f.release()
    return (time.perf_counter() - t - n * seconds) / n


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--preset", default="grand-piano")
    ap.add_argument("--jobs", type=int, default=16)
    ap.add_argument("--seconds", type=float, default=4.0)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--quick", action="store_true")
    a = ap.parse_args(argv)
    if a.quick:
        a.preset, a.jobs, a.seconds, a.runs = "biwa", 4, 1.0, 1

    from dask.distributed import Client

    from synth.apps import batch as B

    work = Path(tempfile.mkdtemp(prefix="bench-batch-"))
    try:
        spec = work / "spec.toml"
        spec.write_text(_spec(a.preset, a.jobs, a.seconds), "utf-8")
        jobs = B.load_spec(spec)
        n = len(jobs)
        audio_s = n * a.seconds
        B.warm_worker(B._distinct_presets(jobs))

        def one_process() -> float:
            out = work / "single"
            shutil.rmtree(out, ignore_errors=True)
            B._VOICES.clear()
            t = time.perf_counter()
            for j in jobs:
                B._store(out, j, B.render_job(j))
            return time.perf_counter() - t

        def dask(client) -> float:
            out = work / "dask"
            shutil.rmtree(out, ignore_errors=True)
            client.run(B._VOICES.clear)
            t = time.perf_counter()
            res = B.render_many(jobs, out, client=client, progress=False, log=lambda s: None)
            el = time.perf_counter() - t
            assert res.rendered == n and not res.failed, res.failed
            return el

        t1 = [one_process() for _ in range(a.runs)]
        rows = [("one process", 1, statistics.median(t1), None)]
        for w in sorted({1, a.workers}):
            t = time.perf_counter()
            cluster = B.local_cluster(w, dashboard=False)
            client = Client(cluster)
            client.run(B.warm_worker, B._distinct_presets(jobs))
            start = time.perf_counter() - t
            try:
                ts = [dask(client) for _ in range(a.runs)]
                if w == 1:
                    job_s = statistics.median(t1) / n
                    nbytes = max(f.stat().st_size for f in (work / "single").rglob("*.wav"))
                    machinery = statistics.median(
                        _machinery(client, n, job_s, nbytes) for _ in range(a.runs))
            finally:
                client.close()
                cluster.close()
            rows.append((f"Dask, {w} worker{'s' if w > 1 else ''}", w, statistics.median(ts), start))
        base = rows[0][2]
        import dask

        import cpu_target  # tools/, on sys.path when run as a script

        print(cpu_target.describe())
        print(f"# dask {dask.__version__}")
        print(f"# {n} notes of {a.seconds:g} s on {a.preset} ({audio_s:g} s of audio), "
              f"median of {a.runs} run(s), {os.cpu_count()} cores")
        print("| way | workers | wall s | audio s per wall s | per core | vs one process | cluster start s |")
        print("|---|---|---|---|---|---|---|")
        for name, w, el, start in rows:
            st = "-" if start is None else f"{start:.1f}"
            print(f"| {name} | {w} | {el:.2f} | {audio_s / el:.2f} | {audio_s / el / w:.2f} | "
                  f"{base / el:.2f}x | {st} |")
        d1 = next(r for r in rows if r[0] == "Dask, 1 worker")[2]
        per_job = (d1 - base) / n
        print(f"\nDask's overhead per job (1 worker against one process): {per_job * 1e3:+.0f} ms, "
              f"{100 * per_job / (base / n):+.1f} % of a job's {base / n:.2f} s")
        print(f"Dask's own cost per job (stand-in jobs as long, returning as many bytes, on "
              f"1 worker): {machinery * 1e3:+.1f} ms, {100 * machinery / (base / n):+.1f} %")
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
