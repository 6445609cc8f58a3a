#!/usr/bin/env python3
"""chassis-mc against an independent NumPy reference of the same Monte Carlo, in one run.

The reference re-implements the thesis study from docs/model.md (vehicle, terrain, regression) with NumPy only: the cos²
terrain and forward-Euler grade, RK4 drive cycles (all scales integrated together), speed
noise from NumPy's own generator (PCG64), OLS through the 3×3 normal equations, and the
thesis bound. It shares no code and no random numbers with chassis-mc, so the two agree
only statistically: for every scale and parameter the means and empirical SEs must agree
within 4 combined Monte Carlo standard errors (66 comparisons per reference, 198 with the
two Numba ones; a 4-MCSE band has two-sided probability 6e-5 each, about 1 % for all 198).

It then prints the time per realisation of each, single-threaded, measured in this run:
chassis-mc's is its whole `run` (cycle simulation, output and summary included) divided
by the realisations; the reference's is its Monte Carlo loop alone (cycle simulation
excluded), so the ratio is conservative.

When Numba is installed (it is in benches/requirements.txt) it also times a fused Numba
loop of the same Monte Carlo: per realisation one pass over the samples that forms the
regressors and accumulates XᵀX and Xᵀy, then a 3×3 solve, compiled before timing. It runs
twice, once drawing the normals with Numba's own generator (np.random inside the compiled
code, slow) and once fed normals from NumPy's Generator (PCG64 and a ziggurat, drawn inside
the timing): the second is the faster Python one can write without a native extension. Both
are checked against chassis-mc the same way (without `--correlation-time` and
`--differentiated` only).

    python3 -m venv .venv && .venv/bin/pip install -r benches/requirements.txt
    cargo build --release
    .venv/bin/python benches/compare_numpy.py [--r-rust 2000] [--r-numpy 200]

With `--correlation-time TAU` [s] the speed noise is a stationary AR(1) process
(docs/model.md#sensors: e_0 = σ z_0, e_i = φ e_{i−1} + √(1 − φ²) σ z_i, φ = exp(−Δt/τ)),
generated here by its own recursion over NumPy's normals, at scales 1.0 and 2.0 only.

With `--differentiated` the acceleration in the output is the central difference of the
measured speed (docs/model.md#sensors: ỹ_i = (Ṽ_{i+1} − Ṽ_{i−1}) / (2h) + g sin θ_i, the first
and last sample left out), at scales 1.0 and 2.0 only; it combines with `--correlation-time`.
"""

import os

# Single-threaded BLAS: the comparison is per realisation on one core each.
for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(var, "1")

import argparse  # noqa: E402
import pathlib  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
import tomllib  # noqa: E402

import numpy as np  # noqa: E402
import pyarrow.parquet as pq  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[1]
BINARY = ROOT / "target" / "release" / "chassis-mc"
STUDY = ROOT / "studies" / "thesis.toml"
PARAMS = ["inv_mass", "drag_over_mass", "rolling_resistance"]


def grade_tables(study):
    t = study["terrain"]
    x = np.arange(t["length"] + 1, dtype=float)
    y = t["height"] * np.cos(x / t["period"]) ** 2
    base = np.arctan(np.diff(y))  # θ_i = atan(y_{i+1} - y_i), i = 0 … L-1
    return np.array([a * base for a in t["scales"]])  # scale multiplies the grade


def simulate(study, grades):
    """RK4 at the sample step for every scale at once; grade by linear interpolation."""
    v, d = study["vehicle"], study["drive"]
    m, g = v["mass"], v["gravity"]
    k_drag = 0.5 * v["air_density"] * v["frontal_area"] * v["drag_coefficient"]
    h = d["time_step"]
    n = int(round(d["duration"] / h)) + 1
    rows = np.arange(grades.shape[0])

    def grade_at(x):
        i = np.minimum(np.floor(x).astype(int), grades.shape[1] - 2)
        f = x - i
        return grades[rows, i] + f * (grades[rows, i + 1] - grades[rows, i])

    def force(t):
        tau = d["torque_mean"] * (1 + d["torque_amplitude"] * np.sin(d["torque_frequency"] * t))
        return tau * v["final_drive_ratio"] / v["wheel_radius"]

    def accel(t, x, vel):
        th = grade_at(x)
        return (force(t) - k_drag * vel**2 - v["rolling_resistance"] * m * g * np.cos(th)
                - m * g * np.sin(th)) / m

    out = {k: np.empty((len(rows), n)) for k in ("v", "grade", "f", "a")}
    x = np.zeros(len(rows))
    vel = np.full(len(rows), d["initial_speed"])
    for i in range(n):
        t = i * h
        out["v"][:, i], out["grade"][:, i], out["f"][:, i] = vel, grade_at(x), force(t)
        out["a"][:, i] = accel(t, x, vel)
        k1x, k1v = vel, out["a"][:, i]
        k2x = vel + 0.5 * h * k1v
        k2v = accel(t + 0.5 * h, x + 0.5 * h * k1x, k2x)
        k3x = vel + 0.5 * h * k2v
        k3v = accel(t + 0.5 * h, x + 0.5 * h * k2x, k3x)
        k4x = vel + h * k3v
        k4v = accel(t + h, x + h * k3x, k4x)
        x = x + h / 6 * (k1x + 2 * k2x + 2 * k3x + k4x)
        vel = vel + h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
    return out


def ar1(z, phi):
    """A stationary AR(1) series along the last axis of `z` (unit-variance normals)."""
    e = np.empty_like(z)
    e[..., 0] = z[..., 0]
    scale = np.sqrt(1 - phi * phi)
    for i in range(1, z.shape[-1]):
        e[..., i] = phi * e[..., i - 1] + scale * z[..., i]
    return e


def numpy_monte_carlo(study, cycles, r, seed, tau=0.0, differentiated=False):
    """OLS estimates of θ for r realisations of speed noise per scale: (scales, r, 3)."""
    v = study["vehicle"]
    g, k = v["gravity"], 0.5 * v["air_density"] * v["frontal_area"]
    sd = study["noise"]["velocity_sd"][0]
    rng = np.random.default_rng(seed)
    est = np.empty((cycles["v"].shape[0], r, 3))
    for s in range(cycles["v"].shape[0]):
        f, vel = cycles["f"][s], cycles["v"][s]
        c = -g * np.cos(cycles["grade"][s])
        y = cycles["a"][s] + g * np.sin(cycles["grade"][s])
        noise = None
        if tau > 0:
            phi = np.exp(-study["drive"]["time_step"] / tau)
            noise = ar1(rng.standard_normal((r, vel.shape[0])), phi)
        for j in range(r):
            e = rng.standard_normal(vel.shape[0]) if noise is None else noise[j]
            vt = vel + sd * e
            x = np.column_stack((f, -k * vt * vt, c))
            yt = y
            if differentiated:
                h = study["drive"]["time_step"]
                inner = slice(1, -1)
                yt = (vt[2:] - vt[:-2]) / (2 * h) + g * np.sin(cycles["grade"][s][inner])
                x = x[inner]
            est[s, j] = np.linalg.solve(x.T @ x, x.T @ yt)
    return est


def numba_monte_carlo(study, cycles, r, seed):
    """The Monte Carlo of `numpy_monte_carlo` (white speed noise, model acceleration) as a
    fused Numba loop per realisation, twice: with Numba's own normal generator, and fed
    normals from NumPy's (PCG64, ziggurat; drawn inside the timing). None when Numba is not
    installed; else ((estimates, seconds), (estimates, seconds)), estimates (scales, r, 3),
    seconds for the Monte Carlo alone (compiled beforehand on a tiny run)."""
    try:
        import numba
    except ImportError:
        return None

    @numba.njit(cache=False)
    def run(f, vel, c, y, k, sd, r, seed):
        np.random.seed(seed)
        n = vel.shape[0]
        out = np.empty((r, 3))
        for j in range(r):
            out[j] = fused(f, vel, c, y, k, sd, np.random.standard_normal(n))
        return out

    @numba.njit(cache=False)
    def run_given(f, vel, c, y, k, sd, z):
        out = np.empty((z.shape[0], 3))
        for j in range(z.shape[0]):
            out[j] = fused(f, vel, c, y, k, sd, z[j])
        return out

    @numba.njit(cache=False)
    def fused(f, vel, c, y, k, sd, z):
        # One pass: the regressors of each sample and the sums XᵀX, Xᵀy, then the solve.
        a = np.zeros((3, 3))
        b = np.zeros(3)
        for i in range(vel.shape[0]):
            vt = vel[i] + sd * z[i]
            x0, x1, x2 = f[i], -k * vt * vt, c[i]
            a[0, 0] += x0 * x0
            a[0, 1] += x0 * x1
            a[0, 2] += x0 * x2
            a[1, 1] += x1 * x1
            a[1, 2] += x1 * x2
            a[2, 2] += x2 * x2
            b[0] += x0 * y[i]
            b[1] += x1 * y[i]
            b[2] += x2 * y[i]
        a[1, 0], a[2, 0], a[2, 1] = a[0, 1], a[0, 2], a[1, 2]
        return solve3(a, b)

    @numba.njit(cache=False)
    def solve3(a, b):
        # Gaussian elimination with partial pivoting (Numba's np.linalg needs SciPy's BLAS).
        m = np.empty((3, 4))
        m[:, :3], m[:, 3] = a, b
        for col in range(3):
            p = col + np.argmax(np.abs(m[col:, col]))
            if p != col:
                tmp = m[col].copy()
                m[col], m[p] = m[p], tmp
            for row in range(col + 1, 3):
                m[row] -= m[row, col] / m[col, col] * m[col]
        x = np.empty(3)
        for row in range(2, -1, -1):
            acc = m[row, 3]
            for q in range(row + 1, 3):
                acc -= m[row, q] * x[q]
            x[row] = acc / m[row, row]
        return x

    v = study["vehicle"]
    g, k = v["gravity"], 0.5 * v["air_density"] * v["frontal_area"]
    sd = study["noise"]["velocity_sd"][0]
    columns = []
    for s in range(cycles["v"].shape[0]):
        c = -g * np.cos(cycles["grade"][s])
        y = cycles["a"][s] + g * np.sin(cycles["grade"][s])
        columns.append((np.ascontiguousarray(cycles["f"][s]), np.ascontiguousarray(cycles["v"][s]),
                        c, y))
    run(*columns[0], k, sd, 1, seed)  # compile
    run_given(*columns[0], k, sd, np.zeros((1, columns[0][1].shape[0])))
    own = np.empty((len(columns), r, 3))
    started = time.perf_counter()
    for s, (f, vel, c, y) in enumerate(columns):
        own[s] = run(f, vel, c, y, k, sd, r, seed + 1 + s)
    own_s = time.perf_counter() - started
    given = np.empty((len(columns), r, 3))
    rng = np.random.default_rng(seed + 100)
    started = time.perf_counter()
    for s, (f, vel, c, y) in enumerate(columns):
        given[s] = run_given(f, vel, c, y, k, sd, rng.standard_normal((r, vel.shape[0])))
    given_s = time.perf_counter() - started
    return (own, own_s), (given, given_s)

def compare(summary, scales, est, label):
    """Print the per-scale, per-parameter agreement of `est` with chassis-mc's summary;
    return the number of comparisons beyond 4 MCSE."""
    failures = 0
    print(f"\n{label}")
    print(f"{'scale':>5} {'parameter':>18} {'mean (chassis-mc)':>18} {'mean (' + label + ')':>14} "
          f"{'z':>6} {'EmpSE ratio':>11} {'z':>6}")
    for s, scale in enumerate(scales):
        for p, name in enumerate(PARAMS):
            row = summary[(np.isclose(summary.scale, scale)) & (summary.parameter == name)].iloc[0]
            x = est[s, :, p]
            n = len(x)
            mean, sd = x.mean(), x.std(ddof=1)
            z_mean = (row["mean"] - mean) / np.hypot(row["mean_mcse"], sd / np.sqrt(n))
            ratio = row["emp_se"] / sd
            # MCSE of a ratio of independent SD estimates: ratio·√(1/(2(n₁−1)) + 1/(2(n₂−1)))
            ratio_mcse = ratio * np.sqrt(1 / (2 * (row["n"] - 1)) + 1 / (2 * (n - 1)))
            z_ratio = (ratio - 1) / ratio_mcse
            bad = abs(z_mean) > 4 or abs(z_ratio) > 4
            failures += bad
            print(f"{scale:5.1f} {name:>18} {row['mean']:18.6e} {mean:14.6e} {z_mean:6.2f} "
                  f"{ratio:11.4f} {z_ratio:6.2f}{'  <-- disagree' if bad else ''}")
    return failures


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--r-rust", type=int, default=2000, help="chassis-mc realisations per scale")
    ap.add_argument("--r-numpy", type=int, default=200, help="NumPy realisations per scale")
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--correlation-time", type=float, default=0.0,
                    help="AR(1) speed noise with this correlation time [s], scales 1 and 2")
    ap.add_argument("--differentiated", action="store_true",
                    help="acceleration differentiated from the measured speed, scales 1 and 2")
    args = ap.parse_args()
    if not BINARY.exists():
        sys.exit(f"{BINARY} not found: run `cargo build --release` first")
    text = STUDY.read_text()
    if args.correlation_time > 0 or args.differentiated:
        text = "\n".join("scales = [1.0, 2.0]" if line.startswith("scales =") else line
                         for line in text.splitlines())
    if args.differentiated:
        text = text.replace("[estimation]", "[estimation]\nacceleration = \"differentiated\"")
    if args.correlation_time > 0:
        text = text.replace("[noise]", "[noise]\nvelocity_correlation_time = "
                            f"[{args.correlation_time}]")
    study = tomllib.loads(text)

    with tempfile.TemporaryDirectory() as out:
        study_path = pathlib.Path(out) / "study.toml"
        study_path.write_text(text)
        started = time.perf_counter()
        subprocess.run([BINARY, "run", study_path, "--out", pathlib.Path(out) / "run", "--quiet",
                        "--threads", "1", "--realisations", str(args.r_rust)], check=True)
        rust_s = time.perf_counter() - started
        summary = pq.read_table(pathlib.Path(out) / "run" / "summary.parquet").to_pandas()

    cycles = simulate(study, grade_tables(study))
    started = time.perf_counter()
    est = numpy_monte_carlo(study, cycles, args.r_numpy, args.seed, args.correlation_time,
                            args.differentiated)
    numpy_s = time.perf_counter() - started

    plain = args.correlation_time == 0 and not args.differentiated
    numba_runs = (numba_monte_carlo(study, cycles, args.r_numpy, args.seed + 1000)
                  if plain else None)

    scales = study["terrain"]["scales"]
    per_realisation = lambda seconds: 1e3 * seconds / (len(scales) * args.r_numpy)  # noqa: E731
    timings = [("NumPy", per_realisation(numpy_s), "Monte Carlo loop only")]
    failures = compare(summary, scales, est, "NumPy")
    compared = 1
    if numba_runs is not None:
        for label, (numba_est, numba_s) in zip(("Numba", "Numba+NumPy normals"), numba_runs):
            failures += compare(summary, scales, numba_est, label)
            compared += 1
            timings.append((label, per_realisation(numba_s), "fused loop only"))
    elif plain:
        print("\nNumba not installed: no fused-loop reference (pip install numba)")

    rust_ms = 1e3 * rust_s / (len(scales) * args.r_rust)
    print(f"\nper realisation, single thread: chassis-mc {rust_ms:.3f} ms (whole run)")
    for label, ms, what in timings:
        print(f"  {label:20} {ms:.3f} ms ({what}): {ms / rust_ms:.1f}x chassis-mc's time")
    total = 3 * len(scales) * 2 * compared
    if failures:
        sys.exit(f"{failures} of {total} comparisons disagree beyond 4 MCSE")
    print(f"all {total} comparisons agree within 4 MCSE")

if __name__ == "__main__":
    main()
