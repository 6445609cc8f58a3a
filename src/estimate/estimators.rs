//! OLS and BCLS, the estimators that need only a realisation's moments, and what every
//! estimator is reached by: [`EstimatorRef`] by name, and the estimates on rows without
//! draws (see docs/model.md#estimators).
//!
//! An estimator is one [`Estimator`] impl with one line in the `estimators!` registry of
//! `estimate/mod.rs` ([`ESTIMATORS`]): the study file names it, the model runs every listed
//! one on the same draws, the output and the summary take its name from the layout. Nothing
//! else matches on it.

use super::bounds::Spread;
use super::channels::{BlockNoise, NoiseLevels};
pub use super::ESTIMATORS;
pub use super::estimator::{
    ESTIMATE_COLUMNS, Estimate, EstimateColumn, Estimator, EstimatorRef, EstimatorSettings,
    FirstOrder, Realisation, RowScan, RowScans, ScanStart, compensated_bias, expected_sums_bias,
    reads_rows,
};
use super::moments::{Rows, noise_free_moments};
use super::regression::Regression;
use crate::noise::BLOCK;

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

    fn reads_grade_sums(&self) -> bool {
        true
    }

    fn needs_even_differentiation(&self) -> bool {
        true
    }

    fn first_order_bias(&self, at: &FirstOrder<'_>) -> [f64; 3] {
        compensated_bias(at)
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


impl EstimatorRef {
    /// The registered estimator called `name`.
    pub fn find(name: &str) -> Option<EstimatorRef> {
        ESTIMATORS
            .iter()
            .find(|e| e.name() == name)
            .map(|&e| EstimatorRef(e))
    }
}

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
    let rows = reads_rows(estimators).then(|| {
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
        // One scan of these rows: nothing to share with others.
        let start = ScanStart {
            noise,
            settings,
            truth,
            shared: false,
        };
        scans.reset(estimators, reg, &start);
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

#[cfg(test)]
mod tests;
