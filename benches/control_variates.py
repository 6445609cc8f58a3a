#!/usr/bin/env python3
"""What the control variates buy: the plain bias and the control-variate bias, with MCSEs.

Runs the thesis study (`studies/thesis.toml`) at σ_v = 1 m/s with OLS and BCLS, R
realisations per scale, and prints per estimator and parameter the plain `bias` ± MCSE, the
control-variate `bias_cv` ± MCSE (docs/model.md#control-variates), the MCSE ratio, and the
realisations saved for an equal MCSE of the bias: plain R × ratio² would be needed without
control variates. Ranges are over the 11 terrain scales.

    cargo build --release
    .venv/bin/python benches/control_variates.py [--realisations 1000]
"""

import argparse
import pathlib
import subprocess
import tempfile

import pyarrow.parquet as pq

ROOT = pathlib.Path(__file__).resolve().parents[1]
BINARY = ROOT / "target" / "release" / "chassis-mc"
STUDY = ROOT / "studies" / "thesis.toml"
PARAMS = ["inv_mass", "drag_over_mass", "rolling_resistance"]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--realisations", type=int, default=1000)
    args = parser.parse_args()
    text = STUDY.read_text().replace('estimators = ["ols"]', 'estimators = ["ols", "bcls"]')
    assert 'estimators = ["ols", "bcls"]' in text and "velocity_sd = [1.0]" in text
    with tempfile.TemporaryDirectory() as out:
        study = pathlib.Path(out) / "study.toml"
        study.write_text(text)
        subprocess.run([BINARY, "run", study, "--out", pathlib.Path(out) / "run", "--quiet",
                        "--realisations", str(args.realisations)], check=True)
        s = pq.read_table(pathlib.Path(out) / "run" / "summary.parquet").to_pandas()
    r = args.realisations
    print(f"thesis cycle, σ_v = 1 m/s, R = {r} per scale, 11 scales; ranges over the scales\n")
    print(f"{'estimator':>9} {'parameter':>18} {'scale':>5} {'bias ± MCSE':>24} "
          f"{'bias_cv ± MCSE':>24} {'MCSE ratio':>10} {'R for equal MCSE':>17}")
    for est in ["ols", "bcls"]:
        for p in PARAMS:
            rows = s[(s.estimator == est) & (s.parameter == p)].sort_values("scale")
            for _, row in rows[rows.scale.isin([1.0, 2.0])].iterrows():
                ratio = row.bias_mcse / row.bias_cv_mcse
                print(f"{est:>9} {p:>18} {row.scale:>5.1f} "
                      f"{row.bias:>+12.4e} ± {row.bias_mcse:.2e} "
                      f"{row.bias_cv:>+12.4e} ± {row.bias_cv_mcse:.2e} "
                      f"{ratio:>10.0f} {r * ratio**2:>17.3g}")
            ratios = rows.bias_mcse / rows.bias_cv_mcse
            print(f"{est:>9} {p:>18} {'all':>5} MCSE ratio {ratios.min():.0f}–{ratios.max():.0f}"
                  f" over the 11 scales: R × ratio² = {r * ratios.min()**2:.3g}–"
                  f"{r * ratios.max()**2:.3g} realisations for the same MCSE without them")


if __name__ == "__main__":
    main()
