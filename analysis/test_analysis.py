#!/usr/bin/env python3
"""The analysis path and the engine must not disagree.

Runs a small study with the release binary (3 scales × 2 speed-noise levels, OLS and BCLS,
R = 100), runs each analysis script against its output, and checks that every number the
scripts compute from realisations.parquet (DuckDB) or from the study (NumPy) equals the
engine's summary.parquet within 1e-12 relative.

Why 1e-12 can hold: both sides sum the same ≤ 100 centred terms; the engine's sums are
exactly rounded and DuckDB's fsum is Kahan-compensated, so each differs from the exact sum by
at most ~2 ulp of Σ|terms|. Relative to the result that is ~1e-16 · Σ|x|/|Σx|, ≤ 1e-13 for
every quantity here except a bias that happens to lie within ~1e-3 MCSE of zero, where
Σ|d|/|Σd| is huge. Biases are therefore compared relative to max(|bias|, MCSE), the scale
on which they are ever read. ς is recomputed by NumPy from the cos² profile (pairwise sum of
50 000 squares, error ~1e-16 · log n).

    cargo build --release && python analysis/test_analysis.py
"""

import pathlib
import subprocess
import sys
import tempfile

import pandas as pd
import pyarrow.parquet as pq

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parent
BINARY = ROOT / "target" / "release" / "chassis-mc"
TOL = 1e-12


def small_study(path):
    text = (ROOT / "studies" / "bias_compensation.toml").read_text()
    lines = []
    for line in text.splitlines():
        if line.startswith("scales ="):
            line = "scales = [1.0, 1.5, 2.0]"
        elif line.startswith("velocity_sd ="):
            line = "velocity_sd = [0.5, 1.0]"
        lines.append(line)
    path.write_text("\n".join(lines) + "\n")


def compare(name, engine, script, columns, relative_to=None):
    """Max relative difference per column; fails the test beyond TOL."""
    key = ["condition", "estimator", "parameter"]
    merged = engine.merge(script, on=key, suffixes=("_engine", "_script"), validate="one_to_one")
    assert len(merged) == len(engine), f"{name}: {len(merged)} of {len(engine)} rows matched"
    worst = 0.0
    for col in columns:
        a, b = merged[f"{col}_engine"], merged[f"{col}_script"]
        both_null = a.isna() & b.isna()
        assert (a.isna() == b.isna()).all(), f"{name}: {col} null in one side only"
        scale = a.abs()
        if relative_to and col in relative_to:
            scale = pd.concat([scale, merged[f"{relative_to[col]}_engine"].abs()], axis=1).max(axis=1)
        rel = ((a - b).abs() / scale)[~both_null]
        m = float(rel.max()) if len(rel) else 0.0
        worst = max(worst, m)
        print(f"  {name:>15} {col:>32}: max relative difference {m:.2e}")
        assert m <= TOL, f"{name}: {col} differs by {m:.3e} relative (> {TOL})"
    return worst


def main():
    if not BINARY.exists():
        sys.exit(f"{BINARY} not found: run `cargo build --release` first")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        study = tmp / "study.toml"
        small_study(study)
        run = tmp / "run"
        subprocess.run([BINARY, "run", study, "--out", run, "--realisations", "100", "--quiet",
                        "--no-figures"], check=True)
        engine = pq.read_table(run / "summary.parquet").to_pandas()

        scripts = {
            "thesis_figures": (["mean", "emp_se", "thesis_bound_se", "terrain_ms_grid",
                                "mean_mcse", "emp_se_mcse"], None),
            "bias_report": (["bias", "bias_mcse", "emp_se", "emp_over_thesis_bound",
                             "emp_over_crlb_output", "emp_over_eiv_sandwich",
                             "emp_over_eiv_crlb_linearized"], {"bias": "bias_mcse"}),
        }
        for script, (columns, relative_to) in scripts.items():
            csv = tmp / f"{script}.csv"
            subprocess.run([sys.executable, HERE / f"{script}.py", run, "--csv", csv],
                           check=True, stdout=subprocess.DEVNULL)
            numbers = pd.read_csv(csv)
            compare(script, engine, numbers, columns, relative_to)
        figures = list((run / "analysis").glob("figure*_*.png"))
        assert len(figures) == 3, f"thesis_figures drew {len(figures)} figures, expected 3"
    print("analysis scripts agree with the engine's summary within 1e-12 relative")


if __name__ == "__main__":
    main()
