//! The estimators of the vehicle regression: each builds its normal equations from a
//! realisation's [`Moments`] (see docs/model.md#estimators).
//!
//! An estimator is one [`Estimator`] impl listed in [`ESTIMATORS`]: the study file names it,
//! the model runs every listed one on the same draws, the output and the summary take its
//! name from the layout. Nothing else matches on it.

use std::fmt;
use std::ops::Deref;

use nalgebra::{Matrix3, Vector3};

use super::bounds::Bound;
use super::channels::{Channel, NoiseLevels};
use super::moments::{Moments, Rows, RowsView};
use super::regression::Regression;
use super::rls::Rls;
use super::wbcls::Wbcls;
use crate::numeric::linalg::{SolveError, solve_spd};

/// Everything an estimator may use from one realisation: what a real log would give (the
/// measured sums and rows, the sample times, the known noise levels), never the noise-free
/// signals; the truth only to score itself (the RLS settle time).
#[derive(Debug, Clone, Copy)]
pub struct Realisation<'a> {
    /// The sums of the measured rows.
    pub moments: &'a Moments,
    /// The measured rows (`Some` when an estimator of the study [needs them](Estimator::needs_rows)).
    pub rows: Option<&'a Rows>,
    /// The condition's regression: only its sample times `t`, k = ½ρA and g are read.
    pub regression: &'a Regression,
    /// The condition's noise levels (known to the estimator, as in the thesis).
    pub noise: &'a NoiseLevels,
    /// The estimator settings of the study.
    pub settings: &'a EstimatorSettings,
    /// The true θ (for scores such as the settle time, never for the estimate).
    pub truth: &'a [f64; 3],
}

impl<'a> Realisation<'a> {
    /// The measured rows; an estimator that reads them says so in
    /// [`Estimator::needs_rows`], so the model always provides them.
    pub fn rows(&self) -> RowsView<'a> {
        self.rows
            .expect("the model provides the rows to an estimator that needs them")
            .view(self.regression)
    }
}

/// Study settings of the estimators (`[estimation]`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EstimatorSettings {
    /// Exponential forgetting factor λ of `rls`, 0 < λ ≤ 1 (1: no forgetting).
    pub forgetting: f64,
}

impl Default for EstimatorSettings {
    fn default() -> Self {
        EstimatorSettings { forgetting: 1.0 }
    }
}

/// One estimator's result on one realisation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    /// θ̂, or why the normal equations could not be solved.
    pub theta: Result<Vector3<f64>, SolveError>,
    /// `rls` only: the time \[s\] after which the 1/M estimate stays within ±2 % of its
    /// truth, from the first row (`None`: never, or not this estimator).
    pub settle_time_s: Option<f64>,
}

impl Estimate {
    /// An estimate with nothing but θ̂.
    pub fn theta(theta: Result<Vector3<f64>, SolveError>) -> Self {
        Estimate {
            theta,
            settle_time_s: None,
        }
    }
}

/// An estimator of θ from one realisation.
pub trait Estimator: Sync + Send + fmt::Debug {
    /// Name in study files and in the `estimator` column.
    fn name(&self) -> &'static str;

    /// One line on what it is.
    fn description(&self) -> &'static str;

    /// Whether it reads the measured rows, not only their sums (the model then keeps the
    /// rows of each realisation in memory).
    fn needs_rows(&self) -> bool {
        false
    }

    /// Its estimate from the realisation.
    fn estimate(&self, r: &Realisation<'_>) -> Estimate;

    /// Whether it compensates the speed noise's bias with the noise's moments (BCLS and
    /// its kin): such an estimator stays unbiased under a differentiated acceleration with
    /// AR(1) speed noise only when the samples are evenly spaced.
    fn compensates_speed_noise(&self) -> bool {
        false
    }

    /// Whether `bound` is reported next to this estimator's estimates (where the bound
    /// applies to the noise at all): a bound that does not describe this estimator's
    /// spread is left out (NaN) rather than misread. Every bound by default.
    fn reports(&self, bound: &Bound, settings: &EstimatorSettings) -> bool {
        let _ = (bound, settings);
        true
    }
}

/// Ordinary least squares on the noisy regressors (the thesis).
#[derive(Debug, Clone, Copy)]
pub struct Ols;

impl Estimator for Ols {
    fn name(&self) -> &'static str {
        "ols"
    }

    fn description(&self) -> &'static str {
        "ordinary least squares on the measured regressors (the thesis)"
    }

    fn estimate(&self, r: &Realisation<'_>) -> Estimate {
        Estimate::theta(solve(&r.moments.ols_system(r.regression.k)))
    }
}

/// Bias-compensated least squares for speed noise of known σ_v.
#[derive(Debug, Clone, Copy)]
pub struct Bcls;

impl Estimator for Bcls {
    fn name(&self) -> &'static str {
        "bcls"
    }

    fn description(&self) -> &'static str {
        "bias-compensated least squares: unbiased replacements of V² and V⁴ for speed noise of known σ_v"
    }

    fn compensates_speed_noise(&self) -> bool {
        true
    }

    fn estimate(&self, r: &Realisation<'_>) -> Estimate {
        Estimate::theta(solve(
            &r.moments
                .bcls_system(r.regression.k, r.noise[Channel::Velocity]),
        ))
    }
}

/// Every estimator a study can name, in the order they are listed in messages.
pub static ESTIMATORS: [&dyn Estimator; 4] = [&Ols, &Bcls, &Wbcls, &Rls];

/// A registered estimator, compared by name.
#[derive(Debug, Clone, Copy)]
pub struct EstimatorRef(pub &'static dyn Estimator);

impl EstimatorRef {
    /// The registered estimator called `name`.
    pub fn find(name: &str) -> Option<EstimatorRef> {
        ESTIMATORS
            .iter()
            .find(|e| e.name() == name)
            .map(|&e| EstimatorRef(e))
    }
}

impl Deref for EstimatorRef {
    type Target = dyn Estimator;

    fn deref(&self) -> &Self::Target {
        self.0
    }
}

impl PartialEq for EstimatorRef {
    fn eq(&self, other: &Self) -> bool {
        self.name() == other.name()
    }
}

impl Eq for EstimatorRef {}

impl Moments {
    /// OLS normal equations X̃ᵀX̃ θ = X̃ᵀỹ (thesis eq. 20).
    pub fn ols_system(&self, k: f64) -> (Matrix3<f64>, Vector3<f64>) {
        self.system(k, self.s_1w, self.s_3w, self.s_ww, self.s_wy)
    }

    /// BCLS normal equations for speed noise of known σ_v: each noisy power of speed is
    /// replaced by its unbiased estimate, `V² → Ṽ² − σ²`, `V⁴ → Ṽ⁴ − 6σ²Ṽ² + 3σ⁴`, in
    /// Σ F V², Σ c V², Σ V⁴ and Σ y V² (E\[Ṽ²\] = V² + σ², E\[Ṽ⁴\] = V⁴ + 6V²σ² + 3σ⁴).
    pub fn bcls_system(&self, k: f64, velocity_sd: f64) -> (Matrix3<f64>, Vector3<f64>) {
        let s2 = velocity_sd * velocity_sd;
        self.system(
            k,
            self.s_1w - s2 * self.s_1,
            self.s_3w - s2 * self.s_3,
            self.s_ww - 6.0 * s2 * self.s_w + 3.0 * s2 * s2 * self.n,
            self.s_wy - s2 * self.s_y,
        )
    }

    fn system(
        &self,
        k: f64,
        s_1w: f64,
        s_3w: f64,
        s_ww: f64,
        s_wy: f64,
    ) -> (Matrix3<f64>, Vector3<f64>) {
        let a = Matrix3::new(
            self.s_11,
            -k * s_1w,
            self.s_13,
            -k * s_1w,
            k * k * s_ww,
            -k * s_3w,
            self.s_13,
            -k * s_3w,
            self.s_33,
        );
        let b = Vector3::new(self.s_1y, -k * s_wy, self.s_3y);
        (a, b)
    }
}

/// Solve a normal-equation system (OLS or BCLS).
pub fn solve(system: &(Matrix3<f64>, Vector3<f64>)) -> Result<Vector3<f64>, SolveError> {
    solve_spd(&system.0, &system.1)
}
