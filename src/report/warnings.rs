//! Plain-language warnings about a run's numbers, shown where they are easy to misread: a
//! bound that is not valid or applies to some conditions only, bias found by a t test per
//! estimate under Holm's rule, failed estimates, and the model errors no bound covers.

use crate::model::{ConditionInfo, Layout};
use crate::stats::summary::Measure;
use crate::stats::summary::SummaryRow;

/// Plain-language warnings about the numbers of this run.
pub fn warnings(layout: &Layout, infos: &[ConditionInfo], summary: &[SummaryRow]) -> Vec<String> {
    let mut out = Vec::new();
    for (b, bound) in layout.bounds.iter().enumerate() {
        let ratios: Vec<f64> = summary
            .iter()
            .filter_map(|r| r.bounds[b].as_ref().map(|s| s.emp_over.value))
            .filter(|v| v.is_finite())
            .collect();
        let applies = infos
            .iter()
            .filter(|i| i.applies.iter().any(|e| e[b]))
            .count();
        if let Some(why) = bound.not_valid
            && !ratios.is_empty()
        {
            let (lo, hi) = min_max(&ratios);
            // The same ratio by the second moment's control variates, where they apply
            // (docs/model.md#spread-control-variates): far sharper than the plain one.
            let by_cv: Vec<f64> = summary
                .iter()
                .filter_map(|r| r.bounds[b].as_ref().map(|s| s.emp_over_cv.value))
                .filter(|v| v.is_finite())
                .collect();
            let sharper = if by_cv.is_empty() {
                String::new()
            } else {
                let (lo, hi) = min_max(&by_cv);
                format!(" ({lo:.4}–{hi:.4} with the spread by control variates)")
            };
            out.push(format!(
                "{name} is not a valid bound{why}. Here the real spread of the estimates is \
                 {lo:.3}–{hi:.3} times {name}{sharper}.",
                name = bound.name
            ));
        } else if applies > 0 && applies < infos.len() {
            out.push(format!(
                "{} is reported in {applies} of {} conditions only: {}.",
                bound.name,
                infos.len(),
                bound.description
            ));
        }
    }
    for (e, name) in layout.estimators.iter().enumerate() {
        let rows: Vec<&SummaryRow> = summary.iter().filter(|r| r.estimator == e).collect();
        let tested = bias_tests(&rows);
        if tested.is_empty() {
            continue;
        }
        let biased = holm_rejections(&tested, FAMILY_WISE_ALPHA);
        let rule = format!(
            "two-sided Student's t at n − 1 degrees of freedom on bias / MCSE, Holm's rule over \
             its {} estimates at a {:.0} % family-wise error rate",
            tested.len(),
            100.0 * FAMILY_WISE_ALPHA
        );
        match biased.iter().map(|&k| tested[k].0).max_by(|a, b| {
            a[Measure::RelBias]
                .value
                .abs()
                .total_cmp(&b[Measure::RelBias].value.abs())
        }) {
            Some(worst) => out.push(format!(
                "{name} is biased in {} of its {} estimates ({rule}; largest: {} {:+.2} % of the \
                 truth in condition {}). EmpSE and every bound describe the spread only; RMSE \
                 includes the bias.",
                biased.len(),
                tested.len(),
                layout.parameters[worst.parameter].name,
                100.0 * worst[Measure::RelBias].value,
                worst.condition
            )),
            None => out.push(format!(
                "{name}: no evidence of bias in any of its {} estimates ({rule}).",
                tested.len()
            )),
        }
    }
    let failed: u64 = summary
        .iter()
        .filter(|r| r.parameter == 0)
        .map(|r| r.n_failed)
        .sum();
    if failed > 0 {
        out.push(format!(
            "{failed} estimates failed (singular normal equations, or a realisation whose own \
             truth could not be driven: status in realisations.parquet) and are left out of \
             every measure."
        ));
    }
    out
}

/// The family-wise error rate of the bias warnings: the chance that an estimator with no
/// bias at all is called biased in any of its estimates.
pub const FAMILY_WISE_ALPHA: f64 = 0.05;

/// Each row of `rows` with a finite bias and MCSE, with the two-sided p of H₀: no bias —
/// t = bias / MCSE against Student's t at n − 1 degrees of freedom (the MCSE is S/√n, so t
/// is the one-sample t statistic, exact for normal estimates).
fn bias_tests<'a>(rows: &[&'a SummaryRow]) -> Vec<(&'a SummaryRow, f64)> {
    use statrs::distribution::{ContinuousCDF, StudentsT};
    rows.iter()
        .filter(|r| {
            r.n >= 2 && r[Measure::Bias].value.is_finite() && r[Measure::Bias].mcse.is_finite()
        })
        .map(|&r| {
            let t = r[Measure::Bias].value / r[Measure::Bias].mcse;
            let p = match (t.is_finite(), StudentsT::new(0.0, 1.0, (r.n - 1) as f64)) {
                (true, Ok(dist)) => (2.0 * dist.sf(t.abs())).min(1.0),
                // a bias with no spread at all (MCSE 0): certain unless it is 0
                _ => match r[Measure::Bias].value == 0.0 {
                    true => 1.0,
                    false => 0.0,
                },
            };
            (r, p)
        })
        .collect()
}

/// The indices of `tested` whose hypothesis Holm's step-down rule rejects at family-wise
/// error rate `alpha`: sorted by p, the k-th smallest (from 0) is rejected while
/// p ≤ alpha / (m − k). Valid under any dependence between the tests (the three parameters
/// of one condition share their realisations).
fn holm_rejections(tested: &[(&SummaryRow, f64)], alpha: f64) -> Vec<usize> {
    let mut order: Vec<usize> = (0..tested.len()).collect();
    order.sort_by(|&a, &b| tested[a].1.total_cmp(&tested[b].1));
    let m = tested.len();
    order
        .into_iter()
        .enumerate()
        .take_while(|&(k, i)| tested[i].1 <= alpha / (m - k) as f64)
        .map(|(_, i)| i)
        .collect()
}

/// The warnings of the model errors (docs/model.md#model-errors, "In report.html"): one per
/// condition × estimator × parameter whose truth has a model error and whose `bias_model`
/// (what the model errors alone do to the estimate) exceeds its EmpSE, with the estimate's
/// error X = 100·bias_model/truth [%], Y = |bias_model|/EmpSE, and the coverage (± MCSE)
/// of every bound reported for it. `bias_model` and not `bias`: the warning is about what
/// the model errors cause, which no bound can see; the noise's own bias has its warning in
/// [`warnings`], and `bias_model` has no Monte Carlo error. Only the conditions of
/// `listed` are written out one by one (a larger grid's warnings are counted first).
pub fn model_error_warnings(
    layout: &Layout,
    infos: &[ConditionInfo],
    summary: &[SummaryRow],
    listed: &[usize],
) -> Vec<String> {
    let beyond: Vec<&SummaryRow> = summary
        .iter()
        .filter(|r| {
            !infos[r.condition].model_errors.is_empty()
                && r.bias_model.is_finite()
                && r[Measure::EmpSe].value.is_finite()
                && r.bias_model.abs() > r[Measure::EmpSe].value
        })
        .collect();
    let shown: Vec<&SummaryRow> = beyond
        .iter()
        .filter(|r| listed.binary_search(&r.condition).is_ok())
        .copied()
        .collect();
    let mut out = Vec::new();
    if shown.len() < beyond.len() {
        out.push(format!(
            "The model errors alone bias {} estimates (condition × estimator × parameter) by \
             more than their spread; those of the {} conditions listed in the tables follow, \
             and summary.parquet has every one (bias_model against emp_se).",
            beyond.len(),
            listed.len()
        ));
    }
    out.extend(
        shown
            .iter()
            .map(|r| model_error_warning(layout, &infos[r.condition], r)),
    );
    out
}

/// The warning of [`model_error_warnings`] for row `r` of the condition `info`.
fn model_error_warning(layout: &Layout, info: &ConditionInfo, r: &SummaryRow) -> String {
    let parameter = &layout.parameters[r.parameter];
    let unit = match parameter.unit {
        "1" | "" => String::new(),
        u => format!(" {u}"),
    };
    let mut errors: Vec<String> = info.model_errors.iter().map(ToString::to_string).collect();
    // A fleet's vehicle first: its B/A is one of the model errors, and says less than its name.
    if crate::stats::fleet::is_fleet(layout) {
        errors.insert(0, format!("vehicle {}", info.axes[0]));
    }
    let wrong = match 100.0 * r.bias_model / r.truth {
        x if x.is_finite() => format!("{x:+.2} %"),
        _ => format!("{:+.3e}{unit} (its truth is 0)", r.bias_model),
    };
    let spread = match r[Measure::EmpSe].value {
        0.0 => "while its estimates do not spread at all (EmpSE 0)".to_string(),
        s => format!("{:.2} times its spread", r.bias_model.abs() / s),
    };
    let coverages: Vec<String> = r
        .bounds
        .iter()
        .zip(&layout.bounds)
        .filter_map(|(s, bound)| {
            let c = s.as_ref()?.coverage;
            c.value.is_finite().then(|| {
                format!(
                    "{} {:.1} ± {:.1} %{}",
                    bound.name,
                    100.0 * c.value,
                    100.0 * c.mcse,
                    if bound.valid() {
                        ""
                    } else {
                        " (not a valid bound)"
                    }
                )
            })
        })
        .collect();
    let coverage = match coverages.is_empty() {
        true => "no bound is reported for it".to_string(),
        false => format!(
            "coverage of the truth by the 95 % interval θ̂ ± 1.96·bound (± MCSE): {}",
            coverages.join(", ")
        ),
    };
    format!(
        "Condition {c} ({errors}), {est}, {description} ({name}): no bound covers this: the \
         estimate is wrong by {wrong}, {spread}. The model errors alone move it by \
         {bias:+.3e}{unit} (bias_model), against an EmpSE of {emp:.3e}{unit}; EmpSE and every \
         bound describe the spread around that wrong value, not the distance to the truth. \
         Here the {coverage}.",
        c = r.condition,
        errors = errors.join(", "),
        est = layout.estimators[r.estimator],
        description = parameter.description,
        name = parameter.name,
        bias = r.bias_model,
        emp = r[Measure::EmpSe].value,
    )
}

fn min_max(v: &[f64]) -> (f64, f64) {
    v.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| {
            (lo.min(x), hi.max(x))
        })
}
