//! The extended Kalman filter of \[V, 1/M, φ\] from the measured speed and force
//! (docs/model.md#ekf).
//!
//! Started at x̂₀ = \[z₀, 1/M₀, 0\], P₀ = diag(σ_v², (σ_M/M₀²)², σ_φ0²); each step predicts
//! with the Jacobian at the estimate, P⁻ = F P Fᵀ + diag(q_v, 0, q·|V̂|·Δt), and updates with
//! the next measured speed: S = P⁻₀₀ + σ_v², K = P⁻e₀/S, x̂ = x⁻ + K(z − V⁻),
//! P = P⁻ − K Kᵀ S.

use nalgebra::{Matrix3, Vector3};

use super::{CHECKPOINTS_S, FilterModel, GRADE, INV_MASS, SPEED, State, checkpoint_indices};

/// The prior of the filters: the mass M₀ ± σ_M \[kg\] and the grade's SD at the start
/// \[rad\] (its mean 0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prior {
    /// M₀ \[kg\].
    pub mass_kg: f64,
    /// σ_M \[kg\].
    pub mass_sd_kg: f64,
    /// σ_φ0 \[rad\].
    pub grade_sd_rad: f64,
}

impl Prior {
    /// 1/M₀ \[1/kg\].
    pub fn inv_mass(&self) -> f64 {
        1.0 / self.mass_kg
    }

    /// The variance of 1/M by the delta method, (σ_M/M₀²)² \[1/kg²\].
    pub fn inv_mass_var(&self) -> f64 {
        (self.mass_sd_kg / (self.mass_kg * self.mass_kg)).powi(2)
    }
}

/// The filter's estimate and covariance at one sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reading {
    /// x̂.
    pub state: State,
    /// P.
    pub cov: Matrix3<f64>,
}

/// What the filter gives after a run over the samples.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EkfRun {
    /// At the last sample.
    pub end: Reading,
    /// At each of [`CHECKPOINTS_S`] the samples reach.
    pub checkpoints: [Option<Reading>; CHECKPOINTS_S.len()],
}

/// The filter over measured speeds `z` and forces `force` at times `t` (one of each per
/// sample, at least one sample); `watch` sees the estimate of 1/M at every sample.
pub fn run(
    model: &FilterModel,
    prior: &Prior,
    t: &[f64],
    z: &[f64],
    force: &[f64],
    mut watch: impl FnMut(usize, f64),
) -> EkfRun {
    let n = t.len();
    assert!(
        n > 0 && z.len() == n && force.len() == n,
        "one z and F per sample"
    );
    let at = checkpoint_indices(t);
    let mut checkpoints = [None; CHECKPOINTS_S.len()];
    let mut x: State = [z[0], prior.inv_mass(), 0.0];
    let mut p = Matrix3::from_diagonal(&Vector3::new(
        model.speed_noise_var,
        prior.inv_mass_var(),
        prior.grade_sd_rad * prior.grade_sd_rad,
    ));
    let read = |k: usize, x: State, p: Matrix3<f64>, checkpoints: &mut [Option<Reading>; 3]| {
        for (c, &i) in checkpoints.iter_mut().zip(&at) {
            if i == Some(k) {
                *c = Some(Reading { state: x, cov: p });
            }
        }
    };
    watch(0, x[INV_MASS]);
    read(0, x, p, &mut checkpoints);
    for k in 0..n - 1 {
        let dt = t[k + 1] - t[k];
        let jac = model.jacobian(&x, force[k], dt);
        let q_grade = model.grade_step_var(x[SPEED], dt);
        x = model.step(&x, force[k], dt);
        let mut prior_cov = jac * p * jac.transpose();
        prior_cov[(SPEED, SPEED)] += model.speed_process_var;
        prior_cov[(GRADE, GRADE)] += q_grade;
        let s = prior_cov[(SPEED, SPEED)] + model.speed_noise_var;
        let gain = prior_cov.column(SPEED) / s;
        let innovation = z[k + 1] - x[SPEED];
        for (xi, ki) in x.iter_mut().zip(gain.iter()) {
            *xi += ki * innovation;
        }
        p = prior_cov - gain * gain.transpose() * s;
        // Symmetric to the last bit, whatever the rounding of the products.
        p = (p + p.transpose()) * 0.5;
        watch(k + 1, x[INV_MASS]);
        read(k + 1, x, p, &mut checkpoints);
    }
    EkfRun {
        end: Reading { state: x, cov: p },
        checkpoints,
    }
}

/// The normalised estimation error squared (x̂ − x)ᵀ P⁻¹ (x̂ − x) of `reading` against the
/// true state `truth` (NaN where P is not positive definite).
pub fn nees(reading: &Reading, truth: &State) -> f64 {
    let e = Vector3::from_fn(|i, _| reading.state[i] - truth[i]);
    match crate::numeric::linalg::solve_spd(&reading.cov, &e) {
        Ok(x) => e.dot(&x),
        Err(_) => f64::NAN,
    }
}
