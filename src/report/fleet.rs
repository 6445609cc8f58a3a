//! The report's fleet section (docs/model.md#fleet): per estimator, parameter and level of
//! the other axes, the distribution across the vehicles of the relative EmpSE and bias, and
//! of the campaign's pass probability.

use std::fmt::Write as _;

use super::escape;
use crate::model::{ConditionInfo, Layout};
use crate::stats::fleet::{fleet_groups, quantile};
use crate::stats::summary::SummaryRow;

/// The section, empty unless `layout` is a fleet's.
pub(super) fn section(layout: &Layout, infos: &[ConditionInfo], rows: &[SummaryRow]) -> String {
    if !crate::stats::fleet::is_fleet(layout) {
        return String::new();
    }
    let groups = fleet_groups(layout, rows, |r| &infos[r.condition]);
    let vehicles = groups.first().map_or(0, |g| g.rel_emp_se.len());
    let mut out = format!(
        "<h2>Across the fleet</h2>\n<p>{vehicles} vehicles: the distribution of each measure \
         across them (min, 10 %, median, 90 %, max), relative to each vehicle's truth. Each \
         vehicle's own row, with its MCSE, is in summary.parquet (column <code>vehicle</code>).</p>\n\
         <table>\n<tr><th>estimator</th><th>parameter</th><th>condition</th><th>measure</th>\
         <th>min</th><th>10 %</th><th>median</th><th>90 %</th><th>max</th></tr>\n"
    );
    let mut line = |e: &str,
                    p: &str,
                    label: &str,
                    measure: &str,
                    v: &[f64],
                    fmt: &dyn Fn(f64) -> String| {
        let q = [0.0, 0.1, 0.5, 0.9, 1.0].map(|q| fmt(quantile(v, q)));
        let _ = writeln!(
            out,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{measure}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            escape(e),
            escape(p),
            escape(label),
            q[0],
            q[1],
            q[2],
            q[3],
            q[4]
        );
    };
    let sci = |x: f64| format!("{x:.3e}");
    for g in &groups {
        let (e, p) = (
            layout.estimators[g.estimator],
            layout.parameters[g.parameter].name,
        );
        line(e, p, &g.label, "EmpSE / |θ|", &g.rel_emp_se, &sci);
        line(e, p, &g.label, "bias / |θ|", &g.rel_bias, &sci);
    }
    for g in groups
        .iter()
        .filter(|g| g.estimator == 0 && g.parameter == 0)
    {
        if !g.pass_probability.is_empty() {
            line(
                "",
                "",
                &g.label,
                "pass probability",
                &g.pass_probability,
                &|x| format!("{x:.3}"),
            );
        }
    }
    out.push_str("</table>\n");
    out
}
