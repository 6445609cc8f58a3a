#!/usr/bin/env python3
"""Why a cycle identifies θ, recomputed with NumPy from a run's cycles.parquet: per condition,
the information J = XᵀX of the regression's noise-free rows (X = [F, −kV², −g cos θ] over the
fitted parameters), each parameter's uncentred variance inflation factor
VIF_j = J_jj (J⁻¹)_jj, the regressors' uncentred correlations J_ij/√(J_ii J_jj), and the
condition number of J scaled to unit diagonal (docs/model.md#identification). Prints them
beside the engine's summary.parquet columns and the largest relative difference.

The rows of a condition are cycles.parquet's block of its scale, acceleration source and
truth axes, those marked `used`, within its `duration` from the first sample; the grade in
−g cos θ is the block's plus the condition's `grade_bias`, and 1 with `estimation.grade =
"none"` (k and g scale a column, which none of these quantities sees). Conditions of a
coast-down's runs or with a measured air speed are not handled (the script says so).

    python analysis/identification.py RUN_DIR [--check]

With --check the exit status is 1 when any quantity differs from the engine's by more than
1e-9 relative (both sides sum the same products; J's condition number ~1e3 amplifies their
~1e-16 rounding to ~1e-13).
"""

import argparse
import sys

import numpy as np
import pyarrow.parquet as pq

from common import PARAMETERS, check_output_set, study_of

TOLERANCE = 1e-9


def metrics(j):
    """VIFs, correlations (pairs i < j, row-major) and the scaled condition number of J."""
    d = np.sqrt(np.diag(j))
    s = j / np.outer(d, d)
    vif = np.diag(j) * np.diag(np.linalg.inv(j))
    p = len(j)
    corr = [s[a, b] for a in range(p) for b in range(a + 1, p)]
    eig = np.linalg.eigvalsh(s)
    return list(vif) + corr + [eig[-1] / eig[0]]


def names(free):
    pars = [PARAMETERS[i] for i in free]
    pairs = [f"corr_{pars[a]}_{pars[b]}" for a in range(len(pars)) for b in range(a + 1, len(pars))]
    return [f"vif_{p}" for p in pars] + pairs + ["condition_number"]


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("run_dir")
    parser.add_argument("--check", action="store_true", help="exit 1 beyond 1e-9 relative")
    args = parser.parse_args()
    check_output_set(args.run_dir)
    study = study_of(args.run_dir)
    estimation = study.get("estimation", {})
    if study.get("drive", {}).get("mode") == "coastdown" or estimation.get("air_speed") == "measured":
        sys.exit("identification.py: a coast-down's runs and a measured air speed are not handled")
    free = [1, 2] if estimation.get("known_mass", False) else [0, 1, 2]
    no_grade = estimation.get("grade", "measured") == "none"
    cycles = pq.read_table(f"{args.run_dir}/cycles.parquet").to_pandas()
    summary = pq.read_table(f"{args.run_dir}/summary.parquet").to_pandas()
    keys = [c for c in cycles.columns if c in summary.columns]
    columns = names(free)
    worst = 0.0
    print("condition  " + "  ".join(f"{c:>24}" for c in columns))
    for _, row in summary.drop_duplicates("condition").iterrows():
        block = cycles
        for k in keys:
            block = block[block[k] == row[k]]
        block = block[block["used"]]
        if "duration" in summary.columns:
            block = block[block["t"] - cycles.loc[block.index[0], "t"] <= row["duration"]] if len(block) else block
        grade = block["grade"].to_numpy() + (row["grade_bias"] if "grade_bias" in summary.columns else 0.0)
        v = block["v"].to_numpy()
        x = np.column_stack([block["f_prop"].to_numpy(), -v * v, -(np.ones_like(grade) if no_grade else np.cos(grade))])
        x = x[:, free]
        mine = metrics(x.T @ x)
        engine = [row[c] for c in columns]
        rel = max(abs(a / b - 1.0) for a, b in zip(mine, engine))
        worst = max(worst, rel)
        print(f"{int(row['condition']):>9}  " + "  ".join(f"{a:>24.12g}" for a in mine))
    print(f"largest relative difference from summary.parquet: {worst:.2e}")
    if args.check and not worst <= TOLERANCE:
        sys.exit(1)


if __name__ == "__main__":
    main()
