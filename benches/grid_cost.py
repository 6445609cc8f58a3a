#!/usr/bin/env python3
"""What a large grid of conditions costs: `chassis-mc check` and `run` on studies/grid.toml.

The thesis cycle at 11 terrain scales × 10 durations × 10 speed-noise levels, OLS and BCLS
(1100 conditions). Prints check's estimates, then the run's wall time, peak RSS (with and
without figures) and the size of every file it wrote, so the two can be compared.

Peak RSS is the child's ru_maxrss, read in a fresh Python process per run, so no other
run's memory counts. No third-party packages are needed.

    cargo build --release && python3 benches/grid_cost.py [--realisations 50]
"""

import argparse
import json
import pathlib
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parents[1]
BINARY = ROOT / "target" / "release" / "chassis-mc"
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


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--realisations", type=int, default=50)
    args = ap.parse_args()
    r = str(args.realisations)
    check = subprocess.run([str(BINARY), "check", str(STUDY), "--realisations", r],
                           check=True, capture_output=True, text=True).stdout
    print("check:")
    print("\n".join(check.splitlines()[-8:]))
    with tempfile.TemporaryDirectory() as tmp:
        for figures in (True, False):
            out = pathlib.Path(tmp) / ("with-figures" if figures else "without-figures")
            cmd = [str(BINARY), "run", str(STUDY), "--out", str(out), "--quiet",
                   "--realisations", r] + ([] if figures else ["--no-figures"])
            m = measure(cmd)
            label = "run" if figures else "run --no-figures"
            print(f"{label}: {m['wall_s']:.1f} s wall, peak RSS {m['max_rss_mb']:.0f} MB")
            if figures:
                for f in sorted(p for p in out.rglob("*") if p.is_file()
                                and not p.name.startswith(".")):
                    if f.parent == out:
                        print(f"  {f.relative_to(out)}: {f.stat().st_size / 1e6:.2f} MB")
                svgs = list((out / "figures").glob("*.svg"))
                total = sum(f.stat().st_size for f in svgs)
                print(f"  figures/ ({len(svgs)} SVG files): {total / 1e6:.2f} MB, "
                      f"cycles.svg {(out / 'figures' / 'cycles.svg').stat().st_size / 1e3:.0f} kB")


if __name__ == "__main__":
    main()
