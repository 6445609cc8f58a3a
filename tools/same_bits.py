#!/usr/bin/env python3
"""Whether two chassis-mc builds give the same bytes: the check of a change not meant to
change results (a refactor, a faster kernel).

Runs, with each binary in turn and from this checkout (so both record the same study
directory), the studies below at small realisation counts, `fit` on the fit example and
`design` on the thesis design example, then compares every Parquet file each wrote byte for
byte. Where two files differ and pyarrow is installed, it names the columns whose values
differ (float columns by their bits) and the key-value metadata that differs.

    python3 tools/same_bits.py --before OLD/chassis-mc --after target/release/chassis-mc

Exit status 0 when every file is the same, 1 otherwise.
"""

import argparse
import filecmp
import pathlib
import struct
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parent.parent

# (study, realisations): the sensor paths, drawn model errors, the coast-down, the truck,
# bias compensation and the terrain/sensor grid.
RUNS = [
    ("sensors", 20),
    ("model_errors", 8),
    ("coastdown", 20),
    ("heavy_duty", 8),
    ("bias_compensation", 20),
    ("terrain_vs_sensor", 10),
]


def outputs(binary, out):
    """Every run of `binary` into `out`; each command's output in `out/NAME.log`."""
    commands = {
        name: ["run", f"studies/{name}.toml", "--realisations", str(r), "--no-figures",
               "--out", str(out / name)]
        for name, r in RUNS
    }
    commands["fit"] = ["fit", "studies/fit_example.toml", "--out", str(out / "fit")]
    commands["design"] = ["design", "studies/design_thesis.toml", "--vary", "drive.duration",
                          "--from", "60", "--to", "600", "--target",
                          "drag_over_mass:rel_rmse<=0.001", "--estimator", "bcls",
                          "--out", str(out / "design")]
    for name, args in commands.items():
        with open(out / f"{name}.log", "w") as log:
            subprocess.run([str(binary), *args], cwd=ROOT, stdout=log, stderr=log,
                           check=True)


def same_value(x, y):
    """Whether two cells are equal, floats by their bits (so 0.0 and -0.0 differ, and NaNs
    of the same bits agree)."""
    if isinstance(x, float) and isinstance(y, float):
        return struct.pack("<d", x) == struct.pack("<d", y)
    return x == y


def differing_columns(a, b):
    """The columns and metadata keys of Parquet files `a` and `b` that differ (None without
    pyarrow)."""
    try:
        import pyarrow.parquet as pq
    except ImportError:
        return None
    ta, tb = pq.read_table(a), pq.read_table(b)
    names = [n for n in ta.column_names if n in tb.column_names]
    found = [f"only before: {n}" for n in ta.column_names if n not in tb.column_names]
    found += [f"only after: {n}" for n in tb.column_names if n not in ta.column_names]
    if ta.num_rows != tb.num_rows:
        return found + [f"rows {ta.num_rows} vs {tb.num_rows}"]
    for n in names:
        ca, cb = ta.column(n).to_pylist(), tb.column(n).to_pylist()
        if not all(same_value(x, y) for x, y in zip(ca, cb)):
            found.append(n)
    ma = pq.read_metadata(a).metadata or {}
    mb = pq.read_metadata(b).metadata or {}
    found += [f"metadata {k.decode()}" for k in set(ma) | set(mb)
              if k != b"ARROW:schema" and ma.get(k) != mb.get(k)]
    return found


def main():
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="\n\n".join(__doc__.split("\n\n")[1:]))
    parser.add_argument("--before", required=True, type=pathlib.Path,
                        help="the chassis-mc of the commit before the change")
    parser.add_argument("--after", required=True, type=pathlib.Path,
                        help="the chassis-mc of the change")
    parser.add_argument("--keep", type=pathlib.Path,
                        help="write the outputs here (before/, after/) instead of a "
                             "temporary directory")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        top = args.keep or pathlib.Path(tmp)
        for side, binary in (("before", args.before), ("after", args.after)):
            (top / side).mkdir(parents=True, exist_ok=False)
            outputs(binary.resolve(), top / side)
        files = sorted(p.relative_to(top / "before")
                       for p in (top / "before").rglob("*.parquet"))
        differ = 0
        for f in files:
            a, b = top / "before" / f, top / "after" / f
            if b.exists() and filecmp.cmp(a, b, shallow=False):
                print(f"same   {f}")
                continue
            differ += 1
            columns = differing_columns(a, b) if b.exists() else ["missing after"]
            detail = "" if columns is None else f": {', '.join(columns) or 'bytes only'}"
            print(f"DIFFER {f}{detail}")
        print(f"{len(files) - differ} of {len(files)} files the same")
        return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
