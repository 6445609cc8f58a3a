//! The longitudinal vehicle model and the RK4 drive-cycle simulation (docs/model.md#vehicle).
//!
//! `M dV/dt = F_prop(t) − ½ ρ Cd A V² − Cr M g cos θ(X) − M g sin θ(X)`, brake force zero,
//! `F_prop(t) = τ0 (1 + a_τ sin(ω_τ t)) R_fd / r_wheel`. The cycle is integrated by classical
//! fixed-step RK4 at the sample step, with θ(X) the linear interpolation of the grade table.
//! A stall or running off the terrain is an error, never a silent NaN.

use thiserror::Error;

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

/// Drive-cycle settings (`[drive]`; docs/model.md#vehicle).
#[derive(Debug, Clone, PartialEq)]
pub struct DriveParams {
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

impl DriveParams {
    /// Propulsion force F_prop(t) = τ0 (1 + a_τ sin(ω_τ t)) R_fd / r_wheel \[N\] (thesis eq. 30).
    #[inline]
    pub fn propulsion_n(&self, vehicle: &VehicleParams, t_s: f64) -> f64 {
        let torque = self.torque_mean_n_m
            * (1.0 + self.torque_amplitude * (self.torque_frequency_rad_s * t_s).sin());
        torque * vehicle.final_drive_ratio / vehicle.wheel_radius_m
    }

    /// Number of samples N = steps + 1 (t = 0 … duration inclusive).
    pub fn samples(&self) -> usize {
        self.steps + 1
    }
}

/// Why a drive cycle could not be simulated.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum SimulationError {
    /// The speed fell to zero or below after the start: the grade is too steep for the force.
    #[error(
        "the vehicle stalls: its speed falls to {speed_m_s:.3} m/s at t = {time_s:.2} s, x = {position_m:.1} m (the grade is too steep for the propulsion force)"
    )]
    Stalled {
        /// Time of the first sample with V ≤ 0 \[s\].
        time_s: f64,
        /// Position there \[m\].
        position_m: f64,
        /// The speed there \[m/s\].
        speed_m_s: f64,
    },
    /// The vehicle passed the last point of the grade table.
    #[error(
        "the vehicle runs off the end of the terrain (x > {end_m} m) at t = {time_s:.2} s; make terrain.length longer or drive.duration shorter"
    )]
    RanOffTerrain {
        /// Time of the step that left the table \[s\].
        time_s: f64,
        /// Last grid point of the table \[m\].
        end_m: f64,
    },
    /// The state became NaN or infinite.
    #[error("the simulation diverged (non-finite state) at t = {time_s:.2} s")]
    NonFinite {
        /// Time at which it happened \[s\].
        time_s: f64,
    },
}

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
    /// Propulsion force F_prop(t) \[N\].
    pub f_prop_n: Vec<f64>,
    /// Model acceleration dV/dt at the sample's state \[m/s²\].
    pub accel_m_s2: Vec<f64>,
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
}

/// Simulate one drive cycle over `terrain` by fixed-step RK4 at the sample step.
pub fn simulate(
    vehicle: &VehicleParams,
    drive: &DriveParams,
    terrain: &GradeTable,
) -> Result<DriveCycle, SimulationError> {
    let h = drive.time_step_s;
    let n = drive.samples();
    let mut cycle = DriveCycle {
        t_s: Vec::with_capacity(n),
        x_m: Vec::with_capacity(n),
        v_m_s: Vec::with_capacity(n),
        grade_rad: Vec::with_capacity(n),
        f_prop_n: Vec::with_capacity(n),
        accel_m_s2: Vec::with_capacity(n),
    };
    let end_m = terrain.end_m();
    // dV/dt at time t (propulsion force f there), position x and speed v, or the error of
    // leaving the table.
    let accel = |t: f64, f: f64, x: f64, v: f64| -> Result<f64, SimulationError> {
        let grade = terrain
            .grade_at(x)
            .ok_or(SimulationError::RanOffTerrain { time_s: t, end_m })?;
        Ok(vehicle.acceleration(f, v, grade))
    };

    let (mut x, mut v) = (0.0_f64, drive.initial_speed_m_s);
    let mut f = drive.propulsion_n(vehicle, 0.0);
    for i in 0..n {
        let t = i as f64 * h;
        if !(x.is_finite() && v.is_finite()) {
            return Err(SimulationError::NonFinite { time_s: t });
        }
        if i > 0 && v <= 0.0 {
            return Err(SimulationError::Stalled {
                time_s: t,
                position_m: x,
                speed_m_s: v,
            });
        }
        let grade = terrain
            .grade_at(x)
            .ok_or(SimulationError::RanOffTerrain { time_s: t, end_m })?;
        cycle.t_s.push(t);
        cycle.x_m.push(x);
        cycle.v_m_s.push(v);
        cycle.grade_rad.push(grade);
        cycle.f_prop_n.push(f);
        cycle.accel_m_s2.push(vehicle.acceleration(f, v, grade));
        if i + 1 == n {
            break;
        }
        // Classical RK4 on (X, V): dX/dt = V, dV/dt = accel(t, X, V); the force at the
        // half step serves two stages and the one at the full step the next sample. The
        // full step's force is taken at the next sample's time t_{i+1} = (i+1)·Δt (the
        // time the cycle records), which can differ from t + Δt in the last bit.
        let f_mid = drive.propulsion_n(vehicle, t + 0.5 * h);
        let f_end = drive.propulsion_n(vehicle, (i + 1) as f64 * h);
        let k1x = v;
        let k1v = cycle.accel_m_s2[i];
        let k2x = v + 0.5 * h * k1v;
        let k2v = accel(t + 0.5 * h, f_mid, x + 0.5 * h * k1x, k2x)?;
        let k3x = v + 0.5 * h * k2v;
        let k3v = accel(t + 0.5 * h, f_mid, x + 0.5 * h * k2x, k3x)?;
        let k4x = v + h * k3v;
        let k4v = accel(t + h, f_end, x + h * k3x, k4x)?;
        x += h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
        v += h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
        f = f_end;
    }
    Ok(cycle)
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
            final_drive_ratio: 2.7,
            wheel_radius_m: 0.3,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn drive(duration_s: f64) -> DriveParams {
        DriveParams {
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
