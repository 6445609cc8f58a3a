//! A vehicle model of one cycle given in memory: `fit`'s bootstrap world (the fitted
//! vehicle replayed on a log's rows, docs/model.md#fit), and that world with a model error
//! for `fit`'s systematic-error budget, built from typed values with no study file.

use std::sync::Arc;

use super::{ErrorAt, VehicleModel};
use crate::dynamics::filter_truth::FilterTruth;
use crate::dynamics::{Replay, RowSelection, VehicleParams};
use crate::estimate::channels::{Channel, NoiseLevels, PerChannel};
use crate::estimate::estimators::{EstimatorRef, EstimatorSettings};
use crate::study::{
    AirSpeed, LevelAxes, LevelAxis, NoiseAxes, StudyError, TruthAxes, VehicleStudy,
};

/// The truth of a replayed world ([`VehicleModel::for_cycle`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReplayTruth {
    /// Its model errors (one truth: [`TruthAxes::single`]; [`TruthAxes::default`] for
    /// none).
    pub model_errors: TruthAxes,
    /// When drawn, each realisation's truth follows the filters' model from the cycle's
    /// first speed under its force (a filter's bootstrap world).
    pub filter: FilterTruth,
}

impl VehicleModel {
    /// The one-condition model of `vehicle` on the cycle `replay` (taken as the equation's
    /// motion, its `used` rows the regression's) with the truth `truth`, measured with the
    /// noise `noise` (its acceleration source too) and estimated by `estimators` with
    /// `settings`: what a study of drive mode `replay` with one level per noise axis, no
    /// terrain and no row selection of its own prepares. An error (the rows leave fewer
    /// than 3 samples, or a compensating estimator meets correlated speed noise on uneven
    /// samples) names `origin` and the key such a study would have.
    pub fn for_cycle(
        replay: Replay,
        vehicle: VehicleParams,
        noise: NoiseLevels,
        estimators: Vec<EstimatorRef>,
        settings: EstimatorSettings,
        truth: ReplayTruth,
        origin: &str,
    ) -> Result<VehicleModel, StudyError> {
        debug_assert_eq!(truth.model_errors.combinations(), 1, "one truth");
        let vs = VehicleStudy {
            vehicle,
            drive: Arc::new(replay),
            selection: RowSelection {
                min_speed_m_s: 0.0,
                exclude_braking: false,
            },
            durations: None,
            terrain: None,
            scales: vec![1.0],
            noise: NoiseAxes::new(PerChannel::from_fn(|c: Channel| vec![noise[c]])),
            levels: LevelAxes::defaults().with(
                LevelAxis::VelocityCorrelation,
                vec![noise.velocity_correlation_s],
            ),
            estimators,
            settings,
            acceleration: vec![noise.acceleration],
            share_across_scales: false,
            grade_map_length_m: 200.0,
            air_speed: AirSpeed::Ground,
            truth: truth.model_errors,
            filter_truth: truth.filter,
            grade_walks: vec![settings.filter.grade_walk],
            campaign: None,
        };
        let error_at: &ErrorAt<'_> = &|key: &str, reason: String| StudyError {
            file: origin.to_string(),
            key: Some(key.to_string()),
            line: None,
            reason,
        };
        // The seed is read only by the condition's bound over drawn truths
        // (docs/model.md#pcrlb), which a replayed world's user does not report.
        Self::prepare(vs, 0, error_at)
    }
}
