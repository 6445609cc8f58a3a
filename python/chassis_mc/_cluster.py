"""Shards of a study run on any worker (Dask, Ray, ``multiprocessing``, a SLURM array) and
combined into the files of one local run: :func:`shards`, :meth:`ShardTask.run`,
:func:`summarize` (README, "Python on a cluster")."""

from __future__ import annotations

import os
import pathlib
from dataclasses import dataclass
from typing import Any, List, Optional, Union

import pyarrow.parquet as pq

from . import (
    Base,
    Progress,
    RunResult,
    Source,
    _core,
    _read,
    _Reporter,
    _table,
    _threads,
    _whole,
    load,
)


@dataclass(frozen=True)
class ShardResult:
    """A shard run by :meth:`ShardTask.run`: where its rows are, for :func:`summarize`.

    Attributes:
        directory: ``out/shard=K``, holding the shard's realisations.parquet.
        index: K (0-based). count: N.
        computed: realisations computed. reused: realisations kept from an earlier,
            interrupted run of the same shard there.
    """

    directory: pathlib.Path
    index: int
    count: int
    computed: int
    reused: int


@dataclass(frozen=True)
class ShardTask:
    """Shard K of N of a study: realisations ⌊K·R/N⌋ … ⌊(K+1)·R/N⌋ − 1 of every condition,
    as ``chassis-mc run STUDY --shard K/N``. It pickles (the study with it), so any worker
    process can run it: each realisation's draws depend only on the study's seed, its
    condition and its index, never on the worker or the split.

    Attributes:
        study: the study as run (overrides applied). index: K. count: N.
    """

    study: "_core.Study"
    index: int
    count: int

    def run(
        self,
        out: Union[str, "os.PathLike[str]"],
        *,
        threads: Optional[int] = None,
        progress: Progress = False,
    ) -> ShardResult:
        """Run the shard into ``out/shard=K/`` (``out`` on storage every worker and the
        summarising process see; created if missing); an interrupted shard there resumes.
        Returns a :class:`ShardResult` for :func:`summarize`."""
        reporter = _Reporter(progress)
        try:
            ran = _core.run(self.study, os.fspath(out), _threads(threads), False,
                            reporter.callback, reporter.notice, (self.index, self.count))
        finally:
            reporter.close()
        # the directory the shard wrote: that of its realisation file
        directory = pathlib.Path(ran.files[0]).parent
        return ShardResult(directory, self.index, self.count, ran.computed, ran.reused)


def shards(
    study: Source,
    n: int,
    *,
    realisations: Optional[int] = None,
    seed: Optional[int] = None,
    base: Optional[Base] = None,
) -> List[ShardTask]:
    """Split a study into ``n`` picklable tasks, 1 ≤ n ≤ its realisations per condition
    (``realisations``, ``seed`` and ``base`` as in :func:`load`), each run by ``task.run(out)`` on any worker (Dask, Ray,
    ``multiprocessing``, a SLURM array); :func:`summarize` of their results gives the files
    of one local run of the study, byte for byte (README, "Python on a cluster")."""
    loaded = load(study, realisations=realisations, seed=seed, base=base)
    # every shard holds at least one realisation of every condition
    count, reason = _whole("n", n, 1, loaded.realisations)
    if reason is not None:
        raise ValueError(f"n {reason} (the study's realisations per condition)")
    return [ShardTask(loaded, k, count) for k in range(count)]


def summarize(
    shards: Any,
    out: Union[str, "os.PathLike[str]"],
    *,
    figures: bool = True,
) -> RunResult:
    """Combine shards of one study into ``out``, as ``chassis-mc summarize``: the
    summary, the model's tables (cycles), the figures (``figures=True``) and the report,
    and the shards' realisations assembled in order into ``out/realisations.parquet``,
    which together are the files of one local run of the study, byte for byte.

    ``shards``: :class:`ShardResult` objects, shard directories (``out/shard=K``) or
    realisation files, in any order (one path or a list); every realisation of every
    condition must be in exactly one of them. Returns the :class:`RunResult` of ``out``.
    """
    items = shards if isinstance(shards, (list, tuple)) else [shards]
    inputs = []
    for item in items:
        if isinstance(item, ShardResult):
            inputs.append(os.fspath(item.directory))
        elif isinstance(item, RunResult) and item.out is not None:
            inputs.append(os.fspath(item.out))
        elif isinstance(item, (str, os.PathLike)):
            inputs.append(os.fspath(item))
        else:
            raise TypeError(
                "summarize takes ShardResults, shard directories or realisation files, not "
                f"a {type(item).__name__}"
            )
    kept = pathlib.Path(out)
    done = _core.summarize(inputs, os.fspath(kept), bool(figures))
    table = _read(kept / "realisations.parquet")
    assert table is not None, "summarize assembles realisations.parquet"
    footer = pq.read_metadata(kept / "realisations.parquet").metadata or {}
    study = _core._study_from_toml(
        footer[b"chassis_mc.study"].decode(),
        f"{kept / 'realisations.parquet'} (footer)",
        footer.get(b"chassis_mc.study_dir", b".").decode(),
    )
    report = kept / "report.html"
    return RunResult(
        summary=_table(done.summary),
        realisations=table,
        study=study,
        report_path=report if report.exists() else None,
        out=kept,
        files=[pathlib.Path(f) for f in done.files],
        reused=0,
        computed=0,
    )
