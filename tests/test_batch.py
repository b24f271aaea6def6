"""synth batch: specs, expansion, a LocalCluster of 2 workers, resuming,
determinism and a worker killed in the middle of a job (issue 15)."""

from __future__ import annotations

import hashlib
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from synth.apps import batch as B
from synth.apps import batch_worker as W
from synth.apps.batch import BatchError, load_spec, render_job, render_many
from synth.io.errors import display_path

pytest.importorskip("dask.distributed")
pd = pytest.importorskip("pandas")
pytest.importorskip("pyarrow")

# (a second cluster's scheduler serves its health page on another port, and says so)
pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning",
                                        "ignore::ResourceWarning",
                                        "ignore:Port 8787 is already in use:UserWarning")


def _spec(tmp_path: Path, text: str, name: str = "spec.toml") -> Path:
    p = tmp_path / name
    p.write_text(text, "utf-8")
    return p


#: 20 short jobs: 2 presets x 2 keys x 5 velocities (the biwa and the sitar:
#: the cheapest to render, and the sitar has a buzzing termination)
SPEC_20 = """
schema = 1
description = "twenty short notes"
[[notes]]
name = "grid"
presets = ["biwa", "sitar"]
keys = [50, 57]
velocities = {low = 40, high = 120, steps = 5}
seconds = 0.4
"""


# --------------------------------------------------------------------------- the spec
@pytest.mark.parametrize("text, msg", [
    ("[[notes]]\nname='a'\npreset='biwa'\nkeys=[50]", "missing key 'schema'"),
    ("schema = 2\n[[notes]]\nname='a'\npreset='biwa'\nkeys=[50]",
     "schema = 2 is not allowed (choices: 1)"),
    ("schema = 1", "no jobs"),
    ("schema = 1\n[[notes]]\nname='a'\npreset='biwa'\nkeys=[50]\nvelocity=3",
     "unknown key 'notes[0].velocity'"),
    ("schema = 1\n[[notes]]\nname='a'\npreset='biwa'\nkeys=[50]\nvelocities=[0, 64]",
     "notes[0].velocities[0] = 0 is out of range (1 <= value <= 127)"),
    ("schema = 1\n[[notes]]\nname='a'\npreset='biwa'\nkeys=[20]",
     "key 20 is outside the playable range of biwa"),
    ("schema = 1\n[[notes]]\nname='a'\npreset='bivwa'\nkeys=[50]", "unknown preset 'bivwa'"),
    ("schema = 1\n[[notes]]\nname='a'\npreset='biwa'\nkeys=[50]\nset={'pluck.positon'=[0.2]}",
     "unknown key 'pluck.positon'"),
    ("schema = 1\n[[notes]]\nname='a'\npreset='sitar'\nkeys=[50]\nset={'termination.buzz'=[2.0]}",
     "termination.buzz = 2"),
    ("schema = 1\n[[notes]]\nname='a'\npreset='biwa'\nkeys=[50]\nsweep='random'",
     "missing key 'notes[0].samples'"),
    ("schema = 1\n[[notes]]\nname='a'\npreset='biwa'\nkeys=[50]\n[[notes]]\nname='a'\n"
     "preset='biwa'\nkeys=[52]", "notes[1].name = 'a' is used twice"),
    ("schema = 1\n[[notes]]\nname='a b'\npreset='biwa'\nkeys=[50]", "notes[0].name = 'a b'"),
    ("schema = 1\n[[notes]]\nname='a'\npreset='biwa'\nkeys=[50]\nseconds={low=1, high=2}",
     "needs steps"),
    ("schema = 1\n[[midi]]\nname='m'\npreset='biwa'\nfiles='nothing*.mid'",
     "'nothing*.mid' matches no file"),
    ("schema = 1\n[[notes]]\nname='a'\npreset='biwa'\nkeys=[50]\nquality='best'",
     "notes[0].quality = 'best' is not allowed"),
])
def test_a_bad_spec_is_one_line_naming_the_key(tmp_path, text, msg):
    p = _spec(tmp_path, text)
    with pytest.raises(BatchError) as e:
        load_spec(p)
    s = str(e.value)
    assert msg in s and "\n" not in s and s.startswith(display_path(p) + ": ")


def test_a_bad_spec_exits_2_from_the_command(tmp_path):
    p = _spec(tmp_path, "schema = 1\n[[notes]]\nname='a'\npreset='biwa'\nkeys=[50]\nvelocity=3")
    r = subprocess.run([sys.executable, "-m", "synth.cli", "batch", str(p), "-o",
                        str(tmp_path / "out"), "--dry-run"], capture_output=True, text=True)
    assert r.returncode == 2
    assert r.stderr.strip().splitlines() == [
        f"synth: error: {display_path(p)}: unknown key 'notes[0].velocity' (allowed: name, "
        "preset, presets, keys, velocities, seconds, hold_seconds, quality, set, sweep, "
        "samples, seed)"]
    assert not (tmp_path / "out").exists()


def test_a_grid_expands_in_order_and_records_its_values(tmp_path):
    jobs = load_spec(_spec(tmp_path, """
schema = 1
[[notes]]
name = "g"
presets = ["sitar"]
keys = [50, 52]
velocities = [60, 100]
quality = ["draft", "standard"]
set = { "termination.buzz" = [0.0, 1.0] }
"""))
    assert len(jobs) == 16
    assert [j.index for j in jobs] == list(range(16))
    j = jobs[0]
    assert (j.key, j.velocity, j.quality, j.params) == (50, 60, "draft", (("termination.buzz", 0.0),))
    assert j.overrides == ("termination.buzz=0.0", "play.quality=draft")
    assert (jobs[1].quality, jobs[1].params[0][1]) == ("draft", 1.0)   # the last axis fastest
    assert jobs[-1].key == 52 and jobs[-1].velocity == 100
    assert len({j.hash for j in jobs}) == 16 and len({j.path for j in jobs}) == 16
    # the preset's content hash follows the values, not the name
    assert jobs[0].preset_sha256 != jobs[1].preset_sha256


def test_random_sweeps_are_seeded_and_the_playable_keys_follow_the_preset(tmp_path):
    text = """
schema = 1
[[notes]]
name = "r"
presets = ["grand-piano", "biwa"]
sweep = "random"
samples = 40
seed = {seed}
keys = "playable"
velocities = {{low = 1, high = 127}}
set = {{ "output.gain" = {{low = 0.001, high = 0.01}} }}
"""
    a = load_spec(_spec(tmp_path, text.format(seed=3), "a.toml"))
    b = load_spec(_spec(tmp_path, text.format(seed=3), "b.toml"))
    c = load_spec(_spec(tmp_path, text.format(seed=4), "c.toml"))
    assert [j.hash for j in a] == [j.hash for j in b]
    assert [j.hash for j in a] != [j.hash for j in c]
    for j in a:
        lo, hi = (21, 108) if j.preset == "grand-piano" else (43, 74)
        assert lo <= j.key <= hi and 1 <= j.velocity <= 127
        g = dict(j.params)["output.gain"]
        assert isinstance(g, float) and 0.001 <= g <= 0.01
    assert {j.preset for j in a} == {"grand-piano", "biwa"}


def test_the_shipped_specs_expand():
    counts = {"nsynth-small": 1225, "grand-hardness": 168, "folk-tunes": 9}
    for name, n in counts.items():
        jobs = load_spec(name)
        assert len(jobs) == n, name
    nsynth = load_spec("nsynth-small")
    assert {j.hold_s for j in nsynth} == {3.0} and {j.seconds for j in nsynth} == {4.0}
    assert {j.velocity for j in nsynth} == {25, 50, 75, 100, 127}
    folk = load_spec("folk-tunes")
    assert all(j.kind == "midi" and j.midi_bytes[:4] == b"MThd" for j in folk)


def test_a_user_preset_file_travels_with_the_job(tmp_path):
    from synth.io.presets import shipped_preset_dir

    text = (shipped_preset_dir() / "biwa.toml").read_text("utf-8")
    (tmp_path / "mybiwa.toml").write_text(text.replace("G2-D5", "G2-D5 (mine)"), "utf-8")
    jobs = load_spec(_spec(tmp_path, """
schema = 1
[[notes]]
name = "mine"
preset = "mybiwa.toml"
keys = [55]
seconds = 0.3
"""))
    (j,) = jobs
    assert j.preset == "mybiwa.toml" and j.preset_toml is not None
    os.rename(tmp_path / "mybiwa.toml", tmp_path / "gone.toml")    # a worker elsewhere
    r = render_job(j)
    assert r["row"]["preset"] == "mybiwa.toml" and r["wav"][:4] == b"RIFF"


# --------------------------------------------------------------------------- rendering
@pytest.fixture(scope="module")
def cluster():
    from dask.distributed import Client

    c = B.local_cluster(2, dashboard=False)
    client = Client(c)
    yield client
    client.close()
    c.close()


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.mark.slow  # over 2 s on a quiet 2-core machine (2026-11-29: 2.0-6.1 s)
def test_two_workers_render_a_spec_a_second_run_renders_nothing(tmp_path, cluster):
    import soundfile as sf

    jobs = load_spec(_spec(tmp_path, SPEC_20))
    assert len(jobs) == 20
    out = tmp_path / "out"
    res = render_many(jobs, out, client=cluster, csv=True, progress=False)
    assert (res.rendered, res.skipped, res.failed) == (20, 0, [])
    df = pd.read_parquet(out / "manifest.parquet")
    assert len(df) == 20 and df["hash"].is_unique
    assert list(df["hash"]) == [j.hash for j in jobs]          # spec order
    assert len(pd.read_csv(out / "manifest.csv")) == 20
    assert len(set(df["worker"])) == 2                          # both worked
    for j, row in zip(jobs, df.itertuples()):
        f = out / row.file
        assert row.file == j.path and _sha(f) == row.wav_sha256 and f.stat().st_size == row.wav_bytes
        x, fs = sf.read(f, always_2d=True)
        assert fs == row.fs_hz == 48000 and x.shape[0] == round(0.4 * 48000) == round(row.duration_s * fs)
        assert (row.preset, row.key, row.velocity) == (j.preset, j.key, j.velocity)
        assert row.preset_sha256 == j.preset_sha256 and len(row.preset_json) > 100
        # the analysis summary: within 10 cents (the sitar's key 50 at velocity
        # 120 starts sharp as its tension follows its swing: +6.3 over 0.4 s)
        assert abs(row.f0_cents) < 10.0
        assert -60 < row.loudness_lufs < 0 and row.centroid_hz > row.f0_hz
        assert row.render_s > 0
    # louder with velocity, per preset and key
    for (_, _), g in df.groupby(["preset", "key"]):
        assert g.sort_values("velocity")["loudness_lufs"].is_monotonic_increasing
    before = {p: p.stat().st_mtime_ns for p in out.rglob("*.wav")}
    res2 = render_many(jobs, out, client=cluster, progress=False)
    assert (res2.rendered, res2.skipped) == (0, 20)
    assert {p: p.stat().st_mtime_ns for p in out.rglob("*.wav")} == before
    pd.testing.assert_frame_equal(pd.read_parquet(out / "manifest.parquet"), df)
    # a missing file and a broken one are rendered again, and come out the same
    gone, broken = out / df.file[3], out / df.file[11]
    sha_gone, sha_broken = _sha(gone), _sha(broken)
    gone.unlink()
    with open(broken, "r+b") as fh:
        fh.truncate(1000)
    res3 = render_many(jobs, out, client=cluster, progress=False)
    assert (res3.rendered, res3.skipped) == (2, 18)
    assert _sha(gone) == sha_gone and _sha(broken) == sha_broken
    assert len(pd.read_parquet(out / "manifest.parquet")) == 20


@pytest.mark.slow  # over 2 s on a quiet 2-core machine: ~7 s of CPU, six renders with fresh voices
def test_the_same_spec_gives_the_same_bytes_in_one_process(tmp_path, cluster):
    """Against render_job in this process, voices fresh and reused alike."""
    jobs = load_spec(_spec(tmp_path, SPEC_20))
    out = tmp_path / "out"
    render_many(jobs[:6], out, client=cluster, progress=False)
    W._VOICES.clear()
    for j in reversed(jobs[:6]):            # another order: the voice is reused differently
        assert hashlib.sha256(render_job(j)["wav"]).hexdigest() == _sha(out / j.path)


@pytest.mark.slow  # over 2 s on a quiet 2-core machine: ~8 s of CPU, a cluster of its own
def test_a_killed_worker_s_job_is_done_again(tmp_path):
    """SIGKILL one of two workers while it renders: the scheduler reruns its
    job on the restarted worker; every job is in the manifest once."""
    from dask.distributed import Client

    jobs = load_spec(_spec(tmp_path, """
schema = 1
[[notes]]
name = "k"
preset = "sitar"
keys = [45, 55]
velocities = [70, 110]
seconds = 1.2
"""))
    c = B.local_cluster(2, dashboard=False)
    client = Client(c)
    killed = {}

    def kill():
        t_end = time.time() + 60
        while time.time() < t_end:
            started = [w for w, ks in client.processing().items() if ks]
            if started:
                time.sleep(0.3)                   # into the render
                w = started[0]
                pid = client.run(os.getpid, workers=[w])[w]
                killed["pid"], killed["tasks"] = pid, list(client.processing()[w])
                os.kill(pid, signal.SIGKILL)
                return
            time.sleep(0.05)

    try:
        B.warm_worker([("sitar", None)])
        client.run(B.warm_worker, [("sitar", None)])
        th = threading.Thread(target=kill)
        th.start()
        res = render_many(jobs, tmp_path / "out", client=client, progress=False)
        th.join()
        pids = set(client.run(os.getpid).values())
    finally:
        client.close()
        c.close()
    assert killed.get("tasks"), "no worker was busy to be killed"
    assert killed["pid"] not in pids                   # it died; the nanny started another
    assert (res.rendered, res.failed) == (4, [])
    df = pd.read_parquet(tmp_path / "out" / "manifest.parquet")
    assert len(df) == 4 and df["hash"].is_unique
    assert not list((tmp_path / "out").rglob("*.tmp"))
    for row in df.itertuples():
        assert _sha(tmp_path / "out" / row.file) == row.wav_sha256


@pytest.mark.slow  # over 2 s on a quiet 2-core machine (2026-11-29: 3.5 s)
def test_midi_jobs_render_with_loudness_and_centroid(tmp_path, cluster):
    from synth.io.presets import shipped_preset_dir

    mid = shipped_preset_dir() / "checks" / "phrases" / "biwa.mid"
    jobs = load_spec(_spec(tmp_path, f"""
schema = 1
format = "pcm24"
[[midi]]
name = "m"
files = "{mid.as_posix()}"
presets = ["biwa"]
max_seconds = 2.0
"""))
    res = render_many(jobs, tmp_path / "out", client=cluster, progress=False)
    (row,) = res.manifest.itertuples()
    assert row.kind == "midi" and row.midi_file == "biwa.mid" and row.notes >= 1
    assert row.duration_s <= 2.0 + 1e-9 and row.format == "pcm24"
    assert row.loudness_lufs < 0 and row.centroid_hz > 100 and pd.isna(row.f0_hz)


def test_without_the_extra_the_error_says_how_to_install(monkeypatch, tmp_path):
    import builtins

    real = builtins.__import__

    def no_dask(name, *a, **k):
        if name.startswith("dask"):
            raise ImportError(name)
        return real(name, *a, **k)

    jobs = load_spec(_spec(tmp_path, SPEC_20))
    monkeypatch.setattr(builtins, "__import__", no_dask)
    with pytest.raises(BatchError, match=r'needs the \[batch\] extra: pip install "synth\[batch\]"'):
        render_many(jobs, tmp_path / "out")


@pytest.mark.slow  # over 2 s on a quiet 2-core machine
def test_the_throughput_benchmark_runs_in_its_quick_mode(tmp_path):
    """tools/bench.py batch (docs/benchmarks.md, "Batch rendering") in CI's quick mode."""
    import json

    root = Path(__file__).resolve().parents[1]
    out = tmp_path / "batch.json"
    p = subprocess.run([sys.executable, str(root / "tools" / "bench.py"), "batch", "--quick",
                        "--json", str(out)], capture_output=True, text=True, cwd=root, timeout=600)
    assert p.returncode == 0, p.stderr
    d = json.loads(out.read_text())
    assert d["jobs"] == 4 and d["audio_s"] == pytest.approx(4.0) and d["runs"] == 1
    assert [(w["way"], w["workers"]) for w in d["ways"]] == [
        ("one process", 1), ("Dask, 1 worker", 1), ("Dask, 2 workers", 2)]
    assert all(w["wall_s"] > 0 and w["cpu_s"] > 0 for w in d["ways"])
    assert d["ways"][0]["start_s"] is None and all(w["start_s"] > 0 for w in d["ways"][1:])
    b = d["presets"]["biwa"]
    assert list(d["presets"]) == ["biwa"] and b["jobs"] == 4
    # a job's time holds its render, its analysis and its write
    assert b["render_s"] + b["analysis_s"] + b["store_s"] <= b["wall_s"] * 1.001
    assert b["audio_s_per_wall_s"] == pytest.approx(1.0 / b["wall_s"], rel=1e-9)
    pr = d["projection"]
    assert pr["jobs"] == 2000 and pr["cores"] == 100 and pr["mix"] == {"biwa": 1.0}
    assert pr["rendering_s"] == pytest.approx(2000 * (pr["job_cpu_s"] + pr["dask_own_s"]) / 100)
    assert pr["total_s"] >= max(pr["rendering_s"], pr["client_writes_s"], pr["network_s"])
    assert "Projection: 2000 jobs with the mix of biwa" in p.stdout


@pytest.mark.slow  # a Dask cluster renders a spec: 5 s
def test_the_python_api_returns_the_manifest(tmp_path, cluster):
    import synth.batch as api

    p = _spec(tmp_path, SPEC_20.replace("keys = [50, 57]", "keys = [50]").replace(
        "steps = 5", "steps = 2"))
    df = api.render_many(str(p), client=cluster, out_dir=tmp_path / "o", progress=False)
    assert isinstance(df, pd.DataFrame) and len(df) == 4
    assert df.attrs["rendered"] == 4 and df.attrs["failed"] == [] and df.attrs["skipped"] == 0
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "o" / "manifest.parquet"), df)


def _set_trim(value):
    if value is None:
        os.environ.pop("MALLOC_TRIM_THRESHOLD_", None)
    else:
        os.environ["MALLOC_TRIM_THRESHOLD_"] = value


@pytest.mark.slow  # the module's LocalCluster of two processes: 5.6 s
def test_workers_with_dask_s_malloc_trim_get_a_note(tmp_path, cluster):
    """The local cluster's workers run without Dask's MALLOC_TRIM_THRESHOLD_
    (2x slower renders); on a cluster whose workers have it, a note says so."""
    assert set(cluster.run(B._malloc_trim).values()) == {None}
    jobs = load_spec(_spec(tmp_path, SPEC_20))[:2]
    notes = []
    render_many(jobs, tmp_path / "a", client=cluster, progress=False, log=notes.append)
    assert not any("MALLOC_TRIM" in n for n in notes)
    cluster.run(_set_trim, "65536")
    try:
        render_many(jobs, tmp_path / "b", client=cluster, progress=False, log=notes.append)
    finally:
        cluster.run(_set_trim, None)
    assert any("2 of the cluster's 2 workers have MALLOC_TRIM_THRESHOLD_ below" in n for n in notes)


def _set_dask(key, value):
    import dask

    dask.config.set({key: value})


@pytest.mark.slow  # the module's LocalCluster (2.3 s) and a second cluster: 4.8 s
def test_the_local_cluster_quiets_dask_s_own_threads_and_other_clusters_get_a_note(tmp_path,
                                                                                     cluster):
    """The local cluster's workers run without Dask's profiler and with slow
    monitors (B.QUIET_DASK: 6 % of a core to 0.4 %); a worker that runs
    them at Dask's defaults gets a note naming the settings."""
    assert set(map(tuple, cluster.run(B._noisy_dask).values())) == {()}
    jobs = load_spec(_spec(tmp_path, SPEC_20))[:2]
    notes = []
    render_many(jobs, tmp_path / "a", client=cluster, progress=False, log=notes.append)
    assert not any("Dask's own threads" in n for n in notes)
    cluster.run(_set_dask, "distributed.worker.profile.enabled", True)
    cluster.run(_set_dask, "distributed.admin.tick.interval", "20ms")
    try:
        render_many(jobs, tmp_path / "b", client=cluster, progress=False, log=notes.append)
    finally:
        for k, v in B.QUIET_DASK.items():
            cluster.run(_set_dask, k, v)
    note = [n for n in notes if "Dask's own threads" in n]
    assert len(note) == 1
    assert note[0].startswith("note: 2 of the cluster's 2 workers")
    assert "distributed.admin.tick.interval, distributed.worker.profile.enabled" in note[0]
    assert "memory.monitor-interval" not in note[0]


def _set_env(key, value):
    if value is None:
        os.environ.pop(key, None)
    else:
        os.environ[key] = value


@pytest.mark.slow  # over 2 s on a quiet 2-core machine
def test_the_local_cluster_s_workers_have_one_malloc_arena_others_get_a_note(tmp_path, cluster):
    """MALLOC_ARENA_MAX=1 is in the workers' environment from their start (the
    task thread's own arena made A0 23 % slower); a worker without it gets a
    note."""
    assert set(cluster.run(B._malloc_arenas).values()) == {"1"}
    jobs = load_spec(_spec(tmp_path, SPEC_20))[:2]
    notes = []
    cluster.run(_set_env, "MALLOC_ARENA_MAX", None)
    try:
        render_many(jobs, tmp_path / "b", client=cluster, progress=False, log=notes.append)
    finally:
        cluster.run(_set_env, "MALLOC_ARENA_MAX", "1")
    assert any(n.startswith("note: 2 of the cluster's 2 workers run without MALLOC_ARENA_MAX=1")
               for n in notes)


def test_a_warmed_worker_has_run_the_analysis_once(monkeypatch):
    """warm_worker runs the manifest's analysis on a made-up note once per
    process (its first call imports SciPy's filters and pyloudnorm, which
    would otherwise be timed in the worker's first job): the made-up note
    reads as the 220 Hz tone it is, with no analysis error, and a second
    warm-up does not analyse again."""
    from synth.apps import batch_worker as W

    seen = []
    real = W._analysis

    def spy(x, fs, job, expected):
        out = real(x, fs, job, expected)
        seen.append(out)
        return out

    monkeypatch.setattr(W, "_analysis", spy)
    monkeypatch.setattr(W, "_ANALYSIS_WARM", False)
    W.warm_worker([])
    W.warm_worker([])
    assert len(seen) == 1
    assert seen[0]["analysis_error"] is None
    assert abs(seen[0]["f0_cents"]) < 1.0 and seen[0]["t60_s"] > 0
