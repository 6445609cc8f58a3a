//! The vehicle's longitudinal dynamics, its drive cycles and how the truth may differ from
//! the equation (docs/model.md#vehicle); the vehicle study's conditions and realisations are
//! `model::vehicle`.
//!
//! `M dV/dt = F_prop(t) − ½ ρ Cd A V² − Cr M g cos θ(X) − M g sin θ(X)`. A drive cycle
//! comes from a [`CycleSource`], one entry of [`DRIVE_MODES`] each: `torque` (the thesis's
//! sinusoidal torque, integrated by RK4; in `torque.rs`) and `speed_trace` (a recorded speed
//! trace followed exactly, the force from inverse dynamics; in `speed_trace.rs`) and `replay`
//! (a cycle given sample by sample; in `replay.rs`) and `coastdown` (runs coasting in
//! neutral, alternating direction; in `coastdown.rs`). A stall or
//! running off the terrain is an error, never a silent NaN. How the truth may differ from
//! this equation (model errors) is in [`truth`].

mod coastdown;
mod designed;
mod error;
pub mod filter_truth;
mod replay;
mod spare;
#[cfg(test)]
pub(crate) use spare::{clear_spares, spare_cycles};
mod speed_trace;
mod torque;
pub mod truth;

pub use coastdown::{CoastDown, Directions, RUN_PAIR};
pub use designed::{Candidate, DesignSummary, DesignedDrive, DriveDesign, Driven, Shape};
pub use error::SimulationError;
pub use replay::Replay;
pub use speed_trace::{SpeedTrace, SpeedUnit, central_differences, positions};
pub use torque::{TorqueDrive, simulate};
pub use truth::Truth;

use std::fmt;
use std::sync::Arc;

use crate::settings::{KeyError, Params};
use crate::terrain::GradeTable;

/// The vehicle's physical parameters (the truth the estimators try to recover).
#[derive(Debug, Clone, PartialEq)]
pub struct VehicleParams {
    /// Mass M \[kg\].
    pub mass_kg: f64,
    /// Aerodynamic drag coefficient Cd \[-\].
    pub drag_coefficient: f64,
    /// Rolling-resistance coefficient Cr \[-\].
    pub rolling_resistance: f64,
    /// Frontal area A \[m²\].
    pub frontal_area_m2: f64,
    /// Air density ρ \[kg/m³\].
    pub air_density_kg_m3: f64,
    /// Gravitational acceleration g \[m/s²\].
    pub gravity_m_s2: f64,
    /// The drivetrain, which turns a torque into a force (needed by drive modes that
    /// simulate from a torque).
    pub drivetrain: Option<Drivetrain>,
}

/// The drivetrain: F = τ R_fd / r_wheel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Drivetrain {
    /// Final-drive gear ratio R_fd \[-\].
    pub final_drive_ratio: f64,
    /// Wheel radius r_wheel \[m\].
    pub wheel_radius_m: f64,
}

impl VehicleParams {
    /// k = ½ ρ A [kg/m]: the drag force is Cd · k · V².
    pub fn drag_factor_kg_m(&self) -> f64 {
        0.5 * self.air_density_kg_m3 * self.frontal_area_m2
    }

    /// The regression parameters θ = \[1/M, Cd/M, Cr\] (thesis eq. 34).
    pub fn theta(&self) -> [f64; 3] {
        [
            1.0 / self.mass_kg,
            self.drag_coefficient / self.mass_kg,
            self.rolling_resistance,
        ]
    }

    /// The vehicle with regression parameters `theta` = \[1/M, Cd/M, Cr\] and these known
    /// quantities: M = 1/θ₁, Cd = θ₂ M, Cr = θ₃ (the inverse of [`VehicleParams::theta`]).
    pub fn with_theta(&self, theta: [f64; 3]) -> VehicleParams {
        let mass_kg = 1.0 / theta[0];
        VehicleParams {
            mass_kg,
            drag_coefficient: theta[1] * mass_kg,
            rolling_resistance: theta[2],
            ..self.clone()
        }
    }

    /// dV/dt \[m/s²\] at speed `v` \[m/s\] on grade `grade` \[rad\] under force `f_prop` \[N\].
    #[inline]
    pub fn acceleration(&self, f_prop_n: f64, v_m_s: f64, grade_rad: f64) -> f64 {
        let m = self.mass_kg;
        let g = self.gravity_m_s2;
        let drag = self.drag_coefficient * self.drag_factor_kg_m() * v_m_s * v_m_s;
        let roll = self.rolling_resistance * m * g * grade_rad.cos();
        let climb = m * g * grade_rad.sin();
        (f_prop_n - drag - roll - climb) / m
    }
}

/// Largest number of drive-cycle samples accepted (keeps a typo from allocating gigabytes).
pub const MAX_SAMPLES: usize = 50_000_000;

/// The road a cycle is driven on, at one terrain scale.
#[derive(Debug, Clone, Copy)]
pub struct Road<'a> {
    /// The grade table at this scale; `None` when the study has no terrain profile (the
    /// cycle brings its own grade).
    pub table: Option<&'a GradeTable>,
    /// The terrain scale factor (it multiplies a grade the cycle brings itself).
    pub scale: f64,
}

/// Where a condition's noise-free drive cycle comes from: one entry of [`DRIVE_MODES`].
pub trait CycleSource: fmt::Debug + Send + Sync {
    /// The noise-free cycle of `vehicle` on `road` when the truth differs from the
    /// equation by `truth` (docs/model.md#model-errors): its motion, the truth's
    /// acceleration and the force the log records.
    fn cycle(
        &self,
        vehicle: &VehicleParams,
        road: Road<'_>,
        truth: &Truth,
    ) -> Result<DriveCycle, SimulationError>;

    /// The cycle of [`cycle`](CycleSource::cycle) for each of `truths` (each
    /// realisation's own), bit for bit what `cycle` gives each: one after the other, or,
    /// in a mode that integrates the motion, several side by side.
    fn cycles(
        &self,
        vehicle: &VehicleParams,
        road: Road<'_>,
        truths: &[Truth],
    ) -> Vec<Result<DriveCycle, SimulationError>> {
        truths
            .iter()
            .map(|truth| self.cycle(vehicle, road, truth))
            .collect()
    }

    /// The cycle of [`cycle`](CycleSource::cycle) cut to its first `runs` runs, made without
    /// the rest (a coast-down integrates only those; a drive of one run ignores `runs`).
    fn cycle_of_runs(
        &self,
        vehicle: &VehicleParams,
        road: Road<'_>,
        truth: &Truth,
        runs: usize,
    ) -> Result<DriveCycle, SimulationError> {
        let _ = runs;
        self.cycle(vehicle, road, truth)
    }

    /// The drive in a few words, for tables and figures.
    fn describe(&self) -> String;

    /// Whether [`cycle`](Self::cycle) writes into the thread's spare cycles
    /// ([`DriveCycle::one_run`]) when it integrates a realisation's own cycle: only then is
    /// that cycle worth giving back to them ([`DriveCycle::recycle`]) once read.
    fn reuses_spares(&self) -> bool {
        false
    }

    /// Whether the cycle needs a terrain profile (otherwise `[terrain]` is optional, and only
    /// its `scales` are read unless [`uses_terrain`](Self::uses_terrain)).
    fn needs_terrain(&self) -> bool {
        true
    }

    /// Whether a terrain profile the study gives is the road, when the cycle does not need
    /// one (a coast-down: a flat road without `[terrain]`).
    fn uses_terrain(&self) -> bool {
        false
    }

    /// The levels of the mode's `drive.runs` axis, when its cycle is made of independent
    /// runs (a coast-down; docs/model.md#coastdown): a condition with k runs uses the first
    /// k, and `drive.durations` does not apply. `None`: the cycle is one run.
    fn runs(&self) -> Option<&[usize]> {
        None
    }

    /// Whether a drive of runs drives every other run the other way (a coast-down's
    /// `directions = "alternate"`); false for a drive of one run.
    fn alternates(&self) -> bool {
        false
    }

    /// Whether the cycle needs the vehicle's drivetrain (`final_drive_ratio`,
    /// `wheel_radius`).
    fn needs_drivetrain(&self) -> bool {
        false
    }

    /// The samples of the cycle the regression may use, when the cycle itself says
    /// (`None`: all); `min_speed`, `exclude_braking` and `durations` select among them.
    fn used(&self) -> Option<&[bool]> {
        None
    }

    /// The time step \[s\] that the mode's `drive.duration` is a whole multiple of, when the
    /// mode has that key (`None`: the cycle lasts as long as its data).
    fn duration_step(&self) -> Option<f64> {
        None
    }

    /// The keys of a drive still to be designed (`drive.mode = "designed"`), which the
    /// study's preparation designs for its sensors and estimator (`design::drive`).
    fn design(&self) -> Option<&DriveDesign> {
        None
    }

    /// The drive as designed, when it was (its torque and what the search found).
    fn designed(&self) -> Option<&DesignedDrive> {
        None
    }
}

/// A drive mode as study files name it (`[drive] mode = ...`).
#[derive(Debug, Clone, Copy)]
pub struct DriveMode {
    /// The value of `drive.mode`.
    pub name: &'static str,
    /// The mode's own keys of `[drive]` (besides `mode` and the keys every mode has).
    pub keys: &'static [&'static str],
    /// Read the mode's own keys of `[drive]` (all of them but `mode`: an unknown key is an
    /// error).
    pub parse: fn(&Params<'_>) -> Result<Arc<dyn CycleSource>, KeyError>,
}

/// Every drive mode a study can name; the first is the default when `mode` is absent.
pub static DRIVE_MODES: [DriveMode; 5] = [
    DriveMode {
        name: "torque",
        keys: TorqueDrive::KEYS,
        parse: TorqueDrive::parse,
    },
    DriveMode {
        name: "speed_trace",
        keys: SpeedTrace::KEYS,
        parse: SpeedTrace::parse,
    },
    DriveMode {
        name: "replay",
        keys: Replay::KEYS,
        parse: Replay::parse,
    },
    DriveMode {
        name: "coastdown",
        keys: CoastDown::KEYS,
        parse: CoastDown::parse,
    },
    DriveMode {
        name: "designed",
        keys: DriveDesign::KEYS,
        parse: DriveDesign::parse,
    },
];

/// The noise-free time series of a drive cycle, one entry per sample (SI units).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DriveCycle {
    /// Time t_i = i · Δt \[s\].
    pub t_s: Vec<f64>,
    /// Position X \[m\].
    pub x_m: Vec<f64>,
    /// Speed V \[m/s\].
    pub v_m_s: Vec<f64>,
    /// Grade θ(X) \[rad\].
    pub grade_rad: Vec<f64>,
    /// Propulsion force F_prop(t) \[N\], as the log records it (with a calibration error
    /// of the truth's, the logged one).
    pub f_prop_n: Vec<f64>,
    /// The truth's acceleration dV/dt at the sample's state \[m/s²\].
    pub accel_m_s2: Vec<f64>,
    /// The run each sample belongs to, 0-based and non-decreasing: a coast-down's runs are
    /// independent stretches of driving (docs/model.md#coastdown); every other drive mode
    /// has one run, 0.
    pub run: Vec<u32>,
    /// The heading of each run, one entry per run: +1 when it drives the route forwards
    /// (its position grows), −1 backwards (it sees the grade negated and a steady wind
    /// flipped). Every drive mode but a coast-down has one run, forwards: `[1.0]`.
    pub run_heading: Vec<f64>,
}

impl DriveCycle {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t_s.len()
    }

    /// True when the cycle has no samples.
    pub fn is_empty(&self) -> bool {
        self.t_s.is_empty()
    }

    /// Terrain variability over the cycle's samples, mean of θ(X_i)² \[rad²\] (thesis eq. 43).
    pub fn terrain_mean_square(&self) -> f64 {
        crate::terrain::mean_square(&self.grade_rad)
    }

    /// Time from the first sample to the last \[s\].
    pub fn length_s(&self) -> f64 {
        match (self.t_s.first(), self.t_s.last()) {
            (Some(a), Some(b)) => b - a,
            _ => 0.0,
        }
    }

    /// Which samples the regression uses: those in `prefix`, at a true speed of at least
    /// `selection.min_speed_m_s` and, with `selection.exclude_braking`, a tractive force ≥ 0.
    pub fn used(&self, selection: &RowSelection, prefix: Prefix) -> Vec<bool> {
        (0..self.len())
            .map(|i| {
                prefix.holds(self, i)
                    && self.v_m_s[i] >= selection.min_speed_m_s
                    && !(selection.exclude_braking && self.f_prop_n[i] < 0.0)
            })
            .collect()
    }

    /// The samples where `used` is true, in order.
    pub fn select(&self, used: &[bool]) -> DriveCycle {
        let pick = |v: &Vec<f64>| -> Vec<f64> {
            v.iter()
                .zip(used)
                .filter(|(_, u)| **u)
                .map(|(x, _)| *x)
                .collect()
        };
        DriveCycle {
            t_s: pick(&self.t_s),
            x_m: pick(&self.x_m),
            v_m_s: pick(&self.v_m_s),
            grade_rad: pick(&self.grade_rad),
            f_prop_n: pick(&self.f_prop_n),
            accel_m_s2: pick(&self.accel_m_s2),
            run: self
                .run
                .iter()
                .zip(used)
                .filter(|(_, u)| **u)
                .map(|(r, _)| *r)
                .collect(),
            run_heading: self.run_heading.clone(),
        }
    }

    /// The heading of sample `i`'s run (+1 forwards, −1 backwards).
    pub fn heading(&self, i: usize) -> f64 {
        self.run_heading[self.run[i] as usize]
    }

    /// Whether sample `i` is the first or the last of its run (a differentiated
    /// acceleration has no neighbour there on one side).
    pub fn at_run_edge(&self, i: usize) -> bool {
        let n = self.run.len();
        i == 0 || i + 1 == n || self.run[i - 1] != self.run[i] || self.run[i + 1] != self.run[i]
    }

    /// Number of runs (1 for every drive mode but a coast-down; 0 without samples).
    pub fn runs(&self) -> usize {
        self.run.last().map_or(0, |&r| r as usize + 1)
    }
}

/// How much of a cycle a condition uses, from its start (docs/model.md#row-selection).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Prefix {
    /// All of it.
    #[default]
    Whole,
    /// The samples with t − t₀ ≤ this \[s\] (`drive.durations`).
    Duration(f64),
    /// The samples of the first this many runs (`drive.runs` of a coast-down).
    Runs(usize),
}

impl Prefix {
    /// Whether sample `i` of `cycle` is in the prefix.
    pub fn holds(self, cycle: &DriveCycle, i: usize) -> bool {
        match self {
            Prefix::Whole => true,
            Prefix::Duration(d) => cycle.t_s[i] - cycle.t_s[0] <= d,
            Prefix::Runs(k) => (cycle.run[i] as usize) < k,
        }
    }

    /// The time \[s\] from the first sample of `cycle` to the last in the prefix: the
    /// duration a condition's axis column reports (the duration itself for
    /// [`Prefix::Duration`]).
    pub fn length_s(self, cycle: &DriveCycle) -> f64 {
        match self {
            Prefix::Whole => cycle.length_s(),
            Prefix::Duration(d) => d,
            Prefix::Runs(k) => match cycle.run.iter().rposition(|&r| (r as usize) < k) {
                Some(last) => cycle.t_s[last] - cycle.t_s[0],
                None => 0.0,
            },
        }
    }
}

/// Which samples of a cycle the regression uses (`[drive]` `min_speed`, `exclude_braking`);
/// chosen from the noise-free signals, the same in every realisation.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RowSelection {
    /// Samples slower than this are left out \[m/s\] (standstill, where rolling resistance
    /// is not defined).
    pub min_speed_m_s: f64,
    /// Leave out samples with a negative tractive force (braking).
    pub exclude_braking: bool,
}

#[cfg(test)]
impl VehicleParams {
    /// The thesis vehicle (the defaults of docs/model.md#vehicle), for unit tests.
    pub(crate) fn thesis() -> Self {
        VehicleParams {
            mass_kg: 1800.0,
            drag_coefficient: 0.35,
            rolling_resistance: 0.0125,
            frontal_area_m2: 5.5,
            air_density_kg_m3: 1.2,
            gravity_m_s2: 9.81,
            drivetrain: Some(Drivetrain {
                final_drive_ratio: 2.7,
                wheel_radius_m: 0.3,
            }),
        }
    }
}
