//! The report's table of why each condition's cycle identifies θ: the regressors' VIFs,
//! correlations and the scaled information's condition number (docs/model.md#identification).

use std::fmt::Write as _;

use super::escape;
use crate::model::vehicle::is_identification_metric;
use crate::model::{ConditionInfo, Layout};

/// The section: one row per `listed` condition, its varying axes then each identification
/// metric of the layout (empty where the layout has none).
pub(super) fn section(layout: &Layout, infos: &[ConditionInfo], listed: &[usize]) -> String {
    let metrics: Vec<usize> = (0..layout.condition_metrics.len())
        .filter(|&m| is_identification_metric(layout.condition_metrics[m]))
        .collect();
    let Some(first) = infos.first() else {
        return String::new();
    };
    if metrics.is_empty() {
        return String::new();
    }
    let varying: Vec<usize> = (0..layout.axes.len())
        .filter(|&a| infos.iter().any(|i| i.axes[a] != first.axes[a]))
        .collect();
    let mut out = String::from(
        "<h2>Why it identifies</h2>\n<p>Of each condition's noise-free rows, J = XᵀX over the \
         fitted parameters: each one's variance inflation factor VIF = J_jj (J⁻¹)_jj (uncentred: \
         the model has no intercept; 1 for a regressor orthogonal to the others, and the factor \
         by which the others inflate its variance), the regressors' uncentred correlations, and \
         the condition number of J scaled to unit diagonal (docs/model.md#identification).</p>\n\
         <table class=\"vehicle\">\n<tr>",
    );
    for &a in &varying {
        let _ = write!(out, "<th>{}</th>", escape(layout.axes[a].name));
    }
    for &m in &metrics {
        let _ = write!(out, "<th>{}</th>", escape(layout.condition_metrics[m]));
    }
    out.push_str("</tr>\n");
    for &c in listed {
        out.push_str("<tr>");
        for &a in &varying {
            let _ = write!(out, "<td>{}</td>", escape(&infos[c].axes[a].to_string()));
        }
        for &m in &metrics {
            let value = infos[c].metrics[m];
            let _ = match layout.condition_metrics[m].starts_with("corr_") {
                true => write!(out, "<td>{value:+.4}</td>"),
                false => write!(out, "<td>{value:.4}</td>"),
            };
        }
        out.push_str("</tr>\n");
    }
    out.push_str("</table>\n");
    out
}
