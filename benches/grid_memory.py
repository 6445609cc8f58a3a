#!/usr/bin/env python3
"""Peak memory of `check` and `run` on a 10 000-condition grid: does it grow with the grid?

The thesis cycle (studies/grid.toml) at 10 terrain scales × 10 durations × N speed-noise
levels, OLS and BCLS: N = 100 makes 10 000 conditions, N = 20 makes 2 000. For each grid it
prints the wall time and the peak resident memory (the child's ru_maxrss, each measured in
a fresh Python process so that no other run's memory counts) of `check` and of `run` with
its figures, at R = 20. Compare the two grids' peaks: memory that is independent of the
grid's size differs little between them.

    cargo build --release && python3 benches/grid_memory.py [--binary PATH] [--levels 20 100]

`--binary` measures another build (e.g. an older commit's target/release/chassis-mc) the
same way. No third-party packages are needed.
"""

import argparse
import json
import pathlib
import re
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parents[1]
STUDY = ROOT / "studies" / "grid.toml"

MEASURE = r"""
import json, resource, subprocess, sys, time
t = time.perf_counter()
subprocess.run(sys.argv[1:], check=True, stdout=subprocess.DEVNULL)
wall = time.perf_counter() - t
print(json.dumps({"wall_s": wall, "max_rss_mb": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024}))
"""


def measure(cmd):
    res = subprocess.run([sys.executable, "-c", MEASURE, *cmd], check=True,
                         capture_output=True, text=True)
    return json.loads(res.stdout)


def grid(levels, path):
    """studies/grid.toml at 10 scales and `levels` speed-noise levels, written to `path`."""
    text = STUDY.read_text()
    scales = ", ".join(f"{1.0 + 0.1 * i:.1f}" for i in range(10))
    text = re.sub(r"^scales = .*$", f"scales = [{scales}]", text, count=1, flags=re.M)
    sds = ", ".join(f"{0.02 * (i + 1) * 100 / levels:.4f}" for i in range(levels))
    text = re.sub(r"^velocity_sd = .*$", f"velocity_sd = [{sds}]", text, count=1, flags=re.M)
    path.write_text(text)
    return 10 * 10 * levels


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--binary", default=str(ROOT / "target" / "release" / "chassis-mc"),
                    help="the chassis-mc executable to measure (default: this checkout's)")
    ap.add_argument("--levels", type=int, nargs="+", default=[20, 100],
                    help="speed-noise levels of each grid (10 × 10 × levels conditions)")
    ap.add_argument("--realisations", type=int, default=20)
    args = ap.parse_args()
    r = str(args.realisations)
    with tempfile.TemporaryDirectory() as tmp:
        for levels in args.levels:
            study = pathlib.Path(tmp) / f"grid{levels}.toml"
            conditions = grid(levels, study)
            check = measure([args.binary, "check", str(study), "--realisations", r])
            out = pathlib.Path(tmp) / f"out{levels}"
            run = measure([args.binary, "run", str(study), "--out", str(out), "--quiet",
                           "--realisations", r])
            print(f"{conditions} conditions, R = {r}: check {check['wall_s']:.0f} s, peak "
                  f"{check['max_rss_mb']:.0f} MB; run (with figures) {run['wall_s']:.0f} s, "
                  f"peak {run['max_rss_mb']:.0f} MB", flush=True)


if __name__ == "__main__":
    main()
