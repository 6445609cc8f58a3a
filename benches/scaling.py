#!/usr/bin/env python3
"""Thread scaling, wall time and peak memory of `chassis-mc run studies/thesis.toml`.

Measured in one run on this machine:
  - two threads against one on the thesis study (R = 2000; ratio of best wall times),
  - R = 10 000 on all cores: wall time and peak RSS,
  - R = 100 000 on all cores: peak RSS, as a ratio to R = 10 000 (memory must not grow
    with R: realisations stream to Parquet, summaries use exact sums),
  - the same two runs with `noise.share_across_scales = true` (one draw per realisation
    serves all 11 scales; docs/model.md#shared-noise).

Peak RSS is the child's ru_maxrss, read in a fresh Python process per run, so no other
run's memory counts. No third-party packages are needed.

    cargo build --release && python3 benches/scaling.py [--skip-large] [--skip-threads]
"""

import argparse
import json
import pathlib
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parents[1]
BINARY = ROOT / "target" / "release" / "chassis-mc"
STUDY = ROOT / "studies" / "thesis.toml"

MEASURE = r"""
import json, resource, subprocess, sys, time
t = time.perf_counter()
subprocess.run(sys.argv[1:], check=True, stdout=subprocess.DEVNULL)
wall = time.perf_counter() - t
print(json.dumps({"wall_s": wall, "max_rss_mb": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024}))
"""


def measure(realisations, threads=None, shared=False):
    with tempfile.TemporaryDirectory() as out:
        study = STUDY
        if shared:
            study = pathlib.Path(out) / "thesis_shared.toml"
            text = STUDY.read_text().replace("[noise]", "[noise]\nshare_across_scales = true", 1)
            study.write_text(text)
        cmd = [str(BINARY), "run", str(study), "--out", str(pathlib.Path(out) / "run"),
               "--quiet", "--realisations", str(realisations)]
        if threads:
            cmd += ["--threads", str(threads)]
        res = subprocess.run([sys.executable, "-c", MEASURE, *cmd], check=True,
                             capture_output=True, text=True)
        return json.loads(res.stdout)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--skip-large", action="store_true", help="skip the R = 100 000 runs")
    ap.add_argument("--skip-threads", action="store_true", help="skip the 1-vs-2-thread runs")
    ap.add_argument("--r-threads", type=int, default=2000,
                    help="realisations for the thread comparison (2000: the thesis study as shipped)")
    args = ap.parse_args()
    if not BINARY.exists():
        sys.exit(f"{BINARY} not found: run `cargo build --release` first")
    # Alternate 1 and 2 threads and keep each one's best of five: the machine is shared and
    # its speed drifts, so a single pair of runs can mislead in either direction.
    if not args.skip_threads:
        runs = {1: [], 2: []}
        for _ in range(5):
            for threads in (1, 2):
                runs[threads].append(measure(args.r_threads, threads=threads)["wall_s"])
        one, two = min(runs[1]), min(runs[2])
        print(f"R = {args.r_threads}, 1 thread : {one:7.2f} s (best of {runs[1]})")
        print(f"R = {args.r_threads}, 2 threads: {two:7.2f} s (best of {runs[2]})   speed-up {one / two:.2f}x")
    # R = 10 000 unshared and shared, alternating, best of two each.
    ten = {False: [], True: []}
    for _ in range(2):
        for shared in (False, True):
            ten[shared].append(measure(10_000, shared=shared))
    for shared in (False, True):
        best = min(ten[shared], key=lambda m: m["wall_s"])
        label = "shared" if shared else "unshared"
        walls = ", ".join(f"{m['wall_s']:.2f}" for m in ten[shared])
        print(f"R = 10 000, all cores, {label:8}: {best['wall_s']:6.2f} s wall (runs {walls}), "
              f"peak RSS {max(m['max_rss_mb'] for m in ten[shared]):.0f} MB")
    if not args.skip_large:
        for shared in (False, True):
            big = measure(100_000, shared=shared)
            small = max(m["max_rss_mb"] for m in ten[shared])
            label = "shared" if shared else "unshared"
            print(f"R = 100 000, all cores, {label:8}: {big['wall_s']:6.2f} s wall, peak RSS "
                  f"{big['max_rss_mb']:.0f} MB   RSS ratio to R = 10 000: {big['max_rss_mb'] / small:.2f}")

if __name__ == "__main__":
    main()
