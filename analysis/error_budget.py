#!/usr/bin/env python3
"""The error budget of a run of studies/model_errors.toml: per estimator and parameter, what
each model error at its stated magnitude does to the estimate, against the spread.

The study is a factorial of [off, on] per `[truth]` axis and the map's error, with the mass
drift (`truth.mass_rate`, one value) on in every condition. For each error it reads the
condition where that error alone is on, and prints the shift of the estimate against the
baseline condition (every axis off; the mass drift alone):

- a steady error: the difference of `bias_model` (exact: the estimate on the noise-free
  rows, no Monte Carlo error);
- an error drawn per realisation (gusts, the random calibration, the map): the difference
  of the Monte Carlo `bias` (the two conditions draw independently, so its MCSE is the root
  sum of squares), and the EmpSE with it against the baseline's.

Each shift is given in % of the truth and in units of the baseline's EmpSE, beside the
baseline's EmpSE and its smallest bound (the sharpest reported bound's SE). "all" is every
error on together.

    .venv/bin/python analysis/error_budget.py results/model_errors
"""

import argparse
import pathlib

import pandas as pd

# The axes of the factorial, with the value that means "off".
OFF = {
    "wind_speed": 0.0,
    "wind_gust_sd": 0.0,
    "rotating_mass_factor": 0.0,
    "force_scale": 0.0,
    "force_scale_sd": 0.0,
    "rolling_speed_coefficient": 0.0,
    "air_density_ratio": 1.0,
    "grade_map_sd": 0.0,
}
DRAWN = {"wind_gust_sd", "force_scale_sd", "grade_map_sd"}
BOUNDS = ["crlb_output", "eiv_sandwich", "eiv_crlb_linearized"]
NAMES = {"inv_mass": "1/M", "drag_over_mass": "Cd/M", "rolling_resistance": "Cr"}


def condition(summary, on):
    """The rows of the condition where exactly the axes in `on` are on."""
    mask = pd.Series(True, index=summary.index)
    for axis, off in OFF.items():
        mask &= (summary[axis] != off) if axis in on else (summary[axis] == off)
    rows = summary[mask]
    assert rows["condition"].nunique() == 1, f"{on}: {rows['condition'].unique()}"
    return rows.set_index(["estimator", "parameter"])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("run_dir", type=pathlib.Path,
                    help="output directory of a run of studies/model_errors.toml")
    summary = pd.read_parquet(ap.parse_args().run_dir / "summary.parquet")
    base = condition(summary, set())
    entries = [(axis, {axis}) for axis in OFF] + [("all", set(OFF))]
    for estimator in summary["estimator"].unique():
        print(f"\n{estimator}: shift of the estimate, % of the truth "
              "(× the baseline's EmpSE)")
        header = f"{'error':28}" + "".join(f"{NAMES[p]:>24}" for p in NAMES)
        print(header)
        row = f"{'baseline EmpSE, % of truth':28}"
        for p in NAMES:
            b = base.loc[(estimator, p)]
            row += f"{100 * b['emp_se'] / b['truth']:>23.3f} "
        print(row)
        row = f"{'smallest bound, % of truth':28}"
        for p in NAMES:
            b = base.loc[(estimator, p)]
            ses = [b[f"{k}_se"] for k in BOUNDS if pd.notna(b[f"{k}_se"])]
            row += f"{100 * min(ses) / b['truth']:>23.3f} " if ses else f"{'-':>23} "
        print(row)
        row = f"{'mass drift (every condition)':28}"
        for p in NAMES:
            b = base.loc[(estimator, p)]
            row += f"{100 * b['bias_model'] / b['truth']:>+14.3f} ({b['bias_model'] / b['emp_se']:>+6.1f})"
        print(row)
        for name, on in entries:
            c = condition(summary, on)
            drawn = bool(on & DRAWN)
            row = f"{name + (' *' if drawn else ''):28}"
            for p in NAMES:
                b, x = base.loc[(estimator, p)], c.loc[(estimator, p)]
                if drawn:
                    shift = x["bias"] - b["bias"]
                    mcse = (x["bias_mcse"] ** 2 + b["bias_mcse"] ** 2) ** 0.5
                    cell = f"{100 * shift / b['truth']:+.3f}±{100 * mcse / b['truth']:.3f}"
                else:
                    shift = x["bias_model"] - b["bias_model"]
                    cell = f"{100 * shift / b['truth']:+.3f}"
                row += f"{cell:>14} ({shift / b['emp_se']:>+6.1f})"
            print(row)
        print("* drawn per realisation: a Monte Carlo shift ± its MCSE; EmpSE with it, "
              "× the baseline's:", end="")
        for name in sorted(DRAWN):
            c = condition(summary, {name})
            ratios = [c.loc[(estimator, p)]["emp_se"] / base.loc[(estimator, p)]["emp_se"]
                      for p in NAMES]
            print(f" {name} " + "/".join(f"{r:.2f}" for r in ratios), end=";")
        print()


if __name__ == "__main__":
    main()
