//! The drive mode `designed`: a final-drive torque chosen, within torque and speed limits, to
//! make the chosen estimator's bound as small as the study's sensors allow
//! (docs/model.md#designed-drive). This file holds the mode's keys, the profile (piecewise
//! constant or piecewise linear over `segments` pieces), the speed governor that holds the
//! limits, and the designed drive once it is chosen; the search itself is `numeric::profile_search`.
//!
//! The torque is held over each integration step (zero-order hold): sample i's logged force
//! is the torque applied from t_i to t_{i+1}, times R_fd / r_wheel, and the speed is
//! integrated by RK4 at the sample step as in the `torque` mode.

use std::sync::Arc;

mod outcome;

pub use outcome::{Candidate, DesignSummary, DesignedDrive};

use super::torque::duration_steps;
use super::truth::TruthSample;
use super::{CycleSource, DriveCycle, Road, SimulationError, Truth, VehicleParams};
use crate::numeric::ode::{Stage, rk4_step};
use crate::settings::{KeyError, Params};
use crate::terrain::GradeTable;

/// How the torque varies within the drive.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shape {
    /// Constant over each segment.
    Constant,
    /// Linear between the segments' midpoints (constant before the first and after the
    /// last).
    Smooth,
}

/// The keys of a designed drive (`[drive] mode = "designed"`), before it is designed.
#[derive(Debug, Clone, PartialEq)]
pub struct DriveDesign {
    /// Length of the drive \[s\].
    pub duration_s: f64,
    /// Sample and integration step \[s\].
    pub time_step_s: f64,
    /// Number of steps; the drive has `steps + 1` samples.
    pub steps: usize,
    /// Speed at t = 0 \[m/s\], within the speed limits.
    pub initial_speed_m_s: f64,
    /// Smallest final-drive torque \[N·m\] (negative: the brakes).
    pub torque_min_n_m: f64,
    /// Largest final-drive torque \[N·m\].
    pub torque_max_n_m: f64,
    /// Lowest speed allowed on every sample \[m/s\].
    pub speed_min_m_s: f64,
    /// Highest speed allowed on every sample \[m/s\].
    pub speed_max_m_s: f64,
    /// How far inside a limit the governor brings the speed before it hands the torque back
    /// to the profile \[m/s\].
    pub speed_band_m_s: f64,
    /// Number of pieces of the profile (the search's unknowns).
    pub segments: usize,
    /// Piecewise constant or smooth.
    pub shape: Shape,
    /// What is minimised: `d` (ln det of the bound's covariance), `a` (the sum of the
    /// parameters' relative variances) or a parameter's name (its relative variance).
    pub criterion: String,
    /// The estimator whose bound is minimised (`None`: the study's first).
    pub estimator: Option<String>,
    /// Iterations of the Nelder–Mead polish after the segment search.
    pub polish_iterations: u64,
    /// The study's own drive, reported beside the designed one at equal duration and
    /// limits: the thesis torque τ0 (1 + a sin(ω t)) of `torque_mean`, `torque_amplitude`,
    /// `torque_frequency` (`None` without them).
    pub reference: Option<[f64; 3]>,
}

impl DriveDesign {
    /// The mode's keys of `[drive]`.
    pub const KEYS: &'static [&'static str] = &[
        "duration",
        "time_step",
        "initial_speed",
        "torque_min",
        "torque_max",
        "speed_min",
        "speed_max",
        "speed_band",
        "segments",
        "shape",
        "criterion",
        "estimator",
        "polish_iterations",
        "torque_mean",
        "torque_amplitude",
        "torque_frequency",
    ];

    /// Read `[drive]` of mode `designed`.
    pub fn parse(p: &Params<'_>) -> Result<Arc<dyn CycleSource>, KeyError> {
        p.only(Self::KEYS)?;
        let (duration_s, time_step_s, steps) = duration_steps(p)?;
        let torque_min_n_m = p.number("torque_min")?;
        let torque_max_n_m = p.number("torque_max")?;
        if torque_max_n_m <= torque_min_n_m {
            return Err(p.error(
                "torque_max",
                format!(
                    "must be above drive.torque_min ({torque_min_n_m} N·m), got {torque_max_n_m}"
                ),
            ));
        }
        let speed_min_m_s = p.positive("speed_min")?;
        let speed_max_m_s = p.positive("speed_max")?;
        if speed_max_m_s <= speed_min_m_s {
            return Err(p.error(
                "speed_max",
                format!("must be above drive.speed_min ({speed_min_m_s} m/s), got {speed_max_m_s}"),
            ));
        }
        let initial_speed_m_s = p.positive("initial_speed")?;
        if !(speed_min_m_s..=speed_max_m_s).contains(&initial_speed_m_s) {
            return Err(p.error(
                "initial_speed",
                format!(
                    "must lie within the speed limits [{speed_min_m_s}, {speed_max_m_s}] m/s, got {initial_speed_m_s}"
                ),
            ));
        }
        let speed_band_m_s = match p.optional("speed_band", Params::positive)? {
            Some(b) if 2.0 * b >= speed_max_m_s - speed_min_m_s => {
                return Err(p.error(
                    "speed_band",
                    format!("must be less than half the speed range, got {b} m/s"),
                ));
            }
            Some(b) => b,
            None => (0.5_f64).min(0.25 * (speed_max_m_s - speed_min_m_s)),
        };
        let segments = p.positive("segments")?;
        if segments.fract() != 0.0 || !steps.is_multiple_of(segments as usize) {
            return Err(p.error(
                "segments",
                format!(
                    "must be a whole number that divides the drive's {steps} steps, got {segments}"
                ),
            ));
        }
        let shape = p.named(
            "shape",
            &[("constant", Shape::Constant), ("smooth", Shape::Smooth)],
        )?;
        let criterion = p.string("criterion")?.to_string();
        let estimator = p.optional("estimator", |p, k| p.string(k))?;
        let polish_iterations = match p.optional("polish_iterations", Params::non_negative)? {
            Some(n) if n.fract() != 0.0 => {
                return Err(p.error(
                    "polish_iterations",
                    format!("must be a whole number, got {n}"),
                ));
            }
            Some(n) => n as u64,
            None => 200,
        };
        let torque_keys = ["torque_mean", "torque_amplitude", "torque_frequency"];
        let reference = match torque_keys.map(|k| p.has(k)) {
            [false, false, false] => None,
            [true, true, true] => Some([
                p.number("torque_mean")?,
                p.non_negative("torque_amplitude")?,
                p.non_negative("torque_frequency")?,
            ]),
            given => {
                let missing = torque_keys[given.iter().position(|g| !g).unwrap_or(0)];
                return Err(p.error(
                    missing,
                    "is missing: the study's own drive needs torque_mean, torque_amplitude and torque_frequency together",
                ));
            }
        };
        Ok(Arc::new(DriveDesign {
            duration_s,
            time_step_s,
            steps,
            initial_speed_m_s,
            torque_min_n_m,
            torque_max_n_m,
            speed_min_m_s,
            speed_max_m_s,
            speed_band_m_s,
            segments: segments as usize,
            shape,
            criterion,
            estimator: estimator.map(str::to_string),
            polish_iterations,
            reference,
        }))
    }

    /// Number of samples, steps + 1.
    pub fn samples(&self) -> usize {
        self.steps + 1
    }

    /// The torque \[N·m\] the profile of segment `levels` asks for at each sample.
    pub fn planned(&self, levels: &[f64]) -> Vec<f64> {
        let n = self.samples();
        let per = self.steps / self.segments;
        match self.shape {
            Shape::Constant => (0..n)
                .map(|i| levels[(i / per).min(self.segments - 1)])
                .collect(),
            Shape::Smooth => (0..n)
                .map(|i| {
                    // Position in segment units measured from the first midpoint.
                    let u = (i as f64 + 0.5 - 0.5 * per as f64) / per as f64;
                    if u <= 0.0 {
                        levels[0]
                    } else if u >= (self.segments - 1) as f64 {
                        levels[self.segments - 1]
                    } else {
                        let j = u.floor() as usize;
                        let w = u - j as f64;
                        levels[j] + w * (levels[j + 1] - levels[j])
                    }
                })
                .collect(),
        }
    }

    /// The study's own drive's torque \[N·m\] at each sample, within the torque limits
    /// (`None` without it).
    pub fn reference_planned(&self) -> Option<Vec<f64>> {
        let [mean, amplitude, frequency] = self.reference?;
        Some(
            (0..self.samples())
                .map(|i| {
                    let t = i as f64 * self.time_step_s;
                    (mean * (1.0 + amplitude * (frequency * t).sin()))
                        .clamp(self.torque_min_n_m, self.torque_max_n_m)
                })
                .collect(),
        )
    }

    /// Drive `planned` (a torque per sample) on `table` with the governor holding the speed
    /// limits: where the profile's torque would take the next sample's speed above
    /// `speed_max` (below `speed_min`) the step is taken at `torque_min` (`torque_max`)
    /// instead, and the governor keeps that torque until the speed is `speed_band` inside the
    /// limit. An error where even that torque leaves the limits.
    pub fn governed(
        &self,
        vehicle: &VehicleParams,
        table: &GradeTable,
        planned: &[f64],
    ) -> Result<Driven, SimulationError> {
        let mut hold = Hold::Profile;
        let (lo, hi) = (self.speed_min_m_s, self.speed_max_m_s);
        let band = self.speed_band_m_s;
        let mut governed = 0usize;
        let driven = integrate(vehicle, table, &Truth::default(), self, |i, t, v, step| {
            hold = match hold {
                Hold::Min if v <= hi - band => Hold::Profile,
                Hold::Max if v >= lo + band => Hold::Profile,
                h => h,
            };
            let torque = |h: Hold| match h {
                Hold::Profile => planned[i],
                Hold::Min => self.torque_min_n_m,
                Hold::Max => self.torque_max_n_m,
            };
            let Some(step) = step else {
                return Ok((torque(hold), None));
            };
            let mut next = step(torque(hold))?;
            if next.state[1] > hi && hold != Hold::Min {
                hold = Hold::Min;
                next = step(torque(hold))?;
            } else if next.state[1] < lo && hold != Hold::Max {
                hold = Hold::Max;
                next = step(torque(hold))?;
            }
            if hold != Hold::Profile {
                governed += 1;
            }
            let v_next = next.state[1];
            if v_next > hi || v_next < lo {
                let (key, limit) = match v_next > hi {
                    true => ("speed_max", hi),
                    false => ("speed_min", lo),
                };
                return Err(SimulationError::SpeedLimit {
                    time_s: t + self.time_step_s,
                    key,
                    reason: format!(
                        "even {} N·m takes the speed to {v_next:.3} m/s, beyond {limit} m/s \
                         (the grade is too steep for the torque limits)",
                        torque(hold)
                    ),
                });
            }
            Ok((torque(hold), Some(next)))
        })?;
        Ok(Driven {
            governed_fraction: governed as f64 / self.steps as f64,
            ..driven
        })
    }
}

/// Who sets the torque: the profile, or the governor at a limit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Hold {
    Profile,
    Min,
    Max,
}

/// A drive integrated under a torque chosen sample by sample.
#[derive(Debug, Clone)]
pub struct Driven {
    /// The cycle.
    pub cycle: DriveCycle,
    /// The torque applied from each sample to the next \[N·m\] (the last sample's: the one
    /// it logs).
    pub torque_n_m: Vec<f64>,
    /// The fraction of the steps at which the governor, not the profile, set the torque.
    pub governed_fraction: f64,
}

/// One RK4 step's result: the next state and the acceleration at the step's start.
#[derive(Debug, Clone, Copy)]
struct Next {
    state: [f64; 2],
    accel: f64,
}

/// A step under a torque, as the chooser of [`integrate`] tries it.
type Step<'a> = &'a dyn Fn(f64) -> Result<Next, SimulationError>;

/// Integrate a drive at `drive`'s step from its initial speed, the torque of each sample
/// chosen by `choose(i, t, v, step)` (`step` is `None` at the last sample, which takes no
/// step), which returns the torque and the step it took with it.
fn integrate(
    vehicle: &VehicleParams,
    table: &GradeTable,
    truth: &Truth,
    drive: &DriveDesign,
    mut choose: impl FnMut(
        usize,
        f64,
        f64,
        Option<Step<'_>>,
    ) -> Result<(f64, Option<Next>), SimulationError>,
) -> Result<Driven, SimulationError> {
    let h = drive.time_step_s;
    let n = drive.samples();
    let gear = vehicle
        .drivetrain
        .map(|d| d.final_drive_ratio / d.wheel_radius_m)
        .expect("the designed mode is validated to have a drivetrain");
    let end_m = table.end_m();
    let mut cycle = DriveCycle::one_run(n);
    let mut torque_n_m = Vec::with_capacity(n);
    let state = TruthSample::forwards;
    let grade_at = |t: f64, x: f64| {
        table
            .grade_at(x)
            .ok_or(SimulationError::RanOffTerrain { time_s: t, end_m })
    };
    let (mut x, mut v) = (0.0_f64, drive.initial_speed_m_s);
    for i in 0..n {
        let t = i as f64 * h;
        SimulationError::check_state(i, t, x, v)?;
        let grade = grade_at(t, x)?;
        let here = state(t, x, v, grade);
        // One RK4 step from (x, v) under the constant force of `torque`.
        let step = |torque: f64| -> Result<Next, SimulationError> {
            let f = torque * gear;
            let a = truth.acceleration(vehicle, &here, f);
            let state = rk4_step([x, v], h, [v, a], |stage, [xs, vs]| {
                let ts = match stage {
                    Stage::Half => t + 0.5 * h,
                    Stage::Full => t + h,
                };
                let g = grade_at(ts, xs)?;
                Ok([vs, truth.acceleration(vehicle, &state(ts, xs, vs, g), f)])
            })?;
            Ok(Next { state, accel: a })
        };
        let last = i + 1 == n;
        let (torque, next) = choose(i, t, v, (!last).then_some(&step as Step<'_>))?;
        let f = torque * gear;
        let accel = match next {
            Some(next) => next.accel,
            None => truth.acceleration(vehicle, &here, f),
        };
        cycle.t_s.push(t);
        cycle.x_m.push(x);
        cycle.v_m_s.push(v);
        cycle.grade_rad.push(grade);
        cycle.f_prop_n.push(truth.logged_force(f));
        cycle.accel_m_s2.push(accel);
        torque_n_m.push(torque);
        if let Some(next) = next {
            [x, v] = next.state;
        }
    }
    Ok(Driven {
        cycle,
        torque_n_m,
        governed_fraction: 0.0,
    })
}

impl CycleSource for DriveDesign {
    fn cycle(
        &self,
        _vehicle: &VehicleParams,
        _road: Road<'_>,
        _truth: &Truth,
    ) -> Result<DriveCycle, SimulationError> {
        Err(SimulationError::Undesigned)
    }

    fn describe(&self) -> String {
        format!(
            "designed for criterion {}, {} s (not yet designed)",
            self.criterion, self.duration_s
        )
    }

    fn duration_step(&self) -> Option<f64> {
        Some(self.time_step_s)
    }

    fn needs_drivetrain(&self) -> bool {
        true
    }

    fn design(&self) -> Option<&DriveDesign> {
        Some(self)
    }
}

#[cfg(test)]
mod tests;
