#!/usr/bin/env python3
"""Write a long-haul truck's 23-hour log at 1 Hz with gaps, the kind of log a user brings,
for the 1 Hz rows of benches/path_costs.py (README "Performance").

The truck of studies/heavy_duty.toml (30 t, Cd 0.59, Cr 0.0063) on its rolling route,
driven by its torque for 23 hours (82 800 s) and integrated by RK4 at the log's own 1 s step
(`chassis-mc simulate-log`, noise-free: the file is the truth a `replay` drive takes), then
logged as a real logger does: twelve gaps of 20 s to 10 minutes (the logger restarting, a
tunnel, a stop not logged) cut out of the rows, at fixed places. The rows next to a gap are
marked unusable (`used` = 0: a differentiated acceleration there would difference across
the gap).

Columns: t [s], v [m/s], f_prop [N], grade [rad], accel [m/s²], used (1 or 0): the columns
of a `replay` drive (docs/model.md#replay).

Deterministic (no random numbers): the same bytes for the same chassis-mc build.
Usage: python3 tools/make_truck_log.py [--binary target/release/chassis-mc] [--out FILE]
  (default FILE: benches/data/truck_23h_1hz.csv, which .gitignore keeps out of the repo)
"""

import argparse
import csv
import pathlib
import re
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parent.parent
OUT = ROOT / "benches" / "data" / "truck_23h_1hz.csv"
HOURS = 23
# (start [s], length [s]) of each gap: cut out of the 1 Hz rows.
GAPS = [(3_100, 20), (9_000, 45), (14_400, 600), (21_000, 30), (27_500, 120), (33_000, 25),
        (40_200, 300), (47_000, 60), (52_300, 20), (60_000, 480), (68_800, 40), (77_000, 90)]


def study_text():
    """studies/heavy_duty.toml driven for 23 hours at a 1 s step, noise-free, on a route
    long enough (1 800 km)."""
    text = (ROOT / "studies" / "heavy_duty.toml").read_text()
    edits = {
        "duration": f"{HOURS * 3600}.0",
        "time_step": "1.0",
        "durations": f"[{HOURS * 3600}.0]",
        "length": "1800000",
        "velocity_sd": "[0.0]",
        "estimators": '["ols"]',
    }
    for key, value in edits.items():
        text, count = re.subn(rf"^{key} = .*$", f"{key} = {value}", text, count=1, flags=re.M)
        if count != 1:
            sys.exit(f"studies/heavy_duty.toml: no line `{key} = …` to set")
    return text


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--binary", default=str(ROOT / "target" / "release" / "chassis-mc"))
    ap.add_argument("--out", default=str(OUT))
    args = ap.parse_args()
    out = pathlib.Path(args.out)
    with tempfile.TemporaryDirectory() as tmp:
        study = pathlib.Path(tmp) / "truck_23h.toml"
        study.write_text(study_text())
        log = pathlib.Path(tmp) / "log.csv"
        subprocess.run([args.binary, "simulate-log", str(study), "--out", str(log)], check=True)
        with log.open(newline="") as f:
            rows = list(csv.DictReader(f))
    cut = [False] * len(rows)
    for start, length in GAPS:
        for i in range(start, start + length):
            cut[i] = True
    kept = [i for i in range(len(rows)) if not cut[i]]
    out.parent.mkdir(parents=True, exist_ok=True)
    partial = out.with_suffix(".csv.tmp")
    with partial.open("w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["t", "v", "f_prop", "grade", "accel", "used"])
        for k, i in enumerate(kept):
            beside_gap = (k > 0 and kept[k - 1] != i - 1) or (
                k + 1 < len(kept) and kept[k + 1] != i + 1)
            r = rows[i]
            w.writerow([r["time_s"], r["speed_m_s"], r["force_n"], r["grade_rad"],
                        r["accel_m_s2"], 0 if beside_gap else 1])
    partial.replace(out)
    print(f"{out}: {len(kept)} rows at 1 Hz over {HOURS} h, {len(GAPS)} gaps "
          f"({len(rows) - len(kept)} s cut)")


if __name__ == "__main__":
    main()
