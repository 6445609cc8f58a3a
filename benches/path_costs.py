#!/usr/bin/env python3
"""The cost of each sensor path per realisation and per sample, on one thread, measured in
one run (README "Performance").

For each path a one-condition study is run with `--threads 1` at R = 20 and R = `--large`
(default 1020; best of `--repeat` wall times each); the marginal cost per realisation is
(T(large) − T(20)) / (large − 20), which leaves out the study's preparation (simulating the cycle,
the bounds, the covariances of the control variates), and per sample that over the rows
regressed. The "× thesis" column is the per-sample cost over the thesis path's, measured
again just before each path with the same binary: ratios of timings taken moments apart are
what a shared, noisy machine can compare.

Paths: the thesis cycle (scale 1, 600 s at 100 Hz, σ_v = 1 m/s) with OLS, then OLS with
BCLS, WBCLS, RLS added; AR(1) speed noise (τ = 1 s); a differentiated acceleration; both;
grade noise σ_θ = 0.001 rad; and the heavy-duty truck (studies/heavy_duty.toml, its first
hour) with OLS, with grade noise, and with a differentiated acceleration, grade noise and
OLS + BCLS + WBCLS; the truck's 23-hour log at 1 Hz with gaps, replayed
(tools/make_truck_log.py writes it on first use) with OLS, with grade noise, and with a
differentiated acceleration, grade noise and OLS + BCLS + WBCLS; the thesis cycle with a
model error drawn in every realisation (gusts, a random force calibration, an elevation
map's error); and the filters without a grade sensor, `ekf` and `rls_mf` alone on the
thesis cycle (their bound along the path is made once per condition there, outside the
marginal cost: examples/filter_costs.rs times it).

    cargo build --release && .venv/bin/python benches/path_costs.py [--repeat 3] [--large 1020]
        [--rounds N] [--before OTHER/target/release/chassis-mc] [--only REGEX]

With `--rounds N` (default 1) the whole table is measured N times over (each path again
beside the thesis path in each round) and each cell is the median of its N values, with the
range of the ratio: one round's ratio moves by ±20 % on the shared machine. Each cell's
median is taken on its own, so two cells of a row may come from different rounds.

With `--in-process` the costs come instead from `examples/path_ratio.rs` (built by
`cargo build --release --example path_ratio`), which computes realisations of the thesis
path and of each path alternately in one process, best of eight rounds each: no process
start, preparation or output in the timings, and the two timings moments apart (with
`--rounds`, that run again per round).
"""

import argparse
import pathlib
import re
import shutil
import statistics
import sys
import subprocess
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
BINARY = ROOT / "target" / "release" / "chassis-mc"
SMALL = 20


def variant(base, edits, estimators='["ols"]', extra_noise="", estimation_extra=""):
    """studies/`base` with each `key = value` line of `edits` set, the estimators given, and
    extra lines after `velocity_sd` (more noise) and after `estimators` (estimation keys)."""
    text = (ROOT / "studies" / base).read_text()
    edits = {**edits, "estimators": estimators}
    tails = {"velocity_sd": extra_noise, "estimators": estimation_extra}
    for key, value in edits.items():
        text = re.sub(rf"^{key} = .*$", f"{key} = {value}" + tails.get(key, ""), text,
                      count=1, flags=re.M)
    return text


def thesis(**options):
    """The thesis cycle at scale 1 with σ_v = 1 m/s."""
    return variant("bias_compensation.toml", {"scales": "[1.0]", "velocity_sd": "[1.0]"},
                   **options)


def truck(**options):
    """studies/heavy_duty.toml's first hour with σ_v = 0.1 m/s."""
    return variant("heavy_duty.toml", {"durations": "[3600.0]", "velocity_sd": "[0.1]"},
                   **options)


TRUCK_LOG = ROOT / "benches" / "data" / "truck_23h_1hz.csv"


def truck_log(extra_noise="", estimators='["ols"]', estimation_extra=""):
    """The truck of studies/heavy_duty.toml replayed from its 23-hour log at 1 Hz with gaps
    (tools/make_truck_log.py, benches/data/truck_23h_1hz.csv), σ_v = 0.1 m/s."""
    text = (ROOT / "studies" / "heavy_duty.toml").read_text()
    vehicle = text[text.index("[vehicle]"):text.index("[drive]")]
    return (f'name = "truck_log"\nseed = 2018\nrealisations = 1000\n\n{vehicle}'
            f'[drive]\nmode = "replay"\nfile = "{TRUCK_LOG}"\nused_column = "used"\n\n'
            f'[noise]\nvelocity_sd = [0.1]\noutput_sd = [0.0]{extra_noise}\n\n'
            f'[estimation]\nestimators = {estimators}{estimation_extra}\n')


PATHS = [
    ("thesis cycle, OLS", thesis()),
    ("+ BCLS", thesis(estimators='["ols", "bcls"]')),
    ("+ WBCLS", thesis(estimators='["ols", "bcls", "wbcls"]')),
    ("+ RLS", thesis(estimators='["ols", "bcls", "wbcls", "rls"]')),
    ("AR(1) speed noise (τ = 1 s)", thesis(extra_noise="\nvelocity_correlation_time = [1.0]")),
    ("differentiated acceleration", thesis(estimation_extra='\nacceleration = "differentiated"')),
    ("AR(1) + differentiated", thesis(extra_noise="\nvelocity_correlation_time = [1.0]",
                                      estimation_extra='\nacceleration = "differentiated"')),
    ("grade noise σ_θ = 0.001", thesis(extra_noise="\ngrade_sd = [0.001]")),
    ("truck, 1 h, OLS", truck()),
    ("… with grade noise", truck(extra_noise="\ngrade_sd = [0.001]")),
    ("… differentiated + grade noise, OLS + BCLS + WBCLS",
     truck(estimators='["ols", "bcls", "wbcls"]', extra_noise="\ngrade_sd = [0.001]",
           estimation_extra='\nacceleration = "differentiated"')),
    ("truck log, 23 h at 1 Hz with gaps, OLS", truck_log()),
    ("… with grade noise", truck_log(extra_noise="\ngrade_sd = [0.001]")),
    ("… differentiated + grade noise, OLS + BCLS + WBCLS",
     truck_log(extra_noise="\ngrade_sd = [0.001]", estimators='["ols", "bcls", "wbcls"]',
               estimation_extra='\nacceleration = "differentiated"')),
    ("drawn: gusts σ_w = 2 m/s", thesis() + "\n[truth]\nwind_gust_sd = [2.0]\n"),
    ("drawn: random force calibration 1 %", thesis() + "\n[truth]\nforce_scale_sd = [0.01]\n"),
    ("drawn: elevation-map error σ_h = 0.1 m", thesis(extra_noise="\ngrade_map_sd = [0.1]")),
    ("no grade sensor: ekf", thesis(estimators='["ekf"]', estimation_extra='\ngrade = "none"')),
    ("no grade sensor: rls_mf", thesis(estimators='["rls_mf"]',
                                       estimation_extra='\ngrade = "none"')),
]


def wall(binary, study, realisations, out, repeat):
    """The best wall time of `repeat` fresh runs (a run into a filled directory would resume)."""
    best = float("inf")
    for _ in range(repeat):
        shutil.rmtree(out, ignore_errors=True)
        start = time.perf_counter()
        subprocess.run([str(binary), "run", str(study), "--out", str(out), "--threads", "1",
                        "--realisations", str(realisations), "--quiet"], check=True,
                       stdout=subprocess.DEVNULL)
        best = min(best, time.perf_counter() - start)
    return best


def rows_regressed(out):
    import pyarrow.parquet as pq
    used = pq.read_table(out / "cycles.parquet", columns=["used"]).column("used")
    return sum(1 for u in used.to_pylist() if u)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=3, help="runs per timing (best kept)")
    ap.add_argument("--large", type=int, default=1020,
                    help="the larger R (the difference must outweigh the timing noise)")
    ap.add_argument("--binary", type=pathlib.Path, default=BINARY,
                    help="the chassis-mc measured (default: this checkout's release build)")
    ap.add_argument("--rounds", type=int, default=1,
                    help="measure the table this many times over and give each cell's median "
                         "over the rounds, with the range of the ratio")
    ap.add_argument("--before", type=pathlib.Path,
                    help="another chassis-mc (an earlier commit's build) measured in the same "
                         "run, alternating with --binary: its columns come first")
    ap.add_argument("--in-process", action="store_true",
                    help="time realisations in one process (examples/path_ratio.rs, built "
                         "by `cargo build --release --example path_ratio`) instead of "
                         "whole runs (--repeat and --large do not apply); --binary still "
                         "gives the rows regressed")
    ap.add_argument("--only", metavar="REGEX",
                    help="measure only the paths whose names match (the thesis path always, "
                         "as the base of the ratios)")
    args = ap.parse_args()
    if args.rounds < 1:
        ap.error("--rounds must be at least 1")
    paths = [p for i, p in enumerate(PATHS)
             if i == 0 or args.only is None or re.search(args.only, p[0])]
    if any(str(TRUCK_LOG) in text for _, text in paths) and not TRUCK_LOG.exists():
        subprocess.run([sys.executable, str(ROOT / "tools" / "make_truck_log.py"),
                        "--binary", str(args.binary)], check=True)
    binaries = [args.before, args.binary] if args.before else [args.binary]
    # results[b][i]: per round, (s per realisation, s per sample, rows, s per sample of the
    # thesis path measured just before it with the same binary)
    results = [[[] for _ in paths] for _ in binaries]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)

        def cost(binary, i, text):
            """Marginal cost per realisation and the rows regressed, of path i."""
            study = tmp / f"path{i}.toml"
            # heavy_duty.toml names no files; both studies are read from the temp dir.
            study.write_text(text)
            out = tmp / f"out{i}"
            small = wall(binary, study, SMALL, out, args.repeat)
            large = wall(binary, study, args.large, out, args.repeat)
            return (large - small) / (args.large - SMALL), rows_regressed(out)

        if args.in_process:
            if args.before:
                ap.error("--in-process measures this checkout's build only (no --before)")
            in_process(args, paths, tmp)
            return
        for _ in rounds(args.rounds):
            for i, (name, text) in enumerate(paths):
                for binary, rows in zip(binaries, results):
                    # The thesis path again beside each path, so that its ratio compares two
                    # timings taken moments apart (the machine drifts within a run).
                    base, base_n = cost(binary, 0, paths[0][1])
                    per_r, n = (base, base_n) if i == 0 else cost(binary, i, text)
                    rows[i].append((per_r, per_r / n, n, base / base_n))
    heads = ["before: ", "after: "] if args.before else [""]
    names = columns(args.rounds)
    print("| path | rows | " + " | ".join(f"{h}{c}" for h in heads for c in names) + " |")
    print("|---|---|" + "---|" * len(names) * len(heads))
    for i, (name, _) in enumerate(paths):
        cells = []
        for rows in results:
            cells += summary_cells([r[0] for r in rows[i]], [r[1] for r in rows[i]],
                                   [per_s / base for _, per_s, _, base in rows[i]])
        print(f"| {name} | {results[0][i][0][2]} | " + " | ".join(cells) + " |")


def rounds(count):
    """range(count), saying on stderr which round starts when there are several."""
    for k in range(count):
        if count > 1:
            print(f"round {k + 1} of {count}", file=sys.stderr, flush=True)
        yield k


def columns(count):
    """The table's columns for one binary measured over `count` rounds."""
    names = ["ms / realisation", "ns / sample", "× thesis per sample"]
    return names + ["× thesis, range"] if count > 1 else names


def summary_cells(per_r, per_s, ratios):
    """The cells of one path: the medians over the rounds of the cost per realisation and
    per sample [s] and of the ratio to the thesis path, then the ratio's range when there
    are several rounds."""
    cells = [f"{1e3 * statistics.median(per_r):.3f}", f"{1e9 * statistics.median(per_s):.1f}",
             f"{statistics.median(ratios):.2f}"]
    return cells + [f"{min(ratios):.2f}–{max(ratios):.2f}"] if len(ratios) > 1 else cells


def in_process(args, paths, tmp):
    """The table from `examples/path_ratio.rs`: each path against the thesis path in one
    process."""
    ratio = ROOT / "target" / "release" / "examples" / "path_ratio"
    if not ratio.exists():
        raise SystemExit(f"{ratio} missing: cargo build --release --example path_ratio")

    def study(i, text):
        """The study file of path i and the rows it regresses (from a run of one
        realisation)."""
        file = tmp / f"path{i}.toml"
        file.write_text(text)
        out = tmp / f"rows{i}"
        shutil.rmtree(out, ignore_errors=True)
        subprocess.run([str(args.binary), "run", str(file), "--out", str(out), "--threads", "1",
                        "--realisations", "1", "--quiet"], check=True,
                       stdout=subprocess.DEVNULL)
        return file, rows_regressed(out)

    base, base_n = study(0, paths[0][1])
    files = [(base, base_n)] + [study(i, text) for i, (_, text) in enumerate(paths) if i > 0]
    # per path, per round: (s per realisation, s per sample, ratio to the thesis path's)
    measured = [[] for _ in paths]
    for _ in rounds(args.rounds):
        for (file, n), each in zip(files, measured):
            line = subprocess.run([str(ratio), str(base), str(file), "8", "80"], check=True,
                                  capture_output=True, text=True).stdout.split()
            base_r, per_r = float(line[0]) * 1e-3, float(line[1]) * 1e-3
            each.append((per_r, per_r / n, (per_r / n) / (base_r / base_n)))
    names = columns(args.rounds)
    print("| path | rows | " + " | ".join(names) + " |")
    print("|---|---|" + "---|" * len(names))
    for (name, _), (_, n), each in zip(paths, files, measured):
        cells = summary_cells(*([r[k] for r in each] for k in range(3)))
        print(f"| {name} | {n} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
