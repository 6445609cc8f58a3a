#!/usr/bin/env python3
"""What the spread's control variates buy: the MCSE of EmpSE, plain and by control variates.

Runs the thesis study (`studies/thesis.toml`, σ_v = 1 m/s, OLS and BCLS) and the sensors
study (`studies/sensors.toml`: white and AR(1) speed noise, the model's and a differentiated
acceleration; OLS, BCLS, WBCLS, RLS) at R realisations per condition, and prints per
estimator and parameter the ratio `emp_se_mcse / emp_se_cv_mcse` (how many times smaller the
control-variate MCSE is; R × ratio² realisations would give the same MCSE without them) and
the EmpSE / bound ratios of `eiv_sandwich` and `eiv_crlb_linearized` by control variates,
each as a range over the terrain scales (docs/model.md#spread-control-variates).

    cargo build --release
    .venv/bin/python benches/spread_control_variates.py [--realisations 200]
"""

import argparse
import pathlib
import subprocess
import tempfile

import pyarrow.parquet as pq

ROOT = pathlib.Path(__file__).resolve().parents[1]
BINARY = ROOT / "target" / "release" / "chassis-mc"
PARAMS = ["inv_mass", "drag_over_mass", "rolling_resistance"]
BOUNDS = ["eiv_sandwich", "eiv_crlb_linearized"]


def run(text, out, realisations):
    study = pathlib.Path(out) / "study.toml"
    study.write_text(text)
    subprocess.run([BINARY, "run", study, "--out", pathlib.Path(out) / "run", "--quiet",
                    "--no-figures", "--realisations", str(realisations)], check=True)
    return pq.read_table(pathlib.Path(out) / "run" / "summary.parquet").to_pandas()


def span(values, fmt):
    values = list(values)
    if not values:
        return "—"
    lo, hi = min(values), max(values)
    return fmt.format(lo) if fmt.format(lo) == fmt.format(hi) else f"{fmt.format(lo)}–{fmt.format(hi)}"


def report(s, group):
    print(f"{'':>28} {'estimator':>9} {'parameter':>18} {'MCSE ratio':>11} "
          + " ".join(f"{'EmpSE/' + b + ' (cv)':>34}" for b in BOUNDS))
    for key, g in s.groupby(group, sort=True):
        label = ", ".join(f"{k} {v}" for k, v in zip(group, key if isinstance(key, tuple) else (key,)))
        for est in g.estimator.unique():
            for p in PARAMS:
                rows = g[(g.estimator == est) & (g.parameter == p)]
                ok = rows[rows.emp_se_cv_mcse.notna()]
                ratio = span(ok.emp_se_mcse / ok.emp_se_cv_mcse, "{:.0f}") if len(ok) else "null"
                cells = []
                for b in BOUNDS:
                    col = f"emp_over_{b}_cv"
                    if col not in ok or ok[col].isna().all():
                        cells.append(f"{'—':>34}")
                        continue
                    v = ok[ok[col].notna()]
                    cells.append(f"{span(v[col], '{:.4f}'):>17} (± ≤ {v[col + '_mcse'].max():.1e})")
                print(f"{label:>28} {est:>9} {p:>18} {ratio:>11} " + " ".join(cells))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--realisations", type=int, default=200)
    args = parser.parse_args()
    r = args.realisations
    thesis = (ROOT / "studies" / "thesis.toml").read_text().replace(
        'estimators = ["ols"]', 'estimators = ["ols", "bcls"]')
    assert 'estimators = ["ols", "bcls"]' in thesis
    sensors = (ROOT / "studies" / "sensors.toml").read_text()
    with tempfile.TemporaryDirectory() as a, tempfile.TemporaryDirectory() as b:
        s = run(thesis, a, r)
        print(f"thesis study, σ_v = 1 m/s, R = {r} per scale; ranges over the 11 scales\n")
        report(s, ["velocity_sd"])
        s = run(sensors, b, r)
        print(f"\nsensors study, σ_v = 1 m/s, R = {r} per condition; ranges over the 11 scales "
              "(null: not covered)\n")
        report(s, ["velocity_correlation_time", "acceleration"])


if __name__ == "__main__":
    main()
