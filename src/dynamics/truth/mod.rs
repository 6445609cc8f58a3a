//! Model errors: how the simulated vehicle may differ from the regression's equation
//! (docs/model.md#model-errors).
//!
//! The estimators always fit the thesis's equation, `M dV/dt = F − ½ρ Cd A V² − Cr M g cos θ
//! − M g sin θ`. A model error is something the truth has and the equation leaves out: wind,
//! the inertia of rotating parts, a miscalibrated force signal, rolling resistance that grows
//! with speed, another air density, a mass that drifts. Each is one [`ModelError`] (what it
//! adds to the truth's dynamics or does to the logged force, whether it is drawn per
//! realisation) and one entry of [`MODEL_ERRORS`] (its key of `[truth]`, unit, neutral value,
//! and how it is built from a value). The steady entries are in `steady.rs`.
//!
//! An entry acts in one of two ways, or both:
//! - **a force the truth has**, D(t) = m_D(t)·dV/dt + D₀(t) \[N\], opposing the motion when
//!   positive: an inertia m_D (the part proportional to the acceleration: rotating parts, a
//!   changing mass) and the rest D₀. The truth is `(M + Σ m_D) dV/dt = F − Σ D₀ − (the
//!   equation's forces)`. A drive mode that integrates the motion (`torque`) integrates it;
//!   one that prescribes the motion (`speed_trace`, `replay`) logs the force the truth
//!   needed, the equation's F plus D.
//! - **a calibration error of the log**: the logged force is a function of the truth's force
//!   F (`force_scale`: (1 + s)·F); the truth's motion is unchanged in every drive mode.
//!
//! To first order the estimate moves by Δθ ≈ −θ₁ (XᵀX)⁻¹ Xᵀ D for a force D (the
//! regression's normal equations applied to the output error −θ₁ D), and by the entry's own
//! form for a calibration error: its `bias_model`. Entries combine by adding their inertias
//! and forces and composing their calibrations; the aerodynamic force is made once from
//! every entry's wind and air-density factor (so wind at another density is exact). An entry
//! drawn anew in every realisation (`drawn.rs`) realises as a steady one per realisation.

mod drawn;
mod steady;

use std::fmt;
use std::sync::Arc;

use super::{DriveCycle, VehicleParams};
use crate::noise::NormalSequence;
pub use drawn::{ForceScaleDrawn, Gust, RunGusts, WindSeries};
pub use steady::{AirDensity, ForceScale, MassRate, RollingSpeed, RotatingMass, Wind};

/// The state of the truth at one sample, as a model error sees it (its acceleration is not
/// part of it: the part of a force proportional to the acceleration is the entry's
/// [`ModelError::added_inertia_kg`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruthSample {
    /// Time since the start of the cycle \[s\].
    pub time_s: f64,
    /// Position along the route \[m\] (the distance travelled, for a drive that only goes
    /// forwards).
    pub distance_m: f64,
    /// Speed V \[m/s\].
    pub speed_m_s: f64,
    /// Road grade θ \[rad\], as the vehicle sees it in its direction of travel.
    pub grade_rad: f64,
    /// +1 when the vehicle drives the route forwards (its position grows), −1 backwards (a
    /// coast-down's return runs, docs/model.md#coastdown): a steady wind along the route is
    /// a headwind one way and a tailwind the other.
    pub heading: f64,
    /// The run it belongs to (0 in a drive of one run; a coast-down's run k): an entry drawn
    /// per run reads that run's draw.
    pub run: usize,
    /// Time since its run's first sample \[s\] (`time_s` in a drive of one run).
    pub run_time_s: f64,
}

impl TruthSample {
    /// A sample of a drive of one run driven forwards (every mode but a coast-down): at time
    /// `time_s` \[s\], position `distance_m` \[m\], speed `speed_m_s` \[m/s\], grade
    /// `grade_rad` \[rad\].
    pub fn forwards(time_s: f64, distance_m: f64, speed_m_s: f64, grade_rad: f64) -> Self {
        TruthSample {
            time_s,
            distance_m,
            speed_m_s,
            grade_rad,
            heading: 1.0,
            run: 0,
            run_time_s: time_s,
        }
    }
}

/// How a model error drawn anew in every realisation draws: its own stream of normals (so
/// that switching it on leaves every other draw as it was), and whether it changes the
/// truth's motion.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Drawn {
    /// Its random stream (docs/model.md#streams).
    pub stream: crate::noise::Stream,
    /// Whether it changes the force the truth needs (a drive mode that integrates the
    /// motion integrates each realisation again; one that prescribes it logs another
    /// force), not only how the log records the force.
    pub moves_the_vehicle: bool,
}

/// One way the truth differs from the regression's equation. Every method has the neutral
/// default (no force, no inertia, no wind, the assumed air density, the force logged as it
/// is, the same in every realisation), so an entry implements what it changes.
pub trait ModelError: Send + Sync + fmt::Debug {
    /// The inertia \[kg\] the truth has beyond the equation's M at `sample`: the part of the
    /// omitted force proportional to dV/dt.
    fn added_inertia_kg(&self, _vehicle: &VehicleParams, _sample: &TruthSample) -> f64 {
        0.0
    }

    /// The rest of the force \[N\] the equation leaves out at `sample`, opposing the motion
    /// when positive, beyond the aerodynamic force (which the truth makes of every entry's
    /// wind and air density together).
    fn omitted_force(&self, _vehicle: &VehicleParams, _sample: &TruthSample) -> f64 {
        0.0
    }

    /// The wind \[m/s\] along the direction of travel it adds at `sample`, positive a
    /// headwind: the air speed is V plus every entry's wind.
    fn wind_m_s(&self, _sample: &TruthSample) -> f64 {
        0.0
    }

    /// The factor by which it multiplies the air density the regression assumes.
    fn air_density_factor(&self) -> f64 {
        1.0
    }

    /// Its added inertia, omitted force, wind and air density factor at `sample`, in that
    /// order: one call where the truth's force needs all four (each entry's own methods,
    /// called statically inside it). An entry that overrides it gives what they give.
    #[inline]
    fn contributions(&self, vehicle: &VehicleParams, sample: &TruthSample) -> [f64; 4] {
        [
            self.added_inertia_kg(vehicle, sample),
            self.omitted_force(vehicle, sample),
            self.wind_m_s(sample),
            self.air_density_factor(),
        ]
    }

    /// The force \[N\] the log records when the truth's propulsion force is `force_n` (a
    /// calibration error; the truth's motion does not see it).
    fn logged_force(&self, force_n: f64) -> f64 {
        force_n
    }

    /// Each of `forces_n` \[N\] replaced by the force the log records for it
    /// ([`ModelError::logged_force`] of each in turn: one call for a whole column). An
    /// entry that overrides it gives what `logged_force` gives, value by value.
    #[inline]
    fn log_forces(&self, forces_n: &mut [f64]) {
        for f in forces_n {
            *f = self.logged_force(*f);
        }
    }

    /// How it draws, when it is drawn anew in every realisation (`None`: the same in every
    /// realisation, set per condition).
    fn drawn(&self) -> Option<Drawn> {
        None
    }

    /// Its value in one realisation: a steady model error made from the realisation's
    /// `normals` (its own stream) for a cycle whose runs are sampled at `run_times_s` (one
    /// entry per run, each from its run's first sample; a drive of one run has one), each run
    /// drawn independently of the others. Only an entry that is [`drawn`](ModelError::drawn)
    /// is asked.
    fn realise(
        &self,
        _normals: &mut NormalSequence,
        _run_times_s: &[Arc<[f64]>],
    ) -> Arc<dyn ModelError> {
        unreachable!("only a drawn model error is realised")
    }
}

/// A model error as study files name it: one key of `[truth]`.
#[derive(Debug, Clone, Copy)]
pub struct ModelErrorEntry {
    /// Its name in messages and docs (e.g. "steady wind").
    pub name: &'static str,
    /// Its key of `[truth]`.
    pub key: &'static str,
    /// The unit of its value (empty when dimensionless).
    pub unit: &'static str,
    /// Whether the key is a condition axis (a list of values, one condition each).
    pub axis: bool,
    /// Whether it is drawn anew in every realisation (so not a steady key `design` varies).
    pub drawn: bool,
    /// The value that leaves the truth as the equation (the default when the key is
    /// absent; at it no entry is built, so the numbers are those without `[truth]`).
    pub neutral: f64,
    /// Why a value is not accepted (`None`: it is), e.g. "must be > −1".
    pub check: fn(f64) -> Option<&'static str>,
    /// The model error of a value other than `neutral`, given every entry's value (in the
    /// order of [`MODEL_ERRORS`]; a key that only sets another entry's parameter, such as
    /// `wind_gust_time`, builds none).
    pub build: BuildModelError,
}

/// How an entry of [`MODEL_ERRORS`] builds its model error from its value and every
/// entry's values.
pub type BuildModelError = fn(f64, &[f64; MODEL_ERROR_COUNT]) -> Option<Arc<dyn ModelError>>;

/// Number of entries of [`MODEL_ERRORS`].
pub const MODEL_ERROR_COUNT: usize = 9;

/// Every model error a study can name, in the order of their keys in `[truth]` (the order
/// of their condition axes, nested after the other axes).
pub static MODEL_ERRORS: [ModelErrorEntry; MODEL_ERROR_COUNT] = [
    steady::WIND,
    drawn::GUST,
    drawn::GUST_TIME,
    steady::ROTATING_MASS,
    steady::FORCE_SCALE,
    drawn::FORCE_SCALE_SD,
    steady::ROLLING_SPEED,
    steady::AIR_DENSITY,
    steady::MASS_RATE,
];

/// The position in [`MODEL_ERRORS`] of the entry with key `key`.
pub fn entry_index(key: &str) -> Option<usize> {
    MODEL_ERRORS.iter().position(|e| e.key == key)
}

/// The model errors of one condition: what the truth has beyond the equation (none: the
/// truth is the equation, and every drive mode computes exactly what it did without them).
#[derive(Debug, Clone, Default)]
pub struct Truth {
    entries: Vec<Arc<dyn ModelError>>,
}

impl Truth {
    /// The truth with each entry of [`MODEL_ERRORS`] at its value in `values` (an entry at
    /// its neutral value is left out).
    pub fn from_values(values: &[f64; MODEL_ERROR_COUNT]) -> Truth {
        Truth {
            entries: MODEL_ERRORS
                .iter()
                .zip(values)
                .filter(|(e, v)| **v != e.neutral)
                .filter_map(|(e, &v)| (e.build)(v, values))
                .collect(),
        }
    }

    /// Whether the truth is the equation.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Whether an entry is drawn anew in every realisation.
    pub fn is_drawn(&self) -> bool {
        self.entries.iter().any(|e| e.drawn().is_some())
    }

    /// Whether an entry drawn in every realisation changes the force the truth needs (so
    /// each realisation's cycle is made again, not only its log recalibrated).
    pub fn moves_per_realisation(&self) -> bool {
        self.entries
            .iter()
            .any(|e| e.drawn().is_some_and(|d| d.moves_the_vehicle))
    }

    /// The truth with its drawn entries left out: what `bias_model` and cycles.parquet
    /// describe.
    pub fn steady(&self) -> Truth {
        Truth {
            entries: self
                .entries
                .iter()
                .filter(|e| e.drawn().is_none())
                .cloned()
                .collect(),
        }
    }

    /// The truth's drawn entries alone.
    pub fn drawn_part(&self) -> Truth {
        Truth {
            entries: self
                .entries
                .iter()
                .filter(|e| e.drawn().is_some())
                .cloned()
                .collect(),
        }
    }

    /// The truth of realisation `r`: each drawn entry realised from its own stream of
    /// (`seed`, `key`, its stream, `r`) for a cycle sampled at `times_s` (from 0); the
    /// steady entries as they are.
    pub fn realise(&self, seed: u64, key: u64, r: u64, run_times_s: &[Arc<[f64]>]) -> Truth {
        Truth {
            entries: self
                .entries
                .iter()
                .map(|e| match e.drawn() {
                    Some(d) => {
                        let mut normals = NormalSequence::for_realisation(seed, key, d.stream, r);
                        e.realise(&mut normals, run_times_s)
                    }
                    None => e.clone(),
                })
                .collect(),
        }
    }

    /// The truth's dV/dt \[m/s²\] at `sample` under the propulsion force `force_n` \[N\]:
    /// `(F − Σ D₀ − the equation's forces) / (M + Σ m_D)`; without entries exactly
    /// [`VehicleParams::acceleration`].
    #[inline]
    pub fn acceleration(&self, vehicle: &VehicleParams, sample: &TruthSample, force_n: f64) -> f64 {
        if self.entries.is_empty() {
            return vehicle.acceleration(force_n, sample.speed_m_s, sample.grade_rad);
        }
        let (inertia, omitted) = self.forces(vehicle, sample);
        let equation = vehicle.acceleration(force_n - omitted, sample.speed_m_s, sample.grade_rad);
        equation * vehicle.mass_kg / (vehicle.mass_kg + inertia)
    }

    /// The force \[N\] the truth needs at `sample` to accelerate at `accel_m_s2`, when the
    /// equation needs `equation_force_n` there: that plus Σ m_D·dV/dt + Σ D₀.
    pub fn needed_force(
        &self,
        vehicle: &VehicleParams,
        sample: &TruthSample,
        accel_m_s2: f64,
        equation_force_n: f64,
    ) -> f64 {
        if self.entries.is_empty() {
            return equation_force_n;
        }
        let (inertia, omitted) = self.forces(vehicle, sample);
        equation_force_n + inertia * accel_m_s2 + omitted
    }

    /// The force \[N\] the log records at every sample of `cycle`, whose `f_prop_n` is the
    /// force the equation needs for the cycle's motion (a drive mode that prescribes the
    /// motion): the truth needed that plus D ([`Truth::needed_force`]), recorded through each
    /// calibration. Time is counted from the cycle's first sample. Without entries,
    /// `f_prop_n` itself.
    pub fn logged_forces(&self, vehicle: &VehicleParams, cycle: &DriveCycle) -> Vec<f64> {
        if self.entries.is_empty() {
            return cycle.f_prop_n.clone();
        }
        (0..cycle.t_s.len())
            .map(|i| {
                let sample = sample_of(cycle, i);
                let needed =
                    self.needed_force(vehicle, &sample, cycle.accel_m_s2[i], cycle.f_prop_n[i]);
                self.logged_force(needed)
            })
            .collect()
    }

    /// The force \[N\] the log records for the truth's force `force_n` (each entry's
    /// calibration in turn).
    pub fn logged_force(&self, force_n: f64) -> f64 {
        self.entries.iter().fold(force_n, |f, e| e.logged_force(f))
    }

    /// [`Truth::logged_force`] of each of `forces_n` in place: each entry's calibration
    /// applied to the whole column in turn (each value through the same operations).
    pub fn log_forces(&self, forces_n: &mut [f64]) {
        for e in &self.entries {
            e.log_forces(forces_n);
        }
    }

    /// The truth's inertia \[kg\] at `sample`: M plus every entry's added inertia (a
    /// drifting mass, rotating parts). It must stay positive over a cycle.
    pub fn inertia_kg(&self, vehicle: &VehicleParams, sample: &TruthSample) -> f64 {
        vehicle.mass_kg
            + self
                .entries
                .iter()
                .map(|e| e.added_inertia_kg(vehicle, sample))
                .sum::<f64>()
    }

    /// The wind \[m/s\] at `sample`, positive a headwind: the sum of the entries' (so the
    /// air speed is V plus this).
    pub fn wind_m_s(&self, sample: &TruthSample) -> f64 {
        self.entries.iter().map(|e| e.wind_m_s(sample)).sum()
    }

    /// The air speed \[m/s\] at every sample of `cycle`: V + the truth's wind (time from
    /// the cycle's first sample). Without wind, the speed itself.
    pub fn air_speeds(&self, cycle: &DriveCycle) -> Vec<f64> {
        (0..cycle.t_s.len())
            .map(|i| {
                let sample = sample_of(cycle, i);
                sample.speed_m_s + self.wind_m_s(&sample)
            })
            .collect()
    }

    /// Σ m_D \[kg\] and Σ D₀ \[N\] at `sample`, D₀ including the aerodynamic force the
    /// equation leaves out: k·Cd·[r·(V + w)|V + w| − V²] for the entries' wind w and
    /// air-density factor r (zero without either).
    fn forces(&self, vehicle: &VehicleParams, sample: &TruthSample) -> (f64, f64) {
        let (inertia, omitted, wind, density) =
            self.entries
                .iter()
                .fold((0.0, 0.0, 0.0, 1.0), |(m, d, w, r), e| {
                    let [inertia, omitted, wind, density] = e.contributions(vehicle, sample);
                    (m + inertia, d + omitted, w + wind, r * density)
                });
        let aero = match wind == 0.0 && density == 1.0 {
            true => 0.0,
            false => {
                let v = sample.speed_m_s;
                let air = v + wind;
                vehicle.drag_coefficient
                    * vehicle.drag_factor_kg_m()
                    * (density * air * air.abs() - v * v)
            }
        };
        (inertia, omitted + aero)
    }
}

/// Sample `i` of `cycle` as the truth sees it (time from the cycle's first sample and from
/// its run's; its run and the run's heading).
pub fn sample_of(cycle: &DriveCycle, i: usize) -> TruthSample {
    let start = cycle.t_s.first().copied().unwrap_or(0.0);
    let run = cycle.run[i];
    let run_start = cycle.run.partition_point(|&r| r < run);
    TruthSample {
        time_s: cycle.t_s[i] - start,
        distance_m: cycle.x_m[i],
        speed_m_s: cycle.v_m_s[i],
        grade_rad: cycle.grade_rad[i],
        heading: cycle.heading(i),
        run: run as usize,
        run_time_s: cycle.t_s[i] - cycle.t_s[run_start],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(v: f64, grade: f64) -> TruthSample {
        TruthSample {
            time_s: 10.0,
            distance_m: 100.0,
            speed_m_s: v,
            grade_rad: grade,
            heading: 1.0,
            run: 0,
            run_time_s: 10.0,
        }
    }

    #[test]
    fn the_neutral_truth_is_the_equation_bit_for_bit() {
        let veh = VehicleParams::thesis();
        let neutral = MODEL_ERRORS.map(|e| e.neutral);
        let truth = Truth::from_values(&neutral);
        assert!(truth.is_empty());
        let s = sample(12.3, 0.02);
        assert_eq!(
            truth.acceleration(&veh, &s, 2000.0),
            veh.acceleration(2000.0, 12.3, 0.02)
        );
        assert_eq!(truth.needed_force(&veh, &s, 0.3, 1234.5), 1234.5);
        assert_eq!(truth.logged_force(1234.5), 1234.5);
    }

    #[test]
    fn the_dynamics_and_the_needed_force_are_one_equation() {
        // Every steady entry on: the force the truth needs for the acceleration it has
        // under F is F again (to rounding, ~1e-12 relative of forces ~1e3 N).
        let veh = VehicleParams::thesis();
        let truth = Truth::from_values(&[3.0, 0.0, 10.0, 0.03, 0.05, 0.0, 0.002, 1.1, -0.01]);
        let s = sample(15.0, 0.03);
        let f = 2100.0;
        let a = truth.acceleration(&veh, &s, f);
        let m = veh.mass_kg;
        let g = veh.gravity_m_s2;
        let equation = m * a
            + veh.drag_coefficient * veh.drag_factor_kg_m() * 15.0 * 15.0
            + veh.rolling_resistance * m * g * 0.03_f64.cos()
            + m * g * 0.03_f64.sin();
        let needed = truth.needed_force(&veh, &s, a, equation);
        assert!((needed - f).abs() < 1e-9, "{needed} vs {f}");
        // The calibration acts on the log only.
        assert!((truth.logged_force(f) - 1.05 * f).abs() < 1e-9);
    }
}
