#!/usr/bin/env python3
"""A designed drive checked with NumPy from a run's own files (docs/model.md#designed-drive):
the drive stays within its torque and speed limits on every sample (designed_drive.parquet);
its trace is the drive of its torque — the logged force is the torque times R_fd/r_wheel, each
sample's acceleration is the vehicle's equation at its state and force, and each step's speed
change is the trapezoid of the accelerations under the torque held over the step (the left
limit at the step's end: a(t_{i+1}) − (F_{i+1} − F_i)/M; an error of O(h³), ≤ 1e-6 m/s here,
where a torque applied one sample off would be ~h·ΔF/M ~ 1e-2 m/s); the trace is
cycles.parquet's cycle; and the criterion the engine reports for it (drive_design.parquet, row
`designed`) equals the one computed here from cycles.parquet.

Handled: white speed noise with a model acceleration (noise.velocity_sd; no other noise
channel), every parameter fitted, BCLS or OLS, and the criteria "d", "a" and a parameter's
name. The bound is `eiv_sandwich`: with X = [F, −kV², −g cos θ] over the used rows,
Ω_i = θ₂²k²(4V_i²σ² + 2σ⁴) and B = (XᵀX)⁻¹, the covariance is B (Σ_i Ω_i x_i x_iᵀ + O_i) B,
where for BCLS (compensated) O_i = k²(kθ₂)²(32V⁴σ⁴ + 96V²σ⁶ + 24σ⁸) e₂e₂ᵀ
− k(kθ₂)²·8V²σ⁴ (x_i e₂ᵀ + e₂ x_iᵀ) and for OLS O_i = 0 (docs/model.md#compensated-sandwich).
"d" is ln det of the covariance, "a" Σ_j Cov_jj/θ_j², a parameter's Cov_jj/θ_j².

    python analysis/designed_drive.py RUN_DIR [--check]

With --check the exit status is 1 when a limit is broken or the criteria differ by more than
1e-9 relative (both sides sum the same 60 001 products in a different order, ~1e-13; the
determinant of a covariance of condition ~1e4 amplifies that to ~1e-12 at most).
"""

import argparse
import pathlib
import sys

import numpy as np
import pyarrow.parquet as pq

from common import PARAMETERS, check_output_set, study_of, truth

TOLERANCE = 1e-9


def covariance(rows, study):
    vehicle = study["vehicle"]
    k = 0.5 * vehicle["air_density"] * vehicle["frontal_area"]
    g = vehicle["gravity"]
    theta = np.array(list(truth(study).values()))
    noise = study["noise"]
    for key, value in noise.items():
        if key.endswith("_sd") and key != "velocity_sd" and any(v != 0 for v in np.atleast_1d(value)):
            sys.exit(f"designed_drive.py: noise.{key} is not handled (white speed noise only)")
    (sigma,) = np.atleast_1d(noise["velocity_sd"])
    estimation = study.get("estimation", {})
    if estimation.get("acceleration", ["model"]) not in (["model"], "model"):
        sys.exit("designed_drive.py: only a model acceleration is handled")
    v = rows["v"].to_numpy()
    x = np.column_stack([rows["f_prop"].to_numpy(), -k * v * v, -g * np.cos(rows["grade"].to_numpy())])
    s2 = sigma * sigma
    omega = theta[1] ** 2 * k * k * (4 * v * v * s2 + 2 * s2 * s2)
    meat = (x * omega[:, None]).T @ x
    estimator = study["drive"].get("estimator", estimation["estimators"][0])
    if estimator == "bcls":
        a2 = (k * theta[1]) ** 2
        var_q = 32 * v**4 * s2 * s2 + 96 * v * v * s2**3 + 24 * s2**4
        meat[1, 1] += np.sum(k * k * a2 * var_q)
        cross = np.sum((k * a2 * 8 * v * v * s2 * s2)[:, None] * x, axis=0)  # Σ c_i x_i
        meat[1, :] -= cross
        meat[:, 1] -= cross
    elif estimator != "ols":
        sys.exit(f"designed_drive.py: estimator {estimator} is not handled (bcls, ols)")
    bread = np.linalg.inv(x.T @ x)
    return bread @ meat @ bread, theta


def dynamics(trace, cycles, study):
    """The trace against the vehicle's equation and the zero-order hold (see the docstring)."""
    vehicle, drive = study["vehicle"], study["drive"]
    m, g = vehicle["mass"], vehicle["gravity"]
    k = 0.5 * vehicle["air_density"] * vehicle["frontal_area"]
    gear = vehicle["final_drive_ratio"] / vehicle["wheel_radius"]
    t, v, f, a, th = (trace[c].to_numpy() for c in ("t", "v", "f_prop", "accel", "grade"))
    problems = []
    checks = {
        "force = torque R_fd / r_wheel": np.max(np.abs(f - trace["torque"].to_numpy() * gear)) / np.max(np.abs(f)),
        "acceleration = the equation": np.max(np.abs(a - (f - vehicle["drag_coefficient"] * k * v * v
                                                           - vehicle["rolling_resistance"] * m * g * np.cos(th)
                                                           - m * g * np.sin(th)) / m)) / np.max(np.abs(a)),
        "trace = cycles.parquet": max(np.max(np.abs(trace[c].to_numpy() - cycles[c].to_numpy()))
                                      for c in ("t", "v", "grade", "f_prop", "accel")),
    }
    h = drive["time_step"]
    left = a[1:] - (f[1:] - f[:-1]) / m
    step_error = np.max(np.abs(np.diff(v) - 0.5 * h * (a[:-1] + left)))
    for name, value in checks.items():
        print(f"{name}: largest relative difference {value:.2e}")
        if value > 1e-12:
            problems.append(f"{name} differs by {value:.2e}")
    print(f"speed steps against the trapezoid of the held torque: largest {step_error:.2e} m/s")
    if step_error > 1e-6:
        problems.append(f"a speed step differs from the held torque's by {step_error:.2e} m/s")
    return problems


def criterion(cov, theta, name):
    if name == "d":
        return np.linalg.slogdet(cov)[1]
    rel = np.diag(cov) / theta**2
    if name == "a":
        return rel.sum()
    return rel[PARAMETERS.index(name)]


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("run_dir")
    parser.add_argument("--check", action="store_true", help="exit 1 beyond 1e-9 relative or a broken limit")
    args = parser.parse_args()
    run = pathlib.Path(args.run_dir)
    check_output_set(run)
    study = study_of(run)
    drive = study["drive"]
    if drive.get("mode") != "designed" or study.get("estimation", {}).get("known_mass", False):
        sys.exit("designed_drive.py: a run of a designed drive with every parameter fitted is needed")
    trace = pq.read_table(run / "designed_drive.parquet").to_pandas()
    broken = []
    for column, lo, hi in (("v", drive["speed_min"], drive["speed_max"]),
                           ("torque", drive["torque_min"], drive["torque_max"])):
        outside = int(((trace[column] < lo) | (trace[column] > hi)).sum())
        print(f"{column}: {trace[column].min():.6f} … {trace[column].max():.6f} within [{lo}, {hi}]: "
              f"{len(trace) - outside} of {len(trace)} samples")
        if outside:
            broken.append(f"{outside} samples of {column} outside [{lo}, {hi}]")
    cycles = pq.read_table(run / "cycles.parquet").to_pandas()
    broken += dynamics(trace, cycles, study)
    rows = cycles[cycles["used"]]
    cov, theta = covariance(rows, study)
    ours = criterion(cov, theta, drive["criterion"])
    design = pq.read_table(run / "drive_design.parquet").to_pandas().set_index("drive")
    engine = design.loc["designed", "criterion_value"]
    diff = abs(ours - engine) / abs(engine)
    print(f"criterion {drive['criterion']}: engine {engine!r}, NumPy {ours!r}, relative difference {diff:.2e}")
    for p, j in zip(PARAMETERS, range(3)):
        se = np.sqrt(cov[j, j]) / abs(theta[j])
        engine_se = design.loc["designed", f"rel_se_{p}"]
        print(f"  SE/|θ| of {p}: engine {engine_se:.10e}, NumPy {se:.10e}")
    print(design[["criterion_value", "rel_se_inv_mass", "rel_se_drag_over_mass",
                  "rel_se_rolling_resistance", "governed_fraction"]].to_string())
    if args.check:
        if diff > TOLERANCE:
            broken.append(f"the criterion differs by {diff:.2e} relative (> {TOLERANCE})")
        if broken:
            sys.exit("designed_drive.py: " + "; ".join(broken))
        print(f"designed_drive.py: limits held, criterion within {TOLERANCE} relative")


if __name__ == "__main__":
    main()
