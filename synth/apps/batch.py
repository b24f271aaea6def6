"""``synth batch``: many renders with their parameters and analysis, on every
core of a machine or on a Dask cluster.

A *spec* (versioned TOML, :data:`SPEC_SCHEMA`; ``docs/batch.md`` documents
every key) lists entries: ``[[notes]]`` (single notes, swept over presets,
keys, velocities, lengths, quality levels and any preset value given as a
``--set`` path) and ``[[midi]]`` (Standard MIDI Files played by presets).
:func:`load_spec` validates it and expands it into :class:`Job` objects;
an error is one line naming the file and the key (``spec.toml:
notes[1].velocities = [0] is out of range (1 <= value <= 127)``).

:func:`render_many` renders the jobs with ``dask.distributed`` (the
``[batch]`` extra):

* by default on a ``LocalCluster`` of one single-threaded worker process
  per core (``NUMBA_NUM_THREADS=1`` in each), the numba cache shared and
  warmed once by this process before the workers start;
* or on an existing cluster (``client=`` or ``synth batch --scheduler
  tcp://HOST:8786``), whose workers have ``synth`` installed.

Who writes what.  A worker renders a job in memory and returns the WAV
file's bytes and its manifest row; only the process that called
:func:`render_many` writes files: the WAV (atomically), then the row
(``DIR/.synth-batch/rows/HASH.json``, atomically), then, at the end, the
manifest ``DIR/manifest.parquet`` (and ``manifest.csv`` on request) from
the rows of the spec's jobs in spec order.  So a worker that dies (Dask
reruns its job elsewhere) leaves nothing half-written, a job is in the
manifest at most once (rows are keyed by the job's hash), the workers need
no shared file system, and a run stopped half-way keeps every job it
finished.  MIDI files and preset files given as paths travel with the job,
so a remote worker needs only ``synth``.

Resuming.  A job's hash (:mod:`synth.apps.batch_spec`) covers everything
that decides its samples.  A second run skips a job whose row exists and
whose WAV has the size and SHA-256 its row records; a missing or broken
file is rendered again.

Determinism.  The renders have no randomness (the soundboard's modes are
drawn from a seeded generator), random sweeps draw from
``numpy.random.default_rng(seed)`` in a documented order, and a voice
reused for several jobs in one worker renders the same samples as a fresh
one, so the same spec gives the same WAV bytes on any number of workers
(``tests/test_batch.py``).

Modules.  This one runs the jobs (the Dask cluster, the files, the
manifest) and re-exports the public names of the other two, which import
no Dask: :mod:`synth.apps.batch_spec` (the spec and :class:`Job`) and
:mod:`synth.apps.batch_worker` (:func:`render_job`, a worker's task).
Dask, pandas and pyarrow (the ``[batch]`` extra) are imported only when a
run starts.
"""

from __future__ import annotations

import hashlib
import importlib
import io
import json
import math
import os
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..io.errors import display_path

# the spec's and the worker's public names are this module's too (the names
# in __all__ and the spec's limits, as before the split)
from .batch_spec import (  # noqa: F401
    DEFAULT_SECONDS,
    DEFAULT_VELOCITY,
    MAX_JOBS,
    MAX_MIDI_S,
    MAX_NOTE_S,
    SPEC_SCHEMA,
    BatchError,
    Job,
    _toml_value,
    find_spec,
    load_spec,
    preset_sha256,
)
from .batch_worker import ANALYSIS_PARTIALS, VOICE_CACHE, render_job, warm_worker  # noqa: F401

__all__ = [
    "SPEC_SCHEMA",
    "MANIFEST_FILE",
    "STATE_DIR",
    "BatchError",
    "Job",
    "BatchResult",
    "load_spec",
    "find_spec",
    "preset_sha256",
    "render_job",
    "render_many",
    "local_cluster",
]

#: the manifest (Parquet) in the output directory
MANIFEST_FILE = "manifest.parquet"
#: the output directory's folder of finished jobs' rows
STATE_DIR = ".synth-batch"
#: the retries of a job whose worker raised (a worker that dies is rerun by
#: the scheduler itself, up to ``distributed.scheduler.allowed-failures``)
RETRIES = 2
#: the glibc tuning variable Dask's nanny sets (see :func:`local_cluster`)
MALLOC_TRIM = "MALLOC_TRIM_THRESHOLD_"
#: a trim threshold this high (bytes) leaves the renders at their speed
#: (1 GiB: a grand note in 0.53 s, as unset; 65536: 1.12 s)
MALLOC_TRIM_OK = 1 << 30
#: glibc's number of malloc arenas in a worker: 1, the main thread's.  Dask
#: runs a task in a thread of its own, which by default gets an arena of its
#: own, whose heaps glibc unmaps whenever they empty: a 4-s grand note on A0
#: took 23 % more CPU in a thread than in the main thread, with 1.6x the page
#: faults (``tools/bench.py batch --where``); in a worker with one arena, the same.
MALLOC_ARENAS = "MALLOC_ARENA_MAX"
#: Dask settings for the workers (and the local cluster's scheduler and
#: nannies).  With Dask's defaults (the statistical profiler every 10 ms, the
#: event loop's health tick every 20 ms, the memory monitor every 100 ms, the
#: system monitor every 0.5 s) an idle worker took 33-40 ms of CPU a second and
#: its nanny 20 more, about 6 % of the core it shares with the renders; with
#: these, 3-4 ms.  What is given up: the dashboard's profile page, and memory
#: limits checked once a second (a render holds far less than a worker's limit).
QUIET_DASK = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.worker.memory.monitor-interval": "1s",
    "distributed.admin.system-monitor.interval": "5s",
}


# --------------------------------------------------------------------------- driver
@dataclass
class BatchResult:
    """What :func:`render_many` did.

    Attributes
    ----------
    manifest : pandas.DataFrame
        One row per finished job of the spec, in spec order.
    rendered, skipped : int
        Jobs rendered now; jobs found finished and intact.
    failed : list of (Job, str)
        Jobs that failed, with the one-line reason.
    wall_s : float
        Time of the whole run (s).
    dashboard : str or None
        The Dask dashboard's address, if one ran.
    """

    manifest: Any
    rendered: int
    skipped: int
    failed: list
    wall_s: float
    dashboard: str | None = None


def _need_batch_extra(what: str):
    return BatchError(f'{what} needs the [batch] extra: pip install "synth[batch]"')


def _row_path(out: Path, h: str) -> Path:
    return out / STATE_DIR / "rows" / f"{h}.json"


def _finished(out: Path, job: Job) -> dict | None:
    """The job's row if it is finished and its WAV intact, else None."""
    rp = _row_path(out, job.hash)
    try:
        row = json.loads(rp.read_text("utf-8"))
    except (OSError, ValueError):
        return None
    wav = out / job.path
    try:
        if wav.stat().st_size != row.get("wav_bytes"):
            return None
        h = hashlib.sha256()
        with open(wav, "rb") as f:
            for chunk in iter(lambda: f.read(1 << 20), b""):
                h.update(chunk)
    except OSError:
        return None
    return row if h.hexdigest() == row.get("wav_sha256") else None


def _store(out: Path, job: Job, result: dict) -> dict:
    """Write a finished job: its WAV, then its row (both atomically)."""
    from ..io.wav import write_bytes_atomic, write_text_atomic

    wav = out / job.path
    wav.parent.mkdir(parents=True, exist_ok=True)
    write_bytes_atomic(wav, result["wav"])
    row = result["row"]
    rp = _row_path(out, job.hash)
    rp.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(rp, json.dumps(row, default=_jsonable))
    return row


def _jsonable(v):
    if isinstance(v, np.generic):
        return v.item()
    raise TypeError(f"{v!r} is not JSON")


def _manifest(rows: list[dict]):
    """The rows as a DataFrame with one dtype per column (``set.PATH``
    columns of numbers as float64, of other values as text)."""
    import pandas as pd

    df = pd.DataFrame(rows)
    for c in df.columns:
        if c.startswith("set."):
            vals = [v for v in df[c] if v is not None and not (isinstance(v, float) and math.isnan(v))]
            if vals and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in vals):
                df[c] = df[c].astype("float64")
            elif vals:
                df[c] = [None if v is None else (v if isinstance(v, str) else _toml_value(v))
                         for v in df[c]]
    for c in ("key", "velocity", "n_clipped", "notes"):
        if c in df.columns:
            df[c] = df[c].astype("Int64")
    return df


def _write_manifest(out: Path, df, csv: bool) -> None:
    from ..io.wav import write_bytes_atomic, write_text_atomic

    try:
        importlib.import_module("pyarrow")
    except ImportError:
        raise _need_batch_extra("the Parquet manifest") from None
    buf = io.BytesIO()
    df.to_parquet(buf, index=False)
    write_bytes_atomic(out / MANIFEST_FILE, buf.getvalue())
    if csv:
        write_text_atomic(out / "manifest.csv", df.to_csv(index=False))


def local_cluster(n_workers: int | None = None, *, dashboard: bool = True):
    """A ``LocalCluster`` of single-threaded worker processes, one per core
    by default, each with ``NUMBA_NUM_THREADS=1`` and ``SYNTH_THREADS=1`` (one
    render thread), ``MALLOC_ARENA_MAX=1``
    and this process's numba cache (``NUMBA_CACHE_DIR``, if set), and
    Dask's own threads slowed down (:data:`QUIET_DASK`).  Dask's nanny puts
    ``MALLOC_ARENA_MAX=1`` in this process's ``os.environ`` to spawn the
    workers with it (as it does with its own ``OMP_NUM_THREADS``)."""
    try:
        from dask.distributed import LocalCluster
    except ImportError:
        raise _need_batch_extra("synth batch") from None
    n = n_workers or os.cpu_count() or 1
    # one render thread per worker (synth.dsp.threads): the workers are the cores
    env = {"NUMBA_NUM_THREADS": "1", "SYNTH_THREADS": "1", "OMP_NUM_THREADS": "1",
           "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    if os.environ.get("NUMBA_CACHE_DIR"):
        env["NUMBA_CACHE_DIR"] = os.environ["NUMBA_CACHE_DIR"]
    import dask

    # Dask's nanny sets MALLOC_TRIM_THRESHOLD_=65536 in its workers: glibc
    # then hands freed memory back at once and stops raising its mmap
    # threshold, and the engine's per-block arrays fault their pages in
    # again and again.  A grand note rendered 2.3x slower (0.48 s -> 1.12 s
    # for 4 s, the same with the variable set in one process).  None leaves
    # glibc's own adaptive thresholds.  MALLOC_ARENA_MAX=1 (MALLOC_ARENAS):
    # the task thread allocates from the main arena; glibc reads it when the
    # process starts, so it is set before the spawn, not in `env`.
    # QUIET_DASK: Dask's own threads take 0.4 % of a core instead of 6 % (the
    # nannies pass this configuration on to their workers).
    with dask.config.set({f"distributed.nanny.pre-spawn-environ.{MALLOC_TRIM}": None,
                          f"distributed.nanny.pre-spawn-environ.{MALLOC_ARENAS}": "1",
                          **QUIET_DASK}):
        return LocalCluster(n_workers=n, threads_per_worker=1, processes=True, env=env,
                            dashboard_address=":8787" if dashboard else None, silence_logs=40)


def render_many(jobs: Sequence[Job], out_dir: str | os.PathLike, client=None, *,
                workers: int | None = None, csv: bool = False, progress: bool | None = None,
                dashboard: bool = True, log: Callable[[str], None] | None = None) -> BatchResult:
    """Render jobs into ``out_dir`` and write the manifest.

    Parameters
    ----------
    jobs : sequence of Job
        From :func:`load_spec`.
    out_dir : path
        Output directory (created): ``NAME/...wav``, ``manifest.parquet``,
        ``.synth-batch/rows/``.
    client : dask.distributed.Client or None
        An existing cluster's client; None: a :func:`local_cluster` for
        this run (closed at the end).
    workers : int or None
        Workers of the local cluster (default: one per core).
    csv : bool
        Also write ``manifest.csv``.
    progress : bool or None
        A progress bar (tqdm) on stderr; None: when stderr is a terminal.
    dashboard : bool
        Start the local cluster's dashboard (``http://...:8787/status``).
    log : callable or None
        Receives one-line notes (default: stderr).

    Returns
    -------
    BatchResult
        ``.manifest`` is the DataFrame written to ``manifest.parquet``.

    Raises
    ------
    BatchError
        The ``[batch]`` extra is missing, or the output directory cannot
        be written.  A job that fails is not raised: it is listed in
        ``failed`` and left out of the manifest.
    """
    t_run = time.perf_counter()
    if log is None:
        def log(line):
            print(line, file=sys.stderr, flush=True)
    try:
        importlib.import_module("pandas")
        from dask.distributed import as_completed
    except ImportError:
        raise _need_batch_extra("synth batch") from None
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise BatchError(f"-o {display_path(out)}: is a file, give a directory")
    try:
        (out / STATE_DIR / "rows").mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise BatchError(f"-o {display_path(out)}: cannot create ({e.strerror or e})") from None
    rows: dict[str, dict] = {}
    todo = []
    for j in jobs:
        r = _finished(out, j)
        if r is None:
            todo.append(j)
        else:
            rows[j.hash] = r
    skipped = len(rows)
    failed: list = []
    dash = None
    if todo:
        own = client is None
        cluster = None
        if own:
            from dask.distributed import Client

            # the kernels are compiled (or loaded) here first, into the cache
            # the workers share, so they do not all compile them at once
            warm_worker(_distinct_presets(todo))
            cluster = local_cluster(workers, dashboard=dashboard)
            client = Client(cluster)
        try:
            dash = _dashboard(client)
            if dash:
                log(f"note: Dask dashboard at {dash}")
            try:
                trims = client.run(_malloc_trim)
            except Exception as err:       # a worker with another synth, or none
                raise BatchError(f"the cluster's workers cannot run this synth's batch jobs "
                                 f"({_one_line(err)}); is the same synth version installed "
                                 "on them?") from None
            trimmed = [w for w, v in trims.items() if v is not None and v < MALLOC_TRIM_OK]
            if trimmed:
                log(f"note: {len(trimmed)} of the cluster's {len(trims)} workers have {MALLOC_TRIM} "
                    f"below {MALLOC_TRIM_OK} (Dask's nanny sets 65536), which makes renders "
                    f"about 2x slower; start them with {MALLOC_TRIM}={MALLOC_TRIM_OK} in "
                    f"their environment (docs/batch.md)")
            arenas = [w for w, v in client.run(_malloc_arenas).items() if v != "1"]
            if arenas:
                log(f"note: {len(arenas)} of the cluster's {len(trims)} workers run without "
                    f"{MALLOC_ARENAS}=1, which makes low notes up to 23 % slower; "
                    f"start them with it in their environment (docs/batch.md)")
            loud = client.run(_noisy_dask)
            noisy = {k for v in loud.values() for k in v}
            n_noisy = sum(bool(v) for v in loud.values())
            if noisy:
                log(f"note: {n_noisy} of the cluster's {len(trims)} workers run Dask's own "
                    f"threads more often than synth batch's local cluster does "
                    f"({', '.join(sorted(noisy))}), which takes up to 6 % of each worker's "
                    f"core; docs/batch.md gives the settings")
            client.run(warm_worker, _distinct_presets(todo))
            futures = {}
            for j in todo:
                fut = client.submit(render_job, j, key=f"synth-batch-{j.name}-{j.hash[:20]}",
                                    retries=RETRIES, pure=False)
                futures[fut] = j
            bar = None
            show = progress if progress is not None else _is_terminal(sys.stderr)
            if show:
                from tqdm import tqdm

                bar = tqdm(total=len(todo), file=sys.stderr, unit="job", desc="rendering",
                           mininterval=0.5)
            try:
                for fut in as_completed(list(futures)):
                    j = futures.pop(fut)
                    try:
                        res = fut.result()
                    except Exception as err:          # the job's own failure: reported
                        failed.append((j, _one_line(err)))
                    else:
                        rows[j.hash] = _store(out, j, res)
                    fut.release()
                    if bar is not None:
                        bar.update(1)
            finally:
                if bar is not None:
                    bar.close()
                for fut in futures:
                    fut.cancel()
        finally:
            if own:
                client.close()
                cluster.close()
    # in this spec's order (a row kept from a run of an earlier version of
    # the spec is given its place in this one)
    ordered = [{**rows[j.hash], "index": j.index} for j in jobs if j.hash in rows]
    df = _manifest(ordered)
    _write_manifest(out, df, csv)
    return BatchResult(df, len(todo) - len(failed), skipped, failed,
                       time.perf_counter() - t_run, dash)


def _malloc_trim() -> int | None:
    """This worker's ``MALLOC_TRIM_THRESHOLD_`` (bytes), or None (glibc's
    adaptive default).  A function of this module, so that it runs in the
    worker: ``os.environ.get`` would be pickled with the client's mapping."""
    v = os.environ.get(MALLOC_TRIM)
    try:
        return None if v is None else int(v)
    except ValueError:
        return None


def _malloc_arenas() -> str | None:
    """This worker's ``MALLOC_ARENA_MAX`` (as :func:`_malloc_trim`, run in the worker)."""
    return os.environ.get(MALLOC_ARENAS)


def _noisy_dask() -> list[str]:
    """The settings of :data:`QUIET_DASK` that this worker runs more often
    than they say (or, for the profiler, at all)."""
    import dask
    from dask.utils import parse_timedelta

    out = []
    for k, v in QUIET_DASK.items():
        cur = dask.config.get(k, None)
        if isinstance(v, bool):
            if bool(cur) != v:
                out.append(k)
        elif cur is not None and parse_timedelta(cur) < parse_timedelta(v):
            out.append(k)
    return out


def _distinct_presets(jobs: Sequence[Job]) -> list:
    seen = {}
    for j in jobs:
        seen.setdefault(j.preset, j.preset_toml)
    return list(seen.items())


def _dashboard(client) -> str | None:
    try:
        info = client.scheduler_info()
        if "dashboard" not in info.get("services", {}):
            return None
        return client.dashboard_link
    except Exception:      # a scheduler without the dashboard service
        return None


def _one_line(err: BaseException) -> str:
    text = str(err).strip().splitlines()
    return f"{type(err).__name__}: {text[0]}" if text else type(err).__name__


def _is_terminal(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError, OSError):
        return False
