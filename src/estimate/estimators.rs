//! The estimators of the vehicle regression: each builds its normal equations from a
//! realisation's [`Moments`] (see docs/model.md#estimators).
//!
//! An estimator is one [`Estimator`] impl listed in [`ESTIMATORS`]: the study file names it,
//! the model runs every listed one on the same draws, the output and the summary take its
//! name from the layout. Nothing else matches on it.

use std::fmt;
use std::ops::Deref;

use nalgebra::{Matrix3, Vector3};

use super::bounds::{Bound, Spread};
use super::channels::{BlockNoise, Channel, NoiseLevels, Signal};
use super::moments::{Moments, Rows, RowsView, noise_free_moments};
use super::parameters::Parameters;
use super::regression::Regression;
use super::rls::scan::RlsResult;
use super::rls::{Rls, rls_target};
use super::road_load::RoadLoad;
use super::row_sums::{RowRead, RowReads, RowScans};
use super::wbcls::Wbcls;
use crate::noise::BLOCK;
use crate::numeric::linalg::SolveError;

/// Everything an estimator may use from one realisation: what a real log would give (the
/// measured sums and rows, the sample times, the known noise levels), never the noise-free
/// signals; the truth only to score itself (the RLS settle time).
#[derive(Debug, Clone, Copy)]
pub struct Realisation<'a> {
    /// The sums of the measured rows.
    pub moments: &'a Moments,
    /// The measured rows (`Some` when an estimator of the study [reads them](Estimator::reads)).
    pub rows: Option<&'a Rows>,
    /// The sums over the rows that the study's estimators [read](Estimator::reads).
    pub scans: Option<&'a RowScans>,
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
    /// The measured rows; an estimator that reads them says so in [`Estimator::reads`],
    /// so the model always provides them.
    pub fn rows(&self) -> RowsView<'a> {
        self.rows
            .expect("the model provides the rows to an estimator that reads them")
            .view(self.regression)
    }

    /// The moments of each weight segment of `wbcls` ([`RowRead::Segments`]).
    pub fn segment_moments(&self) -> &'a [Moments] {
        self.scans
            .and_then(RowScans::segments)
            .expect("the model provides the segments to an estimator that reads them")
    }

    /// The running normal equations of `rls` and its settle row ([`RowRead::Rls`]).
    pub fn rls(&self) -> RlsResult {
        self.scans
            .and_then(RowScans::rls)
            .expect("the model provides the scan to an estimator that reads it")
    }
}

/// Study settings of the estimators (`[estimation]`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EstimatorSettings {
    /// Exponential forgetting factor λ of `rls`, 0 < λ ≤ 1 (1: no forgetting).
    pub forgetting: f64,
    /// The parameters fitted: all three, or with `estimation.known_mass` \[Cd/M, Cr\] with
    /// the weighed 1/M known (docs/model.md#known-mass).
    pub parameters: Parameters,
    /// The rotating-mass factor δ̂ `road_load` assumes (`estimation.effective_mass_factor`;
    /// 0: none).
    pub effective_mass_factor: f64,
}

impl Default for EstimatorSettings {
    fn default() -> Self {
        EstimatorSettings {
            forgetting: 1.0,
            parameters: Parameters::All,
            effective_mass_factor: 0.0,
        }
    }
}

impl EstimatorSettings {
    /// The solution of the normal equations `system` over the fitted parameters.
    pub fn solve(&self, system: &(Matrix3<f64>, Vector3<f64>)) -> Result<Vector3<f64>, SolveError> {
        self.parameters.solve(system)
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
    /// `road_load` only: its fitted A \[N\], B \[N·s/m\], C \[N·s²/m²\] (`None`: not
    /// this estimator, or the fit failed).
    pub road_load: Option<[f64; 3]>,
}

impl Estimate {
    /// An estimate with nothing but θ̂.
    pub fn theta(theta: Result<Vector3<f64>, SolveError>) -> Self {
        Estimate {
            theta,
            settle_time_s: None,
            road_load: None,
        }
    }
}

/// An estimator of θ from one realisation.
pub trait Estimator: Sync + Send + fmt::Debug {
    /// Name in study files and in the `estimator` column.
    fn name(&self) -> &'static str;

    /// One line on what it is.
    fn description(&self) -> &'static str;

    /// What it reads from the measured rows beyond their sums: the kernel takes the sums
    /// it reads over the rows as it measures them (or keeps the rows, for
    /// [`RowRead::Rows`]).
    fn reads(&self) -> RowRead {
        RowRead::Nothing
    }

    /// Its estimate from the realisation.
    fn estimate(&self, r: &Realisation<'_>) -> Estimate;

    /// Whether it reads `estimation.effective_mass_factor`
    /// ([`EstimatorSettings::effective_mass_factor`]): the key is refused when no listed
    /// estimator does.
    fn reads_effective_mass_factor(&self) -> bool {
        false
    }

    /// Whether it needs the mass known (`estimation.known_mass = true`): the study is refused
    /// otherwise.
    fn needs_known_mass(&self) -> bool {
        false
    }

    /// How `design` predicts its bias to first order (docs/model.md#design).
    fn bias_prediction(&self) -> BiasPrediction {
        match self.compensates_speed_noise() {
            true => BiasPrediction::ModelErrors,
            false => BiasPrediction::ExpectedSums,
        }
    }

    /// Whether it reads `estimation.forgetting` ([`EstimatorSettings::forgetting`]): the key
    /// is refused when no listed estimator does.
    fn reads_forgetting(&self) -> bool {
        false
    }

    /// Whether it compensates the noise's bias with the noise's moments (BCLS and its kin,
    /// every channel: docs/model.md#bcls): such an estimator stays unbiased under a
    /// differentiated acceleration with AR(1) speed noise only when the samples are evenly
    /// spaced.
    fn compensates_speed_noise(&self) -> bool {
        false
    }

    /// What its spread is predicted from (the sandwich of its estimating function): the
    /// noisy sums as they are, by default.
    fn spread(&self) -> Spread {
        Spread::Plain
    }

    /// Whether `bound` is reported next to this estimator's estimates (where the bound
    /// applies to the noise at all): a bound that does not describe this estimator's
    /// spread is left out (NaN) rather than misread. Every bound by default.
    fn reports(&self, bound: &Bound, settings: &EstimatorSettings) -> bool {
        let _ = (bound, settings);
        true
    }
}

/// How an estimator's bias is predicted to first order (docs/model.md#design).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BiasPrediction {
    /// The normal equations of the expected sums under the speed noise, solved: the ratio
    /// of expectations (OLS and RLS, which do not compensate the noise).
    ExpectedSums,
    /// Its estimate on the noise-free rows (`bias_model`): what the model errors and the
    /// deterministic measurement effects make it estimate; the noise adds nothing to first
    /// order (the compensating estimators), or what it adds is not predicted (`road_load`).
    ModelErrors,
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
        Estimate::theta(r.settings.solve(&r.moments.ols_system(r.regression.k)))
    }
}

/// Bias-compensated least squares for speed, force and grade noise of known SDs.
#[derive(Debug, Clone, Copy)]
pub struct Bcls;

impl Estimator for Bcls {
    fn name(&self) -> &'static str {
        "bcls"
    }

    fn description(&self) -> &'static str {
        "bias-compensated least squares: every noisy sum replaced by an unbiased estimate of its noise-free value (speed, force and grade noise of known SD)"
    }

    fn compensates_speed_noise(&self) -> bool {
        true
    }

    fn spread(&self) -> Spread {
        Spread::Compensated
    }

    fn estimate(&self, r: &Realisation<'_>) -> Estimate {
        Estimate::theta(
            r.settings.solve(
                &r.moments
                    .bcls_system(r.regression.k, r.regression.g, r.noise),
            ),
        )
    }
}

/// Every estimator a study can name, in the order they are listed in messages.
pub static ESTIMATORS: [&dyn Estimator; 5] = [&Ols, &Bcls, &Wbcls, &Rls, &RoadLoad];

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

/// Each estimator's estimate on the rows of `reg` as they are, with no draws: a simulated
/// regression's noise-free rows (`bias_model`), or a log's measured ones (`fit`). The rows
/// are laid out as for `rows_noise`; the estimators are told `noise` (the levels they assume)
/// and `truth` (NaN where unknown). The rows are built only when an estimator reads them.
pub fn estimates_without_draws(
    reg: &Regression,
    rows_noise: &NoiseLevels,
    noise: &NoiseLevels,
    estimators: &[EstimatorRef],
    settings: &EstimatorSettings,
    truth: &[f64; 3],
) -> Vec<Estimate> {
    let moments = noise_free_moments(reg);
    let reads = RowReads::of(estimators.iter().map(|e| e.reads()));
    let rows = reads.any().then(|| {
        let mut rows = Rows::new(reg, rows_noise);
        let n = reg.len();
        for start in (0..n).step_by(BLOCK) {
            let len = BLOCK.min(n - start);
            rows.push_block(reg, rows_noise, start, len, BlockNoise::default(), None);
        }
        rows
    });
    let scans = rows.as_ref().map(|rows| {
        let mut scans = RowScans::default();
        let grade = noise.measures_noisy(Signal::Grade);
        // One scan of these rows: nothing to share with others.
        scans.reset(reads, reg, grade, rls_target(settings, truth), false);
        scans.advance(rows.view(reg), reg.len());
        scans
    });
    estimators
        .iter()
        .map(|e| {
            e.estimate(&Realisation {
                moments: &moments,
                rows: rows.as_ref(),
                scans: scans.as_ref(),
                regression: reg,
                noise,
                settings,
                truth,
            })
        })
        .collect()
}

impl Moments {
    /// OLS normal equations X̃ᵀX̃ θ = X̃ᵀỹ (thesis eq. 20).
    pub fn ols_system(&self, k: f64) -> (Matrix3<f64>, Vector3<f64>) {
        self.system(k, self.s_1w, self.s_3w, self.s_ww, self.s_wy)
    }

    /// BCLS normal equations: the OLS system of the [compensated](Self::compensated) moments.
    pub fn bcls_system(&self, k: f64, g: f64, noise: &NoiseLevels) -> (Matrix3<f64>, Vector3<f64>) {
        self.compensated(g, noise).ols_system(k)
    }

    /// Every sum replaced by an unbiased estimate of its value without the noise of `noise`
    /// (known SDs), from measured quantities only: each channel that is on corrects the sums
    /// its noise enters ([`Moments::compensate`]). The channels are independent and each
    /// correction is linear in the sums with constant coefficients, so applied one after
    /// the other they stay unbiased (docs/model.md#bcls). `g` \[m/s²\] is gravity.
    pub fn compensated(&self, g: f64, noise: &NoiseLevels) -> Moments {
        let mut m = *self;
        for (channel, &sd) in noise.iter() {
            if sd > 0.0 {
                m = m.compensate(channel, sd, g);
            }
        }
        m
    }

    /// The sums corrected for `channel`'s noise at SD `sd` (docs/model.md#bcls): each sum
    /// gets the expectation it would have without that channel's noise, the other channels
    /// left as they are (the channel's [`ChannelTerms::compensate`](super::channels::ChannelTerms::compensate)).
    pub fn compensate(&self, channel: Channel, sd: f64, g: f64) -> Moments {
        channel.compensate(self, sd, g)
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

#[cfg(test)]
mod tests;
