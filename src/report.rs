//! What a reader sees of a run: the table printed after it (per parameter, one line per
//! condition × estimator with the mean ± MCSE, the control-variate bias ± MCSE, the
//! empirical SE, the applicable bound and EmpSE/bound) and `report.html`, the page written
//! next to its files.

use std::fmt::Write as _;

mod html;

pub use html::{Page, escape, head, page, warnings};

use crate::model::{ConditionInfo, Layout};
use crate::stats::summary::SummaryRow;

/// Format `rows` as plain-text tables, one per parameter. Axes that take one value in
/// every condition are named once above the tables instead of repeated in every line.
pub fn table(layout: &Layout, infos: &[ConditionInfo], rows: &[SummaryRow]) -> String {
    let mut out = String::new();
    let varies: Vec<bool> = (0..layout.axes.len())
        .map(|a| a == 0 || infos.iter().any(|i| i.axes[a] != infos[0].axes[a]))
        .collect();
    let fixed: Vec<String> = layout
        .axes
        .iter()
        .zip(&varies)
        .enumerate()
        .filter(|(_, (_, v))| !**v)
        .map(|(a, (axis, _))| format!("{} = {}", axis.name, infos[0].axes[a]))
        .collect();
    for line in &layout.context {
        let _ = writeln!(out, "\n{line}");
    }
    if !fixed.is_empty() {
        let _ = writeln!(out, "In every condition: {}.", fixed.join(", "));
    }
    for (p, param) in layout.parameters.iter().enumerate() {
        let truth = rows
            .iter()
            .find(|r| r.parameter == p)
            .map_or(f64::NAN, |r| r.truth);
        let _ = writeln!(
            out,
            "\n{} — {} [{}], truth {:.6e}",
            param.name, param.description, param.unit, truth
        );
        let mut header = format!("{:>4}", "cond");
        for (a, _) in layout.axes.iter().zip(&varies).filter(|(_, v)| **v) {
            let _ = write!(header, " {:>11}", a.name);
        }
        if let Some(m) = layout.condition_metrics.first() {
            let _ = write!(header, " {:>11}", short_metric(m));
        }
        let _ = write!(
            header,
            " {:>5}  {:>27}  {:>22}  {:>10}  {:>20}  {:>16}",
            "est", "mean ± MCSE", "bias (CV) ± MCSE", "EmpSE", "bound", "EmpSE/bound"
        );
        let _ = writeln!(out, "{header}");
        for r in rows.iter().filter(|r| r.parameter == p) {
            let info = &infos[r.condition];
            let mut line = format!("{:>4}", r.condition);
            for (a, _) in info.axes.iter().zip(&varies).filter(|(_, v)| **v) {
                match a {
                    crate::model::AxisValue::Number(v) => {
                        let _ = write!(line, " {v:>11.4}");
                    }
                    crate::model::AxisValue::Text(t) => {
                        let _ = write!(line, " {t:>11}");
                    }
                }
            }
            if let Some(m) = info.metrics.first() {
                let _ = write!(line, " {m:>11.5e}");
            }
            let mean = format!("{:.6e} ± {:.1e}", r.mean.value, r.mean.mcse);
            let bias_cv = if r.bias_cv.value.is_finite() {
                format!("{:.4e} ± {:.1e}", r.bias_cv.value, r.bias_cv.mcse)
            } else {
                "—".to_string()
            };
            let (bound, ratio) = match r
                .bounds
                .iter()
                .enumerate()
                .find_map(|(b, s)| s.as_ref().map(|s| (b, s)))
            {
                Some((b, s)) => (
                    format!("{:.3e} {}", s.se.value, short_bound(layout.bounds[b].name)),
                    format!("{:.4} ± {:.4}", s.emp_over.value, s.emp_over.mcse),
                ),
                None => ("—".to_string(), "—".to_string()),
            };
            let _ = writeln!(
                line,
                " {:>5}  {:>27}  {:>22}  {:>10.3e}  {:>20}  {:>16}",
                layout.estimators[r.estimator], mean, bias_cv, r.emp_se.value, bound, ratio
            );
            out.push_str(&line);
        }
    }
    if let Some(r) = rows.first() {
        let _ = writeln!(
            out,
            "\n{} realisations per condition{}; bias (CV) = the bias by control variates \
             (docs/model.md#control-variates); bound = the first that applies (see \
             summary.parquet for all).",
            r.n + r.n_failed,
            failed_note(rows)
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
        format!(" ({failed} estimates failed: singular normal equations)")
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

fn short_bound(name: &str) -> &str {
    match name {
        "thesis_bound" => "(thesis)",
        "crlb_output" => "(CRLB)",
        other => other,
    }
}
