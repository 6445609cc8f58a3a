"""Generate the 256-layer ziggurat tables for the standard normal used by chassis-mc.

The tables in src/noise/tables.rs were produced by this script (mpmath, 60 digits),
then rounded to the nearest f64 by Python's repr. Layout (Marsaglia & Tsang 2000):

  f(x) = exp(-x^2/2) (unnormalised), V = r f(r) + int_r^inf f(x) dx (area of each layer),
  X[0] = V / f(r), X[1] = r, X[i+1] = f^-1(f(X[i]) + V / X[i]), X[256] = 0,
  F[i] = f(X[i]).

r solves X[256] = 0, i.e. the top layer closes exactly at the mode.
Run (a development tool; needs mpmath, see tools/requirements.txt):
  python3 tools/ziggurat_tables.py   # prints the ZIG_X and ZIG_F arrays of src/noise/tables.rs
"""
import argparse
import sys

try:
    import mpmath as mp
except ImportError:  # --help answers without it; generating the tables needs it
    mp = None

N = 256


def f(x):
    return mp.exp(-x * x / 2)


def tail_area(r):
    return mp.sqrt(mp.pi / 2) * mp.erfc(r / mp.sqrt(2))


def closure(r):
    """f(X[255]) + V/X[255] - 1: zero when the top layer ends exactly at f(0) = 1."""
    v = r * f(r) + tail_area(r)
    x = r
    for _ in range(1, N - 1):
        y = f(x) + v / x
        if y >= 1:
            return mp.mpf(1)  # closed too early: r too small
        x = mp.sqrt(-2 * mp.log(y))
    return f(x) + v / x - 1


def solve():
    lo, hi = mp.mpf("3.5"), mp.mpf("3.8")
    for _ in range(200):
        mid = (lo + hi) / 2
        if closure(mid) > 0:
            lo = mid
        else:
            hi = mid
    return (lo + hi) / 2


def tables(r):
    v = r * f(r) + tail_area(r)
    xs = [v / f(r), r]
    for _ in range(1, N - 1):
        xs.append(mp.sqrt(-2 * mp.log(f(xs[-1]) + v / xs[-1])))
    xs.append(mp.mpf(0))
    return v, xs, [f(x) for x in xs]


if __name__ == "__main__":
    argparse.ArgumentParser(description=__doc__.splitlines()[0],
                            epilog="Needs mpmath: pip install -r tools/requirements.txt"
                            ).parse_args()
    if mp is None:
        sys.exit("tools/ziggurat_tables.py needs mpmath: pip install -r tools/requirements.txt")
    mp.mp.dps = 60
    r = solve()
    v, xs, fs = tables(r)
    print(f"// r = {mp.nstr(r, 25)}, v = {mp.nstr(v, 25)}")
    for name, values in (("ZIG_X", xs), ("ZIG_F", fs)):
        print(f"pub(crate) const {name}: [f64; 257] = [")
        for k in range(0, len(values), 4):
            print("    " + " ".join(f"{float(x)!r}," for x in values[k : k + 4]))
        print("];")
