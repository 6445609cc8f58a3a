#!/usr/bin/env python3
"""Coast-down: an independent NumPy Monte Carlo of the road_load analysis against the engine.

A coast-down (`drive.mode = "coastdown"`, docs/model.md#coastdown) analysed by `road_load`
(docs/model.md#road-load) with the mass known (docs/model.md#known-mass). This script
simulates it with its own code and its own random numbers (numpy.random.default_rng) from
the study's parameters alone: studies/coastdown.toml with white speed noise σ_v = 0.2 m/s,
the model acceleration (`estimation.acceleration = "model"`, `output_sd = 0`), estimator
road_load, R = 2000. It runs the engine on the same study and checks, for Cd/M and Cr (the
engine's summary.parquet: `mean`, `emp_se` and their MCSEs) and for the fitted A, B, C (the
engine's realisations.parquet, `road_load_a/b/c`: mean and SD computed here), that the two
Monte Carlo means and the two SDs agree within 4 combined MCSEs:
|engine − NumPy| ≤ 4·√(MCSE_engine² + MCSE_NumPy²), the MCSE of a mean s/√R and of an SD
s/√(2(R−1)) (the engine's own formulas). No expected value is written here: each side's
expected value is the other side's Monte Carlo estimate of the same quantity (the mean or
SD of the estimator over the noise), both unbiased for it (the SD to O(1/R)), so their
difference has mean 0 and SD the combined MCSE. The two runs share no random numbers, so
the two estimates are independent and, as averages over R = 2000 realisations, close to
normal. Why 4: when both sides are right a |z| beyond 4 has probability ≈ 6e-5 per
comparison and ≤ 6e-4 over the 10 here (a union bound; Cd/M and Cr are C and A rescaled),
against ≈ 3e-3 per comparison at 3 — a failure in CI is then a finding, not noise. What
that tolerance can miss (measured in NumPy with paired draws, README): σ_v off by 10 %
moves the SDs and C's mean by ~1.1–1.3 tolerances, so it is caught only about half the
time; a B column read from the noise-free V moves the means by > 100 tolerances, the same
noise repeated in every run the SDs by ~20.

The NumPy model, written from docs/model.md (not from the engine's code paths):
- the flat road in calm air: M dV/dt = −k Cd V² − Cr M g, k = ½ρA_f, dX/dt = heading·V;
- run k starts at V = speed_high, X = start_distance + k·spacing (spacing: the distance run
  0 covers, unless given), heading −1 for odd k with directions "alternate"; one classical
  RK4 step of Δt = time_step after each sample; a step that brings V below speed_low ends
  the run unrecorded, so a run's last sample is the last with V ≥ speed_low; the runs lie
  end to end on one clock, t_i = i·Δt over the whole cycle;
- each realisation measures Ṽ_i = V_i + σ_v e_i (e_i independent N(0, 1)) at every sample;
  the acceleration a_i is the model's (noise-free); every sample is a row;
- road_load: F_RL,i = F_i − M(1 + δ̂) a_i − M g sin θ_i (here F = 0, θ = 0, δ̂ =
  `estimation.effective_mass_factor`, default 0), fitted by least squares as A + B·V + C·V²
  with V = |Ṽ_i| over all rows of all runs, by a Householder QR of [1, V, V², F_RL] per
  realisation (no normal equations); Cd/M = C/(kM), Cr = A/(Mg).

Self-checks of the NumPy code (one extra realisation with σ_v = 0 fitted alongside): its
fit gives A = Cr M g, C = k Cd within 1e-9 relative and |B| ≤ 1e-9 A, and its cycle equals
the engine's noise-free cycle (cycles.parquet: samples per run, t, X, V, dV/dt) to rounding.
Those are the only things read from cycles.parquet; the NumPy Monte Carlo reads none of the
engine's output.

    cargo build --release && python analysis/coastdown_check.py
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
COASTDOWN = ROOT / "studies" / "coastdown.toml"
PARAMETERS = ["drag_over_mass", "rolling_resistance"]
SYMBOL = {"drag_over_mass": "Cd/M", "rolling_resistance": "Cr"}
COEFFICIENTS = ["road_load_a", "road_load_b", "road_load_c"]
COEFFICIENT_SYMBOL = {"road_load_a": "A", "road_load_b": "B", "road_load_c": "C"}

# σ_v [m/s]: at R = 2000 the SDs are measured to 1/√(2(R−1)) = 1.6 %, and C's
# errors-in-variables bias (−6.4e-4 N·s²/m², 0.8 of its SD) is ~35 MCSEs from zero.
SPEED_SD = 0.2
Z_MAX = 4.0  # agreement: |difference| ≤ 4 combined MCSEs
# The noise-free fit: F_RL = k Cd V² + Cr M g holds at every row to rounding (~1e-16
# relative), and a Householder QR solves it with an error ≲ κ([1, V, V²])·1e-16 relative;
# κ is ~1e4 for V in [8.3, 33.3] m/s, so 1e-9 leaves a margin of ~1e3.
SELF_TOL = 1e-9
# The noise-free cycle against the engine's: the same RK4 steps in float64, differing only
# in the order of operations (≤ a few ulp per step). The dynamics are damped (∂a/∂V =
# −2kCdV/M < 0), so per-step differences of ~1e-15 relative do not grow: over a run's
# ~1.3e3 steps they stay below ~1.3e3 · 1e-15 · 33 m/s ≈ 4e-11 m/s (dV/dt: times
# |∂a/∂V| ≤ 0.02 /s); X sums steps of ≤ 3.4 m to positions ≤ ~2e4 m, each rounded to
# ≤ 4e-12 m, over the cycle's ~1e4 steps: ≤ 4e-8 m. t_i = i·Δt on both sides. Bounds are set
# well above (V to the 1e-9 the engine's own RK4 test reaches against the closed form).
CYCLE_TOL = {"t": 1e-12, "x": 1e-6, "v": 1e-9, "accel": 1e-9}
MAX_RUN_S = 3600.0  # a run that has not slowed to speed_low by then is an error (both sides)


def study_text(realisations):
    """studies/coastdown.toml with σ_v = SPEED_SD, the model acceleration, no output noise,
    road_load only, R realisations."""
    lines = []
    for line in COASTDOWN.read_text().splitlines():
        if line.startswith("realisations ="):
            line = f"realisations = {realisations}"
        elif line.startswith("velocity_sd ="):
            line = f"velocity_sd = [{SPEED_SD}]"
        elif line.startswith("output_sd ="):
            line = "output_sd = [0.0]"
        elif line.startswith("estimators ="):
            line = 'estimators = ["road_load"]\nacceleration = "model"'
        lines.append(line)
    return "\n".join(lines) + "\n"


def run_engine(text, tmp):
    """The engine's summary (per parameter), road_load's realisations and its cycle."""
    study = tmp / "coastdown.toml"
    study.write_text(text)
    out = tmp / "coastdown"
    subprocess.run([BINARY, "run", study, "--out", out, "--quiet", "--no-figures"], check=True)
    summary = pq.read_table(out / "summary.parquet").to_pandas()
    summary = summary[summary["estimator"] == "road_load"].set_index("parameter")
    realisations = pq.read_table(out / "realisations.parquet",
                                 columns=["estimator", "status", *COEFFICIENTS]).to_pandas()
    realisations = realisations[realisations["estimator"] == "road_load"]
    cycle = pq.read_table(out / "cycles.parquet",
                          columns=["run", "t", "x", "v", "grade", "f_prop", "accel", "used"])
    return summary, realisations, cycle.to_pandas()


class CoastDown:
    """The constants of the study that the coast-down and its analysis need."""

    def __init__(self, study):
        veh, drive, noise = study["vehicle"], study["drive"], study["noise"]
        est = study["estimation"]
        # What this model covers: a flat road, calm air, white speed noise only, the model
        # acceleration, the mass known.
        assert drive["mode"] == "coastdown" and "terrain" not in study and "truth" not in study
        assert est["known_mass"] and est.get("acceleration", "model") == "model"
        assert noise["output_sd"] == [0.0] and "velocity_correlation_time" not in noise
        assert set(noise) == {"velocity_sd", "output_sd"}, f"unmodelled noise: {noise}"
        (self.sigma,) = noise["velocity_sd"]
        self.m = veh["mass"]
        self.cd = veh["drag_coefficient"]
        self.cr = veh["rolling_resistance"]
        self.g = veh["gravity"]
        self.k = 0.5 * veh["air_density"] * veh["frontal_area"]
        self.delta = est.get("effective_mass_factor", 0.0)
        self.v_high = drive["speed_high"]
        self.v_low = drive["speed_low"]
        runs = drive["runs"]
        self.runs = max(runs) if isinstance(runs, list) else runs
        self.h = drive["time_step"]
        self.start = drive.get("start_distance", 0.0)
        self.spacing = drive.get("run_spacing")
        self.directions = drive.get("directions", "alternate")
        # Noise-free: F_RL = k Cd V² + Cr M g, so A = Cr M g, B = 0, C = k Cd.
        self.abc = np.array([self.cr * self.m * self.g, 0.0, self.k * self.cd])

    def accel(self, v):
        """dV/dt on a flat road in calm air with no propulsion."""
        return -(self.k * self.cd * v * v + self.cr * self.m * self.g) / self.m

    def cycle(self):
        """The noise-free cycle: arrays run, t, x, v, accel over every run, end to end."""
        h, accel = self.h, self.accel
        out = {key: [] for key in ["run", "t", "x", "v", "accel"]}
        spacing, i = self.spacing, 0
        for k in range(self.runs):
            heading = -1.0 if self.directions == "alternate" and k % 2 == 1 else 1.0
            x = self.start + k * (spacing or 0.0)
            v, first = self.v_high, len(out["x"])
            for j in range(round(MAX_RUN_S / h) + 2):
                if j * h > MAX_RUN_S:
                    raise RuntimeError(f"run {k} has not slowed to speed_low in {MAX_RUN_S} s")
                a = accel(v)
                for key, value in [("run", k), ("t", i * h), ("x", x), ("v", v), ("accel", a)]:
                    out[key].append(value)
                i += 1
                k2v = accel(v + 0.5 * h * a)
                k3v = accel(v + 0.5 * h * k2v)
                k4v = accel(v + h * k3v)
                x_next = x + h / 6.0 * heading * (
                    v + 2.0 * (v + 0.5 * h * a) + 2.0 * (v + 0.5 * h * k2v) + (v + h * k3v))
                v_next = v + h / 6.0 * (a + 2.0 * k2v + 2.0 * k3v + k4v)
                if v_next < self.v_low:
                    break
                x, v = x_next, v_next
            if spacing is None:
                spacing = abs(out["x"][-1] - out["x"][first])
        return {key: np.array(values) for key, values in out.items()}

    def road_load(self, cycle, sigma, rng, block=50):
        """The road_load fit of one realisation per entry of `sigma` (its speed noise's SD):
        rows (realisations × 5) of A, B, C, Cd/M, Cr."""
        v, a = cycle["v"], cycle["accel"]
        f, sin_theta = 0.0, 0.0  # no propulsion force, flat road
        force = f - self.m * (1.0 + self.delta) * a - self.m * self.g * sin_theta
        abc = np.empty((len(sigma), 3))
        for start in range(0, len(sigma), block):
            s = sigma[start:start + block, None]
            speed = np.abs(v + s * rng.standard_normal((len(s), len(v))))
            rows = np.stack([np.ones_like(speed), speed, speed * speed,
                             np.broadcast_to(force, speed.shape)], axis=-1)
            r = np.linalg.qr(rows, mode="r")
            abc[start:start + block] = np.linalg.solve(r[:, :3, :3], r[:, :3, 3:]).squeeze(-1)
        return np.column_stack([abc, abc[:, 2] / (self.k * self.m),
                                abc[:, 0] / (self.m * self.g)])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--realisations", type=int, default=2000)
    ap.add_argument("--seed", type=int, default=20261202, help="NumPy's seed")
    args = ap.parse_args()
    if not BINARY.exists():
        sys.exit(f"{BINARY} not found: run `cargo build --release` first")
    r = args.realisations
    text = study_text(r)

    clock = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        engine, engine_abc, engine_cycle = run_engine(text, pathlib.Path(tmp))
    engine_s = time.perf_counter() - clock

    clock = time.perf_counter()
    cd = CoastDown(tomllib.loads(text))
    cycle = cd.cycle()
    sigma = np.full(r + 1, cd.sigma)
    sigma[0] = 0.0  # realisation 0: noise-free, for the self-check
    fits = cd.road_load(cycle, sigma, np.random.default_rng(args.seed))
    numpy_s = time.perf_counter() - clock
    print(f"coast-down ({cd.runs} runs, {cd.v_high} → {cd.v_low} m/s, Δt = {cd.h} s, "
          f"{len(cycle['t'])} rows), σ_v = {cd.sigma} m/s, road_load, R = {r}: "
          f"engine {engine_s:.1f} s, NumPy {numpy_s:.1f} s")

    # Self-checks of the NumPy code.
    rel = np.abs(fits[0, :3] - cd.abc) / cd.abc[0]
    rel[2] = abs(fits[0, 2] / cd.abc[2] - 1.0)
    print(f"  NumPy at σ_v = 0: |A/(Cr M g) − 1| = {rel[0]:.1e}, |B|/A = {rel[1]:.1e}, "
          f"|C/(k Cd) − 1| = {rel[2]:.1e} (each ≤ {SELF_TOL:g})")
    assert rel.max() <= SELF_TOL, f"NumPy's noise-free A, B, C {fits[0, :3]} are not {cd.abc}"
    counts = np.bincount(cycle["run"], minlength=cd.runs)
    engine_counts = engine_cycle.groupby("run").size().reindex(range(cd.runs)).to_numpy()
    print(f"  samples per run: NumPy {counts.tolist()}, engine {engine_counts.tolist()}")
    assert (counts == engine_counts).all(), "the runs' sample counts differ"
    assert (engine_cycle["run"].to_numpy() == cycle["run"]).all()
    assert engine_cycle["used"].all(), "the engine leaves rows out: NumPy fits every sample"
    assert (engine_cycle["grade"] == 0).all() and (engine_cycle["f_prop"] == 0).all()
    for key, tol in CYCLE_TOL.items():
        d = np.abs(cycle[key] - engine_cycle[key].to_numpy()).max()
        print(f"  NumPy at σ_v = 0 against the engine's cycles.parquet: max |Δ{key}| = {d:.1e} "
              f"(≤ {tol:g})")
        assert d <= tol, f"NumPy's noise-free {key} differs from the engine's by {d:.3e}"
    assert (engine["n_failed"] == 0).all() and (engine["n"] == r).all(), engine[["n", "n_failed"]]
    assert len(engine_abc) == r and (engine_abc["status"] == "ok").all()

    # The comparison: Cd/M and Cr from the engine's summary, A, B, C from its realisations.
    numpy_columns = dict(zip(COEFFICIENTS + PARAMETERS, fits[1:].T))
    compared = []
    for p in PARAMETERS:
        e = engine.loc[p]
        compared.append((SYMBOL[p], (e["mean"], e["mean_mcse"], e["emp_se"], e["emp_se_mcse"]),
                         numpy_columns[p]))
    for c in COEFFICIENTS:
        compared.append((COEFFICIENT_SYMBOL[c], mc_summary(engine_abc[c].to_numpy()),
                         numpy_columns[c]))
    failures, rows = [], []
    for sym, (em, em_se, es, es_se), estimates in compared:
        nm, nm_se, ns, ns_se = mc_summary(estimates)
        for what, ev, emc, nv, nmc in [("mean", em, em_se, nm, nm_se),
                                       ("SD", es, es_se, ns, ns_se)]:
            z = (ev - nv) / math.hypot(emc, nmc)
            rows.append((sym, what, ev, emc, nv, nmc, z))
            if abs(z) > Z_MAX:
                failures.append(f"{sym} {what}: z = {z:+.2f}")
    print(f"\n  {'':<5} {'':<4} {'engine ± MCSE':>21}   {'NumPy ± MCSE':>21}   {'z':>5}")
    for sym, what, ev, em, nv, nm, z in rows:
        print(f"  {sym:<5} {what:<4} {ev:>11.4e} ± {em:.1e}   {nv:>11.4e} ± {nm:.1e}"
              f"   {z:>+5.2f}")
    print(f"  truth: Cd/M = {cd.cd / cd.m:.4e}, Cr = {cd.cr:.4e}, A = {cd.abc[0]:.4e} N, B = 0, "
          f"C = {cd.abc[2]:.4e} N·s²/m²; agreement: |z| ≤ {Z_MAX:g}, "
          "z = (engine − NumPy)/√(MCSE² + MCSE²)")
    # The SD's MCSE s/√(2(R−1)) assumes normal estimates; their excess kurtosis says how
    # far that holds (it scales that MCSE by about √(1 + excess/2)).
    centred = fits[1:] - fits[1:].mean(axis=0)
    excess = (centred**4).mean(axis=0) / (centred**2).mean(axis=0) ** 2 - 3.0
    print("  NumPy estimates' excess kurtosis: " + ", ".join(
        f"{s} {k:+.2f}" for s, k in zip(["A", "B", "C", "Cd/M", "Cr"], excess)))
    assert not failures, "the engine and NumPy disagree: " + "; ".join(failures)
    print("coast-down: the engine's road_load Monte Carlo agrees with an independent NumPy one")


if __name__ == "__main__":
    main()
