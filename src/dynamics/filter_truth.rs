//! A truth that follows the filters' model (docs/model.md#filter-truth): the motion stepped
//! with the filters' Euler step and process noise, the grade a random walk in distance,
//! the mass drawn from the filters' prior, each anew in every realisation from its own
//! stream.

use super::{DriveCycle, VehicleParams};
use crate::noise::{NormalSequence, Stream};
use crate::terrain::GradeTable;
pub use crate::terrain::profiles::GradeWalk;

/// What a truth that follows the filters' model draws (each part off when `None` or 0).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FilterTruth {
    /// The speed equation's process noise per step (`truth.speed_process_sd`) \[m/s\].
    pub speed_process_sd: f64,
    /// The prior 1/M is drawn from (`truth.mass_from_prior`: the filters' prior).
    pub mass_prior: Option<InvMassPrior>,
    /// The grade's walk (`terrain.profile = "random_walk"`), its SDs multiplied by the
    /// terrain scale.
    pub grade_walk: Option<GradeWalk>,
}

/// A normal prior of 1/M: N(mean, sd²) (the filters' prior by the delta method,
/// N(1/M₀, (σ_M/M₀²)²)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InvMassPrior {
    /// Its mean \[1/kg\].
    pub mean: f64,
    /// Its SD \[1/kg\].
    pub sd: f64,
}

impl FilterTruth {
    /// Whether it draws anything: else the truth is the drive mode's.
    pub fn is_drawn(&self) -> bool {
        self.speed_process_sd > 0.0 || self.mass_prior.is_some() || self.grade_walk.is_some()
    }

    /// Realisation `r`'s cycle and true 1/M: from the nominal cycle's first speed, at its
    /// sample times with its logged force (a drive whose force does not depend on the
    /// motion), each step
    /// V_{k+1} = V_k + Δt·[θ₁(F_k − cV_k²) − g(Cr cos φ_k + sin φ_k)] + u_k,
    /// X_{k+1} = X_k + Δt·V_k, the grade the walk's (times `scale`) or the table's at X_k.
    /// The normals are drawn in one order whatever is on: 1/M's, φ₀'s, then u_k and w_k
    /// per step. An error says why the path cannot be used.
    pub fn cycle(
        &self,
        nominal: &DriveCycle,
        vehicle: &VehicleParams,
        table: Option<&GradeTable>,
        scale: f64,
        (seed, key, r): (u64, u64, u64),
    ) -> Result<(DriveCycle, f64), String> {
        let n = nominal.len();
        let mut z = vec![0.0; 2 * n];
        NormalSequence::for_realisation(seed, key, Stream::FilterTruth, r).fill(&mut z);
        let inv_mass = match self.mass_prior {
            Some(p) => p.mean + p.sd * z[0],
            None => 1.0 / vehicle.mass_kg,
        };
        if inv_mass.is_nan() || inv_mass <= 0.0 {
            return Err(format!("the drawn 1/M is {inv_mass}, not positive"));
        }
        let c =
            0.5 * vehicle.air_density_kg_m3 * vehicle.frontal_area_m2 * vehicle.drag_coefficient;
        let (g, cr) = (vehicle.gravity_m_s2, vehicle.rolling_resistance);
        let mut cycle = nominal.clone();
        let mut v = nominal.v_m_s[0];
        let mut x = nominal.x_m[0];
        let mut walk = self.grade_walk.map(|w| scale * w.sd0_rad * z[1]);
        for k in 0..n {
            let grade = match (walk, table) {
                (Some(phi), _) => phi,
                (None, Some(table)) => table
                    .grade_at(x)
                    .ok_or_else(|| format!("the vehicle ran off the terrain at {x:.0} m"))?,
                (None, None) => nominal.grade_rad[k],
            };
            let f = nominal.f_prop_n[k];
            let accel = inv_mass * (f - c * v * v) - g * (cr * grade.cos() + grade.sin());
            cycle.v_m_s[k] = v;
            cycle.x_m[k] = x;
            cycle.grade_rad[k] = grade;
            cycle.accel_m_s2[k] = accel;
            if k + 1 == n {
                break;
            }
            let dt = nominal.t_s[k + 1] - nominal.t_s[k];
            if let (Some(phi), Some(w)) = (&mut walk, self.grade_walk) {
                *phi += scale * (w.intensity * v.abs() * dt).sqrt() * z[2 * k + 3];
            }
            x += dt * v;
            v += dt * accel + self.speed_process_sd * z[2 * k + 2];
            if v.is_nan() || v <= 0.0 {
                return Err(format!(
                    "the vehicle stalled at {:.2} s",
                    nominal.t_s[k + 1]
                ));
            }
        }
        Ok((cycle, inv_mass))
    }
}
