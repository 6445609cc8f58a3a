"""Shared helpers of the analysis scripts: the study in a run's footer, the true parameters,
and the terrain metric, each computed here independently of the engine."""

import pathlib
import tomllib

import numpy as np
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
