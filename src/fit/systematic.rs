//! `[systematic]`: the systematic-error budget of a fit (docs/model.md#fit). Per estimator
//! and model error of the fit file's `[systematic]`, how far the estimate moves when the
//! truth has that error at that magnitude: the estimator on the noise-free rows of its fit's
//! world with the error, minus the same without it (`bias_model` of the two worlds).

use nalgebra::Vector3;

use crate::dynamics::Replay;
use crate::dynamics::truth::MODEL_ERRORS;
use crate::estimate::estimators::EstimatorRef;
use crate::model::Model;
use crate::model::vehicle::VehicleModel;
use crate::study::TruthAxes;

use super::{FitError, FitSpec, bootstrap, with_derived};

/// One row of `systematic.parquet`: how far one estimator's estimate of one parameter moves
/// under one model error at the fit file's magnitude, beside the statistical interval.
#[derive(Debug, Clone, PartialEq)]
pub struct SystematicRow {
    /// Estimator name.
    pub estimator: &'static str,
    /// One of [`FIT_PARAMETERS`](super::FIT_PARAMETERS).
    pub parameter: &'static str,
    /// The model error's key of `[systematic]` (and of a study's `[truth]`).
    pub entry: &'static str,
    /// The unit of `magnitude` (empty when dimensionless).
    pub unit: &'static str,
    /// The model error's value in `[systematic]`.
    pub magnitude: f64,
    /// The estimate in the fit's world with the model error minus the estimate without it
    /// (both noise-free), in the parameter's unit.
    pub shift: f64,
    /// `shift` over the fit's estimate.
    pub rel_shift: f64,
    /// Half the width of the 95 % bootstrap interval (`(ci_high − ci_low) / 2` of
    /// fit.parquet): the statistical interval beside it.
    pub ci_half_width: f64,
}

/// The shift of each of [`FIT_PARAMETERS`](super::FIT_PARAMETERS) (θ, then M and Cd) of
/// `estimator`, whose fit is `theta` and whose bootstrap world `base` is built on `replay`,
/// under each model error of `spec.systematic` in turn: the noise-free estimate in the world
/// with the error minus the noise-free estimate in `base`.
pub(super) fn shifts(
    spec: &FitSpec,
    estimator: EstimatorRef,
    theta: &Vector3<f64>,
    replay: &Replay,
    base: &VehicleModel,
) -> Result<Vec<[f64; 5]>, FitError> {
    let noise_free = |model: &VehicleModel| {
        let info = model.condition_info(0);
        spec.settings
            .parameters
            .theta(|p| info.truth[p] + info.bias_model[0][p])
    };
    let without = with_derived(&noise_free(base));
    spec.systematic
        .iter()
        .map(|&(entry, magnitude)| {
            let mut values = MODEL_ERRORS.map(|e| e.neutral);
            values[entry] = magnitude;
            let world = bootstrap::world(
                spec,
                estimator,
                theta,
                replay.clone(),
                TruthAxes::single(values),
            )?;
            let with = with_derived(&noise_free(&world));
            Ok(std::array::from_fn(|p| with[p] - without[p]))
        })
        .collect()
}
