"""Batch rendering's throughput and Dask's overhead (issue 15).

The same jobs rendered three ways, in one run:

* **one process**: :func:`synth.apps.batch_worker.render_job` and the writes of
  the WAV and its row, in a loop in this process, then the manifest (what
  :func:`~synth.apps.batch.render_many` does, without Dask);
* **Dask, 1 worker**: :func:`synth.apps.batch.render_many` on a
  LocalCluster of one single-threaded worker;
* **Dask, 2 workers** (or ``--workers N``).

Dask's overhead per job is (Dask with 1 worker - one process) / jobs,
also given as a share of a job's time in one process.  The one-process
runs alternate with the 1-worker runs (one of each, ``--runs`` times), so
that a change of the machine's load during the run falls on both; each
way's figure is the median of its runs.  The cluster's start (and its
workers' warm-up) is timed apart, as it is paid once per run of ``synth
batch``, not per job.  The CPU time of the one-process runs (this
process's user + system time) is printed next to their wall time: on a
machine shared with other work the two differ, and the CPU time is what
one core would take on its own.

The jobs are notes of ``--preset`` spread over its keys, or, with
``--spec NAME`` (a spec file or a shipped spec, e.g. ``nsynth-small``),
``--sample K`` jobs of each of the spec's presets, spread evenly over that
preset's jobs (0: all of them).  A table per preset gives each one's cost
per job and its throughput per core in one process.

``--project N`` adds a projection, on paper, of a set of N jobs with the
spec's mix of presets on ``--cores`` cores, from the measured figures: the
one-process cost of a job per preset and Dask's per-core rate against it,
the client's cost per job (writing a WAV and its row, measured here), the
WAV bytes through the client at ``--net-gbps`` (an assumption, printed as
one), Dask's cost per task (no-op tasks through this machine's cluster),
and the final manifest written from N rows (measured here, on N copies of
the measured rows).

Usage
-----
    python tools/bench.py batch [--preset grand-piano] [--jobs 16] [--seconds 4]
                                [--workers 2] [--runs 3] [--dask-defaults] [--quick]
    python tools/bench.py batch --spec nsynth-small --sample 4 --runs 3 \\
                                --project 300000 --cores 100
    python tools/bench.py batch --jobs 4 --where 20
    python tools/bench.py batch --idle 20

Two probes of Dask's cost, each alone:

* ``--where ROUNDS``: the jobs rendered in this process's main thread, in a
  thread of it, and in a Dask worker's task thread, alternated; per job the
  wall time, the time on a CPU and the time blocked (the GIL, files), from
  the kernel's per-thread ``schedstat`` (a busy machine skews it far less
  than the wall time);
* ``--idle SECONDS``: the CPU time Dask's own threads take in an idle
  1-worker local cluster, with synth batch's settings
  (:data:`synth.apps.batch.QUIET_DASK`) and with Dask's defaults.

``--quick`` (a few 1-s biwa notes, one run, a projection of 2000 jobs)
checks that the tool works.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

# as in the workers (synth.apps.batch.local_cluster), before numpy is imported
if "numba" not in sys.modules:
    # one core; only before numba is imported (imported by a test, after numba
    # started its threads, a changed NUMBA_NUM_THREADS fails the next compile)
    os.environ.setdefault("NUMBA_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
# glibc read it when this process started (the local cluster sets it in
# os.environ for its workers later)
ARENAS_HERE = os.environ.get("MALLOC_ARENA_MAX", "unset")


def _spec(preset: str, n: int, seconds: float) -> str:
    from synth.io.presets import load_preset

    p = load_preset(preset)
    lo, hi = p.play.key_low, p.play.key_high
    keys = sorted({lo + round(i * (hi - lo) / max(n - 1, 1)) for i in range(n)})
    hold = min(3.0, 0.75 * seconds)
    return (f'schema = 1\n[[notes]]\nname = "bench"\npreset = "{preset}"\n'
            f"keys = {keys}\nvelocities = [90]\nseconds = {seconds}\nhold_seconds = {hold}\n")


def _sample(jobs: list, k: int) -> list:
    """``k`` jobs of each preset, spread evenly over that preset's jobs."""
    by: dict = {}
    for j in jobs:
        by.setdefault(j.preset, []).append(j)
    out = []
    for js in by.values():
        if 0 < k < len(js):
            idx = [len(js) // 2] if k == 1 else sorted(
                {round(i * (len(js) - 1) / (k - 1)) for i in range(k)})
            js = [js[i] for i in idx]
        out += js
    return sorted(out, key=lambda j: j.index)


def _busy(seconds: float, nbytes: int) -> dict:
    """A stand-in job: busy for `seconds` (as a render is), returning a
    WAV-sized result, for Dask's own cost per job."""
    t = time.perf_counter()
    while time.perf_counter() - t < seconds:
        pass
    return {"wav": os.urandom(nbytes), "row": {}}


def _machinery(client, n: int, seconds: float, nbytes: int) -> float:
    """Dask's cost per job (s): n stand-in jobs through the cluster, less their work."""
    from dask.distributed import as_completed

    t = time.perf_counter()
    futs = [client.submit(_busy, seconds, nbytes, pure=False) for _ in range(n)]
    for f in as_completed(futs):
        f.result()
        f.release()
    return (time.perf_counter() - t - n * seconds) / n


def _noop(i: int) -> int:
    return i


def _task_rate(client, n: int) -> float:
    """Seconds per task of n no-op tasks through the cluster (submitted,
    run, gathered as they finish): Dask's own ceiling on jobs per second."""
    from dask.distributed import as_completed

    t = time.perf_counter()
    futs = client.map(_noop, range(n), pure=False)
    for f in as_completed(futs):
        f.result()
    return (time.perf_counter() - t) / n


def _cpu() -> float:
    """This thread's CPU time (s): the one-process way's own work, without
    the threads a running LocalCluster keeps in this process."""
    return time.thread_time()


def _tree_cpu() -> float:
    """CPU time (s) of this process and its children (the cluster's workers):
    every thread of Dask's client, scheduler, nannies and workers."""
    import psutil

    me = psutil.Process()
    tot = 0.0
    for q in [me, *me.children(recursive=True)]:
        try:
            t = q.cpu_times()
        except psutil.Error:
            continue
        tot += t.user + t.system
    return tot


def _manifest_cost(rows: list[dict], n: int, work: Path) -> tuple[float, float, int]:
    """Build and write the manifest of ``n`` rows (copies of ``rows``, each
    with its own hash): seconds for the DataFrame, for the Parquet file, and
    its size in bytes."""
    from synth.apps import batch as B

    big = []
    for i in range(n):
        r = dict(rows[i % len(rows)])
        r["index"], r["hash"] = i, f"{i:064x}"
        big.append(r)
    t = time.perf_counter()
    df = B._manifest(big)
    t_df = time.perf_counter() - t
    out = work / "manifest-cost"
    out.mkdir(exist_ok=True)
    t = time.perf_counter()
    B._write_manifest(out, df, csv=False)
    t_pq = time.perf_counter() - t
    return t_df, t_pq, (out / B.MANIFEST_FILE).stat().st_size


def _sched() -> tuple[float, float]:
    """This thread's time on a CPU and waiting for one (s), from the kernel."""
    import threading

    with open(f"/proc/self/task/{threading.get_native_id()}/schedstat") as f:
        on, wait, _ = f.read().split()
    return int(on) * 1e-9, int(wait) * 1e-9


def _timed_jobs(jobs: list) -> list[tuple[float, float, float, int, float]]:
    """Render the jobs here (in memory, as a worker does); per job its wall
    time, the time its thread was on a CPU, the time it was blocked (neither
    on a CPU nor waiting for one: the GIL, files), its page faults and its
    system time."""
    import resource

    from synth.apps import batch as B

    out = []
    for j in jobs:
        on0, wait0 = _sched()
        r0 = resource.getrusage(resource.RUSAGE_THREAD)
        t = time.perf_counter()
        B.render_job(j)
        wall = time.perf_counter() - t
        r1 = resource.getrusage(resource.RUSAGE_THREAD)
        on1, wait1 = _sched()
        out.append((wall, on1 - on0, wall - (on1 - on0) - (wait1 - wait0),
                    r1.ru_minflt - r0.ru_minflt, r1.ru_stime - r0.ru_stime))
    return out


def _in_thread(jobs: list) -> list:
    import threading

    box: list = []
    th = threading.Thread(target=lambda: box.append(_timed_jobs(jobs)))
    th.start()
    th.join()
    return box[0]


def _cluster(workers: int, dask_defaults: bool = False):
    """synth batch's local cluster, or, with ``dask_defaults``, the same with
    Dask's own settings for its threads (the profiler, the ticks, the
    monitors) instead of QUIET_DASK and glibc's own malloc arenas instead of
    MALLOC_ARENA_MAX=1: the local cluster before they were set."""
    from synth.apps import batch as B

    if not dask_defaults:
        return B.local_cluster(workers, dashboard=False)
    if os.environ.get(B.MALLOC_ARENAS) is not None:
        raise SystemExit(f"--dask-defaults: unset {B.MALLOC_ARENAS} first")
    saved, arenas = dict(B.QUIET_DASK), B.MALLOC_ARENAS
    B.QUIET_DASK.clear()
    B.MALLOC_ARENAS = "SYNTH_BENCH_NOT_SET"          # a variable glibc does not read
    try:
        return B.local_cluster(workers, dashboard=False)
    finally:
        B.QUIET_DASK.update(saved)
        B.MALLOC_ARENAS = arenas


def _where(jobs: list, rounds: int) -> None:
    """The same jobs in this process's main thread, in a thread of it, and
    in a Dask worker's task thread, alternated (the order turns each round)."""
    from dask.distributed import Client

    from synth.apps import batch as B

    cluster = _cluster(1)
    client = Client(cluster)
    try:
        client.run(B.warm_worker, B._distinct_presets(jobs))
        client.submit(_timed_jobs, jobs[:1], pure=False).result()
        ways = {"main thread": lambda: _timed_jobs(jobs), "a thread": lambda: _in_thread(jobs),
                "Dask worker": lambda: client.submit(_timed_jobs, jobs, pure=False).result()}
        names = list(ways)
        res: dict = {k: [] for k in names}          # per round, per job
        for r in range(rounds):
            for k in names[r % 3:] + names[:r % 3]:
                res[k].append(ways[k]())
    finally:
        client.close()
        cluster.close()
    print(f"# {len(jobs)} jobs a round, {rounds} rounds; load average {os.getloadavg()[0]:.2f}; "
          f"{B.MALLOC_ARENAS} here {ARENAS_HERE}, in the worker 1")
    print("| where | wall s per job | on a CPU s per job | blocked ms per job | page faults "
          "per job | system ms per job | wall vs main thread | on a CPU vs main thread |")
    print("|---|---|---|---|---|---|---|---|")
    base = res["main thread"]

    def per_job(run, i):
        return sum(x[i] for x in run) / len(run)

    for k in names:
        v = res[k]
        rw = statistics.median(per_job(x, 0) / per_job(b, 0) for x, b in zip(v, base))
        rc = statistics.median(per_job(x, 1) / per_job(b, 1) for x, b in zip(v, base))
        m = [statistics.median(per_job(x, i) for x in v) for i in range(5)]
        print(f"| {k} | {m[0]:.3f} | {m[1]:.3f} | {1e3 * m[2]:.1f} | {m[3]:.0f} | "
              f"{1e3 * m[4]:.1f} | {rw:.3f} | {rc:.3f} |")
    print("(medians over the rounds; the ratios are each round's, paired)")
    print("\n| key | on a CPU s, main thread | a thread vs main | Dask worker vs main "
          "| page faults: main, thread, worker |")
    print("|---|---|---|---|---|")
    for i, j in enumerate(jobs):
        def med(k, f):
            return statistics.median(f(run[i], b[i]) for run, b in zip(res[k], base))
        print(f"| {j.key} | {statistics.median(b[i][1] for b in base):.3f} | "
              f"{med('a thread', lambda x, b: x[1] / b[1]):.3f} | "
              f"{med('Dask worker', lambda x, b: x[1] / b[1]):.3f} | "
              + ", ".join(f"{statistics.median(run[i][3] for run in res[k]):.0f}" for k in names)
              + " |")


def _idle(jobs: list, seconds: float) -> None:
    """CPU time Dask's own threads take, idle, in a 1-worker local cluster:
    the worker process, and this process (scheduler, nanny, client)."""
    import psutil
    from dask.distributed import Client

    from synth.apps import batch as B

    def cpu(p) -> float:
        t = p.cpu_times()
        return t.user + t.system

    print("| settings | worker ms CPU per s | scheduler, nanny and client ms CPU per s |")
    print("|---|---|---|")
    # Dask's defaults first: synth's cluster leaves MALLOC_ARENA_MAX=1 in os.environ
    for name, defaults in (("Dask's defaults", True), ("synth batch's (QUIET_DASK)", False)):
        cluster = _cluster(1, dask_defaults=defaults)
        client = Client(cluster)
        try:
            client.run(B.warm_worker, B._distinct_presets(jobs))
            time.sleep(2.0)
            w = psutil.Process(next(iter(client.run(os.getpid).values())))
            me = psutil.Process()
            w0, m0, t = cpu(w), cpu(me), time.perf_counter()
            time.sleep(seconds)
            el = time.perf_counter() - t
            print(f"| {name} | {1e3 * (cpu(w) - w0) / el:.1f} | {1e3 * (cpu(me) - m0) / el:.1f} |")
        finally:
            client.close()
            cluster.close()


def _hms(s: float) -> str:
    s = round(s)
    return f"{s // 3600}:{s % 3600 // 60:02d}:{s % 60:02d}"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--preset", default="grand-piano")
    ap.add_argument("--jobs", type=int, default=16)
    ap.add_argument("--seconds", type=float, default=4.0)
    ap.add_argument("--spec", help="take the jobs from this batch spec (a file or a shipped name)")
    ap.add_argument("--sample", type=int, default=0,
                    help="with --spec: this many jobs of each preset (0: all)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--project", type=int, default=0, metavar="N",
                    help="project the time of N jobs with the spec's preset mix on --cores")
    ap.add_argument("--cores", type=int, default=100)
    ap.add_argument("--net-gbps", type=float, default=1.0,
                    help="assumed network rate into the client, GB/s (for --project)")
    ap.add_argument("--where", type=int, default=0, metavar="ROUNDS",
                    help="only compare where a job runs (main thread, a thread, a Dask "
                         "worker), ROUNDS rounds")
    ap.add_argument("--idle", type=float, default=0, metavar="SECONDS",
                    help="only measure the CPU Dask's own threads take, idle, for SECONDS")
    ap.add_argument("--dask-defaults", action="store_true",
                    help="run the clusters with Dask's own settings for its threads and "
                         "glibc's own malloc arenas (not QUIET_DASK, MALLOC_ARENA_MAX=1)")
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--json", metavar="OUT.json",
                    help="also write the figures printed as JSON (the ways, the presets, the projection)")
    a = ap.parse_args(argv)
    if a.quick:
        a.preset, a.jobs, a.seconds, a.runs, a.spec = "biwa", 4, 1.0, 1, None
        a.project = a.project or 2000
    n_tasks = 200 if a.quick else 2000

    from dask.distributed import Client

    from synth.apps import batch as B
    from synth.apps import batch_worker as W

    work = Path(tempfile.mkdtemp(prefix="bench-batch-"))
    try:
        if a.spec:
            every = B.load_spec(a.spec)
            jobs = _sample(every, a.sample)
            what = f"{a.spec} (a sample of {a.sample or 'all'} per preset)"
        else:
            spec = work / "spec.toml"
            spec.write_text(_spec(a.preset, a.jobs, a.seconds), "utf-8")
            jobs = every = B.load_spec(spec)
            what = a.preset
        n = len(jobs)
        load0 = os.getloadavg()
        B.warm_worker(B._distinct_presets(jobs))
        if a.where or a.idle:
            if a.where:
                _where(jobs, a.where)
            if a.idle:
                _idle(jobs, a.idle)
            return 0
        import pandas  # noqa: F401  (imported before the timed runs, for both ways)
        import pyarrow  # noqa: F401

        per_job: dict = {j.hash: [] for j in jobs}      # (wall, cpu, store, row) per run

        def one_process() -> tuple[float, float]:
            out = work / "single"
            shutil.rmtree(out, ignore_errors=True)
            W._VOICES.clear()
            t, c = time.perf_counter(), _cpu()
            done = []
            for j in jobs:
                tj, cj = time.perf_counter(), _cpu()
                res = B.render_job(j)
                ts = time.perf_counter()
                row = B._store(out, j, res)
                te = time.perf_counter()
                per_job[j.hash].append((te - tj, _cpu() - cj, te - ts, row))
                done.append(row)
            B._write_manifest(out, B._manifest(done), csv=False)    # as render_many does
            return time.perf_counter() - t, _cpu() - c

        def dask(client) -> tuple[float, float]:
            out = work / "dask"
            shutil.rmtree(out, ignore_errors=True)
            client.run(W._VOICES.clear)
            t, c = time.perf_counter(), _tree_cpu()
            res = B.render_many(jobs, out, client=client, progress=False, log=lambda s: None)
            el, cpu = time.perf_counter() - t, _tree_cpu() - c
            assert res.rendered == n and not res.failed, res.failed
            return el, cpu

        t1: list = []
        rows = []
        task_s = None
        for w in sorted({1, a.workers}):
            t = time.perf_counter()
            cluster = _cluster(w, a.dask_defaults)
            client = Client(cluster)
            client.run(B.warm_worker, B._distinct_presets(jobs))
            start = time.perf_counter() - t
            try:
                ts = []
                for _ in range(a.runs):
                    if w == 1:
                        t1.append(one_process())
                    ts.append(dask(client))
                if w == 1:
                    d1_cpu = statistics.median(x[1] for x in ts)
                    job_s = statistics.median(x[0] for x in t1) / n
                    nbytes = max(r[-1][3]["wav_bytes"] for r in per_job.values())
                    machinery = statistics.median(
                        _machinery(client, n, job_s, nbytes) for _ in range(a.runs))
                if w == max(1, a.workers) and a.project:
                    task_s = _task_rate(client, n_tasks)
            finally:
                client.close()
                cluster.close()
            rows.append((f"Dask, {w} worker{'s' if w > 1 else ''}", w,
                         statistics.median(x[0] for x in ts), start,
                         statistics.median(x[1] for x in ts)))
        base = statistics.median(x[0] for x in t1)
        base_cpu = statistics.median(x[1] for x in t1)
        rows.insert(0, ("one process", 1, base, None, base_cpu))
        audio_s = sum(per_job[j.hash][0][3]["duration_s"] for j in jobs)
        import dask

        from synth.apps.bench import harness

        print(harness.header())
        print(f"# dask {dask.__version__}; load average {load0[0]:.2f} at the start, "
              f"{os.getloadavg()[0]:.2f} at the end ({os.cpu_count()} cores)")
        print(f"# {n} jobs of {what} ({audio_s:g} s of audio), median of {a.runs} run(s)"
              + ("; Dask's default settings" if a.dask_defaults else ""))
        print("| way | workers | wall s | audio s per wall s | per core | vs one process "
              "| CPU s | cluster start s |")
        print("|---|---|---|---|---|---|---|---|")
        for name, w, el, start, cpu in rows:
            st = "-" if start is None else f"{start:.1f}"
            print(f"| {name} | {w} | {el:.2f} | {audio_s / el:.2f} | {audio_s / el / w:.2f} | "
                  f"{base / el:.2f}x | {cpu:.2f} | {st} |")
        print("(CPU s: one process, its thread's CPU time; Dask, every thread of the client, "
              "scheduler, nannies and workers)")
        d1 = next(r for r in rows if r[0] == "Dask, 1 worker")[2]
        per = (d1 - base) / n
        per_cpu = (d1_cpu - base_cpu) / n
        print(f"\nDask's overhead per job (1 worker against one process): {per * 1e3:+.0f} ms, "
              f"{100 * per / (base / n):+.1f} % of a job's {base / n:.2f} s; in CPU time "
              f"{per_cpu * 1e3:+.0f} ms, {100 * per_cpu / (base_cpu / n):+.1f} % of a job's "
              f"{base_cpu / n:.2f} s")
        print(f"Dask's own cost per job (stand-in jobs as long, returning as many bytes, on "
              f"1 worker): {machinery * 1e3:+.1f} ms, {100 * machinery / (base / n):+.1f} %")

        # per preset, in one process: the median over the runs of each job
        med = {h: [statistics.median(x[k] for x in v) for k in range(3)]
               for h, v in per_job.items()}
        by: dict = {}
        for j in jobs:
            row = per_job[j.hash][0][3]
            s = by.setdefault(j.preset, {"n": 0, "audio": 0.0, "wall": 0.0, "cpu": 0.0,
                                         "store": 0.0, "render": 0.0, "analysis": 0.0,
                                         "bytes": 0})
            wall, cpu, store = med[j.hash]
            s["n"] += 1
            s["audio"] += row["duration_s"]
            s["wall"] += wall
            s["cpu"] += cpu
            s["store"] += store
            s["render"] += statistics.median(x[3]["render_s"] for x in per_job[j.hash])
            s["analysis"] += statistics.median(x[3]["analysis_s"] for x in per_job[j.hash])
            s["bytes"] += row["wav_bytes"]
        print("\nOne process, per preset (each job's median over the runs):")
        print("| preset | jobs | s per job | CPU s per job | render s | analysis s | write s "
              "| audio s per core-second | WAV MB |")
        print("|---|---|---|---|---|---|---|---|---|")
        for p, s in by.items():
            k = s["n"]
            print(f"| {p} | {k} | {s['wall'] / k:.3f} | {s['cpu'] / k:.3f} | "
                  f"{s['render'] / k:.3f} | {s['analysis'] / k:.3f} | {s['store'] / k:.4f} | "
                  f"{s['audio'] / s['wall']:.2f} | {s['bytes'] / k / 1e6:.2f} |")
        out_json = {
            "jobs": n, "audio_s": audio_s, "runs": a.runs,
            "ways": [{"way": name, "workers": w, "wall_s": el, "cpu_s": cpu, "start_s": start}
                     for name, w, el, start, cpu in rows],
            "overhead_per_job_s": {"wall": per, "cpu": per_cpu, "machinery": machinery},
            "presets": {p: {"jobs": s["n"], **{f"{key}_s": s[key] / s["n"] for key in
                                               ("wall", "cpu", "render", "analysis", "store")},
                            "audio_s_per_wall_s": s["audio"] / s["wall"],
                            "wav_bytes": s["bytes"] / s["n"]} for p, s in by.items()},
            "projection": None}

        if a.project:
            import pickle

            mix: dict = {}
            for j in every:
                mix[j.preset] = mix.get(j.preset, 0) + 1
            tot = sum(mix.values())

            def mean(key: str) -> float:
                return sum(mix[p] / tot * by[p][key] / by[p]["n"] for p in mix)

            job_s, job_cpu, job_b = mean("wall"), mean("cpu"), mean("bytes")
            job_pickle = statistics.mean(len(pickle.dumps(j)) for j in jobs)
            store_s = statistics.median(x[2] for v in per_job.values() for x in v)
            t = time.perf_counter()
            intact = sum(B._finished(work / "dask", j) is not None for j in jobs)
            check_s = (time.perf_counter() - t) / n
            assert intact == n
            N, C = a.project, a.cores
            own = max(machinery, 0.0)
            compute = N * (job_cpu + own) / C
            compute_here = N * job_s / (C * base / d1)
            rate = C / (job_cpu + own)
            net = N * job_b / (a.net_gbps * 1e9)
            sched = N * task_s
            t_df, t_pq, pq_bytes = _manifest_cost(
                [per_job[j.hash][0][3] for j in jobs], N, work)
            client_s = N * store_s
            mix_s = ", ".join(f"{p} {mix[p] / tot:.1%}" for p in mix)
            print(f"\nProjection: {N} jobs with the mix of {a.spec or a.preset} ({mix_s}) "
                  f"on {C} cores, each running one worker:")
            print(f"* a job, the mix's mean in one process: {job_cpu:.3f} s CPU, {job_s:.3f} s "
                  f"wall at this machine's load; Dask's own cost {own * 1e3:.1f} ms a job")
            print(f"* rendering, a core taking a job's CPU time plus Dask's own cost: "
                  f"{_hms(compute)} (h:mm:ss), {rate:.0f} jobs finishing per second "
                  f"(at the wall times of this machine's load, Dask 1 worker: {_hms(compute_here)})")
            print(f"* the client writes a WAV and its row in {store_s * 1e3:.2f} ms (two fsyncs): "
                  f"{_hms(client_s)} for all, at most {1 / store_s:.0f} jobs per second")
            print(f"* the WAVs, {job_b / 1e6:.2f} MB a job, {N * job_b / 1e9:.0f} GB in all, "
                  f"through the client at {a.net_gbps:g} GB/s (assumed): {_hms(net)}")
            print(f"* Dask here ran {1 / task_s:.0f} no-op tasks a second ({n_tasks} on {a.workers} "
                  f"workers, client and scheduler on the same cores): {_hms(sched)} for {N} "
                  f"tasks at that rate; a job's task is {job_pickle / 1e3:.1f} kB pickled, "
                  f"{N * job_pickle / 1e9:.2f} GB for all")
            print(f"* the manifest of {N} rows: {t_df:.1f} s to build the DataFrame, "
                  f"{t_pq:.1f} s to write it ({pq_bytes / 1e6:.0f} MB)")
            print(f"* resuming checks each finished job (its row, its WAV's SHA-256) in "
                  f"{check_s * 1e3:.1f} ms: {_hms(N * check_s)} before a second run starts")
            # (Dask's task rate is left out: here the scheduler shares 2 cores with
            # the client and the workers; on a cluster it has a machine of its own)
            longest = max(("rendering", compute), ("the client's writes", client_s),
                          ("the network", net), key=lambda x: x[1])
            print(f"* these overlap; the longest is {longest[0]}: about "
                  f"{_hms(longest[1] + t_df + t_pq)} with the manifest")
            out_json["projection"] = {
                "jobs": N, "cores": C, "mix": {p: mix[p] / tot for p in mix},
                "job_cpu_s": job_cpu, "job_wall_s": job_s, "dask_own_s": own,
                "rendering_s": compute, "client_writes_s": client_s, "network_s": net,
                "scheduler_s": sched, "manifest_s": t_df + t_pq, "resume_check_s": N * check_s,
                "longest": longest[0], "total_s": longest[1] + t_df + t_pq}
        if a.json:
            Path(a.json).write_text(json.dumps(out_json, indent=1) + "\n", "utf-8")
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return 0
