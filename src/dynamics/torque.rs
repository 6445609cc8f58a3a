//! The drive mode `torque`: F_prop(t) = τ0 (1 + a_τ sin(ω_τ t)) R_fd / r_wheel, the cycle
//! integrated by classical fixed-step RK4 at the sample step with θ(X) the linear
//! interpolation of the grade table (docs/model.md#vehicle).

use std::cell::RefCell;
use std::sync::Arc;

use super::truth::TruthSample;
use super::{CycleSource, DriveCycle, MAX_SAMPLES, Road, SimulationError, Truth, VehicleParams};
use std::convert::Infallible;

use crate::numeric::ode::{Stage, rk4_step_in};
use crate::numeric::simd::{Lanes, Quad, Scalar};
use crate::settings::{KeyError, Params};
use crate::terrain::GradeTable;

/// The thesis's drive mode `torque`: a sinusoidal final-drive torque, the speed integrated
/// by RK4 (`[drive]`; docs/model.md#vehicle).
#[derive(Debug, Clone, PartialEq)]
pub struct TorqueDrive {
    /// Length of the cycle \[s\].
    pub duration_s: f64,
    /// Sample and integration step \[s\].
    pub time_step_s: f64,
    /// Number of steps, duration / time_step; the cycle has `steps + 1` samples.
    pub steps: usize,
    /// Speed at t = 0 \[m/s\].
    pub initial_speed_m_s: f64,
    /// Mean final-drive torque τ0 \[N·m\].
    pub torque_mean_n_m: f64,
    /// Relative torque amplitude a_τ \[-\].
    pub torque_amplitude: f64,
    /// Torque oscillation frequency ω_τ \[rad/s\].
    pub torque_frequency_rad_s: f64,
}

impl TorqueDrive {
    /// Propulsion force F_prop(t) = τ0 (1 + a_τ sin(ω_τ t)) R_fd / r_wheel \[N\] (thesis eq. 30).
    #[inline]
    pub fn propulsion_n(&self, vehicle: &VehicleParams, t_s: f64) -> f64 {
        let torque = self.torque_mean_n_m
            * (1.0 + self.torque_amplitude * (self.torque_frequency_rad_s * t_s).sin());
        let drivetrain = vehicle
            .drivetrain
            .expect("the torque mode is validated to have a drivetrain");
        torque * drivetrain.final_drive_ratio / drivetrain.wheel_radius_m
    }

    /// Number of samples N = steps + 1 (t = 0 … duration inclusive).
    pub fn samples(&self) -> usize {
        self.steps + 1
    }
}

impl TorqueDrive {
    /// The mode's keys of `[drive]`.
    pub const KEYS: &'static [&'static str] = &[
        "duration",
        "time_step",
        "initial_speed",
        "torque_mean",
        "torque_amplitude",
        "torque_frequency",
    ];

    /// Read `[drive]`: `duration` (a whole multiple of `time_step`), `time_step`,
    /// `initial_speed` and the torque keys.
    pub fn parse(p: &Params<'_>) -> Result<Arc<dyn CycleSource>, KeyError> {
        p.only(Self::KEYS)?;
        let (duration_s, time_step_s, steps) = duration_steps(p)?;
        Ok(Arc::new(TorqueDrive {
            duration_s,
            time_step_s,
            steps,
            initial_speed_m_s: p.non_negative("initial_speed")?,
            torque_mean_n_m: p.non_negative("torque_mean")?,
            torque_amplitude: p.non_negative("torque_amplitude")?,
            torque_frequency_rad_s: p.non_negative("torque_frequency")?,
        }))
    }
}

/// `drive.duration` and `drive.time_step` of a mode integrated at a fixed step: the duration,
/// the step and the number of steps (the duration a whole multiple of the step).
pub(super) fn duration_steps(p: &Params<'_>) -> Result<(f64, f64, usize), KeyError> {
    let duration_s = p.positive("duration")?;
    let time_step_s = p.positive("time_step")?;
    let steps = (duration_s / time_step_s).round();
    if (steps * time_step_s - duration_s).abs() > 1e-9 * duration_s || steps < 1.0 {
        return Err(p.error(
            "duration",
            format!(
                "must be a whole multiple of drive.time_step ({time_step_s} s), got {duration_s} s"
            ),
        ));
    }
    if steps + 1.0 > MAX_SAMPLES as f64 {
        return Err(p.error(
            "time_step",
            format!(
                "gives {} samples; at most {MAX_SAMPLES} are supported",
                steps + 1.0
            ),
        ));
    }
    Ok((duration_s, time_step_s, steps as usize))
}

/// The grade table of `road`, which the torque mode is validated to have.
fn terrain(road: Road<'_>) -> &GradeTable {
    road.table
        .expect("the torque mode is validated to have a terrain profile")
}

impl CycleSource for TorqueDrive {
    /// The cycle is integrated into a spare ([`DriveCycle::one_run`]).
    fn reuses_spares(&self) -> bool {
        true
    }

    fn cycle(
        &self,
        vehicle: &VehicleParams,
        road: Road<'_>,
        truth: &Truth,
    ) -> Result<DriveCycle, SimulationError> {
        simulate_truth(vehicle, self, terrain(road), truth)
    }

    fn cycles(
        &self,
        vehicle: &VehicleParams,
        road: Road<'_>,
        truths: &[Truth],
    ) -> Vec<Result<DriveCycle, SimulationError>> {
        simulate_truths(vehicle, self, terrain(road), truths)
    }

    fn duration_step(&self) -> Option<f64> {
        Some(self.time_step_s)
    }

    fn needs_drivetrain(&self) -> bool {
        true
    }

    fn describe(&self) -> String {
        format!(
            "torque {} N·m ± {} %, {} s",
            self.torque_mean_n_m,
            100.0 * self.torque_amplitude,
            self.duration_s
        )
    }
}

/// Simulate one drive cycle over `terrain` by fixed-step RK4 at the sample step.
pub fn simulate(
    vehicle: &VehicleParams,
    drive: &TorqueDrive,
    terrain: &GradeTable,
) -> Result<DriveCycle, SimulationError> {
    simulate_truth(vehicle, drive, terrain, &Truth::default())
}

/// [`simulate`] for a truth that differs from the equation by `truth`: RK4 on the truth's
/// dynamics, the truth's acceleration and the logged force recorded
/// (docs/model.md#model-errors).
fn simulate_truth(
    vehicle: &VehicleParams,
    drive: &TorqueDrive,
    terrain: &GradeTable,
    truth: &Truth,
) -> Result<DriveCycle, SimulationError> {
    let [cycle] = simulate_lanes(Scalar, vehicle, drive, terrain, &[truth])
        .try_into()
        .expect("one cycle per truth");
    cycle
}

/// [`simulate_truth`] of each of `truths` (at most `L::WIDTH`), integrated side by side in
/// the lanes of `l`: each lane's arithmetic is the one truth's alone, in the same order (so
/// the same bits), and the cycles, whose every stage waits on the one before, overlap in the
/// processor. A truth that fails (it stalls or leaves the terrain) stops its own lane only.
fn simulate_lanes<L: Lanes>(
    l: L,
    vehicle: &VehicleParams,
    drive: &TorqueDrive,
    terrain: &GradeTable,
    truths: &[&Truth],
) -> Vec<Result<DriveCycle, SimulationError>> {
    const MAX: usize = 8;
    let lanes = truths.len();
    assert!(
        lanes <= L::WIDTH && L::WIDTH <= MAX,
        "at most a number's lanes of truths"
    );
    let h = drive.time_step_s;
    let n = drive.samples();
    let mut cycles: Vec<DriveCycle> = (0..lanes).map(|_| DriveCycle::one_run(n)).collect();
    let mut failed: [Option<SimulationError>; MAX] = std::array::from_fn(|_| None);
    let end_m = terrain.end_m();
    let state = TruthSample::forwards;
    // dV/dt of `truth` at time t (propulsion force f there), position x and speed v, or the
    // error of leaving the table.
    let accel = |truth: &Truth, t: f64, f: f64, x: f64, v: f64| -> Result<f64, SimulationError> {
        let grade = terrain
            .grade_at(x)
            .ok_or(SimulationError::RanOffTerrain { time_s: t, end_m })?;
        Ok(truth.acceleration(vehicle, &state(t, x, v, grade), f))
    };

    // Each lane's position, speed and acceleration at the current sample (the lanes after
    // `lanes` stay unused).
    let (mut x, mut v, mut a) = ([0.0_f64; MAX], [drive.initial_speed_m_s; MAX], [0.0; MAX]);
    let mut f = drive.propulsion_n(vehicle, 0.0);
    let stage_forces = stage_forces(drive, vehicle);
    for i in 0..n {
        let t = i as f64 * h;
        for (k, (truth, cycle)) in truths.iter().zip(&mut cycles).enumerate() {
            if failed[k].is_some() {
                continue;
            }
            let (xk, vk) = (x[k], v[k]);
            let mut sample = || -> Result<f64, SimulationError> {
                SimulationError::check_state(i, t, xk, vk)?;
                let grade = terrain
                    .grade_at(xk)
                    .ok_or(SimulationError::RanOffTerrain { time_s: t, end_m })?;
                let accel = truth.acceleration(vehicle, &state(t, xk, vk, grade), f);
                cycle.t_s.push(t);
                cycle.x_m.push(xk);
                cycle.v_m_s.push(vk);
                cycle.grade_rad.push(grade);
                cycle.f_prop_n.push(truth.logged_force(f));
                cycle.accel_m_s2.push(accel);
                Ok(accel)
            };
            match sample() {
                Ok(accel) => a[k] = accel,
                Err(e) => failed[k] = Some(e),
            }
        }
        // The last sample, or every lane failed.
        if i + 1 == n || failed[..lanes].iter().all(Option::is_some) {
            break;
        }
        // Classical RK4 on (X, V): dX/dt = V, dV/dt = accel(t, X, V); the force at the
        // half step serves two stages and the one at the full step the next sample. The
        // full step's force is taken at the next sample's time t_{i+1} = (i+1)·Δt (the
        // time the cycle records), which can differ from t + Δt in the last bit.
        let [f_mid, f_end] = stage_forces[i];
        let start = [l.load(&x, 0), l.load(&v, 0)];
        let k1 = [start[1], l.load(&a, 0)];
        let step = rk4_step_in(l, start, h, k1, |stage, [xs, vs]| {
            let (ts, fs) = match stage {
                Stage::Half => (t + 0.5 * h, f_mid),
                Stage::Full => (t + h, f_end),
            };
            let (mut xa, mut va, mut out) = ([0.0; MAX], [0.0; MAX], [0.0; MAX]);
            l.store(xs, &mut xa, 0);
            l.store(vs, &mut va, 0);
            for (k, truth) in truths.iter().enumerate() {
                if failed[k].is_some() {
                    continue;
                }
                match accel(truth, ts, fs, xa[k], va[k]) {
                    Ok(accel) => out[k] = accel,
                    Err(e) => failed[k] = Some(e),
                }
            }
            Ok::<_, Infallible>([vs, l.load(&out, 0)])
        });
        let Ok([x_next, v_next]) = step;
        l.store(x_next, &mut x, 0);
        l.store(v_next, &mut v, 0);
        f = f_end;
    }
    cycles
        .into_iter()
        .zip(failed)
        .map(|(cycle, failed)| match failed {
            Some(e) => Err(e),
            None => Ok(cycle),
        })
        .collect()
}

/// [`simulate_truth`] of each of `truths`, four at a time side by side
/// ([`simulate_lanes`]).
fn simulate_truths(
    vehicle: &VehicleParams,
    drive: &TorqueDrive,
    terrain: &GradeTable,
    truths: &[Truth],
) -> Vec<Result<DriveCycle, SimulationError>> {
    let refs: Vec<&Truth> = truths.iter().collect();
    refs.chunks(Quad::WIDTH)
        .flat_map(|chunk| simulate_lanes(Quad, vehicle, drive, terrain, chunk))
        .collect()
}

/// The propulsion force of every RK4 step of `drive` for `vehicle`: at step i's half step
/// t_i + Δt/2 (t_i = i·Δt) and at the next sample's time (i + 1)·Δt. The same for every
/// realisation of a drive, so each thread keeps those of the last drive it integrated
/// (a drive drawing gusts is integrated again in every realisation).
fn stage_forces(drive: &TorqueDrive, vehicle: &VehicleParams) -> Arc<[[f64; 2]]> {
    // Every number the forces are made of, by its bits (−0 is not +0).
    type Key = ([u64; 7], Option<[u64; 2]>);
    type Kept = Option<(Key, Arc<[[f64; 2]]>)>;
    thread_local! {
        static LAST: RefCell<Kept> = const { RefCell::new(None) };
    }
    let drivetrain = vehicle
        .drivetrain
        .map(|d| [d.final_drive_ratio.to_bits(), d.wheel_radius_m.to_bits()]);
    let key = (
        [
            drive.duration_s.to_bits(),
            drive.time_step_s.to_bits(),
            drive.steps as u64,
            drive.initial_speed_m_s.to_bits(),
            drive.torque_mean_n_m.to_bits(),
            drive.torque_amplitude.to_bits(),
            drive.torque_frequency_rad_s.to_bits(),
        ],
        drivetrain,
    );
    let make = || -> Arc<[[f64; 2]]> {
        let h = drive.time_step_s;
        (0..drive.samples().saturating_sub(1))
            .map(|i| {
                let t = i as f64 * h;
                [
                    drive.propulsion_n(vehicle, t + 0.5 * h),
                    drive.propulsion_n(vehicle, (i + 1) as f64 * h),
                ]
            })
            .collect()
    };
    LAST.with(|last| {
        let mut last = last.borrow_mut();
        match &*last {
            Some((k, forces)) if *k == key => forces.clone(),
            _ => {
                let forces = make();
                *last = Some((key, forces.clone()));
                forces
            }
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn drive(duration_s: f64) -> TorqueDrive {
        TorqueDrive {
            duration_s,
            time_step_s: 0.01,
            steps: (duration_s / 0.01).round() as usize,
            initial_speed_m_s: 0.0,
            torque_mean_n_m: 225.0,
            torque_amplitude: 0.0,
            torque_frequency_rad_s: 0.1,
        }
    }

    #[test]
    fn flat_road_constant_force_matches_the_closed_form() {
        // With constant F, no grade: M dV/dt = F' − kCd V², F' = F − Cr M g, whose solution
        // from rest is V(t) = V∞ tanh(t F' / (M V∞)), V∞ = sqrt(F'/(k Cd)).
        let veh = VehicleParams::thesis();
        let d = drive(60.0);
        let flat = GradeTable::from_grades(vec![0.0; 5000]);
        let cycle = simulate(&veh, &d, &flat).unwrap();
        let f_net =
            d.propulsion_n(&veh, 0.0) - veh.rolling_resistance * veh.mass_kg * veh.gravity_m_s2;
        let v_inf = (f_net / (veh.drag_factor_kg_m() * veh.drag_coefficient)).sqrt();
        for i in (0..cycle.len()).step_by(500) {
            let t = cycle.t_s[i];
            let exact = v_inf * (t * f_net / (veh.mass_kg * v_inf)).tanh();
            // RK4 global error ~ C h^4 with h = 0.01 s: far below 1e-9 m/s here.
            assert!(
                (cycle.v_m_s[i] - exact).abs() < 1e-9,
                "t={t}: {} vs {exact}",
                cycle.v_m_s[i]
            );
        }
    }

    #[test]
    fn truths_side_by_side_are_each_truth_alone_bit_for_bit() {
        use crate::dynamics::truth::{MODEL_ERRORS, entry_index};
        // A rolling road that ends at 600 m: with a steady wind from −20 m/s (a tailwind)
        // to +30 m/s (a headwind), and gusts drawn per truth, some lanes run off the road,
        // some stall on a climb, some drive it; each lane's cycle (or error) is the one its
        // truth gives alone, whichever lanes share its group and however many there are.
        let veh = VehicleParams::thesis();
        let d = drive(45.0);
        let grades = (0..600)
            .map(|j| 0.05 * (f64::from(j) / 45.0).sin())
            .collect();
        let road = GradeTable::from_grades(grades);
        let times: Arc<[f64]> = (0..d.samples()).map(|i| i as f64 * 0.01).collect();
        let truths: Vec<Truth> = (0..11u32)
            .map(|r| {
                let mut values = MODEL_ERRORS.map(|e| e.neutral);
                values[entry_index("wind_speed").unwrap()] = -20.0 + 5.0 * f64::from(r);
                values[entry_index("wind_gust_sd").unwrap()] = 1.5;
                let times = std::slice::from_ref(&times);
                Truth::from_values(&values).realise(3, 1, u64::from(r), times)
            })
            .collect();
        let alone: Vec<_> = truths
            .iter()
            .map(|truth| simulate_truth(&veh, &d, &road, truth))
            .collect();
        let errors = alone.iter().filter(|c| c.is_err()).count();
        let what: Vec<String> = alone
            .iter()
            .map(|c| match c {
                Ok(c) => format!("ok {:.0} m", c.x_m.last().unwrap()),
                Err(e) => e.to_string(),
            })
            .collect();
        assert!(
            0 < errors && errors < alone.len(),
            "{errors} failed: {what:#?}"
        );
        let bits = |c: &Result<DriveCycle, SimulationError>| match c {
            Ok(c) => Ok([
                &c.t_s,
                &c.x_m,
                &c.v_m_s,
                &c.grade_rad,
                &c.f_prop_n,
                &c.accel_m_s2,
            ]
            .map(|v| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>())),
            Err(e) => Err(e.to_string()),
        };
        for from in 0..3 {
            let together = simulate_truths(&veh, &d, &road, &truths[from..]);
            assert_eq!(together.len(), truths.len() - from);
            for (i, (a, b)) in alone[from..].iter().zip(&together).enumerate() {
                assert_eq!(bits(a), bits(b), "truth {}", from + i);
            }
        }
    }

    #[test]
    fn a_wall_stalls_the_vehicle_with_a_named_error() {
        let veh = VehicleParams::thesis();
        let mut grades = vec![0.0; 200];
        grades.extend(vec![0.5; 4800]); // a 0.5 rad climb: M g sin θ ≫ F_prop
        let err = simulate(&veh, &drive(100.0), &GradeTable::from_grades(grades)).unwrap_err();
        assert!(matches!(err, SimulationError::Stalled { .. }), "{err}");
    }

    #[test]
    fn a_short_road_is_run_off() {
        let veh = VehicleParams::thesis();
        let err =
            simulate(&veh, &drive(100.0), &GradeTable::from_grades(vec![0.0; 50])).unwrap_err();
        assert!(
            matches!(err, SimulationError::RanOffTerrain { .. }),
            "{err}"
        );
    }
}
