"""chassis-mc in Python: run a study, check it, design a road test, fit a measured log.

Every function calls the same Rust library as the ``chassis-mc`` command (installed by the
same wheel), so a study run here writes the bytes the command writes for the same study and
seed. Results come back as pyarrow Tables (``.to_pandas()`` for pandas; DuckDB reads them
directly), handed over in memory through the Arrow C stream interface: a call without
``out`` creates no file. The columns and units are in the
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
``reason``), and so does an override out of range (``realisations``, ``seed``: ``key`` is
the argument); ``threads`` out of range raises ValueError; a failure while running raises
:class:`RunError`. Errors, a :class:`Study` and a :class:`RunResult` pickle (to and from
worker processes), a result without its cycles table, which it reads again when asked for.

Ctrl-C (KeyboardInterrupt) stops a run after the chunk it is writing; its completed parts
stay in ``out`` and the same call resumes from them (a run without ``out`` keeps nothing).
"""

from __future__ import annotations

import operator
import os
import pathlib
import re
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
    "ShardResult",
    "ShardTask",
    "shards",
    "simulate_log",
    "summarize",
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


def _whole(name: str, value: Any, low: int, high: int) -> Tuple[int, Optional[str]]:
    """`value` as an int and, when it is outside [low, high], why (for the caller's error).
    A bool or a float is not a whole number (TypeError); a numpy integer is."""
    try:
        if isinstance(value, bool):
            raise TypeError
        number = operator.index(value)
    except TypeError:
        raise TypeError(
            f"{name} must be a whole number from {low} to {high} (an int), not "
            f"{type(value).__name__} {value!r}"
        ) from None
    if low <= number <= high:
        return number, None
    return number, f"must be a whole number from {low} to {high}, got {number}"


def _override(name: str, value: Optional[int], low: int, high: int) -> Optional[int]:
    """An override of the study's `realisations` or `seed`: a StudyError (file
    ``<arguments>``, key `name`) outside the command line's range."""
    if value is None:
        return None
    number, reason = _whole(name, value, low, high)
    if reason is not None:
        raise StudyError(f"{name} {reason}", "<arguments>", name, None, reason)
    return number


def _count(name: str, value: Optional[int], low: int, high: int) -> Optional[int]:
    """A count that is no part of the study (``threads``): a ValueError outside its range."""
    if value is None:
        return None
    number, reason = _whole(name, value, low, high)
    if reason is not None:
        raise ValueError(f"{name} {reason}")
    return number


def _threads(threads: Optional[int]) -> Optional[int]:
    """Worker threads: 1 to 65535 as the command line's --threads, or None (every core)."""
    return _count("threads", threads, 1, _core.MAX_THREADS)


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
    realisations = _override("realisations", realisations, 1, _core.MAX_REALISATIONS)
    seed = _override("seed", seed, 0, _core.MAX_SEED)
    if isinstance(study, _core.Study):
        if base is not None:
            raise ValueError("base= applies to a study given as TOML text or a dict, not "
                             "to a Study (its data paths are already resolved)")
        if realisations is None and seed is None:
            return study
        return study.with_overrides(realisations, seed)
    kind, value = _kind(study)
    return _core.load_study(**{kind: value}, realisations=realisations, seed=seed,
                            base=_base(base, kind))


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
    realisations = _override("realisations", realisations, 1, _core.MAX_REALISATIONS)
    seed = _override("seed", seed, 0, _core.MAX_SEED)
    return _core.load_study(text=text, realisations=realisations, seed=seed,
                            base=_base(base, "text"))


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


def _table(held: Any) -> pa.Table:
    """A table the Rust side holds (``_core.ArrowTable``), as a pyarrow Table: read through
    the Arrow C stream interface, in memory (no file, no copy of the columns)."""
    from_stream = getattr(pa.RecordBatchReader, "from_stream", None)
    if from_stream is not None:  # pyarrow >= 15
        return from_stream(held).read_all()
    return pa.RecordBatchReader._import_from_c_capsule(held.__arrow_c_stream__()).read_all()


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


def _cycles(study: "_core.Study", out: Optional[pathlib.Path]) -> Optional[pa.Table]:
    """The cycles table of a run of `study`: ``out/cycles.parquet`` when it is there and
    from a run of this study, else computed again from the study (the same table; a run's
    cycles do not depend on its realisations or seed). None for a model without cycles."""
    if out is not None:
        path = out / "cycles.parquet"
        if path.is_file():
            footer = pq.read_metadata(path).metadata or {}
            identity = footer.get(b"chassis_mc.identity", b"").decode()
            if identity.startswith(study.identity()):
                return pq.read_table(path, memory_map=False)
    for name, held in _core.cycles(study):
        if name == "cycles.parquet":
            return _table(held)
    return None


@dataclass
class RunResult:
    """A finished run.

    Attributes:
        summary: summary.parquet: one row per condition × estimator × parameter (bias,
            EmpSE, bounds, MCSEs).
        realisations: realisations.parquet: one row per realisation × estimator.
        cycles: cycles.parquet (the drive cycles), or None for a model without cycles:
            read when first asked for (from ``out``, or computed again from the study),
            then kept.
        study: the study as run (overrides applied).
        report_path: report.html in ``out``, or None (no ``out``, or no report written).
        out: the output directory, or None for a run held in memory (no file written).
        files: the files written under ``out`` (none without it).
        reused: realisations kept from an earlier, interrupted or smaller run in ``out``.
        computed: realisations computed by this call.

    A result pickles (e.g. from a worker process) with its summary, realisations and
    study, never its cycles (82 MB for the thesis study): the copy reads them when asked.
    """

    summary: pa.Table
    realisations: pa.Table
    study: "_core.Study" = field(repr=False, compare=False)
    report_path: Optional[pathlib.Path]
    out: Optional[pathlib.Path]
    files: List[pathlib.Path] = field(default_factory=list)
    reused: int = 0
    computed: int = 0
    _cycles: Optional[pa.Table] = field(default=None, init=False, repr=False, compare=False)
    _cycles_read: bool = field(default=False, init=False, repr=False, compare=False)

    @property
    def cycles(self) -> Optional[pa.Table]:
        """cycles.parquet (the drive cycles), or None for a model without cycles."""
        if not self._cycles_read:
            self._cycles = _cycles(self.study, self.out)
            self._cycles_read = True
        return self._cycles

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state["_cycles"], state["_cycles_read"] = None, False
        return state


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
            is resumed or extended). Without it nothing is written: the run is held in
            memory and its tables cross to Python through the Arrow C stream interface.
        realisations: realisations per condition, overriding the study's: a whole number
            from 1 to 2^40 (out of range: :class:`StudyError` with ``key="realisations"``).
        seed: master seed, overriding the study's: a whole number from 0 to 2^63 − 1.
        threads: worker threads, 1 to 65535 as the command line's ``--threads`` (default:
            every core; out of range: ValueError). Results do not depend on it.
        progress: True for a bar (tqdm) or a plain line, False for none, or a callable
            taking (done, total).
        figures: draw the SVG figures into ``out/figures`` (default: when ``out`` is given;
            True without ``out`` is a ValueError).
        base: the directory the relative data paths of TOML text or a dict resolve against
            (default: the current directory; see :func:`load`).

    Raises:
        StudyError: the study cannot be run. RunError: a failure while running.
        KeyboardInterrupt: Ctrl-C; the completed parts stay in ``out`` for the next call
            (a run without ``out`` keeps nothing).
    """
    threads = _threads(threads)
    loaded = load(study, realisations=realisations, seed=seed, base=base)
    reporter = _Reporter(progress)
    kept = None if out is None else pathlib.Path(out)
    draw = kept is not None if figures is None else bool(figures)
    if kept is None and draw:
        raise ValueError("figures=True needs out= (a run without out writes no file)")
    try:
        ran = _core.run(
            loaded,
            None if kept is None else os.fspath(kept),
            threads,
            draw,
            reporter.callback,
            reporter.notice,
        )
    finally:
        reporter.close()
    # with out, the rows the file holds (an earlier run's it kept too), as they were written
    table = _table(ran.realisations)
    report = None if kept is None else kept / "report.html"
    return RunResult(
        summary=_table(ran.summary),
        realisations=table,
        study=loaded,
        report_path=report if report is not None and report.exists() else None,
        out=kept,
        files=[pathlib.Path(f) for f in ran.files],
        reused=ran.reused,
        computed=ran.computed,
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
    threads = _threads(threads)
    loaded = load(study, realisations=realisations, seed=seed, base=base)
    found = _core.check(loaded, threads)
    return CheckResult(found.text, list(found.ms_per_realisation), found.estimated_seconds,
                       found.output_bytes)


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
    threads = _threads(threads)
    loaded = load(study, realisations=realisations, seed=seed, base=base)
    with _Output(out) as output:
        found = _core.design(
            loaded, vary, float(from_), float(to), target, os.fspath(output.path),
            estimator, threads,
        )
        return DesignResult(
            sentence=found.sentence,
            answer=found.answer,
            answer_sd=found.answer_sd,
            estimator=found.estimator,
            realisations=found.realisations,
            points=_read(output.path / "design.parquet"),
            out=output.kept,
            files=[pathlib.Path(f) for f in found.files],
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
        out: the output directory, or None when nothing was written.
        files: the files written.
    """

    table: pa.Table
    systematic: Optional[pa.Table]
    text: str
    out: Optional[pathlib.Path]
    files: List[pathlib.Path] = field(default_factory=list)

    def __str__(self) -> str:
        return self.text


@dataclass
class _LogTable:
    """A log given as a table, handed to the fit in memory: `name` says what it was in
    errors, `index` holds a DataFrame's index labels."""

    name: str
    table: pa.Table
    index: Any = None

    def place(self, row: int) -> str:
        """`row N` (1-based, as the engine counts a table's rows) with its position in the
        table and, for a DataFrame, its index label."""
        where = f"row {row} (position {row - 1}"
        if self.index is not None and 0 <= row - 1 < len(self.index):
            label = self.index[row - 1]
            label = label.item() if hasattr(label, "item") else label
            where += f", index label {label!r}"
        return where + ")"

    def renamed(self, error: ChassisMcError) -> ChassisMcError:
        """`error` with each row it names given with its position and index label."""

        def rename(text: str) -> str:
            pattern = re.escape(self.name) + r': (column "[^"]*", )?row (\d+):'
            return re.sub(
                pattern,
                lambda m: f"{self.name}: {m.group(1) or ''}{self.place(int(m.group(2)))}:",
                text,
            )

        message = rename(str(error.args[0]) if error.args else "")
        if isinstance(error, StudyError):
            reason = rename(error.reason)
            if error.key == "log.file" and reason.startswith(f"{self.name}: "):
                # about the table, not the fit file's log.file (which the table replaces)
                reason = reason[len(self.name) + 2 :]
                return StudyError(f"{self.name}: {reason}", self.name, None, None, reason)
            return StudyError(message, error.file, error.key, error.line, reason)
        if isinstance(error, RunError):
            return RunError(message, error.bad_input)
        return type(error)(message)


def _unconvertible(frame: Any, name: str) -> StudyError:
    """The error of a DataFrame log whose columns pyarrow cannot convert: the first column
    that fails, and its first cell that is not a number."""
    import pandas as pd

    for position, column_name in enumerate(frame.columns):
        column = frame.iloc[:, position]
        try:
            pa.array(column, from_pandas=True)
            continue
        except (pa.ArrowInvalid, pa.ArrowTypeError) as e:
            failure = str(e)
        numbers = pd.to_numeric(column, errors="coerce")
        odd = (column.notna() & numbers.isna()).to_numpy().nonzero()[0]
        log = _LogTable(name, pa.table({}), frame.index)
        if len(odd):
            value = column.iloc[int(odd[0])]
            reason = (
                f'column "{column_name}", {log.place(int(odd[0]) + 1)}: {value!r} (a '
                f"{type(value).__name__}) is not a number"
            )
        else:
            reason = f'column "{column_name}": cannot be converted to a table column: {failure}'
        return StudyError(f"{name}: {reason}", name, None, None, reason)
    raise AssertionError("pyarrow converts each column alone but not the whole DataFrame")


def _log_table(log: Any) -> Union[str, _LogTable]:
    """A log given as a path (returned as it is), a pandas DataFrame or a pyarrow Table: a
    table with its numeric columns as float64 (the values exactly as given), handed over in
    memory and named in errors as what it was given as."""
    if isinstance(log, (str, os.PathLike)):
        return os.fspath(log)
    index = None
    if isinstance(log, pa.Table):
        table = log
        name = "the pyarrow Table given as log"
    elif hasattr(log, "to_parquet") and hasattr(log, "columns"):
        name = "the DataFrame given as log"
        try:
            table = pa.Table.from_pandas(log, preserve_index=False)
        except (pa.ArrowInvalid, pa.ArrowTypeError):
            raise _unconvertible(log, name) from None
        index = log.index
    else:
        raise TypeError(
            f"log: a path, a pandas DataFrame or a pyarrow Table, not a {type(log).__name__}"
        )
    columns = []
    for column in table.columns:
        if pa.types.is_integer(column.type) or pa.types.is_floating(column.type):
            column = column.cast(pa.float64())
        columns.append(column)
    # by position: two columns of one name stay two (the fit names them as such)
    return _LogTable(name, pa.Table.from_arrays(columns, names=table.column_names), index)


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
            pandas DataFrame or a pyarrow Table with the columns ``[log]`` names. An error
            in a table names it (``the DataFrame given as log``), its column and its row
            (1-based, with its position and index label).
        out: the output directory; without it nothing is written.
        base: the directory a relative ``log.file`` of TOML text or a dict resolves against
            (default: the current directory; a fit file's resolves against its own).
    """
    if isinstance(fit, _core.Study):
        raise TypeError("fit takes a fit file (path, TOML text or dict), not a Study")
    kind, value = _kind(fit, "fit")
    directory = _base(base, kind, "fit")
    given = None if log is None else _log_table(log)
    log_path = given if isinstance(given, str) else None
    log_table = (given.name, given.table) if isinstance(given, _LogTable) else None
    kept = None if out is None else pathlib.Path(out)
    try:
        done = _core.fit(**{kind: value}, out=None if kept is None else os.fspath(kept),
                         log=log_path, base=directory, log_table=log_table)
    except ChassisMcError as e:
        if not isinstance(given, _LogTable):
            raise
        # name the rows as the caller knows them: position and index label
        raise given.renamed(e) from None
    return FitResult(
        table=_table(done.table),
        systematic=None if done.systematic is None else _table(done.systematic),
        text=done.text,
        out=kept,
        files=[pathlib.Path(f) for f in done.files],
    )


def simulate_log(
    study: Source,
    *,
    out: Optional[Union[str, "os.PathLike[str]"]] = None,
    realisation: int = 0,
    realisations: Optional[int] = None,
    seed: Optional[int] = None,
    base: Optional[Base] = None,
    force: bool = False,
) -> pa.Table:
    """One realisation of a one-condition study as a measured log, as ``chassis-mc
    simulate-log STUDY --out FILE``: written as CSV to ``out`` when given, and returned as a
    pyarrow Table (``base`` as in :func:`load`). A file already at ``out`` is replaced only
    when it is a log simulate-log wrote (its header row) or with ``force=True``: a measured
    log is never overwritten by mistake (:class:`RunError` with ``bad_input``)."""
    realisation = _count("realisation", realisation, 0, 2**64 - 1)
    loaded = load(study, realisations=realisations, seed=seed, base=base)
    path = None if out is None else os.fspath(out)
    return _table(_core.simulate_log(loaded, path, realisation, bool(force)))


# Shards of a study for a cluster (Dask, Ray, multiprocessing), in their own module.
from ._cluster import ShardResult, ShardTask, shards, summarize  # noqa: E402
