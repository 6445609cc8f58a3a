#!/usr/bin/env python3
"""Coast-down campaign: an independent NumPy Monte Carlo of the EU 70/220/EEC pass probability.

For every condition of a run of a coast-down campaign study (studies/coastdown_campaign.toml),
this script simulates R realisations of the campaign with its own code and its own random
numbers (numpy.random.default_rng) and checks that its share of passing campaigns agrees with
the engine's `pass_probability` (summary.parquet): |p_engine − p_NumPy| ≤ 3·√(MCSE_e² +
MCSE_n²), MCSE = √(p(1 − p)/R) on each side (the engine's formula). Tolerance: the two Monte
Carlos share no random numbers, so their difference has mean 0 and SD the combined MCSE when
both are right; by the normal approximation |z| > 3 has probability ≈ 0.0027 per condition
(≤ 0.05 over 18 conditions by a union bound). A side at p = 0 or 1 has MCSE 0, so a condition
with a pass probability of a few 1/R can fail by chance; read such a z with its p's. The
median of `campaign_precision` (realisations.parquet) beside NumPy's is a diagnostic only.
Exit status: 0 agreement, 1 a disagreement (or a failed realisation), 2 a bad run directory.

Independent: no engine code runs; the script reads the study TOML, summary.parquet's axes and
pass probabilities, realisations.parquet's `campaign_precision` (diagnostic) and, for its
self-check only, cycles.parquet. Its model, from docs/model.md ("The coast-down drive mode",
"Model errors"; no engine source):
- flat road, no propulsion: M dV/dt = −k Cd (V + w)|V + w| − Cr M g, k = ½ρA; w = h_r w_s + g(t),
  w_s the steady headwind, run r's heading h_r = +1 (even r), −1 (odd r, "alternate");
- run r starts at V = speed_high; one classical RK4 step of Δt after each sample; a step
  that brings V below speed_low ends the run unrecorded; the gust g is run r's own AR(1)
  series at its samples (g₀ = σ_w z₀, g_i = φ g_{i−1} + σ_w √(1 − φ²) z_i, φ = e^(−Δt/τ)),
  linear between them (RK4's half-step stages read the mean of the two samples);
- rows: every sample with V ≥ drive.min_speed (default 0) except, for a differentiated
  acceleration, each run's first and last; each row's speed is measured as Ṽ = V + σ_v e;
- a run's time in interval v_j ± Δv: from Ṽ's first crossing (over rows) of v_j + Δv to its
  first of v_j − Δv, each interpolated linearly between the last row above and the first at
  or below the level; NaN if the first row is already at or below v_j + Δv or Ṽ never falls
  to v_j − Δv; a condition with n runs uses runs 0 … n−1 of one 16-run simulation;
- a campaign passes iff n ≥ min_runs, every time is finite and max_j t₀.₉₇₅,ₙ₋₁ s_j/(√n T̄_j)
  ≤ precision (s_j with ddof = 1).
Self-check: with σ_w = 0 its trajectory equals the engine's noise-free cycle (cycles.parquet).
Measured (engine R = 2000, seed 7; NumPy R = 2000): largest |z| 1.89, ~45 s on 2 shared cores.
What it catches (NumPy variants against that run): a steady wind not alternating, |z| 45; σ_v
×1.25, |z| 20; τ ×2, |z| 3.9 (just); each run's first and last rows kept, nothing (|z| ≤ 1.5).

    python analysis/campaign_check.py RUN_DIR [--study studies/coastdown_campaign.toml]
"""

import argparse
import math
import pathlib
import sys
import time
import tomllib

import numpy as np
import pyarrow.parquet as pq

from common import fail, study_of

ROOT = pathlib.Path(__file__).resolve().parent.parent
Z_MAX = 3.0
MAX_RUN_S = 3600.0  # a run not slowed to speed_low by then is an error (both sides)
CYCLE_TOL = 1e-9  # m/s: the same RK4 steps in float64, differing only in rounding
T975 = {3: 3.182446305284263, 7: 2.3646242510102993, 15: 2.131449545559323}


def t975(dof):
    try:
        from scipy.stats import t
        return float(t.ppf(0.975, dof))
    except ImportError:
        return T975[dof]


class Campaign:
    """The study's constants that the motion and the criterion need."""

    def __init__(self, study):
        veh, drive, est = study["vehicle"], study["drive"], study["estimation"]
        truth, camp, noise = study.get("truth", {}), study["campaign"], study["noise"]
        assert drive["mode"] == "coastdown" and "terrain" not in study
        assert camp.get("criterion", "eu_70_220") == "eu_70_220"
        assert set(truth) <= {"wind_speed", "wind_gust_sd", "wind_gust_time"}, truth
        assert set(noise) <= {"velocity_sd", "output_sd"}, f"unmodelled noise: {noise}"
        self.m, self.g, self.cd = veh["mass"], veh["gravity"], veh["drag_coefficient"]
        self.crmg = veh["rolling_resistance"] * self.m * self.g
        self.kcd = 0.5 * veh["air_density"] * veh["frontal_area"] * self.cd
        self.v_high, self.v_low = drive["speed_high"], drive["speed_low"]
        self.h = drive["time_step"]
        self.min_speed = drive.get("min_speed", 0.0)
        self.alternate = drive.get("directions", "alternate") == "alternate"
        self.differentiated = est.get("acceleration", "model") == "differentiated"
        self.tau = truth.get("wind_gust_time")
        speeds, dv = np.array(camp["speeds"]), camp["half_width"]
        self.upper, self.lower = speeds + dv, speeds - dv
        self.precision = camp.get("precision", 0.02)
        self.min_runs = camp.get("min_runs", 4)

    def trajectories(self, runs, count, wind, gust, rng):
        """Noise-free V of `count` realisations × `runs` runs: (count·runs, samples), NaN
        after each run's last sample."""
        h, hh = self.h, 0.5 * self.h
        heading = np.where((np.arange(runs) % 2 == 1) & self.alternate, -1.0, 1.0)
        steady = np.tile(heading * wind, count)
        e = count * runs
        phi = math.exp(-h / self.tau) if gust > 0 else 0.0
        innovation = gust * math.sqrt(1.0 - phi * phi)

        def accel(v, w):
            air = v + steady + w
            return -(self.kcd * air * np.abs(air) + self.crmg) / self.m

        v = np.full(e, self.v_high)
        w = gust * rng.standard_normal(e)
        alive = np.ones(e, dtype=bool)
        out = []
        for i in range(round(MAX_RUN_S / h) + 2):
            if i * h > MAX_RUN_S:
                raise RuntimeError(f"a run has not slowed to speed_low in {MAX_RUN_S} s")
            out.append(np.where(alive, v, np.nan))
            a1 = accel(v, w)
            w1 = phi * w + innovation * rng.standard_normal(e)
            wm = 0.5 * (w + w1)
            a2 = accel(v + hh * a1, wm)
            a3 = accel(v + hh * a2, wm)
            a4 = accel(v + h * a3, w1)
            v_next = v + h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
            alive &= v_next >= self.v_low
            if not alive.any():
                return np.stack(out, axis=1)
            v, w = np.where(alive, v_next, v), w1

    def times(self, v, sigma, rng):
        """Each run's coast-down time per interval, (runs, intervals), from its noise-free
        trajectory v (runs, samples) measured with white noise of SD sigma."""
        idx = np.arange(v.shape[1])
        valid = ~np.isnan(v)
        last = valid.sum(axis=1, keepdims=True) - 1
        row = valid & (v >= self.min_speed)
        if self.differentiated:
            row &= (idx >= 1) & (idx < last)
        measured = np.where(row, v + sigma * rng.standard_normal(v.shape), np.inf)
        first_row = row.argmax(axis=1)
        # Rows are contiguous (V falls monotonically), so the first row at or below a level,
        # if not the run's first row, follows a row above it: the running minimum finds it.
        running_min = np.minimum.accumulate(measured, axis=1)

        def crossing(level):
            i = (running_min > level[:, None, None]).sum(axis=2).T  # (runs, intervals)
            ok = (i > first_row[:, None]) & (i < v.shape[1])
            i = np.where(ok, i, 1)
            a = np.take_along_axis(measured, i - 1, axis=1)
            b = np.take_along_axis(measured, i, axis=1)
            return np.where(ok, self.h * ((i - 1) + (a - level) / (a - b)), np.nan)

        return crossing(self.lower) - crossing(self.upper)

    def precision_of(self, t):
        """max_j p_j per realisation from times (realisations, n runs, intervals); inf if a
        time is missing."""
        n = t.shape[1]
        p = t975(n - 1) * t.std(axis=1, ddof=1) / (math.sqrt(n) * t.mean(axis=1))
        return np.where(np.isnan(p).any(axis=1), np.inf, p.max(axis=1))


def self_check(c, run_dir, conditions):
    """NumPy's noise-free cycle (σ_w = 0) against the engine's cycles.parquet."""
    cycles = pq.read_table(run_dir / "cycles.parquet",
                           columns=["wind_speed", "wind_gust_sd", "run", "v"]).to_pandas()
    worst = 0.0
    for wind in sorted(set(conditions["wind_speed"])):
        engine = cycles[(cycles["wind_speed"] == wind)
                        & (cycles["wind_gust_sd"] == cycles["wind_gust_sd"].iloc[0])]
        runs = engine["run"].max() + 1
        mine = c.trajectories(runs, 1, wind, 0.0, np.random.default_rng(0))
        for r in range(runs):
            ours, theirs = mine[r][~np.isnan(mine[r])], engine[engine["run"] == r]["v"].to_numpy()
            assert len(ours) == len(theirs), f"wind {wind}, run {r}: {len(ours)} ≠ {len(theirs)}"
            worst = max(worst, np.abs(ours - theirs).max())
    print(f"self-check: NumPy's calm cycle against cycles.parquet: samples per run equal, "
          f"max |ΔV| = {worst:.1e} m/s (≤ {CYCLE_TOL:g})")
    assert worst <= CYCLE_TOL


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run_dir", type=pathlib.Path, help="a run of the campaign study")
    ap.add_argument("--study", type=pathlib.Path,
                    default=ROOT / "studies" / "coastdown_campaign.toml")
    ap.add_argument("--realisations", type=int, default=2000, help="NumPy's R")
    ap.add_argument("--seed", type=int, default=20261206, help="NumPy's seed")
    args = ap.parse_args()
    study = tomllib.loads(args.study.read_text())
    footer = study_of(args.run_dir)
    for key in ["vehicle", "drive", "noise", "estimation", "truth", "campaign"]:
        ours, run = study.get(key, {}), footer.get(key, {})  # the footer adds zero defaults
        if any(ours.get(k) != v and not (k not in ours and v in (0, [0])) for k, v in run.items()) \
                or not set(ours) <= set(run):
            fail(f"[{key}] of {args.study} differs from the study of {args.run_dir}")
    c = Campaign(study)
    summary = pq.read_table(args.run_dir / "summary.parquet").to_pandas()
    axes = ["runs", "wind_speed", "wind_gust_sd", "velocity_sd"]
    cols = axes + ["pass_probability", "pass_probability_mcse", "n", "n_failed"]
    assert (summary.groupby("condition")[cols].nunique() == 1).all().all()
    conditions = summary.groupby("condition")[cols].first()
    real = pq.read_table(args.run_dir / "realisations.parquet",
                         columns=["condition", "estimator", "campaign_precision"]).to_pandas()
    assert (real.groupby(["condition", "estimator"])["campaign_precision"].median()
            .groupby("condition").nunique() == 1).all()
    engine_median = real.groupby("condition")["campaign_precision"].median()
    self_check(c, args.run_dir, conditions)

    rng, r_n = np.random.default_rng(args.seed), args.realisations
    chunk = max(1, 2000 // int(conditions["runs"].max()))  # ~30 MB per (runs × samples) array
    clock = time.perf_counter()
    rows, failures = [], []
    for (wind, gust, sigma), group in conditions.groupby(
            ["wind_speed", "wind_gust_sd", "velocity_sd"]):
        runs = int(group["runs"].max())
        t = np.concatenate([
            c.times(c.trajectories(runs, min(chunk, r_n - s), wind, gust, rng), sigma, rng)
            .reshape(-1, runs, len(c.upper)) for s in range(0, r_n, chunk)])
        for cond, e in group.iterrows():
            n = int(e["runs"])
            prec = c.precision_of(t[:, :n]) if n >= c.min_runs else np.full(r_n, np.inf)
            p = float(np.mean(prec <= c.precision))
            mcse = math.sqrt(p * (1.0 - p) / r_n)
            pe, me = e["pass_probability"], e["pass_probability_mcse"]
            combined = math.hypot(me, mcse)
            z = (pe - p) / combined if combined > 0 else (0.0 if pe == p else math.inf)
            if abs(z) > Z_MAX or e["n_failed"] > 0:
                failures.append(f"condition {cond}: z = {z:+.2f}, "
                                f"n_failed = {int(e['n_failed'])}")
            rows.append((cond, n, wind, gust, sigma, pe, me, p, mcse, z,
                         engine_median[cond], np.median(prec)))
    numpy_s = time.perf_counter() - clock

    print(f"\n{'cond':>4} {'runs':>4} {'wind':>5} {'gust':>5} {'σ_v':>5}  "
          f"{'engine p ± MCSE':>17}  {'NumPy p ± MCSE':>17}  {'z':>6}  "
          f"{'median max p_j: engine':>22} {'NumPy':>7}")
    for cond, n, wind, gust, sigma, pe, me, p, mcse, z, med_e, med_n in sorted(rows):
        print(f"{cond:>4} {n:>4} {wind:>5.2f} {gust:>5.2f} {sigma:>5.3f}  {pe:>7.4f} ± {me:.4f}"
              f"  {p:>7.4f} ± {mcse:.4f}  {z:>+6.2f}  {med_e:>22.5f} {med_n:>7.5f}")
    print(f"engine R = {int(conditions['n'].iloc[0])}, NumPy R = {r_n} (seed {args.seed}, "
          f"{numpy_s:.1f} s); agreement: |z| ≤ {Z_MAX:g}, "
          "z = (engine − NumPy)/√(MCSE² + MCSE²)")
    if failures:
        print("the engine and NumPy disagree: " + "; ".join(failures))
        sys.exit(1)
    print("campaign: the engine's pass probabilities agree with an independent NumPy Monte Carlo")


if __name__ == "__main__":
    main()
