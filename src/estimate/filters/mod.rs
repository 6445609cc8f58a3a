//! Mass and grade estimated together, without a grade sensor: the filters' model of the
//! longitudinal motion ([`FilterModel`]), the extended Kalman filter ([`ekf`]), recursive
//! least squares with a forgetting factor per parameter ([`rls_mf`]) and the posterior
//! Cramér–Rao bound of the model ([`pcrlb`]) (docs/model.md#no-grade-sensor).
//!
//! The state is x = \[V, θ₁ = 1/M, φ\]: the speed \[m/s\], the inverse mass \[1/kg\] (constant)
//! and the grade \[rad\] (a random walk in distance). Cd, Cr, A and ρ are known. One step of
//! Δt from sample k to k + 1 with the propulsion force F_k:
//!
//! ```text
//! V_{k+1} = V_k + Δt·[θ₁(F_k − c V_k²) − g(Cr cos φ_k + sin φ_k)] + u_k,  u_k ~ N(0, q_v)
//! θ₁      constant
//! φ_{k+1} = φ_k + w_k,                                            w_k ~ N(0, q·|V_k|·Δt)
//! z_k     = V_k + e_k,                                            e_k ~ N(0, σ_v²)
//! ```
//!
//! with c = ½ρCdA.

use nalgebra::Matrix3;

pub use ekf::Prior;

pub mod ekf;
pub mod pcrlb;
pub mod rls_mf;

#[cfg(test)]
mod tests;

/// A state \[V, θ₁, φ\].
pub type State = [f64; 3];

/// The index of the speed, the inverse mass and the grade in a [`State`].
pub const SPEED: usize = 0;
/// See [`SPEED`].
pub const INV_MASS: usize = 1;
/// See [`SPEED`].
pub const GRADE: usize = 2;

/// The times after the first sample at which the filters and the bound are also read
/// (besides the last sample) \[s\].
pub const CHECKPOINTS_S: [f64; 3] = [60.0, 120.0, 300.0];

/// The filters' model of the motion (docs/model.md#no-grade-sensor).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FilterModel {
    /// c = ½ρCdA \[kg/m\].
    pub drag: f64,
    /// Cr \[-\].
    pub rolling: f64,
    /// g \[m/s²\].
    pub g: f64,
    /// q_v, the variance of the speed equation's process noise per step \[m²/s²\].
    pub speed_process_var: f64,
    /// q, the grade walk's intensity \[rad²/m\].
    pub grade_walk: f64,
    /// σ_v², the variance of the speed measurement's noise \[m²/s²\].
    pub speed_noise_var: f64,
}

impl FilterModel {
    /// The state after one step of `dt` from `x` with the force `force` (the noise-free part
    /// of the transition).
    #[inline]
    pub fn step(&self, x: &State, force: f64, dt: f64) -> State {
        let [v, inv_mass, grade] = *x;
        let accel = inv_mass * (force - self.drag * v * v)
            - self.g * (self.rolling * grade.cos() + grade.sin());
        [v + dt * accel, inv_mass, grade]
    }

    /// The Jacobian of [`FilterModel::step`] at `x`.
    #[inline]
    pub fn jacobian(&self, x: &State, force: f64, dt: f64) -> Matrix3<f64> {
        let [v, inv_mass, grade] = *x;
        let (sin, cos) = grade.sin_cos();
        Matrix3::new(
            1.0 - 2.0 * dt * inv_mass * self.drag * v,
            dt * (force - self.drag * v * v),
            dt * self.g * (self.rolling * sin - cos),
            0.0,
            1.0,
            0.0,
            0.0,
            0.0,
            1.0,
        )
    }

    /// The variance of the grade walk's step of `dt` at speed `v`, q·|V|·Δt \[rad²\].
    #[inline]
    pub fn grade_step_var(&self, v: f64, dt: f64) -> f64 {
        self.grade_walk * v.abs() * dt
    }
}

/// One path of the truth the bound is taken along: per sample its time, speed, grade and
/// force, and its inverse mass.
#[derive(Debug, Clone, Copy)]
pub struct TruePath<'a> {
    /// Sample times \[s\].
    pub t: &'a [f64],
    /// V \[m/s\].
    pub v: &'a [f64],
    /// φ \[rad\].
    pub grade: &'a [f64],
    /// F \[N\].
    pub force: &'a [f64],
    /// θ₁ \[1/kg\].
    pub inv_mass: f64,
}

impl TruePath<'_> {
    /// The state at sample `k`.
    pub fn state(&self, k: usize) -> State {
        [self.v[k], self.inv_mass, self.grade[k]]
    }

    /// The number of samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// Whether it has no samples.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }
}

/// The sample index at which each of [`CHECKPOINTS_S`] is read in `t`: the first sample at
/// least that long after the first (`None`: the samples end before it).
pub fn checkpoint_indices(t: &[f64]) -> [Option<usize>; 3] {
    let t0 = t.first().copied().unwrap_or(0.0);
    CHECKPOINTS_S.map(|c| {
        let i = t.partition_point(|&s| s - t0 < c);
        (i < t.len()).then_some(i)
    })
}

/// Where an estimate of θ₁ settles: the first sample after which it stays within `band`
/// of `target` (`None`: it ends outside the band), tracked one sample at a time.
#[derive(Debug, Clone, Copy)]
pub struct Settle {
    target: f64,
    band: f64,
    /// The first sample after the last one outside the band.
    from: usize,
}

impl Settle {
    /// Tracking towards `target` within ±`band`.
    pub fn new(target: f64, band: f64) -> Self {
        Settle {
            target,
            band,
            from: 0,
        }
    }

    /// The estimate at sample `k`.
    #[inline]
    pub fn see(&mut self, k: usize, estimate: f64) {
        // NaN counts as outside.
        let inside = (estimate - self.target).abs() <= self.band;
        if !inside {
            self.from = k + 1;
        }
    }

    /// The sample it settled at, of `n` seen.
    pub fn settled(&self, n: usize) -> Option<usize> {
        (self.from < n).then_some(self.from)
    }
}

/// Whether the estimators read a measured grade (`estimation.grade`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum GradeSource {
    /// The measured grade (with its noise, offset or map error), as the regression reads it.
    #[default]
    Measured,
    /// None: no grade signal reaches any estimator.
    None,
}

/// The settings of the filters (`[estimation]`; docs/model.md#no-grade-sensor), with the
/// vehicle's Cd and Cr they take as known.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FilterSettings {
    /// The prior of the mass and the grade.
    pub prior: Prior,
    /// √q_v, the speed equation's process noise per step (`speed_process_sd`) \[m/s\].
    pub speed_process_sd: f64,
    /// q, the grade walk's intensity (`grade_walk`) \[rad²/m\].
    pub grade_walk: f64,
    /// λ₁ of `rls_mf` (`forgetting_mass`).
    pub forgetting_mass: f64,
    /// λ₂ of `rls_mf` (`forgetting_grade`).
    pub forgetting_grade: f64,
    /// The half-width of `rls_mf`'s central difference (`difference_window`) \[s\].
    pub difference_window_s: f64,
    /// The vehicle's Cd \[-\].
    pub drag_coefficient: f64,
    /// The vehicle's Cr \[-\].
    pub rolling: f64,
}

impl Default for FilterSettings {
    /// The defaults of `[estimation]`'s keys; the thesis vehicle's Cd and Cr.
    fn default() -> Self {
        FilterSettings {
            prior: Prior {
                mass_kg: 1500.0,
                mass_sd_kg: 250.0,
                grade_sd_rad: 0.01,
            },
            speed_process_sd: 1e-3,
            grade_walk: 1e-7,
            forgetting_mass: 1.0,
            forgetting_grade: 0.999,
            difference_window_s: 0.5,
            drag_coefficient: 0.3,
            rolling: 0.01,
        }
    }
}

impl FilterSettings {
    /// The filters' model for a regression with k = ½ρA `k`, gravity `g` and speed noise
    /// of SD `speed_sd`.
    pub fn model(&self, k: f64, g: f64, speed_sd: f64) -> FilterModel {
        FilterModel {
            drag: k * self.drag_coefficient,
            rolling: self.rolling,
            g,
            speed_process_var: self.speed_process_sd * self.speed_process_sd,
            grade_walk: self.grade_walk,
            speed_noise_var: speed_sd * speed_sd,
        }
    }
}
