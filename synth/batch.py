"""Batch rendering, the Python API: ``synth.batch.render_many(jobs, client=None)``.

The implementation is :mod:`synth.apps.batch` (``synth batch`` is its
command); this module is the short name the API is used by::

    from synth.batch import load_spec, render_many

    jobs = load_spec("my-sweep.toml")          # or a shipped spec: "folk-tunes"
    result = render_many(jobs, "out/")         # a LocalCluster, one worker per core
    result.manifest                            # pandas.DataFrame, one row per job

Pass ``client=dask.distributed.Client("tcp://HOST:8786")`` to render on an
existing cluster.  Needs the ``[batch]`` extra.
"""

from __future__ import annotations

from .apps.batch import (
    BatchError,
    BatchResult,
    Job,
    load_spec,
    local_cluster,
    preset_sha256,
    render_job,
    render_many,
)

__all__ = ["BatchError", "BatchResult", "Job", "load_spec", "local_cluster", "preset_sha256",
           "render_job", "render_many"]
