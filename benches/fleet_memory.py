#!/usr/bin/env python3
"""Wall time and peak memory of a fleet of N vehicles (default 1 000) at R realisations.

Writes a table of the EPA Test Car List's shape (its column names, as in
studies/data/epa_2022_fleet.csv) of N vehicles — each one of the twelve shipped vehicles
with its A, B, C and test weight scaled by independent factors in [0.8, 1.25] (seeded, so
the table is the same on every run) — and runs studies/fleet.toml on it (its coast-down
with `--runs` runs, default 8, one condition per vehicle), measuring the wall time and the
child's peak resident memory (ru_maxrss, in a fresh Python process). `--table` runs the
study on another table instead, e.g. the whole EPA list (its FTP rows, one per Test Number).

    cargo build --release && python3 benches/fleet_memory.py [--vehicles 1000] \\
        [--realisations 100] [--runs 8] [--no-campaign] [--table 22-tstcar.csv]

No third-party packages are needed.
"""

import argparse
import csv
import json
import pathlib
import random
import re
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parents[1]
SHIPPED = ROOT / "studies" / "data" / "epa_2022_fleet.csv"
STUDY = ROOT / "studies" / "fleet.toml"

MEASURE = r"""
import json, resource, subprocess, sys, time
t = time.perf_counter()
subprocess.run(sys.argv[1:], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
wall = time.perf_counter() - t
print(json.dumps({"wall_s": wall, "max_rss_mb": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024}))
"""


def synthetic(n, path):
    lines = [l for l in SHIPPED.read_text().splitlines() if not l.startswith("#")]
    rows = list(csv.DictReader(lines))
    rows = [r for r in rows if r["Test Category"] == "FTP"]
    rng = random.Random(2018)
    scaled = ["Equivalent Test Weight (lbs.)", "Target Coef A (lbf)",
              "Target Coef B (lbf/mph)", "Target Coef C (lbf/mph**2)"]
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        for k in range(n):
            r = dict(rng.choice(rows))
            for c in scaled:
                r[c] = repr(float(r[c]) * rng.uniform(0.8, 1.25))
            r["Represented Test Veh Model"] = f"{r['Represented Test Veh Model']} #{k}"
            r["Test Vehicle ID"] = f"V{k:05d}"
            w.writerow(r)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--vehicles", type=int, default=1000)
    ap.add_argument("--realisations", type=int, default=100)
    ap.add_argument("--runs", type=int, default=8)
    ap.add_argument("--no-campaign", action="store_true",
                    help="leave out [campaign] (its verdict reads every realisation's rows)")
    ap.add_argument("--table", type=pathlib.Path, help="the EPA list itself (CSV)")
    ap.add_argument("--binary", type=pathlib.Path,
                    default=ROOT / "target" / "release" / "chassis-mc")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        text = STUDY.read_text()
        text = re.sub(r"(?m)^runs = .*$", f"runs = [{args.runs}]", text)
        if args.no_campaign:
            text = text[: text.index("[campaign]")]
        if args.table:
            table = args.table.resolve()
            text = re.sub(r'(?m)^id = .*$', 'id = "Test Number"', text)
            text = re.sub(r'(?m)^distinct = .*$', 'distinct = ["Test Number"]', text)
        else:
            table = tmp / "fleet.csv"
            synthetic(args.vehicles, table)
        text = re.sub(r'(?m)^file = .*$', f'file = "{table}"', text)
        study = tmp / "fleet.toml"
        study.write_text(text)
        cmd = [str(args.binary), "run", str(study), "--out", str(tmp / "out"),
               "--realisations", str(args.realisations), "--quiet"]
        res = subprocess.run([sys.executable, "-c", MEASURE, *cmd], check=True,
                             capture_output=True, text=True)
        m = json.loads(res.stdout)
        summary = tmp / "out" / "summary.parquet"
        print(f"fleet of {'the table' if args.table else args.vehicles} vehicles, "
              f"{args.runs} runs, R = {args.realisations}"
              f"{'' if args.no_campaign else ', with the campaign'}: "
              f"{m['wall_s']:.1f} s wall, peak RSS {m['max_rss_mb']:.0f} MiB "
              f"(summary {summary.stat().st_size / 1e6:.1f} MB)")


if __name__ == "__main__":
    main()
