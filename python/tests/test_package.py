"""The Python package against the command line: the same study and seed give the same
numbers, a bad dict names its key, Ctrl-C leaves a resumable run, a DataFrame log fits as
its CSV does, and the installed command works.

Run from the repository root after `pip install .` (see .ci/run):
    python -m pytest python/tests
The command line compared against is target/release/chassis-mc when it is built (an
independent build of the same library), else the wheel's `chassis-mc` command.
"""

from __future__ import annotations

import os
import pathlib
import shutil
import subprocess
import sys
import textwrap

import pyarrow as pa
import pyarrow.parquet as pq
import pytest

import chassis_mc

ROOT = pathlib.Path(__file__).resolve().parents[2]
THESIS = ROOT / "studies" / "thesis.toml"


def cli() -> list:
    """The command line to compare against."""
    built = ROOT / "target" / "release" / "chassis-mc"
    if built.exists():
        return [str(built)]
    installed = shutil.which("chassis-mc")
    assert installed, "neither target/release/chassis-mc nor an installed chassis-mc"
    return [installed]


def bits(column: pa.ChunkedArray) -> list:
    """A column's values for an exact comparison: floats by their bit patterns (so NaN
    equals NaN and -0.0 differs from 0.0), everything else as Python values."""
    column = column.combine_chunks()
    if pa.types.is_floating(column.type):
        width = {16: pa.uint16(), 32: pa.uint32(), 64: pa.uint64()}[column.type.bit_width]
        nulls = column.is_null().to_pylist()
        values = column.fill_null(0).view(width).to_pylist()
        return [None if n else v for n, v in zip(nulls, values)]
    return column.to_pylist()


def assert_same_table(a: pa.Table, b: pa.Table) -> None:
    assert a.schema.names == b.schema.names
    assert [f.type for f in a.schema] == [f.type for f in b.schema]
    assert a.num_rows == b.num_rows
    for name in a.schema.names:
        assert bits(a.column(name)) == bits(b.column(name)), f"column {name} differs"


def test_the_thesis_summary_is_the_command_lines_bit_for_bit(tmp_path):
    out = tmp_path / "cli"
    subprocess.run(
        cli() + ["run", str(THESIS), "--out", str(out), "--realisations", "200",
                 "--no-figures", "--quiet"],
        check=True,
    )
    result = chassis_mc.run(str(THESIS), realisations=200, progress=False)
    assert result.out is None and result.report_path is None
    assert result.summary.num_rows > 0
    assert_same_table(result.summary, pq.read_table(out / "summary.parquet"))
    assert_same_table(result.realisations, pq.read_table(out / "realisations.parquet"))
    # and the same study as TOML text, and as a Study with another thread count
    text = THESIS.read_text()
    again = chassis_mc.run(text, realisations=200, threads=1, progress=False)
    assert_same_table(again.summary, result.summary)


def test_a_run_into_out_writes_the_files_and_the_report(tmp_path):
    result = chassis_mc.run(THESIS, out=tmp_path / "out", realisations=20, progress=False)
    assert result.out == tmp_path / "out"
    assert result.report_path == tmp_path / "out" / "report.html"
    assert (tmp_path / "out" / "summary.parquet").exists()
    assert result.cycles is not None and result.cycles.num_rows > 0
    assert result.computed == 11 * 20 and result.reused == 0
    # the summary goes to pandas without per-row objects
    frame = result.summary.to_pandas()
    assert list(frame.columns) == result.summary.schema.names


def thesis_dict() -> dict:
    tomllib = pytest.importorskip("tomllib")
    return tomllib.loads(THESIS.read_text())


def test_a_dict_study_runs_as_its_file_does():
    study = thesis_dict()
    study["realisations"] = 20
    from_dict = chassis_mc.run(study, progress=False)
    from_file = chassis_mc.run(THESIS, realisations=20, progress=False)
    assert_same_table(from_dict.summary, from_file.summary)


def test_a_dict_with_a_bad_key_names_the_key_path():
    study = thesis_dict()
    study["vehicle"]["mass"] = -1500.0
    with pytest.raises(chassis_mc.StudyError) as bad:
        chassis_mc.load(study)
    assert bad.value.key == "vehicle.mass"
    assert bad.value.file == "<dict>"
    assert bad.value.line is None
    assert bad.value.reason and "vehicle.mass" in str(bad.value)

    study = thesis_dict()
    study["terrain"]["scalez"] = [1.0]
    with pytest.raises(chassis_mc.StudyError) as unknown:
        chassis_mc.load(study)
    assert unknown.value.key is not None and "scalez" in unknown.value.key

    study = thesis_dict()
    study["vehicle"]["mass"] = object()
    with pytest.raises(chassis_mc.StudyError) as untyped:
        chassis_mc.load(study)
    assert untyped.value.key == "vehicle.mass"


def test_a_dict_key_that_is_not_a_str_is_named_by_where_it_is():
    study = thesis_dict()
    study[3] = 1.0
    with pytest.raises(chassis_mc.StudyError) as top:
        chassis_mc.load(study)
    assert (top.value.key, top.value.reason) == (None, "every key must be a str")
    study = thesis_dict()
    study["vehicle"][5] = 1.0
    with pytest.raises(chassis_mc.StudyError) as inner:
        chassis_mc.load(study)
    assert inner.value.key == "vehicle"
    assert inner.value.reason == "every key of vehicle must be a str"


def test_a_file_error_carries_its_line(tmp_path):
    text = THESIS.read_text().replace("seed = ", "seed = -", 1)
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(chassis_mc.StudyError) as bad:
        chassis_mc.load(path)
    assert bad.value.key == "seed"
    assert bad.value.file == str(path)
    line = next(i for i, l in enumerate(text.splitlines(), 1) if l.startswith("seed = -"))
    assert bad.value.line == line


def test_a_failure_while_running_is_a_run_error(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    with pytest.raises(chassis_mc.RunError):
        chassis_mc.run(THESIS, out=blocker / "out", realisations=20, progress=False)


INTERRUPTED = textwrap.dedent(
    """
    import os, signal, sys, threading, time, chassis_mc
    # Python's own Ctrl-C handler, as in a terminal: a process started in the background
    # by a shell without job control inherits SIGINT ignored, and Python then leaves it so.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    stop_at = int(sys.argv[4])
    done = [0]
    def progress(count, total):
        print(f"progress {count} {total}", file=sys.stderr, flush=True)
        done[0] = count
    def ctrl_c():
        # Ctrl-C as the terminal sends it (SIGINT to the process) once the progress shows
        # `stop_at` realisations done, from this thread while the main thread waits on the
        # run: it arrives while the run is going whatever the load on the machine (a parent
        # reading the progress could be scheduled after a short run has finished).
        while done[0] < stop_at:
            time.sleep(0.001)
        os.kill(os.getpid(), signal.SIGINT)
    threading.Thread(target=ctrl_c, daemon=True).start()
    try:
        out = None if sys.argv[2] == "-" else sys.argv[2]  # "-": a run held in memory
        chassis_mc.run(sys.argv[1], out=out, realisations=int(sys.argv[3]),
                       threads=1, progress=progress)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr, flush=True)
        sys.exit(3)
    sys.exit(0)
    """
)


def test_ctrl_c_stops_a_run_and_running_it_again_gives_the_uninterrupted_bytes(tmp_path):
    realisations = 3000
    out = tmp_path / "interrupted"
    # SIGINT once the progress shows two conditions' parts done (a run commits a part per
    # condition; R realisations are one condition's): the rerun then resumes from them.
    child = subprocess.Popen(
        [sys.executable, "-c", INTERRUPTED, str(THESIS), str(out), str(realisations),
         str(2 * realisations)],
        stderr=subprocess.PIPE,
        text=True,
    )
    rest = child.stderr.read()
    code = child.wait(timeout=600)
    assert code == 3, rest
    assert "interrupted" in rest
    assert not (out / "summary.parquet").exists()

    resumed = chassis_mc.run(THESIS, out=out, realisations=realisations, progress=False)
    whole = chassis_mc.run(
        THESIS, out=tmp_path / "whole", realisations=realisations, progress=False
    )
    assert resumed.reused > 0, "the rerun kept the interrupted run's parts"
    assert resumed.computed + resumed.reused == whole.computed
    for name in ["realisations.parquet", "summary.parquet", "cycles.parquet"]:
        assert (out / name).read_bytes() == (tmp_path / "whole" / name).read_bytes(), name


def test_ctrl_c_stops_a_run_held_in_memory(tmp_path):
    # Without out the run is held in memory: Ctrl-C stops it after the chunk in progress
    # (well before its 11 conditions are done) with a KeyboardInterrupt, and nothing is
    # written (the working directory stays empty).
    realisations = 3000
    child = subprocess.Popen(
        [sys.executable, "-c", INTERRUPTED, str(THESIS), "-", str(realisations),
         str(2 * realisations)],
        stderr=subprocess.PIPE, text=True, cwd=tmp_path,
    )
    rest = child.stderr.read()
    assert child.wait(timeout=600) == 3, rest
    assert "interrupted" in rest
    shown = [int(line.split()[1]) for line in rest.splitlines() if line.startswith("progress")]
    assert shown and max(shown) < 11 * realisations, shown[-3:]
    assert list(tmp_path.iterdir()) == []


FIT = ROOT / "studies" / "fit_example.toml"


def test_a_dataframe_log_fits_as_its_csv_does(tmp_path):
    pandas = pytest.importorskip("pandas")
    frame = pandas.read_csv(ROOT / "studies" / "data" / "fit_log.csv")
    csv = tmp_path / "log.csv"
    frame.to_csv(csv, index=False)
    fit_text = FIT.read_text().replace('file = "data/fit_log.csv"', f'file = "{csv}"')
    assert fit_text != FIT.read_text()
    fit_file = tmp_path / "fit.toml"
    fit_file.write_text(fit_text)
    subprocess.run(
        cli() + ["fit", str(fit_file), "--out", str(tmp_path / "cli")],
        check=True,
        stdout=subprocess.DEVNULL,
    )
    from_frame = chassis_mc.fit(FIT, log=frame)
    assert_same_table(from_frame.table, pq.read_table(tmp_path / "cli" / "fit.parquet"))
    # a pyarrow table, and the fit file as a dict without log.file
    tomllib = pytest.importorskip("tomllib")
    spec = tomllib.loads(FIT.read_text())
    del spec["log"]["file"]
    from_arrow = chassis_mc.fit(spec, log=pa.Table.from_pandas(frame))
    assert_same_table(from_arrow.table, from_frame.table)
    # a Parquet log as pandas writes it (Snappy-compressed), given as a path
    frame.to_parquet(tmp_path / "log.parquet", index=False)
    from_parquet = chassis_mc.fit(FIT, log=tmp_path / "log.parquet")
    assert_same_table(from_parquet.table, from_frame.table)


def test_simulate_log_never_overwrites_a_measured_log(tmp_path):
    # simulate_log(out=FILE) overwrote an existing file, a real measured log: it is now
    # replaced only when simulate-log wrote it, or with force=True.
    study = ROOT / "studies" / "fit_log.toml"
    measured = tmp_path / "measured.csv"
    measured.write_text("t,v\n0,1\n")
    with pytest.raises(chassis_mc.RunError) as e:
        chassis_mc.simulate_log(study, out=measured)
    assert e.value.bad_input and "measured.csv" in str(e.value) and "force" in str(e.value)
    assert measured.read_text() == "t,v\n0,1\n"
    chassis_mc.simulate_log(study, out=tmp_path / "own.csv")
    chassis_mc.simulate_log(study, out=tmp_path / "own.csv", realisation=1)
    table = chassis_mc.simulate_log(study, out=measured, force=True)
    assert table.num_rows > 0 and measured.read_text().startswith("time_s,")


def test_simulate_log_returns_the_commands_csv(tmp_path):
    study = ROOT / "studies" / "fit_log.toml"
    table = chassis_mc.simulate_log(study, out=tmp_path / "py.csv")
    subprocess.run(
        cli() + ["simulate-log", str(study), "--out", str(tmp_path / "cli.csv")],
        check=True,
        stdout=subprocess.DEVNULL,
    )
    assert (tmp_path / "py.csv").read_bytes() == (tmp_path / "cli.csv").read_bytes()
    assert table.num_rows > 0


def test_check_reports_what_the_command_prints():
    found = chassis_mc.check(THESIS, realisations=200, threads=1)
    assert len(found.ms_per_realisation) == 11
    assert found.estimated_seconds > 0 and found.output_bytes > 0
    assert "11 conditions × 200 realisations" in found.text


def test_the_installed_command_runs():
    # the command pip installed beside this interpreter (the venv need not be activated)
    beside = pathlib.Path(sys.executable).parent / "chassis-mc"
    installed = str(beside) if beside.exists() else shutil.which("chassis-mc")
    assert installed, "the wheel installs a chassis-mc command"
    shown = subprocess.run([installed, "--help"], capture_output=True, text=True)
    assert shown.returncode == 0
    assert "Usage: chassis-mc" in shown.stdout
    bad = subprocess.run([installed, "run", "--nonsense"], capture_output=True, text=True)
    assert bad.returncode == 2


def files_under(root: pathlib.Path) -> set:
    return {str(p.relative_to(root)) for p in root.rglob("*")}


@pytest.mark.skipif(
    "CHASSIS_MC_WHEEL" not in os.environ,
    reason="set CHASSIS_MC_WHEEL to the built wheel (as .ci/run does)",
)
def test_the_wheel_installs_its_command_and_uninstalls_without_a_trace(tmp_path):
    wheel = os.environ["CHASSIS_MC_WHEEL"]
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    python = venv / "bin" / "python"
    # the dependency first, so that what the wheel adds is all that is compared
    pip = [str(python), "-m", "pip", "--quiet", "--disable-pip-version-check"]
    subprocess.run(pip + ["install", "pyarrow"], check=True)
    before = files_under(venv)
    subprocess.run(pip + ["install", "--no-deps", wheel], check=True)
    # byte-compiled files too: the command and the module run as a user's would
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    shown = subprocess.run(
        [str(venv / "bin" / "chassis-mc"), "--help"], capture_output=True, text=True, env=env
    )
    assert shown.returncode == 0 and "Usage: chassis-mc" in shown.stdout, shown.stderr
    subprocess.run(
        [str(python), "-c", "import chassis_mc, chassis_mc._cli; print(chassis_mc.__version__)"],
        check=True,
        env=env,
        stdout=subprocess.DEVNULL,
    )
    assert (venv / "bin" / "chassis-mc").exists()
    subprocess.run(pip + ["uninstall", "--yes", "chassis-mc"], check=True)
    after = files_under(venv)
    # Importing may byte-compile pyarrow's own modules; nothing else may stay.
    left = sorted(
        p for p in after - before if "__pycache__" not in p or "chassis" in p.lower()
    )
    assert left == [], left
    assert not any("chassis" in p.lower() for p in after)


def test_design_answers_as_the_command_does(tmp_path):
    study = ROOT / "studies" / "design_thesis.toml"
    args = ["--vary", "drive.duration", "--from", "60", "--to", "600",
            "--target", "drag_over_mass:rel_rmse<=0.001", "--estimator", "bcls",
            "--realisations", "200"]
    shown = subprocess.run(
        cli() + ["design", str(study), *args, "--out", str(tmp_path / "cli")],
        capture_output=True,
        text=True,
    )
    found = chassis_mc.design(
        study, vary="drive.duration", from_=60, to=600,
        target="drag_over_mass:rel_rmse<=0.001", estimator="bcls", realisations=200,
    )
    # the command prints the sentence first and exits 1 when no value meets the target
    assert shown.stdout.splitlines()[0] == found.sentence
    assert shown.returncode == (0 if found.answer is not None else 1), shown.stderr
    assert found.points is not None
    assert_same_table(found.points, pq.read_table(tmp_path / "cli" / "design.parquet"))
    with pytest.raises(ValueError):
        chassis_mc.design(study, vary="drive.nonsense", from_=60, to=600,
                          target="drag_over_mass:rel_rmse<=0.001")


# Issue 43, item 7: every error class pickles with its fields, so that an error raised in a
# worker process reaches the parent whole (multiprocessing and concurrent.futures pickle it).

def error_examples() -> list:
    """One instance of each error class the package raises, every field set."""
    return [
        chassis_mc.StudyError(
            "bad.toml: key `vehicle.mass` (line 7): must be > 0, got -1",
            "bad.toml", "vehicle.mass", 7, "must be > 0, got -1",
        ),
        chassis_mc.StudyError("<dict>: key `seed`: must be >= 0", "<dict>", "seed", None,
                              "must be >= 0"),
        chassis_mc.RunError("out: is a file, not a directory", True),
        chassis_mc.RunError("disk full", False),
        chassis_mc.ChassisMcError("something"),
    ]


FIELDS = ["file", "key", "line", "reason", "bad_input"]


def test_every_error_class_pickles_with_its_fields():
    import pickle

    for error in error_examples():
        back = pickle.loads(pickle.dumps(error))
        assert type(back) is type(error)
        assert str(back) == str(error)
        assert back.args == error.args
        for name in FIELDS:
            assert getattr(back, name, "absent") == getattr(error, name, "absent"), name


def bad_study() -> dict:
    study = thesis_dict()
    study["vehicle"]["mass"] = -1500.0
    return study


def test_a_bad_study_in_a_multiprocessing_pool_reaches_the_parent_as_a_study_error():
    import concurrent.futures
    import multiprocessing

    # spawn: a fresh interpreter per worker (no fork of this process's threads). A timeout,
    # so that an error the parent cannot unpickle fails the test instead of hanging it
    # (multiprocessing.Pool then waits for the result forever).
    context = multiprocessing.get_context("spawn")
    pool = context.Pool(1)
    raised = None
    try:
        pending = pool.map_async(chassis_mc.load, [bad_study()])
        try:
            pending.get(timeout=120)
        except chassis_mc.StudyError as e:
            raised = e
        except multiprocessing.TimeoutError:
            pass
    finally:
        # Pool.terminate asserts that the pool's result thread is alive: it is not when the
        # error could not be unpickled (the failure this test is about, reported below).
        try:
            pool.terminate()
        except AssertionError:
            assert raised is None
    assert raised is not None, "the worker's StudyError did not reach the parent in 120 s"
    assert raised.file == "<dict>"
    assert raised.key == "vehicle.mass"
    assert raised.line is None
    assert raised.reason and "vehicle.mass" in str(raised)

    with concurrent.futures.ProcessPoolExecutor(1, mp_context=context) as executor:
        future = executor.submit(chassis_mc.load, bad_study())
        with pytest.raises(chassis_mc.StudyError) as bad:
            future.result(timeout=120)
    assert bad.value.key == "vehicle.mass" and bad.value.file == "<dict>"


# Issue 43, item 8: a str that names an existing file is a path, whatever it contains (the
# engine's own shard directories are named shard=K); TOML text is a str that names no file
# and holds a newline or parses as TOML, or explicitly chassis_mc.loads(text).

def test_a_str_path_with_an_equals_sign_is_read_as_a_path(tmp_path):
    for directory in ["seed=3", "shard=0"]:
        path = tmp_path / directory / "thesis.toml"
        path.parent.mkdir()
        shutil.copy(THESIS, path)
        study = chassis_mc.load(str(path))
        assert study.origin == str(path)
        assert study.to_toml() == chassis_mc.load(THESIS).to_toml()


def test_a_str_that_names_no_file_and_is_not_toml_says_the_file_does_not_exist(tmp_path):
    missing = str(tmp_path / "seed=3" / "thesis.toml")
    for call in [chassis_mc.load, chassis_mc.check, chassis_mc.run]:
        with pytest.raises(chassis_mc.StudyError) as bad:
            call(missing)
        assert bad.value.file == missing
        assert "does not exist" in bad.value.reason
        assert missing in str(bad.value)
    with pytest.raises(chassis_mc.StudyError) as bad:
        chassis_mc.fit(missing)
    assert bad.value.file == missing and "does not exist" in bad.value.reason


def test_loads_takes_toml_text_and_a_one_line_toml_str_is_still_text():
    text = THESIS.read_text()
    study = chassis_mc.loads(text, realisations=20)
    assert study.origin == "<string>" and study.realisations == 20
    assert chassis_mc.load(text, realisations=20).to_toml() == study.to_toml()
    # TOML text on one line (no newline) that names no file is text: its error is the
    # study's (a missing key), not a missing file
    with pytest.raises(chassis_mc.StudyError) as bad:
        chassis_mc.load('name = "one line"')
    assert bad.value.file == "<string>"
    # loads never reads a file, even when the text is an existing file's name
    with pytest.raises(chassis_mc.StudyError) as bad:
        chassis_mc.loads(str(THESIS))
    assert bad.value.file == "<string>"


# Issue 43, item 20: a study given as a dict (or TOML text) has no file to resolve its data
# paths against: they resolve against `base=` when given, else the current directory, and an
# error for a relative data path not found there says so.

ROUTE = ROOT / "studies" / "route_trace.toml"  # drive.trace = "data/route_trace.csv"


def test_a_dict_study_resolves_its_data_paths_against_base(tmp_path, monkeypatch):
    tomllib = pytest.importorskip("tomllib")
    study = tomllib.loads(ROUTE.read_text())
    monkeypatch.chdir(tmp_path)  # where data/route_trace.csv is not
    with pytest.raises(chassis_mc.StudyError) as bad:
        chassis_mc.load(study)
    assert bad.value.key == "drive.trace" and bad.value.file == "<dict>"
    assert "current directory" in bad.value.reason and "base=" in bad.value.reason
    assert "current directory" in str(bad.value)
    # the same as TOML text
    with pytest.raises(chassis_mc.StudyError) as bad:
        chassis_mc.load(ROUTE.read_text())
    assert bad.value.key == "drive.trace" and "base=" in bad.value.reason

    from_dict = chassis_mc.load(study, base=ROUTE.parent)
    from_file = chassis_mc.load(ROUTE)
    assert from_dict.to_toml() == from_file.to_toml()
    assert chassis_mc.loads(ROUTE.read_text(), base=str(ROUTE.parent)).to_toml() == \
        from_file.to_toml()
    ran = chassis_mc.run(study, base=ROUTE.parent, realisations=10, progress=False)
    assert_same_table(ran.summary, chassis_mc.run(ROUTE, realisations=10, progress=False).summary)
    assert chassis_mc.check(study, base=ROUTE.parent, realisations=10).estimated_seconds > 0

    # a data path that does not exist under base either: the error names it, no hint
    with pytest.raises(chassis_mc.StudyError) as bad:
        chassis_mc.load(study, base=tmp_path)
    assert bad.value.key == "drive.trace" and str(tmp_path) in bad.value.reason
    # base is for a study without a file of its own
    with pytest.raises(ValueError, match="base"):
        chassis_mc.load(ROUTE, base=ROUTE.parent)


def test_a_study_loaded_elsewhere_keeps_its_data_paths_when_overridden(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    study = chassis_mc.load(ROUTE)
    again = chassis_mc.load(study, realisations=10, seed=5)
    assert (again.realisations, again.seed) == (10, 5)
    assert chassis_mc.check(study, realisations=10).estimated_seconds > 0


def test_a_dict_fit_file_resolves_its_log_against_base(tmp_path, monkeypatch):
    tomllib = pytest.importorskip("tomllib")
    spec = tomllib.loads(FIT.read_text())  # log.file = "data/fit_log.csv"
    monkeypatch.chdir(tmp_path)
    with pytest.raises(chassis_mc.StudyError) as bad:
        chassis_mc.fit(spec)
    assert bad.value.key == "log.file" and "base=" in bad.value.reason
    assert_same_table(chassis_mc.fit(spec, base=FIT.parent).table, chassis_mc.fit(FIT).table)


# Issue 43, item 9: arguments out of range are clear errors naming the argument and its
# range (as the command line's: --threads 1 to 65535, --seed 0 to 2^63 − 1); a DataFrame
# log's errors name the DataFrame and its column and row, never the temporary file it is
# handed to the engine as.

def test_arguments_out_of_range_name_the_argument_and_its_range():
    for value in [-1, 0, 2**40 + 1]:
        with pytest.raises(chassis_mc.StudyError) as bad:
            chassis_mc.load(THESIS, realisations=value)
        assert bad.value.key == "realisations" and bad.value.file == "<arguments>"
        assert str(bad.value) == (
            f"realisations must be a whole number from 1 to {2**40}, got {value}"
        )
    for value in [-1, 2**63, 2**64]:
        with pytest.raises(chassis_mc.StudyError) as bad:
            chassis_mc.load(THESIS, seed=value)
        assert bad.value.key == "seed"
        assert str(bad.value) == (
            f"seed must be a whole number from 0 to {2**63 - 1}, got {value}"
        )
    for value in [-2, 0, 65536]:
        with pytest.raises(ValueError) as bad:
            chassis_mc.run(THESIS, realisations=5, threads=value, progress=False)
        assert str(bad.value) == f"threads must be a whole number from 1 to 65535, got {value}"
        with pytest.raises(ValueError, match="^threads must be a whole number from 1"):
            chassis_mc.check(THESIS, realisations=5, threads=value)
    with pytest.raises(ValueError, match="^realisation must be a whole number from 0"):
        chassis_mc.simulate_log(ROOT / "studies" / "fit_log.toml", realisation=-1)
    # a bool or a float is not a count
    for value in [True, 2.5, "20"]:
        with pytest.raises(TypeError, match="^realisations must be a whole number"):
            chassis_mc.load(THESIS, realisations=value)
    # the run goes on with the values in range, and a numpy integer is a whole number
    numpy = pytest.importorskip("numpy")
    assert chassis_mc.load(THESIS, realisations=numpy.int64(7), seed=2**63 - 1).seed == 2**63 - 1


def fit_log_frame():
    pandas = pytest.importorskip("pandas")
    return pandas.read_csv(ROOT / "studies" / "data" / "fit_log.csv")


def test_a_dataframe_log_column_that_cannot_be_converted_is_named():
    frame = fit_log_frame()
    frame.index = frame.index + 100  # index labels that are not positions
    frame["speed_m_s"] = frame["speed_m_s"].astype(object)
    frame.loc[105, "speed_m_s"] = "fast"
    with pytest.raises(chassis_mc.StudyError) as bad:
        chassis_mc.fit(FIT, log=frame)
    assert bad.value.file == "the DataFrame given as log"
    assert str(bad.value) == (
        'the DataFrame given as log: column "speed_m_s", row 6 (position 5, index label '
        "105): 'fast' (a str) is not a number"
    )


def test_errors_of_a_dataframe_log_name_the_dataframe_and_not_a_temporary_file():
    import tempfile

    frame = fit_log_frame()
    frame.index = frame.index + 100
    with_gap = frame.copy()
    with_gap.loc[107, "speed_m_s"] = float("nan")
    without_force = frame.drop(columns=["force_n"])
    cases = [
        (with_gap, "the DataFrame given as log",
         'column "speed_m_s", row 8 (position 7, index label 107): the cell is empty'),
        (without_force, "the DataFrame given as log", 'column "force_n", no such column'),
        (pa.Table.from_pandas(with_gap, preserve_index=False), "the pyarrow Table given as log",
         'column "speed_m_s", row 8 (position 7): the cell is empty'),
    ]
    for log, name, detail in cases:
        with pytest.raises(chassis_mc.StudyError) as bad:
            chassis_mc.fit(FIT, log=log)
        # about the table given, not the fit file's log.file (which it replaces)
        assert (bad.value.file, bad.value.key, bad.value.line) == (name, None, None)
        assert str(bad.value).startswith(f"{name}: {detail}")
        assert bad.value.reason.startswith(detail)
        for text in [str(bad.value), bad.value.reason]:
            assert tempfile.gettempdir() not in text and "log.parquet" not in text


# Issue 43, item 10: the README's first Python example needs pandas, which the wheel does
# not install: the package has a pandas extra and the README's install command names it;
# and the README says how to make the .venv its commands run in before it first uses one.

def readme_section(title: str) -> str:
    text = (ROOT / "README.md").read_text()
    start = text.index(f"\n## {title}\n")
    end = text.find("\n## ", start + 1)
    return text[start:end]


def test_the_readme_installs_the_pandas_extra_its_python_example_needs():
    tomllib = pytest.importorskip("tomllib")
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    extra = project["optional-dependencies"]["pandas"]
    assert any(requirement.split(">")[0].split("=")[0].strip() == "pandas"
               for requirement in extra), extra
    assert not any("pandas" in d for d in project["dependencies"]), "pandas is an extra"
    python = readme_section("Python")
    first_block = python[python.index("```sh"):python.index("```", python.index("```sh") + 5)]
    assert "pip install '.[pandas]'" in first_block, first_block
    assert ".to_pandas()" in first_block, "the example the extra is for"


def test_the_readme_says_how_to_make_the_venv_before_it_uses_one():
    import re

    text = (ROOT / "README.md").read_text()
    first_use = re.search(r"\.venv/bin/python [\w/]+\.py", text).start()  # a command
    made = text.find("python3 -m venv .venv")
    assert 0 <= made < first_use, "the README uses .venv/bin/python before making .venv"
    # and with which requirements (analysis/ and benches/ scripts both run in it)
    setup = text[made:made + 300]
    assert ".venv/bin/pip install -r analysis/requirements.txt" in setup, setup
    assert "benches/requirements.txt" in setup, setup


# Issue 43, item 18: a RunResult carries its summary and realisations, and reads its cycles
# only when asked (from out, or computed again from the study): pickling it (to send it from
# a worker process) does not carry the cycles table (82 MB in memory for the thesis study).

def test_a_run_result_pickles_without_its_cycles_and_reads_them_after(tmp_path):
    import pickle

    result = chassis_mc.run(THESIS, realisations=20, progress=False)
    data = pickle.dumps(result)
    # What it must carry: its two tables as pyarrow pickles them, the study as run (its
    # TOML text, reloaded on unpickling), and a few paths and counts, for which 16 KiB is
    # ample (the class and field names, the study's origin and directory, the file names).
    # At R = 20 the two tables pickle to about 168 kB and the study's TOML is 1.5 kB, so the
    # bound is about 185 kB; the thesis study's cycles alone pickle to 82 MB.
    study_text = chassis_mc.load(THESIS, realisations=20).to_toml()
    bound = (len(pickle.dumps(result.summary)) + len(pickle.dumps(result.realisations))
             + len(study_text.encode()) + 16 * 1024)
    assert len(data) <= bound, f"{len(data)} bytes pickled, more than {bound}"

    back = pickle.loads(data)
    assert_same_table(back.summary, result.summary)
    assert_same_table(back.realisations, result.realisations)
    assert (back.out, back.reused, back.computed) == (None, 0, 11 * 20)
    # the cycles, computed again from the study, are those a run writes
    kept = chassis_mc.run(THESIS, out=tmp_path / "out", realisations=20, progress=False)
    written = pq.read_table(tmp_path / "out" / "cycles.parquet")
    assert back.cycles is not None
    assert_same_table(back.cycles, written)
    assert_same_table(result.cycles, written)
    # once read, the cycles still stay out of the pickle
    assert len(pickle.dumps(result)) <= bound

    # a result with `out` carries the path, and reads the cycles from it
    data = pickle.dumps(kept)
    assert len(data) <= bound + len(pickle.dumps(kept.files)), len(data)
    back = pickle.loads(data)
    assert back.out == tmp_path / "out" and back.report_path == kept.report_path
    assert_same_table(back.cycles, written)


def test_a_study_pickles_as_run_with_its_data_paths(tmp_path, monkeypatch):
    import pickle

    monkeypatch.chdir(tmp_path)  # the study's data file is relative to its own directory
    study = chassis_mc.load(ROUTE, realisations=10, seed=5)
    back = pickle.loads(pickle.dumps(study))
    assert back.to_toml() == study.to_toml() and back.origin == study.origin
    assert (back.realisations, back.seed, back.dir) == (10, 5, ROUTE.parent)
    assert back.identity() == study.identity()
