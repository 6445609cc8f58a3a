//! What a reader sees of a run: the table printed after it (per parameter, one line per
//! condition × estimator with the mean ± MCSE, the control-variate bias ± MCSE, the
//! empirical SE, the applicable bound and EmpSE/bound, plain and, where they apply, by the
//! second moment's control variates) and `report.html`, the page written next to its files.

use crate::stats::summary::Measure;
use std::fmt::Write as _;

mod fleet;
mod html;
mod identification;
mod warnings;

pub use html::{Page, escape, head, page};
pub use warnings::{model_error_warnings, warnings};

use crate::model::{AxisValue, ConditionInfo, Layout};
use crate::stats::summary::{BoundSummary, SummaryRow};

/// Most conditions a table lists one by one; a larger study's tables list a selection
/// ([`listed_conditions`]) and point at summary.parquet for the rest.
pub const MAX_LISTED_CONDITIONS: usize = 100;

/// The bound a table leads with for row `r`: the first of the layout's valid bounds
/// ([`BoundInfo::valid`](crate::model::BoundInfo::valid)) reported for it, else the first
/// reported at all (then not valid); `None` where none is.
pub fn lead_bound<'a>(layout: &Layout, r: &'a SummaryRow) -> Option<(usize, &'a BoundSummary)> {
    let reported = || {
        r.bounds
            .iter()
            .enumerate()
            .filter_map(|(b, s)| s.as_ref().map(|s| (b, s)))
    };
    reported()
        .find(|(b, _)| layout.bounds[*b].valid())
        .or_else(|| reported().next())
}

/// The conditions the tables list, in study order: every one up to
/// [`MAX_LISTED_CONDITIONS`]; beyond, the grid's corners (every varying axis at its first
/// or last value) and, per parameter and estimator, the conditions of the largest |bias|,
/// the largest and smallest EmpSE / bound (the bound the table leads with) and the largest
/// and smallest relative EmpSE.
pub fn listed_conditions(
    layout: &Layout,
    infos: &[ConditionInfo],
    rows: &[SummaryRow],
) -> Vec<usize> {
    if infos.len() <= MAX_LISTED_CONDITIONS {
        return (0..infos.len()).collect();
    }
    let mut picked = std::collections::BTreeSet::new();
    // Each varying axis's first and last value, in study order.
    let ends: Vec<(usize, [&AxisValue; 2])> = (0..layout.axes.len())
        .filter_map(|a| {
            let first = &infos[0].axes[a];
            let last = infos
                .iter()
                .rev()
                .map(|i| &i.axes[a])
                .find(|v| *v != first)?;
            Some((a, [first, last]))
        })
        .collect();
    // At most 16 corners; with more varying axes, the first and last condition.
    if ends.len() <= 4 {
        for corner in 0..1usize << ends.len() {
            let found = infos.iter().position(|i| {
                ends.iter()
                    .enumerate()
                    .all(|(k, (a, v))| &i.axes[*a] == v[(corner >> k) & 1])
            });
            picked.extend(found);
        }
    } else {
        picked.extend([0, infos.len() - 1]);
    }
    for p in 0..layout.parameters.len() {
        for e in 0..layout.estimators.len() {
            let of = |r: &&SummaryRow| r.parameter == p && r.estimator == e;
            let candidates: Vec<&SummaryRow> = rows.iter().filter(of).collect();
            let measures: [&dyn Fn(&SummaryRow) -> f64; 3] = [
                &|r| r[Measure::RelBias].value.abs(),
                &|r| lead_bound(layout, r).map_or(f64::NAN, |(_, s)| s.emp_over.value),
                &|r| r[Measure::EmpSe].value / r.truth.abs(),
            ];
            for (m, measure) in measures.iter().enumerate() {
                let finite = || {
                    candidates
                        .iter()
                        .map(|r| (r.condition, measure(r)))
                        .filter(|(_, v)| v.is_finite())
                };
                let by = |a: &(usize, f64), b: &(usize, f64)| a.1.total_cmp(&b.1);
                picked.extend(finite().max_by(by).map(|(c, _)| c));
                // The smallest |bias| is rarely news; the smallest ratio and spread are.
                if m > 0 {
                    picked.extend(finite().min_by(by).map(|(c, _)| c));
                }
            }
        }
    }
    picked.into_iter().collect()
}

/// Format `rows` as plain-text tables, one per parameter. Axes that take one value in
/// every condition are named once above the tables instead of repeated in every line. Each
/// line leads with the bound that applies ([`lead_bound`]), named in the header when it is
/// the same in every line. A study of more than [`MAX_LISTED_CONDITIONS`] conditions lists
/// the selection of [`listed_conditions`].
pub fn table(layout: &Layout, infos: &[ConditionInfo], rows: &[SummaryRow]) -> String {
    table_of(layout, infos, rows, &listed_conditions(layout, infos, rows))
}

/// [`table`] of the conditions `listed` (ascending: [`listed_conditions`]).
fn table_of(
    layout: &Layout,
    infos: &[ConditionInfo],
    rows: &[SummaryRow],
    listed: &[usize],
) -> String {
    let mut out = String::new();
    // The condition metric's column, where any condition has a value: a flat road (a
    // coast-down without [terrain]) has no terrain metric, and its terrain scale means
    // nothing, so neither is shown.
    let metric_shown = infos
        .iter()
        .any(|i| i.metrics.first().is_some_and(|m| m.is_finite()));
    let no_terrain = !metric_shown && layout.condition_metrics.first() == Some(&"terrain_ms_grid");
    let meaningless = |a: usize| no_terrain && layout.axes[a].name == "scale";
    let varies: Vec<bool> = (0..layout.axes.len())
        .map(|a| !meaningless(a) && (a == 0 || infos.iter().any(|i| i.axes[a] != infos[0].axes[a])))
        .collect();
    let fixed: Vec<String> = layout
        .axes
        .iter()
        .zip(&varies)
        .enumerate()
        .filter(|(a, (_, v))| !**v && !meaningless(*a))
        .map(|(a, (axis, _))| format!("{} = {}", axis.name, infos[0].axes[a]))
        .collect();
    for line in &layout.context {
        let _ = writeln!(out, "\n{line}");
    }
    if !fixed.is_empty() {
        let _ = writeln!(out, "In every condition: {}.", fixed.join(", "));
    }
    if listed.len() < infos.len() {
        let _ = writeln!(
            out,
            "{} of {} conditions listed: the grid's corners and, per parameter and estimator, \
             those of the largest |bias|, the largest and smallest EmpSE/bound and relative \
             EmpSE. Every condition is in summary.parquet.",
            listed.len(),
            infos.len()
        );
    }
    let is_listed = |c: usize| listed.binary_search(&c).is_ok();
    let mut any_ratio_cv = false;
    for (p, param) in layout.parameters.iter().enumerate() {
        let mut truths = rows.iter().filter(|r| r.parameter == p).map(|r| r.truth);
        let truth = truths.next().unwrap_or(f64::NAN);
        let truth = match truths.all(|t| t == truth) {
            true => format!("truth {truth:.6e}"),
            false => "truth per condition (summary.parquet's `truth`)".to_string(),
        };
        let _ = writeln!(
            out,
            "\n{} — {} [{}], {truth}",
            param.name, param.description, param.unit
        );
        let shown: Vec<&SummaryRow> = rows
            .iter()
            .filter(|r| r.parameter == p && is_listed(r.condition))
            .collect();
        let leads: Vec<Option<usize>> = shown
            .iter()
            .map(|r| lead_bound(layout, r).map(|(b, _)| b))
            .collect();
        // The bound's name in the header when every line leads with the same one.
        let common = match leads.first() {
            Some(&Some(b)) if leads.iter().all(|l| *l == Some(b)) => Some(b),
            _ => None,
        };
        let bound_name = |b: usize| {
            let bound = &layout.bounds[b];
            if bound.valid() {
                bound.name.to_string()
            } else {
                format!("{} (not valid)", bound.name)
            }
        };
        let (bound_header, ratio_header) = match common {
            Some(b) => (bound_name(b), format!("EmpSE/{}", layout.bounds[b].name)),
            None => ("bound".to_string(), "EmpSE/bound".to_string()),
        };
        let name_width = leads
            .iter()
            .flatten()
            .map(|&b| bound_name(b).chars().count())
            .max()
            .unwrap_or(0);
        let bound_width = match common {
            Some(_) => bound_header.chars().count().max(10),
            None => 11 + name_width,
        };
        let ratio_width = ratio_header.chars().count().max(16);
        // The same ratio by the second moment's control variates, where any line has it
        // (docs/model.md#spread-control-variates).
        let ratio_cv = |r: &SummaryRow| {
            lead_bound(layout, r)
                .map(|(_, s)| s.emp_over_cv)
                .filter(|e| e.value.is_finite())
        };
        let cv_header = "(CV)";
        let cv_width = if shown.iter().any(|r| ratio_cv(r).is_some()) {
            any_ratio_cv = true;
            Some("0.94471 ± 4.2e-5".chars().count()) // a cell's width below 10
        } else {
            None
        };
        let mut header = format!("{:>4}", "cond");
        for (a, _) in layout.axes.iter().zip(&varies).filter(|(_, v)| **v) {
            let _ = write!(header, " {:>11}", a.name);
        }
        if let Some(m) = layout.condition_metrics.first().filter(|_| metric_shown) {
            let _ = write!(header, " {:>11}", short_metric(m));
        }
        let _ = write!(
            header,
            " {:>5}  {:>27}  {:>22}  {:>10}  {:>bound_width$}  {:>ratio_width$}",
            "est", "mean ± MCSE", "bias (CV) ± MCSE", "EmpSE", bound_header, ratio_header
        );
        if let Some(w) = cv_width {
            let _ = write!(header, "  {cv_header:>w$}");
        }
        let _ = writeln!(out, "{header}");
        for r in shown {
            let info = &infos[r.condition];
            let mut line = format!("{:>4}", r.condition);
            for (a, _) in info.axes.iter().zip(&varies).filter(|(_, v)| **v) {
                match a {
                    AxisValue::Number(v) => {
                        let _ = write!(line, " {v:>11.4}");
                    }
                    AxisValue::Text(t) => {
                        let _ = write!(line, " {t:>11}");
                    }
                }
            }
            if let Some(m) = info.metrics.first().filter(|_| metric_shown) {
                let _ = write!(line, " {m:>11.5e}");
            }
            let mean = format!(
                "{:.6e} ± {:.1e}",
                r[Measure::Mean].value,
                r[Measure::Mean].mcse
            );
            let bias_cv = if r[Measure::BiasCv].value.is_finite() {
                format!(
                    "{:.4e} ± {:.1e}",
                    r[Measure::BiasCv].value,
                    r[Measure::BiasCv].mcse
                )
            } else {
                "—".to_string()
            };
            let (bound, ratio) = match lead_bound(layout, r) {
                Some((b, s)) => (
                    match common {
                        Some(_) => format!("{:.3e}", s.se.value),
                        None => format!("{:.3e} {}", s.se.value, bound_name(b)),
                    },
                    format!("{:.4} ± {:.4}", s.emp_over.value, s.emp_over.mcse),
                ),
                None => ("—".to_string(), "—".to_string()),
            };
            let _ = write!(
                line,
                " {:>5}  {:>27}  {:>22}  {:>10.3e}  {:>bound_width$}  {:>ratio_width$}",
                layout.estimators[r.estimator],
                mean,
                bias_cv,
                r[Measure::EmpSe].value,
                bound,
                ratio
            );
            if let Some(w) = cv_width {
                let cell = ratio_cv(r).map_or("—".to_string(), |e| {
                    format!("{:.5} ± {:.1e}", e.value, e.mcse)
                });
                let _ = write!(line, "  {cell:>w$}");
            }
            line.push('\n');
            out.push_str(&line);
        }
    }
    if let Some(r) = rows.first() {
        let ratio_cv_note = if any_ratio_cv {
            "; (CV) = EmpSE/bound with EmpSE by the second moment's control variates \
             (docs/model.md#spread-control-variates; — where none apply)"
        } else {
            ""
        };
        let _ = writeln!(
            out,
            "\n{} realisations per condition{}; bias (CV) = the bias by control variates \
             (docs/model.md#control-variates){ratio_cv_note}; the bound is the first valid one \
             that applies (README \"What the numbers mean\"; summary.parquet has every bound).",
            r.n + r.n_failed,
            failed_note(rows)
        );
    }
    out.push_str(&campaign_lines(layout, infos, rows, listed, &varies));
    out
}

/// A campaign's pass probability ± MCSE per listed condition (docs/model.md#campaign), the
/// condition's varying axes beside it; empty without a campaign.
fn campaign_lines(
    layout: &Layout,
    infos: &[ConditionInfo],
    rows: &[SummaryRow],
    listed: &[usize],
    varies: &[bool],
) -> String {
    let mut out = String::new();
    for &c in listed {
        let Some(p) = rows
            .iter()
            .find(|r| r.condition == c)
            .and_then(|r| r.pass_probability)
        else {
            continue;
        };
        if out.is_empty() {
            out.push_str("\ncampaign: the chance that the condition's runs pass the criterion (pass_probability ± MCSE)\n");
        }
        let axes: Vec<String> = (0..layout.axes.len())
            .filter(|&a| varies[a])
            .map(|a| format!("{} {}", layout.axes[a].name, infos[c].axes[a]))
            .collect();
        let _ = writeln!(
            out,
            "{c:>4}  {}  {:.4} ± {:.4}",
            axes.join(", "),
            p.value,
            p.mcse
        );
    }
    out
}

fn failed_note(rows: &[SummaryRow]) -> String {
    let failed: u64 = rows
        .iter()
        .filter(|r| r.parameter == 0)
        .map(|r| r.n_failed)
        .sum();
    if failed > 0 {
        format!(
            " ({failed} estimates failed: singular normal equations, or a realisation's own \
             truth not driven)"
        )
    } else {
        String::new()
    }
}

fn short_metric(name: &str) -> &str {
    match name {
        "terrain_ms_grid" => "ς_grid",
        other => other,
    }
}
