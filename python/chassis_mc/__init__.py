"""chassis-mc in Python: run a study, check it, design a road test, fit a measured log.

Every function calls the same Rust library as the ``chassis-mc`` command (installed by the
same wheel), so a study run here writes the bytes the command writes for the same study and
seed. Results come back as pyarrow Tables (``.to_pandas()`` for pandas; DuckDB reads them
directly), read from the Parquet files the run wrote. The columns and units are in the
README ("Outputs") and docs/model.md.

A study (or a fit file) is given as a path (``str`` or ``os.PathLike``), as TOML text, or
as a dict of the TOML's tables and keys (e.g. from ``tomllib.load``); a dict is validated by
the same code as a file, and its errors name the key (``vehicle.mass``). A ``str`` is read
as follows:

- a ``str`` that names an existing file is that file's path, whatever it holds
  (``results/seed=3/thesis.toml``, a shard's ``shard=0/``);
- otherwise a ``str`` holding a newline, or parsing as TOML, is TOML text;
- any other ``str`` is a path to a file that does not exist: a :class:`StudyError` says so,
  naming it.

:func:`loads` takes TOML text explicitly (never a path). A study file's relative data paths
(``drive.trace``, a terrain ``file``, a fit file's ``log.file``) resolve against the file's
own directory; TOML text and a dict have none, so theirs resolve against ``base=`` (a
directory, e.g. the one the TOML was read from) when given, else against the current
directory.

    >>> import chassis_mc
    >>> result = chassis_mc.run("studies/thesis.toml", realisations=200)
    >>> result.summary.to_pandas()

Errors: a study that cannot be run raises :class:`StudyError` (``file``, ``key``, ``line``,
``reason``); a failure while running raises :class:`RunError`. Ctrl-C (KeyboardInterrupt)
stops a run after the chunk it is writing; its completed parts stay in ``out`` and the same
call resumes from them.
"""

from __future__ import annotations

import os
import pathlib
import sys
import tempfile
import time
from dataclasses import dataclass, field
from typing import Any, Callable, List, Mapping, Optional, Tuple, Union

import pyarrow as pa
import pyarrow.parquet as pq

from . import _core
from ._errors import ChassisMcError, RunError, StudyError

__all__ = [
    "ChassisMcError",
    "CheckResult",
    "DesignResult",
    "FitResult",
    "RunError",
    "RunResult",
    "Study",
    "StudyError",
    "check",
    "design",
    "fit",
    "load",
    "loads",
    "run",
    "simulate_log",
]

__version__: str = _core.__version__

#: A study validated by :func:`load` (name, seed, realisations, origin, ``to_toml()``).
Study = _core.Study

#: What a study or fit file may be given as.
Source = Union[str, "os.PathLike[str]", Mapping[str, Any], "_core.Study"]

#: A progress argument: True (a bar, or a plain line without tqdm), False (silent), or a
#: callable taking (done, total) realisations.
Progress = Union[bool, Callable[[int, int], None]]

#: Least time between two plain progress lines when stderr is not a terminal [s].
LINE_INTERVAL = 10.0


#: A directory: where the relative data paths of a study given as TOML text or a dict are.
Base = Union[str, "os.PathLike[str]"]


def _kind(source: Any, what: str = "study") -> Tuple[str, Any]:
    """('path' | 'text' | 'dict', value) for a study or fit file given as any Source: a str
    naming an existing file is a path; else one holding a newline or parsing as TOML is
    text; any other str is a file that does not exist (a StudyError naming it)."""
    if isinstance(source, Mapping):
        return "dict", dict(source)
    if isinstance(source, os.PathLike):
        return "path", os.fspath(source)
    if isinstance(source, str):
        if os.path.exists(source):
            return "path", source
        if "\n" in source or _core.parses_as_toml(source):
            return "text", source
        where = "" if os.path.isabs(source) else f" in the current directory, {os.getcwd()}"
        hint = " (chassis_mc.loads takes TOML text)" if what == "study" else ""
        reason = (
            f"the file does not exist{where}: a str names a {what} file unless it holds "
            f"TOML text, and this one is not TOML either{hint}"
        )
        raise StudyError(f"{source}: {reason}", source, None, None, reason)
    raise TypeError(
        f"a {what} is a path, TOML text or a dict, not a {type(source).__name__}"
    )


def _base(base: Optional[Base], kind: str, what: str = "study") -> Optional[str]:
    """`base` as a directory for a study without a file of its own; refused for a file (its
    relative paths resolve against its own directory)."""
    if base is None:
        return None
    if kind == "path":
        raise ValueError(
            f"base= applies to a {what} given as TOML text or a dict: a {what} file's "
            "relative paths resolve against the file's own directory"
        )
    directory = os.fspath(base)
    if not os.path.isdir(directory):
        raise ValueError(f"base: {directory!r} is not a directory")
    return directory


def load(
    study: Source,
    *,
    realisations: Optional[int] = None,
    seed: Optional[int] = None,
    base: Optional[Base] = None,
) -> "_core.Study":
    """Read and validate a study (path, TOML text or dict) without running it.

    ``realisations`` and ``seed`` override the study's, as ``--realisations`` and
    ``--seed`` do on the command line. ``base`` is the directory that the relative data
    paths of TOML text or a dict resolve against (default: the current directory; a study
    file's resolve against its own). Raises :class:`StudyError`.
    """
    if isinstance(study, _core.Study):
        if base is not None:
            raise ValueError("base= applies to a study given as TOML text or a dict, not "
                             "to a Study (its data paths are already resolved)")
        if realisations is None and seed is None:
            return study
        return study.with_overrides(realisations, seed)
    kind, value = _kind(study)
    return _core.load_study(kind, value, realisations, seed, _base(base, kind))


def loads(
    text: str,
    *,
    realisations: Optional[int] = None,
    seed: Optional[int] = None,
    base: Optional[Base] = None,
) -> "_core.Study":
    """Read and validate a study given as TOML text (never read as a path), as
    :func:`load` does: its relative data paths resolve against ``base`` (default: the
    current directory). Raises :class:`StudyError`."""
    if not isinstance(text, str):
        raise TypeError(f"loads takes TOML text (a str), not a {type(text).__name__}")
    return _core.load_study("text", text, realisations, seed, _base(base, "text"))


class _Reporter:
    """Progress of a call: a tqdm bar (also in a notebook) when tqdm is installed, else a
    line on stderr (rewritten in place on a terminal, at most every LINE_INTERVAL in a log
    file); notices always go to stderr."""

    def __init__(self, progress: Progress) -> None:
        self.callback: Optional[Callable[[int, int], None]] = None
        self.bar: Any = None
        self.tqdm: Any = None
        self.started = time.monotonic()
        self.last_line = 0.0
        self.line_shown = False
        self.terminal = sys.stderr.isatty()
        if callable(progress):
            self.callback = progress
        elif progress:
            try:
                from tqdm.auto import tqdm

                self.tqdm = tqdm
            except ImportError:
                self.tqdm = None
            self.callback = self._show

    def _show(self, done: int, total: int) -> None:
        if self.tqdm is not None:
            if self.bar is None:
                self.bar = self.tqdm(total=total, unit="realisation", dynamic_ncols=True)
            self.bar.total = total
            self.bar.n = done
            self.bar.refresh()
            return
        now = time.monotonic()
        elapsed = now - self.started
        text = (
            f"progress: {done}/{total} realisations "
            f"({100.0 * done / max(total, 1):.1f} %), {elapsed:.0f} s elapsed"
        )
        if self.terminal:
            print("\r" + text, end="", file=sys.stderr, flush=True)
            self.line_shown = True
        elif now - self.last_line >= LINE_INTERVAL or done >= total:
            self.last_line = now
            print(text, file=sys.stderr, flush=True)

    @staticmethod
    def notice(message: str) -> None:
        print(f"notice: {message}", file=sys.stderr, flush=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
        if self.line_shown:
            print(file=sys.stderr, flush=True)


def _read(path: pathlib.Path) -> Optional[pa.Table]:
    """A Parquet file read whole into memory, or None when it was not written."""
    if not path.exists():
        return None
    return pq.read_table(path, memory_map=False)


class _Output:
    """The output directory of a call: `out` (kept), or a temporary one removed after."""

    def __init__(self, out: Optional[Union[str, "os.PathLike[str]"]]) -> None:
        self.temporary: Optional[tempfile.TemporaryDirectory] = None
        if out is None:
            self.temporary = tempfile.TemporaryDirectory(prefix="chassis-mc-")
            self.path = pathlib.Path(self.temporary.name)
        else:
            self.path = pathlib.Path(out)

    @property
    def kept(self) -> Optional[pathlib.Path]:
        return None if self.temporary is not None else self.path

    def __enter__(self) -> "_Output":
        return self

    def __exit__(self, *exc: Any) -> None:
        if self.temporary is not None:
            self.temporary.cleanup()


@dataclass
class RunResult:
    """A finished run.

    Attributes:
        summary: summary.parquet: one row per condition × estimator × parameter (bias,
            EmpSE, bounds, MCSEs).
        realisations: realisations.parquet: one row per realisation × estimator.
        cycles: cycles.parquet (the drive cycles), or None for a model without cycles.
        report_path: report.html in ``out``, or None (no ``out``, or no report written).
        out: the output directory, or None when the run wrote to a temporary one.
        files: the files written (under ``out``; in the removed temporary directory
            otherwise).
        reused: realisations kept from an earlier, interrupted or smaller run in ``out``.
        computed: realisations computed by this call.
    """

    summary: pa.Table
    realisations: pa.Table
    cycles: Optional[pa.Table]
    report_path: Optional[pathlib.Path]
    out: Optional[pathlib.Path]
    files: List[pathlib.Path] = field(default_factory=list)
    reused: int = 0
    computed: int = 0


def run(
    study: Source,
    *,
    out: Optional[Union[str, "os.PathLike[str]"]] = None,
    realisations: Optional[int] = None,
    seed: Optional[int] = None,
    threads: Optional[int] = None,
    progress: Progress = True,
    figures: Optional[bool] = None,
    base: Optional[Base] = None,
) -> RunResult:
    """Run a study, as ``chassis-mc run STUDY --out OUT``, and return its tables.

    Args:
        study: a path, TOML text, a dict, or a :class:`Study` from :func:`load`.
        out: the output directory (created if missing; an interrupted or smaller run there
            is resumed or extended). Without it the run writes to a temporary directory,
            reads the tables into memory and removes it.
        realisations: realisations per condition, overriding the study's.
        seed: master seed, overriding the study's.
        threads: worker threads (default: every core). Results do not depend on it.
        progress: True for a bar (tqdm) or a plain line, False for none, or a callable
            taking (done, total).
        figures: draw the SVG figures into ``out/figures`` (default: when ``out`` is given).
        base: the directory the relative data paths of TOML text or a dict resolve against
            (default: the current directory; see :func:`load`).

    Raises:
        StudyError: the study cannot be run. RunError: a failure while running.
        KeyboardInterrupt: Ctrl-C; the completed parts stay in ``out`` for the next call.
    """
    loaded = load(study, realisations=realisations, seed=seed, base=base)
    reporter = _Reporter(progress)
    with _Output(out) as output:
        draw = output.kept is not None if figures is None else figures
        try:
            files, reused, computed = _core.run(
                loaded,
                os.fspath(output.path),
                threads,
                draw,
                reporter.callback,
                reporter.notice,
            )
        finally:
            reporter.close()
        summary = _read(output.path / "summary.parquet")
        table = _read(output.path / "realisations.parquet")
        assert summary is not None and table is not None, "a run writes both tables"
        report = output.path / "report.html"
        return RunResult(
            summary=summary,
            realisations=table,
            cycles=_read(output.path / "cycles.parquet"),
            report_path=report if output.kept is not None and report.exists() else None,
            out=output.kept,
            files=[pathlib.Path(f) for f in files],
            reused=reused,
            computed=computed,
        )


@dataclass
class CheckResult:
    """What ``chassis-mc check`` reports: the conditions, the time a few realisations took,
    the estimated run time and output size.

    Attributes:
        text: the report the command prints.
        ms_per_realisation: per condition, the measured time of one realisation [ms].
        estimated_seconds: the estimated run time [s] (a lower bound on a shared machine).
        output_bytes: the estimated size of every output file [bytes].
    """

    text: str
    ms_per_realisation: List[float]
    estimated_seconds: float
    output_bytes: float

    def __str__(self) -> str:
        return self.text


def check(
    study: Source,
    *,
    realisations: Optional[int] = None,
    seed: Optional[int] = None,
    threads: Optional[int] = None,
    base: Optional[Base] = None,
) -> CheckResult:
    """Validate a study and time a few realisations, as ``chassis-mc check``, without
    running it (``base`` as in :func:`load`). Raises :class:`StudyError` for a study that
    cannot be run."""
    loaded = load(study, realisations=realisations, seed=seed, base=base)
    text, per, seconds, size = _core.check(loaded, threads)
    return CheckResult(text, list(per), seconds, size)


@dataclass
class DesignResult:
    """The answer of ``chassis-mc design``.

    Attributes:
        sentence: the answer in words, as the command prints it.
        answer: the smallest (or, for a noise level, largest) value of the key meeting the
            target, or None when no value in the range does.
        answer_sd: the answer's standard deviation from the Monte Carlo error, or None.
        estimator: the estimator the target applies to.
        realisations: realisations per Monte Carlo evaluation.
        points: design.parquet: every value evaluated (prediction, and the Monte Carlo
            estimate with its MCSE where one was run).
        out: the output directory, or None for a temporary one.
        files: the files written.
    """

    sentence: str
    answer: Optional[float]
    answer_sd: Optional[float]
    estimator: str
    realisations: int
    points: Optional[pa.Table]
    out: Optional[pathlib.Path]
    files: List[pathlib.Path] = field(default_factory=list)

    def __str__(self) -> str:
        return self.sentence


def design(
    study: Source,
    *,
    vary: str,
    from_: float,
    to: float,
    target: str,
    estimator: Optional[str] = None,
    out: Optional[Union[str, "os.PathLike[str]"]] = None,
    realisations: Optional[int] = None,
    seed: Optional[int] = None,
    threads: Optional[int] = None,
    base: Optional[Base] = None,
) -> DesignResult:
    """The smallest duration (or scale, or largest noise) meeting a target precision, as
    ``chassis-mc design STUDY --vary KEY --from A --to B --target TARGET``; the keys and
    targets are those of ``chassis-mc design --help`` (``base`` as in :func:`load`). Unlike
    the command, a range without an answer is not an error: ``answer`` is None."""
    loaded = load(study, realisations=realisations, seed=seed, base=base)
    with _Output(out) as output:
        sentence, answer, sd, used, r, files = _core.design(
            loaded, vary, float(from_), float(to), target, os.fspath(output.path),
            estimator, threads,
        )
        return DesignResult(
            sentence=sentence,
            answer=answer,
            answer_sd=sd,
            estimator=used,
            realisations=r,
            points=_read(output.path / "design.parquet"),
            out=output.kept,
            files=[pathlib.Path(f) for f in files],
        )


@dataclass
class FitResult:
    """The estimates from a measured log, as ``chassis-mc fit``.

    Attributes:
        table: fit.parquet: one row per estimator × parameter (estimate, bootstrap
            interval, bounds).
        systematic: systematic.parquet (the systematic-error budget), or None without a
            ``[systematic]`` table.
        text: the tables the command prints.
        out: the output directory, or None for a temporary one.
        files: the files written.
    """

    table: pa.Table
    systematic: Optional[pa.Table]
    text: str
    out: Optional[pathlib.Path]
    files: List[pathlib.Path] = field(default_factory=list)

    def __str__(self) -> str:
        return self.text


def _log_file(log: Any, directory: pathlib.Path) -> str:
    """A log given as a path, a pandas DataFrame or a pyarrow Table, as a file the fit
    reads: a table is written as Parquet with its numeric columns as float64 (the values
    exactly as given)."""
    if isinstance(log, (str, os.PathLike)):
        return os.fspath(log)
    if isinstance(log, pa.Table):
        table = log
    elif hasattr(log, "to_parquet") and hasattr(log, "columns"):
        table = pa.Table.from_pandas(log, preserve_index=False)
    else:
        raise TypeError(
            f"log: a path, a pandas DataFrame or a pyarrow Table, not a {type(log).__name__}"
        )
    columns = []
    for name, column in zip(table.column_names, table.columns):
        if pa.types.is_integer(column.type) or pa.types.is_floating(column.type):
            column = column.cast(pa.float64())
        columns.append((name, column))
    table = pa.table({name: column for name, column in columns})
    path = directory / "log.parquet"
    pq.write_table(table, path, compression="zstd")
    return os.fspath(path)


def fit(
    fit: Source,
    *,
    log: Any = None,
    out: Optional[Union[str, "os.PathLike[str]"]] = None,
    base: Optional[Base] = None,
) -> FitResult:
    """Estimate θ from a measured log, as ``chassis-mc fit FIT --out OUT``.

    Args:
        fit: the fit file: a path, TOML text or a dict.
        log: the log, replacing the fit file's ``log.file``: a path (CSV or Parquet), a
            pandas DataFrame or a pyarrow Table with the columns ``[log]`` names.
        out: the output directory; without it a temporary one, removed after.
        base: the directory a relative ``log.file`` of TOML text or a dict resolves against
            (default: the current directory; a fit file's resolves against its own).
    """
    if isinstance(fit, _core.Study):
        raise TypeError("fit takes a fit file (path, TOML text or dict), not a Study")
    kind, value = _kind(fit, "fit")
    directory = _base(base, kind, "fit")
    with _Output(out) as output, tempfile.TemporaryDirectory(prefix="chassis-mc-log-") as tmp:
        log_path = None if log is None else _log_file(log, pathlib.Path(tmp))
        text, files = _core.fit(kind, value, os.fspath(output.path), log_path, directory)
        table = _read(output.path / "fit.parquet")
        assert table is not None, "a fit writes fit.parquet"
        return FitResult(
            table=table,
            systematic=_read(output.path / "systematic.parquet"),
            text=text,
            out=output.kept,
            files=[pathlib.Path(f) for f in files],
        )


def simulate_log(
    study: Source,
    *,
    out: Optional[Union[str, "os.PathLike[str]"]] = None,
    realisation: int = 0,
    realisations: Optional[int] = None,
    seed: Optional[int] = None,
    base: Optional[Base] = None,
) -> pa.Table:
    """One realisation of a one-condition study as a measured log, as ``chassis-mc
    simulate-log STUDY --out FILE``: written as CSV to ``out`` when given, and returned as a
    pyarrow Table (``base`` as in :func:`load`)."""
    loaded = load(study, realisations=realisations, seed=seed, base=base)
    import pyarrow.csv as pacsv

    if out is not None:
        path = pathlib.Path(out)
        _core.simulate_log(loaded, os.fspath(path), realisation)
        return pacsv.read_csv(path)
    with tempfile.TemporaryDirectory(prefix="chassis-mc-") as tmp:
        path = pathlib.Path(tmp) / "log.csv"
        _core.simulate_log(loaded, os.fspath(path), realisation)
        return pacsv.read_csv(path)
