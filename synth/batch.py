"""Batch rendering, the Python API: ``synth.batch.render_many(jobs, client=None)``.

The implementation is :mod:`synth.apps.batch` (``synth batch`` is its
command); this module is the API by the issue's name::

    from synth.batch import load_spec, render_many

    jobs = load_spec("my-sweep.toml")              # or a shipped spec: "grand-hardness"
    df = render_many(jobs, out_dir="sweep/")       # a LocalCluster, one worker per core
    df.attrs["failed"]                             # [] when every job rendered

Pass ``client=dask.distributed.Client("tcp://HOST:8786")`` to render on an
existing cluster.  Needs the ``[batch]`` extra.
"""

from __future__ import annotations

import os
from collections.abc import Sequence

from .apps import batch as _b
from .apps.batch import BatchError, BatchResult, Job, load_spec, local_cluster, preset_sha256, render_job

__all__ = ["BatchError", "BatchResult", "Job", "load_spec", "local_cluster", "preset_sha256",
           "render_job", "render_many"]

#: where :func:`render_many` writes when no ``out_dir`` is given
DEFAULT_OUT_DIR = "synth-batch"


def render_many(jobs: Sequence[Job] | str | os.PathLike, client=None, *,
                out_dir: str | os.PathLike = DEFAULT_OUT_DIR, **kw):
    """Render jobs (or a spec, by path or shipped name) and return the manifest.

    Parameters
    ----------
    jobs : sequence of Job, or str or path
        Jobs from :func:`load_spec`, or a spec to load.
    client : dask.distributed.Client or None
        An existing cluster's client; None: a local cluster for this call.
    out_dir : path
        Where the WAV files, ``manifest.parquet`` and the finished jobs'
        rows go (default ``synth-batch`` in the working directory).
    **kw
        ``workers``, ``csv``, ``progress``, ``dashboard``, ``log`` of
        :func:`synth.apps.batch.render_many`.

    Returns
    -------
    pandas.DataFrame
        The manifest (as ``manifest.parquet``), one row per finished job
        in spec order.  ``.attrs`` holds ``rendered`` and ``skipped`` (job
        counts), ``failed`` (``[(file, reason), ...]``), ``wall_s`` and
        ``out_dir``.
    """
    if isinstance(jobs, (str, os.PathLike)):
        jobs = load_spec(jobs)
    res = _b.render_many(jobs, out_dir, client, **kw)
    df = res.manifest
    df.attrs.update(rendered=res.rendered, skipped=res.skipped,
                    failed=[(j.path, why) for j, why in res.failed], wall_s=res.wall_s,
                    out_dir=os.fspath(out_dir))
    return df
