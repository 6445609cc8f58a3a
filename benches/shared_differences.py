#!/usr/bin/env python3
"""What `noise.share_across_scales` does to the Monte Carlo error of a difference between scales.

Runs the thesis study twice (R realisations, scales 1.0 and 2.0 only): with independent
draws per condition, and with the draws shared across scales. For each parameter it prints
the difference in EmpSE and in mean between scale 1.0 and scale 2.0, and the MCSE of each
difference, estimated by a paired bootstrap over realisations (realisation r of both scales
resampled together, which is what sharing pairs; 2000 resamples, fixed seed). The
per-scale MCSEs of the summary are marginal; only the paired estimate sees the covariance
that sharing creates (docs/model.md#shared-noise).

    cargo build --release
    .venv/bin/python benches/shared_differences.py [--realisations 2000]
"""

import argparse
import pathlib
import subprocess
import sys
import tempfile

import numpy as np
import pyarrow.parquet as pq

ROOT = pathlib.Path(__file__).resolve().parents[1]
BINARY = ROOT / "target" / "release" / "chassis-mc"
STUDY = ROOT / "studies" / "thesis.toml"
PARAMS = ["inv_mass", "drag_over_mass", "rolling_resistance"]


def run(text, out, realisations):
    study = pathlib.Path(out) / "study.toml"
    study.write_text(text)
    subprocess.run([BINARY, "run", study, "--out", pathlib.Path(out) / "run", "--quiet",
                    "--realisations", str(realisations)], check=True)
    table = pq.read_table(pathlib.Path(out) / "run" / "realisations.parquet").to_pandas()
    by_scale = {}
    for scale, rows in table.groupby("scale"):
        rows = rows.sort_values("realisation")
        by_scale[round(scale, 6)] = np.column_stack([rows[f"theta_{p}"] for p in PARAMS])
    return by_scale[1.0], by_scale[2.0]


def paired_bootstrap(a, b, statistic, resamples=2000, seed=1):
    rng = np.random.default_rng(seed)
    n = a.shape[0]
    values = np.empty((resamples, a.shape[1]))
    for k in range(resamples):
        idx = rng.integers(0, n, n)
        values[k] = statistic(a[idx]) - statistic(b[idx])
    return values.std(axis=0, ddof=1)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--realisations", type=int, default=2000)
    args = ap.parse_args()
    if not BINARY.exists():
        sys.exit(f"{BINARY} not found: run `cargo build --release` first")
    base = "\n".join("scales = [1.0, 2.0]" if line.startswith("scales =") else line
                     for line in STUDY.read_text().splitlines())
    shared = base.replace("[noise]", "[noise]\nshare_across_scales = true", 1)
    emp_se = lambda x: x.std(axis=0, ddof=1)  # noqa: E731
    mean = lambda x: x.mean(axis=0)  # noqa: E731
    results = {}
    for label, text in (("independent", base), ("shared", shared)):
        with tempfile.TemporaryDirectory() as out:
            a, b = run(text, out, args.realisations)
        corr = [np.corrcoef(a[:, p], b[:, p])[0, 1] for p in range(3)]
        results[label] = (emp_se(a) - emp_se(b), paired_bootstrap(a, b, emp_se),
                          mean(a) - mean(b), paired_bootstrap(a, b, mean), corr)
    print(f"R = {args.realisations}: scale 1.0 minus scale 2.0, MCSE by paired bootstrap\n")
    print(f"{'parameter':>18} {'draws':>12} {'corr(1.0, 2.0)':>14} {'ΔEmpSE':>12} "
          f"{'MCSE':>10} {'Δmean':>12} {'MCSE':>10}")
    for p, name in enumerate(PARAMS):
        for label in ("independent", "shared"):
            d_se, m_se, d_mean, m_mean, corr = results[label]
            print(f"{name:>18} {label:>12} {corr[p]:14.3f} {d_se[p]:12.4e} {m_se[p]:10.2e} "
                  f"{d_mean[p]:12.4e} {m_mean[p]:10.2e}")
        ratio_se = results["independent"][1][p] / results["shared"][1][p]
        ratio_mean = results["independent"][3][p] / results["shared"][3][p]
        print(f"{'':>18} {'ratio':>12} {'':>14} {'':>12} {ratio_se:9.1f}x {'':>12} {ratio_mean:9.1f}x")


if __name__ == "__main__":
    main()
