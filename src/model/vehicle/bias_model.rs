//! `bias_model`: what the model errors alone make each estimator estimate
//! (docs/model.md#model-errors).
//!
//! Each estimator of the study runs once on a condition's logged signals with every noise
//! level zero (and no per-realisation entry): the pseudo-true value its model errors lead
//! to. The condition's deterministic measurement effects stay in (a grade bias, the
//! truncation error of a differentiated acceleration), as they are in every realisation.

use nalgebra::Vector3;

use crate::estimate::channels::{Acceleration, NoiseLevels};
use crate::estimate::estimators::{EstimatorRef, EstimatorSettings, estimates_without_draws};
use crate::estimate::regression::Regression;

/// Per estimator, per fitted parameter: its estimate on `regression`'s noise-free rows (its
/// acceleration source `acceleration`, every noise level zero) minus `truth`; NaN where the
/// normal equations are singular. It depends on the condition only through its regression,
/// so conditions that share one share it.
pub(super) fn bias_model(
    regression: &Regression,
    acceleration: Acceleration,
    estimators: &[EstimatorRef],
    settings: &EstimatorSettings,
    truth: &[f64; 3],
) -> Vec<Vec<f64>> {
    let quiet = NoiseLevels {
        acceleration,
        ..NoiseLevels::default()
    };
    estimates_without_draws(regression, &quiet, &quiet, estimators, settings, truth)
        .into_iter()
        .map(|estimate| {
            let theta = estimate.theta.unwrap_or_else(|_| Vector3::repeat(f64::NAN));
            let free = settings.parameters.free();
            free.iter().map(|&p| theta[p] - truth[p]).collect()
        })
        .collect()
}
