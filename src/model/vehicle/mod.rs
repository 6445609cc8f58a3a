//! The thesis's vehicle study as a [`Model`](super::Model): one drive cycle per terrain
//! scale; noise on the measured speed, output, grade and force; OLS and BCLS on the same draw
//! of each realisation (common random numbers); and every bound that applies.
//!
//! This file prepares the conditions and predicts to first order; `prepare.rs` simulates the
//! cycles (one per terrain scale and truth) and builds their regressions, `bias_model.rs`
//! estimates on the noise-free rows (what the model errors alone do), `axes.rs` lists the condition axes, `kernel.rs`
//! computes one realisation, `layout.rs` is the row layout and the [`Model`](super::Model)
//! implementation, `replayed.rs` builds the model of one given cycle (`for_cycle`, for the
//! bootstrap of `fit`), and `cycles_table.rs` writes cycles.parquet.

use std::sync::Arc;

use rayon::prelude::*;

mod axes;
mod bias_model;
mod campaign;
mod cycles_table;
mod designed;
mod designed_tables;
mod draws;
mod extras;
mod identification;
mod kernel;
mod layout;
mod pcrlb;
mod prepare;
mod replayed;
mod side_by_side;
pub use designed::designed_profile_criterion;
pub use identification::is_metric as is_identification_metric;
pub use replayed::ReplayTruth;
mod world;

pub use axes::{Point, VehicleAxis, axes, axes_of, grid};
pub use cycles_table::{cycles_batch, cycles_schema};
pub use layout::layout;

use super::{ConditionInfo, Layout, ModelErrorValue};
use crate::dynamics::DriveCycle;
use crate::dynamics::truth::MODEL_ERRORS;
use crate::estimate::bounds::{BOUNDS, BoundKind, BoundValue, Spread};
use crate::estimate::channels::{Channel, NoiseLevels, Signal, sum_covariances};
use crate::estimate::controls::{CONTROLS, Expectations, varies};
use crate::estimate::estimators::{EstimatorSettings, FirstOrder, reads_rows};
use crate::estimate::regression::Regression;
use crate::estimate::sums::Sum;
use crate::study::{self, LevelAxis, Study, StudyError, VehicleStudy};
use extras::{ExtraColumn, study_extras};
use prepare::{ScaleCycle, prefixes, scale_cycles, segments};
use world::{GradeMap, Place, World};

/// Parameter names of θ = [1/M, Cd/M, Cr] as used in every output column.
pub const PARAMETERS: [&str; 3] = ["inv_mass", "drag_over_mass", "rolling_resistance"];

/// One prepared condition: its noise and the regression of its rows.
#[derive(Debug)]
struct Condition {
    info: ConditionInfo,
    /// Its drive cycle: index into [`VehicleModel::cycles`] (scale-major, then truth).
    cycle_index: usize,
    noise: NoiseLevels,
    regression: Arc<Regression>,
    /// AR(1) coefficients of correlated speed noise (`None` when white).
    ar1: Option<Vec<[f64; 2]>>,
    /// Per estimator, per entry of [`BOUNDS`]: its standard errors where they are constant
    /// over the realisations and the bound applies (NaN otherwise); the estimators of one
    /// [`Spread`] share them.
    constant_bounds: Vec<Arc<Vec<[f64; 3]>>>,
    /// Its draw group ([`Model::draw_group`](super::Model::draw_group)): its own index
    /// unless the draws are shared.
    group: usize,
    /// The expected moments: what the control variates are centred on.
    expected: Expectations,
    /// What each realisation draws beyond its sensor noise, when something is (its own
    /// regression then, made from its own truth and map).
    world: Option<World>,
    /// The estimator settings of its realisations (the study's, at its level of the filters'
    /// grade walk).
    settings: EstimatorSettings,
    /// The number of runs a campaign judges (docs/model.md#campaign).
    campaign_runs: usize,
}

/// An error about key `key` (dotted) of the study a model is prepared from, for `reason`.
type ErrorAt<'a> = dyn Fn(&str, String) -> StudyError + Sync + 'a;

/// The bit that marks a draw group's key, so that a shared stream is never some condition's
/// own.
const SHARED_GROUP: u64 = 1 << 63;

/// The vehicle model with all its conditions prepared (drive cycles simulated).
#[derive(Debug)]
pub struct VehicleModel {
    study: VehicleStudy,
    layout: Layout,
    conditions: Vec<Condition>,
    /// One cycle per terrain scale and truth (kept for cycles.parquet and figures).
    cycles: Vec<ScaleCycle>,
    /// Whether an estimator of the study reads the measured rows or scans them (the kernel
    /// keeps them only then).
    reads_rows: bool,
    /// Whether an estimator reads the kernel's sums of the grade term (the compensation of
    /// grade noise).
    grade_sums: bool,
    /// The per-row extras its tables carry.
    extras: Vec<ExtraColumn>,
    /// The sums whose control variates the layout carries (indices into [`CONTROLS`]).
    controls: Vec<usize>,
    /// `noise.share_across_scales`: conditions differing only in scale and duration read
    /// the same draws, as prefixes of one normal sequence per channel.
    shared: bool,
    /// The true θ.
    truth: [f64; 3],
}

impl VehicleModel {
    /// Prepare every condition of `study`: one drive cycle per terrain scale, the regression
    /// of each (scale, duration). A scale at which the vehicle stalls or runs off the
    /// terrain is an error naming that scale.
    pub fn new(study: &Study) -> Result<Self, StudyError> {
        if let Some(fleet) = study.fleet() {
            return Err(study.error_at(
                "fleet",
                format!(
                    "this command works on one vehicle, and the study has a fleet of {} \
                     (`chassis-mc run` runs a fleet; give one vehicle in [vehicle] here)",
                    fleet.vehicles.len()
                ),
            ));
        }
        let vs = study
            .vehicle()
            .ok_or_else(|| study.error_at("model", "is not a vehicle study"))?
            .clone();
        Self::prepare(vs, study.seed(), &|key: &str, reason: String| {
            study.error_at(key, reason)
        })
    }

    /// Prepare every condition of the validated `vs` run with `seed`; `error_at` names a key
    /// of the study it came from in an error.
    fn prepare(vs: VehicleStudy, seed: u64, error_at: &ErrorAt<'_>) -> Result<Self, StudyError> {
        let vs = designed::resolve(vs, seed, error_at)?;
        let truth = vs.vehicle.theta();
        let free = vs.settings.parameters.free();
        let cycles = scale_cycles(&vs, error_at)?;
        let segments = segments(&vs, &cycles, error_at)?;
        let prefixes = prefixes(&vs);
        let layout = layout(&vs);
        uneven_differentiation(&vs, &segments, error_at)?;
        let points = grid(&vs);
        let controls = study_controls(&vs);
        let filters_listed = vs.estimators.iter().any(|e| e.estimates_grade());
        let layout_controls = &controls;
        // Scale, duration and runs are the outermost axes: the conditions of one draw group
        // are `inner` apart.
        let inner = points.len() / (vs.scales.len() * prefixes.len());
        // `bias_model` of each regression, once (conditions differing only in their noise
        // levels share one): per segment, acceleration source and grade bias.
        let bias_models: Vec<Vec<Vec<Vec<Vec<f64>>>>> = segments
            .par_iter()
            .map(|segment| {
                segment
                    .regressions
                    .iter()
                    .zip(&vs.acceleration)
                    .map(|(regressions, &acceleration)| {
                        regressions
                            .iter()
                            .map(|r| {
                                bias_model::bias_model(
                                    r,
                                    acceleration,
                                    &vs.estimators,
                                    &vs.settings,
                                    &truth,
                                )
                            })
                            .collect()
                    })
                    .collect()
            })
            .collect();
        let conditions: Vec<Condition> = points
            .par_iter()
            .enumerate()
            .map(|(c, point)| {
                let group = if vs.share_across_scales { c % inner } else { c };
                let noise = point.noise;
                let cycle_index =
                    prepare::cycle_index(&vs, point.scale_index, point.truth_index(&vs));
                let prefix = point.prefix_index(&vs);
                let k = cycle_index * prefixes.len() + prefix;
                let segment = &segments[k];
                let source = vs
                    .acceleration
                    .iter()
                    .position(|&a| a == noise.acceleration)
                    .expect("the grid takes the source from the study's list");
                // The regressions and bias models are one per grade bias.
                let bias = point.level_index(LevelAxis::GradeBias);
                let regression = segment.regressions[source][bias].clone();
                let campaign_runs = campaign::runs_of(prefixes[prefix], &regression);
                let of_spread = |spread: Spread| -> Arc<Vec<[f64; 3]>> {
                    Arc::new(
                        BOUNDS
                            .iter()
                            .map(|bound| {
                                match bound.value {
                                    BoundValue::Constant(se) if (bound.applies)(&noise) => se(
                                        &regression,
                                        &truth,
                                        &noise,
                                        vs.settings.parameters,
                                        spread,
                                    ),
                                    _ => None,
                                }
                                .unwrap_or([f64::NAN; 3])
                            })
                            .collect(),
                    )
                };
                let mut by_spread: Vec<(Spread, Arc<Vec<[f64; 3]>>)> = Vec::new();
                let constant_bounds = vs
                    .estimators
                    .iter()
                    .map(|e| {
                        let spread = e.spread();
                        match by_spread.iter().find(|(s, _)| *s == spread) {
                            Some((_, b)) => b.clone(),
                            None => {
                                let b = of_spread(spread);
                                by_spread.push((spread, b.clone()));
                                b
                            }
                        }
                    })
                    .collect();
                let applies = vs
                    .estimators
                    .iter()
                    .map(|e| {
                        BOUNDS
                            .iter()
                            .map(|b| (b.applies)(&noise) && e.reports(b, &vs.settings))
                            .collect()
                    })
                    .collect();
                let ar1 = noise
                    .velocity_correlated()
                    .then(|| regression.ar1_coefficients(noise.velocity_correlation_s));
                let expected = Expectations::new(&regression, &noise, ar1.as_deref());
                let condition_truth = vs.truth.truth(point.truth_index(&vs));
                let grade_map_sd = point.level(&vs, LevelAxis::GradeMap);
                let grade_map = (grade_map_sd > 0.0).then_some(GradeMap {
                    sd_m: grade_map_sd,
                    length_m: vs.grade_map_length_m,
                });
                let cycle = &cycles[cycle_index];
                let world = World::new(
                    condition_truth,
                    grade_map,
                    vs.filter_truth,
                    Place {
                        cycle: cycle.cycle.clone(),
                        table: cycle.table.clone(),
                        scale: vs.scales[point.scale_index],
                        prefix: prefixes[prefix],
                        source: noise.acceleration,
                        grade_bias_rad: point.level(&vs, LevelAxis::GradeBias),
                    },
                );
                // The control variates are centred on the condition's regression: with
                // another regression in every realisation, none applies.
                let controls: Vec<bool> = layout_controls
                    .iter()
                    .map(|&j| expected.applies()[j] && world.is_none())
                    .collect();
                let active: Vec<Sum> = layout_controls
                    .iter()
                    .zip(&controls)
                    .filter(|&(_, &on)| on)
                    .map(|(&j, _)| Sum::ALL[j])
                    .collect();
                let control_covariance = (!active.is_empty())
                    .then(|| sum_covariances(&regression, &noise, ar1.as_deref(), &active))
                    .flatten();
                let mut settings = vs.settings;
                settings.filter.grade_walk = vs.grade_walks[point.grade_walk_index];
                let mut metrics = segment.metrics.clone();
                metrics.extend(identification::metrics(&regression, vs.settings.parameters));
                if filters_listed {
                    let key = match vs.share_across_scales {
                        true => SHARED_GROUP | group as u64,
                        false => group as u64,
                    };
                    let bound = pcrlb::metrics(
                        &vs,
                        &settings,
                        &regression,
                        world.as_ref(),
                        &noise,
                        (seed, key),
                    );
                    metrics.extend(bound);
                }
                Condition {
                    info: ConditionInfo {
                        axes: axes_of(&vs)
                            .map(|a| a.value(&vs, point, segment.duration_s))
                            .collect(),
                        metrics,
                        truth: free.iter().map(|&i| truth[i]).collect(),
                        // The filters' noise-free estimates depend on the grade walk: made
                        // for each condition where it is an axis of several levels.
                        bias_model: match vs.grade_walks.len() > 1 && filters_listed {
                            true => bias_model::bias_model(
                                &regression,
                                noise.acceleration,
                                &vs.estimators,
                                &settings,
                                &truth,
                            ),
                            false => bias_models[k][source][bias].clone(),
                        },
                        model_errors: model_errors(&vs, point.truth_index(&vs)),
                        applies,
                        controls,
                        control_covariance,
                    },
                    cycle_index,
                    noise,
                    ar1,
                    regression,
                    constant_bounds,
                    group,
                    expected,
                    world,
                    settings,
                    campaign_runs,
                }
            })
            .collect();
        for cond in &conditions {
            let scale = vs.scales[cond.cycle_index / vs.truth.combinations()];
            campaign::check_noise_free(&vs, &cond.regression, cond.campaign_runs, scale, error_at)?;
        }
        // Members of a draw group read one set of draws: they must agree on everything but
        // the cycle (the group's first member is condition `group`).
        assert!(
            conditions
                .iter()
                .all(|c: &Condition| conditions[c.group].noise == c.noise),
            "a draw group mixes noise levels: the scale, duration and runs axes must be outermost"
        );
        Ok(VehicleModel {
            layout,
            conditions,
            cycles,
            reads_rows: reads_rows(&vs.estimators) || vs.campaign.is_some(),
            grade_sums: vs.estimators.iter().any(|e| e.reads_grade_sums()),
            extras: study_extras(&vs),
            controls,
            shared: vs.share_across_scales,
            truth,
            study: vs,
        })
    }

    /// Every condition's drive cycle (conditions with the same terrain scale and truth share
    /// one).
    pub fn cycles(&self) -> Vec<Arc<DriveCycle>> {
        self.conditions
            .iter()
            .map(|c| self.cycles[c.cycle_index].cycle.clone())
            .collect()
    }

    /// The first-order prediction of estimator `e`'s (index in the study's list) bias and
    /// standard error in condition `c`, per parameter, and the SE of the first bound the
    /// estimator reports among `crlb_output`, `eiv_sandwich` and `eiv_crlb_linearized` (NaN
    /// where none applies). The bias is the estimator's own prediction
    /// ([`Estimator::first_order_bias`](crate::estimate::estimator::Estimator::first_order_bias):
    /// the ratio of expectations for one that does not compensate the noise, the model
    /// errors' effect for one that does; docs/model.md#design), from the condition's
    /// `bias_model`, its estimate on the truth's logged rows, which have the model errors in
    /// them.
    pub fn first_order(&self, c: usize, e: usize) -> ([f64; 3], [f64; 3]) {
        let cond = &self.conditions[c];
        let est = &self.study.estimators[e];
        let parameters = self.study.settings.parameters;
        let first = parameters.free()[0];
        let se = [
            BoundKind::CrlbOutput,
            BoundKind::EivSandwich,
            BoundKind::EivCrlbLinearized,
        ]
        .into_iter()
        .map(BoundKind::index)
        .find(|&b| cond.info.applies[e][b] && cond.constant_bounds[e][b][first].is_finite())
        .map_or([f64::NAN; 3], |b| cond.constant_bounds[e][b]);
        let mut noise_free_bias = [0.0; 3];
        for (p, &i) in parameters.free().iter().enumerate() {
            noise_free_bias[i] = cond.info.bias_model[e][p];
        }
        let bias = est.first_order_bias(&FirstOrder {
            regression: &cond.regression,
            noise: &cond.noise,
            parameters,
            truth: &self.truth,
            noise_free_bias,
            model_errors: !cond.info.model_errors.is_empty(),
        });
        (bias, se)
    }

    /// The number condition `c`'s random streams are keyed by: its index, or, with
    /// `noise.share_across_scales`, its draw group's, marked (docs/model.md#shared-noise).
    fn stream_key(&self, c: usize) -> u64 {
        let group = self.conditions[c].group as u64;
        if self.shared {
            SHARED_GROUP | group
        } else {
            group
        }
    }

    /// The noise levels of condition `c`.
    pub fn noise_levels(&self, c: usize) -> NoiseLevels {
        self.conditions[c].noise
    }

    /// The validated study settings.
    pub fn study(&self) -> &VehicleStudy {
        &self.study
    }
}

/// The steady model errors of truth `index` of `vs` at their values (those at their
/// neutral value left out): what `bias_model` describes. Entries drawn per realisation are
/// left out of it, and so of this list.
fn model_errors(vs: &VehicleStudy, index: usize) -> Vec<ModelErrorValue> {
    MODEL_ERRORS
        .iter()
        .zip(vs.truth.values(index))
        .filter(|(e, v)| *v != e.neutral && !e.drawn)
        .map(|(e, value)| ModelErrorValue {
            key: e.key,
            unit: e.unit,
            value,
        })
        .collect()
}

/// The rule on sample spacing ([`crate::study::uneven_differentiation`]) on the spans of
/// the study's differentiated regressions: an error naming `estimation.acceleration`.
fn uneven_differentiation(
    vs: &VehicleStudy,
    segments: &[prepare::Segment],
    error_at: &ErrorAt<'_>,
) -> Result<(), StudyError> {
    let correlated = vs.levels[LevelAxis::VelocityCorrelation]
        .iter()
        .any(|&t| t > 0.0)
        && vs
            .noise
            .levels(Channel::of(Signal::Speed))
            .iter()
            .any(|&s| s > 0.0);
    let spans = segments
        .iter()
        .flat_map(|s| s.regressions.iter().flatten())
        .filter_map(|r| r.differentiation.as_ref().map(|d| &*d.span_t));
    match study::uneven_differentiation(correlated, &vs.estimators, spans) {
        Some(e) => Err(error_at(
            "estimation.acceleration",
            study::uneven_reason(
                e,
                "estimation.acceleration \"differentiated\"",
                "this cycle",
            ),
        )),
        None => Ok(()),
    }
}

/// The sums (indices into [`CONTROLS`]) that are control variates in some condition of
/// `study`: the columns its realisation table carries.
fn study_controls(study: &VehicleStudy) -> Vec<usize> {
    let points = grid(study);
    (0..CONTROLS.len())
        .filter(|&j| points.iter().any(|p| varies(&p.noise)[j]))
        .collect()
}
