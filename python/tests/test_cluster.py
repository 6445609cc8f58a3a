"""The package in memory and on a cluster: results cross from Rust without a file, every
public object pickles into a fresh process, a study split into shards on Dask (or a
multiprocessing pool) and summarised gives the bytes of one local run, and the README's
Python examples run as written.

Run from the repository root after `pip install .` (see .ci/run): python -m pytest python/tests
"""

from __future__ import annotations

import os
import pathlib
import pickle
import re
import shutil
import stat
import subprocess
import sys
import textwrap

import pyarrow as pa
import pyarrow.csv as pacsv
import pyarrow.parquet as pq
import pytest

import chassis_mc

ROOT = pathlib.Path(__file__).resolve().parents[2]
THESIS = ROOT / "studies" / "thesis.toml"
FIT = ROOT / "studies" / "fit_example.toml"
FIT_LOG_STUDY = ROOT / "studies" / "fit_log.toml"
TABLES = ["summary.parquet", "realisations.parquet", "cycles.parquet"]

# The three calls that must create no file: a run without `out`, a simulated log without
# `out`, and a fit of a DataFrame log without `out`.
IN_MEMORY = textwrap.dedent(
    f"""
    import os, sys
    import pandas
    import chassis_mc
    frame = pandas.read_csv({str(ROOT / "studies" / "data" / "fit_log.csv")!r})
    study = chassis_mc.load({str(THESIS)!r}, realisations=200)
    os.path.exists("/chassis-mc-calls-start")  # marks the trace: the calls start here
    try:
        result = chassis_mc.run(study, progress=False)
        log = chassis_mc.simulate_log({str(FIT_LOG_STUDY)!r})
        fitted = chassis_mc.fit({str(FIT)!r}, log=frame)
        cycles = result.cycles
    finally:
        os.path.exists("/chassis-mc-calls-end")
    print(result.summary.num_rows, result.realisations.num_rows, log.num_rows,
          fitted.table.num_rows, cycles.num_rows)
    """
)


def run_in_memory_script(env_dir: pathlib.Path, prefix: list) -> subprocess.CompletedProcess:
    """IN_MEMORY run by `prefix + [python]` with TMPDIR and the working directory
    `env_dir`."""
    env = dict(os.environ, TMPDIR=str(env_dir), TEMP=str(env_dir), TMP=str(env_dir))
    return subprocess.run(prefix + [sys.executable, "-c", IN_MEMORY], cwd=env_dir, env=env,
                          capture_output=True, text=True, timeout=600)


def test_results_cross_in_memory_with_a_read_only_tmpdir(tmp_path):
    # TMPDIR and the working directory read-only (which stops a process that is not root
    # from creating a file there) and left empty: the three calls write nowhere.
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(stat.S_IRUSR | stat.S_IXUSR)
    try:
        done = run_in_memory_script(locked, [])
    finally:
        locked.chmod(stat.S_IRWXU)
    assert done.returncode == 0, done.stderr
    counts = [int(x) for x in done.stdout.split()]
    assert all(c > 0 for c in counts), counts
    assert list(locked.iterdir()) == []


def strace_works() -> bool:
    """Whether strace is here and may trace (a container can forbid ptrace)."""
    if shutil.which("strace") is None or not sys.platform.startswith("linux"):
        return False
    try:
        probe = subprocess.run(["strace", "-f", "-qq", "-o", os.devnull, "true"],
                               capture_output=True, timeout=30)
    except (OSError, subprocess.TimeoutExpired):
        return False
    return probe.returncode == 0


@pytest.mark.skipif(not strace_works(), reason="needs strace, allowed to trace (Linux)")
def test_strace_of_the_calls_shows_no_file_created(tmp_path):
    # strace -f of every process and thread, file system calls only: between the two
    # markers, no open for writing or creating, and no mkdir, rename, unlink, link or
    # symlink anywhere (root can write a read-only directory, so this is the test that
    # holds for every user).
    trace = tmp_path / "trace.txt"
    work = tmp_path / "work"
    work.mkdir()
    done = run_in_memory_script(
        work, ["strace", "-f", "-qq", "-e", "trace=%file", "-o", str(trace)])
    assert done.returncode == 0, done.stderr
    lines = trace.read_text().splitlines()
    start = next(i for i, l in enumerate(lines) if "/chassis-mc-calls-start" in l)
    end = next(i for i, l in enumerate(lines) if "/chassis-mc-calls-end" in l)
    assert end > start + 10, "the trace holds the calls' file system activity"
    writes = re.compile(r"O_WRONLY|O_RDWR|O_CREAT|O_TRUNC|\b(mkdir|mkdirat|rename|renameat2?|"
                        r"unlink|unlinkat|rmdir|link|linkat|symlink|symlinkat|creat)\(")
    found = [l for l in lines[start:end] if writes.search(l)]
    assert found == [], "\n".join(found[:20])
    assert list(work.iterdir()) == []


def bits(table: pa.Table) -> list:
    """Every column's values, floats by their bit patterns."""
    out = []
    for column in table.columns:
        column = column.combine_chunks()
        if pa.types.is_floating(column.type):
            column = column.fill_null(0).view(pa.uint64())
        out.append(column.to_pylist())
    return out


def test_a_simulated_log_in_memory_holds_the_csvs_numbers(tmp_path):
    # The CSV holds each number's shortest decimal that reads back as the same float64: the
    # table in memory and the file read back agree bit for bit, column by column.
    table = chassis_mc.simulate_log(FIT_LOG_STUDY, out=tmp_path / "log.csv")
    in_memory = chassis_mc.simulate_log(FIT_LOG_STUDY)
    read = pacsv.read_csv(tmp_path / "log.csv", convert_options=pacsv.ConvertOptions(
        column_types={name: pa.float64() for name in table.column_names}))
    assert table.column_names == read.column_names == in_memory.column_names
    assert bits(table) == bits(read) == bits(in_memory)


# Pickling into a fresh process: the child unpickles each object and pickles back what it
# found (fields and tables); the parent compares.

CHILD = textwrap.dedent(
    """
    import pickle, sys
    objects = pickle.load(sys.stdin.buffer)
    found = {}
    for name, x in objects.items():
        if name.endswith("error"):
            found[name] = (type(x).__name__, str(x), getattr(x, "file", None),
                           getattr(x, "key", None), getattr(x, "line", None),
                           getattr(x, "reason", None), getattr(x, "bad_input", None))
        elif name == "study":
            found[name] = (x.to_toml(), x.origin, str(x.dir), x.identity())
        elif name == "run":
            found[name] = (x.summary, x.realisations, x.study.to_toml(), x.computed)
        elif name == "fit":
            found[name] = (x.table, x.text)
        elif name == "task":
            found[name] = (x.study.to_toml(), x.index, x.count)
        else:  # dataclasses of plain values and tables: equal to the original
            found[name] = x
    sys.stdout.buffer.write(pickle.dumps(found))
    """
)


def test_every_public_object_pickles_into_a_fresh_process(tmp_path):
    study = chassis_mc.load(THESIS, realisations=20, seed=9)
    run = chassis_mc.run(study, progress=False)
    fit = chassis_mc.fit(FIT)
    with pytest.raises(chassis_mc.StudyError) as study_error:
        chassis_mc.loads("[vehicle]\nmass = -3\n")
    (tmp_path / "file").write_text("")
    with pytest.raises(chassis_mc.RunError) as run_error:
        chassis_mc.run(study, out=tmp_path / "file", progress=False)
    task = chassis_mc.shards(study, 3)[1]
    shard = task.run(tmp_path / "shards")
    checked = chassis_mc.check(study)
    designed = chassis_mc.design(
        ROOT / "studies" / "design_thesis.toml", vary="drive.duration", from_=60, to=600,
        target="drag_over_mass:rel_rmse<=0.001", estimator="bcls", realisations=50)
    objects = {"study": study, "run": run, "fit": fit, "study_error": study_error.value,
               "run_error": run_error.value, "task": task, "shard": shard,
               "check": checked, "design": designed}
    done = subprocess.run([sys.executable, "-c", CHILD], input=pickle.dumps(objects),
                          capture_output=True, timeout=300)
    assert done.returncode == 0, done.stderr.decode()
    found = pickle.loads(done.stdout)
    assert found["study"] == (study.to_toml(), study.origin, str(study.dir), study.identity())
    summary, realisations, toml, computed = found["run"]
    assert summary.equals(run.summary) and realisations.equals(run.realisations)
    assert (toml, computed) == (study.to_toml(), run.computed)
    table, text = found["fit"]
    assert table.equals(fit.table) and text == fit.text
    for name in ["study_error", "run_error"]:
        e = objects[name]
        assert found[name] == (type(e).__name__, str(e), getattr(e, "file", None),
                               getattr(e, "key", None), getattr(e, "line", None),
                               getattr(e, "reason", None), getattr(e, "bad_input", None))
    assert found["study_error"][3] is not None  # the key at fault came across
    assert found["task"] == (study.to_toml(), 1, 3)
    assert found["shard"] == shard and shard.computed == 11 * (13 - 6)
    assert found["check"] == checked
    assert found["design"] == designed and designed.points is not None


def assert_same_files(a: pathlib.Path, b: pathlib.Path) -> None:
    for name in TABLES:
        assert (a / name).read_bytes() == (b / name).read_bytes(), name


@pytest.fixture(scope="module")
def whole(tmp_path_factory):
    """One local run of the thesis study at R = 101 (shards of unequal size)."""
    out = tmp_path_factory.mktemp("whole")
    chassis_mc.run(THESIS, out=out, realisations=101, progress=False, figures=False)
    return out


def test_shards_on_a_dask_cluster_summarize_to_the_bytes_of_one_run(tmp_path, whole):
    distributed = pytest.importorskip("dask.distributed")
    tasks = chassis_mc.shards(THESIS, 4, realisations=101)
    shared = tmp_path / "shards"
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        futures = client.map(chassis_mc.ShardTask.run, tasks, out=str(shared))
        results = client.gather(futures)
        # the workers are other processes: the shards ran there, not here
        pids = set(client.run(os.getpid).values())
        assert len(pids) == 2 and os.getpid() not in pids
    assert sorted(r.index for r in results) == [0, 1, 2, 3]
    assert sum(r.computed for r in results) == 11 * 101
    combined = chassis_mc.summarize(list(reversed(results)), tmp_path / "combined",
                                    figures=False)
    assert_same_files(tmp_path / "combined", whole)
    assert combined.realisations.num_rows == pq.read_metadata(
        whole / "realisations.parquet").num_rows
    assert combined.summary.equals(pq.read_table(whole / "summary.parquet"))


def test_shards_in_a_multiprocessing_pool_summarize_to_the_bytes_of_one_run(tmp_path, whole):
    import functools
    import multiprocessing

    tasks = chassis_mc.shards(THESIS, 4, realisations=101)
    with multiprocessing.get_context("spawn").Pool(2) as pool:
        run = functools.partial(chassis_mc.ShardTask.run, out=str(tmp_path / "shards"))
        results = pool.map(run, tasks)
    chassis_mc.summarize(results, tmp_path / "combined", figures=False)
    assert_same_files(tmp_path / "combined", whole)
    # and from the shard directories by path
    chassis_mc.summarize([tmp_path / "shards" / f"shard={k}" for k in range(4)],
                         tmp_path / "by_path", figures=False)
    assert_same_files(tmp_path / "by_path", whole)


def test_shards_refuses_a_count_that_is_not_a_whole_number_or_leaves_a_shard_empty():
    with pytest.raises(ValueError, match="n must be a whole number from 1 to 20"):
        chassis_mc.shards(THESIS, 0, realisations=20)
    # more shards than realisations would leave some without a row
    with pytest.raises(ValueError, match="got 21"):
        chassis_mc.shards(THESIS, 21, realisations=20)
    assert len(chassis_mc.shards(THESIS, 20, realisations=20)) == 20
    with pytest.raises(TypeError):
        chassis_mc.shards(THESIS, 2.0)
    with pytest.raises(ValueError, match="out="):
        chassis_mc._core.run(chassis_mc.load(THESIS, realisations=2), None, shard=(0, 2))


# The README's Python examples, each run as written in a fresh interpreter, in a directory
# whose `studies` is the repository's (so what they write goes there, not into the
# repository). An example that needs what this machine does not have (a SLURM cluster
# through dask-jobqueue, Ray) is skipped, by name.

def readme_python_blocks() -> list:
    text = (ROOT / "README.md").read_text()
    start = text.index("\n## Python\n")
    end = text.find("\n## ", text.index("\n## Python on a cluster\n") + 5)
    section = text[start:end]
    return re.findall(r"```python\n(.*?)```", section, flags=re.S)


NEEDS = {"dask_jobqueue": "a SLURM cluster (dask-jobqueue)", "ray": "Ray"}


@pytest.mark.parametrize("index", range(len(readme_python_blocks())))
def test_the_readmes_python_examples_run_as_written(index, tmp_path):
    block = readme_python_blocks()[index]
    for module, what in NEEDS.items():
        if re.search(rf"^\s*(import|from) {module}\b", block, flags=re.M):
            pytest.skip(f"needs {what}")
    (tmp_path / "studies").symlink_to(ROOT / "studies")
    done = subprocess.run([sys.executable, "-c", block], cwd=tmp_path, capture_output=True,
                          text=True, timeout=900)
    assert done.returncode == 0, f"{block}\n{done.stderr}"
    assert done.stdout.strip(), "an example prints what it shows"


def test_the_readme_has_python_examples_for_a_cluster():
    blocks = readme_python_blocks()
    assert any("LocalCluster" in b for b in blocks)
    assert any("SLURMCluster" in b for b in blocks)
    assert any("ray.remote" in b for b in blocks)


def test_a_run_into_out_returns_the_files_tables_without_reading_them(tmp_path):
    # With out, the tables come back from the run itself, not read from the files: they
    # are the files' rows bit for bit, an earlier run's kept rows among them when it extends
    # one (R = 20, then 30 into the same directory).
    out = tmp_path / "out"
    chassis_mc.run(THESIS, out=out, realisations=20, progress=False, figures=False)
    extended = chassis_mc.run(THESIS, out=out, realisations=30, progress=False, figures=False)
    assert (extended.reused, extended.computed) == (11 * 20, 11 * 10)
    for table, name in [(extended.summary, "summary.parquet"),
                        (extended.realisations, "realisations.parquet")]:
        read = pq.read_table(out / name)
        assert table.column_names == read.column_names
        assert bits(table) == bits(read), name
