//! The summary of a study: every measure of docs/model.md#measures per condition × estimator × parameter,
//! from two passes over the realisation rows.
//!
//! Pass one gives counts, means and coverage of the truth; pass two, knowing the means,
//! gives centred sums (so variances never come from the difference of two large sums),
//! bias-eliminated coverage and the cross-products of estimators. All sums are
//! [`ExactSum`](crate::numeric::sum::ExactSum)s, so the summary is bit-identical whatever
//! the order in which rows arrive: one file or many shards, one thread or many.

use thiserror::Error;

use super::measures::Estimate;
use crate::model::{ConditionInfo, Layout};

mod campaign;
mod condition;
pub mod filter;
pub mod measure;

pub use condition::ConditionSummarizer;
pub use measure::{MEASURE_COUNT, Measure, MeasureInputs, SummaryMeasure};

/// One realisation row of one estimator, as read from memory or from Parquet.
#[derive(Debug, Clone, Copy)]
pub struct Record<'a> {
    /// Condition index.
    pub condition: usize,
    /// Realisation index.
    pub realisation: u64,
    /// Estimator index in the layout.
    pub estimator: usize,
    /// The estimator succeeded (status "ok").
    pub ok: bool,
    /// θ̂, one per parameter.
    pub theta: &'a [f64],
    /// Bound values, bound-major (`b * P + p`); NaN where the bound is absent.
    pub bounds: &'a [f64],
    /// The realisation's control variates, one per control of the layout (the same on
    /// every estimator's row; NaN where one is not a control in the condition).
    pub controls: &'a [f64],
    /// The row's values of the filters' columns [`filter::INPUTS`] (NaN where absent).
    pub filter: [f64; 4],
    /// The row's `campaign_pass` (1 pass, 0 fail; NaN where absent,
    /// docs/model.md#campaign).
    pub campaign: f64,
}

/// Rows that do not form a complete, consistent set of realisations.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[non_exhaustive]
pub enum SummaryError {
    /// A row names a condition or estimator the study does not have.
    #[error(
        "row refers to condition {condition} / estimator {estimator}, which the study does not have"
    )]
    UnknownRow {
        /// Condition index of the row.
        condition: usize,
        /// Estimator index of the row.
        estimator: usize,
    },
    /// A realisation appears twice, or its estimator rows are not adjacent.
    #[error("realisation {realisation} of condition {condition} appears more than once")]
    Duplicate {
        /// Condition index.
        condition: usize,
        /// Realisation index.
        realisation: u64,
    },
    /// A file's rows go back to an earlier condition (chassis-mc writes them sorted by
    /// condition, then realisation).
    #[error(
        "rows of condition {condition} follow rows of condition {after}: the rows are not sorted by condition, as chassis-mc writes them"
    )]
    Unsorted {
        /// Condition index of the row out of order.
        condition: usize,
        /// The condition of an earlier row.
        after: usize,
    },
    /// Realisations are missing.
    #[error(
        "condition {condition} has {found} of its {expected} realisations (estimator {estimator})"
    )]
    Incomplete {
        /// Condition index.
        condition: usize,
        /// Estimator name.
        estimator: String,
        /// Rows found.
        found: u64,
        /// Rows expected.
        expected: u64,
    },
}

/// The measures of one bound for one condition × estimator × parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoundSummary {
    /// Realisations with a value of this bound.
    pub n: u64,
    /// Model SE √(mean b²).
    pub se: Estimate,
    /// EmpSE / ModSE.
    pub emp_over: Estimate,
    /// 100 (ModSE / EmpSE − 1) [%].
    pub rel_error: Estimate,
    /// Coverage of θ̂ ± z·b.
    pub coverage: Estimate,
    /// Bias-eliminated coverage: of θ̄ by θ̂ ± z·b.
    pub be_coverage: Estimate,
    /// p-value of the χ² test of EmpSE² = ModSE².
    pub chi2_p: f64,
    /// EmpSE / ModSE with the control-variate EmpSE.
    pub emp_over_cv: Estimate,
    /// p-value of the normal test of Var θ̂ = ModSE² with the control-variate variance.
    pub p_cv: f64,
}

impl BoundSummary {
    /// Every measure undefined (NaN), as before any value is known.
    pub fn undefined() -> Self {
        BoundSummary {
            n: 0,
            se: Estimate::undefined(),
            emp_over: Estimate::undefined(),
            rel_error: Estimate::undefined(),
            coverage: Estimate::undefined(),
            be_coverage: Estimate::undefined(),
            chi2_p: f64::NAN,
            emp_over_cv: Estimate::undefined(),
            p_cv: f64::NAN,
        }
    }
}

/// One summary row: condition × estimator × parameter.
#[derive(Debug, Clone, PartialEq)]
pub struct SummaryRow {
    /// Condition index.
    pub condition: usize,
    /// Estimator index.
    pub estimator: usize,
    /// Parameter index.
    pub parameter: usize,
    /// True value.
    pub truth: f64,
    /// The estimate with every noise off minus the truth: what the model errors alone
    /// cause (docs/model.md#model-errors).
    pub bias_model: f64,
    /// Realisations with a valid estimate.
    pub n: u64,
    /// Realisations where the estimator failed (singular).
    pub n_failed: u64,
    /// Per bound of the layout: its measures where it applies.
    pub bounds: Vec<Option<BoundSummary>>,
    /// Control variates in the mean's regression (0: none applies).
    pub n_controls: u64,
    /// Every [`Measure`], in its order: read them by `row[measure]`.
    pub measures: [Estimate; MEASURE_COUNT],
    /// A filter's measures ([`filter::FilterMeasure`], in its order) on its `inv_mass` row
    /// (`None` elsewhere).
    pub filter: Option<[Estimate; 4]>,
    /// `pass_probability`: the share of the condition's realisations whose campaign passes,
    /// with its MCSE √(p(1 − p)/R) (`None` without a campaign; docs/model.md#campaign).
    pub pass_probability: Option<Estimate>,
}

impl std::ops::Index<Measure> for SummaryRow {
    type Output = Estimate;
    fn index(&self, m: Measure) -> &Estimate {
        &self.measures[m.index()]
    }
}

impl std::ops::IndexMut<Measure> for SummaryRow {
    fn index_mut(&mut self, m: Measure) -> &mut Estimate {
        &mut self.measures[m.index()]
    }
}

/// Two-pass accumulation of the summary of every condition at once, for rows that arrive in
/// any order (a [`ConditionSummarizer`] per condition).
#[derive(Debug)]
pub struct Summarizer<'a> {
    layout: &'a Layout,
    conditions: Vec<ConditionSummarizer<'a>>,
}

impl<'a> Summarizer<'a> {
    /// A summarizer for `realisations` per condition of a model with `layout`, whose
    /// conditions are `infos`; intervals are θ̂ ± z·bound.
    pub fn new(layout: &'a Layout, infos: &'a [ConditionInfo], realisations: u64, z: f64) -> Self {
        let conditions = infos
            .iter()
            .enumerate()
            .map(|(c, info)| ConditionSummarizer::new(layout, c, info, realisations, z))
            .collect();
        Summarizer { layout, conditions }
    }

    fn condition(&mut self, r: &Record<'_>) -> Result<&mut ConditionSummarizer<'a>, SummaryError> {
        let unknown = SummaryError::UnknownRow {
            condition: r.condition,
            estimator: r.estimator,
        };
        if r.estimator >= self.layout.estimators.len() {
            return Err(unknown);
        }
        self.conditions.get_mut(r.condition).ok_or(unknown)
    }

    /// Pass one: counts, Σd, Σd², bound sums and coverage of the truth.
    pub fn first_pass(&mut self, r: &Record<'_>) -> Result<(), SummaryError> {
        self.condition(r)?.first_pass(r)
    }

    /// Close pass one: check that every realisation of every condition arrived once.
    pub fn end_first_pass(&mut self) -> Result<(), SummaryError> {
        self.conditions
            .iter_mut()
            .try_for_each(ConditionSummarizer::end_first_pass)
    }

    /// Pass two (same rows, any order that keeps a realisation's rows adjacent): centred
    /// sums, bias-eliminated coverage and cross-products with the first estimator.
    pub fn second_pass(&mut self, r: &Record<'_>) -> Result<(), SummaryError> {
        self.condition(r)?.second_pass(r)
    }

    /// Finish pass two and compute every measure.
    pub fn finish(self) -> Vec<SummaryRow> {
        self.conditions
            .into_iter()
            .flat_map(ConditionSummarizer::finish)
            .collect()
    }
}
