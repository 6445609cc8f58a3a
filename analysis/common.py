"""Shared helpers of the analysis scripts: the check that a run's output set is complete and
from one run, the study in a run's footer, the true parameters, the terrain metric over the
drive cycle (from cycles.parquet), and the loop that runs a script's SQL once per
parameter over the realisations (of an unsharded run, or of every shard of a sharded one)."""

import math
import pathlib
import re
import sys
import tomllib

import duckdb
import pandas as pd
import pyarrow.parquet as pq

PARAMETERS = ["inv_mass", "drag_over_mass", "rolling_resistance"]
SYMBOL = {"inv_mass": "1/M", "drag_over_mass": "Cd/M", "rolling_resistance": "Cr"}
UNIT = {"inv_mass": "1/kg", "drag_over_mass": "1/kg", "rolling_resistance": "-"}


# While a run replaces its output files this journal exists; after a kill it stays until
# the next `chassis-mc run` completes the replacement (see the README, "Nothing half-written").
JOURNAL = ".chassis-mc-journal"


def fail(message):
    """Stop the script with `message` on stderr (exit status 2)."""
    print(f"error: {message}", file=sys.stderr)
    sys.exit(2)


def realisation_files(run_dir):
    """The realisation files of a run: its realisations.parquet, or else the
    shard=K/realisations.parquet of a sharded run, in shard order."""
    run_dir = pathlib.Path(run_dir)
    direct = run_dir / "realisations.parquet"
    if direct.is_file():
        return [direct]
    shards = sorted(
        run_dir.glob("shard=*/realisations.parquet"),
        key=lambda p: int(re.fullmatch(r"shard=(\d+)", p.parent.name).group(1)),
    )
    if not shards:
        fail(f"{run_dir}: no realisations.parquet and no shard=*/realisations.parquet")
    return shards


def check_output_set(run_dir):
    """Refuse an incomplete or mixed output set: a journal left by an interrupted run, or
    files whose footers name different studies, seeds or realisation counts."""
    run_dir = pathlib.Path(run_dir)
    files = [run_dir / "summary.parquet", *realisation_files(run_dir)]
    if (run_dir / "cycles.parquet").is_file():
        files.append(run_dir / "cycles.parquet")
    for d in {f.parent for f in files}:
        if (d / JOURNAL).exists():
            fail(f"{d}: incomplete output: a run was interrupted while replacing its files, "
                 "so they may mix two runs; run `chassis-mc run` into it again to complete it")
    first = None
    for f in files:
        if not f.is_file():
            fail(f"{f}: missing (run `chassis-mc run`, or `chassis-mc summarize` for shards)")
        meta = pq.read_metadata(f).metadata or {}
        key = (meta.get(b"chassis_mc.identity"), meta.get(b"chassis_mc.realisations"))
        if None in key:
            fail(f"{f}: not a chassis-mc output file (no identity in its footer)")
        if first is None:
            first = (f, key)
        elif key != first[1]:
            fail(f"{f} and {first[0]} come from different runs (study, seed or realisations "
                 "differ): the output set is mixed; run the study again into this directory")


def study_of(run_dir):
    """The study TOML a run used, from the footer of its summary.parquet, after checking
    that the run's output set is complete and from one run."""
    check_output_set(run_dir)
    meta = pq.read_metadata(pathlib.Path(run_dir) / "summary.parquet").metadata
    return tomllib.loads(meta[b"chassis_mc.study"].decode())


def truth(study):
    """θ = [1/M, Cd/M, Cr] from the study's vehicle (thesis eq. 34)."""
    v = study["vehicle"]
    return {
        "inv_mass": 1.0 / v["mass"],
        "drag_over_mass": v["drag_coefficient"] / v["mass"],
        "rolling_resistance": v["rolling_resistance"],
    }


def terrain_metrics(run_dir):
    """Per condition: ς over the terrain table (`terrain_ms_grid`, from summary.parquet; the
    table itself is not in the output) and ς over the drive cycle (`terrain_ms_cycle`, the
    mean of θ² over the samples the regression uses, thesis eq. 43), computed here from the
    grades in cycles.parquet with a compensated sum.

    cycles.parquet holds each distinct cycle once, keyed by `scale` and `acceleration`; a
    condition's samples are its cycle's `used` rows within its duration (t − t₀ ≤ duration,
    t₀ the cycle's first time; README, "Output files")."""
    run_dir = pathlib.Path(run_dir)
    with duckdb.connect() as con:
        con.execute("SET threads = 1")
        return con.execute(
            "SELECT s.condition, any_value(s.terrain_ms_grid) AS terrain_ms_grid, "
            "fsum(c.grade * c.grade) / count(*) AS terrain_ms_cycle "
            "FROM (SELECT DISTINCT condition, scale, acceleration, duration, terrain_ms_grid "
            "      FROM read_parquet($summary)) s "
            "JOIN (SELECT scale, acceleration, grade, used, "
            "             t - min(t) OVER (PARTITION BY scale, acceleration) AS elapsed "
            "      FROM read_parquet($cycles)) c "
            "  ON c.scale = s.scale AND c.acceleration = s.acceleration "
            "  AND c.used AND c.elapsed <= s.duration "
            "GROUP BY s.condition ORDER BY s.condition",
            {"summary": str(run_dir / "summary.parquet"),
             "cycles": str(run_dir / "cycles.parquet")},
        ).df()


def per_parameter(run_dir, columns, sql, after):
    """Run `sql` once per parameter and stack the results, one row per result row × parameter.

    The realisations (realisations.parquet, or every shard's), which can be large, are read
    once: their rows with status 'ok' and the
    `columns` listed (`{p}` in a name stands for each parameter in turn) go into a temporary
    table `realisations`, in file order. `sql` then runs on that table for every parameter,
    with `{p}` replaced by the parameter's name and `$truth` bound to its true value; a
    `parameter` column is inserted after the column `after` of each result.

    The queries run on one thread: fsum's compensated sum depends (in the last bits) on the
    order of its terms, and one thread adds each group's terms in file order, so the numbers
    do not depend on the number of cores or on how DuckDB splits the table among them.
    """
    theta = truth(study_of(run_dir))
    names = list(dict.fromkeys(c.replace("{p}", p) for c in columns for p in PARAMETERS))
    with duckdb.connect() as con:
        con.execute(
            f"CREATE TEMP TABLE realisations AS SELECT {', '.join(names)} "
            "FROM read_parquet($files) WHERE status = 'ok'",
            {"files": [str(f) for f in realisation_files(run_dir)]},
        )
        con.execute("SET threads = 1")
        frames = []
        for p in PARAMETERS:
            df = con.execute(sql.replace("{p}", p), {"truth": theta[p]}).df()
            df.insert(df.columns.get_loc(after) + 1, "parameter", p)
            frames.append(df)
    return pd.concat(frames, ignore_index=True)


def mc_summary(estimates):
    """Mean and SD of R estimates with their MCSEs (s/√R, s/√(2(R−1)))."""
    r = len(estimates)
    s = estimates.std(ddof=1)
    return estimates.mean(), s / math.sqrt(r), s, s / math.sqrt(2 * (r - 1))
