#!/usr/bin/env python3
"""Coast-down or road drive? Runs studies/coastdown_vs_road.toml (an 8-run coast-down on a
flat road) and studies/coastdown_vs_road_drive.toml (a 20-minute drive on a hilly route),
the same weighed passenger car, speed sensor and model errors, and prints, per test,
estimator and condition (calm; a 3 m/s wind; an unmodelled rotating-mass factor of 0.03;
the logged force 1 % off; all three), how often Cd and Cr come out within 1 % of the truth, with its Monte Carlo standard
error sqrt(p (1 − p) / R) (a binomial proportion over R independent realisations; none of R
is shown as the rule of three's 95 % bound, < 3/R), and the
relative bias (± its MCSE, the SD over √R) and the relative EmpSE.

Cd is `cd_hat` = M θ̂₂ with M weighed, Cr is θ̂₃; both read from realisations.parquet.

    cargo build --release
    .venv/bin/python analysis/coastdown_vs_road.py results/coastdown_vs_road
"""

import argparse
import pathlib
import subprocess

import duckdb

from common import check_output_set, realisation_files

ROOT = pathlib.Path(__file__).resolve().parent.parent
BINARY = ROOT / "target" / "release" / "chassis-mc"
STUDIES = {"coast-down, 8 runs": "coastdown_vs_road", "road drive, 20 min": "coastdown_vs_road_drive"}
TRUTH = {"cd": 0.30, "cr": 0.010}
CONDITIONS = [
    (0.0, 0.0, 0.0, "calm"),
    (3.0, 0.0, 0.0, "wind 3 m/s"),
    (0.0, 0.03, 0.0, "δ = 0.03"),
    (0.0, 0.0, 0.01, "force 1 % off"),
    (3.0, 0.03, 0.01, "all three"),
]


def run(out):
    """Run both studies into out/<name> (skipped when a complete run is there)."""
    for name in STUDIES.values():
        target = out / name
        if not (target / "summary.parquet").is_file():
            subprocess.run(
                [str(BINARY), "run", str(ROOT / "studies" / f"{name}.toml"), "--out", str(target)],
                check=True,
                stdout=subprocess.DEVNULL,
            )
        check_output_set(target)


def table(out):
    rows = []
    for test, name in STUDIES.items():
        files = [str(f) for f in realisation_files(out / name)]
        frame = duckdb.sql(
            f"""
            SELECT estimator, wind_speed, rotating_mass_factor, force_scale, count(*) AS n,
                   avg((abs(cd_hat / {TRUTH['cd']} - 1) < 0.01)::DOUBLE) AS cd_within,
                   avg((abs(theta_rolling_resistance / {TRUTH['cr']} - 1) < 0.01)::DOUBLE)
                       AS cr_within,
                   avg(cd_hat / {TRUTH['cd']} - 1) AS cd_bias,
                   stddev_samp(cd_hat / {TRUTH['cd']}) AS cd_sd,
                   avg(theta_rolling_resistance / {TRUTH['cr']} - 1) AS cr_bias,
                   stddev_samp(theta_rolling_resistance / {TRUTH['cr']}) AS cr_sd
            FROM read_parquet({files})
            WHERE status = 'ok'
            GROUP BY estimator, wind_speed, rotating_mass_factor, force_scale
            ORDER BY list_position(['ols', 'bcls', 'road_load'], estimator), wind_speed,
                rotating_mass_factor, force_scale
            """
        ).df()
        frame.insert(0, "test", test)
        rows.append(frame)
    return rows


def cell(p, n):
    if p == 0:
        # None of n: the rule of three's 95 % upper bound.
        return f"< {300 / n:.1f} %"
    se = (p * (1 - p) / n) ** 0.5
    return f"{100 * p:.1f} ± {100 * se:.1f} %"


def bias(value, sd, n):
    return f"{100 * value:+.2f} ± {100 * sd / n ** 0.5:.2f}, {100 * sd:.2f}"


def print_table(frames, title, show):
    """A markdown table: a row per test and estimator, a column per condition, each cell
    `show` of that condition's row."""
    print(title + "\n")
    print("| test | estimator | " + " | ".join(c[3] for c in CONDITIONS) + " |")
    print("|---|---|" + "---|" * len(CONDITIONS))
    for frame in frames:
        for est in frame.estimator.unique():
            cells = []
            for wind, delta, scale, _ in CONDITIONS:
                r = frame[(frame.estimator == est) & (frame.wind_speed == wind)
                          & (frame.rotating_mass_factor == delta)
                          & (frame.force_scale == scale)].iloc[0]
                cells.append(show(r))
            print(f"| {frame.test.iloc[0]} | {est} | " + " | ".join(cells) + " |")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out", type=pathlib.Path,
                    help="directory of the two runs (run into it when not complete there)")
    out = ap.parse_args().out
    run(out)
    frames = table(out)
    print_table(frames, "How often within 1 % of the truth (± MCSE), Cd | Cr:",
                lambda r: f"{cell(r.cd_within, r.n)} \\| {cell(r.cr_within, r.n)}")
    print()
    print_table(frames, "Relative bias ± MCSE (SD / √R) and relative EmpSE [%], Cd | Cr:",
                lambda r: f"{bias(r.cd_bias, r.cd_sd, r.n)} \\| {bias(r.cr_bias, r.cr_sd, r.n)}")

if __name__ == "__main__":
    main()
