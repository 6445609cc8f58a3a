//! One condition's two-pass accumulation ([`ConditionSummarizer`]) and its accumulators.

use std::collections::BTreeMap;

use super::campaign::CampaignAcc;
use super::filter::FilterAcc;
use super::{BoundSummary, Measure, MeasureInputs, Record, SummaryError, SummaryRow};
use crate::estimate::filtering::PCRLB_INV_MASS;
use crate::model::{ConditionInfo, Layout};
use crate::numeric::dd::Dd;
use crate::numeric::sum::ExactSum;
use crate::stats::control::ControlAcc;
use crate::stats::measures::{
    BoundSums, EstimateSums, SpreadCv, coverage, emp_over_model, model_se, model_se_relative_error,
    variance_ratio_p,
};
use crate::stats::spread::{Coefficients, Residuals, SpreadGram, SpreadSolver};

#[derive(Debug, Clone, Default)]
struct BoundAcc {
    n: u64,
    sum_b_sq: ExactSum,
    covered: u64,
    // pass two
    sum_b_sq_dev_sq: ExactSum,
    be_covered: u64,
    mean_b_sq: f64,
}

#[derive(Debug, Clone, Default)]
struct ParamAcc {
    n: u64,
    sum_d: ExactSum,
    sum_d_sq: ExactSum,
    bounds: Vec<BoundAcc>,
    // pass two
    sum_centred_sq: ExactSum,
    sum_sq_dev_sq: ExactSum,
    sum_cross_ref: ExactSum,
    /// Σ (d − d̄)(c_j − c̄_j) per active control of the condition.
    sum_cross_controls: Vec<ExactSum>,
    /// Σ d cⱼ per active control (pass one, where the spread's control variates apply).
    spread_cross: Vec<ExactSum>,
    /// The regression on the controls, fixed at the end of pass one.
    coefficients: Option<Coefficients>,
    /// Its residuals' sums (pass two).
    residuals: Residuals,
    mean: f64,
    mse: f64,
}

/// Per condition: which realisations have been seen, for completeness checks, as disjoint
/// ranges. Rows arrive sorted within each file, so the ranges number about as many as the
/// files (shards), and memory does not grow with R.
#[derive(Debug, Clone, Default)]
struct Seen {
    /// start → end (exclusive) of each range of realisations seen.
    ranges: BTreeMap<u64, u64>,
}

impl Seen {
    /// Mark `r`; false if it was already marked.
    fn mark(&mut self, r: u64) -> bool {
        let before = self.ranges.range(..=r).next_back().map(|(&s, &e)| (s, e));
        if let Some((_, end)) = before
            && r < end
        {
            return false;
        }
        let after = self.ranges.get(&(r + 1)).copied();
        match before {
            Some((start, end)) if end == r => {
                let new_end = after.unwrap_or(r + 1);
                self.ranges.insert(start, new_end);
            }
            _ => {
                self.ranges.insert(r, after.unwrap_or(r + 1));
            }
        }
        if after.is_some() {
            self.ranges.remove(&(r + 1));
        }
        true
    }
}

/// Two-pass accumulation of one condition's summary.
///
/// Its memory is that of one condition (a few dozen [`ExactSum`]s per estimator ×
/// parameter), so a caller that streams the rows condition by condition — both passes over
/// one condition, then the next, as the summary of a run does — holds one
/// condition's accumulators at a time, however many conditions the study has.
#[derive(Debug)]
pub struct ConditionSummarizer<'a> {
    layout: &'a Layout,
    condition: usize,
    info: &'a ConditionInfo,
    realisations: u64,
    z: f64,
    /// [estimator][parameter]
    acc: Vec<Vec<ParamAcc>>,
    /// [estimator] rows seen
    rows: Vec<u64>,
    failed: Vec<u64>,
    seen: Seen,
    /// The realisation currently streaming and its estimators seen.
    current: Option<u64>,
    current_estimators: Vec<bool>,
    /// Pass two: centred θ̂ of each estimator of the current realisation (NaN when absent).
    current_centred: Vec<f64>,
    controls: ControlAcc,
    /// The spread's Gram matrix of the controls, where their covariances are known.
    spread: Option<SpreadGram>,
    /// Its factorisation, at the end of pass one.
    spread_solver: Option<SpreadSolver>,
    /// The current realisation's HC2 weight (pass two).
    spread_weight: f64,
    /// [estimator]: the sums of a filter's own columns.
    filter: Vec<FilterAcc>,
    /// [estimator]: a campaign's verdicts.
    campaign: Vec<CampaignAcc>,
}

impl<'a> ConditionSummarizer<'a> {
    /// A summarizer for the `realisations` rows per estimator of `condition` (whose
    /// description is `info`) of a model with `layout`; intervals are θ̂ ± z·bound.
    pub fn new(
        layout: &'a Layout,
        condition: usize,
        info: &'a ConditionInfo,
        realisations: u64,
        z: f64,
    ) -> Self {
        let e = layout.estimators.len();
        let p = layout.parameters.len();
        let controls = ControlAcc::new(&info.controls);
        let spread = info
            .control_covariance
            .as_ref()
            .map(|cov| SpreadGram::new(&info.controls, cov));
        let param = ParamAcc {
            bounds: vec![BoundAcc::default(); layout.bounds.len()],
            sum_cross_controls: vec![ExactSum::new(); controls.len()],
            spread_cross: if spread.is_some() {
                vec![ExactSum::new(); controls.len()]
            } else {
                Vec::new()
            },
            ..ParamAcc::default()
        };
        ConditionSummarizer {
            layout,
            condition,
            info,
            realisations,
            z,
            acc: vec![vec![param; p]; e],
            controls,
            spread,
            spread_solver: None,
            spread_weight: f64::NAN,
            rows: vec![0; e],
            failed: vec![0; e],
            seen: Seen::default(),
            current: None,
            current_estimators: vec![false; e],
            current_centred: vec![f64::NAN; e * p],
            filter: vec![FilterAcc::default(); e],
            campaign: vec![CampaignAcc::default(); e],
        }
    }

    /// The condition summarised.
    pub fn condition(&self) -> usize {
        self.condition
    }

    /// The exact accumulators this summarizer holds: its memory is about
    /// `size_of::<ExactSum>()` times this.
    pub fn accumulators(&self) -> usize {
        let per_param = |acc: &ParamAcc| {
            5 + acc.sum_cross_controls.len()
                + 2 * acc.bounds.len()
                + acc.spread_cross.len()
                + if acc.spread_cross.is_empty() {
                    0
                } else {
                    Residuals::ACCUMULATORS
                }
        };
        self.acc.iter().flatten().map(per_param).sum::<usize>()
            + self.controls.accumulators()
            + self.spread.as_ref().map_or(0, SpreadGram::accumulators)
    }

    fn check_row(&self, r: &Record<'_>) -> Result<(), SummaryError> {
        if r.condition != self.condition || r.estimator >= self.layout.estimators.len() {
            return Err(SummaryError::UnknownRow {
                condition: r.condition,
                estimator: r.estimator,
            });
        }
        Ok(())
    }

    /// Pass one: counts, Σd, Σd², bound sums and coverage of the truth.
    pub fn first_pass(&mut self, r: &Record<'_>) -> Result<(), SummaryError> {
        self.check_row(r)?;
        if self.current != Some(r.realisation) {
            if !self.seen.mark(r.realisation) {
                return Err(SummaryError::Duplicate {
                    condition: r.condition,
                    realisation: r.realisation,
                });
            }
            self.current = Some(r.realisation);
            self.current_estimators.fill(false);
            self.controls.first(r.controls);
            if let Some(spread) = &mut self.spread {
                spread.first(r.controls);
            }
        }
        if std::mem::replace(&mut self.current_estimators[r.estimator], true) {
            return Err(SummaryError::Duplicate {
                condition: r.condition,
                realisation: r.realisation,
            });
        }
        self.rows[r.estimator] += 1;
        // A campaign's verdict does not depend on the estimator's success.
        self.campaign[r.estimator].add(r.campaign);
        if !r.ok {
            self.failed[r.estimator] += 1;
            return Ok(());
        }
        self.filter[r.estimator].add(&r.filter);
        let np = self.layout.parameters.len();
        for (p, acc) in self.acc[r.estimator].iter_mut().enumerate() {
            let d = r.theta[p] - self.info.truth[p];
            acc.n += 1;
            acc.sum_d.add(d);
            acc.sum_d_sq.add(d * d);
            for (x, &j) in acc.spread_cross.iter_mut().zip(&self.controls.active) {
                x.add(d * r.controls[j]);
            }
            for (b, bacc) in acc.bounds.iter_mut().enumerate() {
                let bound = r.bounds[b * np + p];
                if bound.is_nan() {
                    continue;
                }
                bacc.n += 1;
                bacc.sum_b_sq.add(bound * bound);
                bacc.covered += u64::from(d.abs() <= self.z * bound);
            }
        }
        Ok(())
    }

    /// Close pass one: check that every realisation arrived once.
    pub fn end_first_pass(&mut self) -> Result<(), SummaryError> {
        for (e, &found) in self.rows.iter().enumerate() {
            if found != self.realisations {
                return Err(SummaryError::Incomplete {
                    condition: self.condition,
                    estimator: self.layout.estimators[e].to_string(),
                    found,
                    expected: self.realisations,
                });
            }
        }
        for acc in self.acc.iter_mut().flatten() {
            let n = acc.n as f64;
            acc.mean = acc.sum_d.value() / n;
            acc.mse = acc.sum_d_sq.value() / n;
            for b in &mut acc.bounds {
                b.mean_b_sq = b.sum_b_sq.value() / b.n as f64;
            }
        }
        self.controls.end_first();
        self.spread_solver = self.spread.as_ref().and_then(|s| {
            s.solver(
                self.controls.count(),
                &self.controls.sums_dd(),
                self.controls.means(),
            )
        });
        if let Some(solver) = &self.spread_solver {
            for acc in self.acc.iter_mut().flatten() {
                acc.coefficients =
                    solver.coefficients(acc.n, &acc.sum_d, acc.mean, &acc.spread_cross);
            }
        }
        self.current = None;
        Ok(())
    }

    /// Pass two (same rows, any order that keeps a realisation's rows adjacent): centred
    /// sums, bias-eliminated coverage and cross-products with the first estimator.
    pub fn second_pass(&mut self, r: &Record<'_>) -> Result<(), SummaryError> {
        self.check_row(r)?;
        if self.current != Some(r.realisation) {
            self.flush_cross();
            self.current = Some(r.realisation);
            self.controls.second(r.controls);
            if let Some(solver) = &self.spread_solver {
                self.spread_weight = solver.weight(&self.controls.centred);
            }
        }
        if !r.ok {
            return Ok(());
        }
        let np = self.layout.parameters.len();
        for (p, acc) in self.acc[r.estimator].iter_mut().enumerate() {
            let d = r.theta[p] - self.info.truth[p];
            let centred = d - acc.mean;
            acc.sum_centred_sq.add(centred * centred);
            let q = d * d - acc.mse;
            acc.sum_sq_dev_sq.add(q * q);
            self.current_centred[r.estimator * np + p] = centred;
            for (x, c) in acc
                .sum_cross_controls
                .iter_mut()
                .zip(&self.controls.centred)
            {
                x.add(centred * c);
            }
            if let Some(c) = &acc.coefficients {
                acc.residuals
                    .add(c, centred, &self.controls.centred, self.spread_weight);
            }
            for (b, bacc) in acc.bounds.iter_mut().enumerate() {
                let bound = r.bounds[b * np + p];
                if bound.is_nan() {
                    continue;
                }
                let dev = bound * bound - bacc.mean_b_sq;
                bacc.sum_b_sq_dev_sq.add(dev * dev);
                bacc.be_covered += u64::from(centred.abs() <= self.z * bound);
            }
        }
        Ok(())
    }

    /// Add the current realisation's cross-products with the reference estimator.
    fn flush_cross(&mut self) {
        if self.current.is_none() {
            return;
        }
        let np = self.layout.parameters.len();
        let r = self.layout.reference_estimator();
        for e in 0..self.layout.estimators.len() {
            for p in 0..np {
                let x = self.current_centred[e * np + p];
                let reference = self.current_centred[r * np + p];
                if !(x.is_nan() || reference.is_nan()) {
                    self.acc[e][p].sum_cross_ref.add(x * reference);
                }
            }
        }
        self.current_centred.fill(f64::NAN);
    }

    /// Finish pass two and compute every measure: the condition's rows, estimator-major.
    pub fn finish(mut self) -> Vec<SummaryRow> {
        self.flush_cross();
        let mut out = Vec::with_capacity(self.acc.len() * self.layout.parameters.len());
        let reference = self.layout.reference_estimator();
        let factor = self.controls.factor();

        let (c, info) = (self.condition, self.info);
        // A filter's measures go on its inv_mass row, against the condition's PCRLB.
        let inv_mass = self
            .layout
            .parameters
            .iter()
            .position(|p| p.name == "inv_mass");
        let pcrlb = self
            .layout
            .condition_metrics
            .iter()
            .position(|m| *m == PCRLB_INV_MASS)
            .map_or(f64::NAN, |i| info.metrics[i]);
        for (e, per_e) in self.acc.iter().enumerate() {
            for (p, acc) in per_e.iter().enumerate() {
                let truth = info.truth[p];
                let sums = estimate_sums(acc);
                let reference = estimate_sums(&self.acc[reference][p]);
                let spread = self
                    .spread_solver
                    .as_ref()
                    .zip(acc.coefficients.as_ref())
                    .map_or_else(SpreadCv::undefined, |(solver, c)| {
                        let sum_u =
                            acc.sum_d.value_dd() - Dd::from(acc.n as f64) * Dd::from(acc.mean);
                        let f = solver.fit(c, &acc.residuals, acc.mean, sum_u);
                        SpreadCv::new(f.variance, f.variance_var, f.bias, f.bias_var, f.covariance)
                    });
                let bounds = acc
                    .bounds
                    .iter()
                    .enumerate()
                    .map(|(b, bacc)| {
                        (info.applies[e][b] && bacc.n > 0)
                            .then(|| bound_summary(&sums, &spread, bacc, acc.n))
                    })
                    .collect();
                let cv = factor.as_ref().and_then(|f| {
                    f.fit(
                        acc.n,
                        &acc.sum_d,
                        &acc.sum_centred_sq,
                        &acc.sum_cross_controls,
                    )
                });
                let inputs = MeasureInputs {
                    truth,
                    sums: &sums,
                    reference: &reference,
                    sum_cross_reference: acc.sum_cross_ref.value(),
                    spread: &spread,
                    control: cv.as_ref(),
                };
                out.push(SummaryRow {
                    condition: c,
                    estimator: e,
                    parameter: p,
                    truth,
                    bias_model: info.bias_model[e][p],
                    n: acc.n,
                    n_failed: self.failed[e],
                    bounds,
                    n_controls: cv.as_ref().map_or(0, |f| f.used as u64),
                    measures: Measure::compute_all(&inputs),
                    filter: (Some(p) == inv_mass && self.filter[e].seen())
                        .then(|| self.filter[e].finish(pcrlb)),
                    pass_probability: self.campaign[e].finish(),
                });
            }
        }
        out
    }
}

fn estimate_sums(acc: &ParamAcc) -> EstimateSums {
    EstimateSums {
        n: acc.n as f64,
        sum_d: acc.sum_d.value(),
        sum_centred_sq: acc.sum_centred_sq.value(),
        sum_d_sq: acc.sum_d_sq.value(),
        sum_sq_dev_sq: acc.sum_sq_dev_sq.value(),
    }
}

fn bound_summary(
    sums: &EstimateSums,
    spread: &SpreadCv,
    b: &BoundAcc,
    n_estimates: u64,
) -> BoundSummary {
    let bs = BoundSums {
        n: b.n as f64,
        sum_b_sq: b.sum_b_sq.value(),
        sum_b_sq_dev_sq: b.sum_b_sq_dev_sq.value(),
    };
    debug_assert!(b.n <= n_estimates);
    BoundSummary {
        n: b.n,
        se: model_se(&bs),
        emp_over: emp_over_model(sums, &bs),
        rel_error: model_se_relative_error(sums, &bs),
        coverage: coverage(b.covered as f64, b.n as f64),
        be_coverage: coverage(b.be_covered as f64, b.n as f64),
        chi2_p: variance_ratio_p(sums, &bs),
        emp_over_cv: spread.emp_over_model(&bs),
        p_cv: spread.variance_ratio_p(&bs),
    }
}

#[cfg(test)]
mod tests;
