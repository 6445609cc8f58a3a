//! The model layer: what one Monte Carlo realisation computes, and how its results are laid
//! out, independent of how realisations are scheduled, summarised or written.
//!
//! A [`Model`] owns its prepared conditions (for the vehicle: one simulated drive cycle per
//! condition) and turns (condition, realisation) into one row per estimator: status,
//! estimates, derived quantities and bounds. The executor, the statistics and the Parquet
//! output work from the model's [`Layout`] alone, so a second model (the line fit of the
//! thesis's worked example) reuses all of them unchanged.

pub mod fleet;
pub mod line_fit;
pub mod vehicle;

use std::fmt;

use arrow::array::RecordBatch;
use arrow::datatypes::SchemaRef;
use arrow::error::ArrowError;

use crate::estimate::controls::Control;
use crate::estimate::conversions::Extra;
use crate::estimate::estimators::{Estimator, Ols};
use crate::study::{ModelSpec, Study, StudyError};

/// The type of a condition axis column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AxisKind {
    /// A number (Float64 column).
    Number,
    /// A label (string column), e.g. a noise distribution.
    Text,
}

/// A condition axis: one column of every table, one value per condition.
#[derive(Debug, Clone, PartialEq)]
pub struct Axis {
    /// Column name, e.g. `scale`.
    pub name: &'static str,
    /// Column type.
    pub kind: AxisKind,
    /// Unit, e.g. `m/s` (empty when dimensionless or a label).
    pub unit: &'static str,
}

impl Axis {
    /// A numeric axis.
    pub const fn number(name: &'static str, unit: &'static str) -> Self {
        Axis {
            name,
            kind: AxisKind::Number,
            unit,
        }
    }

    /// A label axis.
    pub const fn text(name: &'static str) -> Self {
        Axis {
            name,
            kind: AxisKind::Text,
            unit: "",
        }
    }
}

/// The value of one axis for one condition.
#[derive(Debug, Clone, PartialEq)]
pub enum AxisValue {
    /// For [`AxisKind::Number`].
    Number(f64),
    /// For [`AxisKind::Text`].
    Text(String),
}

impl AxisValue {
    /// The number, or NaN for a label.
    pub fn number(&self) -> f64 {
        match self {
            AxisValue::Number(v) => *v,
            AxisValue::Text(_) => f64::NAN,
        }
    }
}

impl fmt::Display for AxisValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AxisValue::Number(v) => write!(f, "{v}"),
            AxisValue::Text(t) => f.write_str(t),
        }
    }
}

/// A model parameter: a component of θ.
#[derive(Debug, Clone, PartialEq)]
pub struct ParameterInfo {
    /// Column-safe name, e.g. `inv_mass`.
    pub name: &'static str,
    /// Unit, e.g. `1/kg`.
    pub unit: &'static str,
    /// One-line description.
    pub description: &'static str,
}

/// A per-row derived quantity stored next to the estimates (e.g. `mass_hat`).
#[derive(Debug, Clone, PartialEq)]
pub struct ExtraInfo {
    /// Column name.
    pub name: &'static str,
    /// Unit.
    pub unit: &'static str,
    /// One-line description.
    pub description: &'static str,
}

impl From<&Extra> for ExtraInfo {
    fn from(x: &Extra) -> Self {
        ExtraInfo {
            name: x.name,
            unit: x.unit,
            description: x.description,
        }
    }
}

impl From<&Control> for ExtraInfo {
    fn from(x: &Control) -> Self {
        ExtraInfo {
            name: x.name,
            unit: x.unit,
            description: x.description,
        }
    }
}

/// A bound or predicted standard error reported for each parameter.
#[derive(Debug, Clone, PartialEq)]
pub struct BoundInfo {
    /// Name used as column prefix, e.g. `thesis_bound`.
    pub name: &'static str,
    /// What it is and when it is valid.
    pub description: &'static str,
    /// Why, where it applies, it is not a bound or prediction of the estimates' spread, for
    /// one reported for fidelity only (the thesis's bound under speed noise, README "What
    /// the numbers mean"); `None` for a valid one. Tables lead with a valid one.
    pub not_valid: Option<&'static str>,
}

impl BoundInfo {
    /// Whether, where it applies, it bounds or predicts the estimates' spread.
    pub fn valid(&self) -> bool {
        self.not_valid.is_none()
    }
}

/// Everything the executor, statistics and output need to know about a model's rows.
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    /// Condition axis columns, e.g. `scale`, `velocity_sd`.
    pub axes: Vec<Axis>,
    /// Per-condition metric columns of the summary (f64), e.g. `terrain_ms_grid`.
    pub condition_metrics: Vec<&'static str>,
    /// Parameters θ, in order.
    pub parameters: Vec<ParameterInfo>,
    /// Estimator names, in the order rows are written for each realisation.
    pub estimators: Vec<&'static str>,
    /// Derived per-row quantities.
    pub extras: Vec<ExtraInfo>,
    /// Bounds, each with one value per parameter.
    pub bounds: Vec<BoundInfo>,
    /// Control variates: per-realisation quantities of known mean zero that the summary
    /// regresses the estimates on (docs/model.md#control-variates); one slot per
    /// realisation, shared by its estimators' rows.
    pub controls: Vec<ExtraInfo>,
    /// What figures plot against instead of the first axis that varies, if anything.
    pub figure_x: Option<FigureX>,
    /// What every condition shares, in words (e.g. the route and the drive), for tables.
    pub context: Vec<String>,
}

/// A condition metric that figures use as their x axis in place of a condition axis (e.g.
/// the terrain metric ς for `scale`, as the thesis plots).
#[derive(Debug, Clone, PartialEq)]
pub struct FigureX {
    /// The metric column (one of [`Layout::condition_metrics`]).
    pub metric: &'static str,
    /// Axis label, with unit.
    pub label: &'static str,
    /// The condition axis it stands for (not repeated in series labels).
    pub replaces: &'static str,
}

impl Layout {
    /// f64 slots of one estimator's row: status, θ, extras, bounds × parameters.
    pub fn estimator_stride(&self) -> usize {
        1 + self.parameters.len() + self.extras.len() + self.bounds.len() * self.parameters.len()
    }

    /// f64 slots of one realisation: every estimator's, then the control variates.
    pub fn realisation_stride(&self) -> usize {
        self.estimators.len() * self.estimator_stride() + self.controls.len()
    }

    /// Offset of control variate `j` in a realisation's slots.
    pub fn control_at(&self, j: usize) -> usize {
        self.estimators.len() * self.estimator_stride() + j
    }

    /// Offset of the status slot of estimator `e` in a realisation's slots.
    pub fn status_at(&self, e: usize) -> usize {
        e * self.estimator_stride()
    }

    /// Offset of θ_p of estimator `e`.
    pub fn theta_at(&self, e: usize, p: usize) -> usize {
        self.status_at(e) + 1 + p
    }

    /// Offset of extra `x` of estimator `e`.
    pub fn extra_at(&self, e: usize, x: usize) -> usize {
        self.status_at(e) + 1 + self.parameters.len() + x
    }

    /// Offset of bound `b` for parameter `p` of estimator `e`.
    pub fn bound_at(&self, e: usize, b: usize, p: usize) -> usize {
        self.status_at(e)
            + 1
            + self.parameters.len()
            + self.extras.len()
            + b * self.parameters.len()
            + p
    }

    /// Index of the estimator called `name`.
    pub fn estimator_index(&self, name: &str) -> Option<usize> {
        self.estimators.iter().position(|e| *e == name)
    }

    /// The estimator others are compared with (relative precision): OLS when present,
    /// else the first listed.
    pub fn reference_estimator(&self) -> usize {
        self.estimator_index(Ols.name()).unwrap_or(0)
    }
}

/// Outcome of one estimator on one realisation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Status {
    /// Estimates are valid.
    Ok = 0,
    /// The normal equations were singular; estimates are NaN.
    Singular = 1,
    /// The realisation's truth could not be simulated (its drawn model errors stalled the
    /// vehicle or ran it off the terrain); estimates are NaN.
    Unsimulated = 2,
}

impl Status {
    /// Name written to the `status` column.
    pub fn name(self) -> &'static str {
        match self {
            Status::Ok => "ok",
            Status::Singular => "singular",
            Status::Unsimulated => "unsimulated",
        }
    }

    /// Status from its slot value.
    pub fn from_slot(v: f64) -> Status {
        match v {
            0.0 => Status::Ok,
            2.0 => Status::Unsimulated,
            _ => Status::Singular,
        }
    }

    /// Status from its column name.
    pub fn from_name(name: &str) -> Option<Status> {
        [Status::Ok, Status::Singular, Status::Unsimulated]
            .into_iter()
            .find(|s| s.name() == name)
    }
}

impl fmt::Display for Status {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// What is known about a condition before any realisation: its axes, metrics, the truth,
/// and which bounds apply to which estimator.
#[derive(Debug, Clone, PartialEq)]
pub struct ConditionInfo {
    /// Values of the layout's axes.
    pub axes: Vec<AxisValue>,
    /// Values of the layout's condition metrics.
    pub metrics: Vec<f64>,
    /// True θ.
    pub truth: Vec<f64>,
    /// `bias_model[e][p]`: estimator `e`'s estimate of parameter `p` with every noise off,
    /// minus the truth (what the model errors alone make it estimate,
    /// docs/model.md#model-errors; NaN where unknown).
    pub bias_model: Vec<Vec<f64>>,
    /// The steady model errors the condition's truth has (docs/model.md#model-errors), each
    /// at its value: those `bias_model` describes; empty where the steady truth is the
    /// equation (and for a model without model errors).
    pub model_errors: Vec<ModelErrorValue>,
    /// `applies[e][b]`: bound `b` is valid (and reported) for estimator `e`.
    pub applies: Vec<Vec<bool>>,
    /// `controls[j]`: control variate `j` of the layout is one in this condition (it
    /// varies and its mean is known); the others are NaN.
    pub controls: Vec<bool>,
    /// The exact covariances Cov(cⱼ, cₖ) of the condition's controls (those `controls`
    /// marks, in the layout's order), packed j ≤ k row by row, which the spread's control
    /// variates centre the products of the controls with
    /// (docs/model.md#spread-control-variates), with the rounding each may carry; `None`
    /// where they are not derived (or no control applies).
    pub control_covariance: Option<crate::estimate::channels::SumCovariances>,
}

/// One model error of a condition's truth at its value (docs/model.md#model-errors), for
/// tables and warnings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModelErrorValue {
    /// Its key of `[truth]`, e.g. `wind_speed`.
    pub key: &'static str,
    /// The unit of its value (empty when dimensionless).
    pub unit: &'static str,
    /// Its value in the condition.
    pub value: f64,
}

impl fmt::Display for ModelErrorValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.unit {
            "" => write!(f, "{} = {}", self.key, self.value),
            unit => write!(f, "{} = {} {unit}", self.key, self.value),
        }
    }
}

/// A table a model writes besides the realisations and the summary (e.g. the vehicle's
/// drive cycles), produced batch by batch by [`Model::extra_batch`].
#[derive(Debug, Clone)]
pub struct ExtraTable {
    /// File name in the output directory, e.g. `cycles.parquet`.
    pub file: &'static str,
    /// What the footer's `chassis_mc.table` key says it holds, e.g. `cycles`.
    pub table: &'static str,
    /// Its schema.
    pub schema: SchemaRef,
}

/// Prepare the model a study asks for (this simulates the vehicle's drive cycles; a
/// condition that cannot be simulated is a [`StudyError`]).
pub fn prepare(study: &Study) -> Result<Box<dyn Model>, StudyError> {
    if study.fleet().is_some() {
        return Ok(Box::new(fleet::FleetModel::new(study)?));
    }
    Ok(match &study.model() {
        ModelSpec::Vehicle(_) => Box::new(vehicle::VehicleModel::new(study)?),
        ModelSpec::LineFit(_) => Box::new(line_fit::LineFitModel::new(study)?),
    })
}

/// The row layout a study's model will have, without preparing it (no simulation).
pub fn layout_of(study: &Study) -> Layout {
    if study.fleet().is_some() {
        return fleet::layout(study);
    }
    match &study.model() {
        ModelSpec::Vehicle(v) => vehicle::layout(v),
        ModelSpec::LineFit(_) => line_fit::layout(),
    }
}

/// Realisations of a single condition the executor computes together by one task (at
/// most; a draw group's take more): the condition's data per block is one condition's, so
/// this many side by side already keep it in cache. The kernel's filters of AR(1) noise
/// are compiled for a batch of this many.
pub const SINGLE_BATCH: usize = 8;

/// A model: prepared conditions and the per-realisation computation.
pub trait Model: Sync + fmt::Debug {
    /// Layout of this model's rows.
    fn layout(&self) -> &Layout;

    /// Number of conditions.
    fn condition_count(&self) -> usize;

    /// What is known about condition `c` before realising it.
    fn condition_info(&self, c: usize) -> &ConditionInfo;

    /// Compute realisation `r` of condition `c` into `slots` (length
    /// [`Layout::realisation_stride`]); a pure function of (seed, c, r).
    fn realise(&self, seed: u64, c: usize, r: u64, slots: &mut [f64]);

    /// The draw group of condition `c`: conditions of one group read the same noise draws
    /// in realisation r (common random numbers), so one draw can serve them all through
    /// [`Model::realise_group`]. By default each condition is its own group.
    fn draw_group(&self, c: usize) -> usize {
        c
    }

    /// Realisations `first .. first + count` of each of `conditions` (all of one draw
    /// group) into `slots`, realisation-major: realisation `first + i` of the k-th
    /// condition at `(i · conditions.len() + k) · stride`. Bit for bit what
    /// [`Model::realise`] gives for each. By default one after the other; a model overrides
    /// it to draw once for the group.
    fn realise_group(
        &self,
        seed: u64,
        conditions: &[usize],
        first: u64,
        count: usize,
        slots: &mut [f64],
    ) {
        realise_one_by_one(self, seed, conditions, first, count, slots);
    }

    /// Every condition's info, in order.
    fn infos(&self) -> Vec<ConditionInfo> {
        (0..self.condition_count())
            .map(|c| self.condition_info(c).clone())
            .collect()
    }

    /// The tables this model writes besides realisations and summary (none by default).
    fn extra_tables(&self) -> Vec<ExtraTable> {
        Vec::new()
    }

    /// Batch `index` of extra table `table`, or `None` after the last.
    fn extra_batch(&self, _table: usize, _index: usize) -> Option<Result<RecordBatch, ArrowError>> {
        None
    }
}

/// [`Model::realise_group`] by [`Model::realise`], one realisation of one condition at a time.
pub fn realise_one_by_one<M: Model + ?Sized>(
    model: &M,
    seed: u64,
    conditions: &[usize],
    first: u64,
    count: usize,
    slots: &mut [f64],
) {
    let stride = model.layout().realisation_stride();
    let mut slots = slots.chunks_exact_mut(stride);
    for i in 0..count as u64 {
        for (&c, slots) in conditions.iter().zip(&mut slots) {
            model.realise(seed, c, first + i, slots);
        }
    }
}
