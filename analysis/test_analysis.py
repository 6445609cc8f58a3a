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
on which they are ever read. ς over the cycle is recomputed by DuckDB from the grades in
cycles.parquet (a compensated sum of 60 001 squares).

identification.py recomputes each condition's VIFs, correlations and condition number from
cycles.parquet with NumPy (1e-9 relative; see there), and designed_drive.py a designed drive's
criterion and limits (studies/designed_drive.toml at R = 20). Then runs gusts_check.py and
coastdown_check.py: the engine's Monte Carlo under random gusts,
and its road_load analysis of a coast-down under speed noise, each against an independent
NumPy one (means and SDs within 4 MCSEs; see those scripts); and campaign_check.py: a
coast-down campaign's pass probability against an independent NumPy Monte Carlo of the
coast-down, its gusts and the EU criterion (within 3 combined MCSEs).

First of all, every Python script in analysis/, benches/ and tools/ must answer `--help`
with its usage and exit 0 at once, without running anything (check_help).

    cargo build --release && python analysis/test_analysis.py
"""

import argparse
import os
import pathlib
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time

import pandas as pd
import pyarrow.parquet as pq

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parent
# Where cargo put the binary: $CARGO_TARGET_DIR when set (relative to the repository, as
# cargo reads it), else target/.
BINARY = ROOT / os.environ.get("CARGO_TARGET_DIR", "target") / "release" / "chassis-mc"
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


def run_scripts(run, tmp, engine, label):
    """Run both scripts on the output directory `run`; compare with the engine's summary."""
    scripts = {
        "thesis_figures": (["mean", "emp_se", "thesis_bound_se", "terrain_ms_cycle",
                            "mean_mcse", "emp_se_mcse"], None),
        "bias_report": (["bias", "bias_mcse", "emp_se", "emp_over_thesis_bound",
                         "emp_over_crlb_output", "emp_over_eiv_sandwich",
                         "emp_over_eiv_crlb_linearized"], {"bias": "bias_mcse"}),
    }
    print(label)
    for script, (columns, relative_to) in scripts.items():
        csv = tmp / f"{label}-{script}.csv"
        subprocess.run([sys.executable, HERE / f"{script}.py", run, "--csv", csv],
                       check=True, stdout=subprocess.DEVNULL)
        numbers = pd.read_csv(csv)
        compare(script, engine, numbers, columns, relative_to)


def refuses(run, what):
    """Each script must refuse `run` (exit 2, a message naming the problem)."""
    for script in ["thesis_figures", "bias_report"]:
        done = subprocess.run([sys.executable, HERE / f"{script}.py", run],
                              capture_output=True, text=True)
        assert done.returncode == 2, f"{script} read {what}: exit {done.returncode}"
        assert what in done.stderr, f"{script}: {done.stderr!r} does not say {what!r}"
    print(f"  both scripts refuse a directory with {what}")


# Python files of analysis/, benches/ and tools/ that are modules other scripts import, not
# scripts; every other one is a script and must answer --help.
MODULES = {"analysis/common.py"}
# Seconds a script may take to answer --help: its imports (pandas, matplotlib, DuckDB) take
# a second or two on a loaded 2-core machine; a script that starts a run takes minutes.
HELP_SECONDS = 60


def files_under(directory):
    """(path, size, mtime) of every file under `directory`: what a script wrote there."""
    return {(str(p), p.stat().st_size, p.stat().st_mtime_ns)
            for p in pathlib.Path(directory).rglob("*") if p.is_file()}


def check_help():
    """Every script in analysis/, benches/ and tools/ answers --help with a usage line and
    exit status 0 within HELP_SECONDS, writing nothing (in the repository's studies/ and
    script folders, nor in the directory it is run from)."""
    scripts = []
    for folder in ["analysis", "benches", "tools"]:
        for path in sorted((ROOT / folder).glob("*.py")):
            name = f"{folder}/{path.name}"
            text = path.read_text()
            is_script = re.search(r"^if __name__ == .__main__.:", text, re.M) is not None
            if name in MODULES:
                assert not is_script, f"{name} is listed as a module but runs as a script"
            else:
                assert is_script, f"{name}: a script without `if __name__ == \"__main__\":`"
                scripts.append((name, path))
    watched = [ROOT / "studies", ROOT / "analysis", ROOT / "benches", ROOT / "tools"]
    failures = []
    with tempfile.TemporaryDirectory() as cwd:
        for name, path in scripts:
            before = set().union(*(files_under(d) for d in watched))
            started = time.monotonic()
            # its own session, so that a script that starts a run is stopped with its children
            child = subprocess.Popen([sys.executable, str(path), "--help"], cwd=cwd,
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                     start_new_session=True)
            try:
                out, err = child.communicate(timeout=HELP_SECONDS)
            except subprocess.TimeoutExpired:
                os.killpg(child.pid, signal.SIGKILL)
                child.communicate()
                failures.append(f"{name}: no answer to --help in {HELP_SECONDS} s")
                continue
            seconds = time.monotonic() - started
            failed = len(failures)
            if child.returncode != 0:
                failures.append(f"{name}: exit {child.returncode} on --help: {err.strip()[-300:]}")
            elif not re.search(rf"^usage: {re.escape(path.name)}", out, re.M):
                failures.append(f"{name}: no usage line on --help: {out.strip()[:200]!r}")
            wrote = set().union(*(files_under(d) for d in watched)) ^ before
            if wrote or any(pathlib.Path(cwd).iterdir()):
                failures.append(f"{name}: --help wrote files: "
                                f"{sorted({w[0] for w in wrote} | set(os.listdir(cwd)))}")
                shutil.rmtree(cwd)
                os.mkdir(cwd)
            if len(failures) == failed:
                print(f"  {name} --help: usage in {seconds:.1f} s")
    assert not failures, "scripts that do not answer --help:\n  " + "\n  ".join(failures)
    print(f"all {len(scripts)} scripts answer --help with their usage, writing nothing")


def main():
    argparse.ArgumentParser(description=__doc__.split("\n\n")[0]).parse_args()
    check_help()
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
        run_scripts(run, tmp, engine, "unsharded")
        figures = list((run / "analysis").glob("figure*_*.png"))
        assert len(figures) == 3, f"thesis_figures drew {len(figures)} figures, expected 3"
        # VIFs, correlations and condition numbers from cycles.parquet by NumPy (1e-9).
        subprocess.run([sys.executable, HERE / "identification.py", run, "--check"], check=True)
        # A designed drive: its limits on every sample and its criterion by NumPy (1e-9).
        designed = tmp / "designed"
        subprocess.run([BINARY, "run", ROOT / "studies" / "designed_drive.toml", "--out", designed,
                        "--realisations", "20", "--quiet", "--no-figures"], check=True)
        subprocess.run([sys.executable, HERE / "designed_drive.py", designed, "--check"], check=True)

        # The same study in 3 shards, then summarized: no realisations.parquet at the top.
        sharded = tmp / "sharded"
        for k in range(3):
            subprocess.run([BINARY, "run", study, "--out", sharded, "--realisations", "100",
                            "--quiet", "--shard", f"{k}/3"], check=True)
        subprocess.run([BINARY, "summarize", sharded, "--quiet", "--no-figures"], check=True)
        assert not (sharded / "realisations.parquet").exists()
        run_scripts(sharded, tmp, engine, "sharded, then summarized")

        # A mixed set (another seed's summary) and an interrupted commit are refused.
        other = tmp / "other"
        subprocess.run([BINARY, "run", study, "--out", other, "--realisations", "100",
                        "--seed", "7", "--quiet", "--no-figures"], check=True)
        mixed = tmp / "mixed"
        shutil.copytree(run, mixed)
        shutil.copy(other / "summary.parquet", mixed / "summary.parquet")
        refuses(mixed, "different runs")
        (run / ".chassis-mc-journal").write_text("chassis-mc journal 1\n")
        refuses(run, "incomplete output")
    print("analysis scripts agree with the engine's summary within 1e-12 relative")
    subprocess.run([sys.executable, HERE / "gusts_check.py"], check=True)
    subprocess.run([sys.executable, HERE / "coastdown_check.py"], check=True)
    # A coast-down campaign's pass probability against an independent NumPy Monte Carlo
    # (studies/coastdown_campaign.toml at its R = 400; NumPy R = 2000; 3 combined MCSE).
    with tempfile.TemporaryDirectory() as tmp:
        campaign = pathlib.Path(tmp) / "campaign"
        subprocess.run([BINARY, "run", ROOT / "studies" / "coastdown_campaign.toml", "--out",
                        campaign, "--quiet", "--no-figures"], check=True)
        subprocess.run([sys.executable, HERE / "campaign_check.py", campaign], check=True)


if __name__ == "__main__":
    main()
