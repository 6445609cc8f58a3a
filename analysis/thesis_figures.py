#!/usr/bin/env python3
"""Reproduce the thesis's Figures 4-6 and Table 3 from a chassis-mc run, with the Monte Carlo
behind every number.

The aggregation is DuckDB SQL over realisations.parquet (per terrain scale: the mean of each
estimate, its empirical SE and the thesis bound's SE √mean(b²)); the table is pandas. The
terrain metric ς over the terrain table (what the thesis plotted against) comes from the
summary, and ς over the drive cycle (the thesis's eq. 43) is computed here from the grades
in cycles.parquet. Figures 4-6 plot the
thesis bound against ς as the thesis did, next to the real spread of the estimates (EmpSE
± MCSE); Table 3 puts the thesis's single-realisation values next to the Monte Carlo means.

    python analysis/thesis_figures.py results/thesis [--out results/thesis/analysis] [--csv numbers.csv]
"""

import argparse
import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

from common import PARAMETERS, SYMBOL, UNIT, per_parameter, terrain_metrics  # noqa: E402

# Table 3 of the thesis (§6.2): one realisation per scale, σ_v = 1 m/s.
TABLE3 = pd.DataFrame(
    {
        "scale": [1.0, 1.1, 1.2, 1.3, 1.4, 1.5, 1.6, 1.7, 1.8, 1.9, 2.0],
        "inv_mass": [0.00055479, 0.000557093, 0.000555393, 0.000555327, 0.00055618,
                     0.000557523, 0.000553248, 0.000557133, 0.000555928, 0.000555913,
                     0.000553493],
        "drag_over_mass": [0.000182927, 0.000183416, 0.00018401, 0.000184525, 0.000184976,
                           0.000185593, 0.000185952, 0.000186381, 0.000187029, 0.000187111,
                           0.000187759],
        "rolling_resistance": [0.018010557, 0.01823568, 0.017581247, 0.01731914, 0.017232048,
                               0.017242714, 0.016142849, 0.016797372, 0.016186674,
                               0.016150069, 0.015312255],
    }
)

# The columns of realisations.parquet the query uses; {p} stands for each parameter.
COLUMNS = ["condition", "scale", "velocity_sd", "estimator", "theta_{p}", "thesis_bound_{p}"]

# Runs once per parameter on the table `realisations` (see common.per_parameter); r is NOT
# MATERIALIZED because a second scan of that in-memory table is cheaper than a copy of it.
# Centred sums (fsum: Kahan summation) so that neither a mean nor a variance is the small
# difference of two large numbers.
SQL = """
WITH r AS NOT MATERIALIZED (
    SELECT condition, scale, velocity_sd, estimator,
           theta_{p} - $truth AS d, thesis_bound_{p} AS b
    FROM realisations
), m AS (
    SELECT condition, estimator, fsum(d) / count(*) AS mean_d FROM r GROUP BY ALL
)
SELECT r.condition, any_value(r.scale) AS scale, any_value(r.velocity_sd) AS velocity_sd,
       r.estimator, count(*) AS n,
       $truth + any_value(m.mean_d) AS mean,
       sqrt(fsum((r.d - m.mean_d) * (r.d - m.mean_d)) / (count(*) - 1)) AS emp_se,
       sqrt(fsum(r.b * r.b) / count(r.b)) AS thesis_bound_se
FROM r JOIN m USING (condition, estimator)
GROUP BY r.condition, r.estimator
ORDER BY r.condition, r.estimator
"""


def aggregate(run_dir):
    """One row per condition × estimator × parameter: n, mean, emp_se, thesis_bound_se, and
    ς over the terrain table and over the cycle."""
    out = per_parameter(run_dir, COLUMNS, SQL, after="velocity_sd")
    metrics = terrain_metrics(run_dir)
    out = out.merge(metrics, on="condition", how="left", validate="many_to_one")
    out["mean_mcse"] = out.emp_se / out.n**0.5
    out["emp_se_mcse"] = out.emp_se / (2 * (out.n - 1)) ** 0.5
    return out


def table3(agg):
    """The thesis's Table 3 beside the Monte Carlo means (OLS, σ_v = 1 m/s)."""
    ols = agg[(agg.estimator == "ols") & (agg.velocity_sd == 1.0)]
    rows = []
    for _, t in TABLE3.iterrows():
        row = {"scale": t.scale}
        for p in PARAMETERS:
            mc = ols[(ols.scale.round(9) == round(t.scale, 9)) & (ols.parameter == p)]
            if mc.empty:
                continue
            mc = mc.iloc[0]
            row[f"{p} thesis"] = t[p]
            row[f"{p} MC mean ± MCSE"] = f"{mc['mean']:.6e} ± {mc['mean_mcse']:.1e}"
            row[f"{p} diff %"] = 100 * (t[p] - mc["mean"]) / mc["mean"]
            row[f"{p} diff / EmpSE"] = (t[p] - mc["mean"]) / mc["emp_se"]
        rows.append(row)
    return pd.DataFrame(rows)


def figures(agg, out_dir):
    """Figures 4-6: the thesis bound against ς (as in the thesis) and the real spread."""
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    for k, p in enumerate(PARAMETERS, start=4):
        fig, ax = plt.subplots(figsize=(7, 4.5))
        for (est, sd), g in agg[agg.parameter == p].groupby(["estimator", "velocity_sd"]):
            label = f"{est}, σ_v = {sd:g} m/s"
            if g.thesis_bound_se.notna().any():
                ax.plot(g.terrain_ms_grid, g.thesis_bound_se, "x-", label=f"thesis bound ({label})")
            ax.errorbar(g.terrain_ms_grid, g.emp_se, yerr=g.emp_se_mcse, fmt="o",
                        capsize=3, label=f"EmpSE ± MCSE ({label})")
        ax.set_yscale("log")
        ax.set_xlabel("terrain variability ς [rad²]")
        ax.set_ylabel(f"{SYMBOL[p]} estimation error [{UNIT[p]}]")
        ax.set_title(f"Figure {k}: {SYMBOL[p]} error against ς")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
        fig.tight_layout()
        path = out_dir / f"figure{k}_{p}.png"
        fig.savefig(path, dpi=120)
        plt.close(fig)
        paths.append(path)
    return paths


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir", type=pathlib.Path, help="output directory of `chassis-mc run`")
    ap.add_argument("--out", type=pathlib.Path, help="where to write the figures (default RUN_DIR/analysis)")
    ap.add_argument("--csv", type=pathlib.Path, help="also write the aggregated numbers as CSV")
    args = ap.parse_args()
    agg = aggregate(args.run_dir)
    if args.csv:
        agg.to_csv(args.csv, index=False, float_format="%.17g")
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(agg.to_string(index=False, float_format=lambda v: f"{v:.6e}"))
        t3 = table3(agg)
        if not t3.empty:
            print("\nTable 3 of the thesis next to the Monte Carlo means (OLS, σ_v = 1 m/s):")
            print(t3.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    for path in figures(agg, args.out or args.run_dir / "analysis"):
        print(path)


if __name__ == "__main__":
    main()
