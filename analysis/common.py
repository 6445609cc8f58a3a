"""Shared helpers of the analysis scripts: the study in a run's footer, the true parameters,
the terrain metric, each computed here independently of the engine, and the loop that runs
a script's SQL once per parameter over the realisations."""

import pathlib
import tomllib

import duckdb
import numpy as np
import pandas as pd
import pyarrow.parquet as pq

PARAMETERS = ["inv_mass", "drag_over_mass", "rolling_resistance"]
SYMBOL = {"inv_mass": "1/M", "drag_over_mass": "Cd/M", "rolling_resistance": "Cr"}
UNIT = {"inv_mass": "1/kg", "drag_over_mass": "1/kg", "rolling_resistance": "-"}


def study_of(run_dir):
    """The study TOML a run used, from the footer of its summary.parquet."""
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


def terrain_metric(study, scale):
    """ς = mean θ² over the terrain table (the thesis code's `rgm`), from the cos² profile."""
    t = study["terrain"]
    x = np.arange(t["length"] + 1, dtype=float)
    rise = np.diff(t["height"] * np.cos(x / t["period"]) ** 2)
    if t["scale_applies_to"] == "grade":
        grade = scale * np.arctan(rise)
    else:
        grade = np.arctan(scale * rise)
    return float(np.mean(grade**2))


def parquet(run_dir, name):
    """Path of one of a run's Parquet files, as a string for DuckDB."""
    return str(pathlib.Path(run_dir) / name)


def per_parameter(run_dir, columns, sql, after):
    """Run `sql` once per parameter and stack the results, one row per result row × parameter.

    realisations.parquet, which can be large, is read once: its rows with status 'ok' and the
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
            "FROM read_parquet($file) WHERE status = 'ok'",
            {"file": parquet(run_dir, "realisations.parquet")},
        )
        con.execute("SET threads = 1")
        frames = []
        for p in PARAMETERS:
            df = con.execute(sql.replace("{p}", p), {"truth": theta[p]}).df()
            df.insert(df.columns.get_loc(after) + 1, "parameter", p)
            frames.append(df)
    return pd.concat(frames, ignore_index=True)
