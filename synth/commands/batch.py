"""`synth batch`: a spec's jobs on every core or a Dask cluster (synth.apps.batch)."""

from __future__ import annotations

import sys

from .common import check_not_inputs, fail, require_extra

NAME = "batch"
HELP = ("render a spec's notes, sweeps and MIDI files on every core "
        "or a Dask cluster, with a Parquet manifest (needs the [batch] extra)")
EPILOG = ("examples:\n"
          "  synth batch nsynth-small -o out --dry-run      # a shipped spec's jobs, rendered not\n"
          "  synth batch nsynth-small -o out --workers 2    # on a local cluster of 2 workers\n"
          "  synth batch mine.toml -o out --scheduler tcp://HOST:8786 --csv\n"
          "\n"
          "The spec format and the manifest's columns: synth help batch.")


def add_arguments(parser) -> None:
    parser.add_argument("spec", metavar="SPEC", help="batch spec (.toml; the format: synth help "
                        "batch) or a shipped spec's name (nsynth-small, grand-hardness, folk-tunes)")
    parser.add_argument("-o", "--output", required=True, metavar="DIR",
                        help="output directory (created; a second run skips the jobs it finds "
                             "finished; required)")
    parser.add_argument("--scheduler", metavar="ADDRESS", help="an existing Dask scheduler, e.g. "
                        "tcp://HOST:8786 (default: a local cluster, one worker per core)")
    parser.add_argument("--workers", type=int, metavar="N",
                        help="workers of the local cluster, 1-1024 (default: one per core)")
    parser.add_argument("--csv", action="store_true",
                        help="also write manifest.csv (default: the Parquet manifest only)")
    parser.add_argument("--dry-run", action="store_true",
                        help="validate the spec and list its jobs, render nothing (default: off)")


def run(args) -> int:
    from ..apps.batch import BatchError, load_spec, render_many

    if args.workers is not None and not (1 <= args.workers <= 1024):
        fail(f"--workers = {args.workers} is out of range (1 <= value <= 1024)")
    if args.workers is not None and args.scheduler is not None:
        fail("--workers and --scheduler are exclusive: an existing cluster has its own workers")
    import os

    check_not_inputs([("-o", args.output)],
                     [("spec", args.spec if os.path.isfile(args.spec) else None)])
    if not args.dry_run:
        require_extra("batch", "synth batch")
    jobs = load_spec(args.spec)
    n_notes = sum(j.kind == "note" for j in jobs)
    print(f"{args.spec}: {len(jobs)} jobs ({n_notes} notes, {len(jobs) - n_notes} MIDI renders)",
          file=sys.stderr)
    if args.dry_run:
        for j in jobs:
            what = f"key {j.key} velocity {j.velocity} {j.seconds:g} s" if j.kind == "note" \
                else f"{j.midi_name}"
            sets = f" [{'; '.join(j.overrides)}]" if j.overrides else ""
            print(f"{j.index}\t{j.path}\t{j.preset}: {what}{sets}")
        return 0
    client = None
    if args.scheduler is not None:
        try:
            from dask.distributed import Client
        except ImportError:
            fail('synth batch needs the [batch] extra: pip install "synth[batch]"')
        try:
            client = Client(args.scheduler, timeout="20s")
        except (OSError, TimeoutError) as e:
            fail(f"--scheduler {args.scheduler}: cannot connect ({str(e).splitlines()[0]})")
    try:
        res = render_many(jobs, args.output, client=client, workers=args.workers, csv=args.csv)
    except BatchError:
        raise
    finally:
        if client is not None:
            client.close()
    audio_s = sum(float(d or 0.0) for d in res.manifest["duration_s"]) if len(res.manifest) else 0.0
    print(f"{args.output}: {res.rendered} rendered, {res.skipped} already done, "
          f"{len(res.failed)} failed; {len(res.manifest)} rows in {args.output}/manifest.parquet; "
          f"{audio_s:.0f} s of audio, run took {res.wall_s:.1f} s")
    for j, why in res.failed:
        print(f"synth: error: {j.path}: {why}", file=sys.stderr)
    return 1 if res.failed else 0
