#!/usr/bin/env python3
"""Gusts: an independent NumPy Monte Carlo of the re-integrated motion against the engine.

Under `[truth] wind_gust_sd` every realisation's cycle is integrated again under its own
random wind and its OLS estimate fitted to the thesis equation (docs/model.md#model-errors).
This script simulates the same thing with its own code and its own random numbers
(numpy.random.default_rng) on the thesis cycle (studies/thesis.toml at scale 1.0, speed
noise off, σ_w = 2 m/s, τ = 10 s, R = 400), runs the engine on the same study, and checks,
per parameter, that the two Monte Carlo means and the two empirical SDs agree within
4 combined MCSEs (mean: s/√R; SD: s/√(2(R−1)), the engine's own formulas). The two runs
share no random numbers, so this is a statistical comparison: with independent estimates a
|z| beyond 4 has probability ≈ 6e-5 per comparison when both are right.

The NumPy model, written from the definitions (not from the engine's code paths):
- gust at the sample times t_i = i Δt: w_0 = σ z_0, w_i = φ w_{i−1} + σ √(1−φ²) z_i,
  φ = exp(−Δt/τ), linear between samples (RK4's half-step stages read (w_i + w_{i+1})/2);
- M dV/dt = F(t) − k Cd (V + w)|V + w| − Cr M g cos θ(x) − M g sin θ(x), k = ½ρA,
  F(t) = τ0 (1 + a sin(ω t)) R_fd / r_wheel, θ(x) the linear interpolation of the 1 m grade
  table θ_j = scale · atan(y(j+1) − y(j)), y(x) = h cos²(x/P);
- classical RK4 at the sample step (force at the half step for stages 2–3, at t_{i+1} for
  stage 4), vectorised across realisations;
- OLS of y = dV/dt + g sin θ on x = [F, −kV², −g cos θ] over all samples, by a Householder
  QR updated block by block (no normal equations, so no squared condition number).

Self-checks of the NumPy code (one extra trajectory with σ_w = 0 integrated alongside):
its θ̂ equals the truth θ within 1e-9 relative, and its trajectory equals the engine's
noise-free cycle (cycles.parquet) to rounding.

    cargo build --release && python analysis/gusts_check.py
"""

import argparse
import math
import os
import pathlib
import subprocess
import sys
import tempfile
import time
import tomllib

import numpy as np
import pyarrow.parquet as pq

from common import mc_summary

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parent
# Where cargo put the binary: $CARGO_TARGET_DIR when set (relative to the repository, as
# cargo reads it), else target/.
BINARY = ROOT / os.environ.get("CARGO_TARGET_DIR", "target") / "release" / "chassis-mc"
THESIS = ROOT / "studies" / "thesis.toml"
PARAMETERS = ["inv_mass", "drag_over_mass", "rolling_resistance"]
SYMBOL = {"inv_mass": "1/M", "drag_over_mass": "Cd/M", "rolling_resistance": "Cr"}

GUST_SD = 2.0  # σ_w [m/s]
GUST_TIME = 10.0  # τ [s]
Z_MAX = 4.0  # agreement: |difference| ≤ 4 combined MCSEs
# θ̂ of the noise-free trajectory: y = Xθ holds at every sample to rounding (~1e-16
# relative), and a Householder QR solves it with an error ≲ κ(X)·1e-16 relative; κ(X) of
# the column-scaled design is ~1e3 here, so 1e-9 leaves a margin of ~1e4.
SELF_TOL = 1e-9
# The noise-free trajectory against the engine's: the same RK4 steps in float64, differing
# only in rounding (operation order, libm's sin/cos/atan: ≤ a few ulp per step). The
# dynamics are damped (∂a/∂V = −2kCdV/M < 0), so per-step differences of ~1e-15 relative do
# not grow: summed over 6e4 steps they stay below ~6e4 · 1e-15 · 30 m/s ≈ 2e-9 m/s, and x
# accumulates V over 600 s: ≤ 600 s · 2e-9 m/s ≈ 1e-6 m. Bounds set one decade above.
TRAJECTORY_TOL = {"v": 2e-8, "x": 1e-5, "accel": 2e-8, "grade": 1e-9}


def study_text(realisations):
    """studies/thesis.toml at scale 1.0, speed noise off, gusts on, R realisations."""
    lines = []
    for line in THESIS.read_text().splitlines():
        if line.startswith("realisations ="):
            line = f"realisations = {realisations}"
        elif line.startswith("scales ="):
            line = "scales = [1.0]"
        elif line.startswith("velocity_sd ="):
            line = "velocity_sd = [0.0]"
        elif line.startswith("estimators ="):
            line = 'estimators = ["ols"]'
        lines.append(line)
    lines += ["", "[truth]", f"wind_gust_sd = [{GUST_SD}]", f"wind_gust_time = {GUST_TIME}"]
    return "\n".join(lines) + "\n"


def run_engine(realisations, tmp):
    """The engine's summary (per parameter) and its noise-free cycle."""
    study = tmp / "gusts.toml"
    study.write_text(study_text(realisations))
    out = tmp / "gusts"
    subprocess.run([BINARY, "run", study, "--out", out, "--quiet", "--no-figures"], check=True)
    summary = pq.read_table(out / "summary.parquet").to_pandas().set_index("parameter")
    cycle = pq.read_table(out / "cycles.parquet", columns=["t", "x", "v", "grade", "accel"])
    return summary, cycle.to_pandas()


class Thesis:
    """The constants of studies/thesis.toml that the motion needs."""

    def __init__(self, scale=1.0):
        s = tomllib.loads(THESIS.read_text())
        veh, drive, ter = s["vehicle"], s["drive"], s["terrain"]
        assert ter["profile"] == "cos2" and ter["scale_applies_to"] == "grade"
        self.m = veh["mass"]
        self.cd = veh["drag_coefficient"]
        self.cr = veh["rolling_resistance"]
        self.g = veh["gravity"]
        self.k = 0.5 * veh["air_density"] * veh["frontal_area"]
        self.theta = np.array([1.0 / self.m, self.cd / self.m, self.cr])
        self.h = drive["time_step"]
        self.n = round(drive["duration"] / self.h) + 1
        self.v0 = drive["initial_speed"]
        gain = veh["final_drive_ratio"] / veh["wheel_radius"]
        self.force = lambda t: (drive["torque_mean"] * (1.0 + drive["torque_amplitude"]
                                * np.sin(drive["torque_frequency"] * t)) * gain)
        x = np.arange(ter["length"] + 1, dtype=float)
        y = ter["height"] * np.cos(x / ter["period"]) ** 2
        self.grade = scale * np.arctan(np.diff(y))  # θ_j at x_j = j m, j = 0 … L−1


def simulate(th, sigma, tau, rng, block=1000):
    """Integrate one trajectory per entry of `sigma` (its gusts' SD) at once; OLS on each.

    Returns θ̂ (columns × 3), whether each column stalled, and column 0's trajectory
    (t, x, v, grade, accel), for the self-checks."""
    cols = len(sigma)
    h, n = th.h, th.n
    hh = 0.5 * h
    t = np.arange(n) * h
    f_sample = th.force(t)
    f_mid = th.force(t + hh)
    grade, last = th.grade, len(th.grade) - 1
    dgrade = np.diff(grade)
    kcd, crmg, mg, m = th.k * th.cd, th.cr * th.m * th.g, th.m * th.g, th.m
    phi = math.exp(-h / tau)
    innovation = sigma * math.sqrt(1.0 - phi * phi)

    def accel(x, air, f):
        """dV/dt and θ at position x, air speed `air`, force f."""
        u = np.maximum(x, 0.0)  # θ(x ≤ 0) = θ_0, as the grade table clamps
        if u.max() > last:
            raise RuntimeError("a trajectory ran off the grade table")
        j = np.minimum(u.astype(np.intp), last - 1)
        theta = grade[j] + (u - j) * dgrade[j]
        a = (f - kcd * air * np.abs(air) - crmg * np.cos(theta) - mg * np.sin(theta)) / m
        return a, theta

    x = np.zeros(cols)
    v = np.full(cols, th.v0)
    w = sigma * rng.standard_normal(cols)
    stalled = np.zeros(cols, dtype=bool)
    r_factor = np.zeros((cols, 4, 4))  # R of the QR of [X y] so far, per column
    trajectory = {key: np.empty(n) for key in ["x", "v", "grade", "accel"]}
    for start in range(0, n, block):
        stop = min(start + block, n)
        z = rng.standard_normal((stop - start, cols))
        xs, vs, thetas, accels = (np.empty((stop - start, cols)) for _ in range(4))
        for i in range(start, stop):
            b = i - start
            a1, theta = accel(x, v + w, f_sample[i])
            xs[b], vs[b], thetas[b], accels[b] = x, v, theta, a1
            if i + 1 == n:
                break
            w1 = phi * w + innovation * z[b]
            w_mid = 0.5 * (w + w1)
            k2x = v + hh * a1
            k2v, _ = accel(x + hh * v, k2x + w_mid, f_mid[i])
            k3x = v + hh * k2v
            k3v, _ = accel(x + hh * k2x, k3x + w_mid, f_mid[i])
            k4x = v + h * k3v
            k4v, _ = accel(x + h * k3x, k4x + w1, f_sample[i + 1])
            x = x + h / 6.0 * (v + 2.0 * k2x + 2.0 * k3x + k4x)
            v = v + h / 6.0 * (a1 + 2.0 * k2v + 2.0 * k3v + k4v)
            w = w1
            stalled |= v <= 0.0
        # This block's rows [F, −kV², −g cos θ, dV/dt + g sin θ], stacked under R so far.
        rows = np.empty((cols, stop - start, 4))
        rows[:, :, 0] = f_sample[start:stop]
        rows[:, :, 1] = (-th.k * vs * vs).T
        rows[:, :, 2] = (-th.g * np.cos(thetas)).T
        rows[:, :, 3] = (accels + th.g * np.sin(thetas)).T
        r_factor = np.linalg.qr(np.concatenate([r_factor, rows], axis=1), mode="r")[:, :4, :]
        for key, values in [("x", xs), ("v", vs), ("grade", thetas), ("accel", accels)]:
            trajectory[key][start:stop] = values[:, 0]
    theta_hat = np.linalg.solve(r_factor[:, :3, :3], r_factor[:, :3, 3:]).squeeze(-1)
    trajectory["t"] = t
    return theta_hat, stalled, trajectory


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--realisations", type=int, default=400)
    ap.add_argument("--seed", type=int, default=20240611, help="NumPy's seed")
    args = ap.parse_args()
    if not BINARY.exists():
        sys.exit(f"{BINARY} not found: run `cargo build --release` first")
    r = args.realisations
    th = Thesis()

    clock = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        engine, cycle = run_engine(r, pathlib.Path(tmp))
    engine_s = time.perf_counter() - clock

    clock = time.perf_counter()
    sigma = np.full(r + 1, GUST_SD)
    sigma[0] = 0.0  # column 0: the noise-free trajectory, for the self-checks
    rng = np.random.default_rng(args.seed)
    theta_hat, stalled, trajectory = simulate(th, sigma, GUST_TIME, rng)
    numpy_s = time.perf_counter() - clock
    print(f"gusts σ_w = {GUST_SD} m/s, τ = {GUST_TIME} s on the thesis cycle (scale 1.0, "
          f"no speed noise), OLS, R = {r}: engine {engine_s:.1f} s, NumPy {numpy_s:.1f} s")

    # Self-checks of the NumPy code.
    rel = np.abs(theta_hat[0] / th.theta - 1.0)
    print(f"  NumPy at σ_w = 0: max |θ̂/θ − 1| = {rel.max():.1e} (≤ {SELF_TOL:g})")
    assert rel.max() <= SELF_TOL, f"NumPy's noise-free θ̂ {theta_hat[0]} is not θ {th.theta}"
    assert len(cycle) == th.n, f"the engine's cycle has {len(cycle)} samples, not {th.n}"
    for key, tol in TRAJECTORY_TOL.items():
        d = np.abs(trajectory[key] - cycle[key].to_numpy()).max()
        print(f"  NumPy at σ_w = 0 against the engine's cycles.parquet: max |Δ{key}| = {d:.1e} "
              f"(≤ {tol:g})")
        assert d <= tol, f"NumPy's noise-free {key} differs from the engine's by {d:.3e}"
    assert not stalled.any(), f"{stalled.sum()} NumPy trajectories stalled"
    assert (engine["n_failed"] == 0).all() and (engine["n"] == r).all(), engine[["n", "n_failed"]]

    # The comparison.
    failures = []
    rows = []
    for p, estimates in zip(PARAMETERS, theta_hat[1:].T):
        e = engine.loc[p]
        mean, mean_mcse, sd, sd_mcse = mc_summary(estimates)
        for what, ev, em, nv, nm in [("mean", e["mean"], e["mean_mcse"], mean, mean_mcse),
                                     ("SD", e["emp_se"], e["emp_se_mcse"], sd, sd_mcse)]:
            z = (ev - nv) / math.hypot(em, nm)
            rows.append((SYMBOL[p], what, ev, em, nv, nm, z))
            if abs(z) > Z_MAX:
                failures.append(f"{SYMBOL[p]} {what}: z = {z:+.2f}")
    print(f"\n  {'θ':<5} {'':<4} {'engine ± MCSE':>21}   {'NumPy ± MCSE':>21}   {'z':>5}")
    for sym, what, ev, em, nv, nm, z in rows:
        print(f"  {sym:<5} {what:<4} {ev:>11.4e} ± {em:.1e}   {nv:>11.4e} ± {nm:.1e}   {z:>+5.2f}")
    print(f"  truth: 1/M = {th.theta[0]:.4e}, Cd/M = {th.theta[1]:.4e}, Cr = {th.theta[2]:.4e};"
          f" agreement: |z| ≤ {Z_MAX:g}, z = (engine − NumPy)/√(MCSE² + MCSE²)")
    # The SD's MCSE s/√(2(R−1)) assumes normal estimates; their excess kurtosis says how
    # far that holds (it scales that MCSE by about √(1 + excess/2)).
    centred = theta_hat[1:] - theta_hat[1:].mean(axis=0)
    excess = (centred**4).mean(axis=0) / (centred**2).mean(axis=0) ** 2 - 3.0
    print("  NumPy estimates' excess kurtosis: "
          + ", ".join(f"{SYMBOL[p]} {k:+.2f}" for p, k in zip(PARAMETERS, excess)))
    assert not failures, "the engine and NumPy disagree: " + "; ".join(failures)
    print("gusts: the engine's Monte Carlo agrees with an independent NumPy one")


if __name__ == "__main__":
    main()
