#!/usr/bin/env python3
"""Bias ± MCSE and EmpSE/bound per estimator, recomputed from a run's realisations.

For every condition, estimator and parameter: the bias of the estimates with its Monte
Carlo standard error √(S²/n), and for every bound that applies the ratio EmpSE / bound SE
(√ of the mean per-realisation variance) — computed with DuckDB from realisations.parquet,
independently of the engine's summary, so the two can be checked against each other.

    python analysis/bias_report.py results/bc [--csv numbers.csv]
"""

import argparse
import pathlib

import pandas as pd

from common import per_parameter

BOUNDS = ["thesis_bound", "crlb_output", "eiv_sandwich", "eiv_crlb_linearized"]

# The columns of realisations.parquet the query uses; {p} stands for each parameter.
COLUMNS = ["condition", "scale", "velocity_sd", "estimator", "theta_{p}"] + [b + "_{p}" for b in BOUNDS]

# Runs once per parameter on the table `realisations` (see common.per_parameter); r is NOT
# MATERIALIZED because a second scan of that in-memory table is cheaper than a copy of it.
SQL = """
WITH r AS NOT MATERIALIZED (
    SELECT condition, scale, velocity_sd, estimator, theta_{p} - $truth AS d, {bound_cols}
    FROM realisations
), m AS (
    SELECT condition, estimator, fsum(d) / count(*) AS bias FROM r GROUP BY ALL
), s AS (
    SELECT r.condition, r.estimator, any_value(r.scale) AS scale,
           any_value(r.velocity_sd) AS velocity_sd, count(*) AS n, any_value(m.bias) AS bias,
           sqrt(fsum((r.d - m.bias) * (r.d - m.bias)) / (count(*) - 1)) AS emp_se,
           {bound_aggs}
    FROM r JOIN m USING (condition, estimator)
    GROUP BY r.condition, r.estimator
)
SELECT condition, scale, velocity_sd, estimator, n, bias, emp_se / sqrt(n) AS bias_mcse,
       emp_se, {ratios}
FROM s ORDER BY condition, estimator
"""


def report(run_dir):
    """One row per condition × estimator × parameter."""
    sql = (
        SQL.replace("{bound_cols}", ", ".join(f"{b}_{{p}} AS {b}" for b in BOUNDS))
        .replace("{bound_aggs}", ", ".join(f"sqrt(fsum({b} * {b}) / count({b})) AS {b}_se" for b in BOUNDS))
        .replace("{ratios}", ", ".join(f"emp_se / {b}_se AS emp_over_{b}" for b in BOUNDS))
    )
    return per_parameter(run_dir, COLUMNS, sql, after="estimator")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir", type=pathlib.Path, help="output directory of `chassis-mc run`")
    ap.add_argument("--csv", type=pathlib.Path, help="also write the numbers as CSV")
    args = ap.parse_args()
    df = report(args.run_dir)
    if args.csv:
        df.to_csv(args.csv, index=False, float_format="%.17g")
    shown = df.assign(**{"bias ± MCSE": [f"{b:+.3e} ± {m:.1e}" for b, m in zip(df.bias, df.bias_mcse)],
                         "|bias|/MCSE": (df.bias / df.bias_mcse).abs()})
    cols = ["scale", "velocity_sd", "parameter", "estimator", "bias ± MCSE", "|bias|/MCSE"]
    cols += [f"emp_over_{b}" for b in BOUNDS if df[f"emp_over_{b}"].notna().any()]
    with pd.option_context("display.width", 200, "display.max_rows", 1000):
        print(shown[cols].to_string(index=False, float_format=lambda v: f"{v:.4g}"))


if __name__ == "__main__":
    main()
