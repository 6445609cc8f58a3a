//! The drive mode `coastdown` (SAE J2263): the vehicle coasts in neutral, no propulsion and
//! no braking, from `speed_high` down to `speed_low`, several runs, alternating direction
//! along the route (docs/model.md#coastdown).
//!
//! Each run is integrated by classical fixed-step RK4 at the sample step, as the `torque`
//! mode is, with F = 0 and the truth's dynamics; the runs are laid end to end on one clock
//! and kept apart by [`DriveCycle::run`].

use std::sync::Arc;

use super::truth::TruthSample;
use super::{CycleSource, DriveCycle, MAX_SAMPLES, Road, SimulationError, Truth, VehicleParams};
use crate::numeric::ode::{Stage, rk4_step};
use crate::settings::{KeyError, Params, one_or_many};
use crate::terrain::GradeTable;

/// The longest a coast-down run may last \[s\]: a run that has not slowed down to
/// `speed_low` after an hour of coasting is an error (a downhill grade or a tailwind
/// carries the vehicle; a car's coast-down run lasts minutes).
pub const MAX_RUN_S: f64 = 3600.0;

/// The fewest samples a run may have: enough for one row of a differentiated acceleration,
/// which needs a sample of its run on each side.
pub const MIN_RUN_SAMPLES: usize = 3;

/// Runs come in pairs, a run each way (SAE J2263): `drive.runs` is a positive whole multiple
/// of this.
pub const RUN_PAIR: usize = 2;

/// Which way the runs drive the route (`drive.directions`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Directions {
    /// Even runs forwards, odd runs backwards (the default; SAE J2263's opposite directions).
    Alternate,
    /// Every run forwards.
    OneWay,
}

impl Directions {
    /// Every value, as study files name them.
    pub const ALL: [(&'static str, Directions); 2] = [
        ("alternate", Directions::Alternate),
        ("one_way", Directions::OneWay),
    ];

    /// The heading of run `k`: +1 forwards (position growing), −1 backwards.
    pub fn heading(self, k: usize) -> f64 {
        match self {
            Directions::Alternate if k % 2 == 1 => -1.0,
            _ => 1.0,
        }
    }
}

/// The coast-down drive mode (`[drive]`; docs/model.md#coastdown).
#[derive(Debug, Clone, PartialEq)]
pub struct CoastDown {
    /// Speed at each run's first sample \[m/s\].
    pub speed_high_m_s: f64,
    /// A run's last sample is the last with V ≥ this \[m/s\].
    pub speed_low_m_s: f64,
    /// The levels of the `runs` axis: positive even numbers of runs, distinct, in study
    /// order; the cycle has the largest.
    pub runs: Vec<usize>,
    /// Sample and integration step \[s\].
    pub time_step_s: f64,
    /// Where run 0 starts along the route \[m\].
    pub start_distance_m: f64,
    /// How far along the route each run starts from the previous one's start \[m\]
    /// (`None`: the distance run 0 covers).
    pub run_spacing_m: Option<f64>,
    /// Which way the runs drive the route.
    pub directions: Directions,
}

impl CoastDown {
    /// The mode's keys of `[drive]`.
    pub const KEYS: &'static [&'static str] = &[
        "speed_high",
        "speed_low",
        "runs",
        "time_step",
        "start_distance",
        "run_spacing",
        "directions",
    ];

    /// Read `[drive]` of mode `coastdown`: `speed_high` > `speed_low` > 0, `runs` (positive
    /// even integers, an axis), `time_step`, and optionally `start_distance` (default 0),
    /// `run_spacing` (default: the distance run 0 covers) and `directions` (default
    /// "alternate").
    pub fn parse(p: &Params<'_>) -> Result<Arc<dyn CycleSource>, KeyError> {
        p.only(Self::KEYS)?;
        let speed_high_m_s = p.positive("speed_high")?;
        let speed_low_m_s = p.positive("speed_low")?;
        if speed_low_m_s >= speed_high_m_s {
            return Err(p.error(
                "speed_low",
                format!(
                    "must be below drive.speed_high ({speed_high_m_s} m/s), got {speed_low_m_s} m/s"
                ),
            ));
        }
        Ok(Arc::new(CoastDown {
            speed_high_m_s,
            speed_low_m_s,
            runs: runs(p, "runs")?,
            time_step_s: p.positive("time_step")?,
            start_distance_m: p
                .optional("start_distance", Params::non_negative)?
                .unwrap_or(0.0),
            run_spacing_m: p.optional("run_spacing", Params::non_negative)?,
            directions: p
                .optional("directions", |p, k| p.named(k, &Directions::ALL))?
                .unwrap_or(Directions::Alternate),
        }))
    }

    /// The number of runs the cycle has: the largest level of the axis.
    pub fn most_runs(&self) -> usize {
        self.runs.iter().copied().max().unwrap_or(0)
    }
}

/// The `runs` axis at `key`: a positive even integer or a non-empty list of distinct ones.
fn runs(p: &Params<'_>, key: &str) -> Result<Vec<usize>, KeyError> {
    const MAX_RUNS: i64 = (MAX_SAMPLES / MIN_RUN_SAMPLES) as i64;
    let value = p.value(key)?;
    let items = one_or_many(value);
    if items.is_empty() {
        return Err(p.error(
            key,
            "must be an even number of runs or a non-empty list of them",
        ));
    }
    let name = |i: usize| match value {
        toml::Value::Array(_) => format!("{key}[{i}]"),
        _ => key.to_string(),
    };
    let mut levels = Vec::with_capacity(items.len());
    for (i, item) in items.iter().enumerate() {
        let n = match item {
            toml::Value::Integer(n) => *n,
            other => {
                return Err(p.error(
                    &name(i),
                    format!("must be a whole number of runs, got {}", other.type_str()),
                ));
            }
        };
        if n <= 0 || n % RUN_PAIR as i64 != 0 {
            return Err(p.error(
                &name(i),
                format!(
                    "must be a positive even number of runs (a run each way per pair), got {n}"
                ),
            ));
        }
        if n > MAX_RUNS {
            return Err(p.error(
                &name(i),
                format!(
                    "is {n}; at most {MAX_RUNS} runs are supported (each has at least \
                     {MIN_RUN_SAMPLES} samples, a cycle at most {MAX_SAMPLES})"
                ),
            ));
        }
        let n = n as usize;
        if levels.contains(&n) {
            return Err(p.error(&name(i), format!("{n} is listed twice")));
        }
        levels.push(n);
    }
    Ok(levels)
}

impl CycleSource for CoastDown {
    fn cycle(
        &self,
        vehicle: &VehicleParams,
        road: Road<'_>,
        truth: &Truth,
    ) -> Result<DriveCycle, SimulationError> {
        simulate_coastdown(vehicle, self, road.table, truth, self.most_runs())
    }

    fn cycle_of_runs(
        &self,
        vehicle: &VehicleParams,
        road: Road<'_>,
        truth: &Truth,
        runs: usize,
    ) -> Result<DriveCycle, SimulationError> {
        simulate_coastdown(vehicle, self, road.table, truth, runs.min(self.most_runs()))
    }

    fn describe(&self) -> String {
        let directions = match self.directions {
            Directions::Alternate => "alternating directions",
            Directions::OneWay => "one way",
        };
        format!(
            "coast-down {} → {} m/s, {} runs, {directions}",
            self.speed_high_m_s,
            self.speed_low_m_s,
            self.most_runs()
        )
    }

    fn needs_terrain(&self) -> bool {
        false
    }

    fn uses_terrain(&self) -> bool {
        true
    }

    fn runs(&self) -> Option<&[usize]> {
        Some(&self.runs)
    }

    fn alternates(&self) -> bool {
        self.directions == Directions::Alternate
    }
}

/// Simulate the coast-down's first `runs` runs on `table` (a flat road without one) and lay
/// them end to end: run k's first sample is one time step after run k − 1's last, so the
/// whole cycle is sampled at t_i = i·Δt (docs/model.md#coastdown). A run does not depend on
/// the runs after it, so the first k runs are the same whatever `runs` ≥ k.
fn simulate_coastdown(
    vehicle: &VehicleParams,
    drive: &CoastDown,
    table: Option<&GradeTable>,
    truth: &Truth,
    runs: usize,
) -> Result<DriveCycle, SimulationError> {
    let mut cycle = DriveCycle::default();
    let mut spacing = drive.run_spacing_m;
    for k in 0..runs {
        let start = drive.start_distance_m + k as f64 * spacing.unwrap_or(0.0);
        let heading = drive.directions.heading(k);
        let first = cycle.len();
        coast(vehicle, drive, table, truth, k, start, heading, &mut cycle)?;
        if spacing.is_none() {
            // The distance run 0 covers.
            spacing = Some((cycle.x_m[cycle.len() - 1] - cycle.x_m[first]).abs());
        }
    }
    Ok(cycle)
}

/// Append run `k` to `cycle`: from V = `speed_high` at position `start_m`, driving the
/// route with `heading`, sampled every Δt until the last sample with V ≥ `speed_low`.
#[allow(clippy::too_many_arguments)]
fn coast(
    vehicle: &VehicleParams,
    drive: &CoastDown,
    table: Option<&GradeTable>,
    truth: &Truth,
    k: usize,
    start_m: f64,
    heading: f64,
    cycle: &mut DriveCycle,
) -> Result<(), SimulationError> {
    let h = drive.time_step_s;
    let first = cycle.len();
    let max_steps = (MAX_RUN_S / h).floor() as usize;
    let run_error = |key: &'static str, time_s: f64, reason: String| SimulationError::CoastRun {
        run: k,
        key,
        time_s,
        reason,
    };
    // The grade the vehicle sees at route position x (the route's grade negated when it
    // drives backwards), or the error of leaving the table.
    let grade = |t: f64, x: f64| -> Result<f64, SimulationError> {
        let Some(table) = table else {
            return Ok(0.0);
        };
        if x < 0.0 {
            return Err(run_error(
                "drive.start_distance",
                t,
                format!(
                    "the vehicle runs off the start of the terrain (x = {x:.1} m < 0) driving \
                     backwards; make drive.start_distance larger"
                ),
            ));
        }
        let theta = table.grade_at(x).ok_or_else(|| {
            run_error(
                "terrain.length",
                t,
                format!(
                    "the vehicle runs off the end of the terrain (x > {} m); make terrain.length \
                     longer, or drive.start_distance or drive.run_spacing smaller",
                    table.end_m()
                ),
            )
        })?;
        Ok(heading * theta)
    };
    let run_start_s = first as f64 * h;
    let state = |t: f64, x: f64, v: f64, grade: f64| TruthSample {
        time_s: t,
        distance_m: x,
        speed_m_s: v,
        grade_rad: grade,
        heading,
        run: k,
        run_time_s: t - run_start_s,
    };
    // dV/dt at time t, route position x and speed v, with no propulsion force.
    let accel = |t: f64, x: f64, v: f64| -> Result<f64, SimulationError> {
        Ok(truth.acceleration(vehicle, &state(t, x, v, grade(t, x)?), 0.0))
    };
    let (mut x, mut v) = (start_m, drive.speed_high_m_s);
    for j in 0.. {
        let i = first + j;
        let t = i as f64 * h;
        if i >= MAX_SAMPLES {
            return Err(run_error(
                "drive.time_step",
                t,
                format!("the cycle would have more than {MAX_SAMPLES} samples"),
            ));
        }
        if j > max_steps {
            return Err(run_error(
                "drive.speed_low",
                t,
                format!(
                    "the vehicle has not slowed down to drive.speed_low ({} m/s) after {MAX_RUN_S} s \
                     of coasting: its speed is {v:.3} m/s (a downhill grade or a tailwind carries it)",
                    drive.speed_low_m_s
                ),
            ));
        }
        let g = grade(t, x)?;
        cycle.t_s.push(t);
        cycle.x_m.push(x);
        cycle.v_m_s.push(v);
        cycle.grade_rad.push(g);
        cycle.f_prop_n.push(truth.logged_force(0.0));
        let a = truth.acceleration(vehicle, &state(t, x, v, g), 0.0);
        cycle.accel_m_s2.push(a);
        cycle.run.push(k as u32);
        // Classical RK4 on (X, V): dX/dt = heading·V, dV/dt = accel(t, X, V), as the torque
        // mode integrates (the full step's time is the next sample's, (i+1)·Δt).
        let [x_next, v_next] = rk4_step([x, v], h, [heading * v, a], |stage, [xs, vs]| {
            let ts = match stage {
                Stage::Half => t + 0.5 * h,
                Stage::Full => (i + 1) as f64 * h,
            };
            Ok([heading * vs, accel(ts, xs, vs)?])
        })?;
        if !(x_next.is_finite() && v_next.is_finite()) {
            return Err(SimulationError::NonFinite {
                time_s: (i + 1) as f64 * h,
            });
        }
        // The run ends at its last sample with V ≥ speed_low.
        if v_next < drive.speed_low_m_s {
            break;
        }
        (x, v) = (x_next, v_next);
    }
    let samples = cycle.len() - first;
    if samples < MIN_RUN_SAMPLES {
        return Err(run_error(
            "drive.time_step",
            first as f64 * h,
            format!(
                "it has {samples} samples from drive.speed_high to drive.speed_low; at least \
                 {MIN_RUN_SAMPLES} are needed: make drive.time_step smaller"
            ),
        ));
    }
    cycle.run_heading.push(heading);
    Ok(())
}

#[cfg(test)]
mod tests;
